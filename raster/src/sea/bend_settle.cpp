// The bend nodes' distances by sea: see sea_exact/sea_exact.cpp for the method, bend_settle.hpp for the
// parts.
#include "sea/bend_settle.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <queue>

#include "rv/field/error.hpp"
#include "sea/near_bends.hpp"
#include "sea/visible_region.hpp"

namespace rv::sea {

namespace {
// The blocking edges a search remembers (Searches::best_path).
constexpr int kRecentBlockers = 4;
}  // namespace

Searches::Searches(const Prepared& prepared) : Searches(prepared, prepared.geometric) {}

Searches::Searches(const Prepared& prepared, const std::vector<int32_t>& geometric)
    : p(prepared), nodes(sea::bend_nodes(prepared.vis)) {
  // (Geodesic: the trees' bounds are plane distances scaled down to metres they cannot exceed,
  // a segment's box widened by the bending of its image.)
  std::vector<RootTree::Box> boxes;
  const double bend = p.vis.frame() ? p.vis.frame()->deviation() : 0.0;
  for (int32_t id : geometric) {
    const LocalSite& s = p.local[static_cast<size_t>(id)];
    const double w = p.segment(id) ? bend : 0.0;
    boxes.push_back({{std::min(s.ax, s.bx()) - w, std::min(s.ay, s.by()) - w},
                     {std::max(s.ax, s.bx()) + w, std::max(s.ay, s.by()) + w}});
    site_of.push_back(id);
  }
  sites = RootTree(boxes, p.lower_scale());
  touch_first = static_cast<int32_t>(site_of.size());
  // (Sites are ascending: a touch's site is found by bisection.)
  for (size_t k = 0; k < p.touches.size(); ++k) {
    const Prepared::Touch& t = p.touches[k];
    if (!std::binary_search(geometric.begin(), geometric.end(), t.site)) continue;
    site_of.push_back(t.site);
    touch_of.push_back(static_cast<int32_t>(k));
    touch_xyz.push_back(p.geodesic ? p.xyz(t.ll) : Prepared::Xyz{});
    boxes.push_back({{t.at.at.x - bend, t.at.at.y - bend}, {t.at.at.x + bend, t.at.at.y + bend}});
  }
  for (const Node& n : nodes) boxes.push_back({p.vis.vertex(n.vertex), p.vis.vertex(n.vertex)});
  all = RootTree(boxes, p.lower_scale());
  for (size_t i = 0; i < site_of.size(); ++i) {
    if (static_cast<int32_t>(i) < touch_first) sites.set_weight(static_cast<int32_t>(i), 0.0);
    all.set_weight(static_cast<int32_t>(i), 0.0);
  }
  dist.assign(nodes.size(), Best{});
  from.assign(nodes.size(), Vec2{});
  prev.assign(nodes.size(), -1);
  tauts.assign(nodes.size(), TautTest{});
}

Best Searches::best_path(const Place& at, const Spot& spot, Best best, int64_t& tests, int32_t skip_vertex,
                         std::vector<int32_t>* blockers, int32_t first, int32_t* winner, uint64_t since,
                         double searched, double cap, double near_radius, const NearBends* far, size_t far_node) const {
  const Vec2 x = at.at;
  int32_t won = -1;
  // On the ellipsoid a candidate's chord decides most candidates before its inverse problem.
  const Prepared::Xyz xyz = p.spot_xyz(spot);
  // Whether the edge that last hid the root from a neighbour still does (one crossing test).
  auto hinted = [&](int32_t item, const Place& to) {
    if (!blockers) return false;
    const int32_t b = (*blockers)[static_cast<size_t>(item)];
    return b >= 0 && p.vis.crosses(b, at, to);
  };
  // The edges that hid the last roots tested from this point, newest first: the roots a point
  // does not see lie mostly behind the same few headlands (one crossing test each).
  int32_t recent[kRecentBlockers];
  std::fill_n(recent, kRecentBlockers, -1);
  auto seen = [&](int32_t item, const Place& to) {
    int32_t* b = blockers ? &(*blockers)[static_cast<size_t>(item)] : nullptr;
    if (hinted(item, to)) return false;
    for (const int32_t e : recent) {
      if (e < 0) break;
      if ((!b || e != *b) && p.vis.crosses(e, at, to)) {
        if (b) *b = e;
        return false;
      }
    }
    ++tests;
    int32_t found = -1;
    const bool free = p.vis.sees(at, to, &found);
    if (b) *b = found;
    if (!free && found >= 0 && found != recent[0]) {
      std::copy_backward(recent, recent + kRecentBlockers - 1, recent + kRecentBlockers);
      recent[0] = found;
    }
    return free;
  };
  auto consider_item = [&](int32_t item) {
    if (near_radius >= 0.0 && item >= site_items() &&
        length(x, p.vis.vertex(nodes[static_cast<size_t>(item - site_items())].vertex)) <= near_radius)
      return;
    if (consider(item, at, spot, xyz, skip_vertex, best, seen)) won = item;
  };
  if (first >= 0 && std::isfinite(all.weight(first))) consider_item(first);
  all.within(
      x, [&] { return std::min(best.d + 1e-12 * best.d, cap); }, [&](int32_t item, double) { consider_item(item); },
      since, searched, [&](const RootTree::Box& box) { return !far || far->may_see(far_node, x, box.lo, box.hi); });
  if (winner) *winner = won >= 0 ? won : first;
  return best;
}

// The Dijkstra's state between runs.
struct Settling::State {
  std::unique_ptr<RootTree> open;  // weight: the key of a node not yet settled
  std::vector<double> key;
  using Entry = std::pair<double, int32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  std::vector<uint8_t> settled;
  // The edge that last hid each root (see best_path): nodes evaluated one after the other are
  // often hidden from the same roots by the same headland.
  std::vector<int32_t> hint;
  std::vector<Best> last_val;      // each node's best path when last evaluated
  std::vector<int32_t> last_root;  // and the item of `all` it came from (-1: none yet)
  std::vector<uint64_t> seen_at;   // and the stamp of `all` then
  std::vector<double> seen_bound;  // and the bound its roots were searched to then
  // With near bends: below this, every path over a root the node's best (last_val) does not
  // account for is longer (the roots searched to seen_bound; those settled since and not near
  // it, at least a reach past the least key then); its key is the smaller of the two.
  std::vector<double> beyond;
  double diameter = 0.0, farthest = 0.0;
  int64_t steps = 0;
};

Settling::Settling(Searches& b, const NearBends* near) : b_(b), near_(near), st_(std::make_unique<State>()) {
  const Prepared& p = b.p;
  const Visibility& vis = p.vis;
  State& st = *st_;
  const size_t n = b.nodes.size();
  // (The unsettled nodes' tree bounds their keys without near bends only.)
  if (!near_) {
    std::vector<RootTree::Box> boxes;
    boxes.reserve(n);
    for (const Node& node : b.nodes) boxes.push_back({vis.vertex(node.vertex), vis.vertex(node.vertex)});
    st.open = std::make_unique<RootTree>(boxes, p.lower_scale());
  }
  st.key.resize(n);
  for (size_t i = 0; i < n; ++i) {
    st.key[i] = std::sqrt(b.straight(p.vertex_spot(b.nodes[i].vertex)).first);
    if (!near_) st.open->set_weight(static_cast<int32_t>(i), st.key[i]);
    st.queue.emplace(st.key[i], static_cast<int32_t>(i));
  }
  st.beyond = st.key;
  st.settled.assign(n, 0);
  st.hint.assign(static_cast<size_t>(b.site_items()) + n, -1);
  st.last_val.assign(n, Best{});
  st.last_root.assign(n, -1);
  st.seen_at.assign(n, 0);
  // (none searched before the first evaluation)
  st.seen_bound.assign(n, -std::numeric_limits<double>::infinity());
  // Nodes no seed can reach (a lagoon without a port) never settle: their keys only climb. While
  // a reachable node waits, the first node not yet settled on its path is at most the diameter
  // of everything beyond the farthest node settled (or a site it sees), so a least key above that
  // means every node left is unreachable.
  double xmin = std::numeric_limits<double>::infinity(), ymin = xmin, xmax = -xmin, ymax = -xmin;
  auto cover = [&](Vec2 v) {
    xmin = std::min(xmin, v.x);
    ymin = std::min(ymin, v.y);
    xmax = std::max(xmax, v.x);
    ymax = std::max(ymax, v.y);
  };
  for (const Node& node : b.nodes) cover(vis.vertex(node.vertex));
  for (int32_t id : p.geometric) {
    const LocalSite& l = p.local[static_cast<size_t>(id)];
    cover({l.ax, l.ay});
    cover({l.bx(), l.by()});
  }
  // (Geodesic: a geodesic's image bends by millimetres, so its length is its plane distance
  // to well within the margin.)
  if (xmin <= xmax) st.diameter = length({xmin, ymin}, {xmax, ymax}) * (p.geodesic ? 1.01 : 1.0);
}

Settling::~Settling() = default;

void Settling::settle(size_t u) {
  Searches& b = b_;
  const Prepared& p = b.p;
  const Visibility& vis = p.vis;
  State& st = *st_;
  const Best& val = st.last_val[u];
  const auto i = static_cast<int32_t>(u);
  const Place at = vis.at_vertex(b.nodes[u].vertex, b.nodes[u].wedge);
  st.settled[u] = 1;
  b.dist[u] = val;
  b.prev[u] = st.last_root[u] >= b.site_items() ? st.last_root[u] - b.site_items() : -1;
  if (val.via != kNoVia)
    b.from[u] = vis.vertex(val.via);
  else if (val.d == 0.0)
    b.from[u] = at.at;
  else if (const int32_t root = st.last_root[u]; root >= b.touch_first && root < b.site_items())
    b.from[u] = p.touches[static_cast<size_t>(b.touch_of[static_cast<size_t>(root - b.touch_first)])].at.at;
  else if (val.site != kNoSite)
    b.from[u] = p.site_place(val.site, p.vertex_spot(b.nodes[u].vertex)).at;
  b.tauts[u] = taut_test(vis, b.nodes[u], b.from[u]);
  if (!near_) st.open->set_weight(i, std::numeric_limits<double>::infinity());
  if (std::isfinite(val.d)) {
    // (A node whose path runs on into its land is the last bend of no path: no search weighs it.)
    if (!DeadArrivals(vis, b.nodes[u]).from(b.from[u])) b.all.set_weight(b.site_items() + i, val.d);
    st.farthest = std::max(st.farthest, val.d);
  }
}

bool Settling::next(const std::atomic<bool>* cancel, double within, double& k, size_t& u) {
  State& st = *st_;
  auto& queue = st.queue;
  while (!queue.empty()) {
    const auto [key, i] = queue.top();
    u = static_cast<size_t>(i);
    if (st.settled[u] || key != st.key[u]) {  // (an older entry of a node since settled or raised)
      queue.pop();
      continue;
    }
    if (key > (st.farthest + st.diameter) * (1 + 1e-9)) {  // the rest is unreachable
      queue = {};
      return false;
    }
    // (A key is a lower bound: every node left is farther. The entry stays for the next run.)
    if (key > within) return false;
    if (cancel && (++st.steps & 255) == 0 && cancel->load(std::memory_order_relaxed))
      throw Error(ErrorKind::cancelled, "computation cancelled");
    queue.pop();
    k = key;
    return true;
  }
  return false;
}

void Settling::run(int64_t& tests, const std::atomic<bool>* cancel, double within) {
  if (near_) {
    run_near(tests, cancel, within);
    return;
  }
  Searches& b = b_;
  const Prepared& p = b.p;
  const Visibility& vis = p.vis;
  State& st = *st_;
  RootTree& open = *st.open;
  auto& queue = st.queue;
  auto& key = st.key;
  double k = 0.0;
  size_t u = 0;
  while (next(cancel, within, k, u)) {
    const auto i = static_cast<int32_t>(u);
    const Node& node = b.nodes[u];
    ++b.evaluations;
    const Place at = vis.at_vertex(node.vertex, node.wedge);
    // The least a path through a node not yet settled can be: its key plus the way from it.
    double bound = std::numeric_limits<double>::infinity();
    open.nearest(at.at, [&](int32_t item, double lower) {
      if (b.nodes[static_cast<size_t>(item)].vertex == node.vertex) return true;
      bound = lower;
      return false;
    });
    // Only a path below that bound settles the node, so only the roots that could give one are
    // searched (a node deep in a shadow would otherwise test every root settled meanwhile, at
    // every evaluation); those searched before (settled by then, within the bound then) are not
    // searched again: the best of them is last_val.
    int32_t won = -1;
    const Best val = b.best_path(at, p.vertex_spot(node.vertex), st.last_val[u], tests, node.vertex, &st.hint, -1, &won,
                                 st.seen_at[u], st.seen_bound[u], bound);
    if (won >= 0) st.last_root[u] = won;
    st.last_val[u] = val;
    st.seen_at[u] = b.all.stamp();
    st.seen_bound[u] = bound;
    if (val.d < bound || !std::isfinite(bound)) {
      settle(u);
      continue;
    }
    // Not yet final: back in the queue with the larger bound (at least one step of rounding up,
    // so that the queue moves on; the settle test above uses the bound as computed).
    key[u] = std::max(bound, std::nextafter(k, std::numeric_limits<double>::infinity()));
    open.set_weight(i, key[u]);
    queue.emplace(key[u], i);
  }
}

// Dijkstra over the roots settled so far (see the header): a node is taken from the queue at
// the least key, which is the smaller of its best path so far (last_val) and the bound below
// which every path it does not account for lies (beyond). When its best is below that bound it
// is the least of every unsettled node's paths over settled roots, so it is final (the first
// unsettled node on any path to it would be at least as far). Else its roots are searched up to
// the key plus its reach: a root settled later is at least that far from it (settled distances
// only grow, from the least key on) unless it is near, and a near root hands its path over when
// it settles.
void Settling::run_near(int64_t& tests, const std::atomic<bool>* cancel, double within) {
  Searches& b = b_;
  const Prepared& p = b.p;
  const Visibility& vis = p.vis;
  const NearBends& near = *near_;
  State& st = *st_;
  auto& queue = st.queue;
  auto& key = st.key;
  // (`queued`: the node's entry is still in the queue, valid while its key stays.)
  auto rekey = [&](size_t v, bool queued) {
    const double k = std::min(st.last_val[v].d, st.beyond[v]);
    if (queued && k == key[v]) return;
    key[v] = k;
    queue.emplace(k, static_cast<int32_t>(v));
  };
  double k = 0.0;
  size_t u = 0;
  while (next(cancel, within, k, u)) {
    const auto i = static_cast<int32_t>(u);
    const Node& node = b.nodes[u];
    if (st.last_val[u].d < st.beyond[u]) {
      settle(u);
      // Its path handed to the near nodes it sees, as Searches::through weighs a root.
      const Best& from = b.dist[u];
      if (!b.root(u)) continue;
      for (int32_t t = near.first[u]; t < near.first[u + 1]; ++t) {
        const auto v = static_cast<size_t>(near.to[static_cast<size_t>(t)]);
        if (st.settled[v]) continue;
        const Spot spot = p.vertex_spot(b.nodes[v].vertex);
        const Prepared::Xyz xyz = p.geodesic ? p.vertex_xyz[static_cast<size_t>(b.nodes[v].vertex)] : Prepared::Xyz{};
        const double d = b.through(
            u, spot, xyz, st.last_val[v].d,
            [&](double length) {
              return Best{length, from.site, node.vertex} < st.last_val[v];
            },
            [](const Place&) { return true; });
        if (!std::isfinite(d)) continue;
        st.last_val[v] = Best{d, from.site, node.vertex};
        st.last_root[v] = b.site_items() + i;
        rekey(v, true);
      }
      continue;
    }
    ++b.evaluations;
    // (At least one step of rounding up, so that the queue moves on.)
    const double cap = std::max(k + near.reach[u], std::nextafter(k, std::numeric_limits<double>::infinity()));
    const Place at = vis.at_vertex(node.vertex, node.wedge);
    int32_t won = -1;
    // (The near nodes are left out: each hands its path over when it settles.)
    const Best val = b.best_path(at, p.vertex_spot(node.vertex), st.last_val[u], tests, node.vertex, &st.hint, -1, &won,
                                 st.seen_at[u], st.seen_bound[u], cap, near.radius[u], &near, u);
    if (won >= 0) st.last_root[u] = won;
    st.last_val[u] = val;
    st.seen_at[u] = b.all.stamp();
    st.seen_bound[u] = cap;
    st.beyond[u] = cap;
    rekey(u, false);
  }
}

void settle_bends(Searches& b, int64_t& tests, const std::atomic<bool>* cancel) { Settling(b).run(tests, cancel); }

}  // namespace rv::sea

namespace rv {

PreparedSea::PreparedSea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid,
                         const SeaOptions& options)
    : prepared(sea::prepare(seeds, barriers, grid, options.metric, options.geolocator)), search(prepared) {
  const auto start = std::chrono::steady_clock::now();
  if (!seeds.adjusted()) {
    sea::settle_bends(search, bend_tests, options.cancel);
  } else {
    for (sea::SiteClass& c : sea::site_classes(seeds, prepared.geometric)) {
      classes.push_back(Class{c.weight, c.reach, std::make_unique<sea::Searches>(prepared, c.sites)});
      sea::settle_bends(*classes.back().search, bend_tests, options.cancel);
    }
  }
  bends_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

const PreparedSea::CutEdges& PreparedSea::cut_edges() const {
  std::call_once(cut_once_, [&] {
    auto cut = std::make_unique<CutEdges>();
    cut->edges = sea::barrier_edges(prepared.vis);
    cut->index = sea::EdgeIndex(cut->edges, {});
    cut_ = std::move(cut);
  });
  return *cut_;
}

}  // namespace rv
