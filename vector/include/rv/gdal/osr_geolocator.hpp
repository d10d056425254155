// An rv::Geolocator (rv/field/geolocate.hpp) backed by GDAL's OSR/PROJ: between a projected grid CRS
// and its geographic base CRS (the same datum's longitude/latitude, OSRCloneGeogCS), for the
// geodesic metric on projected grids. GDAL types stay behind this header.
//
// Axis order: traditional GIS order on both sides (x = easting, y = northing; lon = longitude
// east, lat = latitude north, degrees), whatever the CRS definitions say.
// Units: grid side in the CRS's own linear unit (metres, US feet, ...), geographic side in
// degrees (the base CRS's angular unit is not honoured if it is not degrees: OSR's transform
// returns degrees for traditional-order geographic CRSs with degree units, which is what
// EPSG-defined bases use; a base CRS in grads or radians is refused at construction).
//
// Thread safety: to_lonlat / to_grid may be called from any number of threads at once. Each
// thread gets its own pair of OGRCoordinateTransformation objects (PROJ transformations are not
// safe to share between threads), created on the thread's first call and owned by the
// geolocator; afterwards a call takes no lock (a small thread-local cache finds the thread's
// pair). Destroying the geolocator while calls are in flight is undefined.
// Determinism: every thread's transformation is built from the same two CRS objects with the
// same options, so the same input gives the same bits on every thread; a batch gives the same
// bits as its points one at a time (PROJ transforms each point independently).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>

#include "rv/field/geolocate.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace rv {

class OsrGeolocator final : public Geolocator {
 public:
  // `grid_crs`: any definition OSR understands (WKT, "EPSG:32633", PROJ string) of a projected
  // CRS. Throws rv::Error(invalid_argument) when it cannot be parsed, is geographic (nothing to
  // locate) or has no geographic base, rv::Error(unsupported) when PROJ has no transformation
  // between it and its base.
  explicit OsrGeolocator(const std::string& grid_crs);
  ~OsrGeolocator() override;
  OsrGeolocator(const OsrGeolocator&) = delete;
  OsrGeolocator& operator=(const OsrGeolocator&) = delete;

  // Grid CRS units in, degrees out. A point PROJ cannot transform (outside the projection's
  // domain, non-finite) throws rv::Error(invalid_input) naming the point; no partial result is
  // promised then.
  void to_lonlat(const double* x, const double* y, double* lon, double* lat, size_t n) const override;
  // Degrees in, grid CRS units out; failures as for to_lonlat.
  void to_grid(const double* lon, const double* lat, double* x, double* y, size_t n) const override;

  // The geographic base CRS (WKT2), e.g. to load seeds into it, and its description (ellipsoid).
  const std::string& geographic_wkt() const { return geographic_wkt_; }
  const CrsInfo& geographic_crs() const { return geographic_info_; }

 private:
  struct Impl;
  struct PerThread;
  PerThread& local() const;
  void transform(bool inverse, const double* in_x, const double* in_y, double* out_x, double* out_y, size_t n) const;

  std::unique_ptr<Impl> impl_;
  std::string geographic_wkt_;
  CrsInfo geographic_info_;
  const uint64_t serial_;     // unique per geolocator for the thread-local cache (never reused)
  mutable std::mutex mutex_;  // guards per_thread_ (taken only on a thread's first call)
  mutable std::unordered_map<std::thread::id, std::unique_ptr<PerThread>> per_thread_;
};

}  // namespace rv
