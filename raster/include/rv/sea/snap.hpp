// Seeds on the coast: a port surveyed a few metres inland, or a coast line digitised against
// another source's land, is moved onto the barriers' boundary rather than refused.
//
// Every seed vertex (points, line and polygon vertices) that lies on land (rv/sea/visibility.hpp)
// within `tolerance` (the seeds' CRS units; metres where projected) of the sea is moved to the
// nearest point of the barriers' boundary, then, where rounding left that point on land, a few
// units in the last place further out, until it is sea. The same position everywhere it occurs
// (a polygon's ring and its edges' sites) moves alike, so features stay closed. A vertex farther
// inside land than `tolerance` is rv::Error(invalid_input) naming the feature and how deep it
// lies, but for a line's or a polygon's vertex that lies on a barrier polygon's boundary under
// another barrier polygon (a land border where two barriers overlap, as neighbouring states' land
// does when coasts are seeds and barriers both): it stays, reached by no path, the seed reached
// where it is at sea; a seed all of whose vertices are such is invalid_input (inside the
// barriers). The boundary a vertex is moved to is the land's: a polygon's edge under another
// polygon is none. A segment whose ends are sea but which crosses land is left as it is (a line
// seed may cross a headland; its distances are measured from its nearest points that a path
// reaches).
//
// Geodesic (`frame` given): seeds and barriers in longitude/latitude, land and the nearest
// boundary point decided in the frame's plane (edges read as geodesics, rv/sea/visibility.hpp),
// `tolerance` and the moves in metres as the plane measures them (within its scale of the
// ellipsoid's: GeodesicFrame::max_scale), the moved point stepped out by at least a micrometre so
// that it stays sea through the projection's round trip.
//
// Pure; the barriers are in the seeds' frame. Cost: O(E) per vertex on land, nothing for the
// others beyond the land test.
#pragma once

#include <cstdint>
#include <memory>

#include "rv/field/seeds.hpp"
#include "rv/sea/barriers.hpp"
#include "rv/sea/geodesic_frame.hpp"

namespace rv {

struct SnappedSeeds {
  SeedSet seeds;
  int64_t moved = 0;            // distinct positions moved
  double largest_move = 0;      // the farthest any moved (seeds' CRS units)
  int64_t on_land_borders = 0;  // distinct line and polygon vertex positions left on a land border
};

SnappedSeeds snap_to_sea(const SeedSet& seeds, const Barriers& barriers, double tolerance,
                         std::shared_ptr<const GeodesicFrame> frame = nullptr);

}  // namespace rv
