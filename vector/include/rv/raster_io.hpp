// Writing and reading GeoTIFFs through GDAL. GDAL types stay behind this header.
//
// Layout of a written file: one band, tiled 256x256, ZSTD compression (level 3 unless
// compression_level says otherwise (default level 1); DEFLATE where this GDAL lacks ZSTD) with the horizontal predictor (2) for Int32 and the floating-point predictor (3)
// for Float32, BIGTIFF=IF_SAFER, compressed by `threads` threads. The geotransform is
// {xmin, res, 0, ymax, 0, -res} of the raster's window (Raster::window() inside Raster::grid()),
// the CRS is GridSpec::crs (any definition OSR understands; none written when empty).
// Category labels go into a raster attribute table (columns Value: Integer, Owner: String) and
// the band's category names; GDAL 3.6 keeps both in the PAM sidecar `<path>.aux.xml`, written
// and renamed together with the file (a stale sidecar of an earlier file of that name is
// removed). Units and metadata are stored in the TIFF itself.
//
// Thread safety: functions may run concurrently on different files. They call gdal_init().
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "rv/grid.hpp"
#include "rv/raster.hpp"

namespace rv {

struct GeoTiffOptions {
  bool cloud_optimized = false;  // COG layout with overviews (nearest for categorical bands,
                                 // average otherwise), made by the COG driver
  bool categorical = false;      // owner codes: overviews never invent values
  int threads = 0;               // compression threads, 0 = all
  int compression_level = 0;     // 0 = ours: ZSTD 1 (GDAL's default 9 costs ~11x the time for
                                 // ~8% smaller distance rasters), DEFLATE 6; else ZSTD 1..22 /
                                 // DEFLATE 1..12, passed to GDAL as given
  std::map<std::string, std::string> metadata;  // band metadata items (e.g. UNITS)
  std::string units;             // band unit type (e.g. "m", "nmi")
  std::vector<std::string> category_labels;     // value i+1 -> label: written as a raster attribute
                                                // table; Int32 rasters only (else invalid_argument)
};

// Writes to `path` atomically (a hidden temporary name in the same directory, then rename): a
// reader never sees half a file, and on failure nothing is left behind. Nodata: 0 for Int32 owner
// codes, -1 for Float32 distances (the engine's kNoDistance), as given by `nodata`.
// The sidecar (when there are category labels) is renamed just before the file.
// Throws rv::Error: io (cannot create, write or rename; the message carries GDAL's reason),
// invalid_argument (empty raster, unparsable CRS, labels on a Float32 raster),
// too_large (more than 2^31 columns or rows).
void write_geotiff(const std::string& path, const Raster<int32_t>& raster, double nodata,
                   const GeoTiffOptions& options);
void write_geotiff(const std::string& path, const Raster<float>& raster, double nodata,
                   const GeoTiffOptions& options);

// Writes one plain (not cloud-optimised) GeoTIFF strip by strip, top to bottom, for callers
// that never hold the whole raster (the job façade's streaming path). The file is the one
// write_geotiff() writes for the same cells (same layout, georeferencing, nodata, units,
// metadata, categories): write_geotiff() itself goes through this class.
//
// Rows go in with write_rows() in order, in strips of any height (1 row .. the whole raster);
// finish() then flushes, closes and renames into place (temporary name in the target's
// directory, sidecar first, as write_geotiff). A writer destroyed or moved-over before finish()
// succeeded, or after any call threw, removes its temporary file and sidecar: nothing is left.
// Memory: strips that end on a 256-row tile boundary go straight to GDAL's compression queue;
// otherwise one band of 256 rows x window.width cells is buffered.
// Thread safety: none inside; a writer may be used from different threads one after the other
// (every call installs its own GDAL error capture), ordered by the caller (e.g. a queue).
// T: int32_t or float.
template <class T>
class GeoTiffStripWriter {
 public:
  // Creates the temporary file for a raster covering `window` of `grid`, describes it (CRS,
  // geotransform, nodata, units, metadata, categories). Throws rv::Error like write_geotiff;
  // invalid_argument for options.cloud_optimized (a COG needs the whole raster).
  GeoTiffStripWriter(const std::string& path, const GridSpec& grid, const Window& window, double nodata,
                     const GeoTiffOptions& options);
  ~GeoTiffStripWriter();
  GeoTiffStripWriter(GeoTiffStripWriter&&) noexcept;
  GeoTiffStripWriter& operator=(GeoTiffStripWriter&&) noexcept;
  GeoTiffStripWriter(const GeoTiffStripWriter&) = delete;
  GeoTiffStripWriter& operator=(const GeoTiffStripWriter&) = delete;

  // Appends `rows` whole rows below those already written: rows * window.width values,
  // row-major, no padding. The caller's buffer is free again when the call returns. Throws
  // invalid_argument (more rows than the raster has left, or after finish()), io.
  void write_rows(const T* cells, int64_t rows);
  // Rows accepted so far.
  int64_t rows_written() const;
  // Every row written: flush, close, rename into place. Throws invalid_argument when rows are
  // missing, io when GDAL or the rename fails (nothing is left behind then).
  void finish();
  // Gives up: removes the temporary file now (what the destructor does). No-op after finish().
  void abort() noexcept;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

extern template class GeoTiffStripWriter<int32_t>;
extern template class GeoTiffStripWriter<float>;

// Reads a GeoTIFF's grid (extent, cell size, CRS as WKT2), for --like. Throws rv::Error(not_found,
// invalid_input for rotated, south-up or non-square-cell rasters, or a file that is not a raster).
GridSpec read_grid(const std::string& path);

// Reads band 1 back (tests and validation), converted to the requested type by GDAL. The result's
// grid is read_grid(path) and its window the whole grid.
Raster<int32_t> read_int32(const std::string& path);
Raster<float> read_float32(const std::string& path);

// The category labels of band 1: label of value v at index v-1, from the raster attribute table
// (columns Value and Owner) or, without one, the band's category names (index 0 = value 0 is
// skipped). Empty when the file has neither.
std::vector<std::string> read_category_labels(const std::string& path);

}  // namespace rv
