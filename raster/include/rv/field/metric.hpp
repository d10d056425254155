// Which distance the engines measure, and the units distances are reported in.
//
// Two metrics:
//   planar    Euclidean distance in the grid's CRS units (for projected grids: metres or feet).
//   geodesic  Shortest-path distance on an ellipsoid of revolution (semi-major axis a in metres,
//             flattening f), computed with GeographicLib (C. F. F. Karney, "Algorithms for
//             geodesics", J. Geodesy 87:43-55, 2013). Grid and seed coordinates are then
//             longitude (x) and latitude (y) in degrees; distances are metres.
//
// Geodesic on a *projected* grid (UTM, a national grid, ...): the seeds are still longitude /
// latitude degrees (of the CRS's geographic base), and every cell centre is taken to longitude /
// latitude on the CRS's ellipsoid by a caller-supplied rv::Geolocator (rv/field/geolocate.hpp,
// ComputeOptions::geolocator) before measuring. The core does not link PROJ; the vector layer
// provides an OSR-backed Geolocator.
//
// All functions are pure and thread-safe.
#pragma once

#include <string>
#include <string_view>

namespace rv {

inline constexpr double kWgs84SemiMajor = 6378137.0;             // metres
inline constexpr double kWgs84Flattening = 1.0 / 298.257223563;  // dimensionless

struct MetricSpec {
  enum Kind { planar, geodesic };
  Kind kind = planar;
  double semi_major = kWgs84SemiMajor;   // metres, geodesic only; finite, > 0
  double flattening = kWgs84Flattening;  // geodesic only; |f| <= 0.01 (GeographicLib::Geodesic's
                                         // accuracy range: errors of 15 nm for WGS84)
  bool operator==(const MetricSpec&) const = default;
};

std::string_view to_string(MetricSpec::Kind kind);

// Throws rv::Error(invalid_argument) when a geodesic spec has an unusable ellipsoid.
void validate_metric(const MetricSpec& metric);

// The user's request (--metric auto|planar|geodesic).
enum class MetricRequest { automatic, planar, geodesic };
// Accepts "auto", "planar", "geodesic"; throws rv::Error(invalid_argument) otherwise.
MetricRequest parse_metric_request(std::string_view name);

// The policy: auto = geodesic on a geographic CRS, planar otherwise (auto never picks geodesic
// on a projected CRS: the projection's own metres are what such a grid was made for).
// geodesic on a projected CRS is allowed (the engine then needs a Geolocator, see above).
// Refusal: planar on a geographic CRS -> rv::Error(invalid_argument): degrees are not a distance.
// semi_major / flattening describe the CRS's ellipsoid (used for geodesic only).
MetricSpec resolve_metric(MetricRequest requested, bool crs_is_geographic, double semi_major = kWgs84SemiMajor,
                          double flattening = kWgs84Flattening);

// Units for reported distances (--distance-units m|km|nmi). The engines always return metric
// units (metres for geodesic); the caller divides by metres_per_unit() when writing output.
enum class DistanceUnit { m, km, nmi };
// Accepts "m", "km", "nmi" (case-sensitive); throws rv::Error(invalid_argument) otherwise.
DistanceUnit parse_distance_unit(std::string_view name);
std::string_view to_string(DistanceUnit unit);
// 1, 1000, 1852 (the international nautical mile is exactly 1852 m).
double metres_per_unit(DistanceUnit unit);

// For antimeridian-crossing extents given west > east (e.g. 170 .. -170): returns the east edge
// moved by +360 so that east > west (190), which is how geodesic grids express the crossing
// (cell longitudes beyond 180 are normalised when measuring). Other extents are returned as is.
double unwrap_east_longitude(double west, double east);

}  // namespace rv
