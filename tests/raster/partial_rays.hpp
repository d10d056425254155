// The partial-effect tests' analytic case (test_partial_effect.cpp, and by sea
// test_sea_partial.cpp): owners A and B whose lines are rays from a common point O. A at azimuth
// 310, B's mainland at 90 and its island (the partial feature) at `island_azimuth` (170 unless
// given), all 30 km from O: the A-B line is the ray at 20 degrees and, at nil effect, the ray at
// 200; at full effect the ray at (310 + island_azimuth) / 2 (240). The e : (1 - e) locus between
// the nil ray and one `wedge` degrees on is the ray at 200 + theta with
// sin(theta) / sin(wedge - theta) = e / (1 - e) (220 at half effect and a 40-degree wedge).
#pragma once

#include <cmath>
#include <numbers>

#include "rv/field/seeds.hpp"
#include "seed_gen.hpp"

namespace rv::test::rays {

constexpr double kDeg = std::numbers::pi / 180.0;
inline const Vec2 kO{500000.0, 6000000.0};
// 120 x 100 cells of 1 km round O.
inline const GridSpec kGrid = test::grid_of(120, 100, 1000.0, 420000.0, 6030000.0);

inline Vec2 toward(double azimuth_deg, double r) {
  return Vec2{kO.x + r * std::sin(azimuth_deg * kDeg), kO.y + r * std::cos(azimuth_deg * kDeg)};
}

inline double azimuth_of(Vec2 p) {
  const double az = std::atan2(p.x - kO.x, p.y - kO.y) / kDeg;
  return az < 0.0 ? az + 360.0 : az;
}

inline SeedSet rays(double effect, double island_azimuth = 170.0) {
  SeedSet s;
  const int32_t a = s.owner_code("A"), b = s.owner_code("B");
  s.add_point(s.add_feature(a), toward(310.0, 30000.0));
  s.add_point(s.add_feature(b), toward(90.0, 30000.0));
  const int32_t island = s.add_feature(b);
  s.add_point(island, toward(island_azimuth, 30000.0));
  s.set_effect(island, effect);
  return s;
}

inline double locus_azimuth(double e, double wedge = 40.0) {
  const double k = e / (1.0 - e);
  return 200.0 + std::atan(k * std::sin(wedge * kDeg) / (1.0 + k * std::cos(wedge * kDeg))) / kDeg;
}

}  // namespace rv::test::rays
