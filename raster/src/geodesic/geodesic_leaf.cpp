// Leaves of the exact geodesic method (GeodesicExactSolver, geodesic_solver.hpp): the
// interpolants of a leaf's candidates gathered, then the row kernels over its rows.
#include "geodesic/geodesic_solver.hpp"

namespace rv::detail {

void GeodesicExactSolver::solve_segment_leaf(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0,
                                             int64_t c1, int64_t r1) {
  if (line_block_ < kLeafKernelMinBlock || cands.empty() || !in_one_line_block(c0, r0, c1, r1) ||
      cands.size() > kInterpMaxCandidates || !gather_interpolants(wk, cands, c0, r0, c1, r1))
    return solve_cells(wk, cands, c0, r0, c1, r1);
  solve_interp_rows(wk, cands, c0, r0, c1, r1);
}

bool GeodesicExactSolver::gather_interpolants(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0,
                                              int64_t c1, int64_t r1) {
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

void GeodesicExactSolver::solve_interp(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0,
                                       int64_t c1, int64_t r1) {
  if (cands.empty()) return fill_none(c0, r0, c1, r1);
  if (!gather_interpolants(wk, cands, c0, r0, c1, r1)) return solve_cells(wk, cands, c0, r0, c1, r1);
  solve_interp_rows(wk, cands, c0, r0, c1, r1);
}

namespace {

// A candidate's row structure without its row values (qr, dz2): what stays the same on every
// row of the block.
void fixed_part(const Interpolant* it, int32_t id, double tag, RowCandidate& rc) {
  rc = RowCandidate{{0.0, 0.0, 0.0, 0.0}, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, static_cast<double>(id), tag, 0.0, 0.0};
  if (!it) return;  // a form without an interpolant: its cells are forced to the per-cell method
  rc.sx = it->sx;
  rc.sy = it->sy;
  rc.sz = it->sz;
  rc.nx = it->nx;
  rc.ny = it->ny;
  rc.nz = it->nz;
  rc.k3 = it->k3;
}

void copy_end(const SegmentEnd& v, double* out) {
  const double src[9] = {v.x, v.y, v.z, v.nx, v.ny, v.nz, v.ex, v.ey, v.ez};
  std::memcpy(out, src, sizeof(src));
}

// eval()'s row step, the same operations in the same order.
void reduce(const Interpolant* it, const CellWeights& rw, RowCandidate& rc) {
  if (!it) return;
  const double* wt = it->additive ? rw.lt : rw.wt;
  for (int b = 0; b < 4; ++b)
    rc.qr[b] = wt[0] * it->q[0][b] + wt[1] * it->q[1][b] + wt[2] * it->q[2][b] + wt[3] * it->q[3][b];
}

}  // namespace

bool GeodesicExactSolver::rows_setup(GeoWorker& wk, int km[3]) const {
  auto fix = [&](const Interpolant* it, int32_t id, RowCandidate& rc) { fixed_part(it, id, tag_of(it, id), rc); };
  wk.row_points.resize(wk.interp.size());
  wk.row_additive.resize(wk.interp_additive.size());
  wk.row_segments.resize(wk.changing.size());
  for (size_t j = 0; j < wk.interp.size(); ++j) fix(wk.interp[j], wk.interp_id[j], wk.row_points[j]);
  for (size_t j = 0; j < wk.interp_additive.size(); ++j)
    fix(wk.interp_additive[j], wk.interp_additive_id[j], wk.row_additive[j]);
  for (size_t j = 0; j < wk.changing.size(); ++j) {
    RowSegment& g = wk.row_segments[j];
    for (size_t k = 0; k < 3; ++k) fix(wk.changing_interp[j][k], wk.changing[j], g.part[k]);
    for (int e = 0; e < 2; ++e) copy_end(regimes_.end(wk.changing[j], e), g.end[e]);
    for (int k = 0; k < 3; ++k) g.has[k] = wk.changing_interp[j][static_cast<size_t>(k)] ? 1.0 : 0.0;
  }
  // The masked interiors, grouped by their deciding end (km).
  km[0] = km[1] = km[2] = 0;
  wk.row_masked.resize(wk.masked.size());
  wk.masked_order.clear();
  for (int grp = 0; grp < 3; ++grp)
    for (size_t j = 0; j < wk.masked.size(); ++j)
      if (wk.masked_near[j] == grp) {
        const size_t i = wk.masked_order.size();
        wk.masked_order.push_back(j);
        ++km[grp];
        RowMasked& g = wk.row_masked[i];
        fix(wk.masked_interp[j], wk.masked[j], g.part);
        g.has = wk.masked_interp[j] ? 1.0 : 0.0;
        if (grp < 2) copy_end(regimes_.end(wk.masked[j], grp), g.end);
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
  bool plain = wk.row_additive.empty() && wk.row_segments.empty() && wk.row_masked.empty();
  for (const RowCandidate& rc : wk.row_points) plain = plain && rc.tag < 0.0;
  return plain;
}

RowPositions GeodesicExactSolver::row_positions(GeoWorker& wk, int64_t r, int64_t c0, int64_t n) const {
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
  return pos;
}

void GeodesicExactSolver::reduce_to_row(GeoWorker& wk, const CellWeights& rw, const RowPositions& pos) const {
  for (size_t j = 0; j < wk.interp.size(); ++j) {
    reduce(wk.interp[j], rw, wk.row_points[j]);
    if (located_) continue;  // (dz2 serves geographic rows only)
    const double dz = pos.z - wk.row_points[j].sz;
    wk.row_points[j].dz2 = dz * dz;
  }
  for (size_t j = 0; j < wk.interp_additive.size(); ++j) reduce(wk.interp_additive[j], rw, wk.row_additive[j]);
  for (size_t i = 0; i < wk.masked_order.size(); ++i)
    reduce(wk.masked_interp[wk.masked_order[i]], rw, wk.row_masked[i].part);
  for (size_t j = 0; j < wk.changing.size(); ++j)
    for (size_t k = 0; k < 3; ++k) reduce(wk.changing_interp[j][k], rw, wk.row_segments[j].part[k]);
}

void GeodesicExactSolver::solve_interp_rows(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0,
                                            int64_t c1, int64_t r1) {
  const int64_t n = c1 - c0;
  const int64_t stride = (n + kRowPad - 1) / kRowPad * kRowPad;  // padded: whole vectors
  const double* wcols = &wcols_[static_cast<size_t>(c0)];        // the window's (init_column_weights)
  wk.site_row.resize(static_cast<size_t>(stride));
  wk.distance_row.resize(static_cast<size_t>(stride));
  // The kernels write every lane of their outputs before anything reads them; the located
  // positions are read in the padding lanes too, so those start at zero.
  for (auto* v : {&wk.best, &wk.second, &wk.value, &wk.best_id, &wk.force}) v->resize(static_cast<size_t>(stride));
  for (auto* v : {&wk.cx, &wk.cy, &wk.cz}) v->assign(static_cast<size_t>(stride), 0.0);
  int km[3];
  const bool plain = rows_setup(wk, km);  // interp_argmin_points can do the rows alone
  FlaggedCells flagged_cells;
  for (int64_t r = r0; r < r1; ++r) {
    CellWeights rw;
    cell_weights_row(r, rw);
    const RowPositions pos = row_positions(wk, r, c0, n);
    reduce_to_row(wk, rw, pos);
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
    if (flagged) solve_flagged_row(wk, cands, c0, r0, c1, r1, r, flagged_cells);
  }
}

void GeodesicExactSolver::solve_flagged_row(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0,
                                            int64_t c1, int64_t r1, int64_t r, FlaggedCells& state) {
  // A flagged cell whose centre is inside a polygon ends at distance 0 with its area site
  // unless a lower site is at distance exactly 0 there (apply_interiors); solve_zero finds
  // that site with lower bounds and rarely an exact distance, where the per-cell method
  // measures every candidate exactly. (On the Oresund coastline at 0.0004 deg a quarter of
  // the flagged cells are on land: cells within kAdditiveMinValue of an edge, both sides.)
  // The per-cell method's set-up is made once per leaf, at its first such cell: the leaf lies
  // in one interpolation block, so its candidates' interpolants are looked up once.
  for (int64_t c = 0; c < c1 - c0; ++c) {
    if (wk.second[static_cast<size_t>(c)] == 0.0) continue;
    if (fully_interior(c0 + c, r, c0 + c + 1, r + 1)) {
      solve_zero(wk, cands, c0 + c, r, c0 + c + 1, r + 1);
      continue;
    }
    if (!state.ready) {
      state.one_block = in_one_line_block(c0, r0, c1, r1);
      cells_setup(wk, cands, state.one_block);
      state.ready = true;
    }
    solve_cells_row(wk, cands, state.one_block, r, c0 + c, c0 + c + 1);
  }
}

}  // namespace rv::detail
