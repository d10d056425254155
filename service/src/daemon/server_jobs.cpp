#include "daemon/server_jobs.hpp"

#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <system_error>

#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/json_text.hpp"
#include "rv/options.hpp"

namespace rv::daemon {
void remove_dir(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);  // best effort: a leftover directory only costs disk
}

namespace {

// Temporary name in the same directory, then rename: a reader never sees half a report.
void write_file_atomically(const std::filesystem::path& path, const std::string& text) {
  const std::filesystem::path tmp = path.parent_path() / ("." + path.filename().string() + ".tmp");
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw Error(ErrorKind::io, "cannot write " + tmp.filename().string());
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw Error(ErrorKind::io, "cannot rename the report into place");
  }
}

}  // namespace

JobManager::JobManager(JobStore& store, const ServerConfig& config, JobRunner runner, MemoryAccount& memory)
    : store_(&store),
      root_(std::filesystem::path(config.data_dir) / "jobs"),
      objects_(root_.string()),
      config_(config),
      runner_(std::move(runner)),
      memory_(memory),
      limits_(effective_limits(config)),
      cells_(config.principal_limits.cells_per_hour) {
  // The hour before this start counts: a restart hands out no fresh allowance.
  const auto now = std::chrono::system_clock::now();
  for (const CellCharge& c : store_->charges_since(rfc3339(now - CellAllowance::kWindow)))
    if (const auto at = parse_rfc3339(c.created)) cells_.restore(c.principal, *at, c.cells);
  start_threads();
}

JobManager::JobManager(store::PostgresJobStore& shared, const ServerConfig& config, JobRunner runner,
                       MemoryAccount& memory, std::string holder, std::string name, std::string url)
    : shared_(&shared),
      holder_(std::move(holder)),
      name_(std::move(name)),
      url_(std::move(url)),
      // On a bucket, data_dir's folder holds what this daemon's attempts write before upload.
      root_(config.store.results.rfind("s3://", 0) == 0 ? std::filesystem::path(config.data_dir) / "jobs"
                                                        : std::filesystem::path(config.store.results)),
      objects_(config.store.results),
      config_(config),
      runner_(std::move(runner)),
      memory_(memory),
      limits_(effective_limits(config)),
      cells_(config.principal_limits.cells_per_hour) {
  objects_.probe();  // unreachable at start: one line, and the daemon exits
  if (objects_.remote()) {
    // What an earlier life of this daemon wrote there was never uploaded (its leases are gone
    // with its holder): another attempt runs those jobs.
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(root_, ec)) remove_dir(e.path());
  }
  start_threads();
  heartbeat_ = std::thread([this] { heartbeat_loop(); });
  listener_ = std::thread([this] { listen_loop(); });
  sweeper_ = std::thread([this] { sweep_loop(); });
}

void JobManager::start_threads() {
  std::error_code ec;
  std::filesystem::create_directories(root_, ec);
  if (ec) throw Error(ErrorKind::io, "the jobs' folder '" + root_.string() + "': " + ec.message());
  for (int i = 0; i < std::max(1, config_.jobs.workers); ++i) {
    workers_.emplace_back([this] { worker_loop(); });
  }
  watchdog_ = std::thread([this] { watchdog_loop(); });
}

JobManager::~JobManager() { shutdown(std::chrono::duration<double>(0)); }

std::filesystem::path JobManager::job_dir(const std::string& id) const {
  if (!is_job_id(id)) throw Error(ErrorKind::internal, "job_dir: not a job id");
  return root_ / id;
}

std::string JobManager::results_prefix(const JobRecord& rec) const {
  if (!shared_ || rec.results.empty()) return rec.id;
  // "<id>/<attempt>", written by this program: checked all the same before it names a file.
  const std::string attempt = rec.results.substr(std::min(rec.results.size(), rec.id.size() + 1));
  if (rec.results.compare(0, rec.id.size() + 1, rec.id + "/") != 0 || attempt.empty() ||
      attempt.find_first_not_of("0123456789") != std::string::npos)
    throw Error(ErrorKind::internal, "job " + rec.id + " names damaged results");
  return rec.results;
}

std::unique_ptr<store::ObjectReader> JobManager::open_result(const JobRecord& rec, const std::string& name) const {
  if (!store::is_object_key(name)) throw Error(ErrorKind::internal, "open_result: not a file name");
  try {
    return objects_.open(results_prefix(rec) + "/" + name);
  } catch (const Error& e) {
    // The storage away is no fault of the request: the client retries.
    if (e.kind() != ErrorKind::io || !objects_.remote()) throw;
    throw Error(ErrorKind::busy, "the results storage is unavailable: " + objects_.without_paths(valid_utf8(e.what())));
  }
}

void JobManager::remove_files(const std::string& prefix) const {
  remove_dir(root_ / prefix);
  if (!objects_.remote()) return;
  try {
    objects_.remove_tree(prefix);
  } catch (const std::exception& e) {
    log_event("{\"event\":\"objects_not_removed\",\"prefix\":" + json_text(prefix) +
              ",\"error\":" + json_text(valid_utf8(e.what())) + "}");
  }
}

int64_t JobManager::cells_retry_after(const std::string& principal, int64_t cells) const {
  if (!shared_) return cells_.retry_after(principal, cells);
  // A shared store's hour is every daemon's: read from it (the store away: the rule's answer
  // without the charges, at least a second).
  CellAllowance hour(config_.principal_limits.cells_per_hour);
  try {
    const auto now = std::chrono::system_clock::now();
    for (const CellCharge& c : shared_->charges_since(rfc3339(now - CellAllowance::kWindow)))
      if (const auto at = parse_rfc3339(c.created); at && c.principal == principal)
        hour.restore(principal, *at, c.cells);
  } catch (const std::exception&) {
  }
  return hour.retry_after(principal, cells);
}

int JobManager::running_count() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(running_.size());
}

int JobManager::queued_count() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(queue_.size());
}

void JobManager::check_capacity() const {
  // Capacity counts the workers too: a free worker takes a job even with queue_length 0.
  const size_t capacity = static_cast<size_t>(config_.jobs.queue_length + std::max(1, config_.jobs.workers));
  if (queue_.size() + running_.size() >= capacity)
    throw Error(ErrorKind::busy, "all " + std::to_string(config_.jobs.workers) + " workers are busy and " +
                                     std::to_string(queue_.size()) + " jobs are waiting; retry later");
}

int64_t JobManager::disk_free_bytes() const {
  std::error_code ec;
  const std::filesystem::space_info space = std::filesystem::space(root_, ec);
  if (ec || space.available == static_cast<std::uintmax_t>(-1)) return -1;
  return static_cast<int64_t>(std::min<std::uintmax_t>(space.available, std::numeric_limits<int64_t>::max()));
}

bool JobManager::disk_low(int64_t free) const {
  const int64_t floor = config_.min_free_disk_bytes;
  if (floor <= 0) return false;
  const bool low = free >= 0 && free < floor;
  // (Logged when it changes, whoever asked: a worker polling the shared queue, /health.)
  if (disk_low_.exchange(low) != low)
    log_event(std::string("{\"event\":\"") + (low ? "disk_low" : "disk_ok") +
              "\",\"free_bytes\":" + std::to_string(free) + ",\"min_free_disk_bytes\":" + std::to_string(floor) + "}");
  return low;
}

void JobManager::check_disk() const {
  // Refused up front, with nothing written: a job let through would compute for its whole time
  // and fail on its last write, and could fill the disk under the jobs that fit.
  const int64_t floor = config_.min_free_disk_bytes;
  if (floor <= 0) return;
  const int64_t free = disk_free_bytes();
  if (!disk_low(free)) return;
  throw Error(ErrorKind::busy, "the server's disk has " + std::to_string(free >> 20) +
                                   " MiB free, less than it keeps free for running jobs (limits.min_free_disk_bytes, " +
                                   std::to_string(floor >> 20) + " MiB); retry later");
}

void JobManager::check_job_count(const std::string& principal) const {
  const int limit = config_.principal_limits.jobs;
  if (limit <= 0) return;
  int count = 0;
  for (const Task& t : queue_) count += t.principal == principal;
  for (const auto& [id, r] : running_) count += r.principal == principal && !r.ended;
  if (count >= limit) throw too_many_jobs(count, limit);
}

std::string JobManager::snapshot_base(const std::string& base, const std::string& id,
                                      const auth::Principal& who) const {
  // Every refusal is a bad input of the execution request (400), a base that names no job too: the
  // resource requested, the process, exists (a 404 would say it does not).
  auto bad = [](const std::string& what) { throw Error(ErrorKind::invalid_argument, "input 'baseJob': " + what); };
  if (!is_job_id(base)) bad("not a job id");
  const std::optional<JobRecord> rec = shared_ ? shared_->get(base) : store_->get(base);
  // Another principal's job is no job, exactly as one that does not exist.
  if (!rec || rec->status == JobStatus::dismissed || !auth::may_see(who, rec->principal)) bad("no job " + base);
  if (rec->status != JobStatus::successful)
    bad("job " + base + " is " + std::string(to_string(rec->status)) + "; only a successful job can be edited");
  // The base's report and kept field, copied (in a folder: linked) into the new job's snapshot
  // now: the base job may be deleted while this one waits or runs, and its files then live on.
  const std::string from = results_prefix(*rec), to = id + "/" + kBaseSnapshotDir;
  const std::string report = output_file_name("report", ""), kept = std::string(kEditBaseDir);
  const std::optional<std::string> manifest_text = objects_.get(from + "/" + kept + "/manifest.json");
  if (!manifest_text) bad("job " + base + " kept nothing for edits (only streamed jobs of the exact method do)");
  nlohmann::json manifest;
  try {
    manifest = nlohmann::json::parse(*manifest_text);
  } catch (const nlohmann::json::exception&) {
    bad("job " + base + " kept a damaged manifest");
  }
  try {
    objects_.copy(from + "/" + report, to + "/" + report);
    for (const std::string& name : objects_.list(from + "/" + kept))
      objects_.copy(from + "/" + kept + "/" + name, to + "/" + kept + "/" + name);
    // The rasters the edit copies tiles from, the job's own beside the kept folder among them (the
    // kept distance may be its distance raster).
    if (manifest.contains("rasters") && manifest["rasters"].is_object())
      for (const auto& [role, r] : manifest["rasters"].items()) {
        if (!r.is_object() || !r.contains("file") || !r["file"].is_string())
          bad("job " + base + " kept a damaged manifest");
        const std::string rel =
            std::filesystem::path(kept + "/" + r["file"].get<std::string>()).lexically_normal().generic_string();
        if (!store::is_object_key(rel) || rel.rfind(kept + "/", 0) == 0) continue;  // outside, or copied above
        if (objects_.exists(from + "/" + rel) && !objects_.exists(to + "/" + rel))
          objects_.copy(from + "/" + rel, to + "/" + rel);
      }
  } catch (const Error& e) {
    if (e.kind() != ErrorKind::io) throw;
    throw Error(ErrorKind::io, std::string("cannot keep the base job's files: ") + e.what());
  }
  return (job_dir(id) / kBaseSnapshotDir / report).string();
}

// Tells a waiting client that its job ended. The callback builds an answer and must not take a
// worker (or the thread that dismissed the job) down with it if that fails: logged, dropped.
void notify_done(const std::function<void(const JobRecord&)>& on_done, const JobRecord& record) {
  if (!on_done) return;
  try {
    on_done(record);
  } catch (...) {
    log_line("{\"time\":\"" + now_rfc3339() + "\",\"event\":\"answer_failed\",\"job\":\"" + record.id + "\"}");
  }
}

JobRecord accepted_record(const std::string& id, const Execution& execution, const auth::Principal& who) {
  JobRecord rec;
  rec.id = id;
  rec.process_id = "voronoi";
  rec.status = JobStatus::accepted;
  rec.message = "queued";
  rec.created = rec.updated = now_rfc3339();
  rec.inputs = execution.inputs_summary;
  rec.outputs = execution.outputs;
  rec.transmission = execution.transmission;
  rec.formats = execution.formats;
  rec.principal = who.name;
  rec.cells = execution.cells;
  return rec;
}

bool exempt_from_limits(const auth::Principal& who) { return who.role == Role::admin && who.how != "none"; }

QuotaExceeded too_many_jobs(int64_t count, int limit) {
  return QuotaExceeded("this principal has " + std::to_string(count) + " jobs queued or running, the most " +
                           std::to_string(limit) + " this server allows each; retry when one has finished",
                       kJobsRetryAfterS);
}

void JobManager::charge_cells(const auth::Principal& who, int64_t cells) {
  if (exempt_from_limits(who)) return;
  if (!shared_) return cells_.charge(who.name, cells);
  // On a shared store the hour is every daemon's (a session's grid counts on all of them).
  shared_->charge(who.name, cells, [&](const store::AdmissionView& v) { admit_shared(v, who, cells, false, false); });
}

void JobManager::submit_work(const std::string& name, const auth::Principal& who,
                             std::shared_ptr<std::atomic<bool>> cancel, std::function<void()> run,
                             std::function<void()> dropped) {
  std::lock_guard lock(mutex_);
  if (stopping_) throw Error(ErrorKind::busy, "the server is shutting down; retry later");
  check_capacity();
  if (!exempt_from_limits(who)) check_job_count(who.name);
  Task t;
  t.id = name;
  t.principal = who.name;
  t.charged = true;
  t.work = std::move(run);
  t.dropped = std::move(dropped);
  t.cancel = std::move(cancel);
  queue_.push_back(std::move(t));
  work_cv_.notify_one();
}

JobRecord JobManager::submit(const std::string& id, Execution execution, const auth::Principal& who, Done on_done) {
  if (shared_) return submit_shared(id, std::move(execution), who, std::move(on_done));
  const JobRecord rec = accepted_record(id, execution, who);
  check_disk();

  std::lock_guard lock(mutex_);
  if (stopping_) throw Error(ErrorKind::busy, "the server is shutting down; resubmit the job later");
  check_capacity();
  const bool exempt = exempt_from_limits(who);
  if (!exempt) check_job_count(who.name);
  // A grid known up front is charged now (refused now when over the allowance); others when
  // they are planned.
  const bool charged = execution.cells > 0;
  if (charged && !exempt) cells_.charge(who.name, execution.cells);
  // An edit's copy of its base is made last: a refused submission leaves no directory behind.
  try {
    if (!execution.spec.base_name.empty())
      execution.spec.base_report = snapshot_base(execution.spec.base_name, id, who);
    store_->insert(rec);
  } catch (...) {
    if (charged && !exempt) cells_.refund(who.name, execution.cells);
    std::error_code ec;
    if (!execution.spec.base_name.empty()) std::filesystem::remove_all(job_dir(id) / kBaseSnapshotDir, ec);
    std::filesystem::remove(job_dir(id), ec);  // only if empty: never another job's files
    throw;
  }
  Task t;
  t.id = id;
  t.execution = std::move(execution);
  t.on_done = std::move(on_done);
  t.principal = who.name;
  t.charged = charged || exempt;
  queue_.push_back(std::move(t));
  work_cv_.notify_one();
  return rec;
}

bool JobManager::next_task(Task& task) {
  std::unique_lock lock(mutex_);
  for (;;) {
    if (!queue_.empty()) {
      task = std::move(queue_.front());
      queue_.pop_front();
      break;
    }
    if (stopping_) return false;  // nothing left
    if (!shared_) {
      work_cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      continue;
    }
    // The shared queue, outside the lock (a database call); then a nap until a notification, a
    // local task or the poll interval.
    const uint64_t hint = queue_hint_;
    lock.unlock();
    std::optional<Task> claimed = claim_shared();
    lock.lock();
    if (claimed && stopping_) {
      lock.unlock();
      release_lease(*claimed->lease, "queued again: the daemon that claimed it is shutting down");
      return false;
    }
    if (claimed) {
      task = std::move(*claimed);
      break;
    }
    work_cv_.wait_for(lock, std::chrono::duration<double>(config_.jobs.poll_s),
                      [&] { return stopping_ || !queue_.empty() || queue_hint_ != hint; });
  }
  Running r;
  r.principal = task.principal;
  r.cancel = task.cancel ? task.cancel : std::make_shared<std::atomic<bool>>(false);
  r.deadline = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                      std::chrono::duration<double>(config_.jobs.job_timeout_s));
  r.lease = task.lease;
  r.leased_at = task.leased_at;
  running_.emplace(task.id, r);
  return true;
}

void JobManager::worker_loop() {
  for (;;) {
    Task task;
    if (!next_task(task)) return;
    if (task.work) {
      task.work();  // answers for itself and never throws
      {
        std::lock_guard lock(mutex_);
        running_.erase(task.id);
      }
      idle_cv_.notify_all();
      continue;
    }
    JobRecord final_record;
    try {
      final_record = run_task(task);
    } catch (...) {
      // The store itself failed (disk full, database gone): the worker must survive it, and
      // the client waiting on the job must still get an answer.
      std::string what = "unknown exception";
      try {
        throw;
      } catch (const std::exception& e) {
        what = e.what();
      } catch (...) {
      }
      log_line("{\"time\":\"" + now_rfc3339() + "\",\"event\":\"job_store_failure\",\"job\":\"" + task.id +
               "\",\"error\":" + json_text(what) + "}");
      final_record.id = task.id;
      final_record.process_id = "voronoi";
      final_record.status = JobStatus::failed;
      final_record.error_kind = std::string(to_string(ErrorKind::io));
      final_record.message = valid_utf8("the job store failed: " + what);
    }
    bool idle = false;
    {
      std::lock_guard lock(mutex_);
      running_.erase(task.id);
      idle = running_.empty();
    }
    idle_cv_.notify_all();
    log_line("{\"time\":\"" + now_rfc3339() + "\",\"event\":\"job\",\"job\":\"" + task.id + "\",\"status\":\"" +
             std::string(to_string(final_record.status)) + "\",\"message\":" + json_text(final_record.message) + "}");
    // Only now: whoever is told the job ended (a synchronous client) may act on it at once, and
    // a dismissal then finds it finished, not running.
    notify_done(task.on_done, final_record);
#ifdef __GLIBC__
    // The job's grid-sized buffers are free now, but glibc keeps freed heap memory in the arenas
    // (large blocks under its adaptive mmap threshold included) for reuse. A daemon idles most
    // of the time: hand the memory back when no job runs, so that its resident size returns near
    // its start instead of staying at the last peak (tests/service/daemon/test_load.py checks it).
    // After the answer above, which need not wait for it.
    if (idle) malloc_trim(0);
#endif
  }
}

void JobManager::update_progress(JobRecord& record, const std::string& stage, double fraction, bool validate,
                                 int& last_percent) {
  // The stages' shares of the whole: reading and writing are short next to the computation;
  // brute-force validation, when asked for, costs about as much as the computation.
  double lo = 0, hi = 10;
  if (stage == "compute") {
    lo = 10;
    hi = validate ? 50 : 90;
  } else if (stage == "validate") {
    lo = 50;
    hi = 90;
  } else if (stage == "write" || stage == "deliver") {
    lo = 90;
    hi = 99;
  }
  const double f = std::isfinite(fraction) ? std::clamp(fraction, 0.0, 1.0) : 0.0;
  const int percent = static_cast<int>(lo + (hi - lo) * f);
  if (percent <= last_percent) return;  // monotonic, and at most ~100 store writes per job
  last_percent = percent;
  {
    std::lock_guard lock(mutex_);
    record.progress = percent;
    record.message = "running: " + stage;
    record.updated = now_rfc3339();
  }
  try {
    write_running(record.id, record);
  } catch (const std::exception&) {
    // Progress is advisory, and this runs on an engine thread: a failed write must not end
    // the computation. The final status is written (and its failure handled) by the worker.
  }
}

bool JobManager::write_running(const std::string& id, const JobRecord& rec) {
  if (!shared_) {
    std::lock_guard lock(mutex_);
    const auto it = running_.find(id);
    if (it == running_.end() || it->second.dismissed) return false;
    store_->update(rec);
    return true;
  }
  std::optional<store::Lease> lease;
  JobRecord copy;
  {
    std::lock_guard lock(mutex_);
    const auto it = running_.find(id);
    if (it == running_.end() || it->second.dismissed || it->second.lost || !it->second.lease) return false;
    lease = it->second.lease;
    copy = rec;
  }
  // Outside the lock: a database call may wait for a connection, and /health must not.
  if (shared_->write_running(*lease, copy)) return true;
  lose_lease(id);
  return false;
}

namespace {

// The job as the façade runs it: every file in the job's directory, COGs, only the requested
// outputs (the file name's extension selects the format). The ownership raster is always
// written (it carries the owner names, its attribute table); the report is written by the
// worker, with file names instead of this server's paths.
JobSpec spec_in_directory(const Execution& execution, const JobRecord& rec, const std::filesystem::path& dir) {
  JobSpec spec = execution.spec;
  OutputRequest& out = spec.outputs;
  out.cloud_optimized = true;
  out.ownership = (dir / output_file_name("ownership", "")).string();
  out.report.clear();
  out.edit_base = (dir / kEditBaseDir).string();
  for (size_t i = 0; i < rec.outputs.size(); ++i) {
    const std::string& id = rec.outputs[i];
    if (id == "ownership" || id == "report") continue;  // above
    if (std::string* path = output_path(out, id))
      *path = (dir / output_file_name(id, i < rec.formats.size() ? rec.formats[i] : "")).string();
  }
  return spec;
}

}  // namespace

// The message of a failed job as its client should read it.
std::string client_message(const Error& e, const std::string& id, const std::filesystem::path& dir) {
  std::string message = client_names(valid_utf8(e.what()), id);
  // The job directory is this server's business: the client knows the files by output id.
  for (size_t at; (at = message.find(dir.string() + "/")) != std::string::npos;)
    message.erase(at, dir.string().size() + 1);
  // Reading happens in memory; an I/O failure is the result files (a full disk, a file size
  // limit): say so first, GDAL's reason (e.g. "No space left on device") follows.
  if (e.kind() == ErrorKind::io) message = "the job's results could not be written: " + message;
  // The seed reader names the feature at fault; say which input it came from (the seeds, unless
  // the message names one of the other uploads).
  if (e.kind() == ErrorKind::invalid_input || e.kind() == ErrorKind::conflict) {
    std::string input = "seeds";
    for (const OptionSpec& o : job_options())
      if (o.type == OptionType::layers && o.input != "seeds" && message.find(o.input) != std::string::npos)
        input = std::string(o.input);
    if (message.rfind(input + ": ", 0) == 0) message.erase(0, input.size() + 2);  // said once
    message = "input '" + input + "': " + message;
  }
  return message;
}

Outcome execute(const JobRunner& runner, const JobSpec& spec, const JobLimits& limits, const JobHooks& hooks,
                const std::string& id, const std::filesystem::path& dir) {
  Outcome o;
  try {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw Error(ErrorKind::io, "cannot create the job directory: " + ec.message());
    o.result = runner(spec, limits, hooks);
    if (o.result.report.contains("outputs") && o.result.report["outputs"].is_object()) {
      for (auto& [key, value] : o.result.report["outputs"].items())
        if (value.is_string()) value = std::filesystem::path(value.get<std::string>()).filename().string();
    }
    write_file_atomically(dir / output_file_name("report", ""), json_text(o.result.report, 2) + "\n");
  } catch (const Error& e) {
    o.error_kind = e.kind();
    o.message = client_message(e, id, dir);
  } catch (const std::bad_alloc&) {
    o.error_kind = ErrorKind::too_large;
    o.message = "the job ran out of memory; use a coarser resolution or a smaller extent";
  } catch (const std::exception& e) {
    o.error_kind = ErrorKind::internal;
    o.message = valid_utf8(e.what());
  } catch (...) {
    o.error_kind = ErrorKind::internal;
    o.message = "unknown exception";
  }
  return o;
}

JobRecord JobManager::run_task(Task& task) {
  const std::string& id = task.id;
  // A shared store's attempts write apart: a worker that lost its lease cannot touch the files
  // of the attempt that replaced it.
  const std::filesystem::path dir = task.lease ? job_dir(id) / std::to_string(task.lease->attempt) : job_dir(id);
  std::shared_ptr<std::atomic<bool>> cancel;
  std::optional<JobRecord> stored;
  {
    std::lock_guard lock(mutex_);
    cancel = running_.at(id).cancel;
  }
  stored = task.lease ? std::optional<JobRecord>(task.claimed) : store_->get(id);
  if (!stored) throw Error(ErrorKind::internal, "job " + id + " vanished from the store");
  JobRecord rec = *stored;
  if (task.kind == "band") return run_band(task, rec);
  try {
    // Parsed again from the stored request, as the daemon that accepted it did: a request that
    // no longer parses (a build that reads it otherwise) fails the job with the reason.
    if (task.from_queue) task.execution = load_execution(id, task.lease->attempt);
    // An edit on a bucket reads its base's snapshot from this daemon's disk.
    if (task.lease && !task.execution.spec.base_name.empty()) fetch_base(id);
  } catch (const Error& e) {
    // Not the results: the job's own stored files (its request, its base) could not be read.
    record_end(rec, e.kind(), e.kind() == ErrorKind::io ? valid_utf8(e.what()) : client_message(e, id, dir), nullptr,
               dir);
    return rec;
  }
  JobSpec spec = spec_in_directory(task.execution, rec, dir);
  try {
    // A large job is split into bands for every daemon, and assembled once they are computed.
    if (task.from_queue && split_or_assemble(task, rec, dir, spec)) return rec;
  } catch (const Error& e) {
    // The store away is not the job's fault: it stays running, and its lease, no longer renewed,
    // expires and queues it again. Any other failure is the job's.
    if (e.kind() == ErrorKind::busy) {
      lose_lease(id);
      remove_dir(dir);
      return rec;
    }
    record_end(rec, e.kind(), valid_utf8(e.what()), nullptr, dir);
    return rec;
  }

  rec.status = JobStatus::running;
  rec.message = "running";
  rec.started = rec.updated = task.lease ? rec.started : now_rfc3339();
  rec.progress = 0;
  if (!task.lease) write_running(id, rec);  // a shared store's claim recorded it

  int last_percent = 0;
  JobHooks hooks;
  hooks.cancel = cancel.get();
  hooks.progress = [&](const std::string& stage, double fraction) {
    update_progress(rec, stage, fraction, spec.validate, last_percent);
  };
  // Held until the job's end: whatever it reserved returns to the account then.
  MemoryAccount::Reservation memory = memory_.open();
  hooks.reserve_memory = [&memory, cancel, id](int64_t bytes) { memory.need(bytes, true, cancel.get(), "job " + id); };
  // A grid known only from its seeds is charged to the principal's hour now (refused, failing
  // the job, when over it) and recorded with the job, so that a restart counts it too.
  // The record keeps the grid's size either way: a job failed over the allowance answers with
  // the Retry-After its cells need (and the store's charges leave such jobs out).
  hooks.planned = [this, &rec, &task](int64_t cells) {
    {
      std::lock_guard lock(mutex_);
      rec.cells = cells;
    }
    if (task.lease && !task.charged) {
      task.charged = true;
      charge_planned_shared(task, cells);
      return;
    }
    if (!task.charged) cells_.charge(task.principal, cells);
    task.charged = true;
    write_running(rec.id, rec);
  };
  Outcome outcome = execute(task.execution.run ? task.execution.run : runner_, spec, limits_, hooks, id, dir);
  memory.release();
  task.execution.uploads.reset();                       // the in-memory seed files are no longer needed
  if (!task.lease) remove_dir(dir / kBaseSnapshotDir);  // a shared job's attempts may need it again
  record_end(rec, outcome.error_kind, outcome.message, outcome.result.report, dir);
  return rec;
}

void JobManager::end_record(JobRecord& rec, const std::optional<ErrorKind>& error_kind, const std::string& message,
                            const nlohmann::json& report, bool timed_out, bool shut_down) const {
  rec.finished = rec.updated = now_rfc3339();
  if (!error_kind) {
    rec.status = JobStatus::successful;
    rec.message = "finished";
    rec.progress = 100;
    rec.report = report;
    return;
  }
  rec.status = JobStatus::failed;
  rec.error_kind = std::string(to_string(*error_kind));
  rec.message = message;
  if (timed_out) {
    rec.error_kind = std::string(to_string(ErrorKind::too_large));
    rec.message = "the job exceeded this server's time limit of " + seconds_text(config_.jobs.job_timeout_s) +
                  " s and was cancelled";
  } else if (shut_down) {
    rec.error_kind = std::string(to_string(ErrorKind::busy));
    rec.message = "the server shut down while the job was running; resubmit it";
  }
}

void JobManager::record_end(JobRecord& rec, const std::optional<ErrorKind>& error_kind, const std::string& message,
                            const nlohmann::json& report, const std::filesystem::path& dir) {
  if (shared_) return record_end_shared(rec, error_kind, message, report, dir);
  std::lock_guard lock(mutex_);
  Running& r = running_.at(rec.id);
  // Under the same lock as the record: a client that reads the job as finished and submits at
  // once is not refused for it, while the worker is still letting go of it.
  r.ended = true;
  if (r.dismissed) {
    // dismiss() has recorded the status already; the files go whatever run_job returned.
    remove_dir(dir);
    rec = store_->get(rec.id).value_or(rec);
    return;
  }
  end_record(rec, error_kind, message, report, r.timed_out, r.shutdown);
  if (rec.status == JobStatus::failed) remove_dir(dir);
  store_->update(rec);
}

std::optional<JobRecord> JobManager::dismiss(const std::string& id) {
  if (shared_) return dismiss_shared(id);
  std::optional<Task> dropped;
  std::optional<JobRecord> rec;
  {
    std::lock_guard lock(mutex_);
    rec = store_->get(id);
    if (!rec) return std::nullopt;
    if (rec->status == JobStatus::dismissed) return rec;
    const std::string now = now_rfc3339();
    for (auto it = queue_.begin(); it != queue_.end(); ++it) {
      if (it->id == id) {
        dropped = std::move(*it);
        queue_.erase(it);
        break;
      }
    }
    // A job recorded as finished may still be on its worker's list for a moment (record_end ran,
    // the worker has not let go of it yet): it is finished, and its files go now.
    const bool finished = rec->status == JobStatus::successful || rec->status == JobStatus::failed;
    if (const auto r = running_.find(id); r != running_.end() && !finished) {
      r->second.dismissed = true;
      r->second.cancel->store(true);
      rec->message = "dismissed by the client; the computation was cancelled";
    } else if (dropped) {
      rec->message = "dismissed by the client before it started";
    } else {
      rec->message = "dismissed by the client; its results were deleted";
      remove_dir(job_dir(id));
    }
    rec->status = JobStatus::dismissed;
    rec->finished = rec->finished.empty() ? now : rec->finished;
    rec->updated = now;
    store_->update(*rec);
  }
  if (dropped) notify_done(dropped->on_done, *rec);
  return rec;
}

void JobManager::shutdown(std::chrono::duration<double> grace) {
  std::vector<Task> dropped;
  std::vector<JobRecord> dropped_records;
  {
    std::unique_lock lock(mutex_);
    if (joined_) return;
    stopping_ = true;
    // Queued jobs' inputs live in memory and die with the process: fail them now, clearly.
    const std::string now = now_rfc3339();
    while (!queue_.empty()) {
      Task t = std::move(queue_.front());
      queue_.pop_front();
      if (t.work) {
        dropped.push_back(std::move(t));
        dropped_records.emplace_back();
        continue;
      }
      if (auto rec = t.lease ? std::optional<JobRecord>(t.claimed) : store_->get(t.id)) {
        rec->status = JobStatus::failed;
        rec->error_kind = std::string(to_string(ErrorKind::busy));
        rec->message = "the server shut down before the job started; resubmit it";
        rec->finished = rec->updated = now;
        if (!t.lease) store_->update(*rec);  // a shared store's: below, outside the lock
        dropped_records.push_back(*rec);
        dropped.push_back(std::move(t));
      }
    }
    work_cv_.notify_all();
    idle_cv_.wait_for(lock, grace, [this] { return running_.empty(); });
    for (auto& [id, r] : running_) {
      r.shutdown = true;
      r.cancel->store(true);
    }
  }
  for (size_t i = 0; i < dropped.size(); ++i) {
    if (dropped[i].work) {
      if (dropped[i].dropped) dropped[i].dropped();
      continue;
    }
    if (dropped[i].lease) {
      try {
        shared_->finish(*dropped[i].lease, dropped_records[i], "");
      } catch (const std::exception&) {
        // The store is away: the job's lease expires, and a reaper fails it (only this daemon
        // could have run it).
      }
    }
    notify_done(dropped[i].on_done, dropped_records[i]);
  }
  for (std::thread& w : workers_) w.join();
  {
    std::lock_guard lock(mutex_);
    joined_ = true;
  }
  watchdog_cv_.notify_all();
  watchdog_.join();
  if (shared_) {
    shared_stop_ = true;
    shared_cv_.notify_all();
    heartbeat_.join();
    listener_.join();
    sweeper_.join();
  }
}

void JobManager::watchdog_loop() {
  std::unique_lock lock(mutex_);
  while (!joined_) {
    watchdog_cv_.wait_for(lock, std::chrono::milliseconds(100));
    const auto now = std::chrono::steady_clock::now();
    for (auto& [id, r] : running_) {
      if (!r.timed_out && now > r.deadline) {
        r.timed_out = true;
        r.cancel->store(true);
      }
    }
  }
}

}  // namespace rv::daemon
