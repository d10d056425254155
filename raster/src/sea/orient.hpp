// The exact orientation predicate the distance by sea decides every visibility with.
//
// orient(a, b, c) is the sign of the determinant (b - a) x (c - a): +1 when c lies to the left of
// the directed line a -> b (counter-clockwise turn), -1 to the right, 0 exactly on it. Exact for
// every finite double input (no rounding can flip or zero the sign): a floating-point filter
// answers almost every call; the rest are decided by exact expansion arithmetic. Inputs whose
// products overflow (coordinates beyond about 1e150) are outside the contract.
// Pure, thread-safe.
#pragma once

#include <cmath>

#include "rv/field/seeds.hpp"

namespace rv::sea {

// The exact evaluation, for the calls the filter below cannot decide.
int orient_exact(const Vec2& a, const Vec2& b, const Vec2& c);

inline int orient(const Vec2& a, const Vec2& b, const Vec2& c) {
  const double l = (b.x - a.x) * (c.y - a.y);
  const double r = (b.y - a.y) * (c.x - a.x);
  const double det = l - r;
  // The rounded determinant's error is below (3 + 16 eps) eps (|l| + |r|) (Shewchuk 1997, the
  // "ccwerrboundA" bound); the factor here is larger and safe.
  const double bound = 4.0e-16 * (std::abs(l) + std::abs(r));
  if (det > bound) return 1;
  if (det < -bound) return -1;
  // A difference of two doubles is zero exactly when they are equal, so a factor that rounds to
  // zero is zero: both products are then exactly zero, and so is the determinant.
  if ((b.x == a.x || c.y == a.y) && (b.y == a.y || c.x == a.x)) return 0;
  if (c == b || c == a) return 0;  // a repeated point: common where a path ends at a vertex
  return orient_exact(a, b, c);
}

// Where c lies on the line through a and b (orient(a, b, c) == 0 assumed), compared along the
// line's dominant axis: -1 before a, 0 at a, +1 after a towards b (a != b). Exact.
int along(const Vec2& a, const Vec2& b, const Vec2& c);

}  // namespace rv::sea
