// end_at_owned_edge and end_at_barriers (boundary_stages.hpp): boundary lines carried to where the
// owned area ends, and onto the barriers they meet by sea.
//
// Why: the crossings of two owners' cells stop at the last pair of cells both own, up to a cell
// short of the edge of the owned area; a boundary's end there (in delimitation, a terminus on
// the 200 nmi limit) is a point of law, so it is solved exactly. Where unowned sea thinner than a
// cell pokes between the last two cells, their crossing lies on one owner's arc with the other
// out of reach: not on the boundary, so it is dropped.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/Gnomonic.hpp>

#include "lines/boundary_stages.hpp"
#include "lines/line_tools.hpp"
#include "lines/locus_follow.hpp"
#include "rv/field/parallel.hpp"

namespace rv::boundary_stages {

using namespace line_tools;

namespace {

// A line's end at p with the two owners' hits there (residual and arc left to the caller).
BoundaryVertex junction(Vec2 p, const OwnerIndex::Hit& a, const OwnerIndex::Hit& b) {
  BoundaryVertex v;
  v.p = p;
  v.site_a = a.site;
  v.site_b = b.site;
  v.distance_a = a.distance;
  v.distance_b = b.distance;
  v.distance = 0.5 * (a.distance + b.distance);
  return v;
}

// How far beyond its reach an owner is at p (<= 0 where it counts).
struct Beyond {
  const OwnerIndex& index;
  double D;
  bool adjusted;
  OwnerIndex::Hit hit(Vec2 p, int32_t owner) const {
    return adjusted ? index.deepest(p, owner) : index.nearest_of(p, owner);
  }
  double of(Vec2 p, int32_t owner) const {
    const OwnerIndex::Hit h = hit(p, owner);
    return adjusted ? h.cost : h.distance - D;
  }
};

// Carries the back end of `line` (see the contract); true when it moved.
bool carry_back(const BoundaryGrid& b, const Beyond& beyond, const std::vector<Tripoint>& tripoints,
                BoundaryLine& line) {
  std::vector<BoundaryVertex>& v = line.vertices;
  const Vec2 end = v.back().p;
  if (on_centre_frame(b.g, end)) return false;
  const int32_t oa = line.owner_a, ob = line.owner_b;
  auto outside = [&](Vec2 p) { return std::max(beyond.of(p, oa), beyond.of(p, ob)) > b.ftol; };
  if (at_tripoint(tripoints, end) && !outside(end)) return false;
  auto f = [&](Vec2 p) { return std::array<double, 2>{beyond.of(p, oa), beyond.of(p, ob)}; };
  Vec2 j;
  if (!solve2(f, end, b.g.res, b.ftol, j)) return false;
  // On the edge only where no third owner counts there (else it lies inside the owned area,
  // where another line of these owners' goes on).
  const OwnerIndex::Hit any = beyond.adjusted ? beyond.index.deepest(j) : beyond.index.nearest(j);
  if ((beyond.adjusted ? any.cost : any.distance - beyond.D) < -b.ftol) return false;
  const std::vector<BoundaryVertex> kept = v;
  while (v.size() > 1 && outside(v.back().p)) v.pop_back();
  if (outside(v.back().p)) {  // nothing of the line in reach: not an end of this kind
    v = kept;
    return false;
  }
  if (v.back().p.x == j.x && v.back().p.y == j.y) return true;
  BoundaryVertex jv = junction(j, beyond.hit(j, oa), beyond.hit(j, ob));
  const std::array<double, 2> r = f(j);
  jv.residual = std::max(std::abs(r[0]), std::abs(r[1]));
  jv.arc = v.back().arc;
  v.push_back(jv);
  return true;
}

}  // namespace

void end_at_owned_edge(const BoundaryGrid& b, double max_distance, const std::vector<Tripoint>& tripoints,
                       std::vector<BoundaryLine>& lines, BoundaryStats& stats) {
  const Beyond beyond{b.index, max_distance, b.index.adjusted()};
  // Only where reaches (or the cap with weights) end the owned area: with a plain max distance
  // the ends stay at the last crossing, which region_edges joins to the max-distance line (in
  // dense sets carrying them first left more ends in the open there).
  if (!beyond.adjusted) return;
  // Ends in the open near another: lines that meet in a hole of unowned sea thinner than a cell,
  // or at a tripoint no square resolved. The edge there is not the one extraction stopped at
  // (region_edges joins such ends); only a lone end is carried.
  std::vector<Vec2> open;
  for (const BoundaryLine& line : lines)
    if (!line.closed && !line.vertices.empty())
      for (const Vec2 p : {line.vertices.front().p, line.vertices.back().p})
        if (!on_centre_frame(b.g, p) && !at_tripoint(tripoints, p)) open.push_back(p);
  std::sort(open.begin(), open.end(), [](Vec2 u, Vec2 v) { return u.x < v.x || (u.x == v.x && u.y < v.y); });
  auto crowded = [&](Vec2 p) {
    const double r = 2.0 * b.g.res;
    auto it = std::lower_bound(open.begin(), open.end(), Vec2{p.x - r, -std::numeric_limits<double>::infinity()},
                               [](Vec2 u, Vec2 v) { return u.x < v.x || (u.x == v.x && u.y < v.y); });
    for (; it != open.end() && it->x <= p.x + r; ++it)
      if (!(*it == p) && std::hypot(it->x - p.x, it->y - p.y) <= r) return true;
    return false;
  };
  for (BoundaryLine& line : lines) {
    if (line.closed || line.vertices.empty()) continue;
    for (int end = 0; end < 2; ++end) {
      if (end == 1) std::reverse(line.vertices.begin(), line.vertices.end());
      if (crowded(line.vertices.back().p)) {
        if (end == 1) std::reverse(line.vertices.begin(), line.vertices.end());
        continue;
      }
      const auto before = static_cast<int64_t>(line.vertices.size());
      if (carry_back(b, beyond, tripoints, line)) {
        stats.vertices += static_cast<int64_t>(line.vertices.size()) - before;
        ++stats.ends_on_owned_edge;
        stats.max_residual = std::max(stats.max_residual, line.vertices.back().residual);
      }
      if (end == 1) std::reverse(line.vertices.begin(), line.vertices.end());
    }
  }
}

namespace {

// Where the locus of owners oa and ob, from `from` (a point of it at sea), meets a barrier edge
// within `radius` CRS units: the nearest such point, no third owner nearer, seen from `from`; with
// `away`, on the far side of `from` from it.
bool coast_junction(const BoundaryGrid& b, int32_t oa, int32_t ob, Vec2 from, double radius, const Vec2* away,
                    Vec2& j) {
  auto f = [&](Vec2 p) { return cost_gap(b, oa, ob, p); };
  auto accept = [&](Vec2 p) {
    OwnerIndex::Hit ha, hb;
    return on_pair_locus(b, oa, ob, p, ha, hb);
  };
  return onto_domain_edge(b.index.metric(), from, radius, b.ftol, f, accept, j, away, 2.0 * b.index.cost_slope());
}

// The line's vertex at junction j on a barrier.
BoundaryVertex on_barrier_at(const BoundaryGrid& b, int32_t oa, int32_t ob, Vec2 j) {
  const OwnerIndex::Hit ha = b.index.nearest_of(j, oa), hb = b.index.nearest_of(j, ob);
  BoundaryVertex jv = junction(j, ha, hb);
  jv.residual = std::abs(ha.cost - hb.cost);
  jv.on_barrier = true;
  return jv;
}

// The junction of the back end of `line` with a barrier edge near it (see end_at_barriers); with
// `away`, on the far side of the end from it.
bool onto_barrier(const BoundaryGrid& b, BoundaryLine& line, const Vec2* away = nullptr) {
  Vec2 j;
  if (!coast_junction(b, line.owner_a, line.owner_b, line.vertices.back().p, 4.0 * b.g.res, away, j)) return false;
  line.vertices.push_back(on_barrier_at(b, line.owner_a, line.owner_b, j));
  return true;
}

// Whether the way back from the end of `v` to q runs along the line itself: q, or the middle of
// the chord from the end to it, within `near` of one of its chords (q then lies on the line's own
// stretch of the locus, at or beyond its other end).
bool back_along_itself(const std::vector<BoundaryVertex>& v, Vec2 q, double near) {
  const Vec2 mid = lerp(v.back().p, q, 0.5);
  for (size_t k = 0; k + 1 < v.size(); ++k)
    for (const Vec2 x : {q, mid})
      if (segment_distance(x, v[k].p, v[k + 1].p) <= near) return true;
  return false;
}

// Whether the back end of `line`, just carried onto a barrier (its last vertex), turned back to get
// there: the junction lies behind the end, seen along the line's last chord before it.
bool turned_back(const std::vector<BoundaryVertex>& v) {
  if (v.size() < 3) return false;
  const Vec2 j = v.back().p, e = v[v.size() - 2].p, q = v[v.size() - 3].p;
  return (j.x - e.x) * (e.x - q.x) + (j.y - e.y) * (e.y - q.y) < 0.0;
}

}  // namespace

bool along_locus(const BoundaryGrid& b, int32_t oa, int32_t ob, Vec2 p, Vec2 q) {
  constexpr int kSamples = 16;
  const double apart = 0.1 * b.index.metric().point_distance(p, q);
  for (int k = 1; k < kSamples; ++k) {
    OwnerIndex::Hit ha, hb;
    if (!no_third_between(b, oa, ob, lerp(p, q, static_cast<double>(k) / kSamples), ha, hb) ||
        !(std::abs(ha.cost - hb.cost) <= apart))
      return false;
  }
  return true;
}

bool walk_runs_along(const BoundaryGrid& b, const std::vector<BoundaryLine>& lines, const std::vector<Vec2>& points,
                     int32_t oa, int32_t ob, int64_t own) {
  const double near = 2e-2 * b.g.res;
  // (A walk can be thousands of steps and a line thousands of vertices: only the segments that
  // come within `near` of the walk's bounds are measured.)
  Bounds walked;
  for (size_t k = 2; k + 2 < points.size(); ++k) walked.add(points[k]);
  for (size_t n = 0; n < lines.size(); ++n) {
    const BoundaryLine& l = lines[n];
    if (static_cast<int64_t>(n) == own || l.owner_a != oa || l.owner_b != ob) continue;
    for (size_t s = 0; s + 1 < l.vertices.size(); ++s) {
      const Vec2 u = l.vertices[s].p, w = l.vertices[s + 1].p;
      Bounds segment;
      segment.add(u);
      segment.add(w);
      if (!segment.meets(walked, near)) continue;
      for (size_t k = 2; k + 2 < points.size(); ++k)
        if (segment_distance(points[k], u, w) <= near) return true;
    }
  }
  return false;
}

// The level of the locus of `line`'s two owners, for the follower: their balance, and the band
// where no third owner is nearer.
locus_follow::Level pair_level(const BoundaryGrid& b, int32_t oa, int32_t ob) {
  locus_follow::Level level;
  level.balance = [&b, oa, ob](Vec2 p) { return cost_gap(b, oa, ob, p); };
  level.in_band = [&b, oa, ob](Vec2 p) {
    OwnerIndex::Hit ha, hb;
    return no_third_between(b, oa, ob, p, ha, hb);
  };
  level.metric = &b.index.metric();
  level.grid = b.g;
  level.ftol = b.ftol;
  level.slope = 2.0 * b.index.cost_slope();
  return level;
}

// Appends the points walked along the locus of `line`'s owners (points[0], the line's back end,
// left out) as its vertices.
void append_walked(const BoundaryGrid& b, BoundaryLine& line, const std::vector<Vec2>& points) {
  std::vector<BoundaryVertex>& v = line.vertices;
  const int32_t oa = line.owner_a, ob = line.owner_b;
  for (size_t k = 1; k < points.size(); ++k) {
    const Vec2 p = points[k];
    BoundaryVertex w = vertex_between(p, b.index.nearest_of(p, oa), b.index.nearest_of(p, ob));
    // Where one side's nearest site changes between two points walked the locus turns, at times
    // sharply (a tip, where the walk rounds the corner on a small circle): the turning point of
    // the three sites is put between them, where the walk has the sites at hand (the refinement
    // would look for it beyond the chord only once nothing nearer checks out).
    const BoundaryVertex& u = v.back();
    const bool a_changes = u.site_a != w.site_a, b_changes = u.site_b != w.site_b;
    Vec2 t;
    if (a_changes != b_changes &&
        equal_costs_point(b.index, a_changes ? u.site_a : u.site_b, a_changes ? w.site_a : w.site_b,
                          a_changes ? u.site_b : u.site_a, lerp(u.p, p, 0.5),
                          2.0 * std::hypot(p.x - u.p.x, p.y - u.p.y), b.ftol, t) &&
        b.index.metric().open_between(u.p, t) && b.index.metric().open_between(t, p)) {
      OwnerIndex::Hit ha, hb;
      if (no_third_between(b, oa, ob, t, ha, hb) && std::abs(ha.cost - hb.cost) <= 4.0 * b.ftol)
        v.push_back(vertex_between(t, ha, hb));
    }
    v.push_back(w);
  }
}

namespace {

// How far the ends are followed: an eighth of a cell a step, over at most eight cells.
constexpr int kPerCell = 8, kCells = 8;

// Where the geodesics a0-a1 and b0-b1 (longitude, latitude in degrees, on the ellipsoid of
// `metric`) cross, from `near` (their chords' crossing in longitude and latitude, millimetres off
// it on Usedom, where edges of a kilometre or more cross at a small angle): the crossing of their
// images in an ellipsoidal gnomonic projection centred at the last estimate (straight lines on a
// sphere, all but straight near the centre on the ellipsoid), three rounds.
Vec2 geodesics_meet(const MetricSpec& metric, Vec2 a0, Vec2 a1, Vec2 b0, Vec2 b1, Vec2 near) {
  const GeographicLib::Geodesic earth(metric.semi_major, metric.flattening);
  const GeographicLib::Gnomonic gnomonic(earth);
  const Vec2 ends[4] = {a0, a1, b0, b1};
  Vec2 x = near;
  for (int round = 0; round < 3; ++round) {
    Vec2 q[4];
    for (int k = 0; k < 4; ++k) gnomonic.Forward(x.y, x.x, ends[k].y, ends[k].x, q[k].x, q[k].y);
    double s = 0.0, t = 0.0;
    if (!lines_meet(q[0], Vec2{q[1].x - q[0].x, q[1].y - q[0].y}, q[2], Vec2{q[3].x - q[2].x, q[3].y - q[2].y}, s, t))
      return x;
    double lat = 0.0, lon = 0.0;
    gnomonic.Reverse(x.y, x.x, q[0].x + s * (q[1].x - q[0].x), q[0].y + s * (q[1].y - q[0].y), lat, lon);
    if (!std::isfinite(lat) || !std::isfinite(lon)) return x;
    x = Vec2{lon, lat};
  }
  return x;
}

// The back end of `line` followed on along its locus to the coast (see end_at_barriers), in steps
// of an eighth of a cell over at most eight cells; true (the points walked appended, the last on
// the barrier) where it gets there. `coast` (or null): a point of the coast on the locus, which
// the walk may pass where the locus only touches the coast between two steps (passing within a
// step and a half of it ends the walk there, as on the coast). `ends`: open ends of other lines of
// the same owners (reaching one of those, false: the two are to be joined). `elsewhere`
// (optional): whether the walk stopped where a third owner came nearer, or at one of those ends.
bool follow_to_barrier(const BoundaryGrid& b, BoundaryLine& line, const Vec2* coast, const std::vector<Vec2>& ends,
                       bool* elsewhere = nullptr) {
  std::vector<BoundaryVertex>& v = line.vertices;
  if (v.size() < 2) return false;
  const locus_follow::Level level = pair_level(b, line.owner_a, line.owner_b);
  const Vec2 end = v.back().p, before = v[v.size() - 2].p;
  std::vector<Vec2> stops;
  if (coast) stops.push_back(*coast);
  stops.insert(stops.end(), ends.begin(), ends.end());
  const int first_end = coast ? 1 : 0;
  const locus_follow::Followed f = locus_follow::follow_on(level, end, Vec2{end.x - before.x, end.y - before.y},
                                                           b.g.res / kPerCell, kPerCell * kCells, stops);
  if (elsewhere) *elsewhere = f.left_band || (f.stop == locus_follow::Stop::target && f.other >= first_end);
  if (!(f.stop == locus_follow::Stop::coast || (coast && f.stop == locus_follow::Stop::target && f.other == 0)) ||
      f.points.size() < 2)
    return false;
  append_walked(b, line, f.points);
  v.back().on_barrier = true;
  return true;
}

// Where the stretches of a line by sea at consecutive vertices v[i] and v[i + 1] (one side's site
// changes between them) would turn on land: their tangents (from the neighbouring vertices) meet
// on land within four cells; j1 and j2 are each stretch's junction with the coast ahead.
bool turned_on_land(const BoundaryGrid& b, const BoundaryLine& line, size_t i, Vec2& j1, Vec2& j2) {
  const std::vector<BoundaryVertex>& v = line.vertices;
  const BoundaryVertex &u = v[i], &w = v[i + 1];
  const Vec2 d1{u.p.x - v[i - 1].p.x, u.p.y - v[i - 1].p.y}, d2{w.p.x - v[i + 2].p.x, w.p.y - v[i + 2].p.y};
  double s, t;
  if (!lines_meet(u.p, d1, w.p, d2, s, t) || !(s > 0.0) || !(t > 0.0)) return false;
  const Vec2 turn{u.p.x + s * d1.x, u.p.y + s * d1.y};
  const double reach =
      1.5 * std::max(std::hypot(turn.x - u.p.x, turn.y - u.p.y), std::hypot(turn.x - w.p.x, turn.y - w.p.y));
  if (b.index.metric().in_domain(turn) || !(reach <= 4.0 * b.g.res)) return false;
  const Vec2 back1 = v[i - 1].p, back2 = v[i + 2].p;
  return coast_junction(b, line.owner_a, line.owner_b, u.p, reach, &back1, j1) &&
         coast_junction(b, line.owner_a, line.owner_b, w.p, reach, &back2, j2) &&
         std::hypot(j2.x - j1.x, j2.y - j1.y) > 1e-6 * b.g.res;
}

// Where the locus from consecutive vertices v[i] and v[i + 1] of a line by sea meets a coast
// before it gets from one to the other: the cells linked two stretches that end on a coast (one
// owner's sea touching the coast between them, round an island's corner). Followed from each
// vertex towards the other (locus_follow::follow_on, an eighth of a cell a step, over twice the
// chord), both walks reach a coast without meeting the other vertex; j1 and j2 are where. Asked
// only where a barrier edge lies within the chord of its middle, and the chord crosses one (a
// straight bisector through an islet: the locus is at sea, the chord across land) or the locus
// is off the chord's middle by over a twentieth of the chord, or the middle is on land.
bool coast_between(const BoundaryGrid& b, const BoundaryLine& line, size_t i, Vec2& j1, Vec2& j2) {
  const SiteMetric& m = b.index.metric();
  const Vec2 u = line.vertices[i].p, w = line.vertices[i + 1].p;
  const double chord = std::hypot(w.x - u.x, w.y - u.y);
  const Vec2 mid = lerp(u, w, 0.5);
  std::vector<int32_t> edges;
  m.domain_edges_near(mid, chord, edges);
  if (edges.empty()) return false;
  if (m.open_between(u, w)) {
    const double gap = cost_gap(b, line.owner_a, line.owner_b, mid);
    if (std::isfinite(gap) && !(std::abs(gap) > 0.1 * b.index.cost_slope() * m.point_distance(u, w))) return false;
  }
  const locus_follow::Level level = pair_level(b, line.owner_a, line.owner_b);
  const double step = b.g.res / kPerCell;
  const auto steps = static_cast<int64_t>(std::min(kPerCell * kCells * 1.0, std::ceil(2.0 * chord / step) + 1.0));
  // A walk that loses the level by a coast (the locus meets it beside a corner of the coast, and
  // the step goes past the corner: the last point is off the locus) ends at the junction within
  // three steps of its last point on the locus, ahead of it.
  auto to_coast = [&](Vec2 from, Vec2 other, Vec2& j) {
    // A vertex on a coast's edge with land towards the other (a crossing between two cells whose
    // centres lie on the coast, the way between them along it): the coast is the vertex itself.
    // The least step towards the other crosses land there; any step from a point at sea would
    // have to be shorter than a billionth of the chord to do so.
    j = from;
    if (!m.open_between(from, lerp(from, other, 1e-9))) return true;
    const locus_follow::Followed f =
        locus_follow::follow_on(level, from, Vec2{other.x - from.x, other.y - from.y}, step, steps, {other});
    const size_t n = f.points.size();
    j = f.points.back();
    if (f.stop == locus_follow::Stop::coast) return true;
    const double off = cost_gap(b, line.owner_a, line.owner_b, f.points.back());
    if (f.stop != locus_follow::Stop::lost || n < 2 || (std::isfinite(off) && std::abs(off) <= 4.0 * b.ftol))
      return false;
    const Vec2 behind = n > 2 ? f.points[n - 3] : from;
    return coast_junction(b, line.owner_a, line.owner_b, f.points[n - 2], 3.0 * step, &behind, j);
  };
  return to_coast(u, w, j1) && to_coast(w, u, j2) && std::hypot(j2.x - j1.x, j2.y - j1.y) > 1e-6 * b.g.res;
}

}  // namespace

void end_at_barriers(const BoundaryGrid& b, const std::vector<Tripoint>& tripoints, std::vector<BoundaryLine>& lines,
                     BoundaryStats& stats) {
  for (BoundaryLine& line : lines) {
    if (line.closed || line.vertices.empty()) continue;
    for (int end = 0; end < 2; ++end) {
      if (end == 1) std::reverse(line.vertices.begin(), line.vertices.end());
      const Vec2 p = line.vertices.back().p;
      if (!on_centre_frame(b.g, p) && !at_tripoint(tripoints, p) && onto_barrier(b, line)) {
        // A junction behind the end is another stretch's: the line there goes on where its cells
        // do not show it (round an islet in a channel narrower than a cell). So may be one more
        // than a cell off: its chord from the end leaves the locus (along_locus), and the end's
        // locus may go on to a third owner where the cells do not show it (complete_tripoints
        // finds the tripoint); or an open end of another line of the same owners lies nearer (the
        // line passes a coast closer than a cell there: join_parted_ends joins the two). Either is
        // followed on along the locus instead. Where the follower reaches no coast, the junction
        // behind is kept, unless the walk met a third owner (the locus goes on from the end to a
        // tripoint: complete_tripoints walks the end there) or another open end of the same
        // owners (follow_open_ends joins the two), or the way back to the junction runs along the
        // line itself (the junction is its own stretch's, at or beyond its other end); the one far
        // off is dropped and the end left open, as where the walk meets the other line's end.
        const BoundaryVertex junction = line.vertices.back();
        const double reach = std::hypot(junction.p.x - p.x, junction.p.y - p.y);
        const bool far = reach > b.g.res, behind = turned_back(line.vertices);
        std::vector<Vec2> ends;
        bool doubt = false;
        // (The other open ends matter only to an end that is followed: one far off or behind.)
        if (far || behind)
          for (const BoundaryLine& o : lines)
            if (&o != &line && !o.closed && !o.vertices.empty() && o.owner_a == line.owner_a &&
                o.owner_b == line.owner_b)
              for (const BoundaryVertex* e : {&o.vertices.front(), &o.vertices.back()})
                if (open_line_end(b, tripoints, *e)) {
                  ends.push_back(e->p);
                  doubt = doubt || (far && std::hypot(e->p.x - p.x, e->p.y - p.y) < reach);
                }
        doubt = doubt || (far && !along_locus(b, line.owner_a, line.owner_b, p, junction.p));
        if (doubt || behind) {
          line.vertices.pop_back();
          const auto before = static_cast<int64_t>(line.vertices.size());
          bool elsewhere = false;
          // (The junction is a stop of the walk only where it is in doubt: one just behind the end
          // is passed on the first step, and is not the coast the locus goes on to.)
          if (follow_to_barrier(b, line, doubt ? &junction.p : nullptr, ends, &elsewhere)) {
            stats.vertices += static_cast<int64_t>(line.vertices.size()) - before - 1;
            ++stats.ends_followed;
          } else if (!doubt && !elsewhere && !back_along_itself(line.vertices, junction.p, 0.1 * b.g.res)) {
            line.vertices.push_back(junction);
          } else {
            if (end == 1) std::reverse(line.vertices.begin(), line.vertices.end());
            continue;
          }
        }
        ++stats.vertices;
        ++stats.ends_on_barriers;
        stats.max_residual = std::max(stats.max_residual, line.vertices.back().residual);
      }
      if (end == 1) std::reverse(line.vertices.begin(), line.vertices.end());
    }
  }
}

void part_where_turning_on_land(const BoundaryGrid& b, std::vector<BoundaryLine>& lines, BoundaryStats& stats) {
  const SiteMetric& m = b.index.metric();
  if (m.straight()) return;
  // The walks along the locus first, every chord of every line at once on the threads (each
  // chord's answer depends on its two vertices alone, and a parting keeps the vertices before it).
  struct Cut {
    size_t line = 0, i = 0;
    bool found = false;
    Vec2 j1, j2;
  };
  std::vector<Cut> cuts;
  std::vector<size_t> first(lines.size(), 0);  // line n's chord i: cuts[first[n] + i]
  for (size_t n = 0; n < lines.size(); ++n) {
    first[n] = cuts.size();
    if (!lines[n].closed)
      for (size_t i = 0; i + 1 < lines[n].vertices.size(); ++i) cuts.push_back(Cut{n, i, false, {}, {}});
  }
  detail::parallel_for(b.threads, static_cast<int64_t>(cuts.size()), [&](int64_t k, int) {
    Cut& c = cuts[static_cast<size_t>(k)];
    const std::vector<BoundaryVertex>& v = lines[c.line].vertices;
    if (!v[c.i].on_barrier && !v[c.i + 1].on_barrier) c.found = coast_between(b, lines[c.line], c.i, c.j1, c.j2);
  });
  std::vector<BoundaryLine> parts;
  for (size_t n = 0; n < lines.size(); ++n) {
    BoundaryLine& line = lines[n];
    std::vector<BoundaryVertex>& v = line.vertices;
    if (line.closed || v.size() < 2) continue;
    const int32_t oa = line.owner_a, ob = line.owner_b;
    // From the back: each part split off is the line's tail, the rest scanned on.
    for (size_t i = v.size() - 1; i-- > 0;) {
      const BoundaryVertex &u = v[i], &w = v[i + 1];
      if (u.on_barrier || w.on_barrier) continue;
      Vec2 j1, j2;
      // (The tangents need a vertex either side.)
      const bool turns = i >= 1 && i + 2 < v.size() && !(u.site_a == w.site_a && u.site_b == w.site_b) &&
                         turned_on_land(b, line, i, j1, j2);
      if (!turns) {
        const Cut& walked = cuts[first[n] + i];
        if (!walked.found) continue;
        j1 = walked.j1;
        j2 = walked.j2;
      }
      // (A junction at the vertex itself, on the coast already, takes its place.)
      const bool at_u = j1.x == u.p.x && j1.y == u.p.y, at_w = j2.x == w.p.x && j2.y == w.p.y;
      BoundaryLine tail;
      tail.owner_a = line.owner_a;
      tail.owner_b = line.owner_b;
      tail.vertices.push_back(on_barrier_at(b, oa, ob, j2));
      tail.vertices.insert(tail.vertices.end(), v.begin() + static_cast<std::ptrdiff_t>(i + (at_w ? 2 : 1)), v.end());
      v.resize(at_u ? i : i + 1);
      v.push_back(on_barrier_at(b, oa, ob, j1));
      stats.max_residual = std::max({stats.max_residual, v.back().residual, tail.vertices.front().residual});
      line.bows.clear();
      parts.push_back(std::move(tail));
      stats.vertices += (at_u ? 0 : 1) + (at_w ? 0 : 1);
      stats.ends_on_barriers += 2;
      ++stats.turns_on_land;
    }
  }
  for (BoundaryLine& part : parts) lines.push_back(std::move(part));
}

void cross_channels(const BoundaryGrid& b, std::vector<BoundaryLine>& lone, std::vector<BoundaryLine>& lines,
                    BoundaryStats& stats) {
  if (b.index.metric().straight()) return;
  std::vector<BoundaryLine> left;
  for (BoundaryLine& line : lone) {
    if (line.vertices.size() == 1 && onto_barrier(b, line)) {
      const Vec2 first = line.vertices.back().p;
      std::reverse(line.vertices.begin(), line.vertices.end());
      if (onto_barrier(b, line, &first)) {
        for (size_t k : {size_t{0}, size_t{2}}) {
          ++stats.vertices;
          ++stats.ends_on_barriers;
          stats.max_residual = std::max(stats.max_residual, line.vertices[k].residual);
        }
        lines.push_back(std::move(line));
        continue;
      }
      line.vertices.erase(line.vertices.begin());  // (only one side: left as it was)
    }
    left.push_back(std::move(line));
  }
  lone = std::move(left);
}

namespace {

// Whether the locus of owners oa and ob passes between p and q: the two owners' costs of opposite
// signs across the chord's middle, on the chord's perpendicular there, at a sixteenth, an eighth, a
// quarter or half the chord's length either side, as far as the way is open from the middle (an
// islet beside the chord, or land on one side, leaves the nearer points to tell).
bool locus_between(const BoundaryGrid& b, int32_t oa, int32_t ob, Vec2 p, Vec2 q) {
  const SiteMetric& metric = b.index.metric();
  const Vec2 mid = lerp(p, q, 0.5), across{-(q.y - p.y) * 0.5, (q.x - p.x) * 0.5};
  const double fm = cost_gap(b, oa, ob, mid);
  if (fm == 0.0) return true;
  if (!std::isfinite(fm)) return false;
  for (const double side : {-1.0, 1.0})
    for (const double t : {0.125, 0.25, 0.5, 1.0}) {
      const Vec2 x{mid.x + side * t * across.x, mid.y + side * t * across.y};
      const double fx = cost_gap(b, oa, ob, x);
      if (!std::isfinite(fx) || !metric.open_between(mid, x)) break;
      if ((fx < 0.0) != (fm < 0.0)) return true;
    }
  return false;
}

}  // namespace

void join_parted_ends(const BoundaryGrid& b, double per, const std::vector<Tripoint>& tripoints,
                      std::vector<BoundaryLine>& lines, BoundaryStats& stats) {
  const SiteMetric& metric = b.index.metric();
  if (metric.straight()) return;
  // The open ends left: (line, which end), neither on the frame, at a tripoint nor on a barrier.
  struct End {
    size_t line;
    bool back;
    Vec2 p;
  };
  std::vector<End> ends;
  for (size_t n = 0; n < lines.size(); ++n) {
    const BoundaryLine& l = lines[n];
    if (l.closed || l.vertices.empty()) continue;
    for (const bool back : {false, true}) {
      const BoundaryVertex& v = back ? l.vertices.back() : l.vertices.front();
      if (!v.on_barrier && !at_tripoint(tripoints, v.p) && !on_centre_frame(b.g, v.p))
        ends.push_back(End{n, back, v.p});
    }
  }
  // Pairs of the same two owners within four cells, the way between them open, and the locus
  // passing between them (the two owners' costs of opposite signs across the chord's middle).
  std::vector<NearPair> pairs;
  for (size_t i = 0; i < ends.size(); ++i)
    for (size_t j = i + 1; j < ends.size(); ++j) {
      const BoundaryLine &li = lines[ends[i].line], &lj = lines[ends[j].line];
      if (li.owner_a != lj.owner_a || li.owner_b != lj.owner_b) continue;
      if (ends[i].line == ends[j].line && li.vertices.size() < 3) continue;
      const Vec2 p = ends[i].p, q = ends[j].p;
      const double d = std::hypot(q.x - p.x, q.y - p.y);
      if (!(d <= 4.0 * b.g.res) || !metric.open_between(p, q)) continue;
      if (locus_between(b, li.owner_a, li.owner_b, p, q)) pairs.push_back(NearPair{d, i, j});
    }
  sort_nearest_first(pairs);
  std::vector<bool> used(ends.size(), false), gone(lines.size(), false);
  std::vector<size_t> merged_into(lines.size());
  for (size_t n = 0; n < lines.size(); ++n) merged_into[n] = n;
  auto root = [&](size_t n) {
    while (merged_into[n] != n) n = merged_into[n];
    return n;
  };
  // The points walked on along the locus from the end of line n at p to q (both included), where
  // the walk reaches q within three times their distance: the test above holds for any two ends
  // of a locus that bends between them (a line's two ends round a tripoint or a coast the cells do
  // not show), which the walk tells apart.
  auto walk_to = [&](size_t n, Vec2 p, Vec2 q) -> std::optional<std::vector<Vec2>> {
    const std::vector<BoundaryVertex>& v = lines[n].vertices;
    if (v.size() < 2) return std::nullopt;
    const Vec2 before = v.front().p == p ? v[1].p : v[v.size() - 2].p;
    const double step = b.g.res / kPerCell;
    const auto steps = static_cast<int64_t>(std::ceil(3.0 * std::hypot(q.x - p.x, q.y - p.y) / step)) + kPerCell;
    locus_follow::Followed w = locus_follow::follow_on(narrow_level(b, lines[n].owner_a, lines[n].owner_b, per), p,
                                                       Vec2{p.x - before.x, p.y - before.y}, step, steps, {q});
    // (A walk that reaches q along a line of the same owners came round that line's other end:
    // joined, the line would be drawn twice.)
    if (w.stop != locus_follow::Stop::target ||
        walk_runs_along(b, lines, w.points, lines[n].owner_a, lines[n].owner_b, static_cast<int64_t>(n)))
      return std::nullopt;
    return std::move(w.points);
  };
  for (const NearPair& pr : pairs) {
    if (used[pr.i] || used[pr.j]) continue;
    const size_t a = root(ends[pr.i].line), c = root(ends[pr.j].line);
    const Vec2 pa = ends[pr.i].p, pc = ends[pr.j].p;
    // The way between them, pa first: the points walked, the join's own vertices (a chord between
    // them may cut an islet's corner the locus goes round, where refining it could not follow).
    std::optional<std::vector<Vec2>> way = walk_to(a, pa, pc);
    if (!way && (way = walk_to(c, pc, pa))) std::reverse(way->begin(), way->end());
    if (!way) continue;
    way->pop_back();  // pc: the other line's own end
    used[pr.i] = used[pr.j] = true;
    BoundaryLine& la = lines[a];
    if (!(la.vertices.back().p == pa)) std::reverse(la.vertices.begin(), la.vertices.end());
    const size_t before_count = la.vertices.size();
    append_walked(b, la, *way);
    stats.vertices += static_cast<int64_t>(la.vertices.size() - before_count);
    la.bows.clear();
    if (a == c) {
      // Both ends of one line: a ring.
      la.vertices.push_back(la.vertices.front());
      la.closed = true;
    } else {
      // Line a ends at pa, line c starts at pc: c appended to a.
      BoundaryLine& lc = lines[c];
      if (!(lc.vertices.front().p == pc)) std::reverse(lc.vertices.begin(), lc.vertices.end());
      la.vertices.insert(la.vertices.end(), lc.vertices.begin(), lc.vertices.end());
      lc.vertices.clear();
      gone[c] = true;
      merged_into[c] = a;
    }
    ++stats.ends_joined;
  }
  std::vector<BoundaryLine> kept;
  for (size_t n = 0; n < lines.size(); ++n)
    if (!gone[n]) kept.push_back(std::move(lines[n]));
  lines = std::move(kept);
}

// The level of the locus of owners oa and ob for follow_open_ends: pair_level's, with steps of at
// most half the way to the nearer side (`per`: metric units per CRS unit) and where the sides meet.
locus_follow::Level narrow_level(const BoundaryGrid& b, int32_t oa, int32_t ob, double per) {
  locus_follow::Level level = pair_level(b, oa, ob);
  // Steps of at most half the way to the nearer side: a locus that runs on up a sliver of sea
  // along a land border (two states' polygons metres apart, as the western Baltic's are on
  // Usedom and at the head of the Flensburg Fjord) is walked up it, to where the two coasts
  // meet or out at its other end.
  // (The walk asks both at the same point: the two owners' hits there are measured once.)
  struct Near {
    Vec2 p{std::numeric_limits<double>::quiet_NaN(), 0.0};
    OwnerIndex::Hit a, b;
  };
  auto near = std::make_shared<Near>();
  auto hits = [&b, oa, ob, near](Vec2 p) -> const Near& {
    if (!(near->p == p)) *near = Near{p, b.index.nearest_of(p, oa), b.index.nearest_of(p, ob)};
    return *near;
  };
  level.clearance = [hits, per](Vec2 p) {
    const Near& n = hits(p);
    return std::min(n.a.distance, n.b.distance) / per;
  };
  level.meet = 1e-4 * b.g.res;
  // Where the two sides meet: the crossing X of their nearest coast edges (of their geodesics on
  // a longitude/latitude grid), or of one with the edge next to the other on its ring (where one
  // side's vertex comes within a hair of the other's edge and their land overlaps beyond), within
  // two cells, ahead; the locus runs straight there (the two edges' bisector) where the nearest
  // sites halfway are still those edges or their neighbours.
  level.meeting = [&b, oa, ob, hits](Vec2 p, Vec2& at) {
    const std::vector<Site>& sites = b.index.metric().seeds().sites();
    const int32_t sa = hits(p).a.site, sb = hits(p).b.site;
    if (sa == kNoSite || sb == kNoSite) return false;
    // The site and its neighbours along the same feature's edges.
    auto near_of = [&](int32_t s) {
      std::array<int32_t, 3> out{s, kNoSite, kNoSite};
      for (int k : {-1, 1}) {
        const int32_t n = s + k;
        if (n >= 0 && n < static_cast<int32_t>(sites.size()) &&
            sites[static_cast<size_t>(n)].feature == sites[static_cast<size_t>(s)].feature)
          out[static_cast<size_t>(k < 0 ? 1 : 2)] = n;
      }
      return out;
    };
    const std::array<int32_t, 3> na = near_of(sa), nb = near_of(sb);
    double best = 2.0 * b.g.res;
    bool found = false;
    for (const int32_t i : na)
      for (const int32_t j : nb) {
        if (i == kNoSite || j == kNoSite || (i != sa && j != sb)) continue;
        const Site &u = sites[static_cast<size_t>(i)], &w = sites[static_cast<size_t>(j)];
        const Vec2 du{u.b.x - u.a.x, u.b.y - u.a.y}, dw{w.b.x - w.a.x, w.b.y - w.a.y};
        double t, s;
        if (!lines_meet(u.a, du, w.a, dw, t, s) || !(t >= 0.0 && t <= 1.0 && s >= 0.0 && s <= 1.0)) continue;
        Vec2 x{u.a.x + t * du.x, u.a.y + t * du.y};
        // (On a longitude/latitude grid the edges are geodesics: their own crossing.)
        if (b.index.metric().kind() == SiteMetric::Kind::geodesic)
          x = geodesics_meet(b.index.metric().spec(), u.a, u.b, w.a, w.b, x);
        const double d = std::hypot(x.x - p.x, x.y - p.y);
        if (!(d <= best)) continue;
        const Vec2 mid = lerp(p, x, 0.5);
        const int32_t ma = b.index.nearest_of(mid, oa).site, mb = b.index.nearest_of(mid, ob).site;
        if (std::find(na.begin(), na.end(), ma) == na.end() || std::find(nb.begin(), nb.end(), mb) == nb.end())
          continue;
        best = d;
        at = x;
        found = true;
      }
    return found;
  };
  return level;
}

void follow_open_ends(const BoundaryGrid& b, double max_distance, double per, const std::vector<Tripoint>& tripoints,
                      std::vector<BoundaryLine>& lines, BoundaryStats& stats) {
  // (Where a maximum distance or a reach ends the owned area, lines end on its edge, which the
  // walk does not know: it is not taken there.)
  if (b.index.metric().straight() || std::isfinite(max_distance) || !std::isfinite(b.index.cost_slope())) return;
  auto open = [&](const BoundaryVertex& v) { return open_line_end(b, tripoints, v); };
  // The open ends, by line and position (a line's ends move to another line when it is joined).
  struct End {
    size_t line;
    Vec2 p;
  };
  std::vector<End> ends;
  for (size_t n = 0; n < lines.size(); ++n) {
    const BoundaryLine& l = lines[n];
    if (l.closed || l.vertices.size() < 2 || l.vertices.front().p == l.vertices.back().p) continue;
    if (open(l.vertices.front())) ends.push_back(End{n, l.vertices.front().p});
    if (open(l.vertices.back())) ends.push_back(End{n, l.vertices.back().p});
  }
  if (ends.empty()) return;
  // (Steps shrink in a sliver: up to a few thousand of them to go up one several kilometres long.)
  constexpr int64_t kMaxNarrowSteps = 8192;
  std::vector<size_t> merged_into(lines.size());
  for (size_t n = 0; n < lines.size(); ++n) merged_into[n] = n;
  auto root = [&](size_t n) {
    while (merged_into[n] != n) n = merged_into[n];
    return n;
  };
  // Line n turned so that its back end is at p (false where neither end is).
  auto to_back = [&](size_t n, Vec2 p) {
    std::vector<BoundaryVertex>& v = lines[n].vertices;
    if (v.back().p == p) return true;
    if (!(v.front().p == p)) return false;
    std::reverse(v.begin(), v.end());
    return true;
  };
  std::vector<bool> done(ends.size(), false);
  for (size_t i = 0; i < ends.size(); ++i) {
    if (done[i]) continue;
    done[i] = true;
    const size_t n = root(ends[i].line);
    BoundaryLine& line = lines[n];
    if (line.closed || !to_back(n, ends[i].p) || line.vertices.size() < 2) continue;
    // The other open ends of the same two owners: reaching one joins the two lines there.
    std::vector<Vec2> others;
    std::vector<size_t> other_end;
    for (size_t j = 0; j < ends.size(); ++j) {
      const BoundaryLine& o = lines[root(ends[j].line)];
      if (done[j] || o.closed || o.owner_a != line.owner_a || o.owner_b != line.owner_b) continue;
      others.push_back(ends[j].p);
      other_end.push_back(j);
    }
    const std::vector<BoundaryVertex>& v = line.vertices;
    const Vec2 end = v.back().p, before = v[v.size() - 2].p;
    const locus_follow::Level level = narrow_level(b, line.owner_a, line.owner_b, per);
    const locus_follow::Followed f = locus_follow::follow_on(level, end, Vec2{end.x - before.x, end.y - before.y},
                                                             b.g.res / kPerCell, kMaxNarrowSteps, others);
    // (A walk along another line of the same owners is not taken: that stretch is drawn, and the
    // end is one to be carried to a tripoint or joined by complete_tripoints.)
    if (f.points.size() < 2 || walk_runs_along(b, lines, f.points, line.owner_a, line.owner_b, static_cast<int64_t>(n)))
      continue;
    // (A walk that reaches the frame of the cell centres is not taken: by sea a line there goes on
    // to the grid's edge, which cross_hidden_channels draws.)
    if (f.stop == locus_follow::Stop::coast) {
      const auto before_count = static_cast<int64_t>(line.vertices.size());
      append_walked(b, line, f.points);
      stats.vertices += static_cast<int64_t>(line.vertices.size()) - before_count;
      line.bows.clear();
      ++stats.ends_followed;
      line.vertices.back().on_barrier = true;
      ++stats.ends_on_barriers;
      stats.max_residual = std::max(stats.max_residual, line.vertices.back().residual);
    } else if (f.stop == locus_follow::Stop::target && f.other >= 0) {
      const size_t j = other_end[static_cast<size_t>(f.other)];
      const size_t m = root(ends[j].line);
      // The other line turned to start at the end reached (the line's own front: a ring).
      if (m != n && !to_back(m, ends[j].p)) continue;
      done[j] = true;
      // The points walked up to the other end (its own vertex, not repeated).
      const std::vector<Vec2> walked(f.points.begin(), f.points.end() - 1);
      const auto before_count = static_cast<int64_t>(line.vertices.size());
      append_walked(b, line, walked);
      stats.vertices += static_cast<int64_t>(line.vertices.size()) - before_count;
      line.bows.clear();
      if (m == n) {
        line.vertices.push_back(line.vertices.front());
        line.closed = true;
      } else {
        BoundaryLine& o = lines[m];
        line.vertices.insert(line.vertices.end(), o.vertices.rbegin(), o.vertices.rend());
        merged_into[m] = n;
      }
      ++stats.ends_followed;
      ++stats.ends_joined;
    }
  }
  std::vector<BoundaryLine> kept;
  for (size_t n = 0; n < lines.size(); ++n)
    if (merged_into[n] == n) kept.push_back(std::move(lines[n]));
  lines = std::move(kept);
}

}  // namespace rv::boundary_stages
