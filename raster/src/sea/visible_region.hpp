// The part of a box a point sees past the barriers: a star-shaped ring round the point, for an
// engine that draws a root's region row by row (the shortest-path map) instead of proving
// visibility block by block or cell by cell (sea_map/site_sight.hpp), and for the directions in
// which a bend node sees far (near_bends.hpp's far sight). Internal to rv_raster.
//
// Made by a rotational sweep in the plane of the visibility's reading. The barrier edges that
// meet the box, cut where they cross (overlapping polygons, lines across land), are clipped to
// it and the box's sides added, so every ray from the point ends on a piece, and pieces meet
// only at their ends. Between two consecutive angles at which a piece ends, one piece is nearest
// along every ray: that piece bounds the region there. Floating point throughout: the answer is
// the exact rule's (Visibility::sees) for every point of the box farther than `margin` from the
// ring's boundary (the segments from the point along its wedge's sides included); nearer points
// are for the exact predicates to decide. A ray at one of those angles may see past the pieces
// on both sides of it (it grazes vertices, runs along an edge, passes between two polygons that
// meet, or is stopped there, which the sweep cannot tell apart): the ring runs out along it and
// back, a spike of no width, so that the points on it lie on the boundary, for the exact rule.
//
// Geodesic reading: pieces are the chords of the edges' images and rays straight lines in the
// frame's plane; both bend off by at most the frame's deviation(), which the margin includes
// twice (an edge's and a path's), plus a micrometre.
//
// Cost: O(n log n + n k) for n edges meeting the box, k of them across one ray at once.
// Thread safety: pure functions; const access to the Visibility from any number of threads.
#pragma once

#include <cstdint>
#include <vector>

#include "rv/sea/visibility.hpp"
#include "sea/edge_index.hpp"

namespace rv::sea {

struct VisibleRegion {
  Vec2 from;
  // Counter-clockwise, star-shaped from `from` (which is a vertex of it when the point's wedge is
  // narrower than a whole turn). Empty when the wedge is land, or `blurred`.
  std::vector<Vec2> ring;
  // Plane units: points farther than this from the ring's boundary are seen exactly when inside.
  double margin = 0.0;
  // A barrier edge that does not end at the point passes within `margin` of it (a vertex a
  // rounding apart from another, an edge through the point): which side of it the point lies on
  // is the exact predicates' to say, so the ring is left empty and the point's cells are theirs.
  bool blurred = false;
  // Even-odd test against the ring (a point within `margin` of its boundary: either answer).
  bool contains(Vec2 x) const;
  // The least distance from x to the ring's boundary (+infinity for an empty ring).
  double boundary_distance(Vec2 x) const;
};

// The part of segment a-b inside the box [lo, hi], its ends included (Liang-Barsky): a and b
// moved to that part's ends, or false where there is none.
bool clip_to_box(Vec2& a, Vec2& b, Vec2 lo, Vec2 hi);

// The barrier edges of `vis` in its plane (every polygon ring's, then every line's), each cut
// where another edge crosses it or ends inside it, as visible_region reads them.
std::vector<EdgeIndex::Segment> barrier_edges(const Visibility& vis);

// The region `from` sees within the box [lo, hi] (lo < hi componentwise; from.at strictly
// inside), leaving `from` within its wedge (Visibility::Place: a vertex with `wedge` set, or -1
// where the vertex has one wedge; a point with `open` true sees all round; any other point is
// read with Visibility::star_at). `edges`: barrier_edges(vis); `near`: the indices of those that
// may meet the box (an EdgeIndex::cover's answer, a superset), or null for all of them.
// Throws rv::Error(invalid_argument) for a box that does not hold the point, or a vertex of
// several wedges without one chosen.
VisibleRegion visible_region(const Visibility& vis, const Visibility::Place& from, Vec2 lo, Vec2 hi,
                             const std::vector<EdgeIndex::Segment>& edges, const std::vector<int32_t>* near = nullptr);

}  // namespace rv::sea
