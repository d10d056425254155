// The GeoTIFF writer's own tile encoding (vector/src/writing/tiff_tiles.hpp): every profile and file
// type decoded by libtiff (through GDAL: its inverse predictors and codecs are the oracle) back
// to the cells written, bit for bit; the file independent of the thread count; GDAL's virtual
// files; the layout check. test_raster_io checks each profile's tags and sizes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <cpl_string.h>
#include <cpl_vsi.h>
#include <gdal_priv.h>

#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "vector_test_util.hpp"
#include "writing/tiff_tiles.hpp"

namespace rv {
namespace {

using test::expect_error;
using test::ScratchDir;

GridSpec grid_of(int64_t w, int64_t h) { return test::utm_grid(w, h, 25.0, 32, 500000.0, 6200000.0); }

std::unique_ptr<GDALDataset> open(const std::string& path) {
  return std::unique_ptr<GDALDataset>(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
}

// Band 1's cells as raw bytes in the file's own type: equal bytes mean equal values, NaN payloads
// and the sign of zero included.
std::vector<uint8_t> raw_cells(const std::string& path) {
  const auto ds = open(path);
  EXPECT_TRUE(ds) << path;
  if (!ds) return {};
  GDALRasterBand* b = ds->GetRasterBand(1);
  const GDALDataType t = b->GetRasterDataType();
  std::vector<uint8_t> out(static_cast<size_t>(ds->GetRasterXSize()) * ds->GetRasterYSize() *
                           GDALGetDataTypeSizeBytes(t));
  EXPECT_EQ(b->RasterIO(GF_Read, 0, 0, ds->GetRasterXSize(), ds->GetRasterYSize(), out.data(), ds->GetRasterXSize(),
                        ds->GetRasterYSize(), t, 0, 0),
            CE_None);
  return out;
}

std::vector<char> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Codes with long runs, the type's extremes, and steps that wrap the predictor's differences.
Raster<int32_t> codes_for(const GridSpec& grid, int64_t max_code) {
  Raster<int32_t> r(grid, 0);
  const bool any = max_code < 0;
  const int64_t top = any ? INT32_MAX : max_code;
  for (int64_t row = 0; row < grid.height; ++row)
    for (int64_t col = 0; col < grid.width; ++col) {
      int64_t v = (col / 37 + 11 * (row / 23)) % (top + 1);
      if ((col + row) % 17 == 0) v = top;  // top next to small values: wrapping differences
      if ((col * 3 + row) % 29 == 0) v = 0;
      int32_t code = static_cast<int32_t>(v);
      if (any && (col + 2 * row) % 13 == 0) code = (col % 2 == 0) ? INT32_MIN : -static_cast<int32_t>(col + 1);
      r.at(col, row) = code;
    }
  return r;
}

// Distances with the values a float predictor must carry through: -0, denormals, infinities,
// NaN, the nodata value, and a smooth field in between.
Raster<float> distances_for(const GridSpec& grid) {
  Raster<float> r(grid, 0.0f);
  const float specials[] = {-0.0f,
                            std::numeric_limits<float>::denorm_min(),
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity(),
                            std::numeric_limits<float>::quiet_NaN(),
                            std::numeric_limits<float>::max(),
                            -1.0f};
  for (int64_t row = 0; row < grid.height; ++row)
    for (int64_t col = 0; col < grid.width; ++col) {
      const int64_t k = col * 31 + row * 7;
      r.at(col, row) =
          k % 53 == 0 ? specials[(k / 53) % 7] : static_cast<float>(std::hypot(col - 140.25, row - 77.5) * 25.0);
    }
  return r;
}

// Every tile of `path` decoded by TileDecompressor equals GDAL's block of it, byte for byte.
// Returns the tiles compared.
int decoded_like_gdal(const std::string& path) {
  detail::RawTileFile raw(path, detail::TileFormat{}, path, detail::RawTileFile::Access::raw);
  const detail::StoredTiles& stored = raw.stored();
  EXPECT_TRUE(stored.decodable) << path;
  if (!stored.decodable) return 0;
  const auto ds = open(path);
  GDALRasterBand* band = ds->GetRasterBand(1);
  int bx = 0, by = 0;
  band->GetBlockSize(&bx, &by);
  EXPECT_EQ(bx, stored.format.width);
  EXPECT_EQ(by, stored.format.height);
  const size_t bytes = static_cast<size_t>(bx) * by * stored.format.sample_bytes;
  EXPECT_EQ(static_cast<int>(bytes / (static_cast<size_t>(bx) * by)),
            GDALGetDataTypeSizeBytes(band->GetRasterDataType()));
  detail::TileDecompressor decoder(stored.format);
  std::vector<uint8_t> buf, ours(bytes), theirs(bytes);
  int tiles = 0;
  for (int64_t ty = 0; ty * by < ds->GetRasterYSize(); ++ty)
    for (int64_t tx = 0; tx < raw.tiles_across(); ++tx) {
      decoder.decode(raw.read(tx, ty, buf), ours.data());
      EXPECT_EQ(band->ReadBlock(static_cast<int>(tx), static_cast<int>(ty), theirs.data()), CE_None);
      // The cells inside the image (what an edit takes; GDAL may fill an edge tile's outside).
      const int64_t rows = std::min<int64_t>(by, ds->GetRasterYSize() - ty * by);
      const int64_t cols = std::min<int64_t>(bx, ds->GetRasterXSize() - tx * bx);
      const auto row_bytes = static_cast<size_t>(bx) * stored.format.sample_bytes;
      for (int64_t r = 0; r < rows; ++r)
        EXPECT_EQ(std::memcmp(ours.data() + r * row_bytes, theirs.data() + r * row_bytes,
                              static_cast<size_t>(cols) * stored.format.sample_bytes),
                  0)
            << path << " tile " << tx << ", " << ty << " row " << r;
      ++tiles;
    }
  return tiles;
}

TEST(TiffTiles, EveryProfileAndTypeDecodesBitForBit) {
  gdal_init();
  ScratchDir dir;
  // Neither side a multiple of the tile size: edge tiles in both directions, 2 x 2 tiles.
  const GridSpec grid = grid_of(300, 290);
  const Raster<float> dist = distances_for(grid);
  for (const Compression c : {Compression::fast, Compression::small, Compression::deflate, Compression::none}) {
    for (const int64_t max_code : {int64_t{200}, int64_t{60000}, int64_t{-1}}) {
      const std::string tag = std::string(to_string(c)) + "_" + std::to_string(max_code);
      SCOPED_TRACE(tag);
      GeoTiffOptions o;
      o.compression = c;
      o.max_code = max_code;
      const Raster<int32_t> codes = codes_for(grid, max_code);
      const std::string ours = dir.file("i_" + tag + ".tif");
      write_geotiff(ours, codes, 0.0, o);
      EXPECT_EQ(read_int32(ours).cells(), codes.cells());
      EXPECT_EQ(decoded_like_gdal(ours), 4);  // and by the edits' own decoder
    }
    const std::string tag(to_string(c));
    SCOPED_TRACE(tag);
    GeoTiffOptions o;
    o.compression = c;
    const std::string ours = dir.file("f_" + tag + ".tif");
    write_geotiff(ours, dist, -1.0, o);
    const std::vector<uint8_t> cells = raw_cells(ours);
    ASSERT_EQ(cells.size(), dist.cells().size() * sizeof(float));
    EXPECT_EQ(std::memcmp(cells.data(), dist.cells().data(), cells.size()), 0);
    EXPECT_EQ(decoded_like_gdal(ours), 4);
  }
}

// The decoder an edit recodes its base's tiles with (tiff_tiles.hpp) on files GDAL (libtiff's
// encoder) wrote, as GDAL decodes them (the files written here: the test above); a damaged tile is
// an error, not garbage.
TEST(TiffTiles, TheDecoderReadsGdalsTilesAndRefusesDamagedOnes) {
  gdal_init();
  ScratchDir dir;
  const GridSpec grid = grid_of(300, 290);
  const Raster<float> dist = distances_for(grid);
  // Written by GDAL's own encoders (libtiff): ZSTD and DEFLATE, each predictor.
  GDALDriver* gtiff = GetGDALDriverManager()->GetDriverByName("GTiff");
  struct Case {
    const char* compress;
    const char* predictor;
    GDALDataType type;
  } cases[] = {{"ZSTD", "2", GDT_UInt16},  {"DEFLATE", "2", GDT_Int32},   {"ZSTD", "1", GDT_Byte},
               {"ZSTD", "3", GDT_Float32}, {"DEFLATE", "3", GDT_Float32}, {"NONE", "1", GDT_Int16}};
  for (const Case& k : cases) {
    const std::string path = dir.file(std::string("g_") + k.compress + k.predictor + ".tif");
    CPLStringList options;
    options.SetNameValue("TILED", "YES");
    options.SetNameValue("BLOCKXSIZE", "256");
    options.SetNameValue("BLOCKYSIZE", "256");
    options.SetNameValue("COMPRESS", k.compress);
    if (std::string(k.compress) != "NONE") options.SetNameValue("PREDICTOR", k.predictor);
    {
      std::unique_ptr<GDALDataset> ds(gtiff->Create(path.c_str(), 300, 290, 1, k.type, options.List()));
      ASSERT_TRUE(ds);
      const Raster<int32_t> codes = codes_for(grid, k.type == GDT_Byte ? 200 : k.type == GDT_UInt16 ? 60000 : 30000);
      if (k.type == GDT_Float32)
        ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, 300, 290, const_cast<float*>(dist.cells().data()), 300,
                                                 290, GDT_Float32, 0, 0),
                  CE_None);
      else
        ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, 300, 290, const_cast<int32_t*>(codes.cells().data()),
                                                 300, 290, GDT_Int32, 0, 0),
                  CE_None);
    }
    SCOPED_TRACE(path);
    EXPECT_EQ(decoded_like_gdal(path), 4);
  }
  // A damaged tile: cut short, or other bytes.
  const std::string path = dir.file("damaged.tif");
  GeoTiffOptions o;
  o.compression = Compression::fast;
  write_geotiff(path, codes_for(grid, -1), 0.0, o);
  detail::RawTileFile raw(path, detail::TileFormat{}, path, detail::RawTileFile::Access::raw);
  std::vector<uint8_t> buf;
  const detail::EncodedTile t = raw.read(0, 0, buf);
  std::vector<uint8_t> out(static_cast<size_t>(256 * 256 * raw.stored().format.sample_bytes));
  detail::TileDecompressor decoder(raw.stored().format);
  expect_error(ErrorKind::io, [&] { decoder.decode({t.data, t.size / 2}, out.data()); }, {"does not decode"});
  std::vector<uint8_t> junk(t.size, 0x5a);
  expect_error(ErrorKind::io, [&] { decoder.decode({junk.data(), junk.size()}, out.data()); }, {"does not decode"});
}

TEST(TiffTiles, TheFileDoesNotDependOnTheThreadCount) {
  ScratchDir dir;
  // Ten tiles across: several chunks per band, and bands of 256 and of 44 rows.
  const GridSpec grid = grid_of(2500, 300);
  const Raster<float> dist = distances_for(grid);
  const Raster<int32_t> codes = codes_for(grid, 60000);
  std::vector<char> first_i, first_f;
  for (const int threads : {1, 2, 3, 8}) {
    SCOPED_TRACE(threads);
    GeoTiffOptions o;
    o.threads = threads;
    GeoTiffOptions oi = o;
    oi.max_code = 60000;
    const std::string i = dir.file("i" + std::to_string(threads) + ".tif");
    const std::string f = dir.file("f" + std::to_string(threads) + ".tif");
    write_geotiff(i, codes, 0.0, oi);
    write_geotiff(f, dist, -1.0, o);
    if (first_i.empty()) {
      first_i = file_bytes(i);
      first_f = file_bytes(f);
      EXPECT_EQ(read_int32(i).cells(), codes.cells());
      continue;
    }
    EXPECT_TRUE(file_bytes(i) == first_i);
    EXPECT_TRUE(file_bytes(f) == first_f);
  }
}

TEST(TiffTiles, GdalsVirtualFilesAreWrittenToo) {
  gdal_init();
  const GridSpec grid = grid_of(270, 260);
  const Raster<int32_t> codes = codes_for(grid, 255);
  GeoTiffOptions o;
  o.max_code = 255;
  o.category_labels = {"a", "b"};
  const std::string path = "/vsimem/rv_tiff_tiles_test/owners.tif";
  VSIMkdir("/vsimem/rv_tiff_tiles_test", 0755);
  write_geotiff(path, codes, 0.0, o);
  EXPECT_EQ(read_int32(path).cells(), codes.cells());
  EXPECT_EQ(read_category_labels(path), o.category_labels);
  VSIRmdirRecursive("/vsimem/rv_tiff_tiles_test");
}

TEST(TiffTiles, AFileLaidOutOtherwiseIsRefused) {
  gdal_init();
  ScratchDir dir;
  GDALDriver* gtiff = GetGDALDriverManager()->GetDriverByName("GTiff");
  const auto make = [&](const std::string& name, const char* compress, const char* block, GDALDataType type) {
    CPLStringList co;
    co.SetNameValue("TILED", "YES");
    co.SetNameValue("BLOCKXSIZE", block);
    co.SetNameValue("BLOCKYSIZE", block);
    co.SetNameValue("COMPRESS", compress);
    co.SetNameValue("SPARSE_OK", "TRUE");
    std::unique_ptr<GDALDataset> ds(gtiff->Create(dir.file(name).c_str(), 300, 300, 1, type, co.List()));
    EXPECT_TRUE(ds);
    return dir.file(name);
  };
  detail::TileFormat zstd16;
  zstd16.codec = detail::TileCodec::zstd;
  zstd16.level = 1;
  zstd16.sample_bytes = 2;
  // The layout it was made for opens; another codec, tile size, type or predictor is refused.
  { detail::RawTileFile ok(make("ok.tif", "ZSTD", "256", GDT_UInt16), zstd16, "ok.tif"); }
  for (const auto& [name, path] :
       std::vector<std::pair<std::string, std::string>>{{"deflate", make("d.tif", "DEFLATE", "256", GDT_UInt16)},
                                                        {"tiles", make("t.tif", "ZSTD", "128", GDT_UInt16)},
                                                        {"type", make("y.tif", "ZSTD", "256", GDT_Int32)},
                                                        {"float", make("f.tif", "ZSTD", "256", GDT_Float32)}}) {
    SCOPED_TRACE(name);
    // (An init-capture: clang 14 cannot capture a structured binding.)
    expect_error(ErrorKind::io, [&, file = path] { detail::RawTileFile bad(file, zstd16, "shown.tif"); },
                 {"shown.tif", "layout"});
  }
  detail::TileFormat predicted = zstd16;
  predicted.predictor = 2;
  expect_error(ErrorKind::io, [&] { detail::RawTileFile bad(dir.file("ok.tif"), predicted, "p.tif"); }, {"layout"});
  expect_error(ErrorKind::io, [&] { detail::RawTileFile bad(dir.file("none.tif"), zstd16, "none.tif"); }, {"none.tif"});
}

}  // namespace
}  // namespace rv
