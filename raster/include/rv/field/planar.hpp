// Planar (Euclidean) distance between a cell centre and a site, in the engines' local frame.
//
// The local frame is the grid origin (xmin, ymax) moved to (0, 0): see GridSpec::local_x. Sites
// are translated once into this frame (LocalSite) so that every distance is a difference of two
// moderate doubles, whatever the magnitude of the CRS coordinates.
//
// key() returns the squared distance. Every method (brute force, scans, exact) compares the same
// key computed by the same inline function, so agreement between methods is bit-for-bit and a
// tie is a true tie of the computed values. Pure, thread-safe.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "rv/field/grid.hpp"
#include "rv/field/seeds.hpp"

namespace rv {

struct LocalSite {
  double ax, ay;    // first end (or the point), local frame
  double dx, dy;    // b - a (0 for points)
  double inv_len2;  // 1 / |b - a|^2, 0 for points
  double bx() const { return ax + dx; }
  double by() const { return ay + dy; }
};

inline LocalSite to_local(const Site& s, const GridSpec& g) {
  LocalSite l;
  l.ax = s.a.x - g.xmin;
  l.ay = s.a.y - g.ymax;
  const double bx = s.b.x - g.xmin;
  const double by = s.b.y - g.ymax;
  l.dx = bx - l.ax;
  l.dy = by - l.ay;
  const double len2 = l.dx * l.dx + l.dy * l.dy;
  l.inv_len2 = (s.kind == SiteKind::segment && len2 > 0.0) ? 1.0 / len2 : 0.0;
  return l;
}

std::vector<LocalSite> to_local(const SeedSet& seeds, const GridSpec& g);

// Squared distance from (px, py) to the site (point: to a; segment: to the nearest point of the
// closed segment). For area sites the caller never asks (they are resolved by interior spans).
inline double planar_key(double px, double py, const LocalSite& s) {
  double t = ((px - s.ax) * s.dx + (py - s.ay) * s.dy) * s.inv_len2;
  t = std::clamp(t, 0.0, 1.0);
  const double ex = px - (s.ax + t * s.dx);
  const double ey = py - (s.ay + t * s.dy);
  return ex * ex + ey * ey;
}

inline double planar_distance_from_key(double key) { return std::sqrt(key); }

}  // namespace rv
