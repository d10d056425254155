// The exact method for the geodesic metric: its solver's state and parts. Why the method is
// exact and fast is at the top of geodesic_exact.cpp; the solver's members are defined by concern:
//   geodesic_exact.cpp          set-up, tiles, block culling, dominance, blocks of zero distance
//   geodesic_interpolants.cpp   building the interpolants of a block (point and additive forms)
//   geodesic_leaf.cpp           leaves: gathering interpolants, the row kernels over their rows
//   geodesic_cells.cpp          the per-cell method: values, close calls decided exactly
// with parts that have contracts of their own: geodesic_regime.hpp (which part of a segment is
// nearest), geodesic_interpolant.hpp (the interpolants), geodesic_kernels.hpp (the row kernels).
//
// One solver per run (run_exact_geodesic). Thread safety: run() works on the context's threads,
// each with its own GeoWorker; during run() the solver's members are read only, but for the
// shared interpolants (thread-safe) and the output rasters (each thread its own tiles' cells).
// Internal to rv_raster.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <type_traits>
#include <unordered_map>
#include <utility>
#include <vector>

#include <GeographicLib/GeodesicLine.hpp>
#include <GeographicLib/Math.hpp>

#include "engine/culling.hpp"
#include "engine/engine_internal.hpp"
#include "engine/kernel_memory.hpp"
#include "geodesic/geodesic_interpolant.hpp"
#include "geodesic/geodesic_kernels.hpp"
#include "geodesic/geodesic_regime.hpp"
#include "rv/field/parallel.hpp"

// The solver's helpers split out of a hot loop for reading are inlined back into it: each is
// defined, and called, in one file only. (The solver's members have external linkage, so the
// compiler would not inline a helper called once as it did a file-local one.)
#define RV_GEO_INLINE __attribute__((always_inline)) inline

namespace rv::detail {

inline constexpr int64_t kGeoTile = 256;  // top-level tile edge, cells (tiles aligned to the grid; 128
                                          // before: 256 computes the same bits with a quarter of the
                                          // top-level lower bounds, all sites against each tile)
static_assert(kTileBand % kGeoTile == 0);
// Blocks with segments this small (or smaller) are leaves, solved by the row kernels or per cell.
// 16 x 16 rather than 8 x 8: a leaf's set-up (interpolants gathered, weights, one reduction per
// row and candidate) is spread over 4x the cells, for a few more candidates per cell (faster on
// coastlines: bench/RESULTS-kernels.md).
inline constexpr int64_t kLeafCells = 256;
inline constexpr int kProbes = 2;               // sites whose exact distance from a block's centre give U
inline constexpr size_t kDominanceMax = 24;     // leaves with more candidates skip drop_dominated (O(k^2))
inline constexpr size_t kDominators = 4;        // candidates tried as dominators by drop_dominated
inline constexpr double kChordReachSpan = 1.0;  // degrees: blocks up to this take reach_of's chord bound

// Projected geodesic grids: the located cell centres of the tile a worker is solving (cells
// are not separable into per-row latitudes and per-column longitudes there).
struct TileCells {
  int64_t c0 = 0, r0 = 0, w = 0;  // window-relative origin and width
  std::vector<double> lat, lon, x, y, z, rho;
};

// A candidate of point form over a block (drop_dominated): its index in the block's list, the
// ECEF point its distance is measured from, the largest chord from it to the block's box and
// the bound beta on geodesic / chord there.
struct Anchor {
  size_t index;
  double x, y, z, cmax, beta;
};

// The leaf a block's cull chose (GeodesicExactSolver::cull).
enum class LeafKind { interpolants, segments, cells };

struct GeoWorker {
  LeafKind leaf = LeafKind::cells;           // set by cull for solve_leaf
  std::vector<std::vector<int32_t>> levels;  // candidate lists per recursion depth
  std::vector<double> lb;
  std::vector<double> cell_lb;
  std::vector<Anchor> anchors;  // drop_dominated
  std::vector<const Interpolant*> interp;
  std::vector<const Interpolant*> slots;  // solve_cells: per candidate and end (value())
  std::vector<const GeoPiece*> pieces;    // solve_cells: per candidate, single pieces
  TileCells tile;                         // projected grids: the current tile's located centres
  // Interpolants looked up by the current tile: key = interpolation block (tile-relative) and
  // site; the entries they come from (SharedInterpolants) held until the tile is done.
  std::unordered_map<uint64_t, const Interpolant*> cache;
  std::vector<std::shared_ptr<SharedInterpolants::Entry>> held;
  // Row scratch of the kernels: cache-line aligned (kernel_memory.hpp).
  AlignedVector<double> best, second, value, cx, cy, cz;  // per column of the block's row
  AlignedVector<double> best_id;
  std::vector<RowCandidate> row_points,
      row_additive;                                    // solve_interp: the candidates on the current row
  std::vector<RowSegment> row_segments;                // ... those whose form changes in the block
  std::vector<RowMasked> row_masked;                   // ... those of them that one end's test decides
  std::vector<int32_t> masked;                         // gather_interpolants: those segments,
  std::vector<const Interpolant*> masked_interp;       // their interiors' interpolants
  std::vector<int> masked_near;                        // and the deciding end: 0 first, 1 second, 2 neither
  std::vector<size_t> masked_order;                    // solve_interp_rows: row_masked[i] is masked[masked_order[i]]
  std::vector<const Interpolant*> interp_additive;     // solve_interp: the additive interpolants
  std::vector<int32_t> interp_id, interp_additive_id;  // ... and the candidate each stands for
  std::vector<int32_t> changing;                       // ... the segments whose form changes
  std::vector<std::array<const Interpolant*, 3>> changing_interp;  // ... and their interpolants
  AlignedVector<int32_t> site_row;                                 // ... the row's results before they go out
  AlignedVector<float> distance_row;
  AlignedVector<double> force;  // ... per column: 1 where a cell needs the per-cell method
};

class GeodesicExactSolver {
 public:
  GeodesicExactSolver(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance);

  // The row kernels' column weights for every column of the window, weight b of window column c
  // at b * wstride_ + c: b = 0 .. 3 in the point form's interpolation block, 4 .. 7 in the
  // additive form's (weights_col's values). They depend on the column alone, so they are made
  // once here rather than per leaf. Zeros pad kRowPad past the last column: the kernels read
  // whole vectors.
  void init_column_weights(const Window& w);

  void init_separable(const Window& w);

  // The interpolation blocks of each form: the largest power of two (8 .. kPointMaxBlock or
  // kLineMaxBlock cells) spanning at most kPointSpan or kLineSpan degrees (projected grids: the
  // spans in metres, with the cell size measured on the ellipsoid at the grid's centre, so that
  // it does not depend on the window); coarser grids still get 8-cell blocks, which the centre
  // check rejects where inaccurate. The line block divides the point block (powers of two).
  void init_interp_block();

  void run();

  // The value the method takes for site `id` at window cell (c, r) of a geographic grid: the
  // interpolated one where an interpolant of the cell's regime serves (exact = false; additive,
  // if given, says which form), else the exact distance (exact = true). Metres. wk's interpolant
  // cache serves one tile at a time: clear wk.cache and wk.held before a cell of another tile.
  // For tests of the parts.
  double value_at(GeoWorker& wk, int64_t c, int64_t r, int32_t id, bool& exact, bool* additive = nullptr) const;

  // ---- The culling skeleton's policy (culling.hpp) ----
  using Worker = GeoWorker;
  static constexpr bool kInteriors = true;
  static constexpr int64_t kTile = kGeoTile;
  static constexpr int kDepths = 20;  // candidate lists per recursion depth
  // A tile's set-up: every site a candidate, the worker's interpolant cache emptied, shared
  // interpolants of finished tile rows dropped, projected grids' centres located.
  bool start_tile(GeoWorker& wk, const Block& t);
  bool empty(GeoWorker& wk, int depth, const Block&) const { return wk.levels[depth].empty(); }
  void solve_interior(GeoWorker& wk, int depth, const Block& b);
  // The candidates within the bound U + reach (kProbes exact probes from the block's centre, the
  // reach of reach_of) of the lower bounds; the leaf kind chosen (wk.leaf) and dominated
  // candidates of a leaf dropped.
  BlockStep cull(GeoWorker& wk, int depth, const Block& b);
  void solve_leaf(GeoWorker& wk, int depth, const Block& b);
  template <class F>
  void split(const Block& b, F&& f) const {
    split_aligned(ctx_.window, b, std::forward<F>(f));
  }
  void fill_none(const Block& b) { detail::fill_none(site_, distance_, b); }
  void workers_done(GeoWorker&) const {
    if (stream_) store_fence();  // this worker's non-temporal stores, before the join
  }

 private:
  // Projected grids: every cell centre of the tile, through the geolocator (one batch per row).
  void locate_tile(TileCells& t, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const;

  GeoCell cell_at(const GeoWorker& wk, int64_t c, int64_t r) const {
    if (located_) {
      const TileCells& t = wk.tile;
      const auto i = static_cast<size_t>((r - t.r0) * t.w + (c - t.c0));
      return GeoCell{t.lat[i], t.lon[i], t.x[i], t.y[i], t.z[i]};
    }
    return GeoCell{lat_[r], lon_[c], rho_[r] * cos_[c], rho_[r] * sin_[c], z_[r]};
  }

  // Projected grids: the ECEF box of a block's located centres, and the largest parallel radius
  // and longitude / latitude offsets from cell (cc, rc), by visiting every cell.
  EcefBox located_box(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const;
  double located_reach(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1, int64_t cc,
                       int64_t rc) const;

  // ECEF box of the cell centres of a block: x = rho cos(lon), y = rho sin(lon), z; interval
  // products over the block's rows and columns contain every centre.
  EcefBox box_of(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const;

  // Upper bound of the geodesic distance from cell (cc, rc) to any cell of the block: along the
  // cell's parallel (radius rho <= the block's largest) to the centre's meridian, then along
  // that meridian (radius of curvature <= max_meridian_radius). On blocks up to kChordReachSpan
  // degrees a second bound, from the longest chord, is usually a quarter tighter, and the
  // smaller of the two is taken: the plane through both points and the ellipsoid's normal at the
  // centre cell cuts the ellipsoid in an ellipse whose curvature is at most 1 / rho with rho =
  // b^2 / a (an ellipse's least radius of curvature is B^2 / A, and every such plane section has
  // B >= b, A <= a, shrunk by at most 1e-5 where the plane misses the centre: reach_rho_ takes
  // 0.99 of it), so the arc between them, a path on the ellipsoid no shorter than the geodesic,
  // is at most 2 rho asin(chord / (2 rho)) long (Schur: a curve whose curvature is at most a
  // circle's has no longer arc over the same chord). The longest chord from the centre cell is
  // to a corner: along a parallel the chord grows with the longitude difference, and along a
  // meridian arc of under a degree its square is convex (its second derivative along the arc is
  // 2 (1 + (P - C) . P'') >= 2 (1 - |P - C| / M_min) > 0).
  double reach_of(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1, int64_t cc, int64_t rc) const;

  // Drops from `cands` (a leaf's candidates) every candidate of point form over the block that
  // another of point form beats by more than kGeoSlack at every cell of the block, so that the
  // row kernels and the interpolants skip it. Point form: a point site, or a segment certainly
  // nearest at one end over the block (block_regime), whose distance is then that vertex's.
  //
  // Why it is exact. For a candidate j of point form at S_j, d_j(P) >= |P - S_j| (the chord). For
  // i at S_i, d_i(P) <= beta_i |P - S_i|, beta_i = (2 rho / c) asin(c / (2 rho)) at the largest
  // chord c from S_i to the block's ECEF box: the plane through P, S_i and the Earth's centre
  // cuts the ellipsoid in an ellipse of semi-axes a and B >= b, whose curvature is at most
  // a / b^2 = 1 / rho, and over that chord such an arc is no longer than a circle's of radius
  // rho (Schur); reach_rho_ takes 0.99 of it. So d_j - d_i > M = kGeoSlack wherever
  // |P - S_j|^2 - beta_i^2 |P - S_i|^2 > 2 beta_i M c + M^2. The left side is a concave
  // quadratic of P (beta_i >= 1), so its least value over the box is at one of the box's eight
  // corners, which hold every cell centre of the block. A candidate dropped that way is never
  // the nearest, never within kInterpTie of it (kGeoSlack is 10x that, far beyond the
  // interpolants' error), nor a lower id at distance 0 in a polygon (solve_zero): the cells get
  // the bits they would get with it. A dominator may be dropped itself later: whatever beats it
  // beats the other by more still. Up to kDominators of the candidates with the shortest
  // largest chords are tried as dominators of every other.
  RV_GEO_INLINE void drop_dominated(GeoWorker& wk, std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                                    int64_t r1) const;

  // An upper bound of the distance from window cell (c, r), centred at p, to site `id`: its
  // interpolated value plus kInterpTie (interpolants are within ~1e-8 m, checked to
  // kInterpCheck) where it has one, else the exact distance. Cheap where the block's
  // interpolants exist, which the cells will use anyway.
  double probe_distance(GeoWorker& wk, int64_t c, int64_t r, const GeoCell& p, int32_t id) const;

  // ---- Interpolated distances (see the top of this file) ----

  // The interpolant of site `id` (`end` says which part) on the grid-aligned interpolation
  // block that contains window cell (c, r), or null where it is rejected (the caller then
  // measures exactly).
  // `end`: 0 for a point site, 1 / 2 for a segment's first / second end, 3 for its interior.
  const Interpolant* interpolant(GeoWorker& wk, int64_t c, int64_t r, int32_t id, int end = 0) const;

  // Node positions: grid-relative fractional rows/columns at 0, 1/3, 2/3, 1 of the block's
  // first to last cell centre.
  static double node_at(int64_t first, int64_t last, double t) {
    return static_cast<double>(first) + static_cast<double>(last - first) * t;
  }
  GeoCell cell_at_fraction(double gcol, double grow) const;

  bool build_interpolant(Interpolant& it, int64_t bx0, int64_t by0, int64_t bx1, int64_t by1, int32_t id,
                         int end) const;

  // The interior of a segment: d_line(P), the distance to the edge's geodesic extended beyond
  // both ends (far enough that every node's nearest point is inside). Where the cell's nearest
  // point of the edge is inside it (segment_regime 3) that is the segment's distance.
  // With h(P) the signed distance to the plane through the chord and the mean of the ends'
  // normals, d_line carrying the sign of h is the signed distance to the curve, a smooth
  // function across it, and so is its difference from the linear h: that difference
  // (millimetres near the edge, O(x^3 / R^2) away from it) is interpolated, and the value is
  // |h + q|. A node's side is the geodesic's own (the sign of sin w where the search found the
  // nearest point, GeoEnd::sin_w), not the plane's: the geodesic leaves the plane by up to
  // metres along long edges, so the plane could put a node on the wrong side of it. (A ratio
  // d_line / distance to the chord line, as for points, has a pole next to the edge, where the
  // two vanish on slightly different curves; measured on the geodesic_bench coastlines, its
  // worst error offshore was 1e-5 m against 7.6e-9 m for this form, which also reaches across
  // the edge.)
  bool build_line_interpolant(Interpolant& it, int64_t bx0, int64_t by0, int64_t bx1, int64_t by1, int32_t id) const;

  // Weights of window cell column c / row r inside the interpolation block of S cells holding
  // them.
  // (S is a power of two: the block's first cell is a mask away, not a division.)
  void weights_col(int64_t c, int64_t S, double w[4]) const {
    const int64_t gc = ctx_.window.col0 + c, b0 = gc & ~(S - 1);
    const int64_t b1 = std::min(b0 + S, ctx_.grid.width) - 1;
    cubic_weights(static_cast<double>(gc - b0) / static_cast<double>(b1 - b0), w);
  }
  void weights_row(int64_t r, int64_t S, double w[4]) const {
    const int64_t gr = ctx_.window.row0 + r, b0 = gr & ~(S - 1);
    const int64_t b1 = std::min(b0 + S, ctx_.grid.height) - 1;
    cubic_weights(static_cast<double>(gr - b0) / static_cast<double>(b1 - b0), w);
  }

  // Both forms' weights of row r, and of column c (into wc, lc).
  void cell_weights_row(int64_t r, CellWeights& cw) const {
    const double* w = &wrows_[static_cast<size_t>(8 * r)];
    std::memcpy(cw.wt, w, sizeof(cw.wt));
    std::memcpy(cw.lt, w + 4, sizeof(cw.lt));
  }
  void cell_weights_col(int64_t c, double wc[4], double lc[4]) const {
    weights_col(c, point_block_, wc);
    weights_col(c, line_block_, lc);
  }

  // Which part of site `id` is nearest from p (SegmentRegimes::at; uncertain, the index of the
  // point form, for a point site).
  Regime regime_of(const GeoCell& p, int32_t id) const {
    return geo_.site(id).segment ? regimes_.at(p, id) : Regime::uncertain;
  }

  // The value the method uses for candidate `id` at cell (c, r), whose centre is p and regime
  // regime_of(p, id): the interpolated distance where the site has an interpolant on the cell's
  // block (a point site; a segment's end or interior, as the regime says), else the exact
  // distance. `exact` says which.
  // `from` (optional) receives the interpolant used, null for an exact value.
  // `canonical` (optional): the value stands for brute force's bits of a vertex distance shared
  // by the edges meeting there (at_vertex), so equal values of two such edges are a tie.
  // `cell` (optional): the cell's interpolation weights, computed once for all candidates;
  // `slots` (optional): the candidate's interpolants by `end` (0..3) in the caller's leaf block
  // (one interpolation block), kNotLooked until looked up, which saves the cache's hashing.
  RV_GEO_INLINE double value(GeoWorker& wk, int64_t c, int64_t r, const GeoCell& p, int32_t id, Regime regime,
                             bool& exact, const Interpolant** from = nullptr, bool* canonical = nullptr,
                             const CellWeights* cell = nullptr, const Interpolant** slots = nullptr) const;

  // A close call between interpolated values: the exact distances of every candidate whose
  // value is within kInterpTie of the best decide, with brute force's rule (lowest id on ties).
  void resolve_exactly(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c, int64_t r, double best);

  // A leaf block of sites of any kind: its interpolants where the candidates that can win
  // certainly keep one form over the whole block (gather_interpolants), else cell by cell
  // (solve_cells).
  void solve_segment_leaf(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                          int64_t r1);

  // wk.interp / wk.interp_additive: the interpolants of the candidates over the block (which
  // lies in one interpolation block), each once; wk.changing: the segments whose form is not
  // certain over the block (block_regime; an edge's interior within kAdditiveMinValue of the
  // block), with all three of their interpolants, chosen per cell. False when a point site or
  // a segment of certain form has no interpolant there.
  // Two edges measuring the vertex they share use one interpolant: the same bits, a tie that
  // the per-cell method gives to the lower id without a close call; keeping the first
  // (candidates ascend) does the same.
  bool gather_interpolants(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                           int64_t r1);

  // The distinct vertex interpolant `it` measures for candidate `id` (ends 1, 2), or -1.
  double tag_of(const Interpolant* it, int32_t id) const {
    if (!it || it->additive || !geo_.site(id).segment) return -1.0;
    for (int e = 0; e < 2; ++e) {
      const SegmentEnd& v = regimes_.end(id, e);
      if (v.lat == it->lat && v.lon == it->lon) return static_cast<double>(v.vertex);
    }
    return -1.0;
  }

  // A block inside one interpolation block whose candidates are all point sites.
  void solve_interp(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1, int64_t r1);

  // Every cell of the block from the interpolants gathered (gather_interpolants), a row at a
  // time; cells whose call may be close are then solved by the per-cell method, so every cell
  // gets what solve_cells would give it.
  void solve_interp_rows(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                         int64_t r1);

  // solve_interp_rows' stages. rows_setup: the gathered candidates' row structures, what stays
  // the same on every row of the block; km counts the masked interiors by deciding end; true
  // when the points' kernel (interp_argmin_points) can do the rows alone.
  bool rows_setup(GeoWorker& wk, int km[3]) const;
  // Row r's cells [c0, c0 + n) as the kernels read them: located centres in wk (projected
  // grids) or the row's and columns' trigonometry (geographic ones).
  RV_GEO_INLINE RowPositions row_positions(GeoWorker& wk, int64_t r, int64_t c0, int64_t n) const;
  // Each candidate's interpolant reduced to the row of weights rw (eval()'s row step).
  RV_GEO_INLINE void reduce_to_row(GeoWorker& wk, const CellWeights& rw, const RowPositions& pos) const;
  // The cells of row r the kernels flagged (wk.second != 0), solved by the per-cell method (or
  // solve_zero inside polygons); the per-cell set-up is made at the leaf's first such cell.
  struct FlaggedCells {
    bool ready = false, one_block = false;
  };
  void solve_flagged_row(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                         int64_t r1, int64_t r, FlaggedCells& state);

  void fill_none(int64_t c0, int64_t r0, int64_t c1, int64_t r1) { fill_none(Block{c0, r0, c1, r1, 0}); }

  // True when every cell of the block has its centre inside a polygon (one span per row).
  bool fully_interior(int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
    return detail::fully_interior(ctx_, Block{c0, r0, c1, r1, 0});
  }

  // A block inside polygons: per cell the lowest of `cands` at distance exactly 0 (as the
  // float32 written, which apply_interiors compares), else no site; apply_interiors does the
  // rest, exactly as after brute force.
  // Large blocks are split first, each part keeping the candidates that touch its own box: a
  // polygon's interior block touched at one corner by a coastline edge then costs a few boxes,
  // not a lower bound per cell. (Both filters are lower bounds of the distance, so a candidate
  // dropped cannot be at distance 0 in that part.)
  void solve_zero(const GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                  int64_t r1);

  void put(int64_t c, int64_t r, int32_t id, double d) {
    const bool none = id == kNoSite || d > max_distance_;
    site_.row(r)[c] = none ? kNoSite : id;
    distance_.row(r)[c] = none ? kNoDistance : static_cast<float>(d);
  }

  // Per-cell argmin over `cands` (ascending ids): ties keep the lowest id. Point sites use their
  // interpolated value where they have one (so a cell gets the same value whichever path solves
  // it), segments their exact distance; a close call involving an interpolated value is decided
  // by exact distances (resolve_exactly).
  void solve_cells(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1, int64_t r1);

  // Whether the cells [c0, c1) x [r0, r1) lie in one interpolation block of each form (in one
  // line block is in one point block: the line block divides the point block), so that a
  // candidate's interpolants are the same for all of them.
  bool in_one_line_block(int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
    const int64_t S = line_block_, gx = ctx_.window.col0, gy = ctx_.window.row0;
    return (gx + c0) / S == (gx + c1 - 1) / S && (gy + r0) / S == (gy + r1 - 1) / S;
  }

  // The per-cell method's scratch for `cands` (non-empty): interpolant slots per candidate and
  // end when the cells to solve lie in one interpolation block (one_block), looked up once for
  // all of them, and each candidate's single piece. solve_cells_row then solves any of those
  // cells.
  void cells_setup(GeoWorker& wk, const std::vector<int32_t>& cands, bool one_block) const;

  // Cells [c0, c1) of row r by the per-cell method, after cells_setup(wk, cands, one_block).
  void solve_cells_row(GeoWorker& wk, const std::vector<int32_t>& cands, bool one_block, int64_t r, int64_t c0,
                       int64_t c1);

  // solve_cells_row's parts. The row kernels' column weights of window column c into cw.wc and
  // cw.lc (init_column_weights).
  RV_GEO_INLINE void column_weights(int64_t c, CellWeights& cw) const;
  // A lower bound of candidate cands[i]'s distance at p, metres (cells_setup's pieces).
  RV_GEO_INLINE double cell_bound(const GeoWorker& wk, const std::vector<int32_t>& cands, const GeoCell& p,
                                  size_t i) const;
  // The nearest of `cands` at cell (c, r), centre p: its distance, id and index in cands, and
  // whether the call is close (exact distances must decide it: resolve_exactly). cands[first]
  // is measured first; wk.cell_lb holds the candidates' lower bounds, each plus the travel
  // when it was made, refreshed here when `stale` (further along the row by `travel`).
  struct CellCall {
    double best;
    int32_t id;
    size_t index;
    bool close;
  };
  RV_GEO_INLINE CellCall call_cell(GeoWorker& wk, const std::vector<int32_t>& cands, bool one_block, const GeoCell& p,
                                   int64_t c, int64_t r, const CellWeights& cw, size_t first, bool stale,
                                   double travel);

  const EngineContext& ctx_;
  const GeoSites& geo_;
  Raster<int32_t>& site_;
  Raster<float>& distance_;
  std::vector<double> lat_, rho_, z_;  // per window row
  std::vector<double> lon_;
  AlignedVector<double> cos_, sin_;  // per window column (loaded as vectors by the row kernels)
  AlignedVector<double> wcols_;      // per window column: its eight weights (init_column_weights)
  std::vector<double> wrows_;        // per window row: its eight weights (cell_weights_row)
  int64_t wstride_ = 0;
  double max_distance_ = std::numeric_limits<double>::infinity();
  bool stream_ = false;                    // rows of the row kernels go out with non-temporal stores (put_row)
  int64_t point_block_ = kInterpMinBlock;  // interpolation block edges, cells (grid-aligned):
  int64_t line_block_ = kInterpMinBlock;   // the point form's and the additive form's
  mutable SharedInterpolants shared_;      // the interpolants built so far (any worker)
  bool located_ = false;                   // projected grid: cells located by ctx.geolocator
  double reach_rho_ = 0.0;                 // reach_of: 0.99 b^2 / a, metres
  SegmentRegimes regimes_;                 // the segments' ends and their regimes
};

}  // namespace rv::detail
