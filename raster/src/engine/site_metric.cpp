// SiteMetric's area sites and boxes, PlanarSiteMetric and OwnerIndex (rv/engine/site_metric.hpp,
// rv/engine/owner_index.hpp): how the deliverables measure a point's distance to a seed site, and find an owner's
// nearest site.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "engine/engine_internal.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/field/planar.hpp"

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
  const double dx = std::max(std::max(b.x0 - q.x, 0.0), q.x - b.x1);
  const double dy = std::max(std::max(b.y0 - q.y, 0.0), q.y - b.y1);
  const double dz = std::max(std::max(b.z0 - q.z, 0.0), q.z - b.z1);
  // A relative shave keeps the bound below the site distance despite rounding.
  return std::sqrt(dx * dx + dy * dy + dz * dz) * (1.0 - 1e-12);
}

double SiteMetric::distance_at_vertex(Vec2 p, int32_t site, Vec2& gradient, VertexHit& hit) const {
  hit = VertexHit{};
  gradient = Vec2{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  return distance(p, site);
}

double SiteMetric::distance_within(Vec2 p, int32_t site, double, Vec2& gradient, VertexHit& hit) const {
  return distance_at_vertex(p, site, gradient, hit);
}

int32_t SiteMetric::search_start(Vec2, int32_t) const { return kNoSite; }

bool SiteMetric::ties_at_vertex(Vec2, int32_t, const VertexHit&, double) const { return false; }

bool SiteMetric::open_between(Vec2, Vec2) const { return true; }

int32_t SiteMetric::last_bend(Vec2, int32_t) const { return -1; }

Vec2 SiteMetric::bend_position(int32_t) const { throw Error(ErrorKind::internal, "a straight metric has no bends"); }

void SiteMetric::domain_edges_near(Vec2, double, std::vector<int32_t>& out) const { out.clear(); }

bool SiteMetric::domain_edge_point(int32_t, double, Vec2, Vec2&) const { return false; }

bool SiteMetric::domain_edge_ends(int32_t, Vec2&, Vec2&) const { return false; }

double SiteMetric::domain_edge_bow(int32_t) const { return 0.0; }

bool SiteMetric::in_domain(Vec2) const { return true; }

double SiteMetric::distance_lower_bound(Vec2 p, int32_t site) const { return lower_bound(embed(p), site_bounds(site)); }

void SiteMetric::distance_lower_bounds(Vec2 p, std::span<const int32_t> sites, std::span<double> out) const {
  for (size_t i = 0; i < sites.size(); ++i) out[i] = distance_lower_bound(p, sites[i]);
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

double PlanarSiteMetric::distance_at_vertex(Vec2 p, int32_t site, Vec2& gradient, VertexHit& hit) const {
  hit = VertexHit{};
  const double d = distance(p, site);
  const Site& s = seeds().sites()[static_cast<size_t>(site)];
  const Vec2 q = nearest_point(p, site);
  gradient = (s.kind == SiteKind::area || !(d > 0.0))
                 ? Vec2{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()}
                 : Vec2{(p.x - q.x) / d, (p.y - q.y) / d};
  return d;
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

std::unique_ptr<SiteMetric> make_site_metric(const SeedSet& seeds, const GridSpec& grid,
                                             const ComputeOptions& options) {
  if (options.geolocator != nullptr)
    return std::make_unique<LocatedGeodesicSiteMetric>(seeds, options.metric, options.geolocator,
                                                       options.grid_polygons);
  if (options.metric.kind == MetricSpec::geodesic) {
    const std::shared_ptr<const PreparedSeeds>& p = options.prepared;
    if (p && p->seeds == &seeds && p->site_count == seeds.sites().size() && p->geo && p->metric == options.metric)
      return std::make_unique<GeodesicSiteMetric>(seeds, options.metric, p);
    return std::make_unique<GeodesicSiteMetric>(seeds, options.metric);
  }
  return std::make_unique<PlanarSiteMetric>(seeds, Vec2{grid.xmin, grid.ymax});
}

namespace {

// A ball query's test with adjustments: a site of weight w and effective reach r can be nearest
// at a position within `reach` of the centre only if its distance there, at least its lower bound
// at the centre less `reach`, is within r and, over w, within `bound` (the nearest's largest cost
// in the ball). The threshold of that lower bound, a little wider for the product's rounding.
auto threshold(double bound, double reach) {
  return [bound, reach](double w, double r) { return std::min(r, w * bound) * (1.0 + 1e-12) + reach; };
}

}  // namespace

struct OwnerIndex::Tree {
  struct Node {
    Box3 box;
    int32_t left = -1, right = -1;                           // children; -1 for a leaf
    int32_t begin = 0, end = 0;                              // leaf: range of ids
    double w_max = 1.0;                                      // largest weight below the node
    double r_max = std::numeric_limits<double>::infinity();  // largest effective reach below it
  };
  struct Item {
    int32_t id;
    Box3 box;
    double weight, reach;
  };
  std::vector<Node> nodes;
  std::vector<int32_t> ids;
  std::vector<Box3> boxes;     // per id position
  std::vector<double> weight;  // per id position: the feature's weight (1 in plain indexes)
  std::vector<double> reach;   // per id position: min(the feature's reach, cap) (inf in plain ones)

  int32_t build(std::vector<Item>& items, int32_t begin, int32_t end) {
    Node n;
    n.box = items[static_cast<size_t>(begin)].box;
    n.w_max = 0.0;
    n.r_max = 0.0;
    for (int32_t i = begin; i < end; ++i) {
      const Item& it = items[static_cast<size_t>(i)];
      n.box.include(it.box);
      n.w_max = std::max(n.w_max, it.weight);
      n.r_max = std::max(n.r_max, it.reach);
    }
    const auto index = static_cast<int32_t>(nodes.size());
    nodes.push_back(n);
    if (end - begin <= 4) {
      nodes[static_cast<size_t>(index)].begin = static_cast<int32_t>(ids.size());
      for (int32_t i = begin; i < end; ++i) {
        const Item& it = items[static_cast<size_t>(i)];
        ids.push_back(it.id);
        boxes.push_back(it.box);
        weight.push_back(it.weight);
        reach.push_back(it.reach);
      }
      nodes[static_cast<size_t>(index)].end = static_cast<int32_t>(ids.size());
      return index;
    }
    const double ex = n.box.x1 - n.box.x0, ey = n.box.y1 - n.box.y0, ez = n.box.z1 - n.box.z0;
    const int axis = ex >= ey && ex >= ez ? 0 : (ey >= ez ? 1 : 2);
    const int32_t mid = begin + (end - begin) / 2;
    std::nth_element(
        items.begin() + begin, items.begin() + mid, items.begin() + end, [&](const Item& a, const Item& b) {
          auto mid = [&](const Box3& x) { return axis == 0 ? x.x0 + x.x1 : (axis == 1 ? x.y0 + x.y1 : x.z0 + x.z1); };
          return mid(a.box) < mid(b.box);
        });
    const int32_t l = build(items, begin, mid);
    const int32_t r = build(items, mid, end);
    nodes[static_cast<size_t>(index)].left = l;
    nodes[static_cast<size_t>(index)].right = r;
    return index;
  }

  // The ids whose box lies within threshold(weight, reach) of q (lower_bound), in tree order; a
  // node is tested with its largest weight and reach (the threshold grows with both).
  template <class Threshold>
  void within(int32_t node, const Vec3& q, const Threshold& threshold, std::vector<int32_t>& out) const {
    const Node& n = nodes[static_cast<size_t>(node)];
    if (SiteMetric::lower_bound(q, n.box) > threshold(n.w_max, n.r_max)) return;
    if (n.left < 0) {
      for (int32_t i = n.begin; i < n.end; ++i) {
        const auto k = static_cast<size_t>(i);
        if (SiteMetric::lower_bound(q, boxes[k]) <= threshold(weight[k], reach[k])) out.push_back(ids[k]);
      }
      return;
    }
    within(n.left, q, threshold, out);
    within(n.right, q, threshold, out);
  }

  // A lower bound `lb` of a true distance as a lower bound of the cost (reach r, weight w).
  static double cost_bound(double lb, double w, double r) {
    return lb > r ? std::numeric_limits<double>::infinity() : lb / w;
  }

  // Whether a cost bound rules a site or node out against the best so far: above it, or
  // infinite (beyond every reach there: nothing there can count, even while nothing has).
  static bool ruled_out(double bound, double best) {
    return bound > best || bound == std::numeric_limits<double>::infinity();
  }

  // Depth-first, nearest child first, pruned by the cost's lower bounds. Without adjustments
  // (w = 1, r = inf) every comparison is the one on true distances, to the bit.
  // `margin`: only sites within their reach less it count (0: the index's rule).
  void search(const SiteMetric& m, int32_t node, Vec2 p, const Vec3& q, Hit& best, double margin = 0.0) const {
    const Node& n = nodes[static_cast<size_t>(node)];
    if (n.left < 0) {
      for (int32_t i = n.begin; i < n.end; ++i) {
        const auto k = static_cast<size_t>(i);
        const double r = reach[k] - margin;
        if (ruled_out(cost_bound(SiteMetric::lower_bound(q, boxes[k]), weight[k], r), best.cost)) continue;
        const int32_t id = ids[k];
        if (id == best.site) continue;  // a known hit, measured already
        // The box holds a whole edge around its middle; the metric's own bound is far tighter
        // for the edge's neighbours along a coast, which then go unmeasured.
        if (ruled_out(cost_bound(m.distance_lower_bound(p, id), weight[k], r), best.cost)) continue;
        // Only a distance within the reach whose cost is at most the best's counts (a value above
        // `within` fails one of the two tests below).
        const double within = std::min(r, best.cost * weight[k] * (1.0 + 1e-12));
        Vec2 gradient;
        SiteMetric::VertexHit hit;
        const double d = m.distance_within(p, id, within, gradient, hit);
        if (d > r) continue;
        const double c = d / weight[k];
        if (c < best.cost || (c == best.cost && id < best.site)) best = Hit{id, d, c};
      }
      return;
    }
    const Node& nl = nodes[static_cast<size_t>(n.left)];
    const Node& nr = nodes[static_cast<size_t>(n.right)];
    const double ll = cost_bound(SiteMetric::lower_bound(q, nl.box), nl.w_max, nl.r_max - margin);
    const double lr = cost_bound(SiteMetric::lower_bound(q, nr.box), nr.w_max, nr.r_max - margin);
    const int32_t first = ll <= lr ? n.left : n.right, second = ll <= lr ? n.right : n.left;
    const double lf = std::min(ll, lr), ls = std::max(ll, lr);
    if (!ruled_out(lf, best.cost)) search(m, first, p, q, best, margin);
    if (!ruled_out(ls, best.cost)) search(m, second, p, q, best, margin);
  }

  // Depth-first as search(), for the least d - reach (deepest()): a node's bound is its box's
  // lower bound less its largest reach.
  void search_deepest(const SiteMetric& m, int32_t node, Vec2 p, const Vec3& q, Hit& best) const {
    const Node& n = nodes[static_cast<size_t>(node)];
    if (n.left < 0) {
      for (int32_t i = n.begin; i < n.end; ++i) {
        const auto k = static_cast<size_t>(i);
        if (SiteMetric::lower_bound(q, boxes[k]) - reach[k] > best.cost) continue;
        const int32_t id = ids[k];
        if (m.distance_lower_bound(p, id) - reach[k] > best.cost) continue;
        const double d = m.distance(p, id);
        const double c = d - reach[k];
        if (c < best.cost || (c == best.cost && id < best.site)) best = Hit{id, d, c};
      }
      return;
    }
    const Node& nl = nodes[static_cast<size_t>(n.left)];
    const Node& nr = nodes[static_cast<size_t>(n.right)];
    const double ll = SiteMetric::lower_bound(q, nl.box) - nl.r_max;
    const double lr = SiteMetric::lower_bound(q, nr.box) - nr.r_max;
    const int32_t first = ll <= lr ? n.left : n.right, second = ll <= lr ? n.right : n.left;
    // (An infinite reach makes every bound -inf: the first such hit is as deep as any.)
    if (std::min(ll, lr) <= best.cost && best.cost != -std::numeric_limits<double>::infinity())
      search_deepest(m, first, p, q, best);
    if (std::max(ll, lr) <= best.cost && best.cost != -std::numeric_limits<double>::infinity())
      search_deepest(m, second, p, q, best);
  }

  double root_bound(const Vec3& q) const {
    const Node& n = nodes[0];
    return cost_bound(SiteMetric::lower_bound(q, n.box), n.w_max, n.r_max);
  }
};

OwnerIndex::OwnerIndex(const SiteMetric& metric, Measure measure, double cap) : metric_(metric) {
  const SeedSet& seeds = metric.seeds();
  if (std::isnan(cap) || !(cap >= 0.0)) throw Error(ErrorKind::invalid_argument, "OwnerIndex: cap must be >= 0");
  const bool plain = measure == Measure::plain;
  cap_ = plain ? std::numeric_limits<double>::infinity() : cap;
  adjusted_ = !plain && (seeds.adjusted() || std::isfinite(cap_));
  std::vector<std::vector<Tree::Item>> items(static_cast<size_t>(seeds.owner_count()));
  for (int32_t i = 0; i < static_cast<int32_t>(seeds.sites().size()); ++i) {
    const Feature& f = seeds.features()[static_cast<size_t>(seeds.site_feature(i))];
    const double w = plain ? 1.0 : f.weight;
    const double r = plain ? std::numeric_limits<double>::infinity() : std::min(f.reach, cap_);
    items[static_cast<size_t>(seeds.site_owner(i) - 1)].push_back(Tree::Item{i, metric.site_bounds(i), w, r});
    cost_slope_ = std::isfinite(r) ? std::numeric_limits<double>::infinity() : std::max(cost_slope_, 1.0 / w);
  }
  for (auto& list : items) {
    auto tree = std::make_unique<Tree>();
    if (!list.empty()) tree->build(list, 0, static_cast<int32_t>(list.size()));
    trees_.push_back(std::move(tree));
  }
}

OwnerIndex::~OwnerIndex() = default;
OwnerIndex::OwnerIndex(OwnerIndex&&) noexcept = default;

double OwnerIndex::cost_of(int32_t site, double d) const {
  if (!adjusted_) return d;
  const SeedSet& seeds = metric_.seeds();
  return adjusted_distance(seeds.features()[static_cast<size_t>(seeds.site_feature(site))], d, cap_);
}

double OwnerIndex::reach_of(int32_t site) const {
  if (!adjusted_) return std::numeric_limits<double>::infinity();
  const SeedSet& seeds = metric_.seeds();
  return std::min(seeds.features()[static_cast<size_t>(seeds.site_feature(site))].reach, cap_);
}

double OwnerIndex::weight_of(int32_t site) const {
  if (!adjusted_) return 1.0;
  const SeedSet& seeds = metric_.seeds();
  return seeds.features()[static_cast<size_t>(seeds.site_feature(site))].weight;
}

OwnerIndex::Hit OwnerIndex::nearest_of(Vec2 p, int32_t owner, int32_t hint) const {
  Hit best;
  if (owner < 1 || owner > static_cast<int32_t>(trees_.size())) return best;
  // The hint's distance is a bound from the start: the search then prunes nearly everything it
  // would have measured before finding it. Its tie rule keeps the lowest index whatever the
  // start, so the result is the one without a hint.
  const SeedSet& seeds = metric_.seeds();
  if (hint >= 0 && hint < static_cast<int32_t>(seeds.sites().size()) && seeds.site_owner(hint) == owner) {
    const double d = metric_.distance(p, hint);
    const double c = cost_of(hint, d);
    if (!adjusted_ || std::isfinite(c)) best = Hit{hint, d, c};
  } else {
    best = start_of(p, owner);
  }
  const Tree& t = *trees_[static_cast<size_t>(owner - 1)];
  if (!t.nodes.empty()) t.search(metric_, 0, p, metric_.embed(p), best);
  return best;
}

OwnerIndex::Hit OwnerIndex::deepest(Vec2 p, int32_t owner) const {
  Hit best;
  if (owner < 0 || owner > static_cast<int32_t>(trees_.size())) return best;
  const Vec3 q = metric_.embed(p);
  for (size_t o = 0; o < trees_.size(); ++o)
    if ((owner == 0 || static_cast<int32_t>(o) + 1 == owner) && !trees_[o]->nodes.empty())
      trees_[o]->search_deepest(metric_, 0, p, q, best);
  return best;
}

OwnerIndex::Hit OwnerIndex::start_of(Vec2 p, int32_t owner) const {
  const int32_t site = metric_.search_start(p, owner);
  const SeedSet& seeds = metric_.seeds();
  if (site < 0 || site >= static_cast<int32_t>(seeds.sites().size()) || seeds.site_owner(site) != owner) return Hit{};
  const double d = metric_.distance(p, site);
  const double c = cost_of(site, d);
  // (An infinite cost would keep the site as the answer where no site of the owner is reached.)
  return std::isfinite(c) ? Hit{site, d, c} : Hit{};
}

double OwnerIndex::ball_bound(const Hit& h, double reach) const {
  if (h.site == kNoSite || !std::isfinite(h.cost)) return std::numeric_limits<double>::infinity();
  // The hit stays within its reach over the whole ball only if it is that far inside it; then
  // its cost anywhere in the ball is at most (d + reach) / w.
  const double d_far = h.distance + reach;
  const double c = cost_of(h.site, d_far);
  return c;
}

double OwnerIndex::ball_bound_at(Vec2 centre, double reach, int32_t owner, bool others, const Hit& nearest) const {
  const double bound = ball_bound(nearest, reach);
  if (std::isfinite(bound) || nearest.site == kNoSite) return bound;
  // The nearest can leave its reach within the ball (an island's arc runs through it): the
  // nearest of the sites that reach over the whole ball bounds the cost there instead; without
  // one, every site can be nearest somewhere in it.
  const double margin = reach * (1.0 + 1e-12) + 1e-12;
  const Vec3 q = metric_.embed(centre);
  Hit settled;
  for (size_t o = 0; o < trees_.size(); ++o) {
    const bool mine = static_cast<int32_t>(o) + 1 == owner;
    if (mine == others || trees_[o]->nodes.empty()) continue;
    trees_[o]->search(metric_, 0, centre, q, settled, margin);
  }
  return ball_bound(settled, reach);
}

void OwnerIndex::candidates_of(Vec2 centre, double reach, int32_t owner, int32_t hint, std::vector<int32_t>& out,
                               double nearest_at_most) const {
  out.clear();
  if (owner < 1 || owner > static_cast<int32_t>(trees_.size())) return;
  const Tree& t = *trees_[static_cast<size_t>(owner - 1)];
  if (t.nodes.empty()) return;
  const SeedSet& seeds = metric_.seeds();
  const bool valid = hint >= 0 && hint < static_cast<int32_t>(seeds.sites().size()) && seeds.site_owner(hint) == owner;
  if (adjusted_) {
    // nearest_at_most bounds a true distance, not a cost: the measured nearest gives the bound.
    const double bound = ball_bound_at(centre, reach, owner, false, nearest_of(centre, owner, valid ? hint : kNoSite));
    t.within(0, metric_.embed(centre), threshold(bound, reach), out);
    keep_within(centre, reach, bound, out);
    std::sort(out.begin(), out.end());
    return;
  }
  // At a position p within `reach` of the centre: the nearest is within d(centre, hint) + reach
  // (the distance to a site is 1-Lipschitz), and a site whose box is farther than that plus
  // reach from the centre's embedding is farther than it from p's (the embedding does not
  // lengthen distances): it can neither be nearest nor tie.
  double at_centre = std::isfinite(nearest_at_most) ? nearest_at_most
                     : valid                        ? metric_.distance(centre, hint)
                                                    : std::numeric_limits<double>::infinity();
  // (An area site's distance is infinite outside its polygon: the nearest then gives the bound.)
  if (!std::isfinite(at_centre)) at_centre = nearest_of(centre, owner, valid ? hint : kNoSite).distance;
  const double bound = at_centre + 2.0 * reach;
  t.within(
      0, metric_.embed(centre), [bound](double, double) { return bound; }, out);
  if (std::isfinite(bound)) keep_within(centre, reach, bound, out);
  std::sort(out.begin(), out.end());
}

void OwnerIndex::keep_within(Vec2 centre, double reach, double bound, std::vector<int32_t>& sites) const {
  // The boxes hold whole edges; the metric's own bounds at the centre drop the many whose box
  // is near but whose distance is not (the same test: a site farther than `bound` from the
  // centre is farther than the nearest from every position within reach of it).
  std::vector<double> lb(sites.size());
  metric_.distance_lower_bounds(centre, sites, lb);
  size_t kept = 0;
  if (!adjusted_) {
    for (size_t i = 0; i < sites.size(); ++i)
      if (!(lb[i] > bound)) sites[kept++] = sites[i];
  } else {
    const SeedSet& seeds = metric_.seeds();
    const auto limit = threshold(bound, reach);
    for (size_t i = 0; i < sites.size(); ++i) {
      const Feature& f = seeds.features()[static_cast<size_t>(seeds.site_feature(sites[i]))];
      if (!(lb[i] > limit(f.weight, std::min(f.reach, cap_)))) sites[kept++] = sites[i];
    }
  }
  sites.resize(kept);
}

void OwnerIndex::candidates_not_of(Vec2 centre, double reach, int32_t owner, Hit known, std::vector<int32_t>& out,
                                   double nearest_at_most) const {
  out.clear();
  // The bound as in candidates_of: the nearest is within the known hit's distance (or the
  // nearest's) plus reach of any position within reach of the centre.
  const SeedSet& seeds = metric_.seeds();
  const bool valid = known.site >= 0 && known.site < static_cast<int32_t>(seeds.sites().size()) &&
                     seeds.site_owner(known.site) != owner && std::isfinite(known.distance);
  const Vec3 q = metric_.embed(centre);
  if (adjusted_) {
    const double bound =
        ball_bound_at(centre, reach, owner, true, nearest_not_of(centre, owner, valid ? known : Hit{}));
    const auto limit = threshold(bound, reach);
    for (size_t o = 0; o < trees_.size(); ++o)
      if (static_cast<int32_t>(o) + 1 != owner && !trees_[o]->nodes.empty()) trees_[o]->within(0, q, limit, out);
    keep_within(centre, reach, bound, out);
    std::sort(out.begin(), out.end());
    return;
  }
  const double at_centre = std::isfinite(nearest_at_most) ? nearest_at_most
                           : valid                        ? known.distance
                                                          : nearest_not_of(centre, owner).distance;
  const double bound = std::isfinite(at_centre) ? at_centre + 2.0 * reach : std::numeric_limits<double>::infinity();
  for (size_t o = 0; o < trees_.size(); ++o)
    if (static_cast<int32_t>(o) + 1 != owner && !trees_[o]->nodes.empty())
      trees_[o]->within(
          0, q, [bound](double, double) { return bound; }, out);
  if (std::isfinite(bound)) keep_within(centre, reach, bound, out);
  std::sort(out.begin(), out.end());
}

void OwnerIndex::candidates_among(Vec2 centre, double reach, const std::vector<int32_t>& from,
                                  std::vector<int32_t>& out) const {
  out.clear();
  if (from.empty()) return;
  const Hit h = nearest_among(centre, from);
  out = from;
  if (!adjusted_) {
    // As in candidates_of: the nearest anywhere in the ball is within d + reach of it, so a site
    // farther than d + 2 reach from the centre never is.
    if (h.site != kNoSite) keep_within(centre, reach, h.distance + 2.0 * reach, out);
    return;
  }
  keep_within(centre, reach, ball_bound(h, reach), out);
}

OwnerIndex::Hit OwnerIndex::nearest_among(Vec2 p, const std::vector<int32_t>& sites, Vec2* gradient) const {
  Hit best;
  Vec2 slope{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  SiteMetric::VertexHit at_vertex;  // where the best so far was attained
  const SeedSet& seeds = metric_.seeds();
  // The lowest index among exact ties, as measuring every one in index order kept.
  auto measure = [&](int32_t id) {
    Vec2 g;
    SiteMetric::VertexHit v;
    // (Adjusted: cost_of's reach and cap decide; without, a distance above the best's cannot win.)
    const double within = adjusted_ ? std::numeric_limits<double>::infinity() : best.cost * (1.0 + 1e-12);
    const double d = metric_.distance_within(p, id, within, g, v);
    const double c = cost_of(id, d);
    if (!std::isfinite(c)) return;
    if (c < best.cost || (c == best.cost && id < best.site)) {
      best = Hit{id, d, c};
      // The slope of what is compared: the cost's (the distance's over the weight).
      const double w = adjusted_ ? seeds.features()[static_cast<size_t>(seeds.site_feature(id))].weight : 1.0;
      slope = w == 1.0 ? g : Vec2{g.x / w, g.y / w};
      at_vertex = v;
    }
  };
  if (gradient != nullptr) *gradient = slope;
  if (sites.size() == 1) {
    measure(sites[0]);
    if (gradient != nullptr && best.site != kNoSite) *gradient = slope;
    return best;
  }
  // The sites of a stretch of coast all pass the candidates' ball test, but nearly all of them
  // are metres farther than the nearest: measured in order of their lower bounds, the first
  // usually rules out the rest.
  // (Per-thread scratch: a search per cell of the adjusted method, and several per vertex of the
  // lines, each allocating two vectors, spent more in the allocator than in the measuring.)
  thread_local std::vector<double> bounds;
  thread_local std::vector<std::pair<double, int32_t>> order;
  bounds.resize(sites.size());
  order.resize(sites.size());
  metric_.distance_lower_bounds(p, sites, bounds);
  for (size_t i = 0; i < sites.size(); ++i) {
    double lb = bounds[i];
    if (adjusted_) {
      const Feature& f = seeds.features()[static_cast<size_t>(seeds.site_feature(sites[i]))];
      lb = Tree::cost_bound(lb, f.weight, std::min(f.reach, cap_));
    }
    order[i] = {lb, sites[i]};
  }
  std::sort(order.begin(), order.end());
  for (const auto& [lb, id] : order) {
    if (lb > best.cost) break;
    // A coast's vertex controls much of the sea, and both its edges are candidates there: the
    // second ties the first at the vertex's canonical distance, known without measuring (the
    // same cost too when both are of one feature).
    if (at_vertex.valid && (!adjusted_ || seeds.site_feature(id) == seeds.site_feature(best.site)) &&
        metric_.ties_at_vertex(p, id, at_vertex, best.distance)) {
      best.site = std::min(best.site, id);  // the same distance and gradient
      continue;
    }
    measure(id);
  }
  if (gradient != nullptr && best.site != kNoSite) *gradient = slope;
  return best;
}

OwnerIndex::Hit OwnerIndex::nearest_third(Vec2 p, int32_t a, int32_t b, double within) const {
  const Vec3 q = metric_.embed(p);
  // A site above every index at `within`: a site at that very cost still replaces it.
  constexpr int32_t kNone = std::numeric_limits<int32_t>::max();
  Hit best{kNone, within, within};
  for (size_t o = 0; o < trees_.size(); ++o) {
    const auto code = static_cast<int32_t>(o) + 1;
    if (code == a || code == b || trees_[o]->nodes.empty()) continue;
    if (trees_[o]->root_bound(q) > best.cost) continue;
    trees_[o]->search(metric_, 0, p, q, best);
  }
  return best.site == kNone ? Hit{} : best;
}

OwnerIndex::Hit OwnerIndex::nearest_within(Vec2 p, int32_t owner, double within) const {
  if (owner < 0 || owner > static_cast<int32_t>(trees_.size())) return Hit{};
  const Vec3 q = metric_.embed(p);
  constexpr int32_t kNone = std::numeric_limits<int32_t>::max();  // (as in nearest_third)
  Hit best{kNone, within, within};
  for (size_t o = 0; o < trees_.size(); ++o) {
    if ((owner != 0 && static_cast<int32_t>(o) + 1 != owner) || trees_[o]->nodes.empty()) continue;
    if (trees_[o]->root_bound(q) > best.cost) continue;
    trees_[o]->search(metric_, 0, p, q, best);
  }
  return best.site == kNone ? Hit{} : best;
}

OwnerIndex::Hit OwnerIndex::nearest_not_of(Vec2 p, int32_t owner, Hit known) const {
  // Owners in order of their trees' lower bounds, so the first search makes the rest prune.
  const Vec3 q = metric_.embed(p);
  std::vector<std::pair<double, int32_t>> order;
  order.reserve(trees_.size());
  for (size_t o = 0; o < trees_.size(); ++o) {
    if (static_cast<int32_t>(o) + 1 == owner || trees_[o]->nodes.empty()) continue;
    order.emplace_back(trees_[o]->root_bound(q), static_cast<int32_t>(o));
  }
  std::sort(order.begin(), order.end());
  // A known hit is a bound from the start (see nearest_of); it must not be of `owner`.
  Hit best;
  if (known.site >= 0 && known.site < static_cast<int32_t>(metric_.seeds().sites().size()) &&
      metric_.seeds().site_owner(known.site) != owner) {
    const double c = cost_of(known.site, known.distance);
    if (!adjusted_ || std::isfinite(c)) best = Hit{known.site, known.distance, c};
  }
  for (const auto& [lb, o] : order) {
    if (lb > best.cost) break;
    if (!std::isfinite(best.cost)) {
      const Hit start = start_of(p, o + 1);
      if (start.site != kNoSite) best = start;
    }
    trees_[static_cast<size_t>(o)]->search(metric_, 0, p, q, best);
  }
  return best;
}

}  // namespace rv
