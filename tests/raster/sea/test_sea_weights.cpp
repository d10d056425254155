// Weights and reaches by sea (rv/sea/sea_field.hpp): a seed's cost is its path length by sea over
// its weight, within its reach. Both engines, cell for cell, against closed forms round a wall
// (where a heavier seed's path bends round the wall's end against a seed in view, the line is a
// Cartesian oval), a reach that ends where the path by sea reaches it, an island beyond its reach
// that is no seed but still land, and random archipelagos
// with weights and reaches; the lines' metric gives each owner's cheapest path, and boundaries
// drawn with it lie on the oval.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "engines_agree.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/sea_metric.hpp"
#include "rv/sea/visibility.hpp"
#include "seed_gen.hpp"
#include "wall_paths.hpp"
#include "wall_sea.hpp"

namespace rv {
namespace {

constexpr double kNone = std::numeric_limits<double>::infinity();
Vec2 centre(const GridSpec& g, int64_t c, int64_t r) { return Vec2{g.centre_x(c), g.centre_y(r)}; }

using test::crosses_wall;
using test::dist;
using test::wall_path;

// Point seeds, one owner each, with a weight and a reach.
struct Weighted {
  Vec2 at;
  double weight = 1.0;
  double reach = kNone;
};
SeedSet weighted_points(const std::vector<Weighted>& points) {
  SeedSet s;
  for (size_t i = 0; i < points.size(); ++i) {
    const int32_t f = s.add_feature(s.owner_code("o" + std::to_string(i)));
    s.add_point(f, points[i].at);
    s.set_adjustment(f, points[i].weight, points[i].reach);
  }
  return s;
}

// The closed form round a vertical wall from a to b: seed i's cost at x is its path length (round
// the nearer end where the wall is in the way) over its weight, where that length is within its
// reach and the maximum distance.
double cost(const Weighted& p, Vec2 x, Vec2 a, Vec2 b, double max_distance) {
  const double d = wall_path(p.at, x, a, b);
  return d > p.reach || d > max_distance ? kNone : d / p.weight;
}

// What a closed-form run counted.
struct WallCount {
  int64_t owned = 0;
  int64_t bent_winners = 0;    // cells won by a path round the wall's end
  int64_t changed = 0;         // cells whose owner the straight weighted comparison gets wrong
  int64_t beyond_by_path = 0;  // cells within a reach in a straight line but not by sea
};

// Both engines against the closed form, every cell: the owner where the two cheapest costs differ
// by more than rounding, the distance (the winner's path length) to float rounding.
WallCount expect_wall_closed_form(const std::vector<Weighted>& points, Vec2 a, Vec2 b, const GridSpec& g,
                                  double max_distance = kNone) {
  const SeedSet s = weighted_points(points);
  Barriers wall;
  wall.add_line(std::vector<Vec2>{a, b}, "wall");
  SeaOptions options;
  options.max_distance = max_distance;
  const SeaField f = test::engines_agree(s, wall, g, options);
  EXPECT_EQ(f.unreachable_cells, 0);  // beyond a reach is not unreachable
  WallCount n;
  double worst = 0.0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, r);
      std::vector<std::pair<double, size_t>> costs, straight;
      for (size_t i = 0; i < points.size(); ++i) {
        costs.emplace_back(cost(points[i], x, a, b, max_distance), i);
        const double d = dist(points[i].at, x);
        straight.emplace_back(d > points[i].reach || d > max_distance ? kNone : d / points[i].weight, i);
        n.beyond_by_path += d <= points[i].reach && wall_path(points[i].at, x, a, b) > points[i].reach;
      }
      std::sort(costs.begin(), costs.end());
      std::sort(straight.begin(), straight.end());
      const int32_t site = f.field.site.at(c, r);
      if (!std::isfinite(costs[0].first)) {
        EXPECT_EQ(site, kNoSite) << c << "," << r;
        continue;
      }
      const bool clear = costs.size() < 2 || costs[1].first - costs[0].first > 1e-9 * costs[0].first;
      if (!clear) continue;
      EXPECT_EQ(site, static_cast<int32_t>(costs[0].second)) << c << "," << r;
      const double want = wall_path(points[costs[0].second].at, x, a, b);
      EXPECT_NEAR(f.field.distance.at(c, r), want, 1e-6 * want) << c << "," << r;
      if (::testing::Test::HasFailure()) return n;
      worst = std::max(worst, std::abs(f.field.distance.at(c, r) - want) / want);
      ++n.owned;
      n.bent_winners += crosses_wall(points[costs[0].second].at, x, a.x, a.y, b.y);
      n.changed += straight[0].second != costs[0].second && std::isfinite(straight[0].first);
    }
  std::printf(
      "closed form with weights | %lld cells owned, %lld won round the wall, %lld owned otherwise than in a "
      "straight line | worst relative |d - closed form| %.3g\n",
      static_cast<long long>(n.owned), static_cast<long long>(n.bent_winners), static_cast<long long>(n.changed),
      worst);
  return n;
}

TEST(SeaWeights, AHeavierSeedBehindAWallsEndAgainstOneInViewMeetsItOnACartesianOval) {
  // s1 (weight 2) behind the wall's end A, s2 (weight 1) in view: where x is in s1's shadow and
  // sees A and s2, the line is (|s1 - A| + |x - A|) / 2 = |x - s2|, a Cartesian oval.
  const Vec2 a{20, 25}, b{20, 60};
  const GridSpec g = test::grid_of(48, 48);
  const WallCount n = expect_wall_closed_form({{{14.2, 31.7}, 2.0}, {{33.1, 38.3}, 1.0}}, a, b, g);
  EXPECT_GT(n.bent_winners, 200);  // the heavy seed's sea reaches round the wall
  EXPECT_GT(n.changed, 100);       // which a straight weighted comparison hands to it across the wall
  // And the light one behind it, with a third for a triple meeting.
  const WallCount m = expect_wall_closed_form({{{14.2, 31.7}, 0.7}, {{33.1, 38.3}, 1.3}, {{40.6, 8.9}, 1.0}}, a, b, g);
  EXPECT_GT(m.bent_winners, 20);
  EXPECT_GT(m.changed, 20);
}

TEST(SeaWeights, AReachEndsWhereThePathBySeaReachesIt) {
  const Vec2 a{20, 12}, b{20, 40};
  const GridSpec g = test::grid_of(40, 48);
  // Alone: its sea is the cells within the reach by sea; those within it in a straight line but
  // not round the wall have no owner (and are not unreachable).
  const WallCount alone = expect_wall_closed_form({{{14.3, 26.6}, 1.0, 13.0}}, a, b, g);
  EXPECT_GT(alone.beyond_by_path, 100);
  EXPECT_GT(alone.owned, 300);
  const WallCount round_the_ends = expect_wall_closed_form({{{14.3, 26.6}, 1.0, 19.0}}, a, b, g);
  EXPECT_GT(round_the_ends.bent_winners, 20);  // the reach's arcs round the wall's ends
  EXPECT_GT(round_the_ends.beyond_by_path, 100);
  // Beside an unreached seed east of the wall, which takes those cells; then with weights and a
  // maximum distance as well.
  const WallCount two = expect_wall_closed_form({{{14.3, 26.6}, 1.0, 13.0}, {{36.2, 7.4}, 1.0}}, a, b, g);
  EXPECT_GT(two.changed, 100);
  const WallCount three =
      expect_wall_closed_form({{{14.3, 26.6}, 2.5, 13.0}, {{36.2, 7.4}, 1.0, 30.0}, {{5.5, 44.5}, 0.8}}, a, b, g, 25.0);
  EXPECT_GT(three.changed, 50);
}

// An island that is a seed with a reach of 3 and also land: within its reach it owns the sea
// round it; beyond, it is no seed but still land, so a port west of it reaches the sea east of it
// only round its corners (|p - c1| + |c1 - c2| + |c2 - x| over the nearer pair of corners), never
// in a straight line through it; its own cells are land. Both engines, every cell.
TEST(SeaWeights, AnIslandOutOfItsReachIsNoSeedButStillLand) {
  const double lo = 16.0, hi = 24.0, reach = 3.0;
  const Vec2 port{4.0, 20.3};
  const std::vector<Ring> square{{{lo, lo}, {hi, lo}, {hi, hi}, {lo, hi}}};
  SeedSet s;
  const int32_t island = s.add_feature(s.owner_code("island"));
  s.add_polygon(island, square);
  s.set_adjustment(island, 1.0, reach);
  s.add_point(s.add_feature(s.owner_code("port")), port);
  Barriers land;
  land.add_polygon(square, "island");
  const GridSpec g = test::grid_of(40, 40);
  const SeaField f = test::engines_agree(s, land, g);
  const int32_t port_site = static_cast<int32_t>(s.sites().size()) - 1;
  int64_t inside = 0, near = 0, shadow = 0, detoured = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, r);
      const int32_t site = f.field.site.at(c, r);
      if (x.x > lo && x.x < hi && x.y > lo && x.y < hi) {
        ++inside;
        EXPECT_EQ(site, kNoSite) << c << "," << r;
        continue;
      }
      const double to_island = std::hypot(std::max({lo - x.x, 0.0, x.x - hi}), std::max({lo - x.y, 0.0, x.y - hi}));
      if (x.x > hi && x.y > lo && x.y < hi) {
        // East of the island, facing it: the island's sea within its reach, else the port's round it.
        if (to_island <= reach) {
          ++near;
          EXPECT_TRUE(site != kNoSite && s.site_feature(site) == island) << c << "," << r;
          EXPECT_NEAR(f.field.distance.at(c, r), to_island, 1e-6) << c << "," << r;
          continue;
        }
        ++shadow;
        const double over_top = dist(port, {lo, hi}) + (hi - lo) + dist({hi, hi}, x);
        const double under = dist(port, {lo, lo}) + (hi - lo) + dist({hi, lo}, x);
        const double want = std::min(over_top, under);
        EXPECT_EQ(site, port_site) << c << "," << r;
        EXPECT_NEAR(f.field.distance.at(c, r), want, 1e-6 * want) << c << "," << r;
        EXPECT_GT(want, dist(port, x) * (1 + 1e-6)) << c << "," << r;  // (no straight line through the island)
        detoured += want > dist(port, x) + 1.0;
      }
      if (::testing::Test::HasFailure()) return;
    }
  EXPECT_EQ(inside, 64);
  EXPECT_EQ(f.land_cells, 64);
  EXPECT_EQ(near, 3 * 8);
  EXPECT_GT(shadow, 100);
  EXPECT_GT(detoured, 20);
}

// Random archipelagos (islands with lagoons, a boom) with point and line seeds of three owners
// and several weights and reaches: the exact engine equals the reference cell for cell, with any
// thread count and in strips of one preparation.
TEST(SeaWeights, RandomArchipelagosWithWeightsAndReachesExactEqualsTheReference) {
  std::mt19937_64 rng(73);
  std::uniform_int_distribution<int> coord(0, 36);
  const double weights[] = {1.0, 0.6, 1.8};
  const double reaches[] = {kNone, 14.0, 22.5};
  int rounds = 0;
  int64_t bent = 0, unreachable = 0;
  for (int round = 0; round < 8; ++round) {
    Barriers b;
    for (int k = 0; k < 6; ++k) {
      const double x = coord(rng), y = coord(rng), w = 2 + coord(rng) % 7, h = 2 + coord(rng) % 7;
      std::vector<Ring> rings{{{x, y}, {x + w, y}, {x + w * 0.6, y + h}, {x, y + h * 0.8}}};
      if (w > 5 && h > 5) rings.push_back({{x + 1.5, y + 1.5}, {x + 3, y + 1.5}, {x + 2.5, y + 3}});
      b.add_polygon(rings, "island");
    }
    b.add_line(std::vector<Vec2>{{double(coord(rng)), double(coord(rng))}, {double(coord(rng)), double(coord(rng))}},
               "boom");
    const Visibility vis(b);
    SeedSet s;
    int placed = 0;
    for (int k = 0; k < 24 && placed < 7; ++k) {
      const Vec2 p{coord(rng) + 0.25, coord(rng) + 0.75}, q{p.x + 1.5, p.y - 0.5};
      if (vis.on_land(p) || vis.on_land(q)) continue;
      const int32_t f = s.add_feature(s.owner_code(std::string(1, static_cast<char>('A' + placed % 3))));
      if (placed == 3)
        s.add_polyline(f, std::vector<Vec2>{p, q});
      else
        s.add_point(f, p);
      s.set_adjustment(f, weights[placed % 3], reaches[(placed / 2) % 3]);
      ++placed;
    }
    if (placed < 4) continue;
    ++rounds;
    const GridSpec g = test::grid_of(40, 40, 1.0, -1.0, 41.0);
    SeaOptions options;
    options.max_distance = round % 2 ? 26.0 : kNone;
    const SeaField whole = test::engines_agree(s, b, g, options);
    if (::testing::Test::HasFailure()) return;
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) bent += whole.via.at(c, r) != kNoVia;
    unreachable += whole.unreachable_cells;
    SeaOptions strips = options;
    strips.prepared = prepare_sea(s, b, g, options);
    strips.threads = round % 3 + 1;
    for (int64_t row0 = 0; row0 < g.height; row0 += 11) {
      const Window w{0, row0, g.width, std::min<int64_t>(11, g.height - row0)};
      const SeaField strip = compute_sea(s, b, g, w, strips);
      for (int64_t r = 0; r < w.height; ++r)
        for (int64_t c = 0; c < w.width; ++c) {
          ASSERT_EQ(strip.field.site.at(c, r), whole.field.site.at(c, row0 + r));
          ASSERT_EQ(strip.field.distance.at(c, r), whole.field.distance.at(c, row0 + r));
          ASSERT_EQ(strip.via.at(c, r), whole.via.at(c, row0 + r));
        }
    }
  }
  EXPECT_GE(rounds, 5);
  EXPECT_GT(bent, 300);  // paths round land, not only straight ones
  // Lagoons no seed reaches (counted alike by both engines: within a reach, no path at all).
  EXPECT_GT(unreachable, 0);
}

// The lines' metric with weights: each owner's cheapest cost from the index, cell for cell the
// reference's on that owner's seeds alone (one owner with two weights), the boundary of a heavy
// seed behind a wall and a light one in view on the oval, and an islet's reach ending its sea.
TEST(SeaWeights, TheLinesMetricGivesEachOwnersCheapestPathAndTheBoundaryIsTheOval) {
  const Vec2 a{20, 25}, b{20, 60};
  const std::vector<Weighted> points{
      {{14.2, 31.7}, 2.0}, {{33.1, 38.3}, 1.0}, {{8.4, 12.2}, 1.0, 9.0}, {{44.5, 6.5}, 1.0}};
  const char* owners[] = {"heavy", "light", "islet", "heavy"};  // heavy: two weights
  SeedSet s;
  for (size_t i = 0; i < points.size(); ++i) {
    const int32_t f = s.add_feature(s.owner_code(owners[i]));
    s.add_point(f, points[i].at);
    s.set_adjustment(f, points[i].weight, points[i].reach);
  }
  const GridSpec g = test::grid_of(48, 48);
  const test::WallSea sea(s, a, b, g);
  const Barriers& wall = sea.wall;
  const SeaField& field = sea.field;
  const OwnerIndex& index = *sea.index;
  ASSERT_TRUE(index.adjusted());
  int64_t compared = 0;
  for (int32_t owner = 1; owner <= s.owner_count(); ++owner) {
    std::vector<bool> drop(s.features().size());
    for (size_t f = 0; f < drop.size(); ++f) drop[f] = s.features()[f].owner != owner;
    std::vector<int32_t> site_of;
    const SeedSet alone = s.without(drop, site_of);
    const SeaField reference = brute_force_sea(alone, wall, g, g.full_window());
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        const OwnerIndex::Hit hit = index.nearest_of(centre(g, c, r), owner);
        const int32_t want = reference.field.site.at(c, r);
        if (want == kNoSite) {
          ASSERT_EQ(hit.site, kNoSite) << c << "," << r << " owner " << owner;
          continue;
        }
        ASSERT_EQ(hit.site, site_of[static_cast<size_t>(want)]) << c << "," << r << " owner " << owner;
        const double d = reference.field.distance.at(c, r);
        ASSERT_NEAR(hit.distance, d, 1e-6 * d) << c << "," << r;
        ASSERT_NEAR(hit.cost, d / points[static_cast<size_t>(hit.site)].weight, 1e-6 * d) << c << "," << r;
        ++compared;
      }
  }
  EXPECT_GT(compared, 2000);
  BoundaryOptions options;
  options.line_tolerance = 1e-4;
  const BoundaryResult lines = extract_boundaries(field.field, index, options);
  ASSERT_FALSE(lines.lines.empty());
  int64_t on_oval = 0, arcs = 0;
  double worst = 0.0;
  for (const BoundaryLine& line : lines.lines)
    for (size_t v = 0; v < line.vertices.size(); ++v) {
      const BoundaryVertex& x = line.vertices[v];
      if (x.arc != 0) {  // where the third seed's reach ends: its path by sea is the reach
        const auto i = static_cast<size_t>(x.arc == 1 ? x.site_a : x.site_b);
        EXPECT_NEAR(wall_path(points[i].at, x.p, a, b), points[i].reach, 1e-9 * points[i].reach);
        ++arcs;
        continue;
      }
      const double ca = cost(points[static_cast<size_t>(x.site_a)], x.p, a, b, kNone);
      const double cb = cost(points[static_cast<size_t>(x.site_b)], x.p, a, b, kNone);
      EXPECT_NEAR(ca, cb, 1e-9 * ca) << x.p.x << "," << x.p.y;
      EXPECT_NEAR(x.distance_a, wall_path(points[static_cast<size_t>(x.site_a)].at, x.p, a, b), 1e-9 * ca);
      worst = std::max(worst, std::abs(ca - cb));
      on_oval += crosses_wall(points[0].at, x.p, a.x, a.y, b.y);
      if (v > 0) {
        EXPECT_FALSE(crosses_wall(line.vertices[v - 1].p, x.p, a.x, a.y, b.y)) << x.p.x << "," << x.p.y;
      }
    }
  EXPECT_GT(on_oval, 10);
  EXPECT_GT(arcs, 3);
  EXPECT_EQ(lines.stats.locus.unresolved, 0);
  std::printf("a boundary by sea with weights: %zu lines, %lld vertices on the oval, worst |cost_a - cost_b| %.3g\n",
              lines.lines.size(), static_cast<long long>(on_oval), worst);
}

}  // namespace
}  // namespace rv
