// What the turning-point report states of the lines: the turning points of boundary lines and
// the arcs of distance-limit lines, each with its controlling basepoints.
//
// Pure: `threads` only splits the work and never changes the result.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "rv/engine/owner_index.hpp"
#include "rv/field/geolocate.hpp"
#include "rv/field/seeds.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"

namespace rv {

// The turning points of boundary lines: where the pair of controlling basepoints changes.
//
// A side's controlling basepoint at a point of a line is where its nearest seed is nearest: a
// basepoint seed, a vertex of a coastline (whichever of the vertex's two edges the index names),
// or the moving foot on an edge's interior (the line is then a parabola, not a bisector). Along a
// line the pair changes where a new seed takes over (the locus turns: a turning point of three
// basepoints, equidistant from all of them) and where the foot on an edge reaches its end (the
// line passes from a parabola to a bisector, without a corner). Both are found between the
// line's vertices by bisection on the locus, to 2^-26 of the distance between two vertices (the
// refinement has usually placed the first kind on a vertex already), every point a locus point.
// Where a reach ends the line follows an arc (BoundaryVertex::arc): only that side's basepoint
// controls it, the junctions with the locus or another arc (the refinement's vertices) are
// turning points, and so is a change of the arc's basepoint (bisection on the arc, then the
// corner where both basepoints are at the reach).
struct Basepoint {
  int32_t site = kNoSite;  // the controlling site
  Vec2 at;                 // the basepoint (as SiteMetric::nearest_point places it; by sea where the path starts)
  double distance = 0.0;   // true distance from the turning point, metric units (by sea: along the path)
  // By sea (a metric whose paths bend): the path's last barrier vertex (SiteMetric::last_bend;
  // -1 where the basepoint is seen directly) and its position. The element that controls the
  // line is the site with that bend: a turning point is also where a side's last bend changes
  // (the locus passes from a bisector to a hyperbola branch round the bend, or between bends).
  int32_t via = -1;
  Vec2 via_at;
};
struct TurningPoint {
  enum class Kind { end, turn, start };  // a line's end, a change of basepoint, a ring's first vertex
  Kind kind = Kind::turn;
  Vec2 p;
  // The line's vertices strictly between this point and the next turning point start here (the
  // true line between the two is this point, those vertices, and the next point).
  size_t next_vertex = 0;
  // Each side's basepoints here: one, or two where that side's changes (before, then after). A
  // side whose site does not control the line (the other side's reach ends there) has none.
  std::vector<Basepoint> a, b;
  // What the line follows from here to the next turning point: 0, the equidistance locus; 1 or
  // 2, the arc where side a's (1) or b's (2) reach ends (Feature::reach): round that side's last
  // basepoint here, at its distance (a circle round a basepoint, or a parallel to an edge).
  int8_t arc = 0;
};
struct TurningLine {
  int32_t owner_a = 0, owner_b = 0;
  bool closed = false;
  size_t line = 0;  // index into BoundaryResult::lines
  std::vector<TurningPoint> points;
};
// `geolocator`: the field's (projected geodesic grids), else null.
std::vector<TurningLine> turning_points(const BoundaryResult& boundaries, const OwnerIndex& index,
                                        const Geolocator* geolocator = nullptr, int threads = 0);

// The arcs of distance-limit lines: the stretches of a line drawn from one basepoint (a circular
// arc round a basepoint seed or a coastline vertex) or from one edge's interior (a line parallel
// to it), split where the controlling element changes, found as turning points are. `index`:
// the one the limits were measured with (plain: true distances).
struct LimitArc {
  Vec2 from, to;        // on the line, at distance D
  Basepoint basepoint;  // the controlling element at `from` (an edge's interior: its foot there)
  bool edge = false;    // true: drawn from an edge's interior (the foot moves along it)
  Vec2 edge_to;         // the foot at `to` when `edge`
};
struct LimitArcs {
  size_t line = 0;  // index into LimitResult::lines
  std::vector<LimitArc> arcs;
};
std::vector<LimitArcs> limit_arcs(const LimitResult& limits, const OwnerIndex& index,
                                  const Geolocator* geolocator = nullptr, int threads = 0);

}  // namespace rv
