// A crossing where a reach ends (Feature::reach) rather than where two owners' costs meet: the
// point of the reach's arc on a cell-centre segment (boundaries.cpp's place_crossings). Internal
// to rv_raster; a pure function of its arguments.
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>

#include "lines/line_tools.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/lines/boundaries.hpp"

namespace rv::boundary_stages {

using line_tools::lerp;
using line_tools::newton_then_bracket;

// Where the costs of owners x (nearest towards p0) and y (towards p1) jump between two positions
// of segment p0-p1 instead of crossing: a site's reach ends there (x's nearest inside it
// reaching its reach) or begins (y's). The arc point solves d_s = reach_s on the segment by
// Newton's method with the site's gradient; the vertex has that site on its side (arc 1: x's,
// 2: y's, in x-y order) and the other side's nearest beyond. `between`: the larger of the two
// winners' costs there, which a third owner must beat to come between. site kNoSite: no reach
// explains the jump (left as it was).
struct ArcPoint {
  int32_t site = kNoSite;
  double t = 0.0, between = 0.0;
  BoundaryVertex vertex;
};

template <class NearestOf>
ArcPoint reach_arc(const OwnerIndex& index, NearestOf&& nearest_of, Vec2 p0, Vec2 p1, int32_t x, int32_t y, double t0,
                   double t1, double t, double ftol) {
  ArcPoint out;
  const SiteMetric& m = index.metric();
  const double step = 1e-7;
  const Vec2 inside = lerp(p0, p1, std::max(t0, t - step)), beyond = lerp(p0, p1, std::min(t1, t + step));
  const OwnerIndex::Hit xin = nearest_of(inside, x, nullptr), yin = nearest_of(beyond, y, nullptr);
  if (xin.site == kNoSite || yin.site == kNoSite) return out;
  const Vec2 p = lerp(p0, p1, t);
  const double gx = std::abs(m.distance(p, xin.site) - index.reach_of(xin.site));
  const double gy = std::abs(m.distance(p, yin.site) - index.reach_of(yin.site));
  if (!std::isfinite(std::min(gx, gy))) return out;
  const bool x_side = gx <= gy;
  const int32_t s = x_side ? xin.site : yin.site;
  const double r = index.reach_of(s);
  Vec2 grad;
  auto g = [&](double u) { return m.distance_and_gradient(lerp(p0, p1, u), s, grad) - r; };
  auto g_slope = [&](double u) {
    const double value = g(u);
    return std::pair{value, grad.x * (p1.x - p0.x) + grad.y * (p1.y - p0.y)};
  };
  // x's site is inside its reach towards p0; y's towards p1.
  const double lo = std::max(t0, t - 1e-6), hi = std::min(t1, t + 1e-6);
  out.t = newton_then_bracket(g, g_slope, t, lo, hi, x_side, ftol);
  const Vec2 q = lerp(p0, p1, out.t);
  const double ds = m.distance(q, s);
  // The other side's nearest where it wins: beyond the arc for y, inside it for x.
  const OwnerIndex::Hit other = x_side ? nearest_of(beyond, y, nullptr) : nearest_of(inside, x, nullptr);
  const double d_other = m.distance(q, other.site);
  const double c_s = ds / index.weight_of(s), c_other = d_other / index.weight_of(other.site);
  out.site = s;
  out.between = std::max(c_s, c_other);
  out.vertex = BoundaryVertex{q,
                              x_side ? s : other.site,
                              x_side ? other.site : s,
                              0.5 * (ds + d_other),
                              std::abs(ds - r),
                              x_side ? ds : d_other,
                              x_side ? d_other : ds,
                              static_cast<int8_t>(x_side ? 1 : 2)};
  return out;
}

}  // namespace rv::boundary_stages
