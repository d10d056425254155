// Reading seed layers: formats, geometry types, owners, CRS, normalisation, input errors.
#include <gtest/gtest.h>

#include <gdal_priv.h>
#include <ogrsf_frmts.h>
#include <GeographicLib/UTMUPS.hpp>

#include <cmath>
#include <set>
#include <thread>

#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "vector_test_util.hpp"

namespace rv {
namespace {

using test::expect_error;
using test::fixture;

constexpr double kX0 = 400000.0, kY0 = 6200000.0;  // fixture origin (make_fixtures.py)
Vec2 km(double u, double v) { return Vec2{kX0 + 1000.0 * u, kY0 + 1000.0 * v}; }

LoadedSeeds load(std::vector<std::string> paths, std::optional<std::string> owner = "owner",
                 std::vector<std::string> layers = {}, std::string target = {}) {
  SeedReadOptions o;
  o.paths = std::move(paths);
  o.owner_field = std::move(owner);
  o.layers = std::move(layers);
  o.target_crs = std::move(target);
  return load_seeds(o);
}

const std::vector<std::string> kCoastLayers = {"points", "lines", "polygons"};

LoadedSeeds coast_geojson() {
  return load({fixture("coast_points.geojson"), fixture("coast_lines.geojson"), fixture("coast_polygons.geojson")});
}

TEST(SeedReader, CoastIsTheSameFromGeoJsonGeoPackageAndZippedShapefile) {
  gdal_init();
  const LoadedSeeds json = coast_geojson();
  const LoadedSeeds gpkg = load({fixture("coast.gpkg")}, "owner", kCoastLayers);
  // A plain .zip path: opened through /vsizip/ automatically.
  const LoadedSeeds shp = load({fixture("coast_shp.zip")}, "owner", kCoastLayers);
  test::expect_same_seeds(json.seeds, gpkg.seeds, "GeoJSON vs GeoPackage");
  test::expect_same_seeds(json.seeds, shp.seeds, "GeoJSON vs zipped Shapefile");
  for (const LoadedSeeds* l : {&json, &gpkg, &shp}) {
    EXPECT_EQ(l->report.features_read, 6);
    EXPECT_EQ(l->report.vertices_removed, 1);  // the repeated (2, 5.5) of the line
    EXPECT_EQ(l->report.points_removed, 1);    // the repeated (8, 1) of the multipoint
    EXPECT_EQ(l->report.polygons_repaired, 0);
    EXPECT_TRUE(l->crs.name.find("UTM zone 33N") != std::string::npos) << l->crs.name;
    EXPECT_FALSE(l->crs.geographic);
  }
  // Owners by first appearance: A, B (points), A, C (lines), B, A (polygons). Features are
  // stored grouped by owner code, in input order within an owner.
  EXPECT_EQ(json.seeds.owner_labels(), (std::vector<std::string>{"A", "B", "C"}));
  std::vector<int32_t> owners;
  std::vector<std::string> sources;
  for (const Feature& f : gpkg.seeds.features()) {
    owners.push_back(f.owner);
    sources.push_back(f.source.str().substr(f.source.str().find("coast.gpkg:")));  // file:layer:fid
  }
  EXPECT_EQ(owners, (std::vector<int32_t>{1, 1, 1, 2, 2, 3}));
  EXPECT_EQ(gpkg.input_position, (std::vector<int64_t>{1, 3, 6, 2, 5, 4}));
  EXPECT_EQ(sources, (std::vector<std::string>{"coast.gpkg:points:fid 1", "coast.gpkg:lines:fid 1",
                                               "coast.gpkg:polygons:fid 2", "coast.gpkg:points:fid 2",
                                               "coast.gpkg:polygons:fid 1", "coast.gpkg:lines:fid 2"}));
}

TEST(SeedReader, ZipWithoutLayerNamesReadsEveryShapefile) {
  const LoadedSeeds shp = load({fixture("coast_shp.zip")});
  EXPECT_EQ(shp.report.features_read, 6);
  EXPECT_EQ(shp.seeds.owner_count(), 3);
  EXPECT_EQ(shp.seeds.polygons().size(), 3u);  // the holed square and the two-part multipolygon
}

TEST(SeedReader, EveryGeometryTypeFromGeoJsonGeoPackageAndFlatGeobuf) {
  const LoadedSeeds json = load({fixture("all_types.geojson")});
  const LoadedSeeds gpkg = load({fixture("all_types.gpkg")});
  const LoadedSeeds fgb = load({fixture("all_types.fgb")});
  test::expect_same_seeds(json.seeds, gpkg.seeds, "GeoJSON vs GeoPackage");
  test::expect_same_seeds(json.seeds, fgb.seeds, "GeoJSON vs FlatGeobuf");

  const SeedSet& s = json.seeds;
  ASSERT_EQ(s.features().size(), 8u);
  // In owner order: the 3D line (input feature 8) shares owner "L" and follows the first line.
  const std::vector<GeometryKind> kinds = {GeometryKind::point,   GeometryKind::point, GeometryKind::line,
                                           GeometryKind::line,    GeometryKind::line,  GeometryKind::polygon,
                                           GeometryKind::polygon, GeometryKind::mixed};
  for (size_t i = 0; i < kinds.size(); ++i) EXPECT_EQ(s.features()[i].kind, kinds[i]) << "feature " << i;
  EXPECT_EQ(s.owner_labels(), (std::vector<std::string>{"P", "MP", "L", "ML", "H", "MPG", "GC"}));
  EXPECT_EQ(s.features()[3].owner, 3);
  EXPECT_NE(s.features()[3].source.str().find("all_types:fid 7"), std::string::npos) << s.features()[3].source;
  // 1 + 2 points, 2 + 2 segments, holed square 4 + 4 + area, two squares 2 x (4 + area),
  // collection point + segment, 3D line 1 segment.
  EXPECT_EQ(s.sites().size(), 29u);
  ASSERT_EQ(s.polygons().size(), 3u);
  EXPECT_EQ(s.polygons()[0].rings.size(), 2u);  // the hole is kept
  // Z dropped: the 3D line's one site is the 2D segment.
  int found = 0;
  for (const Site& site : s.sites()) {
    if (site.feature != 3) continue;
    ++found;
    EXPECT_EQ(site.a, km(8, 3));
    EXPECT_EQ(site.b, km(9, 3.5));
    EXPECT_EQ(site.kind, SiteKind::segment);
  }
  EXPECT_EQ(found, 1);
}

TEST(SeedReader, CurvesAreLinearised) {
  const LoadedSeeds c = load({fixture("curves.gpkg")});
  ASSERT_EQ(c.seeds.features().size(), 2u);
  EXPECT_EQ(c.seeds.features()[0].kind, GeometryKind::line);
  EXPECT_EQ(c.seeds.features()[1].kind, GeometryKind::polygon);
  int arc_segments = 0;
  for (const Site& site : c.seeds.sites()) {
    if (site.kind == SiteKind::area) continue;
    // The arc through (1,1), (2,2), (3,1) km lies on the circle of radius 1 km about (2, 1);
    // the disc's boundary on the circle of radius 1 km about (7, 5).
    const Vec2 centre = site.feature == 0 ? km(2, 1) : km(7, 5);
    for (const Vec2& p : {site.a, site.b}) EXPECT_NEAR(std::hypot(p.x - centre.x, p.y - centre.y), 1000.0, 1e-6);
    arc_segments += site.feature == 0;
  }
  EXPECT_GE(arc_segments, 180);  // a half circle in steps of at most 1 degree
}

TEST(SeedReader, KmlPlacemarksReprojected) {
  const LoadedSeeds k = load({fixture("placemarks.kml")}, "Name", {}, "EPSG:32633");
  EXPECT_EQ(k.seeds.owner_labels(), (std::vector<std::string>{"Malmo", "Helsingor", "Coast"}));
  double x = 0, y = 0;
  int zone = 0;
  bool north = true;
  GeographicLib::UTMUPS::Forward(55.6, 13.0, zone, north, x, y, 33);
  EXPECT_NEAR(k.seeds.sites()[0].a.x, x, 1e-3);
  EXPECT_NEAR(k.seeds.sites()[0].a.y, y, 1e-3);
}

TEST(SeedReader, OwnersWithoutFieldArePositions) {
  const LoadedSeeds l = load({fixture("coast.gpkg")}, std::nullopt, kCoastLayers);
  EXPECT_EQ(l.seeds.owner_labels(), (std::vector<std::string>{"1", "2", "3", "4", "5", "6"}));
  for (size_t i = 0; i < l.seeds.features().size(); ++i)
    EXPECT_EQ(l.seeds.features()[i].owner, static_cast<int32_t>(i + 1));
  // Positions count the input: an empty feature keeps its number.
  const LoadedSeeds e = load({fixture("empty_geometry.geojson")}, std::nullopt);
  EXPECT_EQ(e.seeds.owner_labels(), (std::vector<std::string>{"1", "3"}));
  EXPECT_EQ(e.input_position, (std::vector<int64_t>{1, 3}));
  EXPECT_EQ(e.report.features_skipped_empty, 1);
  EXPECT_EQ(e.report.features_read, 2);
  ASSERT_FALSE(e.report.warnings.empty());
  EXPECT_NE(e.report.warnings[0].find("empty_geometry.geojson:empty_geometry:fid 1"), std::string::npos)
      << e.report.warnings[0];
}

TEST(SeedReader, LayerInAnotherCrsLandsWhereExpected) {
  // Default target: the first layer's CRS (UTM 33N); the lon/lat layer is reprojected.
  const LoadedSeeds l = load({fixture("other_crs.gpkg")});
  ASSERT_EQ(l.seeds.sites().size(), 3u);
  EXPECT_EQ(l.seeds.sites()[0].a, km(0, 0));
  const double lonlat[2][2] = {{15.0, 56.0}, {12.5, 55.7}};
  for (int i = 0; i < 2; ++i) {
    double x = 0, y = 0;
    int zone = 0;
    bool north = true;
    GeographicLib::UTMUPS::Forward(lonlat[i][1], lonlat[i][0], zone, north, x, y, 33);
    EXPECT_NEAR(l.seeds.sites()[1 + i].a.x, x, 1e-3) << i;
    EXPECT_NEAR(l.seeds.sites()[1 + i].a.y, y, 1e-3) << i;
  }
  EXPECT_NEAR(l.seeds.sites()[1].a.x, 500000.0, 1e-6);  // 15 E is the zone's central meridian

  // Into longitude/latitude: x is the longitude (traditional GIS order).
  const LoadedSeeds g = load({fixture("other_crs.gpkg")}, "owner", {}, "EPSG:4326");
  EXPECT_TRUE(g.crs.geographic);
  EXPECT_DOUBLE_EQ(g.crs.semi_major, 6378137.0);
  EXPECT_NEAR(1.0 / g.crs.flattening, 298.257223563, 1e-9);
  double lat = 0, lon = 0;
  GeographicLib::UTMUPS::Reverse(33, true, km(0, 0).x, km(0, 0).y, lat, lon);
  EXPECT_NEAR(g.seeds.sites()[0].a.x, lon, 1e-8);
  EXPECT_NEAR(g.seeds.sites()[0].a.y, lat, 1e-8);
  EXPECT_NEAR(g.seeds.sites()[1].a.x, 15.0, 1e-12);
  EXPECT_NEAR(g.seeds.sites()[1].a.y, 56.0, 1e-12);
}

TEST(SeedReader, DescribeCrs) {
  const CrsInfo utm = describe_crs("EPSG:32633");
  EXPECT_FALSE(utm.geographic);
  EXPECT_EQ(utm.name, "WGS 84 / UTM zone 33N");
  EXPECT_DOUBLE_EQ(utm.linear_unit, 1.0);
  EXPECT_NE(utm.wkt.find("PROJCRS"), std::string::npos);  // WKT2
  const CrsInfo feet = describe_crs("EPSG:2263");         // NAD83 / New York Long Island (ftUS)
  EXPECT_NEAR(feet.linear_unit, 1200.0 / 3937.0, 1e-12);
  EXPECT_NEAR(feet.semi_major, 6378137.0, 1e-9);  // GRS80
  EXPECT_NEAR(1.0 / feet.flattening, 298.257222101, 1e-6);
  const CrsInfo geo = describe_crs("+proj=longlat +ellps=intl +no_defs");
  EXPECT_TRUE(geo.geographic);
  EXPECT_DOUBLE_EQ(geo.semi_major, 6378388.0);
  expect_error(ErrorKind::invalid_argument, [] { describe_crs("not a crs at all"); });
}

TEST(SeedReader, LayersWithoutCrs) {
  const LoadedSeeds l = load({fixture("no_crs_shp.zip")});
  EXPECT_TRUE(l.crs.wkt.empty());
  EXPECT_EQ(l.seeds.sites()[1].a, (Vec2{20.0, 10.0}));
  bool warned = false;
  for (const std::string& w : l.report.warnings) warned |= w.find("no layer has a CRS") != std::string::npos;
  EXPECT_TRUE(warned);
  expect_error(ErrorKind::invalid_input,
               [] {
                 load({fixture("other_crs.gpkg"), fixture("no_crs_shp.zip")});
               },
               {"no_crs_shp.zip:plain", "has no CRS"});
  expect_error(ErrorKind::invalid_input, [] { load({fixture("no_crs_shp.zip")}, "owner", {}, "EPSG:32633"); },
               {"has no CRS"});
}

TEST(SeedReader, InputErrors) {
  test::ScratchDir dir;
  expect_error(ErrorKind::not_found, [&] { load({dir.file("missing.gpkg")}); }, {"missing.gpkg"});
  expect_error(ErrorKind::not_found, [&] { load({dir.file("missing.zip")}); }, {"missing.zip"});
  const std::string text = dir.write("notes.txt", "this is not a vector dataset\n");
  expect_error(ErrorKind::invalid_input, [&] { load({text}); }, {"notes.txt", "not a vector dataset"});
  // A raster is not a vector dataset either.
  GridSpec g;
  g.width = g.height = 4;
  g.ymax = 4;
  write_geotiff(dir.file("r.tif"), Raster<int32_t>(g, 1), 0, {});
  expect_error(ErrorKind::invalid_input, [&] { load({dir.file("r.tif")}); }, {"r.tif", "not a vector dataset"});
  // A layer or field the data does not have is a bad argument (400 in the daemon), not a missing
  // resource: the data is there.
  expect_error(ErrorKind::invalid_argument, [] { load({fixture("coast.gpkg")}, "owner", {"harbours"}); },
               {"'harbours'", "points, lines, polygons"});
  expect_error(ErrorKind::invalid_argument, [] { load({fixture("coast.gpkg")}, "country"); }, {"'country'", "owner"});
  expect_error(ErrorKind::invalid_input, [] { load({fixture("null_owner.geojson")}); },
               {"null_owner.geojson:null_owner:fid 1", "null or missing"});
  expect_error(ErrorKind::invalid_argument, [] { load({fixture("coast.gpkg")}, "owner", {}, "EPSG:999999"); });

  const auto geojson = [&](const std::string& name, const std::string& geometry, const std::string& crs = "") {
    return dir.write(name, R"({"type": "FeatureCollection", )" + crs +
                               R"( "features": [ {"type": "Feature", "properties": {"owner": "A"}, "geometry": )" +
                               geometry + "} ] }");
  };
  const std::string utm = R"("crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},)";
  expect_error(
      ErrorKind::invalid_input,
      [&] { load({geojson("nan_line.geojson", R"({"type": "LineString", "coordinates": [[1, 2], [NaN, 3]]})", utm)}); },
      {"nan_line.geojson:nan_line:fid 0", "non-finite"});
  // OGR flags a point with a NaN coordinate as empty; it must still be an error, not a skip.
  expect_error(ErrorKind::invalid_input,
               [&] { load({geojson("nan_point.geojson", R"({"type": "Point", "coordinates": [NaN, 3]})", utm)}); },
               {"nan_point.geojson", "non-finite"});
  expect_error(ErrorKind::invalid_input,
               [&] { load({geojson("inf.geojson", R"({"type": "Point", "coordinates": [Infinity, 3]})", utm)}); },
               {"inf.geojson", "non-finite"});
  // GeoJSON without "crs" is WGS 84 longitude/latitude.
  expect_error(
      ErrorKind::invalid_input,
      [&] { load({geojson("lat.geojson", R"({"type": "LineString", "coordinates": [[10, 50], [10, 91]]})")}); },
      {"lat.geojson:lat:fid 0", "latitude 91"});
  expect_error(ErrorKind::invalid_input,
               [&] { load({geojson("only_empty.geojson", R"({"type": "Point", "coordinates": []})", utm)}); },
               {"no seed features"});
}

TEST(SeedReader, AllowedDrivers) {
  SeedReadOptions o;
  o.paths = {fixture("hole.geojson")};
  o.owner_field = "owner";
  o.allowed_drivers = {"GPKG"};
  expect_error(ErrorKind::invalid_input, [&] { load_seeds(o); }, {"hole.geojson", "GPKG"});
  o.allowed_drivers = {"GeoJSON"};
  EXPECT_EQ(load_seeds(o).report.features_read, 2);
}

TEST(SeedReader, SelfIntersectingPolygonIsRepairedAndReported) {
  const LoadedSeeds l = load({fixture("self_intersecting.geojson")});
  EXPECT_EQ(l.report.polygons_repaired, 1);
  bool named = false;
  for (const std::string& w : l.report.warnings)
    named |= w.find("self_intersecting.geojson:self_intersecting:fid 0") != std::string::npos &&
             w.find("repaired") != std::string::npos;
  EXPECT_TRUE(named);
  // The bow-tie becomes its two triangles.
  int parts = 0;
  for (const Polygon& p : l.seeds.polygons()) parts += p.feature == 0;
  EXPECT_EQ(parts, 2);
}

TEST(SeedReader, PolygonRepairsAndUnrepairablePolygons) {
  test::ScratchDir dir;
  const auto feature = [](const std::string& owner, const std::string& rings) {
    return R"({"type": "Feature", "properties": {"owner": ")" + owner +
           R"("}, "geometry": {"type": "Polygon", "coordinates": )" + rings + "}}";
  };
  const auto collection = [](const std::string& features) {
    return R"({"type": "FeatureCollection", "features": [)" + features + "]}";
  };
  // An unclosed ring (GDAL accepts it), a hole outside its shell, a degenerate hole.
  const std::string fixable = dir.write(
      "fixable.geojson",
      collection(feature("A", "[[[0, 0], [0, 1], [1, 1], [1, 0]]]") + "," +
                 feature("B", "[[[2, 2], [2, 3], [3, 3], [3, 2], [2, 2]], [[4, 4], [5, 4], [5, 5], [4, 4]]]") + "," +
                 feature("C", "[[[6, 6], [6, 7], [7, 7], [6, 6]], [[6.2, 6.5], [6.3, 6.6], [6.2, 6.5]]]")));
  const LoadedSeeds l = load({fixable});
  EXPECT_EQ(l.report.polygons_repaired, 3);
  const auto warned = [&](const std::string& a, const std::string& b) {
    for (const std::string& w : l.report.warnings)
      if (w.find(a) != std::string::npos && w.find(b) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(warned("fixable.geojson:fixable:fid 0", "unclosed ring closed"));
  EXPECT_TRUE(warned("fixable.geojson:fixable:fid 1", "repaired into 2 polygon(s)"));
  EXPECT_TRUE(warned("fixable.geojson:fixable:fid 2", "degenerate hole dropped"));
  EXPECT_EQ(l.seeds.polygons().size(), 4u);
  // A polygon without area cannot be repaired into one.
  const std::string flat = dir.write("flat.geojson", collection(feature("A", "[[[8, 8], [8, 9], [8, 8]]]")));
  expect_error(ErrorKind::invalid_input, [&] { load({flat}); }, {"flat.geojson:flat:fid 0", "fewer than 3"});
  const std::string spike =
      dir.write("line_polygon.geojson", collection(feature("A", "[[[0, 0], [1, 1], [2, 2], [0, 0]]]")));
  expect_error(ErrorKind::invalid_input, [&] { load({spike}); },
               {"line_polygon.geojson:line_polygon:fid 0", "cannot be repaired"});
}

TEST(SeedReader, MeasuresAndZDroppedAndVsimemPaths) {
  gdal_init();
  // A GeoPackage in GDAL's in-memory file system, with XYM and XYZM geometry.
  const std::string path = "/vsimem/rv_test_measured.gpkg";
  {
    std::unique_ptr<GDALDataset> ds(
        GetGDALDriverManager()->GetDriverByName("GPKG")->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
    ASSERT_TRUE(ds);
    OGRSpatialReference utm;
    utm.importFromEPSG(32633);
    OGRLayer* layer = ds->CreateLayer("measured", &utm, wkbUnknown, nullptr);
    OGRFieldDefn field("owner", OFTString);
    ASSERT_EQ(layer->CreateField(&field), OGRERR_NONE);
    for (const char* wkt : {"LINESTRING M (400000 6200000 5, 401000 6200000 7)", "POINT ZM (402000 6201000 3 4)"}) {
      OGRFeature f(layer->GetLayerDefn());
      f.SetField("owner", wkt);
      OGRGeometry* g = nullptr;
      ASSERT_EQ(OGRGeometryFactory::createFromWkt(wkt, nullptr, &g), OGRERR_NONE);
      f.SetGeometryDirectly(g);
      ASSERT_EQ(layer->CreateFeature(&f), OGRERR_NONE);
    }
  }
  const LoadedSeeds l = load({path});
  VSIUnlink(path.c_str());
  ASSERT_EQ(l.seeds.sites().size(), 2u);
  EXPECT_EQ(l.seeds.sites()[0].a, (Vec2{400000.0, 6200000.0}));
  EXPECT_EQ(l.seeds.sites()[0].b, (Vec2{401000.0, 6200000.0}));
  EXPECT_EQ(l.seeds.sites()[1].a, (Vec2{402000.0, 6201000.0}));
  EXPECT_EQ(l.seeds.sites()[1].kind, SiteKind::point);
  expect_error(ErrorKind::not_found, [] { load({"/vsimem/rv_test_nothing.gpkg"}); }, {"rv_test_nothing"});
}

TEST(SeedReader, ConcurrentLoadsAgree) {
  const LoadedSeeds reference = load({fixture("coast.gpkg")}, "owner", kCoastLayers);
  std::vector<std::thread> threads;
  std::vector<LoadedSeeds> results(4);
  for (size_t i = 0; i < results.size(); ++i)
    threads.emplace_back([&, i] { results[i] = load({fixture("coast.gpkg")}, "owner", kCoastLayers); });
  for (auto& t : threads) t.join();
  for (const LoadedSeeds& r : results) test::expect_same_seeds(reference.seeds, r.seeds, "concurrent");
}

}  // namespace
}  // namespace rv
