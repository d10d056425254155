// The job manager on a shared store (issue 55): submission into the database's queue, claims,
// the lease's heartbeat, fenced ends, dismissal across daemons, the reaper and the sweeps.
#include <map>
#include <set>

#include "common/atomic_file.hpp"
#include "daemon/server_jobs.hpp"
#include "runtime/server_util.hpp"
#include "rv/field/text.hpp"
#include "rv/json_text.hpp"

namespace rv::daemon {
namespace {

namespace fs = std::filesystem;

constexpr const char* kRequestFile = "request.json";

std::string what_of_current() {
  try {
    throw;
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "unknown exception";
  }
}

}  // namespace

void JobManager::admit_shared(const store::AdmissionView& v, const auth::Principal& who, int64_t cells, bool queued,
                              bool new_job) const {
  // The shared queue's length bounds jobs waiting for any daemon (at least one may wait).
  const int64_t most = std::max(1, config_.jobs.queue_length);
  if (queued && v.queued >= most)
    throw Error(ErrorKind::busy, std::to_string(v.queued) +
                                     " jobs are waiting in the shared queue, the most it holds (" +
                                     std::to_string(most) + "); retry later");
  if (exempt_from_limits(who)) return;
  const int limit = config_.principal_limits.jobs;
  if (new_job && limit > 0 && v.principal_unfinished >= limit) throw too_many_jobs(v.principal_unfinished, limit);
  if (cells > 0 && config_.principal_limits.cells_per_hour > 0) {
    // The rule of the one-daemon server, over the charges every daemon recorded.
    CellAllowance hour(config_.principal_limits.cells_per_hour);
    for (const auto& [at, c] : v.charges) hour.restore(who.name, at, c);
    hour.charge(who.name, cells, v.now);
  }
}

JobRecord JobManager::submit_shared(const std::string& id, Execution execution, const auth::Principal& who,
                                    Done on_done) {
  JobRecord rec = accepted_record(id, execution, who);
  // A synchronous client waits on this daemon, and a session's job saves state only this daemon
  // holds: they run here. Jobs submitted for later go to the shared queue with their request.
  const bool here = on_done || execution.run || execution.request.empty();
  if (here) check_disk();
  {
    std::lock_guard lock(mutex_);
    if (stopping_) throw Error(ErrorKind::busy, "the server is shutting down; resubmit the job later");
    if (here) check_capacity();
  }
  store::QueueEntry entry;
  entry.max_attempts = config_.jobs.max_attempts;
  entry.exempt = exempt_from_limits(who);
  const int64_t cells = execution.cells;
  auto admit = [&](const store::AdmissionView& v) { admit_shared(v, who, cells, !here, true); };
  try {
    // An edit's copy of its base, among the job's files every daemon reaches: the base may be
    // deleted while this job waits, or is attempted again.
    if (!execution.spec.base_name.empty())
      execution.spec.base_report = snapshot_base(execution.spec.base_name, id, who);
    if (!here) {
      // The uploads this daemon staged while checking the request go before the row exists: a
      // worker of this daemon may claim the job at once and stage them again under the same
      // names, which this Execution's end would otherwise unlink under it.
      execution.uploads.reset();
      // Persisted before the row that names it, and the row committed before the 201.
      try {
        objects_.put(id + "/" + kRequestFile, execution.request);
      } catch (const Error& e) {
        if (e.kind() != ErrorKind::io) throw;
        throw Error(ErrorKind::busy,
                    "the results storage is unavailable: " + objects_.without_paths(valid_utf8(e.what())));
      }
      entry.payload = id + "/" + kRequestFile;
      try {
        shared_->enqueue(rec, entry, admit);
      } catch (const Error& e) {
        // The connection broke around the commit: the row may have been committed all the same,
        // and then the job is accepted (any daemon will run it), its files must stay.
        if (e.kind() != ErrorKind::busy || !stored(id)) throw;
      }
      return rec;
    }
    entry.retryable = false;
    rec.status = JobStatus::running;
    rec.message = "running";
    rec.started = rec.created;
    Task t;
    t.lease = shared_->insert_running(rec, entry, holder_, config_.jobs.lease_s, admit);
    t.leased_at = std::chrono::steady_clock::now();
    t.id = id;
    t.claimed = rec;
    t.execution = std::move(execution);
    t.on_done = std::move(on_done);
    t.principal = who.name;
    t.who = who;
    t.charged = cells > 0 || entry.exempt;
    std::lock_guard lock(mutex_);
    queue_.push_back(std::move(t));
    work_cv_.notify_one();
    return rec;
  } catch (...) {
    remove_files(id);
    throw;
  }
}

bool JobManager::stored(const std::string& id) const {
  try {
    return shared_->get(id).has_value();
  } catch (...) {
    return false;
  }
}

std::optional<JobManager::Task> JobManager::claim_shared() {
  // A daemon short of disk leaves the queue to the others (or to itself once space is freed).
  if (disk_low(disk_free_bytes())) return std::nullopt;
  std::optional<store::Claim> c;
  try {
    c = shared_->claim(holder_, config_.jobs.lease_s, now_rfc3339());
  } catch (...) {
    // The store is away: the heartbeat says so in the log; the worker naps and tries again.
    return std::nullopt;
  }
  if (!c) return std::nullopt;
  Task t;
  t.id = c->record.id;
  t.principal = c->record.principal;
  t.who.name = c->record.principal;
  t.who.role = c->entry.exempt ? Role::admin : Role::user;
  t.who.how = "stored";
  t.lease = c->lease;
  t.leased_at = std::chrono::steady_clock::now();
  t.from_queue = true;
  t.claimed = c->record;
  t.kind = c->entry.kind;
  t.parent = c->entry.parent;
  t.payload = c->entry.payload;
  t.split = c->split;
  t.charged = c->record.cells > 0 || c->entry.exempt || t.kind == "band";  // a band's cells are its job's
  log_event("{\"event\":\"claimed\",\"job\":\"" + t.id + "\",\"attempt\":" + std::to_string(c->lease.attempt) +
            (t.kind == "band" ? ",\"band_of\":\"" + t.parent + "\",\"rows\":\"" + t.payload + "\"" : std::string()) +
            "}");
  return t;
}

Execution JobManager::load_execution(const std::string& id, int attempt, const std::string& staging) const {
  const std::optional<std::string> text = objects_.get(id + "/" + kRequestFile);
  if (!text) throw Error(ErrorKind::io, "the job's stored request cannot be read from the results storage");
  const nlohmann::json body = nlohmann::json::parse(*text, nullptr, false);
  if (body.is_discarded()) throw Error(ErrorKind::internal, "the job's stored request is damaged");
  Execution ex = parse_execution(body, id, config_, (staging.empty() ? id : staging) + "-a" + std::to_string(attempt));
  if (!ex.spec.base_name.empty())
    ex.spec.base_report = (job_dir(id) / kBaseSnapshotDir / output_file_name("report", "")).string();
  return ex;
}

void JobManager::fetch_base(const std::string& id) const {
  if (!objects_.remote()) return;  // the snapshot is in the folder already
  const std::string key = id + "/" + kBaseSnapshotDir;
  fetch_tree(key, root_ / key, "the base job's files kept for this edit", "are missing from the results");
}

void JobManager::fetch_tree(const std::string& key, const std::filesystem::path& local, const std::string& what,
                            const std::string& missing) const {
  remove_dir(local);
  int copied = 0;
  try {
    copied = objects_.get_tree(key, local);
  } catch (const Error& e) {
    if (e.kind() != ErrorKind::io) throw;
    remove_dir(local);  // never half a tree
    throw Error(ErrorKind::io, what + " cannot be read: " + objects_.without_paths(e.what()));
  }
  if (copied == 0) throw Error(ErrorKind::io, what + " " + missing);
}

void JobManager::charge_planned_shared(const Task& task, int64_t cells) {
  // The store being away is not the job's fault: wait for it as a job's end does; past that, the
  // job goes back to the queue through its lease. Over the allowance (QuotaExceeded) fails the
  // job, as on one daemon.
  const bool through = wait_out_store([&] {
    if (!shared_->charge_planned(
            *task.lease, cells, [&](const store::AdmissionView& v) { admit_shared(v, task.who, cells, false, false); }))
      lose_lease(task.id);
  });
  if (!through) lose_lease(task.id);
}

bool JobManager::wait_out_store(const std::function<void()>& write) const {
  const auto until =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(std::max(60.0, 2 * config_.jobs.lease_s));
  for (;;) {
    try {
      write();
      return true;
    } catch (const Error& e) {
      if (e.kind() != ErrorKind::busy || std::chrono::steady_clock::now() > until) {
        if (e.kind() == ErrorKind::busy) return false;
        throw;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
  }
}

JobManager::EndState JobManager::end_state(const std::string& id) const {
  std::lock_guard lock(mutex_);
  const Running& r = running_.at(id);
  EndState s;
  s.dismissed = r.dismissed;
  s.lost = r.lost;
  s.timed_out = r.timed_out;
  s.shut_down = r.shutdown;
  s.lease = *r.lease;
  s.cancel = r.cancel;
  return s;
}

bool JobManager::upload_results(const std::string& id, const std::string& key, const fs::path& dir,
                                const std::string& what_failed, EndState& state, std::optional<ErrorKind>& kind,
                                std::string& why) {
  if (kind || !state.ours() || state.shut_down || state.timed_out || !objects_.remote()) return false;
  try {
    objects_.put_tree(key, dir, state.cancel.get());
    return false;
  } catch (const Error& e) {
    remove_files(key);
    kind = e.kind() == ErrorKind::cancelled ? ErrorKind::cancelled : ErrorKind::io;
    why = what_failed + ": " + objects_.without_paths(valid_utf8(e.what()));
    state = end_state(id);
    return true;
  }
}

std::string JobManager::daemon_url(const std::string& name) const {
  if (!shared_) return "";
  try {
    const auto d = shared_->daemon(name);
    return d ? d->first : "";
  } catch (...) {
    return "";
  }
}

void JobManager::lose_lease(const std::string& id) {
  std::lock_guard lock(mutex_);
  if (const auto it = running_.find(id); it != running_.end()) {
    it->second.lost = true;
    it->second.cancel->store(true);
  }
}

void JobManager::release_lease(const store::Lease& lease, const std::string& message) {
  try {
    shared_->release(lease, message, now_rfc3339());
  } catch (...) {
    // The store is away: the lease expires, and a reaper queues the job again.
  }
}

void JobManager::record_end_shared(JobRecord& rec, const std::optional<ErrorKind>& error_kind,
                                   const std::string& message, const nlohmann::json& report, const fs::path& dir) {
  EndState state = end_state(rec.id);
  const store::Lease lease = state.lease;
  const std::string attempt = rec.id + "/" + std::to_string(lease.attempt);
  // On a bucket the results go up first: the row that names them commits after the upload.
  // Nothing half-uploaded stays.
  std::optional<ErrorKind> kind = error_kind;
  std::string why = message;
  nlohmann::json kept_report = report;
  if (upload_results(rec.id, attempt, dir, "the job's results could not be stored", state, kind, why))
    kept_report = nullptr;
  auto reread = [&] {  // the record as the store now has it
    try {
      if (auto now = shared_->get(rec.id)) rec = *now;
    } catch (...) {
    }
  };
  if (state.ours() && state.shut_down) {
    // Handed back (a job only this daemon could run is not: it fails below). The store away: the
    // lease expires and a reaper queues the job again; the shutdown does not wait for the store.
    bool handed_back = false, store_away = false;
    try {
      handed_back = shared_->release(lease, "queued again: the daemon running it shut down", now_rfc3339());
    } catch (...) {
      store_away = true;
    }
    if (handed_back || store_away) {
      remove_files(attempt);  // another daemon starts it afresh
      if (handed_back) reread();
      return;
    }
  }
  bool published = false;
  if (state.ours()) {
    end_record(rec, kind, why, kept_report, state.timed_out, state.shut_down);
    rec.results = rec.status == JobStatus::successful ? attempt : "";
    try {
      wait_out_store([&] { published = shared_->finish(lease, rec, rec.results); });
    } catch (const Error&) {
      // Not published: treated below as a job no longer ours.
    }
  }
  if (published) {
    if (rec.status == JobStatus::failed) remove_files(attempt);
    if (objects_.remote()) remove_dir(dir);  // uploaded: the local copy is no longer needed
    remove_files(rec.id + "/" + kBaseSnapshotDir);
    remove_files(rec.id + "/" + kBandsDir);  // an assembled job's bands
    return;
  }
  // Not ours to publish: this attempt's files go (uploaded ones too); the job is as the store says.
  remove_files(attempt);
  reread();
  if (rec.status == JobStatus::dismissed) remove_files(rec.id);
}

std::optional<JobRecord> JobManager::dismiss_shared(const std::string& id) {
  auto message = [](const JobRecord& before) -> std::string {
    if (before.status == JobStatus::accepted) return "dismissed by the client before it started";
    if (before.status == JobStatus::running) return "dismissed by the client; the computation was cancelled";
    return "dismissed by the client; its results were deleted";
  };
  const auto d = shared_->dismiss(id, message, now_rfc3339());
  if (!d) return std::nullopt;
  const auto& [before, after] = *d;
  if (before.status == JobStatus::dismissed) return after;
  std::optional<Task> dropped;
  bool running_here = false;
  {
    std::lock_guard lock(mutex_);
    for (auto it = queue_.begin(); it != queue_.end(); ++it)
      if (it->id == id) {
        dropped = std::move(*it);
        queue_.erase(it);
        break;
      }
    if (const auto r = running_.find(id); r != running_.end()) {
      r->second.dismissed = true;
      r->second.cancel->store(true);
      running_here = true;
    }
  }
  // A job running on another daemon: that daemon removes its files when it learns it.
  if (!running_here && (before.status != JobStatus::running || dropped)) remove_files(id);
  if (dropped) notify_done(dropped->on_done, after);
  return after;
}

void JobManager::learn_dismissed(const std::string& id) {
  if (!is_job_id(id)) return;
  std::optional<Task> dropped;
  {
    std::lock_guard lock(mutex_);
    if (const auto r = running_.find(id); r != running_.end()) {
      r->second.dismissed = true;
      r->second.cancel->store(true);
    }
    for (auto it = queue_.begin(); it != queue_.end(); ++it)
      if (it->id == id) {
        dropped = std::move(*it);
        queue_.erase(it);
        break;
      }
  }
  if (!dropped) return;
  remove_files(id);
  JobRecord rec = dropped->claimed;
  try {
    if (auto now = shared_->get(id)) rec = *now;
  } catch (...) {
  }
  notify_done(dropped->on_done, rec);
}

void JobManager::leases_lost(const std::vector<store::Lease>& held, std::chrono::steady_clock::time_point asked_at) {
  std::set<std::pair<std::string, int>> live;
  for (const store::Lease& l : held) live.emplace(l.id, l.attempt);
  std::vector<std::string> gone_queued;
  {
    std::lock_guard lock(mutex_);
    // Only leases taken before the heartbeat asked: a claim committed after it is not in its answer.
    for (auto& [id, r] : running_)
      if (r.lease && r.leased_at < asked_at && !live.count({id, r.lease->attempt}) && !r.lost) {
        r.lost = true;
        r.cancel->store(true);
        log_event("{\"event\":\"lease_lost\",\"job\":\"" + id + "\",\"attempt\":" + std::to_string(r.lease->attempt) +
                  "}");
      }
    for (const Task& t : queue_)
      if (t.lease && t.leased_at < asked_at && !live.count({t.id, t.lease->attempt})) gone_queued.push_back(t.id);
  }
  for (const std::string& id : gone_queued) learn_dismissed(id);
}

void JobManager::heartbeat_loop() {
  const auto period = std::chrono::duration<double>(config_.jobs.lease_s / 3);
  std::unique_lock lock(shared_mutex_);
  while (!shared_stop_) {
    lock.unlock();
    const auto asked = std::chrono::steady_clock::now();
    std::vector<std::string> ids;  // the leases this daemon still means to hold
    {
      std::lock_guard jobs_lock(mutex_);
      for (const auto& [id, r] : running_)
        if (r.lease) ids.push_back(id);
      for (const Task& t : queue_)
        if (t.lease) ids.push_back(t.id);
    }
    try {
      shared_->announce(name_, url_, holder_);
      const auto held = shared_->heartbeat(holder_, config_.jobs.lease_s, ids);
      if (!store_reachable_.exchange(true)) log_event("{\"event\":\"store_reachable\"}");
      leases_lost(held, asked);
    } catch (...) {
      // Leases are not judged without an answer: the running jobs go on, and their ends wait
      // (record_end_shared) for the store to come back within their lease.
      const std::string what = what_of_current();
      if (store_reachable_.exchange(false))
        log_event("{\"event\":\"store_unreachable\",\"error\":" + json_text(valid_utf8(what)) + "}");
    }
    try {
      for (const store::Reaped& r : shared_->reap(config_.jobs.retry_backoff_s, now_rfc3339()))
        log_event("{\"event\":\"reaped\",\"job\":\"" + r.id + "\",\"attempt\":" + std::to_string(r.attempt) +
                  ",\"requeued\":" + (r.requeued ? "true" : "false") + "}");
    } catch (...) {
      // The store is away; logged above.
    }
    lock.lock();
    shared_cv_.wait_for(lock, period, [this] { return shared_stop_.load(); });
  }
}

void JobManager::sweep_loop() {
  // Apart from the heartbeat: a sweep over many folders must never delay a lease's renewal.
  const auto period = std::chrono::duration<double>(std::min(60.0, config_.jobs.orphan_grace_s));
  std::unique_lock lock(shared_mutex_);
  while (!shared_stop_) {
    lock.unlock();
    probe_results();
    try {
      if (config_.jobs.retention_s > 0)
        for (const store::Expired& e : shared_->expire(config_.jobs.retention_s, 1000))
          if (is_job_id(e.id)) remove_files(e.id);
      sweep_orphans();
      // Multipart uploads a dead daemon left open cost storage until aborted. The storage cannot
      // tell them from a live daemon's upload (GDAL aborts every pending one), so only while no
      // job runs anywhere; a bucket's lifecycle rule (AbortIncompleteMultipartUpload) is the
      // complement for a service that is never idle (README).
      if (objects_.remote() && shared_->running() == 0 && objects_.abort_pending_uploads())
        log_event("{\"event\":\"pending_uploads_aborted\"}");
    } catch (...) {
      // The store is away: the next round sweeps.
    }
    lock.lock();
    shared_cv_.wait_for(lock, period, [this] { return shared_stop_.load(); });
  }
}

void JobManager::probe_results() {
  // On the sweep's thread, not the heartbeat's: a storage that hangs must not delay a lease.
  std::string why;
  try {
    objects_.probe();
    std::error_code ec;
    if (!objects_.remote() && !std::filesystem::is_directory(objects_.location(), ec))
      why = "the results folder is not there";
  } catch (const std::exception& e) {
    why = e.what();
  }
  const bool reachable = why.empty();
  if (results_reachable_.exchange(reachable) == reachable) return;
  log_event(reachable ? std::string("{\"event\":\"results_reachable\"}")
                      : "{\"event\":\"results_unreachable\",\"error\":" +
                            json_text(valid_utf8(objects_.without_paths(why))) + "}");
}

void JobManager::sweep_orphans() {
  // Jobs' files no job names (a daemon died between writing a request and committing its row, or
  // retention's deletion of the row outlived its files), and parts a finished job does not name:
  // attempts other than its published one (a worker died before removing those of a lost lease)
  // and a base snapshot left behind. Judged only once nothing below them was written for
  // jobs.orphan_grace_s: a submission writes its request just before its row. One listing of
  // every object, then the store is asked about a thousand jobs at a time.
  using Clock = std::chrono::system_clock;
  struct Seen {
    Clock::time_point newest{};
    std::map<std::string, Clock::time_point> parts;  // second-level names and their newest write
  };
  std::map<std::string, Seen> jobs;
  // Ages are judged from the moment the listing began, not from the end of the sweep: the listing
  // of a whole bucket and the store's answers take time, and a job whose row was committed within
  // the grace of its first files is then never taken for an orphan, however slow the sweep.
  const Clock::time_point listed_at = Clock::now();
  for (const store::ListedObject& o : objects_.list_all("")) {
    const size_t slash = o.key.find('/');
    const std::string id = o.key.substr(0, slash);
    if (!is_job_id(id)) continue;
    Seen& s = jobs[id];
    s.newest = std::max(s.newest, o.modified);
    if (slash == std::string::npos || slash + 1 >= o.key.size()) continue;
    const std::string part = o.key.substr(slash + 1, o.key.find('/', slash + 1) - slash - 1);
    auto& t = s.parts[part];
    t = std::max(t, o.modified);
  }
  const auto old = [&](Clock::time_point t) {
    return listed_at - t > std::chrono::duration<double>(config_.jobs.orphan_grace_s);
  };
  std::vector<std::string> ids;
  for (const auto& [id, seen] : jobs) ids.push_back(id);
  for (size_t at = 0; at < ids.size(); at += 1000) {
    const std::vector<std::string> batch(ids.begin() + at, ids.begin() + std::min(ids.size(), at + 1000));
    std::map<std::string, JobRecord> known;
    for (JobRecord& r : shared_->get_many(batch)) known.emplace(r.id, std::move(r));
    for (const std::string& id : batch) {
      const Seen& seen = jobs.at(id);
      const auto it = known.find(id);
      if (it == known.end()) {
        if (old(seen.newest)) {
          remove_files(id);
          log_event("{\"event\":\"orphan_removed\",\"job\":\"" + id + "\"}");
        }
        continue;
      }
      const JobRecord& rec = it->second;
      if (rec.status == JobStatus::accepted || rec.status == JobStatus::running) continue;
      if (rec.status == JobStatus::dismissed) {
        if (old(seen.newest)) remove_files(id);
        continue;
      }
      const std::string keep = rec.results.empty() ? "" : rec.results.substr(id.size() + 1);
      for (const auto& [part, when] : seen.parts)
        if (part != keep && part != kRequestFile && old(when)) remove_files(id + "/" + part);
    }
  }
}

void JobManager::listen_loop() {
  std::unique_ptr<pg::Connection> c;
  auto wake = [this] {
    {
      std::lock_guard lock(mutex_);
      ++queue_hint_;
    }
    work_cv_.notify_all();
  };
  while (!shared_stop_) {
    try {
      if (!c || !c->ok()) {
        c = std::make_unique<pg::Connection>(shared_->connect_info());
        c->exec(std::string("LISTEN ") + store::PostgresJobStore::kQueuedChannel);
        c->exec(std::string("LISTEN ") + store::PostgresJobStore::kDismissedChannel);
        wake();  // whatever was queued while no one listened
      }
      for (const pg::Notification& n : c->wait_notifications(std::chrono::milliseconds(500))) {
        if (n.channel == store::PostgresJobStore::kQueuedChannel)
          wake();
        else if (n.channel == store::PostgresJobStore::kDismissedChannel)
          learn_dismissed(n.payload);
      }
    } catch (...) {
      // A hint only: polling carries on without it. Connect again after a pause.
      c.reset();
      std::unique_lock lock(shared_mutex_);
      shared_cv_.wait_for(lock, std::chrono::seconds(1), [this] { return shared_stop_.load(); });
    }
  }
}

}  // namespace rv::daemon
