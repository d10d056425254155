// Feature and vertex limits of load_seeds (SeedReadOptions::max_features / max_vertices): over
// the limit is rv::Error(too_large) naming the limit; at the limit the data loads.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <cpl_vsi.h>

#include "rv/error.hpp"
#include "rv/seed_reader.hpp"

namespace rv {
namespace {

std::string fixture(const std::string& name) {
  const char* env = std::getenv("RV_SOURCE_DIR");
  return (std::filesystem::path(env != nullptr ? env : ".") / "fixtures" / name).string();
}

// n point features, plus one polygon feature with `ring` vertices when ring > 0.
std::string geojson(int n, int ring = 0) {
  std::string f;
  for (int i = 0; i < n; ++i)
    f += std::string(f.empty() ? "" : ",") + R"({"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[)" +
         std::to_string(i * 10) + ",0]}}";
  if (ring > 0) {
    std::string c;
    for (int i = 0; i < ring; ++i) {
      const double a = 6.283185307179586 * i / ring;
      c += "[" + std::to_string(50 + 10 * std::cos(a)) + "," + std::to_string(50 + 10 * std::sin(a)) + "],";
    }
    c += "[60,50]";
    f += std::string(f.empty() ? "" : ",") + R"({"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[)" +
         c + "]]}}";
  }
  return R"({"type":"FeatureCollection","features":[)" + f + "]}";
}

class Limits : public ::testing::Test {
 protected:
  void SetUp() override { gdal_init(); }
  void TearDown() override { VSIUnlink(path_.c_str()); }
  SeedReadOptions options(const std::string& text) {
    VSILFILE* f = VSIFOpenL(path_.c_str(), "wb");
    VSIFWriteL(text.data(), 1, text.size(), f);
    VSIFCloseL(f);
    SeedReadOptions o;
    o.paths = {path_};
    return o;
  }
  static std::string too_large(const SeedReadOptions& o) {
    try {
      load_seeds(o);
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::too_large) << e.what();
      return e.what();
    }
    ADD_FAILURE() << "no too_large error";
    return {};
  }
  std::string path_ = "/vsimem/rv_limits_test/seeds.geojson";
};

TEST_F(Limits, FeaturesOverTheLimitAreTooLarge) {
  SeedReadOptions o = options(geojson(5));
  o.max_features = 5;
  EXPECT_EQ(load_seeds(o).seeds.features().size(), 5u);
  o.max_features = 4;
  const std::string msg = too_large(o);
  EXPECT_NE(msg.find("more than 4 features"), std::string::npos) << msg;
  o.max_features = 0;  // no limit
  EXPECT_EQ(load_seeds(o).seeds.features().size(), 5u);
}

TEST_F(Limits, EmptyFeaturesCountTowardsTheFeatureLimit) {
  SeedReadOptions o = options(R"({"type":"FeatureCollection","features":[)"
                              R"({"type":"Feature","properties":{},"geometry":null},)"
                              R"({"type":"Feature","properties":{},"geometry":null},)"
                              R"({"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[1,2]}}]})");
  o.max_features = 2;
  too_large(o);
  o.max_features = 3;
  EXPECT_EQ(load_seeds(o).report.features_skipped_empty, 2);
}

TEST_F(Limits, VerticesOverTheLimitAreTooLarge) {
  // 3 points + a 100-gon whose closed ring has 101 vertices: 104 in all.
  SeedReadOptions o = options(geojson(3, 100));
  o.max_vertices = 104;
  EXPECT_EQ(load_seeds(o).seeds.features().size(), 4u);
  o.max_vertices = 103;
  const std::string msg = too_large(o);
  EXPECT_NE(msg.find("more than 103 vertices"), std::string::npos) << msg;
}

TEST_F(Limits, LayersWithAKnownCountAreRefusedBeforeReading) {
  // coast.gpkg: three layers of 2 features each; GPKG reports its counts cheaply.
  SeedReadOptions o;
  o.paths = {fixture("coast.gpkg")};
  o.on_conflict = ConflictPolicy::lower_code;
  o.max_features = 5;
  const std::string msg = too_large(o);
  EXPECT_NE(msg.find("more than 5 features"), std::string::npos) << msg;
  o.max_features = 6;
  EXPECT_EQ(load_seeds(o).seeds.features().size(), 6u);
}

}  // namespace
}  // namespace rv
