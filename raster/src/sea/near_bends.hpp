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
// Cost: O(n k) visibility tests for n nodes, on `threads` threads; the answer does not depend on
// their number. Thread safety: immutable once made; const access from any number of threads.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

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
};

// Over `nodes` (bend_nodes(p.vis): every Searches of `p` numbers its nodes so). `k` >= 1.
// Throws rv::Error(cancelled) when `cancel` becomes true.
NearBends near_bends(const Prepared& p, const std::vector<Node>& nodes, int k, int threads,
                     const std::atomic<bool>* cancel);

}  // namespace rv::sea
