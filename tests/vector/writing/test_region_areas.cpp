// Regions' areas follow the exact loci, not the chords between their vertices: discs and lenses
// with a closed form measured on coarse grids within 1e-9 of it (region_edges with a line
// tolerance, ring_area with the segments' bows, polygons made by write_line_regions).
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/PolygonArea.hpp>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/gdal/vector_writer.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/regions.hpp"
#include "rv/lines/strip_lines.hpp"

namespace rv {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = std::numbers::pi;

GridSpec grid(double res, double x0, double y0, double w, double h) {
  GridSpec g;
  g.xmin = x0;
  g.ymax = y0 + h;
  g.res = res;
  g.width = static_cast<int64_t>(std::llround(w / res));
  g.height = static_cast<int64_t>(std::llround(h / res));
  return g;
}

// Each owner's region area as the service measures it: boundaries, the owned area's edge where
// reaches end it, region edges followed to `tol`, polygons, ring areas with the bows (or, with
// `bows` false, the chords alone).
std::vector<double> region_areas(const SeedSet& seeds, const GridSpec& g, const MetricSpec& m, double tol,
                                 bool bows = true) {
  ComputeOptions o;
  o.threads = 2;
  o.metric = m;
  const NearestField field = compute(seeds, g, o);
  std::unique_ptr<SiteMetric> metric;
  if (m.kind == MetricSpec::geodesic)
    metric = std::make_unique<GeodesicSiteMetric>(seeds, m);
  else
    metric = std::make_unique<PlanarSiteMetric>(seeds, Vec2{g.xmin, g.ymax});
  const OwnerIndex index(*metric);
  BoundaryOptions bo;
  bo.line_tolerance = tol;
  LineRequest r;
  r.boundaries = true;
  r.boundary = bo;
  r.owned_edge = seeds.adjusted();
  r.limit.line_tolerance = 0.0;
  StripLines lines(g, index, r);
  lines.add(field);
  const LimitResult edge = seeds.adjusted() ? lines.take_limits() : LimitResult{};
  const BoundaryResult b = lines.take_boundaries();
  RegionEdges e = region_edges(b, index, g, kInf, seeds.adjusted() ? &edge : nullptr, nullptr, tol);
  EXPECT_EQ(e.dangling_ends, 0);
  EXPECT_EQ(e.residual.unresolved, 0);
  EXPECT_LE(e.residual.max_midpoint, tol);
  const SegmentBows segment_bows = bows ? SegmentBows(e) : SegmentBows();
  LineRegions lr;
  lr.edges = std::move(e.edges);
  lr.grid = g;
  lr.owner_of = [&](Vec2 p) { return owner_at(index, p); };
  lr.area = [&](std::span<const Vec2> ring) { return ring_area(ring, m, nullptr, g.res, segment_bows); };
  lr.area_units = "m^2";
  const RegionStats st = write_line_regions("", lr, seeds, seeds.polygons(), {});
  std::vector<double> areas(static_cast<size_t>(seeds.owner_count()) + 1, 0.0);
  for (const RegionStats::OwnerArea& a : st.areas) areas[static_cast<size_t>(a.owner)] = a.area;
  return areas;
}

// Two islands with reaches of 20 km, 30 km apart: each region is its disc less the circular
// segment beyond the bisector, pi R^2 - (R^2 acos(h / R) - h sqrt(R^2 - h^2)), h = 15 km.
TEST(RegionAreas, TheReachLensOnAOneKilometreGrid) {
  SeedSet s;
  for (const double x : {500000.0, 530000.0}) {
    const int32_t f = s.add_feature(s.owner_code(x < 510000.0 ? "A" : "B"));
    s.add_point(f, Vec2{x, 5500000.0});
    s.set_adjustment(f, 1.0, 20000.0);
  }
  const double R = 20000.0, h = 15000.0;
  const double exact = kPi * R * R - (R * R * std::acos(h / R) - h * std::sqrt(R * R - h * h));
  const GridSpec g = grid(1000.0, 470000.0, 5470000.0, 90000.0, 60000.0);
  const std::vector<double> areas = region_areas(s, g, MetricSpec{}, 1e-3);
  EXPECT_NEAR(areas[1], exact, 1e-9 * exact);
  EXPECT_NEAR(areas[2], exact, 1e-9 * exact);
  // The chords alone, within a millimetre of the arc everywhere, fall short by a share of the
  // tolerance times the perimeter: tens of square metres, over ten times the bound.
  const std::vector<double> chords = region_areas(s, g, MetricSpec{}, 1e-3, false);
  EXPECT_GT(std::abs(chords[1] - exact), 10.0 * 1e-9 * exact);
}

// Two basepoints weighted 3 : 1, 40 km apart, on a 1 km grid: B's region is the Apollonius disc
// |p - A| = 3 |p - B|, radius 15 km.
TEST(RegionAreas, TheWeightedApolloniusDisc) {
  SeedSet s;
  const int32_t fa = s.add_feature(s.owner_code("A"));
  s.add_point(fa, Vec2{0.0, 0.0});
  s.set_adjustment(fa, 3.0, kInf);
  s.add_point(s.add_feature(s.owner_code("B")), Vec2{40000.0, 0.0});
  const double R = 15000.0, exact = kPi * R * R;
  const std::vector<double> areas =
      region_areas(s, grid(1000.0, 20000.0, -25000.0, 50000.0, 50000.0), MetricSpec{}, 1e-3);
  EXPECT_NEAR(areas[2], exact, 1e-9 * exact);
}

// On the ellipsoid: an island at 50 N with a reach of 12 nmi on a 0.01 degree grid; the
// reference is GeographicLib's area of the geodesic circle traced by a million points.
TEST(RegionAreas, A12NmiDiscOnTheEllipsoid) {
  SeedSet s;
  const int32_t f = s.add_feature(s.owner_code("I"));
  s.add_point(f, Vec2{0.0, 50.0});
  s.set_adjustment(f, 1.0, 22224.0);
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  GeographicLib::PolygonArea circle(geod);
  constexpr int kPoints = 1000000;
  for (int i = 0; i < kPoints; ++i) {
    double lat = 0.0, lon = 0.0;
    geod.Direct(50.0, 0.0, 360.0 * i / kPoints, 22224.0, lat, lon);
    circle.AddPoint(lat, lon);
  }
  double perimeter = 0.0, exact = 0.0;
  circle.Compute(false, true, perimeter, exact);
  exact = std::abs(exact);
  MetricSpec m;
  m.kind = MetricSpec::geodesic;
  const std::vector<double> areas = region_areas(s, grid(0.01, -0.5, 49.7, 1.0, 0.6), m, 1e-3);
  EXPECT_NEAR(areas[1], exact, 1e-9 * exact);
}

}  // namespace
}  // namespace rv
