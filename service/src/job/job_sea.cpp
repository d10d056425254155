// The distance by sea in a job. See job_sea.hpp for the contract.
#include "job/job_sea.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>

#include "job/job_run.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/partial_effect.hpp"
#include "rv/sea/snap.hpp"

namespace rv::detail {
namespace {

[[noreturn]] void refuse(ErrorKind kind, const std::string& what) { throw Error(kind, "barriers: " + what); }

// An error from reading or snapping, its message said to be about the barriers.
template <class F>
auto about_barriers(F&& f) {
  try {
    return f();
  } catch (const Error& e) {
    const std::string m = e.what();
    if (m.rfind("barriers", 0) == 0) throw;
    throw Error(e.kind(), "barriers: " + m);
  }
}

}  // namespace

void read_barriers(const JobSpec& spec, const SeedReadOptions& read, PreparedJob& job) {
  if (spec.barriers.empty()) return;
  if (spec.method != Method::exact && spec.method != Method::brute_force)
    refuse(ErrorKind::invalid_argument,
           "the distance by sea needs the exact (or brute-force) method: the scans propagate from cell to cell, "
           "not around the barriers' vertices");
  const bool geodesic = job.metric.kind == MetricSpec::geodesic;
  if (spec.band) refuse(ErrorKind::invalid_argument, "a split job's band does not compute by sea");
  const SeedSet& seeds = job.loaded.seeds;

  auto sea = std::make_shared<PreparedJob::Sea>();
  SeedReadOptions options = other_layers(read, spec.barriers, job);
  // (Geodesic on a projected grid: in its geographic base, as the seeds; the cells are located.)
  options.geographic_seeds = geodesic && !job.loaded.crs.geographic;
  sea->loaded = about_barriers([&] { return load_barriers(options); });
  if (sea->loaded.barriers.empty()) refuse(ErrorKind::invalid_input, "the layers hold no polygon or line");

  // Metres (or the length's own unit) to CRS units; CRS units where the seeds have none.
  Length tolerance;
  try {
    tolerance = parse_length(spec.snap_tolerance);
  } catch (const Error& e) {
    throw Error(e.kind(), std::string("snap tolerance: ") + e.what());
  }
  const double metres = tolerance.value * tolerance.metres_per_unit;
  sea->snap_tolerance = job.loaded.crs.wkt.empty() ? tolerance.value : metres / job.loaded.crs.linear_unit;
  // (Geodesic: decided in a frame over the barriers and the seeds, in metres.)
  std::shared_ptr<const GeodesicFrame> frame;
  if (geodesic) {
    sea->snap_tolerance = metres;
    frame = about_barriers([&] { return frame_for(job.metric, sea->loaded.barriers, seeds); });
  }
  // (A seed deeper inland than the tolerance is the seeds' fault: its message names the seed.)
  SnappedSeeds snapped = snap_to_sea(seeds, sea->loaded.barriers, sea->snap_tolerance, frame);
  job.loaded.seeds = std::move(snapped.seeds);
  sea->snapped = snapped.moved;
  sea->largest_snap = snapped.largest_move;
  sea->on_land_borders = snapped.on_land_borders;
  job.sea = std::move(sea);
}

void check_sea_plan(const JobSpec& spec, const PreparedJob& job) {
  if (!job.sea) {
    if (!spec.outputs.via.empty() || spec.outputs.in_memory.via)
      throw Error(ErrorKind::invalid_argument,
                  "the via raster needs barriers (--barriers): it is the distance by sea's");
    return;
  }
  if (!spec.base_report.empty())
    refuse(ErrorKind::unsupported, "an edit of a run by sea is not available yet: run it again with the new seeds");
  if (!spec.bands.empty()) refuse(ErrorKind::invalid_argument, "a split job's assembly does not compute by sea");
}

namespace {

SeaOptions sea_options(const PreparedJob& job, const ComputeOptions& compute) {
  SeaOptions options;
  options.metric = job.metric;
  options.geolocator = job.compute.geolocator;
  options.grid_polygons = job.compute.grid_polygons;
  options.max_distance = compute.max_distance;
  options.threads = compute.threads;
  options.cancel = compute.cancel;
  options.progress = compute.progress;
  return options;
}

// The features `drop` marks taken out of the loaded seeds: the seed set (SeedSet::without), their
// input positions, and (projected geodesic) their polygons in the grid's CRS, renumbered as the
// seed set's.
void drop_features(LoadedSeeds& loaded, const std::vector<bool>& drop) {
  std::vector<int32_t> site_of;
  SeedSet kept = loaded.seeds.without(drop, site_of);
  std::vector<int32_t> new_feature(drop.size(), -1), new_site(loaded.seeds.sites().size(), -1);
  int32_t next = 0;
  std::vector<int64_t> positions;
  for (size_t f = 0; f < drop.size(); ++f) {
    if (drop[f]) continue;
    new_feature[f] = next++;
    if (f < loaded.input_position.size()) positions.push_back(loaded.input_position[f]);
  }
  for (size_t s = 0; s < site_of.size(); ++s) new_site[static_cast<size_t>(site_of[s])] = static_cast<int32_t>(s);
  if (loaded.grid_polygons) {
    auto polygons = std::make_shared<std::vector<Polygon>>();
    for (const Polygon& p : *loaded.grid_polygons) {
      if (drop[static_cast<size_t>(p.feature)]) continue;
      Polygon q = p;
      q.feature = new_feature[static_cast<size_t>(p.feature)];
      q.area_site = new_site[static_cast<size_t>(p.area_site)];
      polygons->push_back(std::move(q));
    }
    loaded.grid_polygons = std::move(polygons);
  }
  loaded.seeds = std::move(kept);
  if (!loaded.input_position.empty()) loaded.input_position = std::move(positions);
}

}  // namespace

void nil_effect_by_sea(PreparedJob& job) {
  if (!job.sea) return;
  const PartialEffect effect = partial_effect_of(job.loaded.seeds);
  // (Above 0 the job computes both fields by sea and the rule between their lines: SeaPartial.)
  if (!effect.any() || effect.effect > 0.0) return;
  drop_features(job.loaded, effect.partial);
  // (Projected geodesic: the engine's copy of the grid polygons follows.)
  if (job.compute.grid_polygons) job.compute.grid_polygons = job.loaded.grid_polygons;
  if (job.loaded.seeds.geometric_site_count() == 0)
    refuse(ErrorKind::invalid_input, "with the features of effect 0 taken out no seed is left");
}

void settle_sea(PreparedJob& job, const JobHooks& hooks) {
  if (!job.sea) return;
  SeaOptions options = sea_options(job, job.compute);
  options.cancel = hooks.cancel;
  options.progress = nullptr;
  job.sea->prepared =
      about_barriers([&] { return prepare_sea(job.loaded.seeds, job.sea->loaded.barriers, job.grid, options); });
}

OtherOwnersField sea_other_owners(const PreparedJob& job, const std::atomic<bool>* cancel) {
  if (!job.sea) return nullptr;
  auto settled = std::make_shared<std::map<int32_t, std::shared_ptr<const PreparedSea>>>();
  return [&job, cancel, settled](int32_t owner, const SeedSet& others, const Window& window) {
    SeaOptions options = sea_options(job, job.compute);
    options.max_distance = std::numeric_limits<double>::infinity();
    options.cancel = cancel;
    options.progress = nullptr;
    std::shared_ptr<const PreparedSea>& prepared = (*settled)[owner];
    if (!prepared)
      prepared = about_barriers([&] { return prepare_sea(others, job.sea->loaded.barriers, job.grid, options); });
    options.prepared = prepared;
    return compute_sea(others, job.sea->loaded.barriers, job.grid, window, options).field;
  };
}

void SeaRun::compute(const Window& window, NearestField& field, std::vector<int32_t>* via,
                     const ComputeOptions& compute) {
  const PreparedJob::Sea& sea = *job_.sea;
  const SeedSet& seeds = seeds_ ? *seeds_ : job_.loaded.seeds;
  SeaField f;
  SeaOptions options = sea_options(job_, compute);
  if (compute.method == Method::brute_force) {
    f = brute_force_sea(seeds, sea.loaded.barriers, job_.grid, window, options);
  } else {
    options.prepared = seeds_ ? prepared_ : sea.prepared;
    // (Made at the first window, where the job's seeds now lie; the oracle needs none.)
    if (!straight_) straight_ = prepare_straight(seeds, job_.grid, options);
    options.straight = straight_;
    f = compute_sea(seeds, sea.loaded.barriers, job_.grid, window, options);
  }
  land_ += f.land_cells;
  unreachable_ += f.unreachable_cells;
  tests_ += f.visibility_tests;
  detour_ = std::max(detour_, f.max_detour);
  if (named_.empty()) named_.assign(static_cast<size_t>(std::max(f.barrier_vertices, 0)), 0);
  if (via) {
    const int64_t n = window.cell_count();
    via->resize(static_cast<size_t>(n));
    const int32_t* v = f.via.data();
    for (int64_t c = 0; c < n; ++c) {
      (*via)[static_cast<size_t>(c)] = v[c] + 1;  // kNoVia (-1) -> 0
      if (v[c] >= 0 && static_cast<size_t>(v[c]) < named_.size()) named_[static_cast<size_t>(v[c])] = 1;
    }
  }
  field = std::move(f.field);
}

void SeaRun::name_vias(const std::vector<int32_t>& codes) {
  std::fill(named_.begin(), named_.end(), uint8_t{0});
  for (const int32_t c : codes)
    if (c > 0 && static_cast<size_t>(c) <= named_.size()) named_[static_cast<size_t>(c) - 1] = 1;
}

nlohmann::json SeaRun::report() const {
  const PreparedJob::Sea& sea = *job_.sea;
  const Barriers& b = sea.loaded.barriers;
  const SeaPreparation prep = sea.prepared ? preparation_of(*sea.prepared) : SeaPreparation{};
  nlohmann::json r;
  r["barriers"] = {{"features", sea.loaded.report.features_read},
                   {"polygons", b.polygons().size()},
                   {"lines", b.lines().size()},
                   {"vertices", prep.barrier_vertices},
                   {"polygons_repaired", sea.loaded.report.polygons_repaired},
                   {"warnings", sea.loaded.report.warnings}};
  // Metres on the ellipsoid (geodesic), else in the grid CRS's units (metres on a projected grid).
  r["snap"] = {{"tolerance", sea.snap_tolerance},
               {"moved", sea.snapped},
               {"largest_move", sea.largest_snap},
               {"on_land_borders", sea.on_land_borders}};
  r["bend_nodes"] = prep.bend_nodes;
  r["bends_seconds"] = prep.seconds;
  r["visibility_tests"] = {{"all", tests_ + prep.bend_tests}, {"bends", prep.bend_tests}};
  r["land_cells"] = land_;
  r["unreachable_cells"] = unreachable_;
  r["max_detour"] = detour_;
  // The vertices the via raster names: [number, x, y] in the grid's CRS.
  if (std::find(named_.begin(), named_.end(), 1) != named_.end()) {
    nlohmann::json vertices = nlohmann::json::array();
    for (size_t v = 0; v < named_.size(); ++v) {
      if (!named_[v]) continue;
      const Vec2 at = via_position(*sea.prepared, job_.grid, static_cast<int32_t>(v));
      vertices.push_back({static_cast<int64_t>(v) + 1, at.x, at.y});
    }
    r["via_vertices"] = std::move(vertices);
  }
  return r;
}

std::unique_ptr<SiteMetric> sea_site_metric(const PreparedJob& job, const SeedSet& seeds,
                                            std::shared_ptr<const PreparedSea> prepared, int threads,
                                            const std::atomic<bool>* cancel, SeaMetricStats& stats,
                                            double settle_within) {
  SeaOptions options;
  options.metric = job.metric;
  options.geolocator = job.compute.geolocator;
  options.threads = threads;
  options.cancel = cancel;
  // (Projected geodesic grids, whose polygons are the job's seeds', take no partial effect.)
  options.grid_polygons = &seeds == &job.loaded.seeds ? job.compute.grid_polygons : nullptr;
  options.prepared = std::move(prepared);
  return make_sea_site_metric(seeds, job.sea->loaded.barriers, job.grid, options, &stats, settle_within);
}

double sea_settle_within(const PreparedJob& job, double farthest) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  // With weights an owner competes for a cell up to the heaviest weight over the lightest times the
  // winner's length (its cost is at most the winner's).
  double lightest = kInf, heaviest = 0.0;
  for (const Feature& f : job.loaded.seeds.features()) {
    lightest = std::min(lightest, f.weight);
    heaviest = std::max(heaviest, f.weight);
  }
  const double ratio = lightest > 0.0 && heaviest >= lightest ? heaviest / lightest : 1.0;
  double level = 0.0;
  for (double l : job.limit_distances) level = std::max(level, l);
  // A cell's diagonal in metric units, generously (on the ellipsoid a degree is at most 112 km).
  const bool degrees = job.metric.kind == MetricSpec::geodesic && !job.compute.geolocator;
  const double cell = job.grid.res * (degrees ? 1.12e5 : 1.0) * std::sqrt(2.0) * 1.01;
  // The margin: the lines ask at positions between cells, at the grid's frame and on coasts,
  // which can lie farther than any cell centre; half as far again, and 16 cells.
  if (farthest < 0.0 && level == 0.0) return 0.0;
  const double within = 1.5 * std::max(std::max(farthest, 0.0) * ratio, level) + 16.0 * cell;
  return std::isfinite(within) ? within : kInf;
}

SeaPartial::SeaPartial(const PreparedJob& job, const ComputeOptions& compute, bool vias)
    : job_(job), compute_(compute), vias_(vias), full_(job) {
  if (job.compute.geolocator)
    throw Error(ErrorKind::internal, "partial effect by sea on a projected geodesic grid was not refused");
}

SeaPartial::~SeaPartial() = default;

PartialEngines SeaPartial::engines() {
  PartialEngines e;
  e.field = [this](const SeedSet& seeds, bool nil) {
    // (The two fields share the job's progress: the full effect's first half, the nil effect's second.)
    ComputeOptions options = compute_;
    if (compute_.progress)
      options.progress = [this, nil](double f) { compute_.progress(0.5 * (f + (nil ? 1.0 : 0.0))); };
    NearestField field;
    const Window whole = job_.grid.full_window();
    if (!nil) {
      full_.compute(whole, field, vias_ ? &full_via_ : nullptr, options);
      return field;
    }
    std::shared_ptr<const PreparedSea> prepared;
    if (options.method != Method::brute_force) {
      SeaOptions o = sea_options(job_, options);
      o.grid_polygons = nullptr;
      o.progress = nullptr;
      prepared = about_barriers([&] { return prepare_sea(seeds, job_.sea->loaded.barriers, job_.grid, o); });
    }
    nil_prepared_ = prepared;
    nil_ = std::make_unique<SeaRun>(job_, seeds, std::move(prepared));
    nil_->compute(whole, field, vias_ ? &nil_via_ : nullptr, options);
    return field;
  };
  e.metric = [this](const SeedSet& seeds, const NearestField& field, bool nil) {
    double farthest = -1.0;
    for (const float d : field.distance.cells())
      if (std::isfinite(d)) farthest = std::max(farthest, static_cast<double>(d));
    return sea_site_metric(job_, seeds, nil ? nil_prepared_ : job_.sea->prepared, compute_.threads, compute_.cancel,
                           stats_[nil ? 1 : 0], sea_settle_within(job_, farthest));
  };
  return e;
}

std::vector<int32_t> SeaPartial::vias(const PartialEffectResult& r) {
  if (!vias_) return {};
  std::vector<int32_t> codes = full_via_;
  const auto& full = r.full.site.cells();
  const auto& now = r.field.site.cells();
  if (codes.size() != now.size() || nil_via_.size() != now.size())
    throw Error(ErrorKind::internal, "the vias do not cover the partial field");
  for (size_t i = 0; i < now.size(); ++i)
    if (now[i] != full[i]) codes[i] = nil_via_[i];
  full_.name_vias(codes);
  return codes;
}

nlohmann::json SeaPartial::report() const { return full_.report(); }

SeaMetricStats SeaPartial::metric_stats() const {
  SeaMetricStats s = stats_[0];
  s.owners += stats_[1].owners;
  s.bend_tests += stats_[1].bend_tests;
  s.seconds += stats_[1].seconds;
  s.within = std::max(s.within, stats_[1].within);
  return s;
}

GeoTiffOptions via_options(const JobSpec& spec, const PreparedJob& job) {
  GeoTiffOptions o = raster_options(spec);
  o.categorical = true;
  o.max_code = job.sea && job.sea->prepared ? preparation_of(*job.sea->prepared).barrier_vertices : 0;
  o.metadata["CONTENT"] =
      "number of the last barrier vertex on the path by sea (0 = the seed seen directly, or none reached); the "
      "report's sea.via_vertices gives each number's position";
  return o;
}

void write_via(JobRun& run, const PreparedJob& job, const std::vector<int32_t>& via) {
  const std::string& path = run.spec.outputs.via;
  timed(run.write_times, "via", [&] {
    Raster<int32_t> r(job.grid, 0);
    if (via.size() != r.cells().size()) throw Error(ErrorKind::internal, "the via raster does not cover the grid");
    std::copy(via.begin(), via.end(), r.cells().begin());
    run.will_write(path);
    write_geotiff(path, r, 0.0, via_options(run.spec, job));
  });
  run.wrote("via", path);
}

}  // namespace rv::detail
