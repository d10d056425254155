// GeoJSON text (vector/src/writing/geojson_text.hpp) against GDAL's GeoJSON driver, the oracle:
// coordinates formatted as GDAL's OGRFormatDouble formats them (15 decimals) for two million
// values over every magnitude the grids use and for crafted ones with runs of zeros or nines of
// every length at every position near their end (where GDAL rounds further); and whole collections -- points, lines of
// many vertices (formatted on threads), polygons and multipolygons with holes, integer, real, string and integer-list
// properties (quotes, slashes, control characters, UTF-8, integers as reals, negative zero, tiny and huge values), in a
// longitude/latitude CRS, a projected one and none, with no feature at all -- equal to GDAL's file byte for byte. And
// the writers: a file in place (renamed from a temporary one), nothing left where the directory does not exist.
#include <gtest/gtest.h>

#include <unistd.h>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <ogr_p.h>
#include <ogrsf_frmts.h>

#include "common/gdal_util.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "writing/geojson_text.hpp"

namespace rv {
namespace {

std::string gdal_coordinate(double v) {
  char buf[400];
  OGRFormatDouble(buf, static_cast<int>(sizeof(buf)), v, '.', 15, 'f');
  return buf;
}

std::string ours(double v) {
  std::string s;
  writing::append_coordinate(s, v);
  return s;
}

TEST(GeoJsonText, CoordinatesAreGdals) {
  gdal_init();
  std::mt19937_64 rng(7);
  int64_t checked = 0;
  auto check = [&](double v) {
    ASSERT_EQ(ours(v), gdal_coordinate(v)) << std::hexfloat << v;
    ++checked;
  };
  // Longitudes and latitudes, projected metres, cell-sized and tiny values, both signs.
  const double scales[] = {1e-9, 1e-4, 0.5, 1.0, 90.0, 180.0, 1e3, 1e5, 5e5, 1e7, 4e7};
  for (const double scale : scales) {
    std::uniform_real_distribution<double> u(-scale, scale);
    for (int i = 0; i < 180000; ++i) check(u(rng));
  }
  // Grid positions: multiples of a cell size plus a little (where zeros run at the end).
  std::uniform_int_distribution<int> k(0, 200000);
  for (const double res : {0.0005, 0.001, 0.25, 1.0, 10.0, 100.0})
    for (int i = 0; i < 20000; ++i) {
      const double base = res * k(rng) + 8.5;
      check(base);
      check(-base);
      check(std::nextafter(base, 1e300));
      check(std::nextafter(base, -1e300));
    }
  // Decimal strings with runs of zeros and nines of every length from two to seven at every
  // position near the end, small and large integer parts.
  for (int digits = 1; digits <= 15; ++digits)
    for (const char run : {'0', '9'})
      for (int i = 0; i < 1200; ++i) {
        const int length = 2 + i % 6;
        std::string s = std::to_string(k(rng) % (i % 4 < 2 ? 1000 : 1000000)) + ".";
        for (int d = 0; d < 15; ++d)
          s.push_back(d >= digits && d < digits + length ? run : static_cast<char>('0' + k(rng) % 10));
        double v = 0.0;
        std::from_chars(s.data(), s.data() + s.size(), v);
        check(v);
        check(-v);
      }
  for (const double v : {0.0, -0.0, 1e-20, -1e-20, 0.5, 12.0, 1e15, 1e16, 1e21, 54.999999999999993, 3.000000000000001,
                         12345.000000011, 2.5e-16, 5e-16})
    check(v);
  EXPECT_GT(checked, 2000000);
}

// A random feature's content, to be written both ways.
struct Feature {
  int64_t id = 0;
  double real = 0.0;
  std::string text;
  std::vector<int> list;
  int kind = 0;                                       // 0 point, 1 line, 2 polygon, 3 multipolygon
  std::vector<std::vector<std::vector<Vec2>>> polys;  // parts, rings, points (lines: one part, one ring)
};

std::vector<Feature> random_features(std::mt19937_64& rng, double scale, int n, int vertices) {
  std::uniform_real_distribution<double> u(-scale, scale);
  std::uniform_int_distribution<int> k(0, 1000000);
  const std::string texts[] = {"DK", "a/b",     "quote \" back \\ slash", "tab\tnew\nline\rcr\bbell\x01", "ÅÆØ åäö ß €",
                               "",   "<script>"};
  const double reals[] = {0.0, -0.0, 12.0, 1.0 / 3.0, 1e-300, 6.02e23, -2.5, 1e21, 1e-5, 123456789.0};
  std::vector<Feature> out;
  for (int i = 0; i < n; ++i) {
    Feature f;
    f.id = k(rng) - 500000;
    f.real = i % 3 == 0 ? reals[static_cast<size_t>(k(rng)) % std::size(reals)] : u(rng) * 1e-3 * k(rng);
    f.text = texts[static_cast<size_t>(k(rng)) % std::size(texts)];
    for (int j = k(rng) % 5; j > 0; --j) f.list.push_back(k(rng) - 1000);
    f.kind = i % 4;
    const int parts = f.kind == 3 ? 1 + k(rng) % 3 : 1;
    for (int p = 0; p < parts; ++p) {
      std::vector<std::vector<Vec2>> rings;
      const int nrings = f.kind >= 2 ? 1 + k(rng) % 2 : 1;
      for (int r = 0; r < nrings; ++r) {
        std::vector<Vec2> ring;
        const int m = f.kind == 0 ? 1 : f.kind == 1 ? 2 + k(rng) % vertices : 3 + k(rng) % 50;
        for (int q = 0; q < m; ++q) ring.push_back(Vec2{u(rng), u(rng)});
        if (f.kind >= 2) ring.push_back(ring.front());
        rings.push_back(ring);
      }
      f.polys.push_back(rings);
    }
    out.push_back(f);
  }
  return out;
}

OGRPolygon ogr_polygon(const std::vector<std::vector<Vec2>>& rings) {
  OGRPolygon poly;
  for (const auto& r : rings) {
    OGRLinearRing ring;
    gdal::set_points(ring, r);  // (at once: addPoint grows the curve a point at a time)
    poly.addRing(&ring);
  }
  return poly;
}

std::unique_ptr<OGRGeometry> ogr_geometry(const Feature& f) {
  if (f.kind == 0) return std::make_unique<OGRPoint>(f.polys[0][0][0].x, f.polys[0][0][0].y);
  if (f.kind == 1) {
    auto ls = std::make_unique<OGRLineString>();
    gdal::set_points(*ls, f.polys[0][0]);
    return ls;
  }
  if (f.kind == 2) return std::make_unique<OGRPolygon>(ogr_polygon(f.polys[0]));
  auto mp = std::make_unique<OGRMultiPolygon>();
  for (const auto& part : f.polys) {
    const OGRPolygon p = ogr_polygon(part);
    mp->addGeometry(&p);
  }
  return mp;
}

std::string read_vsimem(const std::string& path) {
  vsi_l_offset size = 0;
  GByte* bytes = VSIGetMemFileBuffer(path.c_str(), &size, TRUE);
  std::string s(reinterpret_cast<const char*>(bytes), static_cast<size_t>(size));
  CPLFree(bytes);
  return s;
}

// GDAL's file of the features.
std::string gdal_file(const std::vector<Feature>& features, const std::string& crs) {
  const std::string path = "/vsimem/test-geojson-gdal.geojson";
  {
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GeoJSON");
    std::unique_ptr<GDALDataset> ds(driver->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
    OGRSpatialReference srs;
    if (!crs.empty()) srs.SetFromUserInput(crs.c_str());
    srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    OGRLayer* l = ds->CreateLayer("things", crs.empty() ? nullptr : &srs, wkbUnknown, nullptr);
    for (const auto& [name, type] : std::vector<std::pair<const char*, OGRFieldType>>{
             {"id", OFTInteger64}, {"real", OFTReal}, {"text", OFTString}, {"list", OFTIntegerList}}) {
      OGRFieldDefn def(name, type);
      l->CreateField(&def);
    }
    for (const Feature& f : features) {
      OGRFeature* of = OGRFeature::CreateFeature(l->GetLayerDefn());
      of->SetField("id", static_cast<GIntBig>(f.id));
      of->SetField("real", f.real);
      of->SetField("text", f.text.c_str());
      of->SetField("list", static_cast<int>(f.list.size()), f.list.data());
      of->SetGeometryDirectly(ogr_geometry(f).release());
      EXPECT_EQ(l->CreateFeature(of), OGRERR_NONE);
      OGRFeature::DestroyFeature(of);
    }
  }
  return read_vsimem(path);
}

std::string our_file(const std::vector<Feature>& features, const std::string& crs) {
  writing::GeoJsonText text("things", crs, 2);
  for (const Feature& f : features) {
    text.begin_feature();
    text.property("id", f.id);
    text.property("real", f.real);
    text.property("text", f.text);
    text.property("list", std::span<const int>(f.list));
    if (f.kind == 0) text.point(f.polys[0][0][0]);
    if (f.kind == 1) text.line(f.polys[0][0]);
    if (f.kind >= 2) text.polygons(*ogr_geometry(f));
    text.end_feature();
  }
  return text.finish();
}

TEST(GeoJsonText, CollectionsAreGdalsByteForByte) {
  gdal_init();
  std::mt19937_64 rng(54);
  for (const auto& [crs, scale] :
       std::vector<std::pair<std::string, double>>{{"EPSG:4326", 90.0}, {"EPSG:32633", 9e5}, {"", 1000.0}}) {
    SCOPED_TRACE(crs.empty() ? "no CRS" : crs);
    // Lines long enough to be formatted in several blocks.
    const std::vector<Feature> features = random_features(rng, scale, 60, 12000);
    const std::string gdal = gdal_file(features, crs);
    const std::string mine = our_file(features, crs);
    size_t at = 0;
    while (at < mine.size() && at < gdal.size() && mine[at] == gdal[at]) ++at;
    EXPECT_EQ(at, gdal.size()) << "first difference at byte " << at << ": ours \""
                               << mine.substr(at > 60 ? at - 60 : 0, 120) << "\"\nGDAL's \""
                               << gdal.substr(at > 60 ? at - 60 : 0, 120) << "\"";
    EXPECT_EQ(mine.size(), gdal.size());
    EXPECT_EQ(our_file({}, crs), gdal_file({}, crs));  // no feature
  }
}

TEST(GeoJsonText, FilesAreWrittenWholeOrNotAtAll) {
  gdal_init();
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("rv_geojson_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "a.geojson").string();
  writing::write_text_file(path, "{ }\n");
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_EQ(ss.str(), "{ }\n");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()), 1);
  EXPECT_THROW(writing::write_text_file((dir / "missing" / "b.geojson").string(), "x"), Error);
  writing::write_text_file("/vsimem/rv-geojson-text.geojson", "{ }\n");
  EXPECT_EQ(read_vsimem("/vsimem/rv-geojson-text.geojson"), "{ }\n");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rv
