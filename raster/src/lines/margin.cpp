// The margin raster (rv/lines/margin.hpp): for every cell, the distance to the nearest seed of
// another owner minus the distance to its own.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "engine/exact_other.hpp"
#include "lines/line_tools.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/field/planar.hpp"
#include "rv/lines/margin.hpp"

namespace rv {

using namespace line_tools;  // the deliverables' own toolkit (line_tools.hpp)

// ---------------------------------------------------------------------------------------------
// Margin.

NearestField compute_other_owner(const SeedSet& seeds, const NearestField& own, int threads) {
  if (own.metric.kind != MetricSpec::planar)
    throw Error(ErrorKind::invalid_argument, "compute_other_owner culls with planar bounds: planar fields only");
  const GridSpec& grid = own.site.grid();
  const Window window = own.site.window();
  detail::Progress progress({}, nullptr, window.cell_count());
  const std::vector<LocalSite> local = to_local(seeds, grid);
  const std::vector<int32_t> geometric = detail::geometric_sites(seeds);
  detail::EngineContext ctx{
      seeds,     grid,   window, local, geometric, std::numeric_limits<double>::infinity(), resolve_threads(threads),
      &progress, nullptr};
  const std::vector<int32_t> owner_of_site = owner_of_sites(seeds);
  const auto start = std::chrono::steady_clock::now();
  NearestField out;
  out.site = Raster<int32_t>(grid, window, Uninitialized{});
  out.distance = Raster<float>(grid, window, Uninitialized{});
  out.threads = ctx.threads;
  if (ctx.geometric.empty()) {
    std::fill(out.site.cells().begin(), out.site.cells().end(), kNoSite);
    std::fill(out.distance.cells().begin(), out.distance.cells().end(), kNoDistance);
  } else {
    detail::run_exact_other_owner(ctx, own.site, owner_of_site, out.site, out.distance);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

namespace {

// The seeds of every owner but `excluded`, as a new set (features in the same order, polygons
// with their rings, lines as their segments). Distances to it are distances to "another owner".
SeedSet seeds_without(const SeedSet& seeds, int32_t excluded) {
  // Ring edges are the segment sites just before a polygon's area site; they come back with
  // add_polygon and must not be added twice.
  std::vector<bool> ring_edge(seeds.sites().size(), false);
  std::vector<std::vector<const Polygon*>> polygons_of(seeds.features().size());
  for (const Polygon& poly : seeds.polygons()) {
    polygons_of[static_cast<size_t>(poly.feature)].push_back(&poly);
    size_t n = 0;
    for (const Ring& ring : poly.rings) n += ring.size();
    for (size_t k = 1; k <= n; ++k) ring_edge[static_cast<size_t>(poly.area_site) - k] = true;
  }
  std::vector<std::vector<int32_t>> sites_of(seeds.features().size());
  for (int32_t i = 0; i < static_cast<int32_t>(seeds.sites().size()); ++i)
    sites_of[static_cast<size_t>(seeds.sites()[static_cast<size_t>(i)].feature)].push_back(i);
  SeedSet out;
  for (const std::string& label : seeds.owner_labels()) out.owner_code(label);  // same codes
  for (size_t f = 0; f < seeds.features().size(); ++f) {
    const Feature& feat = seeds.features()[f];
    if (feat.owner == excluded) continue;
    const int32_t nf = out.add_feature(feat.owner, feat.source);
    for (const Polygon* poly : polygons_of[f]) out.add_polygon(nf, poly->rings);
    for (int32_t i : sites_of[f]) {
      const Site& site = seeds.sites()[static_cast<size_t>(i)];
      if (ring_edge[static_cast<size_t>(i)] || site.kind == SiteKind::area) continue;
      if (site.kind == SiteKind::point)
        out.add_point(nf, site.a);
      else
        out.add_polyline(nf, std::vector<Vec2>{site.a, site.b});
    }
  }
  return out;
}

// Non-planar metrics: one run of the exact engine per owner O, on the window of O's cells and
// the seeds of all other owners, gives the other-owner distance of O's cells exactly as the
// engine measures it (its culling bounds are the metric's own). Cells inside another owner's
// polygon get distance 0 there, so contested cells come out as margin 0.
Raster<float> margin_by_owner_runs(const NearestField& field, const SiteMetric& metric, int threads,
                                   const OtherOwnersField& other_field = nullptr) {
  const SeedSet& seeds = metric.seeds();
  if (seeds.adjusted())
    throw Error(ErrorKind::unsupported,
                "the margin raster is not available with weights or reaches: it measures unweighted distances");
  const GridSpec& g = field.site.grid();
  const Window w = field.site.window();
  Raster<float> out(g, w, kNoDistance);
  const std::vector<int32_t> owner_of_site = owner_of_sites(seeds);
  const int32_t k = seeds.owner_count();
  // Window (field-relative) of each owner's cells.
  std::vector<std::array<int64_t, 4>> box(static_cast<size_t>(k) + 1, {w.width, w.height, -1, -1});
  for (int64_t r = 0; r < w.height; ++r)
    for (int64_t c = 0; c < w.width; ++c) {
      const int32_t s = field.site.at(c, r);
      if (s == kNoSite) continue;
      auto& b = box[static_cast<size_t>(owner_of_site[static_cast<size_t>(s)])];
      b = {std::min(b[0], c), std::min(b[1], r), std::max(b[2], c), std::max(b[3], r)};
    }
  for (int32_t o = 1; o <= k; ++o) {
    const auto& b = box[static_cast<size_t>(o)];
    if (b[2] < 0) continue;
    const SeedSet others = seeds_without(seeds, o);
    if (others.sites().empty()) continue;
    const Window window{w.col0 + b[0], w.row0 + b[1], b[2] - b[0] + 1, b[3] - b[1] + 1};
    ComputeOptions co;
    co.metric = field.metric;
    co.threads = threads;
    co.window = window;
    const NearestField other = other_field ? other_field(o, others, window) : compute(others, g, co);
    for (int64_t r = b[1]; r <= b[3]; ++r)
      for (int64_t c = b[0]; c <= b[2]; ++c) {
        const int32_t s = field.site.at(c, r);
        if (s == kNoSite || owner_of_site[static_cast<size_t>(s)] != o) continue;
        const float d_other = other.distance.at(c - b[0], r - b[1]);
        if (d_other == kNoDistance) continue;
        out.at(c, r) = std::max(0.0f, d_other - field.distance.at(c, r));
      }
  }
  return out;
}

// A metric that is not straight (by sea): the other owners' distance per cell from the index,
// which measures it (no engine run over the other owners' seeds would: it knows no barriers).
Raster<float> margin_by_index(const NearestField& field, const OwnerIndex& index, int threads) {
  const SeedSet& seeds = index.metric().seeds();
  const GridSpec& g = field.site.grid();
  const Window w = field.site.window();
  Raster<float> out(g, w, kNoDistance);
  if (seeds.owner_count() <= 1) return out;
  const std::vector<int32_t> owner_of_site = owner_of_sites(seeds);
  detail::parallel_for(resolve_threads(threads), w.height, [&](int64_t r, int) {
    for (int64_t c = 0; c < w.width; ++c) {
      const int32_t s = field.site.at(c, r);
      if (s == kNoSite) continue;
      const Vec2 p = centre(g, w.col0 + c, w.row0 + r);
      const OwnerIndex::Hit other = index.nearest_not_of(p, owner_of_site[static_cast<size_t>(s)]);
      if (other.site == kNoSite) continue;
      out.at(c, r) = static_cast<float>(std::max(0.0, other.distance - static_cast<double>(field.distance.at(c, r))));
    }
  });
  return out;
}

}  // namespace

Raster<float> margin_raster(const NearestField& field, const OwnerIndex& index, int threads,
                            const OtherOwnersField& other_field) {
  const SiteMetric& metric = index.metric();
  check_metric(field, metric);
  const SeedSet& seeds = metric.seeds();
  if (seeds.adjusted())
    throw Error(ErrorKind::unsupported,
                "the margin raster is not available with weights or reaches: it measures unweighted distances");
  if (!metric.straight())
    return other_field ? margin_by_owner_runs(field, metric, threads, other_field)
                       : margin_by_index(field, index, threads);
  // The per-owner engine runs below would need the other owners' polygons in the grid's CRS,
  // which the field does not carry.
  if (field.geolocator)
    throw Error(ErrorKind::unsupported,
                "the margin raster is not available for the geodesic metric on a projected "
                "grid yet; use a geographic (longitude/latitude) grid, or metric planar");
  const GridSpec& g = field.site.grid();
  const Window w = field.site.window();
  Raster<float> out(g, w, kNoDistance);
  if (seeds.owner_count() <= 1) return out;
  const int nthreads = resolve_threads(threads);
  const std::vector<int32_t> owner_of_site = owner_of_sites(seeds);
  // Polygons per owner, for cells inside another owner's polygon too (contested: margin 0).
  std::vector<int32_t> area_sites;
  for (const Polygon& p : seeds.polygons()) area_sites.push_back(p.area_site);
  const bool check_contested = field.contested_cells > 0;

  const bool planar = metric.kind() == SiteMetric::Kind::planar;
  if (!planar) return margin_by_owner_runs(field, metric, nthreads);
  const NearestField other = compute_other_owner(seeds, field, nthreads);
  detail::parallel_for(nthreads, w.height, [&](int64_t r, int) {
    for (int64_t c = 0; c < w.width; ++c) {
      const int32_t s = field.site.at(c, r);
      if (s == kNoSite) continue;
      const int32_t o = owner_of_site[static_cast<size_t>(s)];
      const Vec2 p = centre(g, w.col0 + c, w.row0 + r);
      const bool own_area = seeds.sites()[static_cast<size_t>(s)].kind == SiteKind::area;
      const double d_own = own_area ? 0.0 : metric.distance(p, s);
      const int32_t t = other.site.at(c, r);
      if (t == kNoSite) continue;
      const double d_other = metric.distance(p, t);  // in double, not the Float32 of the field
      if (check_contested && own_area)
        for (int32_t a : area_sites)
          if (owner_of_site[static_cast<size_t>(a)] != o && metric.inside_area(p, a)) {
            out.at(c, r) = 0.0f;
            break;
          }
      if (out.at(c, r) == 0.0f) continue;
      out.at(c, r) = static_cast<float>(std::max(0.0, d_other - d_own));
    }
  });
  return out;
}

}  // namespace rv
