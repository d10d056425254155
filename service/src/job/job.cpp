#include "rv/job.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <optional>
#include <tuple>

#include "common/atomic_file.hpp"
#include "job/edit_base.hpp"
#include "job/job_bands.hpp"
#include "job/job_edit.hpp"
#include "job/job_run.hpp"
#include "job/job_sea.hpp"
#include "job/memory_watch.hpp"
#include "rv/edit/edit.hpp"
#include "rv/engine/outputs.hpp"
#include "rv/engine/validate.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/osr_geolocator.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/vector_writer.hpp"
#include "rv/json_text.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/preview.hpp"
#include "rv/version.hpp"
#include "stream/job_stream.hpp"

namespace rv {
namespace {

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
    owners.push_back({{"code", i + 1},
                      {"label", s.owner_labels()[i]},
                      {"colour", colour_hex(owner_colour(static_cast<int32_t>(i + 1)))}});
  const SeedReadReport& r = loaded.report;
  nlohmann::json slivers = nlohmann::json::array();
  for (const BorderSliver& b : r.slivers) {
    const Feature& fa = s.features()[static_cast<size_t>(b.feature_a)];
    const Feature& fb = s.features()[static_cast<size_t>(b.feature_b)];
    slivers.push_back(
        {{"features", {s.feature_name(b.feature_a), s.feature_name(b.feature_b)}},
         {"owners",
          {s.owner_labels()[static_cast<size_t>(fa.owner - 1)], s.owner_labels()[static_cast<size_t>(fb.owner - 1)]}},
         {"at", {b.x, b.y}},
         {"area_m2", b.area},
         {"mean_width_m", b.mean_width}});
  }
  nlohmann::json transformations = nlohmann::json::array();
  for (const TransformStatement& t : r.transformations)
    transformations.push_back({{"layer", t.layer},
                               {"from", t.from},
                               {"to", t.to},
                               {"operation", t.operation},
                               {"accuracy_m", t.accuracy >= 0.0 ? nlohmann::json(t.accuracy) : nlohmann::json()},
                               {"conversion", t.conversion},
                               {"ballpark", t.ballpark},
                               {"missing_grids", t.missing_grids}});
  // The adjustments per owner that has any: the weights' range and the features with a reach (one
  // pass over the features: a set may have as many owners as features).
  struct Adjusted {
    double w_min = std::numeric_limits<double>::infinity(), w_max = 0.0;
    int64_t reaches = 0, weighted = 0;
  };
  std::vector<Adjusted> per_owner(static_cast<size_t>(s.owner_count()));
  for (const Feature& f : s.features()) {
    Adjusted& a = per_owner[static_cast<size_t>(f.owner - 1)];
    a.w_min = std::min(a.w_min, f.weight);
    a.w_max = std::max(a.w_max, f.weight);
    a.weighted += f.weight != 1.0;
    a.reaches += std::isfinite(f.reach);
  }
  nlohmann::json adjustments = nlohmann::json::array();
  for (size_t o = 0; o < per_owner.size(); ++o) {
    const Adjusted& a = per_owner[o];
    if (a.weighted > 0 || a.reaches > 0)
      adjustments.push_back({{"owner", s.owner_labels()[o]},
                             {"weight_min", a.w_min},
                             {"weight_max", a.w_max},
                             {"features_weighted", a.weighted},
                             {"features_with_reach", a.reaches}});
  }
  return {{"features", s.features().size()},
          {"adjustments", adjustments},
          {"points", points},
          {"segments", segments},
          {"polygons", s.polygons().size()},
          {"owners", owners},
          {"features_read", r.features_read},
          {"features_skipped_empty", r.features_skipped_empty},
          {"vertices_removed", r.vertices_removed},
          {"points_removed", r.points_removed},
          {"conflicts", r.conflicts},
          {"land_border_slivers", {{"count", r.sliver_count}, {"listed", slivers}}},
          {"transformations", transformations},
          {"vertices_read", r.vertices_read},
          {"polygons_repaired", r.polygons_repaired},
          {"warnings", r.warnings}};
}

// The memory a job may use: the configured limit, else 80 % of physical memory (0 = unknown).
int64_t memory_budget(const JobLimits& limits) {
  return limits.max_memory_bytes > 0 ? limits.max_memory_bytes : physical_memory_bytes() / 10 * 8;
}

}  // namespace

namespace {

// A number and the unit written after it (spaces around it dropped; "" without one). `ok`: the
// text starts with a finite number.
std::pair<double, std::string> number_and_unit(const std::string& text, bool& ok) {
  const char* begin = text.c_str();
  char* end = nullptr;
  const double value = std::strtod(begin, &end);
  std::string unit(end == begin ? text : std::string(end));
  unit.erase(0, unit.find_first_not_of(" \t"));
  unit.erase(unit.find_last_not_of(" \t") + 1);
  ok = end != begin && std::isfinite(value);
  return {value, unit};
}

}  // namespace

LimitDistance parse_limit_distance(const std::string& text) {
  LimitDistance out;
  out.text = text;
  bool ok = false;
  std::tie(out.value, out.unit) = number_and_unit(text, ok);
  if (!ok || out.value <= 0.0)
    throw Error(ErrorKind::invalid_argument, "limit distance '" + text + "' is not a positive number");
  if (!out.unit.empty()) parse_distance_unit(out.unit);  // throws for an unknown unit
  return out;
}

Length parse_length(const std::string& text) {
  Length out;
  out.text = text;
  bool ok = false;
  std::tie(out.value, out.unit) = number_and_unit(text, ok);
  if (!ok || out.value < 0.0)
    throw Error(ErrorKind::invalid_argument, "length '" + text + "' is not a non-negative number");
  static const std::pair<const char*, double> kUnits[] = {
      {"mm", 0.001}, {"cm", 0.01}, {"m", 1.0}, {"km", 1000.0}, {"nmi", 1852.0}};
  if (!out.unit.empty()) {
    const auto* u =
        std::find_if(std::begin(kUnits), std::end(kUnits), [&](const auto& k) { return out.unit == k.first; });
    if (u == std::end(kUnits))
      throw Error(ErrorKind::invalid_argument,
                  "length '" + text + "': unknown unit '" + out.unit + "' (mm, cm, m, km or nmi)");
    out.metres_per_unit = u->second;
  }
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
// flight and a raw tile per encoding thread (vector/src/writing/raster_io.cpp, kChunkTiles).
constexpr int64_t kWriterBytes = int64_t{12} << 20;

// What a streamed job's deliverables hold besides the strips: the margin of a strip (the other
// owner's field and the margin), a few rows kept per line set, the preview's sample, and the
// lines' pieces (the regions' faces are made of them), which
// grow with the lines' length, not the grid's area: taken as kLineBytes per cell of the grid's
// width and height per line set (boundaries; each limit distance -- with --limits-per-owner
// still one set a distance, an approximation: the plan does not know the owners yet).
constexpr int64_t kLineBytes = 2048;

int64_t deliverables_memory(const JobSpec& spec, const GridSpec& grid, int64_t strip_cells) {
  const OutputRequest& out = spec.outputs;
  int64_t bytes = 0;
  if (!out.margin.empty()) bytes += strip_cells * 12 + kTileRows * grid.width * 4 + kWriterBytes;
  if (!out.preview.empty()) bytes += int64_t{2000} * 2000 * 4;
  const int64_t line_sets =
      (!out.boundaries.empty() || !out.tripoints.empty() || !out.preview.empty() || out.regions_wanted() ||
       !out.turning_points.empty()) +
      (out.limits.empty() ? 0 : static_cast<int64_t>(std::max<size_t>(out.limit_distances.size(), 1))) +
      (out.regions_wanted() && spec.max_distance);  // the max-distance line bounding the regions
  bytes += line_sets * ((grid.width + grid.height) * kLineBytes + 8 * grid.width * 9);
  return bytes;
}

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

namespace {
// The cells a job computes: its window's (JobSpec::window), else the grid's.
int64_t computed_cells(const JobSpec& spec, const GridSpec& grid) {
  if (spec.band) return spec.band->rows * grid.width;
  return spec.window ? spec.window->cell_count() : grid.cell_count();
}
}  // namespace

JobPlan plan_job(const JobSpec& spec, const GridSpec& grid, int64_t sites, MetricSpec::Kind metric,
                 int64_t seed_bytes) {
  JobPlan p;
  const OutputRequest& out = spec.outputs;
  const int64_t cells = computed_cells(spec, grid);
  // A band of a split job writes its site codes and distances (job_bands.hpp).
  const int64_t int_rasters =
      !out.ownership.empty() + !out.nearest_feature.empty() + !out.via.empty() + spec.band.has_value();
  const int64_t rasters = int_rasters + !out.distance.empty() + spec.band.has_value();
  if (spec.method != Method::exact && spec.method != Method::brute_force)
    p.why_whole = "the scan methods propagate inside a window: a strip would differ from the whole grid";
  else if (spec.validate)
    p.why_whole = "validation compares whole fields";
  else if (spec.seeds.effect_field)
    p.why_whole = "partial effect compares two whole fields, without and with the partial features";
  else if (out.in_memory.any())
    p.why_whole = "rasters in memory are made whole";
  else if (rasters == 0 && !out.any_deliverable() && out.report.empty() && out.edit_base.empty())
    p.why_whole = "no raster output";
  else if (spec.strip_rows < 0)
    p.why_whole = "streaming turned off";
  p.streamed = p.why_whole.empty();
  if (p.streamed) {
    const int64_t rows = spec.strip_rows > 0
                             ? spec.strip_rows
                             : (std::max<int64_t>(1, kStripCells / std::max<int64_t>(grid.width, 1)) + kTileRows - 1) /
                                   kTileRows * kTileRows;
    // An edit's strips hold whole bands of tiles: its files copy unchanged tiles band by band; so
    // do a split job's assembly's, read from its bands (automatic strips are whole bands anyway).
    // And so are the strips by sea (a strip source's, job_sea.hpp).
    const bool whole_bands = !spec.base_report.empty() || !spec.bands.empty() || !spec.barriers.empty();
    const int64_t whole = whole_bands ? (rows + kTileRows - 1) / kTileRows * kTileRows : rows;
    p.strip_rows = std::clamp<int64_t>(whole, 1, std::max<int64_t>(grid.height, 1));
    p.strips = (grid.height + p.strip_rows - 1) / p.strip_rows;
    const int64_t strip_cells = p.strip_rows * grid.width;
    // Two strip buffers (the engine's result; the distance is scaled in place), one Int32 strip
    // of codes per integer product (made by its writer), and per file a band of tile rows and
    // the tiles in flight.
    p.memory_bytes = estimate_memory(spec.method, 2 * strip_cells, sites, metric) + strip_cells * 4 * int_rasters +
                     rasters * (kTileRows * grid.width * 4 + kWriterBytes) + seed_bytes;
    if (out.any_deliverable()) p.memory_bytes += deliverables_memory(spec, grid, strip_cells);
    // By sea: the engine's own via raster and a strip of via codes per buffer.
    if (!spec.barriers.empty()) p.memory_bytes += strip_cells * 4 * 3;
    // An edit: the plan's per-cell flags and costs of the tiles it reads (at most a strip's); the
    // base's strip is read into the strip buffers and edited in place.
    // Each file copying from its base's completes a band of tile rows from it where it needs the
    // copied tiles' cells (codes coded again, a COG's overviews).
    if (!spec.base_report.empty()) p.memory_bytes += strip_cells * 9 + (rasters + 1) * kTileRows * grid.width * 4;
    // A COG's writer makes the overviews from the rows as they pass: its levels' rows in the
    // making take under one more band of tile rows.
    if (out.cloud_optimized) p.memory_bytes += (rasters + !out.margin.empty()) * kTileRows * grid.width * 4;
    return p;
  }
  p.strip_rows = grid.height;
  p.strips = 1;
  int64_t need = estimate_memory(spec.method, cells, sites, metric) + cells * 4;  // + one output raster
  const OutputRequest::InMemory& mem = out.in_memory;
  need += cells * 4 * (int64_t{mem.ownership} + mem.distance + mem.nearest_feature);
  if (spec.validate) need += estimate_memory(Method::brute_force, cells, sites, metric);
  if (spec.seeds.effect_field) need += 2 * cells * 8;  // the nil-effect field and the partial one
  if (out.any_deliverable()) {
    need += cells * 4;                                                                          // owner codes
    if (spec.method != Method::exact && spec.method != Method::brute_force) need += cells * 8;  // exact field
    if (!out.margin.empty()) need += cells * 12;  // other-owner field + margin
    if (!out.limits.empty()) need += cells;       // inside flags
  }
  p.memory_bytes = need + seed_bytes;
  return p;
}

namespace {
// The stricter of two limits, where 0 means none.
int64_t stricter(int64_t a, int64_t b) { return a <= 0 ? b : b <= 0 ? a : std::min(a, b); }
}  // namespace

SeedReadOptions detail::with_limits(SeedReadOptions read, const JobLimits& limits) {
  read.max_features = stricter(read.max_features, limits.max_features);
  read.max_vertices = stricter(read.max_vertices, limits.max_vertices);
  read.max_input_bytes = stricter(read.max_input_bytes, limits.max_input_bytes);
  read.max_memory_bytes = stricter(read.max_memory_bytes, memory_budget(limits));
  return read;
}

namespace {

// Stage "read": the seeds with the job's limits and the memory limit for reading.
LoadedSeeds read_seeds(const JobSpec& spec, const JobLimits& limits, const JobHooks& hooks) {
  SeedReadOptions read = detail::with_limits(seed_options_for_metric(spec.seeds, spec.metric), limits);
  read.on_reading_bytes = hooks.reserve_memory;
  if (read.target_crs.empty() && !spec.grid.like.empty()) {
    // Outputs must line up with the template raster, so the seeds go into its CRS.
    read.target_crs = read_grid(spec.grid.like).crs;
  }
  return load_seeds(read);
}

// What weights and reaches cannot be combined with (yet), refused before anything is computed.
void check_adjustments(const JobSpec& spec, const PreparedJob& job) {
  const SeedSet& seeds = job.loaded.seeds;
  const OutputRequest& out = spec.outputs;
  if (job.partial.any()) {
    auto refuse = [](ErrorKind kind, const std::string& what) { throw Error(kind, "partial effect " + what); };
    if (spec.method != Method::exact && spec.method != Method::brute_force)
      refuse(ErrorKind::invalid_argument, "needs the exact or brute-force method: its lines and band are exact");
    if (job.located())
      refuse(ErrorKind::unsupported,
             "is not available for the geodesic metric on a projected grid; use a longitude/latitude grid, or "
             "metric planar");
    for (const Feature& f : seeds.features())
      if (std::isfinite(f.reach)) refuse(ErrorKind::unsupported, "is not available with reaches");
    if (!out.margin.empty()) refuse(ErrorKind::unsupported, "is not available with the margin raster");
    if (seeds.adjusted() && std::isfinite(job.compute.max_distance) && out.regions_wanted())
      refuse(ErrorKind::unsupported,
             "is not available with weights and a max distance together with regions or areas: the rule's band "
             "does not follow where the weighted zones end");
    if (!out.turning_points.empty())
      refuse(ErrorKind::unsupported,
             "is not available with the turning-point report yet: the partial line has no controlling basepoints");
  }
  if (!seeds.adjusted()) return;
  check_method_for(seeds, spec.method);
  if (!out.margin.empty())
    throw Error(ErrorKind::unsupported,
                "the margin raster is not available with weights or reaches: it measures unweighted distances");
}

// Requests refused before anything is computed, and the limits of the planned job.
void check_plan(const JobSpec& spec, const JobLimits& limits, const PreparedJob& job, const JobPlan& plan) {
  const OutputRequest& out = spec.outputs;
  // The margin raster is not available on a projected geodesic grid yet (rv/lines/margin.hpp).
  if (job.located() && !out.margin.empty())
    throw Error(ErrorKind::unsupported,
                "the margin raster is not available for the geodesic metric on a projected grid yet; use a "
                "geographic (longitude/latitude) grid (--crs EPSG:4326), or metric planar");
  check_adjustments(spec, job);
  detail::check_sea_plan(spec, job);
  if (!out.turning_points.empty()) {
    const std::string& tp = out.turning_points;
    auto ends = [&](const char* ext) {
      const size_t n = std::char_traits<char>::length(ext);
      return tp.size() >= n && tp.compare(tp.size() - n, n, ext) == 0;
    };
    if (!ends(".json") && !ends(".csv"))
      throw Error(ErrorKind::invalid_argument,
                  "--turning-points: the file must end in .json or .csv, got '" + tp + "'");
  }
  if (!(out.simplify_cells >= 0.0) || !std::isfinite(out.simplify_cells))
    throw Error(ErrorKind::invalid_argument, "the simplification tolerance must be a non-negative number of cells");
  detail::check_pieces(spec, job.grid, plan);
  if (!out.describe && !out.report.empty())
    throw Error(ErrorKind::invalid_argument, "a report file needs the report (OutputRequest::describe)");
  const int64_t cells = computed_cells(spec, job.grid);
  if (cells > limits.max_cells)
    throw Error(ErrorKind::too_large, "the grid has " + std::to_string(cells) + " cells, over the limit of " +
                                          std::to_string(limits.max_cells));
  const int64_t budget = memory_budget(limits);
  if (budget > 0 && plan.memory_bytes > budget)
    throw Error(ErrorKind::too_large, "the job needs about " + std::to_string(plan.memory_bytes >> 20) + " MiB for " +
                                          std::to_string(cells) + " cells, over the memory limit of " +
                                          std::to_string(budget >> 20) + " MiB");
  if (spec.validate && cells > limits.validate_max_cells)
    throw Error(ErrorKind::too_large, "validate runs brute force, allowed up to " +
                                          std::to_string(limits.validate_max_cells) + " cells; this grid has " +
                                          std::to_string(cells));
}

}  // namespace

PreparedJob prepare_job(const JobSpec& spec, const JobLimits& limits, const JobHooks& hooks) {
  gdal_init();
  PreparedJob job;
  if (hooks.progress) hooks.progress("read", 0.0);
  const auto t = detail::Clock::now();
  job.loaded = read_seeds(spec, limits, hooks);
  job.read_seconds = detail::seconds_since(t);
  if (hooks.progress) hooks.progress("read", 1.0);
  if (hooks.cancel && hooks.cancel->load()) throw Error(ErrorKind::cancelled, "job dismissed");

  // Metric, barriers, grid, units, limits: everything is decided before the big allocations.
  const MetricPlan mp = plan_metric(spec.metric, spec.distance_units, job.loaded.crs);
  job.metric = mp.metric;
  // The distance by sea: the barriers read, and the seeds moved onto the coast before the grid
  // is drawn round them.
  detail::read_barriers(spec, detail::with_limits(seed_options_for_metric(spec.seeds, spec.metric), limits), job);
  job.grid = plan_grid(spec.grid, job.loaded);
  job.to_output = mp.to_output;
  job.unit = mp.unit;
  job.compute.metric = mp.metric;
  job.compute.method = spec.method;
  job.compute.threads = spec.threads;
  job.compute.cancel = hooks.cancel;
  geolocate_grid(job.compute, job.loaded);
  if (spec.max_distance) {
    if (!std::isfinite(*spec.max_distance) || *spec.max_distance < 0.0)
      throw Error(ErrorKind::invalid_argument, "max distance must be a non-negative number");
    job.compute.max_distance = *spec.max_distance / job.to_output;
  }
  // Reaches are given in the job's distance units, like the max distance.
  job.loaded.seeds.scale_reaches(1.0 / job.to_output);
  job.limit_distances = detail::limit_distances_in_metric_units(spec, job);
  job.line_tolerance = detail::line_tolerance_in_metric_units(spec, job);
  detail::nil_effect_by_sea(job);
  job.partial = partial_effect_of(job.loaded.seeds);
  detail::read_relevant(spec, limits, job);
  job.plan = plan_job(spec, job.grid, static_cast<int64_t>(job.loaded.seeds.sites().size()), mp.metric.kind,
                      seed_memory_bytes(job.loaded));
  check_plan(spec, limits, job, job.plan);
  if (hooks.planned) hooks.planned(job.grid.cell_count());
  if (hooks.reserve_memory) hooks.reserve_memory(job.plan.memory_bytes);
  detail::settle_sea(job, hooks);
  return job;
}

namespace {

// How each raster GeoTIFF is described; the same on both paths. The code rasters state their
// largest code, so that they are written in the narrowest type that holds it (owner codes are
// 1..K; feature numbers at most the largest input position).
struct RasterTargets {
  GeoTiffOptions ownership, distance, feature;
};

RasterTargets raster_targets(const JobSpec& spec, const PreparedJob& job) {
  const LoadedSeeds& loaded = job.loaded;
  RasterTargets t{detail::raster_options(spec), detail::raster_options(spec), detail::raster_options(spec)};
  t.ownership.categorical = true;
  t.ownership.category_labels = loaded.seeds.owner_labels();
  t.ownership.max_code = loaded.seeds.owner_count();
  t.ownership.metadata["CONTENT"] = "owner code of the nearest seed (0 = none)";
  t.distance.units = job.unit;
  t.distance.metadata["CONTENT"] = "distance to the nearest seed";
  t.distance.metadata["UNITS"] = job.unit;
  t.distance.metadata["METRIC"] = job.metric.kind == MetricSpec::geodesic ? "geodesic" : "planar";
  t.feature.categorical = true;
  t.feature.max_code = loaded.input_position.empty()
                           ? static_cast<int64_t>(loaded.seeds.features().size())
                           : *std::max_element(loaded.input_position.begin(), loaded.input_position.end());
  t.feature.metadata["CONTENT"] = "1-based position of the nearest seed feature in the input (0 = none)";
  return t;
}

// Stages "compute" and "write" together: strip by strip, each strip encoded while the next is
// computed (JobPlan::streamed).
void compute_streamed(detail::JobRun& run, const PreparedJob& job, const RasterTargets& targets,
                      detail::EditBaseWriter* keep, detail::EditBase* base,
                      std::shared_ptr<const PreparedSeeds> prepared = nullptr) {
  const JobSpec& spec = run.spec;
  // The deliverables take each strip in as it is computed.
  std::optional<detail::StripDeliverables> deliverables;
  if (spec.outputs.any_deliverable()) deliverables.emplace(run, job, true);
  detail::StreamJob stream;
  stream.seeds = &job.loaded.seeds;
  stream.grid = job.grid;
  stream.compute = job.compute;
  stream.compute.cancel = run.hooks.cancel;
  stream.strip_rows = run.plan.strip_rows;
  stream.distance_factor = job.to_output;
  stream.feature_numbering = job.loaded.input_position;
  stream.progress = [&](const char* stage, double f) { run.progress(stage, f); };
  stream.will_write = [&](const std::string& path) { run.will_write(path); };
  if (deliverables) stream.on_strip = [&](const NearestField& strip) { deliverables->add(strip); };
  // A COG is written strip by strip like a plain GeoTIFF (GeoTiffStripWriter assembles it).
  using Product = detail::StreamTarget::Product;
  auto target = [&](Product product, const std::string& path, GeoTiffOptions options, const char* name) {
    detail::StreamTarget& t = stream.targets.emplace_back();
    t.product = product;
    t.path = path;
    t.options = std::move(options);
    t.name = name;
  };
  if (!spec.outputs.ownership.empty())
    target(Product::ownership, spec.outputs.ownership, targets.ownership, "ownership");
  if (!spec.outputs.distance.empty()) target(Product::distance, spec.outputs.distance, targets.distance, "distance");
  if (!spec.outputs.nearest_feature.empty())
    target(Product::nearest_feature, spec.outputs.nearest_feature, targets.feature, "nearest_feature");
  // By sea: the strips are compute_sea's, with their vias (job_sea.hpp).
  std::optional<detail::SeaRun> sea;
  if (job.sea) {
    sea.emplace(job);
    const bool via = !spec.outputs.via.empty();
    if (via) target(Product::codes, spec.outputs.via, detail::via_options(spec, job), "via");
    stream.source = [&sea, via, compute = stream.compute](const Window& w, NearestField& field,
                                                          std::vector<int32_t>& codes, std::vector<uint8_t>&, bool) {
      sea->compute(w, field, via ? &codes : nullptr, compute);
    };
  }
  // The edit of a finished run, and what this run keeps for edits of it (job_edit.hpp).
  detail::StreamEdit edit;
  if (base) {
    const auto t = detail::Clock::now();
    detail::attach_edit(stream, edit, spec, job, *base, std::move(prepared));
    run.timings["attach_edit"] = detail::seconds_since(t);
  }
  nlohmann::json edit_lines;
  if (base && deliverables) edit_lines = detail::attach_edit_lines(stream, edit, *deliverables, *base, spec, job);
  if (keep) detail::attach_keep(stream, *keep, base, base ? &edit : nullptr, job);
  // A split job's assembly: the field read from its bands (job_bands.hpp).
  std::optional<detail::BandFields> bands;
  if (!spec.bands.empty()) {
    bands.emplace(spec.bands, job);
    detail::attach_bands(stream, *bands);
    run.timings["bands"] = bands->count();
  }
  run.progress("compute", 0.0);
  const detail::StreamStats st = detail::run_streamed(stream);
  if (base) {
    std::tie(edit.tally.tiles_copied, edit.tally.tiles_recoded, edit.tally.not_copied) =
        std::tie(st.tiles_copied, st.tiles_recoded, st.not_copied);
    run.report["edit"] = detail::edit_report(*base, *edit.edit, job.loaded.seeds, edit.tally, job.grid,
                                             job.metric.kind == MetricSpec::geodesic);
  }
  if (base && !spec.base_name.empty()) run.report["edit"]["base"] = spec.base_name;
  if (!edit_lines.is_null()) run.report["edit"]["lines"] = edit_lines;
  if (keep) keep->set_costs(detail::run_costs(stream, st, base, base ? &edit : nullptr));
  if (sea) run.report["sea"] = sea->report();
  run.compute_seconds = st.compute;
  run.contested_cells = st.contested_cells;
  run.threads_used = st.threads;
  for (const auto& [name, seconds] : st.write) run.write_times[name] = seconds;
  run.timings["compute"] = st.compute;
  // What the run keeps of its lines for edits of it (before finish() takes the lines).
  if (deliverables && keep) keep->set_line_pieces(deliverables->line_pieces());
  if (deliverables) deliverables->finish();
  for (const detail::StreamTarget& t : stream.targets)
    if (t.product != Product::site && t.product != Product::metric_distance) run.wrote(t.name, t.path);
  // compute and write overlap: their sum exceeds the wall time they took together.
  run.timings["streamed"] = {{"strips", st.strips},
                             {"rows_per_strip", run.plan.strip_rows},
                             {"wall", st.wall},
                             {"convert", st.convert},
                             {"deliverables_in_strips", st.deliverables},
                             {"compute_waited_for_writer", st.compute_waited},
                             {"writer_waited_for_compute", st.write_waited}};
}

// Stage "compute": the whole field.
// By sea (job_sea.hpp), the vias too when asked for: into `via`, and the report's "sea".
NearestField compute_whole(detail::JobRun& run, const PreparedJob& job, std::vector<int32_t>& via) {
  ComputeOptions options = job.compute;
  options.window = run.spec.window;
  options.cancel = run.hooks.cancel;
  options.progress = [&](double f) { run.progress("compute", f); };
  NearestField field;
  if (job.sea) {
    detail::SeaRun sea(job);
    const auto t = detail::Clock::now();
    const bool vias = !run.spec.outputs.via.empty() || run.spec.outputs.in_memory.via;
    sea.compute(run.spec.window.value_or(job.grid.full_window()), field, vias ? &via : nullptr, options);
    field.seconds = detail::seconds_since(t);
    run.report["sea"] = sea.report();
  } else {
    field = compute(job.loaded.seeds, job.grid, options);
  }
  run.compute_seconds = field.seconds;
  run.contested_cells = field.contested_cells;
  run.threads_used = field.threads;
  run.timings["compute"] = field.seconds;
  return field;
}

// Stage "compute" with partial effect: the full- and nil-effect fields, their lines, the rule's
// field and lines (rv/lines/partial_effect.hpp), and the report's entry for it. By sea, the vias
// of the rule's field into `via` when the outputs ask for them, made by `sea`, which must outlive
// the result (its measures report their settling into it).
PartialEffectResult compute_partial(detail::JobRun& run, const PreparedJob& job, std::vector<int32_t>& via,
                                    std::optional<detail::SeaPartial>& sea) {
  const JobSpec& spec = run.spec;
  run.progress("compute", 0.0);
  BoundaryOptions lines;
  lines.simplify_cells = spec.outputs.simplify_cells;
  lines.line_tolerance = job.line_tolerance;
  lines.threads = spec.threads;
  const OutputRequest& out = spec.outputs;
  const bool draw = !out.boundaries.empty() || !out.tripoints.empty() || out.regions_wanted() || !out.preview.empty();
  // By sea: both fields and their lines by sea (job_sea.hpp), the vias of the rule's field.
  ComputeOptions compute = job.compute;
  if (job.sea) {
    compute.progress = [&](double f) { run.progress("compute", f); };
    sea.emplace(job, compute, !out.via.empty() || out.in_memory.via);
  }
  PartialEffectResult r =
      compute_partial_effect(job.loaded.seeds, job.grid, compute, lines, draw, sea ? sea->engines() : PartialEngines{});
  if (sea) {
    via = sea->vias(r);
    run.report["sea"] = sea->report();
    const SeaMetricStats st = sea->metric_stats();
    run.report["partial_effect_by_sea"] = {
        {"owners_settled", st.owners}, {"bend_tests", st.bend_tests}, {"seconds", st.seconds}};
  }
  run.compute_seconds = r.seconds;
  run.contested_cells = r.full.contested_cells;
  run.threads_used = r.full.threads;
  run.timings["compute"] = r.seconds;
  const SeedSet& seeds = job.loaded.seeds;
  const int32_t B = job.partial.owner;
  int64_t features = 0, returned = 0;
  for (bool p : job.partial.partial) features += p;
  const auto& full = r.full.site.cells();
  const auto& now = r.field.site.cells();
  for (size_t i = 0; i < full.size(); ++i) returned += now[i] != full[i];
  run.report["partial_effect"] = {{"owner", seeds.owner_labels()[static_cast<size_t>(B - 1)]},
                                  {"effect", job.partial.effect},
                                  {"features", features},
                                  {"cells_to_neighbours", returned}};
  run.progress("compute", 1.0);
  return r;
}

// Stage "validate": the field against brute force.
void validate_stage(detail::JobRun& run, const PreparedJob& job, const NearestField& field) {
  if (!run.spec.validate) return;
  detail::timed(run.timings, "validate", [&] {
    ComputeOptions brute = job.compute;
    brute.method = Method::brute_force;
    brute.progress = [&](double f) { run.progress("validate", f); };
    NearestField reference;
    if (job.sea)
      detail::SeaRun(job).compute(job.grid.full_window(), reference, nullptr, brute);
    else
      reference = compute(job.loaded.seeds, job.grid, brute);
    const ValidationStats v = compare_fields(job.loaded.seeds, field, reference);
    run.report["validation"] = {{"reference", "brute-force"},
                                {"cells", v.cells},
                                {"wrong_cells", v.wrong_cells},
                                {"wrong_owner_cells", v.wrong_owner_cells},
                                {"tie_cells", v.tie_cells},
                                {"nodata_mismatch", v.nodata_mismatch},
                                {"max_error", v.max_error * job.to_output},
                                {"max_error_cells", v.max_error_cells},
                                {"reference_seconds", reference.seconds}};
  });
  run.check_cancel();
}

// Stage "write": the rasters of the whole field.
void write_rasters(detail::JobRun& run, const PreparedJob& job, const NearestField& field,
                   const RasterTargets& targets) {
  const JobSpec& spec = run.spec;
  const SeedSet& seeds = job.loaded.seeds;
  run.progress("write", 0.0);
  if (!spec.outputs.ownership.empty()) {
    detail::timed(run.write_times, "ownership", [&] {
      Raster<int32_t> owners = owner_raster(seeds, field, spec.threads);
      run.will_write(spec.outputs.ownership);
      write_geotiff(spec.outputs.ownership, owners, 0.0, targets.ownership);
    });
    run.wrote("ownership", spec.outputs.ownership);
  }
  run.progress("write", 0.4);
  if (!spec.outputs.distance.empty()) {
    detail::timed(run.write_times, "distance", [&] {
      const double f = job.to_output;
      const Raster<float> dist = f == 1.0 ? field.distance : scaled_distance(field, f, spec.threads);
      run.will_write(spec.outputs.distance);
      write_geotiff(spec.outputs.distance, dist, static_cast<double>(kNoDistance), targets.distance);
    });
    run.wrote("distance", spec.outputs.distance);
  }
  run.progress("write", 0.8);
  if (!spec.outputs.nearest_feature.empty()) {
    detail::timed(run.write_times, "nearest_feature", [&] {
      run.will_write(spec.outputs.nearest_feature);
      write_geotiff(spec.outputs.nearest_feature, feature_raster(seeds, field, spec.threads, job.loaded.input_position),
                    0.0, targets.feature);
    });
    run.wrote("nearest_feature", spec.outputs.nearest_feature);
  }
}

// The rasters the caller takes in memory (OutputRequest::in_memory), made like the files'.
// `spent`: the same field when nothing reads it after this call: its buffers then become the
// results (the owner codes written over the site indices, the distances moved), so that a chunk
// of a grid allocates no more than the engine did.
// `via`: the vias by sea over the same cells (compute_whole), moved into the results when asked for.
MemoryRasters keep_in_memory(detail::JobRun& run, const PreparedJob& job, const NearestField& field,
                             NearestField* spent = nullptr, std::vector<int32_t>* via = nullptr) {
  const JobSpec& spec = run.spec;
  const OutputRequest::InMemory& want = spec.outputs.in_memory;
  const SeedSet& seeds = job.loaded.seeds;
  MemoryRasters r;
  if (!want.any()) return r;
  detail::timed(run.write_times, "in_memory", [&] {
    if (want.distance && job.to_output != 1.0)
      r.distance = scaled_distance(field, job.to_output, spec.threads);
    else if (want.distance && spent)
      r.distance = std::move(spent->distance);
    else if (want.distance)
      r.distance = field.distance;
    if (want.nearest_feature) r.nearest_feature = feature_raster(seeds, field, spec.threads, job.loaded.input_position);
    if (want.ownership && spent)
      r.ownership = owner_raster(seeds, std::move(spent->site), spec.threads);
    else if (want.ownership)
      r.ownership = owner_raster(seeds, field, spec.threads);
    if (want.via && via) {
      r.via = Raster<int32_t>(field.site.grid(), field.site.window(), Uninitialized{});
      if (via->size() != r.via.cells().size()) throw Error(ErrorKind::internal, "the vias do not cover the field");
      std::copy(via->begin(), via->end(), r.via.cells().begin());
    }
  });
  return r;
}

// Stage "report": what was computed, how, from what, and what it cost.
void assemble_report(detail::JobRun& run, const PreparedJob& job, const detail::MemoryWatch* memory,
                     detail::Clock::time_point start) {
  const JobSpec& spec = run.spec;
  const LoadedSeeds& loaded = job.loaded;
  const JobPlan& plan = run.plan;
  nlohmann::json& report = run.report;
  run.timings["write"] = run.write_times;
  run.timings["total"] = detail::seconds_since(start);
  report["rvoronoi"] = kVersion;
  report["grid"] = grid_json(job.grid, loaded.crs);
  report["method"] = to_string(spec.method);
  report["metric"] = job.metric.kind == MetricSpec::geodesic ? "geodesic" : "planar";
  // Projected geodesic grids: where the cells were located and the seeds measured.
  if (job.located()) report["geodesic_crs"] = loaded.seed_crs.name;
  report["threads"] = run.threads_used;
  report["distance_units"] = job.unit;
  report["compression"] = to_string(spec.outputs.compression);
  if (spec.max_distance) report["max_distance"] = *spec.max_distance;
  report["seeds"] = seeds_json(loaded);
  if (spec.window)
    report["window"] = {{"row0", spec.window->row0},
                        {"col0", spec.window->col0},
                        {"rows", spec.window->height},
                        {"cols", spec.window->width}};
  report["contested_cells"] = run.contested_cells;
  report["streaming"] =
      plan.streamed ? nlohmann::json{{"streamed", true}, {"rows_per_strip", plan.strip_rows}, {"strips", plan.strips}}
                    : nlohmann::json{{"streamed", false}, {"why_not", plan.why_whole}};
  // The peak is the larger of reading the seeds and computing with them (the seeds included).
  report["memory_estimate_bytes"] = std::max(plan.memory_bytes, loaded.report.reading_bytes);
  report["timings_s"] = run.timings;
  const auto cells = static_cast<double>(std::max<int64_t>(computed_cells(spec, job.grid), 1));
  report["compute_ns_per_cell"] = run.compute_seconds * 1e9 / cells;
  // The job's own peak, not the process's (a daemon's high-water mark is its largest job ever).
  report["peak_memory_bytes"] = memory ? memory->peak_growth() : 0;
  report["peak_memory_shared"] = memory ? memory->shared() : false;
  report["outputs"] = run.outputs;
}

// The stages after prepare_job, with run.plan (`base_files`: an edit's base read ahead, or null).
JobResult run_stages(detail::JobRun& run, const PreparedJob& job, const detail::MemoryWatch* memory,
                     detail::Clock::time_point start, std::shared_ptr<detail::EditBaseFiles> base_files = nullptr) {
  const JobSpec& spec = run.spec;
  run.timings["read"] = job.read_seconds;
  if (spec.band) return detail::run_band(run, job);  // one band of a split job: its field alone
  const RasterTargets targets = raster_targets(spec, job);
  NearestField field;  // the whole field (whole path only)
  MemoryRasters in_memory;
  // An edit's base, opened (and checked against this job) before anything is written.
  std::unique_ptr<detail::EditBase> base;
  if (spec.base_report.empty() && !spec.base_name.empty())
    throw Error(ErrorKind::internal, "a base job named but not resolved to its report");
  std::shared_ptr<const PreparedSeeds> prepared;
  if (!spec.base_report.empty()) {
    const auto t = detail::Clock::now();
    // The edited seeds are prepared for the engine on another core while the base is opened.
    std::future<std::shared_ptr<const PreparedSeeds>> preparing;
    if (!job.compute.prepared)
      preparing = std::async(std::launch::async, [&job] { return prepare(job.loaded.seeds, job.grid, job.compute); });
    try {
      if (!base_files) base_files = detail::EditBase::read_files(spec.base_report);
      base = std::make_unique<detail::EditBase>(std::move(base_files), spec, job);
    } catch (...) {
      if (preparing.valid()) preparing.wait();
      throw;
    }
    prepared = preparing.valid() ? preparing.get() : job.compute.prepared;
    run.timings["open_base"] = detail::seconds_since(t);
    run.timings["read_base_ahead"] = base->files_seconds();
    if (!run.plan.streamed)
      throw Error(ErrorKind::invalid_argument, "base: an edit is streamed (" + run.plan.why_whole + ")");
  } else if (!spec.outputs.changes.empty()) {
    throw Error(ErrorKind::invalid_argument, "the changes raster is an edit's: it needs a base");
  }
  // A streamed run with a report keeps its field for edits of it.
  std::unique_ptr<detail::EditBaseWriter> keep;
  if (run.plan.streamed && spec.outputs.keep_for_edits && !job.sea &&
      !(spec.outputs.report.empty() && spec.outputs.edit_base.empty()))
    keep = std::make_unique<detail::EditBaseWriter>(spec, job);
  if (run.plan.streamed) {
    compute_streamed(run, job, targets, keep.get(), base.get(), std::move(prepared));
  } else if (job.partial.any()) {
    std::vector<int32_t> via;
    std::optional<detail::SeaPartial> sea;  // (declared first: it outlives the result)
    const PartialEffectResult partial = compute_partial(run, job, via, sea);
    validate_stage(run, job, partial.full);
    write_rasters(run, job, partial.field, targets);
    if (!spec.outputs.via.empty()) detail::write_via(run, job, via);
    in_memory = keep_in_memory(run, job, partial.field, nullptr, &via);
    detail::deliver(run, job, partial.field, &partial);
  } else {
    std::vector<int32_t> via;
    field = compute_whole(run, job, via);
    validate_stage(run, job, field);
    write_rasters(run, job, field, targets);
    if (!spec.outputs.via.empty()) detail::write_via(run, job, via);
    detail::deliver(run, job, field);
    in_memory = keep_in_memory(run, job, field, &field, &via);
  }
  std::string edit_base_dir;
  if (keep) {
    const auto t = detail::Clock::now();
    edit_base_dir = keep->commit();
    run.timings["keep"] = detail::seconds_since(t);
    run.guard.add_directory(edit_base_dir);
    run.report["edit_base"] = std::filesystem::path(edit_base_dir).filename().string();
  }
  if (spec.outputs.describe) assemble_report(run, job, memory, start);
  if (!spec.outputs.report.empty()) {
    run.will_write(spec.outputs.report);
    write_file_atomically(spec.outputs.report, json_text(run.report, 2) + "\n");
  }
  run.progress("write", 1.0);
  // The files written, the kept field as its directory (not the temporary names it was built under).
  JobResult result{run.report, {}, std::move(in_memory), job.grid};
  for (const std::string& f : run.guard.files())
    if (!keep || f.rfind(keep->temp_dir(), 0) != 0) result.files.push_back(f);
  if (keep) result.files.push_back(edit_base_dir);
  run.guard.commit();
  return result;
}

}  // namespace

JobResult run_job(const JobSpec& spec, const JobLimits& limits, const JobHooks& hooks) {
  const auto start = detail::Clock::now();
  std::optional<detail::MemoryWatch> memory;
  if (spec.outputs.describe) memory.emplace();
  detail::JobRun run(spec, limits, hooks);
  // An edit's base is read on another core while the seeds are read (its errors come after theirs).
  std::future<std::shared_ptr<detail::EditBaseFiles>> base_files;
  if (!spec.base_report.empty())
    base_files = std::async(std::launch::async, [&spec] { return detail::EditBase::read_files(spec.base_report); });
  const PreparedJob job = prepare_job(spec, limits, hooks);
  run.plan = job.plan;
  return run_stages(run, job, memory ? &*memory : nullptr, start, base_files.valid() ? base_files.get() : nullptr);
}

JobResult run_prepared(const JobSpec& spec, const PreparedJob& job, const JobLimits& limits, const JobHooks& hooks) {
  const auto start = detail::Clock::now();
  std::optional<detail::MemoryWatch> memory;
  if (spec.outputs.describe) memory.emplace();
  detail::JobRun run(spec, limits, hooks);
  run.plan = plan_job(spec, job.grid, static_cast<int64_t>(job.loaded.seeds.sites().size()), job.metric.kind,
                      seed_memory_bytes(job.loaded));
  check_plan(spec, limits, job, run.plan);
  return run_stages(run, job, memory ? &*memory : nullptr, start);
}

SeedInventory describe_seeds(const SeedReadOptions& seeds, const JobLimits& limits, bool with_features) {
  return describe_seed_files(detail::with_limits(seeds, limits), with_features);
}

}  // namespace rv
