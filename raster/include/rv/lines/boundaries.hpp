// Boundary (median) lines between owners and their tripoints, from an exact nearest-site field.
//
// Method (why the vertices are exact): the raster only gives the topology. Every output vertex
// is placed by root-finding with the exact metric (rv/engine/site_metric.hpp):
//   - a boundary vertex on the segment between two 4-neighbour cell centres owned by A and B is
//     the root of f(t) = d_A(p(t)) - d_B(p(t)), where d_X is the distance to the nearest site of
//     owner X, recomputed exactly at every evaluation (OwnerIndex: a bounding-volume hierarchy
//     per owner, searched with the metric's lower bounds, so the controlling seed may change
//     along the segment);
//   - a tripoint solves d_A = d_B = d_C by Gauss-Newton from the dual square's centre.
// Connectivity comes from marching squares on the dual grid of cell centres: a saddle square
// (owners A B / B A) is resolved by the exact owner at the square's centre; squares with three
// or more owners are joined through their tripoints.
// Vertices are never moved: simplification (Douglas-Peucker) only drops vertices that lie within
// the tolerance of the simplified line, so every kept vertex is an exact locus point.
//
// Weights (Feature::weight, rv/field/seeds.hpp): the field's owners are the nearest by d / w, and so
// are the index's (OwnerIndex::Measure::adjusted): boundaries follow d_a / w_a = d_b / w_b (a
// circle round two weighted points: an enclave), tripoints equal three such costs, residuals are
// in them. Reaches (Feature::reach) end a feature's influence without equidistance: where two
// owners' costs jump instead of crossing, the boundary is the arc where the site whose reach
// ends is that far (BoundaryVertex::arc), placed and refined as exactly as the locus; where such
// an arc meets a third owner the tripoint lies on it (an arc and the other two's locus, or two
// owners' arcs).
//
// Pure: `threads` only splits the work and never changes the result.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/field/seeds.hpp"
#include "rv/lines/residual.hpp"

namespace rv {

// One vertex of a boundary line: a point where the distances to the nearest sites of the two
// owners are equal.
// With weights (rv/field/seeds.hpp, Feature::weight) the locus is d_a / w_a = d_b / w_b: the two
// true distances differ by design, and `residual` is the difference of the adjusted ones.
struct BoundaryVertex {
  Vec2 p;
  int32_t site_a = kNoSite;  // controlling (nearest) site of owner_a at p
  int32_t site_b = kNoSite;  // controlling site of owner_b
  double distance = 0.0;     // distance to both (the mean of the two; they differ by residual)
  double residual = 0.0;     // |d_a - d_b| at p, metric units (adjusted distances)
  double distance_a = 0.0;   // the true distances to site_a and site_b, metric units
  double distance_b = 0.0;
  // Where a reach ends the comparison (Feature::reach) the line is not the locus but the arc
  // where one side's site reaches that far: 1, site_a's (distance_a is its reach); 2, site_b's;
  // 0, the locus. `residual` is then |d - reach| of that site.
  int8_t arc = 0;
  // By sea: the line's end on a barrier's edge (BoundaryStats::ends_on_barriers), on the side it
  // comes from (within a few units in the last place of the coordinates; on the ellipsoid within
  // a micrometre, SiteMetric::domain_edge_point).
  bool on_barrier = false;
  // By sea: on the edge of a tie region. Behind a barrier vertex equidistant by sea from both
  // owners, where both owners' paths bend last at that vertex, the two costs are equal to the
  // bit over a whole area, not on a line; the field gives that area to the lower site (every
  // engine's tie rule), and the line runs along its edge, where the costs part: the vertex is the
  // last tied point of its cell-centre segment (to the last bit of the segment's parameter), on
  // the lower owner's side of the line.
  bool tie = false;
};

struct BoundaryLine {
  int32_t owner_a = 0;  // owner_a < owner_b
  int32_t owner_b = 0;
  bool closed = false;  // a ring (first vertex repeated at the end)
  std::vector<BoundaryVertex> vertices;
  // Per segment, its bow from the locus as measured (rv/lines/residual.hpp); empty where the
  // line was simplified or not measured.
  std::vector<Bow> bows;
};

struct Tripoint {
  Vec2 p;
  int32_t owners[3] = {0, 0, 0};                   // ascending
  int32_t sites[3] = {kNoSite, kNoSite, kNoSite};  // controlling site of each owner
  double distance = 0.0;                           // mean distance to the three
  double residual = 0.0;                           // max pairwise difference of the three (adjusted) distances
  double distances[3] = {0.0, 0.0, 0.0};           // true distance to each controlling site
  double cost = 0.0;                               // mean adjusted distance (== distance without weights)
};

struct BoundaryOptions {
  // Douglas-Peucker tolerance in cells (0: keep every vertex). Only vertices within this
  // distance of the simplified line are dropped; kept vertices are exact locus points.
  double simplify_cells = 0.0;
  // Root-finding tolerance along a cell-centre segment, in cells.
  double tolerance_cells = 1e-9;
  // The line tolerance (metric units: metres on geodesic grids, CRS units on planar ones): the
  // largest distance left between any point of a line and the locus it stands for. The vertices
  // found on cell edges are exact, but the locus between two of them turns where a controlling
  // site changes and curves where it is not a straight bisector (a point and a segment: a
  // parabola; weighted points: a circle; a reach: its arc; any pair on the ellipsoid): turning
  // points are added exactly, and curved stretches get locus points until every chord is within
  // this of the locus (straight stretches get none). 0: only the vertices on cell edges (every
  // segment still measured).
  double line_tolerance = 1e-3;
  int threads = 0;
  // The field's max distance (metric units). With an adjusted index (reaches, or weights with
  // this as the cap) lines that stop where the owned area ends end exactly on its edge
  // (end_at_owned_edge); with a plain one they stop at the last crossing.
  double max_distance = std::numeric_limits<double>::infinity();
};

struct BoundaryStats {
  int64_t crossings = 0;  // cell-centre segments with two different owners
  // Cell-centre segments where a third owner is nearer at the A-B equidistant point: its
  // region passes between the two centres without holding one (thinner than a cell there). Such
  // a segment carries the A-C and C-B crossings instead (and so on for more owners between).
  int64_t sliver_crossings = 0;
  int64_t unresolved_slivers = 0;    // segments with more owners between than followed (dropped)
  int64_t saddles = 0;               // dual squares A B / B A resolved by the centre's owner
  int64_t multi_owner_squares = 0;   // dual squares with three or more owners
  int64_t unresolved_tripoints = 0;  // such squares where no tripoint converged inside
  // Largest |d_a - d_b| over all vertices and tripoints off land (a vertex at distance 0 from
  // one of its owners lies on land: shared land borders and overlapping land polygons, where
  // any point is on the locus; those are in max_residual_on_land).
  double max_residual = 0.0;
  double max_residual_on_land = 0.0;
  int64_t turning_points = 0;  // vertices added where a controlling site changes
  int64_t arc_points = 0;      // vertices added on curved stretches (line_tolerance)
  // Along the whole length, segment by segment (rv/lines/residual.hpp): the locus' stretches,
  // and the reaches' arcs (BoundaryVertex::arc).
  LineResidual locus, arcs;
  // With simplification: the largest distance from a simplified segment's midpoint to the locus
  // (metric units; 0 without).
  double simplified_midpoint = 0.0;
  int64_t vertices_before_simplify = 0;
  int64_t vertices = 0;
  int64_t ends_on_owned_edge = 0;  // line ends carried to where the owned area ends
  // By sea (SiteMetric::domain_edges_near): line ends carried onto the barrier they meet (a
  // coast, a boom), where the two owners' distances by sea are equal on its edge.
  int64_t ends_on_barriers = 0;
  // By sea: lines joined where they passed a coast closer than a cell (their cells parted by land,
  // the locus at sea between them; boundary_stages::join_parted_ends).
  int64_t ends_joined = 0;
  // By sea: line ends followed along the locus to the coast where the nearest junction lay behind
  // them (the line going on round land where its cells do not show it; end_at_barriers).
  int64_t ends_followed = 0;
  // By sea: lines parted where their locus would turn on land (it meets the coast first; the
  // cells linked its two stretches across the coast's corner), or meets a coast between two
  // vertices whose chord crosses land or lies far off it (part_where_turning_on_land).
  int64_t turns_on_land = 0;
  // By sea: lines across channels where no cell centre lies beside the change of owner, found
  // from the coasts (boundary_stages::cross_hidden_channels); and changes of owner along a coast
  // that no line ends at and none could be drawn from (0 where every one is explained).
  int64_t channels_crossed = 0;
  int64_t coast_changes_unexplained = 0;
  // By sea: the lines' vertices on the edge of a tie region (BoundaryVertex::tie).
  int64_t tie_vertices = 0;
  // Tripoints a crowded square's search missed, found from the ends of their lines (also in
  // unresolved_tripoints, which counts the squares); by sea also those no square showed (its
  // centres on land), found where a line's walk along its locus met a third owner.
  int64_t missing_tripoints_found = 0;
  // By sea: lines drawn from a tripoint along the locus of two of its owners, where the cells
  // showed none of theirs ending there (the line runs along a coast beside land cells; its
  // squares' centres are land).
  int64_t legs_walked = 0;
  // By sea: line ends taken off a tripoint because their last chord to it left the two owners'
  // locus (two tripoints of the same owners in one square, the lines near both linked to one),
  // then walked along the locus to their own.
  int64_t legs_detached = 0;
  // Closed lines dropped because, refined, they ran wholly along another line of the same owners:
  // cells of a wedge narrower than a cell near its tip, cut off from the rest of it.
  int64_t repeated_loops = 0;
};

struct BoundaryResult {
  std::vector<BoundaryLine> lines;
  std::vector<Tripoint> tripoints;
  BoundaryStats stats;
  // Crossings linked to nothing, as one-vertex lines (not boundary lines: a point): where a max
  // distance ends the owned area in both squares beside a crossing, the two owners' boundary is
  // shorter than a cell. region_edges carries them to the max-distance line.
  std::vector<BoundaryLine> lone_crossings;
};

// Boundary lines and tripoints from an exact nearest-site field (method exact or brute force;
// a scan's approximate ownership only gives topology, and crossings it brackets wrongly are
// placed at the better end: use an exact field). `field` must cover the whole grid.
// Throws rv::Error(invalid_argument) for a field that does not cover a whole grid.
BoundaryResult extract_boundaries(const NearestField& field, const OwnerIndex& index,
                                  const BoundaryOptions& options = {});

}  // namespace rv
