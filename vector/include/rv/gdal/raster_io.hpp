// Writing and reading GeoTIFFs through GDAL. GDAL types stay behind this header.
//
// Layout of a written file: one band, tiled 256x256, compressed as GeoTiffOptions::compression
// says (a profile, below), BIGTIFF=IF_SAFER (a COG: BigTIFF when it reaches 4 GiB), compressed by
// `threads` threads. Data type: Float32 for float rasters; Int32 for integer rasters, or the
// narrowest of Byte / UInt16 / Int32 that holds every value when the caller states the largest
// (GeoTiffOptions::max_code). The geotransform is {xmin, res, 0, ymax, 0, -res} of the raster's
// window (Raster::window() inside Raster::grid()), the CRS is GridSpec::crs (any definition OSR
// understands; none written when empty).
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
#include <string_view>
#include <vector>

#include "rv/field/grid.hpp"
#include "rv/field/raster.hpp"

namespace rv {

// How a GeoTIFF is compressed: a few named profiles (the CLI's --compression, the daemon's input
// "compression"). Each profile is one decision of codec, level and predictor per data type, made
// in one place (raster_io.cpp) for the plain GeoTIFF and the COG alike. Every profile is lossless.
// Times and sizes on the 1e8-cell benchmark: bench/RESULTS-encoding.md.
//   fast     (default) integer rasters ZSTD level 1 with the horizontal-differencing predictor (2);
//            Float32 rasters uncompressed: no lossless codec GDAL reads shrinks a distance raster
//            by more than a tenth for less CPU time than the whole computation (ZSTD 1: 11 %;
//            with the floating-point predictor 3: 34 %, at 3x that time; the survey is in
//            bench/RESULTS-encoding.md).
//   small    ZSTD level 6 with predictors 2 (integers) and 3 (Float32): the smallest files worth
//            their time (higher levels shrink them by under 1 %); about 5x fast's encoding time.
//   deflate  DEFLATE level 1 with predictors 2 and 3: for readers whose libtiff lacks ZSTD
//            (libtiff < 4.0.10, GDAL < 2.3, some non-GDAL tools).
//   none     uncompressed: the fastest to write and the largest.
// Where this GDAL's libtiff lacks ZSTD, fast codes take DEFLATE level 1 and small is DEFLATE level
// 6 with predictors 2 and 3.
enum class Compression { fast, small, deflate, none };

std::string_view to_string(Compression c);
// The profile named `name` (exactly one of the names above). Throws rv::Error(invalid_argument)
// naming the accepted profiles for anything else.
Compression parse_compression(std::string_view name);

struct GeoTiffOptions {
  // COG layout (GDAL's: it reports LAYOUT=COG, its validator accepts it) with overviews, nearest
  // for integer and categorical rasters, average (ignoring nodata) for Float32 ones, as GDAL's
  // COG driver makes them; the exact rule is in vector/src/cog_overviews.hpp.
  bool cloud_optimized = false;
  bool categorical = false;  // owner codes: overviews never invent values
  int threads = 0;           // compression threads, 0 = all (one for uncompressed files)
  Compression compression = Compression::fast;
  // Integer rasters only (else invalid_argument): the largest value the caller will write, or -1
  // (default) for an Int32 file holding any value. With 0 <= max_code <= 2^31-1 the file gets the
  // narrowest type that holds [0, max_code]: Byte up to 255, UInt16 up to 65535, Int32 above; every
  // value written and the nodata value must then lie in [0, max_code], else the write throws
  // invalid_argument (nothing is left behind). For owner codes 1..K and feature numbers.
  int64_t max_code = -1;
  std::map<std::string, std::string> metadata;  // band metadata items (e.g. UNITS)
  std::string units;                            // band unit type (e.g. "m", "nmi")
  std::vector<std::string> category_labels;     // value i+1 -> label: written as a raster attribute
                                                // table; integer rasters only (else invalid_argument)
};

// Writes to `path` atomically (a hidden temporary name in the same directory, then rename): a
// reader never sees half a file, and on failure nothing is left behind. Nodata: 0 for integer
// owner codes, -1 for Float32 distances (the engine's kNoDistance), as given by `nodata`.
// The sidecar (when there are category labels) is renamed just before the file.
// Throws rv::Error: io (cannot create, write or rename; the message carries GDAL's reason),
// invalid_argument (empty raster, unparsable CRS, labels or max_code on a Float32 raster, a
// value or the nodata value outside [0, max_code]), too_large (more than 2^31 columns or rows).
void write_geotiff(const std::string& path, const Raster<int32_t>& raster, double nodata,
                   const GeoTiffOptions& options);
void write_geotiff(const std::string& path, const Raster<float>& raster, double nodata, const GeoTiffOptions& options);

// Writes one GeoTIFF, plain or cloud-optimised, strip by strip, top to bottom, for callers that
// never hold the whole raster (the job façade's streaming path). The file is the one
// write_geotiff() writes for the same cells (same layout, georeferencing, nodata, units,
// metadata, categories): write_geotiff() itself goes through this class.
// A COG: the full-resolution tiles go into a plain tiled GeoTIFF staged beside the target (a
// hidden temporary file), the overviews are made from the same rows as they arrive and their
// tiles spooled to a second one; finish() assembles the COG from the encoded tiles as they are
// (no tile is decoded or encoded again) and removes both. Disk: the staging files hold about as
// much as the COG until finish() is done.
//
// Rows go in with write_rows() in order, in strips of any height (1 row .. the whole raster);
// finish() then flushes, closes and renames into place (temporary name in the target's
// directory, sidecar first, as write_geotiff). A writer destroyed or moved-over before finish()
// succeeded, or after any call threw, removes its temporary file and sidecar: nothing is left.
// Memory: strips that end on a 256-row tile boundary are encoded from the caller's buffer;
// otherwise one band of 256 rows x window.width cells is buffered. Besides: up to 24 encoded
// tiles and one raw tile per encoding thread (at most 16 threads); for a COG, the overviews' rows
// in the making, under one more band of 256 rows x window.width cells for all levels together
// (and the tiles' places, 16 bytes a tile).
// Thread safety: none inside; a writer may be used from different threads one after the other
// (every call installs its own GDAL error capture), ordered by the caller (e.g. a queue).
// T: int32_t or float.
template <class T>
class GeoTiffStripWriter {
 public:
  // Creates the temporary file for a raster covering `window` of `grid`, describes it (CRS,
  // geotransform, nodata, units, metadata; the categories on a thread of the writer's own that
  // the first write_rows() starts, so it runs at that caller's scheduling priority, joined by
  // finish() or the destructor). Throws rv::Error like write_geotiff (finish() throws what the
  // categories' thread met).
  GeoTiffStripWriter(const std::string& path, const GridSpec& grid, const Window& window, double nodata,
                     const GeoTiffOptions& options);
  ~GeoTiffStripWriter();
  GeoTiffStripWriter(GeoTiffStripWriter&&) noexcept;
  GeoTiffStripWriter& operator=(GeoTiffStripWriter&&) noexcept;
  GeoTiffStripWriter(const GeoTiffStripWriter&) = delete;
  GeoTiffStripWriter& operator=(const GeoTiffStripWriter&) = delete;

  // Appends `rows` whole rows below those already written: rows * window.width values,
  // row-major, no padding. The caller's buffer is free again when the call returns. Throws
  // invalid_argument (more rows than the raster has left, or after finish(), or a value outside
  // [0, options.max_code]: the writer has then failed, see above), io.
  void write_rows(const T* cells, int64_t rows);
  // Rows accepted so far.
  int64_t rows_written() const;

  // Tiles already encoded: the edits of a finished job copy the tiles no edit touched from the
  // earlier job's file instead of encoding them again. take_tiles_from() opens `earlier`, a
  // GeoTIFF this class wrote for the same cells (extent, cell size) with the same layout (data
  // type, tile size, compression, predictor); else invalid_argument, and the writer is unchanged.
  // write_band() then appends one band of tiles -- the next 256 rows, or the rows left -- at a
  // band's start (no partial band pending; else invalid_argument): from `cells` (the band's rows,
  // as write_rows takes them) where copy[bx] is false, and as the earlier file's bytes of the same
  // tile, unchanged, where it is true (those cells of `cells` are not read). One flag per tile
  // across (ceil(width / 256)). The file is the one write_rows() would write from the same cells
  // where the copied tiles hold the earlier file's cells. A COG's overviews are made from the
  // band's cells, the copied tiles' decoded from the earlier file (`earlier` may itself be a COG
  // this class wrote: its full resolution is copied). Throws as write_rows, and io where the
  // earlier file's tile cannot be read.
  // `checksums`, when not empty, are checksum64 of the earlier file's full-resolution tiles as it
  // was written (row-major, its tile_checksums()): each copied tile is checked against its own,
  // and one that differs throws invalid_input ("<display> was modified since it was written ...",
  // `display` the caller's name for the earlier file; the writer has then failed).
  // `remap`, when not empty (integer rasters only, else invalid_argument): the earlier file holds
  // other codes for the same things; each copied tile is decoded, every value v becomes remap[v]
  // (a value outside remap or mapped to a negative one throws invalid_input), and the tile is
  // encoded again (the earlier file's data type may then differ).
  void take_tiles_from(const std::string& earlier, std::vector<uint64_t> checksums = {},
                       const std::string& display = "", std::vector<int32_t> remap = {});
  void write_band(const T* cells, const std::vector<bool>& copy);
  // checksum64 (rv/field/checksum.hpp) of every full-resolution tile's bytes as stored, row-major over
  // the tiles (ceil(width / 256) across): of the tiles appended so far, 0 for those to come. Once
  // every row is written they are the file's (a COG keeps its full-resolution tiles' bytes).
  const std::vector<uint64_t>& tile_checksums() const;
  // Every row written: flush, close (a COG: assemble), rename into place. Throws invalid_argument
  // when rows are missing, io when GDAL, a file or the rename fails (nothing is left behind then).
  void finish();
  // Gives up: removes the temporary file now (what the destructor does). No-op after finish().
  void abort() noexcept;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

extern template class GeoTiffStripWriter<int32_t>;
extern template class GeoTiffStripWriter<float>;

// GDAL's block cache holds what GDAL reads and writes through it (the rasters the jobs read back:
// regions are polygonized from the ownership file); by default it may grow to 5 % of physical
// memory. The programs bound it (not the library, which leaves an embedding application's GDAL
// settings alone): bound_block_cache() lowers it to kBlockCacheBytes unless the user set
// GDAL_CACHEMAX. Call before GDAL reads anything.
inline constexpr int64_t kBlockCacheBytes = int64_t{256} << 20;
void bound_block_cache();

// Reads a GeoTIFF's grid (extent, cell size, CRS as WKT2), for --like. Throws rv::Error(not_found,
// invalid_input for rotated, south-up or non-square-cell rasters, or a file that is not a raster).
GridSpec read_grid(const std::string& path);

// Reads band 1 back (tests and validation), converted to the requested type by GDAL (so
// read_int32 reads Byte, UInt16 and Int32 code rasters alike). The result's grid is
// read_grid(path) and its window the whole grid.
Raster<int32_t> read_int32(const std::string& path);
Raster<float> read_float32(const std::string& path);

// Band 1 of a GeoTIFF read in whole rows, a window at a time (the base field of an edit, strip by
// strip), converted to T by GDAL. Keeps the file open from construction on: a file renamed over
// or removed meanwhile is still read as it was when opened (POSIX). Throws rv::Error(not_found,
// invalid_input as read_grid; io where GDAL fails to read).
// Thread safety: none inside; one reader per thread.
template <class T>
class GeoTiffRowReader {
 public:
  explicit GeoTiffRowReader(const std::string& path);
  ~GeoTiffRowReader();
  GeoTiffRowReader(GeoTiffRowReader&&) noexcept;
  GeoTiffRowReader& operator=(GeoTiffRowReader&&) noexcept;
  const GridSpec& grid() const;
  // Rows [row0, row0 + rows) into `out` (rows * width values, row-major).
  void read_rows(int64_t row0, int64_t rows, T* out);
  // The cells [col0, col0 + cols) x [row0, row0 + rows) into `out`, whose rows are `stride`
  // values apart (stride >= cols).
  void read_window(int64_t col0, int64_t row0, int64_t cols, int64_t rows, T* out, int64_t stride);
  // checksum64 of tile (bx, by)'s bytes as stored in the file (not decoded): what
  // GeoTiffStripWriter::tile_checksums() recorded when it wrote the file. Throws rv::Error(io) for
  // a file that is not tiled or a tile that cannot be read.
  uint64_t tile_checksum(int64_t bx, int64_t by);
  // Throws rv::Error(invalid_input) when tile (bx, by)'s stored bytes differ from `checksum`, with
  // the message the strip writer gives a copied tile that differs ("<display> was modified since
  // it was written (the tile of rows ..., columns ...)"); io as tile_checksum.
  void check_tile(int64_t bx, int64_t by, uint64_t checksum, const std::string& display);

 private:
  struct State;
  std::unique_ptr<State> st_;
};

extern template class GeoTiffRowReader<int32_t>;
extern template class GeoTiffRowReader<float>;

// The category labels of band 1: label of value v at index v-1, from the raster attribute table
// (columns Value and Owner) or, without one, the band's category names (index 0 = value 0 is
// skipped). Empty when the file has neither.
std::vector<std::string> read_category_labels(const std::string& path);

}  // namespace rv
