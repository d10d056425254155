// Conflicts between owners: overlapping polygons, crossing lines, a line entering another
// owner's polygon (errors naming both features and a location); touching is not a conflict;
// ConflictPolicy::lower_code accepts overlaps and the engine resolves them.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <regex>
#include <sstream>
#include <utility>
#include <vector>

#include "reading/normalise.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/interior.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "vector_test_util.hpp"

namespace rv {
namespace {

using test::expect_error;
using test::fixture;

constexpr double kX0 = 400000.0, kY0 = 6200000.0;

LoadedSeeds load(const std::string& name, ConflictPolicy policy = ConflictPolicy::error) {
  SeedReadOptions o;
  o.paths = {fixture(name)};
  o.owner_field = "owner";
  o.on_conflict = policy;
  return load_seeds(o);
}

// The "(x, y)" after "at " in a conflict message.
Vec2 location(const std::string& message) {
  std::smatch m;
  const std::regex re(R"(at \(([-0-9.eE+]+), ([-0-9.eE+]+)\))");
  if (!std::regex_search(message, m, re)) {
    ADD_FAILURE() << "no location in: " << message;
    return {};
  }
  return Vec2{std::stod(m[1]), std::stod(m[2])};
}

TEST(Conflicts, OverlappingPolygonsNameBothFeaturesAndALocation) {
  const std::string msg =
      expect_error(ErrorKind::conflict, [] { load("overlap.geojson"); },
                   {"overlap.geojson:overlap:fid 0", "overlap.geojson:overlap:fid 1", "'A'", "'B'", "overlap area"});
  const Vec2 p = location(msg);
  // The overlap is the square (3..4, 3..4) km.
  EXPECT_GT(p.x, kX0 + 3000.0);
  EXPECT_LT(p.x, kX0 + 4000.0);
  EXPECT_GT(p.y, kY0 + 3000.0);
  EXPECT_LT(p.y, kY0 + 4000.0);
}

TEST(Conflicts, CrossingLinesReportTheCrossing) {
  const std::string msg =
      expect_error(ErrorKind::conflict, [] { load("crossing_lines.geojson"); },
                   {"crossing_lines.geojson:crossing_lines:fid 0", "crossing_lines:fid 1", "cross"});
  const Vec2 p = location(msg);
  EXPECT_NEAR(p.x, kX0 + 2000.0, 1e-6);
  EXPECT_NEAR(p.y, kY0 + 2000.0, 1e-6);
}

TEST(Conflicts, LineIntoAnotherOwnersPolygon) {
  const std::string msg = expect_error(ErrorKind::conflict, [] { load("line_into_polygon.geojson"); },
                                       {"line_into_polygon:fid 0", "line_into_polygon:fid 1"});
  const Vec2 p = location(msg);
  // Inside polygon A (0..4 km square), on the line y = 2 km.
  EXPECT_GT(p.x, kX0 + 3000.0 - 1e-6);
  EXPECT_LT(p.x, kX0 + 4000.0 + 1e-6);
  EXPECT_NEAR(p.y, kY0 + 2000.0, 1e-6);
}

TEST(Conflicts, TouchingIsNotAConflict) {
  const LoadedSeeds l = load("touching.geojson");
  EXPECT_EQ(l.report.conflicts, 0);
  EXPECT_EQ(l.seeds.owner_count(), 5);
}

TEST(Conflicts, WithoutOwnerFieldEveryFeatureIsAnOwner) {
  // The same-owner line crossing polygon A in touching.geojson becomes a conflict when each
  // feature is its own owner.
  SeedReadOptions o;
  o.paths = {fixture("touching.geojson")};
  expect_error(ErrorKind::conflict, [&] { load_seeds(o); }, {"touching:fid 0", "touching:fid 5"});
}

TEST(Conflicts, LandBorderSliversAreListedNotConflicts) {
  // Two countries' squares sharing a border, A's side with three more vertices on it; read into
  // UTM 32N the border bends through A's vertices but not B's: a sliver ~4 mm wide, ~22 m^2.
  SeedReadOptions o;
  o.paths = {fixture("land_border.geojson")};
  o.owner_field = "owner";
  o.target_crs = "EPSG:32632";
  const LoadedSeeds l = load_seeds(o);
  EXPECT_EQ(l.report.conflicts, 0);
  ASSERT_EQ(l.report.sliver_count, 1);
  ASSERT_EQ(l.report.slivers.size(), 1u);
  const BorderSliver& s = l.report.slivers[0];
  EXPECT_EQ(s.feature_a, 0);
  EXPECT_EQ(s.feature_b, 1);
  // Its area and mean width, against the same overlap measured in UTM by GEOS (22.17 m^2,
  // 11,128.6 m of boundary: 2 A / P = 3.98 mm).
  EXPECT_NEAR(s.area, 22.17, 0.05);
  EXPECT_NEAR(s.mean_width, 0.00398, 0.0001);
  // On the border: 10.05 E, between 55.0 and 55.05 N, in UTM 32N metres.
  EXPECT_GT(s.x, 500000.0 + 60000.0);
  EXPECT_LT(s.x, 500000.0 + 80000.0);
  EXPECT_GT(s.y, 6094000.0);
  EXPECT_LT(s.y, 6101000.0);

  // Read in degrees (geographic: measured in metres on a local projection), the same sliver is
  // not there (the border is straight in degrees on both sides), and nothing is listed.
  o.target_crs = "";
  EXPECT_EQ(load_seeds(o).report.sliver_count, 0);

  // A tolerance below its width makes it a conflict again, said to be wider than the tolerance.
  o.target_crs = "EPSG:32632";
  o.border_tolerance = 0.002;
  expect_error(ErrorKind::conflict, [&] { load_seeds(o); },
               {"land_border:fid 0", "land_border:fid 1", "wider than the land-border tolerance, 0.002 m"});
  o.border_tolerance = 0.0;
  expect_error(ErrorKind::conflict, [&] { load_seeds(o); }, {"overlap area"});
  o.border_tolerance = -1.0;
  expect_error(ErrorKind::invalid_argument, [&] { load_seeds(o); }, {"land-border tolerance"});

  // A real overlap (1 km x 1 km) stays an error with the default tolerance, as any would be.
  EXPECT_EQ(SeedReadOptions{}.border_tolerance, 0.01);
  expect_error(ErrorKind::conflict, [] { load("overlap.geojson"); }, {"wider than the land-border tolerance"});
}

TEST(Conflicts, SliverWidthsInMetresOnGeographicData) {
  // A sliver given in degrees: measured in metres (azimuthal equidistant about it), so a 5 mm
  // wide strip 1 km long (at 55 N) is narrow for 0.01 m and not for 0.004 m.
  OGRSpatialReference wgs84;
  wgs84.SetWellKnownGeogCS("WGS84");
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  const double dlat = 0.005 / 111255.0;  // 5 mm of latitude at 55 N (meridian arc ~111,255 m/deg)
  OGRPolygon strip;
  OGRLinearRing r;
  for (const auto& [x, y] : std::vector<std::pair<double, double>>{
           {10.0, 55.0}, {10.0157, 55.0}, {10.0157, 55.0 + dlat}, {10.0, 55.0 + dlat}, {10.0, 55.0}})
    r.addPoint(x, y);
  strip.addRing(&r);
  double area = 0.0, width = 0.0;
  EXPECT_TRUE(detail::sliver_narrow(strip, &wgs84, 0.01, area, width));
  EXPECT_NEAR(width, 0.005, 0.0002);
  EXPECT_NEAR(area, 0.005 * 1000.0, 20.0 * 0.005);  // 0.0157 deg of longitude at 55 N ~ 1,001 m
  EXPECT_FALSE(detail::sliver_narrow(strip, &wgs84, 0.004, area, width));
  // Lines and points only (polygons that touch): no area, not a sliver.
  OGRLineString line;
  line.addPoint(10.0, 55.0);
  line.addPoint(10.1, 55.0);
  EXPECT_FALSE(detail::sliver_narrow(line, &wgs84, 0.01, area, width));
}

TEST(Conflicts, LowerCodeAcceptsAndTheEngineResolves) {
  const LoadedSeeds l = load("overlap.geojson", ConflictPolicy::lower_code);
  EXPECT_EQ(l.report.conflicts, 1);
  ASSERT_FALSE(l.report.warnings.empty());
  EXPECT_NE(l.report.warnings[0].find("'A' takes the overlap"), std::string::npos) << l.report.warnings[0];

  // 100 m cells over (0..6, 0..6) km.
  GridSpec g = make_grid(kX0, kY0, kX0 + 6000.0, kY0 + 6000.0, 100.0, l.crs.wkt);
  const InteriorSpans spans = build_interiors(l.seeds, g, g.full_window());
  EXPECT_EQ(spans.contested_cells, 100);  // the 10 x 10 cells of the overlap
  ComputeOptions co;
  co.threads = 2;
  const NearestField f = compute(l.seeds, g, co);
  // Cell centre (3.55, 3.55) km is inside both: owner A (code 1), distance 0.
  const int64_t col = 35, row = 60 - 1 - 35;
  const int32_t site = f.site.at(col, row);
  ASSERT_NE(site, kNoSite);
  EXPECT_EQ(l.seeds.site_owner(site), 1);
  EXPECT_EQ(f.distance.at(col, row), 0.0f);
  // Inside B only: (5, 5) km.
  EXPECT_EQ(l.seeds.site_owner(f.site.at(50, 60 - 1 - 50)), 2);
}

// Owners interleaved in the input (A, B, A): the overlap of B's square and A's second square
// still goes to A, the lower code, because features are stored grouped by owner.
TEST(Conflicts, LowerCodeWinsEvenWhenOwnersInterleave) {
  test::ScratchDir dir;
  const auto feature = [](const char* owner, const std::string& geometry) {
    return R"({"type": "Feature", "properties": {"owner": ")" + std::string(owner) + R"("}, "geometry": )" + geometry +
           "}";
  };
  const auto square = [](double u0, double v0, double u1, double v1) {
    std::ostringstream g;
    g.precision(12);
    g << R"({"type": "Polygon", "coordinates": [[)";
    const double pts[5][2] = {{u0, v0}, {u0, v1}, {u1, v1}, {u1, v0}, {u0, v0}};
    for (int k = 0; k < 5; ++k)
      g << (k ? "," : "") << "[" << kX0 + 1000.0 * pts[k][0] << "," << kY0 + 1000.0 * pts[k][1] << "]";
    g << "]]}";
    return g.str();
  };
  const std::string path = dir.write(
      "interleaved.geojson",
      R"({"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}}, "features": [)" +
          feature("A", R"({"type": "Point", "coordinates": [400500, 6209500]})") + "," +
          feature("B", square(0, 0, 4, 4)) + "," + feature("A", square(3, 3, 6, 6)) + "]}");
  SeedReadOptions o;
  o.paths = {path};
  o.owner_field = "owner";
  o.on_conflict = ConflictPolicy::lower_code;
  const LoadedSeeds l = load_seeds(o);
  EXPECT_EQ(l.report.conflicts, 1);
  EXPECT_EQ(l.seeds.owner_labels(), (std::vector<std::string>{"A", "B"}));
  const GridSpec g = make_grid(kX0, kY0, kX0 + 10000.0, kY0 + 10000.0, 100.0, l.crs.wkt);
  ComputeOptions co;
  co.threads = 2;
  const NearestField f = compute(l.seeds, g, co);
  EXPECT_EQ(l.seeds.site_owner(f.site.at(35, 100 - 1 - 35)), 1);  // (3.55, 3.55) km: in both squares
  EXPECT_EQ(l.seeds.site_owner(f.site.at(20, 100 - 1 - 20)), 2);  // B only
  ASSERT_FALSE(l.report.warnings.empty());
  EXPECT_NE(l.report.warnings[0].find("'A' takes the overlap"), std::string::npos) << l.report.warnings[0];
}

// 10 000 squares in a checkerboard of two owners: every square touches four squares of the
// other owner along an edge (the worst case for the envelope pre-filter: every candidate pair
// goes to GEOS). No conflict; then one more square overlapping a cell is found and named.
TEST(Conflicts, TenThousandTouchingFeaturesStayFast) {
  test::ScratchDir dir;
  const int n = 100;
  const auto write = [&](const std::string& name, bool with_overlap) {
    std::ostringstream f;
    f.precision(12);
    f << R"({"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}}, "features": [)";
    const auto square = [&](const char* owner, double x, double y, double size) {
      f << R"({"type": "Feature", "properties": {"owner": ")" << owner
        << R"("}, "geometry": {"type": "Polygon", "coordinates": [[)"
        << "[" << x << "," << y << "],[" << x << "," << y + size << "],[" << x + size << "," << y + size << "],["
        << x + size << "," << y << "],[" << x << "," << y << "]]]}}";
    };
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        if (i + j > 0) f << ",";
        square((i + j) % 2 ? "A" : "B", kX0 + i * 100.0, kY0 + j * 100.0, 100.0);
      }
    if (with_overlap) {
      f << ",";
      square("C", kX0 + 5020.0, kY0 + 7020.0, 50.0);  // inside the square (50, 70)
    }
    f << "]}";
    return dir.write(name, f.str());
  };
  SeedReadOptions o;
  o.owner_field = "owner";
  o.paths = {write("checker.geojson", false)};
  const auto t0 = std::chrono::steady_clock::now();
  const LoadedSeeds l = load_seeds(o);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(l.report.features_read, n * n);
  EXPECT_EQ(l.report.conflicts, 0);
  RecordProperty("load_seconds_10k_touching", std::to_string(seconds));
  std::printf("10 000 touching squares of two owners read and checked in %.2f s\n", seconds);
  EXPECT_LT(seconds, 60.0);  // ~1.4 s on the 2-core development machine

  o.paths = {write("checker_overlap.geojson", true)};
  const std::string msg = expect_error(ErrorKind::conflict, [&] { load_seeds(o); },
                                       {"checker_overlap:fid 5070", "checker_overlap:fid 10000", "'C'"});
  const Vec2 p = location(msg);
  EXPECT_GT(p.x, kX0 + 5020.0);
  EXPECT_LT(p.x, kX0 + 5070.0);
  EXPECT_GT(p.y, kY0 + 7020.0);
  EXPECT_LT(p.y, kY0 + 7070.0);
}

}  // namespace
}  // namespace rv
