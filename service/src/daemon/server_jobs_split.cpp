// Split jobs on a shared store (issue 55): a large job's bands queued for every daemon, a band's
// run, and the job's assembly from its bands (the engine's side: service/src/job/job_bands.hpp).
#include <algorithm>

#include "daemon/server_jobs.hpp"
#include "runtime/server_util.hpp"
#include "rv/field/text.hpp"
#include "rv/json_text.hpp"

namespace rv::daemon {
namespace {

namespace fs = std::filesystem;

constexpr int64_t kBandRows = 256;  // a band holds whole tiles of every file

// Bands of about `cells` cells of whole 256-row bands of tiles over a grid of `width` x `height`.
std::vector<store::BandTask> cut_bands(int64_t width, int64_t height, int64_t cells) {
  const int64_t rows = std::max<int64_t>(1, cells / std::max<int64_t>(1, width) / kBandRows) * kBandRows;
  std::vector<store::BandTask> out;
  for (int64_t r = 0; r < height; r += rows) {
    store::BandTask b;
    b.id = new_job_id();
    b.row0 = r;
    b.rows = std::min(rows, height - r);
    out.push_back(b);
  }
  return out;
}

// A band's "<row0>:<rows>".
std::pair<int64_t, int64_t> band_rows(const std::string& payload) {
  const size_t colon = payload.find(':');
  if (colon == std::string::npos || payload.find_first_not_of("0123456789:") != std::string::npos)
    throw Error(ErrorKind::internal, "a band task names no rows: '" + payload.substr(0, 40) + "'");
  return {std::stoll(payload.substr(0, colon)), std::stoll(payload.substr(colon + 1))};
}

}  // namespace

bool JobManager::split_or_assemble(Task& task, JobRecord& rec, const fs::path& dir, JobSpec& spec) {
  if (!shared_ || task.kind != "job") return false;
  if (task.split) {
    const std::vector<store::BandTask> bands = shared_->bands(task.id);
    // Claimed again once every band was computed: the job's own run reads them.
    for (const store::BandTask& b : bands)
      if (b.status != JobStatus::successful || b.results.rfind(task.id + "/" + kBandsDir + "/", 0) != 0)
        throw Error(ErrorKind::internal, "job " + task.id + " is assembled before its bands are computed");
    std::vector<std::string> dirs;
    for (const store::BandTask& b : bands) {
      const fs::path local = root_ / b.results;
      if (objects_.remote())
        fetch_tree(b.results, local,
                   "the band of rows " + std::to_string(b.row0) + ".." + std::to_string(b.row0 + b.rows),
                   "is missing from the results");
      dirs.push_back(local.string());
    }
    spec.bands = std::move(dirs);
    log_event("{\"event\":\"assembling\",\"job\":\"" + task.id + "\",\"bands\":" + std::to_string(bands.size()) + "}");
    return false;
  }
  // (A job by sea is not split: its bends are settled once for the whole grid.)
  if (config_.jobs.split_cells <= 0 || !spec.base_report.empty() || !spec.base_name.empty() || spec.window ||
      !spec.barriers.empty())
    return false;
  // The grid and the plan, as the run would make them (the seeds read once more): a request that
  // fails here fails in its run below, with its own message.
  PreparedJob planned;
  try {
    JobHooks hooks;
    std::shared_ptr<std::atomic<bool>> cancel;
    {
      std::lock_guard lock(mutex_);
      cancel = running_.at(task.id).cancel;
    }
    hooks.cancel = cancel.get();
    planned = prepare_job(spec, limits_, hooks);
  } catch (const std::exception&) {
    return false;
  }
  if (!planned.plan.streamed || planned.grid.cell_count() <= config_.jobs.split_cells) return false;
  std::vector<store::BandTask> cut = cut_bands(planned.grid.width, planned.grid.height, config_.jobs.split_cells);
  if (cut.size() < 2) return false;
  // The cells are the job's: charged now, as a job planned on one daemon is.
  if (!task.charged) {
    task.charged = true;
    charge_planned_shared(task, planned.grid.cell_count());
  }
  const std::string message = "computing in " + std::to_string(cut.size()) + " bands on the shared queue";
  if (shared_->split(*task.lease, cut, message, now_rfc3339())) {
    log_event("{\"event\":\"split\",\"job\":\"" + task.id + "\",\"bands\":" + std::to_string(cut.size()) + "}");
    rec.message = message;
  } else {
    lose_lease(task.id);  // not ours any more: the job is as the store says
  }
  remove_dir(dir);
  return true;
}

JobRecord JobManager::run_band(Task& task, JobRecord rec) {
  const auto [row0, rows] = band_rows(task.payload);
  const store::Lease lease = *task.lease;
  const std::string key =
      task.parent + "/" + kBandsDir + "/" + std::to_string(row0) + "-a" + std::to_string(lease.attempt);
  const fs::path dir = root_ / key;
  std::shared_ptr<std::atomic<bool>> cancel;
  {
    std::lock_guard lock(mutex_);
    cancel = running_.at(task.id).cancel;
  }
  Outcome outcome;
  try {
    task.execution = load_execution(task.parent, lease.attempt, task.id);
    JobSpec spec = task.execution.spec;
    spec.outputs = OutputRequest{};
    spec.band = JobSpec::Band{row0, rows, dir.string()};
    JobHooks hooks;
    hooks.cancel = cancel.get();
    MemoryAccount::Reservation memory = memory_.open();
    hooks.reserve_memory = [&memory, cancel, id = task.id](int64_t bytes) {
      memory.need(bytes, true, cancel.get(), "band " + id);
    };
    outcome = execute(task.execution.run ? task.execution.run : runner_, spec, limits_, hooks, task.parent, dir);
  } catch (const Error& e) {
    outcome.error_kind = e.kind();
    outcome.message = valid_utf8(e.what());
  }
  task.execution.uploads.reset();
  EndState state = end_state(task.id);
  std::optional<ErrorKind> kind = outcome.error_kind;
  std::string why = outcome.message;
  upload_results(task.id, key, dir, "the band could not be stored", state, kind, why);
  if (objects_.remote()) remove_dir(dir);  // uploaded, or not to be kept
  if (state.ours() && state.shut_down) {
    try {
      shared_->release(lease, "queued again: the daemon running it shut down", now_rfc3339());
    } catch (...) {
      // The store is away: the band's lease expires, and a reaper queues it again.
    }
    remove_files(key);  // another attempt computes it afresh
    return rec;
  }
  bool published = false;
  if (state.ours()) {
    end_record(rec, kind, why, nullptr, state.timed_out, state.shut_down);
    const std::string job_message =
        "the band of rows " + std::to_string(row0) + ".." + std::to_string(row0 + rows) + " failed: " + rec.message;
    try {
      wait_out_store([&] {
        published = shared_->finish_band(lease, task.parent, rec, rec.status == JobStatus::successful ? key : "",
                                         job_message, now_rfc3339());
      });
    } catch (const Error&) {
      // Not published: the band's files go below; the job is as the store says.
    }
  }
  if (!published || rec.status != JobStatus::successful) remove_files(key);
  return rec;
}

}  // namespace rv::daemon
