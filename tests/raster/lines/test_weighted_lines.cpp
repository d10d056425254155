// Boundaries, tripoints and limits of weighted seeds (Feature::weight): the locus
// d_a / w_a = d_b / w_b against analytic references (the Apollonius circle in the plane, the
// geodesic ratio on the ellipsoid through GeographicLib), tripoints where three costs agree, and
// distance limits that keep measuring true distances.
#include <gtest/gtest.h>
#include <GeographicLib/Geodesic.hpp>

#include <cmath>
#include <numbers>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/regions.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

SeedSet weighted_points(const std::vector<Vec2>& points, const std::vector<double>& weights) {
  SeedSet s;
  for (size_t i = 0; i < points.size(); ++i) {
    const int32_t f = s.add_feature(s.owner_code(std::string(1, static_cast<char>('A' + i))));
    s.add_point(f, points[i]);
    s.set_adjustment(f, weights[i], kInf);
  }
  return s;
}

// Two basepoints 100 km apart in UTM metres, weights 3 : 1, on a 1 km grid: the boundary is one
// closed ring, the circle d_A = 3 d_B (centre 112.5 km from A on the axis, radius 37.5 km), and
// B's region inside it has the disc's area, pi 37.5^2 = 4,417.86 km^2.
TEST(WeightedLines, TheApolloniusCircleToTheMillimetre) {
  const Vec2 a{500000.0, 6000000.0}, b{600000.0, 6000000.0}, centre{612500.0, 6000000.0};
  const SeedSet s = weighted_points({a, b}, {3.0, 1.0});
  const GridSpec g = test::grid_of(100, 100, 1000.0, 560000.0, 6050000.0);
  const NearestField field = compute(s, g, ComputeOptions{});
  const PlanarSiteMetric metric(s, Vec2{g.xmin, g.ymax});
  const OwnerIndex index(metric);
  ASSERT_TRUE(index.adjusted());
  const BoundaryResult r = extract_boundaries(field, index);
  ASSERT_EQ(r.lines.size(), 1u);
  const BoundaryLine& line = r.lines[0];
  EXPECT_TRUE(line.closed);
  EXPECT_EQ(line.owner_a, 1);
  EXPECT_EQ(line.owner_b, 2);
  EXPECT_GT(line.vertices.size(), 250u);
  std::vector<Vec2> ring;
  for (const BoundaryVertex& v : line.vertices) {
    EXPECT_NEAR(std::hypot(v.p.x - centre.x, v.p.y - centre.y), 37500.0, 1e-3);
    EXPECT_NEAR(v.distance_a, std::hypot(v.p.x - a.x, v.p.y - a.y), 1e-6);
    EXPECT_NEAR(v.distance_b, std::hypot(v.p.x - b.x, v.p.y - b.y), 1e-6);
    EXPECT_NEAR(v.distance_a, 3.0 * v.distance_b, 3e-3);
    EXPECT_LT(v.residual, 1e-3);
    ring.push_back(v.p);
  }
  const double area = ring_area(ring, MetricSpec{}, nullptr, 0.0);
  const double disc = std::numbers::pi * 37500.0 * 37500.0;
  EXPECT_NEAR(area / disc, 1.0, 1e-4) << area * 1e-6 << " km^2 for " << disc * 1e-6;
  // The owner of a position follows the same rule.
  EXPECT_EQ(owner_at(index, centre), 2);
  EXPECT_EQ(owner_at(index, Vec2{centre.x + 37600.0, centre.y}), 1);
}

// Weights 2 : 1 on the ellipsoid: every vertex is twice as far from A as from B, as GeographicLib's
// inverse problem measures them, to a millimetre.
TEST(WeightedLines, GeodesicRatioOnTheEllipsoid) {
  const SeedSet s = weighted_points({{10.0, 55.0}, {10.4, 55.1}}, {2.0, 1.0});
  const GridSpec g = test::grid_of(120, 80, 0.01, 9.9, 55.5);
  ComputeOptions o;
  o.metric = MetricSpec{MetricSpec::geodesic};
  const NearestField field = compute(s, g, o);
  const GeodesicSiteMetric metric(s, o.metric);
  const OwnerIndex index(metric);
  const BoundaryResult r = extract_boundaries(field, index);
  ASSERT_FALSE(r.lines.empty());
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  int64_t n = 0;
  for (const BoundaryLine& line : r.lines)
    for (const BoundaryVertex& v : line.vertices) {
      double da = 0.0, db = 0.0;
      geod.Inverse(55.0, 10.0, v.p.y, v.p.x, da);
      geod.Inverse(55.1, 10.4, v.p.y, v.p.x, db);
      EXPECT_NEAR(da / 2.0, db, 1e-3) << v.p.x << ", " << v.p.y;
      ++n;
    }
  EXPECT_GT(n, 50);
}

// Three weighted owners: each tripoint has equal costs d / w to all three, and no other
// owner's cost is lower there.
TEST(WeightedLines, TripointsWhereThreeCostsAgree) {
  const std::vector<Vec2> p{{20.0, 30.0}, {70.0, 25.0}, {45.0, 75.0}};
  const std::vector<double> w{1.0, 1.2, 0.9};
  const SeedSet s = weighted_points(p, w);
  const GridSpec g = test::grid_of(100, 100, 1.0);
  const NearestField field = compute(s, g, ComputeOptions{});
  const PlanarSiteMetric metric(s, Vec2{g.xmin, g.ymax});
  const OwnerIndex index(metric);
  const BoundaryResult r = extract_boundaries(field, index);
  ASSERT_GE(r.tripoints.size(), 1u);
  EXPECT_EQ(r.stats.unresolved_tripoints, 0);
  for (const Tripoint& t : r.tripoints) {
    double c[3];
    for (int k = 0; k < 3; ++k)
      c[k] = std::hypot(t.p.x - p[static_cast<size_t>(k)].x, t.p.y - p[static_cast<size_t>(k)].y) /
             w[static_cast<size_t>(k)];
    EXPECT_NEAR(c[0], c[1], 1e-6);
    EXPECT_NEAR(c[0], c[2], 1e-6);
    EXPECT_NEAR(t.cost, c[0], 1e-6);
    EXPECT_LT(t.residual, 1e-6);
  }
}

// Distance limits measure true distances: a weighted job's limit lines are those of the same
// seeds unweighted, every vertex at distance D from the nearest seed.
TEST(WeightedLines, LimitsKeepTrueDistances) {
  const std::vector<Vec2> p{{20.0, 30.0}, {70.0, 25.0}, {45.0, 75.0}, {50.0, 50.0}};
  const SeedSet weighted = weighted_points(p, {1.0, 2.5, 0.5, 1.5});
  const SeedSet plain = weighted_points(p, {1.0, 1.0, 1.0, 1.0});
  const GridSpec g = test::grid_of(100, 100, 1.0);
  const std::vector<double> D{9.0, 17.5};
  for (const bool per_owner : {false, true}) {
    LimitOptions lo;
    lo.per_owner = per_owner;
    std::vector<LimitResult> results;
    for (const SeedSet* s : {&weighted, &plain}) {
      const NearestField field = compute(*s, g, ComputeOptions{});
      const PlanarSiteMetric metric(*s, Vec2{g.xmin, g.ymax});
      const OwnerIndex index(metric);
      results.push_back(extract_limits(field, index, D, lo));
    }
    ASSERT_EQ(results[0].lines.size(), results[1].lines.size());
    ASSERT_EQ(results[0].vertices, results[1].vertices);
    for (size_t i = 0; i < results[0].lines.size(); ++i) {
      const LimitLine& x = results[0].lines[i];
      const LimitLine& y = results[1].lines[i];
      ASSERT_EQ(x.vertices.size(), y.vertices.size());
      for (size_t k = 0; k < x.vertices.size(); ++k) {
        // The same level of the same distance; the roots started from other field values.
        EXPECT_NEAR(x.vertices[k].p.x, y.vertices[k].p.x, 1e-7);
        EXPECT_NEAR(x.vertices[k].p.y, y.vertices[k].p.y, 1e-7);
        double nearest = kInf;
        for (size_t j = 0; j < p.size(); ++j)
          if (x.owner == 0 || x.owner == static_cast<int32_t>(j) + 1)
            nearest = std::min(nearest, std::hypot(x.vertices[k].p.x - p[j].x, x.vertices[k].p.y - p[j].y));
        EXPECT_NEAR(nearest, x.distance, 1e-6);
      }
    }
  }
}

}  // namespace
}  // namespace rv
