#include "store/store_postgres.hpp"

#include <array>
#include <cmath>

#include "rv/field/error.hpp"
#include "store/job_columns.hpp"

namespace rv::store {
namespace {

// Each entry is one schema version, applied in its own transaction. Never edit one that has
// shipped: add the next.
// The record's columns mirror the SQLite store's (the same texts); the queue's columns keep the
// database's time (timestamptz) so that leases and retention use one clock.
constexpr std::array<const char*, 1> kMigrations = {
    R"sql(
CREATE TABLE rv_jobs (
  id text PRIMARY KEY,
  process_id text NOT NULL,
  status text NOT NULL CHECK (status IN ('accepted','running','successful','failed','dismissed')),
  message text NOT NULL,
  error_kind text NOT NULL,
  progress integer NOT NULL,
  created text NOT NULL,
  started text NOT NULL,
  finished text NOT NULL,
  updated text NOT NULL,
  inputs text NOT NULL,
  outputs text NOT NULL,
  transmission text NOT NULL,
  report text NOT NULL,
  formats text NOT NULL,
  principal text NOT NULL,
  cells bigint NOT NULL,
  kind text NOT NULL DEFAULT 'job',
  parent text REFERENCES rv_jobs(id) ON DELETE CASCADE,
  payload text NOT NULL DEFAULT '',
  results text NOT NULL DEFAULT '',
  retryable boolean NOT NULL DEFAULT true,
  attempt integer NOT NULL DEFAULT 0,
  max_attempts integer NOT NULL DEFAULT 3,
  exempt boolean NOT NULL DEFAULT false,
  holder text,
  lease_until timestamptz,
  run_after timestamptz NOT NULL DEFAULT now(),
  created_at timestamptz NOT NULL DEFAULT now(),
  finished_at timestamptz
);
CREATE INDEX rv_jobs_waiting ON rv_jobs (run_after, created_at) WHERE status = 'accepted';
CREATE INDEX rv_jobs_leases ON rv_jobs (lease_until) WHERE status = 'running';
CREATE INDEX rv_jobs_holder ON rv_jobs (holder) WHERE status = 'running';
CREATE INDEX rv_jobs_principal ON rv_jobs (principal, created_at);
CREATE INDEX rv_jobs_listing ON rv_jobs (created DESC, id);
CREATE INDEX rv_jobs_finished ON rv_jobs (finished_at) WHERE finished_at IS NOT NULL;
CREATE INDEX rv_jobs_parent ON rv_jobs (parent) WHERE parent IS NOT NULL;
CREATE TABLE rv_charges (
  id bigserial PRIMARY KEY,
  principal text NOT NULL,
  cells bigint NOT NULL,
  created_at timestamptz NOT NULL DEFAULT now()
);
CREATE INDEX rv_charges_principal ON rv_charges (principal, created_at);
CREATE TABLE rv_daemons (
  name text PRIMARY KEY,
  url text NOT NULL,
  holder text NOT NULL,
  seen_at timestamptz NOT NULL DEFAULT now()
);
)sql",
};

// Any fixed number: the lock that serialises migrations between daemons starting together.
constexpr const char* kMigrationLock = "7267766f726f6e6f";  // pg_advisory_lock takes a bigint

// The record's columns and where its results are: what every read selects.
const std::string kSelect = std::string(kRecordColumns) + ", results";
constexpr int kSelectCount = kRecordColumnCount + 1;

JobRecord record_at(const pg::Result& r, int row) {
  JobRecord rec = record_from_texts([&](int col) { return r.text(row, col); });
  rec.results = r.text(row, kRecordColumnCount);
  return rec;
}

pg::Params record_params(const JobRecord& rec) {
  pg::Params p;
  for (std::string& t : record_texts(rec)) p.emplace_back(std::move(t));
  return p;
}

std::string seconds_param(double s) {
  // Text the server reads as a double precision number of seconds.
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f", std::isfinite(s) && s > 0 ? s : 0.0);
  return buf;
}

// A text[] literal of job ids (the daemons' own, hex), each quoted all the same.
std::string text_array(const std::vector<std::string>& ids) {
  std::string array = "{";
  for (const std::string& id : ids) {
    if (id.find_first_of("\"\\{},") != std::string::npos) throw Error(ErrorKind::internal, "not a job id: " + id);
    array += (array.size() > 1 ? ",\"" : "\"") + id + "\"";
  }
  return array + "}";
}

std::chrono::system_clock::time_point from_epoch(double s) {
  return std::chrono::system_clock::time_point(
      std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(s)));
}

}  // namespace

int postgres_schema_version() { return static_cast<int>(kMigrations.size()); }

PostgresJobStore::PostgresJobStore(pg::ConnectInfo info, int pool_size) : pool_(std::move(info), pool_size) {
  migrate();
}

void PostgresJobStore::migrate() {
  auto c = pool_.acquire();
  // Session-level lock: released by the unlock below, or by the server if this process dies.
  c->exec(std::string("SELECT pg_advisory_lock(x'") + kMigrationLock + "'::bigint)");
  try {
    c->exec(
        "CREATE TABLE IF NOT EXISTS rv_schema_migrations (version integer PRIMARY KEY,"
        " applied_at timestamptz NOT NULL DEFAULT now())");
    const pg::Result v = c->exec("SELECT coalesce(max(version), 0) FROM rv_schema_migrations");
    version_before_ = static_cast<int>(v.integer(0, 0));
    if (version_before_ > postgres_schema_version())
      throw Error(ErrorKind::unsupported, "the job store's schema is version " + std::to_string(version_before_) +
                                              ", newer than this build's " + std::to_string(postgres_schema_version()) +
                                              "; run a daemon of the newer build");
    for (int version = version_before_ + 1; version <= postgres_schema_version(); ++version) {
      pg::Transaction tx(*c);
      tx.exec_script(kMigrations[static_cast<size_t>(version - 1)]);
      tx.exec("INSERT INTO rv_schema_migrations (version) VALUES ($1)", {pg::param(int64_t{version})});
      tx.commit();
    }
  } catch (...) {
    if (c->ok()) c->exec(std::string("SELECT pg_advisory_unlock(x'") + kMigrationLock + "'::bigint)");
    throw;
  }
  c->exec(std::string("SELECT pg_advisory_unlock(x'") + kMigrationLock + "'::bigint)");
}

AdmissionView PostgresJobStore::admission_view(pg::Transaction& tx, const std::string& principal) const {
  // Concurrent submissions of one principal, on any daemon, queue here: each sees the others'
  // committed jobs. The lock ends with the transaction.
  tx.exec("SELECT pg_advisory_xact_lock(hashtextextended('rv_principal:' || $1::text, 0))", {principal});
  AdmissionView v;
  const pg::Result counts = tx.exec(
      "SELECT (SELECT count(*) FROM rv_jobs WHERE principal = $1 AND kind = 'job'"
      "          AND status IN ('accepted','running')),"
      "       (SELECT count(*) FROM rv_jobs WHERE status = 'accepted' AND kind = 'job'),"
      "       extract(epoch FROM now())",
      {principal});
  v.principal_unfinished = counts.integer(0, 0);
  v.queued = counts.integer(0, 1);
  v.now = from_epoch(std::stod(counts.text(0, 2)));
  // The hour's charges: its jobs' cells (not those refused over the allowance once planned), and
  // the charges that are no job (a live session's grid).
  const pg::Result charges = tx.exec(
      "SELECT extract(epoch FROM at), cells FROM ("
      " SELECT created_at AS at, cells FROM rv_jobs WHERE principal = $1 AND kind = 'job'"
      "  AND created_at > now() - interval '1 hour' AND cells > 0"
      "  AND NOT (status = 'failed' AND error_kind = 'over_quota')"
      " UNION ALL SELECT created_at, cells FROM rv_charges WHERE principal = $1"
      "  AND created_at > now() - interval '1 hour') c ORDER BY at",
      {principal});
  for (int i = 0; i < charges.rows(); ++i)
    v.charges.emplace_back(from_epoch(std::stod(charges.text(i, 0))), charges.integer(i, 1));
  return v;
}

void PostgresJobStore::insert(const JobRecord& rec, const QueueEntry& entry,
                              const std::function<void(const AdmissionView&)>& admit, const Lease* lease,
                              double lease_s) {
  auto c = pool_.acquire();
  pg::Transaction tx(*c);
  if (admit) admit(admission_view(tx, rec.principal));
  JobRecord row = rec;
  row.status = lease ? JobStatus::running : JobStatus::accepted;
  pg::Params p = record_params(row);
  p.push_back(entry.kind);
  p.push_back(entry.parent.empty() ? std::nullopt : std::optional<std::string>(entry.parent));
  p.push_back(entry.payload);
  p.push_back(entry.retryable ? "true" : "false");
  p.push_back(pg::param(int64_t{entry.max_attempts}));
  p.push_back(entry.exempt ? "true" : "false");
  p.push_back(pg::param(int64_t{lease ? lease->attempt : 0}));
  p.push_back(lease ? std::optional<std::string>(lease->holder) : std::nullopt);
  p.push_back(seconds_param(lease_s));
  tx.exec(std::string("INSERT INTO rv_jobs (") + kRecordColumns +
              ", kind, parent, payload, retryable, max_attempts, exempt, attempt, holder, lease_until) VALUES"
              " ($1,$2,$3,$4,$5,$6,$7,$8,$9,$10,$11,$12,$13,$14,$15,$16,$17,$18,$19,$20,$21,$22,$23,$24,$25,"
              "  CASE WHEN $25::text IS NULL THEN NULL ELSE now() + $26::double precision * interval '1 second' END)",
          p);
  if (!lease) tx.exec(std::string("SELECT pg_notify('") + kQueuedChannel + "', $1)", {rec.id});
  tx.commit();
}

void PostgresJobStore::enqueue(const JobRecord& rec, const QueueEntry& entry,
                               const std::function<void(const AdmissionView&)>& admit) {
  insert(rec, entry, admit, nullptr, 0);
}

Lease PostgresJobStore::insert_running(const JobRecord& rec, const QueueEntry& entry, const std::string& holder,
                                       double lease_s, const std::function<void(const AdmissionView&)>& admit) {
  const Lease lease{rec.id, 1, holder};
  insert(rec, entry, admit, &lease, lease_s);
  return lease;
}

std::optional<Claim> PostgresJobStore::claim(const std::string& holder, double lease_s, const std::string& now_text) {
  auto c = pool_.acquire();
  // One statement, committed on its own: the lock SKIP LOCKED honours lasts only as long as it.
  const pg::Result r = c->exec(
      "UPDATE rv_jobs SET status = 'running', attempt = attempt + 1, holder = $1,"
      " lease_until = now() + $2::double precision * interval '1 second',"
      " started = $3, updated = $3, message = 'running', progress = 0"
      " WHERE id = (SELECT id FROM rv_jobs WHERE status = 'accepted' AND run_after <= now()"
      "             ORDER BY created_at, id LIMIT 1 FOR UPDATE SKIP LOCKED)"
      " RETURNING " +
          kSelect +
          ", kind, coalesce(parent, ''), payload, retryable, max_attempts, attempt, exempt,"
          " EXISTS (SELECT 1 FROM rv_jobs b WHERE b.parent = rv_jobs.id AND b.kind = 'band')",
      {holder, seconds_param(lease_s), now_text});
  if (r.rows() == 0) return std::nullopt;
  Claim out;
  out.record = record_at(r, 0);
  const int k = kSelectCount;
  out.entry.kind = r.text(0, k);
  out.entry.parent = r.text(0, k + 1);
  out.entry.payload = r.text(0, k + 2);
  out.entry.retryable = r.boolean(0, k + 3);
  out.entry.max_attempts = static_cast<int>(r.integer(0, k + 4));
  out.lease = Lease{out.record.id, static_cast<int>(r.integer(0, k + 5)), holder};
  out.entry.exempt = r.boolean(0, k + 6);
  out.split = r.boolean(0, k + 7);
  return out;
}

std::vector<Lease> PostgresJobStore::heartbeat(const std::string& holder, double lease_s,
                                               const std::vector<std::string>& ids) {
  if (ids.empty()) return {};
  const std::string array = text_array(ids);
  auto c = pool_.acquire();
  const pg::Result r = c->exec(
      "UPDATE rv_jobs SET lease_until = now() + $2::double precision * interval '1 second'"
      " WHERE holder = $1 AND status = 'running' AND id = ANY($3::text[]) RETURNING id, attempt",
      {holder, seconds_param(lease_s), array});
  std::vector<Lease> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(Lease{r.text(i, 0), static_cast<int>(r.integer(i, 1)), holder});
  return out;
}

bool PostgresJobStore::write_running(const Lease& lease, const JobRecord& rec) {
  auto c = pool_.acquire();
  const pg::Result r = c->exec(
      "UPDATE rv_jobs SET progress = $4, message = $5, cells = $6, updated = $7"
      " WHERE id = $1 AND attempt = $2 AND holder = $3 AND status = 'running'",
      {lease.id, pg::param(int64_t{lease.attempt}), lease.holder, pg::param(int64_t{rec.progress}),
       record_texts(rec)[3], pg::param(rec.cells), rec.updated});
  return r.affected() == 1;
}

bool PostgresJobStore::finish(const Lease& lease, const JobRecord& rec, const std::string& results) {
  if (rec.status != JobStatus::successful && rec.status != JobStatus::failed)
    throw Error(ErrorKind::internal, "finish: a job ends successful or failed");
  const auto t = record_texts(rec);
  auto c = pool_.acquire();
  const pg::Result r = c->exec(
      "UPDATE rv_jobs SET status = $4, message = $5, error_kind = $6, progress = $7, finished = $8,"
      " updated = $9, report = $10, cells = $11, results = $12, holder = NULL, lease_until = NULL,"
      " finished_at = now()"
      " WHERE id = $1 AND attempt = $2 AND holder = $3 AND status = 'running'",
      {lease.id, pg::param(int64_t{lease.attempt}), lease.holder, t[2], t[3], t[4], t[5], t[8], t[9], t[13], t[16],
       results});
  return r.affected() == 1;
}

bool PostgresJobStore::charge_planned(const Lease& lease, int64_t cells,
                                      const std::function<void(const AdmissionView&)>& admit) {
  auto c = pool_.acquire();
  pg::Transaction tx(*c);
  const pg::Result who =
      tx.exec("SELECT principal FROM rv_jobs WHERE id = $1 AND attempt = $2 AND holder = $3 AND status = 'running'",
              {lease.id, pg::param(int64_t{lease.attempt}), lease.holder});
  if (who.rows() == 0) return false;
  if (admit) admit(admission_view(tx, who.text(0, 0)));
  const pg::Result r =
      tx.exec("UPDATE rv_jobs SET cells = $4 WHERE id = $1 AND attempt = $2 AND holder = $3 AND status = 'running'",
              {lease.id, pg::param(int64_t{lease.attempt}), lease.holder, pg::param(cells)});
  tx.commit();
  return r.affected() == 1;
}

namespace {

// A job whose band failed fails with it (`message` names the band), and its other bands go.
void fail_split_job(pg::Transaction& tx, const std::string& job, const std::string& message, const std::string& kind,
                    const std::string& now_text) {
  const pg::Result r = tx.exec(
      "UPDATE rv_jobs SET status = 'failed', message = $2, error_kind = $3, finished = $4, updated = $4,"
      " holder = NULL, lease_until = NULL, finished_at = now()"
      " WHERE id = $1 AND status = 'running' AND holder IS NULL",
      {job, message, kind, now_text});
  if (r.affected() == 0) return;
  tx.exec(
      "UPDATE rv_jobs SET status = 'dismissed', message = 'another band of the job failed', updated = $2,"
      " holder = NULL, lease_until = NULL, finished_at = now()"
      " WHERE parent = $1 AND status IN ('accepted', 'running')",
      {job, now_text});
}

}  // namespace

std::vector<Reaped> PostgresJobStore::reap(double backoff_s, const std::string& now_text) {
  auto c = pool_.acquire();
  // One statement: a job is either still running under a live lease (untouched), or requeued, or
  // failed; a worker's fenced write racing it finds the holder changed and writes nothing.
  const pg::Result r = c->exec(
      "UPDATE rv_jobs SET"
      " status = CASE WHEN retryable AND attempt < max_attempts THEN 'accepted' ELSE 'failed' END,"
      " run_after = now() + $1::double precision * power(2, greatest(attempt - 1, 0)) * interval '1 second',"
      " holder = NULL, lease_until = NULL, progress = 0, updated = $2,"
      " message = CASE WHEN retryable AND attempt < max_attempts"
      "   THEN 'queued again: the daemon running attempt ' || attempt || ' stopped renewing its lease'"
      "   WHEN NOT retryable THEN 'the daemon running the job stopped renewing its lease, and only that daemon"
      " could run it; submit it again'"
      "   ELSE 'the job was attempted ' || attempt || ' times, and each time the daemon running it stopped"
      " renewing its lease; it may be what brings them down' END,"
      " error_kind = CASE WHEN retryable AND attempt < max_attempts THEN '' ELSE 'internal' END,"
      " finished = CASE WHEN retryable AND attempt < max_attempts THEN '' ELSE $2 END,"
      " finished_at = CASE WHEN retryable AND attempt < max_attempts THEN NULL ELSE now() END"
      " WHERE status = 'running' AND lease_until < now()"
      " RETURNING id, attempt, status",
      {seconds_param(backoff_s), now_text});
  std::vector<Reaped> out;
  for (int i = 0; i < r.rows(); ++i)
    out.push_back(Reaped{r.text(i, 0), static_cast<int>(r.integer(i, 1)), r.text(i, 2) == "accepted"});
  if (!out.empty()) c->exec(std::string("SELECT pg_notify('") + kQueuedChannel + "', '')");
  // A band failed by the reaper fails its job (a split job has no lease of its own to expire).
  for (const Reaped& x : out) {
    if (x.requeued) continue;
    pg::Transaction tx(*c);
    const pg::Result b = tx.exec(
        "SELECT parent, payload, message FROM rv_jobs WHERE id = $1 AND kind = 'band' AND parent IS NOT NULL", {x.id});
    if (b.rows() == 1)
      fail_split_job(tx, b.text(0, 0), "band of rows " + b.text(0, 1) + " failed: " + b.text(0, 2), "internal",
                     now_text);
    tx.commit();
  }
  return out;
}

bool PostgresJobStore::split(const Lease& job, const std::vector<BandTask>& bands, const std::string& message,
                             const std::string& now_text) {
  auto c = pool_.acquire();
  pg::Transaction tx(*c);
  const pg::Result r = tx.exec(
      "UPDATE rv_jobs SET holder = NULL, lease_until = 'infinity', message = $4, updated = $5"
      " WHERE id = $1 AND attempt = $2 AND holder = $3 AND status = 'running'"
      " RETURNING process_id, principal, max_attempts, exempt",
      {job.id, pg::param(int64_t{job.attempt}), job.holder, message, now_text});
  if (r.rows() == 0) return false;
  for (const BandTask& b : bands)
    tx.exec(
        "INSERT INTO rv_jobs (id, process_id, status, message, error_kind, progress, created, started, finished,"
        " updated, inputs, outputs, transmission, report, formats, principal, cells, kind, parent, payload,"
        " retryable, max_attempts, exempt)"
        " VALUES ($1, $2, 'accepted', 'queued', '', 0, $3, '', '', $3, '', '', '', '', '', $4, $5, 'band', $6, $7,"
        " true, $8, $9)",
        {b.id, r.text(0, 0), now_text, r.text(0, 1), pg::param(b.rows), job.id,
         std::to_string(b.row0) + ":" + std::to_string(b.rows), r.text(0, 2), r.text(0, 3)});
  tx.exec(std::string("SELECT pg_notify('") + kQueuedChannel + "', $1)", {job.id});
  tx.commit();
  return true;
}

std::vector<BandTask> PostgresJobStore::bands(const std::string& job) const {
  auto c = pool_.acquire();
  const pg::Result r = c->exec(
      "SELECT id, payload, status, results, message FROM rv_jobs WHERE parent = $1 AND kind = 'band'"
      " ORDER BY split_part(payload, ':', 1)::bigint",
      {job});
  std::vector<BandTask> out;
  for (int i = 0; i < r.rows(); ++i) {
    BandTask b;
    b.id = r.text(i, 0);
    const std::string payload = r.text(i, 1);
    const size_t colon = payload.find(':');
    if (colon == std::string::npos) throw Error(ErrorKind::internal, "band " + b.id + " names no rows");
    b.row0 = std::stoll(payload.substr(0, colon));
    b.rows = std::stoll(payload.substr(colon + 1));
    b.status = parse_job_status(r.text(i, 2));
    b.results = r.text(i, 3);
    b.message = r.text(i, 4);
    out.push_back(std::move(b));
  }
  return out;
}

bool PostgresJobStore::finish_band(const Lease& band, const std::string& job, const JobRecord& rec,
                                   const std::string& results, const std::string& job_message,
                                   const std::string& now_text) {
  if (rec.status != JobStatus::successful && rec.status != JobStatus::failed)
    throw Error(ErrorKind::internal, "finish_band: a band ends successful or failed");
  const auto t = record_texts(rec);
  auto c = pool_.acquire();
  pg::Transaction tx(*c);
  // The job's row first, locked: bands ending at once are taken one after the other, so that the
  // last one sees every other band's end (each alone would see the others still running, and the
  // job would never be queued to be assembled).
  tx.exec("SELECT 1 FROM rv_jobs WHERE id = $1 FOR UPDATE", {job});
  const pg::Result r = tx.exec(
      "UPDATE rv_jobs SET status = $4, message = $5, error_kind = $6, progress = $7, finished = $8, updated = $8,"
      " results = $9, holder = NULL, lease_until = NULL, finished_at = now()"
      " WHERE id = $1 AND attempt = $2 AND holder = $3 AND status = 'running'",
      {band.id, pg::param(int64_t{band.attempt}), band.holder, t[2], t[3], t[4], t[5], now_text, results});
  if (r.affected() != 1) return false;
  if (rec.status == JobStatus::successful) {
    const pg::Result q = tx.exec(
        "UPDATE rv_jobs SET status = 'accepted', holder = NULL, lease_until = NULL, run_after = now(),"
        " max_attempts = max_attempts + 1, message = 'its bands are computed; queued to be assembled', updated = $2"
        " WHERE id = $1 AND status = 'running' AND holder IS NULL"
        " AND NOT EXISTS (SELECT 1 FROM rv_jobs WHERE parent = $1 AND kind = 'band' AND status <> 'successful')",
        {job, now_text});
    if (q.affected() == 1) tx.exec(std::string("SELECT pg_notify('") + kQueuedChannel + "', $1)", {job});
  } else {
    fail_split_job(tx, job, job_message, rec.error_kind.empty() ? "internal" : rec.error_kind, now_text);
  }
  tx.commit();
  return true;
}

bool PostgresJobStore::release(const Lease& lease, const std::string& message, const std::string& now_text) {
  auto c = pool_.acquire();
  const pg::Result r = c->exec(
      "UPDATE rv_jobs SET status = 'accepted', holder = NULL, lease_until = NULL, run_after = now(),"
      " max_attempts = max_attempts + 1, progress = 0, message = $4, updated = $5"
      " WHERE id = $1 AND attempt = $2 AND holder = $3 AND status = 'running' AND retryable",
      {lease.id, pg::param(int64_t{lease.attempt}), lease.holder, message, now_text});
  if (r.affected() == 1) c->exec(std::string("SELECT pg_notify('") + kQueuedChannel + "', $1)", {lease.id});
  return r.affected() == 1;
}

std::optional<std::pair<JobRecord, JobRecord>> PostgresJobStore::dismiss(
    const std::string& id, const std::function<std::string(const JobRecord&)>& message, const std::string& now_text) {
  auto c = pool_.acquire();
  pg::Transaction tx(*c);
  const pg::Result before = tx.exec("SELECT " + kSelect + " FROM rv_jobs WHERE id = $1 FOR UPDATE", {id});
  if (before.rows() == 0) return std::nullopt;
  JobRecord old = record_at(before, 0);
  if (old.status == JobStatus::dismissed) return std::make_pair(old, old);
  const pg::Result after = tx.exec(
      "UPDATE rv_jobs SET status = 'dismissed', message = $2, updated = $3,"
      " finished = CASE WHEN finished = '' THEN $3 ELSE finished END,"
      " holder = NULL, lease_until = NULL, finished_at = coalesce(finished_at, now())"
      " WHERE id = $1 RETURNING " +
          kSelect,
      {id, message(old), now_text});
  // The tasks of a split job go with it: their holders learn it as the job's do.
  tx.exec(
      "UPDATE rv_jobs SET status = 'dismissed', message = $2, updated = $3, holder = NULL, lease_until = NULL,"
      " finished_at = coalesce(finished_at, now()) WHERE parent = $1 AND status <> 'dismissed'",
      {id, "the job these tasks belong to was dismissed", now_text});
  tx.exec(std::string("SELECT pg_notify('") + kDismissedChannel + "', $1)", {id});
  tx.commit();
  return std::make_pair(old, record_at(after, 0));
}

std::vector<Expired> PostgresJobStore::expire(double retention_s, int limit) {
  auto c = pool_.acquire();
  const pg::Result r = c->exec(
      "DELETE FROM rv_jobs WHERE id IN (SELECT id FROM rv_jobs WHERE parent IS NULL AND finished_at IS NOT NULL"
      " AND finished_at < now() - $1::double precision * interval '1 second' ORDER BY finished_at LIMIT $2)"
      " RETURNING id, payload, results",
      {seconds_param(retention_s), pg::param(int64_t{limit})});
  std::vector<Expired> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(Expired{r.text(i, 0), r.text(i, 1), r.text(i, 2)});
  return out;
}

std::optional<JobRecord> PostgresJobStore::get(const std::string& id) const {
  auto c = pool_.acquire();
  const pg::Result r = c->exec("SELECT " + kSelect + " FROM rv_jobs WHERE id = $1 AND kind = 'job'", {id});
  if (r.rows() == 0) return std::nullopt;
  return record_at(r, 0);
}

std::vector<JobRecord> PostgresJobStore::get_many(const std::vector<std::string>& ids) const {
  if (ids.empty()) return {};
  auto c = pool_.acquire();
  const pg::Result r =
      c->exec("SELECT " + kSelect + " FROM rv_jobs WHERE id = ANY($1::text[]) AND kind = 'job'", {text_array(ids)});
  std::vector<JobRecord> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(record_at(r, i));
  return out;
}

int64_t PostgresJobStore::running() const {
  auto c = pool_.acquire();
  return c->exec("SELECT count(*) FROM rv_jobs WHERE status = 'running'").integer(0, 0);
}

std::optional<QueueEntry> PostgresJobStore::entry(const std::string& id) const {
  auto c = pool_.acquire();
  const pg::Result r =
      c->exec("SELECT kind, coalesce(parent, ''), payload, retryable, max_attempts FROM rv_jobs WHERE id = $1", {id});
  if (r.rows() == 0) return std::nullopt;
  return QueueEntry{r.text(0, 0), r.text(0, 1), r.text(0, 2), r.boolean(0, 3), static_cast<int>(r.integer(0, 4))};
}

std::vector<JobRecord> PostgresJobStore::list(int limit, int offset, const std::vector<JobStatus>& status,
                                              const std::string& principal) const {
  std::string sql = "SELECT " + kSelect + " FROM rv_jobs WHERE kind = 'job'";
  pg::Params p;
  if (!status.empty()) {
    sql += " AND status IN (";
    for (size_t i = 0; i < status.size(); ++i) {
      p.push_back(std::string(to_string(status[i])));
      sql += (i ? ",$" : "$") + std::to_string(p.size());
    }
    sql += ")";
  }
  if (!principal.empty()) {
    p.push_back(principal);
    sql += " AND principal = $" + std::to_string(p.size());
  }
  p.push_back(pg::param(int64_t{limit}));
  p.push_back(pg::param(int64_t{offset}));
  sql += " ORDER BY created DESC, id LIMIT $" + std::to_string(p.size() - 1) + " OFFSET $" + std::to_string(p.size());
  auto c = pool_.acquire();
  const pg::Result r = c->exec(sql, p);
  std::vector<JobRecord> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(record_at(r, i));
  return out;
}

std::vector<CellCharge> PostgresJobStore::charges_since(const std::string& since) const {
  auto c = pool_.acquire();
  const pg::Result r = c->exec(
      "SELECT principal, created, cells FROM rv_jobs WHERE kind = 'job' AND created >= $1 AND cells > 0"
      " AND NOT (status = 'failed' AND error_kind = 'over_quota')"
      " UNION ALL SELECT principal, to_char(created_at AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.MS\"Z\"'), cells"
      " FROM rv_charges WHERE created_at > now() - interval '1 hour'",
      {since});
  std::vector<CellCharge> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(CellCharge{r.text(i, 0), r.text(i, 1), r.integer(i, 2)});
  return out;
}

std::vector<std::pair<std::string, int64_t>> PostgresJobStore::count_by_principal() const {
  auto c = pool_.acquire();
  const pg::Result r =
      c->exec("SELECT principal, count(*) FROM rv_jobs WHERE kind = 'job' GROUP BY principal ORDER BY principal");
  std::vector<std::pair<std::string, int64_t>> out;
  for (int i = 0; i < r.rows(); ++i) out.emplace_back(r.text(i, 0), r.integer(i, 1));
  return out;
}

void PostgresJobStore::charge(const std::string& principal, int64_t cells,
                              const std::function<void(const AdmissionView&)>& admit) {
  auto c = pool_.acquire();
  pg::Transaction tx(*c);
  if (admit) admit(admission_view(tx, principal));
  tx.exec("INSERT INTO rv_charges (principal, cells) VALUES ($1, $2)", {principal, pg::param(cells)});
  // An hour on, a charge counts no more: kept no longer.
  tx.exec("DELETE FROM rv_charges WHERE created_at < now() - interval '1 hour'");
  tx.commit();
}

void PostgresJobStore::announce(const std::string& name, const std::string& url, const std::string& holder) {
  auto c = pool_.acquire();
  c->exec(
      "INSERT INTO rv_daemons (name, url, holder) VALUES ($1, $2, $3) ON CONFLICT (name) DO UPDATE"
      " SET url = EXCLUDED.url, holder = EXCLUDED.holder, seen_at = now()",
      {name, url, holder});
}

std::optional<std::pair<std::string, double>> PostgresJobStore::daemon(const std::string& name) const {
  auto c = pool_.acquire();
  const pg::Result r =
      c->exec("SELECT url, extract(epoch FROM now() - seen_at) FROM rv_daemons WHERE name = $1", {name});
  if (r.rows() == 0) return std::nullopt;
  return std::make_pair(r.text(0, 0), std::stod(r.text(0, 1)));
}

std::vector<std::string> PostgresJobStore::referenced_keys() const {
  auto c = pool_.acquire();
  const pg::Result r =
      c->exec("SELECT payload FROM rv_jobs WHERE payload <> '' UNION SELECT results FROM rv_jobs WHERE results <> ''");
  std::vector<std::string> out;
  for (int i = 0; i < r.rows(); ++i) out.push_back(r.text(i, 0));
  return out;
}

}  // namespace rv::store
