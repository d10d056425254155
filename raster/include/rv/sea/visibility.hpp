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
// Geodesic reading (a GeodesicFrame given): the barriers' coordinates are the frame's plane, and
// every edge and path is the geodesic between its ends: the same rule with the frame's
// orientation predicate (rv/sea/geodesic_frame.hpp), which is the geodesic one. Also exact, to
// GeographicLib's precision; a path through a barrier vertex that only GeographicLib's rounding
// puts on the path is taken to pass on one side of it. A computed far end (`Place::exact` false,
// below) is taken as on a barrier edge within the frame's deviation() (plus a micrometre) of it.
//
// Planar reading: edges are straight segments in the barriers' frame. Every decision (crossings,
// touches, wedges, land) is made with exact orientation predicates, so visibility is symmetric
// and never depends on rounding, with one allowance: the far end of a path (`Place::exact`
// false), a computed point such as the foot of a perpendicular on a coast segment, may lie a few
// units in the last place off the boundary it belongs on, and is taken as on it.
//
// Costs, for V vertices and E edges. With the index (the default: a uniform grid of about 2E
// buckets), sees() takes time in proportion to the buckets along the path and the edges and
// vertices in them; a point's wedges (star_at, on_land, classify, and sees() from a start that
// is neither a vertex nor Place::open) those along a ray from it out of the boxes of the polygons
// whose boxes hold it (the shortest of the four axis directions; the boxes found from a grid).
// Without the index every query scans every edge and vertex: O(E + V), the reference the index
// is tested against.
// Thread safety: immutable once built; const access from any number of threads.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "rv/field/seeds.hpp"
#include "rv/sea/barriers.hpp"
#include "rv/sea/geodesic_frame.hpp"

namespace rv {

class Visibility {
 public:
  // `indexed` false: every query scans every edge and vertex (the reference). `frame`: the
  // geodesic reading, the barriers in its plane (shared, kept alive); null: the planar one.
  explicit Visibility(Barriers barriers, bool indexed = true, std::shared_ptr<const GeodesicFrame> frame = nullptr);

  const Barriers& barriers() const { return barriers_; }
  const GeodesicFrame* frame() const { return frame_.get(); }
  // The orientation predicate of this reading (rv/sea orient.hpp's, or the frame's): +1 when c
  // lies left of the path from a through b, -1 right, 0 on it.
  int orient(const Vec2& a, const Vec2& b, const Vec2& c) const;
  // How far a computed far end q (Place::exact false) of a path from p may lie off the point or
  // barrier edge it belongs on: a few units in the last place of their coordinates; geodesic,
  // plus the frame's deviation() and a micrometre.
  double slack(Vec2 p, Vec2 q) const;

  // The free directions round a point: the barrier edges at it, by their far ends, sorted
  // counter-clockwise from east, and per wedge (from ray k to ray k + 1, the last wrapping to the
  // first) whether it is sea. Without an edge at the point: one wedge, sea unless the point is
  // strictly inside land.
  struct Star {
    Vec2 at;
    std::vector<Vec2> rays;
    std::vector<uint8_t> sea;              // one entry per wedge: max(1, rays.size())
    const GeodesicFrame* frame = nullptr;  // the reading its directions are ordered in
    // Of two rays, the wedge wider than a half-turn (0 or 1; -1: none, or not two rays).
    int wide = -1;
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
  // (`wedge` its index; -1: any). `exact` false for a computed end (see above). `open`: the
  // caller knows the point is sea and on no barrier (classify() said so), which spares the
  // start's wedges from being worked out.
  struct Place {
    Vec2 at;
    int32_t vertex = -1;
    int wedge = -1;
    bool exact = true;
    bool open = false;
  };
  Place at_vertex(int32_t v, int wedge) const { return Place{vertex(v), v, wedge, true}; }

  // Land (see above). Exact.
  bool on_land(Vec2 p) const;
  // Land, open sea (sea on no barrier), or sea on a barrier's boundary. Exact.
  enum class Ground { land, open_sea, on_barrier };
  Ground classify(Vec2 p) const;
  // classify() for the points (xs[i], y), i in [0, n), xs ascending (a row of cell centres),
  // written to out: the same answers, in time proportional to the edges the row meets plus n
  // (plus classify() for the few points on a barrier). Geodesic reading: classify() per point.
  void classify_row(double y, const double* xs, int64_t n, Ground* out) const;
  // classify(q) knowing the ground of p (not on a barrier): the same where the segment p-q meets
  // no barrier edge (a proof in time proportional to the index buckets along it and the edges
  // they hold), else classify(q). For the next cell of a row.
  Ground classify_next(Vec2 p, Ground p_ground, Vec2 q) const;
  // Whether the straight path from `from` to `to` is free, leaving `from` and reaching `to`
  // within their wedges where given. A path of length zero is free where its place is sea.
  // `blocker`, when given: the edge whose crossing blocked the path, else -1 (free, or blocked
  // otherwise: a wedge, a closed-off point).
  bool sees(const Place& from, const Place& to, int32_t* blocker = nullptr) const;
  // Whether edge `edge` (an index of the blocker sees() names) crosses the path from `from` to
  // `to`, which it then blocks: a cheap proof that a path is blocked, for a blocker found on a
  // neighbouring path. Exact, as sees().
  bool crosses(int32_t edge, const Place& from, const Place& to) const;

  // Where the closed segment a-b (a seed's edge, in the barriers' plane) meets a barrier edge
  // anywhere but at one of its own ends where that edge ends too, or along the very same edge (a
  // seed polygon that is a barrier): each crossing (computed: Place::exact false; geodesic, where
  // the chords cross, within the frame's deviation of the geodesics' crossing), each barrier
  // vertex inside a-b (exact), and each end of a-b inside a barrier edge (exact false: on it to
  // rounding); a stretch along a different edge gives its two ends. Decided exactly, as sees().
  std::vector<Place> meetings(Vec2 a, Vec2 b) const;

  // Proofs for many points at once, over a closed box of the plane (lo <= hi componentwise):
  // true holds for every point of the box; false proves nothing. Both decide with margins in
  // floating point (a billionth of the coordinates' magnitude, plus on the ellipsoid the frame's
  // deviation() for each image that may bend), so they say false near the limits the exact
  // predicates decide; the answers they give are those of the exact predicates. Cost: the index
  // buckets the region meets and the edges and vertices they hold (without the index, every one).
  //
  // No barrier edge or vertex comes near the box: every point of it has the same ground (open
  // sea or land), and between two points of it that are sea every straight path is free.
  bool clear_box(Vec2 lo, Vec2 hi) const;
  // Every straight path from `from` to a point x of the box is free (sees(from, Place{x})): the
  // box lies strictly inside one sea wedge of `from` (its wedge when given), and no edge or
  // vertex but those at `from` comes near the region the paths sweep (the hull of `from` and the
  // box). A path from `from` meets an edge through `from` only there: geodesics from one point
  // meet again only beyond their conjugate point.
  bool sees_box(const Place& from, Vec2 lo, Vec2 hi) const;
  // sees_box's proof, or the opposite one: no straight path from `from` to a point of the box is
  // free. Hidden is proved when the box lies strictly inside a wedge of `from` that is land or not
  // its given wedge, or when edges each separating `from` from the box (its line between them)
  // cover every direction from `from` towards the box: a direction inside an edge's angle from
  // `from` crosses it, and one through the vertex two such edges share, on either side of it,
  // would leave that vertex in another wedge than it came in by.
  enum class Sight { seen, hidden, unknown };
  Sight sight_box(const Place& from, Vec2 lo, Vec2 hi) const;

 private:
  struct Edge {
    Vec2 a, b;
    Vec2 prev;        // a polygon edge: the ring's vertex before a
    int32_t polygon;  // its polygon (land on its left), or -1 for a line's edge
  };
  Star build_star(Vec2 p) const;
  // The star round a path's start: its vertex's, one sea wedge for a point known open, else built
  // into `built` (which the answer may refer to).
  const Star& start_star(const Place& from, Star& built) const;
  // A transversal crossing of the edge's interior by the open path p-q (`slack`: see Place::exact).
  bool crossing(const Edge& e, Vec2 p, Vec2 q, double slack) const;
  // Whether no edge comes within edge_margin of the convex polygon (n <= 5 vertices, counter-
  // clockwise) and no vertex within vertex_margin, but those at `from` (when given).
  // `near` (when given): every edge and vertex found near is appended (edges as themselves,
  // vertices as -1 - index) instead of stopping at the first.
  bool region_clear(const Vec2* poly, int n, double edge_margin, double vertex_margin, const Vec2* from,
                    std::vector<int32_t>* near = nullptr) const;
  Sight sight(const Place& from, Vec2 lo, Vec2 hi, bool hidden_too) const;
  // Whether the edges in `near` (indices, others ignored) prove every path from o to the box blocked (sight_box).
  bool covers_box(Vec2 o, Vec2 lo, Vec2 hi, const std::vector<int32_t>& near, double margin) const;
  // The edges and vertices a closed segment may meet: all of them without the index.
  void candidates(Vec2 p, Vec2 q, std::vector<int32_t>& edges, std::vector<int32_t>& vertices) const;

  struct Index;
  struct Lands;  // the polygons' boxes, and which may hold a given point
  Barriers barriers_;
  std::shared_ptr<const GeodesicFrame> frame_;
  std::shared_ptr<const Index> index_;
  std::shared_ptr<const Lands> lands_;
  std::vector<Edge> edges_;
  std::vector<Star> stars_;           // per vertex
  std::vector<int32_t> by_position_;  // vertex indices sorted by (x, y)
  double east_ = 1.0;                 // beyond every vertex's x: where a ray east has met them all
};

}  // namespace rv
