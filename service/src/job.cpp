#include "rv/job.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include "atomic_file.hpp"
#include "job_stream.hpp"
#include "memory_watch.hpp"
#include "rv/deliverables.hpp"
#include "rv/error.hpp"
#include "rv/geolocator.hpp"
#include "rv/json_text.hpp"
#include "rv/outputs.hpp"
#include "rv/preview.hpp"
#include "rv/raster_io.hpp"
#include "rv/validate.hpp"
#include "rv/vector_writer.hpp"
#include "rv/version.hpp"

namespace rv {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Removes every file this job wrote unless the job finishes: a failed job leaves nothing behind.
class OutputGuard {
 public:
  ~OutputGuard() {
    if (committed_) return;
    std::error_code ec;
    for (const std::string& f : files_) {
      std::filesystem::remove(f, ec);
      std::filesystem::remove(f + ".aux.xml", ec);
    }
  }
  void add(const std::string& f) { files_.push_back(f); }
  void commit() { committed_ = true; }
  const std::vector<std::string>& files() const { return files_; }

 private:
  std::vector<std::string> files_;
  bool committed_ = false;
};

nlohmann::json grid_json(const GridSpec& g, const CrsInfo& crs) {
  return {{"width", g.width},        {"height", g.height},
          {"cells", g.cell_count()}, {"xmin", g.xmin},
          {"ymin", g.ymin()},        {"xmax", g.xmax()},
          {"ymax", g.ymax},          {"resolution", g.res},
          {"crs", crs.name},         {"geographic", crs.geographic}};
}

nlohmann::json seeds_json(const LoadedSeeds& loaded) {
  const SeedSet& s = loaded.seeds;
  int64_t points = 0, segments = 0;
  for (const Site& site : s.sites()) {
    points += site.kind == SiteKind::point;
    segments += site.kind == SiteKind::segment;
  }
  nlohmann::json owners = nlohmann::json::array();
  for (size_t i = 0; i < s.owner_labels().size(); ++i)
    owners.push_back({{"code", i + 1}, {"label", s.owner_labels()[i]}});
  const SeedReadReport& r = loaded.report;
  return {{"features", s.features().size()},
          {"points", points},
          {"segments", segments},
          {"polygons", s.polygons().size()},
          {"owners", owners},
          {"features_read", r.features_read},
          {"features_skipped_empty", r.features_skipped_empty},
          {"vertices_removed", r.vertices_removed},
          {"points_removed", r.points_removed},
          {"conflicts", r.conflicts},
          {"vertices_read", r.vertices_read},
          {"polygons_repaired", r.polygons_repaired},
          {"warnings", r.warnings}};
}

// The memory a job may use: the configured limit, else 80 % of physical memory (0 = unknown).
int64_t memory_budget(const JobLimits& limits) {
  return limits.max_memory_bytes > 0 ? limits.max_memory_bytes : physical_memory_bytes() / 10 * 8;
}

}  // namespace

LimitDistance parse_limit_distance(const std::string& text) {
  LimitDistance out;
  out.text = text;
  const char* begin = text.c_str();
  char* end = nullptr;
  out.value = std::strtod(begin, &end);
  std::string unit(end == begin ? text : std::string(end));
  unit.erase(0, unit.find_first_not_of(" \t"));
  unit.erase(unit.find_last_not_of(" \t") + 1);
  if (end == begin || !std::isfinite(out.value) || out.value <= 0.0)
    throw Error(ErrorKind::invalid_argument, "limit distance '" + text + "' is not a positive number");
  if (!unit.empty()) parse_distance_unit(unit);  // throws for an unknown unit
  out.unit = unit;
  return out;
}

int64_t physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), size = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && size > 0 ? static_cast<int64_t>(pages) * size : 0;
}

MetricPlan plan_metric(MetricRequest request, std::optional<DistanceUnit> units, const CrsInfo& crs) {
  MetricPlan p;
  if (request == MetricRequest::geodesic && crs.wkt.empty())
    throw Error(ErrorKind::invalid_argument,
                "metric geodesic needs a CRS (to know the ellipsoid and where the cells lie on it); the seeds have "
                "none: give the layers a CRS, or use metric planar");
  p.metric = resolve_metric(request, crs.geographic, crs.semi_major, crs.flattening);
  // The engines measure in metric units: metres for geodesic, CRS units for planar.
  const double metric_unit_in_metres = p.metric.kind == MetricSpec::geodesic ? 1.0 : crs.linear_unit;
  if (units) {
    if (p.metric.kind == MetricSpec::planar && crs.wkt.empty())
      throw Error(ErrorKind::invalid_argument, "distance units need a CRS with known units; the seeds have none");
    p.to_output = metric_unit_in_metres / metres_per_unit(*units);
    p.unit = std::string(to_string(*units));
  } else if (p.metric.kind == MetricSpec::geodesic || (!crs.wkt.empty() && crs.linear_unit == 1.0)) {
    p.unit = "m";
  } else {
    p.unit = crs.wkt.empty() ? "crs-units" : "crs-units (" + std::to_string(crs.linear_unit) + " m)";
  }
  return p;
}

GridSpec plan_grid(const GridRequest& request, const LoadedSeeds& loaded) {
  if (!request.like.empty()) {
    GridSpec g = read_grid(request.like);
    g.crs = loaded.crs.wkt;
    return g;
  }
  if (!request.resolution) throw Error(ErrorKind::invalid_argument, "a resolution is required (or --like a raster)");
  const double res = *request.resolution;
  if (!std::isfinite(res) || res <= 0.0)
    throw Error(ErrorKind::invalid_argument, "resolution must be a positive number");
  if (request.extent) {
    const auto& e = *request.extent;
    // On geographic grids a west edge east of the east edge crosses the antimeridian.
    const double east = loaded.crs.geographic ? unwrap_east_longitude(e[0], e[2]) : e[2];
    return make_grid(e[0], e[1], east, e[3], res, loaded.crs.wkt);
  }
  // Seeds read in the grid CRS's geographic base (projected geodesic grids) are in degrees:
  // the extent comes from their box in the grid CRS.
  const SeedSet::Box b = loaded.grid_bounds.value_or(loaded.seeds.bounds());
  if (!std::isfinite(b.xmin)) throw Error(ErrorKind::invalid_input, "no seeds: cannot derive an extent");
  if (request.margin && !(std::isfinite(*request.margin) && *request.margin >= 0.0))
    throw Error(ErrorKind::invalid_argument, "margin must be a non-negative number");
  const double span = std::max(b.xmax - b.xmin, b.ymax - b.ymin);
  const double margin = request.margin.value_or(0.05 * span);
  if (!std::isfinite(span) || !std::isfinite(margin))
    throw Error(ErrorKind::invalid_input, "the seeds' extent is too large to derive a grid from; give an extent");
  // A lone point (or a margin of 0) still needs one cell around it.
  const double m = std::max(margin, 0.5 * res);
  GridSpec g = make_aligned_grid(b.xmin - m, b.ymin - m, b.xmax + m, b.ymax + m, res, loaded.crs.wkt);
  if (loaded.crs.geographic && (g.ymin() < -90.0 || g.ymax > 90.0)) {
    // The margin must not carry a default grid past a pole (seeds at or near ±90): latitudes
    // beyond it name no place. The grid keeps whole cells on the same lattice, within ±90.
    const double south = std::max(g.ymin(), std::ceil(-90.0 / res) * res);
    const double north = std::min(g.ymax, std::floor(90.0 / res) * res);
    if (!(south < north))
      throw Error(ErrorKind::invalid_argument, "the resolution is too coarse for a grid between the poles");
    g = make_grid(g.xmin, south, g.xmax(), north, res, loaded.crs.wkt);
  }
  return g;
}

SeedReadOptions seed_options_for_metric(SeedReadOptions read, MetricRequest metric_request) {
  // Geodesic measures in longitude/latitude: on a projected grid the seeds are read in its
  // geographic base (the engine locates the cells there), auto never picks geodesic on one.
  read.geographic_seeds = metric_request == MetricRequest::geodesic;
  return read;
}

void geolocate_grid(ComputeOptions& options, const LoadedSeeds& loaded) {
  if (options.metric.kind != MetricSpec::geodesic || loaded.crs.geographic) return;
  if (!loaded.geographic_base)
    throw Error(ErrorKind::internal,
                "geodesic metric on a projected grid, but the seeds were not read in longitude/latitude");
  options.geolocator = std::make_shared<OsrGeolocator>(loaded.crs.wkt);
  options.grid_polygons = loaded.grid_polygons;
}

namespace {

// Strips of about this many cells (rounded up to whole GeoTIFF tile rows, so that strips go to
// the encoder without a copy). The seeds are prepared once for all strips (rv::prepare), so a
// strip costs little more than its cells: engine_bench --warm --strip-rows 64, 1e8 cells and
// 50 000 points, computes 64-row strips in 242 ms against 186 ms for the whole grid. Small
// strips keep memory low and fault fewer fresh pages (first touches are slow on a VM):
// 10000 x 10000 cells go in 40 strips of 256 rows, peak RSS 210 MB instead of 330 MB with
// 768-row strips.
constexpr int64_t kStripCells = int64_t{2} << 20;
constexpr int64_t kTileRows = 256;  // GeoTiffStripWriter's tile height
// Per streamed GeoTIFF besides its 256-row band buffer: GeoTiffStripWriter's encoded tiles in
// flight and a raw tile per encoding thread (vector/src/raster_io.cpp, kChunkTiles).
constexpr int64_t kWriterBytes = int64_t{12} << 20;

}  // namespace

int64_t seed_memory_bytes(const LoadedSeeds& loaded) {
  int64_t bytes =
      loaded.seeds.memory_bytes() + static_cast<int64_t>(loaded.input_position.capacity() * sizeof(int64_t));
  if (loaded.grid_polygons) {
    for (const Polygon& p : *loaded.grid_polygons)
      for (const Ring& r : p.rings) bytes += static_cast<int64_t>(r.capacity() * sizeof(Vec2) + sizeof(Ring));
  }
  return bytes;
}

JobPlan plan_job(const JobSpec& spec, const GridSpec& grid, int64_t sites, MetricSpec::Kind metric,
                 int64_t seed_bytes) {
  JobPlan p;
  const OutputRequest& out = spec.outputs;
  const int64_t cells = grid.cell_count();
  const int64_t int_rasters = !out.ownership.empty() + !out.nearest_feature.empty();
  const int64_t rasters = int_rasters + !out.distance.empty();
  if (spec.method != Method::exact && spec.method != Method::brute_force)
    p.why_whole = "the scan methods propagate inside a window: a strip would differ from the whole grid";
  else if (out.any_deliverable())
    p.why_whole = "deliverables need the whole field";
  else if (out.cloud_optimized)
    p.why_whole = "a COG is made by copying a complete dataset";
  else if (spec.validate)
    p.why_whole = "validation compares whole fields";
  else if (rasters == 0)
    p.why_whole = "no raster output";
  else if (spec.strip_rows < 0)
    p.why_whole = "streaming turned off";
  p.streamed = p.why_whole.empty();
  if (p.streamed) {
    const int64_t rows = spec.strip_rows > 0
                             ? spec.strip_rows
                             : (std::max<int64_t>(1, kStripCells / std::max<int64_t>(grid.width, 1)) + kTileRows - 1) /
                                   kTileRows * kTileRows;
    p.strip_rows = std::clamp<int64_t>(rows, 1, std::max<int64_t>(grid.height, 1));
    p.strips = (grid.height + p.strip_rows - 1) / p.strip_rows;
    const int64_t strip_cells = p.strip_rows * grid.width;
    // Two strip buffers (the engine's result; the distance is scaled in place), one Int32 strip
    // of codes per integer product (made by its writer), and per file a band of tile rows and
    // the tiles in flight.
    p.memory_bytes = estimate_memory(spec.method, 2 * strip_cells, sites, metric) + strip_cells * 4 * int_rasters +
                     rasters * (kTileRows * grid.width * 4 + kWriterBytes) + seed_bytes;
    return p;
  }
  p.strip_rows = grid.height;
  p.strips = 1;
  int64_t need = estimate_memory(spec.method, cells, sites, metric) + cells * 4;  // + one output raster
  // A COG of codes in a narrower type is copied from a narrowed copy (at most 2 bytes a cell).
  if (out.cloud_optimized && int_rasters > 0) need += cells * 2;
  if (spec.validate) need += estimate_memory(Method::brute_force, cells, sites, metric);
  if (out.any_deliverable()) {
    need += cells * 4;                                                                          // owner codes
    if (spec.method != Method::exact && spec.method != Method::brute_force) need += cells * 8;  // exact field
    if (!out.margin.empty()) need += cells * 12;  // other-owner field + margin
    if (!out.limits.empty()) need += cells;       // inside flags
  }
  p.memory_bytes = need + seed_bytes;
  return p;
}

JobResult run_job(const JobSpec& spec, const JobLimits& limits, const JobHooks& hooks) {
  const auto start = Clock::now();
  auto progress = [&](const char* stage, double f) {
    if (hooks.progress) hooks.progress(stage, f);
  };
  auto check_cancel = [&] {
    if (hooks.cancel && hooks.cancel->load()) throw Error(ErrorKind::cancelled, "job dismissed");
  };
  gdal_init();
  detail::MemoryWatch memory;
  OutputGuard guard;
  nlohmann::json report;
  nlohmann::json timings;

  // 1. Seeds.
  progress("read", 0.0);
  SeedReadOptions read = seed_options_for_metric(spec.seeds, spec.metric);
  // The stricter of two limits, where 0 means none.
  auto stricter = [](int64_t a, int64_t b) { return a <= 0 ? b : b <= 0 ? a : std::min(a, b); };
  read.max_features = stricter(read.max_features, limits.max_features);
  read.max_vertices = stricter(read.max_vertices, limits.max_vertices);
  read.max_input_bytes = stricter(read.max_input_bytes, limits.max_input_bytes);
  read.max_memory_bytes = stricter(read.max_memory_bytes, memory_budget(limits));
  if (read.target_crs.empty() && !spec.grid.like.empty()) {
    // Outputs must line up with the template raster, so the seeds go into its CRS.
    read.target_crs = read_grid(spec.grid.like).crs;
  }
  auto t = Clock::now();
  LoadedSeeds loaded = load_seeds(read);
  timings["read"] = seconds_since(t);
  progress("read", 1.0);
  check_cancel();

  // 2. Grid, metric, units, limits: everything is decided before the big allocations.
  const GridSpec grid = plan_grid(spec.grid, loaded);
  const MetricPlan mp = plan_metric(spec.metric, spec.distance_units, loaded.crs);
  const bool geodesic = mp.metric.kind == MetricSpec::geodesic;
  const double factor = mp.to_output;
  const std::string& unit_name = mp.unit;
  ComputeOptions options;
  options.metric = mp.metric;
  options.method = spec.method;
  options.threads = spec.threads;
  geolocate_grid(options, loaded);
  const bool located = options.geolocator != nullptr;  // geodesic on a projected grid
  if (spec.max_distance) {
    if (!std::isfinite(*spec.max_distance) || *spec.max_distance < 0.0)
      throw Error(ErrorKind::invalid_argument, "max distance must be a non-negative number");
    options.max_distance = *spec.max_distance / factor;
  }
  // Limit distances, converted to metric units (CRS units on planar grids).
  const OutputRequest& deliver = spec.outputs;
  std::vector<double> limit_metric;
  if (!deliver.limits.empty() && deliver.limit_distances.empty())
    throw Error(ErrorKind::invalid_argument, "limit lines need limit distances (e.g. --limit-distances 12nmi,24nmi)");
  for (const std::string& text : deliver.limit_distances) {
    const LimitDistance d = parse_limit_distance(text);
    if (!d.unit.empty()) {
      if (!geodesic && loaded.crs.wkt.empty())
        throw Error(ErrorKind::invalid_argument, "limit distance '" + text + "' has a unit, but the seeds have no CRS");
      // Metric units are metres on geodesic grids, CRS units on planar ones.
      limit_metric.push_back(d.value * metres_per_unit(parse_distance_unit(d.unit)) /
                             (geodesic ? 1.0 : loaded.crs.linear_unit));
    } else {
      limit_metric.push_back(d.value / factor);
    }
  }
  for (double d : limit_metric)
    if (d > options.max_distance)
      throw Error(ErrorKind::invalid_argument,
                  "a limit distance exceeds the max distance: cells beyond it have no distance to draw the line in");
  // The margin raster is not available on a projected geodesic grid yet (rv/deliverables.hpp):
  // refused before anything is computed.
  if (located && !deliver.margin.empty())
    throw Error(ErrorKind::unsupported,
                "the margin raster is not available for the geodesic metric on a projected grid yet; use a "
                "geographic (longitude/latitude) grid (--crs EPSG:4326), or metric planar");
  if (!(deliver.simplify_cells >= 0.0) || !std::isfinite(deliver.simplify_cells))
    throw Error(ErrorKind::invalid_argument, "the simplification tolerance must be a non-negative number of cells");
  const int64_t cells = grid.cell_count();
  if (cells > limits.max_cells)
    throw Error(ErrorKind::too_large, "the grid has " + std::to_string(cells) + " cells, over the limit of " +
                                          std::to_string(limits.max_cells));
  const int64_t sites = static_cast<int64_t>(loaded.seeds.sites().size());
  const JobPlan plan = plan_job(spec, grid, sites, mp.metric.kind, seed_memory_bytes(loaded));
  const int64_t need = plan.memory_bytes;
  const int64_t budget = memory_budget(limits);
  if (budget > 0 && need > budget)
    throw Error(ErrorKind::too_large, "the job needs about " + std::to_string(need >> 20) + " MiB for " +
                                          std::to_string(cells) + " cells, over the memory limit of " +
                                          std::to_string(budget >> 20) + " MiB");
  if (spec.validate && cells > limits.validate_max_cells)
    throw Error(ErrorKind::too_large, "validate runs brute force, allowed up to " +
                                          std::to_string(limits.validate_max_cells) + " cells; this grid has " +
                                          std::to_string(cells));

  // How each raster GeoTIFF is described; the same on both paths. The code rasters state their
  // largest code, so that they are written in the narrowest type that holds it (owner codes are
  // 1..K; feature numbers at most the largest input position).
  GeoTiffOptions common;
  common.cloud_optimized = spec.outputs.cloud_optimized;
  common.threads = spec.threads;
  common.compression = spec.outputs.compression;
  GeoTiffOptions ownership_options = common;
  ownership_options.categorical = true;
  ownership_options.category_labels = loaded.seeds.owner_labels();
  ownership_options.max_code = loaded.seeds.owner_count();
  ownership_options.metadata["CONTENT"] = "owner code of the nearest seed (0 = none)";
  GeoTiffOptions distance_options = common;
  distance_options.units = unit_name;
  distance_options.metadata["CONTENT"] = "distance to the nearest seed";
  distance_options.metadata["UNITS"] = unit_name;
  distance_options.metadata["METRIC"] = geodesic ? "geodesic" : "planar";
  GeoTiffOptions feature_options = common;
  feature_options.categorical = true;
  feature_options.max_code = loaded.input_position.empty()
                                 ? static_cast<int64_t>(loaded.seeds.features().size())
                                 : *std::max_element(loaded.input_position.begin(), loaded.input_position.end());
  feature_options.metadata["CONTENT"] = "1-based position of the nearest seed feature in the input (0 = none)";

  options.cancel = hooks.cancel;
  nlohmann::json write_times = nlohmann::json::object();
  nlohmann::json outputs;
  double compute_seconds = 0.0;
  int64_t contested_cells = 0;
  int threads_used = 1;
  NearestField field;  // the whole field (whole path only)
  if (plan.streamed) {
    // 3+5. Compute strip by strip, each strip encoded while the next is computed.
    detail::StreamJob job;
    job.seeds = &loaded.seeds;
    job.grid = grid;
    job.compute = options;
    job.strip_rows = plan.strip_rows;
    job.distance_factor = factor;
    job.feature_numbering = loaded.input_position;
    job.progress = [&](const char* stage, double f) { progress(stage, f); };
    job.will_write = [&](const std::string& path) { guard.add(path); };
    using Product = detail::StreamTarget::Product;
    if (!spec.outputs.ownership.empty())
      job.targets.push_back({Product::ownership, spec.outputs.ownership, ownership_options, "ownership"});
    if (!spec.outputs.distance.empty())
      job.targets.push_back({Product::distance, spec.outputs.distance, distance_options, "distance"});
    if (!spec.outputs.nearest_feature.empty())
      job.targets.push_back(
          {Product::nearest_feature, spec.outputs.nearest_feature, feature_options, "nearest_feature"});
    progress("compute", 0.0);
    const detail::StreamStats st = detail::run_streamed(job);
    compute_seconds = st.compute;
    contested_cells = st.contested_cells;
    threads_used = st.threads;
    for (const auto& [name, seconds] : st.write) write_times[name] = seconds;
    for (const detail::StreamTarget& t : job.targets) outputs[t.name] = t.path;
    timings["compute"] = st.compute;
    // compute and write overlap: their sum exceeds the wall time they took together.
    timings["streamed"] = {{"strips", st.strips},
                           {"rows_per_strip", plan.strip_rows},
                           {"wall", st.wall},
                           {"convert", st.convert},
                           {"compute_waited_for_writer", st.compute_waited},
                           {"writer_waited_for_compute", st.write_waited}};
  } else {
    // 3. Compute.
    options.progress = [&](double f) { progress("compute", f); };
    field = compute(loaded.seeds, grid, options);
    compute_seconds = field.seconds;
    contested_cells = field.contested_cells;
    threads_used = field.threads;
    timings["compute"] = field.seconds;

    // 4. Validate against brute force.
    if (spec.validate) {
      t = Clock::now();
      ComputeOptions brute = options;
      brute.method = Method::brute_force;
      brute.progress = [&](double f) { progress("validate", f); };
      const NearestField reference = compute(loaded.seeds, grid, brute);
      const ValidationStats v = compare_fields(loaded.seeds, field, reference);
      report["validation"] = {{"reference", "brute-force"},
                              {"cells", v.cells},
                              {"wrong_cells", v.wrong_cells},
                              {"wrong_owner_cells", v.wrong_owner_cells},
                              {"tie_cells", v.tie_cells},
                              {"nodata_mismatch", v.nodata_mismatch},
                              {"max_error", v.max_error * factor},
                              {"max_error_cells", v.max_error_cells},
                              {"reference_seconds", reference.seconds}};
      timings["validate"] = seconds_since(t);
    }
    check_cancel();

    // 5. Write.
    progress("write", 0.0);
    if (!spec.outputs.ownership.empty()) {
      t = Clock::now();
      const Raster<int32_t> owners = owner_raster(loaded.seeds, field, spec.threads);
      guard.add(spec.outputs.ownership);
      write_geotiff(spec.outputs.ownership, owners, 0.0, ownership_options);
      write_times["ownership"] = seconds_since(t);
      outputs["ownership"] = spec.outputs.ownership;
    }
    progress("write", 0.4);
    if (!spec.outputs.distance.empty()) {
      t = Clock::now();
      const Raster<float> dist = factor == 1.0 ? field.distance : scaled_distance(field, factor, spec.threads);
      guard.add(spec.outputs.distance);
      write_geotiff(spec.outputs.distance, dist, static_cast<double>(kNoDistance), distance_options);
      write_times["distance"] = seconds_since(t);
      outputs["distance"] = spec.outputs.distance;
    }
    progress("write", 0.8);
    if (!spec.outputs.nearest_feature.empty()) {
      t = Clock::now();
      guard.add(spec.outputs.nearest_feature);
      write_geotiff(spec.outputs.nearest_feature,
                    feature_raster(loaded.seeds, field, spec.threads, loaded.input_position), 0.0, feature_options);
      write_times["nearest_feature"] = seconds_since(t);
      outputs["nearest_feature"] = spec.outputs.nearest_feature;
    }
  }

  // 6. Deliverables, from an exact field (a scan's ownership is not exact).
  if (deliver.any_deliverable()) {
    check_cancel();
    progress("deliver", 0.0);
    nlohmann::json deliver_times, deliver_report;
    const NearestField* exact_field = &field;
    NearestField exact_copy;
    if (spec.method != Method::exact && spec.method != Method::brute_force) {
      ComputeOptions eo = options;
      eo.method = Method::exact;
      eo.progress = nullptr;
      exact_copy = compute(loaded.seeds, grid, eo);
      exact_field = &exact_copy;
      deliver_times["exact_field"] = exact_copy.seconds;
    }
    // The deliverables measure with the field's own metric (projected geodesic grids: located
    // on the ellipsoid, positions and outputs in the grid's CRS).
    std::unique_ptr<SiteMetric> metric_ptr;
    if (located)
      metric_ptr = std::make_unique<LocatedGeodesicSiteMetric>(loaded.seeds, exact_field->metric, options.geolocator,
                                                               options.grid_polygons);
    else if (exact_field->metric.kind == MetricSpec::geodesic)
      metric_ptr = std::make_unique<GeodesicSiteMetric>(loaded.seeds, exact_field->metric);
    else
      metric_ptr = std::make_unique<PlanarSiteMetric>(loaded.seeds, Vec2{grid.xmin, grid.ymax});
    const SiteMetric& metric = *metric_ptr;
    const OwnerIndex index(metric);
    // One cell's length in metric units near the grid's centre (degrees are not metres).
    const Vec2 mid{grid.centre_x(grid.width / 2), grid.centre_y(grid.height / 2)};
    const double cell_length = metric.point_distance(mid, Vec2{mid.x + grid.res, mid.y});
    VectorOutputOptions vo;
    vo.crs = loaded.crs.wkt;
    vo.distance_factor = factor;
    vo.distance_units = unit_name;
    BoundaryResult boundaries;
    if (!deliver.boundaries.empty() || !deliver.tripoints.empty() || !deliver.preview.empty()) {
      t = Clock::now();
      BoundaryOptions bo;
      bo.simplify_cells = deliver.simplify_cells;
      bo.threads = spec.threads;
      boundaries = extract_boundaries(*exact_field, index, bo);
      const BoundaryStats& st = boundaries.stats;
      deliver_report["boundaries"] = {{"lines", boundaries.lines.size()},
                                      {"vertices", st.vertices},
                                      {"vertices_before_simplify", st.vertices_before_simplify},
                                      {"tripoints", boundaries.tripoints.size()},
                                      {"crossings", st.crossings},
                                      {"saddles", st.saddles},
                                      {"multi_owner_squares", st.multi_owner_squares},
                                      {"unresolved_tripoints", st.unresolved_tripoints},
                                      {"sliver_crossings", st.sliver_crossings},
                                      {"unresolved_slivers", st.unresolved_slivers},
                                      {"max_residual", st.max_residual * factor},
                                      {"max_residual_cells", st.max_residual / cell_length},
                                      {"simplify_cells", deliver.simplify_cells}};
      if (!deliver.boundaries.empty()) {
        guard.add(deliver.boundaries);
        write_boundaries(deliver.boundaries, boundaries, metric, vo);
        outputs["boundaries"] = deliver.boundaries;
      }
      if (!deliver.tripoints.empty()) {
        guard.add(deliver.tripoints);
        write_tripoints(deliver.tripoints, boundaries, metric, vo);
        outputs["tripoints"] = deliver.tripoints;
      }
      deliver_times["boundaries"] = seconds_since(t);
    }
    progress("deliver", 0.3);
    if (!deliver.limits.empty()) {
      check_cancel();
      t = Clock::now();
      LimitOptions lo;
      lo.per_owner = deliver.limits_per_owner;
      lo.simplify_cells = deliver.simplify_cells;
      lo.threads = spec.threads;
      const LimitResult limits = extract_limits(*exact_field, index, limit_metric, lo);
      guard.add(deliver.limits);
      write_limits(deliver.limits, limits, loaded.seeds, vo);
      outputs["limits"] = deliver.limits;
      nlohmann::json ds = nlohmann::json::array();
      for (double d : limit_metric) ds.push_back(d * factor);
      deliver_report["limits"] = {{"distances", ds},
                                  {"as_given", deliver.limit_distances},
                                  {"per_owner", deliver.limits_per_owner},
                                  {"lines", limits.lines.size()},
                                  {"vertices", limits.vertices},
                                  {"max_residual", limits.max_residual * factor},
                                  {"max_residual_cells", limits.max_residual / cell_length}};
      deliver_times["limits"] = seconds_since(t);
    }
    progress("deliver", 0.5);
    std::optional<Raster<int32_t>> owner_codes;
    if (!deliver.regions.empty() || !deliver.preview.empty())
      owner_codes = owner_raster(loaded.seeds, *exact_field, spec.threads);
    if (!deliver.regions.empty()) {
      check_cancel();
      t = Clock::now();
      guard.add(deliver.regions);
      const RegionStats rs = write_regions(deliver.regions, *owner_codes, loaded.seeds, vo);
      outputs["regions"] = deliver.regions;
      deliver_report["regions"] = {{"owners", rs.owners}, {"polygons", rs.polygons}};
      deliver_times["regions"] = seconds_since(t);
    }
    progress("deliver", 0.7);
    if (!deliver.margin.empty()) {
      check_cancel();
      t = Clock::now();
      Raster<float> margin = margin_raster(*exact_field, index, spec.threads);
      if (factor != 1.0)
        for (float& v : margin.cells())
          if (v != kNoDistance) v = static_cast<float>(v * factor);
      GeoTiffOptions o = common;
      o.units = unit_name;
      o.metadata["CONTENT"] = "distance to the nearest seed of another owner minus distance to the own nearest seed";
      o.metadata["UNITS"] = unit_name;
      guard.add(deliver.margin);
      write_geotiff(deliver.margin, margin, static_cast<double>(kNoDistance), o);
      outputs["margin"] = deliver.margin;
      deliver_times["margin"] = seconds_since(t);
    }
    progress("deliver", 0.9);
    if (!deliver.preview.empty()) {
      check_cancel();
      t = Clock::now();
      guard.add(deliver.preview);
      const PreviewInfo pi = write_preview(deliver.preview, *owner_codes, &boundaries);
      outputs["preview"] = deliver.preview;
      deliver_report["preview"] = {{"width", pi.width}, {"height", pi.height}, {"cells_per_pixel", pi.step}};
      deliver_times["preview"] = seconds_since(t);
    }
    progress("deliver", 1.0);
    timings["deliverables"] = deliver_times;
    report["deliverables"] = deliver_report;
  }
  timings["write"] = write_times;
  timings["total"] = seconds_since(start);

  report["rvoronoi"] = kVersion;
  report["grid"] = grid_json(grid, loaded.crs);
  report["method"] = to_string(spec.method);
  report["metric"] = geodesic ? "geodesic" : "planar";
  // Projected geodesic grids: where the cells were located and the seeds measured.
  if (located) report["geodesic_crs"] = loaded.seed_crs.name;
  report["threads"] = threads_used;
  report["distance_units"] = unit_name;
  report["compression"] = to_string(spec.outputs.compression);
  if (spec.max_distance) report["max_distance"] = *spec.max_distance;
  report["seeds"] = seeds_json(loaded);
  report["contested_cells"] = contested_cells;
  report["streaming"] =
      plan.streamed ? nlohmann::json{{"streamed", true}, {"rows_per_strip", plan.strip_rows}, {"strips", plan.strips}}
                    : nlohmann::json{{"streamed", false}, {"why_not", plan.why_whole}};
  // The peak is the larger of reading the seeds and computing with them (the seeds included).
  report["memory_estimate_bytes"] = std::max(plan.memory_bytes, loaded.report.reading_bytes);
  report["timings_s"] = timings;
  report["compute_ns_per_cell"] = compute_seconds * 1e9 / static_cast<double>(std::max<int64_t>(cells, 1));
  // The job's own peak, not the process's (a daemon's high-water mark is its largest job ever).
  report["peak_memory_bytes"] = memory.peak_growth();
  report["peak_memory_shared"] = memory.shared();
  report["outputs"] = outputs;

  if (!spec.outputs.report.empty()) {
    guard.add(spec.outputs.report);
    write_file_atomically(spec.outputs.report, json_text(report, 2) + "\n");
  }
  progress("write", 1.0);
  JobResult result{report, guard.files()};
  guard.commit();
  return result;
}

}  // namespace rv
