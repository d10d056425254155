// The exact method: hierarchical tile culling, then an exact argmin per cell.
//
// Why it is exact. For a block B of cell centres and any site s', every centre p in B has
// d(p, nearest) <= d(p, s') <= max over B's four corner centres of d(., s') (distance to a convex
// set is a convex function of p, so its maximum over a rectangle is at a corner). Call the
// smallest such bound over the candidate sites U(B). A site s can be nearest (or tie with the
// nearest) somewhere in B only if dist(s, rect(B)) <= U(B). Filtering with that test, with a
// slack that covers floating-point rounding, never drops the site brute force would pick; the
// final per-cell argmin uses the same planar_key() and the same tie rule (lower site index) as
// brute force, so the result equals brute force bit for bit.
//
// Why it is fast. Blocks are refined top-down (64 x 64 tiles -> quadrants -> ... -> leaves of
// kLeafCells, 32 x 32, or fewer candidates: is_leaf); most
// blocks deep inside one Voronoi region end with a single candidate and are filled with one
// distance evaluation per cell. Tiles are independent, so threads take them dynamically and the
// result cannot depend on the thread count. Tiles whose candidates are all points (and seeds
// without polygons) take a copy of the candidates' coordinates through the same steps
// (solve_point_tile), which spares the culls a random load of each site per block.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <vector>

#include "engine/bucket_index.hpp"
#include "engine/culling.hpp"
#include "engine/engine_internal.hpp"
#include "engine/kernel_memory.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"

namespace rv::detail {
namespace {

constexpr int64_t kPlanarTile = 64;    // top-level tile edge, cells (tiles aligned to the grid)
constexpr size_t kDominanceMax = 16;   // candidate lists longer than this skip the O(k^2) test
constexpr size_t kLeafCandidates = 8;  // ...when they have at most this many candidates
// Blocks this small are solved per cell (32 x 32: the fewest instructions counted, with the
// dominance test).
constexpr int64_t kLeafCells = 1024;
static_assert(detail::kTileBand % kPlanarTile == 0);

struct Rect {  // local frame; x0 <= x1, y0 <= y1
  double x0, y0, x1, y1;
};

// (Two-argument std::max: the initializer-list form compiled to a loop, a few % of the engine.)
inline double point_rect_key(double px, double py, const Rect& r) {
  const double dx = std::max(std::max(r.x0 - px, 0.0), px - r.x1);
  const double dy = std::max(std::max(r.y0 - py, 0.0), py - r.y1);
  return dx * dx + dy * dy;
}

// Liang-Barsky: does the closed segment meet the closed rectangle?
bool segment_meets_rect(const LocalSite& s, const Rect& r) {
  double t0 = 0.0, t1 = 1.0;
  const double p[4] = {-s.dx, s.dx, -s.dy, s.dy};
  const double q[4] = {s.ax - r.x0, r.x1 - s.ax, s.ay - r.y0, r.y1 - s.ay};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0.0) {
      if (q[i] < 0.0) return false;
    } else {
      const double t = q[i] / p[i];
      if (p[i] < 0.0) {
        if (t > t1) return false;
        t0 = std::max(t0, t);
      } else {
        if (t < t0) return false;
        t1 = std::min(t1, t);
      }
    }
  }
  return t0 <= t1;
}

double segment_rect_key(const LocalSite& s, const Rect& r);

// Lower bound of the squared distance from the site to any point of the rectangle.
inline double site_rect_key(const LocalSite& s, const Rect& r) {
  if (s.inv_len2 == 0.0) return point_rect_key(s.ax, s.ay, r);
  return segment_rect_key(s, r);
}

double segment_rect_key(const LocalSite& s, const Rect& r) {
  if (segment_meets_rect(s, r)) return 0.0;
  // Disjoint convex sets: the closest pair has an endpoint of the segment or a rect corner.
  double k = std::min(point_rect_key(s.ax, s.ay, r), point_rect_key(s.bx(), s.by(), r));
  k = std::min(k, planar_key(r.x0, r.y0, s));
  k = std::min(k, planar_key(r.x1, r.y0, s));
  k = std::min(k, planar_key(r.x0, r.y1, s));
  k = std::min(k, planar_key(r.x1, r.y1, s));
  return k;
}

// A cheaper, looser lower bound: the squared distance from the site's bounding box to the
// rectangle (never above site_rect_key, so it can reject but never wrongly keep).
inline double site_box_rect_key(const LocalSite& s, const Rect& r) {
  const double bx = s.ax + s.dx, by = s.ay + s.dy;
  const double dx = std::max(std::max(r.x0 - std::max(s.ax, bx), 0.0), std::min(s.ax, bx) - r.x1);
  const double dy = std::max(std::max(r.y0 - std::max(s.ay, by), 0.0), std::min(s.ay, by) - r.y1);
  return dx * dx + dy * dy;
}

// Upper bound of the squared distance from the point to any point of the rectangle.
inline double point_rect_max_key(double px, double py, const Rect& r) {
  const double dx = std::max(std::abs(r.x0 - px), std::abs(r.x1 - px));
  const double dy = std::max(std::abs(r.y0 - py), std::abs(r.y1 - py));
  return dx * dx + dy * dy;
}

// Upper bound of the squared distance from the site to any point of the rectangle.
inline double site_rect_max_key(const LocalSite& s, const Rect& r) {
  return std::max(std::max(planar_key(r.x0, r.y0, s), planar_key(r.x1, r.y0, s)),
                  std::max(planar_key(r.x0, r.y1, s), planar_key(r.x1, r.y1, s)));
}

// Cells per register block of argmin_block, at most: one 8-wide double vector in the x86-64-v4
// version (a single AVX-512 register), 4-wide in the AVX2 one, 2-wide in the default
// (RV_LANE_KERNEL). Rows are padded to this. One 8-wide register was faster than two 4-wide
// ones with AVX-512 (bench/RESULTS-kernels.md).
constexpr int64_t kLanes = 8;

// The vector steps of argmin_block are macros, not functions: a vector passed to or returned
// from a function compiled without AVX has another ABI than with AVX, which GCC notes and clang
// refuses outright, and the default version of argmin_block is compiled without AVX.
//
// Keys of candidate j for the cells xv of row y (V: the version's vector type). A point:
// planar_key with t = 0, (x - ax)^2 + (y - ay)^2. A segment: planar_key() operation for
// operation (std::clamp(t, 0, 1) is `t < 0 ? 0 : 1 < t ? 1 : t`), so every lane's key is
// bit-identical to the scalar one.
#define RV_POINT_KEY(j, xv, out)   \
  do {                             \
    const V e_ = (xv)-sites[j].ax; \
    (out) = e_ * e_ + ey2_;        \
  } while (0)
#define RV_POINT_ROW(j) const double ey_ = y - sites[j].ay, ey2_ = ey_ * ey_
#define RV_SEGMENT_KEY(j, xv, out)                                     \
  do {                                                                 \
    const LocalSite& s_ = sites[j];                                    \
    V t_ = (((xv)-s_.ax) * s_.dx + (y - s_.ay) * s_.dy) * s_.inv_len2; \
    const V zero_ = V{} + 0.0, one_ = V{} + 1.0;                       \
    t_ = t_ < zero_ ? zero_ : (one_ < t_ ? one_ : t_);                 \
    const V ex_ = (xv) - (s_.ax + t_ * s_.dx);                         \
    const V ey_ = y - (s_.ay + t_ * s_.dy);                            \
    (out) = ex_ * ex_ + ey_ * ey_;                                     \
  } while (0)
#define RV_SEGMENT_ROW(j) \
  do {                    \
  } while (0)
// All k candidates over the U vectors' cells: the best keys and ids stay in registers (strict
// <, ascending ids: ties keep the lowest id). With AVX2, U = 2 (8 cells per step, as in the
// x86-64-v4 version; not slower than one 4-wide vector: bench/RESULTS-kernels.md).
#define RV_ARGMIN_PASS(KEY, ROW)    \
  do {                              \
    {                               \
      ROW(0);                       \
      for (int u = 0; u < U; ++u) { \
        KEY(0, x[u], b[u]);         \
        id[u] = V{} + ids[0];       \
      }                             \
    }                               \
    for (int j = 1; j < k; ++j) {   \
      ROW(j);                       \
      const V idv = V{} + ids[j];   \
      for (int u = 0; u < U; ++u) { \
        V key;                      \
        KEY(j, x[u], key);          \
        const auto m = key < b[u];  \
        b[u] = m ? key : b[u];      \
        id[u] = m ? idv : id[u];    \
      }                             \
    }                               \
  } while (0)

// A block of w x h cells (centre x px[c], centre y py[r]) against k candidate sites: the exact
// argmin per cell (strict <, candidates in ascending id order, so ties keep the lowest id),
// written straight to the result rows (stride: cells between two rows).
//
// Why this shape: the cells of a row are taken a vector at a time, and each group's best key and
// id stay in registers while all k candidates pass (the earlier loop order, candidate-outer,
// loaded and stored best[] and best_id[] once per candidate per cell). Ids ride along as doubles
// (exact below 2^53), so one compare mask blends both. `px` must hold w rounded up to a multiple
// of kLanes (the caller pads it); `best`/`best_id` the same, and `td`/`ti` w; `stream` as for
// put_row(). Keys use exactly planar_key()'s
// arithmetic (-ffp-contract=off: no fused multiply-add), bit-identical to brute force; the
// distance is planar_distance_from_key(), rounded to float, as everywhere. The version for the
// CPU's instruction set is picked at load time (RV_LANE_KERNEL).
template <class V>
RV_LANES_INLINE void argmin_block_lanes(const LocalSite* __restrict sites, const double* __restrict ids, int k,
                                        const double* __restrict px, int64_t w, const double* __restrict py, int64_t h,
                                        double max_key, double* __restrict best, double* __restrict best_id,
                                        float* __restrict td, int32_t* __restrict ti, int32_t* __restrict out_site,
                                        float* __restrict out_dist, int64_t stride, bool stream) {
  // Vectors per step: 8 cells either way where the registers allow (16 of them with AVX2).
  constexpr int U = kLanesOf<V> >= kLanes ? 1 : 2;
  static_assert(kLanes % (U * kLanesOf<V>) == 0, "padded rows are whole steps");
  bool all_points = true;
  for (int j = 0; j < k; ++j) all_points = all_points && sites[j].inv_len2 == 0.0;
  for (int64_t r = 0; r < h; ++r) {
    const double y = py[r];
    for (int64_t c = 0; c < w; c += U * kLanesOf<V>) {
      // Loaded and stored one vector at a time: a block copy of the array went through the
      // stack in 16-byte pieces, and each 32-byte load of it waited for those stores (no
      // store forwarding), a fifth of the kernel's time.
      V x[U], b[U], id[U];
      for (int u = 0; u < U; ++u) std::memcpy(&x[u], px + c + u * kLanesOf<V>, sizeof(V));
      if (all_points)
        RV_ARGMIN_PASS(RV_POINT_KEY, RV_POINT_ROW);
      else
        RV_ARGMIN_PASS(RV_SEGMENT_KEY, RV_SEGMENT_ROW);
      for (int u = 0; u < U; ++u) {
        std::memcpy(best + c + u * kLanesOf<V>, &b[u], sizeof(V));
        std::memcpy(best_id + c + u * kLanesOf<V>, &id[u], sizeof(V));
      }
    }
    if (max_key == std::numeric_limits<double>::infinity()) {
      for (int64_t c = 0; c < w; ++c) td[c] = static_cast<float>(planar_distance_from_key(best[c]));
      for (int64_t c = 0; c < w; ++c) ti[c] = static_cast<int32_t>(best_id[c]);
    } else {
      for (int64_t c = 0; c < w; ++c) {
        const bool none = best[c] > max_key;
        td[c] = none ? kNoDistance : static_cast<float>(planar_distance_from_key(best[c]));
        ti[c] = none ? kNoSite : static_cast<int32_t>(best_id[c]);
      }
    }
    put_row(out_dist + r * stride, out_site + r * stride, td, ti, w, stream);
  }
}
RV_LANE_KERNEL(void, argmin_block,
               (const LocalSite* __restrict sites, const double* __restrict ids, int k, const double* __restrict px,
                int64_t w, const double* __restrict py, int64_t h, double max_key, double* __restrict best,
                double* __restrict best_id, float* __restrict td, int32_t* __restrict ti, int32_t* __restrict out_site,
                float* __restrict out_dist, int64_t stride, bool stream),
               (sites, ids, k, px, w, py, h, max_key, best, best_id, td, ti, out_site, out_dist, stride, stream))
#undef RV_ARGMIN_PASS
#undef RV_SEGMENT_KEY
#undef RV_POINT_KEY
#undef RV_POINT_ROW
#undef RV_SEGMENT_ROW

// Point candidates of a block, structure of arrays (the point-only path of ExactSolver): the
// coordinates are copied once per tile, so the culls below read them contiguously instead of
// loading each 40-byte LocalSite through its id (a cache miss in a large seed set), and their
// loops vectorise. Ids ride as doubles, as argmin_block wants them (exact below 2^53).
struct TilePoint {  // a point candidate as the tile's index query met it
  int32_t id;
  double x, y;
};

struct PointCands {
  AlignedVector<double> x, y, id;
  size_t size() const { return id.size(); }
  void resize(size_t n) {
    x.resize(n);
    y.resize(n);
    id.resize(n);
  }
  void assign(const PointCands& o) {
    x.assign(o.x.begin(), o.x.end());
    y.assign(o.y.begin(), o.y.end());
    id.assign(o.id.begin(), o.id.end());
  }
};

// dominated[j] = 1 when some candidate i has a key smaller than j's by more than `margin` at all
// four corners (c0..c3: each candidate's key at one corner); 0 otherwise. A candidate never
// dominates itself (0 > margin is false, margin > 0). Loop order i outer, j inner: the inner
// loop is elementwise over j and vectorises (the clones' 4- or 8-wide compares).
RV_KERNEL_CLONES void dominated_flags(const double* __restrict c0, const double* __restrict c1,
                                      const double* __restrict c2, const double* __restrict c3, int k, double margin,
                                      int64_t* __restrict dominated) {
  for (int j = 0; j < k; ++j) dominated[j] = 0;
  for (int i = 0; i < k; ++i) {
    const double a0 = c0[i] + margin, a1 = c1[i] + margin, a2 = c2[i] + margin, a3 = c3[i] + margin;
    for (int j = 0; j < k; ++j)
      dominated[j] |= static_cast<int64_t>((c0[j] > a0) & (c1[j] > a1) & (c2[j] > a2) & (c3[j] > a3));
  }
}

struct PlanarWorker {
  std::vector<int32_t> stamp;  // per site id: last tile that collected it
  int64_t stamp_value = 0;
  std::vector<std::vector<int32_t>> levels;  // candidate lists per recursion depth
  std::vector<LocalSite> gathered;
  // Row scratch of argmin_block, one block row (at most a tile wide, padded to whole register
  // blocks). Cache-line aligned: with the default heap alignment the 32-byte stores of `best`
  // straddled lines, and a 1-thread run spent about half its time on them.
  alignas(64) std::array<double, kPlanarTile> px, py;
  alignas(64) std::array<double, kPlanarTile> best;
  alignas(64) std::array<double, kPlanarTile> best_id;
  alignas(64) std::array<float, kPlanarTile> dist_row;
  alignas(64) std::array<int32_t, kPlanarTile> site_row;
  std::vector<double> gathered_ids;
  std::vector<double> box_keys;  // a block's lower bounds per candidate (both paths)
  // The point-only path: the tile's candidates as the index gave them, candidates per recursion
  // depth.
  std::vector<TilePoint> tile_points;
  std::vector<PointCands> point_levels;
  // dominated_points' scratch: the points' coordinates (the generic path gathers them), their
  // place in the candidate list, their keys at the block's corners, and the flags.
  std::array<double, kDominanceMax> dom_x, dom_y;
  std::array<size_t, kDominanceMax> dom_at;
  alignas(64) std::array<double, kDominanceMax> dom_corner[4];
  alignas(64) std::array<int64_t, kDominanceMax> dom_flags;
  bool top_culled = false;  // the tile's candidates (depth 0) are already culled against it
};

// Absolute slack (in distance units) for rounding in bounds: far above the few ulps of the
// local-frame magnitudes the keys are computed from, far below anything that matters.
double rounding_slack(const EngineContext& ctx) {
  const double scale = std::abs(ctx.grid.local_x(ctx.window.col0 + ctx.window.width)) +
                       std::abs(ctx.grid.local_y(ctx.window.row0 + ctx.window.height)) + ctx.grid.res;
  const double sites = ctx.site_scale >= 0.0 ? ctx.site_scale : site_scale(ctx.local, ctx.geometric);
  return std::max(scale, sites) * 1e-12;
}

// The rectangle of the cell centres of window cells [c0, c1) x [r0, r1), in local coordinates.
Rect centres_rect(const EngineContext& ctx, int64_t c0, int64_t r0, int64_t c1, int64_t r1) {
  const Window& w = ctx.window;
  return Rect{ctx.grid.local_x(w.col0 + c0), ctx.grid.local_y(w.row0 + r1 - 1), ctx.grid.local_x(w.col0 + c1 - 1),
              ctx.grid.local_y(w.row0 + r0)};
}

// An index over the context's sites unless it brings one (rv::PreparedSeeds).
std::optional<BucketIndex> own_index(const EngineContext& ctx) {
  if (ctx.index != nullptr) return std::nullopt;
  return std::optional<BucketIndex>(std::in_place, ctx.local, ctx.geometric);
}

// The planar exact method, a policy of the culling skeleton (culling.hpp) over any sites; tiles
// whose candidates are all points (and seeds without polygons) go through PointPath instead.
class ExactSolver {
 public:
  using Worker = PlanarWorker;
  static constexpr bool kInteriors = true;
  static constexpr int64_t kTile = kPlanarTile;

  ExactSolver(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance)
      : ctx_(ctx),
        site_(site),
        distance_(distance),
        own_index_(own_index(ctx)),
        index_(ctx.index != nullptr ? *ctx.index : *own_index_),
        points_{*this} {
    slack_ = rounding_slack(ctx);
    stream_ = streams_results(ctx.window);
  }

  void run() { run_tiles(ctx_, *this); }

  // ---- The skeleton's policy ----

  // Gathers the tile's candidates from the index: those within the bound of the sites near its
  // centre. A fully interior tile keeps the sites touching it and is solved here, a tile of
  // points alone (no polygons) goes the point path.
  bool start_tile(Worker& wk, const Block& t) {
    if (wk.stamp.empty()) wk.stamp.assign(ctx_.local.size(), -1);
    if (wk.levels.empty()) wk.levels.resize(kDepths);
    const Rect rect = rect_of(t);
    if (fully_interior(ctx_, t)) {
      std::vector<int32_t>& zero = wk.levels[1];
      zero.clear();
      const double touch = keep_bound(0.0);
      index_.for_range(index_.clamp_x(rect.x0) - 1, index_.clamp_y(rect.y0) - 1, index_.clamp_x(rect.x1) + 1,
                       index_.clamp_y(rect.y1) + 1, [&](const BucketIndex::Entry& e) {
                         if (site_rect_key(site_of(e), rect) <= touch) zero.push_back(e.id);
                       });
      std::sort(zero.begin(), zero.end());
      zero.erase(std::unique(zero.begin(), zero.end()), zero.end());
      solve_zero(wk, zero, t);
      return false;
    }
    double upper = std::numeric_limits<double>::infinity();
    index_.near(0.5 * (rect.x0 + rect.x1), 0.5 * (rect.y0 + rect.y1),
                [&](const BucketIndex::Entry& e) { upper = std::min(upper, site_rect_max_key(site_of(e), rect)); });
    const double bound = keep_bound(upper);
    const double reach = std::sqrt(bound);
    std::vector<int32_t>& cands = wk.levels[0];
    cands.clear();
    wk.tile_points.clear();
    bool points = true;  // every candidate is a point
    ++wk.stamp_value;
    const auto stamp = static_cast<int32_t>(wk.stamp_value);
    index_.for_range(index_.clamp_x(rect.x0 - reach) - 1, index_.clamp_y(rect.y0 - reach) - 1,
                     index_.clamp_x(rect.x1 + reach) + 1, index_.clamp_y(rect.y1 + reach) + 1,
                     [&](const BucketIndex::Entry& e) {
                       // Only an entry registered in several buckets can come twice.
                       if (e.shared) {
                         if (wk.stamp[e.id] == stamp) return;
                         wk.stamp[e.id] = stamp;
                       }
                       if (site_rect_key(site_of(e), rect) > bound) return;
                       cands.push_back(e.id);
                       points = points && e.point;
                       if (e.point) wk.tile_points.push_back(TilePoint{e.id, e.ax, e.ay});
                     });
    // The index entries carry a point's coordinates: the point-only path never loads the site
    // array (random accesses into it, one per candidate, were a sixth of this function's time).
    if (points && ctx_.interiors == nullptr) {
      start_point_tile(wk);
      solve_block(ctx_, points_, wk, 0, t);
      return false;
    }
    std::sort(cands.begin(), cands.end());
    // Points only: the tile's bound is as tight as cull's, a second cull would find nothing to
    // drop. With segments the box-key bound of cull may be tighter, so they take it.
    wk.top_culled = points;
    return true;
  }

  bool empty(Worker& wk, int depth, const Block&) const { return wk.levels[depth].empty(); }

  // Inside polygons every cell ends at distance 0 with its area site; the only thing left to
  // find is a lower site at distance exactly 0 (which wins the tie). Only sites touching the
  // block can be at distance 0 somewhere in it.
  void solve_interior(Worker& wk, int depth, const Block& b) {
    const Rect rect = rect_of(b);
    const double touch = keep_bound(0.0);
    std::vector<int32_t>& next = wk.levels[depth + 1];
    next.clear();
    for (int32_t id : wk.levels[depth])
      if (site_rect_key(ctx_.local[id], rect) <= touch) next.push_back(id);
    solve_zero(wk, next, b);
  }

  // Candidates of the block are wk.levels[depth], in ascending site order. At the top of a tile
  // gathered by points alone (top_culled) they were culled against this very block, so only the
  // dominance test remains to do.
  BlockStep cull(Worker& wk, int depth, const Block& b) {
    const std::vector<int32_t>& cands = wk.levels[depth];
    std::vector<int32_t>& next = wk.levels[depth + 1];
    const Rect rect = rect_of(b);
    if (depth == 0 && wk.top_culled) {
      next = cands;
      if (next.size() > 1 && next.size() <= kDominanceMax) drop_dominated_points(wk, next, rect);
    } else if (cands.size() > 1) {
      // Any candidate's largest corner key bounds every cell of the block; the few candidates
      // nearest by the cheap box bound give a tight one without evaluating all of them (a dense
      // coast brings hundreds of candidates per block).
      wk.box_keys.resize(cands.size());
      for (size_t j = 0; j < cands.size(); ++j) wk.box_keys[j] = site_box_rect_key(ctx_.local[cands[j]], rect);
      size_t near1, near2;
      two_smallest(wk.box_keys.data(), cands.size(), near1, near2);
      double upper = site_rect_max_key(ctx_.local[cands[near1]], rect);
      if (near2 != near1) upper = std::min(upper, site_rect_max_key(ctx_.local[cands[near2]], rect));
      const double bound = keep_bound(upper);
      next.clear();
      for (size_t j = 0; j < cands.size(); ++j)
        if (wk.box_keys[j] <= bound && site_rect_key(ctx_.local[cands[j]], rect) <= bound) next.push_back(cands[j]);
      if (next.size() > 1 && next.size() <= kDominanceMax) drop_dominated_points(wk, next, rect);
    } else {
      next = cands;
    }
    return is_leaf(b, next.size(), depth) ? BlockStep::leaf : BlockStep::split;
  }

  void solve_leaf(Worker& wk, int depth, const Block& b) { solve_cells(wk, wk.levels[depth], b, ctx_.max_key); }

  template <class F>
  void split(const Block& b, F&& f) const {
    split_middle(b, std::forward<F>(f));
  }

  void fill_none(const Block& b) { detail::fill_none(site_, distance_, b); }

  // Once per worker: only another thread reads the cells, after the join, so fencing per tile
  // would only wait for the stores to drain more often.
  void workers_done(Worker&) const {
    if (stream_) store_fence();
  }

 private:
  // The point-only path: the same culls, dominance test and leaves as the generic one, over the
  // tile's candidates (wk.tile_points) copied once into PointCands in ascending id order. Taken
  // when every candidate of the tile is a point and no polygon interiors exist (so no block is
  // fully interior). Which sites survive a cull never changes the result, only the work: every
  // cull here is sound, and the leaves run the same argmin_block.
  struct PointPath {
    using Worker = PlanarWorker;
    static constexpr bool kInteriors = false;
    ExactSolver& s;

    bool empty(Worker& wk, int depth, const Block&) const { return wk.point_levels[depth].size() == 0; }
    BlockStep cull(Worker& wk, int depth, const Block& b) const { return s.cull_points(wk, depth, b); }
    void solve_leaf(Worker& wk, int depth, const Block& b) const { s.solve_point_cells(wk, wk.point_levels[depth], b); }
    template <class F>
    void split(const Block& b, F&& f) const {
      split_middle(b, std::forward<F>(f));
    }
    void fill_none(const Block& b) const { s.fill_none(b); }
  };

  static constexpr int kDepths = 16;  // candidate lists per recursion depth

  Rect rect_of(const Block& b) const { return centres_rect(ctx_, b.c0, b.r0, b.c1, b.r1); }

  // An index entry's site: a point from the entry itself (no load from the site array), a
  // segment from the site array.
  LocalSite site_of(const BucketIndex::Entry& e) const {
    return e.point ? LocalSite{e.ax, e.ay, 0.0, 0.0, 0.0} : ctx_.local[e.id];
  }

  // The squared-distance bound a site's lower bound must not exceed to stay a candidate.
  double keep_bound(double upper_key) const {
    const double d = std::sqrt(std::min(upper_key, ctx_.max_key)) + slack_;
    return d * d;
  }

  // A fully interior block's cells: the lowest of `zero` at distance exactly 0, else no site.
  void solve_zero(Worker& wk, const std::vector<int32_t>& zero, const Block& b) {
    if (zero.empty()) return fill_none(b);
    solve_cells(wk, zero, b, 0.0);
  }

  // The tile's points (wk.tile_points) into the point path's first list, ascending ids.
  void start_point_tile(Worker& wk) const {
    if (wk.point_levels.size() < wk.levels.size()) wk.point_levels.resize(wk.levels.size());
    std::sort(wk.tile_points.begin(), wk.tile_points.end(),
              [](const TilePoint& a, const TilePoint& b) { return a.id < b.id; });
    PointCands& p = wk.point_levels[0];
    p.resize(wk.tile_points.size());
    for (size_t j = 0; j < wk.tile_points.size(); ++j) {
      p.x[j] = wk.tile_points[j].x;
      p.y[j] = wk.tile_points[j].y;
      p.id[j] = static_cast<double>(wk.tile_points[j].id);
    }
  }

  // cull for PointCands: the tile's own list (depth 0) was culled against the tile already.
  BlockStep cull_points(Worker& wk, int depth, const Block& b) const {
    const PointCands& cands = wk.point_levels[depth];
    const size_t k = cands.size();
    PointCands& next = wk.point_levels[depth + 1];
    const Rect rect = rect_of(b);
    if (depth == 0 || k == 1) {
      next.assign(cands);
    } else {
      // For a point the box key is its exact lower bound; the two nearest by it give the upper
      // bound, as in cull.
      wk.box_keys.resize(k);
      double* keys = wk.box_keys.data();
      for (size_t j = 0; j < k; ++j) keys[j] = point_rect_key(cands.x[j], cands.y[j], rect);
      size_t near1, near2;
      two_smallest(keys, k, near1, near2);
      double upper = point_rect_max_key(cands.x[near1], cands.y[near1], rect);
      if (near2 != near1) upper = std::min(upper, point_rect_max_key(cands.x[near2], cands.y[near2], rect));
      const double bound = keep_bound(upper);
      next.resize(k);
      size_t n = 0;
      for (size_t j = 0; j < k; ++j) {
        next.x[n] = cands.x[j];
        next.y[n] = cands.y[j];
        next.id[n] = cands.id[j];
        n += keys[j] <= bound;
      }
      next.resize(n);
    }
    if (next.size() > 1 && next.size() <= kDominanceMax) drop_dominated_soa(wk, next, rect);
    return is_leaf(b, next.size(), depth) ? BlockStep::leaf : BlockStep::split;
  }

  // drop_dominated_points for PointCands (all points).
  void drop_dominated_soa(Worker& wk, PointCands& p, const Rect& rect) const {
    const int64_t* dominated = dominated_points(wk, p.x.data(), p.y.data(), p.size(), rect);
    size_t kept = 0;
    for (size_t j = 0; j < p.size(); ++j) {
      p.x[kept] = p.x[j];
      p.y[kept] = p.y[j];
      p.id[kept] = p.id[j];
      kept += dominated[j] == 0;
    }
    p.resize(kept);
  }

  // The indices of the two smallest of keys[0 .. k) (k >= 1; near2 == near1 when k == 1).
  static void two_smallest(const double* keys, size_t k, size_t& near1, size_t& near2) {
    near1 = near2 = 0;
    for (size_t j = 1; j < k; ++j) {
      if (keys[j] < keys[near1]) {
        near2 = near1;
        near1 = j;
      } else if (near2 == near1 || keys[j] < keys[near2]) {
        near2 = j;
      }
    }
  }

  // Stop splitting when one candidate is left, or the block is small and has few candidates.
  // Many candidates (a dense, wiggly coast: every segment of a stretch of coast is nearly
  // equidistant from a distant block) keep splitting down to 2x2, where they cannot survive.
  static bool is_leaf(const Block& b, size_t candidates, int depth) {
    const bool small = b.cells() <= kLeafCells && candidates <= kLeafCandidates;
    return candidates <= 1 || small || b.cells() <= 4 || depth + 2 >= kDepths;
  }

  // For two point sites, d(p, j)^2 - d(p, i)^2 is an affine function of p, so if site i is
  // nearer than site j at the four corners of the block (by more than rounding can explain), it
  // is nearer at every cell centre in it and j cannot win there, not even by a tie. (For
  // segments the difference is not affine, so they are never dropped here.)
  void drop_dominated_points(Worker& wk, std::vector<int32_t>& cands, const Rect& rect) const {
    size_t points = 0;
    for (size_t j = 0; j < cands.size(); ++j) {
      const LocalSite& s = ctx_.local[cands[j]];
      if (s.inv_len2 != 0.0) continue;
      wk.dom_x[points] = s.ax;
      wk.dom_y[points] = s.ay;
      wk.dom_at[points++] = j;
    }
    if (points < 2) return;  // only a point dominates a point
    const int64_t* dominated = dominated_points(wk, wk.dom_x.data(), wk.dom_y.data(), points, rect);
    for (size_t i = 0; i < points; ++i)
      if (dominated[i] != 0) cands[wk.dom_at[i]] = -1;
    cands.erase(std::remove(cands.begin(), cands.end(), -1), cands.end());
  }

  // For k <= kDominanceMax points (x[j], y[j]) of a block: flags[j] != 0 where another of them
  // is nearer at all four corners by more than dominance_margin (drop_dominated_points says why
  // that is enough). One margin for the block, that of its largest corner key: the margin grows
  // with the key, so it covers every corner, and per-corner margins cost four square roots per
  // point. Every point is tested against every other without early exits (dominated_flags,
  // vectorised): the outcomes are data-dependent coin flips, and mispredicted early exits cost
  // more than the tests they skipped. Being dominated by a point that is itself dominated is
  // still sound: whatever dominates that one is nearer still. The flags are wk.dom_flags.
  const int64_t* dominated_points(Worker& wk, const double* x, const double* y, size_t k, const Rect& rect) const {
    double* c[4] = {wk.dom_corner[0].data(), wk.dom_corner[1].data(), wk.dom_corner[2].data(), wk.dom_corner[3].data()};
    double largest = 0.0;
    for (size_t j = 0; j < k; ++j) {
      const LocalSite s{x[j], y[j], 0.0, 0.0, 0.0};
      c[0][j] = planar_key(rect.x0, rect.y0, s);
      c[1][j] = planar_key(rect.x1, rect.y0, s);
      c[2][j] = planar_key(rect.x0, rect.y1, s);
      c[3][j] = planar_key(rect.x1, rect.y1, s);
      largest = std::max(std::max(largest, std::max(c[0][j], c[1][j])), std::max(c[2][j], c[3][j]));
    }
    dominated_flags(c[0], c[1], c[2], c[3], static_cast<int>(k), dominance_margin(largest), wk.dom_flags.data());
    return wk.dom_flags.data();
  }

  // How much two computed keys near `key` may differ through rounding alone (generous).
  double dominance_margin(double key) const { return key * 1e-12 + slack_ * slack_ + 2.0 * slack_ * std::sqrt(key); }

  // Exact per-cell argmin over `cands` (ascending ids; strict < keeps the lowest id on ties).
  void solve_cells(Worker& wk, const std::vector<int32_t>& cands, const Block& b, double max_key) {
    if (cands.empty()) return fill_none(b);
    wk.gathered.clear();
    wk.gathered_ids.clear();
    for (int32_t id : cands) {
      wk.gathered.push_back(ctx_.local[id]);
      wk.gathered_ids.push_back(static_cast<double>(id));
    }
    argmin_gathered(wk, b, max_key);
  }

  // The same for PointCands (ascending ids too: every step above keeps the tile's order).
  void solve_point_cells(Worker& wk, const PointCands& cands, const Block& b) {
    if (cands.size() == 0) return fill_none(b);
    wk.gathered.resize(cands.size());
    for (size_t j = 0; j < cands.size(); ++j) wk.gathered[j] = LocalSite{cands.x[j], cands.y[j], 0.0, 0.0, 0.0};
    wk.gathered_ids.assign(cands.id.begin(), cands.id.end());
    argmin_gathered(wk, b, ctx_.max_key);
  }

  // argmin_block over wk.gathered / wk.gathered_ids for the block's cells.
  void argmin_gathered(Worker& wk, const Block& b, double max_key) {
    const Window& win = ctx_.window;
    const int64_t w = b.width(), h = b.height();
    // Rows padded to whole register blocks: the padding repeats the last centre (a real
    // position, so no spurious overflow) and its results are never stored.
    const int64_t padded = (w + kLanes - 1) / kLanes * kLanes;
    static_assert(kPlanarTile % kLanes == 0, "a padded block row must fit the scratch");
    for (int64_t c = 0; c < w; ++c) wk.px[c] = ctx_.grid.local_x(win.col0 + b.c0 + c);
    for (int64_t c = w; c < padded; ++c) wk.px[c] = wk.px[w - 1];
    for (int64_t r = 0; r < h; ++r) wk.py[r] = ctx_.grid.local_y(win.row0 + b.r0 + r);
    argmin_block(wk.gathered.data(), wk.gathered_ids.data(), static_cast<int>(wk.gathered.size()), wk.px.data(), w,
                 wk.py.data(), h, max_key, wk.best.data(), wk.best_id.data(), wk.dist_row.data(), wk.site_row.data(),
                 site_.row(b.r0) + b.c0, distance_.row(b.r0) + b.c0, win.width, stream_);
  }

  const EngineContext& ctx_;
  Raster<int32_t>& site_;
  Raster<float>& distance_;
  std::optional<BucketIndex> own_index_;  // when the context brings none
  const BucketIndex& index_;
  PointPath points_;
  double slack_ = 0.0;
  bool stream_ = false;  // results go with non-temporal stores (streams_results())
};

// The exact method with an owner filter, a policy of the culling skeleton: for each cell, the
// nearest site whose owner differs from the owner of the cell's own nearest site (the margin
// raster's "other side").
//
// Why it stays exact: a block's cells may have several owners. For each owner O present, the
// bound U_O(B) is the smallest corner-max distance over candidate sites not owned by O, and a
// site s is kept when, for some present owner O != owner(s), its lower bound to the block is
// within U_O(B). A cell of owner O has its true nearest non-O site within U_O(B), so that site
// is never dropped; the per-cell argmin uses planar_key and the lower-id tie rule, as brute
// force does over the filtered sites.
class OtherOwnerSolver {
 public:
  struct Worker {
    std::vector<int32_t> stamp;  // per site id: last gather that collected it
    int64_t stamp_value = 0;
    std::vector<std::vector<int32_t>> levels;  // candidate lists per recursion depth
    std::vector<int32_t> owners;               // the current block's owners (empty())
    std::vector<int32_t> seed;                 // the tile's first gather
    std::vector<double> bounds;                // per owner: U_O(B) as a keep bound
  };
  static constexpr bool kInteriors = false;  // a cell inside its own polygon still has another side
  static constexpr int64_t kTile = kPlanarTile;

  OtherOwnerSolver(const EngineContext& ctx, const Raster<int32_t>& own, const std::vector<int32_t>& owner_of,
                   Raster<int32_t>& site, Raster<float>& distance)
      : ctx_(ctx),
        own_(own),
        owner_of_(owner_of),
        site_(site),
        distance_(distance),
        own_index_(own_index(ctx)),
        index_(ctx.index != nullptr ? *ctx.index : *own_index_) {
    slack_ = rounding_slack(ctx);
  }

  void run() { run_tiles(ctx_, *this); }

  // ---- The skeleton's policy ----

  // Seed candidates: for each owner of the tile's cells, the sites near the tile centre up to one
  // ring past the first ring holding a site of another owner; their bounds give the reach of the
  // tile's gather.
  bool start_tile(Worker& wk, const Block& t) {
    if (wk.stamp.empty()) wk.stamp.assign(ctx_.local.size(), -1);
    if (wk.levels.empty()) wk.levels.resize(kDepths);
    owners_in(t, wk.owners);
    if (wk.owners.empty()) {
      fill_none(t);
      return false;
    }
    const Rect rect = rect_of(t);
    const double mx = 0.5 * (rect.x0 + rect.x1), my = 0.5 * (rect.y0 + rect.y1);
    wk.seed.clear();
    ++wk.stamp_value;
    auto stamp = static_cast<int32_t>(wk.stamp_value);
    for (int32_t o : wk.owners)
      index_.near_filtered(
          mx, my, [&](const BucketIndex::Entry& e) { return owner_of_[e.id] != o; },
          [&](const BucketIndex::Entry& e) {
            if (wk.stamp[e.id] == stamp) return;
            wk.stamp[e.id] = stamp;
            wk.seed.push_back(e.id);
          });
    cull_into(wk, wk.seed, rect, wk.levels[1]);
    double widest = 0.0;
    for (double b : wk.bounds) widest = std::max(widest, b);
    std::vector<int32_t>& cands = wk.levels[0];
    cands.clear();
    ++wk.stamp_value;
    stamp = static_cast<int32_t>(wk.stamp_value);
    if (widest == std::numeric_limits<double>::infinity()) {
      // Some present owner has no other-owner site in reach of the ring search: only possible
      // when no site of another owner exists at all; take every site (cull sorts it out).
      for (int32_t id : ctx_.geometric) cands.push_back(id);
    } else {
      const double reach = std::sqrt(widest);
      index_.for_range(index_.clamp_x(rect.x0 - reach) - 1, index_.clamp_y(rect.y0 - reach) - 1,
                       index_.clamp_x(rect.x1 + reach) + 1, index_.clamp_y(rect.y1 + reach) + 1,
                       [&](const BucketIndex::Entry& e) {
                         if (wk.stamp[e.id] == stamp) return;
                         wk.stamp[e.id] = stamp;
                         cands.push_back(e.id);
                       });
    }
    std::sort(cands.begin(), cands.end());
    return true;
  }

  // Nothing to find where no cell has an owner; the block's owners are kept for cull.
  bool empty(Worker& wk, int, const Block& b) const {
    owners_in(b, wk.owners);
    return wk.owners.empty();
  }

  BlockStep cull(Worker& wk, int depth, const Block& b) const {
    std::vector<int32_t>& next = wk.levels[depth + 1];
    cull_into(wk, wk.levels[depth], rect_of(b), next);
    const bool leaf = next.size() <= 1 || b.cells() <= kLeafCells || depth + 2 >= kDepths;
    return leaf ? BlockStep::leaf : BlockStep::split;
  }

  // Per-cell argmin over the candidates of another owner (ascending ids, strict <).
  void solve_leaf(Worker& wk, int depth, const Block& b) {
    const std::vector<int32_t>& cands = wk.levels[depth];
    const Window& win = ctx_.window;
    for (int64_t r = b.r0; r < b.r1; ++r) {
      const double py = ctx_.grid.local_y(win.row0 + r);
      for (int64_t c = b.c0; c < b.c1; ++c) {
        const int32_t o = cell_owner(c, r);
        double best = std::numeric_limits<double>::infinity();
        int32_t best_id = kNoSite;
        if (o != 0) {
          const double px = ctx_.grid.local_x(win.col0 + c);
          for (int32_t id : cands) {
            if (owner_of_[id] == o) continue;
            const double k = planar_key(px, py, ctx_.local[id]);
            if (k < best) {
              best = k;
              best_id = id;
            }
          }
        }
        site_.at(c, r) = best_id;
        distance_.at(c, r) = best_id == kNoSite ? kNoDistance : static_cast<float>(std::sqrt(best));
      }
    }
  }

  template <class F>
  void split(const Block& b, F&& f) const {
    split_middle(b, std::forward<F>(f));
  }

  void fill_none(const Block& b) { detail::fill_none(site_, distance_, b); }
  void workers_done(Worker&) const {}

 private:
  static constexpr int kDepths = 16;

  Rect rect_of(const Block& b) const { return centres_rect(ctx_, b.c0, b.r0, b.c1, b.r1); }
  double keep_bound(double upper_key) const {
    if (upper_key == std::numeric_limits<double>::infinity()) return upper_key;
    const double d = std::sqrt(upper_key) + slack_;
    return d * d;
  }
  int32_t cell_owner(int64_t c, int64_t r) const {
    const int32_t s = own_.at(c, r);
    return s == kNoSite ? 0 : owner_of_[s];
  }
  // Distinct owners (> 0) of the block's cells, ascending.
  void owners_in(const Block& b, std::vector<int32_t>& out) const {
    out.clear();
    int32_t last = -1;
    for (int64_t r = b.r0; r < b.r1; ++r)
      for (int64_t c = b.c0; c < b.c1; ++c) {
        const int32_t o = cell_owner(c, r);
        if (o == 0 || o == last) continue;
        last = o;
        if (std::find(out.begin(), out.end(), o) == out.end()) out.push_back(o);
      }
    std::sort(out.begin(), out.end());
  }

  // Keeps the sites of `in` that can be the nearest other-owner site of some cell of the block
  // (owners wk.owners); wk.bounds gets each owner's keep bound.
  void cull_into(Worker& wk, const std::vector<int32_t>& in, const Rect& rect, std::vector<int32_t>& out) const {
    const std::vector<int32_t>& owners = wk.owners;
    wk.bounds.assign(owners.size(), std::numeric_limits<double>::infinity());
    for (int32_t id : in) {
      const double mk = site_rect_max_key(ctx_.local[id], rect);
      for (size_t i = 0; i < owners.size(); ++i)
        if (owner_of_[id] != owners[i]) wk.bounds[i] = std::min(wk.bounds[i], mk);
    }
    for (double& b : wk.bounds) b = keep_bound(b);
    out.clear();
    for (int32_t id : in) {
      const double lo = site_rect_key(ctx_.local[id], rect);
      for (size_t i = 0; i < owners.size(); ++i)
        if (owner_of_[id] != owners[i] && lo <= wk.bounds[i]) {
          out.push_back(id);
          break;
        }
    }
  }

  const EngineContext& ctx_;
  const Raster<int32_t>& own_;
  const std::vector<int32_t>& owner_of_;
  Raster<int32_t>& site_;
  Raster<float>& distance_;
  std::optional<BucketIndex> own_index_;  // when the context brings none
  const BucketIndex& index_;
  double slack_ = 0.0;
};

}  // namespace

void run_exact(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance) {
  ExactSolver solver(ctx, site, distance);
  solver.run();
}

void run_exact_other_owner(const EngineContext& ctx, const Raster<int32_t>& own,
                           const std::vector<int32_t>& owner_of_site, Raster<int32_t>& site, Raster<float>& distance) {
  OtherOwnerSolver solver(ctx, own, owner_of_site, site, distance);
  solver.run();
}

}  // namespace rv::detail
