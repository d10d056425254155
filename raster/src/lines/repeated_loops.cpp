// Closed lines that run wholly along another line of the same two owners
// (boundary_stages.hpp, repeated_loops). Cells of a thin wedge cut off from it near its tip
// trace a closed line of their own; refined, its chords across the wedge go out to the tip as the
// main line's chord does, and every stretch of it lies on the stretches the main line follows.
#include <algorithm>
#include <cmath>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/line_tools.hpp"

namespace rv::boundary_stages {

namespace {

using Box = line_tools::Bounds;

Box box_of(const std::vector<BoundaryVertex>& v) {
  Box b;
  for (const BoundaryVertex& x : v) b.add(x.p);
  return b;
}

// Whether every vertex of `loop` and the middle of each of its segments lie within `pad` of
// `other`'s segments.
bool runs_along(const std::vector<BoundaryVertex>& loop, const Box& box, const std::vector<BoundaryVertex>& other,
                double pad) {
  std::vector<std::pair<Vec2, Vec2>> near;
  for (size_t i = 0; i + 1 < other.size(); ++i) {
    Box s;
    s.add(other[i].p);
    s.add(other[i + 1].p);
    if (s.meets(box, pad)) near.emplace_back(other[i].p, other[i + 1].p);
  }
  if (near.empty()) return false;
  auto close = [&](Vec2 p) {
    return std::any_of(near.begin(), near.end(),
                       [&](const auto& s) { return line_tools::segment_distance(p, s.first, s.second) <= pad; });
  };
  for (size_t i = 0; i < loop.size(); ++i) {
    const Vec2 p = loop[i].p, q = loop[(i + 1) % loop.size()].p;
    if (!close(p) || !close(line_tools::lerp(p, q, 0.5))) return false;
  }
  return true;
}

}  // namespace

std::vector<bool> repeated_loops(const std::vector<BoundaryLine>& lines, const LineRefiner& refiner) {
  std::vector<bool> drop(lines.size(), false);
  std::vector<Box> boxes(lines.size());
  for (size_t k = 0; k < lines.size(); ++k) boxes[k] = box_of(lines[k].vertices);
  for (size_t k = 0; k < lines.size(); ++k) {
    const BoundaryLine& loop = lines[k];
    if (!loop.closed || loop.vertices.size() < 3) continue;
    // Twice the tolerance each line's chords keep from the locus, in CRS units, and a billionth
    // of the coordinates for their rounding.
    const Vec2 at = loop.vertices.front().p;
    const double pad =
        2.0 * refiner.crs_length(refiner.tolerance(), at) + 1e-9 * std::max(std::abs(at.x), std::abs(at.y));
    for (size_t m = 0; m < lines.size() && !drop[k]; ++m) {
      const BoundaryLine& other = lines[m];
      if (m == k || drop[m] || other.owner_a != loop.owner_a || other.owner_b != loop.owner_b) continue;
      const Box& b = boxes[m];
      const Box& l = boxes[k];
      if (!(l.x0 >= b.x0 - pad && l.x1 <= b.x1 + pad && l.y0 >= b.y0 - pad && l.y1 <= b.y1 + pad)) continue;
      drop[k] = runs_along(loop.vertices, l, other.vertices, pad);
    }
  }
  return drop;
}

}  // namespace rv::boundary_stages
