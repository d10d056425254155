// Stage 5 of boundary lines (boundary_stages.hpp, LineRefiner, finish_lines): the chords between
// the vertices found on cell edges made to follow the locus -- its turning points added exactly,
// its curved stretches to the line tolerance -- and every final segment measured.
//
// Why. Each vertex on a cell edge is an exact locus point, but the line between two of them is a
// straight chord, and the locus is not: it turns where a controlling site changes (a chord then
// cuts the corner, by up to a quarter of its length times the sine of the turn) and curves where
// its two sites are not two points of equal weight (a parabola of a point and a segment, the
// circle of two weighted points, a geodesic bisector in longitude/latitude). A chord of length c
// cuts inside a curve of radius R by about c^2 / 8R: metres on a 12 nmi arc drawn on a 0.01
// degree grid. Regions, areas and treaty points are drawn from these chords.
//
// How. A side's site set changes between the ends: the turning point solves the three sites'
// costs equal (Newton's method on their gradients, from the chord's middle). The sets agree: the
// chord's sagitta is estimated from the angle between the locus normals at its ends, as on a
// circular arc (0.5 c tan(angle / 4)), and the chord's midpoint is measured against the locus
// (the two owners' nearest sites there). Either above the tolerance: the locus point across the
// chord's middle is found along its perpendicular and added. The midpoint alone can under-read
// a chord whose curvature changes along it (a straight stretch running into an arc: the worst
// point moves towards the arc, by up to an eighth more than the midpoint shows where the
// normals' estimate is also low), so a measured midpoint splits from kSplitAt of the tolerance.
// Added points are checked as the crossings are (each owner's nearest at the point, no third
// owner nearer), carry their sites (and a second site of a side that ties there, so a vertex
// shared by two edges does not read as a change), and the two halves are refined in turn, to a
// bounded depth.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/line_pieces.hpp"
#include "lines/line_tools.hpp"
#include "lines/locus/tie_edge.hpp"
#include "rv/field/parallel.hpp"
#include "rv/lines/simplify.hpp"

namespace rv::boundary_stages {

using namespace line_tools;

namespace {

constexpr int kMaxDepth = 12;
constexpr double kSplitAt = 0.85;
constexpr int kNewtonIterations = 12;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Whether two ends' sites of one side (each a site and maybe a second tied with it) overlap.
bool shares(int32_t s1, int32_t alt1, int32_t s2, int32_t alt2) {
  return s1 == s2 || (alt1 != kNoSite && (alt1 == s2 || alt1 == alt2)) || (alt2 != kNoSite && s1 == alt2);
}

}  // namespace

struct LineRefiner::End {
  BoundaryVertex v;
  int32_t alt_a = kNoSite, alt_b = kNoSite;  // a second site tied with site_a / site_b at v.p
  Vec2 normal{kNaN, kNaN};                   // gradient of cost_a - cost_b at v.p, per CRS unit
};

double site_cost(const OwnerIndex& index, Vec2 p, int32_t site, Vec2& gradient) {
  const double d = index.metric().distance_and_gradient(p, site, gradient);
  const double w = index.weight_of(site);
  if (w != 1.0) gradient = Vec2{gradient.x / w, gradient.y / w};
  return index.cost_of(site, d);
}

bool equal_costs_point(const OwnerIndex& index, int32_t s1, int32_t s2, int32_t t, Vec2 start, double max_move,
                       double ftol, Vec2& out) {
  Vec2 p = start;
  for (int iter = 0; iter < kNewtonIterations; ++iter) {
    Vec2 g1, g2, gt;
    const double c1 = site_cost(index, p, s1, g1), c2 = site_cost(index, p, s2, g2), ct = site_cost(index, p, t, gt);
    const double f0 = c1 - ct, f1 = c2 - ct;
    if (!std::isfinite(f0) || !std::isfinite(f1)) return false;
    if (std::max(std::abs(f0), std::abs(f1)) <= ftol) {
      out = p;
      return true;
    }
    const double j00 = g1.x - gt.x, j01 = g1.y - gt.y, j10 = g2.x - gt.x, j11 = g2.y - gt.y;
    const double det = j00 * j11 - j01 * j10;
    if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return false;
    const double dx = (f0 * j11 - f1 * j01) / det, dy = (j00 * f1 - j10 * f0) / det;
    p = Vec2{p.x - dx, p.y - dy};
    if (!(std::hypot(p.x - start.x, p.y - start.y) <= max_move)) return false;
  }
  return false;
}

double LineRefiner::cost(Vec2 p, int32_t site, Vec2& gradient) const { return site_cost(index_, p, site, gradient); }

int32_t LineRefiner::arc_site(const BoundaryVertex& v) {
  return v.arc == 1 ? v.site_a : v.arc == 2 ? v.site_b : kNoSite;
}

double LineRefiner::arc_value(Vec2 p, int32_t site, Vec2& gradient) const {
  return index_.metric().distance_and_gradient(p, site, gradient) - index_.reach_of(site);
}

void LineRefiner::set_normal(End& e) const {
  if (e.v.site_a == kNoSite || e.v.site_b == kNoSite) return;
  if (e.v.arc != 0) {
    arc_value(e.v.p, arc_site(e.v), e.normal);
    return;
  }
  Vec2 ga, gb;
  cost(e.v.p, e.v.site_a, ga);
  cost(e.v.p, e.v.site_b, gb);
  e.normal = Vec2{ga.x - gb.x, ga.y - gb.y};
}

Vec2 LineRefiner::normal_towards(const End& e, const End& other) const {
  if (e.v.arc != 0) return e.normal;
  // A turning point has two sites on a side: the stretch towards `other` is the one of the site
  // it shares with it.
  auto side = [](int32_t s, int32_t alt, int32_t o, int32_t o_alt) {
    return alt != kNoSite && s != o && s != o_alt && (alt == o || alt == o_alt) ? alt : s;
  };
  const int32_t sa = side(e.v.site_a, e.alt_a, other.v.site_a, other.alt_a);
  const int32_t sb = side(e.v.site_b, e.alt_b, other.v.site_b, other.alt_b);
  if (sa == e.v.site_a && sb == e.v.site_b) return e.normal;
  Vec2 ga, gb;
  cost(e.v.p, sa, ga);
  cost(e.v.p, sb, gb);
  return Vec2{ga.x - gb.x, ga.y - gb.y};
}

void LineRefiner::refine_segments(int32_t a, int32_t b, const std::vector<BoundaryVertex>& vertices, size_t i0,
                                  size_t i1, std::vector<BoundaryVertex>& result, Added& n, std::vector<Bow>* bows,
                                  std::vector<Segment>* each) const {
  std::vector<End> out;
  End u;
  u.v = vertices[i0];
  set_normal(u);
  for (size_t i = i0; i < i1; ++i) {
    End v;
    v.v = vertices[i + 1];
    set_normal(v);
    // Each segment counted on its own, then merged (the same sums and maxima, the first worst).
    Added s;
    out.clear();
    between(u, v, 0, false, a, b, out, s, bows);
    for (const End& e : out) result.push_back(e.v);
    result.push_back(v.v);
    (u.v.arc != 0 || v.v.arc != 0 ? s.arcs : s.locus).added += s.turning_points + s.arc_points;
    n.merge(s);
    if (each != nullptr) each->push_back(Segment{result.size(), bows != nullptr ? bows->size() : 0, s});
    u = std::move(v);
  }
}

double LineRefiner::measure(int32_t a, int32_t b, const std::vector<BoundaryVertex>& vertices) const {
  double worst = 0.0;
  for (size_t i = 1; i < vertices.size(); ++i) {
    if (land_segment(vertices[i - 1], vertices[i])) continue;
    const double off = midpoint_offset(vertices[i - 1], vertices[i], a, b);
    if (std::isfinite(off)) worst = std::max(worst, off);
  }
  return worst;
}

double LineRefiner::midpoint_offset(const BoundaryVertex& u, const BoundaryVertex& v, int32_t a, int32_t b,
                                    Bow* bow) const {
  const Vec2 mid = lerp(u.p, v.p, 0.5);
  Vec2 g;
  if (u.tie && v.tie) {  // along a tie region's edge: the distance to it (the costs' difference is 0 inside)
    End edge;
    double off = std::numeric_limits<double>::quiet_NaN();
    if (bow != nullptr) *bow = Bow{};
    return tie_edge(u, v, a, b, edge, off) ? off : std::numeric_limits<double>::quiet_NaN();
  }
  if (u.arc != 0 || v.arc != 0) {
    // On an arc the distance to it is |d - reach| (a distance's gradient has unit length); where
    // an arc meets the locus, the nearer of the two curves.
    double best = std::numeric_limits<double>::infinity();
    for (const BoundaryVertex* e : {&u, &v}) {
      const double f = curve_value(*e, mid, g);
      const double off = scale_.offset(mid, f, g);
      const double at = std::isfinite(off) ? off : std::abs(f);
      if (at < best) {
        best = at;
        if (bow != nullptr) *bow = scale_.bow(u.p, v.p, f, g);
      }
    }
    return best;
  }
  // Both ends' sites hold the stretch (the cells and the refinement found no other between
  // them): measured with them; else with each owner's nearest there, searched.
  int32_t sa = u.site_a, sb = u.site_b;
  if (!(v.site_a == sa && v.site_b == sb)) {
    sa = index_.nearest_of(mid, a, u.site_a).site;
    sb = index_.nearest_of(mid, b, u.site_b).site;
  }
  if (sa == kNoSite || sb == kNoSite) return std::numeric_limits<double>::quiet_NaN();
  Vec2 ga, gb;
  const double ca = cost(mid, sa, ga), cb = cost(mid, sb, gb);
  if (!std::isfinite(ca) || !std::isfinite(cb)) return std::numeric_limits<double>::quiet_NaN();
  const double f = ca - cb;
  const double off = scale_.offset(mid, f, Vec2{ga.x - gb.x, ga.y - gb.y});
  if (bow != nullptr) *bow = scale_.bow(u.p, v.p, f, Vec2{ga.x - gb.x, ga.y - gb.y});
  if (std::isfinite(off)) return off;
  // No gradient (a projected grid measured on the ellipsoid): the locus point across the middle,
  // and the distance to it.
  End eu, ev;
  eu.v = u;
  ev.v = v;
  const double chord = std::hypot(v.p.x - u.p.x, v.p.y - u.p.y);
  End across;
  if (chord > 0.0 && across_middle(eu, ev, a, b, 0.5 * chord, across))
    return index_.metric().point_distance(mid, across.v.p);
  return std::abs(f);
}

bool LineRefiner::split(const End& u, const End& v, bool same, bool arcs, double stray, int32_t a, int32_t b, End& mid,
                        bool& turning, bool& loose) const {
  // The locus this chord stands for lies within about `stray` (CRS units) of it; a locus point
  // much farther away belongs to another stretch (the locus can cross the chord's perpendicular
  // again).
  const double chord = std::hypot(v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y);
  const double max_off = std::min(2.0 * stray + 1e-9 * chord, chord);
  turning = loose = false;
  // Where a site changes and no turning point of three sites checks out (more sites change
  // within the chord), the chord stays: a root across its middle could be another stretch's.
  if (arcs && same) return across_arc(u, v, a, b, max_off, mid);
  if (arcs) return turning = arc_junction(u, v, a, b, max_off, mid);
  // Both ends held by the same two sites (the cells and the checks at the ends found no other
  // between them): the locus point is theirs, by Newton's method along the two costs' gradient
  // from the chord's middle, without a search; elsewhere the owners' nearest sites across it.
  if (same && u.v.site_a == v.v.site_a && u.v.site_b == v.v.site_b && u.alt_a == kNoSite && u.alt_b == kNoSite &&
      v.alt_a == kNoSite && v.alt_b == kNoSite && onto_locus(u, v, max_off, mid))
    return true;
  if (same) return across_middle(u, v, a, b, max_off, mid);
  if ((turning = turning_point(u, v, a, b, max_off, mid))) return true;
  // No turning point of three sites. Where the sites that change are two edges of one coast
  // that share a vertex (equally near over the whole wedge where that vertex is nearest: no
  // single point where they take over), the locus is one smooth stretch: its point across the
  // middle, with each owner's true nearest there, is checked like any other.
  const std::vector<Site>& sites = index_.metric().seeds().sites();
  auto adjacent = [&](int32_t s1, int32_t s2) {
    if (s1 == s2) return true;
    if (s1 == kNoSite || s2 == kNoSite) return false;
    const Site &x = sites[static_cast<size_t>(s1)], &y = sites[static_cast<size_t>(s2)];
    if (x.kind != SiteKind::segment || y.kind != SiteKind::segment || x.feature != y.feature) return false;
    return x.a == y.a || x.a == y.b || x.b == y.a || x.b == y.b;
  };
  if (adjacent(u.v.site_a, v.v.site_a) && adjacent(u.v.site_b, v.v.site_b))
    return across_middle(u, v, a, b, max_off, mid);
  // Elsewhere more changes lie within the chord: several coast edges of one side, far apart, or
  // by sea one side's site and the bend of the other's path round the land (the turning point of
  // three sites then lies outside the chord). Such chords once stayed, for fear of a root of
  // another stretch of the pair's locus, up to 80 m off the locus on the Øresund at 400 m and 98 m
  // by sea south of Copenhagen (bench/RESULTS-sea.md, session 61). The point across the middle is
  // taken as checked() takes every point, `loose`: between() keeps the refinement it starts only
  // where the line from u to v stays simple (a random layout's root of another stretch sent the
  // line out and back to a turning point). The locus may run back past an end's projection (south
  // of Copenhagen the corner lies beyond u): no order along the chord is asked.
  loose = true;
  if (across_middle(u, v, a, b, max_off, mid)) return true;
  // A tip: one owner's wedge narrower than a cell, between two sites of the other owner that take
  // over from each other at its tip. The cells end the line where the wedge is still a cell wide,
  // a chord across it, and the turning point lies beyond the chord, several chords away in a thin
  // wedge (bench/RESULTS-sea.md, session 80).
  return turning = tip_point(u, v, a, b, mid);
}

void LineRefiner::between(const End& u, const End& v, int depth, bool lifted, int32_t a, int32_t b,
                          std::vector<End>& out, Added& n, std::vector<Bow>* bows) const {
  const double chord = std::hypot(v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y);
  const bool arcs = u.v.arc != 0 || v.v.arc != 0;
  LineResidual& r = arcs ? n.arcs : n.locus;
  if (!(chord > 0.0) || land_segment(u.v, v.v)) {
    if (chord > 0.0) ++r.land_border_segments;
    if (bows != nullptr) bows->push_back(Bow{});
    return;
  }
  // An arc's stretch (a reach ends: Feature::reach) is the same curve only as the same site's,
  // or from a point of the locus that lies on that arc (the tripoint or junction where it
  // begins).
  auto on_arc_of = [&](const BoundaryVertex& p, const BoundaryVertex& arc) {
    Vec2 g;
    return p.arc == 0 && std::abs(arc_value(p.p, arc_site(arc), g)) <= 4.0 * ftol_;
  };
  const bool same =
      arcs ? (u.v.arc == v.v.arc && arc_site(u.v) == arc_site(v.v)) || (v.v.arc != 0 && on_arc_of(u.v, v.v)) ||
                 (u.v.arc != 0 && on_arc_of(v.v, u.v))
           : shares(u.v.site_a, u.alt_a, v.v.site_a, v.alt_a) && shares(u.v.site_b, u.alt_b, v.v.site_b, v.alt_b);
  // By sea, along a tie region's edge (BoundaryVertex::tie): split at the edge's point across the
  // middle (tie_edge) while the chord strays from it by more than the tolerance.
  if (u.v.tie && v.v.tie) {
    End edge;
    double off = 0.0;
    if (tie_edge(u.v, v.v, a, b, edge, off)) {
      if (depth < kMaxDepth && tol_ > 0.0 && off > kSplitAt * tol_) {
        ++n.arc_points;
        between(u, edge, depth + 1, lifted, a, b, out, n, bows);
        out.push_back(edge);
        between(edge, v, depth + 1, lifted, a, b, out, n, bows);
        return;
      }
      if (bows != nullptr) bows->push_back(Bow{});
      const Vec2 m = lerp(u.v.p, v.v.p, 0.5);
      r.add(off, m.x, m.y, tol_ > 0.0 ? tol_ : std::numeric_limits<double>::infinity());
      return;
    }
  }
  // From a tie region's edge to the rest of the locus: the line turns at the region's apex, the
  // barrier vertex where the tied paths bend.
  if (depth < kMaxDepth && u.v.tie != v.v.tie) {
    End apex;
    if (tie_apex(u, v, a, b, apex)) {
      ++n.turning_points;
      between(u, apex, depth + 1, lifted, a, b, out, n, bows);
      out.push_back(apex);
      between(apex, v, depth + 1, lifted, a, b, out, n, bows);
      return;
    }
  }
  // How far the locus can stray from the chord, from the turn of its normal between the ends: a
  // circular arc (the same sites) strays 0.5 c tan(angle / 4), a corner (another site takes
  // over) at most 0.5 c tan(angle / 2). No normal known: nothing estimated (the midpoint
  // decides). A change of site that does not turn the locus (collinear edges) adds nothing.
  const Vec2 nu = normal_towards(u, v), nv = normal_towards(v, u);
  const double angle = std::atan2(std::abs(nu.x * nv.y - nu.y * nv.x), nu.x * nv.x + nu.y * nv.y);
  double stray = angle >= 3.0 ? chord : 0.5 * chord * std::tan((same ? 0.25 : 0.5) * angle);
  if (!std::isfinite(stray)) stray = 0.0;
  const double estimate = stray * per_crs_;
  const bool may_split = depth < kMaxDepth && tol_ > 0.0;
  End mid;
  bool turning = false, loose = false;
  // Refines on either side of `mid`; a loose split (see split()) is undone where the line it gives
  // from u to v is not simple (it crosses itself, or comes back to a vertex).
  auto descend = [&]() {
    const size_t out0 = out.size(), bows0 = bows != nullptr ? bows->size() : 0;
    const Added before = n;
    ++(turning ? n.turning_points : n.arc_points);
    // A tip's turning point lies beyond an end (split()): its halves are new stretches of the
    // line, longer than the chord and as long as a line's first chords can be, and start the
    // halvings afresh (once on a line's way down, so that the depth still bounds the refinement).
    const Vec2 d{v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y};
    const double along = ((mid.v.p.x - u.v.p.x) * d.x + (mid.v.p.y - u.v.p.y) * d.y) / (chord * chord);
    const bool lift = !lifted && !(along >= 0.0 && along <= 1.0);
    const int next = lift ? 0 : depth + 1;
    between(u, mid, next, lifted || lift, a, b, out, n, bows);
    out.push_back(mid);
    between(mid, v, next, lifted || lift, a, b, out, n, bows);
    if (!loose || runs_simply(u.v.p, v.v.p, out, out0)) return true;
    out.resize(out0);
    if (bows != nullptr) bows->resize(bows0);
    n = before;
    return false;
  };
  if (may_split && estimate > tol_ && split(u, v, same, arcs, stray, a, b, mid, turning, loose) && descend()) return;
  Bow bow;
  const double off = midpoint_offset(u.v, v.v, a, b, &bow);
  if (may_split && std::isfinite(off) && off > kSplitAt * tol_) {
    // The measured offset bounds how far the locus lies from the middle (CRS units: over the
    // smaller scale, doubled for the slant of the perpendicular).
    const Vec2 s = scale_.at(u.v.p);
    const double reach = 2.0 * off / std::min(s.x, s.y);
    if (split(u, v, same, arcs, std::max(stray, reach), a, b, mid, turning, loose) && descend()) return;
    // The normals' turn can put the search's ends across another stretch of the locus (the other
    // arm where it turns sharply, at a tip): then within the measured offset alone.
    if (reach < stray && split(u, v, same, arcs, reach, a, b, mid, turning, loose) && descend()) return;
  }
  // Still off the locus with the same sites at both ends: by sea, one side's path may bend last
  // at another vertex at each end, and the locus has a corner between them that halving only
  // approaches (by half the offset a level). Solved as a turning point once the halving stops
  // (checked only here: the bends cost a path search each end), then both halves refined on.
  if (tol_ > 0.0 && depth <= kMaxDepth && same && !arcs && std::isfinite(off) && off > tol_ &&
      bend_corner(u, v, a, b, chord, mid)) {
    ++n.turning_points;
    between(u, mid, depth + 1, lifted, a, b, out, n, bows);
    out.push_back(mid);
    between(mid, v, depth + 1, lifted, a, b, out, n, bows);
    return;
  }
  if (bows != nullptr) bows->push_back(bow);
  const Vec2 m = lerp(u.v.p, v.v.p, 0.5);
  r.add(off, m.x, m.y, tol_ > 0.0 ? tol_ : std::numeric_limits<double>::infinity());
  r.max_estimate = std::max(r.max_estimate, estimate);
}

bool LineRefiner::runs_simply(Vec2 u, Vec2 v, const std::vector<End>& out, size_t from) {
  std::vector<Vec2> p{u};
  for (size_t k = from; k < out.size(); ++k) p.push_back(out[k].v.p);
  p.push_back(v);
  const double near = 1e-6 * std::hypot(v.x - u.x, v.y - u.y);
  auto orient = [](Vec2 a, Vec2 b, Vec2 c) { return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x); };
  for (size_t i = 0; i + 1 < p.size(); ++i)
    for (size_t j = i + 2; j < p.size(); ++j) {
      if (std::hypot(p[j].x - p[i].x, p[j].y - p[i].y) <= near) return false;  // back at a vertex
      if (j + 1 >= p.size()) continue;
      const double o1 = orient(p[i], p[i + 1], p[j]), o2 = orient(p[i], p[i + 1], p[j + 1]);
      const double o3 = orient(p[j], p[j + 1], p[i]), o4 = orient(p[j], p[j + 1], p[i + 1]);
      if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) return false;
    }
  return true;
}

bool LineRefiner::tie_edge(const BoundaryVertex& u, const BoundaryVertex& v, int32_t a, int32_t b, End& out,
                           double& off) const {
  // The costs are equal to the bit over the whole region, so no root of their difference marks
  // its edge: the edge's point across the chord's middle is found by bisection on whether the
  // two owners tie there (equal costs, the paths bending last at one vertex), between the middle
  // and the end of the perpendicular (half a chord each way) on the other side of the edge.
  OwnerIndex::Hit ha, hb;
  auto tied = [&](Vec2 p) {
    ha = index_.nearest_of(p, a, u.site_a);
    hb = index_.nearest_of(p, b, u.site_b);
    return ties(index_.metric(), p, ha, hb);
  };
  End eu, ev;
  eu.v = u;
  ev.v = v;
  const double chord = std::hypot(v.p.x - u.p.x, v.p.y - u.p.y);
  const std::array<Vec2, 2> ends = perpendicular(eu, ev, 0.5 * chord);
  const Vec2 mid = lerp(u.p, v.p, 0.5);
  Vec2 in = mid, parted = mid;
  if (tied(mid)) {
    if (!tied(ends[0]))
      parted = ends[0];
    else if (!tied(ends[1]))
      parted = ends[1];
    else
      return false;
  } else {
    if (tied(ends[0]))
      in = ends[0];
    else if (tied(ends[1]))
      in = ends[1];
    else
      return false;
  }
  const Vec2 from = in;
  const Vec2 edge = lerp(from, parted, last_tied([&](double s) { return tied(lerp(from, parted, s)); }, 0.0, 1.0));
  if (!tied(edge)) return false;
  out = End{};
  out.v = vertex_between(edge, ha, hb);
  out.v.tie = true;
  off = index_.metric().point_distance(mid, edge);
  return true;
}

bool LineRefiner::tie_apex(const End& u, const End& v, int32_t a, int32_t b, End& out) const {
  const BoundaryVertex& tied = u.v.tie ? u.v : v.v;
  const int32_t bend = index_.metric().last_bend(tied.p, tied.site_a);
  if (bend < 0) return false;
  // (Anywhere across the chord: the apex is where the edge turns, which the chord cuts.)
  const double chord = std::hypot(v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y);
  if (!checked(index_.metric().bend_position(bend), a, b, u, v, chord, out)) return false;
  out.v.tie = true;
  return true;
}

bool LineRefiner::bend_corner(const End& u, const End& v, int32_t a, int32_t b, double max_off, End& out) const {
  const SiteMetric& m = index_.metric();
  if (m.straight() || u.v.site_a != v.v.site_a || u.v.site_b != v.v.site_b) return false;
  const double chord = std::hypot(v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y);
  const Vec2 mid = lerp(u.v.p, v.v.p, 0.5);
  // Either side's site s may be the one whose path changes; t is the other side's.
  for (const auto& [side, other] : {std::pair{u.v.site_a, u.v.site_b}, std::pair{u.v.site_b, u.v.site_a}}) {
    // (Plain copies: a lambda may not capture a structured binding before C++20's P1091, which
    // clang 14 lacks.)
    const int32_t s = side, t = other;
    if (s == kNoSite || t == kNoSite) continue;
    const int32_t bu = m.last_bend(u.v.p, s), bv = m.last_bend(v.v.p, s);
    if (bu == bv) continue;
    // Each end's path as its last straight stretch: from its bend (seen directly: from the
    // site's point nearest the end) after the length of the path up to there.
    struct Leg {
      Vec2 from;
      double before;
    };
    auto leg = [&](const End& e, int32_t bend) {
      const Vec2 from = bend >= 0 ? m.bend_position(bend) : m.nearest_point(e.v.p, s);
      const double d = s == e.v.site_a ? e.v.distance_a : e.v.distance_b;  // (its true distance by sea)
      return Leg{from, d - m.point_distance(from, e.v.p)};
    };
    const Leg lu = leg(u, bu), lv = leg(v, bv);
    if (!std::isfinite(lu.before) || !std::isfinite(lv.before)) continue;
    // Newton's method with a numeric Jacobian (the metric gives no gradient of a point-to-point
    // length), steps of at most the chord.
    auto leg_cost = [&](const Leg& l, Vec2 p) { return index_.cost_of(s, l.before + m.point_distance(l.from, p)); };
    auto f = [&](Vec2 p) {
      Vec2 g;
      const double ct = cost(p, t, g);
      return std::array{leg_cost(lu, p) - ct, leg_cost(lv, p) - ct};
    };
    Vec2 p;
    if (line_tools::solve2(f, mid, chord, ftol_, p) && checked(p, a, b, u, v, max_off, out)) return true;
  }
  return false;
}

std::vector<LineRefiner::System> LineRefiner::systems(const End& u, const End& v, bool both_ends) {
  std::vector<System> out;
  if (!shares(u.v.site_a, u.alt_a, v.v.site_a, v.alt_a)) {
    out.push_back({u.v.site_a, v.v.site_a, u.v.site_b});
    if (both_ends && v.v.site_b != u.v.site_b) out.push_back({u.v.site_a, v.v.site_a, v.v.site_b});
  }
  if (!shares(u.v.site_b, u.alt_b, v.v.site_b, v.alt_b)) {
    out.push_back({u.v.site_b, v.v.site_b, u.v.site_a});
    if (both_ends && v.v.site_a != u.v.site_a) out.push_back({u.v.site_b, v.v.site_b, v.v.site_a});
  }
  return out;
}

bool LineRefiner::turning_point(const End& u, const End& v, int32_t a, int32_t b, double max_off, End& out) const {
  const Vec2 mid = lerp(u.v.p, v.v.p, 0.5);
  const double chord = std::hypot(v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y);
  for (const System& sys : systems(u, v, true)) {
    if (sys.s1 == kNoSite || sys.s2 == kNoSite || sys.t == kNoSite) continue;
    Vec2 p;
    if (equal_costs_point(index_, sys.s1, sys.s2, sys.t, mid, chord, ftol_, p) && checked(p, a, b, u, v, max_off, out))
      return true;
  }
  return false;
}

bool LineRefiner::tip_point(const End& u, const End& v, int32_t a, int32_t b, End& out) const {
  // Where the stretches leaving u and v along their tangents meet: the tip itself where both are
  // straight (bisectors), and the start of the search elsewhere.
  const Vec2 nu = normal_towards(u, v), nv = normal_towards(v, u);
  const Vec2 tu{-nu.y, nu.x}, tv{-nv.y, nv.x};
  const double chord = std::hypot(v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y);
  // (Not all but parallel: the meeting point would be anywhere.)
  const double cross = tu.x * tv.y - tu.y * tv.x;
  double s = 0.0, t = 0.0;
  if (!(std::abs(cross) > 1e-9 * std::hypot(tu.x, tu.y) * std::hypot(tv.x, tv.y)) ||
      !lines_meet(u.v.p, tu, v.v.p, tv, s, t))
    return false;
  const Vec2 meet{u.v.p.x + s * tu.x, u.v.p.y + s * tu.y};
  const Vec2 mid = lerp(u.v.p, v.v.p, 0.5);
  const double far = std::hypot(meet.x - mid.x, meet.y - mid.y);
  if (!std::isfinite(far)) return false;
  // The turning point is taken within half the meeting point's distance of it (and a chord): the
  // curved stretches of a tip by sea bend away from their tangents, but not back across the chord.
  const double bound = 0.5 * far + chord;
  for (const System& sys : systems(u, v, false)) {
    if (sys.s1 == kNoSite || sys.s2 == kNoSite || sys.t == kNoSite) continue;
    Vec2 p;
    if (!equal_costs_point(index_, sys.s1, sys.s2, sys.t, meet, bound, ftol_, p)) continue;
    // Not at either end (a turning point solved onto an end adds nothing).
    const double near_end =
        std::min(std::hypot(p.x - u.v.p.x, p.y - u.v.p.y), std::hypot(p.x - v.v.p.x, p.y - v.v.p.y));
    if (!(near_end > 1e-4 * chord)) continue;
    if (verified(p, a, b, u, v, out)) return true;
  }
  return false;
}

bool LineRefiner::onto_locus(const End& u, const End& v, double max_off, End& out) const {
  const int32_t sa = u.v.site_a, sb = u.v.site_b;
  const Vec2 start = lerp(u.v.p, v.v.p, 0.5);
  Vec2 p = start;
  for (int iter = 0; iter < kNewtonIterations; ++iter) {
    Vec2 ga, gb;
    const double ca = cost(p, sa, ga), cb = cost(p, sb, gb);
    const double f = ca - cb;
    const Vec2 g{ga.x - gb.x, ga.y - gb.y};
    if (!std::isfinite(f)) return false;
    if (std::abs(f) <= ftol_) {
      if (!within_chord(p, u, v, max_off)) return false;
      const double da = index_.metric().distance(p, sa), db = index_.metric().distance(p, sb);
      out = End{};
      out.v = BoundaryVertex{p, sa, sb, 0.5 * (da + db), std::abs(f), da, db};
      out.normal = g;
      return true;
    }
    const double gg = g.x * g.x + g.y * g.y;
    if (!(gg > 0.0) || !std::isfinite(gg)) return false;
    p = Vec2{p.x - f * g.x / gg, p.y - f * g.y / gg};
    if (!(std::hypot(p.x - start.x, p.y - start.y) <= max_off)) return false;
  }
  return false;
}

bool LineRefiner::across_middle(const End& u, const End& v, int32_t a, int32_t b, double max_off, End& out) const {
  const Vec2 mid = lerp(u.v.p, v.v.p, 0.5);
  const std::array<Vec2, 2> ends = perpendicular(u, v, max_off);
  const Vec2 p0 = ends[0], p1 = ends[1];  // (named, not bound: lambdas capture them)
  const double reach = edge_reach(index_.metric(), mid, p0, p1);
  std::vector<int32_t> ca, cb;
  index_.candidates_of(mid, reach, a, u.v.site_a, ca);
  index_.candidates_of(mid, reach, b, u.v.site_b, cb);
  Vec2 ga, gb;
  auto f = [&](double t) {
    const Vec2 p = lerp(p0, p1, t);
    return index_.nearest_among(p, ca, &ga).cost - index_.nearest_among(p, cb, &gb).cost;
  };
  auto with_slope = [&](double t) {
    const double value = f(t);
    return std::pair{value, (ga.x - gb.x) * (p1.x - p0.x) + (ga.y - gb.y) * (p1.y - p0.y)};
  };
  double lo = 0.0, hi = 1.0, f0 = f(lo), f1 = f(hi);
  if ((!std::isfinite(f0) || !std::isfinite(f1)) && !index_.metric().straight() && !sea_bracket(f, f0, f1, lo, hi))
    return false;
  if (!std::isfinite(f0) || !std::isfinite(f1) || (f0 < 0.0) == (f1 < 0.0)) return false;
  const double t = newton_then_bracket(f, with_slope, 0.5 * (lo + hi), lo, hi, f0 < 0.0, ftol_);
  return checked(lerp(p0, p1, t), a, b, u, v, max_off, out);
}

template <class F>
bool LineRefiner::sea_bracket(F&& f, double& f0, double& f1, double& lo, double& hi) {
  // By sea an end of the perpendicular may lie on land (no cost there): walked out from the
  // middle both ways in sixteenths while the costs are finite, the sign change nearest the middle
  // brackets the root (the locus point of this stretch at sea). Where none does (a sliver of sea
  // narrower than a step, between two states' land), again in sixteenths of the first step, and
  // of that.
  constexpr int kSteps = 8;
  const double fm = f(0.5);
  if (!std::isfinite(fm)) return false;
  double best = 2.0;
  for (double scale = 1.0; scale >= 1.0 / 256.0 && best > 1.0; scale /= 16.0)
    for (const double dir : {1.0, -1.0}) {
      double t_prev = 0.5, f_prev = fm;
      for (int k = 1; k <= kSteps; ++k) {
        const double t = 0.5 + dir * scale * k / (2.0 * kSteps), ft = f(t);
        if (!std::isfinite(ft)) break;
        if ((ft < 0.0) != (f_prev < 0.0)) {
          if (std::abs(t - 0.5) < best) {
            best = std::abs(t - 0.5);
            lo = std::min(t, t_prev);
            hi = std::max(t, t_prev);
            f0 = dir > 0 ? f_prev : ft;
            f1 = dir > 0 ? ft : f_prev;
          }
          break;
        }
        t_prev = t;
        f_prev = ft;
      }
    }
  return best <= 1.0;
}

std::array<Vec2, 2> LineRefiner::perpendicular(const End& u, const End& v, double max_off) {
  // The perpendicular through the chord's middle, as far as the locus can be (max_off) on either
  // side.
  const Vec2 mid = lerp(u.v.p, v.v.p, 0.5);
  const double chord = std::hypot(v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y);
  const double k = std::min(max_off, chord) / chord;
  const Vec2 across{-(v.v.p.y - u.v.p.y) * k, (v.v.p.x - u.v.p.x) * k};
  return {Vec2{mid.x - across.x, mid.y - across.y}, Vec2{mid.x + across.x, mid.y + across.y}};
}

bool LineRefiner::within_chord(Vec2 p, const End& u, const End& v, double max_off) {
  // Between the two ends along the chord, so the line keeps its order.
  const double dx = v.v.p.x - u.v.p.x, dy = v.v.p.y - u.v.p.y;
  const double along = ((p.x - u.v.p.x) * dx + (p.y - u.v.p.y) * dy) / (dx * dx + dy * dy);
  // (Not at an end either: a turning point solved onto a tripoint or a crossing adds nothing.)
  if (!(along > 1e-4 && along < 1.0 - 1e-4)) return false;
  // And near the chord (max_off: see between()).
  const double off = std::abs((p.x - u.v.p.x) * dy - (p.y - u.v.p.y) * dx) / std::hypot(dx, dy);
  return off <= max_off;
}

bool LineRefiner::checked(Vec2 p, int32_t a, int32_t b, const End& u, const End& v, double max_off, End& out) const {
  return within_chord(p, u, v, max_off) && verified(p, a, b, u, v, out);
}

bool LineRefiner::verified(Vec2 p, int32_t a, int32_t b, const End& u, const End& v, End& out) const {
  const OwnerIndex::Hit ha = index_.nearest_of(p, a, u.v.site_a), hb = index_.nearest_of(p, b, u.v.site_b);
  if (ha.site == kNoSite || hb.site == kNoSite) return false;
  const double residual = std::abs(ha.cost - hb.cost);
  if (!(residual <= 4.0 * ftol_)) return false;
  const OwnerIndex::Hit third = index_.nearest_third(p, a, b, hb.cost);
  if (third.site != kNoSite && third.cost < 0.5 * (ha.cost + hb.cost) - 4.0 * ftol_ - residual) return false;
  out = End{};
  out.v = vertex_between(p, ha, hb);
  // A second site of a side tied with the first here (a turning point's, or the two edges at a
  // coast's vertex), so that the stretches on both sides read as the same sites.
  auto tie = [&](const OwnerIndex::Hit& h, std::array<int32_t, 4> sites) {
    for (const int32_t s : sites) {
      if (s == kNoSite || s == h.site) continue;
      Vec2 g;
      if (std::abs(cost(p, s, g) - h.cost) <= 4.0 * ftol_) return s;
    }
    return kNoSite;
  };
  out.alt_a = tie(ha, {u.v.site_a, u.alt_a, v.v.site_a, v.alt_a});
  out.alt_b = tie(hb, {u.v.site_b, u.alt_b, v.v.site_b, v.alt_b});
  set_normal(out);
  return true;
}

bool LineRefiner::across_arc(const End& u, const End& v, int32_t a, int32_t b, double max_off, End& out) const {
  const std::array<Vec2, 2> ends = perpendicular(u, v, max_off);
  const Vec2 p0 = ends[0], p1 = ends[1];  // (named, not bound: lambdas capture them)
  const int32_t s = arc_site(u.v.arc != 0 ? u.v : v.v);
  Vec2 g;
  auto f = [&](double t) { return arc_value(lerp(p0, p1, t), s, g); };
  auto with_slope = [&](double t) {
    const double value = f(t);
    return std::pair{value, g.x * (p1.x - p0.x) + g.y * (p1.y - p0.y)};
  };
  const double f0 = f(0.0), f1 = f(1.0);
  if (!std::isfinite(f0) || !std::isfinite(f1) || (f0 < 0.0) == (f1 < 0.0)) return false;
  const double t = newton_then_bracket(f, with_slope, 0.5, 0.0, 1.0, f0 < 0.0, ftol_);
  return checked_arc(lerp(p0, p1, t), u.v.arc != 0 ? u.v.arc : v.v.arc, s, a, b, u, v, max_off, out);
}

double LineRefiner::curve_value(const BoundaryVertex& e, Vec2 p, Vec2& gradient) const {
  if (e.arc != 0) return arc_value(p, arc_site(e), gradient);
  // The locus d_a / w_a = d_b / w_b, also a little beyond a reach (where the costs are infinite):
  // the junction with an arc lies on that reach.
  const SiteMetric& m = index_.metric();
  Vec2 ga, gb;
  const double wa = index_.weight_of(e.site_a), wb = index_.weight_of(e.site_b);
  const double value = m.distance_and_gradient(p, e.site_a, ga) / wa - m.distance_and_gradient(p, e.site_b, gb) / wb;
  gradient = Vec2{ga.x / wa - gb.x / wb, ga.y / wa - gb.y / wb};
  return value;
}

bool LineRefiner::arc_junction(const End& u, const End& v, int32_t a, int32_t b, double max_off, End& out) const {
  // Where the curves of the two ends meet (the locus and an arc, or two arcs): Newton's method on
  // both from the chord's middle.
  const Vec2 mid = lerp(u.v.p, v.v.p, 0.5);
  const double chord = std::hypot(v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y);
  Vec2 p = mid;
  for (int iter = 0; iter < kNewtonIterations; ++iter) {
    Vec2 gu, gv;
    const double fu = curve_value(u.v, p, gu), fv = curve_value(v.v, p, gv);
    if (!std::isfinite(fu) || !std::isfinite(fv)) return false;
    if (std::max(std::abs(fu), std::abs(fv)) <= ftol_) {
      const End& arc = u.v.arc != 0 ? u : v;
      return checked_arc(p, arc.v.arc, arc_site(arc.v), a, b, u, v, max_off, out);
    }
    const double det = gu.x * gv.y - gu.y * gv.x;
    if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return false;
    p = Vec2{p.x - (fu * gv.y - fv * gu.y) / det, p.y - (gu.x * fv - gv.x * fu) / det};
    if (!(std::hypot(p.x - mid.x, p.y - mid.y) <= chord)) return false;
  }
  return false;
}

bool LineRefiner::checked_arc(Vec2 p, int8_t arc, int32_t site, int32_t a, int32_t b, const End& u, const End& v,
                              double max_off, End& out) const {
  if (!within_chord(p, u, v, max_off)) return false;
  Vec2 g;
  const double ds = index_.metric().distance_and_gradient(p, site, g);
  const double residual = std::abs(ds - index_.reach_of(site));
  if (!(residual <= 4.0 * ftol_)) return false;
  // The arc's owner wins inside it, the other owner beyond, and no third owner comes between.
  const int32_t other_owner = arc == 1 ? b : a;
  const OwnerIndex::Hit other = index_.nearest_of(p, other_owner, arc == 1 ? u.v.site_b : u.v.site_a);
  if (other.site == kNoSite) return false;
  const double c_s = ds / index_.weight_of(site);
  if (!(c_s <= other.cost + 4.0 * ftol_)) return false;
  const double between = std::max(c_s, other.cost);
  const OwnerIndex::Hit third = index_.nearest_third(p, a, b, between);
  if (third.site != kNoSite && third.cost < between - 4.0 * ftol_ - residual) return false;
  out = End{};
  out.v = BoundaryVertex{
      p,        arc == 1 ? site : other.site,   arc == 1 ? other.site : site,   0.5 * (ds + other.distance),
      residual, arc == 1 ? ds : other.distance, arc == 1 ? other.distance : ds, arc};
  set_normal(out);
  return true;
}

namespace {

// The line's vertices at the same point as the one before them gone (line_tools::unrepeated),
// with their zero-length segments' bows; their flags kept on the one left. A line that would be
// left with fewer than two vertices stays as it is.
void drop_repeated_vertices(BoundaryLine& line) {
  std::vector<BoundaryVertex>& v = line.vertices;
  const std::vector<size_t> keep = unrepeated(v);
  if (keep.size() == v.size() || keep.size() < 2) return;
  const bool bows = line.bows.size() + 1 == v.size();
  std::vector<BoundaryVertex> kept;
  std::vector<Bow> kept_bows;
  for (size_t k = 0; k < keep.size(); ++k) {
    kept.push_back(v[keep[k]]);
    for (size_t i = keep[k] + 1; i < (k + 1 < keep.size() ? keep[k + 1] : v.size()); ++i) {
      kept.back().on_barrier = kept.back().on_barrier || v[i].on_barrier;
      kept.back().tie = kept.back().tie || v[i].tie;
    }
    // (The segment into it from where the one before is.)
    if (bows && k > 0) kept_bows.push_back(line.bows[keep[k] - 1]);
  }
  v = std::move(kept);
  if (bows) line.bows = std::move(kept_bows);
}

}  // namespace

void finish_lines(std::vector<BoundaryLine>& lines, const LineRefiner* refiner, double tol, BoundaryStats& stats,
                  int threads, const SegmentReuse<BoundaryVertex, LineRefiner::Added>* reuse, BoundaryMemo* record) {
  // The refinement runs over blocks of segments of every line at once: a coast's few long lines
  // would leave threads idle were each line one task. Blocks are cut by position alone, and each
  // segment is refined on its own, so the result does not depend on the threads.
  constexpr size_t kBlock = 256;
  struct Block {
    size_t line, i0, i1;
    std::vector<BoundaryVertex> out;
    LineRefiner::Added added;
    std::vector<Bow> bows;
    std::vector<BoundaryMemo::Entry> kept;  // with `record`: its segments
    int64_t taken = 0;                      // of which taken from `reuse`
  };
  std::vector<Block> blocks;
  for (size_t k = 0; k < lines.size(); ++k)
    for (size_t i = 0; i + 1 < lines[k].vertices.size(); i += kBlock)
      blocks.push_back(Block{k, i, std::min(i + kBlock, lines[k].vertices.size() - 1), {}, {}, {}, {}, 0});
  if (refiner != nullptr)
    detail::parallel_for(threads, static_cast<int64_t>(blocks.size()), [&](int64_t k, int) {
      Block& b = blocks[static_cast<size_t>(k)];
      const BoundaryLine& line = lines[b.line];
      const std::vector<BoundaryVertex>& v = line.vertices;
      if (reuse == nullptr && record == nullptr) {
        refiner->refine_segments(line.owner_a, line.owner_b, v, b.i0, b.i1, b.out, b.added, &b.bows);
        return;
      }
      // Segment by segment: a valid earlier one taken, runs of the others refined together.
      std::vector<LineRefiner::Segment> each;
      b.taken = refine_with_memo(
          reuse, record != nullptr ? &b.kept : nullptr, line.owner_a, line.owner_b, v, b.i0, b.i1, b.out, b.bows,
          b.added, [&](size_t i, size_t j, std::vector<RefinedRun<LineRefiner::Added>>& runs) {
            each.clear();
            refiner->refine_segments(line.owner_a, line.owner_b, v, i, j, b.out, b.added, &b.bows, &each);
            for (const LineRefiner::Segment& sg : each) runs.push_back({sg.out_end, sg.bows_end, sg.added});
          });
    });
  if (refiner != nullptr && record != nullptr)
    for (Block& b : blocks) {
      record->append(std::move(b.kept), b.i0 == 0 ? &lines[b.line].vertices.front() : nullptr, b.out, b.bows);
      record->taken += b.taken;
    }
  if (refiner != nullptr) {
    std::vector<std::vector<BoundaryVertex>> joined(lines.size());
    for (size_t k = 0; k < lines.size(); ++k)
      if (!lines[k].vertices.empty()) joined[k].push_back(lines[k].vertices.front());
    for (BoundaryLine& line : lines) line.bows.clear();
    for (Block& b : blocks) {
      joined[b.line].insert(joined[b.line].end(), b.out.begin(), b.out.end());
      lines[b.line].bows.insert(lines[b.line].bows.end(), b.bows.begin(), b.bows.end());
    }
    for (size_t k = 0; k < lines.size(); ++k)
      if (!lines[k].vertices.empty()) lines[k].vertices = std::move(joined[k]);
    // A loop that repeats another line is dropped, and so is what its refinement added.
    const std::vector<bool> drop =
        refiner->tolerance() > 0.0 ? repeated_loops(lines, *refiner) : std::vector<bool>(lines.size(), false);
    for (const Block& b : blocks) {
      if (drop[b.line]) continue;
      stats.turning_points += b.added.turning_points;
      stats.arc_points += b.added.arc_points;
      stats.locus.merge(b.added.locus);
      stats.arcs.merge(b.added.arcs);
    }
    size_t kept = 0;
    for (size_t k = 0; k < lines.size(); ++k)
      if (!drop[k]) {
        if (kept != k) lines[kept] = std::move(lines[k]);
        ++kept;
      }
    stats.repeated_loops += static_cast<int64_t>(lines.size() - kept);
    lines.resize(kept);
  }
  std::vector<int64_t> before(lines.size());
  std::vector<double> simplified(lines.size(), 0.0);
  detail::parallel_for(threads, static_cast<int64_t>(lines.size()), [&](int64_t k, int) {
    const auto i = static_cast<size_t>(k);
    BoundaryLine& line = lines[i];
    drop_repeated_vertices(line);
    before[i] = static_cast<int64_t>(line.vertices.size());
    if (tol > 0.0 && line.vertices.size() > 2) {
      std::vector<Vec2> pts;
      pts.reserve(line.vertices.size());
      for (const auto& v : line.vertices) pts.push_back(v.p);
      std::vector<BoundaryVertex> kept;
      for (size_t j : simplify_indices(pts, tol)) kept.push_back(line.vertices[j]);
      if (kept.size() != line.vertices.size()) {
        line.vertices = std::move(kept);
        line.bows.clear();  // (the simplified segments' bows are not measured)
        if (refiner != nullptr) simplified[i] = refiner->measure(line.owner_a, line.owner_b, line.vertices);
      }
    }
    line.vertices.shrink_to_fit();
  });
  stats.vertices = stats.vertices_before_simplify = stats.tie_vertices = 0;
  stats.max_residual = stats.max_residual_on_land = 0.0;
  for (size_t i = 0; i < lines.size(); ++i) {
    stats.vertices_before_simplify += before[i];
    stats.simplified_midpoint = std::max(stats.simplified_midpoint, simplified[i]);
  }
  for (const BoundaryLine& line : lines) {
    for (const BoundaryVertex& v : line.vertices) {
      double& worst = on_land(v) ? stats.max_residual_on_land : stats.max_residual;
      worst = std::max(worst, v.residual);
      LineResidual& r = v.arc != 0 ? stats.arcs : stats.locus;
      double& at = on_land(v) ? r.max_vertex_on_land : r.max_vertex;
      at = std::max(at, v.residual);
      stats.tie_vertices += v.tie ? 1 : 0;
    }
    stats.vertices += static_cast<int64_t>(line.vertices.size());
  }
}
}  // namespace rv::boundary_stages
