// The ground under every cell of a window (land, open sea, or sea on a barrier), drawn row by row
// from the barriers' edges as a scanline fill draws polygons, instead of classified cell by cell
// (internal to rv_raster). An engine that draws the shortest-path map row by row needs every
// cell's ground at about the cost of writing it; classify() per cell costs a projection into the
// frame and a walk along a ray.
//
// The answers are Visibility::classify()'s for each cell's centre as Prepared::row_cells() holds
// it, cell for cell:
// - The barrier polygons' edges and the lines' edges are drawn as RowPieces (row_pieces.hpp):
//   planar, straight in the local frame; geodesic, each edge the geodesic between its ends (the
//   reading the exact predicates decide by, rv/sea/geodesic_frame.hpp), in chords.
// - A row's ground comes from the polygons' crossings of it: land where the winding number is at
//   least one (rings oriented with land on their left), that is inside one polygon or more:
//   overlapping land borders are land.
// - A cell whose centre lies within a piece's band (a line's pieces too, for sea on a line is on
//   a barrier) is classified exactly, from its position as row_cells() holds it
//   (Prepared::cell_spot). Those are a few per hundred crossings.
// A projected grid whose centres a geolocator locates (its rows are no parallels) is not drawn:
// drawn() is false, and the caller classifies its cells.
// Cost: building, the edges that may reach the window's rows as pieces (geodesic, a GeographicLib
// line only for an edge longer than a few kilometres); a row, its crossings sorted, the cells
// written, and the few cells in bands classified.
// Thread safety: immutable once built; row() from any number of threads. Holds a pointer to the
// Prepared, which must outlive it.
#pragma once

#include <cstdint>
#include <optional>

#include "rv/field/grid.hpp"
#include "rv/field/metric.hpp"
#include "sea/sea_prepare.hpp"
#include "sea_map/row_pieces.hpp"

namespace rv::sea {

class GroundRows {
 public:
  GroundRows(const Prepared& p, const MetricSpec& metric, const GridSpec& grid, const Window& window);
  bool drawn() const { return pieces_.has_value(); }
  // The ground of every cell of window row r (0 <= r < window.height), written to
  // out[0 .. window.width). Returns how many of them were classified exactly. Requires drawn().
  int64_t row(int64_t r, Visibility::Ground* out) const;
  // The pieces the edges were cut into (for benchmarks and tests).
  int64_t piece_count() const { return pieces_ ? pieces_->piece_count() : 0; }

 private:
  const Prepared* p_;
  GridSpec grid_;
  Window window_;
  std::optional<RowPieces> pieces_;
};

}  // namespace rv::sea
