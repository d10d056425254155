// The real Øresund coastline (Denmark and Sweden, EPSG:4326) on its own longitude/latitude grid
// (0.002° cells): geodesic ownership exact against brute force, distances in nautical miles.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>

#include "rv/engine/engine.hpp"
#include "rv/engine/validate.hpp"
#include "rv/gdal/seed_reader.hpp"

#include "fixtures.hpp"

namespace rv {
namespace {

std::string oresund() { return test::fixture("oresund.gpkg"); }

// The fixture's seeds, owners from iso2.
LoadedSeeds load_oresund() {
  const std::string path = oresund();
  gdal_init();
  SeedReadOptions ro;
  ro.paths = {path};
  ro.owner_field = "iso2";
  return load_seeds(ro);
}

// Exact's cells of a window equal brute force's there: the same sites, and distances equal to
// the last bit (interpolated ones, ~1e-8 m off, may differ from brute force's float in it).
void expect_same_as_brute(const NearestField& exact, const NearestField& brute, const Window& w) {
  EXPECT_EQ(exact.site.cells(), brute.site.cells()) << "window at " << w.col0 << "," << w.row0;
  for (size_t i = 0; i < exact.distance.size(); ++i) {
    const float x = exact.distance.cells()[i], y = brute.distance.cells()[i];
    ASSERT_TRUE(x == y || x == std::nextafter(y, x)) << i << ": " << x << " vs " << y;
  }
}

TEST(OresundGeodesic, ExactEqualsBruteForceAcrossTheStrait) {
  const LoadedSeeds loaded = load_oresund();
  ASSERT_TRUE(loaded.crs.geographic);
  const MetricSpec metric =
      resolve_metric(MetricRequest::automatic, true, loaded.crs.semi_major, loaded.crs.flattening);
  ASSERT_EQ(metric.kind, MetricSpec::geodesic);

  GridSpec g = make_grid(12.0, 55.3, 13.2, 56.3, 0.002, loaded.crs.wkt);
  ASSERT_EQ(g.width, 600);
  ASSERT_EQ(g.height, 500);
  ComputeOptions o;
  o.metric = metric;
  const NearestField exact = compute(loaded.seeds, g, o);

  // Brute force (every cell against every segment, each an exact geodesic distance) costs about
  // 600 x 500 x 600 GeographicLib calls for the whole grid, minutes; it runs on three windows
  // across the strait instead: north (Helsingør-Helsingborg), middle, south (Øresund bridge).
  int64_t sea_cells = 0, owners_seen[3] = {0, 0, 0};
  for (const Window w : {Window{280, 40, 48, 40}, Window{250, 230, 48, 40}, Window{230, 380, 48, 40}}) {
    ComputeOptions b = o;
    b.method = Method::brute_force;
    b.window = w;
    const NearestField brute = compute(loaded.seeds, g, b);
    NearestField part;
    part.site = Raster<int32_t>(g, w, kNoSite);
    part.distance = Raster<float>(g, w, kNoDistance);
    part.metric = exact.metric;
    for (int64_t r = 0; r < w.height; ++r)
      for (int64_t c = 0; c < w.width; ++c) {
        part.site.at(c, r) = exact.site.at(w.col0 + c, w.row0 + r);
        part.distance.at(c, r) = exact.distance.at(w.col0 + c, w.row0 + r);
      }
    const ValidationStats v = compare_fields(loaded.seeds, part, brute, 0.0);
    EXPECT_EQ(v.wrong_cells, 0) << "window at " << w.col0 << "," << w.row0;
    EXPECT_EQ(v.nodata_mismatch, 0);
    expect_same_as_brute(part, brute, w);
    for (size_t i = 0; i < part.site.size(); ++i) {
      if (part.distance.cells()[i] > 0.0f) ++sea_cells;
      ++owners_seen[loaded.seeds.site_owner(part.site.cells()[i])];
    }
  }
  EXPECT_GT(sea_cells, 1000);
  EXPECT_GT(owners_seen[1], 0);  // both states present in the windows
  EXPECT_GT(owners_seen[2], 0);

  // A sea cell's distance equals GeographicLib's to the nearest point of its controlling
  // segment, checked independently by sampling that segment densely along its geodesic.
  const GeographicLib::Geodesic geod(loaded.crs.semi_major, loaded.crs.flattening);
  int checked = 0;
  for (int64_t r = 20; r < g.height; r += 97)
    for (int64_t c = 30; c < g.width; c += 89) {
      const float d = exact.distance.at(c, r);
      if (d <= 0.0f) continue;
      const Site& s = loaded.seeds.sites()[exact.site.at(c, r)];
      ASSERT_EQ(s.kind, SiteKind::segment);
      double s12, azi1, azi2;
      geod.Inverse(s.a.y, s.a.x, s.b.y, s.b.x, s12, azi1, azi2);
      const GeographicLib::GeodesicLine line = geod.Line(s.a.y, s.a.x, azi1);
      double best = std::numeric_limits<double>::infinity();
      const int n = 4000;
      for (int i = 0; i <= n; ++i) {
        double lat, lon, dist;
        line.Position(s12 * i / n, lat, lon);
        geod.Inverse(g.centre_y(r), g.centre_x(c), lat, lon, dist);
        best = std::min(best, dist);
      }
      // Sampling step <= s12/4000 bounds how far the sampled minimum can sit above the true one.
      EXPECT_NEAR(d, best, 0.01 + s12 / n) << "cell " << c << "," << r;
      EXPECT_LE(d, best + 0.01);
      ++checked;
    }
  EXPECT_GT(checked, 5);
}

TEST(OresundGeodesic, ExactEqualsBruteForceOnTheBenchmarkGrid) {
  // The grid of bench/geodesic_bench's Øresund scenario (0.00038°, 3474 x 2953 cells), where the
  // row kernels run over every interpolant form (line blocks of 512 cells): windows across the
  // coast where most edges meet (on Zealand's west coast, 17 and 14 edges owning cells of 64 x
  // 64, both states near Helsingør), exact (each window alone: the same bits as the whole grid)
  // against brute force, site for site and to the last bit of the distance.
  const LoadedSeeds loaded = load_oresund();
  const MetricSpec metric =
      resolve_metric(MetricRequest::automatic, true, loaded.crs.semi_major, loaded.crs.flattening);
  GridSpec g = make_grid(11.94, 55.238, 13.26, 56.36, 0.00038, loaded.crs.wkt);
  ASSERT_EQ(g.width, 3474);
  int64_t sea = 0, near_edge = 0;
  std::set<int32_t> sites;
  for (const Window w : {Window{160, 1728, 64, 64}, Window{2304, 1280, 64, 64}, Window{1770, 840, 64, 64}}) {
    ComputeOptions o;
    o.metric = metric;
    o.window = w;
    const NearestField exact = compute(loaded.seeds, g, o);
    o.method = Method::brute_force;
    const NearestField brute = compute(loaded.seeds, g, o);
    expect_same_as_brute(exact, brute, w);
    for (size_t i = 0; i < exact.distance.size(); ++i) {
      const float x = exact.distance.cells()[i];
      if (x > 0.0f) ++sea;
      if (x > 0.0f && x < 100.0f) ++near_edge;
      sites.insert(exact.site.cells()[i]);
    }
  }
  // The windows hold sea and land, cells within 100 m of the coast and many coastline edges.
  EXPECT_GT(sea, 4000);
  EXPECT_GT(near_edge, 1000);
  EXPECT_GT(sites.size(), 30u);
}

}  // namespace
}  // namespace rv
