// Tie regions by sea (BoundaryVertex::tie): behind a barrier vertex equidistant from two owners,
// where both owners' paths bend last at that vertex, their costs are equal to the bit over an
// area. No root of the costs' difference marks such an area's edge (it is 0 throughout), so the
// crossings (lines/boundaries.cpp) and the refinement (lines/line_refine.cpp) find the edge by bisection on
// whether the two owners tie. Internal to rv_raster; pure functions of their arguments.
#pragma once

#include <cmath>
#include <cstdint>

#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"

namespace rv::boundary_stages {

// Whether owners' hits `a` and `b` at p tie over an area: equal finite costs, both paths
// bending last at one barrier vertex (SiteMetric::last_bend). (Costs equal only on a line --
// a cell centre on a bisector -- are no tie region: the paths there do not share a bend.)
inline bool ties(const SiteMetric& m, Vec2 p, const OwnerIndex::Hit& a, const OwnerIndex::Hit& b) {
  if (a.site == kNoSite || b.site == kNoSite || a.cost != b.cost || !std::isfinite(a.cost)) return false;
  const int32_t bend = m.last_bend(p, a.site);
  return bend >= 0 && bend == m.last_bend(p, b.site);
}

// The last parameter from `in` (tied(in) true) towards `out` (false) where tied() holds, by
// bisection to the last bit of the parameter.
template <class Tied>
double last_tied(Tied&& tied, double in, double out) {
  for (int i = 0; i < 64; ++i) {
    const double mid = 0.5 * (in + out);
    if (mid == in || mid == out) break;
    (tied(mid) ? in : out) = mid;
  }
  return in;
}

// On a cell-centre segment from parameter t0 to t1, `tied_at(t)` saying whether the two owners
// tie at its point t: where exactly one end ties, the last tied parameter from that end (the
// region's edge); else NaN.
template <class Tied>
double tie_edge_on(Tied&& tied_at, double t0, double t1) {
  const bool tied0 = tied_at(t0), tied1 = tied_at(t1);
  if (tied0 == tied1) return std::nan("");
  return last_tied(tied_at, tied0 ? t0 : t1, tied0 ? t1 : t0);
}

}  // namespace rv::boundary_stages
