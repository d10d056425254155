// The bounded worker pool that runs jobs, and the bookkeeping of their state in the JobStore.
//
// Queue: at most jobs.queue_length jobs wait; submit() beyond that throws rv::Error(busy).
// Timeouts: a job running longer than jobs.job_timeout_s is cancelled and marked failed.
// Dismissal: a queued job is dropped, a running job is cancelled through JobHooks::cancel; in
// every case the job's status becomes "dismissed" at once and its files are deleted (by the
// worker, for a running job, when run_job() returns).
// Thread safety: every public member may be called from any thread.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "auth/principal.hpp"
#include "daemon/server_execute.hpp"
#include "runtime/principal_usage.hpp"
#include "runtime/server_capacity.hpp"
#include "rv/field/error.hpp"
#include "rv/server.hpp"
#include "rv/store_jobs.hpp"

namespace rv::daemon {

// Inside a job's directory: what the job keeps for edits of it, and the files of the job it edits
// (removed when it ends).
inline constexpr const char* kEditBaseDir = "edit-base";
inline constexpr const char* kBaseSnapshotDir = "base-snapshot";

class JobManager {
 public:
  // Called on a worker thread once the job is finished (successful, failed or dismissed),
  // with its final record.
  using Done = std::function<void(const JobRecord&)>;

  // Each job reserves its memory estimate in `memory` as it goes (JobHooks::reserve_memory),
  // waiting there while other work holds it, and returns it when it ends.
  JobManager(JobStore& store, const ServerConfig& config, JobRunner runner, MemoryAccount& memory);
  ~JobManager();  // shutdown(0) if still running

  // The directory of a job's result files (the id must satisfy is_job_id()).
  std::filesystem::path job_dir(const std::string& id) const;

  // Records the job as `who`'s, accepted, and queues it. Throws rv::Error(busy) when the queue is
  // full or the server is shutting down, QuotaExceeded (over_quota) when `who` has
  // limits.jobs_per_principal jobs unfinished or the grid (when known up front) would take it
  // over its hourly cells; nothing is recorded then. The limits bind everyone but admins
  // authenticated as such. An edit (spec.base_name, the input baseJob)
  // names a successful job `who` may see (auth::may_see): its report and kept field are linked
  // into the new job's directory first (so deleting the base meanwhile breaks nothing), and
  // spec.base_report set to them; else invalid_argument (no such job, another's, not
  // successful, nothing kept).
  JobRecord submit(const std::string& id, Execution execution, const auth::Principal& who, Done on_done = {});

  // Queues work that is not a stored job (a live session's creation) on the same workers and
  // queue as jobs, counted as `who`'s job while it waits or runs: `run` is called on a worker
  // thread with `cancel`, which the watchdog sets after jobs.job_timeout_s (as for a job) and the
  // caller may set; if the server shuts down first, `dropped` is called instead. Neither may
  // throw. Throws as submit() (busy, QuotaExceeded for the principal's job count).
  void submit_work(const std::string& name, const auth::Principal& who, std::shared_ptr<std::atomic<bool>> cancel,
                   std::function<void()> run, std::function<void()> dropped);

  // Charges `cells` to `who`'s hourly allowance (nothing for admins signed in as such). Throws
  // QuotaExceeded when over it.
  void charge_cells(const auth::Principal& who, int64_t cells);

  // Dismisses a job; returns its record afterwards, or nullopt when there is no such job.
  std::optional<JobRecord> dismiss(const std::string& id);

  // Stops taking jobs, fails the queued ones, waits up to `grace` for the running ones, then
  // cancels them and joins the workers. Idempotent.
  void shutdown(std::chrono::duration<double> grace);

  // Seconds until `cells` fit in `principal`'s hourly allowance (CellAllowance::retry_after).
  int64_t cells_retry_after(const std::string& principal, int64_t cells) const;

  int running_count() const;
  int queued_count() const;

 private:
  struct Task {
    std::string id;
    Execution execution;
    Done on_done;
    std::string principal;
    bool charged = false;  // its cells were charged at submission (known up front), or need none
    // Work that is not a stored job (submit_work): run instead of the job; dropped on shutdown.
    std::function<void()> work;
    std::function<void()> dropped;
    std::shared_ptr<std::atomic<bool>> cancel;
  };
  struct Running {
    std::string principal;
    std::shared_ptr<std::atomic<bool>> cancel;
    std::chrono::steady_clock::time_point deadline;
    bool dismissed = false;
    bool timed_out = false;
    bool shutdown = false;
  };

  void worker_loop();
  void watchdog_loop();
  // The base job's files linked into job `id`'s directory; returns the linked report's path.
  // Call with mutex_ held.
  std::string snapshot_base(const std::string& base, const std::string& id, const auth::Principal& who) const;
  // Throws QuotaExceeded when `principal` has limits.jobs_per_principal jobs queued or running.
  // Call with mutex_ held.
  void check_job_count(const std::string& principal) const;
  // Runs one job to its end and returns its final record.
  JobRecord run_task(Task& task);
  // Records how the job ended (unless it was dismissed meanwhile), removing its files if it
  // failed; `rec` becomes the final record.
  void record_end(JobRecord& rec, const std::optional<ErrorKind>& error_kind, const std::string& message,
                  const nlohmann::json& report, const std::filesystem::path& dir);
  void update_progress(JobRecord& record, const std::string& stage, double fraction, bool validate, int& last_percent);

  JobStore& store_;
  const ServerConfig& config_;
  JobRunner runner_;
  MemoryAccount& memory_;
  JobLimits limits_;
  CellAllowance cells_;

  mutable std::mutex mutex_;
  std::condition_variable work_cv_;
  std::condition_variable idle_cv_;
  std::condition_variable watchdog_cv_;  // separate: a notify_one meant for a worker must not wake it
  std::deque<Task> queue_;
  std::map<std::string, Running> running_;
  bool stopping_ = false;
  bool joined_ = false;
  std::vector<std::thread> workers_;
  std::thread watchdog_;
};

}  // namespace rv::daemon
