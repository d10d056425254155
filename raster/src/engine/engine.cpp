#include "rv/engine/engine.hpp"

#include <GeographicLib/GeodesicLine.hpp>
#include <GeographicLib/Math.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "engine/bucket_index.hpp"
#include "engine/engine_internal.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/field/interior.hpp"
#include "rv/field/parallel.hpp"

namespace rv {

std::string_view to_string(Method m) {
  switch (m) {
    case Method::exact:
      return "exact";
    case Method::hv_scan:
      return "hv-scan";
    case Method::h_scan:
      return "h-scan";
    case Method::brute_force:
      return "brute-force";
  }
  return "exact";
}

Method parse_method(std::string_view name) {
  std::string n(name);
  std::replace(n.begin(), n.end(), '_', '-');
  for (Method m : {Method::exact, Method::hv_scan, Method::h_scan, Method::brute_force})
    if (n == to_string(m)) return m;
  throw Error(ErrorKind::invalid_argument,
              "unknown method '" + std::string(name) + "' (expected exact, hv-scan, h-scan or brute-force)");
}

int resolve_threads(int requested) {
  if (requested > 0) return std::min(requested, 256);
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<int>(std::min(hw, 256u));
}

int64_t estimate_memory(Method m, int64_t cells, int64_t sites, MetricSpec::Kind metric) {
  // Result: int32 site + float32 distance per cell. Scans add a double key per cell.
  int64_t per_cell = 8;
  if (m == Method::hv_scan || m == Method::h_scan) per_cell += 8;
  // Per site: the planar form, its entries in the bucket index (one for a point, about four for
  // a segment, which is registered in every bucket it crosses plus one on each side), and
  // (geodesic) the prepared site, its line and usually one piece.
  auto per_site = static_cast<int64_t>(sizeof(LocalSite) + sizeof(Site) + 4 * sizeof(detail::BucketIndex::Entry));
  if (metric == MetricSpec::geodesic)
    per_site +=
        static_cast<int64_t>(sizeof(detail::GeoSite) + sizeof(GeographicLib::GeodesicLine) + sizeof(detail::GeoPiece));
  return cells * per_cell + sites * per_site + (64 << 20);
}

namespace detail {

void Progress::check_cancel() const {
  if (cancel_ && cancel_->load(std::memory_order_relaxed)) throw Error(ErrorKind::cancelled, "computation cancelled");
}

void Progress::advance(int64_t units) {
  check_cancel();
  const int64_t done = done_.fetch_add(units, std::memory_order_relaxed) + units;
  if (!callback_) return;
  const int percent = static_cast<int>(std::min<int64_t>(100, done * 100 / total_));
  int last = last_percent_.load(std::memory_order_relaxed);
  if (percent <= last) return;
  std::lock_guard lock(mutex_);
  last = last_percent_.load(std::memory_order_relaxed);
  if (percent <= last) return;
  last_percent_.store(percent, std::memory_order_relaxed);
  callback_(percent / 100.0);
}

namespace {

template <class Ops>
void brute_force(const EngineContext& ctx, const Ops ops, Raster<int32_t>& site, Raster<float>& distance) {
  const Window& w = ctx.window;
  parallel_for(ctx.threads, w.height, [&](int64_t r, int) {
    int32_t* out_site = site.row(r);
    float* out_dist = distance.row(r);
    // The row's cells at once: on a projected geodesic grid one batch through the geolocator
    // instead of one transformation per cell.
    std::vector<typename Ops::Cell> cells(static_cast<size_t>(w.width));
    ops.cells(w.col0, w.row0 + r, w.width, cells.data());
    for (int64_t c = 0; c < w.width; ++c) {
      const typename Ops::Cell& p = cells[static_cast<size_t>(c)];
      double best = std::numeric_limits<double>::infinity();
      int32_t best_site = kNoSite;
      for (int32_t id : ctx.geometric) {
        const double k = ops.key(p, id);
        if (k < best) {
          best = k;
          best_site = id;
        }
      }
      if (best > ctx.max_key) {
        out_site[c] = kNoSite;
        out_dist[c] = kNoDistance;
      } else {
        out_site[c] = best_site;
        out_dist[c] = static_cast<float>(Ops::distance(best));
      }
    }
    ctx.progress->advance(w.width);
  });
}

}  // namespace

void locate_centres(const Geolocator& geolocator, const double* x, const double* y, double* lon, double* lat,
                    size_t n) {
  geolocator.to_lonlat(x, y, lon, lat, n);
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(lon[i]) || !(std::abs(lat[i]) <= 90.0))
      throw Error(ErrorKind::invalid_input, "geodesic metric: the cell centre (" + std::to_string(x[i]) + ", " +
                                                std::to_string(y[i]) +
                                                ") of the projected grid has no longitude/latitude (located at " +
                                                std::to_string(lon[i]) + ", " + std::to_string(lat[i]) + ")");
}

void GeodesicOps::cells(int64_t col0, int64_t row, int64_t n, Cell* out) const {
  if (ctx.geolocator == nullptr) {
    for (int64_t i = 0; i < n; ++i) out[i] = cell(col0 + i, row);
    return;
  }
  const auto count = static_cast<size_t>(n);
  std::vector<double> x(count), y(count, ctx.grid.centre_y(row)), lon(count), lat(count);
  for (size_t i = 0; i < count; ++i) x[i] = ctx.grid.centre_x(col0 + static_cast<int64_t>(i));
  locate_centres(*ctx.geolocator, x.data(), y.data(), lon.data(), lat.data(), count);
  for (size_t i = 0; i < count; ++i) out[i] = ctx.geo->cell(lon[i], lat[i]);
}

void run_brute_force(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance) {
  if (ctx.geo)
    brute_force(ctx, GeodesicOps{ctx}, site, distance);
  else
    brute_force(ctx, PlanarOps{ctx}, site, distance);
}

namespace {

// Cells whose centre is inside a polygon belong to it at distance 0, unless a lower site is
// also at distance exactly 0 there (the common tie rule). Applying several span sets one after
// the other keeps that rule (the lowest site at distance 0 stays).
//
// Why branch-free and in parallel: on coastline grids a large share of the cells is land (the
// Oresund fixture: most of Scania and Zealand). This pass used to run on one thread, with a
// branch per cell, after the engine's threads had finished, a visible share of the planar
// method's time on such grids (bench/RESULTS-kernels.md). Branch-free, GCC vectorises it; rows
// are independent, so the result cannot depend on the thread count.
void apply_interiors(const InteriorSpans& spans, int threads, Raster<int32_t>& site, Raster<float>& distance) {
  constexpr int64_t kRowsPerTask = 64;
  const auto rows = static_cast<int64_t>(spans.rows.size());
  parallel_for(threads, (rows + kRowsPerTask - 1) / kRowsPerTask, [&](int64_t task, int) {
    for (int64_t r = task * kRowsPerTask; r < std::min(rows, (task + 1) * kRowsPerTask); ++r) {
      int32_t* __restrict s = site.row(r);
      float* __restrict d = distance.row(r);
      for (const Span& span : spans.rows[static_cast<size_t>(r)]) {
        const int32_t area = span.site;
        for (int64_t c = span.col0; c < span.col1; ++c) {
          const int32_t was = s[c];
          const bool lower_tie = (d[c] == 0.0f) & (was != kNoSite) & (was < area);
          s[c] = lower_tie ? was : area;
          d[c] = 0.0f;
        }
      }
    }
  });
}

}  // namespace
}  // namespace detail

std::vector<LocalSite> to_local(const SeedSet& seeds, const GridSpec& g) {
  std::vector<LocalSite> out;
  out.reserve(seeds.sites().size());
  for (const Site& s : seeds.sites()) out.push_back(to_local(s, g));
  return out;
}

namespace {

// Geodesic grids: the scans seed cells from sites' positions in the grid frame, so longitudes
// are moved by whole turns to lie within 180 degrees of the grid's middle meridian, and a
// segment's second end is taken the short way round from its first (as its geodesic runs).
std::vector<LocalSite> to_local_geodesic(const SeedSet& seeds, const GridSpec& g) {
  using GeographicLib::Math;
  const double middle = g.xmin + 0.5 * static_cast<double>(g.width) * g.res;
  std::vector<LocalSite> out;
  out.reserve(seeds.sites().size());
  for (Site s : seeds.sites()) {
    const double ax = middle + Math::AngDiff(middle, s.a.x);
    s.b.x = ax + Math::AngDiff(s.a.x, s.b.x);
    s.a.x = ax;
    out.push_back(to_local(s, g));
  }
  return out;
}

// Polygons for the interior test on a geodesic grid. Each ring is unwrapped in longitude so that
// every edge goes the short way round, as the edge's geodesic does (a ring 179.8 .. -179.7 is
// the small ring 179.8 .. 180.3, not one spanning the globe); holes are put in their outer
// ring's turn. A ring whose longitudes wind once round the globe (it encloses a pole, like
// Antarctica drawn -180 .. 180) is kept as given. Every polygon is then also given one turn
// west and east, so cells with longitudes beyond 180 (or below -180) find it.
std::vector<Polygon> geodesic_polygons(const SeedSet& seeds) {
  using GeographicLib::Math;
  std::vector<Polygon> out;
  out.reserve(seeds.polygons().size() * 3);
  for (Polygon poly : seeds.polygons()) {
    double outer_raw = 0.0, outer_unwrapped = 0.0;
    for (size_t k = 0; k < poly.rings.size(); ++k) {
      Ring& ring = poly.rings[k];
      double winding = 0.0;
      for (size_t i = 0; i < ring.size(); ++i) winding += Math::AngDiff(ring[i].x, ring[(i + 1) % ring.size()].x);
      const bool encircles_pole = std::abs(winding) > 180.0;
      if (k == 0) outer_raw = ring[0].x;
      if (!encircles_pole) {
        const double start = k == 0 ? ring[0].x : outer_unwrapped + Math::AngDiff(outer_raw, ring[0].x);
        double prev_raw = ring[0].x;
        ring[0].x = start;
        for (size_t i = 1; i < ring.size(); ++i) {
          const double raw = ring[i].x;
          ring[i].x = ring[i - 1].x + Math::AngDiff(prev_raw, raw);
          prev_raw = raw;
        }
      }
      if (k == 0) outer_unwrapped = ring[0].x;
    }
    for (const double turn : {0.0, -360.0, 360.0}) {
      Polygon moved = poly;
      for (Ring& ring : moved.rings)
        for (Vec2& v : ring) v.x += turn;
      out.push_back(std::move(moved));
    }
  }
  return out;
}

// Projected geodesic grids: the sites' positions in the grid's CRS, for the scans' seeding (and
// culling hints). Segments become straight in the grid (their geodesics are not, but seeding
// only decides where a site's identity enters the scan). A site the geolocator cannot place
// (outside the projection's domain) gets infinite coordinates: it touches no cell and enters
// the scans through the border like any site outside the window.
std::vector<LocalSite> to_local_projected(const SeedSet& seeds, const GridSpec& g, const Geolocator& geolocator) {
  const std::vector<Site>& sites = seeds.sites();
  const size_t n = sites.size();
  std::vector<double> lon(2 * n), lat(2 * n), x(2 * n), y(2 * n);
  for (size_t i = 0; i < n; ++i) {
    lon[2 * i] = sites[i].a.x;
    lat[2 * i] = sites[i].a.y;
    lon[2 * i + 1] = sites[i].b.x;
    lat[2 * i + 1] = sites[i].b.y;
  }
  auto place = [&](size_t i) {
    try {
      geolocator.to_grid(&lon[i], &lat[i], &x[i], &y[i], 1);
    } catch (const Error& e) {
      if (e.kind() != ErrorKind::invalid_input) throw;
      x[i] = y[i] = std::numeric_limits<double>::infinity();
    }
  };
  try {
    geolocator.to_grid(lon.data(), lat.data(), x.data(), y.data(), 2 * n);
  } catch (const Error& e) {
    // Some point lies outside the projection's domain: place them one by one.
    if (e.kind() != ErrorKind::invalid_input) throw;
    for (size_t i = 0; i < 2 * n; ++i) place(i);
  }
  std::vector<LocalSite> out;
  out.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    Site s = sites[i];
    s.a = Vec2{x[2 * i], y[2 * i]};
    s.b = Vec2{x[2 * i + 1], y[2 * i + 1]};
    if (!std::isfinite(s.a.x) || !std::isfinite(s.a.y) || !std::isfinite(s.b.x) || !std::isfinite(s.b.y)) {
      const double inf = std::numeric_limits<double>::infinity();
      out.push_back(LocalSite{inf, inf, 0.0, 0.0, 0.0});
      continue;
    }
    out.push_back(to_local(s, g));
  }
  return out;
}

// Projected geodesic grids: the interior test runs on the polygons in the grid's CRS, which must
// be the seeds' polygons one for one.
void check_grid_polygons(const SeedSet& seeds, const std::vector<Polygon>* grid_polygons) {
  if (seeds.polygons().empty()) return;
  if (grid_polygons == nullptr)
    throw Error(ErrorKind::invalid_argument,
                "geodesic metric on a projected grid: the seeds have polygons, so their copies in the grid's CRS "
                "(ComputeOptions::grid_polygons) are needed for the interior test");
  if (grid_polygons->size() != seeds.polygons().size())
    throw Error(ErrorKind::invalid_argument, "geodesic metric on a projected grid: grid_polygons has " +
                                                 std::to_string(grid_polygons->size()) + " polygons, the seeds " +
                                                 std::to_string(seeds.polygons().size()));
  for (size_t i = 0; i < grid_polygons->size(); ++i)
    if ((*grid_polygons)[i].area_site != seeds.polygons()[i].area_site)
      throw Error(ErrorKind::invalid_argument, "geodesic metric on a projected grid: grid_polygons[" +
                                                   std::to_string(i) +
                                                   "] is not the seeds' polygon of the same index (area sites differ)");
}

void check_geodesic_grid(const GridSpec& grid) {
  const double eps = 1e-9 * grid.res;
  if (!(grid.ymax <= 90.0 + eps) || !(grid.ymin() >= -90.0 - eps))
    throw Error(ErrorKind::invalid_argument,
                "geodesic metric: the grid's latitudes must lie within [-90, 90] (grid spans " +
                    std::to_string(grid.ymin()) + " .. " + std::to_string(grid.ymax) + ")");
  if (!(static_cast<double>(grid.width) * grid.res <= 360.0 + eps))
    throw Error(ErrorKind::invalid_argument, "geodesic metric: the grid spans more than 360 degrees of longitude");
  if (!std::isfinite(grid.xmin) || std::abs(grid.xmin) > 1080.0)
    throw Error(ErrorKind::invalid_argument, "geodesic metric: the grid's west edge is not a longitude");
}

}  // namespace

void check_method_for(const SeedSet& seeds, Method method) {
  if (seeds.adjusted() && method != Method::exact && method != Method::brute_force)
    throw Error(ErrorKind::invalid_argument,
                "weights and reaches need the exact or brute-force method: a weighted region can be disconnected "
                "(an enclave), which the " +
                    std::string(to_string(method)) + " method's 3x3 propagation cannot find");
}

NearestField compute(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options) {
  NearestField out;
  if (options.mask != nullptr) {
    // The cells a mask leaves out have no earlier value here: no site.
    const Window window = options.window.value_or(grid.full_window());
    if (grid.contains(window)) {
      out.site = Raster<int32_t>(grid, window, kNoSite);
      out.distance = Raster<float>(grid, window, kNoDistance);
    }
  }
  compute_into(seeds, grid, options, out);
  return out;
}

namespace detail {

std::vector<int32_t> geometric_sites(const SeedSet& seeds) {
  std::vector<int32_t> ids;
  for (int32_t i = 0; i < static_cast<int32_t>(seeds.sites().size()); ++i)
    if (seeds.sites()[static_cast<size_t>(i)].kind != SiteKind::area) ids.push_back(i);
  return ids;
}

double site_scale(const std::vector<LocalSite>& local, const std::vector<int32_t>& ids) {
  double scale = 0.0;
  for (int32_t id : ids) {
    const LocalSite& s = local[static_cast<size_t>(id)];
    scale = std::max({scale, std::abs(s.ax), std::abs(s.ay), std::abs(s.bx()), std::abs(s.by())});
  }
  return scale;
}

}  // namespace detail

namespace {

// The checks prepare() and compute() share: the grid, the seeds, the metric and the geolocator.
void check_inputs(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options) {
  if (grid.width <= 0 || grid.height <= 0 || !(grid.res > 0.0) || !std::isfinite(grid.res))
    throw Error(ErrorKind::invalid_argument, "grid must have a positive size and resolution");
  if (seeds.sites().empty()) throw Error(ErrorKind::invalid_input, "no seeds: the seed set is empty");
  validate_metric(options.metric);
  check_method_for(seeds, options.method);
  const bool geodesic = options.metric.kind == MetricSpec::geodesic;
  const Geolocator* geolocator = options.geolocator.get();
  if (geolocator != nullptr && !geodesic)
    throw Error(ErrorKind::invalid_argument,
                "a geolocator is only meaningful with the geodesic metric (planar measures in the grid's CRS)");
  if (geodesic) {
    // A projected grid's extent is in its CRS units, not degrees: the degree checks do not apply;
    // every located centre is checked instead (detail::locate_centres).
    if (geolocator == nullptr)
      check_geodesic_grid(grid);
    else
      check_grid_polygons(seeds, options.grid_polygons.get());
  }
}

}  // namespace

PreparedSeeds::~PreparedSeeds() = default;

namespace {

// prepare() without the input checks: for callers that have just made them.
std::shared_ptr<const PreparedSeeds> prepare_checked(const SeedSet& seeds, const GridSpec& grid,
                                                     const ComputeOptions& options) {
  const bool geodesic = options.metric.kind == MetricSpec::geodesic;
  const Geolocator* geolocator = options.geolocator.get();
  auto p = std::make_shared<PreparedSeeds>();
  p->seeds = &seeds;
  p->site_count = seeds.sites().size();
  p->grid = grid;
  p->metric = options.metric;
  p->geolocator = geolocator;
  p->local = geolocator != nullptr ? to_local_projected(seeds, grid, *geolocator)
             : geodesic            ? to_local_geodesic(seeds, grid)
                                   : to_local(seeds, grid);
  p->geometric = detail::geometric_sites(seeds);
  if (geodesic) p->geo.emplace(options.metric, seeds);
  // Only the planar exact method culls with the bucket index.
  if (!geodesic && options.method == Method::exact)
    p->index = std::make_unique<const detail::BucketIndex>(p->local, p->geometric);
  p->site_scale = detail::site_scale(p->local, p->geometric);
  if (seeds.adjusted()) {
    // Its own sites (sharing p's would make a cycle; sharing another prepared set's, a stale one).
    ComputeOptions alone = options;
    alone.prepared = nullptr;
    p->site_metric = make_site_metric(seeds, grid, alone);
    p->adjusted_cap = options.max_distance;
    p->adjusted_index =
        std::make_unique<const OwnerIndex>(*p->site_metric, OwnerIndex::Measure::adjusted, options.max_distance);
  }
  return p;
}

}  // namespace

std::shared_ptr<const PreparedSeeds> prepare(const SeedSet& seeds, const GridSpec& grid,
                                             const ComputeOptions& options) {
  check_inputs(seeds, grid, options);
  return prepare_checked(seeds, grid, options);
}

namespace {

// Seeds with weights or reaches: the adjusted method (adjusted.cpp), exact or brute force, on
// the prepared index when it was made for this max distance.
void run_adjusted_method(const detail::EngineContext& ctx, const PreparedSeeds& prepared, const ComputeOptions& options,
                         NearestField& out) {
  std::unique_ptr<const OwnerIndex> own;
  const OwnerIndex* index = prepared.adjusted_index.get();
  if (index == nullptr || !(prepared.adjusted_cap == options.max_distance)) {
    if (prepared.site_metric == nullptr) throw Error(ErrorKind::internal, "adjusted seeds prepared without a metric");
    own =
        std::make_unique<const OwnerIndex>(*prepared.site_metric, OwnerIndex::Measure::adjusted, options.max_distance);
    index = own.get();
  }
  if (options.method == Method::brute_force)
    detail::run_adjusted_brute_force(ctx, *index, out.site, out.distance);
  else
    detail::run_adjusted(ctx, *index, out.site, out.distance);
}

}  // namespace

void compute_into(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options, NearestField& out) {
  const auto start = std::chrono::steady_clock::now();
  check_inputs(seeds, grid, options);
  const Window window = options.window.value_or(grid.full_window());
  if (!grid.contains(window)) throw Error(ErrorKind::invalid_argument, "window lies outside the grid");
  if (std::isnan(options.max_distance) || options.max_distance < 0.0)
    throw Error(ErrorKind::invalid_argument, "max distance must be a non-negative number");
  const bool geodesic = options.metric.kind == MetricSpec::geodesic;
  const Geolocator* geolocator = options.geolocator.get();
  std::shared_ptr<const PreparedSeeds> prepared = options.prepared;
  if (prepared == nullptr) {
    prepared = prepare_checked(seeds, grid, options);
  } else if (prepared->seeds != &seeds || prepared->site_count != seeds.sites().size() || !(prepared->grid == grid) ||
             !(prepared->metric == options.metric) || prepared->geolocator != geolocator) {
    throw Error(ErrorKind::invalid_argument,
                "the prepared seeds were made for another seed set, grid, metric or geolocator");
  }

  detail::Progress progress(options.progress, options.cancel, window.cell_count());
  detail::EngineContext ctx{seeds,
                            grid,
                            window,
                            prepared->local,
                            prepared->geometric,
                            0.0,
                            resolve_threads(options.threads),
                            &progress,
                            prepared->geo ? &*prepared->geo : nullptr};
  ctx.geolocator = geolocator;
  ctx.index = prepared->index.get();
  ctx.site_scale = prepared->site_scale;
  if (std::isinf(options.max_distance))
    ctx.max_key = std::numeric_limits<double>::infinity();
  else
    ctx.max_key = geodesic ? options.max_distance : options.max_distance * options.max_distance;

  if (options.mask != nullptr) {
    if (options.method != Method::exact) throw Error(ErrorKind::invalid_argument, "a cell mask needs the exact method");
    if (!options.mask->fits(window))
      throw Error(ErrorKind::invalid_argument, "the cell mask does not fit the window (one row of sorted spans each)");
    if (!(out.site.grid() == grid) || !(out.site.window() == window))
      throw Error(ErrorKind::invalid_argument, "a cell mask needs the earlier field of this grid and window in `out`");
    ctx.mask = options.mask.get();
  }
  if (!(out.site.grid() == grid) || !(out.site.window() == window)) {
    // Strips of a streamed job: the previous strip's buffers serve the next one.
    out.site.retarget(grid, window);
    out.distance.retarget(grid, window);
  }
  out.contested_cells = 0;
  out.threads = ctx.threads;
  out.metric = options.metric;
  out.geolocator = options.geolocator;
  std::optional<InteriorSpans> spans;
  if (!seeds.polygons().empty()) {
    // Under a mask, the interiors of the bands of rows it touches alone (an edit's few hundred
    // rows, not the grid's thousands): no block of the other rows is solved or written.
    Window laid = window;
    if (ctx.mask != nullptr) {
      const auto& rows = ctx.mask->rows;
      int64_t first = 0, last = static_cast<int64_t>(rows.size());
      while (first < last && rows[static_cast<size_t>(first)].empty()) ++first;
      while (last > first && rows[static_cast<size_t>(last - 1)].empty()) --last;
      if (first < last) {
        constexpr int64_t B = detail::kTileBand;
        first = std::max(window.row0, (window.row0 + first) / B * B) - window.row0;
        last = std::min(window.row0 + window.height, (window.row0 + last + B - 1) / B * B) - window.row0;
      }
      laid = Window{window.col0, window.row0 + first, window.width, last - first};
    }
    // Projected geodesic grids: the seeds' polygons are in degrees and cannot be laid on the
    // grid's rows; their copies in the grid's CRS are, and are tested in its plane.
    InteriorSpans built = laid.height == 0        ? InteriorSpans{laid, {}, 0}
                          : geolocator != nullptr ? build_interiors(seeds, *options.grid_polygons, grid, laid)
                          : geodesic              ? build_interiors(seeds, geodesic_polygons(seeds), grid, laid)
                                                  : build_interiors(seeds, grid, laid);
    if (laid == window) {
      spans.emplace(std::move(built));
    } else {
      spans.emplace(InteriorSpans{window, {}, built.contested_cells});
      spans->rows.resize(static_cast<size_t>(window.height));
      std::move(built.rows.begin(), built.rows.end(), spans->rows.begin() + (laid.row0 - window.row0));
    }
    ctx.interiors = &*spans;
  }
  progress.check_cancel();
  if (seeds.adjusted()) {
    run_adjusted_method(ctx, *prepared, options, out);
  } else {
    switch (options.method) {
      case Method::brute_force:
        detail::run_brute_force(ctx, out.site, out.distance);
        break;
      case Method::exact:
        if (geodesic)
          detail::run_exact_geodesic(ctx, out.site, out.distance);
        else
          detail::run_exact(ctx, out.site, out.distance);
        break;
      case Method::h_scan:
        detail::run_scan(ctx, false, out.site, out.distance);
        break;
      case Method::hv_scan:
        detail::run_scan(ctx, true, out.site, out.distance);
        break;
    }
  }
  if (spans) {
    out.contested_cells = spans->contested_cells;
    detail::apply_interiors(*spans, ctx.threads, out.site, out.distance);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace rv
