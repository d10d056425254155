// Internal to run_job: pieces of a grid computed apart. A window (JobSpec::window: the Python
// module's Dask chunks, in memory) is checked here; a grid split into bands of whole rows (a
// shared service's split job, issue 55) is computed and assembled here.
//
// A band run (JobSpec::band) computes rows [row0, row0 + rows) of the planned grid, whole width,
// strip by strip, and writes their field into its folder:
//   site.tif      the nearest site's index + 1 (0 = none), tiled 256 x 256, the band's rows only;
//   distance.tif  the distance to it in metric units, Float32 as the engine computed it;
//   band.json     the rows, the grid's size and the sites' count (checked by the assembler), the
//                 cells decided between contested polygons (NearestField::contested_cells) and
//                 the engine's threads (the assembled report states the most of any band).
// An assembling run (JobSpec::bands) is the job's own streamed run with its field read from the
// bands' folders instead of computed (StreamJob::source): the writers, the COG overviews, the
// lines, the regions, the report and the kept base are the fresh run's code on the same cells,
// so its files are a fresh run's, byte for byte (the exact and brute-force methods compute any
// window as the same cells of the whole grid).
// Not part of the public API. Thread safety: one object per job, used from its computing thread.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "job/job_run.hpp"
#include "rv/job.hpp"
#include "stream/job_stream.hpp"

namespace rv::detail {

// Refuses a window, a band or an assembly the request cannot make (invalid_argument, one line
// each): a window outside the grid, with files or a method that computes a window otherwise; a
// band not on whole bands of 256 rows or outside the grid, a band with any output, either with a
// plan that is not streamed (`why_whole`), a base or a window.
void check_pieces(const JobSpec& spec, const GridSpec& grid, const JobPlan& plan);

// Computes and writes the band of spec.band (above); its report says which rows it holds.
JobResult run_band(JobRun& run, const PreparedJob& job);

// The bands of an assembling run, opened: their rows checked to cover the grid once, each band's
// grid size and sites' count checked against this job's (invalid_argument naming the folder).
class BandFields {
 public:
  BandFields(const std::vector<std::string>& dirs, const PreparedJob& job);
  ~BandFields();
  BandFields(const BandFields&) = delete;
  BandFields& operator=(const BandFields&) = delete;
  // Fills `field` over `window` (whole rows, starting on a band of 256 rows) from the bands.
  void read(const Window& window, NearestField& field);
  int64_t count() const;

 private:
  struct State;
  std::unique_ptr<State> st_;
};

// Makes `stream` read its strips from `bands` instead of computing them.
void attach_bands(StreamJob& stream, BandFields& bands);

}  // namespace rv::detail
