// The ground under every cell of a window (land, open sea, or sea on a barrier), drawn row by row
// from the barriers' edges as a scanline fill draws polygons, instead of classified cell by cell
// (internal to rv_raster). An engine that draws the shortest-path map row by row needs every
// cell's ground at about the cost of writing it; classify() per cell costs a projection into the
// frame and a walk along a ray.
//
// The answers are Visibility::classify()'s for each cell's centre as Prepared::row_cells() holds
// it, cell for cell:
// - The edges are put in the window's cell coordinates (u along a row, v down the rows, a cell's
//   centre at whole numbers). Planar: the barriers' local frame scaled, the edges straight.
//   Geodesic on a longitude/latitude grid: each edge is the geodesic between its ends (the reading
//   the exact predicates decide by, rv/sea/geodesic_frame.hpp), cut into chords straight in
//   longitude/latitude, each halved until its geodesic midpoint lies within a quarter of
//   kChordTolerance of the chord. A geodesic's curvature in longitude/latitude changes little
//   along such a piece, so the piece then lies within the tolerance of its chord (four times the
//   deviation at its middle, where a circular arc departs most).
// - A row's crossings by the polygons' pieces give its ground: land where the winding number of
//   the crossings east of a cell is at least one (rings oriented with land on their left), that
//   is inside one polygon or more: overlapping land borders are land.
// - A cell whose centre lies within a piece's band (its tolerance and a rounding margin; a
//   line's pieces too, for sea on a line is on a barrier) is classified exactly, from its
//   position as row_cells() holds it (Prepared::cell_spot). Those are a few per hundred crossings.
//
// A projected grid whose centres a geolocator locates (its rows are no parallels) is not drawn:
// drawn() is false, and the caller classifies its cells.
// Cost: building, O(E) pieces (a GeographicLib line and a midpoint each, geodesic); a row, its
// crossings sorted, the cells written, and the few cells in bands classified.
// Thread safety: immutable once built; row() from any number of threads. Holds a pointer to the
// Prepared, which must outlive it.
#pragma once

#include <cstdint>
#include <vector>

#include "rv/field/grid.hpp"
#include "rv/field/metric.hpp"
#include "sea/sea_prepare.hpp"

namespace GeographicLib {
class Geodesic;
}

namespace rv::sea {

class GroundRows {
 public:
  // A geodesic chord's largest distance from its geodesic, in cells.
  static constexpr double kChordTolerance = 0.01;

  GroundRows(const Prepared& p, const MetricSpec& metric, const GridSpec& grid, const Window& window);
  bool drawn() const { return drawn_; }
  // The ground of every cell of window row r (0 <= r < window.height), written to
  // out[0 .. window.width). Returns how many of them were classified exactly. Requires drawn().
  int64_t row(int64_t r, Visibility::Ground* out) const;
  // The pieces the edges were cut into (for benchmarks and tests).
  int64_t piece_count() const { return static_cast<int64_t>(pieces_.size()); }

 private:
  struct Piece {
    double u1, v1, u2, v2;
    double band;   // cells: every point of the edge this piece stands for lies within it
    int8_t north;  // a polygon's piece: +1 heading north (v falling), -1 south; a line's: 0
  };
  void add_edge(const GridSpec& grid, const GeographicLib::Geodesic* geod, Vec2 a, Vec2 b, bool polygon);
  void index_rows();

  const Prepared* p_;
  GridSpec grid_;
  Window window_;
  bool drawn_ = false;
  std::vector<Piece> pieces_;
  // The pieces whose band meets each row, as one list per row (CSR).
  std::vector<int64_t> row_start_;
  std::vector<int32_t> row_pieces_;
};

}  // namespace rv::sea
