// Internal to rv_vector: opening a GeoTIFF (any raster GDAL reads) for its cells and grid, and
// the GDAL type of the cell types the rasters are read and written in.
#pragma once

#include <cstdint>
#include <string>

#include <gdal_priv.h>

#include "common/gdal_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/grid.hpp"

namespace rv::detail {

template <class T>
struct PixelType;
template <>
struct PixelType<int32_t> {
  static constexpr GDALDataType gdal = GDT_Int32;
  static constexpr bool floating = false;
};
template <>
struct PixelType<float> {
  static constexpr GDALDataType gdal = GDT_Float32;
  static constexpr bool floating = true;
};

struct OpenedRaster {
  gdal::DatasetPtr ds;
  GridSpec grid;
};

// The error of a tile whose stored bytes differ from the checksum its writer recorded: tile
// (bx, by) of 256 x 256 cells of an image `width` x `height`, `display` the caller's name for it.
Error modified_tile(const std::string& display, int64_t bx, int64_t by, int64_t width, int64_t height);

// Opens `path` read-only. Throws rv::Error: not_found, invalid_input (not a raster GDAL reads, no
// band, no geotransform, rotated, south-up or non-square cells). `with_sidecar` false: the PAM
// sidecar (.aux.xml) is not read, for callers that need only what the file itself holds (its
// size, geotransform and CRS): a categorical raster's sidecar names every category, and parsing
// one of 50,000 owners takes a fifth of a second.
OpenedRaster open_raster(const std::string& path, bool with_sidecar = true);

}  // namespace rv::detail
