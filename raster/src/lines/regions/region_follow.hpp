// The last stage of region_edges (rv/lines/regions.hpp) with a line tolerance: the edges it adds
// or carries on made to follow their loci, and every segment's bow measured.
//
// Internal to rv_raster. Thread safety: a pure function of its arguments but `edges`.
#pragma once

#include "rv/engine/owner_index.hpp"
#include "rv/field/grid.hpp"
#include "rv/lines/regions.hpp"

namespace rv::region_follow {

// `edges` with their loci (RegionEdges::loci) made exact to `tol` (metric units, > 0):
//   - the max-distance line or the owned edge (EdgeLocus::level, on cell edges as extraction
//     gave them) by LimitRefiner: corners where the controlling site changes, points on its arcs;
//   - the first and last segments of every boundary edge (EdgeLocus::pair), where region_edges
//     carried the line on from its last crossing, by LineRefiner (the rest was refined with the
//     line); with `partial` (a partial-effect locus) those stay as they are;
// then every segment's bow (RegionEdges::bows) measured, and RegionEdges::residual filled.
// `D`: the max distance (metric units); `margins`: the level is the owned area's edge (reaches).
// `lines`: the boundary lines the edges were made from, whose segments' bows were measured as
// they were refined (BoundaryLine::bows): taken, not measured again.
void follow(RegionEdges& edges, const OwnerIndex& index, const GridSpec& g, double D, bool margins, double tol,
            bool partial, const BoundaryResult& lines);

}  // namespace rv::region_follow
