// Limits of load_seeds (SeedReadOptions::max_features / max_vertices / max_input_bytes /
// max_memory_bytes): over the limit is rv::Error(too_large) naming the limit; at the limit the
// data loads. Archives and Shapefiles are refused from what they hold before a driver builds a
// geometry (vector/src/reading/input_scan.hpp); each feature is counted before it is copied.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <cpl_vsi.h>
#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"

#include "fixtures.hpp"

namespace rv {
namespace {

using test::fixture;

// n point features, plus one polygon feature with `ring` vertices when ring > 0.
std::string geojson(int n, int ring = 0) {
  std::string f;
  for (int i = 0; i < n; ++i)
    f += std::string(f.empty() ? "" : ",") +
         R"({"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[)" + std::to_string(i * 10) +
         ",0]}}";
  if (ring > 0) {
    std::string c;
    for (int i = 0; i < ring; ++i) {
      const double a = 6.283185307179586 * i / ring;
      c += "[" + std::to_string(50 + 10 * std::cos(a)) + "," + std::to_string(50 + 10 * std::sin(a)) + "],";
    }
    c += "[60,50]";
    f += std::string(f.empty() ? "" : ",") +
         R"({"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[)" + c + "]]}}";
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
  SeedReadOptions o =
      options(R"({"type":"FeatureCollection","features":[)"
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

// Bytes of a file in /vsimem/ (or /vsizip/ for writing a zip member).
void write_file(const std::string& path, const std::string& bytes) {
  VSILFILE* f = VSIFOpenL(path.c_str(), "wb");
  ASSERT_NE(f, nullptr) << path;
  ASSERT_EQ(VSIFWriteL(bytes.data(), 1, bytes.size(), f), bytes.size());
  VSIFCloseL(f);
}

void put_be32(std::string& s, int32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) s += static_cast<char>((static_cast<uint32_t>(v) >> shift) & 0xFF);
}
template <class T>
void put_le(std::string& s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  s.append(b, sizeof(T));
}

std::string shp_header(int32_t type, int32_t file_words) {
  std::string h;
  put_be32(h, 9994);
  for (int i = 0; i < 5; ++i) put_be32(h, 0);
  put_be32(h, file_words);
  put_le<int32_t>(h, 1000);
  put_le<int32_t>(h, type);
  for (int i = 0; i < 8; ++i) put_le<double>(h, 0.0);
  return h;
}

// A zipped Shapefile (written through GDAL's /vsizip/ writer) of one MultiPoint of `points`
// points, all at (500000, 6000000), with its .shx and a one-record .dbf.
std::string multipoint_zip(const std::string& zip, int32_t points) {
  const int32_t content = 4 + 32 + 4 + 16 * points;
  std::string shp = shp_header(8, (100 + 8 + content) / 2);
  put_be32(shp, 1);
  put_be32(shp, content / 2);
  put_le<int32_t>(shp, 8);
  for (double v : {500000.0, 6000000.0, 500000.0, 6000000.0}) put_le<double>(shp, v);
  put_le<int32_t>(shp, points);
  for (int32_t i = 0; i < points; ++i) {
    put_le<double>(shp, 500000.0);
    put_le<double>(shp, 6000000.0);
  }
  std::string shx = shp_header(8, (100 + 8) / 2);
  put_be32(shx, 50);
  put_be32(shx, content / 2);
  // dBASE III: header (32), one character field "state" of width 1 (32), terminator, one record.
  std::string dbf(32, '\0');
  dbf[0] = 3;
  dbf[4] = 1;            // one record
  dbf[8] = 32 + 32 + 1;  // header length
  dbf[10] = 2;           // record length: deletion flag + 1 character
  std::string field(32, '\0');
  std::memcpy(field.data(), "state", 5);
  field[11] = 'C';
  field[16] = 1;
  dbf += field + "\r" + " A" + "\x1a";
  write_file("/vsizip/" + zip + "/bomb.shp", shp);
  write_file("/vsizip/" + zip + "/bomb.shx", shx);
  write_file("/vsizip/" + zip + "/bomb.dbf", dbf);
  return "/vsizip/" + zip;
}

TEST_F(Limits, ShapefilesAreRefusedFromTheirDeclaredCountsBeforeReading) {
  // (10 000 points, not more: GDAL grows a MultiPoint one point at a time, which the sanitizers'
  // realloc, always a copy, makes quadratic -- 50 000 took a minute under ASan.)
  const std::string zip = "/vsimem/rv_limits_test/bomb.zip";
  SeedReadOptions o;
  o.paths = {multipoint_zip(zip, 10000)};
  o.max_vertices = 1000;
  std::string msg = too_large(o);
  EXPECT_NE(msg.find("declares 10000 vertices; refused before reading it"), std::string::npos) << msg;
  // The memory limit bounds reading too: 10 000 points need about 7 MB to read.
  ASSERT_GT(reading_bytes(1, 10000, 0), 4 << 20);
  o.max_vertices = 0;
  o.max_memory_bytes = 2 << 20;
  msg = too_large(o);
  EXPECT_NE(msg.find("memory limit of 2 MiB"), std::string::npos) << msg;
  // Within the limits the archive loads: the 10 000 coincident points are one site, and the
  // report counts what was read.
  o.max_vertices = 10000;
  o.max_memory_bytes = 64 << 20;
  const LoadedSeeds l = load_seeds(o);
  EXPECT_EQ(l.seeds.sites().size(), 1u);
  EXPECT_EQ(l.report.vertices_read, 10000);
  EXPECT_EQ(l.report.reading_bytes, reading_bytes(1, 10000, 0));
  VSIRmdirRecursive("/vsimem/rv_limits_test");
}

TEST_F(Limits, ArchivesAreCountedAsTheyInflate) {
  // 3 MiB of zeros inflate from a few kilobytes; the limit is on what comes out.
  const std::string zip = "/vsimem/rv_limits_test/zeros.zip";
  write_file("/vsizip/" + zip + "/zeros.bin", std::string(3 << 20, '\0'));
  VSIStatBufL st;
  ASSERT_EQ(VSIStatL(zip.c_str(), &st), 0);
  EXPECT_LT(st.st_size, 64 * 1024);
  SeedReadOptions o;
  o.paths = {"/vsizip/" + zip};
  o.max_input_bytes = 1 << 20;
  const std::string msg = too_large(o);
  EXPECT_NE(msg.find("inflates to more than 1048576 bytes"), std::string::npos) << msg;
  // Under the limit the archive is read as usual (and is not a dataset: invalid_input).
  o.max_input_bytes = 4 << 20;
  try {
    load_seeds(o);
    ADD_FAILURE() << "a zip of zeros loaded";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
  }
  VSIRmdirRecursive("/vsimem/rv_limits_test");
}

TEST_F(Limits, CurvesCountAsTheVerticesTheyBecome) {
  // A CircularString of 201 control points is 100 arcs: up to 361 vertices each once linearised
  // at 1 degree, so 36 101 - counted before linearising, so that a few bytes of arcs cannot
  // become millions of vertices unchecked.
  const std::string path = "/vsimem/rv_limits_test/arcs.gpkg";
  {
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GPKG");
    std::unique_ptr<GDALDataset> ds(driver->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
    OGRLayer* layer = ds->CreateLayer("arcs", nullptr, wkbCircularString, nullptr);
    OGRFeature f(layer->GetLayerDefn());
    auto arc = std::make_unique<OGRCircularString>();
    for (int i = 0; i <= 200; ++i) arc->addPoint(i * 10.0, i % 2 == 0 ? 0.0 : 5.0);
    f.SetGeometryDirectly(arc.release());
    ASSERT_EQ(layer->CreateFeature(&f), OGRERR_NONE);
  }
  SeedReadOptions o;
  o.paths = {path};
  o.max_vertices = 36100;
  const std::string msg = too_large(o);
  EXPECT_NE(msg.find("more than 36100 vertices"), std::string::npos) << msg;
  o.max_vertices = 36101;
  EXPECT_EQ(load_seeds(o).report.vertices_read, 36101);
  VSIRmdirRecursive("/vsimem/rv_limits_test");
}

TEST_F(Limits, TheMemoryLimitStopsReadingFeatureByFeature) {
  // 2000 points: about 1.8 MB to read; a 1 MiB limit stops the reader part-way.
  SeedReadOptions o = options(geojson(2000));
  o.max_memory_bytes = 1 << 20;
  const std::string msg = too_large(o);
  EXPECT_NE(msg.find("memory limit of 1 MiB"), std::string::npos) << msg;
  o.max_memory_bytes = 4 << 20;
  const LoadedSeeds l = load_seeds(o);
  EXPECT_EQ(l.report.reading_bytes, reading_bytes(2000, 2000, 0));
}

}  // namespace
}  // namespace rv
