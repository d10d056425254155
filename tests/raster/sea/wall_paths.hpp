// Closed forms of the distance by sea round one vertical wall, written apart from the engines:
// what the field's and the lines' tests check against.
#pragma once

#include <algorithm>
#include <cmath>

#include "rv/field/seeds.hpp"

namespace rv::test {

inline double dist(Vec2 a, Vec2 b) { return std::hypot(a.x - b.x, a.y - b.y); }

// Whether the open segment p-q crosses the vertical wall x = wx, y in (y0, y1) (touching its ends
// is not crossing).
inline bool crosses_wall(Vec2 p, Vec2 q, double wx, double y0, double y1) {
  if ((p.x - wx) * (q.x - wx) >= 0) return false;
  const double y = p.y + (q.y - p.y) * (wx - p.x) / (q.x - p.x);
  return y > y0 && y < y1;
}

// The path length from seed s to x round a vertical wall from a to b: straight when the wall is
// not in the way, else over the nearer end.
inline double wall_path(Vec2 s, Vec2 x, Vec2 a, Vec2 b) {
  if (!crosses_wall(s, x, a.x, a.y, b.y)) return dist(s, x);
  return std::min(dist(s, a) + dist(a, x), dist(s, b) + dist(b, x));
}

}  // namespace rv::test
