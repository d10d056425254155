// Polygon interiors as row spans: which cells of a window have their centre inside a polygon.
//
// A cell belongs to a polygon's interior when its centre is inside by the even-odd rule over the
// polygon's rings, with the half-open convention of scanline filling (a centre exactly on a
// left/lower edge is inside, on a right/upper edge outside) so that two polygons sharing an edge
// never both claim a cell. Where interiors of several polygons cover a cell, the lowest area site
// (hence the lowest feature index and owner code) wins.
//
// Memory is proportional to the number of polygon edges and spans, not to the cell count.
// Pure, thread-safe.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "rv/field/grid.hpp"
#include "rv/field/seeds.hpp"

namespace rv {

struct Span {
  int64_t col0;  // first column (window-relative), inclusive
  int64_t col1;  // last column, exclusive
  int32_t site;  // the area site that owns these cells
};

struct InteriorSpans {
  Window window;
  std::vector<std::vector<Span>> rows;  // per window row: disjoint spans sorted by col0
  int64_t contested_cells = 0;          // cells claimed by polygons of two or more owners
  int64_t cell_count() const;           // cells inside any polygon
  bool empty() const;
  // True when every cell of window-relative columns [c0, c1) x rows [r0, r1) (non-empty, inside
  // the window) has its centre inside a polygon: one span covers each row's columns.
  bool covers(int64_t c0, int64_t r0, int64_t c1, int64_t r1) const;
};

InteriorSpans build_interiors(const SeedSet& seeds, const GridSpec& grid, const Window& window);

// The first column whose centre's local x (GridSpec::local_x) is >= `local_x`, clamped to
// [-1, width + 1]: the interiors' test of a centre against a ring's crossing of its row (a
// centre on the crossing is on the span's side that starts there).
int64_t first_column_at_or_after(const GridSpec& grid, double local_x);

// Where a ring's edge crosses a row's centre line (ring_spans' scratch).
struct RingCrossing {
  int64_t row;  // window-relative
  double x;     // local frame (GridSpec::local_x)
};
// The centres of `window` inside `rings` (even-odd; a centre on a crossing belongs to the span
// that starts there): add(row, c0, c1) for each span of window-relative columns [c0, c1) of
// window row `row`, non-empty and clipped to the window, rows in order. `scratch` is reused
// between calls.
void ring_spans(std::span<const Ring> rings, const GridSpec& grid, const Window& window,
                std::vector<RingCrossing>& scratch,
                const std::function<void(int64_t row, int64_t c0, int64_t c1)>& add);

// The same for a replacement list of polygons (their area_site indices refer to seeds' sites;
// the same site may appear in several polygons, e.g. copies of a polygon one turn of longitude
// apart on geodesic grids).
InteriorSpans build_interiors(const SeedSet& seeds, const std::vector<Polygon>& polygons, const GridSpec& grid,
                              const Window& window);

}  // namespace rv
