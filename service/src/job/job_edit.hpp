// Internal to run_job: the streamed job's parts for edits (issue 32). attach_edit() makes an edit
// of a finished run produce its strips from the base (StreamJob::source: the tiles the edit may
// change read, planned and recomputed; the others left for the files to copy from the base's);
// attach_keep() adds what the run keeps for edits of it (edit_base.hpp).
// Not part of the public API. Thread safety: one job's objects, used by its run alone.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "job/edit_base.hpp"
#include "job/job_run.hpp"
#include "rv/edit/edit.hpp"
#include "rv/job.hpp"
#include "stream/job_stream.hpp"

namespace rv::detail {

// What an edit's strip source keeps across strips; must outlive run_streamed.
struct StreamEdit {
  std::optional<Edit> edit;
  std::optional<ChangeTally> tallier;
  EditTally tally;
  // Per tile of the grid, 1 where its cells are read: the edit may change it, or the lines
  // extract its rows again (attach_edit_lines).
  std::vector<uint8_t> to_read;
  EditCodes codes;  // the base's codes -> the edit's
};

// Makes `stream` an edit of `base`: its source, the changes raster (spec.outputs.changes), and
// on each target whose tiles can be copied, the base's file and checksums. A code file (owners,
// features) whose codes move is recoded tile by tile from the base's, or encoded afresh where the
// base's costs show that decoding every tile costs more than producing every cell (by the engine,
// or by reading the base field whole); the report's edit entry says which and why. `stream`'s targets
// (the job's rasters) must be in place; `st`, `base` and `job` must outlive the run. `prepared`:
// the job's seeds prepared (rv::prepare) already, else prepared here.
void attach_edit(StreamJob& stream, StreamEdit& st, const JobSpec& spec, const PreparedJob& job, EditBase& base,
                 std::shared_ptr<const PreparedSeeds> prepared = nullptr);

// An edit's lines (after attach_edit): the rows near the edit's changes extracted again, every
// other row's pieces taken from the base's (rv::Edit::line_rows, StripDeliverables::
// take_lines_from), and the cells of those rows read besides the tiles the edit may change. Where
// a deliverable needs every cell, or the base kept no pieces of an extraction with its options,
// every row is extracted (every cell read), as before. Returns the edit report's "lines" entry.
nlohmann::json attach_edit_lines(StreamJob& stream, StreamEdit& st, StripDeliverables& deliverables,
                                 const EditBase& base, const JobSpec& spec, const PreparedJob& job);

// Adds the kept field's rasters to `stream`, records every raster's checksums and the tile
// summaries in `keep`; with an edit (`base` and `edit` not null: attach_edit's), the kept rasters
// copy the base's, and the summaries of the tiles the edit did not touch are the base's.
// Call after attach_edit. Everything given must outlive the run.
void attach_keep(StreamJob& stream, EditBaseWriter& keep, const EditBase* base, const StreamEdit* edit,
                 const PreparedJob& job);

// What producing this run's field and files cost (EditBaseWriter::set_costs, EditBase::Costs),
// from the streamed run's figures: its own where it made a thing afresh, else its base's (`base`
// and `edit` null for a fresh run).
nlohmann::json run_costs(const StreamJob& stream, const StreamStats& stats, const EditBase* base,
                         const StreamEdit* edit);

}  // namespace rv::detail
