// The deliverables stage of a job (job_run.hpp): the lines taken in strip by strip as the exact
// field goes by (a streamed job never holds it whole; the whole path feeds it as one strip), each
// deliverable then written to its file, its counts into the report and its time into
// timings["deliverables"].
#include <algorithm>
#include <cmath>
#include <exception>
#include <future>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include <GeographicLib/Geodesic.hpp>

#include "job/job_run.hpp"
#include "job/job_sea.hpp"
#include "job/turning_report.hpp"
#include "rv/engine/outputs.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/geolocate.hpp"
#include "rv/field/parallel.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/vector_writer.hpp"
#include "rv/geodesic/geodesic.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/margin.hpp"
#include "rv/lines/region_check.hpp"
#include "rv/lines/regions.hpp"
#include "rv/lines/relevant_coasts.hpp"
#include "rv/lines/strip_lines.hpp"
#include "rv/preview.hpp"
#include "rv/sea/sea_metric.hpp"

namespace rv::detail {
namespace {

// The deliverables measure with the field's own metric (projected geodesic grids: located on
// the ellipsoid, positions and outputs in the grid's CRS; by sea, the distance by sea, each
// owner's bend nodes settled on the job's threads when a deliverable first asks, up to
// `settle_within` (sea_settle_within), what that took into `stats`).
std::unique_ptr<SiteMetric> site_metric(const PreparedJob& job, const JobRun& run, SeaMetricStats& stats,
                                        double settle_within) {
  if (!job.sea) return make_site_metric(job.loaded.seeds, job.grid, job.compute);
  return sea_site_metric(job, job.loaded.seeds, job.sea->prepared, run.spec.threads, run.hooks.cancel, stats,
                         settle_within);
}

// By sea: the barriers' rings (closed) and lines in the grid's CRS, for the regions' faces. On the
// ellipsoid an edge is a geodesic: followed by chords (straight in the grid's CRS) within the line
// tolerance of it, as every region edge is, and within a ten-thousandth of a cell whatever the
// tolerance (a line ending on a barrier is carried a thousandth of a cell across it to close the
// faces: it must cross the chord too); located back into a projected grid's CRS.
// `cell_length`: one cell in metric units near the grid's centre.
std::vector<std::vector<Vec2>> barrier_linework(const PreparedJob& job, double cell_length) {
  const Barriers& barriers = job.sea->loaded.barriers;
  std::vector<std::vector<Vec2>> out;
  std::optional<GeodesicMeasure> measure;
  if (job.metric.kind == MetricSpec::geodesic) measure.emplace(job.metric);
  const double fine = 1e-4 * cell_length;
  const double tolerance = job.line_tolerance > 0.0 ? std::min(job.line_tolerance, fine) : fine;
  const Geolocator* grid = job.compute.geolocator.get();
  auto add = [&](const std::vector<Vec2>& pts) {
    std::vector<Vec2> line;
    for (size_t i = 0; i + 1 < pts.size(); ++i) {
      const std::vector<Vec2> piece =
          measure ? measure->chords(pts[i], pts[i + 1], tolerance, grid) : std::vector<Vec2>{pts[i], pts[i + 1]};
      line.insert(line.end(), piece.begin() + (line.empty() ? 0 : 1), piece.end());
    }
    if (job.compute.geolocator)
      for (Vec2& p : line) {
        const Vec2 ll = p;
        job.compute.geolocator->to_grid(&ll.x, &ll.y, &p.x, &p.y, 1);
      }
    out.push_back(std::move(line));
  };
  for (const Barriers::Polygon& poly : barriers.polygons())
    for (const Ring& r : poly.rings) {
      std::vector<Vec2> closed(r.begin(), r.end());
      if (!closed.empty()) closed.push_back(closed.front());
      add(closed);
    }
  for (const Barriers::Line& l : barriers.lines()) add(l.vertices);
  return out;
}

}  // namespace

struct StripDeliverables::State {
  JobRun& run;
  const PreparedJob& job;
  bool streamed;
  std::unique_ptr<SiteMetric> metric;
  std::unique_ptr<OwnerIndex> index;
  double cell_length = 0.0;  // one cell in metric units near the grid's centre (degrees are not metres)
  SiteCodes owner_codes;     // site -> owner code (the preview, the regions' check)
  // The regions' check against the cells (rv/lines/region_check.hpp): every cell's owner, by rows.
  std::optional<CellOwners> cell_owners;
  nlohmann::json region_check;  // its report entry
  std::optional<StripLines> boundaries, limits;
  // Regions where the owned area ends: the line at the max distance, or, with adjusted seeds
  // (reaches, or weights with the max distance as a cap), the edge of what the reaches cover.
  std::optional<StripLines> reach;
  // The relevant area (its cells) and the coasts nearest to them (without --relevant-coasts).
  std::optional<InteriorSpans> relevant_cells;
  std::optional<RelevantCoasts> relevant_coasts;
  std::optional<PreviewSample> preview;
  std::optional<GeoTiffStripWriter<float>> margin_writer;  // streamed
  OtherOwnersField sea_margin;                             // by sea: the margin's per-owner engine
  SeaMetricStats sea_stats;                                // by sea: the metric's owners' settling
  double sea_farthest = -1.0;  // by sea: the largest distance of the strips added (metric units)
  double boundary_seconds = 0.0, limit_seconds = 0.0, margin_seconds = 0.0, region_seconds = 0.0;
  double wall_seconds = 0.0;  // in add() and finish(): the deliverables' own wall time, writes included
  VectorOutputOptions vector;
  nlohmann::json times = nlohmann::json::object();
  nlohmann::json report = nlohmann::json::object();

  const PartialEffectResult* partial = nullptr;  // partial effect: its lines and its rule
  // An edit's lines (take_lines_from): the rows fed, the base's pieces by name, its site map.
  struct Taking {
    std::map<std::string, LinePieces> base;
    std::vector<std::pair<int64_t, int64_t>> fed;
    std::vector<int32_t> site_map;
  };
  std::optional<Taking> taking;
  // keep_refined's `before` and `changed`
  std::optional<std::pair<std::map<std::string, RefinedSegments>, ChangedTiles>> keeping;
  bool lines_wanted = false;      // boundaries (a deliverable, or what regions, the preview or the report read)
  bool lines_finished = false;    // finish_lines() done
  BoundaryResult boundary_lines;  // finish_lines()'s
  LimitResult limit_lines;

  State(JobRun& r, const PreparedJob& j, bool s, const PartialEffectResult* p)
      : run(r), job(j), streamed(s), partial(p) {}
  const OutputRequest& out() const { return run.spec.outputs; }

  // The stages of finish(), one per deliverable: each writes its file(s), its report entry and
  // its time (the strips' share included). The lines are taken and reported first (take_*), and
  // their files written (write_*_files, which touch nothing else of the state and return their
  // seconds) beside the regions' work.
  // A kind of line's residual along its length (rv/lines/residual.hpp) for the report, in the
  // job's distance units, with the tolerance that holds after simplification.
  nlohmann::json residual_json(const LineResidual& r, double simplified_midpoint) const;
  BoundaryResult take_boundaries();
  double write_boundary_files(const BoundaryResult& boundaries) const;
  LimitResult take_limits();
  double write_limit_file(const LimitResult& limits) const;
  void write_region_polygons(const BoundaryResult& boundaries);
  // The rows of a strip into cell_owners (a streamed edit's: its fed rows alone, the others' cells
  // are not all computed).
  void add_cell_owners(const NearestField& strip);
  // The regions' faces against the cells: reported, and refused where an owned cell lies clear of
  // the faces' edges in another owner's face or in none.
  void check_regions(std::span<const OwnedFace> faces);
  // The disproportionality test's report entry, from the regions' areas within the relevant area.
  nlohmann::json relevance(const RegionStats& rs, const std::string& area_units);
  void finish_margin();
  void write_quicklook(const BoundaryResult& boundaries, const LimitResult& limits);
  // The line extractions by name (those the job makes).
  std::vector<std::pair<std::string, StripLines*>> lines() {
    std::vector<std::pair<std::string, StripLines*>> out;
    if (boundaries) out.emplace_back("boundaries", &*boundaries);
    if (limits) out.emplace_back("limits", &*limits);
    if (reach) out.emplace_back("reach", &*reach);
    return out;
  }
  // A strip into extraction `name`: whole, or for an edit its fed rows, the rows before each taken
  // from the base.
  void feed(StripLines& lines, const std::string& name, const NearestField& strip);
  // An edit's rows after the last fed ones, taken from the base.
  void complete_lines();
};

void StripDeliverables::State::feed(StripLines& lines, const std::string& name, const NearestField& strip) {
  if (!taking) {
    lines.add(strip);
    return;
  }
  const Window w = strip.site.window();
  for (const auto& [a, b] : taking->fed) {
    const int64_t lo = std::max(a, w.row0), hi = std::min(b, w.row0 + w.height);
    if (lo >= hi) continue;
    if (lines.rows() < lo) lines.take_rows(taking->base.at(name), lo, taking->site_map);
    lines.add(strip, lo, hi);
  }
}

void StripDeliverables::State::complete_lines() {
  if (!taking) return;
  for (auto& [name, lines] : this->lines())
    if (lines->rows() < job.grid.height) lines->take_rows(taking->base.at(name), job.grid.height, taking->site_map);
}

bool StripDeliverables::needs_every_cell() const {
  const State& s = *st_;
  return s.preview || !s.out().margin.empty() || s.relevant_coasts || s.partial;
}

std::map<std::string, std::string> StripDeliverables::line_keys() const {
  std::map<std::string, std::string> out;
  for (auto& [name, lines] : st_->lines()) out[name] = lines->key();
  return out;
}

void StripDeliverables::take_lines_from(std::map<std::string, LinePieces> base,
                                        std::vector<std::pair<int64_t, int64_t>> fed, std::vector<int32_t> site_map,
                                        const ChangedTiles& changed) {
  State& s = *st_;
  s.taking.emplace();
  s.taking->base = std::move(base);
  s.taking->fed = std::move(fed);
  s.taking->site_map = std::move(site_map);
  if (changed.size > 0)
    for (auto& [name, lines] : s.lines()) lines->take_measured(s.taking->base.at(name), changed, s.taking->site_map);
}

int64_t StripDeliverables::vertices_taken() const {
  int64_t n = 0;
  for (auto& [name, lines] : st_->lines()) n += lines->vertices_taken();
  return n;
}

void StripDeliverables::keep_refined(std::map<std::string, RefinedSegments> before, ChangedTiles changed) {
  st_->keeping.emplace(std::move(before), std::move(changed));
}

std::map<std::string, RefinedSegments> StripDeliverables::refined_segments() const {
  std::map<std::string, RefinedSegments> out;
  for (auto& [name, lines] : st_->lines())
    if (lines->taken()) out[name] = lines->refined();
  return out;
}

const BoundaryResult& StripDeliverables::boundaries() const { return st_->boundary_lines; }
const LimitResult& StripDeliverables::limits() const { return st_->limit_lines; }

std::map<std::string, LinePieces> StripDeliverables::line_pieces() {
  st_->complete_lines();
  std::map<std::string, LinePieces> out;
  for (auto& [name, lines] : st_->lines()) out[name] = lines->pieces();
  return out;
}

void StripDeliverables::keep_line_pieces() {
  st_->complete_lines();
  for (auto& [name, lines] : st_->lines()) lines->keep_pieces();
}

std::map<std::string, LinePieces> StripDeliverables::kept_line_pieces() {
  std::map<std::string, LinePieces> out;
  for (auto& [name, lines] : st_->lines()) out[name] = lines->taken() ? lines->kept_pieces() : lines->pieces();
  return out;
}

StripDeliverables::StripDeliverables(JobRun& run, const PreparedJob& job, bool streamed,
                                     const PartialEffectResult* partial)
    : st_(std::make_unique<State>(run, job, streamed, partial)) {
  State& s = *st_;
  const OutputRequest& out = s.out();
  const GridSpec& g = job.grid;
  // (By sea: nothing settled beyond the seeds until add() knows how far the strips' cells lie.)
  s.metric = site_metric(job, run, s.sea_stats, 0.0);
  // With weights or reaches the max distance ends every reach, as the engine compares.
  s.index = job.loaded.seeds.adjusted()
                ? std::make_unique<OwnerIndex>(*s.metric, OwnerIndex::Measure::adjusted, job.compute.max_distance)
                : std::make_unique<OwnerIndex>(*s.metric);
  const Vec2 mid{g.centre_x(g.width / 2), g.centre_y(g.height / 2)};
  s.cell_length = s.metric->point_distance(mid, Vec2{mid.x + g.res, mid.y});
  s.owner_codes = SiteCodes::owners(job.loaded.seeds);
  s.vector.crs = job.loaded.crs.wkt;
  s.vector.distance_factor = job.to_output;
  s.vector.distance_units = job.unit;
  s.vector.threads = run.spec.threads;
  s.lines_wanted = !out.boundaries.empty() || !out.tripoints.empty() || !out.preview.empty() || out.regions_wanted() ||
                   !out.turning_points.empty();
  if (s.lines_wanted && partial == nullptr) {
    LineRequest r;
    r.boundaries = true;
    r.boundary.simplify_cells = out.simplify_cells;
    r.boundary.line_tolerance = job.line_tolerance;
    r.boundary.threads = run.spec.threads;
    r.boundary.max_distance = job.compute.max_distance;
    s.boundaries.emplace(g, *s.index, r);
  }
  if (!out.limits.empty()) {
    LineRequest r;
    r.limit_distances = job.limit_distances;
    r.limit.per_owner = out.limits_per_owner;
    r.limit.simplify_cells = out.simplify_cells;
    r.limit.line_tolerance = job.line_tolerance;
    r.limit.threads = run.spec.threads;
    s.limits.emplace(g, *s.index, r);
  }
  if (job.relevant_area && !job.relevant_coasts) {
    s.relevant_cells.emplace(build_interiors(job.relevant_area->seeds, g, g.full_window()));
    s.relevant_coasts.emplace(g, *s.metric, *s.relevant_cells, job.compute.geolocator.get(), run.spec.threads);
  }
  const bool adjusted = job.loaded.seeds.adjusted() && partial == nullptr;
  if (out.regions_wanted() && (adjusted || std::isfinite(job.compute.max_distance))) {
    LineRequest r;
    if (adjusted)
      r.owned_edge = true;
    else
      r.limit_distances = {job.compute.max_distance};
    r.limit.simplify_cells = out.simplify_cells;
    // The regions' edges are joined square by square (region_edges): these lines stay on cell
    // edges (with the owned edge's corners); they are measured all the same.
    r.limit.line_tolerance = 0.0;
    r.limit.threads = run.spec.threads;
    s.reach.emplace(g, *s.index, r);
  }
  if (out.regions_wanted()) s.cell_owners.emplace(g);
  if (!out.preview.empty()) s.preview.emplace(g, g.full_window());
  if (streamed && !out.margin.empty()) {
    run.will_write(out.margin);
    s.margin_writer.emplace(out.margin, g, g.full_window(), static_cast<double>(kNoDistance), margin_options(run, job));
  }
}

StripDeliverables::~StripDeliverables() = default;

GeoTiffOptions StripDeliverables::margin_options(const JobRun& run, const PreparedJob& job) {
  GeoTiffOptions o = raster_options(run.spec);
  o.units = job.unit;
  o.metadata["CONTENT"] = "distance to the nearest seed of another owner minus distance to the own nearest seed";
  o.metadata["UNITS"] = job.unit;
  return o;
}

void StripDeliverables::add(const NearestField& strip, const NearestField* measured) {
  State& s = *st_;
  const OutputRequest& out = s.out();
  s.run.check_cancel();
  const auto added = Clock::now();
  struct Tally {
    State& s;
    Clock::time_point t;
    ~Tally() { s.wall_seconds += seconds_since(t); }
  } tally{s, added};
  auto seconds = [](auto&& f) {
    const auto t = Clock::now();
    f();
    return seconds_since(t);
  };
  if (s.job.sea) {
    // The lines' metric settles the owners as far as the field's cells so far ask (and, where
    // they were settled for earlier strips, goes on from there).
    for (float d : strip.distance.cells())
      if (std::isfinite(d)) s.sea_farthest = std::max(s.sea_farthest, static_cast<double>(d));
    settle_sea_metric_within(*s.metric, sea_settle_within(s.job, s.sea_farthest));
  }
  if (s.boundaries) s.boundary_seconds += seconds([&] { s.feed(*s.boundaries, "boundaries", strip); });
  const NearestField& lines_from = measured != nullptr ? *measured : strip;
  if (s.limits) s.limit_seconds += seconds([&] { s.feed(*s.limits, "limits", lines_from); });
  if (s.preview)
    s.preview->add_rows(strip.site.data(), strip.site.window().row0, strip.site.height(), &s.owner_codes,
                        strip.distance.data());
  if (s.reach) s.region_seconds += seconds([&] { s.feed(*s.reach, "reach", lines_from); });
  if (s.cell_owners) s.region_seconds += seconds([&] { s.add_cell_owners(strip); });
  if (s.relevant_coasts) s.region_seconds += seconds([&] { s.relevant_coasts->add(strip); });
  if (!out.margin.empty()) {
    s.margin_seconds += seconds([&] {
      if (s.job.sea && !s.sea_margin) s.sea_margin = sea_other_owners(s.job, s.run.hooks.cancel);
      Raster<float> margin = margin_raster(strip, *s.index, s.run.spec.threads, s.sea_margin);
      if (s.job.to_output != 1.0)
        for (float& v : margin.cells())
          if (v != kNoDistance) v = static_cast<float>(v * s.job.to_output);
      if (s.margin_writer) {
        s.margin_writer->write_rows(margin.data(), margin.height());
      } else {
        s.run.will_write(out.margin);
        write_geotiff(out.margin, margin, static_cast<double>(kNoDistance), margin_options(s.run, s.job));
      }
    });
  }
}

nlohmann::json StripDeliverables::State::residual_json(const LineResidual& r, double simplified_midpoint) const {
  const double k = job.to_output;
  // Douglas-Peucker leaves every dropped point within its tolerance of the new chord, and the
  // chords it replaces were within the line tolerance of the locus.
  // (In CRS units: a cell's larger extent of the two, in metric units, bounds it.)
  const GridSpec& g = job.grid;
  const Vec2 mid{g.centre_x(g.width / 2), g.centre_y(g.height / 2)};
  const double simplify =
      out().simplify_cells * std::max(cell_length, metric->point_distance(mid, Vec2{mid.x, mid.y + g.res}));
  nlohmann::json j = {{"tolerance", job.line_tolerance * k},
                      {"tolerance_after_simplify", (job.line_tolerance + simplify) * k},
                      {"segments", r.segments},
                      {"max_midpoint", r.max_midpoint * k},
                      {"max_estimate", r.max_estimate * k},
                      {"max_vertex", r.max_vertex * k},
                      {"points_added", r.added},
                      {"land_border_segments", r.land_border_segments},
                      {"max_vertex_on_land", r.max_vertex_on_land * k},
                      {"unresolved_segments", r.unresolved}};
  if (r.segments > 0) j["worst_midpoint_at"] = {r.worst_x, r.worst_y};
  if (simplify > 0.0) j["max_midpoint_simplified"] = simplified_midpoint * k;
  return j;
}

BoundaryResult StripDeliverables::State::take_boundaries() {
  State& s = *this;
  const OutputRequest& out = s.out();
  BoundaryResult boundaries;
  if (!s.lines_wanted) return boundaries;
  const auto t = Clock::now();
  boundaries = s.partial ? s.partial->boundaries : s.boundaries->take_boundaries();
  const BoundaryStats& st = boundaries.stats;
  s.report["boundaries"] = {{"lines", boundaries.lines.size()},
                            {"vertices", st.vertices},
                            {"vertices_before_simplify", st.vertices_before_simplify},
                            {"tripoints", boundaries.tripoints.size()},
                            {"crossings", st.crossings},
                            {"saddles", st.saddles},
                            {"multi_owner_squares", st.multi_owner_squares},
                            {"unresolved_tripoints", st.unresolved_tripoints},
                            {"turning_points", st.turning_points},
                            {"arc_points", st.arc_points},
                            {"ends_on_owned_edge", st.ends_on_owned_edge},
                            {"ends_on_barriers", st.ends_on_barriers},
                            {"ends_joined", st.ends_joined},
                            {"ends_followed", st.ends_followed},
                            {"turns_on_land", st.turns_on_land},
                            {"channels_crossed", st.channels_crossed},
                            {"coast_changes_unexplained", st.coast_changes_unexplained},
                            {"tie_vertices", st.tie_vertices},
                            {"missing_tripoints_found", st.missing_tripoints_found},
                            {"legs_walked", st.legs_walked},
                            {"legs_detached", st.legs_detached},
                            {"repeated_loops", st.repeated_loops},
                            {"sliver_crossings", st.sliver_crossings},
                            {"unresolved_slivers", st.unresolved_slivers},
                            {"max_residual", st.max_residual * s.job.to_output},
                            {"max_residual_cells", st.max_residual / s.cell_length},
                            {"max_residual_on_land", st.max_residual_on_land * s.job.to_output},
                            {"simplify_cells", out.simplify_cells},
                            {"along_lines", s.residual_json(st.locus, st.simplified_midpoint)},
                            {"along_arcs", s.residual_json(st.arcs, st.simplified_midpoint)}};
  if (s.partial && s.partial->rule)
    s.report["boundaries"]["partial_effect"] = {{"stretches", s.partial->stats.stretches},
                                                {"coast_ends", s.partial->stats.coast_ends},
                                                {"locus_points", s.partial->stats.points},
                                                {"max_residual", s.partial->stats.max_residual * s.job.to_output},
                                                {"along_lines", s.residual_json(s.partial->stats.residual, 0.0)}};
  if (!out.boundaries.empty()) s.run.will_write(out.boundaries);
  if (!out.tripoints.empty()) s.run.will_write(out.tripoints);
  s.boundary_seconds += seconds_since(t);
  return boundaries;
}

double StripDeliverables::State::write_boundary_files(const BoundaryResult& boundaries) const {
  const OutputRequest& out = this->out();
  const auto t = Clock::now();
  if (!out.boundaries.empty()) write_boundaries(out.boundaries, boundaries, *metric, vector);
  if (!out.tripoints.empty()) write_tripoints(out.tripoints, boundaries, *metric, vector);
  return seconds_since(t);
}

LimitResult StripDeliverables::State::take_limits() {
  State& s = *this;
  const OutputRequest& out = s.out();
  if (!s.limits) return LimitResult{};
  const auto t = Clock::now();
  LimitResult limits = s.limits->take_limits();
  s.run.will_write(out.limits);
  nlohmann::json distances = nlohmann::json::array();
  for (double d : s.job.limit_distances) distances.push_back(d * s.job.to_output);
  s.report["limits"] = {{"distances", distances},
                        {"as_given", out.limit_distances},
                        {"per_owner", out.limits_per_owner},
                        {"lines", limits.lines.size()},
                        {"vertices", limits.vertices},
                        {"max_residual", limits.max_residual * s.job.to_output},
                        {"max_residual_cells", limits.max_residual / s.cell_length},
                        {"vertices_before_simplify", limits.vertices_before_simplify},
                        {"corners", limits.corners},
                        {"ends_on_barriers", limits.ends_on_barriers},
                        {"along_lines", s.residual_json(limits.residual, limits.simplified_midpoint)}};
  s.limit_seconds += seconds_since(t);
  return limits;
}

double StripDeliverables::State::write_limit_file(const LimitResult& limits) const {
  if (!this->limits) return 0.0;
  const auto t = Clock::now();
  write_limits(out().limits, limits, job.loaded.seeds, vector);
  return seconds_since(t);
}

void StripDeliverables::State::write_region_polygons(const BoundaryResult& boundaries) {
  State& s = *this;
  const OutputRequest& out = s.out();
  JobRun& run = s.run;
  if (!out.regions_wanted()) return;
  run.check_cancel();
  const auto t = Clock::now();
  // Without --regions (the relevant area alone) the regions are measured, not written.
  if (!out.regions.empty()) run.will_write(out.regions);
  const SeedSet& seeds = s.job.loaded.seeds;
  const double max_distance = s.job.compute.max_distance;
  const LimitResult reach_lines = s.reach ? s.reach->take_limits() : LimitResult{};
  LocusFunction partial_locus_of;
  if (s.partial) partial_locus_of = [&](int32_t a, int32_t b, Vec2 p) { return partial_locus(*s.partial, a, b, p); };
  RegionEdges edges = region_edges(boundaries, *s.index, s.job.grid, max_distance, s.reach ? &reach_lines : nullptr,
                                   s.partial ? &partial_locus_of : nullptr, s.job.line_tolerance);
  // A line stopping in the open would merge two owners' faces: no regions rather than wrong ones.
  if (edges.dangling_ends > 0)
    throw Error(ErrorKind::internal,
                "regions: " + std::to_string(edges.dangling_ends) +
                    " line end(s) stop inside the grid, away from any tripoint (the lines could not be joined "
                    "there, a defect of the extraction); the regions cannot be bounded by them. Leave out the "
                    "regions, or report this case");
  // The areas follow the loci, not only the chords (each segment's bow, rv/lines/regions.hpp).
  const SegmentBows bows(edges);
  const LineResidual along_edges = edges.residual;
  LineRegions lr;
  lr.edges = std::move(edges.edges);
  lr.grid = s.job.grid;
  if (s.job.sea) lr.outline = barrier_linework(s.job, s.cell_length);
  lr.owner_of = [&](Vec2 p) {
    return s.partial ? partial_owner_at(*s.partial, p, max_distance) : owner_at(*s.index, p, max_distance);
  };
  const double to_area = s.job.to_output * s.job.to_output;
  const Geolocator* located = s.job.compute.geolocator.get();
  lr.area = [&, to_area, located](std::span<const Vec2> ring) {
    return to_area * ring_area(ring, s.job.compute.metric, located, s.job.grid.res, bows);
  };
  lr.area_units = s.job.unit + "^2";
  if (s.job.relevant_area) lr.relevant = &s.job.relevant_area->seeds.polygons();
  lr.verify = [&s](std::span<const OwnedFace> faces) { s.check_regions(faces); };
  const RegionStats rs = write_line_regions(
      out.regions, lr, seeds, s.job.loaded.grid_polygons ? *s.job.loaded.grid_polygons : seeds.polygons(), s.vector);
  if (!out.regions.empty()) run.wrote("regions", out.regions);
  // Each owner's areas in the report too, for the analyst who does not open the file.
  nlohmann::json areas = nlohmann::json::array();
  for (const RegionStats::OwnerArea& a : rs.areas)
    areas.push_back({{"owner", a.owner},
                     {"label", seeds.owner_labels()[static_cast<size_t>(a.owner - 1)]},
                     {"area", a.area},
                     {"land_area", a.land},
                     {"sea_area", a.sea}});
  s.report["regions"] = {
      {"owners", rs.owners}, {"polygons", rs.polygons}, {"areas", areas}, {"area_units", lr.area_units}};
  s.report["regions"]["along_edges"] = s.residual_json(along_edges, 0.0);
  s.report["regions"]["against_cells"] = s.region_check;
  // The edge of the owned area (reaches), or the max-distance line, as the regions' edges.
  if (s.reach)
    s.report["regions"][s.job.loaded.seeds.adjusted() ? "owned_edge" : "max_distance_line"] = {
        {"lines", reach_lines.lines.size()},
        {"vertices", reach_lines.vertices},
        {"corners", reach_lines.corners},
        // As extracted, before the regions' edges follow them (along_edges): their chords' worst.
        {"chords_on_cell_edges",
         {{"segments", reach_lines.residual.segments},
          {"max_midpoint", reach_lines.residual.max_midpoint * s.job.to_output}}}};
  if (s.job.relevant_area) s.report["regions"]["relevant_area"] = relevance(rs, lr.area_units);
  s.times["regions"] = s.region_seconds + seconds_since(t);
}

void StripDeliverables::State::add_cell_owners(const NearestField& strip) {
  const Window w = strip.site.window();
  // (Rows apart on the threads: each writes its own row of cell_owners.)
  auto add = [&](int64_t lo, int64_t hi) {
    lo = std::max(lo, w.row0);
    hi = std::min(hi, w.row0 + w.height);
    if (lo >= hi) return;
    detail::parallel_for(run.spec.threads, hi - lo, [&](int64_t k, int) {
      const int64_t r = lo + k;
      cell_owners->add_sites(r, std::span<const int32_t>(strip.site.row(r - w.row0), static_cast<size_t>(w.width)),
                             owner_codes);
    });
  };
  // (A streamed edit's strips hold valid cells on its fed rows alone; a field kept whole, as a
  // session's, on every row.)
  if (!taking || !streamed) {
    add(w.row0, w.row0 + w.height);
    return;
  }
  for (const auto& [a, b] : taking->fed) add(a, b);
}

void StripDeliverables::State::check_regions(std::span<const OwnedFace> faces) {
  const GridSpec& g = job.grid;
  // The centres a face edge may pass on either side of, and still follow the lines: the lines'
  // tolerance (four times, in the grid's narrowest cell side), their simplification, and a
  // thousandth of a cell (a line ending on a barrier is carried that far across it).
  double side = cell_length;
  for (const int64_t row : {int64_t{0}, g.height - 1}) {
    const Vec2 p{g.centre_x(g.width / 2), g.centre_y(row)};
    side = std::min(
        {side, metric->point_distance(p, Vec2{p.x + g.res, p.y}), metric->point_distance(p, Vec2{p.x, p.y + g.res})});
  }
  const double cells = std::max(1e-3, 4.0 * job.line_tolerance / side) + out().simplify_cells;
  const auto started = Clock::now();
  const RegionCellCheck c = check_regions_against_cells(faces, *cell_owners, cells * g.res);
  times["regions_check"] = seconds_since(started);
  nlohmann::json first = nlohmann::json::array();
  const std::vector<std::string>& labels = job.loaded.seeds.owner_labels();
  auto label = [&](int32_t o) { return o == 0 ? std::string() : labels[static_cast<size_t>(o - 1)]; };
  for (const RegionCellCheck::Misplaced& m : c.first)
    first.push_back({{"x", g.centre_x(m.col)},
                     {"y", g.centre_y(m.row)},
                     {"owner", label(m.owner)},
                     {"region", m.region == 0 ? nlohmann::json(nullptr) : nlohmann::json(label(m.region))}});
  region_check = {{"rows", c.rows},
                  {"cells_checked", c.checked},
                  {"cells_near_edges", c.near_edges},
                  {"margin_cells", cells},
                  {"cells_in_another_region", c.misplaced},
                  {"first", first}};
  if (c.misplaced == 0) return;
  const RegionCellCheck::Misplaced& m = c.first.front();
  std::ostringstream text;
  text.precision(10);
  text << "regions: " << c.misplaced
       << " owned cell(s) lie in another owner's region, clear of its edges (the first at " << g.centre_x(m.col) << " "
       << g.centre_y(m.row) << ": a cell of " << label(m.owner) << " in "
       << (m.region == 0 ? std::string("no owner's region") : label(m.region) + "'s region")
       << "); the lines miss a change of owner there (a defect of the extraction, often where a strait or a "
          "sound is narrower than a cell), and the regions' areas would give those cells to the wrong owner. "
          "Leave out the regions, try a finer grid, or report this case";
  throw Error(ErrorKind::internal, text.str());
}

nlohmann::json StripDeliverables::State::relevance(const RegionStats& rs, const std::string& area_units) {
  const SeedSet& seeds = job.loaded.seeds;
  const auto owners = static_cast<size_t>(seeds.owner_count());
  // Each owner's relevant coast: the given lines' length, or the stretches of its seeds nearest
  // to the area's cells.
  std::vector<double> coast(owners + 1, 0.0);
  if (job.relevant_coasts) {
    const SeedSet& cs = job.relevant_coasts->seeds;
    const std::unique_ptr<SiteMetric> m = make_site_metric(cs, job.grid, [&] {
      ComputeOptions o = job.compute;
      o.geolocator = nullptr;  // the coasts are read where the seeds are: longitude/latitude then
      o.grid_polygons = nullptr;
      return o;
    }());
    for (const Site& site : cs.sites()) {
      if (site.kind != SiteKind::segment) continue;
      const std::string& label = cs.owner_labels()[static_cast<size_t>(cs.features()[site.feature].owner - 1)];
      const auto at = std::find(seeds.owner_labels().begin(), seeds.owner_labels().end(), label);
      coast[static_cast<size_t>(at - seeds.owner_labels().begin()) + 1] += m->point_distance(site.a, site.b);
    }
  } else {
    for (const RelevantCoasts::Stretch& st : relevant_coasts->take())
      coast[static_cast<size_t>(seeds.site_owner(st.site))] += st.length;
  }
  double coast_total = 0.0, sea_total = 0.0;
  for (size_t o = 1; o <= owners; ++o) coast_total += coast[o];
  std::vector<double> sea(owners + 1, 0.0), land(owners + 1, 0.0);
  for (const RegionStats::OwnerArea& a : rs.areas) {
    sea[static_cast<size_t>(a.owner)] = a.relevant_sea;
    land[static_cast<size_t>(a.owner)] = a.relevant_land;
    sea_total += a.relevant_sea;
  }
  auto share = [](double part, double whole) { return whole > 0.0 ? nlohmann::json(part / whole) : nlohmann::json(); };
  nlohmann::json list = nlohmann::json::array();
  std::vector<size_t> present;
  for (size_t o = 1; o <= owners; ++o) {
    if (coast[o] == 0.0 && sea[o] == 0.0 && land[o] == 0.0) continue;
    present.push_back(o);
    const nlohmann::json cs = share(coast[o], coast_total), as = share(sea[o], sea_total);
    list.push_back({{"owner", o},
                    {"label", seeds.owner_labels()[o - 1]},
                    {"coast_length", coast[o] * job.to_output},
                    {"coast_share", cs},
                    {"sea_area", sea[o]},
                    {"land_area", land[o]},
                    {"area_share", as},
                    // Above 1: more sea than coast would give; the test compares these.
                    {"area_to_coast", cs.is_number() && as.is_number() && cs.get<double>() > 0.0
                                          ? nlohmann::json(as.get<double>() / cs.get<double>())
                                          : nlohmann::json()}});
  }
  nlohmann::json out = {{"coasts", job.relevant_coasts ? "given" : "nearest to the area's cells"},
                        {"area", rs.relevant_total},
                        {"area_units", area_units},
                        {"length_units", job.unit},
                        {"owners", list}};
  if (present.size() == 2) {
    const size_t a = present[0], b = present[1];
    out["pair"] = {{"owners", {seeds.owner_labels()[a - 1], seeds.owner_labels()[b - 1]}},
                   {"coast_ratio", coast[b] > 0.0 ? nlohmann::json(coast[a] / coast[b]) : nlohmann::json()},
                   {"area_ratio", sea[b] > 0.0 ? nlohmann::json(sea[a] / sea[b]) : nlohmann::json()}};
  }
  return out;
}

void StripDeliverables::State::finish_margin() {
  State& s = *this;
  const OutputRequest& out = s.out();
  JobRun& run = s.run;
  if (!out.margin.empty()) {
    const auto t = Clock::now();
    if (s.margin_writer) s.margin_writer->finish();
    run.wrote("margin", out.margin);
    s.times["margin"] = s.margin_seconds + seconds_since(t);
  }
}

// Ground metres per CRS unit along x at the grid's centre (the quicklook's scale bar): along the
// parallel on the CRS's ellipsoid for geographic grids, the unit's length for projected ones; 0
// without a CRS.
namespace {
double metres_per_unit(const PreparedJob& job) {
  const CrsInfo& crs = job.loaded.crs;
  if (crs.wkt.empty()) return 0.0;
  if (!crs.geographic) return crs.linear_unit;
  const GridSpec& g = job.grid;
  const double lat = std::clamp((g.ymax + g.ymin()) / 2.0, -89.0, 89.0), lon = (g.xmin + g.xmax()) / 2.0;
  double s12 = 0.0;
  GeographicLib::Geodesic(crs.semi_major, crs.flattening).Inverse(lat, lon - 0.5, lat, lon + 0.5, s12);
  return s12;
}
}  // namespace

void StripDeliverables::State::write_quicklook(const BoundaryResult& boundaries, const LimitResult& limits) {
  State& s = *this;
  const OutputRequest& out = s.out();
  JobRun& run = s.run;
  if (s.preview) {
    run.check_cancel();
    timed(s.times, "preview", [&] {
      run.will_write(out.preview);
      PreviewLayers layers;
      layers.boundaries = &boundaries;
      layers.limits = &limits;
      layers.owner_labels = s.job.loaded.seeds.owner_labels();
      layers.metres_per_unit = metres_per_unit(s.job);
      // The regions' sea areas, when they were made (the report has them by now).
      if (s.report.contains("regions")) {
        layers.owner_areas.assign(layers.owner_labels.size(), 0.0);
        for (const auto& a : s.report["regions"]["areas"])
          layers.owner_areas[a.at("owner").get<size_t>() - 1] = a.at("sea_area").get<double>();
        layers.area_units = s.report["regions"]["area_units"].get<std::string>();
      }
      const PreviewInfo pi = write_preview(out.preview, *s.preview, layers);
      run.wrote("preview", out.preview);
      s.report["preview"] = {{"width", pi.width}, {"height", pi.height}, {"cells_per_pixel", pi.step}};
    });
  }
}

void StripDeliverables::finish_lines() {
  State& s = *st_;
  if (s.lines_finished) return;
  const auto started = Clock::now();
  s.run.check_cancel();
  s.run.progress("deliver", 0.0);
  s.complete_lines();
  if (s.keeping)
    for (auto& [name, lines] : s.lines()) {
      // Earlier segments are valid only beside an edit's rows taken from its base.
      const auto it = s.keeping->first.find(name);
      if (s.taking && it != s.keeping->first.end())
        lines->keep_refined(it->second, s.keeping->second, s.taking->site_map);
      else
        lines->keep_refined();
    }
  s.boundary_lines = s.take_boundaries();
  s.limit_lines = s.take_limits();
  s.lines_finished = true;
  s.wall_seconds += seconds_since(started);
}

void StripDeliverables::finish() {
  State& s = *st_;
  JobRun& run = s.run;
  finish_lines();
  const auto started = Clock::now();
  const BoundaryResult& boundaries = s.boundary_lines;
  const LimitResult& limits = s.limit_lines;
  run.check_cancel();
  // The line files are written (GDAL: a dataset of their own each) while the regions are made:
  // serialising their vertices is the longer part of most jobs' finish.
  double boundary_write = 0.0, limit_write = 0.0;
  {
    auto lines = std::async(std::launch::async, [&] { boundary_write = s.write_boundary_files(boundaries); });
    auto limit_file = std::async(std::launch::async, [&] { limit_write = s.write_limit_file(limits); });
    // Each future is waited for, whatever throws first; the first failure is the job's.
    std::exception_ptr failed;
    try {
      s.write_region_polygons(boundaries);
    } catch (...) {
      failed = std::current_exception();
    }
    for (std::future<void>* f : {&lines, &limit_file}) {
      try {
        f->get();
      } catch (...) {
        if (!failed) failed = std::current_exception();
      }
    }
    if (failed) std::rethrow_exception(failed);
  }
  if (s.boundaries) {
    if (!s.out().boundaries.empty()) run.wrote("boundaries", s.out().boundaries);
    if (!s.out().tripoints.empty()) run.wrote("tripoints", s.out().tripoints);
    s.times["boundaries"] = s.boundary_seconds + boundary_write;
    s.times["boundaries_write"] = boundary_write;
  }
  if (s.limits) {
    run.wrote("limits", s.out().limits);
    s.times["limits"] = s.limit_seconds + limit_write;
    s.times["limits_write"] = limit_write;
  }
  if (!s.out().turning_points.empty()) {
    run.check_cancel();
    const auto t = Clock::now();
    run.will_write(s.out().turning_points);
    const nlohmann::json table = turning_report(boundaries, limits, *s.index, s.job, run.spec.threads);
    write_turning_report(s.out().turning_points, table);
    run.wrote("turning_points", s.out().turning_points);
    int64_t points = 0, turns = 0;
    for (const auto& line : table.at("lines"))
      for (const auto& p : line.at("points")) {
        ++points;
        turns += p.at("kind") == "turn";
      }
    s.report["turning_points"] = {{"lines", table.at("lines").size()}, {"points", points}, {"turns", turns}};
    s.times["turning_points"] = seconds_since(t);
  }
  run.progress("deliver", 0.7);
  s.finish_margin();
  run.progress("deliver", 0.9);
  s.write_quicklook(boundaries, limits);
  run.progress("deliver", 1.0);
  // The per-deliverable times overlap where files are written side by side; "wall" does not.
  s.times["wall"] = s.wall_seconds + seconds_since(started);
  for (auto& [k, v] : s.times.items()) run.timings["deliverables"][k] = v;
  // (By sea: 0 owners settled where no deliverable asked the metric: a margin alone.)
  if (s.job.sea) {
    s.report["by_sea"] = {{"owners_settled", s.sea_stats.owners},
                          {"bend_tests", s.sea_stats.bend_tests},
                          {"seconds", s.sea_stats.seconds}};
    if (std::isfinite(s.sea_stats.within)) s.report["by_sea"]["settled_within"] = s.sea_stats.within * s.job.to_output;
  }
  run.report["deliverables"] = s.report;
}

GeoTiffOptions raster_options(const JobSpec& spec) {
  GeoTiffOptions o;
  o.cloud_optimized = spec.outputs.cloud_optimized;
  o.threads = spec.threads;
  o.compression = spec.outputs.compression;
  return o;
}

void deliver(JobRun& run, const PreparedJob& job, const NearestField& computed, const PartialEffectResult* partial) {
  if (!run.spec.outputs.any_deliverable()) return;
  run.check_cancel();
  // From an exact field: a scan's ownership is not exact, so the exact method runs for them.
  const NearestField* field = &computed;
  NearestField exact;
  if (run.spec.method != Method::exact && run.spec.method != Method::brute_force) {
    ComputeOptions eo = job.compute;
    eo.method = Method::exact;
    eo.progress = nullptr;
    exact = compute(job.loaded.seeds, job.grid, eo);
    field = &exact;
    run.timings["deliverables"]["exact_field"] = exact.seconds;
  }
  StripDeliverables d(run, job, false, partial);
  d.add(*field, partial != nullptr ? &partial->full : nullptr);
  d.finish();
}

}  // namespace rv::detail
