// The façade's limits (JobLimits): each one, when exceeded, is rv::Error(too_large) with a
// message naming the limit, raised before the big allocations and leaving no output file.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "rv/error_map.hpp"
#include "rv/field/error.hpp"
#include "rv/job.hpp"

namespace fs = std::filesystem;

namespace rv {
namespace {

class JobLimitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rv_limits_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    // fixtures/demo_basepoints.geojson: 28 point features, UTM 33N.
    spec_.seeds.paths = {std::string(std::getenv("RV_SOURCE_DIR")) + "/fixtures/demo_basepoints.geojson"};
    spec_.seeds.owner_field = "state";
    spec_.grid.resolution = 1000.0;
    spec_.threads = 2;
    spec_.outputs.ownership = (dir_ / "own.tif").string();
    spec_.outputs.report = (dir_ / "report.json").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Runs the job, expects too_large with every part in the message, and no file left behind.
  std::string too_large(const JobLimits& limits, std::initializer_list<std::string> parts) {
    std::string message;
    try {
      run_job(spec_, limits);
      ADD_FAILURE() << "no rv::Error thrown";
    } catch (const Error& e) {
      message = e.what();
      EXPECT_EQ(e.kind(), ErrorKind::too_large) << message;
      for (const std::string& p : parts)
        EXPECT_NE(message.find(p), std::string::npos) << "'" << p << "' not in: " << message;
    }
    EXPECT_TRUE(fs::is_empty(dir_)) << "a refused job left files behind";
    return message;
  }

  int64_t cells() {
    const JobResult r = run_job(spec_);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    return r.report["grid"]["cells"].get<int64_t>();
  }

  fs::path dir_;
  JobSpec spec_;
};

TEST_F(JobLimitsTest, CellLimit) {
  const int64_t n = cells();
  ASSERT_GT(n, 1);
  JobLimits limits;
  limits.max_cells = n;
  EXPECT_NO_THROW(run_job(spec_, limits));
  fs::remove_all(dir_);
  fs::create_directories(dir_);
  limits.max_cells = n - 1;
  too_large(limits, {std::to_string(n) + " cells", "limit of " + std::to_string(n - 1)});
}

TEST_F(JobLimitsTest, MemoryLimit) {
  JobLimits limits;
  limits.max_memory_bytes = 1 << 20;  // below the engines' fixed 64 MiB allowance
  too_large(limits, {"MiB", "memory limit of 1 MiB"});
}

TEST_F(JobLimitsTest, ValidationCellLimit) {
  spec_.validate = true;
  JobLimits limits;
  limits.validate_max_cells = 10;
  too_large(limits, {"validate", "10 cells"});
}

TEST_F(JobLimitsTest, FeatureLimit) {
  JobLimits limits;
  limits.max_features = 27;
  too_large(limits, {"more than 27 features"});
  limits.max_features = 28;
  EXPECT_NO_THROW(run_job(spec_, limits));
}

// The disproportionality test's uploads are read under the same limits as the seeds.
TEST_F(JobLimitsTest, RelevantAreaAndCoastsAreBoundedToo) {
  // (Beside the job's directory, which must stay empty.)
  spec_.outputs.relevant_area = dir_.string() + "_area.geojson";
  {
    std::ofstream area(spec_.outputs.relevant_area);
    area << R"({"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},
      "features":[)";
    for (int i = 0; i < 40; ++i)
      area << (i ? "," : "") << R"({"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[)"
           << "[350000," << 6150000 + i * 100 << "],[351000," << 6150000 + i * 100 << "],[351000," << 6150050 + i * 100
           << "],[350000," << 6150000 + i * 100 << "]]]}}";
    area << "]}";
  }
  JobLimits limits;
  limits.max_features = 30;  // the seeds' 28 pass; the area's 40 do not
  const std::string message = too_large(limits, {"more than 30 features"});
  EXPECT_NE(message.find("_area.geojson"), std::string::npos) << message;
  // One polygon of area, and 40 lines of coast: the coasts are refused.
  {
    std::ofstream area(spec_.outputs.relevant_area);
    area << R"({"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},
      "features":[{"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[[350000,6150000],
      [360000,6150000],[360000,6160000],[350000,6150000]]]}}]})";
  }
  spec_.outputs.relevant_coasts = dir_.string() + "_coasts.geojson";
  {
    std::ofstream coasts(spec_.outputs.relevant_coasts);
    coasts << R"({"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},
      "features":[)";
    for (int i = 0; i < 40; ++i)
      coasts << (i ? "," : "") << R"({"type":"Feature","properties":{"state":"A"},"geometry":{"type":"LineString",)"
             << R"("coordinates":[[350000,)" << 6150000 + i * 100 << "],[351000," << 6150000 + i * 100 << "]]}}";
    coasts << "]}";
  }
  const std::string coasts_message = too_large(limits, {"more than 30 features"});
  EXPECT_NE(coasts_message.find("_coasts.geojson"), std::string::npos) << coasts_message;
  fs::remove(spec_.outputs.relevant_area);
  fs::remove(spec_.outputs.relevant_coasts);
}

TEST_F(JobLimitsTest, VertexLimit) {
  JobLimits limits;
  limits.max_vertices = 27;
  too_large(limits, {"more than 27 vertices"});
}

TEST_F(JobLimitsTest, TheStricterOfRequestAndServerLimitApplies) {
  JobLimits limits;
  limits.max_features = 100;
  spec_.seeds.max_features = 10;  // the request's own limit is stricter
  too_large(limits, {"more than 10 features"});
  limits.max_features = 5;  // now the server's is
  too_large(limits, {"more than 5 features"});
  limits.max_features = 0;  // no server limit: the request's holds
  too_large(limits, {"more than 10 features"});
}

TEST_F(JobLimitsTest, TooLargeMapsToItsOwnExitCodeAndStatus) {
  EXPECT_EQ(error_info(ErrorKind::too_large).exit_code, 6);
  EXPECT_EQ(error_info(ErrorKind::too_large).http_status, 422);
}

}  // namespace
}  // namespace rv
