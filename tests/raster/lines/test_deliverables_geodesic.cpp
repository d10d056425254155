// The deliverables on geodesic grids (longitude/latitude, WGS84): every vertex equidistant
// within 1 cm, measured with GeographicLib and the engines' GeodesicMeasure.
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/geodesic/geodesic.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/margin.hpp"

namespace rv {
namespace {

MetricSpec wgs84() {
  MetricSpec m;
  m.kind = MetricSpec::geodesic;
  return m;
}

GridSpec geo_grid(double xmin, double ymax, double res, int64_t w, int64_t h) {
  GridSpec g;
  g.xmin = xmin;
  g.ymax = ymax;
  g.res = res;
  g.width = w;
  g.height = h;
  return g;
}

NearestField exact(const SeedSet& s, const GridSpec& g) {
  ComputeOptions o;
  o.threads = 2;
  o.metric = wgs84();
  return compute(s, g, o);
}

// Brute-force geodesic distance to the nearest seed of `owner` (0: any), by the engines' measure.
double brute(const SeedSet& s, const GeodesicMeasure& m, Vec2 p, int32_t owner) {
  double best = std::numeric_limits<double>::infinity();
  for (const Site& site : s.sites()) {
    if (owner != 0 && s.features()[site.feature].owner != owner) continue;
    if (site.kind == SiteKind::point) best = std::min(best, m.point_distance(p, site.a));
    if (site.kind == SiteKind::segment) best = std::min(best, m.segment_distance(p, site.a, site.b));
  }
  return best;
}

SeedSet points(std::initializer_list<Vec2> pts) {
  SeedSet s;
  for (Vec2 p : pts) s.add_point(s.add_feature(s.owner_code("o" + std::to_string(s.features().size() + 1))), p);
  return s;
}

TEST(GeodesicDeliverables, TwoPointsBisectorWithinOneCentimetre) {
  // High latitude, where degrees and metres differ most.
  const SeedSet s = points({{10.13, 60.21}, {10.71, 60.48}});
  const GridSpec g = geo_grid(10.0, 60.6, 0.01, 90, 50);
  const NearestField f = exact(s, g);
  const GeodesicSiteMetric metric(s, wgs84());
  const OwnerIndex index(metric);
  const BoundaryResult b = extract_boundaries(f, index);
  ASSERT_EQ(b.lines.size(), 1u);
  const GeographicLib::Geodesic geod(kWgs84SemiMajor, kWgs84Flattening);
  for (const BoundaryVertex& v : b.lines[0].vertices) {
    double d1 = 0, d2 = 0;
    geod.Inverse(v.p.y, v.p.x, 60.21, 10.13, d1);
    geod.Inverse(v.p.y, v.p.x, 60.48, 10.71, d2);
    ASSERT_LE(std::abs(d1 - d2), 0.01);
  }
  EXPECT_GT(b.lines[0].vertices.size(), 40u);
}

// Two parallel lines on the ellipsoid: meridian arcs at 10.00E and 10.20E (55.0N .. 55.6N), each
// of 12 geodesic edges. By the ellipsoid's mirror symmetry in the meridian plane of 10.10E, the
// median line between them, where both are nearest at an edge's interior, is that meridian: every
// vertex there lies on 10.10E within a few millimetres and is equidistant within 1 cm.
TEST(GeodesicDeliverables, TwoParallelLinesGiveTheMedianMidway) {
  SeedSet s;
  std::vector<Vec2> west, east;
  for (int i = 0; i <= 12; ++i) {
    west.push_back({10.0, 55.0 + 0.05 * i});
    east.push_back({10.2, 55.0 + 0.05 * i});
  }
  s.add_polyline(s.add_feature(s.owner_code("west")), west);
  s.add_polyline(s.add_feature(s.owner_code("east")), east);
  const GridSpec g = geo_grid(9.95, 55.65, 0.004, 75, 175);  // 9.95E .. 10.25E, 55.65N .. 54.95N
  const NearestField f = exact(s, g);
  const GeodesicSiteMetric metric(s, wgs84());
  const OwnerIndex index(metric);
  const BoundaryResult b = extract_boundaries(f, index);
  ASSERT_EQ(b.lines.size(), 1u);
  const GeodesicMeasure m(wgs84());
  int64_t inside = 0;
  for (const BoundaryVertex& v : b.lines[0].vertices) {
    ASSERT_LE(std::abs(brute(s, m, v.p, 1) - brute(s, m, v.p, 2)), 0.01) << v.p.x << "," << v.p.y;
    if (v.p.y > 55.02 && v.p.y < 55.58) {
      // 1e-7 degrees of longitude is ~6 mm here.
      EXPECT_NEAR(v.p.x, 10.1, 1e-7) << v.p.y;
      ++inside;
    }
  }
  EXPECT_GT(inside, 100);
}

TEST(GeodesicDeliverables, TripointAndLimitsWithinOneCentimetre) {
  const SeedSet s = points({{3.1, 50.2}, {3.9, 50.35}, {3.4, 50.85}});
  const GridSpec g = geo_grid(2.9, 51.0, 0.01, 120, 100);
  const NearestField f = exact(s, g);
  const GeodesicSiteMetric metric(s, wgs84());
  const OwnerIndex index(metric);
  const GeodesicMeasure m(wgs84());
  const BoundaryResult b = extract_boundaries(f, index);
  ASSERT_EQ(b.tripoints.size(), 1u);
  const Tripoint& t = b.tripoints[0];
  const double d0 = brute(s, m, t.p, 1), d1 = brute(s, m, t.p, 2), d2 = brute(s, m, t.p, 3);
  EXPECT_LE(std::max({std::abs(d0 - d1), std::abs(d0 - d2), std::abs(d1 - d2)}), 0.01);
  for (const BoundaryLine& line : b.lines)
    for (const BoundaryVertex& v : line.vertices)
      ASSERT_LE(std::abs(brute(s, m, v.p, line.owner_a) - brute(s, m, v.p, line.owner_b)), 0.01);
  const std::vector<double> d{12 * 1852.0};
  const LimitResult lim = extract_limits(f, index, d);
  ASSERT_FALSE(lim.lines.empty());
  for (const LimitLine& line : lim.lines)
    for (const LimitVertex& v : line.vertices) ASSERT_NEAR(brute(s, m, v.p, 0), 12 * 1852.0, 0.01);
  // The margin on a geodesic grid (per-cell exact queries) against brute force, on a sample.
  const Raster<float> margin = margin_raster(f, index, 2);
  for (int64_t r = 0; r < g.height; r += 7)
    for (int64_t c = 0; c < g.width; c += 7) {
      const Vec2 p{g.centre_x(c), g.centre_y(r)};
      const int32_t o = s.site_owner(f.site.at(c, r));
      double other = std::numeric_limits<double>::infinity();
      for (int32_t k = 1; k <= 3; ++k)
        if (k != o) other = std::min(other, brute(s, m, p, k));
      ASSERT_NEAR(margin.at(c, r), other - brute(s, m, p, o), 0.05);
    }
}

}  // namespace
}  // namespace rv
