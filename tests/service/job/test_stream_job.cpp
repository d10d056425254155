// The façade's streaming path (rv/job.hpp, JobPlan): GeoTIFFs written strip by strip equal the
// whole-field path's by content (size, geotransform, CRS, nodata, values, categories, units,
// metadata) for any strip height and thread count; a failure or cancellation mid-stream leaves
// no file; the plan and its memory estimate say what the job will hold.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>

#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include "rv/field/error.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/job.hpp"

namespace fs = std::filesystem;

#include "fixtures.hpp"
#include "geotiff_compare.hpp"

namespace rv {
namespace {

using test::expect_same_geotiff;
using test::fixture;

class StreamJob : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rv_stream_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // fixtures/demo_basepoints.geojson: 28 points of owners A..D, UTM 33N; about 275 x 336 cells.
  JobSpec points_spec(const std::string& sub) const {
    JobSpec s;
    s.seeds.paths = {fixture("demo_basepoints.geojson")};
    s.seeds.owner_field = "state";
    s.grid.resolution = 150.0;
    s.distance_units = DistanceUnit::km;  // the distance is converted per strip
    return with_outputs(s, sub);
  }
  // fixtures/coast.gpkg: points, lines and polygons (interiors at distance 0) of two owners.
  JobSpec coast_spec(const std::string& sub) const {
    JobSpec s;
    s.seeds.paths = {fixture("coast.gpkg")};
    s.seeds.owner_field = "owner";
    s.grid.resolution = 30.0;
    return with_outputs(s, sub);
  }
  JobSpec with_outputs(JobSpec s, const std::string& sub) const {
    fs::create_directories(dir_ / sub);
    s.outputs.ownership = (dir_ / sub / "own.tif").string();
    s.outputs.distance = (dir_ / sub / "dist.tif").string();
    s.outputs.nearest_feature = (dir_ / sub / "feat.tif").string();
    return s;
  }

  fs::path dir_;
};

void expect_same_outputs(const JobSpec& x, const JobSpec& y) {
  expect_same_geotiff(x.outputs.ownership, y.outputs.ownership);
  expect_same_geotiff(x.outputs.distance, y.outputs.distance);
  expect_same_geotiff(x.outputs.nearest_feature, y.outputs.nearest_feature);
}

TEST_F(StreamJob, StreamedFilesEqualWholeFieldFiles) {
  gdal_init();
  for (const bool coast : {false, true}) {
    JobSpec whole = coast ? coast_spec("whole") : points_spec("whole");
    whole.strip_rows = -1;
    whole.threads = 2;
    const JobResult ref = run_job(whole);
    ASSERT_FALSE(ref.report["streaming"]["streamed"].get<bool>());
    const int64_t height = ref.report["grid"]["height"].get<int64_t>();
    ASSERT_GT(height, 256) << "the grid must span more than one tile row";
    // 1 row, odd sizes that straddle tile rows, exactly one tile row, automatic, larger than the grid.
    for (const int64_t rows : {int64_t{1}, int64_t{7}, int64_t{256}, int64_t{300}, int64_t{0}, height + 5}) {
      for (const int threads : {1, 2, 3}) {
        SCOPED_TRACE("coast " + std::to_string(coast) + ", strip rows " + std::to_string(rows) + ", threads " +
                     std::to_string(threads));
        const std::string sub = "s" + std::to_string(rows) + "_" + std::to_string(threads);
        JobSpec s = coast ? coast_spec(sub) : points_spec(sub);
        s.strip_rows = rows;
        s.threads = threads;
        const JobResult r = run_job(s);
        ASSERT_TRUE(r.report["streaming"]["streamed"].get<bool>());
        const int64_t want_rows = rows == 0 ? height : std::min(rows, height);
        if (rows != 0) {
          EXPECT_EQ(r.report["streaming"]["rows_per_strip"].get<int64_t>(), want_rows);
        }
        EXPECT_EQ(r.report["contested_cells"], ref.report["contested_cells"]);
        EXPECT_EQ(r.files,
                  (std::vector<std::string>{s.outputs.ownership, s.outputs.distance, s.outputs.nearest_feature}));
        expect_same_outputs(s, whole);
        fs::remove_all(dir_ / sub);
      }
    }
  }
}

TEST_F(StreamJob, BruteForceStreamsToo) {
  JobSpec whole = points_spec("whole");
  whole.method = Method::brute_force;
  whole.strip_rows = -1;
  run_job(whole);
  JobSpec s = points_spec("streamed");
  s.method = Method::brute_force;
  s.strip_rows = 50;
  EXPECT_TRUE(run_job(s).report["streaming"]["streamed"].get<bool>());
  expect_same_outputs(s, whole);
}

TEST_F(StreamJob, ReportKeepsPhaseTimings) {
  JobSpec s = points_spec("r");
  s.strip_rows = 64;
  s.outputs.report = (dir_ / "r" / "report.json").string();
  const JobResult r = run_job(s);
  const auto& t = r.report["timings_s"];
  EXPECT_GT(t["compute"].get<double>(), 0.0);
  for (const char* name : {"ownership", "distance", "nearest_feature"}) EXPECT_GT(t["write"][name].get<double>(), 0.0);
  EXPECT_EQ(t["streamed"]["strips"].get<int64_t>(), r.report["streaming"]["strips"].get<int64_t>());
  EXPECT_GE(t["streamed"]["wall"].get<double>(), 0.0);
  EXPECT_LE(t["streamed"]["wall"].get<double>(), t["total"].get<double>());
  EXPECT_TRUE(fs::exists(s.outputs.report));
}

TEST_F(StreamJob, UnwritableTargetLeavesNothing) {
  JobSpec s = points_spec("x");
  s.strip_rows = 16;
  s.outputs.distance = (dir_ / "x" / "no" / "such" / "dist.tif").string();
  try {
    run_job(s);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::io) << e.what();
  }
  EXPECT_TRUE(fs::is_empty(dir_ / "x"));
}

TEST_F(StreamJob, FailedRenameAfterTheLastStripLeavesNothing) {
  // The distance target's name is taken by a directory: every strip is encoded, the ownership
  // file is already renamed into place, then the distance rename fails: the job removes both.
  JobSpec s = points_spec("x");
  s.strip_rows = 16;
  fs::create_directories(dir_ / "x" / "dist.tif" / "keep");
  try {
    run_job(s);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::io) << e.what();
  }
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(dir_ / "x")) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"dist.tif"});
}

TEST_F(StreamJob, CancellationMidStreamLeavesNothing) {
  for (const int threads : {1, 2}) {
    JobSpec s = points_spec("c");
    s.strip_rows = 8;
    s.threads = threads;
    std::atomic<bool> cancel{false};
    double seen = 0.0;
    JobHooks hooks;
    hooks.cancel = &cancel;
    hooks.progress = [&](const std::string& stage, double f) {
      if (stage == "compute") seen = f;
      if (stage == "compute" && f >= 0.4) cancel = true;
    };
    try {
      run_job(s, {}, hooks);
      FAIL() << "no error";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::cancelled) << e.what();
    }
    EXPECT_GE(seen, 0.4);
    EXPECT_LT(seen, 1.0) << "cancelled only at the end: not mid-stream";
    EXPECT_TRUE(fs::is_empty(dir_ / "c")) << "threads " << threads;
  }
}

TEST_F(StreamJob, ProgressCoversTheGrid) {
  JobSpec s = points_spec("p");
  s.strip_rows = 32;
  std::vector<std::pair<std::string, double>> calls;
  JobHooks hooks;
  hooks.progress = [&](const std::string& stage, double f) { calls.emplace_back(stage, f); };
  run_job(s, {}, hooks);
  double last_compute = -1.0, last_write = -1.0;
  for (const auto& [stage, f] : calls) {
    if (stage == "compute") {
      EXPECT_GE(f, last_compute);
      last_compute = f;
    }
    if (stage == "write") last_write = std::max(last_write, f);
  }
  EXPECT_EQ(last_compute, 1.0);
  EXPECT_EQ(last_write, 1.0);
}

TEST_F(StreamJob, PlanSaysWhenAndHowMuch) {
  GridSpec g;
  g.width = 10000;
  g.height = 10000;
  JobSpec s = points_spec("plan");
  const int64_t sites = 50000;
  const JobPlan streamed = plan_job(s, g, sites, MetricSpec::planar);
  EXPECT_TRUE(streamed.streamed);
  EXPECT_TRUE(streamed.why_whole.empty());
  EXPECT_EQ(streamed.strip_rows % 256, 0);
  EXPECT_EQ(streamed.strips, (g.height + streamed.strip_rows - 1) / streamed.strip_rows);
  JobSpec off = s;
  off.strip_rows = -1;
  const JobPlan whole = plan_job(off, g, sites, MetricSpec::planar);
  EXPECT_FALSE(whole.streamed);
  // The whole field: 8 bytes per cell for the engine plus 4 for an output raster.
  EXPECT_GE(whole.memory_bytes, g.cell_count() * 12);
  // Streamed: two strips in flight (engine result, owner codes, feature numbers) and the
  // writers' buffers, far below the whole field; it grows with the strip, not the grid.
  const int64_t strip_cells = streamed.strip_rows * g.width;
  EXPECT_GE(streamed.memory_bytes, 2 * strip_cells * (8 + 4 + 4));
  EXPECT_LT(streamed.memory_bytes, whole.memory_bytes / 3);
  GridSpec tall = g;
  tall.height = 100000;
  EXPECT_EQ(plan_job(s, tall, sites, MetricSpec::planar).memory_bytes, streamed.memory_bytes);
  // Deliverables stream too: their strips and a share for the lines, which grow with the
  // grid's sides (the lines' length), not with its area.
  JobSpec lines = s;
  lines.outputs.boundaries = "b.gpkg";
  lines.outputs.regions = "r.gpkg";
  lines.outputs.margin = "m.tif";
  lines.outputs.limits = "l.gpkg";
  lines.outputs.limit_distances = {"12nmi", "24nmi"};
  const JobPlan with_lines = plan_job(lines, g, sites, MetricSpec::planar);
  EXPECT_TRUE(with_lines.streamed) << with_lines.why_whole;
  EXPECT_GT(with_lines.memory_bytes, streamed.memory_bytes);
  EXPECT_LT(with_lines.memory_bytes, whole.memory_bytes / 2);
  // Ten times the rows: far from ten times the memory (the lines' share grows with the sides).
  EXPECT_LT(plan_job(lines, tall, sites, MetricSpec::planar).memory_bytes, 6 * with_lines.memory_bytes);
  EXPECT_GT(plan_job(off, tall, sites, MetricSpec::planar).memory_bytes, 9 * whole.memory_bytes);
  // Every rule that keeps a job whole.
  auto why = [&](auto change) {
    JobSpec x = s;
    change(x);
    const JobPlan p = plan_job(x, g, sites, MetricSpec::planar);
    EXPECT_FALSE(p.streamed);
    EXPECT_EQ(p.strips, 1);
    return p.why_whole;
  };
  EXPECT_NE(why([](JobSpec& x) { x.method = Method::hv_scan; }).find("scan"), std::string::npos);
  EXPECT_NE(why([](JobSpec& x) { x.validate = true; }).find("validation"), std::string::npos);
  EXPECT_NE(why([](JobSpec& x) { x.outputs = {}; }).find("no raster"), std::string::npos);
}

// Every layer's features as text: fields and geometry (WKT at full precision), in order.
std::vector<std::string> vector_content(const std::string& path) {
  std::unique_ptr<GDALDataset> d(GDALDataset::Open(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY));
  EXPECT_TRUE(d) << path;
  std::vector<std::string> out;
  if (!d) return out;
  for (OGRLayer* layer : d->GetLayers()) {
    out.push_back(std::string("layer ") + layer->GetName());
    layer->ResetReading();
    for (OGRFeature* f = layer->GetNextFeature(); f != nullptr; f = layer->GetNextFeature()) {
      std::string row;
      for (int i = 0; i < f->GetFieldCount(); ++i) row += std::string(f->GetFieldAsString(i)) + "|";
      if (const OGRGeometry* geom = f->GetGeometryRef()) {
        OGRWktOptions wkt;
        wkt.precision = 17;
        wkt.round = false;
        row += geom->exportToWkt(wkt);
      }
      out.push_back(row);
      OGRFeature::DestroyFeature(f);
    }
  }
  return out;
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST_F(StreamJob, StreamedDeliverablesEqualWholeFieldDeliverables) {
  gdal_init();
  auto with_deliverables = [&](JobSpec s, const std::string& sub) {
    const fs::path d = dir_ / sub;
    s.outputs.boundaries = (d / "b.gpkg").string();
    s.outputs.tripoints = (d / "t.gpkg").string();
    s.outputs.limits = (d / "l.gpkg").string();
    s.outputs.limit_distances = {"0.9km", "2km"};
    s.outputs.regions = (d / "r.gpkg").string();
    s.outputs.margin = (d / "m.tif").string();
    s.outputs.preview = (d / "p.png").string();
    return s;
  };
  // The points, the coast, and the points with a max distance (regions bounded by the
  // max-distance line too).
  for (const int variant : {0, 1, 2}) {
    const bool coast = variant == 1;
    JobSpec whole = with_deliverables(coast ? coast_spec("whole") : points_spec("whole"), "whole");
    if (variant == 2) whole.max_distance = 7.0;  // km: about a third of the grid is left unowned
    whole.strip_rows = -1;
    whole.threads = 2;
    const JobResult ref = run_job(whole);
    ASSERT_FALSE(ref.report["streaming"]["streamed"].get<bool>());
    const auto& b = ref.report["deliverables"]["boundaries"];
    ASSERT_GT(b["vertices"].get<int64_t>(), 100);
    if (variant == 0) {
      ASSERT_GT(b["tripoints"].get<int64_t>(), 0);
    }
    EXPECT_EQ(b["unresolved_tripoints"].get<int64_t>(), 0);
    for (const int64_t rows : {int64_t{1}, int64_t{7}, int64_t{0}}) {
      SCOPED_TRACE("variant " + std::to_string(variant) + ", strip rows " + std::to_string(rows));
      const std::string sub = "s" + std::to_string(variant) + "_" + std::to_string(rows);
      JobSpec s = with_deliverables(coast ? coast_spec(sub) : points_spec(sub), sub);
      s.max_distance = whole.max_distance;
      s.strip_rows = rows;
      s.threads = 2;
      if (rows == 7) s.outputs.ownership.clear();  // regions from an ownership file of their own
      const JobResult r = run_job(s);
      ASSERT_TRUE(r.report["streaming"]["streamed"].get<bool>());
      EXPECT_EQ(r.report["deliverables"], ref.report["deliverables"]);
      for (const auto& [a, z] :
           {std::pair{s.outputs.boundaries, whole.outputs.boundaries},
            std::pair{s.outputs.tripoints, whole.outputs.tripoints}, std::pair{s.outputs.limits, whole.outputs.limits},
            std::pair{s.outputs.regions, whole.outputs.regions}}) {
        const auto va = vector_content(a), vz = vector_content(z);
        if (!(variant == 2 && a == s.outputs.tripoints)) {  // (no tripoint there)
          EXPECT_GT(va.size(), 1u) << a;
        }
        EXPECT_EQ(va, vz) << a;
      }
      expect_same_geotiff(s.outputs.margin, whole.outputs.margin);
      EXPECT_EQ(file_bytes(s.outputs.preview), file_bytes(whole.outputs.preview));
      // Nothing but the requested files is left (the regions' ownership file is removed).
      std::vector<std::string> left;
      for (const auto& e : fs::directory_iterator(dir_ / sub)) left.push_back(e.path().filename().string());
      std::sort(left.begin(), left.end());
      std::vector<std::string> want = {"b.gpkg", "dist.tif", "feat.tif", "l.gpkg",
                                       "m.tif",  "p.png",    "r.gpkg",   "t.gpkg"};
      if (rows != 7) want.insert(want.end(), {"own.tif", "own.tif.aux.xml"});  // its categories beside it
      std::sort(want.begin(), want.end());
      EXPECT_EQ(left, want);
    }
  }
}

TEST_F(StreamJob, StreamedCogsEqualWholeFieldCogs) {
  gdal_init();
  JobSpec whole = points_spec("whole");
  whole.outputs.cloud_optimized = true;
  whole.outputs.margin = (dir_ / "whole" / "m.tif").string();
  whole.outputs.regions = (dir_ / "whole" / "r.gpkg").string();
  whole.strip_rows = -1;
  run_job(whole);
  JobSpec s = points_spec("s");
  s.outputs.cloud_optimized = true;
  s.outputs.margin = (dir_ / "s" / "m.tif").string();
  s.outputs.regions = (dir_ / "s" / "r.gpkg").string();
  s.strip_rows = 7;
  const JobResult r = run_job(s);
  ASSERT_TRUE(r.report["streaming"]["streamed"].get<bool>());
  expect_same_outputs(s, whole);
  expect_same_geotiff(s.outputs.margin, whole.outputs.margin);
  EXPECT_EQ(vector_content(s.outputs.regions), vector_content(whole.outputs.regions));
  for (const std::string& f : {s.outputs.ownership, s.outputs.distance, s.outputs.nearest_feature, s.outputs.margin}) {
    const auto d = test::open_raster_file(f);
    ASSERT_TRUE(d) << f;
    EXPECT_STREQ(d->GetMetadataItem("LAYOUT", "IMAGE_STRUCTURE"), "COG") << f;
    EXPECT_GT(d->GetRasterBand(1)->GetOverviewCount(), 0) << f;
  }
  // The strips' own files are gone; what is left is what was asked for (and the categories).
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(dir_ / "s")) left.push_back(e.path().filename().string());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{"dist.tif", "feat.tif", "m.tif", "own.tif", "own.tif.aux.xml", "r.gpkg"}));
}

TEST_F(StreamJob, DeliverablesAloneStreamWithoutARasterFile) {
  JobSpec s = points_spec("lines");
  s.outputs.ownership.clear();
  s.outputs.distance.clear();
  s.outputs.nearest_feature.clear();
  s.outputs.boundaries = (dir_ / "lines" / "b.geojson").string();
  s.strip_rows = 16;
  const JobResult r = run_job(s);
  EXPECT_TRUE(r.report["streaming"]["streamed"].get<bool>());
  EXPECT_GT(r.report["deliverables"]["boundaries"]["lines"].get<int64_t>(), 2);
  EXPECT_EQ(r.files, std::vector<std::string>{s.outputs.boundaries});
}

TEST_F(StreamJob, MemoryLimitCountsTheStreamedFootprint) {
  // 2000 x 2000 cells: the whole field needs 64 MiB + 48 MB, streamed in 16-row strips about
  // 64 MiB + 10 MB. A limit between the two admits the streamed job only.
  JobSpec s;
  s.seeds.paths = {fixture("demo_basepoints.geojson")};
  s.seeds.owner_field = "state";
  s.grid.resolution = 25.0;
  s.grid.extent = std::array<double, 4>{337000.0, 6140000.0, 387000.0, 6190000.0};
  s.outputs.ownership = (dir_ / "own.tif").string();
  s.strip_rows = 16;
  JobLimits limits;
  limits.max_memory_bytes = int64_t{90} << 20;
  const JobResult r = run_job(s, limits);
  EXPECT_TRUE(r.report["streaming"]["streamed"].get<bool>());
  EXPECT_LT(r.report["memory_estimate_bytes"].get<int64_t>(), limits.max_memory_bytes);
  fs::remove_all(dir_);
  fs::create_directories(dir_);
  s.strip_rows = -1;
  try {
    run_job(s, limits);
    FAIL() << "the whole-field job was not refused";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::too_large) << e.what();
  }
  EXPECT_TRUE(fs::is_empty(dir_));
}

}  // namespace
}  // namespace rv
