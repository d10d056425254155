// The reference field of the distance by sea: the statement of rv/sea/sea_field.hpp evaluated
// literally, the oracle every faster method is compared with cell for cell.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <tuple>

#include "rv/field/error.hpp"
#include "rv/field/interior.hpp"
#include "rv/field/parallel.hpp"
#include "rv/field/planar.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/visibility.hpp"
#include "sea/sea_prepare.hpp"

namespace rv {
namespace {

// The engines' shared parts (sea/sea_prepare.hpp, sea/root_tree.hpp).
using namespace ::rv::sea;

// The points where the edges of `sites` (ascending) meet barriers (Prepared::touches): roots at
// distance 0 of their site.
std::vector<const Prepared::Touch*> touches_of(const Prepared& p, const std::vector<int32_t>& sites) {
  std::vector<const Prepared::Touch*> out;
  for (const Prepared::Touch& t : p.touches)
    if (std::binary_search(sites.begin(), sites.end(), t.site)) out.push_back(&t);
  return out;
}

// The length of the straight path from a touch point to x.
double touch_length(const Prepared& p, const Prepared::Touch& t, const Spot& x) {
  return p.geodesic ? p.geodesic->point_distance(t.ll, x.ll) : length(t.at.at, x.at);
}

// D(v) per bend node over `sites` (geometric sites), by Dijkstra over the full visibility graph.
struct VertexDistances {
  std::vector<Node> nodes;
  std::vector<Best> dist;
  std::vector<Vec2> from;  // where each node's path came from: its previous bend or its site's point
  std::vector<const Prepared::Touch*> touches;  // where the sites' edges meet barriers (touches_of)
};

VertexDistances vertex_distances(const Prepared& p, const std::vector<int32_t>& sites, std::atomic<int64_t>& tests) {
  const Visibility& vis = p.vis;
  VertexDistances out;
  out.nodes = sea::bend_nodes(vis);
  out.touches = touches_of(p, sites);
  const std::vector<Node>& nodes = out.nodes;
  std::vector<Best>& dist = out.dist;
  dist.resize(nodes.size());
  out.from.resize(nodes.size());
  // Each node's best site seen directly, by (distance, site).
  for (size_t n = 0; n < nodes.size(); ++n) {
    const Place at = vis.at_vertex(nodes[n].vertex, nodes[n].wedge);
    const Spot spot = p.vertex_spot(nodes[n].vertex);
    for (int32_t id : sites) {
      Place to{at.at};
      const double key = p.site_key(spot, id, &to);
      const Best c{std::sqrt(key), id, kNoVia};
      if (!(c < dist[n])) continue;
      ++tests;
      if (key == 0.0 || vis.sees(at, to)) {
        dist[n] = c;
        out.from[n] = key == 0.0 ? at.at : to.at;
      }
    }
    for (const Prepared::Touch* t : out.touches) {
      const Best c{touch_length(p, *t, spot), t->site, kNoVia};
      if (!(c < dist[n])) continue;
      ++tests;
      if (c.d == 0.0 || vis.sees(at, t->at)) {
        dist[n] = c;
        out.from[n] = c.d == 0.0 ? at.at : t->at.at;
      }
    }
  }
  std::vector<uint8_t> settled(nodes.size(), 0);
  for (;;) {
    size_t u = nodes.size();
    for (size_t n = 0; n < nodes.size(); ++n)
      if (!settled[n] && std::isfinite(dist[n].d) && (u == nodes.size() || dist[n] < dist[u])) u = n;
    if (u == nodes.size()) break;
    settled[u] = 1;
    const Place from = vis.at_vertex(nodes[u].vertex, nodes[u].wedge);
    for (size_t n = 0; n < nodes.size(); ++n) {
      if (settled[n]) continue;
      const Place to = vis.at_vertex(nodes[n].vertex, nodes[n].wedge);
      const Best c{dist[u].d + p.vertex_length(nodes[u].vertex, p.vertex_spot(nodes[n].vertex)), dist[u].site,
                   nodes[u].vertex};
      if (!(c < dist[n]) || !sea::taut(vis, nodes[u], out.from[u], to.at)) continue;
      ++tests;
      if (vis.sees(from, to)) {
        dist[n] = c;
        out.from[n] = from.at;
      }
    }
  }
  return out;
}

// One sea cell at x, off every seed polygon: its best path over `sites` (vd: over the same),
// whether it is the straight field's answer (the straight nearest site seen), and k0, the straight
// nearest key.
Best cell_value(const Prepared& p, const std::vector<int32_t>& sites, const VertexDistances& vd, const Place& at,
                const Spot& spot, std::vector<std::pair<double, int32_t>>& order, bool& straight, double& k0,
                int64_t& asked) {
  const Vec2 x = at.at;
  order.clear();
  for (int32_t id : sites) order.emplace_back(p.site_key(spot, id), id);
  std::sort(order.begin(), order.end());
  k0 = order.front().first;
  Best best;
  straight = false;
  // The straight field's answer when its nearest site (the lowest index at k0) is seen.
  const int32_t nearest = order.front().second;
  ++asked;
  if (p.vis.sees(at, p.site_place(nearest, spot))) {
    straight = true;
    return Best{std::sqrt(k0), nearest, kNoVia};
  }
  // Else the best site seen, by (distance, site).
  for (const auto& [key, id] : order) {
    const Best c{std::sqrt(key), id, kNoVia};
    if (!(c < best)) continue;
    ++asked;
    if (p.vis.sees(at, p.site_place(id, spot))) best = c;
  }
  if (straight) return best;
  // Or where its edge meets a barrier, seen.
  for (const Prepared::Touch* t : vd.touches) {
    const Best c{touch_length(p, *t, spot), t->site, kNoVia};
    if (!(c < best)) continue;
    ++asked;
    if (c.d == 0.0 || p.vis.sees(at, t->at)) best = c;
  }
  // Hidden: a path round the vertices may be shorter than any site seen directly.
  for (size_t n = 0; n < vd.nodes.size(); ++n) {
    if (!std::isfinite(vd.dist[n].d)) continue;
    const Place v = p.vis.at_vertex(vd.nodes[n].vertex, vd.nodes[n].wedge);
    const Best c{vd.dist[n].d + p.vertex_length(vd.nodes[n].vertex, spot), vd.dist[n].site, vd.nodes[n].vertex};
    if (!(c < best) || !sea::taut(p.vis, vd.nodes[n], vd.from[n], x)) continue;
    ++asked;
    if (p.vis.sees(at, v)) best = c;
  }
  return best;
}

}  // namespace

SeaField brute_force_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const Window& window,
                         double max_distance, int threads, const MetricSpec& metric) {
  SeaOptions options;
  options.max_distance = max_distance;
  options.threads = threads;
  options.metric = metric;
  return brute_force_sea(seeds, barriers, grid, window, options);
}

SeaField brute_force_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const Window& window,
                         const SeaOptions& options) {
  const double max_distance = options.max_distance;
  const MetricSpec& metric = options.metric;
  const Prepared p = sea::prepare(seeds, barriers, grid, metric, options.geolocator);
  std::atomic<int64_t> tests{0};
  // Adjusted seeds: per class of (weight, reach) its own distances, the cheapest class's path
  // (sea::site_classes); else one class of every site.
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const bool adjusted = seeds.adjusted();
  const std::vector<SiteClass> classes =
      adjusted ? sea::site_classes(seeds, p.geometric) : std::vector<SiteClass>{SiteClass{1.0, kInf, p.geometric}};
  std::vector<VertexDistances> vds;
  for (const SiteClass& cls : classes) vds.push_back(vertex_distances(p, cls.sites, tests));

  SeaField out = sea::empty_field(p, grid, window, metric);
  const InteriorSpans interiors = interiors_of(seeds, options.grid_polygons.get(), grid, window);
  out.field.contested_cells = interiors.contested_cells;
  const double max_key = sea::max_key_of(max_distance);
  const int workers = resolve_threads(options.threads);
  std::vector<int64_t> land(static_cast<size_t>(workers), 0), unreachable(static_cast<size_t>(workers), 0);
  std::vector<double> detour(static_cast<size_t>(workers), 1.0);
  detail::parallel_for(workers, window.height, [&](int64_t r, int worker) {
    const auto& spans = interiors.rows[static_cast<size_t>(r)];
    std::vector<std::pair<double, int32_t>> order;
    int64_t asked = 0;
    std::vector<Spot> row;
    p.row_cells(grid, window, r, row);
    for (int64_t c = 0; c < window.width; ++c) {
      const Spot& spot = row[static_cast<size_t>(c)];
      const Vec2 x = spot.at;
      const Visibility::Ground ground = p.vis.classify(x);
      if (ground == Visibility::Ground::land) {
        ++land[static_cast<size_t>(worker)];
        continue;
      }
      const auto span =
          std::find_if(spans.begin(), spans.end(), [&](const Span& s) { return c >= s.col0 && c < s.col1; });
      if (span != spans.end()) {
        out.field.site.at(c, r) = span->site;
        out.field.distance.at(c, r) = 0.0f;
        continue;
      }
      Place at{x};
      at.open = ground == Visibility::Ground::open_sea;
      Best best;
      double cost = kInf, k0 = 0.0;
      // (Unreachable where some seed (class) is within the maximum distance (and its reach) in a
      // straight line and none of those has a path at all, as the exact engine counts.)
      bool straight = false, reached = false, within = false;
      for (size_t k = 0; k < classes.size(); ++k) {
        bool s = false;
        double key = 0.0;
        const Best b = cell_value(p, classes[k].sites, vds[k], at, spot, order, s, key, asked);
        const bool near = adjusted ? std::sqrt(key) <= std::min(max_distance, classes[k].reach) : key <= max_key;
        within = within || near;
        if (b.site == kNoSite) continue;
        reached = reached || near;
        if (!adjusted) {
          if (s ? key > max_key : b.d > max_distance) continue;
          best = b;
          straight = s;
          k0 = key;
          continue;
        }
        const double c =
            adjusted_distance(seeds.features()[static_cast<size_t>(seeds.site_feature(b.site))], b.d, max_distance);
        if (c < cost || (c == cost && c < kInf && b.site < best.site)) {
          best = b;
          cost = c;
          straight = s;
          k0 = key;
        }
      }
      if (!reached) {
        unreachable[static_cast<size_t>(worker)] += within ? 1 : 0;
        continue;
      }
      if (best.site == kNoSite) continue;
      out.field.site.at(c, r) = best.site;
      out.field.distance.at(c, r) = static_cast<float>(best.d);
      out.via.at(c, r) = best.via;
      // (Paths that bend, over the straight distance as the straight field stores it, a float, as
      // the exact engine.)
      if (k0 > 0.0 && !straight)
        detour[static_cast<size_t>(worker)] = std::max(detour[static_cast<size_t>(worker)],
                                                       best.d / static_cast<double>(static_cast<float>(std::sqrt(k0))));
    }
    tests += asked;
  });
  for (int w = 0; w < workers; ++w) {
    out.land_cells += land[static_cast<size_t>(w)];
    out.unreachable_cells += unreachable[static_cast<size_t>(w)];
    out.max_detour = std::max(out.max_detour, detour[static_cast<size_t>(w)]);
  }
  out.visibility_tests = tests.load();
  out.field.threads = workers;
  return out;
}

}  // namespace rv
