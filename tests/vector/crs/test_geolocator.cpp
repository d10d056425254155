// OsrGeolocator (grid CRS <-> its geographic base through OSR/PROJ) and seed reading in the
// geographic base of a projected grid CRS, for the geodesic metric on projected grids.
#include <gtest/gtest.h>

#include <GeographicLib/UTMUPS.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <thread>
#include <vector>

#include "rv/field/error.hpp"
#include "rv/gdal/osr_geolocator.hpp"
#include "rv/gdal/seed_reader.hpp"

#include "error_kind.hpp"
#include "fixtures.hpp"

namespace rv {
namespace {

std::string source(const std::string& rel) { return (test::source_dir() / rel).string(); }

std::string oresund() { return test::fixture("oresund.gpkg"); }

using test::kind_of;

// A lattice of positions over zone 33N, from the central meridian to 3.5 degrees off it.
void utm_points(std::vector<double>& x, std::vector<double>& y) {
  for (double e = 170000.0; e <= 830000.0; e += 55000.0)
    for (double n = 5000000.0; n <= 7600000.0; n += 130000.0) {
      x.push_back(e);
      y.push_back(n);
    }
}

TEST(OsrGeolocator, Utm33AgreesWithGeographicLib) {
  const OsrGeolocator locator("EPSG:32633");
  EXPECT_TRUE(locator.geographic_crs().geographic);
  EXPECT_DOUBLE_EQ(locator.geographic_crs().semi_major, 6378137.0);
  EXPECT_NEAR(locator.geographic_crs().flattening, 1 / 298.257223563, 1e-15);
  std::vector<double> x, y;
  utm_points(x, y);
  const size_t n = x.size();
  ASSERT_GT(n, 200u);
  std::vector<double> lon(n), lat(n), back_x(n), back_y(n);
  locator.to_lonlat(x.data(), y.data(), lon.data(), lat.data(), n);
  for (size_t i = 0; i < n; ++i) {
    double glat, glon;
    GeographicLib::UTMUPS::Reverse(33, true, x[i], y[i], glat, glon);
    // x is longitude (traditional GIS order), within 1e-9 degrees (0.1 mm) of GeographicLib.
    EXPECT_NEAR(lon[i], glon, 1e-9) << x[i] << " " << y[i];
    EXPECT_NEAR(lat[i], glat, 1e-9) << x[i] << " " << y[i];
  }
  locator.to_grid(lon.data(), lat.data(), back_x.data(), back_y.data(), n);
  for (size_t i = 0; i < n; ++i) {
    EXPECT_NEAR(back_x[i], x[i], 1e-6);
    EXPECT_NEAR(back_y[i], y[i], 1e-6);
  }
  // n = 0 is allowed and touches nothing.
  locator.to_lonlat(nullptr, nullptr, nullptr, nullptr, 0);
}

TEST(OsrGeolocator, SameBitsOnEveryThreadAndInBatchesOrOneByOne) {
  const OsrGeolocator locator("EPSG:32633");
  std::vector<double> x, y;
  utm_points(x, y);
  const size_t n = x.size();
  std::vector<double> lon(n), lat(n);
  locator.to_lonlat(x.data(), y.data(), lon.data(), lat.data(), n);
  // One by one: the same bits as the batch (the engine mixes both).
  for (size_t i = 0; i < n; i += 7) {
    double one_lon, one_lat;
    locator.to_lonlat(&x[i], &y[i], &one_lon, &one_lat, 1);
    EXPECT_EQ(std::memcmp(&one_lon, &lon[i], sizeof(double)), 0);
    EXPECT_EQ(std::memcmp(&one_lat, &lat[i], sizeof(double)), 0);
  }
  // Several threads at once, each many times, point by point and in batches.
  constexpr int kThreads = 6;
  std::vector<int> mismatches(kThreads, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      std::vector<double> l(n), b(n), gx(n), gy(n);
      for (int round = 0; round < 20; ++round) {
        if ((round + t) % 2 == 0) {
          locator.to_lonlat(x.data(), y.data(), l.data(), b.data(), n);
        } else {
          for (size_t i = 0; i < n; ++i) locator.to_lonlat(&x[i], &y[i], &l[i], &b[i], 1);
        }
        locator.to_grid(l.data(), b.data(), gx.data(), gy.data(), n);
        if (std::memcmp(l.data(), lon.data(), n * sizeof(double)) != 0 ||
            std::memcmp(b.data(), lat.data(), n * sizeof(double)) != 0)
          ++mismatches[static_cast<size_t>(t)];
      }
    });
  for (std::thread& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) EXPECT_EQ(mismatches[static_cast<size_t>(t)], 0) << "thread " << t;
  // Two geolocators used alternately on one thread keep their own transformations.
  const OsrGeolocator other("EPSG:32632");
  double lon33, lat33, lon32, lat32;
  const double ex = 500000.0, ny = 6000000.0;
  for (int i = 0; i < 3; ++i) {
    locator.to_lonlat(&ex, &ny, &lon33, &lat33, 1);
    other.to_lonlat(&ex, &ny, &lon32, &lat32, 1);
    EXPECT_NEAR(lon33, 15.0, 1e-12);
    EXPECT_NEAR(lon32, 9.0, 1e-12);
  }
}

TEST(OsrGeolocator, Refusals) {
  EXPECT_EQ(kind_of([] { OsrGeolocator("EPSG:4326"); }), ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of([] { OsrGeolocator("not a crs"); }), ErrorKind::invalid_argument);
  const OsrGeolocator locator("EPSG:32633");
  const double lon = 15.0, lat = 95.0, nan = std::nan("");
  double x, y, lo, la;
  EXPECT_EQ(kind_of([&] { locator.to_grid(&lon, &lat, &x, &y, 1); }), ErrorKind::invalid_input);
  EXPECT_EQ(kind_of([&] { locator.to_lonlat(&nan, &lat, &lo, &la, 1); }), ErrorKind::invalid_input);
}

TEST(SeedReader, GeographicSeedsOfAProjectedGridCrs) {
  // Point seeds stored in UTM 33N; the grid CRS is the layer's.
  SeedReadOptions ro;
  ro.paths = {source("fixtures/demo_basepoints.geojson")};
  ro.owner_field = "state";
  const LoadedSeeds plain = load_seeds(ro);
  ro.geographic_seeds = true;
  const LoadedSeeds geo = load_seeds(ro);
  EXPECT_FALSE(plain.geographic_base);
  ASSERT_TRUE(geo.geographic_base);
  EXPECT_FALSE(geo.crs.geographic);  // the grid CRS
  EXPECT_EQ(geo.crs.wkt, plain.crs.wkt);
  EXPECT_TRUE(geo.seed_crs.geographic);
  ASSERT_EQ(geo.seeds.sites().size(), plain.seeds.sites().size());
  for (size_t i = 0; i < plain.seeds.sites().size(); ++i) {
    const Vec2 p = plain.seeds.sites()[i].a, q = geo.seeds.sites()[i].a;
    double lat, lon;
    GeographicLib::UTMUPS::Reverse(33, true, p.x, p.y, lat, lon);
    EXPECT_NEAR(q.x, lon, 1e-9);
    EXPECT_NEAR(q.y, lat, 1e-9);
  }
  // The box in the grid CRS is the plain reading's (through a round trip of each vertex).
  ASSERT_TRUE(geo.grid_bounds.has_value());
  const SeedSet::Box b = plain.seeds.bounds();
  EXPECT_NEAR(geo.grid_bounds->xmin, b.xmin, 1e-5);
  EXPECT_NEAR(geo.grid_bounds->ymin, b.ymin, 1e-5);
  EXPECT_NEAR(geo.grid_bounds->xmax, b.xmax, 1e-5);
  EXPECT_NEAR(geo.grid_bounds->ymax, b.ymax, 1e-5);

  // A geographic target is left as it is.
  SeedReadOptions gr;
  gr.paths = {source("fixtures/demo_basepoints.geojson")};
  gr.target_crs = "EPSG:4326";
  gr.geographic_seeds = true;
  const LoadedSeeds already = load_seeds(gr);
  EXPECT_FALSE(already.geographic_base);
  EXPECT_TRUE(already.crs.geographic);
  EXPECT_FALSE(already.grid_bounds.has_value());
}

TEST(SeedReader, GridPolygonsMatchTheSeedsPolygons) {
  const std::string path = oresund();
  SeedReadOptions ro;
  ro.paths = {path};
  ro.owner_field = "iso2";
  ro.target_crs = "EPSG:32633";
  ro.geographic_seeds = true;
  const LoadedSeeds geo = load_seeds(ro);
  ASSERT_TRUE(geo.geographic_base);
  EXPECT_NE(geo.crs.name.find("UTM zone 33N"), std::string::npos) << geo.crs.name;
  ASSERT_TRUE(geo.grid_polygons);
  const std::vector<Polygon>& grid = *geo.grid_polygons;
  ASSERT_EQ(grid.size(), geo.seeds.polygons().size());
  ASSERT_GT(grid.size(), 0u);
  const OsrGeolocator locator(geo.crs.wkt);
  for (size_t k = 0; k < grid.size(); ++k) {
    const Polygon& a = geo.seeds.polygons()[k];
    const Polygon& b = grid[k];
    EXPECT_EQ(a.area_site, b.area_site);
    EXPECT_EQ(a.feature, b.feature);
    ASSERT_EQ(a.rings.size(), b.rings.size());
    for (size_t r = 0; r < a.rings.size(); ++r) {
      ASSERT_EQ(a.rings[r].size(), b.rings[r].size());
      for (size_t i = 0; i < a.rings[r].size(); i += 25) {
        // Each grid vertex is the seed vertex (longitude/latitude) placed in UTM 33N.
        EXPECT_LT(std::abs(a.rings[r][i].x - 12.6), 1.0);
        double lat, lon;
        GeographicLib::UTMUPS::Reverse(33, true, b.rings[r][i].x, b.rings[r][i].y, lat, lon);
        EXPECT_NEAR(lon, a.rings[r][i].x, 1e-9);
        EXPECT_NEAR(lat, a.rings[r][i].y, 1e-9);
      }
    }
  }
}

}  // namespace
}  // namespace rv
