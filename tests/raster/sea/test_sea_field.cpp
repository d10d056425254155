// The distance by sea against closed forms, both engines (the exact one checked against the
// reference cell for cell in every case): a wall, a seed behind a wall's end
// against one in view (the hyperbola branch) and a third for a tripoint, a regular 64-gon island,
// a strait narrower than a cell, a mirror-symmetric layout, the invariant with barriers that are
// seeds, the tie behind a vertex, unreachable seas and the refusals.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <random>

#include "engines_agree.hpp"
#include "random_archipelago.hpp"
#include "rv/field/error.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/snap.hpp"
#include "rv/sea/visibility.hpp"
#include "sea/sea_prepare.hpp"
#include "seed_gen.hpp"
#include "wall_paths.hpp"
#include "wall_sea.hpp"

namespace rv {
namespace {

// Both engines on one layout, the exact one's field returned (engines_agree.hpp).
SeaField sea_field(const SeedSet& seeds, const Barriers& barriers, const GridSpec& g) {
  return test::engines_agree(seeds, barriers, g);
}

// The largest difference between the engines' distances and a closed form over a case's cells,
// printed for the record (`ctest -R test_raster_sea_field -V`: the closed-form table).
struct Worst {
  const char* name;
  int64_t cells = 0;
  double abs = 0.0, rel = 0.0;
  void add(double got, double want) {
    ++cells;
    abs = std::max(abs, std::abs(got - want));
    if (want > 0) rel = std::max(rel, std::abs(got - want) / want);
  }
  ~Worst() {
    std::printf("closed form | %s | %lld cells | worst |d - closed form| %.3g (relative %.3g)\n", name,
                static_cast<long long>(cells), abs, rel);
  }
};
Vec2 centre(const GridSpec& g, int64_t c, int64_t r) { return Vec2{g.centre_x(c), g.centre_y(r)}; }

SeedSet points(std::initializer_list<std::pair<std::string, Vec2>> list) { return test::named_points(list); }

using test::crosses_wall;
using test::dist;
using test::wall_path;

// Every cell against the closed form of several point seeds round one vertical wall: owners where
// the two best paths differ by more than `margin`, distances to float rounding.
void expect_wall_closed_form(const std::vector<Vec2>& seeds, Vec2 a, Vec2 b, const GridSpec& g, int64_t* hidden_cells,
                             const char* name) {
  Worst worst{name};
  SeedSet s;
  for (size_t i = 0; i < seeds.size(); ++i) s.add_point(s.add_feature(s.owner_code("o" + std::to_string(i))), seeds[i]);
  Barriers walls;
  walls.add_line(std::vector<Vec2>{a, b}, "wall");
  const SeaField f = sea_field(s, walls, g);
  EXPECT_EQ(f.land_cells, 0);
  EXPECT_EQ(f.unreachable_cells, 0);
  EXPECT_EQ(f.barrier_vertices, 2);
  *hidden_cells = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, r);
      std::vector<std::pair<double, size_t>> paths;
      for (size_t i = 0; i < seeds.size(); ++i) paths.emplace_back(wall_path(seeds[i], x, a, b), i);
      std::sort(paths.begin(), paths.end());
      const int32_t site = f.field.site.at(c, r);
      ASSERT_GE(site, 0);
      const bool clear = paths.size() < 2 || paths[1].first - paths[0].first > 1e-9;
      if (clear) {
        ASSERT_EQ(site, static_cast<int32_t>(paths[0].second)) << c << "," << r;
      }
      ASSERT_NEAR(f.field.distance.at(c, r), paths[0].first, 1e-6 * paths[0].first + 1e-9) << c << "," << r;
      worst.add(f.field.distance.at(c, r), paths[0].first);
      const bool hidden = crosses_wall(seeds[static_cast<size_t>(site)], x, a.x, a.y, b.y);
      *hidden_cells += hidden;
      // The via: the wall's end the path bends at, or none where the seed is seen.
      if (hidden) {
        ASSERT_TRUE(f.via.at(c, r) == 0 || f.via.at(c, r) == 1) << c << "," << r;
      } else if (clear) {
        ASSERT_EQ(f.via.at(c, r), kNoVia) << c << "," << r;
      }
    }
}

TEST(SeaField, WallShadowGoesRoundTheNearerEnd) {
  const GridSpec g = test::grid_of(40, 40);
  int64_t hidden = 0;
  expect_wall_closed_form({{10.3, 20.6}}, {20, 10}, {20, 30}, g, &hidden,
                          "a wall, one seed (its shadow round the nearer end)");
  EXPECT_GT(hidden, 150);  // a real shadow
}

TEST(SeaField, SeedBehindTheWallsEndAgainstOneInView) {
  // s1 behind the wall's end A (|s1 - A| < |s2 - A|): where x sees A and s2 but not s1, the line is
  // the hyperbola branch |s1 - A| + |x - A| = |x - s2|. A third seed gives a tripoint on it.
  const Vec2 a{20, 25}, b{20, 60};
  const Vec2 s1{14.2, 31.7}, s2{33.1, 38.3};
  ASSERT_LT(dist(s1, a), dist(s2, a));
  const GridSpec g = test::grid_of(48, 48);
  int64_t hidden = 0;
  expect_wall_closed_form({s1, s2}, a, b, g, &hidden, "a seed behind the wall's end against one in view (hyperbola)");
  EXPECT_GT(hidden, 50);
  // The hyperbola is really there: cells of s1 behind the wall, and cells of s2 beside them.
  expect_wall_closed_form({s1, s2, {40.6, 8.9}}, a, b, g, &hidden, "the same with a third seed (a tripoint on it)");
  EXPECT_GT(hidden, 20);
}

TEST(SeaField, ATieAtAVertexHandsTheRegionBehindItToTheLowerSite) {
  // Two seeds at the same distance from the wall's end A, both hidden from the cells behind it:
  // those cells take the lower site (here the second owner added first: site 0).
  const Vec2 a{20, 20}, b{20, 45};
  const Vec2 s_lo{20 - 6, 20 + 8};  // 10 from A
  const Vec2 s_hi{20 - 8, 20 + 6};  // 10 from A
  SeedSet s = points({{"second", s_hi}, {"first", s_lo}});
  Barriers walls;
  walls.add_line(std::vector<Vec2>{a, b}, "wall");
  const GridSpec g = test::grid_of(40, 50);
  const SeaField f = sea_field(s, walls, g);
  int64_t behind = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, r);
      if (!crosses_wall(s_lo, x, a.x, a.y, b.y) || !crosses_wall(s_hi, x, a.x, a.y, b.y)) continue;
      if (dist(x, a) + 10.0 > dist(x, b) + std::min(dist(s_lo, b), dist(s_hi, b)) - 1e-6) continue;  // round B
      ++behind;
      ASSERT_EQ(f.field.site.at(c, r), 0) << c << "," << r;
      ASSERT_EQ(f.via.at(c, r), 0);
    }
  EXPECT_GT(behind, 40);
}

// A regular n-gon island (centre c, circumradius R): the shortest path between two points outside
// runs along tangents and the polygon's edge chain; the minimum over both ways round and every
// pair of vertices each end sees.
double around_polygon(const std::vector<Vec2>& poly, Vec2 s, Vec2 x, const Visibility& vis) {
  if (vis.sees(Visibility::Place{s}, Visibility::Place{x})) return dist(s, x);
  const size_t n = poly.size();
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < n; ++i) {
    if (!vis.sees(Visibility::Place{s}, Visibility::Place{poly[i]})) continue;
    for (size_t j = 0; j < n; ++j) {
      if (!vis.sees(Visibility::Place{poly[j]}, Visibility::Place{x})) continue;
      double ccw = 0, cw = 0;
      for (size_t k = i; k != j; k = (k + 1) % n) ccw += dist(poly[k], poly[(k + 1) % n]);
      for (size_t k = i; k != j; k = (k + n - 1) % n) cw += dist(poly[k], poly[(k + n - 1) % n]);
      best = std::min(best, dist(s, poly[i]) + std::min(ccw, cw) + dist(poly[j], x));
    }
  }
  return best;
}

TEST(SeaField, Regular64GonIslandTangentChainTangent) {
  const Vec2 c{25.3, 24.7};
  const double radius = 9.5;
  std::vector<Vec2> poly;
  for (int i = 0; i < 64; ++i) {
    const double t = 2 * M_PI * (i + 0.25) / 64;
    poly.push_back({c.x + radius * std::cos(t), c.y + radius * std::sin(t)});
  }
  Barriers island;
  island.add_polygon({poly}, "island");
  const Visibility vis(island);
  const Vec2 seed{6.2, 23.9};
  SeedSet s = points({{"port", seed}});
  const GridSpec g = test::grid_of(50, 50);
  const SeaField f = sea_field(s, island, g);
  int64_t shadow = 0, land = 0;
  Worst worst{"a regular 64-gon island (tangent, edge chain, tangent)"};
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t col = 0; col < g.width; ++col) {
      const Vec2 x = centre(g, col, r);
      if (vis.on_land(x)) {
        ++land;
        ASSERT_EQ(f.field.site.at(col, r), kNoSite);
        ASSERT_EQ(f.via.at(col, r), kNoVia);
        continue;
      }
      const double want = around_polygon(poly, seed, x, vis);
      shadow += want > dist(seed, x) + 1e-9;
      ASSERT_EQ(f.field.site.at(col, r), 0);
      ASSERT_NEAR(f.field.distance.at(col, r), want, 1e-6 * want) << col << "," << r;
      worst.add(f.field.distance.at(col, r), want);
    }
  EXPECT_EQ(f.land_cells, land);
  EXPECT_GT(land, 200);
  EXPECT_GT(shadow, 100);
  EXPECT_GT(f.max_detour, 1.05);
}

TEST(SeaField, StraitNarrowerThanACellStaysOpen) {
  // Two land masses 0.2 apart, reaching far beyond the grid (the way round them is longer than
  // any path through the strait); cells are 1 wide and no centre lies in the strait.
  Barriers b;
  b.add_polygon({{{-60, 10}, {14.9, 10}, {14.9, 20}, {-60, 20}}}, "west");
  b.add_polygon({{{15.1, 10}, {90, 10}, {90, 20}, {15.1, 20}}}, "east");
  SeedSet s = points({{"south", {15.0, 3.3}}});
  const GridSpec g = test::grid_of(30, 30);
  const SeaField f = sea_field(s, b, g);
  EXPECT_EQ(f.unreachable_cells, 0);
  const Visibility vis(b.translated({0, 0}));
  Worst worst{"a strait 0.2 cells wide (open, through its mouth)"};
  for (int64_t r = 0; r < 10; ++r)  // the northern sea (y > 20)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, r);
      ASSERT_EQ(f.field.site.at(c, r), 0);
      // Through the strait: over its mouth (15, 20) at worst.
      const double via_mouth = std::min(dist({15.0, 3.3}, {14.9, 20}) + dist({14.9, 20}, x),
                                        dist({15.0, 3.3}, {15.1, 20}) + dist({15.1, 20}, x));
      const double want =
          vis.sees(Visibility::Place{{15.0, 3.3}}, Visibility::Place{x}) ? dist({15.0, 3.3}, x) : via_mouth;
      ASSERT_NEAR(f.field.distance.at(c, r), want, 1e-5) << c << "," << r;
      worst.add(f.field.distance.at(c, r), want);
      ASSERT_LT(f.field.distance.at(c, r), 45.0);  // not round the land masses
    }
}

TEST(SeaField, MirrorSymmetricLayoutPutsTheLineOnTheAxis) {
  // Mirror image about x = 20, no barrier vertex on the axis; no cell centre on it either.
  Barriers b;
  b.add_polygon({{{8, 12}, {15, 14}, {13, 22}}}, "west island");
  b.add_polygon({{{32, 12}, {27, 22}, {25, 14}}}, "east island");
  b.add_line(std::vector<Vec2>{{17, 30}, {12, 33}}, "west boom");
  b.add_line(std::vector<Vec2>{{23, 30}, {28, 33}}, "east boom");
  SeedSet s = points({{"west", {9.5, 18.5}}, {"east", {30.5, 18.5}}});
  const GridSpec g = test::grid_of(40, 40);
  const SeaField f = sea_field(s, b, g);
  Worst worst{"a mirror-symmetric layout (the line on the axis; d against its mirror cell)"};
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const int64_t m = g.width - 1 - c;
      ASSERT_EQ(f.field.site.at(c, r) == kNoSite, f.field.site.at(m, r) == kNoSite);
      if (f.field.site.at(c, r) == kNoSite) continue;
      ASSERT_EQ(f.field.site.at(c, r), c < 20 ? 0 : 1) << c << "," << r;
      ASSERT_NEAR(f.field.distance.at(c, r), f.field.distance.at(m, r), 1e-5);
      worst.add(f.field.distance.at(c, r), f.field.distance.at(m, r));
    }
}

TEST(SeaField, BarriersThatAreSeedsChangeNothing) {
  // Coasts as both seeds and land, with ports among them: off land the field is the straight
  // one, bit for bit.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 40.0);
  int rounds_compared = 0;
  for (int round = 0; round < 12; ++round) {
    SeedSet s;
    Barriers b;
    for (int k = 0; k < 4; ++k) {
      const Vec2 c{u(rng), u(rng)};
      Ring ring;
      const int n = 3 + static_cast<int>(rng() % 5);
      for (int i = 0; i < n; ++i) {
        const double t = 2 * M_PI * i / n, r = 2.0 + u(rng) / 10.0;
        ring.push_back({c.x + r * std::cos(t), c.y + r * std::sin(t)});
      }
      const int32_t f = s.add_feature(s.owner_code(k % 2 ? "A" : "B"));
      if (k == 3) {
        s.add_polyline(f, std::vector<Vec2>(ring.begin(), ring.end()));  // a line that is a barrier line too
        b.add_line(std::vector<Vec2>(ring.begin(), ring.end()), "line");
      } else {
        s.add_polygon(f, {ring});
        b.add_polygon({ring}, "land");
      }
    }
    s.add_point(s.add_feature(s.owner_code("A")), {u(rng), u(rng)});
    const GridSpec g = test::grid_of(48, 48, 1.0, -4.0, 44.0);
    ComputeOptions o;
    o.method = Method::brute_force;
    NearestField straight;
    try {
      straight = compute(s, g, o);
    } catch (const Error&) {
      continue;
    }
    SeaField sea;
    try {
      sea = sea_field(s, b, g);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input);  // the random point fell on land
      continue;
    }
    const Visibility vis(b);
    int64_t compared = 0;
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        if (vis.on_land(centre(g, c, r))) {
          ASSERT_EQ(sea.field.site.at(c, r), kNoSite);
          continue;
        }
        ++compared;
        ASSERT_EQ(sea.field.site.at(c, r), straight.site.at(c, r)) << round << ": " << c << "," << r;
        ASSERT_EQ(std::bit_cast<uint32_t>(sea.field.distance.at(c, r)),
                  std::bit_cast<uint32_t>(straight.distance.at(c, r)));
        ASSERT_EQ(sea.via.at(c, r), kNoVia);
      }
    EXPECT_GT(compared, 1000);
    ++rounds_compared;
  }
  EXPECT_GE(rounds_compared, 6);
}

// The same invariant where the states' land overlaps along their borders (coasts as seeds and
// barriers both, as the western Baltic's are): each random island pair shares a border strip,
// the seeds' vertices under the other's land stay where they are (snap_to_sea), the engines
// agree cell for cell, and off land the field is the straight one, bit for bit; with a further
// island that is land but no seed, the engines still agree.
TEST(SeaField, OverlappingBarriersThatAreSeedsChangeNothing) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int rounds_compared = 0, borders = 0;
  for (int round = 0; round < 10; ++round) {
    SeedSet s;
    Barriers b;
    for (int k = 0; k < 2; ++k) {
      // Two quadrilaterals side by side, the west one reaching into the east one.
      const double x0 = 4 + 28 * u(rng), y0 = 4 + 28 * u(rng), w = 3 + 3 * u(rng), h = 4 + 4 * u(rng);
      const double over = 0.2 + 0.6 * u(rng);
      const Ring west{{x0, y0}, {x0 + w + over, y0 + 0.3}, {x0 + w + over, y0 + h - 0.2}, {x0, y0 + h}};
      const Ring east{{x0 + w, y0 + 0.1}, {x0 + 2 * w, y0}, {x0 + 2 * w, y0 + h}, {x0 + w, y0 + h - 0.1}};
      s.add_polygon(s.add_feature(s.owner_code("A"), "west"), {west});
      s.add_polygon(s.add_feature(s.owner_code("B"), "east"), {east});
      b.add_polygon({west}, "west");
      b.add_polygon({east}, "east");
    }
    s.add_point(s.add_feature(s.owner_code("C")), {40 * u(rng), 40 * u(rng)});
    const GridSpec g = test::grid_of(48, 48, 1.0, -4.0, 44.0);
    SnappedSeeds snapped;
    try {
      snapped = snap_to_sea(s, b, 0.0);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input);  // the port fell on land, or islands cover one another
      continue;
    }
    borders += snapped.on_land_borders > 0;
    ComputeOptions o;
    o.method = Method::brute_force;
    const NearestField straight = compute(snapped.seeds, g, o);
    const SeaField sea = sea_field(snapped.seeds, b, g);
    const Visibility vis(b);
    int64_t compared = 0;
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        if (vis.on_land(centre(g, c, r))) continue;
        ++compared;
        ASSERT_EQ(sea.field.site.at(c, r), straight.site.at(c, r)) << round << ": " << c << "," << r;
        ASSERT_EQ(std::bit_cast<uint32_t>(sea.field.distance.at(c, r)),
                  std::bit_cast<uint32_t>(straight.distance.at(c, r)));
      }
    EXPECT_GT(compared, 1000);
    // Land that is no seed: paths bend round it; the engines still agree.
    Barriers more = b;
    const double x = 40 * u(rng), y = 40 * u(rng);
    more.add_polygon({{{x, y}, {x + 3, y}, {x + 3, y + 2}, {x, y + 2}}}, "rock");
    try {
      sea_field(snap_to_sea(snapped.seeds, more, 0.0).seeds, more, g);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input);  // the rock covers a seed
    }
    ++rounds_compared;
  }
  EXPECT_GE(rounds_compared, 6);
  EXPECT_GE(borders, 6);
}

TEST(SeaField, PortsOnTheCoastAndAnEnclosedLagoon) {
  // An atoll with a closed lagoon: its port on the outer coast serves the sea outside, the one in
  // the lagoon only the lagoon.
  Barriers b;
  b.add_polygon({{{10, 10}, {30, 10}, {30, 30}, {10, 30}}, {{15, 15}, {25, 15}, {25, 25}, {15, 25}}}, "atoll");
  SeedSet s = points({{"lagoon", {20, 15}}, {"outside", {20, 10}}});
  const GridSpec g = test::grid_of(40, 40);
  const SeaField f = sea_field(s, b, g);
  const Visibility vis(b);
  int64_t lagoon = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, r);
      if (vis.on_land(x)) continue;
      const bool inside = x.x > 15 && x.x < 25 && x.y > 15 && x.y < 25;
      lagoon += inside;
      ASSERT_EQ(f.field.site.at(c, r), inside ? 0 : 1) << c << "," << r;
    }
  EXPECT_EQ(lagoon, 100);
  EXPECT_EQ(f.unreachable_cells, 0);
  // Without the outer port the sea outside is unreachable, and counted.
  SeedSet only = points({{"lagoon", {20, 15}}});
  const SeaField g2 = sea_field(only, b, g);
  EXPECT_EQ(g2.unreachable_cells, 40 * 40 - 400);
}

TEST(SeaField, UnreachableCountsOnlyWithinTheMaximumDistanceInBothEngines) {
  // The atoll's lagoon port alone, with a maximum distance: sea outside the atoll that the port
  // lies within 12 of in a straight line is unreachable (no path leaves the lagoon) and counted;
  // sea beyond 12 has no owner either way and is not counted. The exact engine and the oracle
  // count alike, and both equal the count from the cells' centres.
  Barriers b;
  b.add_polygon({{{10, 10}, {30, 10}, {30, 30}, {10, 30}}, {{15, 15}, {25, 15}, {25, 25}, {15, 25}}}, "atoll");
  SeedSet only = points({{"lagoon", {20, 15}}});
  const GridSpec g = test::grid_of(40, 40);
  SeaOptions limited;
  limited.max_distance = 12.0;
  const SeaField exact = compute_sea(only, b, g, g.full_window(), limited);
  const SeaField reference = brute_force_sea(only, b, g, g.full_window(), 12.0);
  const Visibility vis(b);
  int64_t expected = 0, beyond = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, r);
      if (vis.on_land(x)) continue;
      const bool lagoon = x.x > 15 && x.x < 25 && x.y > 15 && x.y < 25;
      if (lagoon) continue;
      ASSERT_EQ(exact.field.site.at(c, r), kNoSite) << c << "," << r;
      ASSERT_EQ(reference.field.site.at(c, r), kNoSite) << c << "," << r;
      (dist(x, {20, 15}) <= 12.0 ? expected : beyond) += 1;
    }
  EXPECT_GT(expected, 50);
  EXPECT_GT(beyond, 500);
  EXPECT_EQ(exact.unreachable_cells, expected);
  EXPECT_EQ(reference.unreachable_cells, expected);
}

TEST(SeaField, MaximumDistanceCutsPathsNotStraightLines) {
  // Behind the wall a cell's path is longer than its straight distance: the limit cuts the path.
  SeedSet s = points({{"a", {10.3, 20.6}}, {"b", {33.2, 8.7}}});
  Barriers walls;
  walls.add_line(std::vector<Vec2>{{20, 10}, {20, 30}}, "wall");
  const GridSpec g = test::grid_of(40, 40);
  const SeaField all = compute_sea(s, walls, g, g.full_window());
  SeaOptions limited;
  limited.max_distance = 15.0;
  const SeaField cut = compute_sea(s, walls, g, g.full_window(), limited);
  const SeaField reference = brute_force_sea(s, walls, g, g.full_window(), 15.0);
  int64_t kept = 0, dropped = 0, dropped_by_path = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      ASSERT_EQ(cut.field.site.at(c, r), reference.field.site.at(c, r));
      ASSERT_EQ(cut.field.distance.at(c, r), reference.field.distance.at(c, r));
      const float d = all.field.distance.at(c, r);
      if (d <= 15.0f) {
        ++kept;
        ASSERT_EQ(cut.field.site.at(c, r), all.field.site.at(c, r));
        ASSERT_EQ(cut.field.distance.at(c, r), d);
      } else {
        ++dropped;
        ASSERT_EQ(cut.field.site.at(c, r), kNoSite);
        ASSERT_EQ(cut.field.distance.at(c, r), kNoDistance);
        const Vec2 x = centre(g, c, r);
        dropped_by_path += std::min(dist(x, {10.3, 20.6}), dist(x, {33.2, 8.7})) <= 15.0;
      }
    }
  EXPECT_GT(kept, 300);
  EXPECT_GT(dropped, 300);
  EXPECT_GT(dropped_by_path, 10);  // within 15 in a straight line, beyond it by sea
}

TEST(SeaField, Refusals) {
  Barriers b;
  b.add_polygon({{{10, 10}, {20, 10}, {20, 20}, {10, 20}}}, "land.gpkg:coast:fid 3");
  const GridSpec g = test::grid_of(30, 30);
  SeedSet inside;
  inside.add_point(inside.add_feature(inside.owner_code("A"), "ports.gpkg:ports:fid 9"), {15, 15});
  for (bool exact : {false, true}) {
    try {
      exact ? compute_sea(inside, b, g, g.full_window()) : brute_force_sea(inside, b, g, g.full_window());
      FAIL() << "a seed inside a barrier was taken";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::invalid_input);
      EXPECT_NE(std::string(e.what()).find("ports.gpkg:ports:fid 9"), std::string::npos) << e.what();
    }
  }
}

// Partial effect compares two whole fields (the lines' stage): the engines read no effect, and a
// feature of effect 0.5 counts as at full effect, cell for cell.
TEST(SeaField, AFeaturesEffectIsNotTheEnginesToRead) {
  Barriers b;
  b.add_polygon({{{10, 10}, {20, 10}, {20, 20}, {10, 20}}}, "land.gpkg:coast:fid 3");
  const GridSpec g = test::grid_of(30, 30);
  const SeedSet full = points({{"A", {5, 15}}, {"B", {25, 15}}, {"B", {15, 25}}});
  SeedSet partial = full;
  partial.set_effect(2, 0.5);
  for (bool exact : {false, true}) {
    SCOPED_TRACE(exact ? "exact" : "reference");
    auto field = [&](const SeedSet& s) {
      return exact ? compute_sea(s, b, g, g.full_window()) : brute_force_sea(s, b, g, g.full_window());
    };
    const SeaField a = field(full), c = field(partial);
    EXPECT_EQ(a.field.site.cells(), c.field.site.cells());
    EXPECT_EQ(a.field.distance.cells(), c.field.distance.cells());
    EXPECT_EQ(a.via.cells(), c.via.cells());
  }
}

// Random archipelagos (islands that may overlap, with lagoons, booms, islands touching at
// corners, point and line seeds on the coasts and at sea; random_archipelago.hpp): the exact
// engine equals the reference cell for cell, and neighbours keep the triangle inequality.
TEST(SeaField, RandomArchipelagosExactEqualsTheReference) {
  std::mt19937_64 rng(31);
  int64_t via_cells = 0, rounds = 0;
  for (int round = 0; round < 200; ++round) {
    const test::Archipelago a = test::random_archipelago(rng, round);
    const GridSpec g = test::grid_of(40, 40, 1.0, -1.0, 41.0);
    SeaField f;
    try {
      f = sea_field(a.seeds, a.barriers, g);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();  // a coast seed inside another island
      continue;
    }
    if (HasFailure()) return;
    ++rounds;
    ASSERT_TRUE(test::triangle_inequality_holds(f, a.barriers, g, 1)) << "round " << round;
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) via_cells += f.via.at(c, r) != kNoVia;
  }
  EXPECT_GE(rounds, 150);
  EXPECT_GT(via_cells, 10000);  // paths round land, not only straight ones
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// Strips of one grid computed one after the other on one preparation give the whole field (a
// streamed job's way), and the bend nodes are settled once.
TEST(SeaField, StripsOfOnePreparationMakeTheWholeField) {
  Barriers b;
  b.add_polygon({{{10, 10}, {30, 10}, {30, 30}, {10, 30}}, {{15, 15}, {25, 15}, {25, 25}, {15, 25}}}, "atoll");
  b.add_line(std::vector<Vec2>{{33, 2}, {36, 20}}, "boom");
  SeedSet s = points({{"lagoon", {20, 15}}, {"outside", {20, 10}}, {"east", {38.5, 9.5}}});
  const GridSpec g = test::grid_of(40, 40);
  const SeaField whole = compute_sea(s, b, g, g.full_window());
  SeaOptions o;
  o.prepared = prepare_sea(s, b, g);
  int64_t land = 0;
  for (int64_t row0 = 0; row0 < g.height; row0 += 13) {
    const Window w{0, row0, g.width, std::min<int64_t>(13, g.height - row0)};
    const SeaField strip = compute_sea(s, b, g, w, o);
    EXPECT_EQ(strip.bends_seconds, 0.0);
    EXPECT_EQ(strip.bend_tests, 0);
    land += strip.land_cells;
    for (int64_t r = 0; r < w.height; ++r)
      for (int64_t c = 0; c < w.width; ++c) {
        ASSERT_EQ(strip.field.site.at(c, r), whole.field.site.at(c, row0 + r));
        ASSERT_EQ(strip.field.distance.at(c, r), whole.field.distance.at(c, row0 + r));
        ASSERT_EQ(strip.via.at(c, r), whole.via.at(c, row0 + r));
      }
  }
  EXPECT_EQ(land, whole.land_cells);
  EXPECT_GT(whole.bend_tests, 0);
  // Any number of threads gives the same field (the per-thread hints change the work only).
  for (int threads : {1, 3}) {
    SeaOptions t;
    t.threads = threads;
    const SeaField f = compute_sea(s, b, g, g.full_window(), t);
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        ASSERT_EQ(f.field.site.at(c, r), whole.field.site.at(c, r));
        ASSERT_EQ(f.field.distance.at(c, r), whole.field.distance.at(c, r));
        ASSERT_EQ(f.via.at(c, r), whole.via.at(c, r));
      }
  }
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// Blocks of cells answered at once (proofs per block) give the field every cell answered alone
// gives, to the bit: random archipelagos on a grid fine enough that most blocks are clear of
// land, with ports at sea and on coasts, a coast as a line seed, an island as a polygon seed
// (its interior cells are no block's), an atoll whose lagoon no port reaches (a block with no
// path at all), with and without a maximum distance.
TEST(SeaField, BlocksAnswerAsEveryCellAlone) {
  std::mt19937_64 rng(57);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int64_t block_cells = 0, drawn_cells = 0, cells = 0, via_cells = 0, unreachable = 0;
  int rounds = 0;
  for (int round = 0; round < 6; ++round) {
    Barriers b;
    std::vector<Ring> outlines;
    for (int k = 0; k < 9; ++k) {  // one island in each of 3 x 3 squares of 13 units (the atoll's apart)
      if (k == 2) continue;
      const double x = 13 * (k % 3) + 1 + 4 * u(rng), y = 13 * (k / 3) + 1 + 4 * u(rng), w = 1.5 + 6 * u(rng),
                   h = 1.5 + 6 * u(rng);
      std::vector<Ring> rings{{{x, y}, {x + w, y}, {x + w * 0.6, y + h}, {x + w * 0.1, y + h * 0.7}, {x, y + h * 0.8}}};
      outlines.push_back(rings[0]);
      b.add_polygon(rings, "island");
    }
    // An atoll with a wide lagoon no port lies in.
    b.add_polygon({{{27, 1}, {39, 1}, {39, 12}, {27, 12}}, {{28, 2}, {38, 2}, {38, 11}, {28, 11}}}, "atoll");
    b.add_line(std::vector<Vec2>{{40 * u(rng), 40 * u(rng)}, {40 * u(rng), 40 * u(rng)}}, "boom");
    const Visibility vis(b);
    SeedSet s;
    int ports = 0;
    for (int k = 0; k < 20 && ports < 5; ++k) {
      const Vec2 p{40 * u(rng), 40 * u(rng)};
      if (vis.classify(p) != Visibility::Ground::open_sea || (p.x > 27 && p.x < 39 && p.y > 1 && p.y < 12)) continue;
      s.add_point(s.add_feature(s.owner_code(ports % 2 ? "A" : "B")), p);
      ++ports;
    }
    const Ring& o = outlines[static_cast<size_t>(round) % outlines.size()];
    s.add_point(s.add_feature(s.owner_code("C")), {(o[0].x + o[1].x) / 2, (o[0].y + o[1].y) / 2});
    s.add_polyline(s.add_feature(s.owner_code("D")), std::vector<Vec2>{o[1], o[2]});
    const Ring& island = outlines[static_cast<size_t>(round + 1) % outlines.size()];
    s.add_polygon(s.add_feature(s.owner_code("E")), {island});
    const GridSpec g = test::grid_of(200, 200, 0.2, 0.0, 40.0);
    for (const double max_distance : {std::numeric_limits<double>::infinity(), 9.0}) {
      SeaOptions options;
      options.max_distance = max_distance;
      SeaField f;
      try {
        f = test::blocks_agree(s, b, g, options);
      } catch (const Error& e) {
        ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();  // a seed inside another island
        break;
      }
      if (HasFailure()) return;
      ++rounds;
      block_cells += f.block_cells;
      drawn_cells += f.drawn_cells;
      cells += g.width * g.height;
      unreachable += f.unreachable_cells;
      for (int64_t r = 0; r < g.height; ++r)
        for (int64_t c = 0; c < g.width; ++c) via_cells += f.via.at(c, r) != kNoVia;
    }
  }
  EXPECT_GE(rounds, 8);
  EXPECT_GT(block_cells, cells / 2);   // most cells in blocks
  EXPECT_GT(drawn_cells, cells / 10);  // and many drawn before them
  EXPECT_GT(via_cells, 20000);         // many of them round land
  EXPECT_GT(unreachable, 1000);        // the lagoon
}

}  // namespace
}  // namespace rv
