// Which straight paths are free of the barriers, and which points are land: the one rule every
// engine of the distance by sea decides with.
//
// Land and sea for a point (on_land): strictly inside a barrier polygon is land; a point on a
// boundary is sea, unless every direction from it leads into land (a point of a border two land
// polygons share). This differs from seed polygons, whose interior is half-open
// (rv/field/interior.hpp) so that two neighbours never both claim a cell: a barrier's boundary
// belongs to the sea, where a port on the coast may stand.
//
// A straight path is free when it crosses no barrier line, enters no land, and passes through no
// closed-off point. Round every point the free directions form *wedges* between the barrier
// edges there: a polygon's convex corner has one, a line's inner vertex two (one per side), its
// end one (all round), a point where two islands meet at a corner two, a point inside land none.
// Wherever a path touches a barrier it keeps to one wedge; along a barrier edge it keeps to one
// side. So a path may touch a barrier and run along it, but not slip through a line at a vertex
// nor between two polygons that meet.
//
// Planar reading: edges are straight segments in the barriers' frame. Every decision (crossings,
// touches, wedges, land) is made with exact orientation predicates, so visibility is symmetric
// and never depends on rounding, with one allowance: the far end of a path (`Place::exact`
// false), a computed point such as the foot of a perpendicular on a coast segment, may lie a few
// units in the last place off the boundary it belongs on, and is taken as on it.
//
// Costs (the reference implementation, the oracle's; an engine indexes the edges): building is
// O(V E) for V vertices and E edges; sees() is O(E + V), plus O(E) for an end that is not a
// barrier vertex.
// Thread safety: immutable once built; const access from any number of threads.
#pragma once

#include <cstdint>
#include <vector>

#include "rv/field/seeds.hpp"
#include "rv/sea/barriers.hpp"

namespace rv {

class Visibility {
 public:
  explicit Visibility(Barriers barriers);

  const Barriers& barriers() const { return barriers_; }

  // The free directions round a point: the barrier edges at it, by their far ends, sorted
  // counter-clockwise from east, and per wedge (from ray k to ray k + 1, the last wrapping to the
  // first) whether it is sea. Without an edge at the point: one wedge, sea unless the point is
  // strictly inside land.
  struct Star {
    Vec2 at;
    std::vector<Vec2> rays;
    std::vector<uint8_t> sea;  // one entry per wedge: max(1, rays.size())
    int wedges() const { return static_cast<int>(sea.size()); }
    // The wedge the direction towards `x` (x != at) lies in; on a ray, the wedge on its
    // counter-clockwise side when `ccw`, else the one on its clockwise side.
    int wedge_towards(Vec2 x, bool ccw) const;
  };
  Star star_at(Vec2 p) const;

  // The barrier vertices (distinct positions, in first-appearance order) and their stars.
  int32_t vertex_count() const { return static_cast<int32_t>(stars_.size()); }
  Vec2 vertex(int32_t v) const { return stars_[static_cast<size_t>(v)].at; }
  const Star& vertex_star(int32_t v) const { return stars_[static_cast<size_t>(v)]; }
  // The vertex at `p`, or -1.
  int32_t vertex_at(Vec2 p) const;

  // Where a straight path starts or ends: a point, or a barrier vertex in one of its wedges
  // (`wedge` its index; -1: any). `exact` false for a computed end (see above).
  struct Place {
    Vec2 at;
    int32_t vertex = -1;
    int wedge = -1;
    bool exact = true;
  };
  Place at_vertex(int32_t v, int wedge) const { return Place{vertex(v), v, wedge, true}; }

  // Land (see above). Exact.
  bool on_land(Vec2 p) const;
  // Whether the straight path from `from` to `to` is free, leaving `from` and reaching `to`
  // within their wedges where given. A path of length zero is free where its place is sea.
  bool sees(const Place& from, const Place& to) const;

 private:
  struct Edge {
    Vec2 a, b;
    bool polygon;  // land on its left
  };
  Star build_star(Vec2 p) const;

  Barriers barriers_;
  std::vector<Edge> edges_;
  std::vector<Star> stars_;           // per vertex
  std::vector<int32_t> by_position_;  // vertex indices sorted by (x, y)
};

}  // namespace rv
