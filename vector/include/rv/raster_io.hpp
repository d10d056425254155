// Writing and reading GeoTIFFs through GDAL. GDAL types stay behind this header.
// Thread safety: functions may run concurrently on different files.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "rv/grid.hpp"
#include "rv/raster.hpp"

namespace rv {

struct GeoTiffOptions {
  bool cloud_optimized = false;  // COG layout with overviews (nearest/mode for categorical bands)
  bool categorical = false;      // owner codes: overviews never invent values
  int threads = 0;               // compression threads, 0 = all
  std::map<std::string, std::string> metadata;  // band metadata items (e.g. UNITS)
  std::string units;             // band unit type (e.g. "m", "nmi")
  std::vector<std::string> category_labels;     // value i+1 -> label: written as a raster attribute table
};

// Writes to `path` atomically (a temporary name in the same directory, then rename): a reader
// never sees half a file, and on failure nothing is left behind. Nodata: 0 for Int32 owner
// codes, -1 for Float32 distances (the engine's kNoDistance), as given by `nodata`.
void write_geotiff(const std::string& path, const Raster<int32_t>& raster, double nodata,
                   const GeoTiffOptions& options);
void write_geotiff(const std::string& path, const Raster<float>& raster, double nodata,
                   const GeoTiffOptions& options);

// Reads a GeoTIFF's grid (extent, cell size, CRS), for --like. Throws rv::Error(not_found,
// invalid_input for rotated or non-square-cell rasters).
GridSpec read_grid(const std::string& path);

// Reads band 1 back (tests and validation).
Raster<int32_t> read_int32(const std::string& path);
Raster<float> read_float32(const std::string& path);

}  // namespace rv
