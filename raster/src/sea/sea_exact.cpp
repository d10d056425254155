// The exact engine of the distance by sea: the statement of rv/sea/sea_field.hpp, with every
// search ordered by a lower bound so that the work follows what the answer needs rather than
// every pair.
//
// - Bend nodes' distances: a Dijkstra without a graph. Nodes wait in a queue keyed by a lower
//   bound of their distance (at first the straight distance to the nearest site). The node with
//   the least key is evaluated: its best path over the sites it sees and the nodes settled so
//   far (searched in order of weight plus distance, tested for visibility as they come). The
//   last bend of any better path would be a node not yet settled, r, and such a path is at least
//   key(r) + |r - v|; so when the evaluated path is shorter than the least of those (searched
//   the same way) it is final, else the node goes back with that bound as its key, which is
//   larger than the key it had: every step settles a node or raises a key.
// - Cells: the straight nearest site if seen (the straight field's answer, bit for bit), else the
//   best site seen and the best settled node seen, each searched in order of its bound.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <queue>

#include "rv/field/error.hpp"
#include "rv/field/interior.hpp"
#include "rv/field/parallel.hpp"
#include "rv/sea/sea_field.hpp"
#include "sea/root_tree.hpp"
#include "sea/sea_prepare.hpp"

namespace rv {
namespace {

using sea::Best;
using sea::length;
using sea::nearest_point;
using sea::Node;
using sea::Place;
using sea::Prepared;
using sea::RootTree;

// A bound may exceed the value it bounds by rounding (a box's distance against a segment's): a
// search stops only when its bound is above the best by more than that.
bool beyond(double bound, double best) { return bound > best + 1e-12 * best; }

struct Searches {
  const Prepared& p;
  RootTree sites;                // the geometric sites by their boxes, weight 0
  std::vector<int32_t> site_of;  // tree item -> site index

  explicit Searches(const Prepared& prepared) : p(prepared) {
    std::vector<RootTree::Box> boxes;
    for (int32_t id : p.geometric) {
      const LocalSite& s = p.local[static_cast<size_t>(id)];
      boxes.push_back(
          {{std::min(s.ax, s.bx()), std::min(s.ay, s.by())}, {std::max(s.ax, s.bx()), std::max(s.ay, s.by())}});
      site_of.push_back(id);
    }
    sites = RootTree(boxes);
    for (size_t i = 0; i < boxes.size(); ++i) sites.set_weight(static_cast<int32_t>(i), 0.0);
  }

  // The straight nearest key from x (k0), and the best site x sees by (key, site): the
  // straight field's answer when its key is k0. Candidates arrive in order of their box's
  // distance; one is final once a later box is farther than its own distance, so they are
  // tested in (key, site) order and the search stops at the first seen.
  struct Direct {
    double k0 = std::numeric_limits<double>::infinity();
    Best best;
    bool straight = false;
  };
  Direct direct(const Place& at, int64_t& tests) const {
    Direct out;
    const Vec2 x = at.at;
    using Candidate = std::pair<double, int32_t>;  // (key, site)
    std::priority_queue<Candidate, std::vector<Candidate>, std::greater<Candidate>> waiting;
    bool found = false;
    auto test_first = [&] {
      const auto [key, id] = waiting.top();
      waiting.pop();
      if (!std::isfinite(out.k0)) out.k0 = key;  // the first final candidate is the nearest
      ++tests;
      if (key == 0.0 || p.vis.sees(at, nearest_point(p.local[static_cast<size_t>(id)], x))) {
        out.best = Best{std::sqrt(key), id, kNoVia};
        out.straight = key == out.k0;
        found = true;
      }
    };
    sites.nearest(x, [&](int32_t item, double bound) {
      while (!waiting.empty() && beyond(bound * bound, waiting.top().first)) {
        test_first();
        if (found) return false;
      }
      const int32_t id = site_of[static_cast<size_t>(item)];
      waiting.emplace(planar_key(x.x, x.y, p.local[static_cast<size_t>(id)]), id);
      return true;
    });
    while (!found && !waiting.empty()) test_first();
    return out;
  }

  // The straight nearest distance from x: a lower bound of its distance by sea.
  double straight(Vec2 x) const {
    double k0 = std::numeric_limits<double>::infinity();
    sites.nearest(x, [&](int32_t item, double bound) {
      if (beyond(bound * bound, k0)) return false;
      k0 = std::min(k0, planar_key(x.x, x.y, p.local[static_cast<size_t>(site_of[static_cast<size_t>(item)])]));
      return true;
    });
    return std::sqrt(k0);
  }
};

// The bend nodes with their distances, and a tree of the settled ones to search.
struct Bends {
  std::vector<Node> nodes;
  std::vector<Best> dist;
  std::vector<Vec2> from;  // where each node's path came from: its previous bend or its site's point
  RootTree roots;          // weight: the node's distance once settled
  int64_t evaluations = 0;
};

std::vector<RootTree::Box> node_boxes(const Visibility& vis, const std::vector<Node>& nodes) {
  std::vector<RootTree::Box> boxes;
  boxes.reserve(nodes.size());
  for (const Node& n : nodes) boxes.push_back({vis.vertex(n.vertex), vis.vertex(n.vertex)});
  return boxes;
}

// The best path from `at` over the settled bends it sees, if better than `best`; bends at
// `skip_vertex` are not roots (a path cannot turn from one wedge of a vertex into another).
Best via_bends(const Prepared& p, const Bends& b, const Place& at, Best best, int64_t& tests,
               int32_t skip_vertex = -1) {
  b.roots.nearest(at.at, [&](int32_t item, double bound) {
    if (beyond(bound, best.d)) return false;
    const Node& n = b.nodes[static_cast<size_t>(item)];
    if (n.vertex == skip_vertex) return true;
    const Best& d = b.dist[static_cast<size_t>(item)];
    const Best c{d.d + length(p.vis.vertex(n.vertex), at.at), d.site, n.vertex};
    if (!(c < best) || !sea::taut(p.vis, n, b.from[static_cast<size_t>(item)], at.at)) return true;
    ++tests;
    if (p.vis.sees(at, p.vis.at_vertex(n.vertex, n.wedge))) best = c;
    return true;
  });
  return best;
}

Bends settle_bends(const Prepared& p, const Searches& search, int64_t& tests, const std::atomic<bool>* cancel) {
  const Visibility& vis = p.vis;
  Bends b;
  b.nodes = sea::bend_nodes(vis);
  const size_t n = b.nodes.size();
  b.dist.assign(n, Best{});
  b.from.assign(n, Vec2{});
  const std::vector<RootTree::Box> boxes = node_boxes(vis, b.nodes);
  b.roots = RootTree(boxes);
  RootTree open(boxes);  // weight: the key of a node not yet settled
  std::vector<double> key(n);
  using Entry = std::pair<double, int32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  for (size_t i = 0; i < n; ++i) {
    key[i] = search.straight(vis.vertex(b.nodes[i].vertex));
    open.set_weight(static_cast<int32_t>(i), key[i]);
    queue.emplace(key[i], static_cast<int32_t>(i));
  }
  std::vector<uint8_t> settled(n, 0);
  // Nodes no seed can reach (a lagoon without a port) never settle: their keys only climb. While
  // a reachable node waits, the first node not yet settled on its path is at most the diameter
  // of everything beyond the farthest node settled (or a site it sees), so a least key above that
  // means every node left is unreachable.
  double diameter = 0.0;
  {
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
    if (xmin <= xmax) diameter = length({xmin, ymin}, {xmax, ymax});
  }
  double farthest = 0.0;
  int64_t steps = 0;
  while (!queue.empty()) {
    const auto [k, i] = queue.top();
    queue.pop();
    const auto u = static_cast<size_t>(i);
    if (settled[u] || k != key[u]) continue;
    if (k > (farthest + diameter) * (1 + 1e-9)) break;  // the rest is unreachable
    if (cancel && (++steps & 255) == 0 && cancel->load(std::memory_order_relaxed))
      throw Error(ErrorKind::cancelled, "computation cancelled");
    const Node& node = b.nodes[u];
    ++b.evaluations;
    const Place at = vis.at_vertex(node.vertex, node.wedge);
    const Searches::Direct d = search.direct(at, tests);
    const Best val = via_bends(p, b, at, d.best, tests, node.vertex);
    // The least a path through a node not yet settled can be: its key plus the way from it.
    double bound = std::numeric_limits<double>::infinity();
    open.nearest(at.at, [&](int32_t item, double lower) {
      if (b.nodes[static_cast<size_t>(item)].vertex == node.vertex) return true;
      bound = lower;
      return false;
    });
    if (val.d < bound || !std::isfinite(bound)) {
      settled[u] = 1;
      b.dist[u] = val;
      if (val.via != kNoVia)
        b.from[u] = vis.vertex(val.via);
      else if (val.site != kNoSite)
        b.from[u] = val.d == 0.0 ? at.at : nearest_point(p.local[static_cast<size_t>(val.site)], at.at).at;
      open.set_weight(i, std::numeric_limits<double>::infinity());
      if (std::isfinite(val.d)) {
        b.roots.set_weight(i, val.d);
        farthest = std::max(farthest, val.d);
      }
      continue;
    }
    // Not yet final: back in the queue with the larger bound (at least one step of rounding up,
    // so that the queue moves on; the settle test above uses the bound as computed).
    key[u] = std::max(bound, std::nextafter(k, std::numeric_limits<double>::infinity()));
    open.set_weight(i, key[u]);
    queue.emplace(key[u], i);
  }
  return b;
}

}  // namespace

SeaField compute_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const Window& window,
                     const SeaOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const Prepared p = sea::prepare(seeds, barriers, grid);
  const Searches search(p);
  int64_t bend_tests = 0;
  const Bends bends = settle_bends(p, search, bend_tests, options.cancel);
  const double bends_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  SeaField out;
  out.field.site = Raster<int32_t>(grid, window, kNoSite);
  out.field.distance = Raster<float>(grid, window, kNoDistance);
  out.field.metric = MetricSpec{};
  out.via = Raster<int32_t>(grid, window, kNoVia);
  out.barrier_vertices = p.vis.vertex_count();
  out.bend_nodes = static_cast<int64_t>(bends.nodes.size());
  out.bends_seconds = bends_seconds;
  const InteriorSpans interiors = build_interiors(seeds, grid, window);
  out.field.contested_cells = interiors.contested_cells;
  const double max_key = std::isfinite(options.max_distance) ? options.max_distance * options.max_distance
                                                             : std::numeric_limits<double>::infinity();
  const int workers = resolve_threads(options.threads);
  struct Tally {
    int64_t land = 0, unreachable = 0, tests = 0;
    double detour = 1.0;
  };
  std::vector<Tally> tally(static_cast<size_t>(workers));
  std::atomic<int64_t> rows_done{0};
  detail::parallel_for(workers, window.height, [&](int64_t r, int worker) {
    if (options.cancel && options.cancel->load(std::memory_order_relaxed))
      throw Error(ErrorKind::cancelled, "computation cancelled");
    Tally& t = tally[static_cast<size_t>(worker)];
    const auto& spans = interiors.rows[static_cast<size_t>(r)];
    auto span = spans.begin();
    for (int64_t c = 0; c < window.width; ++c) {
      const Vec2 x{grid.local_x(window.col0 + c), grid.local_y(window.row0 + r)};
      const Visibility::Ground ground = p.vis.classify(x);
      if (ground == Visibility::Ground::land) {
        ++t.land;
        continue;
      }
      while (span != spans.end() && span->col1 <= c) ++span;
      if (span != spans.end() && c >= span->col0) {
        out.field.site.at(c, r) = span->site;
        out.field.distance.at(c, r) = 0.0f;
        continue;
      }
      Place at{x};
      at.open = ground == Visibility::Ground::open_sea;
      const Searches::Direct d = search.direct(at, t.tests);
      const Best best = d.straight ? d.best : via_bends(p, bends, at, d.best, t.tests);
      if (best.site == kNoSite) {
        ++t.unreachable;
        continue;
      }
      if (d.straight ? d.k0 > max_key : best.d > options.max_distance) continue;
      out.field.site.at(c, r) = best.site;
      out.field.distance.at(c, r) = static_cast<float>(best.d);
      out.via.at(c, r) = best.via;
      if (d.k0 > 0.0) t.detour = std::max(t.detour, best.d / std::sqrt(d.k0));
    }
    const int64_t done = rows_done.fetch_add(1) + 1;
    if (options.progress && (done * 100 / window.height) != ((done - 1) * 100 / window.height))
      options.progress(static_cast<double>(done) / static_cast<double>(window.height));
  });
  out.visibility_tests = bend_tests;
  out.bend_tests = bend_tests;
  out.bend_evaluations = bends.evaluations;
  for (const Tally& t : tally) {
    out.land_cells += t.land;
    out.unreachable_cells += t.unreachable;
    out.visibility_tests += t.tests;
    out.max_detour = std::max(out.max_detour, t.detour);
  }
  out.field.threads = workers;
  out.field.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace rv
