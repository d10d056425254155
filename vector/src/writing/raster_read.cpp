// Reading GeoTIFFs through GDAL: grids, whole bands, windows, tiles' stored bytes. See
// rv/gdal/raster_io.hpp for the contract.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <exception>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <cpl_string.h>
#include <gdal_rat.h>

#include "common/gdal_util.hpp"
#include "rv/field/checksum.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/raster_io.hpp"
#include "writing/raster_open.hpp"
#include "writing/tiff_tiles.hpp"

namespace rv {
namespace detail {

Error modified_tile(const std::string& display, int64_t bx, int64_t by, int64_t width, int64_t height) {
  constexpr int64_t kTile = 256;
  return Error(ErrorKind::invalid_input,
               display + " was modified since it was written (the tile of rows " + std::to_string(by * kTile) + "-" +
                   std::to_string(std::min(height, (by + 1) * kTile) - 1) + ", columns " + std::to_string(bx * kTile) +
                   "-" + std::to_string(std::min(width, (bx + 1) * kTile) - 1) + ")");
}

OpenedRaster open_raster(const std::string& path, bool with_sidecar) {
  gdal_init();
  if (!gdal::path_exists(path)) throw Error(ErrorKind::not_found, "raster not found: " + path);
  gdal::ErrorCapture capture;
  OpenedRaster r;
  std::optional<gdal::ThreadConfigOption> pam;
  if (!with_sidecar) pam.emplace("GDAL_PAM_ENABLED", "NO");
  r.ds.reset(
      GDALDataset::FromHandle(GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
  if (!r.ds) throw Error(ErrorKind::invalid_input, path + ": not a raster GDAL can read" + capture.suffix());
  if (r.ds->GetRasterCount() < 1) throw Error(ErrorKind::invalid_input, path + ": the raster has no bands");
  double gt[6];
  if (r.ds->GetGeoTransform(gt) != CE_None)
    throw Error(ErrorKind::invalid_input, path + ": the raster has no geotransform");
  if (gt[2] != 0.0 || gt[4] != 0.0) throw Error(ErrorKind::invalid_input, path + ": rotated rasters are not supported");
  if (!(gt[1] > 0.0) || !(gt[5] < 0.0))
    throw Error(ErrorKind::invalid_input,
                path + ": only north-up rasters (positive x step, negative y step) are supported");
  if (std::abs(gt[1] + gt[5]) > 1e-9 * gt[1])
    throw Error(ErrorKind::invalid_input,
                path + ": cells are not square (" + std::to_string(gt[1]) + " x " + std::to_string(-gt[5]) + ")");
  r.grid.xmin = gt[0];
  r.grid.ymax = gt[3];
  r.grid.res = gt[1];
  r.grid.width = r.ds->GetRasterXSize();
  r.grid.height = r.ds->GetRasterYSize();
  if (const OGRSpatialReference* srs = r.ds->GetSpatialRef()) r.grid.crs = gdal::to_wkt2(*srs);
  return r;
}

}  // namespace detail

using detail::open_raster;
using detail::OpenedRaster;
using detail::PixelType;

namespace {

template <class T>
Raster<T> read_band(const std::string& path) {
  OpenedRaster r = open_raster(path);
  gdal::ErrorCapture capture;
  Raster<T> out(r.grid, r.grid.full_window(), Uninitialized{});
  if (r.ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, static_cast<int>(r.grid.width), static_cast<int>(r.grid.height),
                                       out.data(), static_cast<int>(r.grid.width), static_cast<int>(r.grid.height),
                                       PixelType<T>::gdal, 0, 0, nullptr) != CE_None)
    throw Error(ErrorKind::io, "reading " + path + " failed" + capture.suffix());
  return out;
}

}  // namespace

template <class T>
struct GeoTiffRowReader<T>::State {
  OpenedRaster raster;
  std::string path;
  // The tiles' bytes (tile_checksum), opened with the raster so that both read the same file; a
  // file libtiff cannot read raw fails only when a checksum is asked for.
  std::unique_ptr<detail::RawTileFile> raw;
  std::exception_ptr raw_error;
  std::vector<uint8_t> tile;
};

template <class T>
GeoTiffRowReader<T>::GeoTiffRowReader(const std::string& path)
    : st_(std::make_unique<State>(State{open_raster(path), path, nullptr, nullptr, {}})) {
  try {
    st_->raw =
        std::make_unique<detail::RawTileFile>(path, detail::TileFormat{}, path, detail::RawTileFile::Access::raw);
  } catch (const Error&) {
    st_->raw_error = std::current_exception();
  }
}
template <class T>
GeoTiffRowReader<T>::~GeoTiffRowReader() = default;
template <class T>
GeoTiffRowReader<T>::GeoTiffRowReader(GeoTiffRowReader&&) noexcept = default;
template <class T>
GeoTiffRowReader<T>& GeoTiffRowReader<T>::operator=(GeoTiffRowReader&&) noexcept = default;
template <class T>
const GridSpec& GeoTiffRowReader<T>::grid() const {
  return st_->raster.grid;
}

template <class T>
void GeoTiffRowReader<T>::read_rows(int64_t row0, int64_t rows, T* out) {
  const GridSpec& g = st_->raster.grid;
  if (row0 < 0 || rows < 0 || row0 + rows > g.height)
    throw Error(ErrorKind::invalid_argument, st_->path + ": rows beyond the raster");
  if (rows == 0) return;
  gdal::ErrorCapture capture;
  if (st_->raster.ds->GetRasterBand(1)->RasterIO(GF_Read, 0, static_cast<int>(row0), static_cast<int>(g.width),
                                                 static_cast<int>(rows), out, static_cast<int>(g.width),
                                                 static_cast<int>(rows), PixelType<T>::gdal, 0, 0, nullptr) != CE_None)
    throw Error(ErrorKind::io, "reading " + st_->path + " failed" + capture.suffix());
}

template <class T>
void GeoTiffRowReader<T>::read_window(int64_t col0, int64_t row0, int64_t cols, int64_t rows, T* out, int64_t stride) {
  const GridSpec& g = st_->raster.grid;
  if (col0 < 0 || row0 < 0 || cols < 0 || rows < 0 || col0 + cols > g.width || row0 + rows > g.height || stride < cols)
    throw Error(ErrorKind::invalid_argument, st_->path + ": a window beyond the raster");
  if (rows == 0 || cols == 0) return;
  gdal::ErrorCapture capture;
  const auto cell = static_cast<GSpacing>(sizeof(T));
  if (st_->raster.ds->GetRasterBand(1)->RasterIO(
          GF_Read, static_cast<int>(col0), static_cast<int>(row0), static_cast<int>(cols), static_cast<int>(rows), out,
          static_cast<int>(cols), static_cast<int>(rows), PixelType<T>::gdal, cell, cell * stride, nullptr) != CE_None)
    throw Error(ErrorKind::io, "reading " + st_->path + " failed" + capture.suffix());
}

template <class T>
uint64_t GeoTiffRowReader<T>::tile_checksum(int64_t bx, int64_t by) {
  if (!st_->raw) std::rethrow_exception(st_->raw_error);
  const detail::EncodedTile t = st_->raw->read(bx, by, st_->tile);
  return checksum64(t.data, t.size);
}

template <class T>
void GeoTiffRowReader<T>::check_tile(int64_t bx, int64_t by, uint64_t checksum, const std::string& display) {
  if (tile_checksum(bx, by) != checksum)
    throw detail::modified_tile(display, bx, by, st_->raster.grid.width, st_->raster.grid.height);
}

template class GeoTiffRowReader<int32_t>;
template class GeoTiffRowReader<float>;

GridSpec read_grid(const std::string& path) { return open_raster(path).grid; }

Raster<int32_t> read_int32(const std::string& path) { return read_band<int32_t>(path); }

Raster<float> read_float32(const std::string& path) { return read_band<float>(path); }

std::vector<std::string> read_category_labels(const std::string& path) {
  OpenedRaster r = open_raster(path);
  GDALRasterBand* band = r.ds->GetRasterBand(1);
  std::vector<std::string> labels;
  if (GDALRasterAttributeTable* rat = band->GetDefaultRAT()) {
    int value_col = -1, name_col = -1;
    for (int c = 0; c < rat->GetColumnCount(); ++c) {
      if (rat->GetUsageOfCol(c) == GFU_Name || EQUAL(rat->GetNameOfCol(c), "Owner"))
        name_col = name_col < 0 ? c : name_col;
      if (EQUAL(rat->GetNameOfCol(c), "Value")) value_col = c;
    }
    if (value_col >= 0 && name_col >= 0) {
      for (int row = 0; row < rat->GetRowCount(); ++row) {
        const int value = rat->GetValueAsInt(row, value_col);
        if (value < 1 || value > 1'000'000'000) continue;
        if (static_cast<size_t>(value) > labels.size()) labels.resize(static_cast<size_t>(value));
        labels[static_cast<size_t>(value - 1)] = rat->GetValueAsString(row, name_col);
      }
      return labels;
    }
  }
  if (char** names = band->GetCategoryNames()) {
    for (int i = 1; names[0] != nullptr && names[i] != nullptr; ++i) labels.emplace_back(names[i]);
  }
  return labels;
}

}  // namespace rv
