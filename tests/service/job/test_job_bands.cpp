// A job split into bands of whole rows computed apart, and the run that assembles them (a shared
// service's split job, issue 55; service/src/job/job_bands.hpp): the assembled COGs, lines,
// regions and kept base are a one-run job's byte for byte, and its report equal aside from its
// timings, for bands given in any order, planar and geodesic, points and polygons (contested
// cells); bands that cannot make the grid are refused with one line and write nothing.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fixtures.hpp"
#include "rv/field/error.hpp"
#include "rv/job.hpp"

namespace fs = std::filesystem;

namespace rv {
namespace {

using test::fixture;

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class JobBands : public ::testing::Test {
 public:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rv_bands_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Every output a daemon's job writes (COGs, the lines, the regions, the report and the kept base).
  JobSpec with_outputs(JobSpec s, const std::string& sub) const {
    const fs::path d = dir_ / sub;
    fs::create_directories(d);
    OutputRequest& o = s.outputs;
    o.cloud_optimized = true;
    o.ownership = (d / "ownership.tif").string();
    o.distance = (d / "distance.tif").string();
    o.nearest_feature = (d / "nearest_feature.tif").string();
    o.boundaries = (d / "boundaries.geojson").string();
    o.tripoints = (d / "tripoints.geojson").string();
    o.limits = (d / "limits.geojson").string();
    o.limit_distances = {"3km"};
    o.regions = (d / "regions.geojson").string();
    o.report = (d / "report.json").string();
    o.edit_base = (d / "edit-base").string();
    return s;
  }
  // The same request as `whole`, as a band of rows [row0, row0 + rows) (no outputs).
  JobSpec band(JobSpec s, int64_t row0, int64_t rows, const std::string& sub) const {
    s.outputs = OutputRequest{};
    s.band = JobSpec::Band{row0, rows, (dir_ / sub).string()};
    return s;
  }

  fs::path dir_;
};

// The report without what measures time or this process's memory.
nlohmann::json without_timings(nlohmann::json r) {
  for (const char* k : {"timings_s", "compute_ns_per_cell", "peak_memory_bytes", "peak_memory_shared"}) r.erase(k);
  if (r.contains("outputs"))
    for (auto& [k, v] : r["outputs"].items())
      if (v.is_string()) v = fs::path(v.get<std::string>()).filename().string();
  return r;
}

void expect_assembly_equals_whole(const fs::path& a, const fs::path& b) {
  for (const char* f : {"ownership.tif", "distance.tif", "nearest_feature.tif", "boundaries.geojson",
                        "tripoints.geojson", "limits.geojson", "regions.geojson", "ownership.tif.aux.xml"}) {
    ASSERT_TRUE(fs::exists(a / f)) << f;
    EXPECT_TRUE(bytes_of(a / f) == bytes_of(b / f)) << f << " differs from the one-run job's";
  }
  // The kept field for edits too (its manifest carries timings: its rasters are compared).
  for (const char* f : {"site.tif", "seeds.bin"})
    EXPECT_TRUE(bytes_of(a / "edit-base" / f) == bytes_of(b / "edit-base" / f)) << "edit-base/" << f;
  const auto ra = nlohmann::json::parse(bytes_of(a / "report.json"));
  const auto rb = nlohmann::json::parse(bytes_of(b / "report.json"));
  EXPECT_EQ(without_timings(ra), without_timings(rb));
  EXPECT_GT(rb["timings_s"]["bands"].get<int>(), 1);
}

// Runs `whole`, its bands (given to the assembly in reverse order), then the assembly.
void split_and_compare(JobBands& t, const JobSpec& whole_request, const fs::path& root,
                       const std::vector<int64_t>& cuts) {
  const JobSpec whole = whole_request;
  const JobResult one = run_job(whole);
  const int64_t height = one.report["grid"]["height"].get<int64_t>();
  ASSERT_GT(height, cuts.back()) << "the grid must be taller than the last cut";
  std::vector<std::string> bands;
  for (size_t i = 0; i <= cuts.size(); ++i) {
    const int64_t r0 = i == 0 ? 0 : cuts[i - 1], r1 = i == cuts.size() ? height : cuts[i];
    JobSpec b = whole;
    b.outputs = OutputRequest{};
    b.band = JobSpec::Band{r0, r1 - r0, (root / ("band" + std::to_string(i))).string()};
    const JobResult r = run_job(b);
    EXPECT_EQ(r.report["band"]["row0"].get<int64_t>(), r0);
    EXPECT_EQ(r.files.size(), 3u);  // site.tif, distance.tif, band.json: nothing else
    bands.insert(bands.begin(), b.band->dir);
  }
  JobSpec assembled = t.with_outputs(whole, "assembled");
  assembled.bands = bands;
  run_job(assembled);
  expect_assembly_equals_whole(fs::path(whole.outputs.report).parent_path(),
                               fs::path(assembled.outputs.report).parent_path());
}

TEST_F(JobBands, PointsPlanarAssembleByteForByte) {
  JobSpec s;
  s.seeds.paths = {fixture("demo_basepoints.geojson")};
  s.seeds.owner_field = "state";
  s.grid.resolution = 60.0;  // about 690 x 840 cells: four bands of tiles and a short last one
  s.threads = 2;
  split_and_compare(*this, with_outputs(s, "whole"), dir_, {256, 512, 768});
}

TEST_F(JobBands, PolygonsAndLinesAssembleByteForByte) {
  JobSpec s;
  s.seeds.paths = {fixture("coast.gpkg")};
  s.seeds.owner_field = "owner";
  s.grid.resolution = 12.0;
  split_and_compare(*this, with_outputs(s, "whole"), dir_, {256});
}

TEST_F(JobBands, ContestedCellsCountOnceAcrossBands) {
  // Two owners' squares overlapping by 1 km x 1 km, decided for the lower code: the cells so
  // decided are the report's, whichever band computed them.
  JobSpec s;
  s.seeds.paths = {fixture("overlap.geojson")};
  s.seeds.owner_field = "owner";
  s.seeds.on_conflict = ConflictPolicy::lower_code;
  s.grid.resolution = 10.0;
  split_and_compare(*this, with_outputs(s, "whole"), dir_, {256, 512});
  const auto r = nlohmann::json::parse(bytes_of(dir_ / "assembled" / "report.json"));
  EXPECT_GT(r["contested_cells"].get<int64_t>(), 0);
}

TEST_F(JobBands, GeodesicAssemblesByteForByte) {
  JobSpec s;
  s.seeds.paths = {fixture("demo_basepoints.geojson")};
  s.seeds.owner_field = "state";
  s.grid.resolution = 90.0;
  s.metric = MetricRequest::geodesic;
  s.strip_rows = 256;  // the assembly's strips each inside one band; the first band computed in two
  split_and_compare(*this, with_outputs(s, "whole"), dir_, {512});
}

TEST_F(JobBands, BandsThatCannotMakeTheGridAreRefused) {
  JobSpec s;
  s.seeds.paths = {fixture("demo_basepoints.geojson")};
  s.seeds.owner_field = "state";
  s.grid.resolution = 60.0;
  auto refused = [&](const JobSpec& spec, const std::string& words) {
    try {
      run_job(spec);
      ADD_FAILURE() << "accepted; expected: " << words;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::invalid_argument);
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  refused(band(s, 100, 256, "x"), "whole bands of 256 rows");
  refused(band(s, 0, 300, "x"), "whole bands of 256 rows");
  refused(band(s, 0, 100000, "x"), "not inside the grid");
  JobSpec with_file = band(s, 0, 256, "x");
  with_file.outputs.ownership = (dir_ / "o.tif").string();
  refused(with_file, "writes its field only");
  JobSpec scan = band(s, 0, 256, "x");
  scan.method = Method::hv_scan;
  refused(scan, "a split job is streamed");
  EXPECT_FALSE(fs::exists(dir_ / "x"));
  EXPECT_FALSE(fs::exists(dir_ / "o.tif"));

  // Bands that leave rows out, hold rows twice, or come from another grid.
  run_job(band(s, 0, 256, "a"));
  run_job(band(s, 256, 256, "b"));
  run_job(band(s, 0, 512, "ab"));
  JobSpec assembled = with_outputs(s, "out");
  assembled.bands = {(dir_ / "a").string(), (dir_ / "b").string()};
  refused(assembled, "are in no band");
  assembled.bands = {(dir_ / "a").string(), (dir_ / "ab").string()};
  refused(assembled, "are in two bands");
  JobSpec coarser = s;
  coarser.grid.resolution = 120.0;
  run_job(band(coarser, 0, 256, "c"));
  assembled.bands = {(dir_ / "c").string()};
  refused(assembled, "a band of another grid");
  assembled.bands = {(dir_ / "nothing").string()};
  try {
    run_job(assembled);
    ADD_FAILURE() << "a missing band was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::not_found) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir_ / "out" / "ownership.tif"));
  EXPECT_FALSE(fs::exists(dir_ / "out" / "report.json"));
}

}  // namespace
}  // namespace rv
