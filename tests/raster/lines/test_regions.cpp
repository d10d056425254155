// The core's part of regions (raster/src/lines/regions/regions.cpp): boundary lines carried to
// the grid's edge on the equidistance locus, the owner of a position by the engine's rule, and
// ring areas, planar (shoelace) and on the ellipsoid against the closed form for a
// longitude/latitude rectangle (zones of the authalic sphere).
#include <gtest/gtest.h>

#include <GeographicLib/Ellipsoid.hpp>
#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/PolygonArea.hpp>

#include <cmath>
#include <numbers>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/regions.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

TEST(Regions, LinesAreCarriedToTheGridsEdgeOnTheLocus) {
  const test::PointsField k({{20.3, 31.7}, {41.9, 12.4}, {52.2, 40.6}}, {"A", "B", "C"}, test::grid_of(60, 45));
  const BoundaryResult b = extract_boundaries(k.field, k.index);
  ASSERT_EQ(b.lines.size(), 3u);
  const RegionEdges re = region_edges(b, k.index, k.grid);
  EXPECT_EQ(re.dangling_ends, 0);
  const std::vector<std::vector<Vec2>>& edges = re.edges;
  ASSERT_EQ(edges.size(), b.lines.size());
  int on_edge = 0;
  for (size_t i = 0; i < edges.size(); ++i) {
    const BoundaryLine& line = b.lines[i];
    // One end at the tripoint (kept), the other carried one vertex further, onto the grid's edge.
    ASSERT_EQ(edges[i].size(), line.vertices.size() + 1);
    for (const Vec2 end : {edges[i].front(), edges[i].back()}) {
      const bool edge = end.x == 0.0 || end.x == 60.0 || end.y == 0.0 || end.y == 45.0;
      if (!edge) continue;
      ++on_edge;
      EXPECT_NEAR(k.distance(end, line.owner_a), k.distance(end, line.owner_b), 1e-6) << end.x << ", " << end.y;
    }
  }
  EXPECT_EQ(on_edge, 3);
  // Lines that stop in the open are counted: without their tripoint, the three lines' inner ends.
  BoundaryResult broken = b;
  broken.tripoints.clear();
  EXPECT_EQ(region_edges(broken, k.index, k.grid).dangling_ends, 3);
}

TEST(Regions, OwnerAtFollowsTheEngineAlsoInsideOverlappingPolygons) {
  SeedSet s;
  const int32_t a = s.owner_code("A");  // code 1
  s.add_polygon(s.add_feature(s.owner_code("B")), {{{10, 10}, {30, 10}, {30, 30}, {10, 30}, {10, 10}}});
  s.add_polygon(s.add_feature(a), {{{20, 20}, {40, 20}, {40, 40}, {20, 40}, {20, 20}}});
  const PlanarSiteMetric metric(s, Vec2{0, 50});
  const OwnerIndex index(metric);
  EXPECT_EQ(owner_at(index, {25, 25}), 1);  // inside both: the lower code (A)
  EXPECT_EQ(owner_at(index, {15, 15}), 2);
  EXPECT_EQ(owner_at(index, {35, 35}), 1);
  EXPECT_EQ(owner_at(index, {5, 48}), 1);  // nearer A's corner (20, 40) than B's (10, 30)
}

TEST(Regions, RingAreasPlanarAndOnTheEllipsoid) {
  const std::vector<Vec2> square{{0, 0}, {3, 0}, {3, 2}, {0, 2}, {0, 0}};
  EXPECT_DOUBLE_EQ(ring_area(square, MetricSpec{}, nullptr, 1.0), 6.0);
  const std::vector<Vec2> open{{500000, 6000000}, {500000, 6000010}, {500004, 6000010}};  // not closed, clockwise
  EXPECT_DOUBLE_EQ(ring_area(open, MetricSpec{}, nullptr, 1.0), 20.0);
  // 2 x 1.5 degrees at 54-55.5 N: parallels are not geodesics, the area is the authalic zone's.
  MetricSpec geo;
  geo.kind = MetricSpec::geodesic;
  const std::vector<Vec2> box{{10, 54}, {12, 54}, {12, 55.5}, {10, 55.5}, {10, 54}};
  const GeographicLib::Ellipsoid e(geo.semi_major, geo.flattening);
  const double rq2 = e.Area() / (4.0 * std::numbers::pi);
  auto zone = [&](double lat) { return std::sin(e.AuthalicLatitude(lat) * std::numbers::pi / 180.0); };
  const double want = 2.0 / 360.0 * 2.0 * std::numbers::pi * rq2 * (zone(55.5) - zone(54.0));
  // Exact whatever the step: the edges straight in degrees are integrated, not followed.
  EXPECT_NEAR(ring_area(box, geo, nullptr, 0.001), want, 1e-12 * want);
  EXPECT_NEAR(ring_area(box, geo, nullptr, 10.0), want, 1e-12 * want);
  // A ring with slanted and long edges (over 3 degrees of latitude, crossing the equator) and a
  // hole's worth of small ones, against GeographicLib's geodesic polygon through the edges
  // followed in steps of 1e-4 degrees (the geodesics between such steps stray from the straight
  // edge by micrometres).
  const std::vector<Vec2> ring{{10, -1.5}, {12.5, 0.3}, {11.7, 2.1}, {11.7001, 2.1002}, {10.2, 1.9}, {9.1, 0.2}};
  const GeographicLib::Geodesic geod(geo.semi_major, geo.flattening);
  GeographicLib::PolygonArea followed(geod);
  for (size_t i = 0; i < ring.size(); ++i) {
    const Vec2 a = ring[i], b = ring[(i + 1) % ring.size()];
    const int steps = static_cast<int>(std::ceil(std::hypot(b.x - a.x, b.y - a.y) / 1e-4));
    for (int k = 0; k < steps; ++k) followed.AddPoint(a.y + (b.y - a.y) * k / steps, a.x + (b.x - a.x) * k / steps);
  }
  double perimeter = 0.0, area = 0.0;
  followed.Compute(false, true, perimeter, area);
  EXPECT_NEAR(ring_area(ring, geo, nullptr, 1.0), std::abs(area), 1e-9 * std::abs(area));
  // A sphere (flattening 0) takes the sphere's zone, a^2 sin(lat).
  MetricSpec sphere = geo;
  sphere.flattening = 0.0;
  const double r2 = sphere.semi_major * sphere.semi_major;
  const double zone_sphere = 2.0 * std::numbers::pi / 180.0 * r2 *
                             (std::sin(55.5 * std::numbers::pi / 180.0) - std::sin(54.0 * std::numbers::pi / 180.0));
  EXPECT_NEAR(ring_area(box, sphere, nullptr, 1.0), zone_sphere, 1e-12 * zone_sphere);
}

}  // namespace
}  // namespace rv
