// turning_points (rv/report/turning_points.hpp): where a boundary line's pair of controlling basepoints
// changes.
//
// Each vertex of a line gets each side's controlling element: a position (a basepoint seed, or a
// coastline vertex its edge's foot has reached: the two edges at a vertex are one element) or an
// edge's interior. Between two vertices whose elements differ, the change is bracketed on the
// locus: a point across the chord at parameter t (the root of the two sides' adjusted distances
// along the chord's perpendicular), its elements compared with the first vertex's, the bracket
// halved until it is 2^-26 of the chord. Two changes between the same vertices are found one after
// the other.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <tuple>
#include <vector>

#include "lines/line_tools.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/parallel.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/report/turning_points.hpp"

namespace rv {

using namespace line_tools;

namespace {

constexpr int kBisections = 26;  // 2^-26 of the chord: 0.8 micrometres of a 50 m one

// A side's controlling element at a point.
struct Element {
  enum Kind { none, position, interior };
  Kind kind = none;
  Vec2 at;                 // the position (kind position)
  int32_t site = kNoSite;  // the site (kind interior), or the one naming the position
  int32_t via = -1;        // by sea: the path's last bend (SiteMetric::last_bend), -1 straight
};

class Finder {
 public:
  // `arcs`: the index an arc's basepoints are found with (true distances: a plain index); null,
  // `index` itself.
  Finder(const OwnerIndex& index, const Geolocator* geolocator, double tol, const OwnerIndex* arcs = nullptr)
      : index_(index),
        arcs_(arcs != nullptr ? *arcs : index),
        metric_(index.metric()),
        geolocator_(geolocator),
        tol_(tol) {}

  // A seed position where the metric places positions (the grid's CRS on projected geodesic grids).
  Vec2 placed(Vec2 v) const {
    if (geolocator_ == nullptr) return v;
    Vec2 x;
    geolocator_->to_grid(&v.x, &v.y, &x.x, &x.y, 1);
    return x;
  }

  // By sea the element is the site's with the path's last bend: the locus keeps its form (a
  // bisector, a hyperbola branch round that bend, a parabola) while both stay.
  Element element(Vec2 p, int32_t site) const {
    if (site == kNoSite) return {};
    const Site& s = metric_.seeds().sites()[static_cast<size_t>(site)];
    const int32_t via = metric_.straight() ? -1 : metric_.last_bend(p, site);
    if (s.kind == SiteKind::area) return {Element::interior, p, site, via};
    if (s.kind == SiteKind::point) return {Element::position, placed(s.a), site, via};
    const Vec2 foot = metric_.nearest_point(p, site);
    for (const Vec2 end : {placed(s.a), placed(s.b)})
      if (metric_.point_distance(foot, end) <= tol_) return {Element::position, end, site, via};
    return {Element::interior, foot, site, via};
  }

  bool same(const Element& x, const Element& y) const {
    if (x.kind != y.kind || x.via != y.via) return false;
    if (x.kind == Element::interior) return x.site == y.site;
    return x.kind == Element::none || metric_.point_distance(x.at, y.at) <= tol_;
  }

  // The locus point across the chord u-v at parameter t (the chord's point where no root is
  // bracketed along its perpendicular), and each side's element there.
  struct At {
    Vec2 p;
    Element a, b;
    int32_t site_a = kNoSite, site_b = kNoSite;
  };
  At at(Vec2 u, Vec2 v, double t, int32_t owner_a, int32_t owner_b) const {
    const Vec2 c = lerp(u, v, t);
    const Vec2 across{-(v.y - u.y), v.x - u.x};  // the chord's length either way
    const Vec2 p0{c.x - across.x, c.y - across.y}, p1{c.x + across.x, c.y + across.y};
    auto f = [&](double s) {
      const Vec2 q = lerp(p0, p1, s);
      return index_.nearest_of(q, owner_a).cost - index_.nearest_of(q, owner_b).cost;
    };
    At out;
    out.p = c;
    const double f0 = f(0.0), f1 = f(1.0);
    if (std::isfinite(f0) && std::isfinite(f1) && (f0 < 0.0) != (f1 < 0.0))
      out.p = lerp(p0, p1, find_root(f, f0, f1, 1e-3 * tol_, 1e-13));
    const OwnerIndex::Hit ha = index_.nearest_of(out.p, owner_a), hb = index_.nearest_of(out.p, owner_b);
    out.site_a = ha.site;
    out.site_b = hb.site;
    out.a = element(out.p, ha.site);
    out.b = element(out.p, hb.site);
    return out;
  }

  // The limit line's point across the chord u-v at parameter t (d - D = 0 along the
  // perpendicular; the chord's point where no root is bracketed), and its element.
  struct OnLimit {
    Vec2 p;
    Element e;
  };
  OnLimit on_limit(Vec2 u, Vec2 v, double t, int32_t owner, double D) const {
    const Vec2 c = lerp(u, v, t);
    const Vec2 across{-(v.y - u.y), v.x - u.x};
    const Vec2 p0{c.x - across.x, c.y - across.y}, p1{c.x + across.x, c.y + across.y};
    auto hit = [&](Vec2 q) { return owner == 0 ? arcs_.nearest(q) : arcs_.nearest_of(q, owner); };
    auto f = [&](double s) { return hit(lerp(p0, p1, s)).distance - D; };
    OnLimit out{c, {}};
    const double f0 = f(0.0), f1 = f(1.0);
    if (std::isfinite(f0) && std::isfinite(f1) && (f0 < 0.0) != (f1 < 0.0))
      out.p = lerp(p0, p1, find_root(f, f0, f1, 1e-3 * tol_, 1e-13));
    out.e = element(out.p, hit(out.p).site);
    return out;
  }

  // The arcs of one limit line.
  std::vector<LimitArc> arcs(const LimitLine& line) const {
    std::vector<LimitArc> out;
    const size_t n = line.vertices.size();
    if (n == 0) return out;
    std::vector<Element> e(n);
    for (size_t i = 0; i < n; ++i) e[i] = element(line.vertices[i].p, line.vertices[i].site);
    auto start = [&](Vec2 p, const Element& el) {
      LimitArc arc;
      arc.from = p;
      arc.basepoint = basepoint(p, el);
      arc.edge = el.kind == Element::interior;
      return arc;
    };
    auto close = [&](LimitArc& arc, Vec2 p, const Element& el) {
      arc.to = p;
      if (arc.edge) arc.edge_to = metric_.nearest_point(p, el.site);
      out.push_back(arc);
    };
    LimitArc current = start(line.vertices[0].p, e[0]);
    Element cur = e[0];
    for (size_t i = 0; i + 1 < n; ++i) {
      if (same(cur, e[i + 1])) continue;
      // Bisect on the line between vertices i and i + 1 for the change.
      const Vec2 u = line.vertices[i].p, v = line.vertices[i + 1].p;
      double lo = 0.0, hi = 1.0;
      OnLimit at_hi{v, e[i + 1]};
      for (int k = 0; k < kBisections; ++k) {
        const double mid = 0.5 * (lo + hi);
        const OnLimit m = on_limit(u, v, mid, line.owner, line.distance);
        if (same(m.e, cur)) {
          lo = mid;
        } else {
          hi = mid;
          at_hi = m;
        }
      }
      // Bisection finds where the element changes along the chord; the change on the line is
      // where both elements are at distance D (two circles, or a circle and a parallel, meet),
      // which a notch between two discs can put beyond the chord's perpendicular: Newton's method
      // on the two sites' distances from there.
      at_hi.p = corner(at_hi.p, cur.site, at_hi.e.site, line.distance, std::hypot(v.x - u.x, v.y - u.y));
      close(current, at_hi.p, cur);
      current = start(at_hi.p, at_hi.e);
      cur = at_hi.e;
      if (!same(cur, e[i + 1])) {  // a second change before the next vertex: from there on
        close(current, v, cur);
        current = start(v, e[i + 1]);
        cur = e[i + 1];
      }
    }
    close(current, line.vertices[n - 1].p, cur);
    // A ring's last arc goes on into its first when both are drawn from the same element.
    if (line.closed && out.size() > 1 && same(cur, e[0])) {
      out.front().from = out.back().from;
      out.front().basepoint = out.back().basepoint;
      out.pop_back();
    }
    return out;
  }

  // The point near `p` at distance D from both sites (Newton's method on their gradients), or
  // `p` where it does not converge within a few chords of it.
  Vec2 corner(Vec2 p, int32_t s1, int32_t s2, double D, double chord) const {
    if (s1 == kNoSite || s2 == kNoSite || s1 == s2) return p;
    Vec2 q;
    return arcs_meet(metric_, s1, D, s2, D, p, 4.0 * chord, 1e-3 * tol_, 20, q) ? q : p;
  }

  Basepoint basepoint(Vec2 p, const Element& e) const {
    Basepoint b;
    b.site = e.site;
    b.at = e.kind == Element::interior ? metric_.nearest_point(p, e.site) : e.at;
    b.distance = e.site == kNoSite ? 0.0 : metric_.distance(p, e.site);
    if (e.via >= 0) {
      b.via = e.via;
      b.via_at = metric_.bend_position(e.via);
    }
    return b;
  }

  // Whether two arc vertices lie on arcs of one reach (their arc sites' features reach as far).
  bool same_reach(const BoundaryVertex& u, const BoundaryVertex& v) const {
    const int32_t su = u.arc == 1 ? u.site_a : u.site_b, sv = v.arc == 1 ? v.site_a : v.site_b;
    return index_.reach_of(su) == index_.reach_of(sv);
  }

  // Appends the turning point strictly between arc vertices i and i + 1 of `line` where the arc's
  // basepoint changes from `before` to `after` (bisection on the arc, d = reach, then the corner
  // where both are at the reach), as Finder::arcs does on limit lines.
  void along_arc(const BoundaryLine& line, size_t i, const Element& before, const Element& after,
                 std::vector<TurningPoint>& out) const {
    const BoundaryVertex& u = line.vertices[i];
    const BoundaryVertex& v = line.vertices[i + 1];
    const int8_t side = u.arc;
    const int32_t owner = side == 1 ? line.owner_a : line.owner_b;
    const double D = index_.reach_of(side == 1 ? u.site_a : u.site_b);
    double lo = 0.0, hi = 1.0;
    OnLimit at_hi{v.p, after};
    for (int k = 0; k < kBisections; ++k) {
      const double mid = 0.5 * (lo + hi);
      const OnLimit m = on_limit(u.p, v.p, mid, owner, D);
      if (same(m.e, before)) {
        lo = mid;
      } else {
        hi = mid;
        at_hi = m;
      }
    }
    TurningPoint tp;
    tp.kind = TurningPoint::Kind::turn;
    tp.p = corner(at_hi.p, before.site, at_hi.e.site, D, std::hypot(v.p.x - u.p.x, v.p.y - u.p.y));
    tp.next_vertex = i + 1;
    tp.arc = side;
    std::vector<Basepoint>& list = side == 1 ? tp.a : tp.b;
    list.push_back(basepoint(tp.p, before));
    if (at_hi.e.kind != Element::none && !same(at_hi.e, before)) list.push_back(basepoint(tp.p, at_hi.e));
    out.push_back(std::move(tp));
  }

  // Appends the turning points strictly between vertices i and i + 1 of `line`.
  void between(const BoundaryLine& line, size_t i, const Element& ea0, const Element& eb0, const Element& ea1,
               const Element& eb1, std::vector<TurningPoint>& out) const {
    const Vec2 u = line.vertices[i].p, v = line.vertices[i + 1].p;
    Element ca = ea0, cb = eb0;
    double lo = 0.0;
    for (int guard = 0; guard < 4 && !(same(ca, ea1) && same(cb, eb1)); ++guard) {
      double hi = 1.0;
      At at_hi{};
      bool have_hi = false;
      for (int k = 0; k < kBisections; ++k) {
        const double mid = 0.5 * (lo + hi);
        const At m = at(u, v, mid, line.owner_a, line.owner_b);
        if (same(m.a, ca) && same(m.b, cb)) {
          lo = mid;
        } else {
          hi = mid;
          at_hi = m;
          have_hi = true;
        }
      }
      TurningPoint tp;
      tp.kind = TurningPoint::Kind::turn;
      tp.next_vertex = i + 1;
      if (!have_hi) {
        // The change is at the next vertex itself (a turning point the refinement placed there).
        tp.p = v;
        at_hi.a = ea1;
        at_hi.b = eb1;
        hi = 1.0;
      } else {
        tp.p = at_hi.p;
      }
      for (const auto& [before, after, side] : {std::tuple{&ca, &at_hi.a, &tp.a}, std::tuple{&cb, &at_hi.b, &tp.b}}) {
        side->push_back(basepoint(tp.p, *before));
        if (!same(*before, *after)) side->push_back(basepoint(tp.p, *after));
      }
      out.push_back(std::move(tp));
      ca = at_hi.a;
      cb = at_hi.b;
      lo = hi;
    }
  }

 private:
  const OwnerIndex& index_;
  const OwnerIndex& arcs_;
  const SiteMetric& metric_;
  const Geolocator* geolocator_;
  double tol_;
};

// A Finder whose positions agree to 1e-7 of the vertex spacing of `line` (the largest of its
// first steps: the refinement's added points are closer together than a cell).
template <class Vertex>
Finder finder_for(const std::vector<Vertex>& line, const OwnerIndex& index, const Geolocator* geolocator,
                  const OwnerIndex* arcs = nullptr) {
  double spacing = 0.0;
  for (size_t i = 1; i < line.size() && i <= 16; ++i)
    spacing = std::max(spacing, index.metric().point_distance(line[i - 1].p, line[i].p));
  return Finder(index, geolocator, std::max(spacing, 1e-12) * 1e-7, arcs);
}

}  // namespace

std::vector<LimitArcs> limit_arcs(const LimitResult& limits, const OwnerIndex& index, const Geolocator* geolocator,
                                  int threads) {
  std::vector<LimitArcs> out(limits.lines.size());
  if (limits.lines.empty()) return out;
  const Finder finder = finder_for(limits.lines.front().vertices, index, geolocator);
  detail::parallel_for(resolve_threads(threads), static_cast<int64_t>(limits.lines.size()), [&](int64_t k, int) {
    const auto li = static_cast<size_t>(k);
    out[li].line = li;
    out[li].arcs = finder.arcs(limits.lines[li]);
  });
  return out;
}

std::vector<TurningLine> turning_points(const BoundaryResult& boundaries, const OwnerIndex& index,
                                        const Geolocator* geolocator, int threads) {
  std::vector<TurningLine> out(boundaries.lines.size());
  if (boundaries.lines.empty()) return out;
  // Along a reach's arc the basepoint is its site's by true distance (the reach ends just there).
  std::unique_ptr<const OwnerIndex> plain;
  if (index.adjusted()) plain = std::make_unique<const OwnerIndex>(index.metric(), OwnerIndex::Measure::plain);
  const Finder finder = finder_for(boundaries.lines.front().vertices, index, geolocator, plain.get());
  detail::parallel_for(resolve_threads(threads), static_cast<int64_t>(boundaries.lines.size()), [&](int64_t k, int) {
    const auto li = static_cast<size_t>(k);
    const BoundaryLine& line = boundaries.lines[li];
    TurningLine& tl = out[li];
    tl.owner_a = line.owner_a;
    tl.owner_b = line.owner_b;
    tl.closed = line.closed;
    tl.line = li;
    const size_t n = line.vertices.size();
    if (n == 0) return;
    // On an arc (a reach ends) only the arc's side controls the line: the other has no element.
    std::vector<Element> ea(n), eb(n);
    const auto& vs = line.vertices;
    for (size_t i = 0; i < n; ++i) {
      if (vs[i].arc != 2) ea[i] = finder.element(vs[i].p, vs[i].site_a);
      if (vs[i].arc != 1) eb[i] = finder.element(vs[i].p, vs[i].site_b);
    }
    // The stretch after vertex i follows an arc when both its ends lie on one side's arc.
    auto arc_after = [&](size_t i) -> int8_t {
      return i + 1 < n && vs[i].arc != 0 && vs[i + 1].arc != 0 ? vs[i + 1].arc : 0;
    };
    auto add_side = [&](std::vector<Basepoint>& side, Vec2 p, const Element& e) {
      if (e.kind != Element::none) side.push_back(finder.basepoint(p, e));
    };
    auto vertex_point = [&](size_t i, TurningPoint::Kind kind) {
      TurningPoint tp;
      tp.kind = kind;
      tp.p = vs[i].p;
      tp.next_vertex = i + 1;
      add_side(tp.a, tp.p, ea[i]);
      add_side(tp.b, tp.p, eb[i]);
      tp.arc = arc_after(i);
      return tp;
    };
    tl.points.push_back(vertex_point(0, line.closed ? TurningPoint::Kind::start : TurningPoint::Kind::end));
    for (size_t i = 0; i + 1 < n; ++i) {
      if (finder.same(ea[i], ea[i + 1]) && finder.same(eb[i], eb[i + 1])) continue;
      if (vs[i].arc == 0 && vs[i + 1].arc == 0) {
        finder.between(line, i, ea[i], eb[i], ea[i + 1], eb[i + 1], tl.points);
        continue;
      }
      if (vs[i].arc != 0 && vs[i].arc == vs[i + 1].arc && finder.same_reach(vs[i], vs[i + 1])) {
        // Along one reach's arc its basepoint changes: found on the arc.
        finder.along_arc(line, i, vs[i].arc == 1 ? ea[i] : eb[i], vs[i].arc == 1 ? ea[i + 1] : eb[i + 1], tl.points);
        continue;
      }
      // The arc meets the locus or another arc: at the junction the refinement placed (it bears
      // the arc's flag: vertex i + 1 where an arc starts, else vertex i).
      const size_t m = vs[i].arc != 0 ? i : i + 1;
      if (m == 0 || (m == n - 1 && !line.closed)) continue;  // a line's end: a turning point already
      TurningPoint tp;
      tp.kind = TurningPoint::Kind::turn;
      tp.p = vs[m].p;
      tp.next_vertex = m + 1;
      for (const auto& [before, after, side] :
           {std::tuple{&ea[i], &ea[i + 1], &tp.a}, std::tuple{&eb[i], &eb[i + 1], &tp.b}}) {
        add_side(*side, tp.p, *before);
        if (!finder.same(*before, *after)) add_side(*side, tp.p, *after);
      }
      tp.arc = arc_after(m);
      tl.points.push_back(std::move(tp));
    }
    if (!line.closed && n > 1) {
      TurningPoint last = vertex_point(n - 1, TurningPoint::Kind::end);
      last.next_vertex = n;
      tl.points.push_back(std::move(last));
    }
  });
  return out;
}

}  // namespace rv
