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
#include <vector>

#include "rv/field/metric.hpp"
#include "rv/field/planar.hpp"
#include "rv/field/seeds.hpp"
#include "rv/geodesic/geodesic.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/visibility.hpp"

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

// A point as the engines hold it: where it is in the plane, and (geodesic) its longitude and
// latitude, which its distances are measured from.
struct Spot {
  Vec2 at;
  Vec2 ll;
};

struct Prepared {
  Visibility vis;
  std::vector<LocalSite> local;    // the sites in the plane
  std::vector<int32_t> geometric;  // point and segment sites
  // Geodesic (vis.frame() set): distances between longitudes and latitudes on the ellipsoid, the
  // vertices' and the point sites' positions there, and the frame's largest scale (a plane
  // distance d is at least d / max_scale metres: the search trees' lower bounds).
  std::shared_ptr<const GeodesicMeasure> geodesic;
  std::vector<Vec2> vertex_ll, site_ll;
  double max_scale = 1.0;

  // A site's key from x (its squared distance: planar_key, or the geodesic distance squared).
  double site_key(const Spot& x, int32_t site) const {
    if (!geodesic) return planar_key(x.at.x, x.at.y, local[static_cast<size_t>(site)]);
    const double d = geodesic->point_distance(x.ll, site_ll[static_cast<size_t>(site)]);
    return d * d;
  }
  // The length of the straight path from vertex v to x.
  double vertex_length(int32_t v, const Spot& x) const {
    if (!geodesic) return length(vis.vertex(v), x.at);
    return geodesic->point_distance(vertex_ll[static_cast<size_t>(v)], x.ll);
  }
  Spot vertex_spot(int32_t v) const {
    return Spot{vis.vertex(v), geodesic ? vertex_ll[static_cast<size_t>(v)] : Vec2{}};
  }
  // A cell's centre.
  Spot cell(const GridSpec& grid, int64_t col, int64_t row) const {
    if (!geodesic) return Spot{Vec2{grid.local_x(col), grid.local_y(row)}, Vec2{}};
    const Vec2 ll{grid.centre_x(col), grid.centre_y(row)};
    return Spot{vis.frame()->forward(ll), ll};
  }
  // Lower bounds in the measure's units from plane distances: d * lower_scale().
  double lower_scale() const { return 1.0 / max_scale; }
};

// Checks the seeds (sites, no weights, reaches or partial effect, no vertex on land: rv::Error
// naming the feature) and moves seeds and barriers into the plane: the grid's local frame
// (planar), or a geodesic frame over the grid, the barriers and the seeds (geodesic: a
// longitude/latitude grid and point seeds; rv::Error(unsupported) for lines and polygons).
Prepared prepare(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const MetricSpec& metric);

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
// touches it) may leave in any direction. Necessary for a shortest path's bend; exact.
bool taut(const Visibility& vis, const Node& node, Vec2 from, Vec2 x);

// The nearest point of a site from x (the local frame), as planar_key measures it, marked
// computed (not exact) where it is the foot of a perpendicular.
inline Place nearest_point(const LocalSite& s, Vec2 x) {
  double t = ((x.x - s.ax) * s.dx + (x.y - s.ay) * s.dy) * s.inv_len2;
  t = std::clamp(t, 0.0, 1.0);
  if (t == 0.0) return Place{Vec2{s.ax, s.ay}};
  if (t == 1.0) return Place{Vec2{s.bx(), s.by()}};
  Place p{Vec2{s.ax + t * s.dx, s.ay + t * s.dy}};
  p.exact = false;
  return p;
}

// An empty field of the window (no owner anywhere) with the barriers' vertex count, and the
// straight key a maximum distance allows (+infinity for none).
SeaField empty_field(const Prepared& p, const GridSpec& grid, const Window& window, const MetricSpec& metric);
inline double max_key_of(double max_distance) {
  return std::isfinite(max_distance) ? max_distance * max_distance : std::numeric_limits<double>::infinity();
}

}  // namespace rv::sea
