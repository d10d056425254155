// How far the output lines of one kind stray from their exact locus along their whole length,
// not only at their vertices. Pure value type.
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>

namespace rv {

// Measured over the final segments of one kind of line (boundaries, reach arcs, limits, the owned
// area's edge, partial-effect lines, region edges). Distances in metric units (metres on
// geodesic grids, CRS units on planar ones).
struct LineResidual {
  int64_t segments = 0;  // segments measured (land-border segments not among them)
  // The largest distance from a segment's midpoint to the locus: the root of the locus function
  // across the chord's middle, or |f| / |grad f| where the metric gives the gradient.
  double max_midpoint = 0.0;
  // The largest deviation of a segment from the locus that the densification estimated from the
  // turn of the locus' normals between its ends (where the metric gives them): the sagitta of
  // the circular arc with those end normals.
  double max_estimate = 0.0;
  double max_vertex = 0.0;  // the largest residual at a vertex (as each kind defines it)
  int64_t added = 0;        // vertices added between the cell-edge vertices to follow the locus
  // Segments whose both ends lie on land of an owner (distance 0 to one of the two: shared land
  // borders and overlapping land polygons, where every point is on the locus): excluded.
  int64_t land_border_segments = 0;
  double max_vertex_on_land = 0.0;  // the largest vertex residual there
  // Segments left beyond the tolerance: no locus point across them checked out (the cells link
  // two stretches of the locus that meet, if at all, farther than the search goes: two arcs
  // nearly touching within a cell, a channel narrower than one). Among `segments`; the worst's
  // midpoint in grid-CRS coordinates.
  int64_t unresolved = 0;
  double worst_x = 0.0, worst_y = 0.0;

  // One measured segment (its midpoint's offset, NaN: not measured) at midpoint (x, y).
  void add(double offset, double x, double y, double tol) {
    ++segments;
    if (offset > max_midpoint) {
      max_midpoint = offset;
      worst_x = x;
      worst_y = y;
    }
    if (offset > tol) ++unresolved;
  }

  double worst() const { return std::max(max_midpoint, max_estimate); }
  void merge(const LineResidual& o) {
    segments += o.segments;
    if (o.max_midpoint > max_midpoint) {
      max_midpoint = o.max_midpoint;
      worst_x = o.worst_x;
      worst_y = o.worst_y;
    }
    max_estimate = std::max(max_estimate, o.max_estimate);
    max_vertex = std::max(max_vertex, o.max_vertex);
    added += o.added;
    land_border_segments += o.land_border_segments;
    max_vertex_on_land = std::max(max_vertex_on_land, o.max_vertex_on_land);
    unresolved += o.unresolved;
  }
};

// Per segment of a line, how the locus between its ends bows away from it: the signed distance
// from the segment's middle to the locus point across it, positive to the left of the segment's
// direction (metric units), and its length (metric units); NaN where not measured. The area
// between a segment and its locus is 2/3 of the two multiplied (a parabola's segment; a circle's
// to the bow's square over the radius): ring_area (rv/lines/regions.hpp) adds it.
struct Bow {
  double left = std::numeric_limits<double>::quiet_NaN();
  double length = 0.0;
};

}  // namespace rv
