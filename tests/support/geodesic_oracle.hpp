// What the tests of the distance by sea on the ellipsoid check against, written apart from the
// engines: GeographicLib's geodesics, lengths and azimuths on WGS84, in longitude/latitude.
#pragma once

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>

#include <cmath>

#include "rv/field/metric.hpp"
#include "rv/field/seeds.hpp"

namespace rv::test {

inline const GeographicLib::Geodesic& wgs84() { return GeographicLib::Geodesic::WGS84(); }

inline MetricSpec geodesic_metric() {
  MetricSpec m;
  m.kind = MetricSpec::geodesic;
  return m;
}

// Metres between two (lon, lat) points.
inline double metres(Vec2 a, Vec2 b) {
  double s;
  wgs84().Inverse(a.y, a.x, b.y, b.x, s);
  return s;
}

// Which side of the geodesic from a through b the point c lies: +1 left, -1 right (from the
// azimuths at a: c is left when the way to it leaves a at a smaller azimuth).
inline int side(Vec2 a, Vec2 b, Vec2 c) {
  double s, azi_b, azi_c, back;
  wgs84().Inverse(a.y, a.x, b.y, b.x, s, azi_b, back);
  wgs84().Inverse(a.y, a.x, c.y, c.x, s, azi_c, back);
  const double d = std::remainder(azi_c - azi_b, 360.0);
  return d < 0 ? 1 : d > 0 ? -1 : 0;
}

// Whether the geodesics p-q and a-b cross (each pair of ends on either side of the other).
inline bool crosses(Vec2 p, Vec2 q, Vec2 a, Vec2 b) {
  return side(a, b, p) * side(a, b, q) < 0 && side(p, q, a) * side(p, q, b) < 0;
}

// The nearest point of the geodesic segment a-b from x and its distance in metres: a golden-
// section search of the arc length along GeographicLib's GeodesicLine (the distance along a
// segment of tens of kilometres is convex from points within hundreds of kilometres), to
// nanometres. Written apart from the engines' interception iteration.
struct Foot {
  Vec2 at;
  double metres;
};
inline Foot segment_foot(Vec2 x, Vec2 a, Vec2 b) {
  const GeographicLib::GeodesicLine line = wgs84().InverseLine(a.y, a.x, b.y, b.x);
  const double length = line.Distance();
  auto point = [&](double t) {
    double lat, lon;
    line.Position(t, lat, lon);
    return Vec2{lon, lat};
  };
  auto f = [&](double t) { return metres(x, point(t)); };
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double lo = 0.0, hi = length;
  double t1 = hi - g * (hi - lo), t2 = lo + g * (hi - lo), f1 = f(t1), f2 = f(t2);
  for (int i = 0; i < 200 && hi - lo > 1e-9; ++i) {
    if (f1 <= f2) {
      hi = t2;
      t2 = t1;
      f2 = f1;
      t1 = hi - g * (hi - lo);
      f1 = f(t1);
    } else {
      lo = t1;
      t1 = t2;
      f1 = f2;
      t2 = lo + g * (hi - lo);
      f2 = f(t2);
    }
  }
  Foot best{a, metres(x, a)};
  const Foot end{b, metres(x, b)};
  if (end.metres < best.metres) best = end;
  const double t = 0.5 * (lo + hi);
  const Foot inside{point(t), f(t)};
  if (inside.metres < best.metres) best = inside;
  return best;
}

}  // namespace rv::test
