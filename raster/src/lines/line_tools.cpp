#include "lines/line_tools.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"

namespace rv::line_tools {

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

void FieldRows::set_strip(const NearestField& strip) {
  const Window w = strip.site.window();
  set_strip(strip, w.row0, w.row0 + w.height);
}

void FieldRows::set_strip(const NearestField& strip, int64_t row0, int64_t row1) {
  const Window w = strip.site.window();
  if (w.col0 != 0 || w.width != strip.site.grid().width || !(strip.distance.window() == w) || row0 < w.row0 ||
      row1 > w.row0 + w.height || row0 >= row1 || (started_ && (w.width != width_ || row0 != strip_row1_)))
    throw Error(ErrorKind::invalid_argument, "strips of a field must be whole rows of the grid, in order");
  if (!started_) carry_row0_ = row0;
  started_ = true;
  strip_ = &strip;
  width_ = w.width;
  strip_base_ = w.row0;
  strip_row0_ = row0;
  strip_row1_ = row1;
}

void FieldRows::keep_from(int64_t from) {
  from = std::clamp(from, carry_row0_, strip_row1_);
  const auto n = static_cast<size_t>((strip_row1_ - from) * width_);
  std::vector<int32_t> site(n);
  std::vector<float> distance(n);
  for (int64_t r = from; r < strip_row1_; ++r) {
    const auto at = static_cast<size_t>((r - from) * width_);
    std::copy_n(site_row(r), width_, site.begin() + static_cast<std::ptrdiff_t>(at));
    std::copy_n(distance_row(r), width_, distance.begin() + static_cast<std::ptrdiff_t>(at));
  }
  carry_site_ = std::move(site);
  carry_distance_ = std::move(distance);
  carry_row0_ = from;
  strip_row0_ = strip_row1_;  // the strip in hand is now all carried (or dropped)
  strip_ = nullptr;
}

void check_metric(const NearestField& field, const SiteMetric& metric) {
  // A projected geodesic field needs a metric that locates grid positions on the ellipsoid,
  // and only such a field may use one.
  const bool located_metric = metric.kind() == SiteMetric::Kind::located_geodesic;
  if (static_cast<bool>(field.geolocator) != located_metric)
    throw Error(ErrorKind::invalid_argument,
                field.geolocator ? "a field of a projected geodesic grid needs a LocatedGeodesicSiteMetric"
                                 : "a LocatedGeodesicSiteMetric measures fields of projected geodesic grids only");
  const bool geodesic_metric = metric.kind() != SiteMetric::Kind::planar;
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

double cell_metric(const GridSpec& g, const SiteMetric& m) {
  const int64_t c = g.width / 2, r = g.height / 2;
  const double d = m.point_distance(Vec2{g.centre_x(c), g.centre_y(r)}, Vec2{g.centre_x(c) + g.res, g.centre_y(r)});
  return d > 0.0 && std::isfinite(d) ? d : g.res;
}

std::vector<int32_t> owner_of_sites(const SeedSet& seeds) {
  std::vector<int32_t> owner(seeds.sites().size());
  for (size_t i = 0; i < owner.size(); ++i) owner[i] = seeds.site_owner(static_cast<int32_t>(i));
  return owner;
}

CrsScale::CrsScale(const SiteMetric& m, Vec2 p0, double res) {
  lonlat = m.kind() == SiteMetric::Kind::geodesic;
  lat0 = p0.y;
  // A step small against any line's curvature, large against the distances' rounding.
  const double h = 1e-3 * res;
  const double sx = m.point_distance(p0, Vec2{p0.x + h, p0.y}) / h, sy = m.point_distance(p0, Vec2{p0.x, p0.y + h}) / h;
  at0 = Vec2{sx > 0.0 && std::isfinite(sx) ? sx : 1.0, sy > 0.0 && std::isfinite(sy) ? sy : 1.0};
}

Vec2 CrsScale::at(Vec2 p) const {
  if (!lonlat) return at0;
  constexpr double kRad = 3.14159265358979323846 / 180.0;
  const double c0 = std::cos(lat0 * kRad), c = std::cos(p.y * kRad);
  return Vec2{c0 > 1e-12 ? at0.x * c / c0 : at0.x, at0.y};
}

double CrsScale::offset(Vec2 p, double f, Vec2 g) const {
  const Vec2 s = at(p);
  const double n = std::hypot(g.x / s.x, g.y / s.y);
  if (!std::isfinite(n) || !(n > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return std::abs(f) / n;
}

Bow CrsScale::bow(Vec2 p, Vec2 q, double f, Vec2 g) const {
  const Vec2 mid{0.5 * (p.x + q.x), 0.5 * (p.y + q.y)};
  const Vec2 s = at(mid);
  const Vec2 gm{g.x / s.x, g.y / s.y};  // per metric unit
  const double gg = gm.x * gm.x + gm.y * gm.y;
  const Vec2 d{(q.x - p.x) * s.x, (q.y - p.y) * s.y};
  Bow b;
  b.length = std::hypot(d.x, d.y);
  if (!std::isfinite(f) || !(gg > 0.0) || !std::isfinite(gg) || !(b.length > 0.0)) return b;
  const Vec2 step{-f * gm.x / gg, -f * gm.y / gg};  // from the middle to the locus, metric units
  b.left = (step.x * -d.y + step.y * d.x) / b.length;
  return b;
}

bool onto_domain_edge(const SiteMetric& m, Vec2 end, double radius, double ftol, const std::function<double(Vec2)>& f,
                      const std::function<bool(Vec2)>& accept, Vec2& out, const Vec2* away, double slope) {
  auto ahead = [&](Vec2 p) {
    return away == nullptr || (p.x - end.x) * (away->x - end.x) + (p.y - end.y) * (away->y - end.y) < 0.0;
  };
  std::vector<int32_t> edges;
  m.domain_edges_near(end, radius, edges);
  // The edges nearest first, by the least distance any point of theirs can have from `end` (its
  // segment's, less its bow): once that exceeds the nearest point found, no later edge has a
  // nearer one. Among thousands of islands' edges within the radius of a coarse grid's cells, the
  // point is found on the first few, and each edge searched costs the owners' costs at least
  // twice. (An edge beyond the radius has no point usable.)
  struct Near {
    double least;
    int32_t edge;
  };
  std::vector<Near> near;
  near.reserve(edges.size());
  for (const int32_t edge : edges) {
    Vec2 a, b;
    if (!m.domain_edge_ends(edge, a, b)) continue;
    const double least = segment_distance(end, a, b) - m.domain_edge_bow(edge);
    if (least <= radius) near.push_back(Near{least, edge});
  }
  std::sort(near.begin(), near.end(),
            [](const Near& u, const Near& v) { return u.least < v.least || (u.least == v.least && u.edge < v.edge); });
  double best_gap = std::numeric_limits<double>::infinity();
  // (Not at the edges' ends themselves: a point of one edge within a micrometre of its end, on a
  // geodesic edge, has no reliable direction towards that vertex, and its visibility can say it
  // sees through the land behind the vertex. A level through the vertex itself is taken at the
  // vertex, below; one crossing the coast within a millionth of the edge of it, not through it, is
  // missed and the line's end left where it was.)
  constexpr double kEnd = 1e-6;
  for (const Near& n : near) {
    if (n.least > best_gap) break;
    const int32_t edge = n.edge;
    // Each edge is searched only near `end`: within four radii each way of the foot of `end` on
    // the edge's chord (a geodesic edge's parameter is not the chord's fraction, hence the
    // margin). A coast's edge may be far longer than a cell, and the locus can cross it again
    // far away; every crossing the window leaves out lies beyond the radius. A short edge is
    // searched whole.
    // (One end of the edge may lie on other land, where no point of it is at sea, as a boom's end
    // on an island: the window is then taken from the edge's ends, and the samples there are
    // skipped. An edge with both ends on other land -- a land border two polygons share -- is
    // left out: it is seldom at sea between, and a point of an edge under land costs a search.)
    Vec2 e0, e1;
    const bool at_sea0 = m.domain_edge_point(edge, kEnd, end, e0),
               at_sea1 = m.domain_edge_point(edge, 1.0 - kEnd, end, e1);
    if (!at_sea0 && !at_sea1) continue;
    if (!(at_sea0 && at_sea1) && !m.domain_edge_ends(edge, e0, e1)) continue;
    const Vec2 d{e1.x - e0.x, e1.y - e0.y};
    const double len = std::hypot(d.x, d.y);
    double lo = kEnd, hi = 1.0 - kEnd;
    if (len > 1.5 * radius) {
      const double foot = std::clamp(((end.x - e0.x) * d.x + (end.y - e0.y) * d.y) / (len * len), 0.0, 1.0);
      const double w = 1.5 * radius / len;
      lo = std::max(lo, foot - w);
      hi = std::min(hi, foot + w);
    }
    // A root between the window's ends p0 and p1 would be within |f(p0)| / slope of p0 and within
    // |f(p1)| / slope of p1 along the way between them; where that way is open (the edge not
    // under other land) and its length falls short of the sum, there is none. (The margin covers
    // the points' moves off the edge into the sea, micrometres.) On a coast both of whose owners'
    // seeds lie along it (the coasts also the seeds) f keeps one sign along almost every edge,
    // and every one was sampled in vain.
    if (std::isfinite(slope) && slope > 0.0) {
      Vec2 p0, p1;
      if (m.domain_edge_point(edge, lo, end, p0) && m.domain_edge_point(edge, hi, end, p1)) {
        const double f0 = f(p0), f1 = f(p1);
        if (std::isfinite(f0) && std::isfinite(f1) && (f0 < 0.0) == (f1 < 0.0) && f0 != 0.0 && f1 != 0.0 &&
            std::abs(f0) + std::abs(f1) > slope * 1.01 * m.point_distance(p0, p1) + ftol && m.open_between(p0, p1))
          continue;
      }
    }
    // (A few samples across the window: it is short against the curves of the loci a cell holds.)
    constexpr int kSamples = 16;
    // (f, of value fa at ta, reaches 0 by tb only within `slope` of their distance; on the edge's
    // chord, with room for a geodesic edge's bow.)
    auto may_reach = [&](double ta, double fa, double tb) {
      return !(std::isfinite(slope) && slope > 0.0) ||
             std::abs(fa) <= 1.5 * slope * m.point_distance(lerp(e0, e1, ta), lerp(e0, e1, tb)) + ftol;
    };
    const int samples = std::max(kSamples, static_cast<int>(std::ceil(kSamples * (hi - lo) * len / radius)));
    auto usable = [&](Vec2 p) {
      const double gap = std::hypot(p.x - end.x, p.y - end.y);
      return gap <= radius && ahead(p) && accept(p) && m.open_between(end, p);
    };
    nearest_root_along([&](double t, Vec2& p) { return m.domain_edge_point(edge, t, end, p); }, lo, hi, samples, f,
                       ftol, end, usable, best_gap, out, may_reach);
    // A locus through the edge's end vertex itself (an island's corner, a boom's tip on a bisector)
    // changes sign between two edges, or between a boom's two faces, and no bracket along one face
    // holds it: the vertex is taken where f is zero there to the root's tolerance. (The vertex
    // itself, not a point a hair along the edge: its direction from `end` is exact.)
    for (const auto& [t, inside] : {std::pair{0.0, lo <= kEnd}, std::pair{1.0, hi >= 1.0 - kEnd}}) {
      Vec2 v;
      if (!inside || !m.domain_edge_point(edge, t, end, v)) continue;
      const double fv = f(v), gap = std::hypot(v.x - end.x, v.y - end.y);
      if (std::abs(fv) <= ftol && gap < best_gap && usable(v)) {
        best_gap = gap;
        out = v;
      }
    }
  }
  return std::isfinite(best_gap);
}

bool nearest_root_along(const std::function<bool(double, Vec2&)>& at, double lo, double hi, int samples,
                        const std::function<double(Vec2)>& f, double ftol, Vec2 near,
                        const std::function<bool(Vec2)>& accept, double& best_gap, Vec2& out,
                        const std::function<bool(double ta, double fa, double tb)>& may_reach) {
  // |f| at a root, in ftol, beyond which the bracket closed on a jump (a converged root is within
  // ftol, or a bracket of 1e-15 of the step across a slope of at most 2).
  constexpr double kJump = 1e3;
  auto along = [&](double t) {
    Vec2 p;
    return at(t, p) ? f(p) : std::numeric_limits<double>::quiet_NaN();
  };
  auto sample = [&](int k) { return lo + (hi - lo) * static_cast<double>(k) / samples; };
  bool found = false;
  // A sign change by a jump -- f far from 0 where the bracket closes -- is no root (the costs by
  // sea along a coast part where a sightline grazes a vertex); a root beside it, in the same
  // bracket, is looked for on either side of it (to three jumps deep).
  auto try_between = [&](double ta0, double fa0, double tb0, double fb0) {
    struct Bracket {
      double ta, fa, tb, fb;
      int depth;
    };
    // (Each jump puts two brackets for one: seven at most, three deep.)
    std::array<Bracket, 8> todo;
    size_t n = 0;
    todo[n++] = Bracket{ta0, fa0, tb0, fb0, 0};
    while (n > 0) {
      const Bracket k = todo[--n];
      if (!std::isfinite(k.fa) || !std::isfinite(k.fb) || (k.fa <= 0.0) == (k.fb <= 0.0)) continue;
      const double t = root_in(along, k.ta, k.tb - k.ta, k.fa, k.fb, ftol);
      Vec2 p;
      if (!at(t, p)) continue;
      if (!(std::abs(f(p)) <= kJump * ftol)) {
        const double d = 1e-9 * (k.tb - k.ta);
        if (k.depth < 3 && t - d > k.ta && t + d < k.tb) {
          todo[n++] = Bracket{k.ta, k.fa, t - d, along(t - d), k.depth + 1};
          todo[n++] = Bracket{t + d, along(t + d), k.tb, k.fb, k.depth + 1};
        }
        continue;
      }
      const double gap = std::hypot(p.x - near.x, p.y - near.y);
      if (gap < best_gap && accept(p)) {
        out = p;
        best_gap = gap;
        found = true;
      }
    }
  };
  // Where f is undefined (the edge under other land) at one sample and not at the next, the
  // stretch at sea is taken from where it begins (bisected to a four-thousandth of the step): a
  // root between that and the sample (a locus meeting the coast beside the other land) is not
  // left out for the sample under land.
  auto sea_end = [&](double t_land, double t_sea) {
    for (int k = 0; k < 12; ++k) {
      const double t = 0.5 * (t_land + t_sea);
      (std::isfinite(along(t)) ? t_sea : t_land) = t;
    }
    return t_sea;
  };
  double t0 = sample(0), f0 = along(t0);
  for (int k = 1; k <= samples; ++k) {
    const double t1 = sample(k), f1 = along(t1);
    if (std::isfinite(f0) != std::isfinite(f1)) {
      if (may_reach && !(std::isfinite(f0) ? may_reach(t0, f0, t1) : may_reach(t1, f1, t0))) {
        t0 = t1;
        f0 = f1;
        continue;
      }
      const double te = std::isfinite(f0) ? sea_end(t1, t0) : sea_end(t0, t1);
      const double fe = along(te);
      if (std::isfinite(f0))
        try_between(t0, f0, te, fe);
      else
        try_between(te, fe, t1, f1);
    } else {
      try_between(t0, f0, t1, f1);
    }
    t0 = t1;
    f0 = f1;
  }
  return found;
}

}  // namespace rv::line_tools

namespace rv {

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

}  // namespace rv
