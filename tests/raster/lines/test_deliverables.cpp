#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "deliverables_check.hpp"
#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/field/planar.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/margin.hpp"
#include "rv/lines/simplify.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

// The same seeds measured both ways: geodesic (longitude/latitude on WGS 84) and planar (the
// degrees taken as plane units, from `origin`), for the checks that hold for every metric.
struct BothMetrics {
  MetricSpec spec{MetricSpec::geodesic};
  GeodesicSiteMetric geodesic;
  PlanarSiteMetric planar;
  BothMetrics(const SeedSet& s, Vec2 origin) : geodesic(s, spec), planar(s, origin) {}
  std::array<const SiteMetric*, 2> all() const { return {&geodesic, &planar}; }
};

GridSpec grid(int64_t w, int64_t h, double res = 1.0, double xmin = 0.0, double ymax = -1.0) {
  GridSpec g;
  g.xmin = xmin;
  g.ymax = ymax < 0 ? static_cast<double>(h) * res : ymax;
  g.res = res;
  g.width = w;
  g.height = h;
  return g;
}

NearestField exact(const SeedSet& s, const GridSpec& g) {
  ComputeOptions o;
  o.threads = 2;
  return compute(s, g, o);
}

struct Fixture {
  const SeedSet& seeds;
  GridSpec g;
  NearestField field;
  PlanarSiteMetric metric;
  OwnerIndex index;
  Fixture(const SeedSet& s, const GridSpec& grid_)
      : seeds(s), g(grid_), field(exact(s, grid_)), metric(s, Vec2{grid_.xmin, grid_.ymax}), index(metric) {}
};

SeedSet points(std::initializer_list<Vec2> pts) {
  SeedSet s;
  for (Vec2 p : pts) {
    const int32_t f = s.add_feature(s.owner_code("o" + std::to_string(s.features().size() + 1)));
    s.add_point(f, p);
  }
  return s;
}

TEST(Deliverables, TwoPointsGiveThePerpendicularBisector) {
  // Large UTM-like coordinates: the exact placement must not lose precision there.
  const double x0 = 500000.0, y0 = 6100000.0, res = 25.0;
  const SeedSet s = points({{x0 + 10.3 * res, y0 + 12.7 * res}, {x0 + 27.1 * res, y0 + 18.2 * res}});
  Fixture st(s, grid(40, 30, res, x0, y0 + 30 * res));
  const BoundaryResult b = extract_boundaries(st.field, st.index);
  ASSERT_EQ(b.lines.size(), 1u);
  EXPECT_TRUE(b.tripoints.empty());
  const BoundaryLine& line = b.lines[0];
  EXPECT_EQ(line.owner_a, 1);
  EXPECT_EQ(line.owner_b, 2);
  EXPECT_FALSE(line.closed);
  const Vec2 a = s.sites()[0].a, c = s.sites()[1].a;
  const Vec2 m{(a.x + c.x) / 2, (a.y + c.y) / 2};
  const double len = std::hypot(c.x - a.x, c.y - a.y);
  for (const BoundaryVertex& v : line.vertices) {
    EXPECT_LE(std::abs(((v.p.x - m.x) * (c.x - a.x) + (v.p.y - m.y) * (c.y - a.y)) / len), 1e-6 * res);
    EXPECT_EQ(v.site_a, 0);
    EXPECT_EQ(v.site_b, 1);
  }
  // Continuous: no gap wider than a cell diagonal, from one side of the grid to the other.
  for (size_t i = 1; i < line.vertices.size(); ++i)
    EXPECT_LE(
        std::hypot(line.vertices[i].p.x - line.vertices[i - 1].p.x, line.vertices[i].p.y - line.vertices[i - 1].p.y),
        std::sqrt(2.0) * res + 1e-9);
  const Vec2 first = line.vertices.front().p, last = line.vertices.back().p;
  auto at_border = [&](Vec2 p) {
    return p.x <= st.g.centre_x(0) + res || p.x >= st.g.centre_x(39) - res || p.y >= st.g.centre_y(0) - res ||
           p.y <= st.g.centre_y(29) + res;
  };
  EXPECT_TRUE(at_border(first));
  EXPECT_TRUE(at_border(last));
  test::check_boundaries(s, st.field, b, 1e-3 * res);
  EXPECT_LE(b.stats.max_residual, 1e-6 * res);
}

TEST(Deliverables, ThreePointsMeetAtTheCircumcentre) {
  const SeedSet s = points({{8.2, 9.1}, {31.7, 12.4}, {17.5, 33.9}});
  Fixture st(s, grid(40, 40));
  const BoundaryResult b = extract_boundaries(st.field, st.index);
  ASSERT_EQ(b.tripoints.size(), 1u);
  // Circumcentre of the three points.
  const Vec2 A = s.sites()[0].a, B = s.sites()[1].a, C = s.sites()[2].a;
  const double d = 2 * (A.x * (B.y - C.y) + B.x * (C.y - A.y) + C.x * (A.y - B.y));
  const double ux = ((A.x * A.x + A.y * A.y) * (B.y - C.y) + (B.x * B.x + B.y * B.y) * (C.y - A.y) +
                     (C.x * C.x + C.y * C.y) * (A.y - B.y)) /
                    d;
  const double uy = ((A.x * A.x + A.y * A.y) * (C.x - B.x) + (B.x * B.x + B.y * B.y) * (A.x - C.x) +
                     (C.x * C.x + C.y * C.y) * (B.x - A.x)) /
                    d;
  const Tripoint& t = b.tripoints[0];
  EXPECT_NEAR(t.p.x, ux, 1e-3);
  EXPECT_NEAR(t.p.y, uy, 1e-3);
  EXPECT_EQ(t.owners[0], 1);
  EXPECT_EQ(t.owners[1], 2);
  EXPECT_EQ(t.owners[2], 3);
  // Three lines, one per pair, each ending at the tripoint.
  ASSERT_EQ(b.lines.size(), 3u);
  for (const BoundaryLine& line : b.lines) {
    const bool ends_there = line.vertices.front().p == t.p || line.vertices.back().p == t.p;
    EXPECT_TRUE(ends_there) << line.owner_a << "-" << line.owner_b;
  }
  test::check_boundaries(s, st.field, b, 1e-3);
}

TEST(Deliverables, TwoParallelLinesGiveTheMedianMidway) {
  SeedSet s;
  const int32_t fa = s.add_feature(s.owner_code("A"));
  const std::vector<Vec2> la{{-5.0, 4.0}, {20.0, 4.0}, {55.0, 4.0}};
  s.add_polyline(fa, la);
  const int32_t fb = s.add_feature(s.owner_code("B"));
  const std::vector<Vec2> lb{{-5.0, 26.0}, {30.0, 26.0}, {55.0, 26.0}};
  s.add_polyline(fb, lb);
  Fixture st(s, grid(50, 30, 1.0));
  const BoundaryResult b = extract_boundaries(st.field, st.index);
  ASSERT_EQ(b.lines.size(), 1u);
  for (const BoundaryVertex& v : b.lines[0].vertices) EXPECT_NEAR(v.p.y, 15.0, 1e-6);
  EXPECT_EQ(b.lines[0].vertices.size(), 50u);  // one crossing per column
  test::check_boundaries(s, st.field, b, 1e-3);
  // Simplification keeps exact vertices only: a straight median collapses to its two ends.
  BoundaryOptions o;
  o.simplify_cells = 0.01;
  const BoundaryResult simple = extract_boundaries(st.field, st.index, o);
  ASSERT_EQ(simple.lines.size(), 1u);
  EXPECT_EQ(simple.lines[0].vertices.size(), 2u);
  EXPECT_EQ(simple.lines[0].vertices.front().p, b.lines[0].vertices.front().p);
  EXPECT_EQ(simple.lines[0].vertices.back().p, b.lines[0].vertices.back().p);
}

TEST(Deliverables, PolygonsOfTwoOwners) {
  SeedSet s;
  const int32_t fa = s.add_feature(s.owner_code("A"));
  s.add_polygon(fa, {{{2.0, 2.0}, {14.0, 3.0}, {12.0, 20.0}, {3.0, 25.0}}});
  const int32_t fb = s.add_feature(s.owner_code("B"));
  s.add_polygon(fb, {{{30.0, 5.0}, {38.0, 5.0}, {38.0, 28.0}, {25.0, 20.0}}});
  Fixture st(s, grid(40, 30));
  const BoundaryResult b = extract_boundaries(st.field, st.index);
  ASSERT_EQ(b.lines.size(), 1u);
  test::check_boundaries(s, st.field, b, 1e-3);
}

// Random seeds of several owners: points, polylines (the controlling segment changes along
// cell-centre segments) and the checks of every vertex and tripoint.
TEST(Deliverables, RandomMixedSeedsPassTheEquidistanceChecks) {
  for (uint32_t trial = 0; trial < 12; ++trial) {
    std::mt19937 rng(trial);
    std::uniform_real_distribution<double> ux(-5, 65), uy(-5, 50);
    SeedSet s;
    const int owners = 2 + static_cast<int>(trial % 4);
    for (int i = 0; i < 14; ++i) {
      const int32_t f = s.add_feature(s.owner_code("o" + std::to_string(1 + i % owners)));
      if (i % 3 == 0) {
        std::vector<Vec2> line{{ux(rng), uy(rng)}};
        for (int k = 0; k < 3; ++k)
          line.push_back({line.back().x + (ux(rng) - 30) / 4, line.back().y + (uy(rng) - 22) / 4});
        s.add_polyline(f, line);
      } else {
        s.add_point(f, {ux(rng), uy(rng)});
      }
    }
    Fixture st(s, grid(60, 45));
    const BoundaryResult b = extract_boundaries(st.field, st.index);
    SCOPED_TRACE("trial " + std::to_string(trial));
    EXPECT_GT(b.lines.size(), 0u);
    test::check_boundaries(s, st.field, b, 1e-3);
    test::check_no_crossings(b);
    EXPECT_LE(b.stats.max_residual, 1e-3);
  }
}

// Saddle squares (A B / B A): the exact owner of the square's centre decides which diagonal is
// connected, so the two lines never cross, whichever way the centre goes.
TEST(Deliverables, SaddlesAreResolvedByTheCentreOwner) {
  for (double shift : {-0.2, 0.2}) {
    SeedSet s;
    const int32_t a = s.owner_code("A"), b = s.owner_code("B");
    s.add_point(s.add_feature(a), {10.0, 10.0});
    s.add_point(s.add_feature(a), {20.0 + shift, 20.0 + shift});
    s.add_point(s.add_feature(b), {10.0, 20.0});
    s.add_point(s.add_feature(b), {20.0, 10.0});
    Fixture st(s, grid(30, 30));
    const BoundaryResult r = extract_boundaries(st.field, st.index);
    EXPECT_EQ(r.lines.size(), 2u);
    test::check_boundaries(s, st.field, r, 1e-3);
    test::check_no_crossings(r);
  }
}

TEST(Deliverables, ManyOwnersTopology) {
  // Every seed its own owner: many tripoints; lines meet only at tripoints, every tripoint ends
  // one line of each of its three pairs, and every other line end lies on the grid's border.
  int dangling = 0, ends_total = 0;
  for (uint32_t trial = 0; trial < 20; ++trial) {
    const SeedSet s = test::random_points(30, 0, 0, 50, 40, 300 + trial);
    const GridSpec g = grid(50, 40);
    Fixture st(s, g);
    const BoundaryResult r = extract_boundaries(st.field, st.index);
    SCOPED_TRACE("trial " + std::to_string(trial));
    test::check_boundaries(s, st.field, r, 1e-3);
    test::check_no_crossings(r);
    EXPECT_GT(r.tripoints.size(), 10u);
    for (const Tripoint& t : r.tripoints) {
      std::vector<std::pair<int32_t, int32_t>> pairs;
      for (const BoundaryLine& line : r.lines)
        for (const Vec2 end : {line.vertices.front().p, line.vertices.back().p})
          if (end == t.p) pairs.emplace_back(line.owner_a, line.owner_b);
      std::sort(pairs.begin(), pairs.end());
      EXPECT_EQ(std::unique(pairs.begin(), pairs.end()), pairs.end()) << "two lines of one pair end at a tripoint";
      EXPECT_LE(pairs.size(), 3u);
    }
    dangling += test::dangling_ends(r, g, &ends_total);
  }
  // Every end is on the grid's border or at a tripoint. (Regions thinner than a cell used to
  // leave their sides without vertices, and the lines along them dangled: 10 of 2804 ends here.)
  std::printf("line ends %d, dangling %d\n", ends_total, dangling);
  EXPECT_GT(ends_total, 1000);
  EXPECT_EQ(dangling, 0);
}

// Many owners, mixed points and lines, several features per owner: regions thinner than a cell
// are common, and their sides are lines too. Their vertices pass the equidistance checks like
// every other, and lines no longer stop in the open along them.
TEST(Deliverables, NoDanglingEndsWithRegionsThinnerThanACell) {
  int dangling = 0, ends_total = 0;
  int64_t sliver_vertices = 0, slivers = 0;
  for (uint32_t trial = 0; trial < 16; ++trial) {
    std::mt19937 rng(1000 + trial);
    std::uniform_real_distribution<double> ux(-3, 53), uy(-3, 43);
    SeedSet s;
    const int owners = 6 + static_cast<int>(trial % 10);
    for (int i = 0; i < 3 * owners; ++i) {
      const int32_t f = s.add_feature(s.owner_code("o" + std::to_string(1 + i % owners)));
      if (i % 4 == 0) {
        std::vector<Vec2> line{{ux(rng), uy(rng)}};
        for (int k = 0; k < 2; ++k)
          line.push_back({line.back().x + (ux(rng) - 25) / 5, line.back().y + (uy(rng) - 20) / 5});
        // Lines of two owners that cross are seeds in conflict (distance 0 to both, where
        // boundaries may end legitimately): keep the scene free of them.
        auto orient = [](Vec2 p, Vec2 q, Vec2 r) { return (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x); };
        bool crosses = false;
        for (const Site& site : s.sites())
          for (size_t k = 1; k < line.size() && site.kind == SiteKind::segment; ++k) {
            const Vec2 a = line[k - 1], b = line[k];
            crosses |= (orient(a, b, site.a) > 0) != (orient(a, b, site.b) > 0) &&
                       (orient(site.a, site.b, a) > 0) != (orient(site.a, site.b, b) > 0);
          }
        if (crosses)
          s.add_point(f, line.front());
        else
          s.add_polyline(f, line);
      } else {
        s.add_point(f, {ux(rng), uy(rng)});
      }
    }
    const GridSpec g = grid(50, 40);
    Fixture st(s, g);
    const BoundaryResult r = extract_boundaries(st.field, st.index);
    SCOPED_TRACE("trial " + std::to_string(trial));
    test::check_boundaries(s, st.field, r, 1e-3, &sliver_vertices);
    test::check_no_crossings(r);
    dangling += test::dangling_ends(r, g, &ends_total);
    // Every tripoint within the frame of the outermost centres has three lines ending at it, at
    // least (two tripoints a fraction of a cell apart share one with no crossing; where one owner
    // has two sites there, four lines of two pairs meet and the third pair touches at the point).
    for (const Tripoint& t : r.tripoints) {
      if (t.p.x <= g.centre_x(0) || t.p.x >= g.centre_x(g.width - 1) || t.p.y >= g.centre_y(0) ||
          t.p.y <= g.centre_y(g.height - 1))
        continue;
      int ends = 0;
      for (const BoundaryLine& l : r.lines) ends += (l.vertices.front().p == t.p) + (l.vertices.back().p == t.p);
      EXPECT_GE(ends, 3) << "tripoint " << t.p.x << ", " << t.p.y;
    }
    slivers += r.stats.sliver_crossings;
    EXPECT_EQ(r.stats.unresolved_slivers, 0);
  }
  std::printf("line ends %d, dangling %d, sliver segments %lld, vertices on them %lld\n", ends_total, dangling,
              static_cast<long long>(slivers), static_cast<long long>(sliver_vertices));
  EXPECT_GT(slivers, 20);          // the case this test is about occurs
  EXPECT_GT(sliver_vertices, 20);  // and its sides are drawn
  // Before the sides of thin regions were drawn: 6 dangling of 1662 ends; then 3, in one scene
  // (trial 14) where two tripoints of one owner triple lie a fraction of a cell apart and the
  // search from the square's centre found only the first. Searched from the crossings too: none.
  EXPECT_EQ(dangling, 0);
}

TEST(Deliverables, SameResultForAnyThreadCount) {
  const SeedSet s = test::random_points(40, 0, 0, 60, 50, 77);
  Fixture st(s, grid(60, 50));
  BoundaryOptions one, two;
  one.threads = 1;
  two.threads = 2;
  const BoundaryResult a = extract_boundaries(st.field, st.index, one), b = extract_boundaries(st.field, st.index, two);
  ASSERT_EQ(a.lines.size(), b.lines.size());
  for (size_t i = 0; i < a.lines.size(); ++i) {
    ASSERT_EQ(a.lines[i].vertices.size(), b.lines[i].vertices.size());
    for (size_t k = 0; k < a.lines[i].vertices.size(); ++k)
      ASSERT_EQ(a.lines[i].vertices[k].p, b.lines[i].vertices[k].p);
  }
  ASSERT_EQ(a.tripoints.size(), b.tripoints.size());
  const std::vector<double> d{4.0};
  LimitOptions l1, l2;
  l1.threads = 1;
  l2.threads = 2;
  EXPECT_EQ(extract_limits(st.field, st.index, d, l1).vertices, extract_limits(st.field, st.index, d, l2).vertices);
  EXPECT_EQ(margin_raster(st.field, st.index, 1).cells(), margin_raster(st.field, st.index, 2).cells());
}

TEST(Deliverables, LimitLinesAtTheRequestedDistance) {
  const SeedSet s = points({{20.3, 20.6}});
  Fixture st(s, grid(40, 40));
  const std::vector<double> d{10.0};
  const LimitResult r = extract_limits(st.field, st.index, d);
  ASSERT_EQ(r.lines.size(), 1u);
  EXPECT_TRUE(r.lines[0].closed);
  for (const LimitVertex& v : r.lines[0].vertices) EXPECT_NEAR(std::hypot(v.p.x - 20.3, v.p.y - 20.6), 10.0, 1e-6);
  EXPECT_GT(r.lines[0].vertices.size(), 40u);

  // Random seeds, all owners and per owner.
  for (uint32_t trial = 0; trial < 6; ++trial) {
    SeedSet rs = test::random_points(12, -5, -5, 55, 45, 100 + trial);
    Fixture rt(rs, grid(50, 40));
    const std::vector<double> ds{3.0, 7.5};
    for (bool per_owner : {false, true}) {
      LimitOptions o;
      o.per_owner = per_owner;
      const LimitResult lr = extract_limits(rt.field, rt.index, ds, o);
      EXPECT_GT(lr.lines.size(), 0u);
      for (const LimitLine& line : lr.lines)
        for (const LimitVertex& v : line.vertices)
          ASSERT_NEAR(test::brute_owner_distance(rs, v.p, line.owner), line.distance, 1e-3);
    }
  }
  EXPECT_THROW(extract_limits(st.field, st.index, std::vector<double>{-1.0}), Error);
}

TEST(Deliverables, OtherOwnerFieldMatchesBruteForce) {
  for (uint32_t trial = 0; trial < 10; ++trial) {
    std::mt19937 rng(trial + 7);
    SeedSet s;
    std::uniform_real_distribution<double> ux(-10, 150), uy(-10, 110);
    const int owners = 1 + static_cast<int>(trial % 4);
    for (int i = 0; i < 40; ++i) {
      const int32_t f = s.add_feature(s.owner_code("o" + std::to_string(1 + (i * 7) % owners)));
      if (i % 4 == 0) {
        const Vec2 a{ux(rng), uy(rng)};
        const std::vector<Vec2> l{a, {a.x + 9, a.y + 3}};
        s.add_polyline(f, l);
      } else {
        s.add_point(f, {ux(rng), uy(rng)});
      }
    }
    const GridSpec g = grid(140, 100, 1.0);
    const NearestField own = exact(s, g);
    const NearestField other = compute_other_owner(s, own, 2);
    const auto local = to_local(s, g);
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        const int32_t o = s.site_owner(own.site.at(c, r));
        double best = std::numeric_limits<double>::infinity();
        int32_t best_id = kNoSite;
        for (int32_t i = 0; i < static_cast<int32_t>(s.sites().size()); ++i) {
          if (s.site_owner(i) == o) continue;
          const double k = planar_key(g.local_x(c), g.local_y(r), local[i]);
          if (k < best) {
            best = k;
            best_id = i;
          }
        }
        ASSERT_EQ(other.site.at(c, r), best_id) << "trial " << trial << " cell " << c << "," << r;
        if (best_id != kNoSite) {
          ASSERT_EQ(other.distance.at(c, r), static_cast<float>(std::sqrt(best)));
        }
      }
  }
}

TEST(Deliverables, MarginMatchesBruteForce) {
  for (uint32_t trial = 0; trial < 8; ++trial) {
    std::mt19937 rng(trial + 50);
    std::uniform_real_distribution<double> ux(0, 60), uy(0, 40);
    SeedSet s;
    for (int i = 0; i < 12; ++i) {
      const int32_t f = s.add_feature(s.owner_code("o" + std::to_string(1 + i % 3)));
      if (i == 4) {
        const double x = ux(rng), y = uy(rng);
        s.add_polygon(f, {{{x, y}, {x + 6, y}, {x + 6, y + 5}, {x, y + 5}}});
      } else {
        s.add_point(f, {ux(rng), uy(rng)});
      }
    }
    Fixture st(s, grid(60, 40));
    const Raster<float> m = margin_raster(st.field, st.index, 2);
    for (int64_t r = 0; r < 40; ++r)
      for (int64_t c = 0; c < 60; ++c) {
        const Vec2 p{st.g.centre_x(c), st.g.centre_y(r)};
        const int32_t o = s.site_owner(st.field.site.at(c, r));
        double other = std::numeric_limits<double>::infinity();
        for (int32_t k = 1; k <= s.owner_count(); ++k)
          if (k != o) other = std::min(other, test::brute_owner_distance(s, p, k));
        const double expect = other - test::brute_owner_distance(s, p, o);
        ASSERT_NEAR(m.at(c, r), expect, 1e-4 * std::max(1.0, expect)) << "cell " << c << "," << r;
        ASSERT_GE(m.at(c, r), 0.0f);
      }
  }
  // Overlapping polygons of two owners (contested cells): margin 0 inside the overlap.
  {
    SeedSet s;
    s.add_polygon(s.add_feature(s.owner_code("A")), {{{2, 2}, {14, 2}, {14, 12}, {2, 12}}});
    s.add_polygon(s.add_feature(s.owner_code("B")), {{{10, 6}, {24, 6}, {24, 18}, {10, 18}}});
    Fixture st(s, grid(30, 20));
    ASSERT_GT(st.field.contested_cells, 0);
    const Raster<float> m = margin_raster(st.field, st.index, 2);
    for (int64_t r = 0; r < 20; ++r)
      for (int64_t c = 0; c < 30; ++c) {
        const Vec2 p{st.g.centre_x(c), st.g.centre_y(r)};
        const double da = test::brute_owner_distance(s, p, 1), db = test::brute_owner_distance(s, p, 2);
        const int32_t o = s.site_owner(st.field.site.at(c, r));
        const double expect = o == 1 ? db - da : da - db;
        ASSERT_NEAR(m.at(c, r), expect, 1e-4) << "cell " << c << "," << r;
      }
  }
  // One owner: no margin anywhere.
  const SeedSet one = points({{3, 3}});
  Fixture st(one, grid(10, 10));
  const Raster<float> none = margin_raster(st.field, st.index);
  for (float v : none.cells()) EXPECT_EQ(v, kNoDistance);
}

TEST(Deliverables, SimplifyKeepsEndsAndDropsOnlyCloseVertices) {
  std::vector<Vec2> pts;
  for (int i = 0; i <= 100; ++i) pts.push_back({i * 0.1, std::sin(i * 0.1)});
  for (double tol : {0.0, 1e-3, 0.05, 0.5}) {
    const auto keep = simplify_indices(pts, tol);
    ASSERT_EQ(keep.front(), 0u);
    ASSERT_EQ(keep.back(), 100u);
    if (tol == 0.0) {
      EXPECT_EQ(keep.size(), pts.size());
    }
    for (size_t k = 1; k < keep.size(); ++k)
      for (size_t i = keep[k - 1] + 1; i < keep[k]; ++i)
        EXPECT_LE(test::segment_distance(pts[i], pts[keep[k - 1]], pts[keep[k]]), tol + 1e-12);
  }
}

TEST(Deliverables, OwnerIndexMatchesBruteForce) {
  SeedSet s = test::random_points(200, 0, 0, 100, 100, 9);
  PlanarSiteMetric metric(s, Vec2{0, 100});
  OwnerIndex index(metric);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-20, 120);
  for (int i = 0; i < 500; ++i) {
    const Vec2 p{u(rng), u(rng)};
    const int32_t o = 1 + static_cast<int32_t>(rng() % 200);
    EXPECT_DOUBLE_EQ(index.nearest_of(p, o).distance, test::brute_owner_distance(s, p, o));
    EXPECT_NEAR(index.nearest(p).distance, test::brute_owner_distance(s, p, 0), 1e-12);
    double other = std::numeric_limits<double>::infinity();
    for (int32_t k = 1; k <= 200; ++k)
      if (k != o) other = std::min(other, test::brute_owner_distance(s, p, k));
    EXPECT_NEAR(index.nearest_not_of(p, o).distance, other, 1e-12);
  }
}

TEST(Deliverables, DegenerateTripointsArePlacedAndEveryLineEndsAtOne) {
  // Randomised degenerate cases on a 60 x 60 grid: 4-6 cocircular basepoints of as many owners
  // (every triple meets at the centre), four owners meeting at a point (a square of points), a
  // tripoint within a cell of the grid's edge or outside it, two tripoints within a cell of
  // each other. No tripoint may be left unplaced, and every line that is not closed ends at a
  // tripoint or at the outermost cell centres.
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  constexpr double kTau = 6.283185307179586;
  const GridSpec g = test::grid_of(60, 60);
  int64_t tripoints = 0;
  for (int trial = 0; trial < 160; ++trial) {
    SeedSet s;
    auto add = [&](int k, Vec2 p) { s.add_point(s.add_feature(s.owner_code(std::to_string(k))), p); };
    switch (trial % 4) {
      case 0: {  // cocircular, the centre on a cell centre or a grid corner
        const int n = 4 + trial % 3;
        const double cx = 20 + std::floor(u(rng) * 20) + (trial % 8 < 4 ? 0.5 : 0.0);
        const double cy = 20 + std::floor(u(rng) * 20) + (trial % 16 < 8 ? 0.5 : 0.0);
        const double radius = 5 + 10 * u(rng), phase = u(rng);
        for (int k = 0; k < n; ++k)
          add(k, {cx + radius * std::cos(phase + kTau * k / n), cy + radius * std::sin(phase + kTau * k / n)});
        break;
      }
      case 1: {  // four owners meeting at one point
        const double cx = 15 + std::floor(u(rng) * 30) + 0.5 * (trial % 2);
        const double cy = 15 + std::floor(u(rng) * 30) + 0.5 * ((trial / 2) % 2), d = 3 + std::floor(u(rng) * 8);
        int k = 0;
        for (int i : {-1, 1})
          for (int j : {-1, 1}) add(k++, {cx + i * d, cy + j * d});
        break;
      }
      case 2:  // the tripoint near or beyond the grid's bottom edge
        add(0, {10 + 30 * u(rng), -5 - 10 * u(rng)});
        add(1, {30 + 20 * u(rng), 10 + 20 * u(rng)});
        add(2, {20 * u(rng), 10 + 20 * u(rng)});
        break;
      default: {  // two tripoints within a cell: four points nearly cocircular
        const double radius = 8 + 5 * u(rng), eps = 0.3 * u(rng);
        const double angle[4] = {0.3, 1.9, 3.4, 4.9};
        for (int k = 0; k < 4; ++k)
          add(k, {30 + (radius + (k == 0 ? eps : 0)) * std::cos(angle[k]),
                  30 + (radius + (k == 0 ? eps : 0)) * std::sin(angle[k])});
      }
    }
    const NearestField f = compute(s, g, ComputeOptions{});
    const PlanarSiteMetric m(s, Vec2{0.0, 60.0});
    const OwnerIndex index(m);
    const BoundaryResult b = extract_boundaries(f, index);
    EXPECT_EQ(b.stats.unresolved_tripoints, 0) << "trial " << trial;
    EXPECT_EQ(b.stats.unresolved_slivers, 0) << "trial " << trial;
    tripoints += static_cast<int64_t>(b.tripoints.size());
    for (const BoundaryLine& line : b.lines) {
      if (line.closed) continue;
      for (const BoundaryVertex* v : {&line.vertices.front(), &line.vertices.back()}) {
        bool ends = v->p.x <= 0.5 + 1e-9 || v->p.x >= 59.5 - 1e-9 || v->p.y <= 0.5 + 1e-9 || v->p.y >= 59.5 - 1e-9;
        for (const Tripoint& t : b.tripoints) ends = ends || std::hypot(t.p.x - v->p.x, t.p.y - v->p.y) < 1e-6;
        EXPECT_TRUE(ends) << "trial " << trial << ": a line ends at (" << v->p.x << ", " << v->p.y << ")";
      }
    }
  }
  EXPECT_GT(tripoints, 300);
}

TEST(Deliverables, CandidatesAroundAPolygonsEdgeAreFewAndExact) {
  // A land border: owner A's polygon (its area site is at distance 0 inside, infinite outside)
  // beside owner B's many points. Gathered from A's area site as the hint just outside the
  // polygon, the candidates are A's edges near there, not all of A's sites, and serve exactly.
  SeedSet s;
  const int32_t a = s.add_feature(s.owner_code("A"));
  std::vector<Vec2> ring;
  for (int k = 0; k < 40; ++k) {
    const double w = 2.0 * 3.14159265358979323846 * k / 40.0;
    ring.push_back({50.0 + 30.0 * std::cos(w), 50.0 + 30.0 * std::sin(w)});
  }
  s.add_polygon(a, {ring});
  const int32_t b = s.owner_code("B");
  for (int k = 0; k < 30; ++k) s.add_point(s.add_feature(b), {100.0 + k, 10.0 + 3.0 * k});
  const PlanarSiteMetric m(s, Vec2{0.0, 100.0});
  const OwnerIndex index(m);
  int32_t area = kNoSite, a_sites = 0;
  for (int32_t i = 0; i < static_cast<int32_t>(s.sites().size()); ++i) {
    if (s.site_owner(i) != 1) continue;
    ++a_sites;
    if (s.sites()[static_cast<size_t>(i)].kind == SiteKind::area) area = i;
  }
  ASSERT_NE(area, kNoSite);
  const Vec2 mid{81.0, 50.5};  // just outside the ring's east side
  std::vector<int32_t> cands;
  index.candidates_of(mid, 0.6, 1, area, cands);
  EXPECT_LT(static_cast<int32_t>(cands.size()), a_sites / 4);
  for (double t = -1.0; t <= 1.0; t += 0.25) {
    const Vec2 q{mid.x + 0.5 * t, mid.y + 0.3 * t};
    EXPECT_EQ(index.nearest_among(q, cands).site, index.nearest_of(q, 1).site) << t;
    EXPECT_EQ(index.nearest_among(q, cands).distance, index.nearest_of(q, 1).distance) << t;
  }
}

TEST(Deliverables, OwnerIndexAgreesWithBruteForceAlongACoast) {
  // A coast of short edges (a convex arc of 0.005 degree steps, ~400 m, whose vertices control
  // most of the sea: every query there ties two edges at one vertex) and a second owner's
  // points, geodesic and planar. The searches measure a site only where the metric's lower
  // bound allows; every hit must still be the brute-force one (lowest index among exact ties),
  // and every bound must be at most the distance -- geodesic ones within millimetres of it
  // near the coast, or they would prune nothing.
  SeedSet s;
  std::vector<Vec2> coast;
  for (int k = 0; k <= 120; ++k) {
    const double w = 0.6 * k / 120.0;
    coast.push_back({12.0 + 0.3 * std::sin(w), 55.0 + 0.3 * std::cos(w)});
  }
  s.add_polyline(s.add_feature(s.owner_code("A")), coast);
  const int32_t b = s.owner_code("B");
  for (int k = 0; k < 8; ++k) s.add_point(s.add_feature(b), {12.4 + 0.02 * k, 55.5 - 0.06 * k});
  const BothMetrics metrics(s, Vec2{12.0, 55.5});
  const GeodesicSiteMetric& gm = metrics.geodesic;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> lon(12.05, 12.6), lat(55.0, 55.5);
  const auto sites = static_cast<int32_t>(s.sites().size());
  for (const SiteMetric* m : metrics.all()) {
    const OwnerIndex index(*m);
    int tight = 0;
    for (int i = 0; i < 300; ++i) {
      const Vec2 p{lon(rng), lat(rng)};
      std::vector<OwnerIndex::Hit> brute(3);  // [owner]; [0]: any owner
      std::vector<int32_t> all_a;
      for (int32_t id = 0; id < sites; ++id) {
        const double d = m->distance(p, id), lb = m->distance_lower_bound(p, id);
        ASSERT_LE(lb, d) << "site " << id;
        if (m == &gm && d - lb < 0.003) ++tight;
        const int32_t o = s.site_owner(id);
        if (o == 1) all_a.push_back(id);
        for (const int32_t slot : {0, o}) {
          if (d < brute[slot].distance) brute[slot] = OwnerIndex::Hit{id, d};
        }
      }
      for (int32_t o = 1; o <= 2; ++o) {
        EXPECT_EQ(index.nearest_of(p, o).site, brute[o].site) << "owner " << o;
        EXPECT_EQ(index.nearest_of(p, o).distance, brute[o].distance);
      }
      EXPECT_EQ(index.nearest_among(p, all_a).site, brute[1].site);
      EXPECT_EQ(index.nearest_among(p, all_a).distance, brute[1].distance);
      EXPECT_EQ(index.nearest(p).site, brute[0].site);
      // Known hits of either owner, as the boundaries' third-owner test passes them.
      EXPECT_EQ(index.nearest_not_of(p, 1, brute[2]).site, brute[2].site);
      EXPECT_EQ(index.nearest_not_of(p, 2, brute[1]).site, brute[1].site);
      // Candidates for a cell edge from p, bounded as the lines bound them without measuring
      // (p's nearest distance, as a Float32 field holds it, plus the way to the edge's middle):
      // they serve every position of the edge.
      const Vec2 q1{p.x + 0.0005, p.y}, mid{p.x + 0.00025, p.y};
      const double reach = 1.01 * m->point_distance(mid, p) + 1e-9;
      for (const int32_t o : {0, 1}) {
        const double at_p = static_cast<float>(brute[o].distance);
        std::vector<int32_t> cands;
        if (o == 1)
          index.candidates_of(mid, reach, 1, kNoSite, cands, at_p * (1.0 + 1e-6) + reach);
        else
          index.candidates_not_of(mid, reach, 0, OwnerIndex::Hit{}, cands, at_p * (1.0 + 1e-6) + reach);
        for (double t = 0.0; t <= 1.0; t += 0.25) {
          const Vec2 q{p.x + t * (q1.x - p.x), p.y};
          const OwnerIndex::Hit want = o == 1 ? index.nearest_of(q, 1) : index.nearest(q);
          const OwnerIndex::Hit got = index.nearest_among(q, cands);
          ASSERT_EQ(got.site, want.site) << "owner " << o << " t " << t;
          ASSERT_EQ(got.distance, want.distance);
        }
      }
    }
    if (m == &gm) {
      EXPECT_GT(tight, 300);  // at least one tight bound per query, on average
    }
  }
}

TEST(Deliverables, GradientsAreTheDistancesSlopes) {
  // Points and edges (short and 300 km long, several pieces), geodesic and planar: the distance
  // that comes with a gradient is distance()'s, to the bit, and the gradient is the slope of
  // the distance (central differences over 1e-6 degrees, ~0.1 m, agree to 1e-6 of the slope's
  // size); on the site, and for areas, there is none. The nearest point is on the site, at the
  // distance (to a micrometre).
  SeedSet s;
  const int32_t f = s.add_feature(s.owner_code("A"));
  s.add_point(f, {12.0, 55.0});
  s.add_polyline(f, std::vector<Vec2>{{12.2, 55.1}, {12.205, 55.102}, {12.4, 55.3}, {15.0, 57.0}});
  s.add_polygon(s.add_feature(s.owner_code("B")), {{{10.0, 54.0}, {10.5, 54.0}, {10.5, 54.4}, {10.0, 54.4}}});
  const BothMetrics metrics(s, Vec2{12.0, 56.0});
  const GeodesicSiteMetric& gm = metrics.geodesic;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> lon(10.8, 14.0), lat(54.5, 56.8);
  const auto sites = static_cast<int32_t>(s.sites().size());
  for (const SiteMetric* m : metrics.all()) {
    for (int i = 0; i < 200; ++i) {
      const Vec2 p{lon(rng), lat(rng)};
      for (int32_t id = 0; id < sites; ++id) {
        Vec2 g;
        const double d = m->distance_and_gradient(p, id, g);
        ASSERT_EQ(d, m->distance(p, id)) << "site " << id;
        if (s.sites()[static_cast<size_t>(id)].kind == SiteKind::area) {
          EXPECT_TRUE(std::isnan(g.x) && std::isnan(g.y));
          continue;
        }
        // The site's nearest point (the basepoint reports give) is on the site, at the distance,
        // and inside an edge the geodesic to p leaves it square (to 1e-9 of a right angle).
        const Vec2 foot = m->nearest_point(p, id);
        EXPECT_NEAR(m->point_distance(p, foot), d, 1e-6) << "site " << id;
        EXPECT_LT(m->distance(foot, id), 1e-6) << "site " << id;
        const Site& site = s.sites()[static_cast<size_t>(id)];
        if (m == &gm && site.kind == SiteKind::segment && !(foot == site.a) && !(foot == site.b)) {
          const GeographicLib::Geodesic& wgs = GeographicLib::Geodesic::WGS84();
          double along = 0.0, to_p = 0.0, ignored = 0.0;
          wgs.Inverse(site.a.y, site.a.x, foot.y, foot.x, ignored, ignored, along);
          wgs.Inverse(foot.y, foot.x, p.y, p.x, ignored, to_p, ignored);
          EXPECT_LT(std::abs(std::cos((to_p - along) * std::numbers::pi / 180.0)), 1e-9) << "site " << id;
        }
        const double h = 1e-6;
        const double dx = (m->distance({p.x + h, p.y}, id) - m->distance({p.x - h, p.y}, id)) / (2 * h);
        const double dy = (m->distance({p.x, p.y + h}, id) - m->distance({p.x, p.y - h}, id)) / (2 * h);
        const double size = std::hypot(dx, dy);
        EXPECT_NEAR(g.x, dx, 1e-6 * size) << "site " << id << " at " << p.x << " " << p.y;
        EXPECT_NEAR(g.y, dy, 1e-6 * size) << "site " << id;
      }
    }
    Vec2 g;
    EXPECT_EQ(m->distance_and_gradient({12.0, 55.0}, 0, g), 0.0);
    EXPECT_TRUE(std::isnan(g.x) && std::isnan(g.y));
  }
}

TEST(Deliverables, OwnerIndexHintsChangeNoResult) {
  // Owners of 5 sites each (ties included: two sites at one place), geodesic and planar: any
  // hint -- the right site, another of the owner, one of another owner, none -- and any known
  // hit give the very hit of the plain query.
  SeedSet s;
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> lon(11.0, 13.0), lat(54.5, 56.0);
  for (int o = 0; o < 6; ++o) {
    const int32_t code = s.owner_code(std::to_string(o));
    for (int k = 0; k < 5; ++k) {
      const Vec2 a{lon(rng), lat(rng)};
      const int32_t f = s.add_feature(code);
      if (k == 4) {
        s.add_point(f, s.sites().back().a);  // a tie with the previous site
      } else if (k % 2 == 0) {
        s.add_point(f, a);
      } else {
        const std::vector<Vec2> line{a, {a.x + 0.1, a.y + 0.05}};
        s.add_polyline(f, line);
      }
    }
  }
  const BothMetrics metrics(s, Vec2{11.0, 56.0});
  for (const SiteMetric* m : metrics.all()) {
    const OwnerIndex index(*m);
    const auto sites = static_cast<int32_t>(s.sites().size());
    for (int i = 0; i < 60; ++i) {
      const Vec2 p{lon(rng), lat(rng)};
      for (int32_t o = 1; o <= s.owner_count(); ++o) {
        const OwnerIndex::Hit plain = index.nearest_of(p, o);
        for (int32_t hint = -1; hint < sites; ++hint) {
          const OwnerIndex::Hit h = index.nearest_of(p, o, hint);
          ASSERT_EQ(h.site, plain.site) << "owner " << o << " hint " << hint;
          ASSERT_EQ(h.distance, plain.distance);
        }
      }
      // Candidates gathered for a short path around p (a few hundred metres) serve every point
      // of it: nearest_among over them is nearest_of, whatever hint bounded the gathering.
      const double step = 0.004;  // degrees (planar: units of the same size)
      for (int32_t o = 1; o <= s.owner_count(); ++o)
        for (const int32_t hint : {static_cast<int32_t>(kNoSite), static_cast<int32_t>(5 * (o - 1)),
                                   static_cast<int32_t>(5 * (o - 1) + 2)}) {
          const Vec2 a{p.x - step, p.y - 0.5 * step}, b{p.x + step, p.y + 0.5 * step};
          const Vec2 mid{0.5 * (a.x + b.x), 0.5 * (a.y + b.y)};
          const double reach = 1.01 * std::max(m->point_distance(mid, a), m->point_distance(mid, b)) + 1e-9;
          std::vector<int32_t> cands;
          index.candidates_of(mid, reach, o, hint, cands);
          ASSERT_FALSE(cands.empty());
          for (double t = 0.0; t <= 1.0; t += 0.125) {
            const Vec2 q{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
            const OwnerIndex::Hit want = index.nearest_of(q, o), got = index.nearest_among(q, cands);
            ASSERT_EQ(got.site, want.site) << "owner " << o << " hint " << hint << " t " << t;
            ASSERT_EQ(got.distance, want.distance);
          }
        }
      // The same for the sites of every owner but one (0: all owners), from a known hit or none.
      for (int32_t not_of = 0; not_of <= s.owner_count(); ++not_of) {
        const Vec2 a{p.x - step, p.y + 0.5 * step}, b{p.x + step, p.y - 0.5 * step};
        const Vec2 mid{0.5 * (a.x + b.x), 0.5 * (a.y + b.y)};
        const double reach = 1.01 * std::max(m->point_distance(mid, a), m->point_distance(mid, b)) + 1e-9;
        for (const bool with_known : {false, true}) {
          const int32_t k = (not_of * 7) % sites;
          OwnerIndex::Hit known;
          if (with_known && s.site_owner(k) != not_of) known = OwnerIndex::Hit{k, m->distance(mid, k)};
          std::vector<int32_t> cands;
          index.candidates_not_of(mid, reach, not_of, known, cands);
          for (double t = 0.0; t <= 1.0; t += 0.125) {
            const Vec2 q{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
            const OwnerIndex::Hit want = index.nearest_not_of(q, not_of), got = index.nearest_among(q, cands);
            ASSERT_EQ(got.site, want.site) << "not of " << not_of << " t " << t;
            ASSERT_EQ(got.distance, want.distance);
          }
        }
      }
      const OwnerIndex::Hit plain = index.nearest(p);
      for (int32_t known = 0; known < sites; ++known) {
        const OwnerIndex::Hit h = index.nearest(p, OwnerIndex::Hit{known, m->distance(p, known)});
        ASSERT_EQ(h.site, plain.site) << "known " << known;
        ASSERT_EQ(h.distance, plain.distance);
        const int32_t not_of = s.site_owner(known);
        const OwnerIndex::Hit other = index.nearest_not_of(p, not_of);
        // A known hit of the excluded owner is ignored.
        EXPECT_EQ(index.nearest_not_of(p, not_of, OwnerIndex::Hit{known, m->distance(p, known)}).site, other.site);
      }
      // A third owner's nearest (the owners other than a and b), within a distance or not at all.
      for (int32_t a = 1; a <= s.owner_count(); ++a)
        for (int32_t b = a + 1; b <= s.owner_count(); ++b) {
          OwnerIndex::Hit brute;
          for (int32_t id = 0; id < sites; ++id) {
            if (s.site_owner(id) == a || s.site_owner(id) == b) continue;
            const double d = m->distance(p, id);
            if (d < brute.distance) brute = OwnerIndex::Hit{id, d};
          }
          const OwnerIndex::Hit any = index.nearest_third(p, a, b, std::numeric_limits<double>::infinity());
          EXPECT_EQ(any.site, brute.site) << a << " " << b;
          EXPECT_EQ(any.distance, brute.distance);
          EXPECT_EQ(index.nearest_third(p, b, a, brute.distance).site, brute.site);  // ties count
          EXPECT_EQ(index.nearest_third(p, a, b, 0.999 * brute.distance).site, kNoSite);
        }
    }
  }
}

}  // namespace
}  // namespace rv
