// The reference field of the distance by sea: the statement of rv/sea/sea_field.hpp evaluated
// literally, the oracle every faster method is compared with cell for cell.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <tuple>

#include "rv/field/error.hpp"
#include "rv/field/interior.hpp"
#include "rv/field/parallel.hpp"
#include "rv/field/planar.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/visibility.hpp"

namespace rv {
namespace {

using Place = Visibility::Place;

// A path's value: (distance, site, via); lower is better, ties to the lower site, then to a site
// seen directly (via -1) before a vertex, then to the lower vertex.
struct Best {
  double d = std::numeric_limits<double>::infinity();
  int32_t site = kNoSite;
  int32_t via = kNoVia;
  bool operator<(const Best& o) const { return std::tie(d, site, via) < std::tie(o.d, o.site, o.via); }
};

// The nearest point of a site from x (the local frame), as planar_key measures it, and whether it
// is an input vertex (exact) rather than a computed foot.
Place nearest_point(const LocalSite& s, Vec2 x) {
  double t = ((x.x - s.ax) * s.dx + (x.y - s.ay) * s.dy) * s.inv_len2;
  t = std::clamp(t, 0.0, 1.0);
  if (t == 0.0) return Place{Vec2{s.ax, s.ay}};
  if (t == 1.0) return Place{Vec2{s.bx(), s.by()}};
  Place p{Vec2{s.ax + t * s.dx, s.ay + t * s.dy}};
  p.exact = false;
  return p;
}

double length(Vec2 a, Vec2 b) { return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y)); }

// The seeds and barriers in the grid's local frame, checked.
struct Prepared {
  Visibility vis;
  std::vector<LocalSite> local;
  std::vector<int32_t> geometric;  // point and segment sites
};

Prepared prepare(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid) {
  if (seeds.geometric_site_count() == 0) throw Error(ErrorKind::invalid_input, "the seeds have no sites");
  if (seeds.adjusted())
    throw Error(ErrorKind::unsupported,
                "the distance by sea does not take weights or reaches yet: they change which seed a path may reach");
  for (const Feature& f : seeds.features())
    if (f.effect != 1.0) throw Error(ErrorKind::unsupported, "the distance by sea does not take partial effect yet");
  Prepared p{Visibility(barriers.translated(Vec2{grid.xmin, grid.ymax})), to_local(seeds, grid), {}};
  for (int32_t i = 0; i < static_cast<int32_t>(seeds.sites().size()); ++i) {
    const Site& s = seeds.sites()[static_cast<size_t>(i)];
    if (s.kind == SiteKind::area) continue;
    p.geometric.push_back(i);
    const LocalSite& l = p.local[static_cast<size_t>(i)];
    for (Vec2 end : {Vec2{l.ax, l.ay}, Vec2{l.bx(), l.by()}})
      if (p.vis.on_land(end))
        throw Error(ErrorKind::invalid_input, "the seed " + seeds.feature_name(s.feature) +
                                                  " has a vertex inside a barrier: a seed may lie on a barrier's "
                                                  "boundary, not inside it");
  }
  return p;
}

// D(v) per (vertex, sea wedge) node, by Dijkstra over the full visibility graph.
struct Node {
  int32_t vertex;
  int wedge;
};
struct VertexDistances {
  std::vector<Node> nodes;
  std::vector<Best> dist;
};

VertexDistances vertex_distances(const Prepared& p, std::atomic<int64_t>& tests) {
  const Visibility& vis = p.vis;
  VertexDistances out;
  for (int32_t v = 0; v < vis.vertex_count(); ++v)
    for (int k = 0; k < vis.vertex_star(v).wedges(); ++k)
      if (vis.vertex_star(v).sea[static_cast<size_t>(k)]) out.nodes.push_back(Node{v, k});
  const std::vector<Node>& nodes = out.nodes;
  std::vector<Best>& dist = out.dist;
  dist.resize(nodes.size());
  for (size_t n = 0; n < nodes.size(); ++n) {
    const Place at = vis.at_vertex(nodes[n].vertex, nodes[n].wedge);
    for (int32_t id : p.geometric) {
      const LocalSite& s = p.local[static_cast<size_t>(id)];
      const double key = planar_key(at.at.x, at.at.y, s);
      Best c{std::sqrt(key), id, kNoVia};
      if (!(c < dist[n])) continue;
      ++tests;
      if (key == 0.0 || vis.sees(at, nearest_point(s, at.at))) dist[n] = c;
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
      const Best c{dist[u].d + length(from.at, to.at), dist[u].site, kNoVia};
      if (!(c < dist[n])) continue;
      ++tests;
      if (vis.sees(from, to)) dist[n] = c;
    }
  }
  return out;
}

// One sea cell at x, off every seed polygon: its best path, whether it is the straight field's
// answer (the straight nearest site seen), and k0, the straight nearest key.
Best cell_value(const Prepared& p, const VertexDistances& vd, Vec2 x, std::vector<std::pair<double, int32_t>>& order,
                bool& straight, double& k0, int64_t& asked) {
  order.clear();
  for (int32_t id : p.geometric) order.emplace_back(planar_key(x.x, x.y, p.local[static_cast<size_t>(id)]), id);
  std::sort(order.begin(), order.end());
  k0 = order.front().first;
  Best best;
  straight = false;
  for (const auto& [key, id] : order) {
    ++asked;
    if (p.vis.sees(Place{x}, nearest_point(p.local[static_cast<size_t>(id)], x))) {
      best = Best{std::sqrt(key), id, kNoVia};
      straight = key == k0;
      break;
    }
  }
  if (straight) return best;
  // Hidden: a path round the vertices may be shorter than any site seen directly.
  for (size_t n = 0; n < vd.nodes.size(); ++n) {
    if (!std::isfinite(vd.dist[n].d)) continue;
    const Place v = p.vis.at_vertex(vd.nodes[n].vertex, vd.nodes[n].wedge);
    const Best c{vd.dist[n].d + length(v.at, x), vd.dist[n].site, vd.nodes[n].vertex};
    if (!(c < best)) continue;
    ++asked;
    if (p.vis.sees(Place{x}, v)) best = c;
  }
  return best;
}

}  // namespace

SeaField brute_force_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const Window& window,
                         double max_distance, int threads) {
  const Prepared p = prepare(seeds, barriers, grid);
  std::atomic<int64_t> tests{0};
  const VertexDistances vd = vertex_distances(p, tests);

  SeaField out;
  out.field.site = Raster<int32_t>(grid, window, kNoSite);
  out.field.distance = Raster<float>(grid, window, kNoDistance);
  out.field.metric = MetricSpec{};
  out.via = Raster<int32_t>(grid, window, kNoVia);
  out.barrier_vertices = p.vis.vertex_count();
  const InteriorSpans interiors = build_interiors(seeds, grid, window);
  out.field.contested_cells = interiors.contested_cells;
  const double max_key =
      std::isfinite(max_distance) ? max_distance * max_distance : std::numeric_limits<double>::infinity();
  const int workers = resolve_threads(threads);
  std::vector<int64_t> land(static_cast<size_t>(workers), 0), unreachable(static_cast<size_t>(workers), 0);
  std::vector<double> detour(static_cast<size_t>(workers), 1.0);
  detail::parallel_for(workers, window.height, [&](int64_t r, int worker) {
    const auto& spans = interiors.rows[static_cast<size_t>(r)];
    std::vector<std::pair<double, int32_t>> order;
    int64_t asked = 0;
    for (int64_t c = 0; c < window.width; ++c) {
      const Vec2 x{grid.local_x(window.col0 + c), grid.local_y(window.row0 + r)};
      if (p.vis.on_land(x)) {
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
      bool straight = false;
      double k0 = 0.0;
      const Best best = cell_value(p, vd, x, order, straight, k0, asked);
      if (best.site == kNoSite) {
        ++unreachable[static_cast<size_t>(worker)];
        continue;
      }
      if (straight ? k0 > max_key : best.d > max_distance) continue;
      out.field.site.at(c, r) = best.site;
      out.field.distance.at(c, r) = static_cast<float>(best.d);
      out.via.at(c, r) = best.via;
      if (k0 > 0.0)
        detour[static_cast<size_t>(worker)] = std::max(detour[static_cast<size_t>(worker)], best.d / std::sqrt(k0));
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
