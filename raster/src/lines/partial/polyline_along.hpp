// Positions along polylines, for the partial-effect lines (rv/lines/partial_effect.hpp): a
// point's nearest position on a polyline, the stretch between two positions, and points at a
// fraction of a polyline's length. Planar in the polyline's own coordinates (CRS units).
//
// Internal to rv_raster. Thread safety: pure functions.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include "rv/field/seeds.hpp"

namespace rv::polyline_along {

// A position along a polyline: segment k, fraction t of it (and, from project, its distance to
// the point projected, CRS units).
struct Along {
  size_t k = 0;
  double t = 0.0, distance = std::numeric_limits<double>::infinity();
  double at() const { return static_cast<double>(k) + t; }
};

// The position of `pts` nearest p (the first of equals). `pts`: at least two points.
Along project(const std::vector<Vec2>& pts, Vec2 p);

// The length of a polyline (CRS units).
double length(const std::vector<Vec2>& pts);

// The stretch of polyline `pts` from position u to position v (either direction), its ends
// included; on a closed line (last vertex == first) the shorter of the two ways round.
std::vector<Vec2> stretch(const std::vector<Vec2>& pts, bool closed, Along u, Along v);

// The cumulative lengths of a polyline's vertices from its first (the first 0).
std::vector<double> cumulative(const std::vector<Vec2>& pts);

// The point at fraction s in [0, 1] of a polyline's length (`cum`: cumulative(pts)).
Vec2 at_fraction(const std::vector<Vec2>& pts, const std::vector<double>& cum, double s);

// The two ways from a to b along the boundary of the rectangle [x0, x1] x [y0, y1] (CRS units;
// a and b on it, within `eps`): anticlockwise first, then clockwise, each from a to b with the
// corners between. Empty where a or b is not on the boundary.
std::vector<std::vector<Vec2>> round_rectangle(Vec2 a, Vec2 b, double x0, double y0, double x1, double y1, double eps);

}  // namespace rv::polyline_along
