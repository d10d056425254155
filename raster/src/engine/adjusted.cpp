// The adjusted method: the exact and brute-force methods for seeds with weights or reaches
// (rv/field/seeds.hpp, Feature), every metric.
//
// Why a method of its own. The unadjusted methods compare keys of true distances in kernels
// that never see a feature; their culls rely on the nearest being the nearest by distance. With
// weights the nearest by d / w can be far beyond a nearer site, and a weighted region can be
// disconnected (an enclave where d_A / w_A < d_B / w_B holds on a closed curve). So the culls
// here bound costs, not distances, and the cells are measured with the deliverables' exact
// metric (SiteMetric) and searched with the same index (OwnerIndex, its cap the max distance):
// the field and every line drawn on it then follow one rule, adjusted_distance().
//
// Why it is exact. A block of cells is a ball around its middle holding every cell centre; a
// site can be nearest somewhere in it only if its lower bound there, less the ball's radius,
// is within its reach and, over its weight, within the largest cost the nearest at the middle
// can reach in the ball (OwnerIndex::candidates_not_of, candidates_among: sound bounds, no
// site that can win or tie is dropped). The cells are then decided by nearest_among, the same
// comparison and tie rule (lowest site index among equal costs) as the brute-force sweep here.
#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <vector>

#include "engine/culling.hpp"
#include "engine/engine_internal.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"

namespace rv::detail {
namespace {

constexpr int64_t kAdjustedTile = 64;  // top-level tile edge, cells (aligned to the grid)
constexpr int64_t kLeafCells = 64;     // blocks this small are decided per cell
// Longest way across a block in metres: beyond this no corner bound is needed (the ellipsoid's
// half circumference is under 20,004 km).
constexpr double kAnywhere = 2.1e7;
static_assert(detail::kTileBand % kAdjustedTile == 0);

// The cell centres of a block as a ball: the middle and a radius holding every centre.
//   planar: the farthest corner (the distance from a point is convex, so its maximum over a
//           rectangle is at a corner);
//   geodesic (longitude/latitude): the farthest corner too (along a parallel the distance grows
//           with the longitude difference, along a meridian it falls then rises), for blocks
//           under 90 degrees a side; wider ones get the whole Earth;
//   located (projected grids): corners and edge middles, widened by 1 % for the projection's
//           change of scale across the block.
struct Ball {
  Vec2 centre;
  double radius;
};

class BlockBalls {
 public:
  BlockBalls(const EngineContext& ctx, const SiteMetric& metric) : ctx_(ctx), metric_(metric) {}

  Vec2 cell(int64_t c, int64_t r) const {
    return Vec2{ctx_.grid.centre_x(ctx_.window.col0 + c), ctx_.grid.centre_y(ctx_.window.row0 + r)};
  }

  Ball of(const Block& b) const {
    const Vec2 lo = cell(b.c0, b.r1 - 1), hi = cell(b.c1 - 1, b.r0);
    const Vec2 mid{0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y)};
    const bool geodesic = ctx_.geo != nullptr;
    if (geodesic && ctx_.geolocator == nullptr && (hi.x - lo.x > 90.0 || hi.y - lo.y > 90.0))
      return Ball{mid, kAnywhere};
    double r = 0.0;
    for (const Vec2 corner : {lo, hi, Vec2{lo.x, hi.y}, Vec2{hi.x, lo.y}})
      r = std::max(r, metric_.point_distance(mid, corner));
    if (ctx_.geolocator != nullptr) {
      for (const Vec2 edge : {Vec2{mid.x, lo.y}, Vec2{mid.x, hi.y}, Vec2{lo.x, mid.y}, Vec2{hi.x, mid.y}})
        r = std::max(r, metric_.point_distance(mid, edge));
      return Ball{mid, r * 1.01};
    }
    // The rounding of the distances measured.
    return Ball{mid, r * (1.0 + 1e-9) + (geodesic ? 1e-6 : 0.0)};
  }

 private:
  const EngineContext& ctx_;
  const SiteMetric& metric_;
};

// The culling skeleton's policy (culling.hpp) for adjusted distances.
class AdjustedPolicy {
 public:
  struct Worker {
    // Candidates per depth. A deque: growing it keeps every reference to the levels already made,
    // and callers hold one level while asking for the next (a vector's growth left such a
    // reference dangling where the arguments were evaluated left to right, as clang does; its
    // AddressSanitizer caught it).
    std::deque<std::vector<int32_t>> levels;
    std::vector<int32_t>& at(int depth) {
      if (levels.size() <= static_cast<size_t>(depth)) levels.resize(static_cast<size_t>(depth) + 1);
      return levels[static_cast<size_t>(depth)];
    }
  };
  static constexpr bool kInteriors = true;
  static constexpr int64_t kTile = kAdjustedTile;

  AdjustedPolicy(const EngineContext& ctx, const OwnerIndex& index, Raster<int32_t>& site, Raster<float>& distance)
      : ctx_(ctx), index_(index), balls_(ctx, index.metric()), site_(site), distance_(distance) {}

  bool start_tile(Worker& wk, const Block& t) {
    const Ball ball = balls_.of(t);
    index_.candidates_not_of(ball.centre, ball.radius, 0, OwnerIndex::Hit{}, wk.at(0));
    return true;
  }
  bool empty(Worker& wk, int depth, const Block&) { return wk.at(depth).empty(); }

  // Every centre lies inside a polygon, whose area site takes the cell afterwards
  // (apply_interiors) unless a lower site is at distance exactly 0 there: only those are looked
  // for (sites touching the ball).
  void solve_interior(Worker& wk, int depth, const Block& b) {
    const Ball ball = balls_.of(b);
    const std::vector<int32_t>& cands = wk.at(depth);
    std::vector<int32_t>& touching = wk.at(depth + 1);
    touching.clear();
    std::vector<double> lb(cands.size());
    index_.metric().distance_lower_bounds(ball.centre, cands, lb);
    for (size_t i = 0; i < cands.size(); ++i)
      if (!(lb[i] > ball.radius)) touching.push_back(cands[i]);
    for (int64_t r = b.r0; r < b.r1; ++r) {
      int32_t* out_site = site_.row(r);
      float* out_dist = distance_.row(r);
      for (int64_t c = b.c0; c < b.c1; ++c) {
        int32_t zero = kNoSite;
        for (int32_t id : touching)
          if (index_.metric().distance(balls_.cell(c, r), id) == 0.0) {
            zero = id;
            break;
          }
        out_site[c] = zero;
        out_dist[c] = zero == kNoSite ? kNoDistance : 0.0f;
      }
    }
  }

  BlockStep cull(Worker& wk, int depth, const Block& b) {
    const Ball ball = balls_.of(b);
    index_.candidates_among(ball.centre, ball.radius, wk.at(depth), wk.at(depth + 1));
    return wk.at(depth + 1).size() <= 1 || b.cells() <= kLeafCells ? BlockStep::leaf : BlockStep::split;
  }

  void solve_leaf(Worker& wk, int depth, const Block& b) {
    const std::vector<int32_t>& cands = wk.at(depth);
    for (int64_t r = b.r0; r < b.r1; ++r) {
      int32_t* out_site = site_.row(r);
      float* out_dist = distance_.row(r);
      for (int64_t c = b.c0; c < b.c1; ++c) {
        const OwnerIndex::Hit h = index_.nearest_among(balls_.cell(c, r), cands);
        out_site[c] = h.site;
        out_dist[c] = h.site == kNoSite ? kNoDistance : static_cast<float>(h.distance);
      }
    }
  }

  template <class F>
  void split(const Block& b, F&& f) const {
    split_aligned(ctx_.window, b, f);
  }
  void fill_none(const Block& b) { detail::fill_none(site_, distance_, b); }
  void workers_done(Worker&) const {}

 private:
  const EngineContext& ctx_;
  const OwnerIndex& index_;
  BlockBalls balls_;
  Raster<int32_t>& site_;
  Raster<float>& distance_;
};

}  // namespace

void run_adjusted(const EngineContext& ctx, const OwnerIndex& index, Raster<int32_t>& site, Raster<float>& distance) {
  AdjustedPolicy policy(ctx, index, site, distance);
  run_tiles(ctx, policy);
}

void run_adjusted_brute_force(const EngineContext& ctx, const OwnerIndex& index, Raster<int32_t>& site,
                              Raster<float>& distance) {
  const Window& w = ctx.window;
  const SiteMetric& metric = index.metric();
  parallel_for(ctx.threads, w.height, [&](int64_t r, int) {
    int32_t* out_site = site.row(r);
    float* out_dist = distance.row(r);
    const double y = ctx.grid.centre_y(w.row0 + r);
    for (int64_t c = 0; c < w.width; ++c) {
      const Vec2 p{ctx.grid.centre_x(w.col0 + c), y};
      double best = std::numeric_limits<double>::infinity(), best_d = 0.0;
      int32_t best_site = kNoSite;
      for (int32_t id : ctx.geometric) {
        const double d = metric.distance(p, id);
        const double cost = index.cost_of(id, d);
        if (cost < best) {  // ascending ids: ties keep the lowest
          best = cost;
          best_d = d;
          best_site = id;
        }
      }
      out_site[c] = best_site;
      out_dist[c] = best_site == kNoSite ? kNoDistance : static_cast<float>(best_d);
    }
    ctx.progress->advance(w.width);
  });
}

}  // namespace rv::detail
