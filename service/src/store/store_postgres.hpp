// The shared job store and queue on PostgreSQL: what lets several daemons share one queue, and
// any of them run, retry or serve any job (the config key `store` = "postgresql://...").
//
// The queue's rules (what each member below keeps):
// - Every transaction is short: a claim, a heartbeat, a fenced write. None stays open while cells
//   are computed.
// - Claiming takes the oldest job that may run now with FOR UPDATE SKIP LOCKED, in one statement
//   committed before any work: two daemons never claim the same attempt.
// - A claim is a lease: attempt n of job j held by holder h until lease_until (the database's
//   clock, so that the daemons' clocks need not agree). Heartbeats renew it.
// - Every write of a running job's state, progress and end is fenced: it names the job, the
//   attempt and the holder, and is applied only while that lease still holds the job (row count
//   checked). A worker that lost its lease (reaped, dismissed) publishes nothing, and a job's end
//   is written once.
// - The reaper puts jobs whose lease expired back in the queue after a backoff, or fails them
//   once their attempts are used (or when they cannot be retried: work only their daemon held).
//   It touches running jobs only: a finished or dismissed job is never reaped.
// - Dismissal marks the job dismissed whatever it was doing, and notifies: its holder learns it
//   from the notification, or at the latest from its next heartbeat (which no longer finds it).
// - Schema migrations are versioned and applied at open under an advisory lock: daemons starting
//   together apply each once.
// Clock: lease lengths, backoffs and retention in seconds; the record's own RFC 3339 texts are
// written by the daemons as the SQLite store's are.
// Thread safety: every member may be called from any thread (a pool of connections).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "rv/store_jobs.hpp"
#include "store/pg_client.hpp"

namespace rv::store {

// The schema version this build writes (its migrations' count).
int postgres_schema_version();

// A job's place in the queue, besides its record.
struct QueueEntry {
  std::string kind = "job";  // "job"; split jobs add "band" and "assemble" tasks
  std::string parent;        // the job a task belongs to; "" for a job
  std::string payload;       // the storage key of the stored request; "" = nothing to rerun
  bool retryable = true;     // false: only the daemon that took it can run it (a live session's)
  int max_attempts = 3;      // claims before a job whose daemons keep disappearing fails
  bool exempt = false;       // its principal was exempt from the limits when it submitted (an admin)
};

// What an admission check sees, read under the principal's lock: nothing of it changes until
// the insert commits.
struct AdmissionView {
  int64_t principal_unfinished = 0;  // the principal's jobs accepted or running
  int64_t queued = 0;                // every job waiting in the queue (accepted)
  // The principal's charges of the hour before `now`: when, and how many cells.
  std::vector<std::pair<std::chrono::system_clock::time_point, int64_t>> charges;
  std::chrono::system_clock::time_point now;  // the database's clock
};

// A claimed attempt: what the worker runs, and the lease it writes under.
struct Lease {
  std::string id;
  int attempt = 0;
  std::string holder;
};
struct Claim {
  JobRecord record;
  QueueEntry entry;
  Lease lease;
  bool split = false;  // a job split into bands (claimed to be assembled)
};

// How the reaper left a job whose lease expired.
struct Reaped {
  std::string id;
  int attempt = 0;
  bool requeued = false;  // false: failed
};

// A band of a split job (kind "band"): full-width rows [row0, row0 + rows) of the job's grid.
struct BandTask {
  std::string id;  // its own row's id (a job id's form)
  int64_t row0 = 0;
  int64_t rows = 0;
  JobStatus status = JobStatus::accepted;
  std::string results;  // where its field was stored, once successful
  std::string message;
};

// A job deleted by retention: its stored objects go next.
struct Expired {
  std::string id;
  std::string payload;
  std::string results;
};

class PostgresJobStore final : public JobRecords {
 public:
  // Connects (up to `pool_size` connections) and brings the schema to this build's version.
  // Throws rv::Error(busy) when the server cannot be reached, rv::Error(unsupported) when the
  // database's schema is newer than this build's.
  PostgresJobStore(pg::ConnectInfo info, int pool_size);

  // The schema version found at open (before migrating) and now.
  int schema_version_before() const { return version_before_; }

  // Inserts the job as accepted, after `admit` saw the principal's and the queue's counts (under
  // an advisory lock on the principal, so that concurrent submissions to any daemon see each
  // other): `admit` throws to refuse, and nothing is inserted. Wakes the listeners.
  void enqueue(const JobRecord& rec, const QueueEntry& entry,
               const std::function<void(const AdmissionView&)>& admit = {});
  // Inserts the job as running under a fresh lease of `holder`: work that the daemon taking the
  // request runs itself (a synchronous execution, a live session's job).
  // Admitted as enqueue's.
  Lease insert_running(const JobRecord& rec, const QueueEntry& entry, const std::string& holder, double lease_s,
                       const std::function<void(const AdmissionView&)>& admit = {});

  // The oldest job that may run now, as attempt n+1 held by `holder` for `lease_s`; nullopt when
  // none waits. The record comes back running (started, message "running").
  std::optional<Claim> claim(const std::string& holder, double lease_s, const std::string& now_text);

  // Renews `holder`'s leases of the jobs `ids` (those its workers still run or wait to run: a
  // lease its daemon gave up on is left to expire); returns the leases still held (a job missing
  // from them was reaped or dismissed: its worker must stop and publish nothing). A lease that
  // expired but was not reaped yet is renewed: nobody else holds it.
  std::vector<Lease> heartbeat(const std::string& holder, double lease_s, const std::vector<std::string>& ids);

  // Fenced writes: applied only while `lease` holds the job; false when it no longer does.
  // write_running: progress, message, cells and `updated` of a running job.
  bool write_running(const Lease& lease, const JobRecord& rec);
  // finish: the job's end (status successful or failed) and where its results were published.
  bool finish(const Lease& lease, const JobRecord& rec, const std::string& results);
  // The cells a job learnt once planned, charged to its principal: `admit` sees the principal's
  // hour as for enqueue, and throws to refuse. False when the lease was lost.
  bool charge_planned(const Lease& lease, int64_t cells, const std::function<void(const AdmissionView&)>& admit);

  // Charges `cells` that are no job's (a live session's grid) to `principal`'s hour, after `admit`
  // saw the hour as for enqueue (and may throw to refuse).
  void charge(const std::string& principal, int64_t cells, const std::function<void(const AdmissionView&)>& admit);

  // Puts running jobs whose lease expired back in the queue (run again after backoff_s x 2^(n-1)
  // for attempt n) or fails them; `now_text` is the record's time.
  std::vector<Reaped> reap(double backoff_s, const std::string& now_text);

  // Marks the job dismissed (any state but dismissed) with the message `message` makes of its
  // record before, and notifies its holder. Returns the record before and after; nullopt when
  // there is no such job.
  std::optional<std::pair<JobRecord, JobRecord>> dismiss(const std::string& id,
                                                         const std::function<std::string(const JobRecord&)>& message,
                                                         const std::string& now_text);
  // Split jobs (issue 55). split(): under the job's lease, its bands queued as tasks (kind
  // "band", the job as parent, payload "<row0>:<rows>", the job's principal and attempts), and
  // the job left running without a holder (no lease to renew or reap: its bands have theirs)
  // until its bands end; false when the lease was lost (nothing queued). bands(): a job's bands,
  // by row. finish_band(): a band's end, fenced as finish(); in the same transaction, when every
  // band of the job succeeded the job is queued again (to be assembled: its next claim finds
  // its bands successful; not counted against its attempts), and when this band failed the job
  // fails with `job_message` and its other bands are dismissed. The reaper fails a job whose band
  // it failed, likewise.
  bool split(const Lease& job, const std::vector<BandTask>& bands, const std::string& message,
             const std::string& now_text);
  std::vector<BandTask> bands(const std::string& job) const;
  bool finish_band(const Lease& band, const std::string& job, const JobRecord& rec, const std::string& results,
                   const std::string& job_message, const std::string& now_text);
  // Hands a running job back to the queue at once (its daemon is shutting down): fenced, and not
  // counted against its attempts. False when the lease was lost.
  bool release(const Lease& lease, const std::string& message, const std::string& now_text);

  // Deletes jobs finished more than `retention_s` ago (at most `limit`), with their tasks.
  std::vector<Expired> expire(double retention_s, int limit);

  // The record, with where its results were published (JobRecord::results).
  std::optional<JobRecord> get(const std::string& id) const override;
  // The records of those of `ids` that exist, in no order: one question for many (the sweep's).
  std::vector<JobRecord> get_many(const std::vector<std::string>& ids) const;
  std::optional<QueueEntry> entry(const std::string& id) const;
  // How many jobs and tasks run now, on any daemon.
  int64_t running() const;
  std::vector<JobRecord> list(int limit, int offset, const std::vector<JobStatus>& status = {},
                              const std::string& principal = "") const override;
  // The jobs' charges since `since`, and every other charge of the last hour.
  std::vector<CellCharge> charges_since(const std::string& since) const override;
  std::vector<std::pair<std::string, int64_t>> count_by_principal() const override;
  // The daemons: each says where it answers (its heartbeat renews it), so that one can point a
  // client to another (a live session is held by one daemon). daemon(): its URL and the seconds
  // since it was last seen; nullopt for a name never announced.
  void announce(const std::string& name, const std::string& url, const std::string& holder);
  std::optional<std::pair<std::string, double>> daemon(const std::string& name) const;

  // The payload and results keys every stored job names (the orphan sweep keeps these).
  std::vector<std::string> referenced_keys() const;

  // The notification channels: a job was queued (payload: its id), a job was dismissed (its id).
  static constexpr const char* kQueuedChannel = "rv_jobs_queued";
  static constexpr const char* kDismissedChannel = "rv_jobs_dismissed";
  const pg::ConnectInfo& connect_info() const { return pool_.info(); }

 private:
  AdmissionView admission_view(pg::Transaction& tx, const std::string& principal) const;
  // The job as accepted, or as running under `lease` (not null) for `lease_s`.
  void insert(const JobRecord& rec, const QueueEntry& entry, const std::function<void(const AdmissionView&)>& admit,
              const Lease* lease, double lease_s);
  void migrate();
  mutable pg::Pool pool_;
  int version_before_ = 0;
};

}  // namespace rv::store
