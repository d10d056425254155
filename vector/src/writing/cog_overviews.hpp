// The overview levels of a COG, built from the full-resolution rows as they arrive (internal to
// rv_vector): GeoTiffStripWriter feeds them the rows it encodes, a band at a time, and encodes the
// bands of overview rows they hand back like the full resolution's (cog_assembly.hpp spools and
// assembles them).
//
// Levels (GDAL 3.6's COG driver makes the same ones for the same size): level 1 is
// floor(W / 2) x floor(H / 2) cells of a W x H raster, each further level floor() halves the one
// before (a side never below 1 cell), and levels are added while the last one is wider or taller
// than one tile. A raster that fits in one tile has none.
//
// Each level is made from the level before it (level 1 from the full resolution), as GDAL's
// overview builder does it, and takes the same cells and arithmetic, so that the overviews equal
// the ones GDAL's COG driver (OVERVIEW_RESAMPLING NEAREST / AVERAGE) made from the same cells
// (tests/vector/writing/test_cog_assembly.cpp compares them). With s = (source size) / (level size) per
// axis, a double (exactly 2 where the source size is even, up to 3 where it is odd, 1 where a
// side of one cell stays one cell):
//   nearest  cell (i, j) takes source cell (int(0.5 + i * s_x), int(0.5 + j * s_y)): the top-left
//            cell of its block while s is 2; on an odd source the picks drift by one cell to the
//            right (bottom) across the row (column), and the source's last column (row) may not
//            be picked at all.
//   average  cell i spans source columns [i * s_x, (i + 1) * s_x): whole columns count with weight
//            1, the partly covered first and last with the part covered (x0 = int(i * s_x + 1e-8),
//            x1 = ceil((i + 1) * s_x - 1e-8), at least x0 + 1, at most the source width; weight of
//            x0 = 1 - (i * s_x - x0) unless x1 = x0 + 1, then 1; of x1 - 1 = 1 - (x1 - (i + 1) *
//            s_x)); rows likewise. The cell is sum(w_x w_y v) / sum(w_x w_y) over the source cells
//            that are not nodata (GDAL's nodata test: v == nodata or |v - nodata| < 2 FLT_EPSILON
//            |v + nodata|, so a value a few float steps from nodata counts as nodata; NaN nodata:
//            v is NaN), summed in double row by row (left to right, then weighted by the row's
//            weight), rounded to float; a cell with no such source cell is nodata, and an average
//            that happens to equal nodata becomes the float next to it (towards +infinity; towards
//            0 from FLT_MAX), as GDAL does. While s is 2 this is the plain mean of the valid cells
//            of the 2 x 2 block. The right and bottom edges of an odd source are covered by the
//            last cells' windows (s > 2), never dropped.
// Nearest suits codes (it never invents one); average is for Float32 rasters only.
//
// Memory: per level, one band of `band_rows` rows of its width (the tile row being filled) and
// the few source rows a row of it reads (up to 4); over all levels less than one band of the full
// resolution's width. Not thread-safe; one per file.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace rv::detail {

enum class Resampling { nearest, average };

struct LevelSize {
  int64_t width = 0;
  int64_t height = 0;
};

// The overview levels of a width x height raster with square tiles of `tile` cells (see above),
// largest first.
std::vector<LevelSize> overview_sizes(int64_t width, int64_t height, int64_t tile);

// T: int32_t (nearest only) or float.
template <class T>
class OverviewPyramid {
 public:
  // Receives one band of finished rows of overview `level` (0 = the largest): `count` rows of
  // `width` cells, row-major, from row `first_row` of the level; `count` is band_rows except in
  // the level's last band. Bands of one level come in order. The rows are valid during the call.
  // What it throws propagates out of add_rows().
  using BandSink = std::function<void(int level, const T* rows, int64_t first_row, int64_t count, int64_t width)>;

  // For a full-resolution raster of width x height cells with tiles of `band_rows` rows and
  // columns. `nodata` matters to average only. Throws rv::Error(invalid_argument) for average on
  // integer cells.
  OverviewPyramid(int64_t width, int64_t height, int64_t band_rows, Resampling resampling, double nodata,
                  BandSink sink);
  ~OverviewPyramid();
  OverviewPyramid(const OverviewPyramid&) = delete;
  OverviewPyramid& operator=(const OverviewPyramid&) = delete;

  // The levels' sizes (overview_sizes()).
  const std::vector<LevelSize>& levels() const { return sizes_; }
  // The next `count` full-resolution rows (count * width cells, row-major); every level's rows
  // that they complete go to the sink, a band at a time. Throws rv::Error(invalid_argument) past
  // the raster's last row.
  void add_rows(const T* rows, int64_t count);
  // True once every row of every level went to the sink.
  bool complete() const;

 private:
  struct Level;
  void feed(size_t level, const T* row, int64_t index);

  int64_t width_, height_, band_rows_;
  int64_t rows_in_ = 0;
  std::vector<LevelSize> sizes_;
  std::vector<std::unique_ptr<Level>> levels_;
  BandSink sink_;
};

extern template class OverviewPyramid<int32_t>;
extern template class OverviewPyramid<float>;

}  // namespace rv::detail
