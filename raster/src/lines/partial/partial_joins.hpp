// The partial-effect lines taken as a whole once every band is drawn (rv/lines/partial_effect.hpp):
// pieces joined where a followed locus ran from one into another, and lines that cannot be right
// refused.
//
// Internal to rv_raster. Thread safety: pure functions over the arguments.
#pragma once

#include <cstdint>
#include <vector>

#include "rv/field/seeds.hpp"
#include "rv/lines/boundaries.hpp"

namespace rv::partial_joins {

// The open B-X lines that meet end to end (one's last vertex, the other's first, exactly) at each
// point of `at` made one: a band followed from one piece of a full-effect line that a coast cut on
// into another piece's band (partial_effect.cpp, LineRewrite::claimed). The joined line has no
// bows. Throws Error(unsupported), one line naming the owners, where two such lines do not meet so.
void join_at(std::vector<BoundaryLine>& lines, const SeedSet& seeds, int32_t B, int32_t X, const std::vector<Vec2>& at);

// Throws Error(unsupported), one line naming the owners, where an open line ends where it began and
// its second and last-but-one vertices are one point too (within 1e-6 of `res`, the cell size, CRS
// units): it ran out along a locus and back over itself, so the stretch beyond where it turned is
// missing and regions would merge two owners' faces. A line that leaves a point and comes back to
// it another way is not refused.
void refuse_turned_back(const std::vector<BoundaryLine>& lines, const SeedSet& seeds, double res);

}  // namespace rv::partial_joins
