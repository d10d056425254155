#include "sea/sea_prepare.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "field/geodesic_sites.hpp"
#include "rv/field/error.hpp"
#include "sea/orient.hpp"

namespace rv::sea {

// Every site's ends sea (a seed may lie on a barrier's boundary, not inside it).
void check_seeds(Prepared& p, const SeedSet& seeds);

namespace {

// Whether wedge k of a vertex's star is wider than a half-turn: the wedge from ray k
// counter-clockwise to ray k + 1 turns clockwise (exactly a half-turn: collinear and opposite, not
// a bend); a line's end has one wedge, all round.
bool bends(const Visibility& vis, const Visibility::Star& s, int k) {
  const int n = static_cast<int>(s.rays.size());
  return n == 1 || vis.orient(s.at, s.rays[static_cast<size_t>(k)], s.rays[static_cast<size_t>((k + 1) % n)]) < 0;
}

// The longitudes and latitudes a grid covers: its extent's own (geographic), or (projected) the
// box of its outline's located points, a cell's spacing apart and the corners.
LonLatBox grid_box(const GridSpec& grid, const Geolocator* geolocator) {
  if (!geolocator) return LonLatBox{grid.xmin, grid.ymin(), grid.xmax(), grid.ymax};
  std::vector<double> x, y;
  auto add = [&](double px, double py) {
    x.push_back(px);
    y.push_back(py);
  };
  for (int64_t c = 0; c <= grid.width; ++c) {
    add(grid.xmin + static_cast<double>(c) * grid.res, grid.ymax);
    add(grid.xmin + static_cast<double>(c) * grid.res, grid.ymin());
  }
  for (int64_t r = 0; r <= grid.height; ++r) {
    add(grid.xmin, grid.ymax - static_cast<double>(r) * grid.res);
    add(grid.xmax(), grid.ymax - static_cast<double>(r) * grid.res);
  }
  std::vector<double> lon(x.size()), lat(x.size());
  geolocator->to_lonlat(x.data(), y.data(), lon.data(), lat.data(), x.size());
  LonLatBox box{lon[0], lat[0], lon[0], lat[0]};
  for (size_t i = 0; i < lon.size(); ++i) {
    box.xmin = std::min(box.xmin, lon[i]);
    box.xmax = std::max(box.xmax, lon[i]);
    box.ymin = std::min(box.ymin, lat[i]);
    box.ymax = std::max(box.ymax, lat[i]);
  }
  return box;
}

// Where the seeds' edges meet the barriers (Prepared::touches), with their longitudes and
// latitudes on the ellipsoid (a barrier vertex's or a seed end's own, else the frame's reverse).
void find_touches(Prepared& p, const SeedSet& seeds) {
  auto add = [&](size_t s, const Place& m) {
    Vec2 ll;
    if (p.geodesic) {
      const int32_t v = p.vis.vertex_at(m.at);
      ll = v >= 0                                       ? p.vertex_ll[static_cast<size_t>(v)]
           : m.at == Vec2{p.local[s].ax, p.local[s].ay} ? seeds.sites()[s].a
           : m.at == p.end_b[s]                         ? seeds.sites()[s].b
                                                        : p.vis.frame()->reverse(m.at);
    }
    p.touches.push_back(Prepared::Touch{static_cast<int32_t>(s), m, ll});
  };
  for (size_t s = 0; s < p.local.size(); ++s) {
    if (!p.segment(static_cast<int32_t>(s))) continue;
    const Vec2 a{p.local[s].ax, p.local[s].ay}, b = p.end_b[s];
    for (const Place& m : p.vis.meetings(a, b)) add(s, m);
    // An end on a barrier vertex, seen from a sea wedge there that is no bend node (where D = 0
    // would stand for it) and that the edge does not bound: from such a wedge the path cannot
    // slide along the edge, so it ends at the vertex (two islands meeting at the seed's end, a
    // coast straight on past it).
    for (const std::pair<Vec2, Vec2>& ends : {std::pair{a, b}, std::pair{b, a}}) {
      const Vec2 end = ends.first, other = ends.second;  // (plain names: the lambda below takes them)
      const int32_t v = p.vis.vertex_at(end);
      if (v < 0) continue;
      const Visibility::Star& star = p.vis.vertex_star(v);
      const int n = static_cast<int>(star.rays.size());
      auto bounds = [&](int k) {
        const Vec2 r = star.rays[static_cast<size_t>(k % n)];
        return p.vis.orient(end, r, other) == 0 &&
               (r.x - end.x) * (other.x - end.x) + (r.y - end.y) * (other.y - end.y) > 0;
      };
      for (int k = 0; k < star.wedges(); ++k) {
        if (!star.sea[static_cast<size_t>(k)] || bends(p.vis, star, k)) continue;  // land, or a bend node
        if (bounds(k) || bounds(k + 1)) continue;
        add(s, p.vis.at_vertex(v, k));
      }
    }
  }
}

}  // namespace

std::vector<SiteClass> site_classes(const SeedSet& seeds, const std::vector<int32_t>& sites) {
  std::vector<SiteClass> out;
  std::map<std::pair<double, double>, size_t> index;
  for (int32_t id : sites) {
    const Feature& f = seeds.features()[static_cast<size_t>(seeds.site_feature(id))];
    const auto [it, added] = index.emplace(std::make_pair(f.weight, f.reach), out.size());
    if (added) out.push_back(SiteClass{f.weight, f.reach, {}});
    out[it->second].sites.push_back(id);
  }
  return out;
}

InteriorSpans interiors_of(const SeedSet& seeds, const std::vector<Polygon>* grid_polygons, const GridSpec& grid,
                           const Window& window) {
  return grid_polygons ? build_interiors(seeds, *grid_polygons, grid, window) : build_interiors(seeds, grid, window);
}

Prepared prepare(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const MetricSpec& metric,
                 std::shared_ptr<const Geolocator> geolocator) {
  if (seeds.geometric_site_count() == 0) throw Error(ErrorKind::invalid_input, "the seeds have no sites");
  if (metric.kind != MetricSpec::geodesic) {
    if (geolocator)
      throw Error(ErrorKind::invalid_argument,
                  "a geolocator is only meaningful with the geodesic metric (planar measures in the grid's CRS)");
    Prepared p(Visibility(barriers.translated(Vec2{grid.xmin, grid.ymax})));
    p.local = to_local(seeds, grid);
    for (const Site& s : seeds.sites()) p.end_b.push_back(Vec2{s.b.x - grid.xmin, s.b.y - grid.ymax});
    check_seeds(p, seeds);
    find_touches(p, seeds);
    return p;
  }
  // The frame centred in the grid, the barriers and the seeds.
  const std::shared_ptr<const GeodesicFrame> frame =
      frame_for(metric, barriers, seeds, grid_box(grid, geolocator.get()));
  Prepared p(Visibility(barriers.mapped([&](Vec2 v) { return frame->forward(v); }), true, frame));
  p.geodesic = std::make_shared<const GeodesicMeasure>(metric);
  p.max_scale = frame->max_scale();
  p.semi_major = metric.semi_major;
  p.e2 = metric.flattening * (2.0 - metric.flattening);
  p.geo_sites = std::make_shared<const detail::GeoSites>(metric, seeds);
  p.geolocator = std::move(geolocator);
  for (const Site& s : seeds.sites()) {
    const Vec2 a = frame->forward(s.a);
    LocalSite l{a.x, a.y, 0.0, 0.0, 0.0};
    if (s.kind == SiteKind::segment) {
      const Vec2 b = frame->forward(s.b);
      l.dx = b.x - a.x;
      l.dy = b.y - a.y;
      const double len2 = l.dx * l.dx + l.dy * l.dy;
      l.inv_len2 = len2 > 0.0 ? 1.0 / len2 : 0.0;
    }
    p.local.push_back(l);
    p.site_ll.push_back(s.a);
    p.end_b.push_back(s.kind == SiteKind::segment ? frame->forward(s.b) : a);
  }
  // Each vertex's own longitude and latitude (the barriers' as given, by their plane position).
  std::map<std::pair<double, double>, Vec2> given;
  auto note = [&](Vec2 v) {
    const Vec2 at = frame->forward(v);
    given.emplace(std::make_pair(at.x, at.y), v);
  };
  for (const Barriers::Polygon& poly : barriers.polygons())
    for (const Ring& r : poly.rings)
      for (const Vec2& v : r) note(v);
  for (const Barriers::Line& l : barriers.lines())
    for (const Vec2& v : l.vertices) note(v);
  for (int32_t v = 0; v < p.vis.vertex_count(); ++v) {
    const auto it = given.find(std::make_pair(p.vis.vertex(v).x, p.vis.vertex(v).y));
    p.vertex_ll.push_back(it != given.end() ? it->second : frame->reverse(p.vis.vertex(v)));
  }
  for (const Vec2& ll : p.vertex_ll) p.vertex_xyz.push_back(p.xyz(ll));
  for (const Vec2& ll : p.site_ll) p.site_xyz.push_back(p.xyz(ll));
  check_seeds(p, seeds);
  find_touches(p, seeds);
  return p;
}

Prepared::Xyz Prepared::xyz(Vec2 ll) const {
  constexpr double kRad = M_PI / 180.0;
  const double sl = std::sin(ll.y * kRad), cl = std::cos(ll.y * kRad);
  const double n = semi_major / std::sqrt(1.0 - e2 * sl * sl);  // the prime vertical's radius
  return Xyz{n * cl * std::cos(ll.x * kRad), n * cl * std::sin(ll.x * kRad), n * (1.0 - e2) * sl};
}

double Prepared::segment_distance(const Spot& x, int32_t site, Place* foot) const {
  detail::GeoEnd end;
  const double d = geo_sites->distance(geo_sites->cell(x.ll.x, x.ll.y), site, foot ? &end : nullptr);
  if (!foot) return d;
  const LocalSite& l = local[static_cast<size_t>(site)];
  const Vec2 a = site_ll[static_cast<size_t>(site)];
  if (end.valid) {  // at an end: its image, as the barriers' vertices are made
    *foot = end.lon == a.x && end.lat == a.y ? Place{Vec2{l.ax, l.ay}} : Place{end_b[static_cast<size_t>(site)]};
  } else if (std::isnan(end.foot)) {  // x on the segment (distance 0): x itself
    *foot = Place{x.at};
    foot->exact = false;
  } else {
    double lat, lon;
    geo_sites->position(site, end.foot, lat, lon);
    *foot = Place{vis.frame()->forward(Vec2{lon, lat})};
    foot->exact = false;
  }
  return d;
}

void check_seeds(Prepared& p, const SeedSet& seeds) {
  for (int32_t i = 0; i < static_cast<int32_t>(seeds.sites().size()); ++i) {
    const Site& s = seeds.sites()[static_cast<size_t>(i)];
    if (s.kind == SiteKind::area) continue;
    p.geometric.push_back(i);
    const LocalSite& l = p.local[static_cast<size_t>(i)];
    // (A barrier's own vertex under another barrier, where two barriers overlap, is on a land
    // border: no path reaches it, and the seed is reached where it is at sea, snap_to_sea.)
    for (Vec2 end : {Vec2{l.ax, l.ay}, p.end_b[static_cast<size_t>(i)]})
      if (p.vis.on_land(end) && p.vis.vertex_at(end) < 0)
        throw Error(ErrorKind::invalid_input, "the seed " + seeds.feature_name(s.feature) +
                                                  " has a vertex inside a barrier: a seed may lie on a barrier's "
                                                  "boundary, not inside it");
  }
}

void Prepared::row_cells(const GridSpec& grid, const Window& window, int64_t r, std::vector<Spot>& out) const {
  out.resize(static_cast<size_t>(window.width));
  if (!geodesic) {
    for (int64_t c = 0; c < window.width; ++c)
      out[static_cast<size_t>(c)] = Spot{Vec2{grid.local_x(window.col0 + c), grid.local_y(window.row0 + r)}, Vec2{}};
    return;
  }
  if (geolocator) {  // a projected grid's row, located as one batch
    std::vector<double> x(static_cast<size_t>(window.width)), y(x.size(), grid.centre_y(window.row0 + r));
    std::vector<double> lon(x.size()), lat(x.size());
    for (int64_t c = 0; c < window.width; ++c) x[static_cast<size_t>(c)] = grid.centre_x(window.col0 + c);
    geolocator->to_lonlat(x.data(), y.data(), lon.data(), lat.data(), x.size());
    for (size_t c = 0; c < x.size(); ++c) {
      const Vec2 ll{lon[c], lat[c]};
      out[c] = Spot{vis.frame()->forward(ll), ll};
    }
    return;
  }
  // (The plane's positions in a buffer of the thread's own, kept between rows for the same reason.)
  thread_local std::vector<Vec2> plane;
  plane.resize(static_cast<size_t>(window.width));
  const double lat = grid.centre_y(window.row0 + r);
  vis.frame()->forward_row(lat, grid.centre_x(window.col0), grid.res, window.width, plane.data());
  for (int64_t c = 0; c < window.width; ++c)
    out[static_cast<size_t>(c)] = Spot{plane[static_cast<size_t>(c)], Vec2{grid.centre_x(window.col0 + c), lat}};
}

Spot Prepared::cell_spot(const GridSpec& grid, const Window& window, int64_t r, int64_t c) const {
  if (!geodesic) return Spot{Vec2{grid.local_x(window.col0 + c), grid.local_y(window.row0 + r)}, Vec2{}};
  if (geolocator) {
    const double x = grid.centre_x(window.col0 + c), y = grid.centre_y(window.row0 + r);
    Vec2 ll;
    geolocator->to_lonlat(&x, &y, &ll.x, &ll.y, 1);
    return Spot{vis.frame()->forward(ll), ll};
  }
  const double lat = grid.centre_y(window.row0 + r);
  return Spot{vis.frame()->forward_row_point(lat, grid.centre_x(window.col0), grid.res, window.width, c),
              Vec2{grid.centre_x(window.col0 + c), lat}};
}

SeaField empty_field(const Prepared& p, const GridSpec& grid, const Window& window, const MetricSpec& metric,
                     bool filled) {
  SeaField out;
  out.field.site = Raster<int32_t>(grid, window, Uninitialized{});
  out.field.distance = Raster<float>(grid, window, Uninitialized{});
  out.field.metric = metric;
  out.via = Raster<int32_t>(grid, window, Uninitialized{});
  out.barrier_vertices = p.vis.vertex_count();
  if (filled) empty_rows(out, 0, window.height);
  return out;
}

void empty_rows(SeaField& field, int64_t r0, int64_t r1) {
  const int64_t w = field.via.window().width;
  const auto first = static_cast<ptrdiff_t>(r0 * w), count = static_cast<ptrdiff_t>((r1 - r0) * w);
  std::fill_n(field.field.site.cells().begin() + first, count, kNoSite);
  std::fill_n(field.field.distance.cells().begin() + first, count, kNoDistance);
  std::fill_n(field.via.cells().begin() + first, count, kNoVia);
}

std::vector<Node> bend_nodes(const Visibility& vis) {
  std::vector<Node> nodes;
  for (int32_t v = 0; v < vis.vertex_count(); ++v) {
    const Visibility::Star& s = vis.vertex_star(v);
    for (int k = 0; k < s.wedges(); ++k)
      if (s.sea[static_cast<size_t>(k)] && bends(vis, s, k)) nodes.push_back(Node{v, k});
  }
  return nodes;
}

TautTest taut_test(const Visibility& vis, const Node& node, Vec2 from) {
  const Visibility::Star& s = vis.vertex_star(node.vertex);
  TautTest t;
  t.at = s.at;
  t.from = from;
  t.ax = from.x - s.at.x;
  t.ay = from.y - s.at.y;
  // A site's nearest point from the node computed a hair off it: the seed's end is on the node.
  t.near = vis.slack(s.at, from);
  t.any = from == s.at || t.ax * t.ax + t.ay * t.ay <= t.near * t.near;
  if (t.any) return t;
  t.slack = rounding_slack(s.at, from);
  t.line_bend = vis.frame() ? std::sqrt(t.ax * t.ax + t.ay * t.ay) * vis.frame()->deviation() : 0.0;
  t.from_vertex = vis.vertex_at(from) >= 0;
  // The land next to this wedge runs counter-clockwise from ray k + 1 to ray k. Its far ray (k),
  // by its counter-clockwise angle from the arrival's direction: in the left half-turn (0), the
  // right one or straight back (1), or straight ahead at angle 0 (-1).
  const int n = static_cast<int>(s.rays.size());
  if (n == 0) return t;  // (no node: a vertex with no edges has no land to bend round)
  t.land_end = s.rays[static_cast<size_t>(node.wedge % n)];
  t.land_side = vis.orient(s.at, from, t.land_end);
  const bool ahead = (t.land_end.x - s.at.x) * (from.x - s.at.x) + (t.land_end.y - s.at.y) * (from.y - s.at.y) > 0;
  t.land_at_arrival = t.land_side == 0 && ahead;
  t.land_half = t.land_side > 0 ? 0 : t.land_side < 0 ? 1 : ahead ? -1 : 1;
  return t;
}

bool taut(const Visibility& vis, const TautTest& t, Vec2 x) {
  if (t.any) return true;
  // (Squared lengths and an inline filter: this runs for every root a search weighs.)
  const double bx = x.x - t.at.x, by = x.y - t.at.y;
  // vis.orient(at, from, x): the filter of the reading's predicate (rv/sea orient.hpp; the
  // frame's adds the geodesic's bend off its chord), the predicate itself when it cannot decide.
  int o = filtered_sign(t.ax * by, t.ay * bx, t.line_bend);
  if (o == 0) o = vis.orient(t.at, t.from, x);
  // Straight on past the node, from a site's computed point (the foot of a perpendicular lies on
  // the straight path to rounding): the path grazes the node, and that rounding may have put the
  // straight path itself through the node's land. Its length is the straight one's.
  if (t.ax * bx + t.ay * by < 0) {
    const double cross = t.ax * by - t.ay * bx;
    if ((o == 0 || cross * cross <= t.slack * t.slack * (bx * bx + by * by)) && !t.from_vertex) return true;
  }
  if (o == 0) return false;  // straight on (between barrier vertices), or straight back: no bend
  // The land lies in the counter-clockwise sweep from the arrival to the departure when its far
  // ray comes after the arrival's direction and no later than the departure's: ranked by their
  // half-turns from the arrival's direction (the departure's is o's), then in one half-turn by
  // their own orientation.
  bool land_ccw = false;
  if (!t.land_at_arrival) {
    const int half = o > 0 ? 0 : 1;
    const bool departure_first = half != t.land_half ? half < t.land_half : vis.orient(t.at, x, t.land_end) > 0;
    land_ccw = !departure_first;
  }
  return land_ccw ? o > 0 : o < 0;
}

bool taut(const Visibility& vis, const Node& node, Vec2 from, Vec2 x) {
  return taut(vis, taut_test(vis, node, from), x);
}

DeadArrivals::DeadArrivals(const Visibility& vis, const Node& node) {
  const Visibility::Star& s = vis.vertex_star(node.vertex);
  if (s.rays.size() != 2) return;
  // (taut_test's reading: the land next to wedge k runs counter-clockwise from ray k + 1 to ray k.)
  const auto k = static_cast<size_t>(node.wedge % 2);
  const Vec2 near = s.rays[1 - k], far = s.rays[k];
  at_ = s.at;
  nx_ = near.x - at_.x;
  ny_ = near.y - at_.y;
  fx_ = far.x - at_.x;
  fy_ = far.y - at_.y;
  n1_ = std::hypot(nx_, ny_);
  f1_ = std::hypot(fx_, fy_);
  // The frame's orientation filter allows a ray's length times the deviation; the differences
  // from `at` carry rounding of the coordinates' size.
  const double bend = vis.frame() ? vis.frame()->deviation() : 0.0;
  const double coords = 1e-12 * (1.0 + std::abs(at_.x) + std::abs(at_.y));
  kn_ = n1_ * (bend + coords);
  kf_ = f1_ * (bend + coords);
  active_ = n1_ > 0.0 && f1_ > 0.0;
}

bool never_taut(const Visibility& vis, const TautTest& t, Vec2 lo, Vec2 hi) {
  // taut()'s cases by the land's far ray (angle L counter-clockwise from the arrival's
  // direction): L within the half-turn (side > 0), the departures are those with angle in
  // [L, half-turn): left of the arrival's line and not right of the ray; beyond it (side < 0),
  // in (half-turn, L): right of the arrival's line and right of the ray. On the arrival's line
  // (side 0), from the node itself or from within twice the reading's slack of it, no proof is
  // tried.
  const Vec2 v = t.at, land_end = t.land_end;
  const double ax = t.ax, ay = t.ay;
  const int side = t.land_side;
  if (t.any || side == 0 || ax * ax + ay * ay <= 4.0 * t.near * t.near) return false;
  const double la = std::hypot(ax, ay);
  const double lx = land_end.x - v.x, ly = land_end.y - v.y, ll = std::hypot(lx, ly);
  const double r = t.slack;
  const Vec2 corners[4] = {lo, Vec2{hi.x, lo.y}, Vec2{lo.x, hi.y}, hi};
  bool out_arrival = true, out_ray = true;        // every corner outside that half-plane
  bool left = true, right = true, behind = true;  // no point of the box near the straight continuation
  for (const Vec2& c : corners) {
    const double bx = c.x - v.x, by = c.y - v.y;
    const double margin = vis.slack(v, c);
    const double straight_on = r * std::hypot(bx, by) / la + margin;  // taut()'s allowance, and the slack
    const double da = (ax * by - ay * bx) / la;                       // > 0: left of the arrival's line
    const double dl = (lx * by - ly * bx) / ll;                       // > 0: left of the land's far ray
    if (!(side > 0 ? da < -straight_on : da > straight_on)) out_arrival = false;
    if (!(side > 0 ? dl < -margin : dl > margin)) out_ray = false;
    if (!(da > straight_on)) left = false;
    if (!(da < -straight_on)) right = false;
    if (!(ax * bx + ay * by > la * margin)) behind = false;
  }
  // (Beside the ray alone, the box must also keep off the straight continuation, which taut()
  // accepts within rounding whatever the ray: wholly on one side of the arrival's line, or
  // wholly behind the node.)
  return out_arrival || (out_ray && (left || right || behind));
}

}  // namespace rv::sea
