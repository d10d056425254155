// One run of a job as a pipeline of stages (service/src/job/job.cpp drives them): prepare (read the
// seeds, plan the grid and the memory), compute the field whole or stream it in strips, write the
// rasters, the deliverables (job_deliver.cpp), the report. JobRun is what the stages share:
// progress and cancellation, the files written so far (removed unless the job completes), and
// the report's timings and outputs, recorded the same way by every stage. Internal to rv_service.
// Thread safety: one JobRun per job, used from the thread that runs it (progress callbacks may
// come from engine threads, as JobHooks allows).
#pragma once

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/field/error.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/job.hpp"
#include "rv/lines/strip_lines.hpp"

namespace rv::detail {

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
    for (const std::string& d : directories_) std::filesystem::remove_all(d, ec);
  }
  void add(const std::string& f) { files_.push_back(f); }
  // A directory the job made whole (its kept base): removed with everything in it.
  void add_directory(const std::string& d) { directories_.push_back(d); }
  void commit() { committed_ = true; }
  const std::vector<std::string>& files() const { return files_; }

 private:
  std::vector<std::string> files_;
  std::vector<std::string> directories_;
  bool committed_ = false;
};

using Clock = std::chrono::steady_clock;
inline double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct JobRun {
  JobRun(const JobSpec& s, const JobLimits& l, const JobHooks& h) : spec(s), limits(l), hooks(h) {}

  const JobSpec& spec;
  const JobLimits& limits;
  const JobHooks& hooks;
  JobPlan plan;  // this run's (its window's, run_prepared)
  OutputGuard guard;
  nlohmann::json report = nlohmann::json::object();
  nlohmann::json timings = nlohmann::json::object();      // seconds per stage
  nlohmann::json write_times = nlohmann::json::object();  // seconds per raster written
  nlohmann::json outputs = nlohmann::json::object();      // output name -> path
  double compute_seconds = 0.0;
  int64_t contested_cells = 0;
  int threads_used = 1;

  void progress(const char* stage, double fraction) const {
    if (hooks.progress) hooks.progress(stage, fraction);
  }
  void check_cancel() const {
    if (hooks.cancel && hooks.cancel->load()) throw Error(ErrorKind::cancelled, "job dismissed");
  }
  // A file the job is about to write: removed again unless the job completes.
  void will_write(const std::string& path) { guard.add(path); }
  // The file of output `name`, written: listed in the report's outputs.
  void wrote(const std::string& name, const std::string& path) { outputs[name] = path; }
};

// Runs f() and records its wall time in seconds as into[name].
template <class F>
void timed(nlohmann::json& into, const char* name, F&& f) {
  const auto t = Clock::now();
  f();
  into[name] = seconds_since(t);
}

// Runs f() and adds its wall time in seconds to `into`.
template <class F>
void timed_add(double& into, F&& f) {
  const auto t = Clock::now();
  f();
  into += seconds_since(t);
}

// Removes a raster file and its sidecar, if there.
inline void remove_raster_file(const std::string& path) {
  std::error_code ec;
  std::filesystem::remove(path, ec);
  std::filesystem::remove(path + ".aux.xml", ec);
}

// What every GeoTIFF of the job shares: COG or not, threads, compression.
GeoTiffOptions raster_options(const JobSpec& spec);

// Seed reading under the job's limits (features, vertices, input bytes) and the memory limit for
// reading: the stricter of each and the options' own.
SeedReadOptions with_limits(SeedReadOptions read, const JobLimits& limits);

// The options of layers read beside the seeds (job_inputs.cpp): `read` (the seeds' own, limits
// applied) for `paths`, every layer of them, without the owner and adjustment fields, nothing
// refused as a conflict, into the job's grid CRS.
SeedReadOptions other_layers(SeedReadOptions read, std::vector<std::string> paths, const PreparedJob& job);

// The limit lines' distances in metric units (metres on geodesic grids, CRS units on planar);
// refused when a limit lies beyond the max distance or names a unit without a CRS.
std::vector<double> limit_distances_in_metric_units(const JobSpec& spec, const PreparedJob& job);
// The line tolerance in metric units: a length with a unit in metres (CRS units where the seeds
// have no CRS: the default 1 mm is then 0.001 of them), a plain number in the distance units.
double line_tolerance_in_metric_units(const JobSpec& spec, const PreparedJob& job);
// The relevant area (its polygons, in the grid's CRS) and the relevant coasts (in the seeds'
// CRS, owned as the seeds are), read with the seeds' confinement and limits; refused when the
// area holds no polygon, the coasts no line, or a coast's owner has no seeds.
void read_relevant(const JobSpec& spec, const JobLimits& limits, PreparedJob& job);

// The maritime deliverables of a job (boundaries, tripoints, limits, regions, margin, preview)
// from its exact field taken in strip by strip (a streamed job), or as one whole field: each
// written to its file, counted in the report's "deliverables", timed in
// timings["deliverables"]. Construct before the first strip (the margin's file is created then,
// so that an unwritable target fails before anything is computed); add() every strip in order,
// on one thread (the engine's, between strips), with distances in metric units; then finish().
class StripDeliverables {
 public:
  // `partial`: a job with partial effect (whole only): its lines are the rule's
  // (PartialEffectResult::boundaries, not extracted again), regions' faces are owned by the rule,
  // and distance limits measure its full-effect field (add's `measured`). Kept by reference.
  // By sea the lines' metric settles each owner's bend nodes only as far by sea as the strips added
  // so far ask (half as far again as their largest distance, or the largest limit, and 16 cells):
  // add() raises it before their lines are drawn.
  StripDeliverables(JobRun& run, const PreparedJob& job, bool streamed, const PartialEffectResult* partial = nullptr);
  ~StripDeliverables();
  // `measured`: the field the distance limits and the max-distance line are drawn from, when not
  // `strip` (partial effect: the full-effect field; the rest follows the rule's `strip`).
  void add(const NearestField& strip, const NearestField* measured = nullptr);
  // After the last strip: the lines joined, refined and taken (boundaries(), limits(), the
  // report's entries), nothing written yet. finish() calls it when it was not called.
  void finish_lines();
  // Writes every requested deliverable (and the regions' lines, taken here).
  void finish();

  // Whether add() reads every cell of every strip: the quicklook, the margin raster and the
  // relevant coasts do; the lines need not (take_lines_from).
  bool needs_every_cell() const;
  // The line extractions' keys (rv::StripLines::key) by name: "boundaries", "limits", "reach"
  // (the owned area's edge, for regions).
  std::map<std::string, std::string> line_keys() const;
  // An edit's lines (call before the first strip): add() takes in only the rows of `fed` (sorted,
  // disjoint [row0, row1) ranges, rv::Edit::line_rows) and every other row's pieces from `base`,
  // an extraction of the edit's base by name, with the key line_keys() gives, its sites
  // renumbered by `site_map` (rv::StripLines::take_rows). The strips' other rows are not read.
  // With `changed` (rv::Edit::line_tiles' flags), the fed rows' vertices on edges in tiles it
  // leaves unchanged are taken from `base` too (rv::StripLines::take_measured).
  void take_lines_from(std::map<std::string, LinePieces> base, std::vector<std::pair<int64_t, int64_t>> fed,
                       std::vector<int32_t> site_map, const ChangedTiles& changed = {});
  // The vertices the lines took from take_lines_from's base instead of placing them.
  int64_t vertices_taken() const;
  // After the last strip, before finish(): every line extraction's pieces, by name (what the run
  // keeps for edits of it).
  std::map<std::string, LinePieces> line_pieces();
  // The same without copying them (a session's step): keep_line_pieces() after the last strip,
  // before finish_lines(); kept_line_pieces() after it (an extraction finish_lines() does not
  // take, the regions' reach, is copied then).
  void keep_line_pieces();
  std::map<std::string, LinePieces> kept_line_pieces();
  // Before finish(): the lines' refinement keeps what it does (refined_segments()), and, for an
  // edit's lines (take_lines_from), takes the segments of `before` (an earlier state's
  // refined_segments(), by name) that the edit's `changed` tiles leave valid
  // (rv::StripLines::keep_refined).
  void keep_refined(std::map<std::string, RefinedSegments> before, ChangedTiles changed);
  // With keep_refined: the refined segments of every line extraction taken so far, by name (after
  // finish_lines() the boundaries and limits, after finish() the regions' too).
  std::map<std::string, RefinedSegments> refined_segments() const;
  // After finish_lines(): the boundaries and tripoints, and the limit lines, as written (empty
  // when not made).
  const BoundaryResult& boundaries() const;
  const LimitResult& limits() const;

 private:
  static GeoTiffOptions margin_options(const JobRun& run, const PreparedJob& job);
  struct State;
  std::unique_ptr<State> st_;
};

// The deliverables of a job computed whole, from its field (a scan's: the exact field is
// computed for them). Nothing when none is requested.
void deliver(JobRun& run, const PreparedJob& job, const NearestField& field,
             const PartialEffectResult* partial = nullptr);

}  // namespace rv::detail
