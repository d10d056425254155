#include "rv/field/metric.hpp"

#include <cmath>

#include "rv/field/error.hpp"

namespace rv {

std::string_view to_string(MetricSpec::Kind kind) { return kind == MetricSpec::geodesic ? "geodesic" : "planar"; }

void validate_metric(const MetricSpec& metric) {
  if (metric.kind == MetricSpec::planar) return;
  if (!std::isfinite(metric.semi_major) || !(metric.semi_major > 0.0))
    throw Error(ErrorKind::invalid_argument,
                "geodesic metric: the ellipsoid's semi-major axis must be a positive number of metres");
  // GeographicLib::Geodesic uses series in the third flattening that are accurate for |f| <= 0.01;
  // every terrestrial ellipsoid is far inside that range.
  if (!std::isfinite(metric.flattening) || std::abs(metric.flattening) > 0.01)
    throw Error(ErrorKind::invalid_argument, "geodesic metric: flattening must be within [-0.01, 0.01]");
}

MetricRequest parse_metric_request(std::string_view name) {
  if (name == "auto") return MetricRequest::automatic;
  if (name == "planar") return MetricRequest::planar;
  if (name == "geodesic") return MetricRequest::geodesic;
  throw Error(ErrorKind::invalid_argument,
              "unknown metric '" + std::string(name) + "' (expected auto, planar or geodesic)");
}

MetricSpec resolve_metric(MetricRequest requested, bool crs_is_geographic, double semi_major, double flattening) {
  MetricSpec m;
  m.semi_major = semi_major;
  m.flattening = flattening;
  switch (requested) {
    case MetricRequest::automatic:
      m.kind = crs_is_geographic ? MetricSpec::geodesic : MetricSpec::planar;
      break;
    case MetricRequest::planar:
      if (crs_is_geographic)
        throw Error(ErrorKind::invalid_argument,
                    "metric planar refused on a geographic (longitude/latitude) CRS: planar distance "
                    "would measure degrees, and a degree of longitude shrinks from 111 km at the "
                    "equator to 0 at the poles, so cells would go to the wrong seed; use metric "
                    "geodesic (or auto), or reproject the seeds and grid to a projected CRS");
      m.kind = MetricSpec::planar;
      break;
    case MetricRequest::geodesic:
      // On a projected CRS too: cell centres are then located on the ellipsoid by the caller's
      // Geolocator (ComputeOptions::geolocator).
      m.kind = MetricSpec::geodesic;
      break;
  }
  validate_metric(m);
  return m;
}

DistanceUnit parse_distance_unit(std::string_view name) {
  if (name == "m") return DistanceUnit::m;
  if (name == "km") return DistanceUnit::km;
  if (name == "nmi") return DistanceUnit::nmi;
  throw Error(ErrorKind::invalid_argument, "unknown distance unit '" + std::string(name) + "' (expected m, km or nmi)");
}

std::string_view to_string(DistanceUnit unit) {
  switch (unit) {
    case DistanceUnit::m:
      return "m";
    case DistanceUnit::km:
      return "km";
    case DistanceUnit::nmi:
      return "nmi";
  }
  return "m";
}

double metres_per_unit(DistanceUnit unit) {
  switch (unit) {
    case DistanceUnit::m:
      return 1.0;
    case DistanceUnit::km:
      return 1000.0;
    case DistanceUnit::nmi:
      return 1852.0;
  }
  return 1.0;
}

double unwrap_east_longitude(double west, double east) { return east < west ? east + 360.0 : east; }

}  // namespace rv
