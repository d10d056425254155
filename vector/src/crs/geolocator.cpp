// OsrGeolocator: see rv/gdal/osr_geolocator.hpp for the contract.
//
// Why one transformation per thread: OGRCoordinateTransformation::Transform is not const and
// PROJ objects carry per-call state, so sharing one between threads needs a lock around every
// batch, which the engine's threads would then contend for on each cell. Instead each thread
// builds its own pair on first use (under the lock, once) and finds it afterwards through a
// thread-local cache keyed by the geolocator's serial number, without locking.
#include "rv/gdal/osr_geolocator.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>

#include "common/gdal_util.hpp"
#include "rv/field/error.hpp"

namespace rv {
namespace {

using gdal::CtPtr;

std::atomic<uint64_t> g_next_serial{1};  // 0 marks an empty cache entry

std::string point_text(double a, double b) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.10g, %.10g)", a, b);
  return buf;
}

}  // namespace

struct OsrGeolocator::Impl {
  gdal::SrsPtr grid;
  gdal::SrsPtr geographic;
};

struct OsrGeolocator::PerThread {
  CtPtr to_geographic;
  CtPtr to_grid;
};

OsrGeolocator::OsrGeolocator(const std::string& grid_crs)
    : impl_(std::make_unique<Impl>()), serial_(g_next_serial.fetch_add(1)) {
  gdal_init();
  gdal::ErrorCapture capture;
  impl_->grid = gdal::parse_srs(grid_crs);
  if (!impl_->grid) throw Error(ErrorKind::invalid_argument, "cannot parse the grid CRS" + capture.suffix());
  if (impl_->grid->IsGeographic())
    throw Error(ErrorKind::invalid_argument,
                "a geolocator locates a projected grid's cells; this grid CRS is already geographic");
  impl_->geographic.reset(impl_->grid->CloneGeogCS());
  if (!impl_->geographic || !impl_->geographic->IsGeographic())
    throw Error(ErrorKind::invalid_argument,
                "the grid CRS has no geographic base CRS (no datum/ellipsoid), so its cells cannot be located on "
                "an ellipsoid" +
                    capture.suffix());
  impl_->geographic->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  // GeographicLib takes degrees; OSR returns the base CRS's own angular unit.
  const double unit = impl_->geographic->GetAngularUnits(nullptr);
  if (!(std::abs(unit - M_PI / 180.0) < 1e-12))
    throw Error(ErrorKind::unsupported,
                "the grid CRS's geographic base measures angles in a unit other than "
                "degrees, which the geodesic metric does not take");
  geographic_wkt_ = gdal::to_wkt2(*impl_->geographic);
  geographic_info_ = gdal::crs_info(*impl_->geographic);
  local();  // builds this thread's pair now: a CRS PROJ cannot transform fails here, not mid-run
}

OsrGeolocator::~OsrGeolocator() = default;

OsrGeolocator::PerThread& OsrGeolocator::local() const {
  // A few geolocators per thread at a time is the normal case (one per job).
  struct Entry {
    uint64_t serial = 0;
    PerThread* pair = nullptr;
  };
  thread_local std::array<Entry, 4> cache{};
  thread_local size_t next_slot = 0;
  for (const Entry& e : cache)
    if (e.serial == serial_) return *e.pair;

  std::lock_guard lock(mutex_);
  std::unique_ptr<PerThread>& slot = per_thread_[std::this_thread::get_id()];
  if (!slot) {
    gdal::ErrorCapture capture;
    auto pair = std::make_unique<PerThread>();
    pair->to_geographic.reset(OGRCreateCoordinateTransformation(impl_->grid.get(), impl_->geographic.get()));
    pair->to_grid.reset(OGRCreateCoordinateTransformation(impl_->geographic.get(), impl_->grid.get()));
    if (!pair->to_geographic || !pair->to_grid)
      throw Error(ErrorKind::unsupported,
                  "no transformation between the grid CRS and its geographic base" + capture.suffix());
    slot = std::move(pair);
  }
  // A thread whose id was reused after another thread ended takes over that thread's pair: it
  // is no longer used elsewhere, and GDAL binds a transformation to the calling thread's PROJ
  // context on each call.
  cache[next_slot] = Entry{serial_, slot.get()};
  next_slot = (next_slot + 1) % cache.size();
  return *slot;
}

void OsrGeolocator::transform(bool inverse, const double* in_x, const double* in_y, double* out_x, double* out_y,
                              size_t n) const {
  if (n == 0) return;
  PerThread& pair = local();
  OGRCoordinateTransformation& ct = inverse ? *pair.to_grid : *pair.to_geographic;
  for (size_t i = 0; i < n; ++i) {
    out_x[i] = in_x[i];
    out_y[i] = in_y[i];
  }
  // Failed points are reported through the flags; GDAL's messages about them stay off stderr.
  gdal::ErrorCapture capture;
  // Chunks with flags on the stack: no allocation per call (the scans locate one cell a call).
  constexpr size_t kChunk = 512;
  std::array<int, kChunk> ok;
  for (size_t start = 0; start < n; start += kChunk) {
    const size_t count = std::min(kChunk, n - start);
    std::fill(ok.begin(), ok.begin() + static_cast<std::ptrdiff_t>(count), TRUE);
    ct.Transform(static_cast<int>(count), out_x + start, out_y + start, nullptr, nullptr, ok.data());
    for (size_t i = 0; i < count; ++i) {
      const size_t k = start + i;
      const bool bad =
          !ok[i] || !std::isfinite(out_x[k]) || !std::isfinite(out_y[k]) || (!inverse && !(std::abs(out_y[k]) <= 90.0));
      if (bad)
        throw Error(ErrorKind::invalid_input,
                    std::string(inverse ? "the longitude/latitude " : "the grid position ") +
                        point_text(in_x[k], in_y[k]) +
                        (inverse ? " cannot be placed in the grid CRS" : " cannot be located on the ellipsoid") +
                        " (outside the projection's domain?)" + capture.suffix());
    }
  }
}

void OsrGeolocator::to_lonlat(const double* x, const double* y, double* lon, double* lat, size_t n) const {
  transform(false, x, y, lon, lat, n);
}

void OsrGeolocator::to_grid(const double* lon, const double* lat, double* x, double* y, size_t n) const {
  transform(true, lon, lat, x, y, n);
}

}  // namespace rv
