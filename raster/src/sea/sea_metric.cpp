// The distance by sea as a SiteMetric. See rv/sea/sea_metric.hpp for the contract.
#include "rv/sea/sea_metric.hpp"

#include <GeographicLib/Geodesic.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <span>
#include <utility>
#include <vector>

#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "sea/bend_settle.hpp"
#include "sea/near_bends.hpp"

namespace rv {
namespace {

using namespace ::rv::sea;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One site's roots beyond itself: the nodes of its owner's settling whose path starts at it, in
// a tree weighted by their distance by sea.
struct SiteRoots {
  const Searches* search = nullptr;
  int32_t first_hint = 0;      // where `search`'s nodes start among the hints (SeaSiteMetric::hints)
  std::vector<int32_t> nodes;  // tree item -> node of `search`
  RootTree tree;
};

class SeaSiteMetric final : public SiteMetric {
 public:
  SeaSiteMetric(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const SeaOptions& options,
                SeaMetricStats* stats, double settle_within)
      : SiteMetric(seeds, located(options) ? *options.grid_polygons : seeds.polygons()),
        grid_(grid),
        polygons_(options.grid_polygons),
        threads_(options.threads),
        cancel_(options.cancel),
        stats_(stats),
        within_(checked_within(settle_within)) {
    ComputeOptions straight;
    straight.metric = options.metric;
    straight.geolocator = options.geolocator;
    straight.grid_polygons = options.grid_polygons;
    inner_ = make_site_metric(seeds, grid, straight);
    sea_ = options.prepared ? options.prepared : prepare_sea(seeds, barriers, grid, options);
    if (options.metric.kind == MetricSpec::geodesic)
      geod_ = std::make_unique<GeographicLib::Geodesic>(options.metric.semi_major, options.metric.flattening);
    list_edges();
    list_touches();
  }

  double distance(Vec2 p, int32_t site) const override {
    Vec2 gradient;
    VertexHit hit;
    return distance_at_vertex(p, site, gradient, hit);
  }
  double distance_at_vertex(Vec2 p, int32_t site, Vec2& gradient, VertexHit& hit) const override {
    hit = VertexHit{};
    if (seeds().sites()[static_cast<size_t>(site)].kind == SiteKind::area)
      return inner_->distance_at_vertex(p, site, gradient, hit);
    const Path path = best(p, site);
    gradient = path.gradient;
    return path.d;
  }
  double distance_within(Vec2 p, int32_t site, double bound, Vec2& gradient, VertexHit& hit) const override {
    hit = VertexHit{};
    if (seeds().sites()[static_cast<size_t>(site)].kind == SiteKind::area)
      return inner_->distance_at_vertex(p, site, gradient, hit);
    const Path path = best(p, site, bound);
    gradient = path.gradient;
    return path.d;
  }
  // The owner's shortest path over all its roots at once, as the field finds a cell's (each
  // group of the owner searched; with weights or reaches the cheapest of them): its site.
  int32_t search_start(Vec2 p, int32_t owner) const override {
    settled();
    const Where w = where(p);
    if (w.ground == Visibility::Ground::land) return kNoSite;
    const Visibility::Place at = place(w);
    int32_t won = kNoSite;
    double won_cost = std::numeric_limits<double>::infinity();
    std::vector<StartHints>& hints = start_hints();
    for (size_t g = 0; g < groups_.size(); ++g) {
      if (group_owner_[g] != owner) continue;
      int64_t tests = 0;
      StartHints& h = hints[g];
      const Best b = groups_[g].search->best_path(at, w.spot, Best{}, tests, -1, &h.blockers, h.last, &h.last);
      if (b.site == kNoSite) continue;
      const double cost =
          seeds().adjusted()
              ? adjusted_distance(seeds().features()[static_cast<size_t>(seeds().site_feature(b.site))], b.d)
              : b.d;
      if (cost < won_cost) {
        won = b.site;
        won_cost = cost;
      }
    }
    return won;
  }
  Vec2 nearest_point(Vec2 p, int32_t site) const override {
    if (seeds().sites()[static_cast<size_t>(site)].kind == SiteKind::area) return inner_->nearest_point(p, site);
    const Path path = best(p, site);  // (settles the owners: roots_ below is filled)
    if (path.touch >= 0) return grid_of(prepared().touches[static_cast<size_t>(path.touch)].at.at);
    if (path.node < 0) return inner_->nearest_point(p, site);
    // The path's first bend: the site's point nearest to it is where the path starts.
    const Searches& s = *roots_[static_cast<size_t>(roots_of_site_[static_cast<size_t>(site)])].search;
    int32_t first = path.node;
    while (s.prev[static_cast<size_t>(first)] >= 0) first = s.prev[static_cast<size_t>(first)];
    const Vec2 bend = via_position(*sea_, grid_, s.nodes[static_cast<size_t>(first)].vertex);
    return inner_->nearest_point(bend, site);
  }
  int32_t last_bend(Vec2 p, int32_t site) const override {
    if (seeds().sites()[static_cast<size_t>(site)].kind == SiteKind::area) return -1;
    const Path path = best(p, site);
    if (path.node < 0) return -1;
    const Searches& s = *roots_[static_cast<size_t>(roots_of_site_[static_cast<size_t>(site)])].search;
    return s.nodes[static_cast<size_t>(path.node)].vertex;
  }
  Vec2 bend_position(int32_t vertex) const override { return via_position(*sea_, grid_, vertex); }
  Kind kind() const override { return inner_->kind(); }
  MetricSpec spec() const override { return inner_->spec(); }
  bool straight() const override { return false; }
  double point_distance(Vec2 a, Vec2 b) const override { return inner_->point_distance(a, b); }
  Vec3 embed(Vec2 p) const override { return inner_->embed(p); }
  Box3 site_bounds(int32_t site) const override { return inner_->site_bounds(site); }
  double distance_lower_bound(Vec2 p, int32_t site) const override { return inner_->distance_lower_bound(p, site); }
  void distance_lower_bounds(Vec2 p, std::span<const int32_t> sites, std::span<double> out) const override {
    inner_->distance_lower_bounds(p, sites, out);
  }
  bool open_between(Vec2 a, Vec2 b) const override {
    const Where wa = where(a), wb = where(b);
    if (wa.ground == Visibility::Ground::land || wb.ground == Visibility::Ground::land) return false;
    if (a.x == b.x && a.y == b.y) return prepared().vis.sees(place(wa), place(wb));
    if ((wa.ground == Visibility::Ground::on_barrier && parts_the_sea(wa.spot.at)) ||
        (wb.ground == Visibility::Ground::on_barrier && parts_the_sea(wb.spot.at)))
      return false;
    return prepared().vis.sees(place(wa), place(wb));
  }
  void domain_edges_near(Vec2 p, double radius, std::vector<int32_t>& out) const override {
    out.clear();
    const Vec2 at = plane_of(p);
    // The radius in the plane: the farther of its images along x and y, with a margin (the
    // frame's scale varies little over a few cells) and the images' bending.
    const Vec2 ex = plane_of(Vec2{p.x + radius, p.y}), ey = plane_of(Vec2{p.x, p.y + radius});
    const double bend = prepared().vis.frame() ? prepared().vis.frame()->deviation() : 0.0;
    const double r = 1.5 * std::max(length(at, ex), length(at, ey)) + bend;
    for (size_t i = 0; i < edges_.size(); ++i)
      if (segment_distance(at, edges_[i].a, edges_[i].b) <= r) out.push_back(static_cast<int32_t>(i));
  }
  bool in_domain(Vec2 p) const override { return where(p).ground != Visibility::Ground::land; }
  bool domain_edge_ends(int32_t edge, Vec2& first, Vec2& second) const override {
    const Edge& e = edges_[static_cast<size_t>(edge)];
    first = grid_of(e.a);
    second = grid_of(e.b);
    return true;
  }
  bool domain_edge_point(int32_t edge, double t, Vec2 side, Vec2& out) const override {
    const Prepared& pr = prepared();
    const Edge& e = edges_[static_cast<size_t>(edge)];
    const Vec2 q = point_on(e, t);
    const int o = pr.vis.orient(e.a, e.b, plane_of(side));
    if (o == 0) return false;
    const double len = length(e.a, e.b);
    Vec2 n = left_normal(e);
    if (o < 0) n = Vec2{-n.x, -n.y};
    const double scale = std::max({std::abs(q.x), std::abs(q.y), len, std::abs(grid_.xmin), std::abs(grid_.ymax)});
    // On the ellipsoid at least a tenth of a micrometre off the edge. The geodesic reading decides
    // a point within a few units in the last place of its longitude and latitude (a nanometre) of
    // the edge from each triple's own inverse problems, so a point nearer than that may lie on the
    // sea side by the edge's orientation and on the land side by another triple's: a path from it
    // along the edge to the edge's own end then turned the wrong way round the land there, and
    // the owners' costs along a coast jumped by a kilometre at a few points in a hundred.
    constexpr double kGeodesicOff = 1e-7;
    const double upper = farthest_off(e);
    double eps = 16.0 * std::numeric_limits<double>::epsilon() * scale;
    if (geod_) eps = std::min(std::max(eps, kGeodesicOff), upper);
    for (; eps <= upper; eps *= 4.0) {
      // (Tested where the grid's coordinates put it: their rounding may take back a small move.)
      const Vec2 at = grid_of(Vec2{q.x + eps * n.x, q.y + eps * n.y}), back = plane_of(at);
      if (pr.vis.orient(e.a, e.b, back) != o || pr.vis.classify(back) == Visibility::Ground::land) continue;
      out = at;
      return true;
    }
    return false;
  }
  double domain_edge_bow(int32_t edge) const override {
    std::atomic<double>& cached = bows_[static_cast<size_t>(edge)];
    double bow = cached.load(std::memory_order_relaxed);
    if (bow >= 0.0) return bow;
    // The edge's points at its quarters, from its ends' chord in the grid's coordinates: a
    // geodesic's image there is a flat arc (over an edge of a few degrees, its curvature all but
    // constant), which twice its farthest quarter bounds. Then the farthest move off the edge,
    // either side, at its middle.
    const Edge& e = edges_[static_cast<size_t>(edge)];
    const Vec2 g0 = grid_of(e.a), g1 = grid_of(e.b), mid = point_on(e, 0.5), gm = grid_of(mid), n = left_normal(e);
    double dev = segment_distance(gm, g0, g1);
    for (const double t : {0.25, 0.75}) dev = std::max(dev, segment_distance(grid_of(point_on(e, t)), g0, g1));
    const double off = farthest_off(e);
    double move = 0.0;
    for (const double side : {-1.0, 1.0})
      move = std::max(move, length(gm, grid_of(Vec2{mid.x + side * off * n.x, mid.y + side * off * n.y})));
    const double scale = std::max({std::abs(g0.x), std::abs(g0.y), std::abs(g1.x), std::abs(g1.y)});
    bow = 2.0 * dev + 2.0 * move + 64.0 * std::numeric_limits<double>::epsilon() * scale;
    cached.store(bow, std::memory_order_relaxed);
    return bow;
  }

 private:
  static double checked_within(double within) {
    if (!(within >= 0.0))
      throw Error(ErrorKind::invalid_argument, "the owners' settling needs a distance to settle within, 0 or more");
    return within;
  }
  static bool located(const SeaOptions& o) { return o.geolocator != nullptr && o.grid_polygons != nullptr; }
  const Prepared& prepared() const { return sea_->prepared; }

  // A barrier edge in the plane, and (geodesic) its ends' longitudes and latitudes, its length
  // in metres and its azimuth at a (what points along it are found from).
  struct Edge {
    Vec2 a, b, a_ll, b_ll;
    double metres = 0.0, azimuth = 0.0;
  };
  void list_edges() {
    const Prepared& pr = prepared();
    auto ll_of = [&](Vec2 at) {
      if (!pr.geodesic) return Vec2{};
      const int32_t v = pr.vis.vertex_at(at);
      return v >= 0 ? pr.vertex_ll[static_cast<size_t>(v)] : pr.vis.frame()->reverse(at);
    };
    auto add = [&](Vec2 a, Vec2 b) {
      if (a == b) return;
      Edge e{a, b, ll_of(a), ll_of(b)};
      if (geod_) {
        double azi2;
        geod_->Inverse(e.a_ll.y, e.a_ll.x, e.b_ll.y, e.b_ll.x, e.metres, e.azimuth, azi2);
      }
      edges_.push_back(e);
    };
    for (const Barriers::Polygon& poly : pr.vis.barriers().polygons())
      for (const Ring& r : poly.rings)
        for (size_t i = 0; i < r.size(); ++i) add(r[i], r[(i + 1) % r.size()]);
    for (const Barriers::Line& l : pr.vis.barriers().lines())
      for (size_t i = 0; i + 1 < l.vertices.size(); ++i) add(l.vertices[i], l.vertices[i + 1]);
    bows_ = std::make_unique<std::atomic<double>[]>(edges_.size());
    for (size_t i = 0; i < edges_.size(); ++i) bows_[i].store(-1.0, std::memory_order_relaxed);
  }
  static double segment_distance(Vec2 p, Vec2 a, Vec2 b) {
    const double dx = b.x - a.x, dy = b.y - a.y, l2 = dx * dx + dy * dy;
    const double t = l2 > 0.0 ? std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / l2, 0.0, 1.0) : 0.0;
    return length(p, Vec2{a.x + t * dx, a.y + t * dy});
  }
  // The point of edge e at fraction t of its length, in the plane: on the geodesic itself, then
  // projected (geodesic), or on the segment.
  Vec2 point_on(const Edge& e, double t) const {
    if (!geod_) return Vec2{e.a.x + t * (e.b.x - e.a.x), e.a.y + t * (e.b.y - e.a.y)};
    double lat, lon;
    geod_->Direct(e.a_ll.y, e.a_ll.x, e.azimuth, t * e.metres, lat, lon);
    return prepared().vis.frame()->forward(Vec2{e.a_ll.x + std::remainder(lon - e.a_ll.x, 360.0), lat});
  }
  static Vec2 left_normal(const Edge& e) {  // (of a -> b, in the plane, unit)
    const double len = length(e.a, e.b);
    return Vec2{-(e.b.y - e.a.y) / len, (e.b.x - e.a.x) / len};
  }
  // The farthest domain_edge_point moves a point off edge e, in plane units.
  double farthest_off(const Edge& e) const {
    const double bend = prepared().vis.frame() ? prepared().vis.frame()->deviation() : 0.0;
    return 1e-6 * length(e.a, e.b) + 2.0 * bend;
  }

  // Grid-CRS positions to the plane the engines decide in, and back.
  Spot spot_of(Vec2 p) const {
    const Prepared& pr = prepared();
    if (!pr.geodesic) return Spot{Vec2{p.x - grid_.xmin, p.y - grid_.ymax}, Vec2{}};
    Vec2 ll = p;
    if (pr.geolocator) pr.geolocator->to_lonlat(&p.x, &p.y, &ll.x, &ll.y, 1);
    return Spot{pr.vis.frame()->forward(ll), ll};
  }
  Vec2 plane_of(Vec2 p) const { return spot_of(p).at; }
  Vec2 grid_of(Vec2 at) const {
    const Prepared& pr = prepared();
    if (!pr.geodesic) return Vec2{at.x + grid_.xmin, at.y + grid_.ymax};
    const Vec2 ll = pr.vis.frame()->reverse(at);
    if (!pr.geolocator) return ll;
    Vec2 g;
    pr.geolocator->to_grid(&ll.x, &ll.y, &g.x, &g.y, 1);
    return g;
  }

  // A position where the engines hold it, and its ground.
  struct Where {
    Spot spot;
    Visibility::Ground ground = Visibility::Ground::land;
  };
  Where where(Vec2 p) const {
    // (The index measures several sites at one position: its ground is worked out once.)
    // (Keyed by the metric's serial number, not its address: a metric made where another was
    // freed must not read that one's answer.)
    thread_local uint64_t cached_by = 0;
    thread_local Vec2 cached_at{kNaN, kNaN};
    thread_local Where cached;
    if (cached_by == serial_ && cached_at.x == p.x && cached_at.y == p.y) return cached;
    Where w;
    w.spot = spot_of(p);
    w.ground = prepared().vis.classify(w.spot.at);
    cached_by = serial_;
    cached_at = p;
    cached = w;
    return w;
  }
  // Whether p (on a barrier, in the barriers' plane) has sea on more than one side: a line
  // barrier's point (sea either side), or where two islands meet at a corner. Each sea wedge's
  // paths reach p, and p takes the shortest of them, so every site whose shortest comes from
  // another wedge jumps on leaving p into one, or along a ray (the points of a wall take the
  // least of both sides too, which no point beside it does). No way from p is continuous
  // (open_between's contract), and the deliverables put no equidistance point on one: the lines
  // on either side end on the barrier where each side's locus meets it.
  bool parts_the_sea(Vec2 p) const {
    const Visibility::Star star = prepared().vis.star_at(p);
    return std::count(star.sea.begin(), star.sea.end(), uint8_t{1}) >= 2;
  }
  static Visibility::Place place(const Where& w) {
    Visibility::Place at{w.spot.at};
    at.open = w.ground == Visibility::Ground::open_sea;
    return at;
  }

  // A site's best path to p: its length, its last bend (a node of the owner's settling, -1 for a
  // straight path), and the length's gradient at p.
  struct Path {
    double d = std::numeric_limits<double>::infinity();
    int32_t node = -1;
    Vec2 gradient{kNaN, kNaN};
    int32_t touch = -1;  // a straight path to a point where the site's edge meets a barrier
  };
  // The points where the site's edges meet barriers (indices of Prepared::touches).
  std::span<const int32_t> touches_of_site(int32_t site) const {
    const auto s = static_cast<size_t>(site);
    if (s + 1 >= touch_start_.size()) return {};
    return std::span<const int32_t>(touch_list_.data() + touch_start_[s], touch_start_[s + 1] - touch_start_[s]);
  }
  void list_touches() {
    const Prepared& pr = prepared();
    touch_start_.assign(seeds().sites().size() + 1, 0);
    for (const Prepared::Touch& t : pr.touches) ++touch_start_[static_cast<size_t>(t.site) + 1];
    for (size_t i = 1; i < touch_start_.size(); ++i) touch_start_[i] += touch_start_[i - 1];
    touch_list_.assign(pr.touches.size(), 0);
    std::vector<size_t> at(touch_start_.begin(), touch_start_.end() - 1);
    for (size_t k = 0; k < pr.touches.size(); ++k)
      touch_list_[at[static_cast<size_t>(pr.touches[k].site)]++] = static_cast<int32_t>(k);
  }
  // `bound`: a path longer than it need not be found (the result is then any length above it).
  Path best(Vec2 p, int32_t site, double bound = std::numeric_limits<double>::infinity()) const {
    settled();
    Path out;
    const Where w = where(p);
    if (w.ground == Visibility::Ground::land) return out;
    const Prepared& pr = prepared();
    const Visibility::Place at = place(w);
    const Prepared::Xyz xyz = pr.spot_xyz(w.spot);
    // (A point site on the ellipsoid: its place without its length, which the inner metric
    // measures once it is seen.)
    Visibility::Place foot{w.spot.at};
    bool on_site = false;
    double straight = 0.0;  // at most the straight distance to the site
    if (pr.geodesic && !pr.segment(site)) {
      foot = pr.site_place(site, w.spot);
      on_site = w.spot.ll == pr.site_ll[static_cast<size_t>(site)];
      straight = Prepared::chord_below(pr.site_xyz[static_cast<size_t>(site)], xyz);
    } else {
      const double key = pr.site_key(w.spot, site, &foot);
      on_site = key == 0.0;
      straight = std::sqrt(key);
    }
    // Every path to the site is at least the straight line: a site farther than the bound in a
    // straight line is measured no further. (The slack covers the rounding of lengths measured
    // by different routes: to the nanometre on the ellipsoid.)
    if (straight > bound + 1e-9 * bound + (pr.geodesic ? 1e-6 : 0.0)) return out;
    // (The edge that last hid each root from a position this thread measured: the lines ask at
    // positions close together, and one crossing test proves most hidden roots hidden again.)
    std::vector<int32_t>& hint = hints();
    auto seen = [&](size_t item, const Visibility::Place& to) {
      int32_t& b = hint[item];
      if (b >= 0 && pr.vis.crosses(b, at, to)) return false;
      return pr.vis.sees(at, to, &b);
    };
    if (on_site || seen(static_cast<size_t>(site), foot)) {
      VertexHit hit;
      out.d = inner_->distance_at_vertex(p, site, out.gradient, hit);
    }
    // Where the site's edges meet barriers, seen (Prepared::touches).
    for (const int32_t k : touches_of_site(site)) {
      const Prepared::Touch& t = pr.touches[static_cast<size_t>(k)];
      Vec2 gradient{kNaN, kNaN};
      double d;
      if (!pr.geodesic) {
        d = length(w.spot.at, t.at.at);
        if (d > 0.0) gradient = Vec2{(w.spot.at.x - t.at.at.x) / d, (w.spot.at.y - t.at.at.y) / d};
      } else {
        d = pr.geolocator ? pr.geodesic->point_distance(w.spot.ll, t.ll)
                          : pr.geodesic->point_distance(w.spot.ll, t.ll, gradient);
      }
      if (!(d < out.d) || d > bound || !(d == 0.0 || pr.vis.sees(at, t.at))) continue;
      out = Path{d, -1, gradient};
      out.touch = k;
    }
    const int32_t r = roots_of_site_[static_cast<size_t>(site)];
    if (r < 0) return out;
    const SiteRoots& roots = roots_[static_cast<size_t>(r)];
    const Searches& s = *roots.search;
    int32_t won = -1;
    // (The roots' tests in the field's order: Searches::through. Roots whose paths are longer
    // than the bound are left unvisited, as those longer than the best so far are.)
    const auto limit = [&] { return std::min(out.d, bound); };
    roots.tree.within(
        w.spot.at, [&] { return limit() + 1e-12 * limit(); },
        [&](int32_t item, double) {
          const int32_t k = roots.nodes[static_cast<size_t>(item)];
          const double d = s.through(
              static_cast<size_t>(k), w.spot, xyz, limit(),
              [&](double length) { return length < out.d && length <= bound; },
              [&](const Visibility::Place& to) { return seen(static_cast<size_t>(roots.first_hint + k), to); });
          if (!std::isfinite(d)) return;
          out.d = d;
          won = k;
        });
    if (won < 0) return out;
    out.node = won;
    out.touch = -1;
    const int32_t v = s.nodes[static_cast<size_t>(won)].vertex;
    if (!pr.geodesic) {
      const Vec2 q = pr.vis.vertex(v);
      const double dx = w.spot.at.x - q.x, dy = w.spot.at.y - q.y, len = std::hypot(dx, dy);
      out.gradient = len > 0.0 ? Vec2{dx / len, dy / len} : Vec2{kNaN, kNaN};
    } else if (pr.geolocator) {
      out.gradient = Vec2{kNaN, kNaN};
    } else {
      pr.geodesic->point_distance(w.spot.ll, pr.vertex_ll[static_cast<size_t>(v)], out.gradient);
    }
    return out;
  }

  // The owners' settling, at the first distance asked (once, whichever thread asks first; the
  // others wait): a metric made for a margin alone, which runs the engine per owner instead, never
  // pays for it. A failed settling (cancelled) is tried again by the next.
  void settled() const {
    if (ready_.load(std::memory_order_acquire)) return;
    const std::lock_guard<std::mutex> lock(settle_mutex_);
    if (ready_.load(std::memory_order_relaxed)) return;
    const_cast<SeaSiteMetric*>(this)->settle_owners(seeds());
    ready_.store(true, std::memory_order_release);
  }

 public:
  // (settle_sea_metric_within)
  void settle_within(double within) {
    checked_within(within);
    const std::lock_guard<std::mutex> lock(settle_mutex_);
    if (within <= within_) return;
    within_ = within;
    if (!ready_.load(std::memory_order_relaxed)) return;  // (the first distance asked settles)
    try {
      run_groups();
    } catch (...) {
      ready_.store(false, std::memory_order_release);  // (cancelled: settled again from the start when asked)
      throw;
    }
  }

 private:
  // Per owner, the bend nodes settled over its sites alone (with weights or reaches, over each
  // class of its sites alone, sea::site_classes: a site's cost is its length over its weight, so
  // the cheapest of an owner's paths is the shortest of some class's), up to within_; then per
  // site, the nodes its paths reach first.
  void settle_owners(const SeedSet& seeds) {
    const Prepared& pr = prepared();
    const int32_t owners = seeds.owner_count();
    std::vector<std::vector<int32_t>> of_owner(static_cast<size_t>(owners));
    for (int32_t id : pr.geometric) of_owner[static_cast<size_t>(seeds.site_owner(id) - 1)].push_back(id);
    std::vector<std::vector<int32_t>> sites;
    group_owner_.clear();
    for (size_t o = 0; o < of_owner.size(); ++o) {
      const std::vector<int32_t>& owned = of_owner[o];
      if (owned.empty()) continue;
      if (!seeds.adjusted()) {
        sites.push_back(owned);
      } else {
        for (SiteClass& c : site_classes(seeds, owned)) sites.push_back(std::move(c.sites));
      }
      group_owner_.resize(sites.size(), static_cast<int32_t>(o) + 1);
    }
    // (From the start: a settling cancelled before is in no state to go on.)
    const auto start = std::chrono::steady_clock::now();
    groups_.clear();
    groups_.resize(sites.size());
    // (Made once for every owner: which bend nodes see each other nearby depends on the barriers
    // alone. An owner's nodes deep in another's waters would otherwise be searched again at every
    // step of their bound.)
    if (!near_) {
      const PreparedSea::CutEdges& cut = sea_->cut_edges();
      near_ = std::make_unique<NearBends>(
          near_bends(pr, bend_nodes(pr.vis), kNearVertices, threads_, cancel_, cut.edges, cut.index));
    }
    detail::parallel_for(resolve_threads(threads_), static_cast<int64_t>(sites.size()), [&](int64_t g, int) {
      Group& group = groups_[static_cast<size_t>(g)];
      group.search = std::make_unique<Searches>(pr, sites[static_cast<size_t>(g)]);
      group.settling = std::make_unique<Settling>(*group.search, near_.get());
    });
    if (stats_) {
      *stats_ = SeaMetricStats{};
      stats_->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      stats_->bend_tests = near_->tests;
    }
    run_groups();
  }

  // Every group's settling run on to within_, then the sites' roots indexed again.
  void run_groups() {
    const auto start = std::chrono::steady_clock::now();
    std::vector<int64_t> tests(groups_.size(), 0);
    detail::parallel_for(resolve_threads(threads_), static_cast<int64_t>(groups_.size()), [&](int64_t g, int) {
      groups_[static_cast<size_t>(g)].settling->run(tests[static_cast<size_t>(g)], cancel_, within_);
    });
    index_roots(seeds());
    if (stats_) {
      stats_->owners = seeds().owner_count();
      for (int64_t t : tests) stats_->bend_tests += t;
      stats_->seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      stats_->within = within_;
    }
  }

  // Per site, the settled nodes its paths reach first, in a tree weighted by their distance.
  void index_roots(const SeedSet& seeds) {
    const Prepared& pr = prepared();
    roots_.clear();
    roots_of_site_.assign(seeds.sites().size(), -1);
    auto first_hint = static_cast<int32_t>(seeds.sites().size());
    for (const Group& group : groups_) {
      const Searches* s = group.search.get();
      const int32_t group_hint = first_hint;
      first_hint += static_cast<int32_t>(s->nodes.size());
      std::vector<std::vector<int32_t>> by_site(seeds.sites().size());
      for (size_t k = 0; k < s->nodes.size(); ++k)
        if (s->root(k)) by_site[static_cast<size_t>(s->dist[k].site)].push_back(static_cast<int32_t>(k));
      for (size_t site = 0; site < by_site.size(); ++site) {
        if (by_site[site].empty()) continue;
        SiteRoots roots;
        roots.search = s;
        roots.first_hint = group_hint;
        roots.nodes = std::move(by_site[site]);
        std::vector<RootTree::Box> boxes;
        for (int32_t k : roots.nodes) {
          const Vec2 v = pr.vis.vertex(s->nodes[static_cast<size_t>(k)].vertex);
          boxes.push_back({v, v});
        }
        roots.tree = RootTree(boxes, pr.lower_scale());
        for (size_t i = 0; i < roots.nodes.size(); ++i)
          roots.tree.set_weight(static_cast<int32_t>(i), s->dist[static_cast<size_t>(roots.nodes[i])].d);
        roots_of_site_[site] = static_cast<int32_t>(roots_.size());
        roots_.push_back(std::move(roots));
      }
    }
    hint_count_ = static_cast<size_t>(first_hint);
  }

  // This thread's hints for this metric: per site (its index), then per node of each group, the
  // edge that last hid it (-1: none known). Hints only: every answer is exact without them.
  std::vector<int32_t>& hints() const {
    thread_local uint64_t hints_by = 0;
    thread_local std::vector<int32_t> hint;
    if (hints_by != serial_ || hint.size() != hint_count_) {
      hint.assign(hint_count_, -1);
      hints_by = serial_;
    }
    return hint;
  }

  // This thread's hints for search_start, per group: the edge that last hid each root of its
  // search, and the root of its last answer (Searches::best_path's `blockers` and `first`).
  struct StartHints {
    std::vector<int32_t> blockers;
    int32_t last = -1;
  };
  std::vector<StartHints>& start_hints() const {
    thread_local uint64_t hints_by = 0;
    thread_local std::vector<StartHints> hints;
    if (hints_by != serial_ || hints.size() != groups_.size()) {
      hints.assign(groups_.size(), StartHints{});
      for (size_t g = 0; g < groups_.size(); ++g) {
        const Searches& s = *groups_[g].search;
        hints[g].blockers.assign(static_cast<size_t>(s.site_items()) + s.nodes.size(), -1);
      }
      hints_by = serial_;
    }
    return hints;
  }

  // This metric's number among all made in the process (from 1): what the position cache is keyed by.
  const uint64_t serial_ = next_serial();
  static uint64_t next_serial() {
    static std::atomic<uint64_t> count{0};
    return ++count;
  }
  GridSpec grid_;
  std::shared_ptr<const std::vector<Polygon>> polygons_;  // the base's polygons, when located
  std::unique_ptr<SiteMetric> inner_;                     // the straight metric: bounds and straight legs
  std::shared_ptr<const PreparedSea> sea_;
  const int threads_;  // the owners' settling's
  const std::atomic<bool>* cancel_;
  SeaMetricStats* stats_;
  double within_;  // the owners' nodes settled (or to be) up to this distance by sea
  mutable std::mutex settle_mutex_;
  mutable std::atomic<bool> ready_{false};  // settled up to within_
  // Filled by the settling (settled(), settle_within()), then only read.
  struct Group {
    std::unique_ptr<Searches> search;  // per owner with geometric sites (per class of them)
    std::unique_ptr<Settling> settling;
  };
  std::vector<Group> groups_;
  // The near bends every group's settling shares (near_bends.hpp): each node's nearest
  // kNearVertices other vertices.
  static constexpr int kNearVertices = 16;
  std::unique_ptr<NearBends> near_;
  std::vector<int32_t> group_owner_;  // per group, its owner's code
  std::vector<SiteRoots> roots_;
  size_t hint_count_ = 0;                          // sites, then every group's nodes
  std::vector<int32_t> roots_of_site_;             // site -> its entry of roots_, or -1
  std::vector<Edge> edges_;                        // the domain's edges: every barrier edge
  std::unique_ptr<std::atomic<double>[]> bows_;    // per edge, domain_edge_bow once asked (else -1)
  std::vector<size_t> touch_start_;                // per site, its first entry of touch_list_ (and one past)
  std::vector<int32_t> touch_list_;                // Prepared::touches by site
  std::unique_ptr<GeographicLib::Geodesic> geod_;  // geodesic: points along an edge
};

}  // namespace

std::unique_ptr<SiteMetric> make_sea_site_metric(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid,
                                                 const SeaOptions& options, SeaMetricStats* stats,
                                                 double settle_within) {
  return std::make_unique<SeaSiteMetric>(seeds, barriers, grid, options, stats, settle_within);
}

void settle_sea_metric_within(SiteMetric& metric, double within) {
  auto* sea = dynamic_cast<SeaSiteMetric*>(&metric);
  if (!sea) throw Error(ErrorKind::internal, "settle_sea_metric_within: not a metric of the distance by sea");
  sea->settle_within(within);
}

}  // namespace rv
