// The bend nodes each node sees nearby, proved once (internal to rv_raster): a settling that
// owns them (bend_settle.hpp's Settling with NearBends) hands a settled node's distance straight
// to the nearby nodes it sees, as Dijkstra relaxes a graph's edges, and asks every other root
// only for what lies beyond the radius. Without them a node deep in a shadow raises its bound by
// the gap to its nearest unsettled neighbour at a time, and is searched again each time.
//
// For node v, its radius is the plane distance to the k-th nearest other barrier vertex that
// carries a node; every node at another vertex within that distance is near v, and those whose
// place sees v's place (Visibility::sees, exact, in the order a settling's search asks) are v's
// near roots. A root that is not near v is farther than `reach[v]` metres from it (the radius as
// a lower bound of the measure: plane distance times Prepared::lower_scale, less a billionth).
//
// Far sight: round each node's vertex a square of half side `far_factor` times its radius, and
// the directions in which the node sees past the square's sides, from the region it sees in it
// (visible_region.hpp): every part of the ring within `tol` of a side (its margin and the frame's
// deviation, with room) gives the directions from the node to it, widened by four times tol over
// the half side. A root wholly outside the square in none of those directions is hidden from the
// node: its straight path would leave the square at a point the ring's contract says is hidden
// (outside the ring, farther than the margin from it), and a path that sees its end sees every
// point on the way (on the ellipsoid the path's image strays from the straight line by at most
// the deviation, which the widening holds). So a search may pass such roots over unweighed.
// A blurred region, or a node with fewer than k other vertices, has no far sight.
//
// Cost: O(n k) visibility tests for n nodes, and one rotational sweep a node over the edges that
// meet its square, on `threads` threads; the answer does not depend on their number.
// Thread safety: immutable once made; const access from any number of threads.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "sea/edge_index.hpp"
#include "sea/sea_prepare.hpp"

namespace rv::sea {

struct NearBends {
  // Per node: the plane distance (length()) from its vertex within which every node at another
  // vertex is near it (+infinity: every node), and the same in metres as a lower bound, less a
  // billionth: every root of its paths that is not near is at least `reach` away.
  std::vector<double> radius, reach;
  // Per node r, the nodes r is a near root of (ascending): first[r] .. first[r + 1] in `to`.
  std::vector<int32_t> first, to;
  int64_t tests = 0;  // visibility tests made
  // Far sight (above): per node, its square's half side in the plane (0: no far sight), and the
  // directions it sees past the square in, closed intervals of pseudo_angle() within [0, 4]:
  // cone_first[v] .. cone_first[v + 1] in `cones`.
  std::vector<double> far_half;
  std::vector<int32_t> cone_first;
  std::vector<std::pair<double, double>> cones;

  // Whether node v (its vertex at `at`) may see some point of the box [lo, hi]: false only when
  // far sight proves every point of it hidden.
  bool may_see(size_t v, Vec2 at, Vec2 lo, Vec2 hi) const;
};

// An angle's stand-in, rising with it: 0 towards +x, 1 towards +y, 2 towards -x, 3 towards -y,
// below 4. (dx, dy) not both 0.
inline double pseudo_angle(double dx, double dy) {
  const double t = dy / (std::abs(dx) + std::abs(dy));
  return dx >= 0.0 ? (dy >= 0.0 ? t : 4.0 + t) : 2.0 - t;
}

// The half side of each node's square in radii (near_bends' far_factor).
inline constexpr double kFarFactor = 2.0;

inline bool NearBends::may_see(size_t v, Vec2 at, Vec2 lo, Vec2 hi) const {
  const double h = far_half[v];
  if (!(h > 0.0)) return true;
  if (hi.x >= at.x - h && lo.x <= at.x + h && hi.y >= at.y - h && lo.y <= at.y + h) return true;  // meets the square
  if (lo.x == hi.x && lo.y == hi.y) {  // (a point: its one direction)
    const double q = pseudo_angle(lo.x - at.x, lo.y - at.y);
    for (int32_t i = cone_first[v]; i < cone_first[v + 1]; ++i)
      if (cones[static_cast<size_t>(i)].first <= q && q <= cones[static_cast<size_t>(i)].second) return true;
    return false;
  }
  // The box's directions: between its corners' (it does not hold `at`); one that meets the ray
  // towards +x east of `at` spans the angle 0.
  const double p[4] = {pseudo_angle(lo.x - at.x, lo.y - at.y), pseudo_angle(hi.x - at.x, lo.y - at.y),
                       pseudo_angle(hi.x - at.x, hi.y - at.y), pseudo_angle(lo.x - at.x, hi.y - at.y)};
  double a0 = 4.0, a1 = 0.0, b1 = -1.0;  // [a0, a1], and [0, b1] across the angle 0
  const bool across = lo.y <= at.y && hi.y >= at.y && lo.x > at.x;
  for (const double q : p) {
    if (across && q < 2.0) {
      b1 = std::max(b1, q);
    } else {
      a0 = std::min(a0, q);
      a1 = std::max(a1, q);
    }
  }
  if (across) a1 = 4.0;
  for (int32_t i = cone_first[v]; i < cone_first[v + 1]; ++i) {
    const auto& [c0, c1] = cones[static_cast<size_t>(i)];
    if ((c0 <= a1 && c1 >= a0) || (c0 <= b1)) return true;
  }
  return false;
}

// Over `nodes` (bend_nodes(p.vis): every Searches of `p` numbers its nodes so). `k` >= 1.
// `edges`, `index`: barrier_edges(p.vis) and an index of them (PreparedSea::cut_edges()), which
// the far sight's sweeps read. Throws rv::Error(cancelled) when `cancel` becomes true.
NearBends near_bends(const Prepared& p, const std::vector<Node>& nodes, int k, int threads,
                     const std::atomic<bool>* cancel, const std::vector<EdgeIndex::Segment>& edges,
                     const EdgeIndex& index, double far_factor = kFarFactor);

}  // namespace rv::sea
