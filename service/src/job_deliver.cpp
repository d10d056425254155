// The deliverables stage of a job (job_run.hpp): one function per deliverable, each writing its
// file, its counts into the report and its time into timings["deliverables"].
#include <memory>
#include <optional>

#include "job_run.hpp"
#include "rv/deliverables.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/vector_writer.hpp"
#include "rv/outputs.hpp"
#include "rv/preview.hpp"

namespace rv::detail {
namespace {

// What every deliverable of one job measures with and reports in.
struct DeliverContext {
  JobRun& run;
  const PreparedJob& job;
  const NearestField& field;  // exact
  const SiteMetric& metric;
  const OwnerIndex& index;
  double cell_length;  // one cell in metric units near the grid's centre (degrees are not metres)
  VectorOutputOptions vector;
  nlohmann::json times = nlohmann::json::object();
  nlohmann::json report = nlohmann::json::object();
  const OutputRequest& out() const { return run.spec.outputs; }
};

// The deliverables measure with the field's own metric (projected geodesic grids: located on
// the ellipsoid, positions and outputs in the grid's CRS).
std::unique_ptr<SiteMetric> site_metric(const PreparedJob& job, const NearestField& field) {
  const SeedSet& seeds = job.loaded.seeds;
  if (job.located())
    return std::make_unique<LocatedGeodesicSiteMetric>(seeds, field.metric, job.compute.geolocator,
                                                       job.compute.grid_polygons);
  if (field.metric.kind == MetricSpec::geodesic) return std::make_unique<GeodesicSiteMetric>(seeds, field.metric);
  return std::make_unique<PlanarSiteMetric>(seeds, Vec2{job.grid.xmin, job.grid.ymax});
}

BoundaryResult boundaries_stage(DeliverContext& c) {
  const OutputRequest& out = c.out();
  BoundaryResult boundaries;
  if (out.boundaries.empty() && out.tripoints.empty() && out.preview.empty()) return boundaries;
  timed(c.times, "boundaries", [&] {
    BoundaryOptions bo;
    bo.simplify_cells = out.simplify_cells;
    bo.threads = c.run.spec.threads;
    boundaries = extract_boundaries(c.field, c.index, bo);
    const BoundaryStats& st = boundaries.stats;
    c.report["boundaries"] = {{"lines", boundaries.lines.size()},
                              {"vertices", st.vertices},
                              {"vertices_before_simplify", st.vertices_before_simplify},
                              {"tripoints", boundaries.tripoints.size()},
                              {"crossings", st.crossings},
                              {"saddles", st.saddles},
                              {"multi_owner_squares", st.multi_owner_squares},
                              {"unresolved_tripoints", st.unresolved_tripoints},
                              {"sliver_crossings", st.sliver_crossings},
                              {"unresolved_slivers", st.unresolved_slivers},
                              {"max_residual", st.max_residual * c.job.to_output},
                              {"max_residual_cells", st.max_residual / c.cell_length},
                              {"simplify_cells", out.simplify_cells}};
    if (!out.boundaries.empty()) {
      c.run.will_write(out.boundaries);
      write_boundaries(out.boundaries, boundaries, c.metric, c.vector);
      c.run.wrote("boundaries", out.boundaries);
    }
    if (!out.tripoints.empty()) {
      c.run.will_write(out.tripoints);
      write_tripoints(out.tripoints, boundaries, c.metric, c.vector);
      c.run.wrote("tripoints", out.tripoints);
    }
  });
  return boundaries;
}

void limits_stage(DeliverContext& c) {
  const OutputRequest& out = c.out();
  if (out.limits.empty()) return;
  c.run.check_cancel();
  timed(c.times, "limits", [&] {
    LimitOptions lo;
    lo.per_owner = out.limits_per_owner;
    lo.simplify_cells = out.simplify_cells;
    lo.threads = c.run.spec.threads;
    const LimitResult limits = extract_limits(c.field, c.index, c.job.limit_distances, lo);
    c.run.will_write(out.limits);
    write_limits(out.limits, limits, c.job.loaded.seeds, c.vector);
    c.run.wrote("limits", out.limits);
    nlohmann::json distances = nlohmann::json::array();
    for (double d : c.job.limit_distances) distances.push_back(d * c.job.to_output);
    c.report["limits"] = {{"distances", distances},
                          {"as_given", out.limit_distances},
                          {"per_owner", out.limits_per_owner},
                          {"lines", limits.lines.size()},
                          {"vertices", limits.vertices},
                          {"max_residual", limits.max_residual * c.job.to_output},
                          {"max_residual_cells", limits.max_residual / c.cell_length}};
  });
}

void regions_stage(DeliverContext& c, const Raster<int32_t>& owner_codes) {
  const OutputRequest& out = c.out();
  if (out.regions.empty()) return;
  c.run.check_cancel();
  timed(c.times, "regions", [&] {
    c.run.will_write(out.regions);
    const RegionStats rs = write_regions(out.regions, owner_codes, c.job.loaded.seeds, c.vector);
    c.run.wrote("regions", out.regions);
    c.report["regions"] = {{"owners", rs.owners}, {"polygons", rs.polygons}};
  });
}

void margin_stage(DeliverContext& c) {
  const OutputRequest& out = c.out();
  if (out.margin.empty()) return;
  c.run.check_cancel();
  timed(c.times, "margin", [&] {
    Raster<float> margin = margin_raster(c.field, c.index, c.run.spec.threads);
    if (c.job.to_output != 1.0)
      for (float& v : margin.cells())
        if (v != kNoDistance) v = static_cast<float>(v * c.job.to_output);
    GeoTiffOptions o = raster_options(c.run.spec);
    o.units = c.job.unit;
    o.metadata["CONTENT"] = "distance to the nearest seed of another owner minus distance to the own nearest seed";
    o.metadata["UNITS"] = c.job.unit;
    c.run.will_write(out.margin);
    write_geotiff(out.margin, margin, static_cast<double>(kNoDistance), o);
    c.run.wrote("margin", out.margin);
  });
}

void preview_stage(DeliverContext& c, const Raster<int32_t>& owner_codes, const BoundaryResult& boundaries) {
  const OutputRequest& out = c.out();
  if (out.preview.empty()) return;
  c.run.check_cancel();
  timed(c.times, "preview", [&] {
    c.run.will_write(out.preview);
    const PreviewInfo pi = write_preview(out.preview, owner_codes, &boundaries);
    c.run.wrote("preview", out.preview);
    c.report["preview"] = {{"width", pi.width}, {"height", pi.height}, {"cells_per_pixel", pi.step}};
  });
}

}  // namespace

GeoTiffOptions raster_options(const JobSpec& spec) {
  GeoTiffOptions o;
  o.cloud_optimized = spec.outputs.cloud_optimized;
  o.threads = spec.threads;
  o.compression = spec.outputs.compression;
  return o;
}

void deliver(JobRun& run, const PreparedJob& job, const NearestField& computed) {
  if (!run.spec.outputs.any_deliverable()) return;
  run.check_cancel();
  run.progress("deliver", 0.0);
  nlohmann::json times = nlohmann::json::object();
  // From an exact field: a scan's ownership is not exact, so the exact method runs for them.
  const NearestField* field = &computed;
  NearestField exact;
  if (run.spec.method != Method::exact && run.spec.method != Method::brute_force) {
    ComputeOptions eo = job.compute;
    eo.method = Method::exact;
    eo.progress = nullptr;
    exact = compute(job.loaded.seeds, job.grid, eo);
    field = &exact;
    times["exact_field"] = exact.seconds;
  }
  const std::unique_ptr<SiteMetric> metric = site_metric(job, *field);
  const OwnerIndex index(*metric);
  const GridSpec& g = job.grid;
  const Vec2 mid{g.centre_x(g.width / 2), g.centre_y(g.height / 2)};
  DeliverContext c{run, job, *field, *metric, index, metric->point_distance(mid, Vec2{mid.x + g.res, mid.y}), {}};
  c.times = times;
  c.vector.crs = job.loaded.crs.wkt;
  c.vector.distance_factor = job.to_output;
  c.vector.distance_units = job.unit;

  const BoundaryResult boundaries = boundaries_stage(c);
  run.progress("deliver", 0.3);
  limits_stage(c);
  run.progress("deliver", 0.5);
  // The owner raster the write stage kept, or made here.
  std::optional<Raster<int32_t>> owner_codes = std::move(run.owner_codes);
  run.owner_codes.reset();
  if (!owner_codes && (!c.out().regions.empty() || !c.out().preview.empty()))
    owner_codes = owner_raster(job.loaded.seeds, *field, run.spec.threads);
  if (owner_codes) regions_stage(c, *owner_codes);
  run.progress("deliver", 0.7);
  margin_stage(c);
  run.progress("deliver", 0.9);
  if (owner_codes) preview_stage(c, *owner_codes, boundaries);
  run.progress("deliver", 1.0);
  run.timings["deliverables"] = c.times;
  run.report["deliverables"] = c.report;
}

}  // namespace rv::detail
