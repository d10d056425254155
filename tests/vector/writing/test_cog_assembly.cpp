// COGs assembled from the streamed, already-encoded tiles (vector/src/writing/cog_overviews.hpp,
// vector/src/writing/cog_assembly.hpp): the full resolution holds the source cells and the very tile bytes
// of the plain GeoTIFF the same writer makes; every overview level equals a brute-force
// decimation of the level before it and the overviews GDAL's COG driver makes from the same
// cells; GDAL reports LAYOUT=COG and its validator accepts the file; every compression profile;
// BigTIFF; nothing is left behind.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cfloat>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <random>
#include <type_traits>
#include <vector>

#include <cpl_string.h>
#include <cpl_vsi.h>
#include <gdal_priv.h>

#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "vector_test_util.hpp"
#include "writing/cog_assembly.hpp"
#include "writing/cog_overviews.hpp"

namespace rv {
namespace {

using test::ScratchDir;
using test::utm_grid;

std::unique_ptr<GDALDataset> open(const std::string& path) {
  return std::unique_ptr<GDALDataset>(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::vector<std::string> files_in(const std::filesystem::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

// GDAL's validator (python3-gdal, tools/setup.sh): "" when it accepts `path`, else what it said.
std::string cog_validator_errors(const std::string& path) {
  const std::string report = path + ".validation.txt";
  const std::string cmd =
      "/usr/bin/python3 /usr/lib/python3/dist-packages/osgeo_utils/samples/validate_cloud_optimized_geotiff.py '" +
      path + "' > '" + report + "' 2>&1";
  const int status = std::system(cmd.c_str());
  std::string said = file_bytes(report);
  std::filesystem::remove(report);
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return "";
  return said.empty() ? "the validator did not run (status " + std::to_string(status) + ")" : said;
}

// A level's cells as T: 0 = the full resolution, k = overview k.
template <class T>
std::vector<T> read_level(GDALDataset& ds, int level, int64_t* width = nullptr, int64_t* height = nullptr) {
  GDALRasterBand* band = ds.GetRasterBand(1);
  if (level > 0) band = band->GetOverview(level - 1);
  std::vector<T> out(static_cast<size_t>(band->GetXSize()) * static_cast<size_t>(band->GetYSize()));
  const GDALDataType type = std::is_same_v<T, float> ? GDT_Float32 : GDT_Int32;
  EXPECT_EQ(band->RasterIO(GF_Read, 0, 0, band->GetXSize(), band->GetYSize(), out.data(), band->GetXSize(),
                           band->GetYSize(), type, 0, 0, nullptr),
            CE_None);
  if (width != nullptr) *width = band->GetXSize();
  if (height != nullptr) *height = band->GetYSize();
  return out;
}

// The documented rule (cog_overviews.hpp) computed cell by cell from the level before: nearest
// takes the cell at int(0.5 + i * s); average is the mean of the valid source cells weighted by
// how much of each the cell's span [i * s, (i + 1) * s) covers, where a value nearer nodata than
// GDAL's tolerance (two float epsilons of their sum) counts as nodata.
template <class T>
std::vector<T> decimate(const std::vector<T>& src, int64_t sw, int64_t sh, int64_t w, int64_t h, bool average,
                        T nodata) {
  const double sx = static_cast<double>(sw) / static_cast<double>(w),
               sy = static_cast<double>(sh) / static_cast<double>(h);
  std::vector<T> out(static_cast<size_t>(w * h));
  auto cover = [](int64_t cell, double from, double to) {
    return std::max(
        0.0, std::min<double>(static_cast<double>(cell + 1), to) - std::max<double>(static_cast<double>(cell), from));
  };
  for (int64_t j = 0; j < h; ++j)
    for (int64_t i = 0; i < w; ++i) {
      T& o = out[static_cast<size_t>(j * w + i)];
      if (!average) {
        o = src[static_cast<size_t>(static_cast<int64_t>(0.5 + static_cast<double>(j) * sy) * sw +
                                    static_cast<int64_t>(0.5 + static_cast<double>(i) * sx))];
        continue;
      }
      double sum = 0.0, weight = 0.0;
      for (int64_t y = static_cast<int64_t>(static_cast<double>(j) * sy); y < sh && y < (j + 1) * sy; ++y)
        for (int64_t x = static_cast<int64_t>(static_cast<double>(i) * sx); x < sw && x < (i + 1) * sx; ++x) {
          const T v = src[static_cast<size_t>(y * sw + x)];
          const double c = cover(x, i * sx, (i + 1) * sx) * cover(y, j * sy, (j + 1) * sy);
          const bool invalid = v == nodata || std::abs(v - nodata) < 2 * FLT_EPSILON * std::abs(v + nodata);
          if (invalid || c == 0.0) continue;
          sum += c * static_cast<double>(v);
          weight += c;
        }
      o = weight > 0.0 ? static_cast<T>(sum / weight) : nodata;
    }
  return out;
}

// What GDAL's COG driver makes of the same cells (the overviews the COGs were copied with
// before): a MEM dataset of the file's type.
std::unique_ptr<GDALDataset> gdal_cog(const std::string& path, const void* cells, GDALDataType type, int64_t w,
                                      int64_t h, double nodata, bool average) {
  GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
  std::unique_ptr<GDALDataset> src(mem->Create("", static_cast<int>(w), static_cast<int>(h), 1, type, nullptr));
  GDALRasterBand* band = src->GetRasterBand(1);
  band->SetNoDataValue(nodata);
  EXPECT_EQ(band->RasterIO(GF_Write, 0, 0, static_cast<int>(w), static_cast<int>(h), const_cast<void*>(cells),
                           static_cast<int>(w), static_cast<int>(h), type, 0, 0, nullptr),
            CE_None);
  CPLStringList co;
  co.SetNameValue("BLOCKSIZE", "256");
  co.SetNameValue("OVERVIEW_RESAMPLING", average ? "AVERAGE" : "NEAREST");
  GDALDriver* cog = GetGDALDriverManager()->GetDriverByName("COG");
  GDALClose(GDALDataset::ToHandle(cog->CreateCopy(path.c_str(), src.get(), FALSE, co.List(), nullptr, nullptr)));
  return open(path);
}

// Every full-resolution tile of `cog` holds the bytes of the same tile of `plain` (the encoded
// tiles are copied, never encoded again).
void expect_same_tile_bytes(const std::string& cog, const std::string& plain) {
  const auto a = open(cog), b = open(plain);
  ASSERT_TRUE(a && b);
  const std::string ab = file_bytes(cog), bb = file_bytes(plain);
  GDALRasterBand* ba = a->GetRasterBand(1);
  GDALRasterBand* bb_band = b->GetRasterBand(1);
  int bw = 0, bh = 0;
  ba->GetBlockSize(&bw, &bh);
  const int across = (ba->GetXSize() + bw - 1) / bw, down = (ba->GetYSize() + bh - 1) / bh;
  for (int y = 0; y < down; ++y)
    for (int x = 0; x < across; ++x) {
      auto item = [&](GDALRasterBand* band, const char* what) {
        const char* v = band->GetMetadataItem(CPLSPrintf("BLOCK_%s_%d_%d", what, x, y), "TIFF");
        return v == nullptr ? size_t{0} : static_cast<size_t>(std::stoull(v));
      };
      const size_t size = item(ba, "SIZE");
      ASSERT_GT(size, 0u);
      ASSERT_EQ(size, item(bb_band, "SIZE")) << "tile " << x << "," << y;
      EXPECT_EQ(ab.compare(item(ba, "OFFSET"), size, bb, item(bb_band, "OFFSET"), size), 0) << "tile " << x << "," << y;
    }
}

template <class T>
Raster<T> pattern(const GridSpec& grid, bool with_nodata, unsigned seed) {
  Raster<T> r(grid, T{0});
  std::mt19937 rng(seed);
  for (int64_t row = 0; row < grid.height; ++row)
    for (int64_t col = 0; col < grid.width; ++col) {
      if constexpr (std::is_same_v<T, float>) {
        float v = static_cast<float>(std::uniform_real_distribution<double>(0.0, 1000.0)(rng));
        if (with_nodata && (rng() % 10 < 3 || (row < 40 && col < 40))) v = -1.0f;
        if (with_nodata && row == 7 && col % 50 == 1) v = std::nextafter(-1.0f, 0.0f);  // nodata to GDAL's mask
        r.at(col, row) = v;
      } else {
        r.at(col, row) = static_cast<T>((col / 7 + 13 * (row / 5)) % 250 + 1);
      }
    }
  return r;
}

struct Case {
  int64_t width, height;
  int64_t max_code;  // integer rasters: -1, or the stated range (the file type)
  Compression compression = Compression::fast;
};

// The COG of `cells`, streamed in strips of `strip` rows and written whole, against the plain
// GeoTIFF, brute force and GDAL's COG driver.
template <class T>
void check_cog(const Case& c, int64_t strip) {
  SCOPED_TRACE(std::to_string(c.width) + "x" + std::to_string(c.height) + " max_code " + std::to_string(c.max_code) +
               " " + std::string(to_string(c.compression)));
  ScratchDir dir;
  constexpr bool floating = std::is_same_v<T, float>;
  const GridSpec grid = utm_grid(c.width, c.height, 10.0);
  const Raster<T> cells = pattern<T>(grid, floating, static_cast<unsigned>(c.width * 31 + c.height));
  const T nodata = floating ? T(-1) : T(0);
  GeoTiffOptions o;
  o.compression = c.compression;
  o.threads = 2;
  if (!floating) {
    o.categorical = true;
    o.max_code = c.max_code;
    o.category_labels = {"a", "b"};
  }
  GeoTiffOptions cog = o;
  cog.cloud_optimized = true;
  const std::string streamed = dir.file("streamed.tif"), whole = dir.file("whole.tif"), plain = dir.file("plain.tif");
  {
    GeoTiffStripWriter<T> w(streamed, grid, grid.full_window(), nodata, cog);
    for (int64_t row = 0; row < c.height; row += strip) w.write_rows(cells.row(row), std::min(strip, c.height - row));
    w.finish();
  }
  write_geotiff(whole, cells, nodata, cog);
  write_geotiff(plain, cells, nodata, o);
  EXPECT_EQ(file_bytes(streamed), file_bytes(whole)) << "the strips' COG differs from the whole raster's";
  EXPECT_EQ(cog_validator_errors(streamed), "");
  expect_same_tile_bytes(streamed, plain);
  if (!floating) {
    EXPECT_EQ(read_category_labels(streamed), o.category_labels);
  }

  const auto ds = open(streamed);
  ASSERT_TRUE(ds);
  EXPECT_STREQ(ds->GetMetadataItem("LAYOUT", "IMAGE_STRUCTURE"), "COG");
  const auto plain_ds = open(plain);
  EXPECT_EQ(ds->GetRasterBand(1)->GetRasterDataType(), plain_ds->GetRasterBand(1)->GetRasterDataType());
  EXPECT_EQ(std::vector<T>(cells.cells().begin(), cells.cells().end()), read_level<T>(*ds, 0));
  // GDAL's COG driver from the same cells, in the file's type.
  const GDALDataType type = ds->GetRasterBand(1)->GetRasterDataType();
  std::vector<uint8_t> typed(static_cast<size_t>(grid.cell_count() * GDALGetDataTypeSizeBytes(type)));
  GDALCopyWords64(cells.data(), floating ? GDT_Float32 : GDT_Int32, static_cast<int>(sizeof(T)), typed.data(), type,
                  GDALGetDataTypeSizeBytes(type), grid.cell_count());
  const auto reference =
      gdal_cog(dir.file("gdal.tif"), typed.data(), type, c.width, c.height, static_cast<double>(nodata), floating);
  ASSERT_TRUE(reference);
  const int levels = ds->GetRasterBand(1)->GetOverviewCount();
  ASSERT_EQ(levels, reference->GetRasterBand(1)->GetOverviewCount());
  ASSERT_EQ(static_cast<size_t>(levels), detail::overview_sizes(c.width, c.height, 256).size());
  std::vector<T> previous = read_level<T>(*ds, 0);
  int64_t pw = c.width, ph = c.height;
  for (int level = 1; level <= levels; ++level) {
    SCOPED_TRACE("overview " + std::to_string(level));
    int64_t w = 0, h = 0;
    const std::vector<T> got = read_level<T>(*ds, level, &w, &h);
    EXPECT_EQ(got, read_level<T>(*reference, level)) << "differs from GDAL's COG driver";
    const std::vector<T> brute = decimate(previous, pw, ph, w, h, floating, nodata);
    ASSERT_EQ(got.size(), brute.size());
    for (size_t i = 0; i < got.size(); ++i) {
      const bool same = floating ? std::abs(got[i] - brute[i]) <= 1e-4f * std::max(1.0f, std::abs(float(brute[i])))
                                 : got[i] == brute[i];
      if (!same) {
        ADD_FAILURE() << "cell " << i % static_cast<size_t>(w) << "," << i / static_cast<size_t>(w) << ": " << got[i]
                      << ", brute force " << brute[i];
        break;
      }
    }
    previous = got;
    pw = w;
    ph = h;
  }
  EXPECT_EQ(files_in(dir.path()).size(), floating ? 4u : 7u) << "staging files left";
}

TEST(CogAssembly, LevelsAreGdals) {
  gdal_init();
  // Sizes GDAL 3.6's COG driver gives (gdalinfo on its COGs): floor halving while wider or taller
  // than a tile.
  using S = std::vector<detail::LevelSize>;
  auto sizes = [](int64_t w, int64_t h) { return detail::overview_sizes(w, h, 256); };
  auto same = [](const S& a, const S& b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](auto& x, auto& y) {
             return x.width == y.width && x.height == y.height;
           });
  };
  EXPECT_TRUE(same(sizes(1000, 777), S{{500, 388}, {250, 194}}));
  EXPECT_TRUE(same(sizes(300, 5), S{{150, 2}}));
  EXPECT_TRUE(same(sizes(1, 1), S{}));
  EXPECT_TRUE(same(sizes(256, 256), S{}));
  EXPECT_TRUE(same(sizes(257, 1), S{{128, 1}}));
  EXPECT_TRUE(same(sizes(5000, 300), S{{2500, 150}, {1250, 75}, {625, 37}, {312, 18}, {156, 9}}));
}

TEST(CogAssembly, CodesAtEveryStorageType) {
  gdal_init();
  check_cog<int32_t>({1000, 777, 255}, 100);  // Byte
  check_cog<int32_t>({300, 5, 60000}, 2);     // UInt16
  check_cog<int32_t>({1, 1, -1}, 1);          // Int32
  check_cog<int32_t>({1000, 777, -1}, 256);   // Int32, strips of whole tile rows
  check_cog<int32_t>({5000, 300, 255}, 77);   // five levels, one tile down
}

TEST(CogAssembly, FloatsWithNodata) {
  gdal_init();
  check_cog<float>({1000, 777, -1}, 100);
  check_cog<float>({300, 5, -1}, 3);
  check_cog<float>({1, 1, -1}, 1);
  check_cog<float>({513, 1100, -1}, 512);
}

// NaN as nodata: NaN cells are left out of the averages (GDAL's nodata mask), bit for bit as
// GDAL's COG driver does it.
TEST(CogAssembly, NanNodata) {
  gdal_init();
  ScratchDir dir;
  const GridSpec grid = utm_grid(600, 412, 10.0);  // 2 x 2 blocks at every level
  Raster<float> cells = pattern<float>(grid, true, 11);
  for (float& v : cells.cells())
    if (v == -1.0f) v = std::nanf("");
  GeoTiffOptions o;
  o.cloud_optimized = true;
  const double nan = std::nan("");
  write_geotiff(dir.file("nan.tif"), cells, nan, o);
  EXPECT_EQ(cog_validator_errors(dir.file("nan.tif")), "");
  const auto ours = open(dir.file("nan.tif"));
  const auto gdal = gdal_cog(dir.file("gdal.tif"), cells.data(), GDT_Float32, 600, 412, nan, true);
  ASSERT_TRUE(ours && gdal);
  ASSERT_EQ(ours->GetRasterBand(1)->GetOverviewCount(), 2);
  ASSERT_EQ(gdal->GetRasterBand(1)->GetOverviewCount(), 2);
  for (int level = 0; level <= 2; ++level) {
    const std::vector<float> a = read_level<float>(*ours, level), b = read_level<float>(*gdal, level);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << "level " << level;
  }
}

// An average that comes out as the nodata value becomes the float next to it, as in GDAL's
// overviews (4 and 6 average to 5, the nodata value here).
TEST(CogAssembly, AverageEqualToNodataIsReplaced) {
  gdal_init();
  ScratchDir dir;
  const GridSpec grid = utm_grid(512, 2, 10.0);
  Raster<float> cells(grid, 0.0f);
  for (int64_t row = 0; row < 2; ++row)
    for (int64_t col = 0; col < 512; ++col) cells.at(col, row) = col % 2 == 0 ? 4.0f : 6.0f;
  GeoTiffOptions o;
  o.cloud_optimized = true;
  write_geotiff(dir.file("five.tif"), cells, 5.0, o);
  const auto ours = open(dir.file("five.tif"));
  const auto gdal = gdal_cog(dir.file("gdal.tif"), cells.data(), GDT_Float32, 512, 2, 5.0, true);
  ASSERT_TRUE(ours && gdal);
  const std::vector<float> a = read_level<float>(*ours, 1), b = read_level<float>(*gdal, 1);
  ASSERT_EQ(a.size(), 256u);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a[0], std::nextafter(5.0f, FLT_MAX));
}

TEST(CogAssembly, EveryCompressionProfile) {
  gdal_init();
  for (const Compression p : {Compression::fast, Compression::small, Compression::deflate, Compression::none}) {
    check_cog<int32_t>({700, 530, 299, p}, 200);
    check_cog<float>({700, 530, -1, p}, 200);
  }
}

// A forced BigTIFF, assembled from a plain GeoTIFF and overviews encoded here: the same cells as
// the classic COG, and GDAL and its validator accept it.
TEST(CogAssembly, BigTiff) {
  gdal_init();
  ScratchDir dir;
  const GridSpec grid = utm_grid(700, 530, 10.0);
  const Raster<float> cells = pattern<float>(grid, true, 7);
  GeoTiffOptions o;
  o.compression = Compression::deflate;
  write_geotiff(dir.file("plain.tif"), cells, -1.0, o);
  o.cloud_optimized = true;
  write_geotiff(dir.file("classic.tif"), cells, -1.0, o);

  detail::TileFormat f;
  f.codec = detail::TileCodec::deflate;
  f.level = 1;
  f.predictor = 3;
  f.sample_bytes = 4;
  f.floating = true;
  detail::TileCompressor encoder(f);
  std::unique_ptr<detail::TileSpool> spool;
  detail::OverviewPyramid<float> pyramid(
      700, 530, 256, detail::Resampling::average, -1.0,
      [&](int level, const float* rows, int64_t, int64_t count, int64_t width) {
        std::vector<float> tile(256 * 256);
        std::vector<uint8_t> out;
        for (int64_t x0 = 0; x0 < width; x0 += 256) {
          std::fill(tile.begin(), tile.end(), -1.0f);
          for (int64_t r = 0; r < count; ++r)
            std::memcpy(tile.data() + r * 256, rows + r * width + x0,
                        static_cast<size_t>(std::min<int64_t>(256, width - x0)) * sizeof(float));
          spool->append(level, encoder.encode(reinterpret_cast<uint8_t*>(tile.data()), out));
        }
      });
  spool = std::make_unique<detail::TileSpool>(dir.file("spool"), pyramid.levels(), "big.tif");
  pyramid.add_rows(cells.data(), 530);
  ASSERT_TRUE(pyramid.complete());
  detail::assemble_cog(dir.file("plain.tif"), *spool, dir.file("big.tif"), "big.tif", true);
  spool.reset();

  const std::string big = file_bytes(dir.file("big.tif"));
  ASSERT_GT(big.size(), 16u);
  EXPECT_EQ(big.substr(0, 4), std::string("II+\0", 4)) << "not a BigTIFF";
  EXPECT_EQ(cog_validator_errors(dir.file("big.tif")), "");
  expect_same_tile_bytes(dir.file("big.tif"), dir.file("plain.tif"));
  const auto a = open(dir.file("big.tif")), b = open(dir.file("classic.tif"));
  ASSERT_TRUE(a && b);
  EXPECT_STREQ(a->GetMetadataItem("LAYOUT", "IMAGE_STRUCTURE"), "COG");
  ASSERT_EQ(a->GetRasterBand(1)->GetOverviewCount(), 2);
  ASSERT_EQ(b->GetRasterBand(1)->GetOverviewCount(), 2);
  for (int level = 0; level <= 2; ++level) EXPECT_EQ(read_level<float>(*a, level), read_level<float>(*b, level));
  double ga[6], gb[6];
  ASSERT_EQ(a->GetGeoTransform(ga), CE_None);
  ASSERT_EQ(b->GetGeoTransform(gb), CE_None);
  EXPECT_EQ(std::vector<double>(ga, ga + 6), std::vector<double>(gb, gb + 6));
  EXPECT_TRUE(a->GetSpatialRef() != nullptr && a->GetSpatialRef()->IsSame(b->GetSpatialRef()));
}

// A staged BigTIFF (what GDAL's BIGTIFF=IF_SAFER makes of a large raster) whose COG fits a classic
// TIFF: its LONG8 tile arrays and values become LONG.
TEST(CogAssembly, StagedBigTiffIntoClassic) {
  gdal_init();
  ScratchDir dir;
  const std::string staged = dir.file("staged.tif");
  {
    CPLStringList co;
    co.SetNameValue("TILED", "YES");
    co.SetNameValue("BIGTIFF", "YES");
    co.SetNameValue("COMPRESS", "DEFLATE");
    GDALDriver* gtiff = GetGDALDriverManager()->GetDriverByName("GTiff");
    std::unique_ptr<GDALDataset> ds(gtiff->Create(staged.c_str(), 200, 100, 1, GDT_Byte, co.List()));
    ASSERT_TRUE(ds);
    std::vector<uint8_t> cells(200 * 100);
    for (size_t i = 0; i < cells.size(); ++i) cells[i] = static_cast<uint8_t>(i * 7 % 251);
    ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, 200, 100, cells.data(), 200, 100, GDT_Byte, 0, 0, nullptr),
              CE_None);
  }
  ASSERT_EQ(file_bytes(staged).substr(0, 4), std::string("II+\0", 4));
  detail::TileSpool spool(dir.file("spool"), {}, "out.tif");
  detail::assemble_cog(staged, spool, dir.file("out.tif"), "out.tif");
  EXPECT_EQ(file_bytes(dir.file("out.tif")).substr(0, 4), std::string("II*\0", 4)) << "not a classic TIFF";
  EXPECT_EQ(cog_validator_errors(dir.file("out.tif")), "");
  expect_same_tile_bytes(dir.file("out.tif"), staged);
  const auto a = open(dir.file("out.tif")), b = open(staged);
  ASSERT_TRUE(a && b);
  EXPECT_STREQ(a->GetMetadataItem("LAYOUT", "IMAGE_STRUCTURE"), "COG");
  EXPECT_EQ(read_level<int32_t>(*a, 0), read_level<int32_t>(*b, 0));
}

// The assembly refuses what is not a staged tiled GeoTIFF or lacks overview tiles, naming the COG.
TEST(CogAssembly, RefusesIncompleteParts) {
  gdal_init();
  ScratchDir dir;
  const GridSpec grid = utm_grid(600, 300, 10.0);
  write_geotiff(dir.file("plain.tif"), Raster<int32_t>(grid, 3), 0.0, {});
  detail::TileSpool spool(dir.file("spool"), detail::overview_sizes(600, 300, 256), "out.tif");
  test::expect_error(ErrorKind::io,
                     [&] { detail::assemble_cog(dir.file("plain.tif"), spool, dir.file("out.tif"), "out.tif"); },
                     {"out.tif", "lacks tiles"});
  std::ofstream(dir.file("text.tif")) << "not a tiff at all";
  test::expect_error(ErrorKind::io,
                     [&] { detail::assemble_cog(dir.file("text.tif"), spool, dir.file("out.tif"), "out.tif"); },
                     {"out.tif", "not a little-endian TIFF"});
  test::expect_error(ErrorKind::io,
                     [&] { detail::assemble_cog(dir.file("none.tif"), spool, dir.file("out.tif"), "out.tif"); },
                     {"out.tif", "cannot open"});
}

// A COG writer leaves nothing but the COG and its sidecar, and nothing at all unless finished.
TEST(CogAssembly, NoStagingFilesLeft) {
  gdal_init();
  ScratchDir dir;
  const GridSpec grid = utm_grid(600, 600, 10.0);
  const Raster<int32_t> cells = pattern<int32_t>(grid, false, 3);
  GeoTiffOptions o;
  o.cloud_optimized = true;
  o.categorical = true;
  o.category_labels = {"x"};
  {
    GeoTiffStripWriter<int32_t> w(dir.file("a.tif"), grid, grid.full_window(), 0.0, o);
    w.write_rows(cells.data(), 300);
    EXPECT_GE(files_in(dir.path()).size(), 2u) << "the staged file and the spool";
  }
  EXPECT_TRUE(files_in(dir.path()).empty());
  {
    GeoTiffStripWriter<int32_t> w(dir.file("b.tif"), grid, grid.full_window(), 0.0, o);
    w.write_rows(cells.data(), 600);
    w.finish();
    EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"b.tif", "b.tif.aux.xml"})) << "before the writer goes";
  }
  EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"b.tif", "b.tif.aux.xml"}));
}

}  // namespace
}  // namespace rv
