// The datum transformation each reprojected layer goes through: chosen for its area, stated in
// the report with its accuracy, and refused when it is a ballpark one or less accurate than asked
// (unless allowed). The references: EPSG's operations as PROJ's database names them, and the
// shift between the datums (ED50 is about 100 m from WGS 84 in the North Sea).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <ogr_api.h>
#include <ogr_spatialref.h>
#include <ogrsf_frmts.h>

#include "rv/gdal/seed_reader.hpp"
#include "vector_test_util.hpp"

namespace rv {
namespace {

using test::expect_error;

// A GeoPackage with one layer of points (lon/lat or easting/northing in `srs`), owners A and B.
std::string points_layer(const test::ScratchDir& dir, const std::string& name, const OGRSpatialReference& srs,
                         std::vector<std::pair<double, double>> xy) {
  const std::string path = dir.file(name + ".gpkg");
  GDALDriver* gpkg = GetGDALDriverManager()->GetDriverByName("GPKG");
  GDALDataset* ds = gpkg->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr);
  OGRSpatialReference s(srs);
  s.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  OGRLayer* layer = ds->CreateLayer(name.c_str(), &s, wkbPoint, nullptr);
  OGRFieldDefn owner("owner", OFTString);
  layer->CreateField(&owner);
  int k = 0;
  for (const auto& [x, y] : xy) {
    OGRFeature* f = OGRFeature::CreateFeature(layer->GetLayerDefn());
    f->SetField("owner", k++ % 2 == 0 ? "A" : "B");
    OGRPoint p(x, y);
    f->SetGeometry(&p);
    EXPECT_EQ(layer->CreateFeature(f), OGRERR_NONE);
    OGRFeature::DestroyFeature(f);
  }
  GDALClose(ds);
  return path;
}

OGRSpatialReference epsg(int code) {
  OGRSpatialReference s;
  EXPECT_EQ(s.importFromEPSG(code), OGRERR_NONE);
  return s;
}

SeedReadOptions reading(const std::string& path, const std::string& target) {
  SeedReadOptions o;
  o.paths = {path};
  o.owner_field = "owner";
  o.target_crs = target;
  return o;
}

TEST(Transformations, Ed50InTheNorthSeaIsStatedWithItsAccuracy) {
  GDALAllRegister();
  const test::ScratchDir dir;
  const std::string path = points_layer(dir, "ed50", epsg(4230), {{3.0, 56.0}, {3.2, 56.1}});
  const LoadedSeeds l = load_seeds(reading(path, "EPSG:4326"));
  ASSERT_EQ(l.report.transformations.size(), 1u);
  const TransformStatement& t = l.report.transformations[0];
  EXPECT_NE(t.operation.find("ED50 to WGS 84"), std::string::npos) << t.operation;
  EXPECT_FALSE(t.ballpark);
  EXPECT_FALSE(t.conversion);
  EXPECT_GT(t.accuracy, 0.0);
  EXPECT_LE(t.accuracy, 1.0);
  EXPECT_NE(t.from.find("ED50"), std::string::npos);
  EXPECT_NE(t.to.find("WGS 84"), std::string::npos);
  // The datum shift was applied: the point moved by ~100 m (about 0.001 degree of longitude).
  const Vec2 p = l.seeds.sites()[0].a;
  const double moved = std::hypot((p.x - 3.0) * 111320.0 * std::cos(56.0 * M_PI / 180.0), (p.y - 56.0) * 111320.0);
  EXPECT_GT(moved, 50.0);
  EXPECT_LT(moved, 200.0);
}

TEST(Transformations, LessAccurateThanAskedIsRefusedNamingTheGrids) {
  GDALAllRegister();
  const test::ScratchDir dir;
  // NAD27 in Kansas: without NOAA's grids (not installed here) PROJ's best is a Helmert of ~7 m.
  const std::string path = points_layer(dir, "nad27", epsg(4267), {{-98.0, 38.0}, {-97.5, 38.2}});
  const std::string msg =
      expect_error(ErrorKind::invalid_input, [&] { load_seeds(reading(path, "EPSG:4326")); },
                   {"nad27.gpkg:nad27", "NAD27 to WGS 84", "worse than the 1 m accepted", "allow-ballpark"});
  EXPECT_NE(msg.find("grid(s)"), std::string::npos) << msg;  // the grids a better operation needs
  SeedReadOptions o = reading(path, "EPSG:4326");
  o.transform_accuracy = 25.0;
  const LoadedSeeds l = load_seeds(o);
  ASSERT_EQ(l.report.transformations.size(), 1u);
  EXPECT_GT(l.report.transformations[0].accuracy, 1.0);
  o.transform_accuracy = -1.0;
  expect_error(ErrorKind::invalid_argument, [&] { load_seeds(o); }, {"accepted transformation accuracy"});
  o.transform_accuracy = 25.0;
  EXPECT_LE(l.report.transformations[0].accuracy, 25.0);
  EXPECT_FALSE(l.report.transformations[0].missing_grids.empty());
}

TEST(Transformations, BallparkIsRefusedUnlessAllowed) {
  GDALAllRegister();
  const test::ScratchDir dir;
  // A geographic CRS on the International ellipsoid with no datum: PROJ knows no shift to WGS 84.
  OGRSpatialReference unknown;
  ASSERT_EQ(unknown.importFromProj4("+proj=longlat +ellps=intl +no_defs"), OGRERR_NONE);
  const std::string path = points_layer(dir, "nodatum", unknown, {{3.0, 56.0}, {3.2, 56.1}});
  expect_error(ErrorKind::invalid_input, [&] { load_seeds(reading(path, "EPSG:4326")); },
               {"nodatum.gpkg:nodatum", "Ballpark", "is a ballpark one", "allow-ballpark accepts it"});
  SeedReadOptions o = reading(path, "EPSG:4326");
  o.allow_ballpark = true;
  const LoadedSeeds l = load_seeds(o);
  ASSERT_EQ(l.report.transformations.size(), 1u);
  EXPECT_TRUE(l.report.transformations[0].ballpark);
  bool warned = false;
  for (const std::string& w : l.report.warnings) warned |= w.find("accepted (allow-ballpark)") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(Transformations, ConversionsAreExact) {
  GDALAllRegister();
  const test::ScratchDir dir;
  // UTM 32N to WGS 84 longitude/latitude: the same datum, a conversion, accepted whatever the
  // accuracy asked.
  const std::string path = points_layer(dir, "utm", epsg(32632), {{500000.0, 6200000.0}, {510000.0, 6210000.0}});
  SeedReadOptions o = reading(path, "EPSG:4326");
  o.transform_accuracy = 0.0;
  const LoadedSeeds l = load_seeds(o);
  ASSERT_EQ(l.report.transformations.size(), 1u);
  EXPECT_TRUE(l.report.transformations[0].conversion);
  EXPECT_EQ(l.report.transformations[0].accuracy, 0.0);
  // 500000 E is the zone's central meridian, 9 E.
  EXPECT_NEAR(l.seeds.sites()[0].a.x, 9.0, 1e-9);
  // No reprojection, nothing stated.
  EXPECT_TRUE(load_seeds(reading(path, "")).report.transformations.empty());
}

}  // namespace
}  // namespace rv
