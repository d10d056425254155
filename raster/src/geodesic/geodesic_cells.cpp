// The per-cell method of the exact geodesic method (GeodesicExactSolver, geodesic_solver.hpp):
// each candidate's value at a cell, interpolated or exact, and close calls decided exactly.
#include "geodesic/geodesic_solver.hpp"

namespace rv::detail {

double GeodesicExactSolver::value(GeoWorker& wk, int64_t c, int64_t r, const GeoCell& p, int32_t id, Regime regime,
                                  bool& exact, const Interpolant** from, bool* canonical, const CellWeights* cell,
                                  const Interpolant** slots) const {
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

double GeodesicExactSolver::value_at(GeoWorker& wk, int64_t c, int64_t r, int32_t id, bool& exact,
                                     bool* additive) const {
  const GeoCell p = cell_at(wk, c, r);
  const Interpolant* from = nullptr;
  const double v = value(wk, c, r, p, id, regime_of(p, id), exact, &from);
  if (additive) *additive = from != nullptr && from->additive;
  return v;
}

double GeodesicExactSolver::probe_distance(GeoWorker& wk, int64_t c, int64_t r, const GeoCell& p, int32_t id) const {
  bool exact = false;
  const double v = value(wk, c, r, p, id, regime_of(p, id), exact);
  return exact ? v : v + kInterpTie;
}

void GeodesicExactSolver::resolve_exactly(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c, int64_t r,
                                          double best) {
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

void GeodesicExactSolver::solve_cells(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0,
                                      int64_t c1, int64_t r1) {
  if (cands.empty()) return fill_none(c0, r0, c1, r1);
  const bool one_block = in_one_line_block(c0, r0, c1, r1);
  cells_setup(wk, cands, one_block);
  for (int64_t r = r0; r < r1; ++r) solve_cells_row(wk, cands, one_block, r, c0, c1);
}

void GeodesicExactSolver::cells_setup(GeoWorker& wk, const std::vector<int32_t>& cands, bool one_block) const {
  const size_t n = cands.size();
  wk.slots.assign(one_block ? 4 * n : 0, &kNotLooked);
  wk.cell_lb.resize(n);
  wk.pieces.resize(n);
  for (size_t i = 0; i < n; ++i) wk.pieces[i] = geo_.single_piece(cands[i]);
}

void GeodesicExactSolver::column_weights(int64_t c, CellWeights& cw) const {
  for (int b = 0; b < 4; ++b) {
    cw.wc[b] = wcols_[static_cast<size_t>(b * wstride_ + c)];
    cw.lc[b] = wcols_[static_cast<size_t>((4 + b) * wstride_ + c)];
  }
}

double GeodesicExactSolver::cell_bound(const GeoWorker& wk, const std::vector<int32_t>& cands, const GeoCell& p,
                                       size_t i) const {
  // Single-piece edges inline (their capsule bound), others through GeoSites. Any valid bound
  // gives the same result: it only skips candidates that cannot come within kGeoSlack of the
  // best.
  if (const GeoPiece* piece = wk.pieces[i]) return std::max(piece_capsule_bound(*piece, p.x, p.y, p.z), 0.0);
  return geo_.lower_bound(p, cands[i]);
}

void GeodesicExactSolver::solve_cells_row(GeoWorker& wk, const std::vector<int32_t>& cands, bool one_block, int64_t r,
                                          int64_t c0, int64_t c1) {
  CellWeights cw;
  cell_weights_row(r, cw);
  if (cands.size() == 1) {
    const int32_t id = cands[0];
    const bool bounded = std::isfinite(max_distance_);
    for (int64_t c = c0; c < c1; ++c) {
      bool exact = false;
      const GeoCell p = cell_at(wk, c, r);
      column_weights(c, cw);
      const double v =
          value(wk, c, r, p, id, regime_of(p, id), exact, nullptr, nullptr, &cw, one_block ? &wk.slots[0] : nullptr);
      if (!exact && bounded && std::abs(v - max_distance_) <= kInterpTie)
        put(c, r, id, geo_.distance(p, id));
      else
        put(c, r, id, v);
    }
    return;
  }
  const size_t n = cands.size();
  size_t previous = n;  // the previous cell's nearest candidate (n: none yet)
  double travel = 0.0;  // the way along the row since its first cell (an upper bound)
  GeoCell q{};
  const double parallel_step =
      located_ ? 0.0 : rho_[r] * ctx_.grid.res * (3.14159265358979323846 / 180.0) * (1.0 + 1e-12) + 1e-9;
  for (int64_t c = c0; c < c1; ++c) {
    const GeoCell p = cell_at(wk, c, r);
    column_weights(c, cw);
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
        wk.cell_lb[i] = cell_bound(wk, cands, p, i);
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
    const CellCall call = call_cell(wk, cands, one_block, p, c, r, cw, first, previous != n, travel);
    previous = call.index;
    if (call.close)
      resolve_exactly(wk, cands, c, r, call.best);
    else
      put(c, r, call.id, call.best);
  }
}

GeodesicExactSolver::CellCall GeodesicExactSolver::call_cell(GeoWorker& wk, const std::vector<int32_t>& cands,
                                                             bool one_block, const GeoCell& p, int64_t c, int64_t r,
                                                             const CellWeights& cw, size_t first, bool stale,
                                                             double travel) {
  auto slots_of = [&](size_t i) { return one_block ? &wk.slots[4 * i] : nullptr; };
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
    best =
        value(wk, c, r, p, cands[first], first_regime, best_exact, &best_from, &best_canonical, &cw, slots_of(first));
  int32_t best_id = cands[first];
  double runner_up = std::numeric_limits<double>::infinity();
  bool runner_exact = true;
  size_t best_i = first;
  for (size_t i = 0; i < cands.size(); ++i) {
    if (i == first || wk.cell_lb[i] > best + kGeoSlack + travel) continue;
    if (stale) {
      const double lb = cell_bound(wk, cands, p, i);
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
  bool close = (!best_exact || !runner_exact) && runner_up - best <= kInterpTie;
  if (!best_exact && std::isfinite(max_distance_) && std::abs(best - max_distance_) <= kInterpTie) close = true;
  return {best, best_id, best_i, close};
}

}  // namespace rv::detail
