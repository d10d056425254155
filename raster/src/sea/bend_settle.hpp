// The bend nodes' distances by sea (internal to rv_raster): the searches every evaluation runs,
// the Dijkstra without a graph that settles the nodes (sea_exact/sea_exact.cpp's first half, explained
// there), and what prepare_sea() keeps.
// Thread safety: a Searches is filled by settle_bends (one thread), then only read (any number).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include "rv/sea/sea_field.hpp"
#include "sea/edge_index.hpp"
#include "sea/root_tree.hpp"
#include "sea/sea_prepare.hpp"

namespace rv::sea {

// A bound may exceed the value it bounds by rounding (a box's distance against a segment's): a
// search stops only when its bound is above the best by more than that.
inline bool beyond(double bound, double best) { return bound > best + 1e-12 * best; }

// The searches every evaluation runs: the straight nearest site, and the best path over the
// sites seen and the bend nodes settled so far, in one tree ordered by weight plus distance.
struct NearBends;  // near_bends.hpp

struct Searches {
  const Prepared& p;
  RootTree sites;  // the geometric sites by their boxes, weight 0
  // The sites (items [0, touch_first)), the points where their edges meet barriers (items
  // [touch_first, S): Prepared::touches, weight 0), then the bend nodes (S + node), weighted once
  // settled.
  RootTree all;
  std::vector<int32_t> site_of;  // site or touch item -> site index
  int32_t touch_first = 0;
  std::vector<int32_t> touch_of;         // touch item - touch_first -> index in Prepared::touches
  std::vector<Prepared::Xyz> touch_xyz;  // (geodesic) their positions on the ellipsoid
  std::vector<Node> nodes;
  std::vector<Best> dist;       // per node, once settled
  std::vector<Vec2> from;       // where each node's path came from: its previous bend or its site's point
  std::vector<int32_t> prev;    // per settled node: its previous bend (a node), or -1 (it sees its site)
  std::vector<TautTest> tauts;  // per settled node: taut() from its arrival (`from`)
  int64_t evaluations = 0;
  // Whether settled node k is a root of other paths: reached, and its path may bend on there
  // (DeadArrivals, sea_prepare.hpp). Weighing any other node would find it not taut or not seen
  // from every point, so `all` leaves it out (its weight stays +infinity), and so may any index
  // of roots made from the settled nodes.
  bool root(size_t k) const { return std::isfinite(all.weight(site_items() + static_cast<int32_t>(k))); }

  // Over `sites` (geometric sites of `prepared`, ascending: one owner's, for its own distances by
  // sea), or every geometric site.
  explicit Searches(const Prepared& prepared);
  Searches(const Prepared& prepared, const std::vector<int32_t>& sites);
  int32_t site_items() const { return static_cast<int32_t>(site_of.size()); }

  // The straight field's nearest site from x: (k0, the lowest site index at k0).
  std::pair<double, int32_t> straight(const Spot& x) const {
    std::pair<double, int32_t> best{std::numeric_limits<double>::infinity(), kNoSite};
    sites.nearest(x.at, [&](int32_t item, double bound) {
      if (beyond(bound * bound, best.first)) return false;
      const int32_t id = site_of[static_cast<size_t>(item)];
      best = std::min(best, {p.site_key(x, id), id});
      return true;
    });
    return best;
  }

  // Settled node k as the last bend of a path to `spot` (`xyz`: Prepared::spot_xyz(spot)): the
  // path's length when it is taut at the node, `better(length)` holds and `seen(place)` says the
  // node's place sees the spot; else +infinity. A length above `limit` is never better. The tests
  // run cheapest first: on the ellipsoid the chord (a lower bound of the length) against
  // `limit`, taut, seen, then the length (an inverse problem); planar taut, the length, then seen.
  // The field's searches and the sea metric's (rv/sea/sea_metric.hpp) accept paths by it alike.
  template <class Better, class Seen>
  double through(size_t k, const Spot& spot, const Prepared::Xyz& xyz, double limit, Better&& better,
                 Seen&& seen) const {
    constexpr double kNone = std::numeric_limits<double>::infinity();
    const Node& n = nodes[k];
    const double weight = dist[k].d;
    if (p.geodesic && weight + Prepared::chord_below(p.vertex_xyz[static_cast<size_t>(n.vertex)], xyz) > limit)
      return kNone;
    if (!taut(p.vis, tauts[k], spot.at)) return kNone;
    const Place to = p.vis.at_vertex(n.vertex, n.wedge);
    if (p.geodesic && !seen(to)) return kNone;  // (what the chord lets through is mostly hidden)
    const double d = weight + p.vertex_length(n.vertex, spot);
    if (!better(d)) return kNone;
    if (!p.geodesic && !seen(to)) return kNone;
    return d;
  }

  // Root `item` of `all` as the last leg of a path to `spot` (place `at`), weighed as best_path
  // weighs every root: taken into `best` when better (Best's order); `seen(item, place)` says
  // whether the root's place sees `at`. Returns whether it was taken. `xyz`:
  // Prepared::spot_xyz(spot). The answer over a set of roots is the least of them, in any order.
  template <class Seen>
  bool consider(int32_t item, const Place& at, const Spot& spot, const Prepared::Xyz& xyz, int32_t skip_vertex,
                Best& best, Seen&& seen) const {
    if (item >= touch_first && item < site_items()) {  // where a site's edge meets a barrier
      const auto k = static_cast<size_t>(item - touch_first);
      const Prepared::Touch& t = p.touches[static_cast<size_t>(touch_of[k])];
      if (p.geodesic && Prepared::chord_below(touch_xyz[k], xyz) > best.d) return false;
      const double d = p.geodesic ? p.geodesic->point_distance(t.ll, spot.ll) : length(t.at.at, at.at);
      const Best c{d, t.site, kNoVia};
      if (!(c < best) || !(d == 0.0 || seen(item, t.at))) return false;
      best = c;
      return true;
    }
    if (item < site_items()) {
      const int32_t id = site_of[static_cast<size_t>(item)];
      // A point site on the ellipsoid: its chord, then whether it is seen, then its length (most
      // candidates the chord lets through are nearer than the best but hidden).
      if (p.geodesic && !p.segment(id)) {
        if (Prepared::chord_below(p.site_xyz[static_cast<size_t>(id)], xyz) > best.d) return false;
        const Place to = p.site_place(id, spot);
        if (spot.ll != p.site_ll[static_cast<size_t>(id)] && !seen(item, to)) return false;
        const Best c{std::sqrt(p.site_key(spot, id)), id, kNoVia};
        if (!(c < best)) return false;
        best = c;
        return true;
      }
      Place to{at.at};
      const double key = p.site_key(spot, id, &to);
      const Best c{std::sqrt(key), id, kNoVia};
      if (!(c < best) || !(key == 0.0 || seen(item, to))) return false;
      best = c;
      return true;
    }
    const auto k = static_cast<size_t>(item - site_items());
    const Node& n = nodes[k];
    if (n.vertex == skip_vertex || !std::isfinite(dist[k].d)) return false;
    // (seen(): the hint first -- most candidates a cell's search meets are hidden, and mostly by
    // the edge that hid them from its neighbour.)
    const double d = through(
        k, spot, xyz, best.d,
        [&](double length) {
          return Best{length, dist[k].site, n.vertex} < best;
        },
        [&](const Place& to) { return seen(item, to); });
    if (!std::isfinite(d)) return false;
    best = Best{d, dist[k].site, n.vertex};
    return true;
  }

  // The best path from `at` over the sites it sees and the settled bends it sees (taut there),
  // if better than `best`; bends at `skip_vertex` are not roots (a path cannot turn from one
  // wedge of a vertex into another).
  //
  // `blockers` (one entry per item of `all`, or null): the edge that last blocked each root
  // from a neighbouring point. A root still blocked by it is hidden at the cost of one crossing
  // test instead of a walk along the path; the entries are hints, every answer is exact. The
  // search also tries, before each walk, the edges that hid its own last few roots.
  //
  // `first` (an item of `all`, or -1): tried before the search (a neighbour's root), so that the
  // search starts from a good limit.
  //
  // `since`, `searched` (a stamp of `all` and a bound): the roots settled by then whose bound is
  // at most `searched` were searched before (a node evaluated again) and are skipped; `best` is then
  // the answer over them.
  //
  // `cap`: only roots whose bound is at most cap are searched (the answer is exact when below
  // it; else it is some path, or none).
  //
  // `near_radius` (>= 0): bend nodes whose vertex lies within it of `at` in the plane (length())
  // are not searched either: a settling with near bends hands their paths over itself.
  //
  // `far` (with `at` node `far_node`'s place): the roots its far sight proves hidden
  // (NearBends::may_see) are passed over unweighed, whole subtrees of them at once.
  Best best_path(const Place& at, const Spot& spot, Best best, int64_t& tests, int32_t skip_vertex = -1,
                 std::vector<int32_t>* blockers = nullptr, int32_t first = -1, int32_t* winner = nullptr,
                 uint64_t since = 0, double searched = std::numeric_limits<double>::infinity(),
                 double cap = std::numeric_limits<double>::infinity(), double near_radius = -1.0,
                 const NearBends* far = nullptr, size_t far_node = 0) const;
};

// The settling of a Searches' bend nodes, resumable: run(within) settles every node whose
// distance by sea is at most `within` (all of them: nodes are settled in increasing order of
// distance, and the search pauses before the first lower bound above `within`), and a later
// run(farther) goes on from there, settling exactly what one run to `farther` would have. Nodes
// not yet settled have dist +infinity, as if no seed reached them: a path that bends only at
// settled nodes is found as before, and one through a node not settled is longer than `within`.
// Thread safety: run() writes the Searches (b.dist, b.from, b.prev, b.tauts; b.all weighted): no other
// use of either meanwhile. Keeps a reference to `b`, which must outlive it and not move.
//
// With `near` (near_bends.hpp, over b's nodes; it must outlive the settling), a settled node
// hands its distance to the nearby nodes it sees at once, and a node's search asks only for the
// roots beyond its reach: its bound rises a reach at a time, not by the gap to its nearest
// unsettled neighbour; its search passes over the roots the node's far sight proves hidden. Every
// node's answer is the same with or without it, to the bit (the least path over every root, ties
// by Best's order).
class Settling {
 public:
  explicit Settling(Searches& b, const NearBends* near = nullptr);
  ~Settling();
  // Counts the straight paths tested into `tests`. Throws rv::Error(cancelled) when `cancel`
  // becomes true; the settling is then in no state to go on (make a new Searches and Settling).
  void run(int64_t& tests, const std::atomic<bool>* cancel, double within = std::numeric_limits<double>::infinity());

 private:
  struct State;
  // The next node to evaluate, taken from the queue: its key `k` and index `u`; false when the
  // queue is empty, what is left is unreachable, or the least key is above `within`.
  bool next(const std::atomic<bool>* cancel, double within, double& k, size_t& u);
  // The settling with near bends (run() with `near`).
  void run_near(int64_t& tests, const std::atomic<bool>* cancel, double within);
  // Node u settled at its best path so far (State::last_val, from the root State::last_root).
  void settle(size_t u);
  Searches& b_;
  const NearBends* near_;
  std::unique_ptr<State> st_;
};

// Settles every node of `b` reachable from its sites (Settling::run to +infinity).
void settle_bends(Searches& b, int64_t& tests, const std::atomic<bool>* cancel);

}  // namespace rv::sea

namespace rv {

// What prepare_sea() makes (rv/sea/sea_field.hpp).
class PreparedSea {
 public:
  PreparedSea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const SeaOptions& options);
  PreparedSea(const PreparedSea&) = delete;
  PreparedSea& operator=(const PreparedSea&) = delete;

  // Seeds with weights or reaches: per class of sites (sea::site_classes), the nodes settled
  // over its sites alone; `search` is then left unsettled (no path is over every site).
  struct Class {
    double weight = 1.0;
    double reach = std::numeric_limits<double>::infinity();
    std::unique_ptr<sea::Searches> search;  // refers to `prepared`
  };

  const sea::Prepared prepared;
  sea::Searches search;  // refers to `prepared`: the object is never moved
  std::vector<Class> classes;
  int64_t bend_tests = 0;
  double bends_seconds = 0.0;
  // The nodes evaluated while settling (every class's).
  int64_t evaluations() const {
    int64_t n = search.evaluations;
    for (const Class& c : classes) n += c.search->evaluations;
    return n;
  }
  // The barrier edges cut where they cross, as visible regions read them
  // (sea/visible_region.hpp barrier_edges), and their index: made at the first call (from
  // any thread) and kept for every window drawn from this preparation (sea_exact.cpp) and for the
  // owners' far sight (sea_metric.cpp, near_bends.hpp).
  struct CutEdges {
    std::vector<sea::EdgeIndex::Segment> edges;
    sea::EdgeIndex index;
  };
  const CutEdges& cut_edges() const;

 private:
  mutable std::once_flag cut_once_;
  mutable std::unique_ptr<CutEdges> cut_;
};

}  // namespace rv
