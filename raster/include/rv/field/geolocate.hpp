// Cell centres of a projected grid located on the ellipsoid, for the geodesic metric.
//
// The core does not link PROJ. A caller that wants geodesic distances on a grid in a projected
// CRS (UTM, a national grid, ...) supplies a Geolocator: the conversion between the grid CRS's
// coordinates and longitude/latitude on the same datum's ellipsoid (the CRS's geographic base).
// The engine then measures on the ellipsoid exactly as on a geographic grid: every cell centre
// (x, y) of the grid is taken to (lon, lat) and the geodesic distance to the seeds, which are in
// longitude/latitude degrees, is computed there.
//
// Contract for implementations:
//   - to_lonlat: grid CRS units (metres, feet, ...) in, degrees out (longitude east, latitude
//     north, latitude within [-90, 90]); a point outside the projection's domain throws
//     rv::Error(invalid_input).
//   - to_grid: the inverse, degrees in, grid CRS units out (used to place seeds in the grid for
//     the scans' seeding and for culling hints; it need not be exact to better than a cell).
//   - Both are called concurrently from the engine's threads: implementations must be
//     thread-safe (e.g. one PROJ transformation per thread) and deterministic (the same input
//     gives the same bits on every call and thread).
//   - Batches: n points per call, arrays of length n, n may be 0. Output arrays never alias input.
#pragma once

#include <cstddef>

namespace rv {

class Geolocator {
 public:
  virtual ~Geolocator() = default;
  virtual void to_lonlat(const double* x, const double* y, double* lon, double* lat, size_t n) const = 0;
  virtual void to_grid(const double* lon, const double* lat, double* x, double* y, size_t n) const = 0;
};

}  // namespace rv
