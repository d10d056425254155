// GeoTIFF writing and reading: round trips checked through GDAL by content (size, geotransform,
// CRS, nodata, values, layout, raster attribute table), COG overviews, atomic writes.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <thread>

#include <gdal_priv.h>
#include <gdal_rat.h>
#include <ogr_spatialref.h>

#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "vector_test_util.hpp"

namespace rv {
namespace {

using test::expect_error;
using test::ScratchDir;
using test::utm_grid;

std::vector<std::string> files_in(const std::filesystem::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

std::unique_ptr<GDALDataset> open(const std::string& path) {
  return std::unique_ptr<GDALDataset>(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
}

bool same_crs(const std::string& a, const std::string& b) {
  OGRSpatialReference x, y;
  if (x.SetFromUserInput(a.c_str()) != OGRERR_NONE || y.SetFromUserInput(b.c_str()) != OGRERR_NONE) return false;
  return x.IsSame(&y) != 0;
}

TEST(RasterIo, Int32RoundTripWithCategories) {
  gdal_init();
  ScratchDir dir;
  // A window of a larger grid: the file must be georeferenced as the window.
  const GridSpec grid = utm_grid(1000, 800);
  const Window window{300, 100, 517, 389};  // not a multiple of the 256 tile size
  Raster<int32_t> r(grid, window, 0);
  for (int64_t row = 0; row < r.height(); ++row)
    for (int64_t col = 0; col < r.width(); ++col) r.at(col, row) = static_cast<int32_t>((col / 40 + row / 30) % 4);
  GeoTiffOptions o;
  o.categorical = true;
  o.threads = 2;
  o.units = "owner";
  o.metadata = {{"SOURCE", "rvoronoi test"}};
  o.category_labels = {"DK", "SE", "NO"};
  const std::string path = dir.file("owners.tif");
  write_geotiff(path, r, 0.0, o);
  EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"owners.tif", "owners.tif.aux.xml"}));

  const GridSpec back = read_grid(path);
  EXPECT_EQ(back.width, 517);
  EXPECT_EQ(back.height, 389);
  EXPECT_DOUBLE_EQ(back.res, 200.0);
  EXPECT_DOUBLE_EQ(back.xmin, 300000.0 + 300 * 200.0);
  EXPECT_DOUBLE_EQ(back.ymax, 6250000.0 - 100 * 200.0);
  EXPECT_TRUE(same_crs(back.crs, grid.crs));
  const Raster<int32_t> values = read_int32(path);
  EXPECT_EQ(values.cells(), r.cells());
  EXPECT_EQ(read_category_labels(path), o.category_labels);

  // Through GDAL directly.
  auto ds = open(path);
  ASSERT_TRUE(ds);
  GDALRasterBand* band = ds->GetRasterBand(1);
  EXPECT_EQ(band->GetRasterDataType(), GDT_Int32);
  int has_nodata = 0;
  EXPECT_EQ(band->GetNoDataValue(&has_nodata), 0.0);
  EXPECT_TRUE(has_nodata);
  int bx = 0, by = 0;
  band->GetBlockSize(&bx, &by);
  EXPECT_EQ(bx, 256);
  EXPECT_EQ(by, 256);
  const std::string compression = ds->GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE");
  EXPECT_TRUE(compression == "ZSTD" || compression == "DEFLATE") << compression;
  EXPECT_STREQ(ds->GetMetadataItem("PREDICTOR", "IMAGE_STRUCTURE"), "2");
  EXPECT_STREQ(band->GetUnitType(), "owner");
  EXPECT_STREQ(band->GetMetadataItem("SOURCE"), "rvoronoi test");
  GDALRasterAttributeTable* rat = band->GetDefaultRAT();
  ASSERT_NE(rat, nullptr);
  ASSERT_EQ(rat->GetColumnCount(), 2);
  EXPECT_STREQ(rat->GetNameOfCol(0), "Value");
  EXPECT_STREQ(rat->GetNameOfCol(1), "Owner");
  ASSERT_EQ(rat->GetRowCount(), 3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(rat->GetValueAsInt(i, 0), i + 1);
    EXPECT_EQ(std::string(rat->GetValueAsString(i, 1)), o.category_labels[static_cast<size_t>(i)]);
  }
  char** names = band->GetCategoryNames();
  ASSERT_NE(names, nullptr);
  EXPECT_STREQ(names[2], "SE");
  double gt[6];
  ASSERT_EQ(ds->GetGeoTransform(gt), CE_None);
  EXPECT_DOUBLE_EQ(gt[0], back.xmin);
  EXPECT_DOUBLE_EQ(gt[1], 200.0);
  EXPECT_EQ(gt[2], 0.0);
  EXPECT_DOUBLE_EQ(gt[3], back.ymax);
  EXPECT_EQ(gt[4], 0.0);
  EXPECT_DOUBLE_EQ(gt[5], -200.0);
}

TEST(RasterIo, Float32RoundTrip) {
  ScratchDir dir;
  const GridSpec grid = utm_grid(300, 260, 50.0);
  Raster<float> r(grid, -1.0f);
  for (int64_t row = 0; row < r.height(); ++row)
    for (int64_t col = 0; col < r.width(); ++col)
      if ((col + row) % 7 != 0) r.at(col, row) = static_cast<float>(std::hypot(col * 50.0, row * 50.0) * 1.0001);
  GeoTiffOptions o;
  o.units = "m";
  const std::string path = dir.file("distance.tif");
  write_geotiff(path, r, -1.0, o);
  EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"distance.tif"}));  // no labels: no sidecar
  const Raster<float> back = read_float32(path);
  EXPECT_EQ(back.cells(), r.cells());
  EXPECT_EQ(back.grid().width, 300);
  EXPECT_TRUE(same_crs(back.grid().crs, grid.crs));
  auto ds = open(path);
  int has_nodata = 0;
  EXPECT_EQ(ds->GetRasterBand(1)->GetNoDataValue(&has_nodata), -1.0);
  EXPECT_TRUE(has_nodata);
  EXPECT_EQ(ds->GetRasterBand(1)->GetRasterDataType(), GDT_Float32);
  // The default profile (fast) leaves the floating-point predictor out.
  EXPECT_EQ(ds->GetMetadataItem("PREDICTOR", "IMAGE_STRUCTURE"), nullptr);
  EXPECT_STREQ(ds->GetRasterBand(1)->GetUnitType(), "m");
  EXPECT_TRUE(read_category_labels(path).empty());
}

TEST(RasterIo, CloudOptimizedWithOverviews) {
  ScratchDir dir;
  const GridSpec grid = utm_grid(1500, 1100, 100.0);
  Raster<int32_t> owners(grid, 0);
  Raster<float> distance(grid, -1.0f);
  for (int64_t row = 0; row < owners.height(); ++row)
    for (int64_t col = 0; col < owners.width(); ++col) {
      owners.at(col, row) = static_cast<int32_t>(1 + (col * 3 / owners.width()) + 3 * ((row / 97) % 2));  // 1..6
      distance.at(col, row) = static_cast<float>((col % 100) * 10.0);
    }
  GeoTiffOptions o;
  o.cloud_optimized = true;
  o.categorical = true;
  o.category_labels = {"a", "b", "c", "d", "e", "f"};
  write_geotiff(dir.file("owners_cog.tif"), owners, 0.0, o);
  GeoTiffOptions of;
  of.cloud_optimized = true;
  of.units = "m";
  of.metadata = {{"METHOD", "exact"}};
  write_geotiff(dir.file("distance_cog.tif"), distance, -1.0, of);
  EXPECT_EQ(files_in(dir.path()),
            (std::vector<std::string>{"distance_cog.tif", "owners_cog.tif", "owners_cog.tif.aux.xml"}));

  EXPECT_EQ(read_int32(dir.file("owners_cog.tif")).cells(), owners.cells());
  EXPECT_EQ(read_float32(dir.file("distance_cog.tif")).cells(), distance.cells());
  EXPECT_EQ(read_category_labels(dir.file("owners_cog.tif")), o.category_labels);
  auto ds = open(dir.file("owners_cog.tif"));
  ASSERT_TRUE(ds);
  EXPECT_STREQ(ds->GetMetadataItem("LAYOUT", "IMAGE_STRUCTURE"), "COG");
  GDALRasterBand* band = ds->GetRasterBand(1);
  ASSERT_GE(band->GetOverviewCount(), 1);
  // Nearest resampling: every overview value is an owner code of the full resolution.
  GDALRasterBand* ov = band->GetOverview(0);
  std::vector<int32_t> ov_values(static_cast<size_t>(ov->GetXSize()) * ov->GetYSize());
  ASSERT_EQ(ov->RasterIO(GF_Read, 0, 0, ov->GetXSize(), ov->GetYSize(), ov_values.data(), ov->GetXSize(),
                         ov->GetYSize(), GDT_Int32, 0, 0, nullptr),
            CE_None);
  const std::set<int32_t> codes(ov_values.begin(), ov_values.end());
  for (int32_t c : codes) EXPECT_TRUE(c >= 1 && c <= 6) << c;
  auto dd = open(dir.file("distance_cog.tif"));
  EXPECT_STREQ(dd->GetMetadataItem("LAYOUT", "IMAGE_STRUCTURE"), "COG");
  EXPECT_GE(dd->GetRasterBand(1)->GetOverviewCount(), 1);
  EXPECT_STREQ(dd->GetRasterBand(1)->GetUnitType(), "m");
  EXPECT_STREQ(dd->GetRasterBand(1)->GetMetadataItem("METHOD"), "exact");
  int has_nodata = 0;
  EXPECT_EQ(dd->GetRasterBand(1)->GetNoDataValue(&has_nodata), -1.0);
  EXPECT_TRUE(has_nodata);
  double gt[6];
  ASSERT_EQ(dd->GetGeoTransform(gt), CE_None);
  EXPECT_DOUBLE_EQ(gt[0], grid.xmin);
  EXPECT_DOUBLE_EQ(gt[3], grid.ymax);
  EXPECT_TRUE(same_crs(read_grid(dir.file("distance_cog.tif")).crs, grid.crs));
}

TEST(RasterIo, FailedWritesLeaveNothingBehind) {
  ScratchDir dir;
  const GridSpec grid = utm_grid(64, 64);
  Raster<int32_t> r(grid, 1);
  GeoTiffOptions o;
  o.category_labels = {"x"};
  expect_error(ErrorKind::io, [&] { write_geotiff(dir.file("no/such/dir/out.tif"), r, 0.0, o); }, {"no/such/dir"});
  EXPECT_TRUE(files_in(dir.path()).empty());
  // The target name is taken by a directory: everything is written, the final rename fails, and
  // the temporary file and its sidecar are removed.
  std::filesystem::create_directory(dir.path() / "taken.tif");
  std::filesystem::create_directory(dir.path() / "taken.tif" / "keep");
  expect_error(ErrorKind::io, [&] { write_geotiff(dir.file("taken.tif"), r, 0.0, o); }, {"taken.tif"});
  GeoTiffOptions cog = o;
  cog.cloud_optimized = true;
  expect_error(ErrorKind::io, [&] { write_geotiff(dir.file("taken.tif"), r, 0.0, cog); }, {"taken.tif"});
  EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"taken.tif"}));
  // Labels on a float raster are refused before anything is written.
  expect_error(ErrorKind::invalid_argument,
               [&] { write_geotiff(dir.file("f.tif"), Raster<float>(grid, 0.0f), -1.0, o); });
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "f.tif"));
}

TEST(RasterIo, OverwriteReplacesFileAndStaleSidecar) {
  ScratchDir dir;
  const GridSpec grid = utm_grid(40, 30);
  GeoTiffOptions labelled;
  labelled.category_labels = {"A", "B"};
  const std::string path = dir.file("o.tif");
  write_geotiff(path, Raster<int32_t>(grid, 2), 0.0, labelled);
  EXPECT_EQ(read_category_labels(path), labelled.category_labels);
  write_geotiff(path, Raster<int32_t>(grid, 7), 0.0, {});
  EXPECT_EQ(read_int32(path).at(5, 5), 7);
  EXPECT_TRUE(read_category_labels(path).empty());
  EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"o.tif"}));
}

TEST(RasterIo, ConcurrentWritesToDifferentFiles) {
  ScratchDir dir;
  const GridSpec grid = utm_grid(700, 500);
  std::vector<Raster<int32_t>> rasters;
  for (int i = 0; i < 4; ++i) {
    Raster<int32_t> r(grid, 0);
    for (int64_t row = 0; row < r.height(); ++row)
      for (int64_t col = 0; col < r.width(); ++col) r.at(col, row) = static_cast<int32_t>((col * (i + 1) + row) % 9);
    rasters.push_back(std::move(r));
  }
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i)
    threads.emplace_back([&, i] {
      GeoTiffOptions o;
      o.threads = 1;
      o.cloud_optimized = i % 2 == 1;
      o.category_labels = {"l" + std::to_string(i)};
      write_geotiff(dir.file("c" + std::to_string(i) + ".tif"), rasters[static_cast<size_t>(i)], 0.0, o);
    });
  for (auto& t : threads) t.join();
  for (int i = 0; i < 4; ++i) {
    const std::string path = dir.file("c" + std::to_string(i) + ".tif");
    EXPECT_EQ(read_int32(path).cells(), rasters[static_cast<size_t>(i)].cells()) << i;
    EXPECT_EQ(read_category_labels(path), (std::vector<std::string>{"l" + std::to_string(i)})) << i;
  }
  EXPECT_EQ(files_in(dir.path()).size(), 8u);  // four files, four sidecars, no temporaries
}

TEST(RasterIo, StripWriterEqualsWholeWrite) {
  gdal_init();
  ScratchDir dir;
  // A window of a larger grid, neither side a multiple of the 256 tile size.
  const GridSpec grid = utm_grid(900, 1000);
  const Window window{37, 11, 601, 700};
  Raster<int32_t> codes(grid, window, 0);
  Raster<float> dist(grid, window, 0.0f);
  for (int64_t row = 0; row < codes.height(); ++row)
    for (int64_t col = 0; col < codes.width(); ++col) {
      codes.at(col, row) = static_cast<int32_t>((col / 50 + row / 70) % 3);
      dist.at(col, row) = (col + row) % 97 == 0 ? -1.0f : static_cast<float>(col * 0.25 + row * 1.5);
    }
  GeoTiffOptions labelled;
  labelled.category_labels = {"A", "B"};
  labelled.metadata["CONTENT"] = "owner";
  GeoTiffOptions units;
  units.units = "km";
  units.metadata["UNITS"] = "km";
  write_geotiff(dir.file("whole_i.tif"), codes, 0.0, labelled);
  write_geotiff(dir.file("whole_f.tif"), dist, -1.0, units);
  // 1 row, completing a buffered tile row, a whole tile row passed through plus a rest, the rest.
  const std::vector<int64_t> strips{1, 255, 300, 7};
  GeoTiffStripWriter<int32_t> wi(dir.file("strip_i.tif"), grid, window, 0.0, labelled);
  GeoTiffStripWriter<float> wf(dir.file("strip_f.tif"), grid, window, -1.0, units);
  int64_t row = 0;
  for (const int64_t n : strips) {
    wi.write_rows(codes.row(row), n);
    wf.write_rows(dist.row(row), n);
    row += n;
  }
  wi.write_rows(codes.row(row), codes.height() - row);
  wf.write_rows(dist.row(row), dist.height() - row);
  EXPECT_EQ(wi.rows_written(), codes.height());
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "strip_i.tif")) << "visible before finish()";
  wi.finish();
  wf.finish();
  EXPECT_EQ(read_int32(dir.file("strip_i.tif")).cells(), read_int32(dir.file("whole_i.tif")).cells());
  EXPECT_EQ(read_float32(dir.file("strip_f.tif")).cells(), read_float32(dir.file("whole_f.tif")).cells());
  EXPECT_EQ(read_grid(dir.file("strip_i.tif")), read_grid(dir.file("whole_i.tif")));
  EXPECT_EQ(read_category_labels(dir.file("strip_i.tif")), labelled.category_labels);
  const auto ds = open(dir.file("strip_f.tif"));
  EXPECT_STREQ(ds->GetRasterBand(1)->GetUnitType(), "km");
  EXPECT_STREQ(ds->GetRasterBand(1)->GetMetadataItem("UNITS"), "km");
  EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"strip_f.tif", "strip_i.tif", "strip_i.tif.aux.xml",
                                                            "whole_f.tif", "whole_i.tif", "whole_i.tif.aux.xml"}));
}

template <class T>
Raster<T> read_raster(const std::string& path) {
  if constexpr (std::is_same_v<T, float>)
    return read_float32(path);
  else
    return read_int32(path);
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// An earlier file's tiles copied into a new one (the edits of a finished job): the copied tiles
// hold the earlier file's cells whatever the caller passes for them, the others the new cells;
// copying every tile of unchanged cells gives the very bytes of the earlier file.
template <class T>
void check_copied_tiles(const GeoTiffOptions& options, double nodata) {
  ScratchDir dir;
  const GridSpec grid = utm_grid(700, 600);  // 3 x 3 tiles, the last ones partial
  Raster<T> earlier(grid, T{0}), changed(grid, T{0});
  for (int64_t r = 0; r < 600; ++r)
    for (int64_t c = 0; c < 700; ++c) {
      earlier.at(c, r) = static_cast<T>((c / 40 + 3 * (r / 30)) % 7 + 1);
      const bool edited = (c / 256 == 1 && r / 256 == 1) || (c / 256 == 2 && r / 256 == 2);
      changed.at(c, r) = edited ? static_cast<T>((c + r) % 5 + 1) : earlier.at(c, r);
    }
  write_geotiff(dir.file("earlier.tif"), earlier, nodata, options);
  auto copy_flags = [](int64_t by, auto&& keep) {
    std::vector<bool> flags(3);
    for (int64_t bx = 0; bx < 3; ++bx) flags[static_cast<size_t>(bx)] = keep(bx, by);
    return flags;
  };
  auto unedited = [](int64_t bx, int64_t by) { return !((bx == 1 && by == 1) || (bx == 2 && by == 2)); };
  // The new cells; every tile no edit touched is copied.
  {
    GeoTiffStripWriter<T> w(dir.file("new.tif"), grid, grid.full_window(), nodata, options);
    w.take_tiles_from(dir.file("earlier.tif"));
    for (int64_t by = 0; by < 3; ++by) w.write_band(changed.row(by * 256), copy_flags(by, unedited));
    w.finish();
  }
  EXPECT_EQ(read_raster<T>(dir.file("new.tif")).cells(), changed.cells());
  // The copied tiles' cells are not read: spoiled here, they still hold the earlier cells.
  Raster<T> spoiled = changed;
  for (int64_t r = 0; r < 600; ++r)
    for (int64_t c = 0; c < 700; ++c)
      if (unedited(c / 256, r / 256)) spoiled.at(c, r) = T{3};
  {
    GeoTiffStripWriter<T> w(dir.file("spoiled.tif"), grid, grid.full_window(), nodata, options);
    w.take_tiles_from(dir.file("earlier.tif"));
    for (int64_t by = 0; by < 3; ++by) w.write_band(spoiled.row(by * 256), copy_flags(by, unedited));
    w.finish();
  }
  EXPECT_EQ(read_raster<T>(dir.file("spoiled.tif")).cells(), changed.cells());
  // Everything copied, mixed with write_rows: the earlier file, byte for byte.
  {
    GeoTiffStripWriter<T> w(dir.file("same.tif"), grid, grid.full_window(), nodata, options);
    w.take_tiles_from(dir.file("earlier.tif"));
    w.write_band(earlier.row(0), copy_flags(0, [](int64_t, int64_t) { return true; }));
    w.write_rows(earlier.row(256), 256);
    w.write_band(earlier.row(512), copy_flags(2, [](int64_t bx, int64_t) { return bx != 1; }));
    w.finish();
  }
  EXPECT_EQ(file_bytes(dir.file("same.tif")), file_bytes(dir.file("earlier.tif")));
  // Checksums: the writer's of each tile are those a reader finds in the file, and a copied tile
  // whose bytes differ from its checksum is refused (the earlier file modified since).
  std::vector<uint64_t> sums;
  {
    GeoTiffStripWriter<T> w(dir.file("sums.tif"), grid, grid.full_window(), nodata, options);
    w.write_rows(earlier.row(0), 600);
    w.finish();
    sums = w.tile_checksums();
  }
  ASSERT_EQ(sums.size(), 9u);
  {
    GeoTiffRowReader<T> r(dir.file("earlier.tif"));
    for (int64_t k = 0; k < 9; ++k) EXPECT_EQ(r.tile_checksum(k % 3, k / 3), sums[static_cast<size_t>(k)]) << k;
    EXPECT_NE(sums[0], sums[4]);
    // A window read with a stride: the cells of the earlier raster.
    std::vector<T> window(static_cast<size_t>(50 * 10), T{0});
    r.read_window(600, 590, 40, 10, window.data(), 50);
    for (int64_t y = 0; y < 10; ++y)
      for (int64_t x = 0; x < 40; ++x)
        EXPECT_EQ(window[static_cast<size_t>(y * 50 + x)], earlier.at(600 + x, 590 + y)) << x << "," << y;
    expect_error(ErrorKind::invalid_argument, [&] { r.read_window(690, 0, 20, 1, window.data(), 50); }, {"beyond"});
  }
  {
    GeoTiffStripWriter<T> w(dir.file("checked.tif"), grid, grid.full_window(), nodata, options);
    w.take_tiles_from(dir.file("earlier.tif"), sums, "the earlier file");
    w.write_band(earlier.row(0), copy_flags(0, [](int64_t, int64_t) { return true; }));
    std::vector<uint64_t> wrong = sums;
    wrong[4] ^= 1;
    GeoTiffStripWriter<T> v(dir.file("wrong.tif"), grid, grid.full_window(), nodata, options);
    v.take_tiles_from(dir.file("earlier.tif"), wrong, "the earlier file");
    v.write_band(earlier.row(0), copy_flags(0, [](int64_t, int64_t) { return true; }));
    expect_error(ErrorKind::invalid_input,
                 [&] { v.write_band(earlier.row(256), copy_flags(1, [](int64_t, int64_t) { return true; })); },
                 {"the earlier file was modified since it was written", "rows 256-511, columns 256-511"});
    w.write_band(earlier.row(256), copy_flags(1, [](int64_t, int64_t) { return true; }));
    w.write_band(earlier.row(512), copy_flags(2, [](int64_t, int64_t) { return true; }));
    w.finish();
    EXPECT_EQ(w.tile_checksums(), sums);
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("wrong.tif")));
  // Refused: another layout, other cells, a band not at a tile row, flags of another count.
  GeoTiffOptions other = options;
  // (A codec of another name: ZSTD levels share their tags, and a tile of either decodes alike.)
  other.compression = options.compression == Compression::deflate ? Compression::none : Compression::deflate;
  write_geotiff(dir.file("other_layout.tif"), earlier, nodata, other);
  const GridSpec shifted = utm_grid(700, 600, 200.0, 33, 300200.0);
  write_geotiff(dir.file("other_cells.tif"), Raster<T>(shifted, T{1}), nodata, options);
  GeoTiffStripWriter<T> w(dir.file("refused.tif"), grid, grid.full_window(), nodata, options);
  expect_error(ErrorKind::invalid_argument, [&] { w.write_band(earlier.row(0), std::vector<bool>(3)); },
               {"no earlier file"});
  expect_error(ErrorKind::invalid_argument, [&] { w.take_tiles_from(dir.file("other_layout.tif")); },
               {"other_layout.tif", "layout"});
  expect_error(ErrorKind::invalid_argument, [&] { w.take_tiles_from(dir.file("other_cells.tif")); },
               {"other_cells.tif", "other cells"});
  w.take_tiles_from(dir.file("earlier.tif"));
  expect_error(ErrorKind::invalid_argument, [&] { w.write_band(earlier.row(0), std::vector<bool>(4)); },
               {"one copy flag per tile"});
  w.write_rows(earlier.row(0), 10);
  expect_error(ErrorKind::invalid_argument, [&] { w.write_band(earlier.row(10), std::vector<bool>(3)); }, {"tile row"});
}

TEST(RasterIo, StripWriterCopiesTheEncodedTilesOfAnEarlierFile) {
  gdal_init();
  GeoTiffOptions codes;
  codes.max_code = 9;  // a Byte file
  check_copied_tiles<int32_t>(codes, 0.0);
  codes.compression = Compression::small;
  check_copied_tiles<int32_t>(codes, 0.0);
  codes.cloud_optimized = true;  // copied from a COG into a COG
  check_copied_tiles<int32_t>(codes, 0.0);
  GeoTiffOptions distances;
  check_copied_tiles<float>(distances, -1.0);  // uncompressed
  distances.compression = Compression::deflate;
  check_copied_tiles<float>(distances, -1.0);
}

TEST(RasterIo, StripWriterLeavesNothingUnlessFinished) {
  ScratchDir dir;
  const GridSpec grid = utm_grid(300, 300);
  const Raster<int32_t> r(grid, 3);
  GeoTiffOptions labelled;
  labelled.category_labels = {"x"};
  {
    GeoTiffStripWriter<int32_t> w(dir.file("a.tif"), grid, grid.full_window(), 0.0, labelled);
    w.write_rows(r.data(), 260);                 // one tile row encoded, four rows pending
    EXPECT_FALSE(files_in(dir.path()).empty());  // the temporary file
  }
  EXPECT_TRUE(files_in(dir.path()).empty()) << "destroyed unfinished";
  {
    GeoTiffStripWriter<int32_t> w(dir.file("b.tif"), grid, grid.full_window(), 0.0, labelled);
    w.write_rows(r.data(), 299);
    expect_error(ErrorKind::invalid_argument, [&] { w.finish(); }, {"299 of 300 rows"});
    expect_error(ErrorKind::invalid_argument, [&] { w.write_rows(r.data(), 2); }, {"more rows"});
    w.abort();
    EXPECT_TRUE(files_in(dir.path()).empty()) << "aborted";
    w.abort();  // twice is harmless
  }
  // A COG strip by strip (it used to be refused): its staging files go with it unless finished.
  GeoTiffOptions cog = labelled;
  cog.cloud_optimized = true;
  {
    GeoTiffStripWriter<int32_t> w(dir.file("c.tif"), grid, grid.full_window(), 0.0, cog);
    w.write_rows(r.data(), 260);
    EXPECT_FALSE(files_in(dir.path()).empty());  // the staged tiles, the overviews' spool
  }
  EXPECT_TRUE(files_in(dir.path()).empty()) << "COG destroyed unfinished";
  {
    GeoTiffStripWriter<int32_t> w(dir.file("c.tif"), grid, grid.full_window(), 0.0, cog);
    w.write_rows(r.data(), 300);
    w.finish();
  }
  EXPECT_EQ(read_int32(dir.file("c.tif")).cells(), r.cells());
  EXPECT_EQ(files_in(dir.path()), (std::vector<std::string>{"c.tif", "c.tif.aux.xml"}));
  std::filesystem::remove(dir.path() / "c.tif");
  std::filesystem::remove(dir.path() / "c.tif.aux.xml");
  expect_error(ErrorKind::io,
               [&] { GeoTiffStripWriter<int32_t>(dir.file("no/dir/d.tif"), grid, grid.full_window(), 0.0, {}); },
               {"no/dir"});
  EXPECT_TRUE(files_in(dir.path()).empty());
}

// What each compression profile must produce, as GDAL reports it from the file's
// IMAGE_STRUCTURE metadata (nullptr: the item is absent, i.e. no compression / no predictor).
struct ProfileExpectation {
  Compression profile;
  const char* int_codec;
  const char* float_codec;
  const char* int_predictor;
  const char* float_predictor;
};

std::vector<ProfileExpectation> profile_expectations() {
  gdal_init();
  const char* list = GetGDALDriverManager()->GetDriverByName("GTiff")->GetMetadataItem(GDAL_DMD_CREATIONOPTIONLIST);
  const bool zstd = list != nullptr && std::strstr(list, "ZSTD") != nullptr;
  const char* best = zstd ? "ZSTD" : "DEFLATE";
  // fast: codes compressed, Float32 uncompressed.
  return {{Compression::fast, best, nullptr, "2", nullptr},
          {Compression::small, best, best, "2", "3"},
          {Compression::deflate, "DEFLATE", "DEFLATE", "2", "3"},
          {Compression::none, nullptr, nullptr, nullptr, nullptr}};
}

std::string item(GDALDataset& ds, const char* key) {
  const char* v = ds.GetMetadataItem(key, "IMAGE_STRUCTURE");
  return v == nullptr ? "(absent)" : v;
}
std::string text_or_absent(const char* v) { return v == nullptr ? "(absent)" : v; }

TEST(RasterIo, CompressionProfilesSetCodecAndPredictorAndKeepEveryValue) {
  ScratchDir dir;
  // Windows of tiles, partly edge tiles; codes in runs and a smooth distance, like the engine's.
  const GridSpec grid = utm_grid(700, 530, 10.0);
  Raster<int32_t> codes(grid, 0);
  Raster<float> dist(grid, -1.0f);
  for (int64_t row = 0; row < grid.height; ++row)
    for (int64_t col = 0; col < grid.width; ++col) {
      codes.at(col, row) = static_cast<int32_t>((col / 90 + 7 * (row / 60)) % 300);  // needs UInt16
      if ((col * 7 + row * 3) % 101 != 0)
        dist.at(col, row) = static_cast<float>(std::hypot(col - 350.5, row - 260.25) * 10.0);
    }
  std::map<std::string, uintmax_t> float_size;
  for (const ProfileExpectation& e : profile_expectations()) {
    for (const bool cog : {false, true}) {
      const std::string tag = std::string(to_string(e.profile)) + (cog ? "_cog" : "");
      SCOPED_TRACE(tag);
      GeoTiffOptions o;
      o.compression = e.profile;
      o.cloud_optimized = cog;
      GeoTiffOptions oi = o;
      oi.categorical = true;
      oi.max_code = 299;
      const std::string ip = dir.file("i_" + tag + ".tif"), fp = dir.file("f_" + tag + ".tif");
      write_geotiff(ip, codes, 0.0, oi);
      write_geotiff(fp, dist, -1.0, o);
      const auto di = open(ip), df = open(fp);
      ASSERT_TRUE(di && df);
      EXPECT_EQ(item(*di, "COMPRESSION"), text_or_absent(e.int_codec));
      EXPECT_EQ(item(*df, "COMPRESSION"), text_or_absent(e.float_codec));
      EXPECT_EQ(item(*di, "PREDICTOR"), text_or_absent(e.int_predictor));
      EXPECT_EQ(item(*df, "PREDICTOR"), text_or_absent(e.float_predictor));
      EXPECT_EQ(item(*di, "LAYOUT"), cog ? "COG" : "(absent)");
      EXPECT_EQ(di->GetRasterBand(1)->GetRasterDataType(), GDT_UInt16);
      EXPECT_EQ(df->GetRasterBand(1)->GetRasterDataType(), GDT_Float32);
      if (cog) {
        // Overviews are encoded like the full resolution.
        ASSERT_GE(df->GetRasterBand(1)->GetOverviewCount(), 1);
        EXPECT_EQ(di->GetRasterBand(1)->GetOverviewCount(), df->GetRasterBand(1)->GetOverviewCount());
      }
      EXPECT_EQ(read_int32(ip).cells(), codes.cells());
      EXPECT_EQ(read_float32(fp).cells(), dist.cells());
      if (!cog) float_size[tag] = std::filesystem::file_size(fp);
    }
  }
  // The codecs are really applied: uncompressed (none, and fast on Float32) holds every byte, the
  // compressing profiles shrink a smooth Float32 raster.
  EXPECT_GE(float_size["none"], static_cast<uintmax_t>(grid.cell_count() * 4));
  EXPECT_GE(float_size["fast"], static_cast<uintmax_t>(grid.cell_count() * 4));
  EXPECT_LT(float_size["small"], float_size["none"] / 2);
  EXPECT_LT(float_size["deflate"], float_size["none"] / 2);
}

TEST(RasterIo, CompressionProfileNames) {
  for (const Compression c : {Compression::fast, Compression::small, Compression::deflate, Compression::none})
    EXPECT_EQ(parse_compression(to_string(c)), c);
  EXPECT_EQ(to_string(GeoTiffOptions{}.compression), "fast");
  for (const char* bad : {"", "FAST", "zstd", "fast ", "lzw"})
    expect_error(ErrorKind::invalid_argument, [&] { parse_compression(bad); }, {"fast, small, deflate or none"});
}

GDALDataType type_of(const std::string& path) {
  const auto ds = open(path);
  return ds ? ds->GetRasterBand(1)->GetRasterDataType() : GDT_Unknown;
}

TEST(RasterIo, CodeRastersTakeTheNarrowestTypeThatHoldsMaxCode) {
  ScratchDir dir;
  const GridSpec grid = utm_grid(300, 270);
  struct Case {
    int64_t max_code;
    GDALDataType type;
  };
  // Each side of both boundaries, 0 (no owner at all) and no stated range.
  const Case cases[] = {{0, GDT_Byte},      {255, GDT_Byte},        {256, GDT_UInt16}, {65535, GDT_UInt16},
                        {65536, GDT_Int32}, {INT32_MAX, GDT_Int32}, {-1, GDT_Int32}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.max_code);
    // Values spread over [0, max_code], both ends included (any Int32 code without a range).
    Raster<int32_t> r(grid, 0);
    const int64_t top = c.max_code < 0 ? 70000 : c.max_code;
    for (int64_t i = 0; i < grid.cell_count(); ++i)
      r.cells()[static_cast<size_t>(i)] = static_cast<int32_t>(i % 5 == 0 ? 0 : (i * 7919 + i / 1000) % (top + 1));
    r.at(299, 269) = static_cast<int32_t>(top);
    r.at(298, 269) = static_cast<int32_t>(std::max<int64_t>(0, top - 1));
    GeoTiffOptions o;
    o.max_code = c.max_code;
    o.category_labels = {"a"};
    const std::string name = std::to_string(c.max_code);
    write_geotiff(dir.file("w" + name + ".tif"), r, 0.0, o);
    GeoTiffOptions cog = o;
    cog.cloud_optimized = true;
    write_geotiff(dir.file("c" + name + ".tif"), r, 0.0, cog);
    // The strip writer with strips that do and do not end on a tile row.
    GeoTiffStripWriter<int32_t> w(dir.file("s" + name + ".tif"), grid, grid.full_window(), 0.0, o);
    w.write_rows(r.row(0), 100);
    w.write_rows(r.row(100), 170);
    w.finish();
    for (const char* kind : {"w", "c", "s"}) {
      const std::string path = dir.file(kind + name + ".tif");
      EXPECT_EQ(type_of(path), c.type) << path;
      EXPECT_EQ(read_int32(path).cells(), r.cells()) << path;
      EXPECT_EQ(read_category_labels(path), o.category_labels) << path;
    }
  }
}

TEST(RasterIo, CodesOutsideTheStatedRangeAreRefused) {
  ScratchDir dir;
  const GridSpec grid = utm_grid(300, 300);
  for (const int64_t max_code : {int64_t{255}, int64_t{65535}, int64_t{100000}}) {
    SCOPED_TRACE(max_code);
    for (const int32_t wrong : {static_cast<int32_t>(max_code + 1), -1}) {
      Raster<int32_t> r(grid, 1);
      // In the last, partial band of tiles; in the vectorised part of a tile row (column 280 of
      // the tile from 256) or in its remainder (295).
      r.at(wrong < 0 ? 295 : 280, 270) = wrong;
      GeoTiffOptions o;
      o.max_code = max_code;
      o.category_labels = {"x"};
      expect_error(ErrorKind::invalid_argument, [&] { write_geotiff(dir.file("a.tif"), r, 0.0, o); },
                   {"0.." + std::to_string(max_code)});
      GeoTiffOptions cog = o;
      cog.cloud_optimized = true;
      expect_error(ErrorKind::invalid_argument, [&] { write_geotiff(dir.file("b.tif"), r, 0.0, cog); },
                   {"0.." + std::to_string(max_code)});
      {
        GeoTiffStripWriter<int32_t> w(dir.file("c.tif"), grid, grid.full_window(), 0.0, o);
        w.write_rows(r.row(0), 256);
        expect_error(ErrorKind::invalid_argument, [&] { w.write_rows(r.row(256), 44); },
                     {"0.." + std::to_string(max_code)});
        expect_error(ErrorKind::io, [&] { w.finish(); }, {"earlier write failed"});
      }
      EXPECT_TRUE(files_in(dir.path()).empty());
    }
  }
  GeoTiffOptions o;
  o.max_code = 10;
  // The nodata value must be a code of the range; a range on a Float32 raster is a mistake.
  expect_error(ErrorKind::invalid_argument,
               [&] { write_geotiff(dir.file("n.tif"), Raster<int32_t>(grid, 1), 11.0, o); }, {"nodata"});
  expect_error(ErrorKind::invalid_argument,
               [&] { write_geotiff(dir.file("n.tif"), Raster<int32_t>(grid, 1), -1.0, o); }, {"nodata"});
  expect_error(ErrorKind::invalid_argument,
               [&] { write_geotiff(dir.file("f.tif"), Raster<float>(grid, 1.0f), 0.0, o); }, {"integer"});
  o.max_code = int64_t{1} << 31;
  expect_error(ErrorKind::invalid_argument,
               [&] { write_geotiff(dir.file("m.tif"), Raster<int32_t>(grid, 1), 0.0, o); });
  EXPECT_TRUE(files_in(dir.path()).empty());
}

TEST(RasterIo, ReadGridErrors) {
  ScratchDir dir;
  expect_error(ErrorKind::not_found, [&] { read_grid(dir.file("none.tif")); }, {"none.tif"});
  const std::string text = dir.write("t.tif", "not a tiff");
  expect_error(ErrorKind::invalid_input, [&] { read_grid(text); }, {"t.tif"});
  GDALDriver* gtiff = GetGDALDriverManager()->GetDriverByName("GTiff");
  const auto make = [&](const std::string& name, const double gt[6]) {
    std::unique_ptr<GDALDataset> ds(gtiff->Create(dir.file(name).c_str(), 8, 8, 1, GDT_Int32, nullptr));
    ds->SetGeoTransform(const_cast<double*>(gt));
    return dir.file(name);
  };
  const double rotated[6] = {0, 10, 1, 100, 1, -10};
  const double oblong[6] = {0, 10, 0, 100, 0, -20};
  const double south_up[6] = {0, 10, 0, 100, 0, 10};
  expect_error(ErrorKind::invalid_input, [&] { read_grid(make("rot.tif", rotated)); }, {"rotated"});
  expect_error(ErrorKind::invalid_input, [&] { read_grid(make("oblong.tif", oblong)); }, {"square"});
  expect_error(ErrorKind::invalid_input, [&] { read_grid(make("south.tif", south_up)); }, {"north-up"});
}

}  // namespace
}  // namespace rv
