// Grids whose cell centres fall on random_archipelago's whole-number corners, for the tests of what
// is drawn row by row (the ground, the sites' sight): cells on edges, at vertices, on shared
// borders and on rays grazing corners, where floating point cannot say which side a centre is on.
#pragma once

#include "rv/field/grid.hpp"
#include "rv/field/seeds.hpp"
#include "seed_gen.hpp"

namespace rv::test {

// The 40-unit square (and a little more) in cells 0.25 wide: a centre on every whole number.
inline GridSpec planar_lattice_grid() { return grid_of(176, 176, 0.25, -2.125, 41.875); }

// The 40-unit layouts over 0.8 degrees of longitude and 0.5 of latitude at 55 N (lattice_ll maps
// them there), in cells of 0.0025 degrees whose centres fall on every whole unit of longitude and
// every fifth of latitude.
inline Vec2 lattice_ll(Vec2 v) { return Vec2{12.0 + v.x * 0.02, 55.0 + v.y * 0.0125}; }
inline GridSpec ellipsoid_lattice_grid() { return grid_of(368, 224, 0.0025, 11.94875, 55.55125); }

}  // namespace rv::test
