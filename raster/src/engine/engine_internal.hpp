// Internal: what every method kernel receives, and the kernels themselves.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "field/geodesic_sites.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/cell_mask.hpp"
#include "rv/field/interior.hpp"
#include "rv/field/planar.hpp"

namespace rv {
class SiteMetric;  // rv/engine/site_metric.hpp
class OwnerIndex;
}  // namespace rv

namespace rv::detail {

// A multiple of every exact method's top-level tile edge (planar and adjusted 64 cells, geodesic
// 256; tiles aligned to the grid): a block the engine solves under a mask lies within the rows
// of these bands that hold a masked cell (each method's file asserts it divides this).
inline constexpr int64_t kTileBand = 256;

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

class BucketIndex;

struct EngineContext {
  const SeedSet& seeds;
  const GridSpec& grid;
  Window window;
  const std::vector<LocalSite>& local;    // per site id (area sites hold their anchor point)
  const std::vector<int32_t>& geometric;  // ids of point and segment sites, ascending
  double max_key;                         // max_distance in key units (planar: squared; geodesic: metres)
  int threads;
  Progress* progress;
  const GeoSites* geo = nullptr;  // set for the geodesic metric (then `local` serves only the
                                  // scans' seeding, with longitudes unwrapped around the grid)
  // Polygon interiors of the window (null when there are no polygons). Kernels may skip the
  // work for cells inside them: apply_interiors() gives those cells their area site afterwards,
  // keeping only a lower site at distance exactly 0 (so a kernel must still report those).
  const InteriorSpans* interiors = nullptr;
  // Geodesic metric on a projected grid (ComputeOptions::geolocator): cell centres are in the
  // grid's CRS and are located on the ellipsoid with this before measuring (GeodesicOps::cell,
  // locate_centres). `geo` is then set too (seeds in longitude/latitude), `local` holds the
  // sites placed in the grid's CRS (Geolocator::to_grid; a site outside the projection's domain
  // gets infinite coordinates, i.e. touches no cell), and `interiors` come from the polygons
  // in the grid's CRS. Null otherwise. Not owned; thread-safe by the Geolocator contract.
  const Geolocator* geolocator = nullptr;
  // The planar exact method's index over exactly `geometric` in `local`, from rv::PreparedSeeds;
  // null: the solver builds its own (contexts over a subset of the sites must leave it null).
  const BucketIndex* index = nullptr;
  // Largest absolute coordinate of a site of `geometric` in `local` (for rounding slacks); < 0:
  // not known, the solver measures it.
  double site_scale = -1.0;
  // Cells the kernel must produce (ComputeOptions::mask, rv/field/cell_mask.hpp); null: every cell of
  // the window. Honoured by the exact methods (culling.hpp), which skip tiles and blocks without a
  // masked cell; a kernel may write other cells too, with their values. Not owned.
  const CellMask* mask = nullptr;
};

// Ids of the point and segment sites (everything but area sites), ascending.
std::vector<int32_t> geometric_sites(const SeedSet& seeds);

// Largest absolute local coordinate of the sites `ids` (segment ends included).
double site_scale(const std::vector<LocalSite>& local, const std::vector<int32_t>& ids);

}  // namespace rv::detail

namespace rv {

// What rv::prepare() makes (see rv/engine/engine.hpp): everything of a computation that does not depend
// on the window. Immutable once made.
class PreparedSeeds {
 public:
  const SeedSet* seeds = nullptr;  // identity of the seed set it was made from
  size_t site_count = 0;
  GridSpec grid;
  MetricSpec metric;
  const Geolocator* geolocator = nullptr;
  std::vector<LocalSite> local;
  std::vector<int32_t> geometric;
  std::optional<detail::GeoSites> geo;               // geodesic metric
  std::unique_ptr<const detail::BucketIndex> index;  // planar metric
  double site_scale = 0.0;
  // Seeds with weights or reaches (SeedSet::adjusted): the exact metric and the index the
  // adjusted method compares by, its cap the max distance prepare() was given.
  std::unique_ptr<const SiteMetric> site_metric;
  std::unique_ptr<const OwnerIndex> adjusted_index;
  double adjusted_cap = 0.0;
  ~PreparedSeeds();
};

}  // namespace rv

namespace rv::detail {

// Locates n cell centres (grid CRS) on the ellipsoid: lon/lat degrees. Throws
// rv::Error(invalid_input) when the geolocator gives a non-finite position or a latitude
// outside [-90, 90] (a geolocator that breaks its contract must not produce silent garbage).
void locate_centres(const Geolocator& geolocator, const double* x, const double* y, double* lon, double* lat, size_t n);

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
  void cells(int64_t col0, int64_t row, int64_t n, Cell* out) const {
    for (int64_t i = 0; i < n; ++i) out[i] = cell(col0 + i, row);
  }
};

struct GeodesicOps {
  using Cell = GeoCell;
  const EngineContext& ctx;
  // Geographic grids: the centre's own longitude/latitude. Projected grids: the centre located
  // through the geolocator (one transformation per call; see cells() for a row at once).
  Cell cell(int64_t col, int64_t row) const {
    const double x = ctx.grid.centre_x(col), y = ctx.grid.centre_y(row);
    if (ctx.geolocator == nullptr) return ctx.geo->cell(x, y);
    double lon, lat;
    locate_centres(*ctx.geolocator, &x, &y, &lon, &lat, 1);
    return ctx.geo->cell(lon, lat);
  }
  // The n cells (col0 .. col0 + n - 1, row), located in one batch: equal to n calls of cell().
  void cells(int64_t col0, int64_t row, int64_t n, Cell* out) const;
  double key(const Cell& p, int32_t id) const { return ctx.geo->distance(p, id); }
  static double distance(double key) { return key; }
};

// Each kernel writes, for every cell of ctx.window, the nearest geometric site and its distance
// (kNoSite / kNoDistance where the nearest is beyond max_distance). Interiors are applied after.
void run_brute_force(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance);
void run_exact(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance);
void run_exact_geodesic(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance);
void run_scan(const EngineContext& ctx, bool vertical_cycle, Raster<int32_t>& site, Raster<float>& distance);
// The adjusted method (adjusted.cpp): seeds with weights or reaches, compared by `index` (its
// cap the max distance), exact (tile culling) or brute force. Cells inside polygons are left to
// apply_interiors, as the other kernels leave them.
void run_adjusted(const EngineContext& ctx, const OwnerIndex& index, Raster<int32_t>& site, Raster<float>& distance);
void run_adjusted_brute_force(const EngineContext& ctx, const OwnerIndex& index, Raster<int32_t>& site,
                              Raster<float>& distance);

}  // namespace rv::detail
