// The bounded worker pool that runs jobs, and the bookkeeping of their state in the JobStore.
//
// Queue: at most jobs.queue_length jobs wait; submit() beyond that throws rv::Error(busy).
// Timeouts: a job running longer than jobs.job_timeout_s is cancelled and marked failed.
// Dismissal: a queued job is dropped, a running job is cancelled through JobHooks::cancel; in
// every case the job's status becomes "dismissed" at once and its files are deleted (by the
// worker, for a running job, when run_job() returns).
// Shared store (config `store` a postgresql:// URI; issue 55): jobs submitted for later wait in
// the database's queue with their request stored in the results folder, and any daemon's free
// worker claims them (woken by a notification, or polling every jobs.poll_s). A claimed job runs
// under a lease that a heartbeat renews every third of jobs.lease_s; every write of its state is
// fenced by the lease, and a worker that lost it (reaped after its daemon stalled, or dismissed on
// another daemon) cancels its computation and publishes nothing. A shared job's files are objects
// of `results` (a folder every daemon mounts, or an s3:// bucket): <id>/request.json (written
// before its row), <id>/base-snapshot/ (an edit's copy of its base), <id>/<attempt>/ (its results).
// An attempt writes into data_dir's local folder first when `results` is a bucket, and uploads
// before its end is published (an upload that fails fails the job with the storage's message). The reaper of every
// daemon requeues expired leases with backoff; a daemon shutting down hands its running jobs back. Synchronous
// executions and a live session's jobs run on the daemon that took them (their client or state is here): they are
// recorded running at once, and fail if that daemon stops. Thread safety: every public member may be called from any
// thread.
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
#include "store/object_store.hpp"
#include "store/store_postgres.hpp"

namespace rv::daemon {

// Inside a job's directory: what the job keeps for edits of it, and the files of the job it edits
// (removed when it ends).
inline constexpr const char* kEditBaseDir = "edit-base";
inline constexpr const char* kBaseSnapshotDir = "base-snapshot";
inline constexpr const char* kBandsDir = "bands";  // a split job's bands, "<row0>-a<attempt>" each

// Removes a job's folder or an attempt's, best effort (a leftover costs disk; a shared store's
// sweep finds it).
void remove_dir(const std::filesystem::path& dir);
// Tells a waiting client that its job ended; a callback that throws is logged and dropped.
void notify_done(const std::function<void(const JobRecord&)>& on_done, const JobRecord& record);
// A new job's record, accepted (queued) now, as `who`'s.
JobRecord accepted_record(const std::string& id, const Execution& execution, const auth::Principal& who);
// The limits bind every principal but the admins who signed in as such (on a server without
// authentication the anonymous principal is everyone, and bound by them).
bool exempt_from_limits(const auth::Principal& who);
// The refusal of a principal with `count` jobs unfinished, at the most `limit`.
QuotaExceeded too_many_jobs(int64_t count, int limit);

// How a job ended, before it is recorded.
struct Outcome {
  std::optional<ErrorKind> error_kind;
  std::string message;
  JobResult result;
};
// Runs the job into `dir` and writes its report there; every exception becomes an Outcome (none
// leaves a worker).
Outcome execute(const JobRunner& runner, const JobSpec& spec, const JobLimits& limits, const JobHooks& hooks,
                const std::string& id, const std::filesystem::path& dir);
// The message of a failed job as its client should read it (no paths of this server's).
std::string client_message(const Error& e, const std::string& id, const std::filesystem::path& dir);

class JobManager {
 public:
  // Called on a worker thread once the job is finished (successful, failed or dismissed),
  // with its final record.
  using Done = std::function<void(const JobRecord&)>;

  // Each job reserves its memory estimate in `memory` as it goes (JobHooks::reserve_memory),
  // waiting there while other work holds it, and returns it when it ends.
  JobManager(JobStore& store, const ServerConfig& config, JobRunner runner, MemoryAccount& memory);
  // On the shared store: `holder` names this process's leases (fresh at every start).
  // `name` and `url` say where this daemon answers (announced to the other daemons).
  JobManager(store::PostgresJobStore& shared, const ServerConfig& config, JobRunner runner, MemoryAccount& memory,
             std::string holder, std::string name, std::string url);
  ~JobManager();  // shutdown(0) if still running

  // The local directory of a job's files (the id must satisfy is_job_id()): its results with the
  // SQLite store; with a shared store its stored request, base snapshot and attempts (on a bucket:
  // a running attempt's files and its base snapshot before upload, or after download).
  std::filesystem::path job_dir(const std::string& id) const;
  // A finished job's result file `name` (a file name of this program's), open for reading by
  // range wherever the results are; nullptr when there is none. Throws rv::Error(io) when the
  // storage cannot be asked, internal for a record naming damaged results.
  std::unique_ptr<store::ObjectReader> open_result(const JobRecord& rec, const std::string& name) const;
  // Where the daemon `name` of a shared store answers, as it announced itself ("" when unknown
  // or without a shared store; never throws).
  std::string daemon_url(const std::string& name) const;
  // Whether the shared store answered this daemon's last heartbeat (always true without one).
  bool store_reachable() const { return store_reachable_.load(); }
  // Where the results are kept ("s3" for a bucket, else "folder"), and whether the last probe of
  // the sweep (a shared store's, every min(60 s, jobs.orphan_grace_s)) reached them (always true
  // without a shared store).
  const char* results_kind() const { return objects_.remote() ? "s3" : "folder"; }
  bool results_reachable() const { return results_reachable_.load(); }
  // The bytes free to this daemon on the file system of its jobs' local directories (where every
  // job writes its files, also before they go to a bucket); -1 when the system cannot say.
  int64_t disk_free_bytes() const;
  // Whether `free` (disk_free_bytes()) is below limits.min_free_disk_bytes (false when unknown or
  // without a floor); logs a change since the last call.
  bool disk_low(int64_t free) const;

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
    // A shared store's job: the lease it runs under, and whether its execution must still be
    // parsed from the stored request (claimed from the queue).
    std::optional<store::Lease> lease;
    bool from_queue = false;
    std::string kind = "job";                         // a shared store's task: "job" or "band"
    std::string parent;                               // a band's job
    std::string payload;                              // a band's "<row0>:<rows>"
    bool split = false;                               // a job split into bands: to be assembled
    JobRecord claimed;                                // the record as claimed or inserted running
    std::chrono::steady_clock::time_point leased_at;  // when the claim had committed
    auth::Principal who;                              // for the charge of cells planned later
  };
  struct Running {
    std::string principal;
    std::shared_ptr<std::atomic<bool>> cancel;
    std::chrono::steady_clock::time_point deadline;
    bool dismissed = false;
    bool timed_out = false;
    bool shutdown = false;
    std::optional<store::Lease> lease;
    bool lost = false;  // the lease no longer holds the job: publish nothing
    std::chrono::steady_clock::time_point leased_at;
    bool ended = false;  // its end is recorded (a client may see it finished): no longer counted
  };

  // Waits for the next task (the local queue first, then a shared store's) and registers it as
  // running; false when the manager is stopping.
  bool next_task(Task& task);
  void worker_loop();
  void watchdog_loop();
  void start_threads();
  // Shared store (server_jobs_shared.cpp).
  JobRecord submit_shared(const std::string& id, Execution execution, const auth::Principal& who, Done on_done);
  // Admission on the shared store: the queue's length (when `queued`), the principal's jobs and
  // hourly cells (`cells` > 0) as every daemon's submissions left them. Throws busy / QuotaExceeded.
  // `new_job`: a submission (counted against the principal's jobs), else a charge of cells
  // planned later.
  void admit_shared(const store::AdmissionView& v, const auth::Principal& who, int64_t cells, bool queued,
                    bool new_job) const;
  // Whether the shared store holds job `id` (false when it cannot be asked).
  bool stored(const std::string& id) const;
  // The next job of the shared queue as a task; nullopt when none waits or the store is away.
  std::optional<Task> claim_shared();
  // The claimed job's execution, from its stored request (of job `id`; its uploads staged under
  // "<staging>-a<attempt>", the job's id unless given).
  Execution load_execution(const std::string& id, int attempt, const std::string& staging = "") const;
  // Split jobs (server_jobs_split.cpp). A claimed job above jobs.split_cells whose plan streams is
  // queued as bands of whole rows and left to them (true: the task ends here, the job running
  // without a holder); a job whose bands are all computed is assembled from them (its execution
  // reads them: `spec`, the job as it runs here, gains them). Without jobs.split_cells, or for a
  // job that cannot be split, nothing happens.
  bool split_or_assemble(Task& task, JobRecord& rec, const std::filesystem::path& dir, JobSpec& spec);
  // Runs a band task to its end (computed, stored under "<job>/bands/<row0>-a<attempt>", ended
  // fenced by its lease); returns its final record.
  JobRecord run_band(Task& task, JobRecord rec);
  std::optional<JobRecord> dismiss_shared(const std::string& id);
  // Writes the running job's record (false for a dismissed one): fenced by its lease on a shared
  // store (false, and the job cancelled, when the lease was lost), plainly on the SQLite store.
  bool write_running(const std::string& id, const JobRecord& rec);
  // Charges the cells a claimed job learnt once planned (see run_task), waiting out the store.
  void charge_planned_shared(const Task& task, int64_t cells);
  // Marks a running job's lease lost and cancels its computation.
  void lose_lease(const std::string& id);
  // Hands a claimed job back to the shared queue (best effort: else its lease expires).
  void release_lease(const store::Lease& lease, const std::string& message);
  // How a shared task stands at its end, as the running table says.
  struct EndState {
    bool dismissed = false, lost = false, timed_out = false, shut_down = false;
    store::Lease lease;
    std::shared_ptr<std::atomic<bool>> cancel;
    bool ours() const { return !dismissed && !lost; }  // its end is still this daemon's to publish
  };
  EndState end_state(const std::string& id) const;
  // On a bucket, uploads a finished task's folder `dir` as `key` before its end is published,
  // unless it failed (`kind` set) or was stopped. A dismissal, a lost lease, a timeout or a
  // shutdown stops the upload as it stops a computation; a storage that fails turns the outcome
  // into the failure (`kind`, `why` prefixed by `what_failed`), `state` is read again, and what
  // went up is removed. True when the upload failed.
  bool upload_results(const std::string& id, const std::string& key, const std::filesystem::path& dir,
                      const std::string& what_failed, EndState& state, std::optional<ErrorKind>& kind,
                      std::string& why);
  // Runs `write`, a write to the shared store, again every half second while the store is away
  // (busy), for a minute or two leases, whichever is longer: until a reaper has requeued the job
  // its fenced end may still be published, and the heartbeat renews the lease meanwhile. False
  // when the store stayed away; other errors are thrown.
  bool wait_out_store(const std::function<void()>& write) const;
  // How a shared job ended, published under its lease (see record_end).
  void record_end_shared(JobRecord& rec, const std::optional<ErrorKind>& error_kind, const std::string& message,
                         const nlohmann::json& report, const std::filesystem::path& dir);
  // The jobs whose lease a heartbeat or notification says is gone: cancel, publish nothing.
  void leases_lost(const std::vector<store::Lease>& held, std::chrono::steady_clock::time_point asked_at);
  void learn_dismissed(const std::string& id);
  void heartbeat_loop();
  void listen_loop();
  // The key below `results` of a finished job's result files: "<id>/<attempt>" on a shared store,
  // the id on the SQLite store.
  std::string results_prefix(const JobRecord& rec) const;
  // Removes the files below `prefix` (a job "<id>", or "<id>/<part>"): the local folder, and on a
  // bucket its objects too; best effort (logged; a shared store's sweep finds what is left).
  void remove_files(const std::string& prefix) const;
  // On a bucket: downloads job `id`'s base snapshot into its local folder before an edit runs.
  void fetch_base(const std::string& id) const;
  // Copies the tree of objects below `key` into the local folder `local` (emptied first), whole or
  // not at all: rv::Error(io) "<what> cannot be read: <why>" (the folder removed again) or "<what>
  // <missing>" when nothing is there.
  void fetch_tree(const std::string& key, const std::filesystem::path& local, const std::string& what,
                  const std::string& missing) const;
  // Retention and the orphan sweep, every minute (or jobs.orphan_grace_s if shorter), on a thread
  // of their own; the heartbeat's thread runs the reaper.
  void sweep_loop();
  void sweep_orphans();
  // Asks the results storage whether it is there (ObjectStore::probe; a shared folder: whether it
  // is a folder) into results_reachable_, logging a change.
  void probe_results();
  // The base job's files copied (linked, in a folder) into job `id`'s base snapshot; returns the
  // local path its report has when the job runs. Call with mutex_ held.
  std::string snapshot_base(const std::string& base, const std::string& id, const auth::Principal& who) const;
  // Throws rv::Error(busy) when the workers and the local queue are full. Call with mutex_ held.
  void check_capacity() const;
  // Throws rv::Error(busy) when the jobs' file system has less free space than
  // limits.min_free_disk_bytes. Call without mutex_ held: a shared folder's file system may be a
  // network one, and /health takes mutex_ too.
  void check_disk() const;
  // Throws QuotaExceeded when `principal` has limits.jobs_per_principal jobs queued or running.
  // Call with mutex_ held.
  void check_job_count(const std::string& principal) const;
  // Runs one job to its end and returns its final record.
  JobRecord run_task(Task& task);
  // Records how the job ended (unless it was dismissed meanwhile), removing its files if it
  // failed; `rec` becomes the final record.
  // The final record of a job that ended with `error_kind` (none = successful): status, message,
  // report, the time; a timeout or a shutdown said as such.
  void end_record(JobRecord& rec, const std::optional<ErrorKind>& error_kind, const std::string& message,
                  const nlohmann::json& report, bool timed_out, bool shut_down) const;
  void record_end(JobRecord& rec, const std::optional<ErrorKind>& error_kind, const std::string& message,
                  const nlohmann::json& report, const std::filesystem::path& dir);
  void update_progress(JobRecord& record, const std::string& stage, double fraction, bool validate, int& last_percent);

  JobStore* store_ = nullptr;                  // the SQLite store, or
  store::PostgresJobStore* shared_ = nullptr;  // the shared one
  std::string holder_, name_, url_;
  std::filesystem::path root_;  // the jobs' local directories
  store::ObjectStore objects_;  // where the jobs' files are kept (root_ itself, but on a bucket)
  std::atomic<bool> store_reachable_{true};
  mutable std::atomic<bool> disk_low_{false};  // as disk_low() last found it
  std::atomic<bool> results_reachable_{true};  // as probe_results() last found them
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
  uint64_t queue_hint_ = 0;  // counts the shared queue's notifications
  std::vector<std::thread> workers_;
  std::thread watchdog_;
  std::thread heartbeat_, listener_, sweeper_;  // shared store only
  std::atomic<bool> shared_stop_{false};
  std::mutex shared_mutex_;  // for shared_cv_ only
  std::condition_variable shared_cv_;
};

}  // namespace rv::daemon
