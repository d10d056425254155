#include "sea/visible_region.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "rv/field/error.hpp"
#include "sea/orient.hpp"

namespace rv::sea {

namespace {

constexpr double kTurn = 2.0 * std::numbers::pi;
constexpr double kInf = std::numeric_limits<double>::infinity();

// A piece of barrier (or of the box's side) as the point sees it: ends `a` then `b`
// counter-clockwise, at angles t0 <= t1 from the wedge's first side.
struct Piece {
  Vec2 a, b;
  double t0, t1;
  bool split = false;  // the half from angle 0 of a piece across the first side
  bool side = false;   // a side of the box
};

// Angle of p seen from o, from `start` counter-clockwise, in [0, 2 pi).
double angle_from(double start, Vec2 o, Vec2 p) {
  double t = std::atan2(p.y - o.y, p.x - o.x) - start;
  while (t < 0.0) t += kTurn;
  while (t >= kTurn) t -= kTurn;
  return t;
}

// Where the ray from o in direction u meets the piece's line, kept on the piece: a ray along
// which the piece is nearly radial meets it, to rounding, at the end nearer the ray.
Vec2 meet(Vec2 o, Vec2 u, const Piece& p) {
  const double dx = p.b.x - p.a.x, dy = p.b.y - p.a.y;
  const double den = u.x * dy - u.y * dx;
  const double num = u.x * (o.y - p.a.y) - u.y * (o.x - p.a.x);
  double s = den != 0.0 ? num / den : 0.0;
  if (!std::isfinite(s)) s = 0.0;
  s = std::clamp(s, 0.0, 1.0);
  return Vec2{p.a.x + s * dx, p.a.y + s * dy};
}

double dist2(Vec2 a, Vec2 b) { return (a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y); }

double segment_distance(Vec2 x, Vec2 a, Vec2 b) {
  const double dx = b.x - a.x, dy = b.y - a.y, l2 = dx * dx + dy * dy;
  double t = l2 > 0.0 ? ((x.x - a.x) * dx + (x.y - a.y) * dy) / l2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::sqrt(dist2(x, Vec2{a.x + t * dx, a.y + t * dy}));
}

// The wedge `from` leaves in, as a first side's angle and a width in (0, 2 pi]; false when the
// wedge is land.
bool wedge_of(const Visibility& vis, const Visibility::Place& from, double& start, double& width) {
  start = 0.0;
  width = kTurn;
  if (from.vertex < 0 && from.open) return true;
  Visibility::Star built;
  const Visibility::Star& star = from.vertex >= 0 ? vis.vertex_star(from.vertex) : (built = vis.star_at(from.at));
  int w = from.wedge;
  if (w < 0) {
    if (star.wedges() != 1)
      throw Error(ErrorKind::invalid_argument, "visible_region: a point of several wedges needs one chosen");
    w = 0;
  }
  if (w >= star.wedges()) throw Error(ErrorKind::invalid_argument, "visible_region: no such wedge");
  if (!star.sea[static_cast<size_t>(w)]) return false;
  const size_t n = star.rays.size();
  if (n == 0) return true;
  start = std::atan2(star.rays[static_cast<size_t>(w)].y - star.at.y, star.rays[static_cast<size_t>(w)].x - star.at.x);
  if (n > 1) width = angle_from(start, star.at, star.rays[(static_cast<size_t>(w) + 1) % n]);
  if (width <= 0.0) width = kTurn;
  return true;
}

// The pieces the point sees round it: edges clipped to the box and the box's sides, split where
// they pass the wedge's first side; edges through the point itself left out (a path leaves
// along them or beside them, never across).
std::vector<Piece> pieces_round(Vec2 o, double start, Vec2 lo, Vec2 hi, const std::vector<EdgeIndex::Segment>& edges,
                                const std::vector<int32_t>* near, double margin, bool& blurred) {
  std::vector<Piece> out;
  auto add = [&](Vec2 a, Vec2 b) {
    if (a == o || b == o) return;
    const double cross = (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    if (cross == 0.0) return;  // radial, or through the point: blocks no open angle
    if (segment_distance(o, a, b) <= margin) blurred = true;
    if (!clip_to_box(a, b, lo, hi) || a == b) return;
    if (cross < 0.0) std::swap(a, b);
    double t0 = angle_from(start, o, a), t1 = angle_from(start, o, b);
    // A piece subtends less than a half-turn: the other way round means the sign of `cross`
    // and the angles disagree by rounding (a piece all but radial), and the angles decide. (The
    // way round from t0 to t1 taken without fmod(t1 - t0 + 2 pi, 2 pi): with t0 = 0 and t1 a
    // rounding below 2 pi, the sum rounded to 4 pi and the piece, all but radial along the
    // first side, was taken as spanning the whole turn.)
    const double way = t1 >= t0 ? t1 - t0 : t1 - t0 + kTurn;
    if (way > std::numbers::pi) {
      std::swap(a, b);
      std::swap(t0, t1);
    }
    if (t0 <= t1) {
      out.push_back(Piece{a, b, t0, t1});
    } else {  // across the first side: two pieces
      out.push_back(Piece{a, b, t0, kTurn});
      out.push_back(Piece{a, b, 0.0, t1, true});
    }
  };
  if (near) {
    for (const int32_t e : *near) add(edges[static_cast<size_t>(e)].a, edges[static_cast<size_t>(e)].b);
  } else {
    for (const auto& e : edges) add(e.a, e.b);
  }
  const size_t barriers = out.size();
  add(Vec2{lo.x, lo.y}, Vec2{hi.x, lo.y});
  add(Vec2{hi.x, lo.y}, Vec2{hi.x, hi.y});
  add(Vec2{hi.x, hi.y}, Vec2{lo.x, hi.y});
  add(Vec2{lo.x, hi.y}, Vec2{lo.x, lo.y});
  for (size_t i = barriers; i < out.size(); ++i) out[i].side = true;
  return out;
}

}  // namespace

bool clip_to_box(Vec2& a, Vec2& b, Vec2 lo, Vec2 hi) {
  double t0 = 0.0, t1 = 1.0;
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double p[4] = {-dx, dx, -dy, dy}, q[4] = {a.x - lo.x, hi.x - a.x, a.y - lo.y, hi.y - a.y};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0.0) {
      if (q[i] < 0.0) return false;
      continue;
    }
    const double r = q[i] / p[i];
    if (p[i] < 0.0)
      t0 = std::max(t0, r);
    else
      t1 = std::min(t1, r);
    if (t0 > t1) return false;
  }
  const Vec2 a0 = a;
  if (t1 < 1.0) b = Vec2{a0.x + t1 * dx, a0.y + t1 * dy};
  if (t0 > 0.0) a = Vec2{a0.x + t0 * dx, a0.y + t0 * dy};
  return true;
}

std::vector<EdgeIndex::Segment> barrier_edges(const Visibility& vis) {
  std::vector<EdgeIndex::Segment> raw;
  for (const auto& poly : vis.barriers().polygons())
    for (const Ring& r : poly.rings)
      for (size_t i = 0, n = r.size(); i < n; ++i) raw.push_back({r[i], r[(i + 1) % n]});
  for (const auto& line : vis.barriers().lines())
    for (size_t i = 0; i + 1 < line.vertices.size(); ++i) raw.push_back({line.vertices[i], line.vertices[i + 1]});
  // Overlapping polygons and lines across them cross each other's edges, and a vertex may lie
  // inside another's edge: each edge is cut there, so that the sweep's pieces meet only at ends.
  const EdgeIndex index(raw, {});
  std::vector<EdgeIndex::Segment> out;
  std::vector<int32_t> near, unused;
  std::vector<std::pair<double, Vec2>> cuts;  // (where along the edge, the point)
  for (size_t i = 0; i < raw.size(); ++i) {
    const Vec2 a = raw[i].a, b = raw[i].b;
    near.clear();
    index.along(a, b, near, unused);
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());
    cuts.clear();
    const double dx = b.x - a.x, dy = b.y - a.y, l2 = dx * dx + dy * dy;
    auto at = [&](Vec2 p) { return ((p.x - a.x) * dx + (p.y - a.y) * dy) / l2; };
    for (const int32_t j : near) {
      if (static_cast<size_t>(j) == i) continue;
      const Vec2 c = raw[static_cast<size_t>(j)].a, d = raw[static_cast<size_t>(j)].b;
      // Which side is which, by the exact predicate: a vertex on this edge is found as such.
      if (orient(a, b, c) * orient(a, b, d) < 0 && orient(c, d, a) * orient(c, d, b) < 0) {
        const double c3 = (d.x - c.x) * (a.y - c.y) - (d.y - c.y) * (a.x - c.x);
        const double c4 = (d.x - c.x) * (b.y - c.y) - (d.y - c.y) * (b.x - c.x);
        const double t = c3 / (c3 - c4);  // a proper crossing
        cuts.push_back({t, Vec2{a.x + t * dx, a.y + t * dy}});
        continue;
      }
      for (const Vec2 e : {c, d}) {  // the other's end inside this edge
        if (orient(a, b, e) != 0) continue;
        const double t = at(e);
        if (t > 0.0 && t < 1.0) cuts.push_back({t, e});  // (the end itself: a vertex stays one)
      }
    }
    std::sort(cuts.begin(), cuts.end(), [](const auto& p, const auto& q) { return p.first < q.first; });
    Vec2 from = a;
    for (const auto& [t, to] : cuts) {
      if (!(to == from)) out.push_back({from, to});
      from = to;
    }
    if (!(b == from)) out.push_back({from, b});
  }
  return out;
}

VisibleRegion visible_region(const Visibility& vis, const Visibility::Place& from, Vec2 lo, Vec2 hi,
                             const std::vector<EdgeIndex::Segment>& edges, const std::vector<int32_t>* near) {
  const Vec2 o = from.at;
  if (!(lo.x < o.x && o.x < hi.x && lo.y < o.y && o.y < hi.y))
    throw Error(ErrorKind::invalid_argument, "visible_region: the box must hold the point strictly inside");
  VisibleRegion region;
  region.from = o;
  // Rounding in the angles and the meeting points is a few units in the last place of the
  // coordinates; a billionth of their magnitude leaves room for it, as Visibility's box proofs do.
  const double magnitude =
      std::max({std::abs(lo.x), std::abs(lo.y), std::abs(hi.x), std::abs(hi.y), hi.x - lo.x, hi.y - lo.y});
  region.margin = 1e-9 * magnitude + (vis.frame() ? 2.0 * vis.frame()->deviation() + 1e-6 : 0.0);
  double start = 0.0, width = kTurn;
  if (!wedge_of(vis, from, start, width)) return region;

  std::vector<Piece> pieces = pieces_round(o, start, lo, hi, edges, near, region.margin, region.blurred);
  if (region.blurred) return region;  // (no ring: see the header)
  std::vector<double> angles{0.0, width};
  for (const Piece& p : pieces)
    for (const double t : {p.t0, p.t1})
      if (t > 0.0 && t < width) angles.push_back(t);
  std::sort(angles.begin(), angles.end());
  angles.erase(std::unique(angles.begin(), angles.end()), angles.end());
  std::sort(pieces.begin(), pieces.end(), [](const Piece& a, const Piece& b) { return a.t0 < b.t0; });

  auto ray = [&](double t) { return Vec2{std::cos(start + t), std::sin(start + t)}; };
  // (A corner met from both its pieces comes out twice, to rounding: kept once.)
  const double repeat2 = (1e-3 * region.margin) * (1e-3 * region.margin);
  auto push = [&](Vec2 p) {
    if (region.ring.empty() || dist2(region.ring.back(), p) > repeat2) region.ring.push_back(p);
  };
  auto same = [](const Piece* p, const Piece* q) { return p && q && p->a == q->a && p->b == q->b; };
  if (width < kTurn) push(o);
  // A ray along a critical angle may see past both intervals' pieces there (it grazes vertices
  // on both sides, or runs beside an edge along the wedge's side): a spike of no width, put in
  // the ring so that the points along it lie on its boundary, for the exact rule to decide. Where
  // the ray ends: the nearest piece across it, not one that ends on it (at angle 0, the second
  // half of a piece split there is across it).
  auto across = [](const Piece* p, double t) { return (p->t0 < t || (t == 0.0 && p->split)) && t < p->t1; };
  std::vector<const Piece*> active;
  // A piece met within the margin of one of its ends is taken as ending on the ray, whatever
  // the rounding of its angles says: a spike too many only hands points to the exact rule.
  const double margin2 = region.margin * region.margin;
  auto ray_end = [&](double t) {
    double best = kInf;
    for (const Piece* p : active) {
      if (!across(p, t)) continue;
      const Vec2 q = meet(o, ray(t), *p);
      if (p->side || std::min(dist2(q, p->a), dist2(q, p->b)) > margin2) best = std::min(best, dist2(o, q));
    }
    return best;
  };
  auto spike_point = [&](double t, double reach2) {
    const double r = std::sqrt(reach2);
    return Vec2{o.x + r * std::cos(start + t), o.y + r * std::sin(start + t)};
  };
  const Piece* first = nullptr;  // the first interval's piece, and the last one's
  const Piece* last = nullptr;
  bool spike_at_start = false;  // all round: the spike at angle 0, which closes the ring
  Vec2 start_spike{};
  size_t next = 0;
  for (size_t i = 0; i + 1 < angles.size(); ++i) {
    const double t0 = angles[i], t1 = angles[i + 1], mid = 0.5 * (t0 + t1);
    while (next < pieces.size() && pieces[next].t0 <= t0) active.push_back(&pieces[next++]);
    // (pieces that end at or before t0 leave; none of the others can start after t0 and before t1)
    std::erase_if(active, [&](const Piece* p) { return p->t1 <= t0; });
    const Vec2 u = ray(mid);
    const Piece* nearest = nullptr;
    double best = kInf;
    for (const Piece* p : active) {
      if (!(p->t0 < mid && mid < p->t1)) continue;
      const double d = dist2(o, meet(o, u, *p));
      if (d < best) {
        best = d;
        nearest = p;
      }
    }
    if (!nearest) continue;  // (only where rounding leaves a sliver of angle without a piece)
    // Consecutive intervals on one piece: its point between them is no corner of the ring (and
    // the ray between them ends on it: no spike).
    if (same(nearest, last)) {
      region.ring.back() = meet(o, ray(t1), *nearest);
    } else {
      const Vec2 begin = meet(o, ray(t0), *nearest);
      const double reach = ray_end(t0);
      const double before = region.ring.empty() ? 0.0 : dist2(o, region.ring.back());
      if (std::isfinite(reach) && reach > std::max(before, dist2(o, begin)) + repeat2) {
        if (i == 0 && width >= kTurn) {
          spike_at_start = true;
          start_spike = spike_point(t0, reach);
        } else {
          push(spike_point(t0, reach));
        }
      }
      push(begin);
      region.ring.push_back(meet(o, ray(t1), *nearest));  // (always: the next interval on this piece moves it)
    }
    if (!first) first = nearest;
    last = nearest;
  }
  if (width < kTurn) {
    // The wedge's last side: its spike, then back to the point (the ring's first vertex).
    const double reach = ray_end(width);
    if (std::isfinite(reach) && !region.ring.empty() && reach > dist2(o, region.ring.back()) + repeat2)
      push(spike_point(width, reach));
  } else if (spike_at_start) {
    push(start_spike);
  } else if (same(first, last) && region.ring.size() > 3) {
    // All round, the first and last intervals on one piece (the sweep began inside it): the two
    // points where it began and ended are no corners either.
    region.ring.erase(region.ring.begin());
    region.ring.pop_back();
  }
  return region;
}

bool VisibleRegion::contains(Vec2 x) const {
  bool in = false;
  for (size_t i = 0, n = ring.size(), j = n - 1; i < n; j = i++) {
    const Vec2 a = ring[i], b = ring[j];
    if ((a.y > x.y) != (b.y > x.y) && x.x < (b.x - a.x) * (x.y - a.y) / (b.y - a.y) + a.x) in = !in;
  }
  return in;
}

double VisibleRegion::boundary_distance(Vec2 x) const {
  double best = kInf;
  for (size_t i = 0, n = ring.size(), j = n - 1; i < n; j = i++)
    best = std::min(best, segment_distance(x, ring[j], ring[i]));
  return best;
}

}  // namespace rv::sea
