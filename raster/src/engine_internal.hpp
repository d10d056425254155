// Internal: what every method kernel receives, and the kernels themselves.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <vector>

#include "geodesic_sites.hpp"
#include "rv/engine.hpp"
#include "rv/interior.hpp"
#include "rv/planar.hpp"

namespace rv::detail {

// Throttled, serialised progress reporting plus cancellation polling.
class Progress {
 public:
  Progress(std::function<void(double)> callback, const std::atomic<bool>* cancel, int64_t total)
      : callback_(std::move(callback)), cancel_(cancel), total_(total > 0 ? total : 1) {}
  // Adds `units` of work done (units are cells); throws rv::Error(cancelled) if cancellation was requested.
  void advance(int64_t units);
  void check_cancel() const;
  // Changes the amount of work that means 100 %; call before any worker starts.
  void set_total(int64_t total) { total_ = total > 0 ? total : 1; }

 private:
  std::function<void(double)> callback_;
  const std::atomic<bool>* cancel_;
  int64_t total_;
  std::atomic<int64_t> done_{0};
  std::atomic<int> last_percent_{-1};
  std::mutex mutex_;
};

struct EngineContext {
  const SeedSet& seeds;
  const GridSpec& grid;
  Window window;
  std::vector<LocalSite> local;    // per site id (area sites hold their anchor point)
  std::vector<int32_t> geometric;  // ids of point and segment sites, ascending
  double max_key;                  // max_distance in key units (planar: squared; geodesic: metres)
  int threads;
  Progress* progress;
  const GeoSites* geo = nullptr;   // set for the geodesic metric (then `local` serves only the
                                   // scans' seeding, with longitudes unwrapped around the grid)
  // Polygon interiors of the window (null when there are no polygons). Kernels may skip the
  // work for cells inside them: apply_interiors() gives those cells their area site afterwards,
  // keeping only a lower site at distance exactly 0 (so a kernel must still report those).
  const InteriorSpans* interiors = nullptr;
};

// The metric as the kernels see it: a per-cell position, a comparison key per (cell, site), and
// the conversion of a key to a distance. Kernels are templated on these so that the planar
// instantiation compiles to exactly the planar arithmetic it always had.
struct PlanarOps {
  struct Cell {
    double x, y;
  };
  const EngineContext& ctx;
  Cell cell(int64_t col, int64_t row) const { return {ctx.grid.local_x(col), ctx.grid.local_y(row)}; }
  double key(const Cell& p, int32_t id) const { return planar_key(p.x, p.y, ctx.local[id]); }
  static double distance(double key) { return planar_distance_from_key(key); }
};

struct GeodesicOps {
  using Cell = GeoCell;
  const EngineContext& ctx;
  Cell cell(int64_t col, int64_t row) const {
    return ctx.geo->cell(ctx.grid.centre_x(col), ctx.grid.centre_y(row));
  }
  double key(const Cell& p, int32_t id) const { return ctx.geo->distance(p, id); }
  static double distance(double key) { return key; }
};

// Each kernel writes, for every cell of ctx.window, the nearest geometric site and its distance
// (kNoSite / kNoDistance where the nearest is beyond max_distance). Interiors are applied after.
void run_brute_force(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance);
void run_exact(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance);
void run_exact_geodesic(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance);
void run_scan(const EngineContext& ctx, bool vertical_cycle, Raster<int32_t>& site,
              Raster<float>& distance);

}  // namespace rv::detail
