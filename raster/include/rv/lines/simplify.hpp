// Simplification of the lines that never moves a vertex. Pure; thread-safe.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "rv/field/seeds.hpp"

namespace rv {

// Douglas-Peucker on a polyline: indices of the vertices to keep (first and last always kept).
// A vertex is dropped only if it lies within `tolerance` (same units as the coordinates) of the
// segment that replaces it.
std::vector<size_t> simplify_indices(std::span<const Vec2> points, double tolerance);

}  // namespace rv
