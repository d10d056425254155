// Barriers read as seeds are: land polygons from a real coast, lines that cross each other,
// features mixing both, and point features refused by name.
#include <gtest/gtest.h>

#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/sea/visibility.hpp"
#include "vector_test_util.hpp"

namespace rv {
namespace {

using test::expect_error;
using test::fixture;

LoadedBarriers load(std::vector<std::string> paths, std::string target = {}) {
  SeedReadOptions o;
  o.paths = std::move(paths);
  o.target_crs = std::move(target);
  o.owner_field = "iso2";  // ignored: every feature is a barrier of its own
  return load_barriers(o);
}

TEST(BarrierReader, TheWesternBalticsLandOverlapsAtItsBorders) {
  // Four states' land, overlapping by slivers along two land borders: read whole, no conflict.
  const LoadedBarriers b = load({fixture("baltic_west.gpkg")}, "EPSG:32633");
  EXPECT_EQ(b.barriers.polygons().size(), 113u);
  EXPECT_TRUE(b.barriers.lines().empty());
  EXPECT_EQ(b.report.features_read, 4);
  EXPECT_EQ(b.report.conflicts, 0);
  EXPECT_GT(b.barriers.vertex_count(), 7000);
  EXPECT_NE(b.barriers.name(0).find("baltic_west.gpkg:states:fid"), std::string::npos) << b.barriers.name(0);
  EXPECT_EQ(b.crs.name, "WGS 84 / UTM zone 33N");
  // Zealand is land, the Øresund between Copenhagen and Malmö is sea (UTM 33N).
  const Visibility vis(b.barriers);
  EXPECT_TRUE(vis.on_land({297636, 6149525}));   // central Zealand (11.8 E, 55.45 N)
  EXPECT_FALSE(vis.on_land({358601, 6174985}));  // the Øresund (12.75 E, 55.70 N)
}

TEST(BarrierReader, LinesCrossAndMixedFeaturesKeepBoth) {
  test::ScratchDir dir;
  const std::string path = dir.write("barriers.geojson", R"({"type": "FeatureCollection",
"crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
"features": [
{"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": [[400000, 6200000], [404000, 6204000]]}},
{"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": [[400000, 6204000], [404000, 6200000]]}},
{"type": "Feature", "properties": {}, "geometry": {"type": "MultiLineString", "coordinates": [[[410000, 6200000], [411000, 6200000], [411000, 6201000]], [[415000, 6200000], [416000, 6200000]]]}},
{"type": "Feature", "properties": {}, "geometry": {"type": "GeometryCollection", "geometries": [
  {"type": "Polygon", "coordinates": [[[420000, 6200000], [421000, 6200000], [421000, 6201000], [420000, 6200000]]]},
  {"type": "LineString", "coordinates": [[422000, 6200000], [423000, 6200000]]}]}}
]})");
  SeedReadOptions o;
  o.paths = {path};
  const LoadedBarriers b = load_barriers(o);
  EXPECT_EQ(b.barriers.polygons().size(), 1u);
  ASSERT_EQ(b.barriers.lines().size(), 5u);  // two crossing, two parts of one, one beside a polygon
  EXPECT_EQ(b.barriers.lines()[2].vertices.size(), 3u);
  EXPECT_EQ(b.barriers.lines()[2].vertices[2], (Vec2{411000, 6201000}));
  EXPECT_EQ(b.barriers.lines()[4].vertices.front(), (Vec2{422000, 6200000}));
  const Visibility vis(b.barriers);
  EXPECT_FALSE(vis.sees({{401000, 6202000 + 500}}, {{401000, 6202000 - 1500}}));  // through a crossing line
}

TEST(BarrierReader, PointsAreRefusedByName) {
  SeedReadOptions o;
  o.paths = {fixture("coast_points.geojson")};
  expect_error(ErrorKind::invalid_input, [&] { load_barriers(o); },
               {"coast_points.geojson", "is a point: barriers are polygons and lines"});
}

}  // namespace
}  // namespace rv
