// Distance-limit lines (the 12 nmi limit and its kind) from an exact nearest-site field: every
// vertex the root of d(p(t)) - D on a cell-centre segment (d: nearest site of any owner, or of one
// owner), measured with the exact metric. Limits measure true distances
// (OwnerIndex::Measure::plain: the breadth of a zone ignores weights).
//
// Pure: `threads` only splits the work and never changes the result.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/field/seeds.hpp"
#include "rv/lines/residual.hpp"

namespace rv {

struct LimitVertex {
  Vec2 p;
  int32_t site = kNoSite;  // controlling site at p
  double residual = 0.0;   // |d(p) - D|, metric units
  // By sea: the line's end on a barrier's edge (LimitResult::ends_on_barriers), on the side it
  // comes from.
  bool on_barrier = false;
};

// LimitLine::owner of the owned area's edge (LineRequest::owned_edge).
inline constexpr int32_t kOwnedEdge = -1;

struct LimitLine {
  double distance = 0.0;  // D, metric units (0 for the owned area's edge)
  // 0: distance to all owners' seeds; else to this owner's seeds only; kOwnedEdge: the edge of
  // the area some site reaches (OwnerIndex::deepest's zero level; vertex residuals |d - reach|).
  int32_t owner = 0;
  bool closed = false;
  std::vector<LimitVertex> vertices;
};

struct LimitOptions {
  bool per_owner = false;  // false: one set of lines per distance, from all seeds together
  double simplify_cells = 0.0;
  double tolerance_cells = 1e-9;
  // The line tolerance (metric units): the largest distance left between any point of a line and
  // the level d = D. Between two vertices on cell edges the level is an arc of a site's circle
  // (radius D round a point or a segment's end), a straight offset of a segment, or two such
  // meeting in a corner where the controlling site changes: corners are added exactly (both
  // sites at D), arcs get points of the level until every chord is within this of it (straight
  // offsets none). 0: only the vertices on cell edges and the owned edge's corners (every
  // segment still measured).
  double line_tolerance = 1e-3;
  int threads = 0;
};

struct LimitResult {
  std::vector<LimitLine> lines;
  double max_residual = 0.0;
  int64_t vertices = 0;
  int64_t vertices_before_simplify = 0;
  // Along the whole length (rv/lines/residual.hpp): every segment's midpoint measured against the
  // level, the corners and arc points added.
  LineResidual residual;
  int64_t corners = 0;
  // By sea (a metric with domain edges, rv/sea/sea_metric.hpp): two cells a barrier parts are
  // not neighbours, so a level line that meets a coast or a boom stops a cell short of it; its
  // end is carried onto the barrier's edge where d = D (from the side it comes from).
  int64_t ends_on_barriers = 0;
  // With simplification: the largest distance from a simplified segment's midpoint to the level
  // (metric units; 0 without).
  double simplified_midpoint = 0.0;
};

// Lines at the given distances (metric units, > 0) from the seeds. Cells without an owner in
// `field` (beyond its max distance) count as farther than any limit. Throws
// rv::Error(invalid_argument) for a non-positive or non-finite distance.
LimitResult extract_limits(const NearestField& field, const OwnerIndex& index, std::span<const double> distances,
                           const LimitOptions& options = {});

}  // namespace rv
