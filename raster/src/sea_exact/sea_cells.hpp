// The exact engine's answers for cells (internal to rv_raster; sea_exact.cpp runs them): the
// cells answered from what was drawn row by row (answer_drawn), one cell alone, or a block of
// cells at once where the block's proofs hold.
//
// A cell's answer is its nearest site when it sees it (the straight field's answer, bit for bit),
// else the best path over the roots it sees (Searches::best_path). A block of open sea with no
// barrier near it is answered from proofs made once for the block (Visibility::clear_box,
// sees_box): its ground; the straight nearest sites that see the whole block; and, for the
// cells whose path bends, the roots that could give any of them its answer (those within an
// upper bound of the block's distances, as RootTree bounds them, less the bends no cell of the
// block could leave taut: never_taut), each proved to see the whole block or tested per cell as
// before. On a longitude/latitude grid the lengths from those roots come from patches over the
// block's tile (length_patch.hpp) wherever the answer cannot depend on the patches' error.
// Every cell's answer is the one answer_cell gives it, to the bit: the same roots weighed the
// same way (Searches::consider), only the order, the proofs of visibility and which lengths are
// solved differ. The upper bound rests on the statement's triangle inequality (a cell's distance
// is at most that of a cell it sees plus the way between), which needs the points where seeds'
// edges meet barriers among the roots (Prepared::touches).
// Thread safety: a CellRun is shared read-only by the workers (each writes its own cells of
// `out`); a CellWorker belongs to one worker.
#pragma once

#include <cstdint>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/field/interior.hpp"
#include "rv/sea/sea_field.hpp"
#include "sea/bend_settle.hpp"
#include "sea_exact/length_patch.hpp"
#include "sea_map/site_sight.hpp"

namespace rv::sea {

// What every worker of one compute_sea reads.
struct CellRun {
  const PreparedSea& prepared;
  const SeedSet& seeds;
  const NearestField& straight;  // the window's straight field (empty for adjusted seeds)
  const InteriorSpans& interiors;
  double max_distance;
  SeaField& out;  // each cell written by the worker that answers it
  const GridSpec& grid;
  const Window& window;
  // The side of the tiles bent blocks share their length patches over (sea_exact/length_patch.hpp),
  // in cells, a multiple of every block's; 0: no patches (a planar or projected grid).
  int64_t patch_tile = 0;
  const Prepared& p() const { return prepared.prepared; }
  const Searches& search() const { return prepared.search; }
  bool adjusted() const { return !prepared.classes.empty(); }
};

// Hints of one class of adjusted seeds (Searches::best_path's).
struct ClassHints {
  std::vector<int32_t> blockers;  // per item of the class's tree
  int32_t last = -1;              // the root of the previous bent cell
};

// One worker's hints and counts.
struct CellWorker {
  int64_t land = 0, unreachable = 0, tests = 0, block_cells = 0, drawn = 0;
  PatchTiles tiles;
  // Bent blocks' lengths (length_patch.hpp): patches built, cells answered from them, cells
  // weighed again exactly because two roots came within the patches' error.
  int64_t patches = 0, interpolated = 0, patch_retries = 0;
  double detour = 1.0;
  // Per item of the search's tree, the edge that last hid it (best_path's `blockers`):
  // neighbouring cells are mostly hidden from the same roots by the same edges.
  std::vector<int32_t> blockers;
  int32_t last = -1;        // the root of the previous bent cell
  int32_t block_root = -1;  // the root that won the last bent cell answered in a block
  std::vector<ClassHints> classes;
  // Block scratch.
  std::vector<int64_t> pending;
};

// Cell (c, r) of the window (its centre `spot`, its ground not land, not inside a seed polygon).
// `hidden`: its straight nearest site is known not to be seen from it (SiteSight drew it so).
void answer_cell(const CellRun& run, CellWorker& w, int64_t c, int64_t r, const Spot& spot, Visibility::Ground ground,
                 bool hidden = false);

// Row r of the window from what was drawn before any proof (sea_map/ground_rows.hpp,
// site_sight.hpp): grounds[c] for every cell, sight[c] (SiteSight::Sight) or null. Answers the
// land cells (counted) and the open-sea cells that see their straight nearest site and lie in no
// seed polygon (the straight field's answer, as answer_cell gives it), marking them in
// answered[c]; cells already marked are left alone.
void answer_drawn(const CellRun& run, CellWorker& w, int64_t r, const Visibility::Ground* grounds,
                  const SiteSight::Sight* sight, uint8_t* answered);

// Cells [c0, c1) x [r0, r1) of the window (spots[r - r0][c]: their centres; none inside a seed
// polygon; seeds not adjusted) when the block is clear of barriers (clear_box): answered, their
// grounds written to grounds[(r - r0) * stride + c] (land or open sea), and true; else nothing
// done and false. Cells marked in `answered` (same layout) are left alone; `sight` (same layout,
// or null): cells drawn as not seeing their straight nearest site need no proof of it.
bool answer_block(const CellRun& run, CellWorker& w, int64_t c0, int64_t c1, int64_t r0, int64_t r1,
                  const std::vector<Spot>* spots, Visibility::Ground* grounds, int64_t stride, const uint8_t* answered,
                  const SiteSight::Sight* sight_drawn);

}  // namespace rv::sea
