// The exact method for the geodesic metric: hierarchical block culling with provably safe
// bounds (geodesic_sites.hpp), then a per-cell argmin over the candidates left.
//
// Why the owners are exact. For a block B of cells, C one of its cells and R(B) an upper bound
// of the geodesic distance from C to any cell of B (the parallel-then-meridian path length),
// every cell P of B has d(P, nearest) <= d(P, s') <= d(C, s') + R(B) =: U for any site s'
// (triangle inequality). A site s can be nearest anywhere in B only if its chord lower bound to
// B's ECEF box is <= U. Sites are dropped only when the lower bound exceeds min(U, max_distance)
// + kGeoSlack (slack covering rounding and GeographicLib's 15 nm), so the site brute force picks
// is never dropped. Per cell, a candidate is measured only if its lower bound does not exceed
// the best value so far plus the slack. Values are exact distances (GeoSites::distance, as brute
// force computes them) or interpolated ones (below) within ~1e-8 m of them; any comparison
// closer than kInterpTie = 1e-4 m that involves an interpolated value is redone with exact
// distances of every candidate within kInterpTie of the best, with brute force's tie rule
// (lower site index). So the owners equal brute force's cell for cell, and the distances equal
// them to the last bit of the float32 written (one unit in the last place at most).
//
// Why it is fast. A geodesic inverse problem costs thousands of flops, so the method avoids them.
//  - Interpolation: for a point p (a point site, or a segment's end where the segment is
//    certainly nearest at that end), q(P) = d(P, p) / |E(P) - E(p)| (geodesic distance over the
//    ECEF chord) is a very smooth function of the cell position -- it tends to 1 + O(d^2/R^2) at
//    p and varies only with the ellipsoid's flattening elsewhere -- so a bicubic interpolant from
//    16 exact inverse problems on a grid-aligned block reproduces it closely. Measured (bicubic
//    fits of q on blocks at latitudes 0 .. 88, points 0 .. 11 900 km away in 8 directions, 33 x 33
//    cells checked per block): worst error 8.6e-8 m on blocks of 0.128 deg, 4.4e-6 m on blocks
//    of 0.35 deg (above 1e-6 m only for points beyond 10 000 km; 1.7e-11 of the distance at
//    most, far below the float32 written), against kInterpTie = 1e-4 m; 32 cells of 0.05 deg
//    (1.6 deg): 5e-4 m. Point-form blocks are therefore up to 0.35 deg (512 cells; 4 tiles,
//    which share them across threads: SharedInterpolants). For cells certainly nearest at an
//    interior point of an edge, the signed distance to the edge's geodesic (extended beyond its
//    ends) minus a cubic of the signed distance to a plane through the edge (normaliser()) is
//    interpolated the same way (additive form, build_line_interpolant: smooth across the edge)
//    on its own blocks of up to 0.21 deg (512 cells): the extended edge must stay one piece.
//    Worst error measured (9 x 9 cells per block, every block of geodesic_bench's coastlines and
//    of the Oresund fixture at 0.00015 .. 0.0004 deg): 4.0e-9 m on blocks of 0.077 deg, 1.1e-8 m
//    on 0.154 deg, 2.4e-8 m on 0.195 deg, 3.1e-8 m on 0.205 deg (with the plane's distance alone,
//    as before the cubic term: 6.1e-9, 6.1e-8, 1.6e-7, 1.9e-7 m); values under kAdditiveMinValue
//    (2 m, where a float32's last place is 2.4e-7 m, 7x the worst) are measured exactly. Its
//    nodes are measured with LineFoot (one inverse problem each).
//    A cell's value then costs a few tens of flops per candidate.
//    Guards: the blocks' spans are limited (kPointSpan, kLineSpan; in metres on projected
//    grids); every interpolant is checked against an exact value at the block's centre and
//    rejected when off by more than kInterpCheck = 5e-6 m (the worst centre error measured above
//    is 2.5e-6 m: the check catches a fit that breaks, it does not bound the error by itself),
//    the additive form's by more than kInterpCheckAdditive = 6e-8 m;
//    nodes near the antipode (d > kInterpMaxDistance), on the point itself, or an extended edge
//    nearest at its ends reject it too. Rejected interpolants leave those cells to exact
//    distances.
//  - Which part of a segment is nearest is decided per cell from ECEF vectors (segment_regime):
//    the normal section's direction at the vertex stands in for the geodesic's, with a margin
//    (RV_GEO_BEYOND) that covers their difference and brute force's stopping test. Only cells
//    within that margin of a switch between an end and the interior are measured exactly. Two
//    edges sharing a vertex that both measure it (beyond the margin) are a tie (lower id): brute
//    force's search certainly returns the canonical vertex distance for both (RV_GEO_BEYOND).
//  - Row kernels: a leaf block whose candidates all have interpolants there is solved a row
//    at a time, four cells per vector, every candidate passing while the running best, second
//    and id stay in registers, on squared values (one root per cell: point-form values are
//    root(q^2 chord^2) on every path). Point-site leaves always; leaves with segments on fine
//    grids (kLeafKernelMinBlock), where a segment of certain form over the leaf (block_regime:
//    the per-cell test settled from the leaf's centre and radius) uses one interpolant and one
//    whose form changes inside it gets segment_regime's test per cell in the kernel; where only
//    one end's test can change its form over the leaf (RowMasked), the edge is its interior
//    masked by that test plus that vertex as a point candidate of its own, which costs about
//    half as much per cell (most such edges on coastlines: bench/RESULTS-geodesic.md). Dominated
//    candidates are dropped first (drop_dominated). Cells
//    the kernels cannot settle (a possible close call, a regime measured exactly, a value
//    under kAdditiveMinValue) go through the per-cell method, so every cell gets that method's
//    bits whichever path solves it.
//  - Blocks, tiles and interpolation blocks are aligned to the grid, not to the window, so any
//    window and any thread count computes the same bits as the whole grid (the basis of the
//    streamed strips and of tiles computed apart).
//  - Projected grids (ctx.geolocator): cell centres are located tile by tile in one batch per
//    row; boxes and reach come from the located centres instead of separable rows and columns.
// Blocks are independent and taken dynamically by threads.
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

#include "engine_internal.hpp"
#include "geodesic_interpolant.hpp"
#include "geodesic_kernels.hpp"
#include "geodesic_regime.hpp"
#include "kernel_memory.hpp"
#include "rv/parallel.hpp"

namespace rv::detail {
namespace {

constexpr int64_t kTile = 256;  // top-level tile edge, cells (tiles aligned to the grid; 128
                                // before: 256 computes the same bits with a quarter of the
                                // top-level lower bounds, all sites against each tile)
// Blocks with segments this small (or smaller) are leaves, solved by the row kernels or per cell.
// 16 x 16 rather than 8 x 8: a leaf's set-up (interpolants gathered, weights, one reduction per
// row and candidate) is spread over 4x the cells, for a few more candidates per cell (faster on
// coastlines: bench/RESULTS-kernels.md).
constexpr int64_t kLeafCells = 256;
constexpr int kProbes = 2;               // sites whose exact distance from a block's centre give U
constexpr size_t kDominanceMax = 24;     // leaves with more candidates skip drop_dominated (O(k^2))
constexpr size_t kDominators = 4;        // candidates tried as dominators by drop_dominated
constexpr double kChordReachSpan = 1.0;  // degrees: blocks up to this take reach_of's chord bound

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

struct GeoWorker {
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

// The distance from a point to a geodesic line (the extended edge of an additive interpolant,
// between its ends a and b), for the interpolants' nodes: one inverse problem per point instead
// of GeoSites::distance's search (~1.75 of them, each with a position on the line).
//
// The foot of the point on the line is taken from a cubic model of the line in ECEF (through
// its positions at 0, 1/3, 2/3 and 1 of its length, at most ~2e-4 m off the line over 100 km:
// the cubic interpolation error of an arc of radius R, L^4 / (24 R^3) x 0.012), where the
// point's chord to the model is least (Newton's method on the model). The geodesic foot lies
// within c f (c / R)^2 of that (~1e-4 m at c = 10 km: the chord's minimiser moves only with the
// ellipsoid's departure from a sphere), so the distance from the line point there, minus the
// second-order excess of the convex distance, m12 cos^2 w / (2 M12) (the value the search's
// Newton step heads for), is the minimum to far below the nodes' needs: within 3.5e-9 m of
// the search on every node of the Oresund fixture at 0.0002 .. 0.002 deg and of the synthetic
// coastlines, GeographicLib's own ~1e-8 m. `side` gets sin w there, as GeoEnd::sin_w.
// Thread safety: const after construction.
class LineFoot {
 public:
  LineFoot(const GeoSites& geo, const Site& line)
      : geod_(geo.geodesic()),
        line_(geod_.InverseLine(line.a.y, line.a.x, line.b.y, line.b.x,
                                GeographicLib::Geodesic::LATITUDE | GeographicLib::Geodesic::LONGITUDE |
                                    GeographicLib::Geodesic::AZIMUTH | GeographicLib::Geodesic::DISTANCE_IN)),
        length_(line_.Distance()) {
    for (int k = 0; k < 4; ++k) {
      double lat, lon, azi;
      line_.Position(length_ * k / 3.0, lat, lon, azi);
      geo.ecef(lat, lon, x_[k][0], x_[k][1], x_[k][2]);
    }
  }

  // The distance d from p to the line and sin w at its foot; false where the foot is not
  // inside the line (nearest at an end) or the line's geometry there is unusable.
  bool distance(const GeoCell& p, double& d, double& sin_w) const {
    const double ux = x_[3][0] - x_[0][0], uy = x_[3][1] - x_[0][1], uz = x_[3][2] - x_[0][2];
    const double len2 = ux * ux + uy * uy + uz * uz;
    if (!(len2 > 0.0)) return false;
    double u = ((p.x - x_[0][0]) * ux + (p.y - x_[0][1]) * uy + (p.z - x_[0][2]) * uz) / len2;
    for (int iter = 0; iter < 8; ++iter) {
      // The model X(u) = sum w_k(u) x_k (Lagrange weights at 0, 1/3, 2/3, 1), X' and X''.
      const double a = u, b = u - 1.0 / 3.0, c = u - 2.0 / 3.0, e = u - 1.0;
      const double w0[4] = {-4.5 * b * c * e, 13.5 * a * c * e, -13.5 * a * b * e, 4.5 * a * b * c};
      const double w1[4] = {-4.5 * (c * e + b * e + b * c), 13.5 * (c * e + a * e + a * c),
                            -13.5 * (b * e + a * e + a * b), 4.5 * (b * c + a * c + a * b)};
      const double w2[4] = {-9.0 * (b + c + e), 27.0 * (a + c + e), -27.0 * (a + b + e), 9.0 * (a + b + c)};
      double x[3] = {0.0, 0.0, 0.0}, d1[3] = {0.0, 0.0, 0.0}, d2[3] = {0.0, 0.0, 0.0};
      for (int k = 0; k < 4; ++k)
        for (int q = 0; q < 3; ++q) {
          x[q] += w0[k] * x_[k][q];
          d1[q] += w1[k] * x_[k][q];
          d2[q] += w2[k] * x_[k][q];
        }
      const double dx = x[0] - p.x, dy = x[1] - p.y, dz = x[2] - p.z;
      const double g = dx * d1[0] + dy * d1[1] + dz * d1[2];
      const double slope = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2] + dx * d2[0] + dy * d2[1] + dz * d2[2];
      if (!(slope > 0.0)) return false;
      const double step = g / slope;
      u -= step;
      if (std::abs(step) * length_ < 1e-7) break;
    }
    if (!(u > 1e-6 && u < 1.0 - 1e-6)) return false;
    double lat, lon, azi;
    line_.Position(u * length_, lat, lon, azi);
    double s12, azi1, azi2, m12, big_m12, big_m21;
    geod_.Inverse(lat, lon, p.lat, p.lon, s12, azi1, azi2, m12, big_m12, big_m21);
    if (!(m12 > 0.0 && big_m12 > 0.0)) return false;
    double cos_w;
    GeographicLib::Math::sincosd(GeographicLib::Math::AngDiff(azi, azi1), sin_w, cos_w);
    d = s12 - m12 * cos_w * cos_w / (2.0 * big_m12);
    return true;
  }

 private:
  const GeographicLib::Geodesic& geod_;
  GeographicLib::GeodesicLine line_;
  double length_;
  double x_[4][3];  // ECEF of the line at 0, 1/3, 2/3, 1 of its length
};

class GeodesicExactSolver {
 public:
  GeodesicExactSolver(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance)
      : ctx_(ctx),
        geo_(*ctx.geo),
        site_(site),
        distance_(distance),
        located_(ctx.geolocator != nullptr),
        regimes_(*ctx.geo) {
    using GeographicLib::Math;
    const Window& w = ctx.window;
    if (!located_) init_separable(w);
    max_distance_ = ctx.max_key;  // geodesic keys are metres
    {
      const double a = geo_.geodesic().EquatorialRadius(), f = geo_.geodesic().Flattening();
      const double b = a * (1.0 - f);
      reach_rho_ = 0.99 * std::min(a, b) * std::min(a, b) / std::max(a, b);
    }
    stream_ = streams_results(w);
    init_interp_block();
    init_column_weights(w);
  }

  // The row kernels' column weights for every column of the window, weight b of window column c
  // at b * wstride_ + c: b = 0 .. 3 in the point form's interpolation block, 4 .. 7 in the
  // additive form's (weights_col's values). They depend on the column alone, so they are made
  // once here rather than per leaf. Zeros pad kRowPad past the last column: the kernels read
  // whole vectors.
  void init_column_weights(const Window& w) {
    // (And each row's, eight per row: cell_weights_row.)
    wrows_.resize(static_cast<size_t>(8 * w.height));
    for (int64_t r = 0; r < w.height; ++r) {
      weights_row(r, point_block_, &wrows_[static_cast<size_t>(8 * r)]);
      weights_row(r, line_block_, &wrows_[static_cast<size_t>(8 * r + 4)]);
    }
    wstride_ = (w.width + 2 * kRowPad - 1) / kRowPad * kRowPad;
    wcols_.assign(static_cast<size_t>(8 * wstride_), 0.0);
    for (int64_t c = 0; c < w.width; ++c) {
      double pw[4], lw[4];
      weights_col(c, point_block_, pw);
      weights_col(c, line_block_, lw);
      for (int b = 0; b < 4; ++b) {
        wcols_[static_cast<size_t>(b * wstride_ + c)] = pw[b];
        wcols_[static_cast<size_t>((4 + b) * wstride_ + c)] = lw[b];
      }
    }
  }

  void init_separable(const Window& w) {
    using GeographicLib::Math;
    lat_.resize(static_cast<size_t>(w.height));
    rho_.resize(lat_.size());
    z_.resize(lat_.size());
    for (int64_t r = 0; r < w.height; ++r) {
      const double lat = ctx_.grid.centre_y(w.row0 + r);
      double x, y, z;
      geo_.ecef(lat, 0.0, x, y, z);  // at longitude 0: x = the parallel's radius
      lat_[r] = lat;
      rho_[r] = x;
      z_[r] = z;
    }
    lon_.resize(static_cast<size_t>(w.width));
    // Padded to whole vectors of the row kernels, which read up to kRowPad - 1 past the end
    // (lanes never written out).
    cos_.assign(lon_.size() + kRowPad, 0.0);
    sin_.assign(lon_.size() + kRowPad, 0.0);
    for (int64_t c = 0; c < w.width; ++c) {
      lon_[c] = ctx_.grid.centre_x(w.col0 + c);
      Math::sincosd(lon_[c], sin_[c], cos_[c]);
    }
  }

  // The interpolation blocks of each form: the largest power of two (8 .. kPointMaxBlock or
  // kLineMaxBlock cells) spanning at most kPointSpan or kLineSpan degrees (projected grids: the
  // spans in metres, with the cell size measured on the ellipsoid at the grid's centre, so that
  // it does not depend on the window); coarser grids still get 8-cell blocks, which the centre
  // check rejects where inaccurate. The line block divides the point block (powers of two).
  void init_interp_block() {
    const GridSpec& g = ctx_.grid;
    double cell = g.res;
    if (located_) {
      const int64_t cc = std::min<int64_t>(g.width / 2, std::max<int64_t>(g.width - 2, 0)), rc = g.height / 2;
      const GeoCell a = cell_at_fraction(static_cast<double>(cc), static_cast<double>(rc));
      const GeoCell b = cell_at_fraction(static_cast<double>(cc) + 1.0, static_cast<double>(rc));
      double d;
      geo_.geodesic().Inverse(a.lat, a.lon, b.lat, b.lon, d);
      cell = d;
    }
    auto block = [&](int64_t most, double span_degrees, double span_metres) {
      const double limit = located_ ? span_metres : span_degrees;
      int64_t b = kInterpMinBlock;
      while (b * 2 <= most && static_cast<double>(b * 2) * cell <= limit) b *= 2;
      return b;
    };
    point_block_ = block(kPointMaxBlock, kPointSpan, kPointSpanMetres);
    line_block_ = block(kLineMaxBlock, kLineSpan, kLineSpanMetres);
  }

  void run() {
    const Window& w = ctx_.window;
    // Tiles (and every block inside them) are aligned to the grid, not to the window, so that
    // the interpolation blocks -- hence the computed bits -- do not depend on the window.
    const int64_t tx0 = w.col0 / kTile, tx1 = (w.col0 + w.width - 1) / kTile;
    const int64_t ty0 = w.row0 / kTile, ty1 = (w.row0 + w.height - 1) / kTile;
    const int64_t ntx = tx1 - tx0 + 1, nty = ty1 - ty0 + 1;
    std::vector<GeoWorker> workers(static_cast<size_t>(ctx_.threads));
    parallel_for(
        ctx_.threads, ntx * nty,
        [&](int64_t t, int worker) {
          GeoWorker& wk = workers[static_cast<size_t>(worker)];
          if (wk.levels.empty()) wk.levels.resize(20);
          const int64_t gx = (tx0 + t % ntx) * kTile, gy = (ty0 + t / ntx) * kTile;
          const int64_t c0 = std::max<int64_t>(gx - w.col0, 0), c1 = std::min(gx + kTile - w.col0, w.width);
          const int64_t r0 = std::max<int64_t>(gy - w.row0, 0), r1 = std::min(gy + kTile - w.row0, w.height);
          wk.levels[0] = ctx_.geometric;
          wk.cache.clear();
          wk.held.clear();
          // Tiles start in row order: blocks ending a tile row and more above this one are done
          // with (a straggler still needing one would only build it again).
          shared_.drop_rows_before(gy - kTile - point_block_);
          if (located_) locate_tile(wk.tile, c0, r0, c1, r1);
          solve_block(wk, 0, kTile, c0, r0, c1, r1);
          ctx_.progress->advance((c1 - c0) * (r1 - r0));
        },
        [&](int) {
          if (stream_) store_fence();  // this worker's non-temporal stores, before the join
        });
  }

 private:
  // Projected grids: every cell centre of the tile, through the geolocator (one batch per row).
  void locate_tile(TileCells& t, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
    const Window& w = ctx_.window;
    t.c0 = c0;
    t.r0 = r0;
    t.w = c1 - c0;
    const auto n = static_cast<size_t>(t.w * (r1 - r0));
    for (auto* v : {&t.lat, &t.lon, &t.x, &t.y, &t.z, &t.rho}) v->resize(n);
    std::vector<double> gx(static_cast<size_t>(t.w)), gy(static_cast<size_t>(t.w));
    for (int64_t r = r0; r < r1; ++r) {
      for (int64_t c = c0; c < c1; ++c) {
        gx[static_cast<size_t>(c - c0)] = ctx_.grid.centre_x(w.col0 + c);
        gy[static_cast<size_t>(c - c0)] = ctx_.grid.centre_y(w.row0 + r);
      }
      const size_t at = static_cast<size_t>((r - r0) * t.w);
      locate_centres(*ctx_.geolocator, gx.data(), gy.data(), &t.lon[at], &t.lat[at], static_cast<size_t>(t.w));
      for (size_t i = at; i < at + static_cast<size_t>(t.w); ++i) {
        geo_.ecef(t.lat[i], t.lon[i], t.x[i], t.y[i], t.z[i]);
        t.rho[i] = std::hypot(t.x[i], t.y[i]);
      }
    }
  }

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
  EcefBox located_box(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
    const TileCells& t = wk.tile;
    const double inf = std::numeric_limits<double>::infinity();
    EcefBox b{inf, -inf, inf, -inf, inf, -inf};
    for (int64_t r = r0; r < r1; ++r)
      for (int64_t c = c0; c < c1; ++c) {
        const auto i = static_cast<size_t>((r - t.r0) * t.w + (c - t.c0));
        b.x0 = std::min(b.x0, t.x[i]);
        b.x1 = std::max(b.x1, t.x[i]);
        b.y0 = std::min(b.y0, t.y[i]);
        b.y1 = std::max(b.y1, t.y[i]);
        b.z0 = std::min(b.z0, t.z[i]);
        b.z1 = std::max(b.z1, t.z[i]);
      }
    return b;
  }
  double located_reach(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1, int64_t cc,
                       int64_t rc) const {
    const TileCells& t = wk.tile;
    const auto ic = static_cast<size_t>((rc - t.r0) * t.w + (cc - t.c0));
    double rmax = 0.0, dlon = 0.0, dlat = 0.0;
    for (int64_t r = r0; r < r1; ++r)
      for (int64_t c = c0; c < c1; ++c) {
        const auto i = static_cast<size_t>((r - t.r0) * t.w + (c - t.c0));
        rmax = std::max(rmax, t.rho[i]);
        dlon = std::max(dlon, std::abs(GeographicLib::Math::AngDiff(t.lon[ic], t.lon[i])));
        dlat = std::max(dlat, std::abs(t.lat[i] - t.lat[ic]));
      }
    constexpr double kRad = 3.14159265358979323846 / 180.0;
    return (rmax * dlon * kRad + geo_.max_meridian_radius() * dlat * kRad) * (1.0 + 1e-12);
  }

  // ECEF box of the cell centres of a block: x = rho cos(lon), y = rho sin(lon), z; interval
  // products over the block's rows and columns contain every centre.
  EcefBox box_of(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
    if (located_) return located_box(wk, c0, r0, c1, r1);
    double rmin = rho_[r0], rmax = rho_[r0];
    for (int64_t r = r0 + 1; r < r1; ++r) {
      rmin = std::min(rmin, rho_[r]);
      rmax = std::max(rmax, rho_[r]);
    }
    double cmin = cos_[c0], cmax = cos_[c0], smin = sin_[c0], smax = sin_[c0];
    for (int64_t c = c0 + 1; c < c1; ++c) {
      cmin = std::min(cmin, cos_[c]);
      cmax = std::max(cmax, cos_[c]);
      smin = std::min(smin, sin_[c]);
      smax = std::max(smax, sin_[c]);
    }
    auto product = [&](double lo, double hi, double& out_lo, double& out_hi) {
      const double p[4] = {rmin * lo, rmin * hi, rmax * lo, rmax * hi};
      out_lo = std::min({p[0], p[1], p[2], p[3]});
      out_hi = std::max({p[0], p[1], p[2], p[3]});
    };
    EcefBox b;
    product(cmin, cmax, b.x0, b.x1);
    product(smin, smax, b.y0, b.y1);
    b.z0 = std::min(z_[r0], z_[r1 - 1]);  // z is monotone in latitude
    b.z1 = std::max(z_[r0], z_[r1 - 1]);
    return b;
  }

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
  double reach_of(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1, int64_t cc, int64_t rc) const {
    if (located_) return located_reach(wk, c0, r0, c1, r1, cc, rc);
    double rmax = 0.0;
    for (int64_t r = r0; r < r1; ++r) rmax = std::max(rmax, rho_[r]);
    constexpr double kRad = 3.14159265358979323846 / 180.0;
    const double dlon = std::max(lon_[cc] - lon_[c0], lon_[c1 - 1] - lon_[cc]) * kRad;
    const double dlat = std::max(lat_[r0] - lat_[rc], lat_[rc] - lat_[r1 - 1]) * kRad;
    const double path = (rmax * dlon + geo_.max_meridian_radius() * dlat) * (1.0 + 1e-12);
    const double span = static_cast<double>(std::max(c1 - c0, r1 - r0)) * ctx_.grid.res;
    if (!(span <= kChordReachSpan)) return path;
    const GeoCell centre = cell_at(wk, cc, rc);
    double c2 = 0.0;
    for (const int64_t c : {c0, c1 - 1})
      for (const int64_t r : {r0, r1 - 1}) {
        const GeoCell p = cell_at(wk, c, r);
        const double dx = p.x - centre.x, dy = p.y - centre.y, dz = p.z - centre.z;
        c2 = std::max(c2, dx * dx + dy * dy + dz * dz);
      }
    const double chord = std::sqrt(c2) * (1.0 + 1e-12) + 1e-9;
    const double arc = 2.0 * reach_rho_ * std::asin(std::min(1.0, chord / (2.0 * reach_rho_)));
    return std::min(path, arc * (1.0 + 1e-12) + 1e-9);
  }

  void solve_block(GeoWorker& wk, int depth, int64_t level, int64_t c0, int64_t r0, int64_t c1, int64_t r1) {
    const std::vector<int32_t>& cands = wk.levels[depth];
    if (cands.empty()) return fill_none(c0, r0, c1, r1);
    std::vector<int32_t>& next = wk.levels[depth + 1];
    if (fully_interior(c0, r0, c1, r1)) {
      // Every cell ends at distance 0 with its polygon's area site (apply_interiors); what is
      // left to find is a lower site at distance exactly 0 there, which only sites touching
      // the block (lower bound within kGeoSlack) can be.
      const EcefBox box = box_of(wk, c0, r0, c1, r1);
      next.clear();
      for (int32_t id : cands)
        if (geo_.lower_bound(box, id) <= kGeoSlack) next.push_back(id);
      return solve_zero(wk, next, c0, r0, c1, r1);
    }
    const bool bounded = std::isfinite(max_distance_);
    if (cands.size() > 1 || bounded) {
      const EcefBox box = box_of(wk, c0, r0, c1, r1);
      wk.lb.resize(cands.size());
      // The kProbes candidates with the smallest lower bounds give the upper bound U.
      int32_t probe[kProbes];
      double probe_lb[kProbes];
      for (int k = 0; k < kProbes; ++k) {
        probe[k] = -1;
        probe_lb[k] = std::numeric_limits<double>::infinity();
      }
      const BoxBall ball = box_ball(box);
      for (size_t i = 0; i < cands.size(); ++i) {
        const double lb = geo_.lower_bound(box, ball, cands[i]);
        wk.lb[i] = lb;
        for (int k = 0; k < kProbes; ++k) {
          if (lb < probe_lb[k]) {
            for (int j = kProbes - 1; j > k; --j) {
              probe_lb[j] = probe_lb[j - 1];
              probe[j] = probe[j - 1];
            }
            probe_lb[k] = lb;
            probe[k] = static_cast<int32_t>(i);
            break;
          }
        }
      }
      double bound = max_distance_;
      if (cands.size() > 1) {
        const int64_t cc = c0 + (c1 - c0) / 2, rc = r0 + (r1 - r0) / 2;
        const GeoCell centre = cell_at(wk, cc, rc);
        double upper = std::numeric_limits<double>::infinity();
        for (int k = 0; k < kProbes; ++k)
          if (probe[k] >= 0)
            upper = std::min(upper, probe_distance(wk, cc, rc, centre, cands[static_cast<size_t>(probe[k])]));
        bound = std::min(bound, upper + reach_of(wk, c0, r0, c1, r1, cc, rc));
      }
      bound += kGeoSlack;
      next.clear();
      for (size_t i = 0; i < cands.size(); ++i)
        if (wk.lb[i] <= bound) next.push_back(cands[i]);
    } else {
      next = cands;
    }
    const int64_t w = c1 - c0, h = r1 - r0;
    bool points_only = true;
    for (int32_t id : next) points_only = points_only && !geo_.site(id).segment;
    const bool can_split = level > 1 && depth + 2 < static_cast<int>(wk.levels.size());
    const bool interp_leaf = points_only && level <= std::min(point_block_, kInterpSolveBlock) &&
                             (next.size() <= kInterpMaxCandidates || !can_split || level <= kInterpMinBlock);
    const bool segment_leaf = !points_only && (next.size() <= 1 || w * h <= kLeafCells);
    if ((interp_leaf || segment_leaf || !can_split) && next.size() >= 2 && next.size() <= kDominanceMax)
      drop_dominated(wk, next, c0, r0, c1, r1);
    if (interp_leaf) return solve_interp(wk, next, c0, r0, c1, r1);
    if (segment_leaf) return solve_leaf(wk, next, c0, r0, c1, r1);
    if (!can_split) return solve_cells(wk, next, c0, r0, c1, r1);
    // Split at the grid-aligned middle of the block's level.
    const Window& win = ctx_.window;
    const int64_t half = level / 2;
    const int64_t cm = std::clamp(((win.col0 + c0) / level) * level + half - win.col0, c0, c1);
    const int64_t rm = std::clamp(((win.row0 + r0) / level) * level + half - win.row0, r0, r1);
    const int64_t xs[3] = {c0, cm, c1}, ys[3] = {r0, rm, r1};
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i)
        if (xs[i] < xs[i + 1] && ys[j] < ys[j + 1])
          solve_block(wk, depth + 1, half, xs[i], ys[j], xs[i + 1], ys[j + 1]);
  }

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
  void drop_dominated(GeoWorker& wk, std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                      int64_t r1) const {
    const EcefBox box = box_of(wk, c0, r0, c1, r1);
    const double mx = 0.5 * (box.x0 + box.x1), my = 0.5 * (box.y0 + box.y1), mz = 0.5 * (box.z0 + box.z1);
    const double hx = 0.5 * (box.x1 - box.x0), hy = 0.5 * (box.y1 - box.y0), hz = 0.5 * (box.z1 - box.z0);
    const double radius = std::sqrt(hx * hx + hy * hy + hz * hz) * (1.0 + 1e-12) + 1e-9;
    const double corner[8][3] = {{box.x0, box.y0, box.z0}, {box.x1, box.y0, box.z0}, {box.x0, box.y1, box.z0},
                                 {box.x1, box.y1, box.z0}, {box.x0, box.y0, box.z1}, {box.x1, box.y0, box.z1},
                                 {box.x0, box.y1, box.z1}, {box.x1, box.y1, box.z1}};
    const size_t k = cands.size();
    wk.anchors.clear();
    for (size_t i = 0; i < k; ++i) {
      const int32_t id = cands[i];
      const GeoSite& site = geo_.site(id);
      Anchor a{i, 0.0, 0.0, 0.0, 0.0, 0.0};
      if (!site.segment) {
        a.x = site.x;
        a.y = site.y;
        a.z = site.z;
      } else {
        const Regime regime = regimes_.over_block(mx, my, mz, radius, id).certain;
        if (!at_vertex(regime)) continue;
        const SegmentEnd& v = regimes_.end(id, end_of(regime));
        a.x = v.x;
        a.y = v.y;
        a.z = v.z;
      }
      double c2 = 0.0;
      for (const auto& b : corner)
        c2 = std::max(c2, (b[0] - a.x) * (b[0] - a.x) + (b[1] - a.y) * (b[1] - a.y) + (b[2] - a.z) * (b[2] - a.z));
      a.cmax = std::sqrt(c2) * (1.0 + 1e-12) + 1e-9;
      a.beta = a.cmax < 2.0 * reach_rho_
                   ? (2.0 * reach_rho_ / a.cmax) * std::asin(a.cmax / (2.0 * reach_rho_)) * (1.0 + 1e-12)
                   : std::numeric_limits<double>::infinity();
      wk.anchors.push_back(a);
    }
    if (wk.anchors.size() < 2) return;
    // The dominators: the anchors with the shortest largest chords.
    const size_t nd = std::min(kDominators, wk.anchors.size());
    std::partial_sort(wk.anchors.begin(), wk.anchors.begin() + static_cast<std::ptrdiff_t>(nd), wk.anchors.end(),
                      [](const Anchor& u, const Anchor& v) { return u.cmax < v.cmax; });
    constexpr double m = kGeoSlack;
    bool any = false;
    for (const Anchor& j : wk.anchors) {
      for (size_t t = 0; t < nd; ++t) {
        const Anchor& i = wk.anchors[t];
        if (i.index == j.index || !std::isfinite(i.beta)) continue;
        const double b2 = i.beta * i.beta, need = 2.0 * i.beta * m * i.cmax + m * m;
        double least = std::numeric_limits<double>::infinity();
        for (const auto& b : corner) {
          const double dj = (b[0] - j.x) * (b[0] - j.x) + (b[1] - j.y) * (b[1] - j.y) + (b[2] - j.z) * (b[2] - j.z);
          const double di = (b[0] - i.x) * (b[0] - i.x) + (b[1] - i.y) * (b[1] - i.y) + (b[2] - i.z) * (b[2] - i.z);
          // (1e-14 of the squares covers their rounding, ~1e-16 each.)
          least = std::min(least, dj - b2 * di - 1e-14 * (dj + b2 * di));
        }
        if (least > need) {
          cands[j.index] = -1;
          any = true;
          break;
        }
      }
    }
    if (any) cands.erase(std::remove(cands.begin(), cands.end(), -1), cands.end());
  }

  // An upper bound of the distance from window cell (c, r), centred at p, to site `id`: its
  // interpolated value plus kInterpTie (interpolants are within ~1e-8 m, checked to
  // kInterpCheck) where it has one, else the exact distance. Cheap where the block's
  // interpolants exist, which the cells will use anyway.
  double probe_distance(GeoWorker& wk, int64_t c, int64_t r, const GeoCell& p, int32_t id) const {
    bool exact = false;
    const double v = value(wk, c, r, p, id, regime_of(p, id), exact);
    return exact ? v : v + kInterpTie;
  }

  // ---- Interpolated distances (see the top of this file) ----

  // The interpolant of site `id` (`end` says which part) on the grid-aligned interpolation
  // block that contains window cell (c, r), or null where it is rejected (the caller then
  // measures exactly).
  // `end`: 0 for a point site, 1 / 2 for a segment's first / second end, 3 for its interior.
  const Interpolant* interpolant(GeoWorker& wk, int64_t c, int64_t r, int32_t id, int end = 0) const {
    const int64_t S = end == 3 ? line_block_ : point_block_;
    const int64_t gc = ctx_.window.col0 + c, gr = ctx_.window.row0 + r;
    const int64_t bx0 = (gc / S) * S, by0 = (gr / S) * S;
    // Edges meeting at a vertex measure it with one interpolant (same nodes, same bits): the
    // key names the distinct vertex for ends (kind 1), the site for points (0) and interiors (3).
    const bool vertex = end == 1 || end == 2;
    const int32_t who = vertex ? regimes_.end(id, end - 1).vertex : id;
    const uint64_t key = (static_cast<uint64_t>((by0 % kTile) / S * (kTile / S) + (bx0 % kTile) / S) << 34) |
                         (static_cast<uint64_t>(static_cast<uint32_t>(who)) << 2) |
                         static_cast<uint64_t>(vertex ? 1 : end);
    auto it = wk.cache.find(key);
    if (it != wk.cache.end()) return it->second;
    std::shared_ptr<SharedInterpolants::Entry> e = shared_.entry(bx0, by0, who, vertex ? 1 : end);
    std::call_once(e->built, [&] {
      auto made = std::make_unique<Interpolant>();
      if (build_interpolant(*made, bx0, by0, std::min(bx0 + S, ctx_.grid.width), std::min(by0 + S, ctx_.grid.height),
                            id, end))
        e->it = std::move(made);
    });
    const Interpolant* got = e->it.get();
    wk.held.push_back(std::move(e));
    return wk.cache.emplace(key, got).first->second;
  }

  // Node positions: grid-relative fractional rows/columns at 0, 1/3, 2/3, 1 of the block's
  // first to last cell centre.
  static double node_at(int64_t first, int64_t last, double t) {
    return static_cast<double>(first) + static_cast<double>(last - first) * t;
  }
  GeoCell cell_at_fraction(double gcol, double grow) const {
    const GridSpec& g = ctx_.grid;
    const double x = g.xmin + (gcol + 0.5) * g.res, y = g.ymax - (grow + 0.5) * g.res;
    if (!located_) return geo_.cell(x, y);
    double lon, lat;
    locate_centres(*ctx_.geolocator, &x, &y, &lon, &lat, 1);
    return geo_.cell(lon, lat);
  }

  bool build_interpolant(Interpolant& it, int64_t bx0, int64_t by0, int64_t bx1, int64_t by1, int32_t id,
                         int end) const {
    if (bx1 - bx0 < kInterpMinEdge || by1 - by0 < kInterpMinEdge) return false;
    const GeoSite& s = geo_.site(id);
    it.id = id;
    if (end == 3) return build_line_interpolant(it, bx0, by0, bx1, by1, id);
    if (end == 0) {
      it.lat = s.lat;
      it.lon = s.lon;
    } else {
      const SegmentEnd& v = regimes_.end(id, end - 1);
      it.lat = v.lat;
      it.lon = v.lon;
    }
    geo_.ecef(it.lat, it.lon, it.sx, it.sy, it.sz);
    const GeographicLib::Geodesic& geod = geo_.geodesic();
    // The exact distance at p: the point site's own (GeoSites::distance), or the inverse problem
    // from the segment's end, which is the segment's distance wherever it is nearest at that end.
    auto exact = [&](const GeoCell& p) {
      if (end == 0) return geo_.distance(p, id);
      double d;
      geod.Inverse(it.lat, it.lon, p.lat, p.lon, d);
      return d;
    };
    auto value = [&](const GeoCell& p, double& q) {
      const double d = exact(p);
      const double dx = p.x - it.sx, dy = p.y - it.sy, dz = p.z - it.sz;
      const double chord = std::sqrt(dx * dx + dy * dy + dz * dz);
      if (!(d <= kInterpMaxDistance) || !(chord >= kInterpMinChord)) return false;
      q = d / chord;
      return true;
    };
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        if (!value(cell_at_fraction(node_at(bx0, bx1 - 1, b / 3.0), node_at(by0, by1 - 1, a / 3.0)), it.q[a][b]))
          return false;
    // The check: the exact distance at the block's centre (not a node) against the interpolant.
    const GeoCell centre = cell_at_fraction(node_at(bx0, bx1 - 1, 0.5), node_at(by0, by1 - 1, 0.5));
    double wt[4], wc[4];
    cubic_weights(0.5, wt);
    cubic_weights(0.5, wc);
    const double dx = centre.x - it.sx, dy = centre.y - it.sy, dz = centre.z - it.sz;
    const double approx = eval(it, wt, wc) * std::sqrt(dx * dx + dy * dy + dz * dz);
    return std::abs(approx - exact(centre)) <= kInterpCheck;
  }

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
  bool build_line_interpolant(Interpolant& it, int64_t bx0, int64_t by0, int64_t bx1, int64_t by1, int32_t id) const {
    const GeoSite& s = geo_.site(id);
    const SegmentEnd& va = regimes_.end(id, 0);
    const SegmentEnd& vb = regimes_.end(id, 1);
    const double ux = vb.x - va.x, uy = vb.y - va.y, uz = vb.z - va.z;
    const double len = std::sqrt(ux * ux + uy * uy + uz * uz);
    if (!(len >= 1.0)) return false;
    it.additive = true;
    it.lat = s.lat;
    it.lon = s.lon;
    it.sx = va.x;
    it.sy = va.y;
    it.sz = va.z;
    {
      const double mx = va.nx + vb.nx, my = va.ny + vb.ny, mz = va.nz + vb.nz;
      const double px = uy * mz - uz * my, py = uz * mx - ux * mz, pz = ux * my - uy * mx;
      const double pn = std::sqrt(px * px + py * py + pz * pz);
      it.nx = px / pn;
      it.ny = py / pn;
      it.nz = pz / pn;
    }
    {
      // R: the normal section's radius across the edge (azimuth + 90 degrees) at its middle
      // latitude, 1 / R = cos^2(a) / M + sin^2(a) / N.
      using GeographicLib::Math;
      const double a = geo_.geodesic().EquatorialRadius(), f = geo_.geodesic().Flattening();
      const double e2 = f * (2.0 - f);
      double sp, cp, sa, ca;
      Math::sincosd(0.5 * (s.lat + s.lat_b), sp, cp);
      Math::sincosd(s.azi_a + 90.0, sa, ca);
      const double w2 = 1.0 - e2 * sp * sp;
      const double n_radius = a / std::sqrt(w2), m_radius = a * (1.0 - e2) / (w2 * std::sqrt(w2));
      const double inv = ca * ca / m_radius + sa * sa / n_radius;
      it.k3 = inv * inv / 6.0;
    }
    // The extension: a cell of the block whose nearest point is inside the edge has every other
    // cell of the block within the block's diagonal d (its corners' chord, 1.25 d covering
    // chord vs arc) of it, so their nearest points of the extended line lie within that of the
    // edge; 1 km more for good measure. A node nearest at an end of the extension rejects the
    // interpolant anyway.
    const GeoCell c00 = cell_at_fraction(static_cast<double>(bx0), static_cast<double>(by0));
    const GeoCell c11 = cell_at_fraction(static_cast<double>(bx1 - 1), static_cast<double>(by1 - 1));
    const GeoCell c01 = cell_at_fraction(static_cast<double>(bx1 - 1), static_cast<double>(by0));
    const GeoCell c10 = cell_at_fraction(static_cast<double>(bx0), static_cast<double>(by1 - 1));
    auto chord = [](const GeoCell& a, const GeoCell& b) {
      return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
    };
    const double diag = std::max(chord(c00, c11), chord(c01, c10));
    const double ext = 1.25 * diag + 1000.0;
    if (!(ext < 0.45 * kGeoPieceLength)) return false;
    const GeographicLib::Geodesic& geod = geo_.geodesic();
    Site extended;
    extended.kind = SiteKind::segment;
    extended.feature = 0;
    double lat, lon;
    geod.Direct(s.lat, s.lon, s.azi_a + 180.0, ext, lat, lon);
    extended.a = Vec2{lon, lat};
    geod.Direct(s.lat_b, s.lon_b, s.azi_b, ext, lat, lon);
    extended.b = Vec2{lon, lat};
    MetricSpec m;
    m.kind = MetricSpec::geodesic;
    m.semi_major = geod.EquatorialRadius();
    m.flattening = geod.Flattening();
    const GeoSites line(m, std::vector<Site>{extended});
    bool ok = true;
    double side = 0.0;  // the last node's: > 0 right of the edge, < 0 left (GeoEnd::sin_w)
    // The check at the block's centre measures with brute force's search on the extended line.
    auto exact = [&](const GeoCell& p) {
      GeoEnd end;
      const double d = line.distance(p, 0, &end);
      if (end.valid) ok = false;  // nearest at an end of the extension: not the line's distance
      side = end.sin_w;
      return d;
    };
    // The nodes with one inverse problem each instead of the search's ~1.75 (LineFoot).
    const LineFoot foot(geo_, extended);
    auto node = [&](const GeoCell& p) {
      double d;
      if (!foot.distance(p, d, side)) ok = false;
      return d;
    };
    for (int a = 0; a < 4 && ok; ++a)
      for (int b = 0; b < 4 && ok; ++b) {
        const GeoCell p = cell_at_fraction(node_at(bx0, bx1 - 1, b / 3.0), node_at(by0, by1 - 1, a / 3.0));
        const double d = node(p);
        if (!ok) return false;
        const double h = normaliser(it, p.x, p.y, p.z);
        // The side comes from the geodesic itself: the direction to the node at its nearest
        // point is square to the edge, sin w = +-1. A node on the line (d below a millimetre)
        // or not square to it (an unconverged search) rejects the block.
        if (!(d <= kInterpMaxDistance) || !(d >= kInterpMinChord) || !(std::abs(side) >= 0.5)) return false;
        it.q[a][b] = (side > 0.0 ? d : -d) - h;
      }
    if (!ok) return false;
    const GeoCell centre = cell_at_fraction(node_at(bx0, bx1 - 1, 0.5), node_at(by0, by1 - 1, 0.5));
    double wt[4], wc[4];
    cubic_weights(0.5, wt);
    cubic_weights(0.5, wc);
    const double approx = apply(it, eval(it, wt, wc), centre.x, centre.y, centre.z);
    const double want = exact(centre);
    return ok && std::abs(approx - want) <= kInterpCheckAdditive;
  }

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
  double value(GeoWorker& wk, int64_t c, int64_t r, const GeoCell& p, int32_t id, Regime regime, bool& exact,
               const Interpolant** from = nullptr, bool* canonical = nullptr, const CellWeights* cell = nullptr,
               const Interpolant** slots = nullptr) const {
    if (from) *from = nullptr;
    if (canonical) *canonical = at_vertex(regime);
    // The regime is interpolant()'s `end`: uncertain a point site's point form (a segment's is
    // measured exactly).
    if (!geo_.site(id).segment || regime != Regime::uncertain) {
      const int end = index_of(regime);
      const Interpolant* it;
      if (slots) {
        if (slots[end] == &kNotLooked) slots[end] = interpolant(wk, c, r, id, end);
        it = slots[end];
      } else {
        it = interpolant(wk, c, r, id, end);
      }
      if (it) {
        CellWeights own;
        if (!cell) {
          cell_weights_row(r, own);
          cell_weights_col(c, own.wc, own.lc);
          cell = &own;
        }
        const double v = it->additive ? apply(*it, eval(*it, cell->lt, cell->lc), p.x, p.y, p.z)
                                      : apply(*it, eval(*it, cell->wt, cell->wc), p.x, p.y, p.z);
        // The additive form's error is absolute (up to ~3e-8 m): within kAdditiveMinValue of the
        // edge it could reach the last bit of the float32 written, so those few cells are
        // measured exactly.
        if (!it->additive || v >= kAdditiveMinValue) {
          exact = false;
          if (from) *from = it;
          return v;
        }
      }
    }
    exact = true;
    return geo_.distance(p, id);
  }

  // A close call between interpolated values: the exact distances of every candidate whose
  // value is within kInterpTie of the best decide, with brute force's rule (lowest id on ties).
  void resolve_exactly(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c, int64_t r, double best) {
    const GeoCell p = cell_at(wk, c, r);
    double d_best = std::numeric_limits<double>::infinity();
    int32_t id_best = kNoSite;
    for (int32_t id : cands) {
      bool exact = false;
      if (geo_.lower_bound(p, id) > best + kGeoSlack ||
          value(wk, c, r, p, id, regime_of(p, id), exact) > best + kInterpTie)
        continue;
      const double d = geo_.distance(p, id);
      if (d < d_best || (d == d_best && id < id_best)) {
        d_best = d;
        id_best = id;
      }
    }
    put(c, r, id_best, d_best);
  }

  // A leaf block of sites of any kind: its interpolants where the candidates that can win
  // certainly keep one form over the whole block (gather_interpolants), else cell by cell
  // (solve_cells).
  void solve_leaf(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1, int64_t r1) {
    // (In one line block is in one point block: the line block divides the point block.)
    const int64_t S = line_block_, gx = ctx_.window.col0, gy = ctx_.window.row0;
    const bool one_block = (gx + c0) / S == (gx + c1 - 1) / S && (gy + r0) / S == (gy + r1 - 1) / S;
    if (S < kLeafKernelMinBlock || cands.empty() || !one_block || cands.size() > kInterpMaxCandidates ||
        !gather_interpolants(wk, cands, c0, r0, c1, r1))
      return solve_cells(wk, cands, c0, r0, c1, r1);
    solve_interp_rows(wk, cands, c0, r0, c1, r1);
  }

  // wk.interp / wk.interp_additive: the interpolants of the candidates over the block (which
  // lies in one interpolation block), each once; wk.changing: the segments whose form is not
  // certain over the block (block_regime; an edge's interior within kAdditiveMinValue of the
  // block), with all three of their interpolants, chosen per cell. False when a point site or
  // a segment of certain form has no interpolant there.
  // Two edges measuring the vertex they share use one interpolant: the same bits, a tie that
  // the per-cell method gives to the lower id without a close call; keeping the first
  // (candidates ascend) does the same.
  bool gather_interpolants(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                           int64_t r1) {
    wk.interp.clear();
    wk.interp_additive.clear();
    wk.interp_id.clear();
    wk.interp_additive_id.clear();
    wk.changing.clear();
    wk.changing_interp.clear();
    wk.masked.clear();
    wk.masked_interp.clear();
    wk.masked_near.clear();
    // The middle of the block's ECEF box and a radius holding every cell centre of the block
    // (the box's half diagonal, grown for rounding).
    bool have_box = false;
    EcefBox box{};
    double mx = 0.0, my = 0.0, mz = 0.0, radius = 0.0;
    auto the_box = [&]() {
      if (have_box) return;
      box = box_of(wk, c0, r0, c1, r1);
      mx = 0.5 * (box.x0 + box.x1);
      my = 0.5 * (box.y0 + box.y1);
      mz = 0.5 * (box.z0 + box.z1);
      const double hx = 0.5 * (box.x1 - box.x0), hy = 0.5 * (box.y1 - box.y0), hz = 0.5 * (box.z1 - box.z0);
      radius = std::sqrt(hx * hx + hy * hy + hz * hz) * (1.0 + 1e-12) + 1e-9;
      have_box = true;
    };
    for (int32_t id : cands) {
      Regime regime = Regime::uncertain;
      if (geo_.site(id).segment) {
        the_box();
        const BlockRegime br = regimes_.over_block(mx, my, mz, radius, id);
        regime = br.certain;
        // value() measures additive values under kAdditiveMinValue exactly; none may be here.
        if (regime == Regime::interior) {
          const GeoPiece* piece = geo_.single_piece(id);
          const double lb = piece ? piece_capsule_bound(*piece, mx, my, mz) - radius : geo_.lower_bound(box, id);
          if (!(lb > kAdditiveMinValue + kGeoSlack)) regime = Regime::uncertain;
        }
        if (regime == Regime::uncertain) {
          // One end's test settles the cell's form where the other end's is settled over the
          // block (or neither's is needed: inside everywhere, only near the edge): the
          // interior masked by it, and that end's vertex as a point candidate of its own.
          int near = -1;
          if (br.possible == (1u | 4u) && br.before_b)
            near = 0;
          else if (br.possible == (2u | 4u) && br.ahead_a)
            near = 1;
          else if (br.possible == 4u && br.ahead_a && br.before_b)
            near = 2;
          if (near >= 0) {
            if (near < 2) {
              const Interpolant* vt = interpolant(wk, c0, r0, id, near + 1);
              if (!vt) return false;
              if (std::find(wk.interp.begin(), wk.interp.end(), vt) == wk.interp.end()) {
                wk.interp.push_back(vt);
                wk.interp_id.push_back(id);
              }
            }
            wk.masked.push_back(id);
            wk.masked_interp.push_back(interpolant(wk, c0, r0, id, 3));
            wk.masked_near.push_back(near);
            continue;
          }
          // Only the forms some cell may take are built (interpolants cost 17 inverse
          // problems); a cell that takes another is forced to the per-cell method.
          wk.changing.push_back(id);
          wk.changing_interp.push_back({(br.possible & 1u) ? interpolant(wk, c0, r0, id, 1) : nullptr,
                                        (br.possible & 2u) ? interpolant(wk, c0, r0, id, 2) : nullptr,
                                        (br.possible & 4u) ? interpolant(wk, c0, r0, id, 3) : nullptr});
          continue;
        }
      }
      const Interpolant* it = interpolant(wk, c0, r0, id, index_of(regime));
      if (!it) return false;
      // (An interpolant shared by a vertex's edges carries the id of the edge that built it:
      // the candidate's own id is kept beside it.)
      auto& list = it->additive ? wk.interp_additive : wk.interp;
      if (std::find(list.begin(), list.end(), it) != list.end()) continue;
      list.push_back(it);
      (it->additive ? wk.interp_additive_id : wk.interp_id).push_back(id);
    }
    return true;
  }

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
  void solve_interp(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1, int64_t r1) {
    if (cands.empty()) return fill_none(c0, r0, c1, r1);
    if (!gather_interpolants(wk, cands, c0, r0, c1, r1)) return solve_cells(wk, cands, c0, r0, c1, r1);
    solve_interp_rows(wk, cands, c0, r0, c1, r1);
  }

  // Every cell of the block from the interpolants gathered (gather_interpolants), a row at a
  // time; cells whose call may be close are then solved by the per-cell method, so every cell
  // gets what solve_cells would give it.
  void solve_interp_rows(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                         int64_t r1) {
    const int64_t n = c1 - c0;
    const int64_t stride = (n + kRowPad - 1) / kRowPad * kRowPad;  // padded: whole vectors
    const double* wcols = &wcols_[static_cast<size_t>(c0)];        // the window's (init_column_weights)
    wk.site_row.resize(static_cast<size_t>(stride));
    wk.distance_row.resize(static_cast<size_t>(stride));
    // The kernels write every lane of their outputs before anything reads them; the located
    // positions are read in the padding lanes too, so those start at zero.
    for (auto* v : {&wk.best, &wk.second, &wk.value, &wk.best_id, &wk.force}) v->resize(static_cast<size_t>(stride));
    for (auto* v : {&wk.cx, &wk.cy, &wk.cz}) v->assign(static_cast<size_t>(stride), 0.0);
    // What stays the same on every row; the rows fill in qr.
    auto fixed_part = [&](const Interpolant* it, int32_t id, RowCandidate& rc) {
      rc = RowCandidate{{0.0, 0.0, 0.0, 0.0}, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, static_cast<double>(id),
                        tag_of(it, id),       0.0, 0.0};
      if (!it) return;  // a form without an interpolant: its cells are forced to the per-cell method
      rc.sx = it->sx;
      rc.sy = it->sy;
      rc.sz = it->sz;
      rc.nx = it->nx;
      rc.ny = it->ny;
      rc.nz = it->nz;
      rc.k3 = it->k3;
    };
    wk.row_points.resize(wk.interp.size());
    wk.row_additive.resize(wk.interp_additive.size());
    wk.row_segments.resize(wk.changing.size());
    for (size_t j = 0; j < wk.interp.size(); ++j) fixed_part(wk.interp[j], wk.interp_id[j], wk.row_points[j]);
    for (size_t j = 0; j < wk.interp_additive.size(); ++j)
      fixed_part(wk.interp_additive[j], wk.interp_additive_id[j], wk.row_additive[j]);
    for (size_t j = 0; j < wk.changing.size(); ++j) {
      RowSegment& g = wk.row_segments[j];
      for (size_t k = 0; k < 3; ++k) fixed_part(wk.changing_interp[j][k], wk.changing[j], g.part[k]);
      for (int e = 0; e < 2; ++e) {
        const SegmentEnd& v = regimes_.end(wk.changing[j], e);
        const double src[9] = {v.x, v.y, v.z, v.nx, v.ny, v.nz, v.ex, v.ey, v.ez};
        std::memcpy(g.end[e], src, sizeof(src));
      }
      for (int k = 0; k < 3; ++k) g.has[k] = wk.changing_interp[j][static_cast<size_t>(k)] ? 1.0 : 0.0;
    }
    // The masked interiors, grouped by their deciding end (km).
    int km[3] = {0, 0, 0};
    wk.row_masked.resize(wk.masked.size());
    wk.masked_order.clear();
    for (int grp = 0; grp < 3; ++grp)
      for (size_t j = 0; j < wk.masked.size(); ++j)
        if (wk.masked_near[j] == grp) {
          const size_t i = wk.masked_order.size();
          wk.masked_order.push_back(j);
          ++km[grp];
          RowMasked& g = wk.row_masked[i];
          fixed_part(wk.masked_interp[j], wk.masked[j], g.part);
          g.has = wk.masked_interp[j] ? 1.0 : 0.0;
          if (grp < 2) {
            const SegmentEnd& v = regimes_.end(wk.masked[j], grp);
            const double src[9] = {v.x, v.y, v.z, v.nx, v.ny, v.nz, v.ex, v.ey, v.ez};
            std::memcpy(g.end, src, sizeof(src));
          }
        }
    // A vertex's tag only matters against a segment whose form changes in the block and that
    // measures the same vertex (the points are distinct interpolants: gather_interpolants keeps
    // one per vertex): the others are taken as plain points, which the points' kernel can do
    // when nothing else is left (the same results: with distinct tags, equal values are a close
    // call either way).
    for (RowCandidate& rc : wk.row_points) {
      if (rc.tag < 0.0) continue;
      bool shared = false;
      for (int32_t id : wk.changing)
        for (int e = 0; e < 2; ++e) shared = shared || static_cast<double>(regimes_.end(id, e).vertex) == rc.tag;
      if (!shared) rc.tag = -1.0;
    }
    // interp_argmin_points can do the row alone.
    bool plain = wk.row_additive.empty() && wk.row_segments.empty() && wk.row_masked.empty();
    bool cells_ready = false, one_block = false;  // the per-cell method's set-up (flagged cells)
    for (const RowCandidate& rc : wk.row_points) plain = plain && rc.tag < 0.0;
    for (int64_t r = r0; r < r1; ++r) {
      CellWeights rw;
      cell_weights_row(r, rw);
      RowPositions pos;
      if (located_) {
        for (int64_t c = 0; c < n; ++c) {
          const GeoCell p = cell_at(wk, c0 + c, r);
          wk.cx[static_cast<size_t>(c)] = p.x;
          wk.cy[static_cast<size_t>(c)] = p.y;
          wk.cz[static_cast<size_t>(c)] = p.z;
        }
        pos.x = wk.cx.data();
        pos.y = wk.cy.data();
        pos.z_of = wk.cz.data();
      } else {
        pos.cos_lon = &cos_[static_cast<size_t>(c0)];
        pos.sin_lon = &sin_[static_cast<size_t>(c0)];
        pos.rho = rho_[static_cast<size_t>(r)];
        pos.z = z_[static_cast<size_t>(r)];
      }
      // eval()'s row step, the same operations in the same order.
      auto reduce = [&](const Interpolant* it, RowCandidate& rc) {
        if (!it) return;
        const double* wt = it->additive ? rw.lt : rw.wt;
        for (int b = 0; b < 4; ++b)
          rc.qr[b] = wt[0] * it->q[0][b] + wt[1] * it->q[1][b] + wt[2] * it->q[2][b] + wt[3] * it->q[3][b];
      };
      for (size_t j = 0; j < wk.interp.size(); ++j) {
        reduce(wk.interp[j], wk.row_points[j]);
        if (located_) continue;  // (dz2 serves geographic rows only)
        const double dz = pos.z - wk.row_points[j].sz;
        wk.row_points[j].dz2 = dz * dz;
      }
      for (size_t j = 0; j < wk.interp_additive.size(); ++j) reduce(wk.interp_additive[j], wk.row_additive[j]);
      for (size_t i = 0; i < wk.masked_order.size(); ++i)
        reduce(wk.masked_interp[wk.masked_order[i]], wk.row_masked[i].part);
      for (size_t j = 0; j < wk.changing.size(); ++j)
        for (size_t k = 0; k < 3; ++k) reduce(wk.changing_interp[j][k], wk.row_segments[j].part[k]);
      if (plain)
        interp_argmin_points(wk.row_points.data(), static_cast<int>(wk.row_points.size()), wcols, wstride_, pos, n,
                             wk.best.data(), wk.second.data(), wk.best_id.data());
      else
        interp_argmin_row(wk.row_points.data(), static_cast<int>(wk.row_points.size()), wk.row_additive.data(),
                          static_cast<int>(wk.row_additive.size()), wk.row_segments.data(),
                          static_cast<int>(wk.row_segments.size()), wk.row_masked.data(), km, wcols, wstride_, pos, n,
                          wk.best.data(), wk.second.data(), wk.best_id.data(), wk.force.data(), regimes_.k2());
      // Every cell as put() would write it, without branches; then the flagged cells (rare)
      // are solved by the per-cell method and overwrite theirs. A row without them goes out
      // with non-temporal stores when the window is large (put_row).
      const bool flagged = interp_store_row(wk.best.data(), wk.second.data(), wk.best_id.data(), wk.value.data(),
                                            plain ? nullptr : wk.force.data(), n, max_distance_, wk.site_row.data(),
                                            wk.distance_row.data());
      put_row(distance_.row(r) + c0, site_.row(r) + c0, wk.distance_row.data(), wk.site_row.data(), n,
              stream_ && !flagged);
      // A flagged cell whose centre is inside a polygon ends at distance 0 with its area site
      // unless a lower site is at distance exactly 0 there (apply_interiors); solve_zero finds
      // that site with lower bounds and rarely an exact distance, where the per-cell method
      // measures every candidate exactly. (On the Oresund coastline at 0.0004 deg a quarter of
      // the flagged cells are on land: cells within kAdditiveMinValue of an edge, both sides.)
      // The per-cell method's set-up is made once per leaf, at its first such cell: the leaf lies
      // in one interpolation block, so its candidates' interpolants are looked up once.
      if (flagged)
        for (int64_t c = 0; c < n; ++c) {
          if (wk.second[static_cast<size_t>(c)] == 0.0) continue;
          if (fully_interior(c0 + c, r, c0 + c + 1, r + 1)) {
            solve_zero(wk, cands, c0 + c, r, c0 + c + 1, r + 1);
            continue;
          }
          if (!cells_ready) {
            one_block = in_one_line_block(c0, r0, c1, r1);
            cells_setup(wk, cands, one_block);
            cells_ready = true;
          }
          solve_cells_row(wk, cands, one_block, r, c0 + c, c0 + c + 1);
        }
    }
  }

  void fill_none(int64_t c0, int64_t r0, int64_t c1, int64_t r1) {
    for (int64_t r = r0; r < r1; ++r) {
      std::fill(site_.row(r) + c0, site_.row(r) + c1, kNoSite);
      std::fill(distance_.row(r) + c0, distance_.row(r) + c1, kNoDistance);
    }
  }

  // True when every cell of the block has its centre inside a polygon (one span per row).
  bool fully_interior(int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
    return ctx_.interiors != nullptr && ctx_.interiors->covers(c0, r0, c1, r1);
  }

  // A block inside polygons: per cell the lowest of `cands` at distance exactly 0 (as the
  // float32 written, which apply_interiors compares), else no site; apply_interiors does the
  // rest, exactly as after brute force.
  // Large blocks are split first, each part keeping the candidates that touch its own box: a
  // polygon's interior block touched at one corner by a coastline edge then costs a few boxes,
  // not a lower bound per cell. (Both filters are lower bounds of the distance, so a candidate
  // dropped cannot be at distance 0 in that part.)
  void solve_zero(const GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                  int64_t r1) {
    if (cands.empty()) return fill_none(c0, r0, c1, r1);
    const int64_t w = c1 - c0, h = r1 - r0;
    if (w * h > kLeafCells) {
      const int64_t cm = c0 + (w + 1) / 2, rm = r0 + (h + 1) / 2;
      const int64_t xs[3] = {c0, cm, c1}, ys[3] = {r0, rm, r1};
      std::vector<int32_t> part;
      for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
          if (xs[i] >= xs[i + 1] || ys[j] >= ys[j + 1]) continue;
          const EcefBox box = box_of(wk, xs[i], ys[j], xs[i + 1], ys[j + 1]);
          part.clear();
          for (int32_t id : cands)
            if (geo_.lower_bound(box, id) <= kGeoSlack) part.push_back(id);
          solve_zero(wk, part, xs[i], ys[j], xs[i + 1], ys[j + 1]);
        }
      return;
    }
    for (int64_t r = r0; r < r1; ++r)
      for (int64_t c = c0; c < c1; ++c) {
        const GeoCell p = cell_at(wk, c, r);
        int32_t zero = kNoSite;
        for (int32_t id : cands) {  // ascending: the first at distance 0 is the lowest
          if (geo_.lower_bound(p, id) > kGeoSlack) continue;
          if (static_cast<float>(geo_.distance(p, id)) == 0.0f) {
            zero = id;
            break;
          }
        }
        site_.row(r)[c] = zero;
        distance_.row(r)[c] = zero == kNoSite ? kNoDistance : 0.0f;
      }
  }

  void put(int64_t c, int64_t r, int32_t id, double d) {
    const bool none = id == kNoSite || d > max_distance_;
    site_.row(r)[c] = none ? kNoSite : id;
    distance_.row(r)[c] = none ? kNoDistance : static_cast<float>(d);
  }

  // Per-cell argmin over `cands` (ascending ids): ties keep the lowest id. Point sites use their
  // interpolated value where they have one (so a cell gets the same value whichever path solves
  // it), segments their exact distance; a close call involving an interpolated value is decided
  // by exact distances (resolve_exactly).
  void solve_cells(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1, int64_t r1) {
    if (cands.empty()) return fill_none(c0, r0, c1, r1);
    const bool one_block = in_one_line_block(c0, r0, c1, r1);
    cells_setup(wk, cands, one_block);
    for (int64_t r = r0; r < r1; ++r) solve_cells_row(wk, cands, one_block, r, c0, c1);
  }

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
  void cells_setup(GeoWorker& wk, const std::vector<int32_t>& cands, bool one_block) const {
    const size_t n = cands.size();
    wk.slots.assign(one_block ? 4 * n : 0, &kNotLooked);
    wk.cell_lb.resize(n);
    wk.pieces.resize(n);
    for (size_t i = 0; i < n; ++i) wk.pieces[i] = geo_.single_piece(cands[i]);
  }

  // Cells [c0, c1) of row r by the per-cell method, after cells_setup(wk, cands, one_block).
  void solve_cells_row(GeoWorker& wk, const std::vector<int32_t>& cands, bool one_block, int64_t r, int64_t c0,
                       int64_t c1) {
    const bool bounded = std::isfinite(max_distance_);
    auto slots_of = [&](size_t i) { return one_block ? &wk.slots[4 * i] : nullptr; };
    CellWeights cw;
    cell_weights_row(r, cw);
    // The column weights are the window's (init_column_weights: weights_col's values).
    auto column_weights = [&](int64_t c) {
      for (int b = 0; b < 4; ++b) {
        cw.wc[b] = wcols_[static_cast<size_t>(b * wstride_ + c)];
        cw.lc[b] = wcols_[static_cast<size_t>((4 + b) * wstride_ + c)];
      }
    };
    if (cands.size() == 1) {
      const int32_t id = cands[0];
      for (int64_t c = c0; c < c1; ++c) {
        bool exact = false;
        const GeoCell p = cell_at(wk, c, r);
        column_weights(c);
        const double v = value(wk, c, r, p, id, regime_of(p, id), exact, nullptr, nullptr, &cw, slots_of(0));
        if (!exact && bounded && std::abs(v - max_distance_) <= kInterpTie)
          put(c, r, id, geo_.distance(p, id));
        else
          put(c, r, id, v);
      }
      return;
    }
    const size_t n = cands.size();
    // Per-cell lower bounds: single-piece edges inline (their capsule bound), others through
    // GeoSites. Any valid bound gives the same result: it only skips candidates that cannot
    // come within kGeoSlack of the best.
    auto cell_lb = [&](const GeoCell& p, size_t i) {
      if (const GeoPiece* piece = wk.pieces[i]) return std::max(piece_capsule_bound(*piece, p.x, p.y, p.z), 0.0);
      return geo_.lower_bound(p, cands[i]);
    };
    size_t previous = n;  // the previous cell's nearest candidate (n: none yet)
    double travel = 0.0;  // the way along the row since its first cell (an upper bound)
    GeoCell q{};
    const double parallel_step =
        located_ ? 0.0 : rho_[r] * ctx_.grid.res * (3.14159265358979323846 / 180.0) * (1.0 + 1e-12) + 1e-9;
    for (int64_t c = c0; c < c1; ++c) {
      const GeoCell p = cell_at(wk, c, r);
      column_weights(c);
      // Lower bounds stay valid along the row: a bound computed at an earlier cell minus the
      // way since, d(P) >= d(Q) - d(Q, P) (the geodesic distance is 1-Lipschitz). cell_lb
      // holds each bound plus the travel when it was computed, so the stale bound is
      // cell_lb - travel. The step between neighbouring centres: on a geographic grid the arc
      // of their parallel (no shorter than the geodesic between them), on a projected one
      // their chord grown by 1e-5 to cover the arc. Only candidates whose stale bound does not
      // exclude them get a fresh one, which skips most of them on most cells. (Rounding in
      // these sums, ~1e-9 m, is far inside kGeoSlack - kInterpTie.)
      size_t first = 0;
      if (previous == n) {
        for (size_t i = 0; i < n; ++i) {
          wk.cell_lb[i] = cell_lb(p, i);
          if (wk.cell_lb[i] < wk.cell_lb[first]) first = i;
        }
      } else {
        const double step =
            located_ ? std::sqrt((p.x - q.x) * (p.x - q.x) + (p.y - q.y) * (p.y - q.y) + (p.z - q.z) * (p.z - q.z)) *
                               (1.0 + 1e-5) +
                           1e-9
                     : parallel_step;
        travel += step;
        first = previous;
      }
      q = p;
      // The candidate with the smallest lower bound (along a row: the previous cell's nearest)
      // is usually the nearest: measure it first,
      // then only the candidates whose lower bound does not exclude them (kGeoSlack exceeds
      // kInterpTie, so every candidate within kInterpTie of the best is measured). When the
      // best distance is attained at an edge's end, an adjacent edge that is certainly
      // nearest at the same vertex has exactly the same (canonical) distance: it is settled
      // as a tie without a search (geodesic_sites.hpp, attains_at_vertex).
      // Two edges nearest at the vertex they share both measure that vertex: their values
      // are the same bits (same interpolation nodes), as brute force's canonical vertex
      // distances are, so that is a true tie (lower id), not a close call.
      GeoEnd end, other_end;
      bool best_exact = true;
      double best;
      const Interpolant* best_from = nullptr;
      const Interpolant* from = nullptr;
      bool best_canonical = false, canonical = false;
      const Regime first_regime = regime_of(p, cands[first]);
      if (geo_.site(cands[first]).segment && first_regime == Regime::uncertain)
        best = geo_.distance(p, cands[first], &end);
      else
        best = value(wk, c, r, p, cands[first], first_regime, best_exact, &best_from, &best_canonical, &cw,
                     slots_of(first));
      int32_t best_id = cands[first];
      double runner_up = std::numeric_limits<double>::infinity();
      bool runner_exact = true;
      size_t best_i = first;
      for (size_t i = 0; i < n; ++i) {
        if (i == first || wk.cell_lb[i] > best + kGeoSlack + travel) continue;
        if (previous != n) {
          const double lb = cell_lb(p, i);
          wk.cell_lb[i] = lb + travel;
          if (lb > best + kGeoSlack) continue;
        }
        const int32_t id = cands[i];
        bool exact = true;
        double d;
        const Regime regime = regime_of(p, id);
        if (geo_.site(id).segment && regime == Regime::uncertain) {
          if (best_exact && geo_.attains_at_vertex(p, id, end, best)) {
            best_id = std::min(best_id, id);
            continue;
          }
          d = geo_.distance(p, id, &other_end);
        } else {
          d = value(wk, c, r, p, id, regime, exact, &from, &canonical, &cw, slots_of(i));
          other_end.valid = false;
        }
        if (!exact && !best_exact && d == best && canonical && best_canonical && from->lat == best_from->lat &&
            from->lon == best_from->lon) {
          best_id = std::min(best_id, id);
          continue;
        }
        if (d < best || (d == best && id < best_id)) {
          runner_up = best;
          runner_exact = best_exact;
          best = d;
          best_id = id;
          best_i = i;
          best_exact = exact;
          best_from = exact ? nullptr : from;
          best_canonical = !exact && canonical;
          end = other_end;
        } else if (d < runner_up) {
          runner_up = d;
          runner_exact = exact;
        }
      }
      previous = best_i;
      bool close_call = (!best_exact || !runner_exact) && runner_up - best <= kInterpTie;
      if (!best_exact && bounded && std::abs(best - max_distance_) <= kInterpTie) close_call = true;
      if (close_call)
        resolve_exactly(wk, cands, c, r, best);
      else
        put(c, r, best_id, best);
    }
  }

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

}  // namespace

void run_exact_geodesic(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance) {
  GeodesicExactSolver solver(ctx, site, distance);
  solver.run();
}

#undef RV_GEO_BEYOND

}  // namespace rv::detail
