// Internal: seed sites prepared for geodesic measuring, and the bounds the engines cull with.
//
// Bounds (all provable, all in metres):
//   lower  Any path on the ellipsoid between two points is at least as long as the straight
//          3-D chord between them (in Earth-centred, Earth-fixed coordinates). So for a set of
//          cell centres inside an axis-aligned ECEF box and a site piece inside a ball
//          (centre c, radius r), every geodesic distance is >= dist(c, box) - r.
//          A segment piece of arc length l whose middle point is M lies in the ball (M, l/2):
//          every point of it is within arc length l/2 of M along the piece, and chord <= arc.
//          It also lies in a thin capsule around its chord A-B (length c): a point X at arc
//          length t from A has |XA| <= t and |XB| <= l - t, so |XA| + |XB| <= l: X is inside
//          the spheroid with foci A, B and major axis l, whose points are within
//          h = sqrt(((l - c)/2)^2 + (l^2 - c^2)/4) of the segment A-B (radial extent
//          sqrt(l^2 - c^2)/2, overshoot beyond the foci (l - c)/2). For a 500 m coastline edge
//          h is ~5 mm, so the capsule bound is nearly the exact 3-D distance to the edge.
//          Both bounds hold; the larger is used.
//          Far away (chord > 1000 km) the chord falls well short of the geodesic; then also:
//          the ellipsoid lies outside the ball of its smaller semi-axis r (r = b when oblate),
//          and the nearest-point projection onto that ball is 1-Lipschitz, so a path on the
//          ellipsoid projects to a no longer path on the sphere of radius r between the same
//          directions: geodesic >= r * angle(P, Q) (angle between ECEF vectors). A piece lies
//          within angle (l/2)/r of its middle, and a set of cells within a ball of radius h
//          around C within asin(h/|C|) of C's direction.
//   upper  Geodesic distance is the length of the shortest path, so any path bounds it. From a
//          cell P to a cell C: along P's parallel to C's longitude (length rho(P) |dlon|, rho the
//          parallel's radius N cos(lat)), then along the meridian to C's latitude (length <=
//          M_max |dlat|, M_max the largest meridional radius of curvature: a^2/b at the poles of
//          an oblate ellipsoid). With the triangle inequality d(P, s) <= d(P, C) + d(C, s).
// Rounding in these bounds is ~1e-8 m (ECEF magnitudes 6.4e6 m); the engines add kGeoSlack.
#pragma once

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "rv/field/metric.hpp"
#include "rv/field/seeds.hpp"

namespace rv::detail {

// Added to every culling comparison: covers rounding in bounds and GeographicLib's error
// (15 nm) with a wide margin while costing nothing measurable.
inline constexpr double kGeoSlack = 1e-3;  // metres
// The segment search (GeoSites::piece_distance) stops when the distance at its current point
// exceeds the minimum by less than this (estimated as |cos w * dt| / 2, the second-order excess
// of a convex function): its test is |dt cos w| < 2 kGeoConvergence. The exact method's vertex
// margin depends on it (geodesic_exact.cpp, kVertexStop4).
inline constexpr double kGeoConvergence = 1e-10;  // metres
// Edges are searched and bounded in pieces no longer than this.
inline constexpr double kGeoPieceLength = 100e3;  // metres

struct GeoCell {
  double lat, lon;  // degrees
  double x, y, z;   // ECEF, metres
};

struct EcefBox {
  double x0, x1, y0, y1, z0, z1;
};

struct GeoBall {
  double x, y, z, r;
};

// An ECEF box seen as a ball: its middle and half diagonal (every point of it is within `half`
// of the middle), for GeoSites::lower_bound over many sites from one box.
struct BoxBall {
  double x, y, z, half;
};
inline BoxBall box_ball(const EcefBox& b) {
  return BoxBall{
      0.5 * (b.x0 + b.x1), 0.5 * (b.y0 + b.y1), 0.5 * (b.z0 + b.z1),
      0.5 * std::sqrt((b.x1 - b.x0) * (b.x1 - b.x0) + (b.y1 - b.y0) * (b.y1 - b.y0) + (b.z1 - b.z0) * (b.z1 - b.z0))};
}

inline double box_distance(const EcefBox& b, double x, double y, double z) {
  const double dx = x < b.x0 ? b.x0 - x : (x > b.x1 ? x - b.x1 : 0.0);
  const double dy = y < b.y0 ? b.y0 - y : (y > b.y1 ? y - b.y1 : 0.0);
  const double dz = z < b.z0 ? b.z0 - z : (z > b.z1 ? z - b.z1 : 0.0);
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

struct GeoPiece {
  double ta, tb;      // arc length along the site's line, metres
  double ax, ay, az;  // ECEF of the piece's ends
  double bx, by, bz;
  double inv_len2;  // 1 / |B - A|^2 (0 if the ends coincide in ECEF)
  double capsule;   // every point of the piece is within this of the chord segment A-B
  GeoBall ball;     // contains every point of the piece
};

// The capsule part of piece_chord_bound alone (a valid, sometimes weaker bound with one root).
inline double piece_capsule_bound(const GeoPiece& p, double x, double y, double z) {
  const double ux = p.bx - p.ax, uy = p.by - p.ay, uz = p.bz - p.az;
  double t = ((x - p.ax) * ux + (y - p.ay) * uy + (z - p.az) * uz) * p.inv_len2;
  t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
  const double ex = x - (p.ax + t * ux), ey = y - (p.ay + t * uy), ez = z - (p.az + t * uz);
  return std::sqrt(ex * ex + ey * ey + ez * ez) - p.capsule;
}

// Lower bound of the chord distance from (x, y, z) to any point of the piece.
inline double piece_chord_bound(const GeoPiece& p, double x, double y, double z) {
  const double ball =
      std::sqrt((x - p.ball.x) * (x - p.ball.x) + (y - p.ball.y) * (y - p.ball.y) + (z - p.ball.z) * (z - p.ball.z)) -
      p.ball.r;
  const double ux = p.bx - p.ax, uy = p.by - p.ay, uz = p.bz - p.az;
  double t = ((x - p.ax) * ux + (y - p.ay) * uy + (z - p.az) * uz) * p.inv_len2;
  t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
  const double ex = x - (p.ax + t * ux), ey = y - (p.ay + t * uy), ez = z - (p.az + t * uz);
  const double capsule = std::sqrt(ex * ex + ey * ey + ez * ez) - p.capsule;
  return ball > capsule ? ball : capsule;
}

struct GeoSite {
  bool segment = false;
  double lat = 0.0, lon = 0.0;  // the point (segments: first end), as given
  double x = 0.0, y = 0.0, z = 0.0;
  // Segments: the second end as given, the length, and the azimuths of the edge (direction
  // first -> second end) at both ends.
  double lat_b = 0.0, lon_b = 0.0, length = 0.0, azi_a = 0.0, azi_b = 0.0;
  int32_t line = -1;  // index into lines (segments)
  int32_t piece0 = 0, piece_count = 0;
};

// Where a segment distance was attained, when it was at one of the segment's ends: the distance
// is then the *canonical* vertex distance (the inverse problem from the vertex as given to the
// cell, the same bits for every edge sharing that vertex).
struct GeoEnd {
  bool valid = false;
  double lat = 0.0, lon = 0.0;  // the vertex
  double azi_to_cell = 0.0;     // azimuth at the vertex of the geodesic to the cell
  // Whatever the valid flag: at the point of the edge measured nearest, the sine of the angle
  // from the edge's direction to the geodesic toward the cell (+1 for a cell square to the
  // right of the edge, -1 to the left; 0 if nothing was measured).
  double sin_w = 0.0;
  // Whatever the valid flag: the azimuth at the cell (degrees) of the geodesic arriving there
  // from the point of the edge measured nearest, the direction in which the distance grows
  // fastest (NaN if nothing was measured).
  double azi_at_cell = std::numeric_limits<double>::quiet_NaN();
  // Whatever the valid flag: the arc length along the segment's line (metres from its first end)
  // of its point nearest the cell, to well under a micrometre (NaN if nothing was measured).
  double foot = std::numeric_limits<double>::quiet_NaN();
};

class GeoSites {
 public:
  // Prepares every site (area sites get an unused entry). Throws rv::Error(invalid_input) for a
  // latitude outside [-90, 90], naming the feature.
  GeoSites(const MetricSpec& metric, const SeedSet& seeds);
  // Prepares a bare list of sites (no feature names in messages).
  GeoSites(const MetricSpec& metric, const std::vector<Site>& sites);

  GeoCell cell(double lon, double lat) const;
  void ecef(double lat, double lon, double& x, double& y, double& z) const;

  // Geodesic distance in metres from the cell to the site (point or segment). When `end` is
  // given it says whether the distance was attained at an end of a segment (see GeoEnd).
  double distance(const GeoCell& p, int32_t id, GeoEnd* end = nullptr) const;
  // True when distance(p, id) certainly equals, bit for bit, the canonical distance `s` of the
  // vertex `end` (computed for another edge): the vertex is an end of this single-piece edge,
  // the cell is in the convex regime of the edge and the geodesic from the vertex to the cell
  // leaves at more than ~90.6 degrees from the edge, so the search ends at that vertex.
  bool attains_at_vertex(const GeoCell& p, int32_t id, const GeoEnd& end, double s) const;
  // The position (degrees) at arc length t (metres, clamped to the segment) along a segment's
  // line: its ends as given; a point site's position whatever t.
  void position(int32_t id, double t, double& lat, double& lon) const;
  // Lower bounds of distance(): from one cell, and from any cell centre inside a box.
  double lower_bound(const GeoCell& p, int32_t id) const;
  double lower_bound(const EcefBox& box, int32_t id) const { return lower_bound(box, box_ball(box), id); }
  // The same with the box's ball made once (box_ball(box)) for many sites.
  double lower_bound(const EcefBox& box, const BoxBall& ball, int32_t id) const;

  double max_meridian_radius() const { return max_meridian_radius_; }
  // Lower bound of the geodesic distance from any point within h of (x, y, z) (h = 0: the point
  // itself; (x, y, z) on or near the ellipsoid) to any point of the piece; same for a point
  // site at (sx, sy, sz).
  double piece_lower_bound(const GeoPiece& p, double x, double y, double z, double h) const;
  double point_lower_bound(double sx, double sy, double sz, double x, double y, double z, double h) const;
  const GeographicLib::Geodesic& geodesic() const { return geod_; }
  size_t size() const { return sites_.size(); }
  // The one piece of a single-piece segment (its chord bounds, piece_chord_bound and
  // piece_capsule_bound, are lower bounds of distance() too, weaker than lower_bound()); null
  // otherwise.
  const GeoPiece* single_piece(int32_t id) const {
    const GeoSite& s = sites_[static_cast<size_t>(id)];
    return s.segment && s.piece_count == 1 ? &pieces_[static_cast<size_t>(s.piece0)] : nullptr;
  }
  const GeoSite& site(int32_t id) const { return sites_[static_cast<size_t>(id)]; }

 private:
  void prepare(const std::vector<Site>& sites, const SeedSet* seeds);
  double piece_distance(const GeoCell& p, const GeoSite& site, const GeoPiece& piece, GeoEnd* end) const;
  bool convex_regime(const GeoCell& p, const GeoPiece& piece) const;

  GeographicLib::Geodesic geod_;
  // r * (angle(P, Q) - pad) - radius: the far-field bound (see the top of this file).
  double angular_bound(double x, double y, double z, double qx, double qy, double qz, double h, double radius) const;

  double a_, e2_;
  double max_meridian_radius_;
  double inner_radius_;  // min(a, b): the ellipsoid lies outside this ball
  std::vector<GeoSite> sites_;
  std::vector<GeoPiece> pieces_;
  std::vector<GeographicLib::GeodesicLine> lines_;
};

}  // namespace rv::detail
