// The exact method for the geodesic metric: hierarchical block culling with provably safe
// bounds (geodesic_sites.hpp), then a per-cell argmin of exact geodesic distances.
//
// Why it is exact. For a block B of cells, C one of its cells and R(B) an upper bound of the
// geodesic distance from C to any cell of B (the parallel-then-meridian path length), every cell
// P of B has d(P, nearest) <= d(P, s') <= d(C, s') + R(B) =: U for any site s' (triangle
// inequality of the geodesic distance). A site s can be nearest anywhere in B only if its chord
// lower bound to B's ECEF box is <= U. Sites are dropped only when the lower bound exceeds
// min(U, max_distance) + kGeoSlack (slack covering rounding and GeographicLib's 15 nm), so the
// site brute force picks is never dropped. Per cell, the candidate with the smallest chord lower
// bound is measured first, and any other only if its lower bound does not exceed the best
// computed distance plus the slack; the distances compared are computed by the same
// GeoSites::distance() as brute force with the same tie rule (lower site index), so the result
// equals brute force bit for bit.
//
// Why it is (relatively) fast. A geodesic inverse problem costs ~1.5 us, so the method spends
// its effort on never computing one it can avoid: deep inside a Voronoi region a block keeps one
// candidate and each cell costs exactly one distance (the output), point sites one inverse
// problem and segment sites ~3 (the interception iteration). Blocks are independent and taken
// dynamically by threads; the result does not depend on the thread count.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <GeographicLib/Math.hpp>

#include "engine_internal.hpp"
#include "parallel.hpp"

namespace rv::detail {
namespace {

constexpr int64_t kTile = 128;     // top-level tile edge, cells
constexpr int64_t kLeafCells = 64; // blocks this small (or smaller) are solved per cell
constexpr int kProbes = 2;         // sites whose exact distance from a block's centre give U

struct GeoWorker {
  std::vector<std::vector<int32_t>> levels;  // candidate lists per recursion depth
  std::vector<double> lb;
  std::vector<double> cell_lb;
};

class GeodesicExactSolver {
 public:
  GeodesicExactSolver(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance)
      : ctx_(ctx), geo_(*ctx.geo), site_(site), distance_(distance) {
    using GeographicLib::Math;
    const Window& w = ctx.window;
    lat_.resize(static_cast<size_t>(w.height));
    rho_.resize(lat_.size());
    z_.resize(lat_.size());
    for (int64_t r = 0; r < w.height; ++r) {
      const double lat = ctx.grid.centre_y(w.row0 + r);
      double x, y, z;
      geo_.ecef(lat, 0.0, x, y, z);  // at longitude 0: x = the parallel's radius
      lat_[r] = lat;
      rho_[r] = x;
      z_[r] = z;
    }
    lon_.resize(static_cast<size_t>(w.width));
    cos_.resize(lon_.size());
    sin_.resize(lon_.size());
    for (int64_t c = 0; c < w.width; ++c) {
      lon_[c] = ctx.grid.centre_x(w.col0 + c);
      Math::sincosd(lon_[c], sin_[c], cos_[c]);
    }
    max_distance_ = ctx.max_key;  // geodesic keys are metres
  }

  void run() {
    const Window& w = ctx_.window;
    const int64_t tiles_x = (w.width + kTile - 1) / kTile;
    const int64_t tiles_y = (w.height + kTile - 1) / kTile;
    std::vector<GeoWorker> workers(static_cast<size_t>(ctx_.threads));
    parallel_for(ctx_.threads, tiles_x * tiles_y, [&](int64_t t, int worker) {
      GeoWorker& wk = workers[static_cast<size_t>(worker)];
      if (wk.levels.empty()) wk.levels.resize(20);
      const int64_t c0 = (t % tiles_x) * kTile, r0 = (t / tiles_x) * kTile;
      const int64_t c1 = std::min(c0 + kTile, w.width), r1 = std::min(r0 + kTile, w.height);
      wk.levels[0] = ctx_.geometric;
      solve_block(wk, 0, c0, r0, c1, r1);
      ctx_.progress->advance((c1 - c0) * (r1 - r0));
    });
  }

 private:
  GeoCell cell_at(int64_t c, int64_t r) const {
    return GeoCell{lat_[r], lon_[c], rho_[r] * cos_[c], rho_[r] * sin_[c], z_[r]};
  }

  // ECEF box of the cell centres of a block: x = rho cos(lon), y = rho sin(lon), z; interval
  // products over the block's rows and columns contain every centre.
  EcefBox box_of(int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
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
  // that meridian (radius of curvature <= max_meridian_radius).
  double reach_of(int64_t c0, int64_t r0, int64_t c1, int64_t r1, int64_t cc, int64_t rc) const {
    double rmax = 0.0;
    for (int64_t r = r0; r < r1; ++r) rmax = std::max(rmax, rho_[r]);
    constexpr double kRad = 3.14159265358979323846 / 180.0;
    const double dlon = std::max(lon_[cc] - lon_[c0], lon_[c1 - 1] - lon_[cc]) * kRad;
    const double dlat = std::max(lat_[r0] - lat_[rc], lat_[rc] - lat_[r1 - 1]) * kRad;
    return (rmax * dlon + geo_.max_meridian_radius() * dlat) * (1.0 + 1e-12);
  }

  void solve_block(GeoWorker& wk, int depth, int64_t c0, int64_t r0, int64_t c1, int64_t r1) {
    const std::vector<int32_t>& cands = wk.levels[depth];
    if (cands.empty()) return fill_none(c0, r0, c1, r1);
    std::vector<int32_t>& next = wk.levels[depth + 1];
    const bool bounded = std::isfinite(max_distance_);
    if (cands.size() > 1 || bounded) {
      const EcefBox box = box_of(c0, r0, c1, r1);
      wk.lb.resize(cands.size());
      // The kProbes candidates with the smallest lower bounds give the upper bound U.
      int32_t probe[kProbes];
      double probe_lb[kProbes];
      for (int k = 0; k < kProbes; ++k) {
        probe[k] = -1;
        probe_lb[k] = std::numeric_limits<double>::infinity();
      }
      for (size_t i = 0; i < cands.size(); ++i) {
        const double lb = geo_.lower_bound(box, cands[i]);
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
        const GeoCell centre = cell_at(cc, rc);
        double upper = std::numeric_limits<double>::infinity();
        for (int k = 0; k < kProbes; ++k)
          if (probe[k] >= 0) upper = std::min(upper, geo_.distance(centre, cands[static_cast<size_t>(probe[k])]));
        bound = std::min(bound, upper + reach_of(c0, r0, c1, r1, cc, rc));
      }
      bound += kGeoSlack;
      next.clear();
      for (size_t i = 0; i < cands.size(); ++i)
        if (wk.lb[i] <= bound) next.push_back(cands[i]);
    } else {
      next = cands;
    }
    const int64_t w = c1 - c0, h = r1 - r0;
    if (next.size() <= 1 || w * h <= kLeafCells || depth + 2 >= static_cast<int>(wk.levels.size()))
      return solve_cells(wk, next, c0, r0, c1, r1);
    const int64_t cm = c0 + (w + 1) / 2, rm = r0 + (h + 1) / 2;
    solve_block(wk, depth + 1, c0, r0, cm, rm);
    if (cm < c1) solve_block(wk, depth + 1, cm, r0, c1, rm);
    if (rm < r1) {
      solve_block(wk, depth + 1, c0, rm, cm, r1);
      if (cm < c1) solve_block(wk, depth + 1, cm, rm, c1, r1);
    }
  }

  void fill_none(int64_t c0, int64_t r0, int64_t c1, int64_t r1) {
    for (int64_t r = r0; r < r1; ++r) {
      std::fill(site_.row(r) + c0, site_.row(r) + c1, kNoSite);
      std::fill(distance_.row(r) + c0, distance_.row(r) + c1, kNoDistance);
    }
  }

  void put(int64_t c, int64_t r, int32_t id, double d) {
    const bool none = id == kNoSite || d > max_distance_;
    site_.row(r)[c] = none ? kNoSite : id;
    distance_.row(r)[c] = none ? kNoDistance : static_cast<float>(d);
  }

  // Exact per-cell argmin over `cands` (ascending ids): ties keep the lowest id.
  void solve_cells(GeoWorker& wk, const std::vector<int32_t>& cands, int64_t c0, int64_t r0, int64_t c1,
                   int64_t r1) {
    if (cands.empty()) return fill_none(c0, r0, c1, r1);
    if (cands.size() == 1) {
      const int32_t id = cands[0];
      for (int64_t r = r0; r < r1; ++r)
        for (int64_t c = c0; c < c1; ++c) put(c, r, id, geo_.distance(cell_at(c, r), id));
      return;
    }
    const size_t n = cands.size();
    wk.cell_lb.resize(n);
    for (int64_t r = r0; r < r1; ++r) {
      for (int64_t c = c0; c < c1; ++c) {
        const GeoCell p = cell_at(c, r);
        size_t first = 0;
        for (size_t i = 0; i < n; ++i) {
          wk.cell_lb[i] = geo_.lower_bound(p, cands[i]);
          if (wk.cell_lb[i] < wk.cell_lb[first]) first = i;
        }
        // The candidate with the smallest lower bound is usually the nearest: measure it first,
        // then only the candidates whose lower bound does not exclude them. Which ones get
        // measured changes nothing in the result: an excluded candidate's computed distance
        // exceeds the best one's, so the argmin (ties: lowest id) is brute force's.
        // When the best distance is attained at an edge's end, an adjacent edge that is
        // certainly nearest at the same vertex has exactly the same (canonical) distance: it
        // is settled as a tie without a search (geodesic_sites.hpp, attains_at_vertex).
        GeoEnd end, other_end;
        double best = geo_.distance(p, cands[first], &end);
        int32_t best_id = cands[first];
        for (size_t i = 0; i < n; ++i) {
          if (i == first || wk.cell_lb[i] > best + kGeoSlack) continue;
          if (geo_.attains_at_vertex(p, cands[i], end, best)) {
            best_id = std::min(best_id, cands[i]);
            continue;
          }
          const double d = geo_.distance(p, cands[i], &other_end);
          if (d < best || (d == best && cands[i] < best_id)) {
            best = d;
            best_id = cands[i];
            end = other_end;
          }
        }
        put(c, r, best_id, best);
      }
    }
  }

  const EngineContext& ctx_;
  const GeoSites& geo_;
  Raster<int32_t>& site_;
  Raster<float>& distance_;
  std::vector<double> lat_, rho_, z_;  // per window row
  std::vector<double> lon_, cos_, sin_;  // per window column
  double max_distance_ = std::numeric_limits<double>::infinity();
};

}  // namespace

void run_exact_geodesic(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance) {
  GeodesicExactSolver solver(ctx, site, distance);
  solver.run();
}

}  // namespace rv::detail
