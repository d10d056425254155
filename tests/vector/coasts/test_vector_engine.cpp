// The engine on seeds read from the vector fixtures: exact == brute force on lines and polygons,
// identical results whatever the format, the hv-scan's error measured against brute force.
#include <gtest/gtest.h>

#include "rv/engine/engine.hpp"
#include "rv/engine/validate.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "vector_test_util.hpp"

namespace rv {
namespace {

using test::fixture;

constexpr double kX0 = 400000.0, kY0 = 6200000.0;

LoadedSeeds load(std::vector<std::string> paths, std::vector<std::string> layers = {}) {
  SeedReadOptions o;
  o.paths = std::move(paths);
  o.owner_field = "owner";
  o.layers = std::move(layers);
  return load_seeds(o);
}

NearestField run(const SeedSet& s, const GridSpec& g, Method m) {
  ComputeOptions o;
  o.method = m;
  o.threads = 2;
  return compute(s, g, o);
}

// The fixtures' 10 km square with a 1 km margin, at `res` metres (an odd cell size, so that cell
// centres do not line up with the fixtures' whole-kilometre vertices).
GridSpec fixture_grid(const LoadedSeeds& l, double res = 97.0) {
  return make_grid(kX0 - 1000.0, kY0 - 1000.0, kX0 + 11000.0, kY0 + 11000.0, res, l.crs.wkt);
}

TEST(VectorEngine, ExactEqualsBruteForceOnFixtures) {
  for (const char* name :
       {"all_types.geojson", "hole.geojson", "touching.geojson", "curves.gpkg", "self_intersecting.geojson"}) {
    const LoadedSeeds l = load({fixture(name)});
    const GridSpec g = fixture_grid(l);
    const NearestField exact = run(l.seeds, g, Method::exact);
    const NearestField brute = run(l.seeds, g, Method::brute_force);
    EXPECT_EQ(exact.site.cells(), brute.site.cells()) << name;
    EXPECT_EQ(exact.distance.cells(), brute.distance.cells()) << name;
    const ValidationStats v = compare_fields(l.seeds, exact, brute);
    EXPECT_EQ(v.wrong_cells, 0) << name;
  }
}

TEST(VectorEngine, SameResultFromEveryFormat) {
  const std::vector<std::string> layers = {"points", "lines", "polygons"};
  const LoadedSeeds json =
      load({fixture("coast_points.geojson"), fixture("coast_lines.geojson"), fixture("coast_polygons.geojson")});
  const LoadedSeeds gpkg = load({fixture("coast.gpkg")}, layers);
  const LoadedSeeds shp = load({fixture("coast_shp.zip")}, layers);
  const GridSpec g = fixture_grid(json);
  const NearestField a = run(json.seeds, g, Method::exact);
  const NearestField b = run(gpkg.seeds, g, Method::exact);
  const NearestField c = run(shp.seeds, g, Method::exact);
  EXPECT_EQ(a.site.cells(), b.site.cells());
  EXPECT_EQ(a.site.cells(), c.site.cells());
  EXPECT_EQ(a.distance.cells(), b.distance.cells());
  EXPECT_EQ(a.distance.cells(), c.distance.cells());
  const NearestField brute = run(json.seeds, g, Method::brute_force);
  EXPECT_EQ(a.site.cells(), brute.site.cells());
}

TEST(VectorEngine, HoleBelongsToTheNearestSeed) {
  const LoadedSeeds l = load({fixture("hole.geojson")});
  const GridSpec g = make_grid(kX0, kY0, kX0 + 10000.0, kY0 + 10000.0, 100.0, l.crs.wkt);
  const NearestField f = run(l.seeds, g, Method::exact);
  const auto owner_at = [&](double u, double v) {
    const int64_t col = static_cast<int64_t>(u * 10.0), row = static_cast<int64_t>((10.0 - v) * 10.0);
    return l.seeds.owner_labels()[l.seeds.site_owner(f.site.at(col, row)) - 1];
  };
  const auto distance_at = [&](double u, double v) {
    return f.distance.at(static_cast<int64_t>(u * 10.0), static_cast<int64_t>((10.0 - v) * 10.0));
  };
  EXPECT_EQ(owner_at(2.0, 5.0), "land");  // in the polygon body
  EXPECT_EQ(distance_at(2.0, 5.0), 0.0f);
  EXPECT_EQ(owner_at(5.0, 5.0), "islet");  // the hole's middle
  EXPECT_EQ(owner_at(4.5, 5.5), "islet");
  EXPECT_EQ(owner_at(3.2, 5.0), "land");  // in the hole, 0.25 km from the inner ring
  EXPECT_NEAR(distance_at(3.2, 5.0), 250.0f, 1e-3);
}

TEST(VectorEngine, HvScanErrorMeasured) {
  double worst = 0.0;
  int64_t wrong = 0, cells = 0;
  for (const char* name : {"all_types.geojson", "hole.geojson", "touching.geojson", "coast.gpkg"}) {
    const LoadedSeeds l = load({fixture(name)});
    const GridSpec g = fixture_grid(l, 53.0);
    const NearestField brute = run(l.seeds, g, Method::brute_force);
    const ValidationStats hv = compare_fields(l.seeds, run(l.seeds, g, Method::hv_scan), brute);
    EXPECT_EQ(hv.nodata_mismatch, 0) << name;
    // Line and area seeds have no proven bound; on these fixtures the scan stays within a cell.
    EXPECT_LT(hv.max_error_cells, 1.0) << name;
    worst = std::max(worst, hv.max_error_cells);
    wrong += hv.wrong_cells;
    cells += hv.cells;
  }
  RecordProperty("hv_worst_error_cells", std::to_string(worst));
  RecordProperty("hv_wrong_cells", std::to_string(wrong) + " of " + std::to_string(cells));
  std::printf("hv-scan on the vector fixtures: worst error %.4f cells, %lld wrong cells of %lld\n", worst,
              static_cast<long long>(wrong), static_cast<long long>(cells));
}

}  // namespace
}  // namespace rv
