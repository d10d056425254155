// What the tests of the distance by sea on the ellipsoid check against, written apart from the
// engines: GeographicLib's geodesics, lengths and azimuths on WGS84, in longitude/latitude.
#pragma once

#include <GeographicLib/Geodesic.hpp>

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

}  // namespace rv::test
