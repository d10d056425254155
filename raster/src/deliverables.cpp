#include "rv/deliverables.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <numeric>
#include <set>
#include <unordered_map>

#include "exact_other.hpp"
#include "parallel.hpp"
#include "rv/error.hpp"
#include "rv/planar.hpp"

namespace rv {

// ---------------------------------------------------------------------------------------------
// SiteMetric: area sites and boxes.

// Polygon edges bucketed into horizontal slabs, so that an inside test looks at the edges of
// one slab only (coastline polygons have 1e4..1e6 edges; the boundary searches test the
// polygons of both owners at every evaluation).
struct SiteMetric::Slabs {
  double y0 = 0.0, height = 1.0;
  int64_t count = 1;
  std::vector<std::vector<std::pair<Vec2, Vec2>>> edges;  // per slab
};

SiteMetric::SiteMetric(const SeedSet& seeds) : SiteMetric(seeds, seeds.polygons()) {}

SiteMetric::SiteMetric(const SeedSet& seeds, const std::vector<Polygon>& polygons)
    : seeds_(seeds), polygons_(polygons) {
  if (polygons.size() != seeds.polygons().size())
    throw Error(ErrorKind::invalid_argument, "site metric: the polygons must be the seeds' polygons one for one");
  polygon_of_site_.assign(seeds.sites().size(), -1);
  for (size_t i = 0; i < polygons.size(); ++i) {
    const Polygon& poly = polygons[i];
    if (poly.area_site != seeds.polygons()[i].area_site)
      throw Error(ErrorKind::invalid_argument,
                  "site metric: polygon " + std::to_string(i) + " is not the seeds' polygon");
    polygon_of_site_[static_cast<size_t>(poly.area_site)] = static_cast<int32_t>(i);
    auto slabs = std::make_unique<Slabs>();
    double y0 = std::numeric_limits<double>::infinity(), y1 = -y0;
    size_t n = 0;
    for (const Ring& ring : poly.rings) {
      n += ring.size();
      for (const Vec2& v : ring) {
        y0 = std::min(y0, v.y);
        y1 = std::max(y1, v.y);
      }
    }
    slabs->count = std::clamp<int64_t>(static_cast<int64_t>(n / 8), 1, 4096);
    slabs->y0 = y0;
    slabs->height = std::max((y1 - y0) / static_cast<double>(slabs->count), 1e-300);
    slabs->edges.resize(static_cast<size_t>(slabs->count));
    auto slab_of = [&](double y) {
      const double s = std::floor((y - slabs->y0) / slabs->height);
      return static_cast<int64_t>(std::clamp(s, 0.0, static_cast<double>(slabs->count - 1)));
    };
    for (const Ring& ring : poly.rings)
      for (size_t k = 0; k < ring.size(); ++k) {
        const Vec2 a = ring[k], b = ring[(k + 1) % ring.size()];
        if (a.y == b.y) continue;  // horizontal edges never cross a horizontal ray
        for (int64_t s = slab_of(std::min(a.y, b.y)); s <= slab_of(std::max(a.y, b.y)); ++s)
          slabs->edges[static_cast<size_t>(s)].emplace_back(a, b);
      }
    slabs_.push_back(std::move(slabs));
  }
}

SiteMetric::~SiteMetric() = default;

bool SiteMetric::inside_area(Vec2 p, int32_t area_site) const {
  const int32_t pi = polygon_of_site_[static_cast<size_t>(area_site)];
  if (pi < 0) return false;
  const Slabs& sl = *slabs_[static_cast<size_t>(pi)];
  const double s = std::floor((p.y - sl.y0) / sl.height);
  if (!(s >= 0.0) || s >= static_cast<double>(sl.count)) return false;
  bool inside = false;
  for (const auto& [a, b] : sl.edges[static_cast<size_t>(s)]) {
    // Half-open in y, so a vertex on the ray counts once (the scanline convention).
    if ((a.y > p.y) != (b.y > p.y)) {
      const double x = a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
      if (p.x < x) inside = !inside;
    }
  }
  return inside;
}

Box3 SiteMetric::vertex_box(int32_t site) const {
  const Site& s = seeds_.sites()[static_cast<size_t>(site)];
  Box3 b{std::min(s.a.x, s.b.x), std::min(s.a.y, s.b.y), 0.0, std::max(s.a.x, s.b.x), std::max(s.a.y, s.b.y), 0.0};
  if (s.kind == SiteKind::area) {
    const int32_t pi = polygon_of_site_[static_cast<size_t>(site)];
    if (pi >= 0)
      for (const Vec2& v : polygons_[static_cast<size_t>(pi)].rings.front()) b.include({v.x, v.y, 0.0, v.x, v.y, 0.0});
  }
  return b;
}

void Box3::include(const Box3& b) {
  x0 = std::min(x0, b.x0);
  y0 = std::min(y0, b.y0);
  z0 = std::min(z0, b.z0);
  x1 = std::max(x1, b.x1);
  y1 = std::max(y1, b.y1);
  z1 = std::max(z1, b.z1);
}

double SiteMetric::lower_bound(const Vec3& q, const Box3& b) {
  const double dx = std::max({b.x0 - q.x, 0.0, q.x - b.x1});
  const double dy = std::max({b.y0 - q.y, 0.0, q.y - b.y1});
  const double dz = std::max({b.z0 - q.z, 0.0, q.z - b.z1});
  // A relative shave keeps the bound below the site distance despite rounding.
  return std::sqrt(dx * dx + dy * dy + dz * dz) * (1.0 - 1e-12);
}

// ---------------------------------------------------------------------------------------------
// PlanarSiteMetric.

PlanarSiteMetric::PlanarSiteMetric(const SeedSet& seeds, Vec2 origin) : SiteMetric(seeds), origin_(origin) {}

namespace {
// The site in the frame relative to `o` (as the engine's LocalSite, whatever the grid).
LocalSite local_of(const Site& s, Vec2 o) {
  LocalSite l;
  l.ax = s.a.x - o.x;
  l.ay = s.a.y - o.y;
  l.dx = (s.b.x - o.x) - l.ax;
  l.dy = (s.b.y - o.y) - l.ay;
  const double len2 = l.dx * l.dx + l.dy * l.dy;
  l.inv_len2 = (s.kind == SiteKind::segment && len2 > 0.0) ? 1.0 / len2 : 0.0;
  return l;
}
}  // namespace

double PlanarSiteMetric::distance(Vec2 p, int32_t site) const {
  const Site& s = seeds().sites()[static_cast<size_t>(site)];
  if (s.kind == SiteKind::area) return inside_area(p, site) ? 0.0 : std::numeric_limits<double>::infinity();
  return std::sqrt(planar_key(p.x - origin_.x, p.y - origin_.y, local_of(s, origin_)));
}

Vec3 PlanarSiteMetric::embed(Vec2 p) const { return Vec3{p.x - origin_.x, p.y - origin_.y, 0.0}; }

Box3 PlanarSiteMetric::site_bounds(int32_t site) const {
  Box3 b = vertex_box(site);
  b.x0 -= origin_.x;
  b.x1 -= origin_.x;
  b.y0 -= origin_.y;
  b.y1 -= origin_.y;
  return b;
}

Vec2 PlanarSiteMetric::nearest_point(Vec2 p, int32_t site) const {
  const Site& s = seeds().sites()[static_cast<size_t>(site)];
  if (s.kind == SiteKind::area) return p;
  if (s.kind == SiteKind::point) return s.a;
  const LocalSite l = local_of(s, origin_);
  double t = ((p.x - origin_.x - l.ax) * l.dx + (p.y - origin_.y - l.ay) * l.dy) * l.inv_len2;
  t = std::clamp(t, 0.0, 1.0);
  return Vec2{origin_.x + l.ax + t * l.dx, origin_.y + l.ay + t * l.dy};
}

double PlanarSiteMetric::point_distance(Vec2 a, Vec2 b) const { return std::hypot(a.x - b.x, a.y - b.y); }

// ---------------------------------------------------------------------------------------------
// OwnerIndex: one bounding-volume hierarchy per owner, searched depth-first nearest child first
// and pruned by the metric's lower bound. Exact whenever lower_bound() is a valid bound.

struct OwnerIndex::Tree {
  struct Node {
    Box3 box;
    int32_t left = -1, right = -1;  // children; -1 for a leaf
    int32_t begin = 0, end = 0;     // leaf: range of ids
  };
  std::vector<Node> nodes;
  std::vector<int32_t> ids;
  std::vector<Box3> boxes;  // per id position

  int32_t build(std::vector<std::pair<int32_t, Box3>>& items, int32_t begin, int32_t end) {
    Node n;
    n.box = items[static_cast<size_t>(begin)].second;
    for (int32_t i = begin; i < end; ++i) n.box.include(items[static_cast<size_t>(i)].second);
    const auto index = static_cast<int32_t>(nodes.size());
    nodes.push_back(n);
    if (end - begin <= 4) {
      nodes[static_cast<size_t>(index)].begin = static_cast<int32_t>(ids.size());
      for (int32_t i = begin; i < end; ++i) {
        ids.push_back(items[static_cast<size_t>(i)].first);
        boxes.push_back(items[static_cast<size_t>(i)].second);
      }
      nodes[static_cast<size_t>(index)].end = static_cast<int32_t>(ids.size());
      return index;
    }
    const double ex = n.box.x1 - n.box.x0, ey = n.box.y1 - n.box.y0, ez = n.box.z1 - n.box.z0;
    const int axis = ex >= ey && ex >= ez ? 0 : (ey >= ez ? 1 : 2);
    const int32_t mid = begin + (end - begin) / 2;
    std::nth_element(
        items.begin() + begin, items.begin() + mid, items.begin() + end, [&](const auto& a, const auto& b) {
          auto mid = [&](const Box3& x) { return axis == 0 ? x.x0 + x.x1 : (axis == 1 ? x.y0 + x.y1 : x.z0 + x.z1); };
          return mid(a.second) < mid(b.second);
        });
    const int32_t l = build(items, begin, mid);
    const int32_t r = build(items, mid, end);
    nodes[static_cast<size_t>(index)].left = l;
    nodes[static_cast<size_t>(index)].right = r;
    return index;
  }

  void search(const SiteMetric& m, int32_t node, Vec2 p, const Vec3& q, Hit& best) const {
    const Node& n = nodes[static_cast<size_t>(node)];
    if (n.left < 0) {
      for (int32_t i = n.begin; i < n.end; ++i) {
        if (SiteMetric::lower_bound(q, boxes[static_cast<size_t>(i)]) > best.distance) continue;
        const int32_t id = ids[static_cast<size_t>(i)];
        const double d = m.distance(p, id);
        if (d < best.distance || (d == best.distance && id < best.site)) best = Hit{id, d};
      }
      return;
    }
    const double ll = SiteMetric::lower_bound(q, nodes[static_cast<size_t>(n.left)].box);
    const double lr = SiteMetric::lower_bound(q, nodes[static_cast<size_t>(n.right)].box);
    const int32_t first = ll <= lr ? n.left : n.right, second = ll <= lr ? n.right : n.left;
    const double lf = std::min(ll, lr), ls = std::max(ll, lr);
    if (lf <= best.distance) search(m, first, p, q, best);
    if (ls <= best.distance) search(m, second, p, q, best);
  }
};

OwnerIndex::OwnerIndex(const SiteMetric& metric) : metric_(metric) {
  const SeedSet& seeds = metric.seeds();
  std::vector<std::vector<std::pair<int32_t, Box3>>> items(static_cast<size_t>(seeds.owner_count()));
  for (int32_t i = 0; i < static_cast<int32_t>(seeds.sites().size()); ++i)
    items[static_cast<size_t>(seeds.site_owner(i) - 1)].emplace_back(i, metric.site_bounds(i));
  for (auto& list : items) {
    auto tree = std::make_unique<Tree>();
    if (!list.empty()) tree->build(list, 0, static_cast<int32_t>(list.size()));
    trees_.push_back(std::move(tree));
  }
}

OwnerIndex::~OwnerIndex() = default;
OwnerIndex::OwnerIndex(OwnerIndex&&) noexcept = default;

OwnerIndex::Hit OwnerIndex::nearest_of(Vec2 p, int32_t owner) const {
  Hit best;
  if (owner < 1 || owner > static_cast<int32_t>(trees_.size())) return best;
  const Tree& t = *trees_[static_cast<size_t>(owner - 1)];
  if (!t.nodes.empty()) t.search(metric_, 0, p, metric_.embed(p), best);
  return best;
}

OwnerIndex::Hit OwnerIndex::nearest_not_of(Vec2 p, int32_t owner) const {
  // Owners in order of their trees' lower bounds, so the first search makes the rest prune.
  const Vec3 q = metric_.embed(p);
  std::vector<std::pair<double, int32_t>> order;
  order.reserve(trees_.size());
  for (size_t o = 0; o < trees_.size(); ++o) {
    if (static_cast<int32_t>(o) + 1 == owner || trees_[o]->nodes.empty()) continue;
    order.emplace_back(SiteMetric::lower_bound(q, trees_[o]->nodes[0].box), static_cast<int32_t>(o));
  }
  std::sort(order.begin(), order.end());
  Hit best;
  for (const auto& [lb, o] : order) {
    if (lb > best.distance) break;
    trees_[static_cast<size_t>(o)]->search(metric_, 0, p, q, best);
  }
  return best;
}

// ---------------------------------------------------------------------------------------------
// Shared machinery: root-finding, chaining, simplification.

namespace {

Vec2 centre(const GridSpec& g, int64_t col, int64_t row) { return Vec2{g.centre_x(col), g.centre_y(row)}; }
Vec2 lerp(Vec2 a, Vec2 b, double t) { return Vec2{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)}; }

// A root of f on [0, 1] given f(0) <= 0 <= f(1) (or the reverse): the Illinois variant of
// regula falsi, with a bisection step whenever the bracket failed to halve, so convergence is
// superlinear on smooth stretches and never worse than bisection where the controlling seed
// changes. Stops when |f| <= ftol or the bracket is below t_tol. If f does not change sign the
// end with the smaller |f| is returned.
template <class F>
double find_root(F&& f, double f0, double f1, double ftol, double t_tol) {
  if (std::abs(f0) <= ftol) return 0.0;
  if (std::abs(f1) <= ftol) return 1.0;
  if ((f0 < 0.0) == (f1 < 0.0)) return std::abs(f0) <= std::abs(f1) ? 0.0 : 1.0;
  double a = 0.0, b = 1.0, fa = f0, fb = f1;
  int side = 0;
  double width = 1.0;
  for (int iter = 0; iter < 200; ++iter) {
    double t;
    if (iter % 3 == 2 && (b - a) > 0.5 * width) {
      t = 0.5 * (a + b);  // the last steps did not halve the bracket
    } else {
      t = (a * fb - b * fa) / (fb - fa);
      if (!(t > a && t < b)) t = 0.5 * (a + b);
    }
    if (iter % 3 == 2) width = b - a;
    const double ft = f(t);
    if (std::abs(ft) <= ftol) return t;
    if ((ft < 0.0) == (fa < 0.0)) {
      a = t;
      fa = ft;
      if (side == -1) fb *= 0.5;
      side = -1;
    } else {
      b = t;
      fb = ft;
      if (side == 1) fa *= 0.5;
      side = 1;
    }
    if (b - a <= t_tol) break;
  }
  return std::abs(fa) <= std::abs(fb) ? a : b;
}

// Links between graph nodes; chains them into polylines. A chain starts and stops at terminal
// nodes (tripoints, or nodes of degree other than 2); what is left are closed rings.
struct Chains {
  std::vector<std::vector<int32_t>> node_lists;
  std::vector<bool> closed;
  std::vector<int32_t> first_link;  // the link each chain started with (its pair tag)
};

Chains chain_links(int32_t node_count, const std::vector<std::array<int32_t, 2>>& links,
                   const std::vector<bool>& always_terminal) {
  std::vector<int32_t> degree(static_cast<size_t>(node_count) + 1, 0);
  for (const auto& l : links) {
    ++degree[static_cast<size_t>(l[0]) + 1];
    ++degree[static_cast<size_t>(l[1]) + 1];
  }
  std::vector<int32_t> offset(degree);
  for (size_t i = 1; i < offset.size(); ++i) offset[i] += offset[i - 1];
  std::vector<int32_t> adj(static_cast<size_t>(offset.back()));
  std::vector<int32_t> fill(offset.begin(), offset.end() - 1);
  for (int32_t li = 0; li < static_cast<int32_t>(links.size()); ++li) {
    adj[static_cast<size_t>(fill[static_cast<size_t>(links[li][0])]++)] = li;
    adj[static_cast<size_t>(fill[static_cast<size_t>(links[li][1])]++)] = li;
  }
  auto deg = [&](int32_t n) { return offset[static_cast<size_t>(n) + 1] - offset[static_cast<size_t>(n)]; };
  auto terminal = [&](int32_t n) { return always_terminal[static_cast<size_t>(n)] || deg(n) != 2; };
  std::vector<bool> used(links.size(), false);
  Chains out;
  auto walk = [&](int32_t start, int32_t link) {
    std::vector<int32_t> nodes{start};
    const int32_t first = link;
    int32_t cur = start;
    while (true) {
      used[static_cast<size_t>(link)] = true;
      const auto& l = links[static_cast<size_t>(link)];
      const int32_t nxt = l[0] == cur ? l[1] : l[0];
      nodes.push_back(nxt);
      if (terminal(nxt)) break;
      int32_t again = -1;
      for (int32_t k = offset[static_cast<size_t>(nxt)]; k < offset[static_cast<size_t>(nxt) + 1]; ++k)
        if (!used[static_cast<size_t>(adj[static_cast<size_t>(k)])]) again = adj[static_cast<size_t>(k)];
      if (again < 0) break;
      link = again;
      cur = nxt;
    }
    out.closed.push_back(nodes.size() > 2 && nodes.front() == nodes.back());
    out.node_lists.push_back(std::move(nodes));
    out.first_link.push_back(first);
  };
  for (int32_t n = 0; n < node_count; ++n) {
    if (!terminal(n)) continue;
    for (int32_t k = offset[static_cast<size_t>(n)]; k < offset[static_cast<size_t>(n) + 1]; ++k)
      if (!used[static_cast<size_t>(adj[static_cast<size_t>(k)])]) walk(n, adj[static_cast<size_t>(k)]);
  }
  for (int32_t li = 0; li < static_cast<int32_t>(links.size()); ++li)
    if (!used[static_cast<size_t>(li)]) walk(links[static_cast<size_t>(li)][0], li);
  return out;
}

// Grid edges between 4-neighbour cell centres: id 2*(row*W + col) joins (col,row)-(col+1,row),
// id 2*(row*W + col) + 1 joins (col,row)-(col,row+1).
int64_t edge_right(int64_t w, int64_t c, int64_t r) { return 2 * (r * w + c); }
int64_t edge_down(int64_t w, int64_t c, int64_t r) { return 2 * (r * w + c) + 1; }

// The four edges of dual square (c, r), in order top, right, bottom, left; corner k lies between
// edge k-1 and edge k (corners: 0 = (c,r), 1 = (c+1,r), 2 = (c+1,r+1), 3 = (c,r+1)).
std::array<int64_t, 4> square_edges(int64_t w, int64_t c, int64_t r) {
  return {edge_right(w, c, r), edge_down(w, c + 1, r), edge_right(w, c, r + 1), edge_down(w, c, r)};
}

// The field's distances and ownership and the metric's must agree, or the roots are sought in
// a different geometry than the one that decided the owners.
void check_metric(const NearestField& field, const SiteMetric& metric) {
  // A projected geodesic field needs a metric that locates grid positions on the ellipsoid,
  // and only such a field may use one.
  const bool located_metric = dynamic_cast<const LocatedGeodesicSiteMetric*>(&metric) != nullptr;
  if (static_cast<bool>(field.geolocator) != located_metric)
    throw Error(ErrorKind::invalid_argument,
                field.geolocator ? "a field of a projected geodesic grid needs a LocatedGeodesicSiteMetric"
                                 : "a LocatedGeodesicSiteMetric measures fields of projected geodesic grids only");
  const bool geodesic_metric = located_metric || dynamic_cast<const GeodesicSiteMetric*>(&metric) != nullptr;
  if ((field.metric.kind == MetricSpec::geodesic) != geodesic_metric)
    throw Error(ErrorKind::invalid_argument, std::string("the deliverables' metric must be the field's (") +
                                                 std::string(to_string(field.metric.kind)) + ")");
}

void check_whole_grid(const NearestField& field) {
  if (!(field.site.window() == field.site.grid().full_window()))
    throw Error(ErrorKind::invalid_argument, "deliverables need a field that covers the whole grid");
  if (field.site.grid().width < 1 || field.site.grid().height < 1)
    throw Error(ErrorKind::invalid_argument, "deliverables need a non-empty grid");
}

// Metric length of one cell near the grid centre: the scale of every tolerance.
double cell_metric(const GridSpec& g, const SiteMetric& m) {
  const int64_t c = g.width / 2, r = g.height / 2;
  const double d = m.point_distance(Vec2{g.centre_x(c), g.centre_y(r)}, Vec2{g.centre_x(c) + g.res, g.centre_y(r)});
  return d > 0.0 && std::isfinite(d) ? d : g.res;
}

}  // namespace

std::vector<size_t> simplify_indices(std::span<const Vec2> pts, double tolerance) {
  const size_t n = pts.size();
  if (n <= 2 || !(tolerance > 0.0)) {
    std::vector<size_t> all(n);
    std::iota(all.begin(), all.end(), size_t{0});
    return all;
  }
  std::vector<bool> keep(n, false);
  keep[0] = keep[n - 1] = true;
  std::vector<std::pair<size_t, size_t>> stack{{0, n - 1}};
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    if (j <= i + 1) continue;
    const Vec2 a = pts[i], b = pts[j];
    const double dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
    double worst = -1.0;
    size_t at = i;
    for (size_t k = i + 1; k < j; ++k) {
      double t = len2 > 0.0 ? ((pts[k].x - a.x) * dx + (pts[k].y - a.y) * dy) / len2 : 0.0;
      t = std::clamp(t, 0.0, 1.0);
      const double d = std::hypot(pts[k].x - (a.x + t * dx), pts[k].y - (a.y + t * dy));
      if (d > worst) {
        worst = d;
        at = k;
      }
    }
    if (worst > tolerance) {
      keep[at] = true;
      stack.emplace_back(i, at);
      stack.emplace_back(at, j);
    }
  }
  std::vector<size_t> out;
  for (size_t k = 0; k < n; ++k)
    if (keep[k]) out.push_back(k);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Boundaries and tripoints.

namespace {

struct Crossing {
  int64_t edge;
  int32_t owner_lo, owner_hi;
  BoundaryVertex v;
};

// How deep the owners passing between two cell centres are followed (A | C D E ... | B): each
// level finds one more owner between; beyond it the segment is dropped as unresolved.
constexpr int kMaxSliverDepth = 8;

struct TripointSolver {
  const OwnerIndex& index;
  double ftol;  // metric units
  double step;  // finite-difference step, CRS units

  // Solves d_X = d_Y = d_Z from `start` (Gauss-Newton, numeric Jacobian, step halving).
  bool solve(const std::array<int32_t, 3>& o, Vec2 start, double max_move, Tripoint& out) const {
    auto eval = [&](Vec2 p, std::array<double, 2>& f, std::array<OwnerIndex::Hit, 3>* hits) {
      const auto a = index.nearest_of(p, o[0]), b = index.nearest_of(p, o[1]), c = index.nearest_of(p, o[2]);
      f = {a.distance - b.distance, a.distance - c.distance};
      if (hits) *hits = {a, b, c};
      return std::isfinite(f[0]) && std::isfinite(f[1]);
    };
    Vec2 p = start;
    std::array<double, 2> f;
    if (!eval(p, f, nullptr)) return false;
    for (int iter = 0; iter < 60; ++iter) {
      const double norm = std::max(std::abs(f[0]), std::abs(f[1]));
      if (norm <= ftol) {
        std::array<OwnerIndex::Hit, 3> h;
        eval(p, f, &h);
        out.p = p;
        for (int k = 0; k < 3; ++k) {
          out.owners[k] = o[static_cast<size_t>(k)];
          out.sites[k] = h[static_cast<size_t>(k)].site;
        }
        out.distance = (h[0].distance + h[1].distance + h[2].distance) / 3.0;
        out.residual = std::max({std::abs(h[0].distance - h[1].distance), std::abs(h[0].distance - h[2].distance),
                                 std::abs(h[1].distance - h[2].distance)});
        return true;
      }
      std::array<double, 2> fx, fy;
      if (!eval(Vec2{p.x + step, p.y}, fx, nullptr) || !eval(Vec2{p.x, p.y + step}, fy, nullptr)) return false;
      const double j00 = (fx[0] - f[0]) / step, j01 = (fy[0] - f[0]) / step;
      const double j10 = (fx[1] - f[1]) / step, j11 = (fy[1] - f[1]) / step;
      const double det = j00 * j11 - j01 * j10;
      if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return false;
      double dx = (-f[0] * j11 + f[1] * j01) / det;
      double dy = (-j00 * f[1] + j10 * f[0]) / det;
      const double len = std::hypot(dx, dy);
      if (len > max_move) {
        dx *= max_move / len;
        dy *= max_move / len;
      }
      // Step halving: accept the first step that reduces the residual.
      bool moved = false;
      for (int h = 0; h < 30; ++h) {
        const Vec2 q{p.x + dx, p.y + dy};
        std::array<double, 2> fq;
        if (eval(q, fq, nullptr) && std::max(std::abs(fq[0]), std::abs(fq[1])) < norm) {
          p = q;
          f = fq;
          moved = true;
          break;
        }
        dx *= 0.5;
        dy *= 0.5;
      }
      if (!moved) return false;
      if (std::hypot(p.x - start.x, p.y - start.y) > 4.0 * max_move) return false;
    }
    return false;
  }
};

}  // namespace

BoundaryResult extract_boundaries(const NearestField& field, const OwnerIndex& index, const BoundaryOptions& options) {
  check_whole_grid(field);
  check_metric(field, index.metric());
  const GridSpec& g = field.site.grid();
  const SiteMetric& metric = index.metric();
  const SeedSet& seeds = metric.seeds();
  const int64_t W = g.width, H = g.height;
  const int threads = resolve_threads(options.threads);
  const double cell = cell_metric(g, metric);
  const double ftol = std::max(options.tolerance_cells, 1e-15) * cell;
  BoundaryResult result;

  std::vector<int32_t> owner_of_site(seeds.sites().size());
  for (size_t i = 0; i < owner_of_site.size(); ++i) owner_of_site[i] = seeds.site_owner(static_cast<int32_t>(i));
  auto owner = [&](int64_t c, int64_t r) {
    const int32_t s = field.site.at(c, r);
    return s == kNoSite ? 0 : owner_of_site[static_cast<size_t>(s)];
  };

  // 1. Crossings: every 4-neighbour pair of differently owned cells, placed on the locus.
  struct Segment {
    int64_t edge;
    int32_t from, to;  // owner of the first and the second cell centre
  };
  std::vector<Segment> segments;
  for (int64_t r = 0; r < H; ++r)
    for (int64_t c = 0; c < W; ++c) {
      const int32_t o = owner(c, r);
      if (o == 0) continue;
      if (c + 1 < W) {
        const int32_t q = owner(c + 1, r);
        if (q != 0 && q != o) segments.push_back(Segment{edge_right(W, c, r), o, q});
      }
      if (r + 1 < H) {
        const int32_t q = owner(c, r + 1);
        if (q != 0 && q != o) segments.push_back(Segment{edge_down(W, c, r), o, q});
      }
    }
  result.stats.crossings = static_cast<int64_t>(segments.size());
  // A third owner nearer than both at the A-B root means its region passes between the two
  // cell centres without holding one: A and B do not touch there. The segment then carries the
  // A-C and C-B crossings instead (and so on, for more owners between): without them the
  // sides of a region thinner than a cell would have no vertex until the region holds a
  // centre, and the lines along it could not reach the tripoint at its tip (they dangled).
  const int64_t chunk = 256;
  const int64_t chunks = (static_cast<int64_t>(segments.size()) + chunk - 1) / chunk;
  std::vector<std::vector<Crossing>> chunk_crossings(static_cast<size_t>(chunks));
  std::vector<std::vector<std::pair<int64_t, int32_t>>> chunk_slivers(static_cast<size_t>(chunks));
  std::vector<int64_t> chunk_unresolved(static_cast<size_t>(chunks), 0);
  detail::parallel_for(threads, chunks, [&](int64_t k, int) {
    auto& out = chunk_crossings[static_cast<size_t>(k)];
    const size_t end = std::min(segments.size(), static_cast<size_t>((k + 1) * chunk));
    for (size_t i = static_cast<size_t>(k * chunk); i < end; ++i) {
      const Segment& sg = segments[i];
      const int64_t cell_id = sg.edge / 2;
      const int64_t c = cell_id % W, r = cell_id / W;
      const Vec2 p0 = centre(g, c, r);
      const Vec2 p1 = (sg.edge % 2 == 0) ? centre(g, c + 1, r) : centre(g, c, r + 1);
      // Owner x is nearest at t0, owner y at t1: place the x-y root, or split at the owner
      // found nearer there. Appends in order of t.
      auto place = [&](auto&& self, int32_t x, int32_t y, double t0, double t1, int depth) -> void {
        auto f = [&](double t) {
          const Vec2 p = lerp(p0, p1, t);
          return index.nearest_of(p, x).distance - index.nearest_of(p, y).distance;
        };
        const double t =
            t0 + (t1 - t0) * find_root([&](double u) { return f(t0 + (t1 - t0) * u); }, f(t0), f(t1), ftol, 1e-15);
        const Vec2 p = lerp(p0, p1, t);
        const auto hx = index.nearest_of(p, x), hy = index.nearest_of(p, y);
        BoundaryVertex v{p, hx.site, hy.site, 0.5 * (hx.distance + hy.distance), std::abs(hx.distance - hy.distance)};
        const auto nearest = index.nearest(p);
        if (nearest.distance < v.distance - 4.0 * ftol - v.residual) {
          const int32_t z = owner_of_site[static_cast<size_t>(nearest.site)];
          if (depth == 0) chunk_slivers[static_cast<size_t>(k)].emplace_back(sg.edge, z);
          if (depth >= kMaxSliverDepth) {
            ++chunk_unresolved[static_cast<size_t>(k)];
            return;
          }
          self(self, x, z, t0, t, depth + 1);
          self(self, z, y, t, t1, depth + 1);
          return;
        }
        if (x > y) std::swap(v.site_a, v.site_b);
        out.push_back(Crossing{sg.edge, std::min(x, y), std::max(x, y), v});
      };
      place(place, sg.from, sg.to, 0.0, 1.0, 0);
    }
  });
  std::vector<Crossing> crossings;
  // Edge -> its crossings: consecutive in `crossings` (first index, count), in order along it.
  std::unordered_map<int64_t, std::pair<int32_t, int32_t>> crossings_on;
  crossings_on.reserve(segments.size() * 2);
  std::unordered_map<int64_t, int32_t> sliver_at;  // edge -> the (first) owner passing between
  for (size_t k = 0; k < chunk_crossings.size(); ++k) {
    for (const Crossing& x : chunk_crossings[k]) {
      auto [it, fresh] = crossings_on.try_emplace(x.edge, static_cast<int32_t>(crossings.size()), 0);
      ++it->second.second;
      crossings.push_back(x);
    }
    for (const auto& [edge, third] : chunk_slivers[k]) sliver_at.emplace(edge, third);
    result.stats.unresolved_slivers += chunk_unresolved[k];
  }
  result.stats.sliver_crossings = static_cast<int64_t>(sliver_at.size());

  // 2. Dual squares: tripoints, then links between crossings and tripoints.
  std::vector<std::array<int32_t, 2>> links;  // node ids: crossings, then tripoints
  std::vector<int64_t> link_pair;             // owner_lo * 2^32 + owner_hi
  const auto ncross = static_cast<int32_t>(crossings.size());
  auto pair_key = [](int32_t a, int32_t b) {
    return (static_cast<int64_t>(std::min(a, b)) << 32) | static_cast<int64_t>(std::max(a, b));
  };
  std::set<std::pair<int32_t, int32_t>> linked;  // a crossing is seen from both its squares
  auto add_link = [&](int32_t n1, int32_t n2, int64_t pair) {
    if (!linked.emplace(std::min(n1, n2), std::max(n1, n2)).second) return;
    links.push_back({n1, n2});
    link_pair.push_back(pair);
  };
  auto square_mid = [&](int64_t c, int64_t r) {
    return Vec2{g.xmin + (static_cast<double>(c) + 1.0) * g.res, g.ymax - (static_cast<double>(r) + 1.0) * g.res};
  };
  auto corner_owners = [&](int64_t c, int64_t r) {
    return std::array<int32_t, 4>{owner(c, r), owner(c + 1, r), owner(c + 1, r + 1), owner(c, r + 1)};
  };

  // 2a. Tripoints. Candidate squares: three or more corner owners, or a sliver edge (an owner
  // passing between two centres adds itself to the square's owners). Each tripoint found is
  // filed under the square it actually lies in, which need not be the square it was sought from.
  TripointSolver solver{index, ftol, 1e-6 * g.res};
  std::map<std::array<int32_t, 3>, std::vector<int32_t>> tripoints_by_owners;
  std::unordered_map<int64_t, std::vector<int32_t>> tripoints_in;  // square id -> tripoint ids
  // A tripoint between the outermost cell centres and the grid's edge is filed under the
  // border square next to it: the lines of the border squares end there, not half a cell short
  // of it (dropping such tripoints left those lines dangling). Outside the grid: none.
  auto square_of = [&](Vec2 p) -> int64_t {
    const double gc = (p.x - g.xmin) / g.res, gr = (g.ymax - p.y) / g.res;
    if (!(gc >= 0.0 && gr >= 0.0 && gc <= static_cast<double>(W) && gr <= static_cast<double>(H))) return -1;
    if (W < 2 || H < 2) return -1;
    const double fc = std::clamp(std::floor(gc - 0.5), 0.0, static_cast<double>(W - 2));
    const double fr = std::clamp(std::floor(gr - 0.5), 0.0, static_cast<double>(H - 2));
    return static_cast<int64_t>(fr) * W + static_cast<int64_t>(fc);
  };
  auto add_tripoint = [&](const Tripoint& t) {
    auto& list = tripoints_by_owners[{t.owners[0], t.owners[1], t.owners[2]}];
    for (int32_t id : list) {
      const Vec2 q = result.tripoints[static_cast<size_t>(id)].p;
      if (std::hypot(q.x - t.p.x, q.y - t.p.y) <= 1e-6 * g.res) return;
    }
    const int64_t sq = square_of(t.p);
    if (sq < 0) return;  // outside the dual grid: no cell-centre square holds it
    const auto id = static_cast<int32_t>(result.tripoints.size());
    result.tripoints.push_back(t);
    list.push_back(id);
    tripoints_in[sq].push_back(id);
  };
  for (int64_t r = 0; r + 1 < H; ++r)
    for (int64_t c = 0; c + 1 < W; ++c) {
      const auto o = corner_owners(c, r);
      if (o[0] == o[1] && o[1] == o[2] && o[2] == o[3]) continue;
      std::vector<int32_t> distinct;
      for (int32_t v : o)
        if (v != 0 && std::find(distinct.begin(), distinct.end(), v) == distinct.end()) distinct.push_back(v);
      if (!sliver_at.empty())
        for (int64_t e : square_edges(W, c, r)) {
          const auto it = sliver_at.find(e);
          if (it != sliver_at.end() && std::find(distinct.begin(), distinct.end(), it->second) == distinct.end())
            distinct.push_back(it->second);
        }
      if (distinct.size() < 3) continue;
      std::sort(distinct.begin(), distinct.end());
      ++result.stats.multi_owner_squares;
      const Vec2 mid = square_mid(c, r);
      const size_t before = result.tripoints.size();
      for (size_t i = 0; i < distinct.size(); ++i)
        for (size_t j = i + 1; j < distinct.size(); ++j)
          for (size_t k = j + 1; k < distinct.size(); ++k) {
            Tripoint t;
            if (!solver.solve({distinct[i], distinct[j], distinct[k]}, mid, g.res, t)) continue;
            if (std::abs(t.p.x - mid.x) > g.res || std::abs(t.p.y - mid.y) > g.res) continue;
            const auto any = index.nearest(t.p);
            if (any.distance < t.distance - 4.0 * ftol - t.residual) continue;  // another owner is nearer
            add_tripoint(t);
          }
      if (result.tripoints.size() == before && tripoints_in.find(r * W + c) == tripoints_in.end())
        ++result.stats.unresolved_tripoints;
    }

  // 2b. Links per square.
  auto has = [](const Tripoint& t, int32_t a) { return t.owners[0] == a || t.owners[1] == a || t.owners[2] == a; };
  // The nearest tripoint of `ids` that has both owners of the crossing, or -1.
  auto nearest_tripoint = [&](const Crossing& cr, const std::vector<int32_t>& ids) {
    int32_t best = -1;
    double best_d = std::numeric_limits<double>::infinity();
    for (int32_t id : ids) {
      const Tripoint& t = result.tripoints[static_cast<size_t>(id)];
      if (!has(t, cr.owner_lo) || !has(t, cr.owner_hi)) continue;
      const double d = std::hypot(t.p.x - cr.v.p.x, t.p.y - cr.v.p.y);
      if (d < best_d) {
        best_d = d;
        best = id;
      }
    }
    return best;
  };
  for (int64_t r = 0; r + 1 < H; ++r)
    for (int64_t c = 0; c + 1 < W; ++c) {
      const auto o = corner_owners(c, r);
      if (o[0] == o[1] && o[1] == o[2] && o[2] == o[3]) continue;
      const auto edges = square_edges(W, c, r);
      // The crossings on the square's edges: (edge k, crossing id); an edge crossed by owners
      // passing between its two centres carries several.
      std::vector<std::pair<int, int32_t>> items;
      std::array<int, 4> per_edge{0, 0, 0, 0};
      for (int k = 0; k < 4; ++k) {
        const auto it = crossings_on.find(edges[static_cast<size_t>(k)]);
        if (it == crossings_on.end()) continue;
        for (int32_t i = 0; i < it->second.second; ++i) items.emplace_back(k, it->second.first + i);
        per_edge[static_cast<size_t>(k)] = it->second.second;
      }
      if (items.empty()) continue;
      auto cross = [&](size_t item) -> const Crossing& { return crossings[static_cast<size_t>(items[item].second)]; };
      auto node = [&](size_t item) { return items[item].second; };
      const auto here = tripoints_in.find(r * W + c);
      std::vector<size_t> unlinked;
      if (here != tripoints_in.end()) {
        // Crossings end at the nearest tripoint of their pair filed in this square. A tripoint
        // filed here from the half cell beyond the outermost centres (see square_of) lies
        // outside the square: the line may cross the square on its way there, so only the
        // crossing nearest to it ends there, and the others are paired below.
        const double x0 = g.centre_x(c), x1 = g.centre_x(c + 1), y0 = g.centre_y(r + 1), y1 = g.centre_y(r);
        std::vector<int32_t> target(items.size(), -1);
        std::map<std::pair<int32_t, int64_t>, size_t> nearest_to_outside;  // (tripoint, pair) -> item
        for (size_t i = 0; i < items.size(); ++i) {
          const int32_t t = nearest_tripoint(cross(i), here->second);
          if (t < 0) continue;
          target[i] = t;
          const Vec2 q = result.tripoints[static_cast<size_t>(t)].p;
          if (q.x >= x0 && q.x <= x1 && q.y >= y0 && q.y <= y1) continue;
          const auto key = std::make_pair(t, pair_key(cross(i).owner_lo, cross(i).owner_hi));
          auto [it, fresh] = nearest_to_outside.try_emplace(key, i);
          auto dist = [&](size_t j) { return std::hypot(q.x - cross(j).v.p.x, q.y - cross(j).v.p.y); };
          if (!fresh && dist(i) < dist(it->second)) it->second = i;
        }
        // The line to an outside tripoint that leaves the square through the edge facing it
        // (the outermost centre line) entered it through another edge: with exactly one other
        // crossing of the pair here, that one is joined to the crossing on the facing edge.
        std::vector<bool> joined(items.size(), false);
        for (const auto& [key, n] : nearest_to_outside) {
          const Vec2 q = result.tripoints[static_cast<size_t>(key.first)].p;
          const int k = items[n].first;
          const bool facing =
              (k == 0 && q.y > y1) || (k == 1 && q.x > x1) || (k == 2 && q.y < y0) || (k == 3 && q.x < x0);
          std::vector<size_t> same;
          for (size_t i = 0; i < items.size(); ++i)
            if (i != n && pair_key(cross(i).owner_lo, cross(i).owner_hi) == key.second) same.push_back(i);
          if (facing && same.size() == 1) {
            add_link(node(same[0]), node(n), key.second);
            joined[same[0]] = true;
          }
        }
        for (size_t i = 0; i < items.size(); ++i) {
          if (joined[i]) continue;
          const int32_t t = target[i];
          bool ends_here = t >= 0;
          if (ends_here) {
            const auto it = nearest_to_outside.find({t, pair_key(cross(i).owner_lo, cross(i).owner_hi)});
            ends_here = it == nearest_to_outside.end() || it->second == i;
          }
          if (ends_here)
            add_link(node(i), ncross + t, pair_key(cross(i).owner_lo, cross(i).owner_hi));
          else
            unlinked.push_back(i);
        }
        // Two tripoints sharing two owners are joined by those owners' boundary.
        const auto& ids = here->second;
        for (size_t i = 0; i < ids.size(); ++i)
          for (size_t j = i + 1; j < ids.size(); ++j) {
            const Tripoint& ti = result.tripoints[static_cast<size_t>(ids[i])];
            const Tripoint& tj = result.tripoints[static_cast<size_t>(ids[j])];
            std::vector<int32_t> shared;
            for (int32_t a : ti.owners)
              if (has(tj, a)) shared.push_back(a);
            if (shared.size() == 2) add_link(ncross + ids[i], ncross + ids[j], pair_key(shared[0], shared[1]));
          }
      } else if (per_edge == std::array<int, 4>{1, 1, 1, 1} && o[0] == o[2] && o[1] == o[3] && o[0] != o[1]) {
        // Saddle A B / B A: the owner of the square's centre connects its two corners.
        ++result.stats.saddles;
        const Vec2 mid = square_mid(c, r);
        const auto h0 = index.nearest_of(mid, o[0]), h1 = index.nearest_of(mid, o[1]);
        const bool centre_is_o0 = h0.distance < h1.distance || (h0.distance == h1.distance && h0.site < h1.site);
        const int64_t pair = pair_key(o[0], o[1]);
        if (centre_is_o0) {  // corners 1 and 3 are cut off
          add_link(node(0), node(1), pair);
          add_link(node(2), node(3), pair);
        } else {  // corners 0 and 2 are cut off
          add_link(node(3), node(0), pair);
          add_link(node(1), node(2), pair);
        }
        continue;
      } else {
        unlinked.resize(items.size());
        std::iota(unlinked.begin(), unlinked.end(), size_t{0});
      }
      // Crossings of one pair, two in the square: joined. A lone crossing whose pair has a
      // tripoint in a neighbouring square (its third owner passed between two centres): joined
      // to that tripoint.
      for (size_t k : unlinked) {
        int same = 0;
        size_t other = 0;
        for (size_t m : unlinked)
          if (m != k && cross(m).owner_lo == cross(k).owner_lo && cross(m).owner_hi == cross(k).owner_hi) {
            ++same;
            other = m;
          }
        const int64_t pair = pair_key(cross(k).owner_lo, cross(k).owner_hi);
        if (same == 1) {
          if (k < other) add_link(node(k), node(other), pair);
          continue;
        }
        if (same > 1) continue;
        std::vector<int32_t> around;
        for (int64_t dr = -1; dr <= 1; ++dr)
          for (int64_t dc = -1; dc <= 1; ++dc) {
            if ((dr == 0 && dc == 0) || r + dr < 0 || c + dc < 0 || r + dr + 1 >= H || c + dc + 1 >= W) continue;
            const auto it = tripoints_in.find((r + dr) * W + (c + dc));
            if (it != tripoints_in.end()) around.insert(around.end(), it->second.begin(), it->second.end());
          }
        // The line leaves the crossing into this square, so the tripoint lies on this square's
        // side of the crossing's edge (edges: 0 top, 1 right, 2 bottom, 3 left).
        const Vec2 e = cross(k).v.p;
        const int side = items[k].first;
        std::erase_if(around, [&](int32_t id) {
          const Vec2 q = result.tripoints[static_cast<size_t>(id)].p;
          switch (side) {
            case 0:
              return !(q.y < e.y);
            case 1:
              return !(q.x < e.x);
            case 2:
              return !(q.y > e.y);
            default:
              return !(q.x > e.x);
          }
        });
        const int32_t t = nearest_tripoint(cross(k), around);
        if (t >= 0) add_link(node(k), ncross + t, pair);
      }
    }

  // 3. Chains per owner pair.
  const auto ntri = static_cast<int32_t>(result.tripoints.size());
  std::vector<bool> terminal(static_cast<size_t>(ncross + ntri), false);
  for (int32_t i = 0; i < ntri; ++i) terminal[static_cast<size_t>(ncross + i)] = true;
  const Chains chains = chain_links(ncross + ntri, links, terminal);
  const double tol = options.simplify_cells * g.res;
  for (size_t k = 0; k < chains.node_lists.size(); ++k) {
    const int64_t pair = link_pair[static_cast<size_t>(chains.first_link[k])];
    BoundaryLine line;
    line.owner_a = static_cast<int32_t>(pair >> 32);
    line.owner_b = static_cast<int32_t>(pair & 0xffffffff);
    line.closed = chains.closed[k];
    std::vector<BoundaryVertex> all;
    for (int32_t node : chains.node_lists[k]) {
      if (node < ncross) {
        all.push_back(crossings[static_cast<size_t>(node)].v);
        continue;
      }
      const Tripoint& t = result.tripoints[static_cast<size_t>(node - ncross)];
      BoundaryVertex v{t.p, kNoSite, kNoSite, t.distance, t.residual};
      for (int i = 0; i < 3; ++i) {
        if (t.owners[i] == line.owner_a) v.site_a = t.sites[i];
        if (t.owners[i] == line.owner_b) v.site_b = t.sites[i];
      }
      all.push_back(v);
    }
    result.stats.vertices_before_simplify += static_cast<int64_t>(all.size());
    std::vector<Vec2> pts;
    pts.reserve(all.size());
    for (const auto& v : all) pts.push_back(v.p);
    for (size_t i : simplify_indices(pts, tol)) line.vertices.push_back(all[i]);
    for (const auto& v : line.vertices) result.stats.max_residual = std::max(result.stats.max_residual, v.residual);
    result.stats.vertices += static_cast<int64_t>(line.vertices.size());
    result.lines.push_back(std::move(line));
  }
  for (const Tripoint& t : result.tripoints)
    result.stats.max_residual = std::max(result.stats.max_residual, t.residual);
  // Deterministic order: by owner pair, then by first vertex.
  std::stable_sort(result.lines.begin(), result.lines.end(), [](const BoundaryLine& a, const BoundaryLine& b) {
    if (a.owner_a != b.owner_a) return a.owner_a < b.owner_a;
    if (a.owner_b != b.owner_b) return a.owner_b < b.owner_b;
    const Vec2 pa = a.vertices.front().p, pb = b.vertices.front().p;
    return pa.y != pb.y ? pa.y > pb.y : pa.x < pb.x;
  });
  return result;
}

// ---------------------------------------------------------------------------------------------
// Distance-limit lines.

LimitResult extract_limits(const NearestField& field, const OwnerIndex& index, std::span<const double> distances,
                           const LimitOptions& options) {
  check_whole_grid(field);
  check_metric(field, index.metric());
  for (double d : distances)
    if (!std::isfinite(d) || d <= 0.0)
      throw Error(ErrorKind::invalid_argument, "limit distances must be positive finite numbers");
  const GridSpec& g = field.site.grid();
  const SiteMetric& metric = index.metric();
  const SeedSet& seeds = metric.seeds();
  const int64_t W = g.width, H = g.height;
  const int threads = resolve_threads(options.threads);
  const double cell = cell_metric(g, metric);
  const double ftol = std::max(options.tolerance_cells, 1e-15) * cell;
  LimitResult result;

  std::vector<int32_t> owners_to_do;
  if (options.per_owner)
    for (int32_t o = 1; o <= seeds.owner_count(); ++o) owners_to_do.push_back(o);
  else
    owners_to_do.push_back(0);
  std::vector<int32_t> owner_of_site(seeds.sites().size());
  for (size_t i = 0; i < owner_of_site.size(); ++i) owner_of_site[i] = seeds.site_owner(static_cast<int32_t>(i));

  for (double D : distances)
    for (int32_t owner : owners_to_do) {
      auto dist = [&](Vec2 p) { return owner == 0 ? index.nearest(p) : index.nearest_of(p, owner); };
      // Inside (d <= D) per cell. The Float32 field decides clear cases; cells within float
      // rounding of D, and (per owner) cells of other owners within reach, are measured exactly.
      // Per owner, blocks of kBlock x kBlock cells are first settled as a whole where the
      // distance at the block's centre is farther from D than the block's radius (distance is
      // 1-Lipschitz), so exact queries are only spent near the line.
      constexpr int64_t kBlock = 8;
      std::vector<uint8_t> inside(static_cast<size_t>(W * H), 0);
      const int64_t bw = (W + kBlock - 1) / kBlock, bh = (H + kBlock - 1) / kBlock;
      detail::parallel_for(threads, bh, [&](int64_t br, int) {
        for (int64_t bc = 0; bc < bw; ++bc) {
          const int64_t c0 = bc * kBlock, r0 = br * kBlock;
          const int64_t c1 = std::min(W, c0 + kBlock), r1 = std::min(H, r0 + kBlock);
          int settled = -1;  // -1: per cell; 0: all outside; 1: all inside
          if (owner != 0) {
            const Vec2 a = centre(g, c0, r0), b = centre(g, c1 - 1, r1 - 1);
            const Vec2 mid{0.5 * (a.x + b.x), 0.5 * (a.y + b.y)};
            double radius = 0.0;
            for (const Vec2 q : {a, b, Vec2{a.x, b.y}, Vec2{b.x, a.y}})
              radius = std::max(radius, metric.point_distance(mid, q));
            // Corners bound a small block's extent exactly in the plane; 1 % covers the
            // curvature of a longitude/latitude block.
            radius = radius * 1.01 + 1e-6 * cell;
            const double v = dist(mid).distance;
            if (v - radius > D)
              settled = 0;
            else if (v + radius < D)
              settled = 1;
          }
          for (int64_t r = r0; r < r1; ++r)
            for (int64_t c = c0; c < c1; ++c) {
              const int32_t s = field.site.at(c, r);
              if (s == kNoSite) continue;  // beyond the field's max distance: outside every limit
              bool in;
              if (settled >= 0) {
                in = settled == 1;
              } else {
                const double d = field.distance.at(c, r);
                const bool own = owner == 0 || owner_of_site[static_cast<size_t>(s)] == owner;
                if (own && std::abs(d - D) > 1e-6 * (D + cell)) {
                  in = d <= D;
                } else if (!own && d > D + 1e-6 * (D + cell)) {
                  in = false;  // d_owner >= d > D
                } else {
                  in = dist(centre(g, c, r)).distance <= D;
                }
              }
              inside[static_cast<size_t>(r * W + c)] = in ? 1 : 0;
            }
        }
      });
      auto in_at = [&](int64_t c, int64_t r) { return inside[static_cast<size_t>(r * W + c)] != 0; };

      std::vector<int64_t> edges;
      for (int64_t r = 0; r < H; ++r)
        for (int64_t c = 0; c < W; ++c) {
          if (c + 1 < W && in_at(c, r) != in_at(c + 1, r)) edges.push_back(edge_right(W, c, r));
          if (r + 1 < H && in_at(c, r) != in_at(c, r + 1)) edges.push_back(edge_down(W, c, r));
        }
      std::vector<LimitVertex> verts(edges.size());
      const int64_t chunk = 256;
      detail::parallel_for(threads, (static_cast<int64_t>(edges.size()) + chunk - 1) / chunk, [&](int64_t k, int) {
        const size_t end = std::min(edges.size(), static_cast<size_t>((k + 1) * chunk));
        for (size_t i = static_cast<size_t>(k * chunk); i < end; ++i) {
          const int64_t id = edges[i] / 2;
          const int64_t c = id % W, r = id / W;
          const Vec2 p0 = centre(g, c, r);
          const Vec2 p1 = (edges[i] % 2 == 0) ? centre(g, c + 1, r) : centre(g, c, r + 1);
          auto f = [&](double t) { return dist(lerp(p0, p1, t)).distance - D; };
          const double t = find_root(f, f(0.0), f(1.0), ftol, 1e-15);
          const Vec2 p = lerp(p0, p1, t);
          const auto h = dist(p);
          verts[i] = LimitVertex{p, h.site, std::abs(h.distance - D)};
        }
      });
      std::unordered_map<int64_t, int32_t> at;
      at.reserve(edges.size() * 2);
      for (size_t i = 0; i < edges.size(); ++i) at.emplace(edges[i], static_cast<int32_t>(i));

      std::vector<std::array<int32_t, 2>> links;
      for (int64_t r = 0; r + 1 < H; ++r)
        for (int64_t c = 0; c + 1 < W; ++c) {
          const std::array<bool, 4> in{in_at(c, r), in_at(c + 1, r), in_at(c + 1, r + 1), in_at(c, r + 1)};
          if (in[0] == in[1] && in[1] == in[2] && in[2] == in[3]) continue;
          const auto sq = square_edges(W, c, r);
          std::array<int32_t, 4> x;
          std::vector<int> present;
          for (int k = 0; k < 4; ++k) {
            const auto it = at.find(sq[static_cast<size_t>(k)]);
            x[static_cast<size_t>(k)] = it == at.end() ? -1 : it->second;
            if (it != at.end()) present.push_back(k);
          }
          if (present.size() == 2) {
            links.push_back({x[static_cast<size_t>(present[0])], x[static_cast<size_t>(present[1])]});
          } else if (present.size() == 4) {
            // Saddle: the centre's side decides which diagonal pair of corners is connected.
            const Vec2 mid{g.xmin + (static_cast<double>(c) + 1.0) * g.res,
                           g.ymax - (static_cast<double>(r) + 1.0) * g.res};
            const bool centre_in = dist(mid).distance <= D;
            if (centre_in == in[0]) {  // corners 0 and 2 connected: cut off 1 and 3
              links.push_back({x[0], x[1]});
              links.push_back({x[2], x[3]});
            } else {
              links.push_back({x[3], x[0]});
              links.push_back({x[1], x[2]});
            }
          }
        }
      const Chains chains =
          chain_links(static_cast<int32_t>(verts.size()), links, std::vector<bool>(verts.size(), false));
      const double tol = options.simplify_cells * g.res;
      for (size_t k = 0; k < chains.node_lists.size(); ++k) {
        LimitLine line;
        line.distance = D;
        line.owner = owner;
        line.closed = chains.closed[k];
        std::vector<Vec2> pts;
        for (int32_t n : chains.node_lists[k]) pts.push_back(verts[static_cast<size_t>(n)].p);
        for (size_t i : simplify_indices(pts, tol)) {
          const LimitVertex& v = verts[static_cast<size_t>(chains.node_lists[k][i])];
          line.vertices.push_back(v);
          result.max_residual = std::max(result.max_residual, v.residual);
        }
        result.vertices += static_cast<int64_t>(line.vertices.size());
        result.lines.push_back(std::move(line));
      }
    }
  return result;
}

// ---------------------------------------------------------------------------------------------
// Margin.

NearestField compute_other_owner(const SeedSet& seeds, const NearestField& own, int threads) {
  if (own.metric.kind != MetricSpec::planar)
    throw Error(ErrorKind::invalid_argument, "compute_other_owner culls with planar bounds: planar fields only");
  const GridSpec& grid = own.site.grid();
  const Window window = own.site.window();
  detail::Progress progress({}, nullptr, window.cell_count());
  const std::vector<LocalSite> local = to_local(seeds, grid);
  const std::vector<int32_t> geometric = detail::geometric_sites(seeds);
  detail::EngineContext ctx{
      seeds,     grid,   window, local, geometric, std::numeric_limits<double>::infinity(), resolve_threads(threads),
      &progress, nullptr};
  std::vector<int32_t> owner_of_site(seeds.sites().size());
  for (size_t i = 0; i < owner_of_site.size(); ++i) owner_of_site[i] = seeds.site_owner(static_cast<int32_t>(i));
  const auto start = std::chrono::steady_clock::now();
  NearestField out;
  out.site = Raster<int32_t>(grid, window, Uninitialized{});
  out.distance = Raster<float>(grid, window, Uninitialized{});
  out.threads = ctx.threads;
  if (ctx.geometric.empty()) {
    std::fill(out.site.cells().begin(), out.site.cells().end(), kNoSite);
    std::fill(out.distance.cells().begin(), out.distance.cells().end(), kNoDistance);
  } else {
    detail::run_exact_other_owner(ctx, own.site, owner_of_site, out.site, out.distance);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

namespace {

// The seeds of every owner but `excluded`, as a new set (features in the same order, polygons
// with their rings, lines as their segments). Distances to it are distances to "another owner".
SeedSet seeds_without(const SeedSet& seeds, int32_t excluded) {
  // Ring edges are the segment sites just before a polygon's area site; they come back with
  // add_polygon and must not be added twice.
  std::vector<bool> ring_edge(seeds.sites().size(), false);
  std::vector<std::vector<const Polygon*>> polygons_of(seeds.features().size());
  for (const Polygon& poly : seeds.polygons()) {
    polygons_of[static_cast<size_t>(poly.feature)].push_back(&poly);
    size_t n = 0;
    for (const Ring& ring : poly.rings) n += ring.size();
    for (size_t k = 1; k <= n; ++k) ring_edge[static_cast<size_t>(poly.area_site) - k] = true;
  }
  std::vector<std::vector<int32_t>> sites_of(seeds.features().size());
  for (int32_t i = 0; i < static_cast<int32_t>(seeds.sites().size()); ++i)
    sites_of[static_cast<size_t>(seeds.sites()[static_cast<size_t>(i)].feature)].push_back(i);
  SeedSet out;
  for (const std::string& label : seeds.owner_labels()) out.owner_code(label);  // same codes
  for (size_t f = 0; f < seeds.features().size(); ++f) {
    const Feature& feat = seeds.features()[f];
    if (feat.owner == excluded) continue;
    const int32_t nf = out.add_feature(feat.owner, feat.source);
    for (const Polygon* poly : polygons_of[f]) out.add_polygon(nf, poly->rings);
    for (int32_t i : sites_of[f]) {
      const Site& site = seeds.sites()[static_cast<size_t>(i)];
      if (ring_edge[static_cast<size_t>(i)] || site.kind == SiteKind::area) continue;
      if (site.kind == SiteKind::point)
        out.add_point(nf, site.a);
      else
        out.add_polyline(nf, std::vector<Vec2>{site.a, site.b});
    }
  }
  return out;
}

// Non-planar metrics: one run of the exact engine per owner O, on the window of O's cells and
// the seeds of all other owners, gives the other-owner distance of O's cells exactly as the
// engine measures it (its culling bounds are the metric's own). Cells inside another owner's
// polygon get distance 0 there, so contested cells come out as margin 0.
Raster<float> margin_by_owner_runs(const NearestField& field, const SiteMetric& metric, int threads) {
  const SeedSet& seeds = metric.seeds();
  const GridSpec& g = field.site.grid();
  const Window w = field.site.window();
  Raster<float> out(g, w, kNoDistance);
  std::vector<int32_t> owner_of_site(seeds.sites().size());
  for (size_t i = 0; i < owner_of_site.size(); ++i) owner_of_site[i] = seeds.site_owner(static_cast<int32_t>(i));
  const int32_t k = seeds.owner_count();
  // Window (field-relative) of each owner's cells.
  std::vector<std::array<int64_t, 4>> box(static_cast<size_t>(k) + 1, {w.width, w.height, -1, -1});
  for (int64_t r = 0; r < w.height; ++r)
    for (int64_t c = 0; c < w.width; ++c) {
      const int32_t s = field.site.at(c, r);
      if (s == kNoSite) continue;
      auto& b = box[static_cast<size_t>(owner_of_site[static_cast<size_t>(s)])];
      b = {std::min(b[0], c), std::min(b[1], r), std::max(b[2], c), std::max(b[3], r)};
    }
  for (int32_t o = 1; o <= k; ++o) {
    const auto& b = box[static_cast<size_t>(o)];
    if (b[2] < 0) continue;
    const SeedSet others = seeds_without(seeds, o);
    if (others.sites().empty()) continue;
    ComputeOptions co;
    co.metric = field.metric;
    co.threads = threads;
    co.window = Window{w.col0 + b[0], w.row0 + b[1], b[2] - b[0] + 1, b[3] - b[1] + 1};
    const NearestField other = compute(others, g, co);
    for (int64_t r = b[1]; r <= b[3]; ++r)
      for (int64_t c = b[0]; c <= b[2]; ++c) {
        const int32_t s = field.site.at(c, r);
        if (s == kNoSite || owner_of_site[static_cast<size_t>(s)] != o) continue;
        const float d_other = other.distance.at(c - b[0], r - b[1]);
        if (d_other == kNoDistance) continue;
        out.at(c, r) = std::max(0.0f, d_other - field.distance.at(c, r));
      }
  }
  return out;
}

}  // namespace

Raster<float> margin_raster(const NearestField& field, const OwnerIndex& index, int threads) {
  const SiteMetric& metric = index.metric();
  check_metric(field, metric);
  // The per-owner engine runs below would need the other owners' polygons in the grid's CRS,
  // which the field does not carry.
  if (field.geolocator)
    throw Error(ErrorKind::unsupported,
                "the margin raster is not available for the geodesic metric on a projected "
                "grid yet; use a geographic (longitude/latitude) grid, or metric planar");
  const SeedSet& seeds = metric.seeds();
  const GridSpec& g = field.site.grid();
  const Window w = field.site.window();
  Raster<float> out(g, w, kNoDistance);
  if (seeds.owner_count() <= 1) return out;
  const int nthreads = resolve_threads(threads);
  std::vector<int32_t> owner_of_site(seeds.sites().size());
  for (size_t i = 0; i < owner_of_site.size(); ++i) owner_of_site[i] = seeds.site_owner(static_cast<int32_t>(i));
  // Polygons per owner, for cells inside another owner's polygon too (contested: margin 0).
  std::vector<int32_t> area_sites;
  for (const Polygon& p : seeds.polygons()) area_sites.push_back(p.area_site);
  const bool check_contested = field.contested_cells > 0;

  const bool planar = dynamic_cast<const PlanarSiteMetric*>(&metric) != nullptr;
  if (!planar) return margin_by_owner_runs(field, metric, nthreads);
  const NearestField other = compute_other_owner(seeds, field, nthreads);
  detail::parallel_for(nthreads, w.height, [&](int64_t r, int) {
    for (int64_t c = 0; c < w.width; ++c) {
      const int32_t s = field.site.at(c, r);
      if (s == kNoSite) continue;
      const int32_t o = owner_of_site[static_cast<size_t>(s)];
      const Vec2 p = centre(g, w.col0 + c, w.row0 + r);
      const bool own_area = seeds.sites()[static_cast<size_t>(s)].kind == SiteKind::area;
      const double d_own = own_area ? 0.0 : metric.distance(p, s);
      const int32_t t = other.site.at(c, r);
      if (t == kNoSite) continue;
      const double d_other = metric.distance(p, t);  // in double, not the Float32 of the field
      if (check_contested && own_area)
        for (int32_t a : area_sites)
          if (owner_of_site[static_cast<size_t>(a)] != o && metric.inside_area(p, a)) {
            out.at(c, r) = 0.0f;
            break;
          }
      if (out.at(c, r) == 0.0f) continue;
      out.at(c, r) = static_cast<float>(std::max(0.0, d_other - d_own));
    }
  });
  return out;
}

}  // namespace rv
