// The culling skeleton of the exact methods: tiles of the window, each a quadtree of blocks whose
// candidate sites are culled by bounds until a leaf solves its cells exactly. Written once here;
// what differs between the methods is a policy:
//
//   struct Policy {
//     using Worker = ...;                          // per-thread scratch (candidate lists per depth)
//     static constexpr bool kInteriors;            // whether fully interior blocks take
//                                                  // solve_interior (apply_interiors does the rest)
//     static constexpr int64_t kTile;              // tile edge, cells
//     bool start_tile(Worker&, const Block& tile); // gathers the tile's candidates into depth 0;
//                                                  // false when it has solved the tile itself
//     bool empty(Worker&, int depth, const Block&);            // nothing can be nearest here
//     void solve_interior(Worker&, int depth, const Block&);   // every centre inside a polygon
//     BlockStep cull(Worker&, int depth, const Block&);        // depth's candidates -> depth + 1
//     void solve_leaf(Worker&, int depth, const Block&);       // exact per cell, over the list
//                                                               // cull made (depth + 1 of cull's)
//     void split(const Block&, F&& each_part);                 // split_middle or split_aligned
//     void fill_none(const Block&);                            // rv::detail::fill_none on its rasters
//     void workers_done(Worker&);                  // a worker's end (fences for streamed stores)
//   };
//
// The policies today: the planar method over any sites and over points alone (exact.cpp), the
// planar method keeping the nearest site of another owner (exact.cpp), the geodesic method
// (geodesic_exact.cpp). How the extensions filed plug in:
// - a per-site transform of the compared distance (multiplicative weights, a maximum reach) is a
//   policy's bounds: a block's lower and upper bounds of each site transformed like its
//   distances, and the leaf comparing transformed distances; the skeleton is untouched;
// - a cell mask (recompute only some cells): EngineContext::mask, honoured here -- tiles and
//   blocks without a masked cell are skipped;
// - windows (strips, chunks): EngineContext::window; tiles are aligned to the grid, not to the
//   window, so a block's bounds, and the geodesic interpolation blocks, do not depend on it.
//
// Which sites survive a cull never changes a result, only the work: every cull must be sound
// (keep every site that can be the nearest, or tie with it, at some cell of the block), and the
// leaves compute exact per-cell minima with the lower-id tie rule, as brute force does.
//
// Thread safety: run_tiles calls the policy from ctx.threads threads at once, each with a Worker
// of its own; during the run a policy only reads its other members, but for its output rasters
// (each thread its own tiles' cells) and what it shares safely by its own contract.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "engine/engine_internal.hpp"
#include "rv/field/parallel.hpp"

namespace rv::detail {

// Window-relative cells [c0, c1) x [r0, r1), non-empty. level: the size of the grid-aligned
// square the block was split from (split_aligned), the tile size for a tile.
struct Block {
  int64_t c0, r0, c1, r1;
  int64_t level;
  int64_t width() const { return c1 - c0; }
  int64_t height() const { return r1 - r0; }
  int64_t cells() const { return width() * height(); }
};

// What a block's culled candidates call for.
enum class BlockStep { leaf, split };

// No site (kNoSite, kNoDistance) for every cell of the block.
inline void fill_none(Raster<int32_t>& site, Raster<float>& distance, const Block& b) {
  for (int64_t r = b.r0; r < b.r1; ++r) {
    std::fill(site.row(r) + b.c0, site.row(r) + b.c1, kNoSite);
    std::fill(distance.row(r) + b.c0, distance.row(r) + b.c1, kNoDistance);
  }
}

// True when every cell of the block has its centre inside a polygon (one span per row).
inline bool fully_interior(const EngineContext& ctx, const Block& b) {
  return ctx.interiors != nullptr && ctx.interiors->covers(b.c0, b.r0, b.c1, b.r1);
}

// True when the block holds a cell the computation must produce (no mask: every cell).
inline bool in_mask(const EngineContext& ctx, const Block& b) {
  return ctx.mask == nullptr || ctx.mask->any(b.c0, b.r0, b.c1, b.r1);
}

// f(part) for each non-empty quadrant of the block, split at its middle, in row-major order.
template <class F>
void split_middle(const Block& b, F&& f) {
  const int64_t cm = b.c0 + (b.c1 - b.c0 + 1) / 2, rm = b.r0 + (b.r1 - b.r0 + 1) / 2;
  f(Block{b.c0, b.r0, cm, rm, b.level / 2});
  if (cm < b.c1) f(Block{cm, b.r0, b.c1, rm, b.level / 2});
  if (rm < b.r1) {
    f(Block{b.c0, rm, cm, b.r1, b.level / 2});
    if (cm < b.c1) f(Block{cm, rm, b.c1, b.r1, b.level / 2});
  }
}

// f(part) for each non-empty quadrant of the block split at the grid-aligned middle of its level
// (the window at `w`), row-major: every part is again aligned to the grid at half the level.
template <class F>
void split_aligned(const Window& w, const Block& b, F&& f) {
  const int64_t half = b.level / 2;
  const int64_t cm = std::clamp(((w.col0 + b.c0) / b.level) * b.level + half - w.col0, b.c0, b.c1);
  const int64_t rm = std::clamp(((w.row0 + b.r0) / b.level) * b.level + half - w.row0, b.r0, b.r1);
  const int64_t xs[3] = {b.c0, cm, b.c1}, ys[3] = {b.r0, rm, b.r1};
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i)
      if (xs[i] < xs[i + 1] && ys[j] < ys[j + 1]) f(Block{xs[i], ys[j], xs[i + 1], ys[j + 1], half});
}

// The recursion: a block with nothing to find gets no site, a fully interior one goes to the
// policy's interior solver, otherwise its candidates are culled and it is a leaf or is split.
// Blocks outside the mask are skipped.
template <class Policy>
void solve_block(const EngineContext& ctx, Policy& p, typename Policy::Worker& wk, int depth, const Block& b) {
  if (!in_mask(ctx, b)) return;
  if (p.empty(wk, depth, b)) return p.fill_none(b);
  if constexpr (Policy::kInteriors)
    if (fully_interior(ctx, b)) return p.solve_interior(wk, depth, b);
  if (p.cull(wk, depth, b) == BlockStep::leaf) return p.solve_leaf(wk, depth + 1, b);
  p.split(b, [&](const Block& part) { solve_block(ctx, p, wk, depth + 1, part); });
}

// The tiles of the window with a masked cell, as indices t (column t % ntx, row t / ntx of the
// window's tiles, first tile (tx0, ty0)), ascending, found from the mask's spans in one pass (an
// edit's mask of a few thousand cells in a grid of 1e8 then asks no question of the other
// tiles). Needs ctx.mask.
inline std::vector<int64_t> tiles_to_solve(const EngineContext& ctx, int64_t tile, int64_t tx0, int64_t ty0,
                                           int64_t ntx, int64_t nty) {
  const Window& w = ctx.window;
  std::vector<uint8_t> hit(static_cast<size_t>(ntx * nty), 0);
  for (int64_t r = 0; r < w.height; ++r) {
    const int64_t ty = (w.row0 + r) / tile - ty0;
    for (const auto& [c0, c1] : ctx.mask->rows[static_cast<size_t>(r)])
      for (int64_t tx = (w.col0 + c0) / tile - tx0; tx <= (w.col0 + c1 - 1) / tile - tx0; ++tx)
        hit[static_cast<size_t>(ty * ntx + tx)] = 1;
  }
  std::vector<int64_t> out;
  for (size_t t = 0; t < hit.size(); ++t)
    if (hit[t]) out.push_back(static_cast<int64_t>(t));
  return out;
}

// Every tile (Policy::kTile cells square) of the window with a cell to compute (all, or those of
// the mask) on ctx.threads workers (tiles handed out in row-major order of the grid's tiles), each
// started by the policy and then solved by the recursion; progress advances by the tile's cells
// (the skipped tiles' cells at the start). Deterministic for any thread count: tiles write
// disjoint cells.
template <class Policy>
void run_tiles(const EngineContext& ctx, Policy& p) {
  const Window& w = ctx.window;
  constexpr int64_t kTile = Policy::kTile;
  const int64_t tx0 = w.col0 / kTile, tx1 = (w.col0 + w.width - 1) / kTile;
  const int64_t ty0 = w.row0 / kTile, ty1 = (w.row0 + w.height - 1) / kTile;
  const int64_t ntx = tx1 - tx0 + 1, nty = ty1 - ty0 + 1;
  // Under a mask, the tiles it meets (the others' cells advance the progress at once); else all.
  std::vector<int64_t> masked;
  if (ctx.mask != nullptr) masked = tiles_to_solve(ctx, kTile, tx0, ty0, ntx, nty);
  const int64_t count = ctx.mask != nullptr ? static_cast<int64_t>(masked.size()) : ntx * nty;
  auto tile_of = [&](int64_t i) {
    const int64_t t = ctx.mask != nullptr ? masked[static_cast<size_t>(i)] : i;
    const int64_t gx = (tx0 + t % ntx) * kTile, gy = (ty0 + t / ntx) * kTile;
    return Block{std::max<int64_t>(gx - w.col0, 0), std::max<int64_t>(gy - w.row0, 0),
                 std::min(gx + kTile - w.col0, w.width), std::min(gy + kTile - w.row0, w.height), kTile};
  };
  if (ctx.mask != nullptr) {
    int64_t skipped = w.width * w.height;
    for (int64_t i = 0; i < count; ++i) skipped -= tile_of(i).cells();
    if (skipped > 0) ctx.progress->advance(skipped);
  }
  std::vector<typename Policy::Worker> workers(static_cast<size_t>(ctx.threads));
  parallel_for(
      ctx.threads, count,
      [&](int64_t i, int worker) {
        typename Policy::Worker& wk = workers[static_cast<size_t>(worker)];
        const Block tile = tile_of(i);
        if (p.start_tile(wk, tile)) solve_block(ctx, p, wk, 0, tile);  // (every tile here meets the mask)
        ctx.progress->advance(tile.cells());
      },
      [&](int worker) { p.workers_done(workers[static_cast<size_t>(worker)]); });
}

}  // namespace rv::detail
