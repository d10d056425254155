// The rvoronoi command line as a user runs it: the real binary, real files, exit codes.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <gdal.h>
#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/UTMUPS.hpp>
#include <nlohmann/json.hpp>

#include "fixtures.hpp"
#include "rv/engine/engine.hpp"
#include "rv/engine/outputs.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/report/treaty.hpp"

namespace fs = std::filesystem;

namespace rv {
namespace {

struct CliRun {
  int exit_code;
  std::string output;  // stdout and stderr together
};

CliRun run(const std::string& args) {
  const std::string cmd = std::string(RV_BINARY) + " " + args + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf{};
  for (size_t n; (n = std::fread(buf.data(), 1, buf.size(), p)) > 0;) out.append(buf.data(), n);
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

std::string source(const std::string& rel) { return (test::source_dir() / rel).string(); }

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rv_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name)) << text;
    return path(name);
  }
  size_t file_count() const {
    return static_cast<size_t>(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()));
  }
  fs::path dir_;
};

const std::string kDemo = "fixtures/demo_basepoints.geojson";

TEST_F(Cli, ComputeWritesGeoTiffsThatMatchTheEngine) {
  const CliRun r = run("compute " + source(kDemo) + " --owner-field state --resolution 250 --ownership " +
                       path("own.tif") + " --distance " + path("dist.tif") + " --nearest-feature " + path("feat.tif") +
                       " --report " + path("report.json") + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;

  // The same computation in-process.
  gdal_init();
  SeedReadOptions ro;
  ro.paths = {source(kDemo)};
  ro.owner_field = "state";
  const LoadedSeeds seeds = load_seeds(ro);
  const GridSpec grid = read_grid(path("own.tif"));
  EXPECT_DOUBLE_EQ(grid.res, 250.0);
  EXPECT_NE(grid.crs.find("UTM zone 33N"), std::string::npos);
  // Extent: the seeds' box grown by 5 % and snapped outward to whole cells.
  const SeedSet::Box b = seeds.seeds.bounds();
  EXPECT_LE(grid.xmin, b.xmin);
  EXPECT_GE(grid.ymax, b.ymax);
  EXPECT_EQ(std::fmod(grid.xmin, 250.0), 0.0);
  ComputeOptions co;
  const NearestField f = compute(seeds.seeds, grid, co);
  const Raster<int32_t> own = read_int32(path("own.tif"));
  EXPECT_EQ(own.width(), grid.width);
  EXPECT_EQ(own.cells(), owner_raster(seeds.seeds, f).cells());
  EXPECT_EQ(read_int32(path("feat.tif")).cells(), feature_raster(seeds.seeds, f, 0, seeds.input_position).cells());
  EXPECT_EQ(read_float32(path("dist.tif")).cells(), f.distance.cells());
  EXPECT_EQ(read_category_labels(path("own.tif")), (std::vector<std::string>{"A", "B", "C"}));

  const nlohmann::json rep = nlohmann::json::parse(std::ifstream(path("report.json")));
  EXPECT_EQ(rep["method"], "exact");
  EXPECT_EQ(rep["grid"]["width"], grid.width);
  EXPECT_EQ(rep["seeds"]["owners"][1]["label"], "B");
  EXPECT_GT(rep["peak_memory_bytes"].get<int64_t>(), 0);
  EXPECT_TRUE(rep["timings_s"].contains("compute"));
  EXPECT_TRUE(rep["timings_s"]["write"].contains("ownership"));
}

TEST_F(Cli, NearestFeatureNumbersFollowTheInputOrder) {
  // Owners interleaved in the file (A, B, A): the reader stores features grouped by owner, but the
  // nearest-feature raster still numbers them by their position in the input.
  const std::string seeds = write("interleaved.geojson", R"({"type":"FeatureCollection",
    "crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},"features":[
    {"type":"Feature","properties":{"o":"A"},"geometry":{"type":"Point","coordinates":[500000.5,6000000.5]}},
    {"type":"Feature","properties":{"o":"B"},"geometry":{"type":"Point","coordinates":[500010.5,6000000.5]}},
    {"type":"Feature","properties":{"o":"A"},"geometry":{"type":"Point","coordinates":[500020.5,6000000.5]}}]})");
  const CliRun r = run("compute " + seeds +
                       " --owner-field o --resolution 1 --extent 500000 6000000 500021 6000001 "
                       "--ownership " +
                       path("own.tif") + " --nearest-feature " + path("feat.tif") + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Raster<int32_t> own = read_int32(path("own.tif"));
  const Raster<int32_t> feat = read_int32(path("feat.tif"));
  EXPECT_EQ(own.at(0, 0), 1);
  EXPECT_EQ(feat.at(0, 0), 1);
  EXPECT_EQ(own.at(10, 0), 2);
  EXPECT_EQ(feat.at(10, 0), 2);
  EXPECT_EQ(own.at(20, 0), 1);
  EXPECT_EQ(feat.at(20, 0), 3);
}

TEST_F(Cli, LikeTakesGridAndCrsFromARaster) {
  // A template raster in another CRS (UTM 32N) with its own extent and cell size: the outputs
  // must line up with it cell for cell, the seeds (UTM 33N) being reprojected into its CRS.
  GridSpec like;
  like.xmin = 710000;
  like.ymax = 6200000;
  like.res = 300;
  like.width = 160;
  like.height = 210;
  like.crs = "EPSG:32632";
  write_geotiff(path("like.tif"), Raster<int32_t>(like, 7), 0.0, GeoTiffOptions{});
  const CliRun r = run("compute " + source(kDemo) + " --owner-field state --like " + path("like.tif") +
                       " --ownership " + path("own.tif") + " --distance " + path("d.tif") + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const GridSpec got = read_grid(path("own.tif"));
  EXPECT_DOUBLE_EQ(got.xmin, like.xmin);
  EXPECT_DOUBLE_EQ(got.ymax, like.ymax);
  EXPECT_DOUBLE_EQ(got.res, like.res);
  EXPECT_EQ(got.width, like.width);
  EXPECT_EQ(got.height, like.height);
  EXPECT_NE(got.crs.find("UTM zone 32N"), std::string::npos);
  // Every owner appears: the demo's coasts fall inside the template's extent once reprojected.
  const Raster<int32_t> own = read_int32(path("own.tif"));
  const std::set<int32_t> owners(own.cells().begin(), own.cells().end());
  EXPECT_EQ(owners, (std::set<int32_t>{1, 2, 3}));
}

TEST_F(Cli, ThreadCountDoesNotChangeTheFiles) {
  for (const char* t : {"1", "7"}) {
    const CliRun r = run("compute " + source(kDemo) + " --resolution 300 --method hv-scan --threads " + t +
                         " --ownership " + path(std::string("own") + t + ".tif") + " --quiet");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  EXPECT_EQ(read_int32(path("own1.tif")).cells(), read_int32(path("own7.tif")).cells());
}

TEST_F(Cli, MaxDistanceAndUnits) {
  const CliRun r =
      run("compute " + source(kDemo) + " --resolution 500 --max-distance 3 --distance-units km --ownership " +
          path("own.tif") + " --distance " + path("d.tif") + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Raster<float> d = read_float32(path("d.tif"));
  const Raster<int32_t> o = read_int32(path("own.tif"));
  int64_t none = 0;
  for (size_t i = 0; i < d.size(); ++i) {
    if (o.cells()[i] == 0) {
      ++none;
      EXPECT_EQ(d.cells()[i], kNoDistance);
    } else {
      EXPECT_LE(d.cells()[i], 3.0f);  // kilometres
    }
  }
  EXPECT_GT(none, 0);
}

TEST_F(Cli, LandBorderSliversAreReportedAndTheToleranceIsAnOption) {
  // Two countries sharing a border, reprojected to UTM 32N: a sliver ~4 mm wide. Accepted with
  // the default tolerance and listed in the report; refused (exit code of a conflict) below it.
  const std::string seeds = source("fixtures/land_border.geojson");
  const std::string grid = " --owner-field owner --crs EPSG:32632 --resolution 200 --quiet --ownership ";
  const CliRun ok = run("compute " + seeds + grid + path("o.tif") + " --report " + path("r.json"));
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  std::ifstream in(path("r.json"));
  const nlohmann::json report = nlohmann::json::parse(in);
  const nlohmann::json& slivers = report["seeds"]["land_border_slivers"];
  EXPECT_EQ(slivers["count"].get<int>(), 1);
  ASSERT_EQ(slivers["listed"].size(), 1u);
  EXPECT_EQ(slivers["listed"][0]["owners"], nlohmann::json::array({"A", "B"}));
  EXPECT_NEAR(slivers["listed"][0]["mean_width_m"].get<double>(), 0.004, 0.0002);
  EXPECT_EQ(report["seeds"]["conflicts"].get<int>(), 0);
  const CliRun refused = run("compute " + seeds + " --border-tolerance 0.001" + grid + path("o2.tif"));
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.output.find("wider than the land-border tolerance, 0.001 m"), std::string::npos) << refused.output;
  EXPECT_FALSE(std::filesystem::exists(path("o2.tif")));
}

// Bad input: one clear line, a distinct non-zero exit code, and no output file left behind.
void expect_refused(const CliRun& r, int code, const std::string& fragment) {
  EXPECT_EQ(r.exit_code, code) << r.output;
  EXPECT_NE(r.output.find(fragment), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
}

// The area two discs of radii r1 and r2, d apart, have in common.
double lens_area(double r1, double r2, double d) {
  return r1 * r1 * std::acos((d * d + r1 * r1 - r2 * r2) / (2.0 * d * r1)) +
         r2 * r2 * std::acos((d * d + r2 * r2 - r1 * r1) / (2.0 * d * r2)) -
         0.5 * std::sqrt((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2));
}

// Weights from an attribute: two basepoints 100 km apart in UTM, weights 3 : 1, on a 1 km grid.
// The boundary is the circle d_A = 3 d_B (centre 112.5 km from A, radius 37.5 km) and B's
// region its disc, pi 37.5^2 km^2, to 0.01 % in the report; the distance raster keeps true
// distances.
TEST_F(Cli, WeightsFromAnAttributeMakeTheApolloniusCircle) {
  const std::string seeds = write("weighted.geojson", R"({"type":"FeatureCollection",
    "crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},"features":[
    {"type":"Feature","properties":{"state":"A","w":3},"geometry":{"type":"Point","coordinates":[500000,6000000]}},
    {"type":"Feature","properties":{"state":"B","w":1},"geometry":{"type":"Point","coordinates":[600000,6000000]}}]})");
  const std::string grid = " --owner-field state --resolution 1000 --extent 560000 5950000 660000 6050000 --quiet";
  const CliRun r = run("compute " + seeds + grid + " --weight-field w --distance " + path("d.tif") + " --boundaries " +
                       path("b.geojson") + " --regions " + path("r.geojson") + " --report " + path("report.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(path("report.json")));
  const nlohmann::json& areas = report["deliverables"]["regions"]["areas"];
  ASSERT_EQ(areas.size(), 2u);
  const double disc = M_PI * 37500.0 * 37500.0;
  EXPECT_EQ(areas[1]["label"], "B");
  EXPECT_NEAR(areas[1]["area"].get<double>() / disc, 1.0, 1e-4) << areas.dump();
  EXPECT_NEAR(areas[0]["area"].get<double>() + areas[1]["area"].get<double>(), 1e10, 1.0);
  EXPECT_EQ(report["seeds"]["adjustments"][0]["owner"], "A");
  EXPECT_EQ(report["seeds"]["adjustments"][0]["weight_max"].get<double>(), 3.0);
  const nlohmann::json lines = nlohmann::json::parse(std::ifstream(path("b.geojson")));
  ASSERT_EQ(lines["features"].size(), 1u);
  for (const auto& c : lines["features"][0]["geometry"]["coordinates"])
    EXPECT_NEAR(std::hypot(c[0].get<double>() - 612500.0, c[1].get<double>() - 6000000.0), 37500.0, 1e-3);
  // The distance raster: the true distance to the winning point (cell (0, 50): B's side).
  const Raster<float> d = read_float32(path("d.tif"));
  EXPECT_NEAR(d.at(0, 50), std::hypot(560500.0 - 500000.0, 5999500.0 - 6000000.0), 0.01);
  // With a max distance of 60 km every reach ends there: A (weight 3) wins the whole lens where
  // the two discs overlap (B would need d_B < d_A / 3 <= 20 km there), so B's region is its disc
  // less the lens, and the sea beyond both discs is no one's.
  const CliRun capped =
      run("compute " + seeds +
          " --owner-field state --resolution 500 --extent 430000 5930000 670000 6070000 --quiet "
          "--weight-field w --max-distance 60000 --regions " +
          path("rc.geojson") + " --report " + path("capped.json") + " --turning-points " + path("tp.json"));
  ASSERT_EQ(capped.exit_code, 0) << capped.output;
  const nlohmann::json cr = nlohmann::json::parse(std::ifstream(path("capped.json")));
  const nlohmann::json& ca = cr["deliverables"]["regions"]["areas"];
  ASSERT_EQ(ca.size(), 2u) << ca.dump();
  const double r60 = 60000.0, lens = lens_area(r60, r60, 100000.0);
  EXPECT_NEAR(ca[0]["area"].get<double>() / (M_PI * r60 * r60), 1.0, 1e-4) << ca.dump();
  EXPECT_NEAR(ca[1]["area"].get<double>() / (M_PI * r60 * r60 - lens), 1.0, 1e-4) << ca.dump();
  // The A-B line is A's 60 km arc through the lens, from one crossing of the circles to the
  // other, (50, +-33.17) km from A: both ends of the line, and the segment between follows the
  // arc round A at 60 km.
  const nlohmann::json tp = nlohmann::json::parse(std::ifstream(path("tp.json")));
  ASSERT_EQ(tp["lines"].size(), 1u) << tp.dump();
  const nlohmann::json& points = tp["lines"][0]["points"];
  ASSERT_EQ(points.size(), 2u) << points.dump();
  for (const auto& p : points) {
    EXPECT_NEAR(p["x"].get<double>(), 550000.0, 1e-3);
    EXPECT_NEAR(std::abs(p["y"].get<double>() - 6000000.0), std::sqrt(r60 * r60 - 5e4 * 5e4), 1e-3);
  }
  EXPECT_EQ(points[0]["to_next"]["follows"], "arc");
  EXPECT_EQ(points[0]["to_next"]["arc_side"], "a");
  EXPECT_NEAR(points[0]["to_next"]["arc_radius"].get<double>(), 60000.0, 1e-6);
  EXPECT_EQ(points[0]["a"].back()["x"].get<double>(), 500000.0);
  // Refusals: a scan, the margin raster, a bad weight, a missing or text field.
  const std::string out = " --ownership " + path("o.tif");
  expect_refused(run("compute " + seeds + grid + " --weight-field w --method hv-scan" + out), 2,
                 "weights and reaches need the exact or brute-force method");
  expect_refused(run("compute " + seeds + grid + " --weight-field w --margin-raster " + path("m.tif")), 7,
                 "margin raster is not available with weights");
  expect_refused(run("compute " + seeds + grid + " --weight-field nope" + out), 2, "weight field 'nope' not found");
  expect_refused(run("compute " + seeds + grid + " --weight-field state" + out), 2, "is not numeric (String)");
  const std::string zero = write("zero.geojson", R"({"type":"FeatureCollection","features":[
    {"type":"Feature","properties":{"state":"A","w":0},"geometry":{"type":"Point","coordinates":[0,0]}},
    {"type":"Feature","properties":{"state":"B","w":1},"geometry":{"type":"Point","coordinates":[10,0]}}]})");
  expect_refused(run("compute " + zero + " --owner-field state --resolution 1 --weight-field w" + out), 3,
                 ":fid 0: the weight must be a finite number above 0 (got 0)");
  expect_refused(run("compute " + zero + " --owner-field state --resolution 1 --reach-field w" + out), 3,
                 "the reach must be a distance above 0 (got 0)");
  const std::string null_weight = write("null.geojson", R"({"type":"FeatureCollection","features":[
    {"type":"Feature","properties":{"state":"A","w":2},"geometry":{"type":"Point","coordinates":[0,0]}},
    {"type":"Feature","properties":{"state":"B","w":null},"geometry":{"type":"Point","coordinates":[10,0]}}]})");
  expect_refused(run("compute " + null_weight + " --owner-field state --resolution 1 --weight-field w" + out), 3,
                 "the weight field 'w' is null or missing");
  EXPECT_FALSE(fs::exists(path("o.tif")));
  EXPECT_FALSE(fs::exists(path("m.tif")));
  EXPECT_FALSE(fs::exists(path("x.geojson")));
}

// Partial effect from an attribute on a geographic grid: two mainland coasts along meridians
// 10.0 and 10.8 E and B's island at 10.3 E. At nil effect the two owners' areas are equal (the
// mirror), at full effect B gains the island's band; half effect lies between, the raster's
// share and the regions' areas agree, and each step of e moves sea one way. Refusals follow.
TEST_F(Cli, PartialEffectFromAnAttribute) {
  auto seeds_with = [&](const std::string& name, const std::string& effect) {
    return write(name, R"({"type":"FeatureCollection","features":[
    {"type":"Feature","properties":{"state":"A","e":null},"geometry":{"type":"LineString","coordinates":[[10.0,55.0],[10.0,55.6]]}},
    {"type":"Feature","properties":{"state":"B","e":null},"geometry":{"type":"LineString","coordinates":[[10.8,55.0],[10.8,55.6]]}},
    {"type":"Feature","properties":{"state":"B","e":)" +
                           effect + R"(},"geometry":{"type":"Point","coordinates":[10.3,55.3]}}]})");
  };
  const std::string grid = " --owner-field state --effect-field e --resolution 0.005 --quiet";
  std::vector<double> b_area;
  for (const char* e : {"0", "0.25", "0.5", "1"}) {
    const std::string tag = std::string("e") + e;
    const CliRun r = run("compute " + seeds_with(tag + ".geojson", e) + grid + " --ownership " + path(tag + ".tif") +
                         " --boundaries " + path(tag + ".geojson") + " --regions " + path(tag + "r.geojson") +
                         " --report " + path(tag + ".json"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(path(tag + ".json")));
    const nlohmann::json& areas = report["deliverables"]["regions"]["areas"];
    ASSERT_EQ(areas.size(), 2u);
    b_area.push_back(areas[1]["area"].get<double>());
    const double total = areas[0]["area"].get<double>() + areas[1]["area"].get<double>();
    // The raster's share of B's cells is the regions' share, to a cell's width along the line.
    const Raster<int32_t> own = read_int32(path(tag + ".tif"));
    const double cells_b = static_cast<double>(std::count(own.cells().begin(), own.cells().end(), 2));
    EXPECT_NEAR(cells_b / static_cast<double>(own.size()), areas[1]["area"].get<double>() / total, 0.004);
    if (std::string(e) == "1") {
      EXPECT_FALSE(report.contains("partial_effect"));
      continue;
    }
    EXPECT_EQ(report["partial_effect"]["owner"], "B");
    EXPECT_EQ(report["partial_effect"]["effect"].get<double>(), std::stod(e));
    EXPECT_GT(report["partial_effect"]["cells_to_neighbours"].get<int64_t>(), 0);
    const nlohmann::json& pe = report["deliverables"]["boundaries"]["partial_effect"];
    EXPECT_EQ(pe["stretches"].get<int>(), 1);
    EXPECT_LT(pe["max_residual"].get<double>(), 1e-3);
    const nlohmann::json lines = nlohmann::json::parse(std::ifstream(path(tag + ".geojson")));
    ASSERT_EQ(lines["features"].size(), 1u);
  }
  EXPECT_LT(b_area[0], b_area[1]);
  EXPECT_LT(b_area[1], b_area[2]);
  EXPECT_LT(b_area[2], b_area[3]);
  const nlohmann::json nil = nlohmann::json::parse(std::ifstream(path("e0.json")));
  const nlohmann::json& nil_areas = nil["deliverables"]["regions"]["areas"];
  EXPECT_NEAR(nil_areas[0]["area"].get<double>() / nil_areas[1]["area"].get<double>(), 1.0, 1e-9);
  // Refusals: a scan, the margin raster, the turning-point report, an effect out of range, two
  // owners with partial features.
  const std::string half = seeds_with("half.geojson", "0.5"), out = " --ownership " + path("o.tif");
  expect_refused(run("compute " + half + grid + " --method hv-scan" + out), 2,
                 "partial effect needs the exact or brute-force method");
  expect_refused(run("compute " + half + grid + " --margin-raster " + path("m.tif")), 7,
                 "partial effect is not available with the margin raster");
  expect_refused(run("compute " + half + grid + " --turning-points " + path("t.json")), 7,
                 "is not available with the turning-point report");
  expect_refused(run("compute " + seeds_with("big.geojson", "1.5") + grid + out), 3,
                 "the effect must be a number from 0 to 1 (got 1.5)");
  const std::string two = write("two.geojson", R"({"type":"FeatureCollection","features":[
    {"type":"Feature","properties":{"state":"A","e":0.5},"geometry":{"type":"Point","coordinates":[10.0,55.0]}},
    {"type":"Feature","properties":{"state":"A","e":null},"geometry":{"type":"Point","coordinates":[10.0,55.5]}},
    {"type":"Feature","properties":{"state":"B","e":0.5},"geometry":{"type":"Point","coordinates":[10.8,55.0]}},
    {"type":"Feature","properties":{"state":"B","e":null},"geometry":{"type":"Point","coordinates":[10.8,55.5]}}]})");
  expect_refused(run("compute " + two + grid + out), 3, "belong to different owners");
  EXPECT_FALSE(fs::exists(path("o.tif")));
  EXPECT_FALSE(fs::exists(path("m.tif")));
  EXPECT_FALSE(fs::exists(path("t.json")));
}

// Is p inside the GeoJSON (Multi)Polygon `geometry` (even-odd over all its rings)?
bool inside_geojson(const nlohmann::json& geometry, double x, double y) {
  const bool multi = geometry["type"] == "MultiPolygon";
  bool in = false;
  auto rings_of = [&](const nlohmann::json& polygon) {
    for (const nlohmann::json& ring : polygon)
      for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
        const double ax = ring[i][0], ay = ring[i][1], bx = ring[j][0], by = ring[j][1];
        if ((ay > y) != (by > y) && x < ax + (y - ay) * (bx - ax) / (by - ay)) in = !in;
      }
  };
  if (multi)
    for (const nlohmann::json& polygon : geometry["coordinates"]) rings_of(polygon);
  else
    rings_of(geometry["coordinates"]);
  return in;
}

// The western Baltic's 200 ports with Zealand's 27 at half effect, straight on the ellipsoid. The
// DK-SE line leaves the full-effect line's band at a turning point that is a vertex of it; the
// band's stretch of the nil-effect line once ran from there the wrong way, and the partial line,
// traced from the partial tripoint by Ven and back, never reached the grid's northern edge: the
// Kattegat's DK and SE faces merged in the regions (28,812 cells off), and later the line was
// refused. Now: one DK-SE line from the northern edge to the tripoint south of the Sound, no line
// that comes back to where it began, and over the Sound and the Kattegat every cell in the region
// of its owner.
TEST_F(Cli, APartialLineFromATurningPointOnAVertexRunsToTheGridsEdge) {
  const CliRun r = run("compute " + test::fixture("baltic_west_ports_zealand_half.geojson") +
                       " --owner-field owner --effect-field effect --extent 9.0 53.8 15.5 56.2 --resolution 0.01"
                       " --quiet --ownership " +
                       path("z.tif") + " --boundaries " + path("z.geojson") + " --regions " + path("zr.geojson"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json lines = nlohmann::json::parse(std::ifstream(path("z.geojson")));
  int dk_se_from_north = 0;
  for (const nlohmann::json& f : lines["features"]) {
    const nlohmann::json& c = f["geometry"]["coordinates"];
    ASSERT_GE(c.size(), 2u);
    if (f["properties"]["closed"] == 0) {
      EXPECT_FALSE(c.front() == c.back()) << f["properties"]["label_a"] << "-" << f["properties"]["label_b"];
    }
    if (f["properties"]["label_a"] != "DK" || f["properties"]["label_b"] != "SE") continue;
    const double north = std::max(c.front()[1].get<double>(), c.back()[1].get<double>());
    dk_se_from_north += std::abs(north - 56.195) < 1e-9;
  }
  EXPECT_EQ(dk_se_from_north, 1);
  const Raster<int32_t> own = read_int32(path("z.tif"));
  const nlohmann::json regions = nlohmann::json::parse(std::ifstream(path("zr.geojson")));
  int64_t checked = 0, off = 0;
  for (int64_t row = 0; row < 120; ++row)        // 56.195 to 55.005 N
    for (int64_t col = 320; col < 430; ++col) {  // 12.205 to 13.295 E
      const double x = 9.005 + 0.01 * static_cast<double>(col), y = 56.195 - 0.01 * static_cast<double>(row);
      int32_t in = 0;
      for (const nlohmann::json& f : regions["features"])
        if (inside_geojson(f["geometry"], x, y)) in = f["properties"]["owner"].get<int32_t>();
      ++checked;
      off += in != own.at(col, row);
    }
  EXPECT_EQ(checked, 13200);
  EXPECT_EQ(off, 0);
}

// A reach from an attribute, in the job's distance units: 12 nmi on a geographic grid, whose
// island cells are those within 22,224 m of it on the ellipsoid.
TEST_F(Cli, ReachFromAnAttributeInDistanceUnits) {
  const std::string seeds = write("reach.geojson", R"({"type":"FeatureCollection","features":[
    {"type":"Feature","properties":{"state":"main"},"geometry":{"type":"LineString","coordinates":[[10,54],[10,56]]}},
    {"type":"Feature","properties":{"state":"isle","reach":12},"geometry":{"type":"Point","coordinates":[12.3,55]}}]})");
  const CliRun r = run("compute " + seeds + " --owner-field state --reach-field reach --distance-units nmi " +
                       "--resolution 0.01 --extent 11.9 54.7 12.7 55.3 --quiet --ownership " + path("o.tif") +
                       " --report " + path("report.json") + " --boundaries " + path("b.geojson") + " --regions " +
                       path("r.geojson") + " --turning-points " + path("tp.csv"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Raster<int32_t> o = read_int32(path("o.tif"));
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  // The turning-point table: the enclave is one ring of arc, its start row saying so, round the
  // island (b1) at 12 nmi.
  {
    std::ifstream csv(path("tp.csv"));
    std::string header, row;
    std::getline(csv, header);
    std::getline(csv, row);
    auto column = [&](const std::string& name) {
      std::vector<std::string> h, v;
      std::stringstream hs(header), vs(row);
      for (std::string x; std::getline(hs, x, ',');) h.push_back(x);
      for (std::string x; std::getline(vs, x, ',');) v.push_back(x);
      const auto it = std::find(h.begin(), h.end(), name);
      return it == h.end() || static_cast<size_t>(it - h.begin()) >= v.size() ? std::string("?")
                                                                              : v[static_cast<size_t>(it - h.begin())];
    };
    EXPECT_EQ(column("kind"), "start") << row;
    EXPECT_EQ(column("next_follows"), "arc") << row;
    EXPECT_EQ(column("next_arc_side"), "b") << row;
    EXPECT_NEAR(std::stod(column("next_arc_radius")), 12.0, 1e-6) << row;
    EXPECT_EQ(column("b1_owner"), "isle");
    EXPECT_NEAR(std::stod(column("b1_lon")), 12.3, 1e-12);
    EXPECT_EQ(column("a1_owner"), "");  // the main coast does not control the arc
  }
  int64_t isle = 0;
  for (int64_t row = 0; row < o.window().height; ++row)
    for (int64_t c = 0; c < o.window().width; ++c) {
      double d = 0.0;
      geod.Inverse(55.0, 12.3, 55.3 - (row + 0.5) * 0.01, 11.9 + (c + 0.5) * 0.01, d);
      if (std::abs(d - 22224.0) < 1.0) continue;
      ASSERT_EQ(o.at(c, row), d < 22224.0 ? 2 : 1) << c << ", " << row << " at " << d << " m";
      isle += d < 22224.0;
    }
  EXPECT_GT(isle, 500);
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(path("report.json")));
  EXPECT_EQ(report["seeds"]["adjustments"][0]["features_with_reach"].get<int>(), 1);
  // The boundary is the 12 nmi arc: every vertex 22,224 m from the island, to the millimetre; the
  // island's region the geodesic disc (pi r^2 to 1e-4: the ellipsoid's curvature changes it by
  // about 1e-6), in square nautical miles.
  const nlohmann::json lines = nlohmann::json::parse(std::ifstream(path("b.geojson")));
  ASSERT_EQ(lines["features"].size(), 1u);
  size_t vertices = 0;
  for (const auto& c : lines["features"][0]["geometry"]["coordinates"]) {
    double d = 0.0;
    geod.Inverse(55.0, 12.3, c[1].get<double>(), c[0].get<double>(), d);
    EXPECT_NEAR(d, 22224.0, 1e-3);
    ++vertices;
  }
  EXPECT_GT(vertices, 100u);
  EXPECT_EQ(report["deliverables"]["boundaries"]["unresolved_tripoints"].get<int>(), 0);
  const nlohmann::json& areas = report["deliverables"]["regions"]["areas"];
  ASSERT_EQ(areas.size(), 2u);
  EXPECT_EQ(areas[1]["label"], "isle");
  EXPECT_EQ(report["deliverables"]["regions"]["area_units"], "nmi^2");
  EXPECT_NEAR(areas[1]["area"].get<double>() / (M_PI * 12.0 * 12.0), 1.0, 1e-4);
  // With a max distance of 20 nmi the main coast reaches no cell: the island's geodesic disc is
  // all that is owned, bounded by the owned area's edge alone (drawn like a limit line: vertices on
  // the arc, chords between, whose sagitta on 0.004 degree cells keeps the area within 1e-4).
  const CliRun alone =
      run("compute " + seeds + " --owner-field state --reach-field reach --distance-units nmi --max-distance 20 " +
          "--resolution 0.004 --extent 11.9 54.7 12.7 55.3 --quiet --report " + path("alone.json") + " --regions " +
          path("alone.geojson"));
  ASSERT_EQ(alone.exit_code, 0) << alone.output;
  const nlohmann::json ar = nlohmann::json::parse(std::ifstream(path("alone.json")));
  const nlohmann::json& aa = ar["deliverables"]["regions"]["areas"];
  double isle_area = 0.0, main_area = 0.0;
  for (const auto& a : aa) (a["label"] == "isle" ? isle_area : main_area) += a["area"].get<double>();
  EXPECT_NEAR(isle_area / (M_PI * 12.0 * 12.0), 1.0, 1e-4) << aa.dump();
  EXPECT_EQ(main_area, 0.0) << aa.dump();
}

// Regions where reaches leave sea unowned: two points 40 km apart (UTM metres), A's reach 30 km
// and B's 25 km. A's region is the union of the two discs less B's, B's is its disc beyond the
// bisector x = 520 km (a 25 km disc less the segment cut 20 km from its centre), and nothing else
// is owned. The owned area's edge is drawn like a limit line (vertices on the arcs, chords
// between): on a 250 m grid the areas are within 1e-4 of the circles'.
TEST_F(Cli, RegionsWhereReachesLeaveSeaUnowned) {
  const std::string crs = R"("crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},)";
  const std::string seeds = write("discs.geojson", R"({"type":"FeatureCollection",)" + crs + R"("features":[
    {"type":"Feature","properties":{"state":"A","r":30000},"geometry":{"type":"Point","coordinates":[500000,6000000]}},
    {"type":"Feature","properties":{"state":"B","r":25000},"geometry":{"type":"Point","coordinates":[540000,6000000]}}]})");
  const CliRun r = run("compute " + seeds +
                       " --owner-field state --reach-field r --resolution 250 --extent 460000 5960000 580000 6040000 "
                       "--quiet --report " +
                       path("report.json") + " --regions " + path("r.geojson") + " --boundaries " + path("b.geojson"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(path("report.json")));
  const nlohmann::json& areas = report["deliverables"]["regions"]["areas"];
  ASSERT_EQ(areas.size(), 2u) << areas.dump();
  const double r1 = 30000.0, r2 = 25000.0, d = 40000.0;
  const double lens = lens_area(r1, r2, d);
  const double segment = r2 * r2 * std::acos(20000.0 / r2) - 20000.0 * std::sqrt(r2 * r2 - 20000.0 * 20000.0);
  const double b_area = M_PI * r2 * r2 - segment;
  const double a_area = M_PI * (r1 * r1 + r2 * r2) - lens - b_area;
  EXPECT_EQ(areas[0]["label"], "A");
  EXPECT_NEAR(areas[0]["area"].get<double>() / a_area, 1.0, 1e-4) << areas.dump();
  EXPECT_NEAR(areas[1]["area"].get<double>() / b_area, 1.0, 1e-4) << areas.dump();
  // One region per owner, and nothing of the unowned sea in either.
  const nlohmann::json regions = nlohmann::json::parse(std::ifstream(path("r.geojson")));
  ASSERT_EQ(regions["features"].size(), 2u);
  // The same with a max distance below A's reach: the cap ends it at 28 km instead.
  const CliRun capped = run("compute " + seeds +
                            " --owner-field state --reach-field r --max-distance 28000 --resolution 250 --extent "
                            "460000 5960000 580000 6040000 --quiet --report " +
                            path("capped.json") + " --regions " + path("r2.geojson"));
  ASSERT_EQ(capped.exit_code, 0) << capped.output;
  const nlohmann::json cr = nlohmann::json::parse(std::ifstream(path("capped.json")));
  const double c1 = 28000.0;
  const double lens2 = lens_area(c1, r2, d);
  const double total = M_PI * (c1 * c1 + r2 * r2) - lens2;
  const nlohmann::json& ca = cr["deliverables"]["regions"]["areas"];
  ASSERT_EQ(ca.size(), 2u) << ca.dump();
  EXPECT_NEAR((ca[0]["area"].get<double>() + ca[1]["area"].get<double>()) / total, 1.0, 1e-4) << ca.dump();
  EXPECT_NEAR(ca[1]["area"].get<double>() / b_area, 1.0, 1e-4) << ca.dump();
}

// The disproportionality test on a mirror-symmetric case: two owners' coasts along y = 0 either
// side of x = 0 (UTM metres), a relevant area symmetric about the boundary: equal coasts, equal
// sea areas (half the area each), ratios 1.000. Given coasts of 30 and 10 km: a coast ratio of 3.
TEST_F(Cli, RelevantAreaAndTheDisproportionalityTest) {
  const std::string crs = R"("crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},)";
  const std::string seeds = write("coasts.geojson", R"({"type":"FeatureCollection",)" + crs + R"("features":[
    {"type":"Feature","properties":{"state":"A"},"geometry":{"type":"LineString","coordinates":[[440000,6000000],[500000,6000000]]}},
    {"type":"Feature","properties":{"state":"B"},"geometry":{"type":"LineString","coordinates":[[500000,6000000],[560000,6000000]]}}]})");
  const std::string area = write("area.geojson", R"({"type":"FeatureCollection",)" + crs + R"("features":[
    {"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[[460000,6005000],[540000,6005000],[540000,6045000],[460000,6045000],[460000,6005000]]]}}]})");
  const std::string grid =
      " --owner-field state --resolution 500 --extent 450000 5950000 550000 6050000 --quiet --report " +
      path("report.json");
  const CliRun r = run("compute " + seeds + grid + " --relevant-area " + area);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  nlohmann::json report = nlohmann::json::parse(std::ifstream(path("report.json")));
  const nlohmann::json& ra = report["deliverables"]["regions"]["relevant_area"];
  EXPECT_NEAR(ra["area"].get<double>(), 80000.0 * 40000.0, 1.0) << ra.dump();
  ASSERT_EQ(ra["owners"].size(), 2u);
  for (const auto& o : ra["owners"]) {
    EXPECT_NEAR(o["sea_area"].get<double>(), 40000.0 * 40000.0, 1.0) << ra.dump();
    EXPECT_NEAR(o["coast_length"].get<double>(), 39500.0, 1e-6) << ra.dump();  // feet of the cells: 250 m in
    EXPECT_NEAR(o["area_to_coast"].get<double>(), 1.0, 1e-9);
  }
  EXPECT_NEAR(ra["pair"]["coast_ratio"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(ra["pair"]["area_ratio"].get<double>(), 1.0, 1e-9);
  EXPECT_EQ(ra["coasts"], "nearest to the area's cells");
  EXPECT_EQ(file_count(), 4u);  // no regions file was asked for, none written (+ the report's kept base)
  // Given coasts.
  const std::string given = write("given.geojson", R"({"type":"FeatureCollection",)" + crs + R"("features":[
    {"type":"Feature","properties":{"state":"A"},"geometry":{"type":"LineString","coordinates":[[470000,6000000],[500000,6000000]]}},
    {"type":"Feature","properties":{"state":"B"},"geometry":{"type":"LineString","coordinates":[[500000,6000000],[510000,6000000]]}}]})");
  const CliRun g = run("compute " + seeds + grid + " --relevant-area " + area + " --relevant-coasts " + given +
                       " --regions " + path("regions.gpkg"));
  ASSERT_EQ(g.exit_code, 0) << g.output;
  report = nlohmann::json::parse(std::ifstream(path("report.json")));
  const nlohmann::json& rg = report["deliverables"]["regions"]["relevant_area"];
  EXPECT_NEAR(rg["pair"]["coast_ratio"].get<double>(), 3.0, 1e-9) << rg.dump();
  EXPECT_NEAR(rg["owners"][0]["area_to_coast"].get<double>(), 0.5 / 0.75, 1e-9);
  EXPECT_EQ(rg["coasts"], "given");
  EXPECT_TRUE(fs::exists(path("regions.gpkg")));
  // Refusals: an area without polygons, coasts without an area, a coast of an unknown owner.
  const std::string points = write("points.geojson", R"({"type":"FeatureCollection",)" + crs + R"("features":[
    {"type":"Feature","properties":{"state":"C"},"geometry":{"type":"LineString","coordinates":[[470000,6000000],[500000,6000000]]}}]})");
  expect_refused(run("compute " + seeds + grid + " --relevant-area " + points + " --ownership " + path("x.tif")), 3,
                 "holds no polygon");
  expect_refused(run("compute " + seeds + grid + " --relevant-coasts " + given + " --ownership " + path("x.tif")), 2,
                 "relevant coasts need a relevant area");
  expect_refused(run("compute " + seeds + grid + " --relevant-area " + area + " --relevant-coasts " + points +
                     " --ownership " + path("x.tif")),
                 3, "the relevant coasts name owner 'C', which has no seeds");
  EXPECT_FALSE(fs::exists(path("x.tif")));
}

// The turning-point report on the ellipsoid: two basepoints of A and one of B; the line turns
// where all three are equidistant (GeographicLib's inverse, to 1 mm), the degrees-minutes-seconds
// say the same position to 0.0005", and each segment's length is the geodesic's between its ends.
TEST_F(Cli, TurningPointsAsATreatyTable) {
  const std::string seeds = write("basepoints.geojson", R"({"type":"FeatureCollection","features":[
    {"type":"Feature","properties":{"state":"A"},"geometry":{"type":"MultiPoint","coordinates":[[10.0,55.0],[10.0,55.5]]}},
    {"type":"Feature","properties":{"state":"B"},"geometry":{"type":"Point","coordinates":[10.5,55.25]}}]})");
  const std::string grid = " --owner-field state --resolution 0.005 --extent 9.9 54.9 10.6 55.6 --quiet ";
  const CliRun r = run("compute " + seeds + grid + "--turning-points " + path("tp.json") + " --report " +
                       path("report.json") + " --limits " + path("l.geojson") + " --limit-distances 12nmi");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json table = nlohmann::json::parse(std::ifstream(path("tp.json")));
  EXPECT_EQ(table["datum"], "WGS 84");
  ASSERT_EQ(table["lines"].size(), 1u);
  const nlohmann::json& points = table["lines"][0]["points"];
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  int turns = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const nlohmann::json& p = points[i];
    const double lat = p["lat"].get<double>(), lon = p["lon"].get<double>();
    EXPECT_NEAR(from_dms(p["lat_dms"].get<std::string>()), lat, 0.0005 / 3600.0);
    EXPECT_NEAR(from_dms(p["lon_dms"].get<std::string>()), lon, 0.0005 / 3600.0);
    std::vector<double> d;
    for (const char* side : {"a", "b"})
      for (const auto& bp : p[side]) {
        double s12 = 0.0;
        geod.Inverse(lat, lon, bp["lat"].get<double>(), bp["lon"].get<double>(), s12);
        EXPECT_NEAR(bp["distance"].get<double>(), s12, 1e-3);
        d.push_back(s12);
      }
    if (p["kind"] == "turn") {
      ++turns;
      ASSERT_EQ(d.size(), 3u);  // A's two basepoints and B's
      EXPECT_NEAR(d[0], d[2], 1e-3);
      EXPECT_NEAR(d[1], d[2], 1e-3);
    }
    if (i + 1 < points.size()) {
      double s12 = 0.0;
      geod.Inverse(lat, lon, points[i + 1]["lat"].get<double>(), points[i + 1]["lon"].get<double>(), s12);
      EXPECT_NEAR(p["to_next"]["length"].get<double>(), s12, 1e-6);
      // Two point basepoints make a geodesic bisector: within millimetres of the geodesic.
      EXPECT_LT(p["to_next"]["deviation"].get<double>(), 0.05);
    }
  }
  EXPECT_EQ(turns, 1);
  // The 12 nmi limit's arcs: each drawn from one basepoint, both ends 22,224 m from it.
  ASSERT_FALSE(table["limits"].empty());
  int arcs = 0;
  for (const auto& line : table["limits"])
    for (const auto& arc : line["arcs"]) {
      ++arcs;
      ASSERT_EQ(arc["kind"], "arc");
      for (const char* end : {"from", "to"}) {
        double s12 = 0.0;
        geod.Inverse(arc[end]["lat"].get<double>(), arc[end]["lon"].get<double>(),
                     arc["basepoint"]["lat"].get<double>(), arc["basepoint"]["lon"].get<double>(), s12);
        EXPECT_NEAR(s12, 22224.0, 1e-3);
      }
    }
  EXPECT_GE(arcs, 3);  // one round each basepoint at least
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(path("report.json")));
  EXPECT_EQ(report["deliverables"]["turning_points"]["turns"], 1);
  // The same as CSV: a header and one row per point.
  const CliRun c = run("compute " + seeds + grid + "--turning-points " + path("tp.csv") + " --limits " +
                       path("l2.geojson") + " --limit-distances 12nmi");
  ASSERT_EQ(c.exit_code, 0) << c.output;
  std::ifstream csv(path("tp.csv"));
  std::string header, row;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("line,seq,kind,owner_a,owner_b,lon,lat,lon_dms,lat_dms,x,y,a1_feature", 0), 0u) << header;
  EXPECT_NE(header.find(",limit_distance,to_lon,to_lat,to_lon_dms,to_lat_dms,to_x,to_y"), std::string::npos) << header;
  const size_t columns = static_cast<size_t>(std::count(header.begin(), header.end(), ',')) + 1;
  size_t rows = 0, limit_rows = 0;
  while (std::getline(csv, row)) {
    EXPECT_EQ(static_cast<size_t>(std::count(row.begin(), row.end(), ',')) + 1, columns) << row;
    if (row.rfind("L", 0) != 0) {
      ++rows;
      continue;
    }
    // A limit arc: its basepoint (a1_lon, a1_lat) 22,224 m from both its ends, the limit's
    // distance in its column.
    ++limit_rows;
    std::vector<std::string> cells;
    std::stringstream fields(row);
    for (std::string cell; std::getline(fields, cell, ',');) cells.push_back(cell);
    auto column = [&](const std::string& name) {
      std::stringstream h(header);
      size_t i = 0;
      for (std::string cell; std::getline(h, cell, ','); ++i)
        if (cell == name) return std::stod(cells.at(i));
      ADD_FAILURE() << "no column " << name;
      return 0.0;
    };
    EXPECT_NEAR(column("limit_distance"), 22224.0, 1e-6);
    for (const char* end : {"", "to_"}) {
      double s12 = 0.0;
      geod.Inverse(column(std::string(end) + "lat"), column(std::string(end) + "lon"), column("a1_lat"),
                   column("a1_lon"), s12);
      EXPECT_NEAR(s12, 22224.0, 1e-3);
    }
  }
  EXPECT_EQ(rows, points.size());
  EXPECT_EQ(limit_rows, static_cast<size_t>(arcs));
  expect_refused(run("compute " + seeds + grid + "--turning-points " + path("tp.txt")), 2, "must end in .json or .csv");
}

TEST_F(Cli, ValidateReportsZeroWrongCellsForExact) {
  const CliRun r = run("validate " + source(kDemo) + " --resolution 400 --methods exact,hv-scan");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["methods"]["exact"]["wrong_cells"], 0);
  EXPECT_LT(j["methods"]["hv-scan"]["max_error_cells"].get<double>(), 1.0);
}

TEST_F(Cli, RandomTrialsReproduceTable2Buckets) {
  const CliRun r = run("validate --random-seeds 20 --size 100 100 --trials 5 --seed 3");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["buckets_cells"][2], ">3");
  EXPECT_EQ(j["methods"]["hv-scan"]["trials_in_bucket"][0], 5);
  const auto& h = j["methods"]["h-scan"]["trials_in_bucket"];
  EXPECT_EQ(h[0].get<int>() + h[1].get<int>() + h[2].get<int>(), 5);
}

TEST_F(Cli, BadInputFailsCleanly) {
  const std::string out = " --ownership " + path("own.tif") + " --distance " + path("d.tif") + " --quiet";
  const std::string empty = write("empty.geojson", R"({"type":"FeatureCollection","features":[]})");
  expect_refused(run("compute " + empty + " --resolution 10" + out), 3, "no seed");
  expect_refused(run("compute " + path("missing.geojson") + " --resolution 10" + out), 4, "missing.geojson");
  expect_refused(run("compute " + source(kDemo) + " --resolution 10 --extent 5 0 5 10" + out), 2, "xmin");
  expect_refused(run("compute " + source(kDemo) + " --resolution -1" + out), 2, "resolution");
  expect_refused(run("compute " + source(kDemo) + " --resolution 0" + out), 2, "resolution");
  // 1e-4 m cells over ~50 km: ~2e17 cells, refused before any allocation.
  expect_refused(run("compute " + source(kDemo) + " --resolution 0.0001" + out), 6, "limit");
  const std::string nan = write(
      "nan.geojson",
      R"({"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[1,1]}},)"
      R"({"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[NaN,2]}}]})");
  const CliRun rn = run("compute " + nan + " --resolution 1" + out);
  EXPECT_NE(rn.exit_code, 0) << rn.output;
  expect_refused(run("compute " + source(kDemo) + " --resolution 10 --method magic" + out), 2, "magic");
  expect_refused(run("compute " + source(kDemo) + " --resolution 10 --bogus" + out), 2, "--bogus");
  expect_refused(run("compute " + source(kDemo) + " --resolution 10 --compression zip" + out), 2,
                 "--compression: must be one of fast, small, deflate, none, got 'zip'");
  expect_refused(run("compute " + source(kDemo) + " --resolution 10" + out + " --compression"), 2, "--compression");
  expect_refused(run("compute " + source(kDemo) + " --resolution 10"), 2, "nothing to write");
  expect_refused(run("compute " + source(kDemo) + " --resolution 10 --report " + path("r.json")), 2,
                 "nothing to write");
  // Only the two input files written by this test remain: no partial outputs.
  EXPECT_EQ(file_count(), 2u);
}

// The lines alone, without a raster file: the job streams them from strips no file keeps.
TEST_F(Cli, DeliverablesAloneNeedNoRaster) {
  const CliRun r = run("compute " + source(kDemo) + " --owner-field state --resolution 150 --boundaries " +
                       path("b.geojson") + " --report " + path("r.json") + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(path("b.geojson")));
  std::ifstream in(path("r.json"));
  const std::string report((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(report.find("\"streamed\": true"), std::string::npos) << report;
  EXPECT_EQ(file_count(), 3u);  // the lines, the report and what it keeps for edits, nothing else
  EXPECT_TRUE(fs::exists(path("r.json.rvbase/manifest.json")));
}

// A GeoTIFF's layout as GDAL reports it: data type, COMPRESSION, PREDICTOR and LAYOUT of the
// IMAGE_STRUCTURE domain ("-" when absent).
struct TiffLayout {
  std::string type, compression, predictor, layout;
};
TiffLayout layout_of(const std::string& path) {
  GDALDatasetH ds = GDALOpen(path.c_str(), GA_ReadOnly);
  if (ds == nullptr) return {"(unreadable)", "", "", ""};
  auto item = [&](const char* key) {
    const char* v = GDALGetMetadataItem(ds, key, "IMAGE_STRUCTURE");
    return std::string(v == nullptr ? "-" : v);
  };
  TiffLayout l{GDALGetDataTypeName(GDALGetRasterDataType(GDALGetRasterBand(ds, 1))), item("COMPRESSION"),
               item("PREDICTOR"), item("LAYOUT")};
  GDALClose(ds);
  return l;
}

TEST_F(Cli, CompressionProfileReachesEveryGeoTiff) {
  gdal_init();
  const char* list = GDALGetMetadataItem(GDALGetDriverByName("GTiff"), GDAL_DMD_CREATIONOPTIONLIST, nullptr);
  const bool has_zstd = list != nullptr && std::strstr(list, "ZSTD") != nullptr;
  const std::string zstd = has_zstd ? "ZSTD" : "DEFLATE";

  const std::string base = "compute " + source(kDemo) + " --owner-field state --resolution 400 --quiet";
  auto outputs = [&](const std::string& tag) {
    return " --ownership " + path(tag + "_own.tif") + " --distance " + path(tag + "_dist.tif") + " --nearest-feature " +
           path(tag + "_feat.tif") + " --report " + path(tag + ".json");
  };
  struct Case {
    std::string args, int_codec, float_codec, int_predictor, float_predictor;
  };
  // The default is fast: codes compressed, the Float32 distance uncompressed.
  const Case cases[] = {{"", zstd, "-", "2", "-"},
                        {"--compression fast", zstd, "-", "2", "-"},
                        {"--compression small", zstd, zstd, "2", "3"},
                        {"--compression deflate", "DEFLATE", "DEFLATE", "2", "3"},
                        {"--compression none", "-", "-", "-", "-"},
                        {"--compression fast --cog", zstd, "-", "2", "-"},
                        {"--compression small --cog", zstd, zstd, "2", "3"},
                        {"--compression none --cog", "-", "-", "-", "-"}};
  for (size_t i = 0; i < std::size(cases); ++i) {
    const Case& c = cases[i];
    SCOPED_TRACE(c.args);
    const std::string tag = "c" + std::to_string(i);
    const CliRun r = run(base + " " + c.args + outputs(tag));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const bool cog = c.args.find("--cog") != std::string::npos;
    for (const char* product : {"_own.tif", "_feat.tif", "_dist.tif"}) {
      const TiffLayout l = layout_of(path(tag + product));
      const bool floating = std::string(product) == "_dist.tif";
      // Three owners and 28 features: one byte per code.
      EXPECT_EQ(l.type, floating ? "Float32" : "Byte") << product;
      EXPECT_EQ(l.compression, floating ? c.float_codec : c.int_codec) << product;
      EXPECT_EQ(l.predictor, floating ? c.float_predictor : c.int_predictor) << product;
      EXPECT_EQ(l.layout, cog ? "COG" : "-") << product;
    }
    // Lossless: every profile writes the default's values.
    EXPECT_EQ(read_int32(path(tag + "_own.tif")).cells(), read_int32(path("c0_own.tif")).cells());
    EXPECT_EQ(read_int32(path(tag + "_feat.tif")).cells(), read_int32(path("c0_feat.tif")).cells());
    EXPECT_EQ(read_float32(path(tag + "_dist.tif")).cells(), read_float32(path("c0_dist.tif")).cells());
    EXPECT_EQ(read_category_labels(path(tag + "_own.tif")), (std::vector<std::string>{"A", "B", "C"}));
    const nlohmann::json rep = nlohmann::json::parse(std::ifstream(path(tag + ".json")));
    EXPECT_EQ(rep["compression"], c.args.empty() ? "fast" : c.args.substr(14, c.args.find(' ', 14) - 14));
  }
}

TEST_F(Cli, CodeRastersAreUInt16AboveTwoHundredFiftyFiveOwners) {
  // 300 points, each its own owner and feature, on a line: codes up to 300 need UInt16.
  std::string features;
  for (int i = 0; i < 300; ++i)
    features += std::string(i ? "," : "") + R"({"type":"Feature","properties":{"id":)" + std::to_string(i + 1) +
                R"(},"geometry":{"type":"Point","coordinates":[)" + std::to_string(500000.5 + 3.0 * i) +
                ",6000000.5]}}";
  const std::string seeds = write("line.geojson", R"({"type":"FeatureCollection",
    "crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},"features":[)" +
                                                      features + "]}");
  for (const char* cog : {"", " --cog"}) {
    SCOPED_TRACE(cog);
    const CliRun r = run("compute " + seeds +
                         " --owner-field id --resolution 1 --extent 500000 5999990 500900 6000010"
                         " --ownership " +
                         path("own.tif") + " --nearest-feature " + path("feat.tif") + cog + " --quiet");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(layout_of(path("own.tif")).type, "UInt16");
    EXPECT_EQ(layout_of(path("feat.tif")).type, "UInt16");
    gdal_init();
    SeedReadOptions ro;
    ro.paths = {seeds};
    ro.owner_field = "id";
    const LoadedSeeds loaded = load_seeds(ro);
    const NearestField f = compute(loaded.seeds, read_grid(path("own.tif")), ComputeOptions{});
    const Raster<int32_t> own = read_int32(path("own.tif"));
    EXPECT_EQ(own.cells(), owner_raster(loaded.seeds, f).cells());
    EXPECT_EQ(*std::max_element(own.cells().begin(), own.cells().end()), 300);
    EXPECT_EQ(read_int32(path("feat.tif")).cells(), feature_raster(loaded.seeds, f, 0, loaded.input_position).cells());
  }
}

TEST_F(Cli, FailedWriteLeavesNothingBehind) {
  // The distance output goes to a directory that does not exist: the ownership file written
  // before it must be removed too.
  const CliRun r = run("compute " + source(kDemo) + " --resolution 500 --ownership " + path("own.tif") +
                       " --distance " + path("nodir/d.tif") + " --quiet");
  EXPECT_EQ(r.exit_code, 9) << r.output;
  EXPECT_EQ(file_count(), 0u);
}

TEST_F(Cli, GeographicGridIsGeodesicInNauticalMiles) {
  const std::string gpkg = test::fixture("oresund.gpkg");
  const CliRun r = run("compute " + gpkg +
                       " --owner-field iso2 --resolution 0.01 --extent 12 55.3 13.2 56.3 "
                       "--distance-units nmi --ownership " +
                       path("own.tif") + " --distance " + path("d.tif") + " --report " + path("r.json") + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json rep = nlohmann::json::parse(std::ifstream(path("r.json")));
  EXPECT_EQ(rep["metric"], "geodesic");
  EXPECT_EQ(rep["distance_units"], "nmi");
  // The same grid in-process, in metres: the file holds metres / 1852.
  gdal_init();
  SeedReadOptions ro;
  ro.paths = {gpkg};
  ro.owner_field = "iso2";
  const LoadedSeeds seeds = load_seeds(ro);
  ComputeOptions co;
  co.metric = resolve_metric(MetricRequest::automatic, true);
  const NearestField f = compute(seeds.seeds, read_grid(path("own.tif")), co);
  const Raster<float> d = read_float32(path("d.tif"));
  ASSERT_EQ(d.size(), f.distance.size());
  float max_nmi = 0;
  for (size_t i = 0; i < d.size(); ++i) {
    EXPECT_NEAR(d.cells()[i], f.distance.cells()[i] / 1852.0, 1e-5);
    max_nmi = std::max(max_nmi, d.cells()[i]);
  }
  EXPECT_GT(max_nmi, 5.0f);  // the middle of the strait is several miles from both coasts
  EXPECT_LT(max_nmi, 30.0f);
  // Degrees are not distances: planar on this grid is refused.
  expect_refused(run("compute " + gpkg + " --owner-field iso2 --resolution 0.01 --metric planar --ownership " +
                     path("p.tif") + " --quiet"),
                 2, "degrees");
}

TEST_F(Cli, ProjectedGridGeodesicMeasuresOnTheEllipsoid) {
  const std::string gpkg = test::fixture("oresund.gpkg");
  // The strait on a UTM 33N grid of 2 km cells (the layer is EPSG:4326).
  const std::string grid = gpkg +
                           " --owner-field iso2 --crs EPSG:32633 --resolution 2000 "
                           "--extent 324000 6144000 376000 6230000 --quiet";
  const CliRun r = run("compute " + grid + " --metric geodesic --method brute-force --distance-units nmi --ownership " +
                       path("own.tif") + " --distance " + path("d.tif") + " --report " + path("r.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json rep = nlohmann::json::parse(std::ifstream(path("r.json")));
  EXPECT_EQ(rep["metric"], "geodesic");
  EXPECT_EQ(rep["distance_units"], "nmi");
  EXPECT_EQ(rep["grid"]["geographic"], false);
  const GridSpec g = read_grid(path("own.tif"));
  EXPECT_NE(g.crs.find("UTM zone 33N"), std::string::npos);
  ASSERT_EQ(g.width, 26);
  ASSERT_EQ(g.height, 43);
  // The distance raster says its unit and metric (band metadata and unit type).
  {
    GDALDatasetH ds = GDALOpen(path("d.tif").c_str(), GA_ReadOnly);
    ASSERT_NE(ds, nullptr);
    GDALRasterBandH band = GDALGetRasterBand(ds, 1);
    EXPECT_STREQ(GDALGetRasterUnitType(band), "nmi");
    const char* units = GDALGetMetadataItem(band, "UNITS", nullptr);
    const char* metric = GDALGetMetadataItem(band, "METRIC", nullptr);
    EXPECT_STREQ(units ? units : "", "nmi");
    EXPECT_STREQ(metric ? metric : "", "geodesic");
    GDALClose(ds);
  }
  const Raster<int32_t> own = read_int32(path("own.tif"));
  const Raster<float> dist = read_float32(path("d.tif"));

  // Reference: a geographic computation at the same cell centres. Each sample centre is taken
  // to longitude/latitude by GeographicLib (UTM 33N), and a one-cell longitude/latitude grid
  // centred there is computed in-process with the seeds in their own CRS.
  gdal_init();
  SeedReadOptions ro;
  ro.paths = {gpkg};
  ro.owner_field = "iso2";
  const LoadedSeeds seeds = load_seeds(ro);
  ASSERT_TRUE(seeds.crs.geographic);
  ComputeOptions co;
  co.metric = resolve_metric(MetricRequest::geodesic, true);
  co.method = Method::brute_force;
  int sea = 0, compared = 0;
  for (int64_t row = 1; row < g.height; row += 2)
    for (int64_t col = 0; col < g.width; col += 2) {
      double lat, lon;
      GeographicLib::UTMUPS::Reverse(33, true, g.centre_x(col), g.centre_y(row), lat, lon);
      GridSpec one;
      one.res = 1e-6;
      one.xmin = lon - 0.5 * one.res;
      one.ymax = lat + 0.5 * one.res;
      one.width = one.height = 1;
      const NearestField ref = compute(seeds.seeds, one, co);
      const int32_t owner = seeds.seeds.site_owner(ref.site.at(0, 0));
      EXPECT_EQ(own.at(col, row), owner) << "cell " << col << "," << row;
      const double metres = ref.distance.at(0, 0);
      const float nmi = dist.at(col, row);
      // 1 mm, plus the Float32 rounding of both rasters (relative 6e-8 each).
      EXPECT_NEAR(nmi * 1852.0, metres, 1e-3 + metres * 2.4e-7) << "cell " << col << "," << row;
      sea += metres > 0.0;
      ++compared;
    }
  EXPECT_GT(compared, 150);
  EXPECT_GT(sea, 40);

  // Planar on the same grid: the projection's metres, unchanged by the geodesic option; auto on
  // a projected grid is planar too.
  const CliRun p = run("compute " + grid + " --metric planar --ownership " + path("pown.tif") + " --distance " +
                       path("pd.tif") + " --report " + path("p.json"));
  ASSERT_EQ(p.exit_code, 0) << p.output;
  const CliRun a = run("compute " + grid + " --ownership " + path("aown.tif") + " --distance " + path("ad.tif") +
                       " --report " + path("a.json"));
  ASSERT_EQ(a.exit_code, 0) << a.output;
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(path("p.json")))["metric"], "planar");
  EXPECT_EQ(nlohmann::json::parse(std::ifstream(path("a.json")))["metric"], "planar");
  const Raster<float> planar = read_float32(path("pd.tif"));
  EXPECT_EQ(planar.cells(), read_float32(path("ad.tif")).cells());
  EXPECT_EQ(read_int32(path("pown.tif")).cells(), read_int32(path("aown.tif")).cells());
  // Same seeds, read in UTM, planar in-process: the file is exactly the engine's planar field.
  SeedReadOptions utm = ro;
  utm.target_crs = "EPSG:32633";
  const LoadedSeeds utm_seeds = load_seeds(utm);
  ComputeOptions pc;
  pc.method = Method::exact;
  const NearestField pf = compute(utm_seeds.seeds, g, pc);
  EXPECT_EQ(planar.cells(), pf.distance.cells());
  // And the geodesic metres differ from the plane's (UTM scale 0.9996 and more off-centre).
  double gap = 0.0;
  for (size_t i = 0; i < planar.size(); ++i)
    if (planar.cells()[i] > 0.0f) gap = std::max(gap, std::abs(planar.cells()[i] - dist.cells()[i] * 1852.0));
  EXPECT_GT(gap, 1.0);

  // validate works on it (its brute force measures geodesically too), the exact method included.
  const CliRun v = run("validate " + grid + " --metric geodesic --methods hv-scan,exact");
  ASSERT_EQ(v.exit_code, 0) << v.output;
  const nlohmann::json vj = nlohmann::json::parse(v.output.substr(v.output.find('{')));
  EXPECT_EQ(vj["metric"], "geodesic");
  EXPECT_LT(vj["methods"]["hv-scan"]["max_error_cells"].get<double>(), 1.0);
  EXPECT_EQ(vj["methods"]["exact"]["wrong_cells"].get<int64_t>(), 0) << vj.dump();
  // Boundary and limit lines: vertices in the grid's CRS, on the loci measured on the ellipsoid.
  // Checked independently: each vertex taken to longitude/latitude by GeographicLib and measured
  // with the geographic metric on the seeds in their own CRS.
  const CliRun dl = run("compute " + grid + " --metric geodesic --method brute-force --ownership " + path("x.tif") +
                        " --boundaries " + path("b.geojson") + " --limits " + path("l.geojson") +
                        " --limit-distances 3nmi --report " + path("x.json"));
  ASSERT_EQ(dl.exit_code, 0) << dl.output;
  const GeodesicSiteMetric geographic(seeds.seeds, co.metric);
  const OwnerIndex index(geographic);
  auto lonlat = [](const nlohmann::json& xy) {
    double lat, lon;
    GeographicLib::UTMUPS::Reverse(33, true, xy[0].get<double>(), xy[1].get<double>(), lat, lon);
    return Vec2{lon, lat};
  };
  int vertices = 0;
  const nlohmann::json lines = nlohmann::json::parse(std::ifstream(path("b.geojson")));
  for (const auto& f : lines["features"]) {
    const int32_t oa = f["properties"]["owner_a"], ob = f["properties"]["owner_b"];
    for (const auto& xy : f["geometry"]["coordinates"]) {
      EXPECT_GT(xy[0].get<double>(), 300000.0);  // grid CRS (UTM metres), not degrees
      const Vec2 p = lonlat(xy);
      EXPECT_NEAR(index.nearest_of(p, oa).distance, index.nearest_of(p, ob).distance, 1e-3);
      ++vertices;
    }
  }
  EXPECT_GT(vertices, 20);
  int limit_vertices = 0;
  const nlohmann::json limits = nlohmann::json::parse(std::ifstream(path("l.geojson")));
  for (const auto& f : limits["features"])
    for (const auto& xy : f["geometry"]["coordinates"]) {
      EXPECT_NEAR(index.nearest(lonlat(xy)).distance, 3 * 1852.0, 1e-3);
      ++limit_vertices;
    }
  EXPECT_GT(limit_vertices, 20);
  // The margin raster is refused for it, before anything is written.
  expect_refused(run("compute " + grid + " --metric geodesic --method brute-force --ownership " + path("y.tif") +
                     " --margin-raster " + path("m.tif")),
                 7, "margin");
  EXPECT_FALSE(fs::exists(path("y.tif")));
}

TEST_F(Cli, HelpAndVersion) {
  EXPECT_EQ(run("--version").exit_code, 0);
  const CliRun h = run("--help");
  EXPECT_EQ(h.exit_code, 0);
  EXPECT_NE(h.output.find("rvoronoi compute"), std::string::npos);
  EXPECT_NE(h.output.find("--compression PROFILE"), std::string::npos);
  EXPECT_EQ(run("").exit_code, 2);
  EXPECT_EQ(run("frobnicate").exit_code, 2);
}

// The man page (the hidden --help-man, which the build turns into rvoronoi.1) is made from the
// same table as --help: it names every option --help names.
TEST_F(Cli, TheManPageNamesEveryOptionOfTheHelp) {
  const CliRun h = run("--help");
  const CliRun m = run("--help-man");
  ASSERT_EQ(m.exit_code, 0) << m.output;
  EXPECT_EQ(m.output.rfind(".TH RVORONOI 1 ", 0), 0u) << m.output.substr(0, 200);
  EXPECT_EQ(h.output.find("--help-man"), std::string::npos) << "hidden";
  std::string man;  // roff's minus signs as the user reads them
  for (size_t i = 0; i < m.output.size(); ++i) {
    if (m.output.compare(i, 2, "\\-") == 0) ++i;
    man += m.output[i];
  }
  std::set<std::string> options;
  for (size_t at = h.output.find("--"); at != std::string::npos; at = h.output.find("--", at + 2)) {
    size_t end = at + 2;
    while (end < h.output.size() && (std::islower(static_cast<unsigned char>(h.output[end])) || h.output[end] == '-'))
      ++end;
    if (end > at + 2) options.insert(h.output.substr(at, end - at));
  }
  EXPECT_GT(options.size(), 50u);
  auto whole_word = [&](const std::string& o) {  // not a prefix of a longer option
    for (size_t at = man.find(o); at != std::string::npos; at = man.find(o, at + 1)) {
      const char after = at + o.size() < man.size() ? man[at + o.size()] : ' ';
      if (!std::islower(static_cast<unsigned char>(after)) && after != '-') return true;
    }
    return false;
  };
  for (const std::string& o : options) EXPECT_TRUE(whole_word(o)) << o;
}

}  // namespace
// An edit from the command line (issue 32): the user edits the seed file in place and runs the
// same command again with --base naming the earlier report; the files equal a fresh run's, the
// report says what moved; a run with --no-edit-base keeps nothing, and an edit of it is refused
// in one line.
TEST_F(Cli, AnEditOfTheSeedFileInPlace) {
  const std::string crs = R"("crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},)";
  auto seeds = [&](double bx) {
    return write("s.geojson", R"({"type":"FeatureCollection",)" + crs + R"("features":[
      {"type":"Feature","id":1,"properties":{"state":"A"},"geometry":{"type":"Point","coordinates":[401000,6101000]}},
      {"type":"Feature","id":2,"properties":{"state":"B"},"geometry":{"type":"Point","coordinates":[)" +
                                  std::to_string(bx) + R"(,6102000]}},
      {"type":"Feature","id":3,"properties":{"state":"C"},"geometry":{"type":"Point","coordinates":[402000,6108000]}}]})");
  };
  const std::string grid = " --owner-field state --resolution 50 --extent 400000 6100000 410000 6110000 --quiet";
  auto outputs = [&](const std::string& d) {
    fs::create_directories(path(d));
    return " --ownership " + path(d + "/own.tif") + " --distance " + path(d + "/dist.tif") + " --boundaries " +
           path(d + "/b.geojson") + " --report " + path(d + "/r.json");
  };
  CliRun r = run("compute " + seeds(408000) + grid + outputs("base"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("wrote " + path("base/r.json.rvbase")), std::string::npos) << r.output;
  seeds(406000);
  r = run("compute " + path("s.geojson") + grid + outputs("edit") + " --base " + path("base/r.json") + " --changes " +
          path("edit/changes.tif"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_EQ(run("compute " + path("s.geojson") + grid + outputs("fresh")).exit_code, 0);
  for (const char* f : {"own.tif", "dist.tif", "b.geojson"}) {
    std::ifstream a(path(std::string("edit/") + f), std::ios::binary),
        b(path(std::string("fresh/") + f), std::ios::binary);
    const std::string x((std::istreambuf_iterator<char>(a)), {}), y((std::istreambuf_iterator<char>(b)), {});
    EXPECT_TRUE(!x.empty() && x == y) << f;
  }
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(path("edit/r.json")));
  const nlohmann::json& e = report["edit"];
  EXPECT_EQ(e["base"], path("base/r.json"));
  EXPECT_EQ(e["features"]["changed"], 1) << e.dump();
  ASSERT_FALSE(e["area_moved"].empty()) << e.dump();
  // B moved west: every cell that changed hands went to or from B, 50 m x 50 m each.
  double moved = 0.0;
  for (const auto& m : e["area_moved"]) {
    EXPECT_TRUE(m["to"] == "B" || m["from"] == "B") << m.dump();
    moved += m["area"].get<double>();
  }
  EXPECT_EQ(moved, 2500.0 * e["owner_changed_cells"].get<double>());
  EXPECT_TRUE(fs::exists(path("edit/changes.tif")));
  // Kept nothing: an edit of it is refused, and writes nothing.
  ASSERT_EQ(run("compute " + path("s.geojson") + grid + outputs("plain") + " --no-edit-base").exit_code, 0);
  EXPECT_FALSE(fs::exists(path("plain/r.json.rvbase")));
  fs::create_directories(path("refused"));
  expect_refused(run("compute " + path("s.geojson") + grid + " --ownership " + path("refused/own.tif") + " --base " +
                     path("plain/r.json")),
                 3, "names nothing kept for edits");
  std::string grid40 = grid;
  grid40.replace(grid40.find("--resolution 50"), 15, "--resolution 40");
  expect_refused(run("compute " + path("s.geojson") + grid40 + " --ownership " + path("refused/own.tif") + " --base " +
                     path("base/r.json")),
                 2, "grid resolution 40.0 (base: 50.0)");
  EXPECT_TRUE(fs::is_empty(path("refused")));
}

}  // namespace rv
