// The geodesic metric on a projected grid: cell centres in UTM zone 33N located on WGS84 by a
// Geolocator written here with GeographicLib's UTMUPS (no PROJ in the core), measured there.
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>
#include <GeographicLib/UTMUPS.hpp>

#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/engine/validate.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/margin.hpp"
#include "utm33.hpp"

namespace rv {
namespace {

using GeographicLib::UTMUPS;
using test::Utm33;

// A geolocator that breaks its contract (latitude beyond the pole).
class BadLatitude final : public Geolocator {
 public:
  void to_lonlat(const double*, const double*, double* lon, double* lat, size_t n) const override {
    for (size_t i = 0; i < n; ++i) {
      lon[i] = 15.0;
      lat[i] = 95.0;
    }
  }
  void to_grid(const double*, const double*, double* x, double* y, size_t n) const override {
    for (size_t i = 0; i < n; ++i) x[i] = y[i] = 0.0;
  }
};

// 50 x 50 cells of 2 km, about 14.0-15.9 E, 54.8-55.7 N.
GridSpec utm_grid(int64_t width = 50, int64_t height = 50) {
  GridSpec g;
  g.xmin = 400000.0;
  g.ymax = 6180000.0;
  g.res = 2000.0;
  g.width = width;
  g.height = height;
  return g;
}

ComputeOptions projected_options(Method method,
                                 std::shared_ptr<const Geolocator> geolocator = std::make_shared<Utm33>()) {
  ComputeOptions o;
  o.method = method;
  o.metric = resolve_metric(MetricRequest::geodesic, false);
  o.geolocator = std::move(geolocator);
  return o;
}

void centre_lonlat(const GridSpec& g, int64_t c, int64_t r, double& lon, double& lat) {
  UTMUPS::Reverse(33, true, g.centre_x(c), g.centre_y(r), lat, lon);
}

TEST(GeodesicProjected, BruteForceEqualsGeographicLibAtTheLocatedCentres) {
  SeedSet seeds;
  const std::vector<Vec2> points = {{14.5, 55.2}, {15.6, 55.5}, {15.0, 55.9}, {14.1, 55.6}, {15.4, 54.9}};
  for (size_t i = 0; i < points.size(); ++i) {
    const int32_t f = seeds.add_feature(seeds.owner_code(i < 3 ? "A" : "B"));
    seeds.add_point(f, points[i]);
  }
  const GridSpec g = utm_grid();
  const auto locator = std::make_shared<Utm33>();
  const NearestField f = compute(seeds, g, projected_options(Method::brute_force, locator));
  EXPECT_EQ(f.metric.kind, MetricSpec::geodesic);
  EXPECT_EQ(f.geolocator, locator);
  // One batch per row, not one call per cell.
  EXPECT_EQ(locator->calls(), g.height);

  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  double planar_gap = 0.0;  // how far the UTM-plane distance is from the geodesic one
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      double lon, lat;
      centre_lonlat(g, c, r, lon, lat);
      double best = std::numeric_limits<double>::infinity();
      int32_t best_site = kNoSite;
      for (int32_t s = 0; s < static_cast<int32_t>(points.size()); ++s) {
        double d;
        geod.Inverse(lat, lon, points[s].y, points[s].x, d);
        if (d < best - 1e-6) {
          best = d;
          best_site = s;
        }
      }
      ASSERT_EQ(f.site.at(c, r), best_site) << "cell " << c << "," << r;
      // Float32 storage: relative rounding 6e-8.
      EXPECT_NEAR(f.distance.at(c, r), best, 1e-3 + best * 1e-7) << "cell " << c << "," << r;
      double px, py;
      int zone;
      bool northp;
      UTMUPS::Forward(points[best_site].y, points[best_site].x, zone, northp, px, py, 33);
      planar_gap = std::max(planar_gap, std::abs(std::hypot(px - g.centre_x(c), py - g.centre_y(r)) - best));
    }
  // The grid's own metres differ (scale factor 0.9996 on the central meridian): the test would
  // notice a metric that silently measured in the plane.
  EXPECT_GT(planar_gap, 10.0);
}

TEST(GeodesicProjected, SegmentDistanceIsToTheGeodesicBetweenTheEnds) {
  SeedSet seeds;
  const int32_t f = seeds.add_feature(seeds.owner_code("coast"));
  seeds.add_polyline(f, std::vector<Vec2>{{14.2, 55.0}, {14.6, 55.7}, {15.5, 55.75}});
  const GridSpec g = utm_grid(20, 20);
  const NearestField field = compute(seeds, g, projected_options(Method::brute_force));
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  int checked = 0;
  for (int64_t r = 1; r < g.height; r += 6)
    for (int64_t c = 2; c < g.width; c += 5) {
      const Site& s = seeds.sites()[static_cast<size_t>(field.site.at(c, r))];
      ASSERT_EQ(s.kind, SiteKind::segment);
      double lon, lat;
      centre_lonlat(g, c, r, lon, lat);
      double s12, azi1, azi2;
      geod.Inverse(s.a.y, s.a.x, s.b.y, s.b.x, s12, azi1, azi2);
      const GeographicLib::GeodesicLine line = geod.Line(s.a.y, s.a.x, azi1);
      double best = std::numeric_limits<double>::infinity();
      const int n = 4000;
      for (int i = 0; i <= n; ++i) {
        double plat, plon, d;
        line.Position(s12 * i / n, plat, plon);
        geod.Inverse(lat, lon, plat, plon, d);
        best = std::min(best, d);
      }
      const float d = field.distance.at(c, r);
      EXPECT_NEAR(d, best, 0.01 + s12 / n) << "cell " << c << "," << r;
      EXPECT_LE(d, best + 0.01);
      ++checked;
    }
  EXPECT_GE(checked, 9);
}

SeedSet scattered_seeds(int n) {
  SeedSet seeds;
  uint64_t state = 12345;
  auto next = [&] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) / static_cast<double>(1ULL << 53);
  };
  for (int i = 0; i < n; ++i) {
    const int32_t f = seeds.add_feature(seeds.owner_code(std::to_string(i % 5)));
    const Vec2 p{13.9 + 2.1 * next(), 54.7 + 1.1 * next()};
    if (i % 4 == 0) {
      const Vec2 q{p.x + 0.1 * next(), p.y + 0.05 * next()};
      seeds.add_polyline(f, std::vector<Vec2>{p, q});
    } else {
      seeds.add_point(f, p);
    }
  }
  // Far outside the grid and outside the test geolocator's domain: never nearest, and placed
  // at infinity for the scans' seeding.
  seeds.add_point(seeds.add_feature(seeds.owner_code("far")), {120.0, 10.0});
  return seeds;
}

TEST(GeodesicProjected, HvScanStaysWithinOneCellOfBruteForce) {
  const SeedSet seeds = scattered_seeds(40);
  const GridSpec g = utm_grid(60, 60);
  const NearestField brute = compute(seeds, g, projected_options(Method::brute_force));
  EXPECT_EQ(compare_fields(seeds, brute, brute).wrong_cells, 0);
  for (Method m : {Method::hv_scan, Method::h_scan}) {
    ComputeOptions o = projected_options(m);
    o.threads = 1;
    const NearestField one = compute(seeds, g, o);
    o.threads = 3;
    const NearestField three = compute(seeds, g, o);
    EXPECT_EQ(one.site.cells(), three.site.cells()) << to_string(m);
    EXPECT_EQ(one.distance.cells(), three.distance.cells()) << to_string(m);
    const ValidationStats v = compare_fields(seeds, one, brute);
    EXPECT_EQ(v.nodata_mismatch, 0) << to_string(m);
    // The 3x3 scans lose small regions (a seed whose only cell another seed wins), as they do
    // on planar grids; what is asserted is the error bound: below one cell (2 km).
    EXPECT_GT(v.max_error, 0.0) << to_string(m);  // the comparison is not vacuous here
    EXPECT_LT(v.max_error_cells, 1.0) << to_string(m);
    // The scans' distances are exact geodesic distances to the site they keep.
    int64_t same = 0;
    for (size_t i = 0; i < one.site.size(); ++i)
      if (one.site.cells()[i] == brute.site.cells()[i]) {
        EXPECT_EQ(one.distance.cells()[i], brute.distance.cells()[i]);
        ++same;
      }
    EXPECT_GT(same, g.cell_count() / 2);
  }
}

// The exact method on projected grids: cells located tile by tile, blocks culled with the
// located centres' ECEF boxes, distances interpolated on grid-aligned blocks. Owners equal brute
// force's, distances to the last float bit; any window and thread count gives the same bits.
TEST(GeodesicProjected, ExactEqualsBruteForce) {
  const SeedSet seeds = scattered_seeds(40);
  for (const double res : {2000.0, 200.0}) {
    GridSpec g = utm_grid(res == 2000.0 ? 60 : 180, res == 2000.0 ? 60 : 150);
    g.res = res;
    g.xmin = res == 2000.0 ? 400000.0 : 430000.0;
    g.ymax = res == 2000.0 ? 6180000.0 : 6150000.0;
    const NearestField brute = compute(seeds, g, projected_options(Method::brute_force));
    ComputeOptions o = projected_options(Method::exact);
    o.threads = 2;
    const NearestField exact = compute(seeds, g, o);
    EXPECT_EQ(exact.site.cells(), brute.site.cells()) << res;
    int64_t off = 0;
    for (size_t i = 0; i < exact.distance.size(); ++i) {
      const float x = exact.distance.cells()[i], y = brute.distance.cells()[i];
      if (x == y) continue;
      ASSERT_EQ(x, std::nextafter(y, x)) << res << " cell " << i;
      ++off;
    }
    EXPECT_LT(off, exact.distance.size() / 20) << res;
    EXPECT_EQ(compare_fields(seeds, exact, brute).wrong_cells, 0) << res;
    o.threads = 3;
    o.window = Window{17, 23, 90, 70};
    if (res == 2000.0) o.window = Window{7, 9, 40, 33};
    const NearestField part = compute(seeds, g, o);
    for (int64_t r = 0; r < o.window->height; ++r)
      for (int64_t c = 0; c < o.window->width; ++c) {
        ASSERT_EQ(part.site.at(c, r), exact.site.at(o.window->col0 + c, o.window->row0 + r)) << res;
        ASSERT_EQ(part.distance.at(c, r), exact.distance.at(o.window->col0 + c, o.window->row0 + r)) << res;
      }
  }
}

TEST(GeodesicProjected, InteriorsComeFromTheGridPolygons) {
  // A rectangle in the grid (cell edges at x 430..460 km, y 6130..6160 km) and, as the seed, its
  // corners in longitude/latitude; plus a point owner outside it.
  const GridSpec g = utm_grid(40, 40);
  const double x0 = 430000.0, x1 = 460000.0, y0 = 6130000.0, y1 = 6160000.0;
  const std::vector<Vec2> grid_ring = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  Ring ring;
  for (const Vec2& v : grid_ring) {
    double lat, lon;
    UTMUPS::Reverse(33, true, v.x, v.y, lat, lon);
    ring.push_back({lon, lat});
  }
  SeedSet seeds;
  const int32_t island = seeds.add_feature(seeds.owner_code("island"));
  seeds.add_polygon(island, {ring});
  seeds.add_point(seeds.add_feature(seeds.owner_code("rock")), {14.3, 55.3});
  auto grid_polygons = std::make_shared<std::vector<Polygon>>(seeds.polygons());
  (*grid_polygons)[0].rings = {grid_ring};

  ComputeOptions o = projected_options(Method::brute_force);
  // The seeds' polygons are in degrees: without their grid copies the interiors are unknown.
  EXPECT_THROW(
      {
        try {
          compute(seeds, g, o);
        } catch (const Error& e) {
          EXPECT_EQ(e.kind(), ErrorKind::invalid_argument);
          throw;
        }
      },
      Error);
  o.grid_polygons = grid_polygons;
  for (Method m : {Method::brute_force, Method::hv_scan}) {
    o.method = m;
    const NearestField f = compute(seeds, g, o);
    int64_t inside = 0;
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        const double x = g.centre_x(c), y = g.centre_y(r);
        const bool in_rectangle = x > x0 && x < x1 && y > y0 && y < y1;
        const bool zero = f.distance.at(c, r) == 0.0f;
        EXPECT_EQ(zero, in_rectangle) << to_string(m) << " cell " << c << "," << r;
        if (in_rectangle) {
          EXPECT_EQ(seeds.site_owner(f.site.at(c, r)), seeds.features()[island].owner);
          ++inside;
        }
      }
    EXPECT_EQ(inside, 15 * 15) << to_string(m);
  }

  // Grid polygons that are not the seeds' (another count, another area site) are refused.
  auto wrong = std::make_shared<std::vector<Polygon>>(*grid_polygons);
  (*wrong)[0].area_site += 1;
  o.grid_polygons = wrong;
  EXPECT_THROW(compute(seeds, g, o), Error);
  o.grid_polygons = std::make_shared<std::vector<Polygon>>();
  EXPECT_THROW(compute(seeds, g, o), Error);
}

TEST(GeodesicProjected, BoundaryVerticesAreEquidistantOnTheEllipsoid) {
  // Two owners of two points each: the boundary vertices (grid CRS) located by GeographicLib
  // are equidistant from the two owners' nearest points, measured directly.
  SeedSet seeds;
  const std::vector<Vec2> points = {{13.6, 55.1}, {13.8, 55.6}, {14.6, 55.2}, {14.4, 55.65}};
  for (size_t i = 0; i < points.size(); ++i)
    seeds.add_point(seeds.add_feature(seeds.owner_code(i < 2 ? "west" : "east")), points[i]);
  const GridSpec g = utm_grid(40, 40);
  const ComputeOptions o = projected_options(Method::brute_force);
  const NearestField field = compute(seeds, g, o);
  const LocatedGeodesicSiteMetric metric(seeds, o.metric, o.geolocator, nullptr);
  EXPECT_EQ(metric.spec(), o.metric);  // the ellipsoid the lines' geometry reads
  const OwnerIndex index(metric);
  const BoundaryResult b = extract_boundaries(field, index);
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  int vertices = 0;
  for (const BoundaryLine& line : b.lines)
    for (const BoundaryVertex& v : line.vertices) {
      EXPECT_GE(v.p.x, g.xmin);  // grid coordinates
      EXPECT_LE(v.p.x, g.xmax());
      double lat, lon;
      UTMUPS::Reverse(33, true, v.p.x, v.p.y, lat, lon);
      double d[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
      for (size_t i = 0; i < points.size(); ++i) {
        double s12;
        geod.Inverse(lat, lon, points[i].y, points[i].x, s12);
        d[i < 2 ? 0 : 1] = std::min(d[i < 2 ? 0 : 1], s12);
      }
      EXPECT_NEAR(d[0], d[1], 1e-3);
      EXPECT_NEAR(v.distance, d[0], 1e-3);
      ++vertices;
    }
  EXPECT_GT(vertices, 30);
  // The controlling point is given in the grid's CRS.
  const Vec2 q = metric.nearest_point(Vec2{g.centre_x(3), g.centre_y(3)}, field.site.at(3, 3));
  double px, py;
  int zone;
  bool northp;
  const Vec2& s = points[static_cast<size_t>(field.site.at(3, 3))];
  UTMUPS::Forward(s.y, s.x, zone, northp, px, py, 33);
  EXPECT_NEAR(q.x, px, 1e-3);
  EXPECT_NEAR(q.y, py, 1e-3);

  // A metric that does not locate, for a located field, and the reverse, are refused; the margin
  // raster is not available for located fields yet.
  const GeodesicSiteMetric plain(seeds, o.metric);
  const OwnerIndex plain_index(plain);
  EXPECT_THROW(extract_boundaries(field, plain_index), Error);
  EXPECT_THROW(margin_raster(field, index), Error);
  ComputeOptions geographic;
  geographic.metric = o.metric;
  GridSpec lonlat_grid;
  lonlat_grid.xmin = 14.0;
  lonlat_grid.ymax = 56.0;
  lonlat_grid.res = 0.05;
  lonlat_grid.width = lonlat_grid.height = 20;
  EXPECT_THROW(extract_boundaries(compute(seeds, lonlat_grid, geographic), index), Error);
}

ErrorKind kind_of(const SeedSet& seeds, const GridSpec& g, const ComputeOptions& o) {
  try {
    compute(seeds, g, o);
  } catch (const Error& e) {
    return e.kind();
  }
  ADD_FAILURE() << "no error";
  return ErrorKind::internal;
}

// Each metric states the metric it measures with, and the ellipsoid is the one it was given
// (the lines read geodesics' crossings on it): not WGS84 when the data's datum is another.
TEST(GeodesicProjected, MetricsStateTheirEllipsoid) {
  SeedSet seeds;
  seeds.add_point(seeds.add_feature(seeds.owner_code("a")), Vec2{13.6, 55.1});
  MetricSpec sphere;
  sphere.kind = MetricSpec::geodesic;
  sphere.semi_major = 6371000.0;
  sphere.flattening = 0.0;
  EXPECT_EQ(GeodesicSiteMetric(seeds, sphere).spec(), sphere);
  MetricSpec bessel = sphere;
  bessel.semi_major = 6377397.155;
  bessel.flattening = 1.0 / 299.1528128;
  EXPECT_EQ(GeodesicSiteMetric(seeds, bessel).spec(), bessel);
  EXPECT_EQ(PlanarSiteMetric(seeds, Vec2{0.0, 0.0}).spec(), MetricSpec{});
}

TEST(GeodesicProjected, Refusals) {
  SeedSet seeds;
  seeds.add_point(seeds.add_feature(seeds.owner_code("A")), {15.0, 55.0});
  const GridSpec g = utm_grid(10, 10);
  // A geolocator with the planar metric: planar measures in the grid's CRS.
  ComputeOptions planar;
  planar.geolocator = std::make_shared<Utm33>();
  EXPECT_EQ(kind_of(seeds, g, planar), ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of(seeds, g, projected_options(Method::exact, std::make_shared<BadLatitude>())),
            ErrorKind::invalid_input);
  // A geolocator that returns a latitude beyond the pole.
  EXPECT_EQ(kind_of(seeds, g, projected_options(Method::brute_force, std::make_shared<BadLatitude>())),
            ErrorKind::invalid_input);
  EXPECT_EQ(kind_of(seeds, g, projected_options(Method::hv_scan, std::make_shared<BadLatitude>())),
            ErrorKind::invalid_input);
  // Cells the geolocator cannot locate (eastings far outside the zone).
  GridSpec far = g;
  far.xmin = -9e6;
  EXPECT_EQ(kind_of(seeds, far, projected_options(Method::brute_force)), ErrorKind::invalid_input);
  // The degree checks of geographic grids do not apply: a projected extent is no latitude.
  const NearestField ok = compute(seeds, g, projected_options(Method::brute_force));
  EXPECT_GT(ok.distance.at(0, 0), 0.0f);
}

}  // namespace
}  // namespace rv
