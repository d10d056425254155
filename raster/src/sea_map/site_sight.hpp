// Which cells of a window see their straight nearest site, drawn row by row from each point
// site's visible region (internal to rv_raster), instead of proved cell by cell or block by block.
// A cell that sees that site takes the straight field's answer as it is; the others' paths bend.
//
// For each point site that is some cell's straight nearest: the region it sees (visible_region.hpp)
// within a box round those cells, its ring drawn as RowPieces (row_pieces.hpp; geodesic, each ring
// edge the geodesic between its corners' longitudes and latitudes). Each piece's band holds the
// ring's margin, the frame's deviation and the chords' tolerance, twice over: a cell centre
// outside every band is inside the ring exactly when Visibility::sees says it sees the site
// (the ring's contract), and the cells in bands are left unknown, for the exact predicates.
// Unknown too: cells whose straight nearest site is a segment (its nearest point moves from
// cell to cell), or a point whose region is blurred (an edge passes within the margin of it) or
// that has several sea wedges (a line's inner vertex, a corner two islands share): a path may
// reach it in any of them; or a point with fewer than four cells per edge its sweep would read,
// or fewer than 256 cells (a sweep and its drawing cost a few cells' proofs per edge: on coarse
// grids and in thin strips the cells' own proofs are cheaper).
//
// A site's own place is read as answer_cell's test reads it (Prepared::site_place: the point,
// any wedge); where it has one sea wedge (a port on a coast) its region is that wedge's.
// Cost: one rotational sweep per site over the edges that may meet its box; a row, per run of
// cells sharing a site, the crossings of that site's ring.
// Thread safety: immutable once built; row() from any number of threads. Holds a pointer to
// `nearest`, which must outlive it.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "rv/field/grid.hpp"
#include "rv/field/metric.hpp"
#include "rv/field/raster.hpp"
#include "sea/edge_index.hpp"
#include "sea/sea_prepare.hpp"
#include "sea_map/row_pieces.hpp"

namespace rv::sea {

class SiteSight {
 public:
  enum Sight : uint8_t { unknown = 0, seen = 1, hidden = 2 };

  // `nearest`: the window's straight nearest site per cell (kNoSite: none), `window` its window
  // of `grid`. On a projected grid with a geolocator nothing is drawn (every cell unknown). The
  // sites' regions are made on `threads` threads (the same whatever their number).
  // `edges`, `index`: the barrier edges cut where they cross (barrier_edges) and an index of them.
  SiteSight(const Prepared& p, const MetricSpec& metric, const GridSpec& grid, const Window& window,
            const Raster<int32_t>& nearest, const std::vector<EdgeIndex::Segment>& edges, const EdgeIndex& index,
            int threads = 1);
  // Row r of the window: out[c] for every cell c of it.
  void row(int64_t r, Sight* out) const;
  // Sites whose region was drawn, and those left unknown (blurred, several sea wedges, or too
  // few cells for their sweep).
  int64_t regions() const { return regions_; }
  int64_t undrawn() const { return undrawn_; }

 private:
  const Raster<int32_t>* nearest_;
  Window window_;
  std::vector<std::unique_ptr<RowPieces>> rings_;  // per site; null: unknown
  int64_t regions_ = 0, undrawn_ = 0;
};

}  // namespace rv::sea
