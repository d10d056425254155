// What every engine of the distance by sea starts from: the seeds and barriers in the plane
// visibility is decided in (planar: the grid's local frame; geodesic: a GeodesicFrame's plane),
// checked; how distances are measured there; the nodes a shortest path may bend at; the value a
// path is compared by.
#pragma once

#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <tuple>
#include <utility>
#include <vector>

#include "rv/field/geolocate.hpp"
#include "rv/field/interior.hpp"
#include "rv/field/metric.hpp"
#include "rv/field/planar.hpp"
#include "rv/field/seeds.hpp"
#include "rv/geodesic/geodesic.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/visibility.hpp"

namespace rv::detail {
class GeoSites;  // field/geodesic_sites.hpp
}

namespace rv::sea {

using Place = Visibility::Place;

// A path's value: (distance, site, via); lower is better, ties to the lower site, then to a site
// seen directly (via -1) before a vertex, then to the lower vertex.
struct Best {
  double d = std::numeric_limits<double>::infinity();
  int32_t site = kNoSite;
  int32_t via = kNoVia;
  bool operator<(const Best& o) const { return std::tie(d, site, via) < std::tie(o.d, o.site, o.via); }
};

inline double length(Vec2 a, Vec2 b) { return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y)); }

// The nearest point of a site from x (the local frame), as planar_key measures it, marked
// computed (not exact) where it is the foot of a perpendicular. `b`: the site's second end as
// the barriers' vertices are made (s.bx(), s.by() may differ from it in the last place).
inline Place nearest_point(const LocalSite& s, Vec2 b, Vec2 x) {
  double t = ((x.x - s.ax) * s.dx + (x.y - s.ay) * s.dy) * s.inv_len2;
  t = std::clamp(t, 0.0, 1.0);
  if (t == 0.0) return Place{Vec2{s.ax, s.ay}};
  if (t == 1.0) return Place{b};
  Place p{Vec2{s.ax + t * s.dx, s.ay + t * s.dy}};
  p.exact = false;
  return p;
}

// A point as the engines hold it: where it is in the plane, and (geodesic) its longitude and
// latitude, which its distances are measured from.
struct Spot {
  Vec2 at;
  Vec2 ll;
};

struct Prepared {
  explicit Prepared(Visibility visibility) : vis(std::move(visibility)) {}
  Visibility vis;
  std::vector<LocalSite> local;    // the sites in the plane
  std::vector<int32_t> geometric;  // point and segment sites
  // Geodesic (vis.frame() set): distances between longitudes and latitudes on the ellipsoid, the
  // vertices' and the point sites' positions there, and the frame's largest scale (a plane
  // distance d is at least d / max_scale metres: the search trees' lower bounds).
  std::shared_ptr<const GeodesicMeasure> geodesic;
  std::vector<Vec2> vertex_ll, site_ll;  // site_ll: a site's first end (a point's position)
  // Each site's second end in the plane, made as the barriers' vertices are (so that a seed's
  // end on a barrier vertex is that vertex, bit for bit); a point's position for a point.
  std::vector<Vec2> end_b;
  double max_scale = 1.0;
  double semi_major = 0.0, e2 = 0.0;  // geodesic: the ellipsoid (xyz())
  // Geodesic: the sites as the straight geodesic engine measures them (a segment site: the
  // distance to its geodesic segment, and the nearest point of it).
  std::shared_ptr<const detail::GeoSites> geo_sites;

  // A site's key from x (its squared distance: planar_key, or the geodesic distance squared),
  // and (`nearest` not null) the site's nearest point from x as the end of a straight path to
  // it: a site's end is its exact image (a barrier vertex it lies on is that vertex, bit for
  // bit); a point inside a segment is computed (Place::exact false: planar the foot of the
  // perpendicular, geodesic the foot on the geodesic segment, GeoSites' to well under a
  // micrometre, then projected).
  double site_key(const Spot& x, int32_t site, Place* nearest = nullptr) const {
    const LocalSite& l = local[static_cast<size_t>(site)];
    if (!geodesic) {
      if (nearest) *nearest = nearest_point(l, end_b[static_cast<size_t>(site)], x.at);
      return planar_key(x.at.x, x.at.y, l);
    }
    if (segment(site)) {
      const double d = segment_distance(x, site, nearest);
      return d * d;
    }
    if (nearest) *nearest = Place{Vec2{l.ax, l.ay}};
    const double d = geodesic->point_distance(x.ll, site_ll[static_cast<size_t>(site)]);
    return d * d;
  }
  // (A point site's nearest point is the point: on the ellipsoid no length is solved for it.)
  Place site_place(int32_t site, const Spot& x) const {
    if (geodesic && !segment(site)) {
      const LocalSite& l = local[static_cast<size_t>(site)];
      return Place{Vec2{l.ax, l.ay}};
    }
    Place nearest{x.at};
    site_key(x, site, &nearest);
    return nearest;
  }
  // Where seeds' edges meet barriers away from their ends (Visibility::meetings), and a segment's
  // end on a barrier vertex as seen from each sea wedge there that is no bend node and that the
  // segment does not bound: each such point of segment site `site` is a root of its own, reached
  // at distance 0 (a place the site may be seen only up to, beyond which the barrier hides the
  // rest). A shortest path to a segment ends at its nearest point from the last bend, at one of
  // its ends, or at such a point: sliding the end towards the nearest point is shorter unless a
  // barrier stops it there. (An end on a bend node is that node's, at D = 0.)
  struct Touch {
    int32_t site;
    Place at;  // in the plane (exact false: on the barrier edge to rounding; at a vertex: its wedge)
    Vec2 ll;   // geodesic: its longitude and latitude
  };
  std::vector<Touch> touches;
  // Whether a site is a segment (in the plane: its ends' images differ).
  bool segment(int32_t site) const { return local[static_cast<size_t>(site)].inv_len2 != 0.0; }
  // Geodesic, a segment site: the distance in metres, and (`foot` not null) its nearest point.
  double segment_distance(const Spot& x, int32_t site, Place* foot) const;
  // The length of the straight path from vertex v to x.
  double vertex_length(int32_t v, const Spot& x) const {
    if (!geodesic) return length(vis.vertex(v), x.at);
    return geodesic->point_distance(vertex_ll[static_cast<size_t>(v)], x.ll);
  }
  Spot vertex_spot(int32_t v) const {
    return Spot{vis.vertex(v), geodesic ? vertex_ll[static_cast<size_t>(v)] : Vec2{}};
  }
  // Geodesic on a projected grid: what locates its cell centres on the ellipsoid (else null).
  std::shared_ptr<const Geolocator> geolocator;

  // The centres of row r of the window, where every engine holds them: planar, the grid's local
  // frame; geodesic, a row of a longitude/latitude grid projected as one parallel
  // (GeodesicFrame::forward_row, within 1e-8 m of each point's forward problem), a projected
  // grid's centres located as one batch and each projected. Written into `out` (resized to the
  // window's width), so that a caller that keeps it allocates once: a band's rows are megabytes,
  // and freeing them every band gave the pages back to the kernel to be faulted in again.
  void row_cells(const GridSpec& grid, const Window& window, int64_t r, std::vector<Spot>& out) const;
  // Cell c of row r of the window, as row_cells() holds it (to the bit), alone.
  Spot cell_spot(const GridSpec& grid, const Window& window, int64_t r, int64_t c) const;
  // Lower bounds in the measure's units from plane distances: d * lower_scale().
  double lower_scale() const { return 1.0 / max_scale; }

  // Geodesic: earth-centred, earth-fixed positions (metres) on the ellipsoid. The straight line
  // between two points is no longer than any path between them on the surface, so the chord is a
  // lower bound of the geodesic distance, and a close one (the ratio is 1 + d^2 / (24 R^2) on a
  // sphere: 1 + 1e-5 at 100 km, where the plane's lower_scale() leaves the frame's whole scale
  // range), at the cost of a square root instead of an inverse problem.
  struct Xyz {
    double x = 0.0, y = 0.0, z = 0.0;
  };
  std::vector<Xyz> vertex_xyz, site_xyz;  // per barrier vertex; per site, its first end
  Xyz xyz(Vec2 ll) const;
  Xyz spot_xyz(const Spot& s) const { return geodesic ? xyz(s.ll) : Xyz{}; }  // (planar: unused)
  // The chord between two positions less its rounding (coordinates of 6.4e6 m carry errors of
  // nanometres) and GeographicLib's own error (15 nm): never above the distance the inverse
  // problem returns for the same two points.
  static double chord_below(const Xyz& a, const Xyz& b) { return chord(a, b) * (1.0 - 1e-12) - 1e-6; }
  // The chord itself, as computed (metres).
  static double chord(const Xyz& a, const Xyz& b) {
    const double dx = a.x - b.x, dy = a.y - b.y, dz = a.z - b.z;
    return std::sqrt(dx * dx + dy * dy + dz * dz);
  }
};

// Checks the seeds (sites, no vertex on land: rv::Error naming the feature) and moves seeds and
// barriers into the plane: the grid's local frame (planar), or a geodesic frame over the grid, the barriers and the
// seeds (geodesic: seeds and barriers in longitude/latitude, a line's or polygon's edges geodesics as the barriers'
// are; the grid in longitude/latitude too, or projected with a geolocator for its cell centres).
Prepared prepare(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const MetricSpec& metric,
                 std::shared_ptr<const Geolocator> geolocator = nullptr);

// Seeds with weights or reaches (SeedSet::adjusted): a path's cost is its length over its
// site's weight, where the length is within the site's reach (adjusted_distance). Sites of one
// (weight, reach) compare by length alone, so the cheapest path of such a class is its shortest
// one, the unweighted statement over its sites; a position's answer is the least cost over the
// classes (ties to the lower site). `sites` (ascending) grouped by their feature's weight and
// reach, classes in order of their first site, sites ascending within each.
struct SiteClass {
  double weight = 1.0;
  double reach = std::numeric_limits<double>::infinity();
  std::vector<int32_t> sites;
};
std::vector<SiteClass> site_classes(const SeedSet& seeds, const std::vector<int32_t>& sites);

// The polygon seeds' interiors over a window: in the grid's plane on `grid_polygons` when given
// (a projected geodesic grid, as the straight engines test them), else on the seeds' own.
InteriorSpans interiors_of(const SeedSet& seeds, const std::vector<Polygon>* grid_polygons, const GridSpec& grid,
                           const Window& window);

// Where a shortest path may bend: a barrier vertex in a sea wedge wider than a half-turn. A taut
// path turns round land, so it bends only where the sea's angle exceeds 180 degrees; elsewhere
// it could be pulled straighter. (A line's end has one wedge all round, so it qualifies.)
struct Node {
  int32_t vertex;
  int wedge;
};
std::vector<Node> bend_nodes(const Visibility& vis);

// Whether a path that reached bend node `node` from `from` (its previous bend, or the point of
// the site it left) may bend there towards x: the turn wraps round the land at the node (the
// shorter way round from the arrival to the departure passes over the land), so that no path
// straighter than it exists nearby. A path that starts at the node (from == the node: a seed
// touches it; or a computed point within Visibility::slack of it, a seed's end on the node
// measured to rounding) may leave in any direction. Necessary for a shortest path's bend; exact.
bool taut(const Visibility& vis, const Node& node, Vec2 from, Vec2 x);

// taut() with the node and the arrival fixed (a settled node's: every search weighs it against
// many departures): what does not depend on the departure is worked out once, and the arrival
// line's orientation is filtered inline before the reading's predicate. taut(vis, t, x) equals
// taut(vis, node, from, x) for every x, to the bit (the same predicates, decided alike).
// A value type; valid while `vis` lives.
struct TautTest {
  Vec2 at{}, from{}, land_end{};
  double ax = 0.0, ay = 0.0;  // from - at
  double near = 0.0;          // Visibility::slack(at, from)
  double slack = 0.0;         // rounding_slack(at, from): the straight-on allowance
  double line_bend = 0.0;     // |from - at| times the frame's deviation (0 planar)
  bool any = false;           // from the node itself (or within `near`): any departure
  bool from_vertex = false;   // from is a barrier vertex
  bool land_at_arrival = false;
  int land_side = 0;  // orient(at, from, land_end); 0 also for a vertex without rays
  int land_half = 0;  // where land_end lies from the arrival's direction: 0 left, 1 right or straight back, -1 ahead
};
TautTest taut_test(const Visibility& vis, const Node& node, Vec2 from);
bool taut(const Visibility& vis, const TautTest& t, Vec2 x);

// Whether taut(vis, t, x) is false for every x of the box [lo, hi] (plane coordinates), proved
// from the box's corners: the departures taut() accepts lie in the sector between the land's far
// ray at the node and the arrival's straight continuation (narrower than a half-turn), and the
// box lies wholly outside one of the two half-planes that bound it, by more than the reading's
// slack (and, beside the arrival's line, the straight-on allowance). False when unsure.
bool never_taut(const Visibility& vis, const TautTest& t, Vec2 lo, Vec2 hi);

// The arrivals at a bend node that no path goes on from. A straight path into node u from q whose
// continuation past u runs strictly into the wedge next to u's own (for a vertex of two rays,
// the land's: q strictly inside the wedge opposite it) leaves taut() only departures between
// that continuation and the land's far ray, all inside that other wedge, which no path seen from
// u's wedge leaves by (Visibility::sees). So a settled node whose own path arrives so is the last
// bend of no path: the settlings leave it out of the roots (bend_settle.hpp, Searches::root).
// About a third of the bend nodes of a real coast are such: reached head on from the open sea.
// Decided in the plane with margins beyond rounding and the frame's bending (the reading's
// orientation filter, rv/sea/geodesic_frame.hpp), so that in the reading's own predicates (on
// the ellipsoid, azimuths at u) q's direction lies strictly inside the opposite wedge; unsure is
// "may go on". At a vertex with other than two rays every arrival may go on.
// A value type; valid while the Visibility it was made from lives.
class DeadArrivals {
 public:
  DeadArrivals(const Visibility& vis, const Node& node);
  // Whether an arrival from q is dead: q - at strictly right of the near ray and left of the far
  // one, each beyond a relative margin plus the absolute one.
  bool from(Vec2 q) const {
    const double wx = q.x - at_.x, wy = q.y - at_.y, w1 = std::abs(wx) + std::abs(wy);
    return active_ && nx_ * wy - ny_ * wx < -(kRelative * n1_ * w1 + kn_) &&
           fx_ * wy - fy_ * wx > kRelative * f1_ * w1 + kf_;
  }

 private:
  static constexpr double kRelative = 1e-8;
  Vec2 at_{};
  double nx_ = 0.0, ny_ = 0.0, fx_ = 0.0, fy_ = 0.0;  // the near and far rays of the other wedge
  double n1_ = 0.0, f1_ = 0.0;                        // their lengths
  double kn_ = 0.0, kf_ = 0.0;                        // absolute margins: bending, coordinates' rounding
  bool active_ = false;
};

// An empty field of the window (no owner anywhere) with the barriers' vertex count, and the
// straight key a maximum distance allows (+infinity for none). Not `filled`: the rasters' cells
// are left for the caller to empty row by row with empty_rows() (on the threads that go on to
// write them, so that the pages are first touched in parallel) before any is read.
SeaField empty_field(const Prepared& p, const GridSpec& grid, const Window& window, const MetricSpec& metric,
                     bool filled = true);
void empty_rows(SeaField& field, int64_t r0, int64_t r1);
inline double max_key_of(double max_distance) {
  return std::isfinite(max_distance) ? max_distance * max_distance : std::numeric_limits<double>::infinity();
}

}  // namespace rv::sea
