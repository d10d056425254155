// Edges of the plane visibility is decided in, drawn on a window's rows as a scanline fill draws
// polygons (internal to rv_raster): the one drawing the ground (ground_rows.hpp) and the regions
// that points see (site_sight.hpp) are made with.
//
// Edges are put in the window's cell coordinates (u along a row, v down the rows, a cell's centre
// at whole numbers):
// - planar: the grid's local frame (GridSpec::local_x/y) scaled, edges straight;
// - geodesic on a longitude/latitude grid: an edge is the geodesic between its ends' longitudes
//   and latitudes, cut into pieces of equal length along it whose chords, straight in
//   longitude/latitude, lie within kChordTolerance of the geodesic by a bound on a geodesic's
//   bend in longitude/latitude (row_pieces.cpp, geodesic_bend): an edge shorter than a few
//   kilometres is one chord, with no geodesic solved.
// Each piece carries a band (cells): its tolerance, the caller's allowance for the edge, and a
// rounding margin. A row gives its crossings by the counted edges (ring edges: a winding number
// from them) and the cells within some piece's band, which the caller decides exactly.
// Thread safety: add and index from one thread; then row() from any number of threads.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "rv/field/grid.hpp"
#include "rv/field/metric.hpp"
#include "rv/field/seeds.hpp"

namespace GeographicLib {
class Geodesic;
}

namespace rv::sea {

class RowPieces {
 public:
  // A geodesic chord's largest distance from its geodesic, in cells.
  static constexpr double kChordTolerance = 0.01;

  // `geodesic`: edges are given by their ends' longitudes and latitudes on a longitude/latitude
  // grid, else by their ends in the grid's local frame.
  RowPieces(const GridSpec& grid, const Window& window, const MetricSpec& metric, bool geodesic);
  ~RowPieces();
  RowPieces(RowPieces&&) noexcept;
  RowPieces& operator=(RowPieces&&) noexcept;

  // An edge from a to b (local frame, or longitude/latitude). `counted`: its crossings count
  // (a ring's edge, what is inside on its left); else only its band (a line's edge). `band`:
  // cells beyond the pieces' own allowance where the true edge may lie.
  void add_edge(Vec2 a, Vec2 b, bool counted, double band = 0.0);
  // Indexes the pieces by row; add_edge() no more after it.
  void index();

  struct Crossing {
    double u;
    int north;  // +1: the edge heads north (v falling) there; -1: south
  };
  // Row r (0 <= r < window.height), over the cells [c0, c1): the counted pieces' crossings
  // anywhere on the row, sorted by u, and the cells of [c0, c1) within some piece's band, as
  // closed intervals, sorted and merged.
  void row(int64_t r, int64_t c0, int64_t c1, std::vector<Crossing>& crossings,
           std::vector<std::pair<int64_t, int64_t>>& bands) const;
  int64_t piece_count() const { return static_cast<int64_t>(pieces_.size()); }

 private:
  struct Piece {
    double u1, v1, u2, v2;
    double band;
    int8_t north;  // a counted piece: +1 heading north (v falling), -1 south, 0 level; else 0
  };
  void push(double u1, double v1, double u2, double v2, double band, bool counted);

  GridSpec grid_;
  Window window_;
  bool geodesic_ = false;
  std::unique_ptr<GeographicLib::Geodesic> geod_;
  std::vector<Piece> pieces_;
  // The pieces whose band meets each row, as one list per row (CSR).
  std::vector<int64_t> row_start_;
  std::vector<int32_t> row_pieces_;
};

// Calls f(first, end, winding) for consecutive spans of cells [first, end) that cover [c0, c1),
// with the winding number of their centres from a row's sorted crossings: the crossings east of a
// cell heading north less those heading south, which is minus the same sum over those west of it
// (every ring crosses a row as often heading north as south). Inside a ring whose inside lies on
// its left: 1. (A centre on a crossing lies within its piece's band: the caller decides it.)
template <class F>
void for_each_span(const std::vector<RowPieces::Crossing>& crossings, int64_t c0, int64_t c1, F&& f) {
  int west = 0;
  size_t k = 0;
  while (k < crossings.size() && crossings[k].u < static_cast<double>(c0)) west += crossings[k++].north;
  int64_t c = c0;
  for (; k < crossings.size() && c < c1; ++k) {
    const double u = crossings[k].u;
    const int64_t end = u >= static_cast<double>(c1) ? c1 : std::max(c, static_cast<int64_t>(std::ceil(u)));
    if (end > c) {
      f(c, end, -west);
      c = end;
    }
    west += crossings[k].north;
  }
  if (c < c1) f(c, c1, -west);
}

}  // namespace rv::sea
