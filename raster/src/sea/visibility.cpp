#include "rv/sea/visibility.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>

#include "sea/edge_index.hpp"
#include "sea/orient.hpp"

namespace rv {
namespace {

using sea::along;
using sea::line_distance;

// The orientation predicate of a reading: planar (exact in the plane), or the geodesic frame's.
// (Inlined: it is the innermost call of every query.)
[[gnu::always_inline]] inline int turn(const GeodesicFrame* frame, const Vec2& a, const Vec2& b, const Vec2& c) {
  return frame ? frame->orient(a, b, c) : sea::orient(a, b, c);
}

// Angles round `at` are compared exactly: first the half-plane (upper, from east inclusive, to
// west exclusive), then the turn between the two directions. Geodesic: "east" is the geodesic
// towards a point east of `at` in the frame's plane, and the halves are its two sides.
int half(const GeodesicFrame* frame, Vec2 at, Vec2 e) {
  if (!frame) return (e.y > at.y || (e.y == at.y && e.x > at.x)) ? 0 : 1;
  const Vec2 east = frame->east_of(at);
  const int o = frame->orient(at, east, e);
  return (o > 0 || (o == 0 && along(at, east, e) > 0)) ? 0 : 1;
}
bool angle_less(const GeodesicFrame* frame, Vec2 at, Vec2 e1, Vec2 e2) {
  const int h1 = half(frame, at, e1), h2 = half(frame, at, e2);
  if (h1 != h2) return h1 < h2;
  return turn(frame, at, e1, e2) > 0;
}
bool same_direction(const GeodesicFrame* frame, Vec2 at, Vec2 e1, Vec2 e2) {
  return half(frame, at, e1) == half(frame, at, e2) && turn(frame, at, e1, e2) == 0;
}

// Strictly between a and b on their segment (p on the line through them assumed).
bool strictly_between(Vec2 a, Vec2 b, Vec2 p) { return along(a, b, p) > 0 && along(b, a, p) > 0; }

bool position_less(Vec2 a, Vec2 b) { return a.x < b.x || (a.x == b.x && a.y < b.y); }

// How far a computed end may lie off the boundary it belongs on: a few units in the last place of
// the coordinates involved.
// Geodesic: a computed end lies on a geodesic edge to GeoSites' precision (well under a
// micrometre), whose image lies within the frame's deviation of the edge's chord.
double end_slack(const GeodesicFrame* frame, Vec2 p, Vec2 q) {
  return sea::rounding_slack(p, q) + (frame ? frame->deviation() + 1e-6 : 0.0);
}

// A convex polygon of at most five vertices, counter-clockwise (fewer when degenerate), with
// what apart() projects it on: its bounding box, and per edge the outward unit normal and the
// polygon's largest projection on it.
struct Hull {
  Vec2 p[5];
  int n = 0;
  Vec2 lo, hi;
  Vec2 normal[5];
  double top[5];
  void measure() {
    lo = hi = p[0];
    for (int i = 1; i < n; ++i) {
      lo = Vec2{std::min(lo.x, p[i].x), std::min(lo.y, p[i].y)};
      hi = Vec2{std::max(hi.x, p[i].x), std::max(hi.y, p[i].y)};
    }
    for (int i = 0; i < n && n > 1; ++i) {
      const Vec2 a = p[i], b = p[(i + 1) % n];
      const double nx = b.y - a.y, ny = a.x - b.x, len = std::sqrt(nx * nx + ny * ny);
      normal[i] = len > 0.0 ? Vec2{nx / len, ny / len} : Vec2{0.0, 0.0};
      top[i] = -std::numeric_limits<double>::infinity();
      for (int j = 0; j < n; ++j) top[i] = std::max(top[i], normal[i].x * p[j].x + normal[i].y * p[j].y);
    }
  }
};

// The hull of `from` and the box's corners (Andrew's monotone chain; collinear points dropped,
// which rounding may do to a point a few units in the last place outside: the margins cover it).
Hull hull_of(Vec2 from, Vec2 lo, Vec2 hi) {
  Vec2 pts[5] = {lo, {hi.x, lo.y}, hi, {lo.x, hi.y}, from};
  std::sort(pts, pts + 5, position_less);
  auto cross = [](Vec2 o, Vec2 a, Vec2 b) { return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x); };
  Vec2 chain[10];
  int k = 0;
  for (int i = 0; i < 5; ++i) {
    while (k >= 2 && cross(chain[k - 2], chain[k - 1], pts[i]) <= 0) --k;
    chain[k++] = pts[i];
  }
  for (int i = 3, t = k + 1; i >= 0; --i) {
    while (k >= t && cross(chain[k - 2], chain[k - 1], pts[i]) <= 0) --k;
    chain[k++] = pts[i];
  }
  Hull h;
  h.n = std::max(1, k - 1);
  for (int i = 0; i < h.n; ++i) h.p[i] = chain[i];
  h.measure();
  return h;
}

// Whether the segment a-b (a point when a == b) lies farther than m from the hull, proved by a
// separating axis: x and y, the hull's edge normals, the segment's normal and direction (any
// axis with a gap proves the distance; close to a corner none may, which says false).
bool apart(const Hull& h, Vec2 a, Vec2 b, double m) {
  if (std::max(a.x, b.x) < h.lo.x - m || std::min(a.x, b.x) > h.hi.x + m || std::max(a.y, b.y) < h.lo.y - m ||
      std::min(a.y, b.y) > h.hi.y + m)
    return true;
  for (int i = 0; i < h.n && h.n > 1; ++i) {
    const Vec2 n = h.normal[i];
    if (std::min(n.x * a.x + n.y * a.y, n.x * b.x + n.y * b.y) - h.top[i] > m) return true;
  }
  auto gap_along = [&](double nx, double ny) {
    const double len = std::sqrt(nx * nx + ny * ny);
    if (!(len > 0.0)) return false;
    double hmin = std::numeric_limits<double>::infinity(), hmax = -hmin;
    for (int i = 0; i < h.n; ++i) {
      const double v = nx * h.p[i].x + ny * h.p[i].y;
      hmin = std::min(hmin, v);
      hmax = std::max(hmax, v);
    }
    const double sa = nx * a.x + ny * a.y, sb = nx * b.x + ny * b.y;
    return std::min(sa, sb) - hmax > m * len || hmin - std::max(sa, sb) > m * len;
  };
  return gap_along(b.y - a.y, a.x - b.x) || gap_along(b.x - a.x, b.y - a.y);
}

// Whether every point of the box lies in wedge k of the star (from ray k counter-clockwise to
// ray k + 1), farther than m from the lines its rays lie on.
bool box_in_wedge(const Visibility::Star& s, int k, Vec2 lo, Vec2 hi, double m) {
  const Vec2 o = s.at;
  const Vec2 corners[4] = {lo, {hi.x, lo.y}, hi, {lo.x, hi.y}};
  // Every corner strictly left (sign +1) or right (-1) of the line from o through r.
  auto side = [&](Vec2 r, double sign) {
    const double dx = r.x - o.x, dy = r.y - o.y, len = std::sqrt(dx * dx + dy * dy);
    for (const Vec2& c : corners)
      if (!(sign * (dx * (c.y - o.y) - dy * (c.x - o.x)) > m * len)) return false;
    return true;
  };
  const int n = static_cast<int>(s.rays.size());
  const Vec2 r0 = s.rays[static_cast<size_t>(k)], r1 = s.rays[static_cast<size_t>((k + 1) % n)];
  if (n == 1) {  // all round but the ray itself: either side of its line, or behind o
    const double dx = r0.x - o.x, dy = r0.y - o.y, len = std::hypot(dx, dy);
    const bool behind =
        std::all_of(corners, corners + 4, [&](Vec2 c) { return dx * (c.x - o.x) + dy * (c.y - o.y) < -m * len; });
    return behind || side(r0, 1.0) || side(r0, -1.0);
  }
  const int t = turn(s.frame, o, r0, r1);
  if (t > 0) return side(r0, 1.0) && side(r1, -1.0);  // less than a half-turn: both half-planes
  if (t < 0) return side(r0, 1.0) || side(r1, -1.0);  // more: either
  return side(r0, 1.0);                               // a half-turn
}

}  // namespace

int Visibility::Star::wedge_towards(Vec2 x, bool ccw) const {
  const int n = static_cast<int>(rays.size());
  if (n == 0) return 0;
  const auto it =
      std::lower_bound(rays.begin(), rays.end(), x, [&](Vec2 r, Vec2 d) { return angle_less(frame, at, r, d); });
  const int i = static_cast<int>(it - rays.begin());
  if (i < n && same_direction(frame, at, rays[static_cast<size_t>(i)], x)) return ccw ? i : (i + n - 1) % n;
  return (i + n - 1) % n;
}

int Visibility::orient(const Vec2& a, const Vec2& b, const Vec2& c) const { return turn(frame_.get(), a, b, c); }

struct Visibility::Index {
  sea::EdgeIndex buckets;
};

// Which polygons may hold a point: each polygon's box (its vertices' extent, widened by how far a
// geodesic edge's image may bend off its chord), listed in the cells of a uniform grid it
// overlaps. A point strictly inside a polygon, or on its boundary, lies in its box.
struct Visibility::Lands {
  struct Box {
    Vec2 lo, hi;
    bool holds(Vec2 p) const { return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y; }
  };
  std::vector<Box> boxes;  // per polygon
  Vec2 lo{0.0, 0.0};
  double cell_w = 1.0, cell_h = 1.0;
  int64_t nx = 0, ny = 0;
  std::vector<int64_t> first;    // per cell, into `members` (nx * ny + 1 entries)
  std::vector<int32_t> members;  // polygons by cell

  Lands(const Barriers& barriers, double widen) {
    const auto& polygons = barriers.polygons();
    for (const auto& polygon : polygons) {
      Box b{{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()},
            {-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()}};
      for (const Ring& r : polygon.rings)
        for (const Vec2& v : r) {
          b.lo = {std::min(b.lo.x, v.x), std::min(b.lo.y, v.y)};
          b.hi = {std::max(b.hi.x, v.x), std::max(b.hi.y, v.y)};
        }
      b.lo = {b.lo.x - widen, b.lo.y - widen};
      b.hi = {b.hi.x + widen, b.hi.y + widen};
      boxes.push_back(b);
    }
    if (boxes.empty()) return;
    Vec2 hi = boxes[0].hi;
    lo = boxes[0].lo;
    for (const Box& b : boxes) {
      lo = {std::min(lo.x, b.lo.x), std::min(lo.y, b.lo.y)};
      hi = {std::max(hi.x, b.hi.x), std::max(hi.y, b.hi.y)};
    }
    // About as many cells as polygons, no more than 512 a side.
    const double w = std::max(hi.x - lo.x, 1e-9), h = std::max(hi.y - lo.y, 1e-9);
    const double side = std::sqrt(w * h / static_cast<double>(boxes.size()));
    nx = std::clamp<int64_t>(static_cast<int64_t>(std::ceil(w / side)), 1, 512);
    ny = std::clamp<int64_t>(static_cast<int64_t>(std::ceil(h / side)), 1, 512);
    cell_w = w / static_cast<double>(nx);
    cell_h = h / static_cast<double>(ny);
    std::vector<int64_t> count(static_cast<size_t>(nx * ny) + 1, 0);
    auto cover = [&](const Box& b, auto&& each) {
      const int64_t x0 = column(b.lo.x), x1 = column(b.hi.x), y0 = row(b.lo.y), y1 = row(b.hi.y);
      for (int64_t y = y0; y <= y1; ++y)
        for (int64_t x = x0; x <= x1; ++x) each(y * nx + x);
    };
    for (const Box& b : boxes) cover(b, [&](int64_t c) { ++count[static_cast<size_t>(c) + 1]; });
    for (size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
    first = count;
    members.resize(static_cast<size_t>(count.back()));
    for (size_t k = 0; k < boxes.size(); ++k)
      cover(boxes[k], [&](int64_t c) {
        members[static_cast<size_t>(count[static_cast<size_t>(c)]++)] = static_cast<int32_t>(k);
      });
  }
  int64_t column(double x) const {
    return std::clamp<int64_t>(static_cast<int64_t>(std::floor((x - lo.x) / cell_w)), 0, nx - 1);
  }
  int64_t row(double y) const {
    return std::clamp<int64_t>(static_cast<int64_t>(std::floor((y - lo.y) / cell_h)), 0, ny - 1);
  }
  // The polygons whose boxes hold p, appended to `out`. (A cell holds every box that overlaps it,
  // and a box that holds p overlaps p's cell: clamping only moves points outside every box.)
  void holding(Vec2 p, std::vector<int32_t>& out) const {
    if (boxes.empty()) return;
    const int64_t c = row(p.y) * nx + column(p.x);
    for (int64_t i = first[static_cast<size_t>(c)]; i < first[static_cast<size_t>(c) + 1]; ++i) {
      const int32_t k = members[static_cast<size_t>(i)];
      if (boxes[static_cast<size_t>(k)].holds(p)) out.push_back(k);
    }
  }
};

Visibility::Visibility(Barriers barriers, bool indexed, std::shared_ptr<const GeodesicFrame> frame)
    : barriers_(std::move(barriers)), frame_(std::move(frame)) {
  std::vector<Vec2> positions;
  const auto& polygons = barriers_.polygons();
  for (size_t k = 0; k < polygons.size(); ++k)
    for (const Ring& r : polygons[k].rings)
      for (size_t i = 0, n = r.size(); i < n; ++i) {
        edges_.push_back(Edge{r[i], r[(i + 1) % n], r[(i + n - 1) % n], static_cast<int32_t>(k)});
        positions.push_back(r[i]);
      }
  for (const Barriers::Line& l : barriers_.lines())
    for (size_t i = 0; i < l.vertices.size(); ++i) {
      if (i + 1 < l.vertices.size()) edges_.push_back(Edge{l.vertices[i], l.vertices[i + 1], l.vertices[i], -1});
      positions.push_back(l.vertices[i]);
    }
  // Distinct positions in first-appearance order.
  std::vector<int32_t> order(positions.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int32_t>(i);
  std::stable_sort(order.begin(), order.end(),
                   [&](int32_t a, int32_t b) { return position_less(positions[a], positions[b]); });
  std::vector<uint8_t> first(positions.size(), 0);
  for (size_t i = 0; i < order.size(); ++i)
    if (i == 0 || !(positions[order[i]] == positions[order[i - 1]])) first[order[i]] = 1;
  std::vector<Vec2> vertices;
  for (size_t i = 0; i < positions.size(); ++i)
    if (first[i]) vertices.push_back(positions[i]);
  east_ = 1.0;
  for (const Vec2& v : vertices) east_ = std::max(east_, std::abs(v.x) + 1.0);
  lands_ = std::make_shared<const Lands>(barriers_, frame_ ? frame_->deviation() : 0.0);
  if (indexed) {
    std::vector<sea::EdgeIndex::Segment> segments;
    segments.reserve(edges_.size());
    for (const Edge& e : edges_) segments.push_back({e.a, e.b});
    auto index = std::make_shared<Index>();
    // (Geodesic: an edge's or a path's image bends off its chord by up to the frame's deviation.)
    index->buckets = sea::EdgeIndex(segments, vertices, frame_ ? frame_->deviation() : 0.0);
    index_ = std::move(index);
  }
  stars_.reserve(vertices.size());
  for (const Vec2& v : vertices) stars_.push_back(build_star(v));
  by_position_.resize(stars_.size());
  for (size_t i = 0; i < stars_.size(); ++i) by_position_[i] = static_cast<int32_t>(i);
  std::sort(by_position_.begin(), by_position_.end(),
            [&](int32_t a, int32_t b) { return position_less(stars_[a].at, stars_[b].at); });
}

void Visibility::candidates(Vec2 p, Vec2 q, std::vector<int32_t>& edges, std::vector<int32_t>& vertices) const {
  if (!index_) {
    edges.resize(edges_.size());
    for (size_t i = 0; i < edges.size(); ++i) edges[i] = static_cast<int32_t>(i);
    vertices.resize(stars_.size());
    for (size_t i = 0; i < vertices.size(); ++i) vertices[i] = static_cast<int32_t>(i);
    return;
  }
  index_->buckets.along(p, q, edges, vertices);
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
}

int32_t Visibility::vertex_at(Vec2 p) const {
  const auto it = std::lower_bound(by_position_.begin(), by_position_.end(), p,
                                   [&](int32_t v, Vec2 x) { return position_less(stars_[v].at, x); });
  if (it != by_position_.end() && stars_[*it].at == p) return *it;
  return -1;
}

Visibility::Star Visibility::build_star(Vec2 p) const {
  Star s;
  s.at = p;
  s.frame = frame_.get();
  struct Cone {
    Vec2 out, in;  // land from the direction of `out` counter-clockwise to that of `in`
  };
  std::vector<Cone> cones;
  // Per polygon met: whether p is on its boundary, and the parity of its edges crossing the ray
  // from p towards +x (half-open in y). Every polygon round p crosses that ray, so the edges the
  // ray may meet are enough.
  struct Met {
    int32_t polygon;
    bool on_boundary = false;
    int crossings = 0;
  };
  std::vector<Met> met;
  auto state = [&](int32_t polygon) -> Met& {
    for (Met& m : met)
      if (m.polygon == polygon) return m;
    met.push_back(Met{polygon});
    return met.back();
  };
  std::vector<int32_t> near_edges, near_vertices;
  // Land is decided by the parity of a ray's crossings with each polygon that may hold p (its box
  // does): the ray leaves every such box, by more than any edge's image bends, so it ends outside
  // each of them. It runs along the axis direction in which they end nearest: east, west, north or
  // south from p (planar: the axis line; geodesic: the geodesic to that point). Polygons whose
  // boxes do not hold p cannot hold it, and their crossings are not counted. A vertex on the ray's
  // line counts as right of it (half-open), the same for every edge that has it.
  std::vector<int32_t> holding;
  lands_->holding(p, holding);
  const double bend = frame_ ? frame_->deviation() : 0.0;
  double reach[4] = {p.x + 1.0, p.x - 1.0, p.y + 1.0, p.y - 1.0};  // east, west, north, south
  for (int32_t k : holding) {
    const Lands::Box& b = lands_->boxes[static_cast<size_t>(k)];
    reach[0] = std::max(reach[0], b.hi.x);
    reach[1] = std::min(reach[1], b.lo.x);
    reach[2] = std::max(reach[2], b.hi.y);
    reach[3] = std::min(reach[3], b.lo.y);
  }
  const double lengths[4] = {reach[0] - p.x, p.x - reach[1], reach[2] - p.y, p.y - reach[3]};
  const int way = static_cast<int>(std::min_element(lengths, lengths + 4) - lengths);
  const Vec2 far = way == 0   ? Vec2{reach[0] + bend, p.y}
                   : way == 1 ? Vec2{reach[1] - bend, p.y}
                   : way == 2 ? Vec2{p.x, reach[2] + bend}
                              : Vec2{p.x, reach[3] - bend};
  // (Left of the ray from p to far, exactly: for the axis directions, the coordinate comparisons
  // the orientation predicate reduces to.)
  auto above = [&](Vec2 v) {
    if (frame_) return turn(frame_.get(), p, far, v) > 0;
    return way == 0 ? v.y > p.y : way == 1 ? v.y < p.y : way == 2 ? v.x < p.x : v.x > p.x;
  };
  candidates(p, far, near_edges, near_vertices);
  for (int32_t id : near_edges) {
    const Edge& e = edges_[static_cast<size_t>(id)];
    const Vec2 a = e.a, b = e.b;
    if (e.polygon < 0) {
      if (a == p) {
        s.rays.push_back(b);
      } else if (b == p) {
        s.rays.push_back(a);
      } else if (turn(frame_.get(), a, b, p) == 0 && strictly_between(a, b, p)) {
        s.rays.push_back(a);
        s.rays.push_back(b);
      }
      continue;
    }
    // (A polygon whose box does not hold p has p neither inside nor on its boundary.)
    if (std::find(holding.begin(), holding.end(), e.polygon) == holding.end()) continue;
    Met& m = state(e.polygon);
    if (a == p) {
      m.on_boundary = true;
      s.rays.push_back(b);
      s.rays.push_back(e.prev);
      cones.push_back(Cone{b, e.prev});
      continue;
    }
    if (b == p) {
      m.on_boundary = true;  // its rays come with the visit at b
      continue;
    }
    const int o = turn(frame_.get(), a, b, p);
    if (o == 0 && strictly_between(a, b, p)) {
      m.on_boundary = true;
      s.rays.push_back(a);
      s.rays.push_back(b);
      cones.push_back(Cone{b, a});
      continue;
    }
    const bool a_above = above(a), b_above = above(b);
    if (a_above != b_above) {
      const bool up = b_above;
      if (up ? o > 0 : o < 0) ++m.crossings;
    }
  }
  const bool inside_land =
      std::any_of(met.begin(), met.end(), [](const Met& m) { return !m.on_boundary && (m.crossings & 1); });
  const GeodesicFrame* f = frame_.get();
  std::sort(s.rays.begin(), s.rays.end(), [&](Vec2 a, Vec2 b) { return angle_less(f, p, a, b); });
  s.rays.erase(std::unique(s.rays.begin(), s.rays.end(), [&](Vec2 a, Vec2 b) { return same_direction(f, p, a, b); }),
               s.rays.end());
  const int n = static_cast<int>(s.rays.size());
  if (n == 2) {  // (wedge 0 runs counter-clockwise from ray 0 to ray 1: wide when ray 1 is right of ray 0)
    const int o = turn(f, p, s.rays[0], s.rays[1]);
    s.wide = o < 0 ? 0 : o > 0 ? 1 : -1;
  }
  s.sea.assign(static_cast<size_t>(std::max(1, n)), inside_land ? 0 : 1);
  auto index_of = [&](Vec2 e) { return s.wedge_towards(e, true); };  // on a ray: that ray's index
  for (const Cone& c : cones) {
    const int from = index_of(c.out), to = index_of(c.in);
    if (from == to) continue;  // a spike: no area
    for (int k = from; k != to; k = (k + 1) % n) s.sea[static_cast<size_t>(k)] = 0;
  }
  return s;
}

const Visibility::Star& Visibility::start_star(const Place& from, Star& built) const {
  const int32_t v = from.vertex >= 0 ? from.vertex : from.open ? -1 : vertex_at(from.at);
  if (v >= 0) return stars_[static_cast<size_t>(v)];
  if (from.open) {
    built.at = from.at;
    built.sea = {1};
  } else {
    built = build_star(from.at);
  }
  return built;
}

Visibility::Star Visibility::star_at(Vec2 p) const {
  const int32_t v = vertex_at(p);
  return v >= 0 ? stars_[static_cast<size_t>(v)] : build_star(p);
}

bool Visibility::on_land(Vec2 p) const { return classify(p) == Ground::land; }

Visibility::Ground Visibility::classify(Vec2 p) const {
  const int32_t v = vertex_at(p);
  const Star built = v >= 0 ? Star{} : build_star(p);
  const Star& s = v >= 0 ? stars_[static_cast<size_t>(v)] : built;
  if (std::none_of(s.sea.begin(), s.sea.end(), [](uint8_t x) { return x != 0; })) return Ground::land;
  return s.rays.empty() ? Ground::open_sea : Ground::on_barrier;
}

Visibility::Ground Visibility::classify_next(Vec2 p, Ground p_ground, Vec2 q) const {
  if (!index_ || p_ground == Ground::on_barrier) return classify(q);
  // The ground changes only where a path meets an edge (it enters or leaves land, or reaches a
  // boundary); every vertex is an edge's end. So q's ground is p's when the closed segment p-q
  // meets no edge of the buckets along it: the four orientations of the two segments' ends
  // exclude a meeting unless both pairs straddle or touch (collinear pieces included), and any
  // doubt is settled by classify(q).
  bool apart = true;
  index_->buckets.visit(p, q, [&](const int32_t* edges, size_t ne, const int32_t*, size_t) {
    for (size_t i = 0; i < ne && apart; ++i) {
      const Edge& e = edges_[static_cast<size_t>(edges[i])];
      const int o1 = turn(frame_.get(), e.a, e.b, p), o2 = turn(frame_.get(), e.a, e.b, q);
      if (o1 * o2 > 0) continue;
      const int o3 = turn(frame_.get(), p, q, e.a), o4 = turn(frame_.get(), p, q, e.b);
      apart = o3 * o4 > 0;
    }
    return apart;
  });
  return apart ? p_ground : classify(q);
}

void Visibility::classify_row(double y, const double* xs, int64_t n, Ground* out) const {
  if (n <= 0) return;
  if (frame_) {  // (the row's crossings below are planar: point by point for the geodesic reading)
    for (int64_t i = 0; i < n; ++i) out[i] = classify(Vec2{xs[i], y});
    return;
  }
  std::vector<int32_t> near_edges, near_vertices;
  candidates(Vec2{std::min(xs[0], -east_) - 1.0, y}, Vec2{std::max(xs[n - 1], east_) + 1.0, y}, near_edges,
             near_vertices);
  std::vector<uint8_t> on_barrier(static_cast<size_t>(n), 0);
  // The centres a point of the row at x lies between: the index of the first centre at or
  // beyond x (by the rounded x; the exact tests below correct it).
  auto first_at = [&](double x) { return static_cast<int64_t>(std::lower_bound(xs, xs + n, x) - xs); };
  auto mark_on = [&](int64_t i) { on_barrier[static_cast<size_t>(i)] = 1; };
  // Per polygon met, the number of centres left of each of its crossings (half-open in y).
  std::vector<std::pair<int32_t, int64_t>> splits;
  for (int32_t id : near_edges) {
    const Edge& e = edges_[static_cast<size_t>(id)];
    const Vec2 a = e.a, b = e.b;
    if (std::min(a.y, b.y) > y || std::max(a.y, b.y) < y) continue;
    if (a.y == y && b.y == y) {  // along the row: the centres on it are on the barrier
      for (int64_t i = first_at(std::min(a.x, b.x)); i < n && xs[i] <= std::max(a.x, b.x); ++i) mark_on(i);
      continue;
    }
    const double x = a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
    const int64_t guess = first_at(x);
    const bool counted = e.polygon >= 0 && (a.y > y) != (b.y > y);
    const bool up = b.y > a.y;
    auto left = [&](int64_t i) {  // centre i lies left of the edge's crossing of the row
      const int o = turn(frame_.get(), a, b, Vec2{xs[i], y});
      if (o == 0) mark_on(i);
      return up ? o > 0 : o < 0;
    };
    int64_t m = std::clamp<int64_t>(guess, 0, n);
    while (m > 0 && !left(m - 1)) --m;
    while (m < n && left(m)) ++m;
    if (m < n) left(m);  // a centre exactly on the crossing is on the barrier
    if (counted) splits.emplace_back(e.polygon, m);
  }
  for (int32_t v : near_vertices) {  // a centre at a vertex (also a peak the half-open rule skips)
    const Vec2 w = vertex(v);
    if (w.y != y) continue;
    const int64_t i = first_at(w.x);
    if (i < n && xs[i] == w.x) mark_on(i);
  }
  // Even-odd per polygon: between its 2k-th and (2k+1)-th crossing (in centres) is inside; land
  // where any polygon is.
  std::sort(splits.begin(), splits.end());
  std::vector<int32_t> depth(static_cast<size_t>(n) + 1, 0);
  for (size_t i = 0; i + 1 < splits.size(); ++i) {
    if (splits[i].first != splits[i + 1].first) continue;
    ++depth[static_cast<size_t>(splits[i].second)];
    --depth[static_cast<size_t>(splits[i + 1].second)];
    ++i;
  }
  int32_t inside = 0;
  for (int64_t i = 0; i < n; ++i) {
    inside += depth[static_cast<size_t>(i)];
    out[i] = on_barrier[static_cast<size_t>(i)] ? classify(Vec2{xs[i], y})
             : inside > 0                       ? Ground::land
                                                : Ground::open_sea;
  }
}

double Visibility::slack(Vec2 p, Vec2 q) const { return end_slack(frame_.get(), p, q); }

namespace {

// Whether the direction from s.at towards x lies in wedge w of s, its sides included (either of
// wedge_towards' readings on a side gives w). The wide wedge of two rays (every bend node's sea
// wedge): x is outside it exactly when strictly inside the other, narrower one, which runs
// counter-clockwise from ray 1 - w to ray w: left of the first and right of the second (two
// orientations, where ranking x among the rays takes several); else by wedge_towards.
bool in_wedge(const GeodesicFrame* f, const Visibility::Star& s, int w, Vec2 x) {
  if (w == s.wide) {
    const Vec2 narrow_from = s.rays[static_cast<size_t>(1 - w)], narrow_to = s.rays[static_cast<size_t>(w)];
    return !(turn(f, s.at, narrow_from, x) > 0 && turn(f, s.at, narrow_to, x) < 0);
  }
  return s.wedge_towards(x, true) == w || s.wedge_towards(x, false) == w;
}

}  // namespace

bool Visibility::crossing(const Edge& e, Vec2 p, Vec2 q, double slack) const {
  // (Boxes apart by more than the images' bending, geodesic.)
  const double bend = frame_ ? frame_->deviation() : 0.0;
  if (std::max(e.a.x, e.b.x) + bend < std::min(p.x, q.x) || std::min(e.a.x, e.b.x) - bend > std::max(p.x, q.x) ||
      std::max(e.a.y, e.b.y) + bend < std::min(p.y, q.y) || std::min(e.a.y, e.b.y) - bend > std::max(p.y, q.y))
    return false;
  const int o1 = turn(frame_.get(), p, q, e.a), o2 = turn(frame_.get(), p, q, e.b);
  if (o1 * o2 >= 0) return false;
  const int o3 = turn(frame_.get(), e.a, e.b, p);
  int o4 = turn(frame_.get(), e.a, e.b, q);
  if (o4 != 0 && slack > 0.0 && line_distance(e.a, e.b, q) <= slack) o4 = 0;
  return o3 * o4 < 0;
}

bool Visibility::crosses(int32_t edge, const Place& from, const Place& to) const {
  if (from.at == to.at) return false;
  return crossing(edges_[static_cast<size_t>(edge)], from.at, to.at,
                  to.exact ? 0.0 : end_slack(frame_.get(), from.at, to.at));
}

bool Visibility::sees(const Place& from, const Place& to, int32_t* blocker) const {
  if (blocker) *blocker = -1;
  const Vec2 p = from.at, q = to.at;
  Star p_built;
  const Star& ps = start_star(from, p_built);
  if (p == q) {
    // No way from one wedge of a point into another but round a barrier.
    if (from.wedge >= 0 && to.wedge >= 0 && from.wedge != to.wedge) return false;
    if (from.wedge >= 0) return ps.sea[static_cast<size_t>(from.wedge)] != 0;
    return std::any_of(ps.sea.begin(), ps.sea.end(), [](uint8_t x) { return x != 0; });
  }
  const double slack = to.exact ? 0.0 : end_slack(frame_.get(), p, q);
  // The direction the path leaves p in. A computed end taken as on a barrier edge that starts at p
  // (a path along a coast to where a seed's edge crosses it) may lie off the edge's line by
  // rounding, on the land side as often as not: it leaves along the edge.
  Vec2 toward = q;
  if (slack > 0.0)
    for (const Vec2& r : ps.rays)
      if (along(p, r, q) > 0 && line_distance(p, r, q) <= slack) {
        toward = r;
        break;
      }
  // The ends' wedges first (a few exact tests): a path that cannot leave its start's wedge, or
  // reach its end's, is blocked before any walk along it.
  {
    bool leaves = false, arrives = true;
    if (from.wedge >= 0) {
      leaves = ps.sea[static_cast<size_t>(from.wedge)] && in_wedge(frame_.get(), ps, from.wedge, toward);
    } else {
      for (int s = 0; s < 2; ++s) leaves = leaves || ps.sea[static_cast<size_t>(ps.wedge_towards(toward, s == 0))];
    }
    if (to.vertex >= 0 && to.wedge >= 0) {
      const Star& qs = stars_[static_cast<size_t>(to.vertex)];
      arrives = qs.sea[static_cast<size_t>(to.wedge)] && in_wedge(frame_.get(), qs, to.wedge, p);
    }
    if (!leaves || !arrives) return false;
  }
  // A transversal crossing of any edge's interior: through a line, or into land.
  // Bucket by bucket from p: a crossing ends the search at once; the vertices on the path are
  // gathered for what follows.
  std::vector<int32_t> touches;
  auto crossed = [&](int32_t id) {
    if (!crossing(edges_[static_cast<size_t>(id)], p, q, slack)) return false;
    if (blocker) *blocker = id;
    return true;
  };
  auto touch = [&](int32_t v) {
    const Vec2 w = vertex(v);
    if (turn(frame_.get(), p, q, w) != 0 || !strictly_between(p, q, w)) return;
    if (slack > 0.0 && std::hypot(w.x - q.x, w.y - q.y) <= slack) return;  // the end itself
    touches.push_back(v);
  };
  bool blocked = false;
  if (index_) {
    index_->buckets.visit(p, q, [&](const int32_t* edges, size_t ne, const int32_t* vertices, size_t nv) {
      for (size_t i = 0; i < ne; ++i)
        if (crossed(edges[i])) {
          blocked = true;
          return false;
        }
      for (size_t i = 0; i < nv; ++i) touch(vertices[i]);
      return true;
    });
  } else {
    for (int32_t id = 0; id < static_cast<int32_t>(edges_.size()) && !blocked; ++id) blocked = crossed(id);
    for (int32_t v = 0; v < vertex_count() && !blocked; ++v) touch(v);
  }
  if (blocked) return false;
  std::sort(touches.begin(), touches.end(), [&](int32_t a, int32_t b) { return along(vertex(a), q, vertex(b)) > 0; });
  // Which side of the path (left, right of p -> q) it may be nudged to: along a barrier edge the
  // side decides the wedge, and it cannot change while the path runs along edges.
  bool side[2];
  for (int s = 0; s < 2; ++s) {
    const int k = ps.wedge_towards(toward, s == 0);
    side[s] = ps.sea[static_cast<size_t>(k)] && (from.wedge < 0 || k == from.wedge);
  }
  auto any = [&] { return side[0] || side[1]; };
  if (!any()) return false;
  for (int32_t v : touches) {
    const Star& ts = stars_[static_cast<size_t>(v)];
    bool next[2] = {false, false};
    for (int s = 0; s < 2; ++s) {
      if (!side[s]) continue;
      const int back = ts.wedge_towards(p, s == 1);  // left of travel lies clockwise of the way back
      if (!ts.sea[static_cast<size_t>(back)]) continue;
      for (int s2 = 0; s2 < 2; ++s2)
        if (ts.wedge_towards(q, s2 == 0) == back) next[s2] = true;
    }
    side[0] = next[0];
    side[1] = next[1];
    if (!any()) return false;
  }
  if (to.vertex < 0 || to.wedge < 0) return true;  // the last piece was found sea at its start
  const Star& qs = stars_[static_cast<size_t>(to.vertex)];
  for (int s = 0; s < 2; ++s) {
    if (!side[s]) continue;
    const int back = qs.wedge_towards(p, s == 1);
    if (qs.sea[static_cast<size_t>(back)] && back == to.wedge) return true;
  }
  return false;
}

std::vector<Visibility::Place> Visibility::meetings(Vec2 a, Vec2 b) const {
  const GeodesicFrame* f = frame_.get();
  std::vector<int32_t> near_edges, near_vertices;
  candidates(a, b, near_edges, near_vertices);
  std::vector<Place> out;
  auto add = [&](Vec2 at, bool exact) {
    if (at == a || at == b) exact = false;  // (an end of a-b inside an edge: on it to rounding)
    for (const Place& m : out)
      if (m.at == at) return;
    Place m{at};
    m.exact = exact;
    out.push_back(m);
  };
  for (int32_t id : near_edges) {
    const Edge& e = edges_[static_cast<size_t>(id)];
    if ((e.a == a && e.b == b) || (e.a == b && e.b == a)) continue;
    const int o1 = turn(f, a, b, e.a), o2 = turn(f, a, b, e.b);
    const int o3 = turn(f, e.a, e.b, a), o4 = turn(f, e.a, e.b, b);
    if (o1 * o2 > 0 || o3 * o4 > 0) continue;  // apart
    if (o1 * o2 < 0 && o3 * o4 < 0) {          // a crossing inside both
      const double d1 = std::abs((b.x - a.x) * (e.a.y - a.y) - (b.y - a.y) * (e.a.x - a.x));
      const double d2 = std::abs((b.x - a.x) * (e.b.y - a.y) - (b.y - a.y) * (e.b.x - a.x));
      const double t = d1 + d2 > 0.0 ? d1 / (d1 + d2) : 0.5;
      add(Vec2{e.a.x + t * (e.b.x - e.a.x), e.a.y + t * (e.b.y - e.a.y)}, false);
      continue;
    }
    // Touches: an end of either strictly inside the other (collinear stretches give both ends).
    for (const Vec2 v : {e.a, e.b})
      if (v != a && v != b && turn(f, a, b, v) == 0 && strictly_between(a, b, v)) add(v, true);
    for (const Vec2 v : {a, b})
      if (v != e.a && v != e.b && turn(f, e.a, e.b, v) == 0 && strictly_between(e.a, e.b, v)) add(v, false);
  }
  return out;
}

bool Visibility::clear_box(Vec2 lo, Vec2 hi) const {
  const double bend = frame_ ? frame_->deviation() : 0.0;
  const double magnitude = std::max({std::abs(lo.x), std::abs(lo.y), std::abs(hi.x), std::abs(hi.y)});
  // (Points of the box are exact; an edge's image lies within `bend` of its chord.)
  const double m = bend + 1e-9 * (1.0 + magnitude);
  const Hull h = hull_of(lo, lo, hi);
  return region_clear(h.p, h.n, m, m, nullptr);
}

bool Visibility::sees_box(const Place& from, Vec2 lo, Vec2 hi) const {
  return sight(from, lo, hi, false) == Sight::seen;
}

Visibility::Sight Visibility::sight_box(const Place& from, Vec2 lo, Vec2 hi) const { return sight(from, lo, hi, true); }

Visibility::Sight Visibility::sight(const Place& from, Vec2 lo, Vec2 hi, bool hidden_too) const {
  const Vec2 o = from.at;
  const double bend = frame_ ? frame_->deviation() : 0.0;
  const double magnitude =
      std::max({std::abs(lo.x), std::abs(lo.y), std::abs(hi.x), std::abs(hi.y), std::abs(o.x), std::abs(o.y)});
  const double eps = 1e-9 * (1.0 + magnitude);
  Star built;
  const Star& s = start_star(from, built);
  bool in_wedge = true;
  if (s.rays.empty()) {
    if (!s.sea[0]) return Sight::hidden;
  } else {
    const int k = s.wedge_towards(Vec2{(lo.x + hi.x) / 2, (lo.y + hi.y) / 2}, true);
    // (A wedge's side is a geodesic from o: its image within `bend` of the line.)
    in_wedge = box_in_wedge(s, k, lo, hi, bend + eps);
    const bool open = s.sea[static_cast<size_t>(k)] && (from.wedge < 0 || k == from.wedge);
    if (in_wedge && !open) return Sight::hidden;
    if (!open) return Sight::unknown;
  }
  // (The paths' images and the edges' each within `bend` of their chords; vertices are exact.)
  const Hull h = hull_of(o, lo, hi);
  if (!hidden_too)
    return in_wedge && region_clear(h.p, h.n, 2.0 * bend + eps, bend + eps, &o) ? Sight::seen : Sight::unknown;
  std::vector<int32_t> near;
  if (region_clear(h.p, h.n, 2.0 * bend + eps, bend + eps, &o, &near) && in_wedge) return Sight::seen;
  return covers_box(o, lo, hi, near, 2.0 * bend + eps) ? Sight::hidden : Sight::unknown;
}

bool Visibility::covers_box(Vec2 o, Vec2 lo, Vec2 hi, const std::vector<int32_t>& near, double margin) const {
  const GeodesicFrame* f = frame_.get();
  const Vec2 corners[4] = {lo, {hi.x, lo.y}, hi, {lo.x, hi.y}};
  // Every corner strictly left (sign +1) or right (-1) of the line from o through r, by more
  // than m (a path's image bends by up to half the margin).
  auto beside = [&](Vec2 r, double sign, double m) {
    const double dx = r.x - o.x, dy = r.y - o.y, len = std::sqrt(dx * dx + dy * dy);
    for (const Vec2& c : corners)
      if (!(sign * (dx * (c.y - o.y) - dy * (c.x - o.x)) > m * len)) return false;
    return true;
  };
  // The edges whose line separates o from the box, each from its clockwise end to its
  // counter-clockwise end as o sees them.
  std::vector<std::pair<Vec2, Vec2>> spans;
  for (int32_t id : near) {
    if (id < 0) continue;
    const Edge& e = edges_[static_cast<size_t>(id)];
    Vec2 a = e.a, b = e.b;
    const double dx = b.x - a.x, dy = b.y - a.y, len = std::sqrt(dx * dx + dy * dy);
    const double so = dx * (o.y - a.y) - dy * (o.x - a.x);
    if (!(std::abs(so) > margin * len)) continue;
    const double sign = so > 0 ? -1.0 : 1.0;
    if (!std::all_of(corners, corners + 4,
                     [&](Vec2 c) { return sign * (dx * (c.y - a.y) - dy * (c.x - a.x)) > margin * len; }))
      continue;
    const int t = turn(f, o, a, b);
    if (t == 0) continue;
    if (t < 0) std::swap(a, b);
    spans.emplace_back(a, b);
  }
  const double m = margin / 2;
  // From an edge whose clockwise end is before the box, edge by edge while each next one starts
  // strictly before the coverage ends (or at its very vertex), until it reaches past the box.
  bool have = false;
  Vec2 end;
  for (const auto& [a, b] : spans)
    if (beside(a, 1.0, m) && (!have || turn(f, o, end, b) > 0)) {
      end = b;
      have = true;
    }
  for (size_t step = 0; have && step <= spans.size(); ++step) {
    if (beside(end, -1.0, m)) return true;
    Vec2 next = end;
    for (const auto& [a, b] : spans)
      if ((a == end || turn(f, o, a, end) > 0) && turn(f, o, next, b) > 0) next = b;
    if (next == end) return false;
    end = next;
  }
  return false;
}

bool Visibility::region_clear(const Vec2* poly, int n, double edge_margin, double vertex_margin, const Vec2* from,
                              std::vector<int32_t>* near) const {
  Hull h;
  h.n = n;
  std::copy(poly, poly + n, h.p);
  h.measure();
  bool clear = true;
  auto test = [&](const int32_t* edges, size_t ne, const int32_t* vertices, size_t nv) {
    for (size_t i = 0; i < ne; ++i) {
      const Edge& e = edges_[static_cast<size_t>(edges[i])];
      if (apart(h, e.a, e.b, edge_margin)) continue;
      if (from && (e.a == *from || e.b == *from)) continue;
      // An edge through `from` (a port on a coast): two of its rays, outside the wedge.
      if (from && turn(frame_.get(), e.a, e.b, *from) == 0 && strictly_between(e.a, e.b, *from)) continue;
      clear = false;
      if (!near) return false;
      near->push_back(edges[i]);
    }
    for (size_t i = 0; i < nv; ++i) {
      const Vec2 v = vertex(vertices[i]);
      if ((from && v == *from) || apart(h, v, v, vertex_margin)) continue;
      clear = false;
      if (!near) return false;
      near->push_back(-1 - vertices[i]);
    }
    return true;
  };
  if (index_) {
    index_->buckets.cover(poly, n, edge_margin, test);
    return clear;
  }
  std::vector<int32_t> all_edges(edges_.size()), all_vertices(stars_.size());
  for (size_t i = 0; i < all_edges.size(); ++i) all_edges[i] = static_cast<int32_t>(i);
  for (size_t i = 0; i < all_vertices.size(); ++i) all_vertices[i] = static_cast<int32_t>(i);
  test(all_edges.data(), all_edges.size(), all_vertices.data(), all_vertices.size());
  return clear;
}

}  // namespace rv
