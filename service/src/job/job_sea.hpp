// Internal to run_job (rv/job.hpp): the distance by sea in a job (JobSpec::barriers).
//
// The job reads the barriers after the seeds, into the grid's CRS and under the same limits,
// moves seeds lying just inland onto the coast, settles the bend nodes once (prepare_sea), and
// then computes its field window by window with rv::compute_sea instead of the straight engine:
// a streamed job's strips through StreamJob::source, a whole field (a window, rasters in memory,
// validation) in one piece. Everything after the field (codes, units, files, report) is the
// straight job's.
// Not part of the public API. Thread safety: one SeaRun per job, used from the job's thread.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include <nlohmann/json.hpp>

#include "job/job_run.hpp"
#include "rv/field/raster.hpp"
#include "rv/job.hpp"
#include "rv/lines/margin.hpp"
#include "rv/lines/partial_effect.hpp"
#include "rv/sea/sea_metric.hpp"

namespace rv::detail {

// Stage "read", after the seeds and the metric: refuses what the distance by sea does not do
// (one line each, naming the option), reads the barriers (`read`: the seeds' options with the
// job's limits) into the seeds' CRS, and moves the seeds within the snap tolerance of the sea
// onto the coast (job.loaded.seeds). Sets job.sea. Throws rv::Error as load_barriers and
// snap_to_sea do, their messages starting "barriers: ".
void read_barriers(const JobSpec& spec, const SeedReadOptions& read, PreparedJob& job);

// Refusals that need the planned job (deliverables, an edit). No-op without barriers.
void check_sea_plan(const JobSpec& spec, const PreparedJob& job);

// Partial effect 0 by sea (no-op without barriers, partial features, or at an effect above 0):
// features of effect 0 are no seeds (they stay land where the barriers have them) and are taken
// out of job.loaded, after the grid is planned with them as with any seeds. (Above 0 the job
// runs both effects by sea: SeaPartial.)
void nil_effect_by_sea(PreparedJob& job);

// Settles the bend nodes for every window of the job (job.sea->prepared). Honours the hooks'
// cancellation.
void settle_sea(PreparedJob& job, const JobHooks& hooks);

// The margin's engine by sea (rv/lines/margin.hpp's OtherOwnersField): compute_sea over the
// other owners' seeds with the job's barriers, metric and threads, no maximum distance; the bend
// nodes of each owner's "others" settled once and kept for every strip. Null without barriers.
// The returned function refers to `job`, which must outlive it; one thread at a time.
OtherOwnersField sea_other_owners(const PreparedJob& job, const std::atomic<bool>* cancel);

// The lines' measure by sea of `seeds` (the job's, or a subset of them: partial effect's nil-effect
// seeds) with `prepared` (prepare_sea's of those seeds, or null), on `threads`, honouring
// `cancel`: make_sea_site_metric with the job's barriers, grid and metric, settling into `stats`
// up to `settle_within` (metric units). Refers to `seeds` and `job`, which must outlive it.
std::unique_ptr<SiteMetric> sea_site_metric(const PreparedJob& job, const SeedSet& seeds,
                                            std::shared_ptr<const PreparedSea> prepared, int threads,
                                            const std::atomic<bool>* cancel, SeaMetricStats& stats,
                                            double settle_within);

// By sea: how far the lines' metric settles each owner's bend nodes (make_sea_site_metric's
// settle_within, metric units) for a field whose largest distance is `farthest` (metric units; < 0:
// no owned cell): half as far again as `farthest` times the heaviest weight over the lightest, or
// as the largest limit level, whichever is larger, plus 16 cells; 0 without an owned cell or a
// limit.
double sea_settle_within(const PreparedJob& job, double farthest);

// One job's fields by sea and what computing them measured, summed over its windows.
class SeaRun {
 public:
  explicit SeaRun(const PreparedJob& job) : job_(job) {}
  // A run of other seeds than the job's (partial effect's nil-effect seeds: the job's less some
  // features), `prepared` for them (null: settled at the first window). `seeds` must outlive it.
  SeaRun(const PreparedJob& job, const SeedSet& seeds, std::shared_ptr<const PreparedSea> prepared)
      : job_(job), seeds_(&seeds), prepared_(std::move(prepared)) {}

  // The field over `window` into `field` (distances in metric units, straight-field conventions)
  // and, when `via` is not null, one code per cell into it: the last barrier vertex's number + 1,
  // 0 where the seed is seen directly or none is reached. `progress` in [0, 1] of the window.
  void compute(const Window& window, NearestField& field, std::vector<int32_t>* via, const ComputeOptions& options);

  // The report's "sea" entry: the barriers, the snapping, the visibility work, land and
  // unreachable cells, the largest detour, and (with a via raster) the vertices it names with
  // their positions in the grid's CRS.
  nlohmann::json report() const;

  // The vertices the report names are those of `codes` (compute's codes over the whole grid)
  // instead of those of the windows computed (partial effect: the rule's field mixes two runs).
  void name_vias(const std::vector<int32_t>& codes);

 private:
  const PreparedJob& job_;
  const SeedSet* seeds_ = nullptr;  // other seeds than the job's (null: the job's)
  std::shared_ptr<const PreparedSea> prepared_;
  // The straight engine's preparation of the job's seeds where they lie when the run starts (a
  // PreparedJob may have been moved since prepare_job), shared by the run's windows.
  std::shared_ptr<const PreparedSeeds> straight_;
  int64_t land_ = 0, unreachable_ = 0, tests_ = 0;
  double detour_ = 1.0;
  std::vector<uint8_t> named_;  // per barrier vertex: some cell's via
};

// Partial effect above 0 by sea: compute_partial_effect's engines (rv/lines/partial_effect.hpp)
// for one job: the two fields by compute_sea (the nil-effect seeds' bend nodes settled for them),
// their vias when `vias`, and the lines' measures by sea, each settled as far as its field's
// distances ask (sea_settle_within). The engines and the measures they make refer to this object
// (the measures report their settling into it), which must outlive them; one job thread.
class SeaPartial {
 public:
  SeaPartial(const PreparedJob& job, const ComputeOptions& compute, bool vias);
  ~SeaPartial();
  PartialEngines engines();
  // The via codes of the rule's field (SeaRun::compute's codes over the whole grid): the
  // full-effect field's, and the nil-effect field's where the rule hands a cell back (its site is
  // not the full field's). Empty without `vias`.
  std::vector<int32_t> vias(const PartialEffectResult& r);
  // The full-effect run's report entry (SeaRun::report), naming the vertices of vias() once it
  // was called.
  nlohmann::json report() const;
  // The measures' settling, both effects summed (the report's "by_sea").
  SeaMetricStats metric_stats() const;

 private:
  const PreparedJob& job_;
  ComputeOptions compute_;
  bool vias_;
  SeaRun full_;
  std::unique_ptr<SeaRun> nil_;
  std::shared_ptr<const PreparedSea> nil_prepared_;
  std::vector<int32_t> full_via_, nil_via_;
  SeaMetricStats stats_[2];  // the full- and nil-effect measures'
};

// The GeoTIFF options of the via raster (OutputRequest::via).
GeoTiffOptions via_options(const JobSpec& spec, const PreparedJob& job);

// The whole path's via raster (codes as SeaRun::compute makes them, over the whole grid): written
// to OutputRequest::via and listed in the outputs.
void write_via(JobRun& run, const PreparedJob& job, const std::vector<int32_t>& via);

}  // namespace rv::detail
