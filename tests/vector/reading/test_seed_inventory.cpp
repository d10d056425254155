// describe_seed_files(): what seed files hold, without reading them as seeds.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "vector_test_util.hpp"

namespace rv {
namespace {

using test::expect_error;
using test::fixture;

SeedInventory describe(std::vector<std::string> paths, bool features = true, std::string target = {}) {
  SeedReadOptions o;
  o.paths = std::move(paths);
  o.target_crs = std::move(target);
  return describe_seed_files(o, features);
}

const SeedFieldSummary& field(const SeedLayerSummary& l, const std::string& name) {
  for (const SeedFieldSummary& f : l.fields)
    if (f.name == name) return f;
  throw std::runtime_error("no field " + name);
}

TEST(SeedInventory, LayersFieldsValuesAndTheBox) {
  const SeedInventory inv = describe({fixture("coast.gpkg")});
  ASSERT_EQ(inv.layers.size(), 3u);  // points, lines, polygons
  EXPECT_EQ(inv.crs_code, "EPSG:32633");
  EXPECT_FALSE(inv.crs.geographic);
  int64_t features = 0;
  for (const SeedLayerSummary& l : inv.layers) {
    features += l.features;
    const SeedFieldSummary& owner = field(l, "owner");
    EXPECT_EQ(owner.type, "string");
    EXPECT_EQ(owner.non_null, l.features);
    EXPECT_TRUE(owner.distinct_exact);
    EXPECT_EQ(static_cast<size_t>(owner.distinct), owner.values.size());
    ASSERT_FALSE(l.geometry_types.empty()) << l.name;
  }
  EXPECT_EQ(inv.layers[0].geometry_types, std::vector<std::string>{"Multi Point"});  // as the GeoPackage stores them
  EXPECT_EQ(static_cast<int64_t>(inv.features.size()), features);
  // Positions count across layers in reading order, as load_seeds numbers features.
  for (size_t i = 0; i < inv.features.size(); ++i) EXPECT_EQ(inv.features[i].position, static_cast<int64_t>(i + 1));
  // The box is the seeds' box: the same as load_seeds gives.
  SeedReadOptions o;
  o.paths = {fixture("coast.gpkg")};
  o.owner_field = "owner";
  const SeedSet::Box b = load_seeds(o).seeds.bounds();
  ASSERT_TRUE(inv.bounds);
  EXPECT_DOUBLE_EQ(inv.bounds->xmin, b.xmin);
  EXPECT_DOUBLE_EQ(inv.bounds->ymin, b.ymin);
  EXPECT_DOUBLE_EQ(inv.bounds->xmax, b.xmax);
  EXPECT_DOUBLE_EQ(inv.bounds->ymax, b.ymax);
  // Without features, the same summary and no features.
  const SeedInventory bare = describe({fixture("coast.gpkg")}, false);
  EXPECT_TRUE(bare.features.empty());
  EXPECT_EQ(bare.layers.size(), 3u);
}

TEST(SeedInventory, OverlappingOwnersAreDescribedNotRefused) {
  SeedReadOptions o;
  o.paths = {fixture("overlap.geojson")};
  expect_error(ErrorKind::conflict, [&] { load_seeds(o); });
  const SeedInventory inv = describe({fixture("overlap.geojson")});
  ASSERT_EQ(inv.features.size(), 2u);
  EXPECT_EQ(inv.features[0].values[0].value_or(""), "A");
  EXPECT_NE(inv.features[0].geometry.find("\"Polygon\""), std::string::npos);
}

TEST(SeedInventory, EmptyGeometriesAndNullsAreCounted) {
  const SeedInventory inv = describe({fixture("empty_geometry.geojson")});
  ASSERT_EQ(inv.layers.size(), 1u);
  EXPECT_GE(inv.layers[0].empty, 1);
  bool null_geometry = false;
  for (const SeedPreviewFeature& f : inv.features) null_geometry |= f.geometry == "null";
  EXPECT_TRUE(null_geometry);
  const SeedInventory nulls = describe({fixture("null_owner.geojson")});
  const SeedFieldSummary& owner = field(nulls.layers[0], "owner");
  EXPECT_LT(owner.non_null, nulls.layers[0].features);
}

TEST(SeedInventory, FeaturesComeInTheTargetCrs) {
  const SeedInventory utm = describe({fixture("coast_points.geojson")});
  const SeedInventory geo = describe({fixture("coast_points.geojson")}, true, "EPSG:4326");
  EXPECT_EQ(geo.crs_code, "EPSG:4326");
  EXPECT_TRUE(geo.crs.geographic);
  ASSERT_TRUE(geo.bounds && utm.bounds);
  // UTM 33N near 400 km easting, 6200 km northing: about 13.4 E, 55.9 N.
  EXPECT_GT(geo.bounds->xmin, 12.0);
  EXPECT_LT(geo.bounds->xmax, 15.0);
  EXPECT_GT(geo.bounds->ymin, 55.0);
  EXPECT_LT(geo.bounds->ymax, 57.0);
  EXPECT_NE(geo.features[0].geometry, utm.features[0].geometry);
}

TEST(SeedInventory, CurvesAreLinearisedForDrawing) {
  const SeedInventory inv = describe({fixture("curves.gpkg")});
  for (const SeedPreviewFeature& f : inv.features) {
    EXPECT_EQ(f.geometry.find("Curve"), std::string::npos) << f.geometry.substr(0, 80);
    EXPECT_EQ(f.geometry.find("Circular"), std::string::npos) << f.geometry.substr(0, 80);
  }
}

TEST(SeedInventory, DistinctValuesAreCappedAndListedInReadingOrder) {
  test::ScratchDir dir;
  std::ostringstream json;
  const int n = static_cast<int>(SeedFieldSummary::kMaxDistinct) + 200;
  json
      << R"({"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},"features":[)";
  for (int i = 0; i < n; ++i)
    json << (i ? "," : "") << R"({"type":"Feature","properties":{"id":)" << i << R"(,"state":")" << (i % 3 ? "B" : "A")
         << R"(","w":)" << (0.5 + i) << R"(},"geometry":{"type":"Point","coordinates":[)" << 400000 + i
         << ",6200000]}}";
  json << "]}";
  const SeedInventory inv = describe({dir.write("many.geojson", json.str())}, false);
  const SeedLayerSummary& l = inv.layers[0];
  EXPECT_EQ(l.features, n);
  const SeedFieldSummary& id = field(l, "id");
  EXPECT_EQ(id.type, "integer");
  EXPECT_FALSE(id.distinct_exact);
  EXPECT_EQ(id.distinct, SeedFieldSummary::kMaxDistinct);
  EXPECT_EQ(id.values.size(), SeedFieldSummary::kMaxValues);
  EXPECT_EQ(id.values[0], "0");
  EXPECT_EQ(id.values[1], "1");
  const SeedFieldSummary& state = field(l, "state");
  EXPECT_TRUE(state.distinct_exact);
  EXPECT_EQ(state.distinct, 2);
  EXPECT_EQ(state.values, (std::vector<std::string>{"A", "B"}));
  EXPECT_EQ(field(l, "w").type, "real");
}

TEST(SeedInventory, LimitsApplyAsToASeedRun) {
  SeedReadOptions o;
  o.paths = {fixture("coast.gpkg")};
  o.max_features = 2;
  expect_error(ErrorKind::too_large, [&] { describe_seed_files(o, true); }, {"features"});
  o.max_features = 0;
  o.max_vertices = 3;
  expect_error(ErrorKind::too_large, [&] { describe_seed_files(o, true); }, {"vertices"});
  SeedReadOptions missing;
  missing.paths = {(test::source_dir() / "fixtures" / "no_such_file.geojson").string()};
  expect_error(ErrorKind::not_found, [&] { describe_seed_files(missing, false); });
}

TEST(SeedInventory, TextFromTheDataIsEscaped) {
  test::ScratchDir dir;
  const std::string bad =
      "st\xff"
      "ate";
  const std::string path =
      dir.write("bad.geojson", R"({"type":"FeatureCollection","features":[{"type":"Feature","properties":{")" + bad +
                                   R"(":"v\u00e4l"},"geometry":{"type":"Point","coordinates":[1,2]}}]})");
  const SeedInventory inv = describe({path});
  ASSERT_EQ(inv.layers[0].fields.size(), 1u);
  EXPECT_EQ(inv.layers[0].fields[0].name, "st\\xFFate");
  EXPECT_EQ(inv.features[0].values[0].value_or(""), "v\xc3\xa4l");
}

}  // namespace
}  // namespace rv
