#include "rv/engine.hpp"

#include <algorithm>
#include <cmath>
#include <thread>

#include "engine_internal.hpp"
#include "parallel.hpp"
#include "rv/error.hpp"
#include "rv/interior.hpp"

namespace rv {

std::string_view to_string(Method m) {
  switch (m) {
    case Method::exact: return "exact";
    case Method::hv_scan: return "hv-scan";
    case Method::h_scan: return "h-scan";
    case Method::brute_force: return "brute-force";
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

int64_t estimate_memory(Method m, int64_t cells, int64_t sites) {
  // Result: int32 site + float32 distance per cell. Scans add a double key per cell.
  int64_t per_cell = 8;
  if (m == Method::hv_scan || m == Method::h_scan) per_cell += 8;
  return cells * per_cell + sites * static_cast<int64_t>(sizeof(LocalSite) + sizeof(Site) + 16) +
         (64 << 20);
}

namespace detail {

void Progress::check_cancel() const {
  if (cancel_ && cancel_->load(std::memory_order_relaxed))
    throw Error(ErrorKind::cancelled, "computation cancelled");
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

void run_brute_force(const EngineContext& ctx, Raster<int32_t>& site, Raster<float>& distance) {
  const Window& w = ctx.window;
  parallel_for(ctx.threads, w.height, [&](int64_t r, int) {
    const double py = ctx.grid.local_y(w.row0 + r);
    int32_t* out_site = site.row(r);
    float* out_dist = distance.row(r);
    for (int64_t c = 0; c < w.width; ++c) {
      const double px = ctx.grid.local_x(w.col0 + c);
      double best = std::numeric_limits<double>::infinity();
      int32_t best_site = kNoSite;
      for (int32_t id : ctx.geometric) {
        const double k = planar_key(px, py, ctx.local[id]);
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
        out_dist[c] = static_cast<float>(planar_distance_from_key(best));
      }
    }
    ctx.progress->advance(w.width);
  });
}

namespace {

// Cells whose centre is inside a polygon belong to it at distance 0, unless a lower site is
// also at distance exactly 0 there (the common tie rule).
void apply_interiors(const InteriorSpans& spans, Raster<int32_t>& site, Raster<float>& distance) {
  for (size_t r = 0; r < spans.rows.size(); ++r) {
    int32_t* s = site.row(static_cast<int64_t>(r));
    float* d = distance.row(static_cast<int64_t>(r));
    for (const Span& span : spans.rows[r]) {
      for (int64_t c = span.col0; c < span.col1; ++c) {
        if (d[c] == 0.0f && s[c] != kNoSite && s[c] < span.site) continue;
        s[c] = span.site;
        d[c] = 0.0f;
      }
    }
  }
}

}  // namespace
}  // namespace detail

std::vector<LocalSite> to_local(const SeedSet& seeds, const GridSpec& g) {
  std::vector<LocalSite> out;
  out.reserve(seeds.sites().size());
  for (const Site& s : seeds.sites()) out.push_back(to_local(s, g));
  return out;
}

NearestField compute(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options) {
  NearestField out;
  compute_into(seeds, grid, options, out);
  return out;
}

void compute_into(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options,
                  NearestField& out) {
  const auto start = std::chrono::steady_clock::now();
  if (grid.width <= 0 || grid.height <= 0 || !(grid.res > 0.0) || !std::isfinite(grid.res))
    throw Error(ErrorKind::invalid_argument, "grid must have a positive size and resolution");
  const Window window = options.window.value_or(grid.full_window());
  if (!grid.contains(window)) throw Error(ErrorKind::invalid_argument, "window lies outside the grid");
  if (seeds.sites().empty()) throw Error(ErrorKind::invalid_input, "no seeds: the seed set is empty");
  if (std::isnan(options.max_distance) || options.max_distance < 0.0)
    throw Error(ErrorKind::invalid_argument, "max distance must be a non-negative number");

  detail::Progress progress(options.progress, options.cancel, window.cell_count());
  detail::EngineContext ctx{seeds, grid, window, to_local(seeds, grid), {}, 0.0,
                            resolve_threads(options.threads), &progress};
  for (int32_t i = 0; i < static_cast<int32_t>(seeds.sites().size()); ++i)
    if (seeds.sites()[i].kind != SiteKind::area) ctx.geometric.push_back(i);
  ctx.max_key = std::isinf(options.max_distance) ? std::numeric_limits<double>::infinity()
                                                 : options.max_distance * options.max_distance;

  if (!(out.site.grid() == grid) || !(out.site.window() == window)) {
    out.site = Raster<int32_t>(grid, window, Uninitialized{});
    out.distance = Raster<float>(grid, window, Uninitialized{});
  }
  out.contested_cells = 0;
  out.threads = ctx.threads;
  progress.check_cancel();
  switch (options.method) {
    case Method::brute_force: detail::run_brute_force(ctx, out.site, out.distance); break;
    case Method::exact: detail::run_exact(ctx, out.site, out.distance); break;
    case Method::h_scan: detail::run_scan(ctx, false, out.site, out.distance); break;
    case Method::hv_scan: detail::run_scan(ctx, true, out.site, out.distance); break;
  }
  if (!seeds.polygons().empty()) {
    const InteriorSpans spans = build_interiors(seeds, grid, window);
    out.contested_cells = spans.contested_cells;
    detail::apply_interiors(spans, out.site, out.distance);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace rv
