// Internal: seed sites prepared for geodesic measuring, and the bounds the engines cull with.
//
// Bounds (all provable, all in metres):
//   lower  Any path on the ellipsoid between two points is at least as long as the straight
//          3-D chord between them (in Earth-centred, Earth-fixed coordinates). So for a set of
//          cell centres inside an axis-aligned ECEF box and a site piece inside a ball
//          (centre c, radius r), every geodesic distance is >= dist(c, box) - r.
//          A segment piece of arc length l whose middle point is M lies in the ball (M, l/2):
//          every point of it is within arc length l/2 of M along the piece, and chord <= arc.
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
#include <vector>

#include "rv/metric.hpp"
#include "rv/seeds.hpp"

namespace rv::detail {

// Added to every culling comparison: covers rounding in bounds and GeographicLib's error
// (15 nm) with a wide margin while costing nothing measurable.
inline constexpr double kGeoSlack = 1e-3;  // metres
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

inline double box_distance(const EcefBox& b, double x, double y, double z) {
  const double dx = x < b.x0 ? b.x0 - x : (x > b.x1 ? x - b.x1 : 0.0);
  const double dy = y < b.y0 ? b.y0 - y : (y > b.y1 ? y - b.y1 : 0.0);
  const double dz = z < b.z0 ? b.z0 - z : (z > b.z1 ? z - b.z1 : 0.0);
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

struct GeoPiece {
  double ta, tb;     // arc length along the site's line, metres
  double ax, ay, az; // ECEF of the piece's ends (for the starting guess)
  double bx, by, bz;
  GeoBall ball;      // contains every point of the piece
};

struct GeoSite {
  bool segment = false;
  double lat = 0.0, lon = 0.0;  // the point (segments: first end)
  double x = 0.0, y = 0.0, z = 0.0;
  int32_t line = -1;            // index into lines (segments)
  int32_t piece0 = 0, piece_count = 0;
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

  // Geodesic distance in metres from the cell to the site (point or segment).
  double distance(const GeoCell& p, int32_t id) const;
  // Lower bounds of distance(): from one cell, and from any cell centre inside a box.
  double lower_bound(const GeoCell& p, int32_t id) const;
  double lower_bound(const EcefBox& box, int32_t id) const;

  double max_meridian_radius() const { return max_meridian_radius_; }
  const GeographicLib::Geodesic& geodesic() const { return geod_; }
  size_t size() const { return sites_.size(); }

 private:
  void prepare(const std::vector<Site>& sites, const SeedSet* seeds);
  double piece_distance(const GeoCell& p, const GeographicLib::GeodesicLine& line,
                        const GeoPiece& piece) const;

  GeographicLib::Geodesic geod_;
  double a_, e2_;
  double max_meridian_radius_;
  std::vector<GeoSite> sites_;
  std::vector<GeoPiece> pieces_;
  std::vector<GeographicLib::GeodesicLine> lines_;
};

}  // namespace rv::detail
