// A Geolocator for the tests of projected geodesic grids: UTM zone 33N on WGS84 with
// GeographicLib's UTMUPS (no PROJ in the core).
#pragma once

#include <GeographicLib/UTMUPS.hpp>

#include <atomic>
#include <cmath>
#include <cstdint>

#include "rv/field/error.hpp"
#include "rv/field/geolocate.hpp"

namespace rv::test {

// UTM zone 33N on WGS84, exact to GeographicLib's accuracy (5 nm). to_grid refuses points more
// than 30 degrees from the central meridian (its "domain", to exercise sites outside it).
class Utm33 final : public Geolocator {
 public:
  void to_lonlat(const double* x, const double* y, double* lon, double* lat, size_t n) const override {
    calls_.fetch_add(1, std::memory_order_relaxed);
    for (size_t i = 0; i < n; ++i) {
      try {
        GeographicLib::UTMUPS::Reverse(33, true, x[i], y[i], lat[i], lon[i]);
      } catch (const GeographicLib::GeographicErr& e) {
        throw Error(ErrorKind::invalid_input, e.what());
      }
    }
  }
  void to_grid(const double* lon, const double* lat, double* x, double* y, size_t n) const override {
    for (size_t i = 0; i < n; ++i) {
      if (std::abs(lon[i] - 15.0) > 30.0) throw Error(ErrorKind::invalid_input, "outside zone 33's domain");
      int zone;
      bool northp;
      GeographicLib::UTMUPS::Forward(lat[i], lon[i], zone, northp, x[i], y[i], 33);
    }
  }
  int64_t calls() const { return calls_.load(); }

 private:
  mutable std::atomic<int64_t> calls_{0};
};

}  // namespace rv::test
