// The exact orientation predicate the distance by sea decides every visibility with.
//
// orient(a, b, c) is the sign of the determinant (b - a) x (c - a): +1 when c lies to the left of
// the directed line a -> b (counter-clockwise turn), -1 to the right, 0 exactly on it. Exact for
// every finite double input (no rounding can flip or zero the sign): a floating-point filter
// answers almost every call; the rest are decided by exact expansion arithmetic. Inputs whose
// products overflow (coordinates beyond about 1e150) are outside the contract.
// Pure, thread-safe.
#pragma once

#include <algorithm>
#include <cfloat>
#include <cmath>

#include "rv/field/seeds.hpp"

namespace rv::sea {

// The exact evaluation, for the calls the filter below cannot decide.
int orient_exact(const Vec2& a, const Vec2& b, const Vec2& c);

// The sign of an orientation determinant l - r (l and r its two products, as orient() forms them)
// when the rounded difference lies farther from zero than its rounding error plus `beyond` (a
// reading's own allowance: 0 in the plane); else 0, for an exact test to decide.
inline int filtered_sign(double l, double r, double beyond = 0.0) {
  const double det = l - r;
  // The rounded determinant's error is below (3 + 16 eps) eps (|l| + |r|) (Shewchuk 1997, the
  // "ccwerrboundA" bound); the factor here is larger and safe.
  const double bound = 4.0e-16 * (std::abs(l) + std::abs(r)) + beyond;
  return det > bound ? 1 : det < -bound ? -1 : 0;
}

inline int orient(const Vec2& a, const Vec2& b, const Vec2& c) {
  const double l = (b.x - a.x) * (c.y - a.y);
  const double r = (b.y - a.y) * (c.x - a.x);
  if (const int sign = filtered_sign(l, r)) return sign;
  // A difference of two doubles is zero exactly when they are equal, so a factor that rounds to
  // zero is zero: both products are then exactly zero, and so is the determinant.
  if ((b.x == a.x || c.y == a.y) && (b.y == a.y || c.x == a.x)) return 0;
  if (c == b || c == a) return 0;  // a repeated point: common where a path ends at a vertex
  return orient_exact(a, b, c);
}

// How far a point computed from p and q (a foot of a perpendicular, a crossing) may lie off where
// it belongs in the plane: a few units in the last place of their coordinates.
inline double rounding_slack(const Vec2& p, const Vec2& q) {
  const double m = std::max(std::max(std::abs(q.x), std::abs(q.y)), std::max(std::abs(p.x - q.x), std::abs(p.y - q.y)));
  return 64.0 * DBL_EPSILON * m;
}

// The distance from q to the line through a and b (a != b), rounded: for tolerances only.
inline double line_distance(const Vec2& a, const Vec2& b, const Vec2& q) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  return std::abs(dx * (q.y - a.y) - dy * (q.x - a.x)) / std::hypot(dx, dy);
}

// Where c lies on the line through a and b (orient(a, b, c) == 0 assumed), compared along the
// line's dominant axis: -1 before a, 0 at a, +1 after a towards b (a != b). Exact.
int along(const Vec2& a, const Vec2& b, const Vec2& c);

}  // namespace rv::sea
