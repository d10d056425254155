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
// - Cells: the straight field of the window first (the straight exact engine's, rv/engine), then
//   per cell its nearest site if seen (the straight field's answer, bit for bit), else the best
//   site seen and the best settled node seen, each searched in order of its bound.
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

// The engines' shared parts (sea/sea_prepare.hpp, sea/root_tree.hpp).
using namespace ::rv::sea;

// A bound may exceed the value it bounds by rounding (a box's distance against a segment's): a
// search stops only when its bound is above the best by more than that.
bool beyond(double bound, double best) { return bound > best + 1e-12 * best; }

// The searches every evaluation runs: the straight nearest site, and the best path over the
// sites seen and the bend nodes settled so far, in one tree ordered by weight plus distance.
struct Searches {
  const Prepared& p;
  RootTree sites;                // the geometric sites by their boxes, weight 0
  RootTree all;                  // the sites (items [0, S)), then the bend nodes (S + node), weighted once settled
  std::vector<int32_t> site_of;  // site item -> site index
  std::vector<Node> nodes;
  std::vector<Best> dist;  // per node, once settled
  std::vector<Vec2> from;  // where each node's path came from: its previous bend or its site's point
  int64_t evaluations = 0;

  explicit Searches(const Prepared& prepared) : p(prepared), nodes(sea::bend_nodes(prepared.vis)) {
    // (Geodesic: the trees' bounds are plane distances scaled down to metres they cannot exceed,
    // a segment's box widened by the bending of its image.)
    std::vector<RootTree::Box> boxes;
    const double bend = p.vis.frame() ? p.vis.frame()->deviation() : 0.0;
    for (int32_t id : p.geometric) {
      const LocalSite& s = p.local[static_cast<size_t>(id)];
      const double w = p.segment(id) ? bend : 0.0;
      boxes.push_back({{std::min(s.ax, s.bx()) - w, std::min(s.ay, s.by()) - w},
                       {std::max(s.ax, s.bx()) + w, std::max(s.ay, s.by()) + w}});
      site_of.push_back(id);
    }
    sites = RootTree(boxes, p.lower_scale());
    for (const Node& n : nodes) boxes.push_back({p.vis.vertex(n.vertex), p.vis.vertex(n.vertex)});
    all = RootTree(boxes, p.lower_scale());
    for (size_t i = 0; i < site_of.size(); ++i) {
      sites.set_weight(static_cast<int32_t>(i), 0.0);
      all.set_weight(static_cast<int32_t>(i), 0.0);
    }
    dist.assign(nodes.size(), Best{});
    from.assign(nodes.size(), Vec2{});
  }
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

  // The best path from `at` over the sites it sees and the settled bends it sees (taut there),
  // if better than `best`; bends at `skip_vertex` are not roots (a path cannot turn from one
  // wedge of a vertex into another).
  //
  // `blockers` (one entry per item of `all`, or null): the edge that last blocked each root
  // from a neighbouring point. A root still blocked by it is hidden at the cost of one crossing
  // test instead of a walk along the path; the entries are hints, every answer is exact.
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
  Best best_path(const Place& at, const Spot& spot, Best best, int64_t& tests, int32_t skip_vertex = -1,
                 std::vector<int32_t>* blockers = nullptr, int32_t first = -1, int32_t* winner = nullptr,
                 uint64_t since = 0, double searched = std::numeric_limits<double>::infinity(),
                 double cap = std::numeric_limits<double>::infinity()) const {
    const Vec2 x = at.at;
    int32_t won = -1;
    // Whether the edge that last hid the root from a neighbour still does (one crossing test).
    auto hinted = [&](int32_t item, const Place& to) {
      if (!blockers) return false;
      const int32_t b = (*blockers)[static_cast<size_t>(item)];
      return b >= 0 && p.vis.crosses(b, at, to);
    };
    // (`hint_tested`: the caller has just asked hinted() and it said no.)
    auto seen = [&](int32_t item, const Place& to, bool hint_tested = false) {
      if (blockers) {
        int32_t& b = (*blockers)[static_cast<size_t>(item)];
        if (!hint_tested && hinted(item, to)) return false;
        ++tests;
        return p.vis.sees(at, to, &b);
      }
      ++tests;
      return p.vis.sees(at, to);
    };
    auto consider = [&](int32_t item) {
      if (item < site_items()) {
        const int32_t id = site_of[static_cast<size_t>(item)];
        Place to{x};
        const double key = p.site_key(spot, id, &to);
        const Best c{std::sqrt(key), id, kNoVia};
        if (!(c < best)) return;
        if (key == 0.0 || seen(item, to)) {
          best = c;
          won = item;
        }
        return;
      }
      const auto k = static_cast<size_t>(item - site_items());
      const Node& n = nodes[k];
      if (n.vertex == skip_vertex || !std::isfinite(dist[k].d)) return;
      // The taut test (a few turns) before the length: on the ellipsoid a length is an inverse
      // problem, and the test rejects most candidates.
      if (!sea::taut(p.vis, n, from[k], x)) return;
      const Place to = p.vis.at_vertex(n.vertex, n.wedge);
      // On the ellipsoid the hint too: most candidates a cell's search meets are hidden, and
      // mostly by the edge that hid them from its neighbour.
      if (p.geodesic && hinted(item, to)) return;
      const Best c{dist[k].d + p.vertex_length(n.vertex, spot), dist[k].site, n.vertex};
      if (!(c < best)) return;
      if (seen(item, to, p.geodesic != nullptr)) {
        best = c;
        won = item;
      }
    };
    if (first >= 0 && std::isfinite(all.weight(first))) consider(first);
    all.within(
        x, [&] { return std::min(best.d + 1e-12 * best.d, cap); }, [&](int32_t item, double) { consider(item); }, since,
        searched);
    if (winner) *winner = won >= 0 ? won : first;
    return best;
  }
};

void settle_bends(Searches& b, int64_t& tests, const std::atomic<bool>* cancel) {
  const Prepared& p = b.p;
  const Visibility& vis = p.vis;
  const size_t n = b.nodes.size();
  std::vector<RootTree::Box> boxes;
  boxes.reserve(n);
  for (const Node& node : b.nodes) boxes.push_back({vis.vertex(node.vertex), vis.vertex(node.vertex)});
  RootTree open(boxes, p.lower_scale());  // weight: the key of a node not yet settled
  std::vector<double> key(n);
  using Entry = std::pair<double, int32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  for (size_t i = 0; i < n; ++i) {
    key[i] = std::sqrt(b.straight(p.vertex_spot(b.nodes[i].vertex)).first);
    open.set_weight(static_cast<int32_t>(i), key[i]);
    queue.emplace(key[i], static_cast<int32_t>(i));
  }
  std::vector<uint8_t> settled(n, 0);
  // The edge that last hid each root (see best_path): nodes evaluated one after the other are
  // often hidden from the same roots by the same headland.
  std::vector<int32_t> hint(static_cast<size_t>(b.site_items()) + n, -1);
  std::vector<Best> last_val(n);        // each node's best path when last evaluated
  std::vector<uint64_t> seen_at(n, 0);  // and the stamp of `all` then
  // and the bound its roots were searched to then (none before the first evaluation)
  std::vector<double> seen_bound(n, -std::numeric_limits<double>::infinity());
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
    // (Geodesic: a geodesic's image bends by millimetres, so its length is its plane distance
    // to well within the margin.)
    if (xmin <= xmax) diameter = length({xmin, ymin}, {xmax, ymax}) * (p.geodesic ? 1.01 : 1.0);
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
    const Best val = b.best_path(at, p.vertex_spot(node.vertex), last_val[u], tests, node.vertex, &hint, -1, nullptr,
                                 seen_at[u], seen_bound[u], bound);
    last_val[u] = val;
    seen_at[u] = b.all.stamp();
    seen_bound[u] = bound;
    if (val.d < bound || !std::isfinite(bound)) {
      settled[u] = 1;
      b.dist[u] = val;
      if (val.via != kNoVia)
        b.from[u] = vis.vertex(val.via);
      else if (val.site != kNoSite)
        b.from[u] = val.d == 0.0 ? at.at : p.site_place(val.site, p.vertex_spot(node.vertex)).at;
      open.set_weight(i, std::numeric_limits<double>::infinity());
      if (std::isfinite(val.d)) {
        b.all.set_weight(b.site_items() + i, val.d);
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
}

// The cells of row r of the window where the engines hold them (on the ellipsoid the row is one
// parallel, projected as one: GeodesicFrame::forward_row).
std::vector<Spot> row_spots(const Prepared& p, const GridSpec& grid, const Window& window, int64_t r) {
  std::vector<Spot> spots(static_cast<size_t>(window.width));
  if (!p.geodesic) {
    for (int64_t c = 0; c < window.width; ++c)
      spots[static_cast<size_t>(c)] = p.cell(grid, window.col0 + c, window.row0 + r);
    return spots;
  }
  if (p.geolocator) {  // a projected grid's row, located as one batch
    std::vector<double> x(static_cast<size_t>(window.width)), y(x.size(), grid.centre_y(window.row0 + r));
    std::vector<double> lon(x.size()), lat(x.size());
    for (int64_t c = 0; c < window.width; ++c) x[static_cast<size_t>(c)] = grid.centre_x(window.col0 + c);
    p.geolocator->to_lonlat(x.data(), y.data(), lon.data(), lat.data(), x.size());
    for (size_t c = 0; c < x.size(); ++c) {
      const Vec2 ll{lon[c], lat[c]};
      spots[c] = Spot{p.vis.frame()->forward(ll), ll};
    }
    return spots;
  }
  std::vector<Vec2> plane(static_cast<size_t>(window.width));
  const double lat = grid.centre_y(window.row0 + r);
  p.vis.frame()->forward_row(lat, grid.centre_x(window.col0), grid.res, window.width, plane.data());
  for (int64_t c = 0; c < window.width; ++c)
    spots[static_cast<size_t>(c)] = Spot{plane[static_cast<size_t>(c)], Vec2{grid.centre_x(window.col0 + c), lat}};
  return spots;
}

// The straight exact engine's options for the field a computation by sea starts from.
ComputeOptions straight_options(const SeaOptions& options) {
  ComputeOptions o;
  o.method = Method::exact;
  o.metric = options.metric;
  o.geolocator = options.geolocator;
  o.grid_polygons = options.grid_polygons;
  o.threads = options.threads;
  o.max_distance = options.max_distance;
  o.cancel = options.cancel;
  return o;
}

}  // namespace

class PreparedSea {
 public:
  PreparedSea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const SeaOptions& options)
      : prepared(sea::prepare(seeds, barriers, grid, options.metric, options.geolocator)), search(prepared) {
    const auto start = std::chrono::steady_clock::now();
    settle_bends(search, bend_tests, options.cancel);
    bends_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  PreparedSea(const PreparedSea&) = delete;
  PreparedSea& operator=(const PreparedSea&) = delete;

  const Prepared prepared;
  Searches search;  // refers to `prepared`: the object is never moved
  int64_t bend_tests = 0;
  double bends_seconds = 0.0;
};

std::shared_ptr<const PreparedSeeds> prepare_straight(const SeedSet& seeds, const GridSpec& grid,
                                                      const SeaOptions& options) {
  return rv::prepare(seeds, grid, straight_options(options));
}

std::shared_ptr<const PreparedSea> prepare_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid,
                                               const SeaOptions& options) {
  return std::make_shared<const PreparedSea>(seeds, barriers, grid, options);
}

SeaPreparation preparation_of(const PreparedSea& prepared) {
  return SeaPreparation{prepared.prepared.vis.vertex_count(), static_cast<int64_t>(prepared.search.nodes.size()),
                        prepared.bend_tests, prepared.bends_seconds};
}

Vec2 via_position(const PreparedSea& prepared, const GridSpec& grid, int32_t via) {
  if (via < 0 || via >= prepared.prepared.vis.vertex_count())
    throw Error(ErrorKind::internal, "no such barrier vertex");
  const sea::Prepared& p = prepared.prepared;
  if (p.geolocator) {
    const Vec2 ll = p.vertex_ll[static_cast<size_t>(via)];
    Vec2 at;
    p.geolocator->to_grid(&ll.x, &ll.y, &at.x, &at.y, 1);
    return at;
  }
  if (p.geodesic) return p.vertex_ll[static_cast<size_t>(via)];
  const Vec2 local = p.vis.vertex(via);
  // The inverse of Barriers::translated(Vec2{grid.xmin, grid.ymax}) (sea::prepare).
  return Vec2{local.x + grid.xmin, local.y + grid.ymax};
}

SeaField compute_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const Window& window,
                     const SeaOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const bool shared = options.prepared != nullptr;
  const std::shared_ptr<const PreparedSea> prepared =
      shared ? options.prepared : prepare_sea(seeds, barriers, grid, options);
  const Prepared& p = prepared->prepared;
  const Searches& search = prepared->search;
  const int64_t bend_tests = shared ? 0 : prepared->bend_tests;

  SeaField out = sea::empty_field(p, grid, window, options.metric);
  out.bend_nodes = static_cast<int64_t>(search.nodes.size());
  out.bends_seconds = shared ? 0.0 : prepared->bends_seconds;
  const InteriorSpans interiors = interiors_of(seeds, options.grid_polygons.get(), grid, window);
  out.field.contested_cells = interiors.contested_cells;
  // The straight field: each cell's nearest site and distance, as every engine of the straight
  // distance answers them (a cell that sees that site takes them as they are).
  ComputeOptions straight = straight_options(options);
  straight.window = window;
  straight.prepared = options.straight;
  const NearestField straight_field = compute(seeds, grid, straight);
  const int workers = resolve_threads(options.threads);
  struct Tally {
    int64_t land = 0, unreachable = 0, tests = 0;
    double detour = 1.0;
  };
  std::vector<Tally> tally(static_cast<size_t>(workers));
  // Per worker, the edge that last hid each root (see best_path): neighbouring cells are mostly
  // hidden from the same roots by the same edges.
  std::vector<std::vector<int32_t>> blockers(static_cast<size_t>(workers));
  std::atomic<int64_t> rows_done{0};
  detail::parallel_for(workers, window.height, [&](int64_t r, int worker) {
    if (options.cancel && options.cancel->load(std::memory_order_relaxed))
      throw Error(ErrorKind::cancelled, "computation cancelled");
    Tally& t = tally[static_cast<size_t>(worker)];
    std::vector<int32_t>& hint = blockers[static_cast<size_t>(worker)];
    int32_t last = -1;  // the root of the row's previous bent cell
    if (hint.empty()) hint.assign(static_cast<size_t>(search.site_items()) + search.nodes.size(), -1);
    const auto& spans = interiors.rows[static_cast<size_t>(r)];
    auto span = spans.begin();
    const std::vector<Spot> spots = row_spots(p, grid, window, r);
    std::vector<double> xs(static_cast<size_t>(window.width));
    for (int64_t c = 0; c < window.width; ++c) xs[static_cast<size_t>(c)] = spots[static_cast<size_t>(c)].at.x;
    std::vector<Visibility::Ground> grounds(static_cast<size_t>(window.width));
    if (p.geodesic) {  // (a row of a longitude/latitude grid is no straight line in the plane)
      for (int64_t c = 0; c < window.width; ++c)
        grounds[static_cast<size_t>(c)] =
            c == 0 ? p.vis.classify(spots[0].at)
                   : p.vis.classify_next(spots[static_cast<size_t>(c - 1)].at, grounds[static_cast<size_t>(c - 1)],
                                         spots[static_cast<size_t>(c)].at);
    } else {
      p.vis.classify_row(spots.empty() ? 0.0 : spots[0].at.y, xs.data(), window.width, grounds.data());
    }
    for (int64_t c = 0; c < window.width; ++c) {
      const Spot& spot = spots[static_cast<size_t>(c)];
      const Vec2 x = spot.at;
      const Visibility::Ground ground = grounds[static_cast<size_t>(c)];
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
      // The straight field's answer where its nearest site is seen; else the best path. (None
      // within the maximum distance: no path by sea is shorter than the straight line.)
      const int32_t nearest = straight_field.site.at(c, r);
      if (nearest == kNoSite) continue;
      const float d0 = straight_field.distance.at(c, r);
      ++t.tests;
      if (p.vis.sees(at, p.site_place(nearest, spot))) {
        out.field.site.at(c, r) = nearest;
        out.field.distance.at(c, r) = d0;
        continue;
      }
      const Best best = search.best_path(at, spot, Best{}, t.tests, -1, &hint, last, &last);
      if (best.site == kNoSite) {
        ++t.unreachable;
        continue;
      }
      if (best.d > options.max_distance) continue;
      out.field.site.at(c, r) = best.site;
      out.field.distance.at(c, r) = static_cast<float>(best.d);
      out.via.at(c, r) = best.via;
      if (d0 > 0.0f) t.detour = std::max(t.detour, best.d / static_cast<double>(d0));
    }
    const int64_t done = rows_done.fetch_add(1) + 1;
    if (options.progress && (done * 100 / window.height) != ((done - 1) * 100 / window.height))
      options.progress(static_cast<double>(done) / static_cast<double>(window.height));
  });
  out.visibility_tests = bend_tests;
  out.bend_tests = bend_tests;
  out.bend_evaluations = shared ? 0 : search.evaluations;
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
