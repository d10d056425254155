// Lines under the distance by sea: the metric by sea (rv/sea/sea_metric.hpp) gives each owner's
// own distance by sea, cell for cell the reference's for that owner's seeds alone; boundaries
// and tripoints placed with it lie on the closed forms round a wall (the hyperbola branch behind
// its end, and a tripoint on it; the parabola of its end against a coast segment), and never
// cross a barrier; a tie region behind a vertex is the
// lower site's, its edge the line.
#include <gtest/gtest.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include "geodesic_oracle.hpp"
#include "lines/line_tools.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/report/turning_points.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/sea_metric.hpp"
#include "rv/sea/visibility.hpp"
#include "seed_gen.hpp"
#include "wall_paths.hpp"
#include "wall_sea.hpp"

namespace rv {
namespace {

Vec2 centre(const GridSpec& g, int64_t c, int64_t r) { return Vec2{g.centre_x(c), g.centre_y(r)}; }

using test::crosses_wall;
using test::dist;
using test::wall_path;

// Random islands (some with a lake), a boom, point seeds of three owners at sea, a port on a
// coast and a coast line as a seed of a fourth: the layouts the field's random test uses.
struct Archipelago {
  Barriers barriers;
  SeedSet seeds;
};
// `at`: where a position of the layout goes (the same draws whatever it is).
bool archipelago(
    std::mt19937_64& rng, Archipelago& out, Vec2 (*at)(Vec2) = [](Vec2 p) { return p; }) {
  std::uniform_int_distribution<int> coord(0, 36);
  std::vector<Ring> outlines;
  auto placed_at = [&](Ring ring) {
    for (Vec2& v : ring) v = at(v);
    return ring;
  };
  for (int k = 0; k < 6; ++k) {
    const double x = coord(rng), y = coord(rng), w = 2 + coord(rng) % 7, h = 2 + coord(rng) % 7;
    std::vector<Ring> rings{placed_at({{x, y}, {x + w, y}, {x + w * 0.6, y + h}, {x, y + h * 0.8}})};
    if (w > 5 && h > 5) rings.push_back(placed_at({{x + 1.5, y + 1.5}, {x + 3, y + 1.5}, {x + 2.5, y + 3}}));
    outlines.push_back(rings[0]);
    out.barriers.add_polygon(rings, "island");
  }
  out.barriers.add_line(placed_at({{double(coord(rng)), double(coord(rng))}, {double(coord(rng)), double(coord(rng))}}),
                        "boom");
  const Visibility vis(out.barriers);
  int placed = 0;
  for (int k = 0; k < 20 && placed < 7; ++k) {
    const Vec2 p = at(Vec2{coord(rng) + 0.25, coord(rng) + 0.75});
    if (vis.on_land(p)) continue;
    out.seeds.add_point(
        out.seeds.add_feature(out.seeds.owner_code(std::string(1, static_cast<char>('A' + placed % 3)))), p);
    ++placed;
  }
  const Ring& o = outlines[0];
  out.seeds.add_point(out.seeds.add_feature(out.seeds.owner_code("A")), {(o[0].x + o[1].x) / 2, (o[0].y + o[1].y) / 2});
  out.seeds.add_polyline(out.seeds.add_feature(out.seeds.owner_code("D")), std::vector<Vec2>{o[1], o[2]});
  return placed >= 3;
}

// Each owner's distance by sea from the metric's index, cell for cell against the reference run
// on that owner's seeds alone; and the nearest owner against the exact engine's field.
TEST(SeaLines, EachOwnersDistanceIsTheReferencesForItsSeedsAlone) {
  std::mt19937_64 rng(57);
  const GridSpec g = test::grid_of(40, 40, 1.0, -1.0, 41.0);
  int rounds = 0;
  int64_t compared = 0, behind_land = 0;
  double worst = 0.0;
  for (int round = 0; round < 8; ++round) {
    Archipelago a;
    if (!archipelago(rng, a)) continue;
    std::unique_ptr<SiteMetric> metric;
    SeaField field;
    try {
      field = compute_sea(a.seeds, a.barriers, g, g.full_window());
      metric = make_sea_site_metric(a.seeds, a.barriers, g);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();  // a coast seed inside another island
      continue;
    }
    ++rounds;
    const OwnerIndex index(*metric);
    for (int32_t owner = 1; owner <= a.seeds.owner_count(); ++owner) {
      std::vector<bool> drop(a.seeds.features().size());
      for (size_t f = 0; f < drop.size(); ++f) drop[f] = a.seeds.features()[f].owner != owner;
      std::vector<int32_t> site_of;
      const SeedSet alone = a.seeds.without(drop, site_of);
      const SeaField reference = brute_force_sea(alone, a.barriers, g, g.full_window());
      for (int64_t r = 0; r < g.height; ++r)
        for (int64_t c = 0; c < g.width; ++c) {
          const OwnerIndex::Hit hit = index.nearest_of(centre(g, c, r), owner);
          const int32_t want = reference.field.site.at(c, r);
          if (want == kNoSite) {
            ASSERT_EQ(hit.site, kNoSite) << round << ": " << c << "," << r << " owner " << owner;
            continue;
          }
          ASSERT_NE(hit.site, kNoSite) << round << ": " << c << "," << r << " owner " << owner;
          const double d = reference.field.distance.at(c, r);
          ASSERT_NEAR(hit.distance, d, 1e-6 * d + 1e-9) << round << ": " << c << "," << r << " owner " << owner;
          worst = std::max(worst, std::abs(hit.distance - d));
          ++compared;
          behind_land += reference.via.at(c, r) != kNoVia;
        }
    }
    // The index's nearest owner is the field's wherever the field's path is clearly the best.
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        const int32_t site = field.field.site.at(c, r);
        const OwnerIndex::Hit hit = index.nearest(centre(g, c, r));
        if (site == kNoSite) {
          ASSERT_EQ(hit.site, kNoSite);
          continue;
        }
        ASSERT_NEAR(hit.distance, field.field.distance.at(c, r), 1e-6 * hit.distance + 1e-9);
        const OwnerIndex::Hit other = index.nearest_not_of(centre(g, c, r), a.seeds.site_owner(site));
        if (other.distance - hit.distance > 1e-6 * hit.distance + 1e-9) {
          ASSERT_EQ(a.seeds.site_owner(hit.site), a.seeds.site_owner(site)) << round << ": " << c << "," << r;
        }
      }
  }
  EXPECT_GE(rounds, 5);
  EXPECT_GT(behind_land, 2000);  // owners reached round land, not only straight
  std::printf("each owner's distance by sea: %lld cells, worst |d - reference| %.3g\n",
              static_cast<long long>(compared), worst);
}

// The sea metric as it is, but with the owners' searches started elsewhere (SiteMetric::
// search_start): nowhere, or at the owner's last site (mostly not its nearest); counting the
// sites measured.
class StartedElsewhere final : public SiteMetric {
 public:
  enum class Start { as_is, none, last };
  StartedElsewhere(const SiteMetric& m, Start start) : SiteMetric(m.seeds()), m_(m), start_(start) {}
  Kind kind() const override { return m_.kind(); }
  MetricSpec spec() const override { return m_.spec(); }
  bool straight() const override { return m_.straight(); }
  double distance(Vec2 p, int32_t site) const override {
    ++measured;
    return m_.distance(p, site);
  }
  double distance_at_vertex(Vec2 p, int32_t site, Vec2& gradient, VertexHit& hit) const override {
    ++measured;
    return m_.distance_at_vertex(p, site, gradient, hit);
  }
  double distance_within(Vec2 p, int32_t site, double bound, Vec2& gradient, VertexHit& hit) const override {
    ++measured;
    return m_.distance_within(p, site, bound, gradient, hit);
  }
  Vec2 nearest_point(Vec2 p, int32_t site) const override { return m_.nearest_point(p, site); }
  double point_distance(Vec2 a, Vec2 b) const override { return m_.point_distance(a, b); }
  Vec3 embed(Vec2 p) const override { return m_.embed(p); }
  Box3 site_bounds(int32_t site) const override { return m_.site_bounds(site); }
  double distance_lower_bound(Vec2 p, int32_t site) const override { return m_.distance_lower_bound(p, site); }
  int32_t search_start(Vec2 p, int32_t owner) const override {
    if (start_ == Start::as_is) return m_.search_start(p, owner);
    if (start_ == Start::none) return kNoSite;
    for (auto site = static_cast<int32_t>(seeds().sites().size()) - 1; site >= 0; --site)
      if (seeds().site_owner(site) == owner) return site;
    return kNoSite;
  }
  mutable int64_t measured = 0;

 private:
  const SiteMetric& m_;
  const Start start_;
};

// The owners' searches by sea start from the owner's own shortest path over all its roots
// (search_start, as the field finds a cell's) and measure each other site only up to the best so
// far (distance_within): the same hits, to the bit, as started nowhere or at a far site, over
// random archipelagos in the plane (with and without weights, with a reach) and on the
// ellipsoid; the start's distance is the owner's; distance_within is the distance wherever that
// is within the bound, and above the bound elsewhere; and the searches measure fewer sites.
TEST(SeaLines, AnOwnersSearchBySeaFindsTheSameSiteFromAnyStart) {
  std::mt19937_64 rng(68);
  std::uniform_real_distribution<double> u(0.0, 40.0), f(0.0, 2.0);
  const GridSpec plane = test::grid_of(40, 40, 1.0, -1.0, 41.0);
  // (A unit of the layout 0.0175 deg of longitude and 0.01 of latitude, near 55 N.)
  auto on_ellipsoid = [](Vec2 p) { return Vec2{10.0 + 0.0175 * p.x, 55.0 + 0.01 * p.y}; };
  const GridSpec sphere = test::grid_of(40, 40, 0.0175, 10.0 - 0.0175, 55.41);
  int64_t points = 0, hits = 0, behind = 0, within_checked = 0, cut = 0;
  int64_t measured[3] = {0, 0, 0};  // as is, none, last
  for (int round = 0; round < 16; ++round) {
    const int variant = round % 4;  // 0: plane; 1: weights 0.5 and 2; 2: a reach; 3: the ellipsoid
    Archipelago a;
    if (!(variant == 3 ? archipelago(rng, a, on_ellipsoid) : archipelago(rng, a))) continue;
    for (int32_t k = 0; k < static_cast<int32_t>(a.seeds.features().size()); ++k) {
      if (variant == 1) a.seeds.set_adjustment(k, k % 2 == 0 ? 0.5 : 2.0, std::numeric_limits<double>::infinity());
      if (variant == 2 && k == 0) a.seeds.set_adjustment(k, 1.0, 12.0);
    }
    const GridSpec& g = variant == 3 ? sphere : plane;
    SeaOptions options;
    if (variant == 3) options.metric = test::geodesic_metric();
    std::unique_ptr<SiteMetric> metric;
    try {
      metric = make_sea_site_metric(a.seeds, a.barriers, g, options);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
      continue;
    }
    const StartedElsewhere as_is(*metric, StartedElsewhere::Start::as_is), none(*metric, StartedElsewhere::Start::none),
        last(*metric, StartedElsewhere::Start::last);
    const OwnerIndex ia(as_is), in(none), il(last);
    const int32_t owners = a.seeds.owner_count();
    for (int k = 0; k < 120; ++k) {
      const Vec2 p = variant == 3 ? on_ellipsoid(Vec2{u(rng), u(rng)}) : Vec2{u(rng), u(rng)};
      if (!metric->in_domain(p)) continue;
      ++points;
      auto same = [&](const OwnerIndex::Hit& x, const OwnerIndex::Hit& y, const char* what) {
        ASSERT_EQ(x.site, y.site) << what << " " << round << ": " << p.x << "," << p.y;
        ASSERT_EQ(std::bit_cast<uint64_t>(x.distance), std::bit_cast<uint64_t>(y.distance)) << what << " " << round;
        ASSERT_EQ(std::bit_cast<uint64_t>(x.cost), std::bit_cast<uint64_t>(y.cost)) << what << " " << round;
      };
      for (int32_t owner = 1; owner <= owners; ++owner) {
        const OwnerIndex::Hit h = ia.nearest_of(p, owner);
        same(h, in.nearest_of(p, owner), "nearest_of, started nowhere");
        same(h, il.nearest_of(p, owner), "nearest_of, started at the last site");
        const OwnerIndex::Hit other = ia.nearest_not_of(p, owner);
        same(other, in.nearest_not_of(p, owner), "nearest_not_of, started nowhere");
        same(other, il.nearest_not_of(p, owner), "nearest_not_of, started at the last site");
        if (h.site == kNoSite) continue;
        ++hits;
        behind += metric->last_bend(p, h.site) >= 0;
        // The start is the owner's shortest path by sea: its distance (or cost) is the hit's.
        const int32_t start = metric->search_start(p, owner);
        ASSERT_NE(start, kNoSite) << round << ": " << p.x << "," << p.y;
        ASSERT_EQ(a.seeds.site_owner(start), owner);
        const double c = ia.cost_of(start, metric->distance(p, start));
        ASSERT_NEAR(c, h.cost, 1e-9 * h.cost + 1e-9) << round << ": " << p.x << "," << p.y << " owner " << owner;
      }
      const OwnerIndex::Hit nearest = ia.nearest(p);
      same(nearest, in.nearest(p), "nearest, started nowhere");
      same(nearest, il.nearest(p), "nearest, started at the last site");
      // distance_within: the distance where it is within the bound, else above the bound.
      for (int32_t site = 0; site < static_cast<int32_t>(a.seeds.sites().size()); ++site) {
        if (a.seeds.sites()[static_cast<size_t>(site)].kind == SiteKind::area) continue;
        const double d = metric->distance(p, site);
        Vec2 gd, gw;
        SiteMetric::VertexHit hd, hw;
        metric->distance_at_vertex(p, site, gd, hd);
        const double full = std::isfinite(d) ? d : 50.0;
        for (const double bound : {d, std::nextafter(d, 0.0), f(rng) * full, 0.0}) {
          if (!(bound >= 0.0)) continue;
          const double w = metric->distance_within(p, site, bound, gw, hw);
          ++within_checked;
          if (d <= bound) {
            ASSERT_EQ(std::bit_cast<uint64_t>(w), std::bit_cast<uint64_t>(d)) << round << ": site " << site;
            if (!std::isnan(gd.x)) {
              ASSERT_EQ(std::bit_cast<uint64_t>(gw.x), std::bit_cast<uint64_t>(gd.x));
            }
          } else {
            ASSERT_GT(w, bound) << round << ": site " << site << " at " << p.x << "," << p.y;
            cut += w > d;  // (left unmeasured: something above the bound stands for it)
          }
        }
      }
    }
    measured[0] += as_is.measured;
    measured[1] += none.measured;
    measured[2] += last.measured;
  }
  EXPECT_GT(points, 1000);
  EXPECT_GT(hits, 3000);
  EXPECT_GT(behind, 300);  // hits whose path bends round land
  EXPECT_GT(within_checked, 30000);
  EXPECT_GT(cut, 1000);
  // Started from the owner's shortest path, the searches measure fewer sites than from nowhere
  // or from a far site.
  EXPECT_LT(measured[0], measured[1] * 9 / 10);
  EXPECT_LT(measured[0], measured[2]);
  std::printf(
      "owners' searches by sea: %lld points, %lld hits (%lld bent), the same from every start; sites "
      "measured %lld started by the path search, %lld started nowhere, %lld at the last site; "
      "distance_within checked %lld times, %lld left unmeasured\n",
      static_cast<long long>(points), static_cast<long long>(hits), static_cast<long long>(behind),
      static_cast<long long>(measured[0]), static_cast<long long>(measured[1]), static_cast<long long>(measured[2]),
      static_cast<long long>(within_checked), static_cast<long long>(cut));
}

// The search for where a line meets a coast (line_tools::onto_domain_edge) leaves out an edge
// whose ends' balances have one sign and are too far from 0 for it to reach 0 along the edge
// (its `slope`, two owners' costs changing at most OwnerIndex::cost_slope() per unit of way):
// from points all over random archipelagos, with and without weights, the same junction (or
// none) as the search that samples every edge, for fewer evaluations of the balance. With a reach
// a cost jumps, the slope is infinite and nothing is left out.
TEST(SeaLines, TheSearchOfACoastLeavesOutOnlyEdgesWhereTheCostsCannotBalance) {
  std::mt19937_64 rng(91);
  std::uniform_real_distribution<double> u(0.0, 40.0);
  const GridSpec g = test::grid_of(40, 40, 1.0, -1.0, 41.0);
  int64_t searches = 0, found = 0;
  int64_t calls_all[2] = {0, 0}, calls_slope[2] = {0, 0};  // [with a reach]
  for (int round = 0; round < 12; ++round) {
    Archipelago a;
    if (!archipelago(rng, a)) continue;
    const int variant = round % 3;  // 0: no weights; 1: weights 0.5 and 2; 2: a reach
    for (int32_t f = 0; f < static_cast<int32_t>(a.seeds.features().size()); ++f) {
      if (variant == 1) a.seeds.set_adjustment(f, f % 2 == 0 ? 0.5 : 2.0, std::numeric_limits<double>::infinity());
      if (variant == 2 && f == 0) a.seeds.set_adjustment(f, 1.0, 12.0);
    }
    std::unique_ptr<SiteMetric> metric;
    try {
      metric = make_sea_site_metric(a.seeds, a.barriers, g);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
      continue;
    }
    const OwnerIndex index(*metric);
    const double slope = 2.0 * index.cost_slope();
    const double want[] = {2.0, 4.0, std::numeric_limits<double>::infinity()};
    if (variant <= 2) {
      EXPECT_EQ(slope, want[variant]);
    }
    const int32_t owners = a.seeds.owner_count();
    for (int k = 0; k < 60; ++k) {
      const Vec2 end{u(rng), u(rng)};
      if (!metric->in_domain(end)) continue;
      const int32_t oa = 1 + static_cast<int32_t>(rng() % owners), ob = 1 + (oa % owners);
      int64_t* calls = nullptr;
      auto gap = [&](Vec2 p) {
        ++*calls;
        return index.nearest_of(p, oa).cost - index.nearest_of(p, ob).cost;
      };
      auto accept = [&](Vec2) { return true; };
      Vec2 all{}, cut{};
      calls = &calls_all[variant == 2];
      const bool f_all = line_tools::onto_domain_edge(*metric, end, 4.0, 1e-9, gap, accept, all);
      calls = &calls_slope[variant == 2];
      const bool f_cut = line_tools::onto_domain_edge(*metric, end, 4.0, 1e-9, gap, accept, cut, nullptr, slope);
      ASSERT_EQ(f_all, f_cut) << round << ": " << end.x << "," << end.y;
      if (f_all) {
        EXPECT_EQ(all.x, cut.x);
        EXPECT_EQ(all.y, cut.y);
      }
      ++searches;
      found += f_all;
    }
  }
  EXPECT_GT(searches, 300);
  EXPECT_GT(found, 25);
  EXPECT_LT(calls_slope[0], calls_all[0] * 9 / 10);
  EXPECT_EQ(calls_slope[1], calls_all[1]);
  std::printf(
      "coast searches: %lld, %lld found; balance evaluated %lld times sampling every edge, %lld "
      "leaving out what the slope excludes (with a reach: %lld, %lld)\n",
      static_cast<long long>(searches), static_cast<long long>(found), static_cast<long long>(calls_all[0]),
      static_cast<long long>(calls_slope[0]), static_cast<long long>(calls_all[1]),
      static_cast<long long>(calls_slope[1]));
}

// Owners settled only within a distance by sea (make_sea_site_metric's settle_within): every
// site's and owner's distance up to it is the fully settled metric's, to the bit; beyond it some
// length above it or none. A settling raised to it from a shorter one (settle_sea_metric_within)
// gives the same, having tested as many paths. Settled within half as far again as the field's
// largest distance plus a margin (the job's rule), the boundaries and tripoints are the fully
// settled ones, vertex for vertex; and the settling tested fewer paths.
TEST(SeaLines, OwnersSettledWithinADistanceAreExactUpToIt) {
  std::mt19937_64 rng(58);
  const GridSpec g = test::grid_of(40, 40, 1.0, -1.0, 41.0);
  int rounds = 0;
  int64_t within = 0, beyond = 0, sites_beyond = 0, lines_compared = 0;
  for (int round = 0; round < 10; ++round) {
    Archipelago a;
    if (!archipelago(rng, a)) continue;
    SeaField field;
    SeaMetricStats all_stats, cut_stats;
    std::unique_ptr<SiteMetric> all;
    try {
      field = compute_sea(a.seeds, a.barriers, g, g.full_window());
      all = make_sea_site_metric(a.seeds, a.barriers, g, {}, &all_stats);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
      continue;
    }
    ++rounds;
    const double reach = 9.0;
    const std::unique_ptr<SiteMetric> cut = make_sea_site_metric(a.seeds, a.barriers, g, {}, &cut_stats, reach);
    SeaMetricStats raised_stats;
    const std::unique_ptr<SiteMetric> raised = make_sea_site_metric(a.seeds, a.barriers, g, {}, &raised_stats, 4.0);
    const double first = raised->distance(centre(g, 20, 20), 0);  // (settles to 4)
    EXPECT_FALSE(std::isnan(first));                              // (a length or +infinity)
    const int64_t tests_to_4 = raised_stats.bend_tests;
    settle_sea_metric_within(*raised, reach);
    const OwnerIndex full_index(*all), cut_index(*cut);
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        const Vec2 p = centre(g, c, r);
        for (int32_t site = 0; site < static_cast<int32_t>(a.seeds.sites().size()); ++site) {
          const double d = all->distance(p, site), e = cut->distance(p, site);
          ASSERT_EQ(std::bit_cast<uint64_t>(raised->distance(p, site)), std::bit_cast<uint64_t>(e));
          if (d <= reach) {
            ASSERT_EQ(std::bit_cast<uint64_t>(d), std::bit_cast<uint64_t>(e)) << round << ": " << c << "," << r;
          } else {
            ASSERT_GT(e, reach) << round << ": " << c << "," << r << " site " << site;
            sites_beyond += std::isfinite(d);
          }
        }
        for (int32_t owner = 1; owner <= a.seeds.owner_count(); ++owner) {
          const OwnerIndex::Hit h = full_index.nearest_of(p, owner), k = cut_index.nearest_of(p, owner);
          if (h.distance <= reach) {
            ++within;
            ASSERT_EQ(h.site, k.site) << round << ": " << c << "," << r << " owner " << owner;
            ASSERT_EQ(std::bit_cast<uint64_t>(h.distance), std::bit_cast<uint64_t>(k.distance));
          } else {
            ++beyond;
            ASSERT_TRUE(k.site == kNoSite || k.distance > reach) << round << ": " << c << "," << r;
          }
        }
      }
    EXPECT_LT(cut_stats.bend_tests, all_stats.bend_tests) << round;
    EXPECT_EQ(cut_stats.within, reach);
    EXPECT_LT(tests_to_4, cut_stats.bend_tests) << round;
    EXPECT_EQ(raised_stats.bend_tests, cut_stats.bend_tests) << round;
    EXPECT_EQ(raised_stats.within, reach);
    // The job's rule: half as far again as the field's largest distance, and 16 cells.
    float farthest = 0.0f;
    for (float d : field.field.distance.cells())
      if (std::isfinite(d)) farthest = std::max(farthest, d);
    const std::unique_ptr<SiteMetric> ruled =
        make_sea_site_metric(a.seeds, a.barriers, g, {}, nullptr, 1.5 * farthest + 16.0 * std::sqrt(2.0));
    BoundaryOptions options;
    options.line_tolerance = 1e-4;
    const BoundaryResult want = extract_boundaries(field.field, full_index, options);
    const BoundaryResult got = extract_boundaries(field.field, OwnerIndex(*ruled), options);
    ASSERT_EQ(got.lines.size(), want.lines.size()) << round;
    for (size_t i = 0; i < want.lines.size(); ++i) {
      ASSERT_EQ(got.lines[i].vertices.size(), want.lines[i].vertices.size()) << round << " line " << i;
      for (size_t v = 0; v < want.lines[i].vertices.size(); ++v) {
        ASSERT_EQ(got.lines[i].vertices[v].p, want.lines[i].vertices[v].p) << round << " line " << i;
        ++lines_compared;
      }
    }
    ASSERT_EQ(got.tripoints.size(), want.tripoints.size()) << round;
    for (size_t t = 0; t < want.tripoints.size(); ++t) ASSERT_EQ(got.tripoints[t].p, want.tripoints[t].p);
  }
  EXPECT_GE(rounds, 5);
  EXPECT_GT(within, 10000);
  EXPECT_GT(beyond, 1000);        // owners farther than the distance settled within
  EXPECT_GT(sites_beyond, 1000);  // sites with a path beyond it, not sought
  EXPECT_GT(lines_compared, 200);
  std::printf("settled within 9: %lld owner distances within, %lld beyond; %lld line vertices as settled whole\n",
              static_cast<long long>(within), static_cast<long long>(beyond), static_cast<long long>(lines_compared));
}

// Boundaries and tripoints by sea round a vertical wall from a to b, every vertex against the
// closed form; returns the vertices that lie in the first seed's shadow (on the hyperbola branch).
struct WallLines {
  BoundaryResult lines;
  int64_t hidden_vertices = 0;
  int64_t ends_on_wall = 0;
};
WallLines wall_lines(const std::vector<Vec2>& points, Vec2 a, Vec2 b, const GridSpec& g) {
  SeedSet s;
  for (size_t i = 0; i < points.size(); ++i)
    s.add_point(s.add_feature(s.owner_code("o" + std::to_string(i))), points[i]);
  Barriers walls;
  walls.add_line(std::vector<Vec2>{a, b}, "wall");
  const SeaField field = compute_sea(s, walls, g, g.full_window());
  const std::unique_ptr<SiteMetric> metric = make_sea_site_metric(s, walls, g);
  const OwnerIndex index(*metric);
  BoundaryOptions options;
  options.line_tolerance = 1e-4;
  WallLines out;
  out.lines = extract_boundaries(field.field, index, options);
  auto path = [&](size_t i, Vec2 x) { return wall_path(points[i], x, a, b); };
  double worst = 0.0;
  for (const BoundaryLine& line : out.lines.lines) {
    const auto i = static_cast<size_t>(line.owner_a - 1), k = static_cast<size_t>(line.owner_b - 1);
    for (size_t v = 0; v < line.vertices.size(); ++v) {
      const Vec2 x = line.vertices[v].p;
      EXPECT_NEAR(path(i, x), path(k, x), 1e-9 * path(i, x)) << x.x << "," << x.y;
      EXPECT_NEAR(line.vertices[v].distance, path(i, x), 1e-9 * path(i, x));
      worst = std::max(worst, std::abs(path(i, x) - path(k, x)));
      // No third seed nearer.
      for (size_t j = 0; j < points.size(); ++j) EXPECT_GE(path(j, x), path(i, x) * (1 - 1e-9));
      out.hidden_vertices += crosses_wall(points[i], x, a.x, a.y, b.y) || crosses_wall(points[k], x, a.x, a.y, b.y);
      // A line never crosses the wall.
      if (v > 0) {
        EXPECT_FALSE(crosses_wall(line.vertices[v - 1].p, x, a.x, a.y, b.y)) << x.x << "," << x.y;
      }
    }
  }
  for (const Tripoint& t : out.lines.tripoints) {
    const double d0 = path(static_cast<size_t>(t.owners[0] - 1), t.p);
    for (int k = 1; k < 3; ++k) EXPECT_NEAR(path(static_cast<size_t>(t.owners[k] - 1), t.p), d0, 1e-9 * d0);
    worst = std::max(worst, std::abs(path(static_cast<size_t>(t.owners[2] - 1), t.p) - d0));
  }
  EXPECT_EQ(out.lines.stats.locus.unresolved, 0);
  EXPECT_LE(out.lines.stats.locus.max_midpoint, 1e-4);
  // The line that meets the wall ends on it (from the side it comes from).
  for (const BoundaryLine& line : out.lines.lines)
    for (const BoundaryVertex* e : {&line.vertices.front(), &line.vertices.back()})
      if (std::abs(e->p.x - a.x) < 0.5 && e->p.y > a.y && e->p.y < b.y) {
        EXPECT_NEAR(e->p.x, a.x, 1e-9);
        ++out.ends_on_wall;
      }
  EXPECT_EQ(out.lines.stats.ends_on_barriers, out.ends_on_wall);
  std::printf(
      "lines by sea round a wall: %zu lines, %zu tripoints, %lld ends on the wall, worst |d_a - d_b| %.3g, chords "
      "within %.3g\n",
      out.lines.lines.size(), out.lines.tripoints.size(), static_cast<long long>(out.lines.stats.ends_on_barriers),
      worst, out.lines.stats.locus.max_midpoint);
  return out;
}

TEST(SeaLines, TheHyperbolaBehindAWallsEndAndATripointOnIt) {
  const Vec2 a{20, 25}, b{20, 60};
  const Vec2 s1{14.2, 31.7}, s2{33.1, 38.3};
  const GridSpec g = test::grid_of(48, 48);
  const WallLines two = wall_lines({s1, s2}, a, b, g);
  ASSERT_EQ(two.lines.lines.size(), 1u);
  EXPECT_GT(two.hidden_vertices, 10);         // the hyperbola branch, not only the bisector
  EXPECT_GT(two.lines.stats.locus.added, 0);  // its curve followed between cell edges
  EXPECT_EQ(two.ends_on_wall, 1);             // where the hyperbola meets the wall's far side
  const WallLines three = wall_lines({s1, s2, {40.6, 8.9}}, a, b, g);
  ASSERT_EQ(three.lines.tripoints.size(), 1u);
  const Tripoint& t = three.lines.tripoints[0];
  EXPECT_TRUE(crosses_wall(s1, t.p, a.x, a.y, b.y)) << t.p.x << "," << t.p.y;  // on the hyperbola
  EXPECT_EQ(three.lines.lines.size(), 3u);
  EXPECT_EQ(three.ends_on_wall, 1);
}

// A barrier vertex against a segment: behind the wall's end A the first seed's path bends at A,
// and where the second seed, a coast line y = 5 from x = 28 to 44, is nearest at the foot of a
// perpendicular, the line is the parabola |s1 - A| + |x - A| = y - 5 (focus A, directrix
// y = 5 + |s1 - A|). Every vertex of the line east of the wall lies on the locus of the closed
// forms; enough of them lie on the parabola itself (s1 hidden, the foot inside the segment), and
// those at the foot are on that parabola.
TEST(SeaLines, TheParabolaOfAVertexAgainstASegment) {
  const Vec2 a{20, 25}, b{20, 60}, s1{14.2, 31.7};
  const double y0 = 5.0, x0 = 28.0, x1 = 44.0;
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("behind")), s1);
  const std::vector<Vec2> coast{{x0, y0}, {x1, y0}};
  s.add_polyline(s.add_feature(s.owner_code("coast")), coast);
  Barriers walls;
  walls.add_line(std::vector<Vec2>{a, b}, "wall");
  const GridSpec g = test::grid_of(48, 48);
  const SeaField field = compute_sea(s, walls, g, g.full_window());
  const std::unique_ptr<SiteMetric> metric = make_sea_site_metric(s, walls, g);
  const OwnerIndex index(*metric);
  BoundaryOptions options;
  options.line_tolerance = 1e-4;
  const BoundaryResult lines = extract_boundaries(field.field, index, options);
  auto to_coast = [&](Vec2 x) {  // east of the wall the whole coast is in view
    const double t = std::clamp(x.x, x0, x1);
    return dist(x, Vec2{t, y0});
  };
  const double k = dist(s1, a);
  int64_t east = 0, on_parabola = 0;
  double worst = 0.0;
  for (const BoundaryLine& line : lines.lines)
    for (const BoundaryVertex& v : line.vertices) {
      const Vec2 x = v.p;
      if (x.x <= a.x + 1e-9) continue;
      ++east;
      const double d1 = wall_path(s1, x, a, b), d2 = to_coast(x);
      EXPECT_NEAR(d1, d2, 1e-9 * d2) << x.x << "," << x.y;
      EXPECT_NEAR(v.distance, d2, 1e-9 * d2) << x.x << "," << x.y;
      worst = std::max(worst, std::abs(d1 - d2));
      if (crosses_wall(s1, x, a.x, a.y, b.y) && x.x > x0 && x.x < x1) {
        ++on_parabola;
        EXPECT_NEAR(k + dist(x, a), x.y - y0, 1e-9 * (x.y - y0)) << x.x << "," << x.y;
      }
    }
  EXPECT_EQ(lines.stats.locus.unresolved, 0);
  EXPECT_LE(lines.stats.locus.max_midpoint, 1e-4);
  EXPECT_GT(east, 20);
  EXPECT_GT(on_parabola, 10);
  EXPECT_GT(lines.stats.locus.added, 0);  // the curve followed between cell edges
  std::printf(
      "a vertex against a segment: %lld line vertices east of the wall, %lld on the parabola, worst |d_a - "
      "d_b| %.3g\n",
      static_cast<long long>(east), static_cast<long long>(on_parabola), worst);
}

// The turning point where the line passes from the bisector of s1 and s2 to the hyperbola branch
// round the wall's end A (behind it s1's path bends at A): on the ray from s1 through A, s1's side
// changing from the basepoint seen directly to the same basepoint by A (its last bend, named),
// equidistant from both by the closed form, |s1 - A| + |A - x| = |x - s2| = |x - s1|.
TEST(SeaLines, ATurningPointWhereTheBisectorBecomesTheHyperbolaNamesTheBend) {
  const Vec2 a{20, 25}, b{20, 60};
  const Vec2 s1{14.2, 31.7}, s2{33.1, 38.3};
  const GridSpec g = test::grid_of(48, 48);
  const SeedSet seeds = test::named_points({{"o0", s1}, {"o1", s2}});
  const test::WallSea sea(seeds, a, b, g);
  BoundaryOptions options;
  options.line_tolerance = 1e-4;
  const BoundaryResult lines = extract_boundaries(sea.field.field, *sea.index, options);
  const std::vector<TurningLine> turning = turning_points(lines, *sea.index);
  int found = 0;
  for (const TurningLine& l : turning)
    for (const TurningPoint& tp : l.points) {
      // (Either way along the line: the side's two basepoints, before and after.)
      if (tp.a.size() != 2 || (tp.a[0].via >= 0) == (tp.a[1].via >= 0)) continue;
      ++found;
      const Basepoint& bent = tp.a[0].via >= 0 ? tp.a[0] : tp.a[1];
      const Basepoint& seen = tp.a[0].via >= 0 ? tp.a[1] : tp.a[0];
      const Vec2 x = tp.p;
      const Vec2 bend = bent.via_at;
      EXPECT_LT(std::hypot(bend.x - a.x, bend.y - a.y), 1e-12);
      EXPECT_LT(std::abs((a.x - s1.x) * (x.y - s1.y) - (a.y - s1.y) * (x.x - s1.x)) / dist(a, s1), 1e-6)
          << x.x << "," << x.y;
      EXPECT_NEAR(dist(s1, a) + dist(a, x), dist(x, s2), 1e-6);
      EXPECT_NEAR(dist(x, s1), dist(x, s2), 1e-6);
      EXPECT_NEAR(bent.distance, dist(x, s2), 1e-6);
      EXPECT_NEAR(seen.distance, dist(x, s1), 1e-6);
      EXPECT_LT(std::hypot(bent.at.x - s1.x, bent.at.y - s1.y), 1e-12);
      EXPECT_LT(std::hypot(seen.at.x - s1.x, seen.at.y - s1.y), 1e-12);
      EXPECT_TRUE(tp.b.size() == 1 && tp.b[0].via < 0);
    }
  EXPECT_EQ(found, 1);
}

// A tip by sea: B's paths west bend round the top b of a wall just west of it, so B's region is a
// wedge between two hyperbola branches |B - b| + |b - x| = |x - A_i| of owner A's two points A1
// and A2 (ten units either side, three behind), narrower than a cell for units before its tip
// (17.4 units west of B), where A's nearest changes from A1 to A2 and all three paths are equally
// long. The cells
// end the line across the wedge; the line goes on out to the tip and back, every vertex a locus
// point of the closed forms, one of them the tip, and every sampled point of every segment
// within the tolerance of the locus.
TEST(SeaLines, ALineFollowsAWedgeNarrowerThanACellToItsTipRoundAWallsEnd) {
  const Vec2 a{1, -30}, b{1, 0.5}, s_b{2, 0}, a1{-1, 10}, a2{-1, -10};
  auto cost_a = [&](Vec2 x) { return std::min(wall_path(a1, x, a, b), wall_path(a2, x, a, b)); };
  auto cost_b = [&](Vec2 x) { return wall_path(s_b, x, a, b); };
  // The tip lies on y = 0 (A1 and A2 mirror each other there): where |x - A1| = |B - b| + |b - x|.
  double lo = -60.0, hi = -2.0;
  for (int i = 0; i < 200; ++i) {
    const double m = 0.5 * (lo + hi);
    (wall_path(a1, {m, 0}, a, b) > cost_b({m, 0}) ? hi : lo) = m;
  }
  const Vec2 tip{0.5 * (lo + hi), 0.0};
  for (const double res : {3.0, 5.0, 7.0}) {
    const SeedSet seeds = test::named_points({{"A", a1}, {"A", a2}, {"B", s_b}});
    const GridSpec g = test::grid_of(static_cast<int64_t>(std::ceil(170.0 / res)),
                                     static_cast<int64_t>(std::ceil(80.0 / res)), res, -120.0, 40.0);
    const test::WallSea sea(seeds, a, b, g);
    const BoundaryResult lines = extract_boundaries(sea.field.field, *sea.index);
    ASSERT_EQ(lines.lines.size(), 2u) << res;  // (each ends on the wall, one on either side of B)
    EXPECT_EQ(lines.stats.locus.unresolved, 0) << res;
    EXPECT_LE(lines.stats.locus.max_midpoint, 1e-3) << res;
    int tips = 0;
    double worst = 0.0;
    Vec2 at{};
    for (const BoundaryLine& line : lines.lines) {
      for (const BoundaryVertex& v : line.vertices) {
        const double d = cost_b(v.p);
        EXPECT_NEAR(cost_a(v.p), d, 1e-9 * d) << res << ": " << v.p.x << "," << v.p.y;
        if (std::abs(wall_path(a1, v.p, a, b) - d) <= 1e-9 * d && std::abs(wall_path(a2, v.p, a, b) - d) <= 1e-9 * d) {
          ++tips;
          at = v.p;
        }
      }
      // The locus' distance from each sampled point, |f| / |grad f| by central differences.
      for (size_t i = 0; i + 1 < line.vertices.size(); ++i)
        for (int k = 1; k < 8; ++k) {
          const Vec2 p = line_tools::lerp(line.vertices[i].p, line.vertices[i + 1].p, k / 8.0);
          const double h = 1e-6;
          auto f = [&](Vec2 x) { return cost_a(x) - cost_b(x); };
          const double gx = (f({p.x + h, p.y}) - f({p.x - h, p.y})) / (2 * h);
          const double gy = (f({p.x, p.y + h}) - f({p.x, p.y - h})) / (2 * h);
          worst = std::max(worst, std::abs(f(p)) / std::hypot(gx, gy));
        }
    }
    EXPECT_EQ(tips, 1) << res;
    EXPECT_LT(dist(at, tip), 1e-6) << res << ": " << at.x << "," << at.y;
    EXPECT_LE(worst, 1e-3) << res;
    std::printf("a tip by sea at (%.6f, %.6f), cells of %g: chords within %.3g, samples within %.3g\n", tip.x, tip.y,
                res, lines.stats.locus.max_midpoint, worst);
  }
}

// A bisector through an islet narrower than a cell: A and B see most of their locus directly
// (near the coasts one path bends round a corner of the islet: `path`, the shortest way round the
// square by its corners), so the line runs up to the islet's north coast and on from its south
// coast. The cells, parted by no land (the islet holds no centre or lies
// between them), link the two stretches by one chord across the islet. The line is parted there
// (boundaries.turns_on_land): two lines, each ending on the islet's coast where A and B are
// equally far, and no point of either on the islet. On cells of 3 and 7 a row of centres lies on
// the south coast: the cells' crossing between two of them, on the coast, is that end already.
TEST(SeaLines, ABisectorThroughAnIsletNarrowerThanACellEndsOnItsCoasts) {
  const Vec2 a{-3, 0.3}, b{3, -0.2};
  Barriers islet;
  islet.add_polygon({{{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}}}, "islet");
  const SeedSet seeds = test::named_points({{"A", a}, {"B", b}});
  // Whether the segment p-q passes through the islet's open interior (clipped to the square).
  auto crosses = [](Vec2 p, Vec2 q) {
    double t0 = 0.0, t1 = 1.0;
    const double dx = q.x - p.x, dy = q.y - p.y;
    for (const auto& [pk, qk] : {std::pair{-dx, p.x + 0.5}, {dx, 0.5 - p.x}, {-dy, p.y + 0.5}, {dy, 0.5 - p.y}}) {
      if (pk == 0.0) {
        if (qk <= 0.0) return false;
        continue;
      }
      (pk < 0.0 ? t0 : t1) = pk < 0.0 ? std::max(t0, qk / pk) : std::min(t1, qk / pk);
    }
    if (!(t1 - t0 > 1e-12)) return false;
    const Vec2 m = line_tools::lerp(p, q, 0.5 * (t0 + t1));
    return std::abs(m.x) < 0.5 - 1e-12 && std::abs(m.y) < 0.5 - 1e-12;
  };
  // The shortest way from s to x round the islet: Dijkstra over s, its four corners and x.
  auto path = [&](Vec2 s, Vec2 x) {
    const std::array<Vec2, 6> node{s, Vec2{-0.5, -0.5}, Vec2{0.5, -0.5}, Vec2{0.5, 0.5}, Vec2{-0.5, 0.5}, x};
    std::array<double, 6> d;
    d.fill(std::numeric_limits<double>::infinity());
    std::array<bool, 6> done{};
    d[0] = 0.0;
    for (int round = 0; round < 6; ++round) {
      int k = -1;
      for (int i = 0; i < 6; ++i)
        if (!done[i] && (k < 0 || d[i] < d[k])) k = i;
      done[k] = true;
      for (int i = 0; i < 6; ++i)
        if (!done[i] && !crosses(node[k], node[i])) d[i] = std::min(d[i], d[k] + dist(node[k], node[i]));
    }
    return d[5];
  };
  for (const double res : {2.0, 2.5, 3.0, 3.7, 5.0, 7.0}) {
    const auto n = static_cast<int64_t>(std::ceil(20.0 / res));
    const GridSpec g = test::grid_of(n, n, res, -10.0, 10.0);
    const SeaField field = compute_sea(seeds, islet, g, g.full_window());
    const std::unique_ptr<SiteMetric> metric = make_sea_site_metric(seeds, islet, g);
    const OwnerIndex index(*metric);
    const BoundaryResult lines = extract_boundaries(field.field, index);
    ASSERT_EQ(lines.lines.size(), 2u) << res;
    EXPECT_EQ(lines.stats.turns_on_land, 1) << res;
    EXPECT_EQ(lines.stats.locus.unresolved, 0) << res;
    int on_coast = 0;
    for (const BoundaryLine& line : lines.lines) {
      for (const BoundaryVertex& v : line.vertices)
        EXPECT_NEAR(path(a, v.p), path(b, v.p), 1e-8) << res << ": " << v.p.x << "," << v.p.y;
      for (size_t i = 0; i + 1 < line.vertices.size(); ++i)
        for (int k = 0; k <= 64; ++k) {
          const Vec2 p = line_tools::lerp(line.vertices[i].p, line.vertices[i + 1].p, k / 64.0);
          EXPECT_FALSE(std::abs(p.x) < 0.5 - 1e-9 && std::abs(p.y) < 0.5 - 1e-9) << res << ": " << p.x << "," << p.y;
        }
      for (const BoundaryVertex* e : {&line.vertices.front(), &line.vertices.back()})
        if (std::abs(std::abs(e->p.y) - 0.5) < 1e-9 && std::abs(e->p.x) <= 0.5) {
          ++on_coast;
          EXPECT_TRUE(e->on_barrier) << res;
        }
    }
    EXPECT_EQ(on_coast, 2) << res;  // one on the north coast, one on the south
  }
}

// Where one side's path changes the wall's end it bends round, with the same two seeds on both
// sides: s1 lies behind the wall's middle, its path to the line round A below and round B above;
// the line turns at the corner where both paths and s2's straight one are equally long. That
// corner is a vertex of the line (no chord across it left to halving: every segment within the
// tolerance), and the turning points name s1's two bends there. `length`: the closed form's
// straight length (plane or geodesic); `tol`: the line tolerance; `near`: equal lengths.
void corner_of_two_bends(Vec2 a, Vec2 b, Vec2 s1, Vec2 s2, const GridSpec& g, const SeaOptions& options,
                         double (*length)(Vec2, Vec2), double tol, double near) {
  const SeedSet seeds = test::named_points({{"o0", s1}, {"o1", s2}});
  const test::WallSea sea(seeds, a, b, g, options);
  BoundaryOptions bo;
  bo.line_tolerance = tol;
  const BoundaryResult lines = extract_boundaries(sea.field.field, *sea.index, bo);
  ASSERT_EQ(lines.lines.size(), 1u);
  EXPECT_EQ(lines.stats.locus.unresolved, 0);
  EXPECT_LE(lines.stats.locus.max_midpoint, tol);
  // The corner: |s1 - A| + |A - x| = |s1 - B| + |B - x| = |s2 - x|.
  auto via_a = [&](Vec2 x) { return length(s1, a) + length(a, x); };
  auto via_b = [&](Vec2 x) { return length(s1, b) + length(b, x); };
  int corners = 0;
  Vec2 corner{};
  for (const BoundaryVertex& v : lines.lines[0].vertices) {
    const double d = length(s2, v.p);
    EXPECT_NEAR(std::min(via_a(v.p), via_b(v.p)), d, near) << v.p.x << "," << v.p.y;
    if (std::abs(via_a(v.p) - d) <= near && std::abs(via_b(v.p) - d) <= near) {
      ++corners;
      corner = v.p;
    }
  }
  ASSERT_EQ(corners, 1);
  EXPECT_GT(corner.x, a.x);
  const std::vector<TurningLine> turning = turning_points(lines, *sea.index);
  int named = 0;
  for (const TurningLine& l : turning)
    for (const TurningPoint& tp : l.points) {
      // (The report bisects for the change between vertices: within 2^-26 of their spacing.)
      if (dist(tp.p, corner) > 1e-6 * g.res) continue;
      const std::vector<Basepoint>& side = tp.a.size() == 2 ? tp.a : tp.b;
      ASSERT_EQ(side.size(), 2u);
      const Vec2 u = side[0].via_at, w = side[1].via_at;
      EXPECT_TRUE((dist(u, a) < 1e-12 && dist(w, b) < 1e-12) || (dist(u, b) < 1e-12 && dist(w, a) < 1e-12));
      EXPECT_NEAR(length(s2, tp.p), std::min(via_a(tp.p), via_b(tp.p)), near);
      ++named;
    }
  EXPECT_EQ(named, 1);
  std::printf("corner where s1's bend changes: (%.9f, %.9f), %lld turning points, chords within %.3g\n", corner.x,
              corner.y, static_cast<long long>(lines.stats.turning_points), lines.stats.locus.max_midpoint);
}

TEST(SeaLines, ALineTurnsWhereOneSidesPathChangesTheVertexItBendsAt) {
  corner_of_two_bends({20, 10}, {20, 44}, {18, 28.3}, {60.4, 26.1}, test::grid_of(64, 64), {}, dist, 1e-6, 1e-9);
}

// The same on the ellipsoid (a unit of the plane's layout 0.01 deg of latitude, 0.0175 of
// longitude), geodesic lengths from GeographicLib; tolerance a millimetre.
TEST(SeaLines, OnTheEllipsoidALineTurnsWhereOneSidesPathChangesTheVertexItBendsAt) {
  auto at = [](double x, double y) { return Vec2{10.0 + 0.0175 * x, 55.0 + 0.01 * y}; };
  SeaOptions options;
  options.metric = test::geodesic_metric();
  corner_of_two_bends(at(20, 10), at(20, 44), at(18, 28.3), at(60.4, 26.1), test::grid_of(112, 64, 0.01, 10.0, 55.64),
                      options, test::metres, 1e-3, 1e-6);
}

// Two ports in a channel between two coasts: their boundary runs from coast to coast, its ends on
// the coasts exactly. With a boom from the south coast partway across, the boundary runs from
// the north coast to the boom's far face, where the path round the boom's tip meets the other
// port's straight one.
struct Channel {
  Barriers land;
  SeedSet seeds;
  BoundaryResult lines;
};
Channel channel(Vec2 a, Vec2 b, bool boom) {
  Channel c;
  c.land.add_polygon({{{0, 0}, {40, 0}, {40, 10}, {0, 10}}}, "south");
  c.land.add_polygon({{{0, 30}, {40, 30}, {40, 40}, {0, 40}}}, "north");
  if (boom) c.land.add_line(std::vector<Vec2>{{30, 10}, {30, 24}}, "boom");
  c.seeds.add_point(c.seeds.add_feature(c.seeds.owner_code("A")), a);
  c.seeds.add_point(c.seeds.add_feature(c.seeds.owner_code("B")), b);
  const GridSpec g = test::grid_of(40, 40);
  const SeaField field = compute_sea(c.seeds, c.land, g, g.full_window());
  const std::unique_ptr<SiteMetric> metric = make_sea_site_metric(c.seeds, c.land, g);
  const OwnerIndex index(*metric);
  c.lines = extract_boundaries(field.field, index);
  return c;
}

// A limit by sea: a port west of a wall, the line at distance D by sea. West of the wall and
// round its ends the level is the circle |x - s| = D; behind the wall it is the circle round
// the wall's nearer end of radius D - |s - end|. Every vertex at D by the closed form (the line
// follows it between cell edges), none across the wall, and the two ends on the wall's far face.
TEST(SeaLines, ALimitBySeaGoesRoundTheWallsEnds) {
  const Vec2 a{20, 12}, b{20, 28}, s{14.3, 19.6};
  const double D = 12.5;
  SeedSet seeds;
  seeds.add_point(seeds.add_feature(seeds.owner_code("P")), s);
  const GridSpec g = test::grid_of(40, 40);
  const test::WallSea sea(seeds, a, b, g);
  LimitOptions options;
  options.line_tolerance = 1e-4;
  const std::vector<double> distances{D};
  const LimitResult r = extract_limits(sea.field.field, *sea.index, distances, options);
  int64_t behind = 0, vertices = 0;
  double worst = 0.0;
  int on_wall = 0;
  for (const LimitLine& line : r.lines) {
    for (size_t i = 0; i < line.vertices.size(); ++i) {
      const Vec2 x = line.vertices[i].p;
      EXPECT_NEAR(wall_path(s, x, a, b), D, 1e-9 * D) << x.x << "," << x.y;
      worst = std::max(worst, std::abs(wall_path(s, x, a, b) - D));
      behind += crosses_wall(s, x, a.x, a.y, b.y);
      ++vertices;
      if (i > 0) {
        EXPECT_FALSE(crosses_wall(line.vertices[i - 1].p, x, a.x, a.y, b.y)) << x.x << "," << x.y;
      }
    }
    if (line.closed) continue;
    for (const LimitVertex* e : {&line.vertices.front(), &line.vertices.back()})
      if (e->on_barrier) {
        ++on_wall;
        EXPECT_NEAR(e->p.x, a.x, 1e-9);
        EXPECT_GT(e->p.x, a.x);  // the far face, reached round an end
      }
  }
  EXPECT_EQ(on_wall, 2);
  EXPECT_EQ(r.ends_on_barriers, 2);
  EXPECT_GT(behind, 10);
  EXPECT_EQ(r.residual.unresolved, 0) << r.residual.worst_x << "," << r.residual.worst_y;
  std::printf("a limit by sea round a wall: %zu lines, %lld vertices, worst |d - D| %.3g, chords within %.3g\n",
              r.lines.size(), static_cast<long long>(vertices), worst, r.residual.max_midpoint);
}

// Limits by sea where the field's site is not each cell's nearest to the limit's seeds: per owner
// (the port west of the wall and one far east of it), and with a weight on the western port
// (the field then names the cheapest site, the limit measures true distances). Every vertex at
// D by the closed form, the western port's line round the wall's ends as above.
TEST(SeaLines, LimitsPerOwnerAndWithWeightsBySeaLieAtTheirDistanceBySea) {
  const Vec2 a{20, 12}, b{20, 28}, s{14.3, 19.6}, q{33.5, 36.5};
  const double D = 12.5;
  const GridSpec g = test::grid_of(40, 40);
  for (const double weight : {1.0, 2.0}) {
    SeedSet seeds;
    seeds.add_point(seeds.add_feature(seeds.owner_code("P")), s);
    seeds.add_point(seeds.add_feature(seeds.owner_code("Q")), q);
    seeds.set_adjustment(0, weight, std::numeric_limits<double>::infinity());
    const test::WallSea sea(seeds, a, b, g);
    LimitOptions options;
    options.line_tolerance = 1e-4;
    options.per_owner = weight == 1.0;
    const std::vector<double> distances{D};
    const LimitResult r = extract_limits(sea.field.field, *sea.index, distances, options);
    int64_t behind = 0, vertices = 0;
    for (const LimitLine& line : r.lines)
      for (const LimitVertex& v : line.vertices) {
        const double dp = wall_path(s, v.p, a, b), dq = dist(q, v.p);
        const double want = line.owner == 1 ? dp : line.owner == 2 ? dq : std::min(dp, dq);
        EXPECT_NEAR(want, D, 1e-9 * D) << weight << ": " << line.owner << " " << v.p.x << "," << v.p.y;
        behind += crosses_wall(s, v.p, a.x, a.y, b.y) && std::abs(dp - D) < 1e-6;
        ++vertices;
      }
    EXPECT_GT(vertices, 100) << weight;
    EXPECT_GT(behind, 10) << weight;  // round the wall's ends
    EXPECT_EQ(r.ends_on_barriers, 2) << weight;
  }
}

// A channel 0.6 cells wide, one column of centres along it, between two coasts: a line that
// crosses it has one crossing, which no square links to another (the barriers part every other
// pair of their corners). It is still a line, from one coast to the other: the limit of a port
// south of the channel at the distance that crosses it, and the boundary of that port and one
// north of it. Without them the sea either side of the line would be one face of the regions.
struct NarrowChannel {
  Barriers land;
  GridSpec g = test::grid_of(40, 40);
  NarrowChannel() {
    land.add_polygon({{{0, 15}, {20.2, 15}, {20.2, 25}, {0, 25}}}, "west");
    land.add_polygon({{{20.8, 15}, {40, 15}, {40, 25}, {20.8, 25}}}, "east");
  }
  // The line of `lines` with both ends on the channel's coasts (x 20.2 and 20.8); null if none.
  template <class Line>
  static const Line* across(const std::vector<Line>& lines) {
    for (const Line& l : lines) {
      if (l.vertices.size() < 2 || !l.vertices.front().on_barrier || !l.vertices.back().on_barrier) continue;
      const double x0 = std::min(l.vertices.front().p.x, l.vertices.back().p.x);
      const double x1 = std::max(l.vertices.front().p.x, l.vertices.back().p.x);
      if (std::abs(x0 - 20.2) < 1e-9 && std::abs(x1 - 20.8) < 1e-9) return &l;
    }
    return nullptr;
  }
};

TEST(SeaLines, ALineAcrossAChannelNarrowerThanACellIsDrawn) {
  const NarrowChannel c;
  const Vec2 south{20.5, 2.5}, north{20.5, 37.5};
  {
    SeedSet seeds;
    seeds.add_point(seeds.add_feature(seeds.owner_code("S")), south);
    const SeaField field = compute_sea(seeds, c.land, c.g, c.g.full_window());
    const std::unique_ptr<SiteMetric> metric = make_sea_site_metric(seeds, c.land, c.g);
    const OwnerIndex index(*metric);
    const double D = 15.6;  // the level at y = 18.1, in the channel
    const std::vector<double> distances{D};
    const LimitResult r = extract_limits(field.field, index, distances, LimitOptions{});
    const LimitLine* line = NarrowChannel::across(r.lines);
    ASSERT_NE(line, nullptr) << r.lines.size() << " lines";
    for (const LimitVertex& v : line->vertices) {
      EXPECT_NEAR(dist(v.p, south), D, 1e-9) << v.p.x << "," << v.p.y;  // the port sees the channel
      EXPECT_GT(v.p.y, 15.0);
      EXPECT_LT(v.p.y, 25.0);
    }
  }
  SeedSet seeds;
  seeds.add_point(seeds.add_feature(seeds.owner_code("S")), south);
  seeds.add_point(seeds.add_feature(seeds.owner_code("N")), north);
  const SeaField field = compute_sea(seeds, c.land, c.g, c.g.full_window());
  const std::unique_ptr<SiteMetric> metric = make_sea_site_metric(seeds, c.land, c.g);
  const OwnerIndex index(*metric);
  const BoundaryResult r = extract_boundaries(field.field, index);
  const BoundaryLine* line = NarrowChannel::across(r.lines);
  ASSERT_NE(line, nullptr) << r.lines.size() << " lines";
  for (const BoundaryVertex& v : line->vertices) EXPECT_NEAR(v.p.y, 20.0, 1e-9) << v.p.x;  // the bisector
  EXPECT_EQ(r.stats.ends_on_barriers, 2);
  EXPECT_TRUE(r.lone_crossings.empty());
}

// The boundaries by sea of two ports (each its owner's label and position) among `land`.
struct Port {
  const char* owner;
  Vec2 at;
};
BoundaryResult two_ports_by_sea(const Barriers& land, const GridSpec& g, Port a, Port b,
                                const BoundaryOptions& options = {}) {
  SeedSet seeds;
  for (const Port& p : {a, b}) seeds.add_point(seeds.add_feature(seeds.owner_code(p.owner)), p.at);
  const SeaField field = compute_sea(seeds, land, g, g.full_window());
  const std::unique_ptr<SiteMetric> metric = make_sea_site_metric(seeds, land, g);
  const OwnerIndex index(*metric);
  return extract_boundaries(field.field, index, options);
}

// A channel 0.4 cells wide between two columns of centres (x 20.6 to 21.0; the centres at 20.5
// and 21.5 on land), between a port south of it and one north: no cell lies in it, so no two
// cells either side of the owners' change place a line there, yet the change is in it. Found
// from the coasts: the line across, from wall to wall, on the closed form. With the northern port
// behind the channel's mouth its path bends at the mouth's corner (21, 25), and the line is the
// hyperbola branch |s - x| = |n - c| + |c - x|.
TEST(SeaLines, AChangeOfOwnerInAChannelWithNoCellIsALineAcrossIt) {
  Barriers land;
  land.add_polygon({{{0, 15}, {20.6, 15}, {20.6, 25}, {0, 25}}}, "west");
  land.add_polygon({{{21.0, 15}, {40, 15}, {40, 25}, {21.0, 25}}}, "east");
  const GridSpec g = test::grid_of(40, 40);
  const Vec2 south{20.8, 2.5}, corner{21.0, 25.0};
  for (const Vec2 north : {Vec2{20.8, 37.3}, Vec2{30.0, 37.0}}) {
    const bool bent = north.x > 21.0;
    BoundaryOptions options;
    options.line_tolerance = 1e-6;
    const BoundaryResult r = two_ports_by_sea(land, g, {"S", south}, {"N", north}, options);
    ASSERT_EQ(r.lines.size(), 1u) << bent;
    const std::vector<BoundaryVertex>& v = r.lines[0].vertices;
    ASSERT_GE(v.size(), 2u);
    EXPECT_TRUE(v.front().on_barrier && v.back().on_barrier);
    EXPECT_NEAR(std::min(v.front().p.x, v.back().p.x), 20.6, 1e-9);
    EXPECT_NEAR(std::max(v.front().p.x, v.back().p.x), 21.0, 1e-9);
    auto d_north = [&](Vec2 x) { return bent ? dist(north, corner) + dist(corner, x) : dist(north, x); };
    for (const BoundaryVertex& x : v) {
      EXPECT_NEAR(dist(south, x.p), d_north(x.p), 1e-9) << bent << ": " << x.p.x << "," << x.p.y;
      EXPECT_GT(x.p.y, 15.0);
      EXPECT_LT(x.p.y, 25.0);
    }
    if (!bent) {
      EXPECT_NEAR(v.front().p.y, 19.9, 1e-9);  // the bisector of the two ports
    }
    EXPECT_EQ(r.stats.channels_crossed, 1) << bent;
    EXPECT_EQ(r.stats.coast_changes_unexplained, 0) << bent;
    EXPECT_EQ(r.stats.crossings, 0) << bent;  // (no cell shows the change)
    EXPECT_EQ(r.stats.locus.unresolved, 0) << bent;
  }
}

// Two ports either side of islets scattered along their bisector (a layout found by a random
// search in session 85): where an islet parts the cells beside the line, its two open ends are
// joined along the locus walked between them. Joined by a chord, four segments were left off the
// locus by more than the tolerance (the chord cut past an islet's corner the locus goes round).
TEST(SeaLines, PartedEndsAreJoinedAlongTheLocusWalkedBetweenThem) {
  Barriers land;
  const std::vector<std::vector<Vec2>> islets{
      {{18.454825, 19.659996},
       {18.464117, 19.359116},
       {18.691801, 19.049286},
       {18.980310, 19.307523},
       {18.952862, 19.740273}},
      {{19.587847, 25.929181}, {19.396197, 25.660868}, {19.749637, 25.480404}, {19.902883, 25.808436}},
      {{20.448485, 21.957796}, {20.875175, 21.899202}, {20.691694, 22.408772}},
      {{18.899864, 18.095114}, {19.659972, 17.919314}, {19.810126, 18.783985}, {18.990187, 18.687897}},
      {{18.713704, 24.135522}, {18.586469, 24.310798}, {18.526912, 24.124370}},
      {{20.099947, 14.368041},
       {20.492967, 14.551428},
       {20.601194, 15.077568},
       {20.093659, 15.248504},
       {19.722947, 15.028938},
       {19.742452, 14.569244}}};
  for (size_t k = 0; k < islets.size(); ++k) land.add_polygon({islets[k]}, "islet " + std::to_string(k));
  const GridSpec g = test::grid_of(40, 40);
  const Vec2 west{5.0, 20.0}, east{35.0, 20.0};
  BoundaryOptions options;
  options.line_tolerance = 1e-6;
  const BoundaryResult r = two_ports_by_sea(land, g, {"W", west}, {"E", east}, options);
  EXPECT_GE(r.stats.ends_joined, 1);
  EXPECT_EQ(r.stats.locus.unresolved, 0);
  EXPECT_LE(r.stats.locus.max_midpoint, 1e-6);
  // Every vertex on the locus, and no segment across an islet.
  SeedSet seeds;  // (the metric refers to them)
  seeds.add_point(seeds.add_feature(seeds.owner_code("W")), west);
  seeds.add_point(seeds.add_feature(seeds.owner_code("E")), east);
  const std::unique_ptr<SiteMetric> metric = make_sea_site_metric(seeds, land, g);
  int64_t vertices = 0;
  for (const BoundaryLine& l : r.lines)
    for (size_t k = 0; k < l.vertices.size(); ++k) {
      const Vec2 p = l.vertices[k].p;
      EXPECT_NEAR(metric->distance(p, 0), metric->distance(p, 1), 1e-6) << p.x << "," << p.y;
      if (k + 1 < l.vertices.size()) {
        EXPECT_TRUE(metric->open_between(p, l.vertices[k + 1].p)) << "across land from " << p.x << "," << p.y;
      }
      ++vertices;
    }
  EXPECT_GT(vertices, 40);
}

// A channel along the diagonal y = x through a square of land, 0.42 cells wide: its cells meet
// only corner to corner (the centres beside them on land), so no two 4-neighbours of the two
// ports' cells lie either side of the change of owner inside it. Its coasts show it: the line
// across it is the ports' bisector x + y = 40.5, from bank to bank (both ports see it along the
// channel); outside the square the cells' two lines run from the grid's edge to its coast.
TEST(SeaLines, AChangeOfOwnerInAChannelWhoseCellsMeetOnlyDiagonallyIsALineAcrossIt) {
  Barriers land;
  land.add_polygon({{{8, 8.3}, {31.7, 32}, {8, 32}}}, "north-west");
  land.add_polygon({{{8.3, 8}, {32, 8}, {32, 31.7}}}, "south-east");
  const GridSpec g = test::grid_of(40, 40);
  const Vec2 s{4, 4}, n{36.5, 36.5};
  const BoundaryResult r = two_ports_by_sea(land, g, {"S", s}, {"N", n});
  ASSERT_EQ(r.lines.size(), 3u);
  int across = 0;
  for (const BoundaryLine& l : r.lines) {
    const Vec2 a = l.vertices.front().p, b = l.vertices.back().p;
    if (std::min(a.x, b.x) > 19.0 && std::max(a.x, b.x) < 21.0) {
      ++across;
      for (const BoundaryVertex& v : l.vertices) {
        EXPECT_NEAR(dist(s, v.p), dist(n, v.p), 1e-9) << v.p.x << "," << v.p.y;
        EXPECT_NEAR(v.p.x + v.p.y, 40.5, 1e-9) << v.p.x << "," << v.p.y;
      }
      EXPECT_TRUE(l.vertices.front().on_barrier && l.vertices.back().on_barrier);
      EXPECT_NEAR(std::min(a.x, b.x), 20.1, 1e-9);
      EXPECT_NEAR(std::max(a.x, b.x), 20.4, 1e-9);
    }
  }
  EXPECT_EQ(across, 1);
  EXPECT_EQ(r.stats.channels_crossed, 1);
  EXPECT_EQ(r.stats.coast_changes_unexplained, 0);
}

// A block of land across the grid from beyond its northern edge to 0.3 cells short of its
// southern one: the seas either side of it meet only in the strip under it, between the last row
// of centres (on land there) and the grid's edge. The two ports' change of owner lies in that
// strip, where no cell is: the line runs from the block's southern face to the grid's edge, on
// the closed form (each path bent at the block's corner on its side).
TEST(SeaLines, AChangeOfOwnerBetweenTheLastCellsAndTheGridsEdgeIsALineToTheEdge) {
  Barriers land;
  land.add_polygon({{{15, 0.3}, {25, 0.3}, {25, 45}, {15, 45}}}, "block");
  const GridSpec g = test::grid_of(40, 40);
  const Vec2 w{5, 20}, e{35, 10}, cw{15, 0.3}, ce{25, 0.3};
  const BoundaryResult r = two_ports_by_sea(land, g, {"W", w}, {"E", e});
  ASSERT_EQ(r.lines.size(), 1u);
  const std::vector<BoundaryVertex>& v = r.lines[0].vertices;
  ASSERT_GE(v.size(), 2u);
  const BoundaryVertex& coast = v.front().on_barrier ? v.front() : v.back();
  const BoundaryVertex& edge = v.front().on_barrier ? v.back() : v.front();
  EXPECT_TRUE(coast.on_barrier);
  EXPECT_NEAR(coast.p.y, 0.3, 1e-9);
  EXPECT_EQ(edge.p.y, 0.0);
  for (const BoundaryVertex& x : v) {
    EXPECT_NEAR(dist(w, cw) + dist(cw, x.p), dist(e, ce) + dist(ce, x.p), 1e-9) << x.p.x << "," << x.p.y;
    EXPECT_GT(x.p.x, 15.0);
    EXPECT_LT(x.p.x, 25.0);
  }
  EXPECT_EQ(r.stats.channels_crossed, 1);
  EXPECT_EQ(r.stats.coast_changes_unexplained, 0);
  EXPECT_EQ(r.stats.crossings, 0);
}

TEST(SeaLines, ABoundaryEndsOnTheCoastsItMeets) {
  const Vec2 a{12.25, 21.5}, b{27.75, 17.5};
  const Channel open = channel(a, b, false);
  ASSERT_EQ(open.lines.lines.size(), 1u);
  const std::vector<BoundaryVertex>& v = open.lines.lines[0].vertices;
  EXPECT_NEAR(std::min(v.front().p.y, v.back().p.y), 10.0, 1e-9);
  EXPECT_NEAR(std::max(v.front().p.y, v.back().p.y), 30.0, 1e-9);
  for (const BoundaryVertex& x : v) EXPECT_NEAR(dist(x.p, a), dist(x.p, b), 1e-9) << x.p.x << "," << x.p.y;
  EXPECT_EQ(open.lines.stats.ends_on_barriers, 2);

  // The boom from (30, 10) to its tip (30, 24): a port hidden by it goes round the tip.
  const Vec2 ba{26, 15}, bb{35, 13}, tip{30, 24};
  const Channel boomed = channel(ba, bb, true);
  ASSERT_EQ(boomed.lines.lines.size(), 1u);
  auto by_sea = [&](Vec2 port, Vec2 x) {
    return crosses_wall(port, x, 30, 10, 24) ? dist(port, tip) + dist(tip, x) : dist(port, x);
  };
  int64_t round_the_tip = 0;
  for (const BoundaryVertex& x : boomed.lines.lines[0].vertices) {
    EXPECT_NEAR(by_sea(ba, x.p), by_sea(bb, x.p), 1e-9) << x.p.x << "," << x.p.y;
    round_the_tip += crosses_wall(ba, x.p, 30, 10, 24);
  }
  EXPECT_GT(round_the_tip, 2);
  const std::vector<BoundaryVertex>& w = boomed.lines.lines[0].vertices;
  const Vec2 north = w.front().p.y > w.back().p.y ? w.front().p : w.back().p;
  const Vec2 on_boom = w.front().p.y > w.back().p.y ? w.back().p : w.front().p;
  EXPECT_NEAR(north.y, 30.0, 1e-9);
  EXPECT_NEAR(on_boom.x, 30.0, 1e-9);  // on the boom's far face
  EXPECT_GT(on_boom.x, 30.0);
  EXPECT_GT(on_boom.y, 10.0);
  EXPECT_LT(on_boom.y, 24.0);
  EXPECT_EQ(boomed.lines.stats.ends_on_barriers, 2);
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// On the ellipsoid: two ports either side of a 45 km wall (a geodesic) at the western Baltic's
// latitudes, one behind the wall's south end. Every vertex of their boundary is equidistant by
// GeographicLib's lengths round the wall (visibility by GeographicLib's azimuths), and the line
// ends on the wall's far side.
TEST(SeaLines, OnTheEllipsoidTheLineFollowsGeodesicPathsRoundAWall) {
  const Vec2 a{10.5, 55.1}, b{10.5, 55.5}, s1{10.38, 55.16}, s2{10.78, 55.27};
  const SeedSet seeds = test::named_points({{"W", s1}, {"E", s2}});
  const GridSpec g = test::grid_of(50, 30, 0.02, 10.0, 55.6);
  SeaOptions options;
  options.metric = test::geodesic_metric();
  const test::WallSea sea(seeds, a, b, g, options);
  const BoundaryResult r = extract_boundaries(sea.field.field, *sea.index);
  // The line of the hyperbola behind the south end, and (the east port nearer the north end)
  // one on the west side behind the north end.
  ASSERT_EQ(r.lines.size(), 2u);
  auto by_sea = [&](Vec2 s, Vec2 x) {
    using test::metres;
    return test::crosses(s, x, a, b) ? std::min(metres(s, a) + metres(a, x), metres(s, b) + metres(b, x))
                                     : metres(s, x);
  };
  double worst = 0.0;
  int64_t behind_west = 0, behind_east = 0, vertices = 0;
  int ends_on_wall = 0, east_face = 0;
  for (const BoundaryLine& line : r.lines) {
    for (const BoundaryVertex& v : line.vertices) {
      const double d1 = by_sea(s1, v.p), d2 = by_sea(s2, v.p);
      EXPECT_NEAR(d1, d2, 1e-5) << v.p.x << "," << v.p.y;
      EXPECT_NEAR(v.distance, d1, 1e-5);
      worst = std::max(worst, std::abs(d1 - d2));
      behind_west += test::crosses(s1, v.p, a, b);
      behind_east += test::crosses(s2, v.p, a, b);
      ++vertices;
    }
    for (const Vec2 end : {line.vertices.front().p, line.vertices.back().p})
      if (test::segment_foot(end, a, b).metres < 1e-3) {
        ++ends_on_wall;
        east_face += end.x > 10.5;
      }
  }
  EXPECT_GT(behind_west, 5);
  EXPECT_GT(behind_east, 5);
  EXPECT_EQ(ends_on_wall, 2);  // one on each face
  EXPECT_EQ(east_face, 1);
  EXPECT_EQ(r.stats.ends_on_barriers, 2);
  std::printf("lines by sea on the ellipsoid round a 45 km wall: %lld vertices, worst |d_1 - d_2| %.3g m\n",
              static_cast<long long>(vertices), worst);
}

// A tie region: two seeds 10 from a wall's end A, both hidden from the sea behind it, where their
// paths by sea are 10 + |x - A| both, equal to the bit; the field gives it to the lower site (the
// "lo" owner). Beside it, between the two shadows, "hi" sees its cells directly and is nearer.
// The boundary east of the wall runs along the tie region's edge, "hi"'s shadow ray from A (on
// which the two distances are equal, and beyond which they part): every vertex there on the ray
// and flagged tie. (Without the tie rule the root search ends anywhere in the tied area: a
// staircase through its cells.) The two distances part quadratically off the ray (the path
// round A is longer than the straight one by about h^2 / 2 (1/10 + 1/|x - A|) at an offset h),
// so in doubles they stay equal to about 1e-6 of it at 20 units from A: the tolerance.
TEST(SeaLines, ATieRegionBehindAVertexIsOwnedByTheLowerSiteAndTheLineRunsAlongItsEdge) {
  const Vec2 a{20, 20}, b{20, 45}, lo{14, 28}, hi{12, 26};
  ASSERT_EQ(dist(lo, a), 10.0);
  ASSERT_EQ(dist(hi, a), 10.0);
  const SeedSet seeds = test::named_points({{"lo", lo}, {"hi", hi}});
  const GridSpec g = test::grid_of(40, 50);
  const test::WallSea sea(seeds, a, b, g);
  const SeaField& field = sea.field;
  BoundaryOptions options;
  options.line_tolerance = 1e-4;
  const BoundaryResult r = extract_boundaries(field.field, *sea.index, options);
  ASSERT_EQ(r.lines.size(), 1u);
  // The ray from A away from hi: points A + u (A - hi) / 10, u >= 0.
  const Vec2 dir{(a.x - hi.x) / 10.0, (a.y - hi.y) / 10.0};
  int64_t tied = 0, behind = 0, cells = 0, apex = 0;
  for (const BoundaryVertex& v : r.lines[0].vertices) {
    if (v.p.x == a.x && v.p.y == a.y) {  // where the bisector turns onto the tie region's edge
      EXPECT_TRUE(v.tie);
      ++apex;
      ++tied;
      continue;
    }
    if (v.p.x <= a.x) {  // the bisector west of the wall (through A)
      EXPECT_FALSE(v.tie);
      EXPECT_NEAR(dist(v.p, lo), dist(v.p, hi), 1e-9 * dist(v.p, lo));
      continue;
    }
    ++behind;
    const double off = (v.p.x - a.x) * dir.y - (v.p.y - a.y) * dir.x;  // signed distance from the ray's line
    EXPECT_NEAR(off, 0.0, 2e-6) << v.p.x << "," << v.p.y;
    EXPECT_TRUE(v.tie) << v.p.x << "," << v.p.y;
    EXPECT_EQ(v.residual, 0.0);
    tied += v.tie;
    EXPECT_NEAR(v.distance, 10.0 + dist(v.p, a), 1e-9 * v.distance);
  }
  EXPECT_GT(behind, 15);
  EXPECT_EQ(apex, 1);
  EXPECT_EQ(r.stats.tie_vertices, tied);
  // The tie region (both hidden, beyond the ray): the lower site's cells.
  for (int64_t row = 0; row < g.height; ++row)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, row);
      if (!crosses_wall(lo, x, a.x, a.y, b.y) || !crosses_wall(hi, x, a.x, a.y, b.y)) continue;
      if (wall_path(lo, x, a, b) != 10.0 + dist(x, a)) continue;  // (round B instead)
      ASSERT_EQ(field.field.site.at(c, row), 0) << c << "," << row;
      ++cells;
    }
  EXPECT_GT(cells, 100);
  std::printf("a tie region by sea: %lld cells, the line along its edge %lld vertices, all on the ray\n",
              static_cast<long long>(cells), static_cast<long long>(behind));
}

// The tie region on the ellipsoid: a 40 km wall from A north-east (azimuth 45 degrees), two seeds
// south of A placed symmetrically about A's meridian, so that their geodesic distances to A are
// equal to the bit (the inverse problem's longitude difference is taken by its magnitude). The
// east seed ("lo", the lower site) is hidden from the sea beyond the meridian north of A, the
// west one ("hi") from the sea beyond its own shadow geodesic (the geodesic from it through A,
// continued); between the wall and that geodesic both paths bend at A, equal lengths to the bit:
// the tie region, "lo"'s. The boundary runs up A's meridian (the two seeds' bisector), turns at A
// and follows the shadow geodesic, every vertex beyond A on it (within a millimetre: off the
// geodesic the two lengths part quadratically, and stay equal in doubles a fraction of a
// millimetre away) and flagged tie, its distance the path round A.
TEST(SeaLines, OnTheEllipsoidATieRegionsEdgeIsTheShadowGeodesic) {
  using test::metres;
  const GeographicLib::Geodesic& earth = test::wgs84();
  const Vec2 a{10.5, 55.1};
  Vec2 b;
  earth.Direct(a.y, a.x, 45.0, 40e3, b.y, b.x);
  const Vec2 lo{10.6, 54.95}, hi{10.4, 54.95};
  ASSERT_EQ(metres(lo, a), metres(hi, a));
  const SeedSet seeds = test::named_points({{"lo", lo}, {"hi", hi}});
  const GridSpec g = test::grid_of(80, 65, 0.01, 10.2, 55.5);
  SeaOptions options;
  options.metric = test::geodesic_metric();
  const test::WallSea sea(seeds, a, b, g, options);
  const SeaField& field = sea.field;
  BoundaryOptions lines;
  lines.line_tolerance = 1e-3;
  const BoundaryResult r = extract_boundaries(field.field, *sea.index, lines);
  ASSERT_EQ(r.lines.size(), 1u);
  // The shadow geodesic: from A on at the azimuth the geodesic from "hi" arrives with.
  double s12, azi1, ray;
  earth.Inverse(hi.y, hi.x, a.y, a.x, s12, azi1, ray);
  const double round_a = metres(hi, a);
  int64_t on_meridian = 0, beyond = 0, apex = 0, tied = 0, cells = 0;
  double worst = 0.0;
  for (const BoundaryVertex& v : r.lines[0].vertices) {
    tied += v.tie;
    if (v.p.x == a.x && v.p.y == a.y) {
      EXPECT_TRUE(v.tie);
      ++apex;
      continue;
    }
    if (v.p.y < a.y) {  // south of A: the bisector, A's meridian
      EXPECT_FALSE(v.tie) << v.p.x << "," << v.p.y;
      EXPECT_NEAR(v.p.x, a.x, 1e-9) << v.p.y;
      ++on_meridian;
      continue;
    }
    double d, az, back;
    earth.Inverse(a.y, a.x, v.p.y, v.p.x, d, az, back);
    const double off = d * std::sin((az - ray) * M_PI / 180.0);
    EXPECT_NEAR(off, 0.0, 1e-3) << v.p.x << "," << v.p.y;
    worst = std::max(worst, std::abs(off));
    EXPECT_TRUE(v.tie) << v.p.x << "," << v.p.y;
    EXPECT_NEAR(v.distance, round_a + d, 1e-6 * v.distance);
    ++beyond;
  }
  EXPECT_EQ(apex, 1);
  EXPECT_GT(on_meridian, 5);
  EXPECT_GT(beyond, 10);
  EXPECT_EQ(r.stats.tie_vertices, tied);
  // The tie region: cells beyond the shadow geodesic and short of the wall, round A both.
  for (int64_t row = 0; row < g.height; ++row)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x{g.centre_x(c), g.centre_y(row)};
      double d, az, back;
      earth.Inverse(a.y, a.x, x.y, x.x, d, az, back);
      if (!(az > ray + 0.5 && az < 44.5) || d > 30e3 || d < 2e3) continue;
      ASSERT_EQ(field.field.site.at(c, row), 0) << c << "," << row;
      ASSERT_NEAR(field.field.distance.at(c, row), round_a + d, 1e-6 * (round_a + d) + 0.01);
      ++cells;
    }
  EXPECT_GT(cells, 50);
  std::printf(
      "a tie region on the ellipsoid: %lld cells, the line along its edge %lld vertices, worst off the shadow "
      "geodesic %.3g m\n",
      static_cast<long long>(cells), static_cast<long long>(beyond), worst);
}

// A raise of the owners' settling cancelled half-way (settle_sea_metric_within): the call throws
// rv::Error(cancelled), and the metric, asked again, settles from the start: every distance then
// the fully settled metric's, to the bit. (100 square islets, 400 bend nodes: the raise from 2 to
// every node evaluates hundreds, and the cancel check runs every 256 evaluations.)
TEST(SeaLines, ACancelledRaiseOfTheSettlingStartsAgainWhenNextAsked) {
  Barriers islets;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) {
      const double x = 2.0 + 4.0 * i, y = 2.0 + 4.0 * j;
      islets.add_polygon({{{x, y}, {x + 1.5, y}, {x + 1.5, y + 1.5}, {x, y + 1.5}}}, "islet");
    }
  const SeedSet seeds = test::named_points({{"A", {0.5, 0.5}}, {"B", {41.5, 41.5}}});
  const GridSpec g = test::grid_of(42, 42, 1.0, 0.0, 42.0);
  std::atomic<bool> cancel{false};
  SeaOptions options;
  options.cancel = &cancel;
  SeaMetricStats stats;
  const std::unique_ptr<SiteMetric> metric = make_sea_site_metric(seeds, islets, g, options, &stats, 2.0);
  const Vec2 p{20.8, 20.8};
  const double near = metric->distance(p, 0);  // (settles to 2: A is farther)
  EXPECT_GT(near, 2.0);
  EXPECT_EQ(stats.within, 2.0);
  cancel = true;
  try {
    settle_sea_metric_within(*metric, std::numeric_limits<double>::infinity());
    ADD_FAILURE() << "the raise was not cancelled";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::cancelled) << e.what();
  }
  cancel = false;
  const std::unique_ptr<SiteMetric> fresh = make_sea_site_metric(seeds, islets, g);
  int64_t compared = 0, bent = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, r);
      for (int32_t site = 0; site < 2; ++site) {
        const double d = fresh->distance(x, site);
        ASSERT_EQ(std::bit_cast<uint64_t>(metric->distance(x, site)), std::bit_cast<uint64_t>(d)) << c << "," << r;
        compared += std::isfinite(d);
        bent +=
            std::isfinite(d) && d > std::hypot(x.x - (site == 0 ? 0.5 : 41.5), x.y - (site == 0 ? 0.5 : 41.5)) + 1e-9;
      }
    }
  EXPECT_EQ(stats.within, std::numeric_limits<double>::infinity());
  EXPECT_GT(compared, 2000);
  EXPECT_GT(bent, 200);  // paths round the islets
}

}  // namespace
// A wall through a column of cell centres (x = 0, from y = -20 to 20, on cells of 2 and 4):
// those cells lie on the wall, sea on both its faces, and take the nearer of each face's paths,
// which no point beside the wall does: the owners change between them and their neighbours by a
// jump, not on a locus. So no way from them is open, and the lines on either side end on the
// wall's faces where each side's locus meets it (a line of A's and B's cells along the wall, with
// chords up to 15 units off the locus, before). Three layouts: both seeds above the wall's top,
// one below either end, and one either side of it. Every vertex holds the closed form's equal
// paths on the side it is approached from, every sampled point lies within the tolerance of the
// locus, no segment runs along the wall, and the two ends on it are flagged on the barrier.
TEST(SeaLines, LinesEndOnTheFacesOfAWallThroughACellCentreColumnAndNeverRunAlongIt) {
  const Vec2 a{0, -20}, b{0, 20};
  const std::array<std::pair<Vec2, Vec2>, 3> layouts{
      std::pair{Vec2{-5, 30}, Vec2{6, 30}}, std::pair{Vec2{-7, -25}, Vec2{3, 28}}, std::pair{Vec2{-3, 5}, Vec2{4, -2}}};
  for (const double res : {2.0, 4.0})
    for (const std::pair<Vec2, Vec2>& layout : layouts) {
      const Vec2 sa = layout.first, sb = layout.second;  // (lambdas below take them)
      const SeedSet seeds = test::named_points({{"A", sa}, {"B", sb}});
      const auto n = static_cast<int64_t>(80 / res) + 1;
      const GridSpec g = test::grid_of(n, n, res, -40.0 - res / 2, 40.0 + res / 2);
      ASSERT_EQ(g.centre_x(n / 2), 0.0);
      const test::WallSea sea(seeds, a, b, g);
      const BoundaryResult lines = extract_boundaries(sea.field.field, *sea.index);
      const std::string at = std::to_string(res) + " (" + std::to_string(sa.x) + ", " + std::to_string(sa.y) + ")";
      ASSERT_EQ(lines.lines.size(), 2u) << at;
      EXPECT_EQ(lines.stats.locus.unresolved, 0) << at;
      EXPECT_LE(lines.stats.locus.max_midpoint, 1e-3) << at;
      // (An end carried onto the wall lies off it by the least amount that puts it on its side.)
      auto on_wall = [&](Vec2 p) { return std::abs(p.x) <= 1e-9 && p.y > a.y && p.y < b.y; };
      // A and B's paths' difference at p, on the side of the wall that `side` lies on.
      auto gap = [&](Vec2 p, Vec2 side) {
        const Vec2 q = on_wall(p) ? Vec2{std::copysign(1e-9, side.x), p.y} : p;
        return wall_path(sa, q, a, b) - wall_path(sb, q, a, b);
      };
      int ends_on_wall = 0;
      for (const BoundaryLine& line : lines.lines) {
        const std::vector<BoundaryVertex>& v = line.vertices;
        ASSERT_GE(v.size(), 2u) << at;
        for (size_t i = 0; i < v.size(); ++i) {
          const Vec2 side = v[i == 0 ? 1 : i - 1].p;
          EXPECT_NEAR(gap(v[i].p, side), 0.0, 1e-6) << at << ": " << v[i].p.x << "," << v[i].p.y;
          if (on_wall(v[i].p)) {
            EXPECT_TRUE(i == 0 || i + 1 == v.size()) << at << ": " << v[i].p.y;
            EXPECT_TRUE(v[i].on_barrier) << at << ": " << v[i].p.y;
            ++ends_on_wall;
          }
        }
        for (size_t i = 0; i + 1 < v.size(); ++i) {
          EXPECT_FALSE(on_wall(v[i].p) && on_wall(v[i + 1].p)) << at << ": along the wall at " << v[i].p.y;
          for (int k = 1; k < 8; ++k) {
            const Vec2 p = line_tools::lerp(v[i].p, v[i + 1].p, k / 8.0);
            const double h = 1e-7;
            auto f = [&](Vec2 x) { return gap(x, p); };
            const double gx = (f({p.x + h, p.y}) - f({p.x - h, p.y})) / (2 * h);
            const double gy = (f({p.x, p.y + h}) - f({p.x, p.y - h})) / (2 * h);
            EXPECT_LE(std::abs(f(p)) / std::hypot(gx, gy), 1e-3) << at << ": " << p.x << "," << p.y;
          }
        }
      }
      EXPECT_EQ(ends_on_wall, 2) << at;
    }
}

// A random archipelago's lines by sea on the 40-unit square at cells of `res` (the scans'
// grids): the field, the metric and its index, and the boundaries extracted.
struct ArchipelagoLines {
  ArchipelagoLines(const Archipelago& a, double res)
      : n(static_cast<int64_t>(std::ceil(40.0 / res))),
        g(test::grid_of(n, n, res, -0.5, 40.5)),
        field(compute_sea(a.seeds, a.barriers, g, g.full_window())),
        metric(make_sea_site_metric(a.seeds, a.barriers, g)),
        index(*metric),
        lines(extract_boundaries(field.field, index)) {}
  int64_t n;
  GridSpec g;
  SeaField field;
  std::unique_ptr<SiteMetric> metric;
  OwnerIndex index;
  BoundaryResult lines;
};

// No two lines of the same owners run along each other: no segment's middle within a
// thousandth of a cell of another such line.
void expect_no_two_lines_along_each_other(const BoundaryResult& lines, double res, const std::string& at) {
  for (size_t x = 0; x < lines.lines.size(); ++x)
    for (size_t y = x + 1; y < lines.lines.size(); ++y) {
      const BoundaryLine &u = lines.lines[x], &w = lines.lines[y];
      if (u.owner_a != w.owner_a || u.owner_b != w.owner_b) continue;
      for (size_t k = 0; k + 1 < u.vertices.size(); ++k) {
        const Vec2 m = line_tools::lerp(u.vertices[k].p, u.vertices[k + 1].p, 0.5);
        for (size_t q = 0; q + 1 < w.vertices.size(); ++q) {
          const Vec2 p0 = w.vertices[q].p, p1 = w.vertices[q + 1].p;
          EXPECT_GT(dist(line_tools::lerp(p0, p1, line_tools::nearest_t(p0, p1, m)), m), 1e-3 * res)
              << at << ": two lines along each other at " << m.x << "," << m.y;
        }
      }
    }
}

// Calls check(layout, lines, at) on each (round, cell size) of `chosen` among the layouts `make`
// draws in turn from seed `seed` (a round whose layout it refuses counts too); `at` names it.
// Returns how many it checked.
template <class Make, class Check>
int for_chosen_layouts(uint64_t seed, Make make, const std::vector<std::pair<int, double>>& chosen, Check check) {
  int last = 0;
  for (const auto& c : chosen) last = std::max(last, c.first);
  std::mt19937_64 rng(seed);
  int checked = 0;
  for (int round = 0; round <= last; ++round) {
    Archipelago a;
    if (!make(rng, a)) continue;
    for (const auto& [want_round, res] : chosen) {
      if (want_round != round) continue;
      const ArchipelagoLines lines(a, res);
      ++checked;
      check(a, lines, std::to_string(round) + " at " + std::to_string(res));
    }
  }
  return checked;
}

// The oracle of changes of owner along coasts: every barrier edge walked on each side in steps of
// a hundredth of a unit inside the grid, the owner at each step from the index (checked against
// the brute force above); every change of owner between two steps must lie within three steps of
// an end of a line of those two owners, or of a tripoint. Returns how many changes it saw.
int64_t expect_every_coast_change_ends_a_line(const Archipelago& a, const ArchipelagoLines& layout,
                                              const std::string& at) {
  const GridSpec& g = layout.g;
  const BoundaryResult& lines = layout.lines;
  auto owner = [&](Vec2 q) {
    const OwnerIndex::Hit h = layout.index.nearest(q);
    return h.site == kNoSite ? 0 : a.seeds.site_owner(h.site);
  };
  std::vector<std::pair<Vec2, Vec2>> edges;
  for (const Barriers::Polygon& poly : a.barriers.polygons())
    for (const Ring& ring : poly.rings)
      for (size_t k = 0; k < ring.size(); ++k) edges.emplace_back(ring[k], ring[(k + 1) % ring.size()]);
  for (const Barriers::Line& line : a.barriers.lines())
    for (size_t k = 0; k + 1 < line.vertices.size(); ++k) edges.emplace_back(line.vertices[k], line.vertices[k + 1]);
  constexpr double kStep = 0.01;
  auto ends_a_line = [&](int lo, int hi, Vec2 p) {
    for (const BoundaryLine& l : lines.lines)
      if (l.owner_a == lo && l.owner_b == hi)
        for (const BoundaryVertex* e : {&l.vertices.front(), &l.vertices.back()})
          if (dist(e->p, p) <= 3 * kStep) return true;
    return std::any_of(lines.tripoints.begin(), lines.tripoints.end(),
                       [&](const Tripoint& t) { return dist(t.p, p) <= 3 * kStep; });
  };
  int64_t changes = 0;
  for (const auto& [e0, e1] : edges) {
    const double len = dist(e0, e1);
    const Vec2 normal{-(e1.y - e0.y) / len, (e1.x - e0.x) / len};
    const auto steps = static_cast<int>(std::ceil(len / kStep));
    for (const double side : {1.0, -1.0}) {
      int before = 0;
      for (int k = 1; k < steps; ++k) {
        const Vec2 on = line_tools::lerp(e0, e1, static_cast<double>(k) / steps);
        const Vec2 q{on.x + side * 1e-7 * normal.x, on.y + side * 1e-7 * normal.y};
        const bool inside = q.x > g.xmin && q.x < g.xmax() && q.y > g.ymin() && q.y < g.ymax;
        const int o = inside && layout.metric->in_domain(q) ? owner(q) : 0;
        if (before > 0 && o > 0 && o != before) {
          ++changes;
          EXPECT_TRUE(ends_a_line(std::min(o, before), std::max(o, before), on))
              << at << ": owners " << before << " and " << o << " at " << on.x << "," << on.y;
        }
        before = o;
      }
    }
  }
  return changes;
}

// Every vertex of every line on its owners' locus with no third owner nearer, and every sampled
// point of every segment at sea.
void expect_lines_on_their_locus_at_sea(const ArchipelagoLines& layout, const std::string& at) {
  for (const BoundaryLine& u : layout.lines.lines) {
    for (const BoundaryVertex& v : u.vertices) {
      const OwnerIndex::Hit ha = layout.index.nearest_of(v.p, u.owner_a), hb = layout.index.nearest_of(v.p, u.owner_b);
      EXPECT_NEAR(ha.cost, hb.cost, 1e-6 * std::max(1.0, ha.cost)) << at << ": " << v.p.x << "," << v.p.y;
      const OwnerIndex::Hit third = layout.index.nearest_third(v.p, u.owner_a, u.owner_b, std::max(ha.cost, hb.cost));
      EXPECT_TRUE(third.site == kNoSite || third.cost >= std::min(ha.cost, hb.cost) - 1e-6) << at;
    }
    for (size_t k = 0; k + 1 < u.vertices.size(); ++k)
      for (int s = 1; s < 8; ++s) {
        const Vec2 p = line_tools::lerp(u.vertices[k].p, u.vertices[k + 1].p, s / 8.0);
        EXPECT_TRUE(layout.metric->in_domain(p)) << at << ": on land at " << p.x << "," << p.y;
      }
  }
}

// No junction counted unexplained, every change of owner along a coast ending a line (the oracle
// above), every line on its locus and at sea, and no two along each other. Returns the changes
// the oracle saw.
int64_t expect_coasts_explained(const Archipelago& a, const ArchipelagoLines& layout, const std::string& at) {
  EXPECT_EQ(layout.lines.stats.coast_changes_unexplained, 0) << at;
  const int64_t changes = expect_every_coast_change_ends_a_line(a, layout, at);
  expect_lines_on_their_locus_at_sea(layout, at);
  expect_no_two_lines_along_each_other(layout.lines, layout.g.res, at);
  return changes;
}

// Changes of owner along a coast the cells do not show, on random archipelagos at grids coarser
// than their channels (cells of 2.3 to 4.7 on the 40-unit square): a pocket of sea whose cells
// meet the rest only corner to corner, a sound narrower than a cell. The oracle walks every
// barrier edge on each side in steps of a hundredth of a unit inside the grid, the owner at each
// step from the index (checked against the brute force above): every change of owner between
// two steps must be within three steps of an end of a line of those two owners, or of a
// tripoint. Every vertex lies on its owners' locus with no third owner nearer, every sampled
// point of every segment at sea, and no line runs along another of the same owners. The layouts
// are those of the scan (seed 91) where a junction that no pair or grid edge took left a line
// out: its line is now followed from it along the locus to a coast, the frame, another such
// junction or a line's open end (boundaries.channels_crossed). The last six had a change the
// cells do show, in a dual square with every corner at sea (a sound between two islands inside
// it), that no line ended at: the coast between two line ends of an island whose owners there
// disagree is now walked whole, round after round as the lines drawn reach further islands.
TEST(SeaLines, EveryChangeOfOwnerAlongACoastTheCellsDoNotShowEndsALine) {
  const std::vector<std::pair<int, double>> chosen{{7, 2.3},  {10, 2.3}, {26, 2.3}, {45, 2.3}, {45, 3.1}, {47, 2.3},
                                                   {48, 3.1}, {53, 4.7}, {63, 2.3}, {72, 3.1}, {5, 3.1},  {13, 2.3},
                                                   {17, 4.7}, {36, 2.3}, {50, 4.7}, {67, 2.3}};
  int64_t changes = 0, crossed = 0;
  const auto archipelagos = [](std::mt19937_64& rng, Archipelago& a) { return archipelago(rng, a); };
  const int64_t checked = for_chosen_layouts(
      91, archipelagos, chosen, [&](const Archipelago& a, const ArchipelagoLines& layout, const std::string& at) {
        crossed += layout.lines.stats.channels_crossed;
        changes += expect_coasts_explained(a, layout, at);
      });
  EXPECT_EQ(checked, static_cast<int64_t>(chosen.size()));
  EXPECT_GE(crossed, static_cast<int64_t>(chosen.size()));
  std::printf("coasts the cells do not show: %lld layouts, %lld changes of owner along coasts, %lld lines crossed\n",
              static_cast<long long>(checked), static_cast<long long>(changes), static_cast<long long>(crossed));
}

// Chains of islets split by sounds 0.005 to 0.05 wide (a coast like the Archipelago Sea's): three
// to six chains, each of two to six islets of six corners in a row at a random bearing, their
// ends tilted and their sides bent (chains may cross, islets overlap), and three to five ports at
// sea of three owners. False where fewer than three ports found sea.
bool islet_chains(std::mt19937_64& rng, Archipelago& out) {
  std::uniform_real_distribution<double> u(0, 1);
  const int chains = 3 + static_cast<int>(u(rng) * 4);
  for (int c = 0; c < chains; ++c) {
    double x = 4 + u(rng) * 30, y = 4 + u(rng) * 30;
    const double bearing = u(rng) * M_PI, w = 0.3 + u(rng) * 2.0;
    const Vec2 d{std::cos(bearing), std::sin(bearing)}, n{-d.y, d.x};
    const int islets = 2 + static_cast<int>(u(rng) * 5);
    for (int i = 0; i < islets; ++i) {
      const double len = 0.2 + u(rng) * 2.5, gap = 0.005 + u(rng) * 0.045;
      const double t1 = (u(rng) - 0.5) * 0.8, t2 = (u(rng) - 0.5) * 0.8;          // the ends' tilt
      const double b1 = (u(rng) - 0.3) * 0.5 * w, b2 = (u(rng) - 0.3) * 0.5 * w;  // the sides' bend
      auto at = [&](double along, double side) {
        return Vec2{x + d.x * along + n.x * side, y + d.y * along + n.y * side};
      };
      const Ring r{at(-t1 * w / 2, -w / 2),     at(len * 0.5, -w / 2 - b1), at(len - t2 * w / 2, -w / 2),
                   at(len + t2 * w / 2, w / 2), at(len * 0.5, w / 2 + b2),  at(t1 * w / 2, w / 2)};
      if (std::all_of(r.begin(), r.end(), [](Vec2 v) { return v.x > 0.5 && v.x < 39.5 && v.y > 0.5 && v.y < 39.5; }))
        out.barriers.add_polygon({r}, "islet");
      x += d.x * (len + gap);
      y += d.y * (len + gap);
    }
  }
  const Visibility vis(out.barriers);
  std::uniform_int_distribution<int> coord(0, 36);
  int placed = 0;
  for (int k = 0; k < 30 && placed < 5; ++k) {
    const Vec2 p{coord(rng) + 0.25, coord(rng) + 0.75};
    if (vis.on_land(p)) continue;
    out.seeds.add_point(
        out.seeds.add_feature(out.seeds.owner_code(std::string(1, static_cast<char>('A' + placed % 3)))), p);
    ++placed;
  }
  return placed >= 3;
}

// A change of owner on an islet's coast that the cells do not show, where the locus leaves across
// a sound to the next islet narrower than a walk's first step (2 to 3 % of a cell): its line is
// walked from the junction and ends on the far coast. Before, the first step found no locus
// across the sound, the coast was looked for round the walk's point a hundredth of a cell off
// the junction, and the nearest coast point where the costs are equal was the junction itself:
// the walk ended where it began, and the change was left unexplained (the Archipelago Sea's
// FI-AX line at 0.02 deg, broken near 21.09 E 60.40 N and 60.48 N, its regions refused). The
// layouts are those of a scan of islet chains (seed 7) where this happened. (The walks of the
// overlapping islets' coasts, below, now reach these two as well; the Archipelago Sea's fixture in
// test_sea_lines_job.cpp holds the walk's rule alone.)
TEST(SeaLines, AWalkFromACoastAcrossASoundNarrowerThanAStepEndsOnTheFarCoast) {
  const std::vector<std::pair<int, double>> chosen{{252, 2.3}, {598, 1.3}};
  const int checked = for_chosen_layouts(
      7, islet_chains, chosen, [&](const Archipelago&, const ArchipelagoLines& layout, const std::string& at) {
        const BoundaryResult& lines = layout.lines;
        EXPECT_EQ(lines.stats.coast_changes_unexplained, 0) << at;
        EXPECT_GE(lines.stats.channels_crossed, 1) << at;
        // The line across the sound: both ends on coasts, a twentieth of a cell apart at most.
        const auto across = std::count_if(lines.lines.begin(), lines.lines.end(), [&](const BoundaryLine& l) {
          const BoundaryVertex &f = l.vertices.front(), &e = l.vertices.back();
          return f.on_barrier && e.on_barrier && dist(f.p, e.p) <= 0.05 * layout.g.res;
        });
        EXPECT_GE(across, 1) << at;
        expect_lines_on_their_locus_at_sea(layout, at);
        expect_no_two_lines_along_each_other(lines, layout.g.res, at);
      });
  EXPECT_EQ(checked, static_cast<int>(chosen.size()));
}

// Changes of owner on the coast of an islet whose land overlaps its neighbour's (the islet chains
// above, whose tilted ends often overlap): where the locus crosses the chain, a line ends on one
// islet's coast and the change where the locus comes out lies on the other islet's coast, which no
// line ends at; the first islet's coast goes under the other's land there. Every ring whose land
// meets that of a ring with a stretch walked is now walked whole too, and every change ends a
// line (the first five layouts missed one or two before). The last two (before: one junction
// counted unexplained) count only what no line explains at the end of the lines' stages: a
// junction a round leaves may get its line from a later stage (a tripoint's leg).
TEST(SeaLines, ChangesOfOwnerWhereIsletsOverlapEndLinesAndOnlyTheUnexplainedAreCounted) {
  const std::vector<std::pair<int, double>> chosen{{55, 2.3},  {80, 2.3}, {97, 1.3}, {101, 2.3},
                                                   {111, 3.1}, {21, 1.3}, {47, 3.1}};
  int64_t changes = 0;
  const int checked = for_chosen_layouts(
      7, islet_chains, chosen, [&](const Archipelago& a, const ArchipelagoLines& layout, const std::string& at) {
        changes += expect_coasts_explained(a, layout, at);
      });
  EXPECT_EQ(checked, static_cast<int>(chosen.size()));
  EXPECT_GE(changes, static_cast<int64_t>(chosen.size()));
}

}  // namespace rv

namespace rv {
namespace {

// Where the cells hide a stretch of a boundary by sea (land centres on one side of it, one owner's
// on the other; a tripoint whose square's centres are land), the lines still end only where a line
// can: on a coast, on the frame of the cell centres or the grid's edge, at a tripoint, or closed
// into a ring; every tripoint inside the frame has a line of each pair of its owners ending at it;
// and every segment lies on its owners' locus (at seven points of it, their costs within a
// hundredth of a cell of each other and no third owner nearer by as much), with no segment along
// a boom and no two lines of the same owners along each other. The layouts are random
// archipelagos (seed 91, as above) where, before, a walk along the locus stopped where a third
// owner came nearer (no tripoint, its lines left open), a tripoint lacked a line, a coast junction
// was taken across another owner's sea or past another line's end, or a boom's edge with an end
// on an island was not searched; and (rounds 144) where a tripoint's walked line would have
// followed a boom's jump of owners for its locus.
TEST(SeaLines, EveryLineEndsOnACoastTheFrameOrATripointAndEveryTripointHasItsThreeLines) {
  // The second row: a square whose three owners' lines end on an islet inside it (7), two
  // tripoints of the same owners a cell apart with the lines near both linked to one (17, 20, 122,
  // 129), crossings linked to a tripoint across a boom (59) or an island (207, 287; 37, 101 and
  // 188, where the line then ran along the one walked to that tripoint on its own side), a coast
  // point behind a line's end taken though the locus goes on from the end to a tripoint (28, 29),
  // or lies on the line's own stretch (1, 69, 123, 207 at 2.3, 148, 14), an end walked past
  // another line's open end (100, 54), an open end's walk along a line already drawn (255), two
  // crossings at one cell centre linked into a line of no length (41), a locus that meets the coast
  // exactly at an island's corner (63, 186), two open ends whose chord an islet or land beside it
  // hides the locus from (141 at 4.7, 268 at 3.1).
  const std::vector<std::pair<int, double>> chosen{
      {0, 3.1},   {0, 4.7},   {3, 2.3},  {10, 4.7},  {16, 2.3},  {19, 3.1},  {20, 4.7},  {25, 2.3},  {25, 3.1},
      {7, 4.7},   {17, 2.3},  {20, 3.1}, {59, 2.3},  {122, 2.3}, {129, 3.1}, {207, 3.1}, {287, 2.3}, {37, 3.1},
      {101, 2.3}, {188, 2.3}, {28, 3.1}, {29, 2.3},  {1, 3.1},   {69, 3.1},  {123, 3.1}, {207, 2.3}, {255, 2.3},
      {41, 2.3},  {148, 2.3}, {14, 3.1}, {100, 2.3}, {54, 4.7},  {63, 2.3},  {186, 3.1}, {141, 4.7}, {268, 3.1}};
  const std::vector<std::pair<int, double>> booms{{144, 2.3}, {144, 4.7}};
  std::mt19937_64 rng(91);
  int64_t checked = 0, tripoints = 0, ends = 0;
  for (int round = 0; round <= 287; ++round) {
    Archipelago a;
    if (!archipelago(rng, a)) continue;
    for (const bool full : {true, false})
      for (const auto& [want_round, res] : full ? chosen : booms) {
        if (want_round != round) continue;
        const std::string at = std::to_string(round) + " at " + std::to_string(res);
        const ArchipelagoLines layout(a, res);
        const int64_t n = layout.n;
        const GridSpec& g = layout.g;
        const OwnerIndex& index = layout.index;
        const BoundaryResult& lines = layout.lines;
        ++checked;
        // No segment along the boom: both its ends on the boom's line.
        for (const Barriers::Line& boom : a.barriers.lines())
          for (const BoundaryLine& l : lines.lines)
            for (size_t k = 0; k + 1 < l.vertices.size(); ++k) {
              const Vec2 b0 = boom.vertices.front(), b1 = boom.vertices.back();
              auto on_boom = [&](Vec2 p) {
                return dist(line_tools::lerp(b0, b1, line_tools::nearest_t(b0, b1, p)), p) <= 1e-9;
              };
              EXPECT_FALSE(on_boom(l.vertices[k].p) && on_boom(l.vertices[k + 1].p))
                  << at << ": along the boom at " << l.vertices[k].p.x << "," << l.vertices[k].p.y;
            }
        if (!full) continue;
        auto on_tripoint = [&](Vec2 p) {
          return std::any_of(lines.tripoints.begin(), lines.tripoints.end(),
                             [&](const Tripoint& t) { return t.p == p; });
        };
        auto on_frame = [&](Vec2 p) {
          return p.x == g.centre_x(0) || p.x == g.centre_x(n - 1) || p.y == g.centre_y(0) || p.y == g.centre_y(n - 1) ||
                 p.x == g.xmin || p.x == g.xmax() || p.y == g.ymin() || p.y == g.ymax;
        };
        for (const BoundaryLine& l : lines.lines) {
          if (l.closed) continue;
          EXPECT_GT(dist(l.vertices.front().p, l.vertices.back().p), 1e-3 * res)
              << at << ": owners " << l.owner_a << " and " << l.owner_b << " end where they begin, at "
              << l.vertices.front().p.x << "," << l.vertices.front().p.y;
          for (const BoundaryVertex* e : {&l.vertices.front(), &l.vertices.back()}) {
            EXPECT_TRUE(e->on_barrier || on_frame(e->p) || on_tripoint(e->p))
                << at << ": owners " << l.owner_a << " and " << l.owner_b << " end in the open at " << e->p.x << ","
                << e->p.y;
            ++ends;
          }
        }
        for (const Tripoint& t : lines.tripoints) {
          if (t.p.x <= g.centre_x(0) || t.p.x >= g.centre_x(n - 1) || t.p.y >= g.centre_y(0) ||
              t.p.y <= g.centre_y(n - 1))
            continue;
          ++tripoints;
          for (const std::pair<int, int>& pair : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}}) {
            const int i = pair.first, k = pair.second;  // (lambdas below take them)
            const bool has = std::any_of(lines.lines.begin(), lines.lines.end(), [&](const BoundaryLine& l) {
              return l.owner_a == t.owners[i] && l.owner_b == t.owners[k] &&
                     (l.vertices.front().p == t.p || l.vertices.back().p == t.p);
            });
            EXPECT_TRUE(has) << at << ": the tripoint at " << t.p.x << "," << t.p.y << " lacks the line of owners "
                             << t.owners[i] << " and " << t.owners[k];
          }
        }
        for (size_t x = 0; x < lines.lines.size(); ++x) {
          const BoundaryLine& u = lines.lines[x];
          for (size_t k = 0; k + 1 < u.vertices.size(); ++k) {
            EXPECT_TRUE(layout.metric->open_between(u.vertices[k].p, u.vertices[k + 1].p))
                << at << ": owners " << u.owner_a << " and " << u.owner_b << " across a barrier from "
                << u.vertices[k].p.x << "," << u.vertices[k].p.y << " to " << u.vertices[k + 1].p.x << ","
                << u.vertices[k + 1].p.y;
            for (int s = 1; s < 8; ++s) {
              const Vec2 p = line_tools::lerp(u.vertices[k].p, u.vertices[k + 1].p, s / 8.0);
              const OwnerIndex::Hit ha = index.nearest_of(p, u.owner_a), hb = index.nearest_of(p, u.owner_b);
              const OwnerIndex::Hit third = index.nearest_third(p, u.owner_a, u.owner_b, std::max(ha.cost, hb.cost));
              EXPECT_LE(std::abs(ha.cost - hb.cost), 1e-2 * res) << at << ": off the locus at " << p.x << "," << p.y;
              EXPECT_TRUE(third.site == kNoSite || third.cost >= std::min(ha.cost, hb.cost) - 1e-2 * res)
                  << at << ": a third owner nearer at " << p.x << "," << p.y;
            }
          }
        }
        expect_no_two_lines_along_each_other(lines, res, at);
      }
  }
  EXPECT_EQ(checked, static_cast<int64_t>(chosen.size() + booms.size()));
  EXPECT_GT(tripoints, 10);
  std::printf("lines by sea where the cells hide them: %lld layouts, %lld line ends, %lld tripoints\n",
              static_cast<long long>(checked), static_cast<long long>(ends), static_cast<long long>(tripoints));
}

}  // namespace
}  // namespace rv
