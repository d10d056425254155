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
#include "geodesic/geodesic_solver.hpp"

namespace rv::detail {

GeodesicExactSolver::GeodesicExactSolver(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance)
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

void GeodesicExactSolver::init_column_weights(const Window& w) {
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

void GeodesicExactSolver::init_separable(const Window& w) {
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

void GeodesicExactSolver::init_interp_block() {
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

void GeodesicExactSolver::run() { run_tiles(ctx_, *this); }

bool GeodesicExactSolver::start_tile(GeoWorker& wk, const Block& t) {
  if (wk.levels.empty()) wk.levels.resize(kDepths);
  wk.levels[0] = ctx_.geometric;
  wk.cache.clear();
  wk.held.clear();
  // Tiles start in row order: blocks ending a tile row and more above this one are done
  // with (a straggler still needing one would only build it again).
  const int64_t gy = (ctx_.window.row0 + t.r0) / kTile * kTile;
  shared_.drop_rows_before(gy - kTile - point_block_);
  if (located_) locate_tile(wk.tile, t.c0, t.r0, t.c1, t.r1);
  return true;
}

void GeodesicExactSolver::locate_tile(TileCells& t, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
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

EcefBox GeodesicExactSolver::located_box(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
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

double GeodesicExactSolver::located_reach(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1,
                                          int64_t cc, int64_t rc) const {
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

EcefBox GeodesicExactSolver::box_of(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
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

double GeodesicExactSolver::reach_of(const GeoWorker& wk, int64_t c0, int64_t r0, int64_t c1, int64_t r1, int64_t cc,
                                     int64_t rc) const {
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

void GeodesicExactSolver::solve_interior(GeoWorker& wk, int depth, const Block& b) {
  // Every cell ends at distance 0 with its polygon's area site (apply_interiors); what is
  // left to find is a lower site at distance exactly 0 there, which only sites touching
  // the block (lower bound within kGeoSlack) can be.
  const EcefBox box = box_of(wk, b.c0, b.r0, b.c1, b.r1);
  std::vector<int32_t>& next = wk.levels[depth + 1];
  next.clear();
  for (int32_t id : wk.levels[depth])
    if (geo_.lower_bound(box, id) <= kGeoSlack) next.push_back(id);
  solve_zero(wk, next, b.c0, b.r0, b.c1, b.r1);
}

BlockStep GeodesicExactSolver::cull(GeoWorker& wk, int depth, const Block& b) {
  const std::vector<int32_t>& cands = wk.levels[depth];
  std::vector<int32_t>& next = wk.levels[depth + 1];
  const int64_t c0 = b.c0, r0 = b.r0, c1 = b.c1, r1 = b.r1;
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
  // Which leaf, if any: the row kernels over interpolants (points only, inside an interpolation
  // block), a segment leaf, or the per-cell method where the block cannot be split further.
  bool points_only = true;
  for (int32_t id : next) points_only = points_only && !geo_.site(id).segment;
  const int64_t level = b.level;
  const bool can_split = level > 1 && depth + 2 < kDepths;
  const bool interp_leaf = points_only && level <= std::min(point_block_, kInterpSolveBlock) &&
                           (next.size() <= kInterpMaxCandidates || !can_split || level <= kInterpMinBlock);
  const bool segment_leaf = !points_only && (next.size() <= 1 || b.cells() <= kLeafCells);
  wk.leaf = interp_leaf ? LeafKind::interpolants : segment_leaf ? LeafKind::segments : LeafKind::cells;
  if ((interp_leaf || segment_leaf || !can_split) && next.size() >= 2 && next.size() <= kDominanceMax)
    drop_dominated(wk, next, c0, r0, c1, r1);
  return interp_leaf || segment_leaf || !can_split ? BlockStep::leaf : BlockStep::split;
}

void GeodesicExactSolver::solve_leaf(GeoWorker& wk, int depth, const Block& b) {
  const std::vector<int32_t>& cands = wk.levels[depth];
  switch (wk.leaf) {
    case LeafKind::interpolants:
      return solve_interp(wk, cands, b.c0, b.r0, b.c1, b.r1);
    case LeafKind::segments:
      return solve_segment_leaf(wk, cands, b.c0, b.r0, b.c1, b.r1);
    case LeafKind::cells:
      return solve_cells(wk, cands, b.c0, b.r0, b.c1, b.r1);
  }
}

void GeodesicExactSolver::drop_dominated(GeoWorker& wk, std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
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

void GeodesicExactSolver::solve_zero(const GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0,
                                     int64_t c1, int64_t r1) {
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

void run_exact_geodesic(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance) {
  GeodesicExactSolver solver(ctx, site, distance);
  solver.run();
}

}  // namespace rv::detail
