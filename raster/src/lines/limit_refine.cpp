// Stage 4a of distance-limit lines (limit_stages.hpp, LimitRefiner): the chords between the
// vertices found on cell edges made to follow the level d = D -- its corners added exactly, its
// arcs to the line tolerance -- and every final segment measured.
//
// Why. The level of a distance is made of arcs of radius D round points (a basepoint, a coast's
// salient vertex), straight offsets of segments, and corners where two sites' arcs meet (a bay's
// mouth). A chord of length c across an arc of radius D cuts inside it by about c^2 / 8D: on a
// 0.01 degree grid a 12 nmi limit's chords are metres inside the arc, and the areas bounded by it
// inherit that. A chord across a corner cuts it by up to a cell.
//
// How. The level's distance has a gradient of unit length, so the chord's midpoint is |d - D|
// from the level, measured with the stretch's own site (the vertices on cell edges are checked
// against every site; between them the site is the one both ends have). A chord above the
// tolerance is cut into as many pieces as a circle of that sagitta needs (the sagitta falls
// with the square of the chord, so k pieces leave 1/k^2 of it), each new point moved onto the
// level along the site's gradient (Newton's method: from a few millimetres off an arc of
// kilometres, one step is exact to nanometres), and the pieces are measured and cut again where
// the curvature was not a circle's.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "lines/limit_stages.hpp"
#include "lines/line_tools.hpp"

namespace rv::limit_stages {

using namespace line_tools;

namespace {

constexpr int kMaxDepth = 16;
constexpr int kMaxPieces = 64;
constexpr double kCornerReach = 64.0;  // how far from a chord its corner is sought, in chords
constexpr int kNewtonSteps = 6;
// A measured midpoint is cut from this share of the tolerance: where the curvature changes
// along the chord (a straight offset running into an arc) the worst point lies off the middle, by
// up to an eighth more than the midpoint shows.
constexpr double kSplitAt = 0.85;
// The pieces are cut for a sagitta of this share of the tolerance (below kSplitAt: a piece is
// then rarely cut again).
constexpr double kPieceAt = 0.75;

}  // namespace

LimitRefiner::LimitRefiner(const Target& t, double tol, const CrsScale& scale) : t_(t), tol_(tol), scale_(scale) {}

double LimitRefiner::radius(int32_t site) const {
  return t_.owner == kOwnedEdge ? t_.grid.reaches->reach_of(site) : t_.D;
}

double LimitRefiner::level(Vec2 p, int32_t site, Vec2& gradient) const {
  return t_.grid.metric.distance_and_gradient(p, site, gradient) - radius(site);
}

double LimitRefiner::level_near(Vec2 p, int32_t s1, bool any, int32_t& site, Vec2& gradient) const {
  if (!any) {
    site = s1;
    return level(p, site, gradient);
  }
  const OwnerIndex::Hit h = t_.at(p);
  site = h.site;
  return h.site == kNoSite ? std::numeric_limits<double>::quiet_NaN() : h.distance - t_.D;
}

bool LimitRefiner::onto_level(Vec2 start, int32_t site, double max_move, LimitVertex& out) const {
  Vec2 p = start;
  for (int step = 0; step < kNewtonSteps; ++step) {
    Vec2 g;
    const double f = level(p, site, g);
    if (!std::isfinite(f)) return false;
    if (std::abs(f) <= t_.grid.ftol) {
      out = LimitVertex{p, site, std::abs(f)};
      return true;
    }
    const double gg = g.x * g.x + g.y * g.y;
    if (!(gg > 0.0) || !std::isfinite(gg)) return false;
    p = Vec2{p.x - f * g.x / gg, p.y - f * g.y / gg};
    if (!(std::hypot(p.x - start.x, p.y - start.y) <= max_move)) return false;
    // The level of a distance curves by at most 1 / radius, and the step's length in metric
    // units is at most |f| times the ratio of the grid's two scales: what the step leaves is
    // below half the curvature times its square. Where that is within the root tolerance the
    // point is on the level without measuring it again, the bound its residual. (By sea the
    // level curves round a bend's vertex at the radius of the path's last leg, shorter than D:
    // measured again.)
    if (!t_.grid.metric.straight()) continue;
    const Vec2 sc = scale_.at(p);
    const double stretch = std::max(sc.x, sc.y) / std::min(sc.x, sc.y);
    const double left = 0.5 * (f * stretch) * (f * stretch) / radius(site);
    if (left <= t_.grid.ftol) {
      out = LimitVertex{p, site, left};
      return true;
    }
  }
  return false;
}

bool LimitRefiner::across(Vec2 u, Vec2 v, Vec2 at, LimitVertex& out) const {
  // The level across the chord at `at`, within a chord's length either side, by the nearest site
  // at every position (searched): where no single site holds the stretch, a point sliding along
  // one site's gradient could land beside an end and never shorten the chord.
  const double dx = v.x - u.x, dy = v.y - u.y;
  const Vec2 p0{at.x + dy, at.y - dx}, p1{at.x - dy, at.y + dx};
  auto f = [&](double s) {
    const OwnerIndex::Hit h = t_.at(lerp(p0, p1, s));
    return h.site == kNoSite ? std::numeric_limits<double>::infinity() : h.distance - t_.D;
  };
  const double f0 = f(0.0), f1 = f(1.0);
  if (!std::isfinite(f0) || !std::isfinite(f1) || (f0 < 0.0) == (f1 < 0.0)) return false;
  const Vec2 p = lerp(p0, p1, find_root(f, f0, f1, t_.grid.ftol, 1e-15));
  const OwnerIndex::Hit h = t_.at(p);
  if (h.site == kNoSite) return false;
  out = LimitVertex{p, h.site, std::abs(h.distance - t_.D)};
  return out.residual <= 4.0 * t_.grid.ftol;
}

bool LimitRefiner::corner(const End& u, const End& v, End& out) const {
  const double chord = std::hypot(v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y);
  Vec2 q;
  // (Two circles meeting at a shallow angle make a notch narrower than a cell and many cells
  // deep: its corner is sought well beyond the chord.)
  const double reach = t_.owner == kOwnedEdge ? chord : kCornerReach * chord;
  if (!arcs_meet(t_.grid.metric, u.v.site, radius(u.v.site), v.v.site, radius(v.v.site), lerp(u.v.p, v.v.p, 0.5), reach,
                 t_.grid.ftol, 30, q))
    return false;
  // Between the ends along the chord (not at one), and no third site within its level there.
  const double dx = v.v.p.x - u.v.p.x, dy = v.v.p.y - u.v.p.y;
  const double along = ((q.x - u.v.p.x) * dx + (q.y - u.v.p.y) * dy) / (dx * dx + dy * dy);
  // (The owned edge's corners are taken wherever the two arcs meet near the chord, as its
  // regions were always bounded.)
  if (t_.owner != kOwnedEdge && !(along > 1e-4 && along < 1.0 - 1e-4)) return false;
  const OwnerIndex::Hit h = t_.at(q);
  const double deepest = h.distance - t_.D;  // (the owned edge's hit is already d - reach)
  if (!(deepest >= -t_.grid.ftol)) return false;
  out = End{LimitVertex{q, u.v.site, std::abs(deepest)}, v.v.site};
  return true;
}

void LimitRefiner::between(const End& u, const End& v, int depth, std::vector<End>& out, LineResidual& r,
                           int64_t& corners) const {
  const double chord = std::hypot(v.v.p.x - u.v.p.x, v.v.p.y - u.v.p.y);
  if (!(chord > 0.0) || u.v.site == kNoSite || v.v.site == kNoSite) return;
  // The stretch's site: the one both ends have; where they differ, the corner of the two, or,
  // where none checks out (two edges of one coast equally near over the wedge of their shared
  // vertex, where no corner is defined; a third site between them), the nearest site at each
  // point, searched.
  int32_t s1 = u.v.site, s2 = kNoSite;
  if (u.v.site == v.alt) {
  } else if (u.alt != kNoSite && u.alt == v.v.site) {
    s1 = u.alt;
  } else if (u.v.site != v.v.site) {
    End c;
    // (With no tolerance the lines stay on cell edges, but for the owned edge's corners, which
    // its regions were always bounded by.)
    if (depth < kMaxDepth && (tol_ > 0.0 || t_.owner == kOwnedEdge) && corner(u, v, c)) {
      ++corners;
      ++r.added;
      between(u, c, depth + 1, out, r, corners);
      out.push_back(c);
      between(c, v, depth + 1, out, r, corners);
      return;
    }
    s2 = v.v.site;
  }
  const Vec2 mid = lerp(u.v.p, v.v.p, 0.5);
  Vec2 g;
  int32_t at = kNoSite;
  const bool any = s2 != kNoSite;
  const double off = std::abs(level_near(mid, s1, any, at, g));
  if (tol_ > 0.0 && depth < kMaxDepth && std::isfinite(off) && off > kSplitAt * tol_) {
    // Pieces for a circle's sagitta, a little finer than it needs; a corner's chord is halved.
    const int k =
        s2 == kNoSite ? std::clamp(static_cast<int>(std::ceil(std::sqrt(off / (kPieceAt * tol_)))), 2, kMaxPieces) : 2;
    const Vec2 sc = scale_.at(mid);
    const double off_crs = off / std::min(sc.x, sc.y);  // (metric units to CRS units)
    std::vector<End> pts;
    pts.reserve(static_cast<size_t>(k) + 1);
    pts.push_back(u);
    bool ok = true;
    for (int i = 1; i < k && ok; ++i) {
      LimitVertex lv;
      const Vec2 at_chord = lerp(u.v.p, v.v.p, static_cast<double>(i) / k);
      // (By sea a point of the chord is at most about the middle's offset from the level, which
      // on a tight arc round a bend's vertex may exceed a piece's length.)
      const double reach = t_.grid.metric.straight() ? chord / k : std::max(chord / k, 2.0 * off_crs);
      ok = any ? across(u.v.p, v.v.p, at_chord, lv) : onto_level(at_chord, s1, reach, lv);
      if (ok) pts.push_back(End{lv, kNoSite});
    }
    if (ok) {
      pts.push_back(v);
      r.added += k - 1;
      for (size_t i = 1; i < pts.size(); ++i) {
        between(pts[i - 1], pts[i], depth + 1, out, r, corners);
        if (i + 1 < pts.size()) out.push_back(pts[i]);
      }
      return;
    }
  }
  r.add(off, mid.x, mid.y, tol_ > 0.0 ? tol_ : std::numeric_limits<double>::infinity());
}

std::vector<LimitVertex> LimitRefiner::refine(const std::vector<LimitVertex>& v, LineResidual& r,
                                              int64_t& corners) const {
  if (v.size() < 2) return v;
  std::vector<LimitVertex> out{v.front()};
  refine_segments(v, 0, v.size() - 1, out, r, corners);
  return out;
}

void LimitRefiner::refine_segments(const std::vector<LimitVertex>& v, size_t i0, size_t i1,
                                   std::vector<LimitVertex>& result, LineResidual& r, int64_t& corners,
                                   std::vector<Segment>* each) const {
  std::vector<End> out;
  for (size_t i = i0; i < i1; ++i) {
    // Each segment measured on its own, then merged (the same sums and maxima, the first worst).
    LineResidual s;
    int64_t c = 0;
    out.clear();
    between(End{v[i], kNoSite}, End{v[i + 1], kNoSite}, 0, out, s, c);
    for (const End& e : out) result.push_back(e.v);
    result.push_back(v[i + 1]);
    r.merge(s);
    corners += c;
    if (each != nullptr) each->push_back(Segment{result.size(), Measured{s, c}});
  }
}

double LimitRefiner::measure(const std::vector<LimitVertex>& v) const {
  double worst = 0.0;
  for (size_t i = 1; i < v.size(); ++i) {
    const Vec2 mid = lerp(v[i - 1].p, v[i].p, 0.5);
    const OwnerIndex::Hit h = t_.at(mid);
    const double off = std::abs(h.distance - t_.D);
    if (std::isfinite(off)) worst = std::max(worst, off);
  }
  return worst;
}

}  // namespace rv::limit_stages
