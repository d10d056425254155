// The daemon's live what-if sessions (issue 54): rv::Session objects held in memory, each owned by
// the principal that created it, edited through the HTTP API.
//
// Ids: "<daemon>.<run>.<random>": the daemon's name (ServerConfig::daemon_name, so that a shared
// service can tell which daemon holds a session), 8 hex digits drawn at this process's start
// (an id of an earlier run is answered "lost in a restart", not "no such session"), and 24 random
// hex digits. Another principal's session answers exactly as one that does not exist.
//
// Scheduling: a session's creation is work on the job workers (JobManager::submit_work: it waits
// in the job queue and counts as its principal's job). Everything else that touches a session
// (its status, features, deliverables, edits, undo, redo, saving) runs on this manager's own
// threads (sessions.workers), never behind queued jobs, one request of a session at a time in
// the order they came; at most sessions.pending_per_session wait behind the running one (then
// rv::Error busy).
//
// Limits: sessions.max_sessions held at once (busy), sessions.max_per_principal (QuotaExceeded);
// memory: every session's bytes together at most sessions_memory_budget() (a creation or an edit
// that would pass it: busy, and an edit rolls back), one session at most
// session_memory_limit() (too_large, likewise); a session's bytes are also held in the daemon's
// memory account (a standing reservation, so jobs see them). A session unused for
// sessions.idle_expiry_s is deleted; its id then answers 404 saying it expired.
//
// Thread safety: every public member may be called from any thread.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "auth/principal.hpp"
#include "daemon/server_execute.hpp"
#include "daemon/server_jobs.hpp"
#include "runtime/server_capacity.hpp"
#include "rv/server_config.hpp"
#include "rv/session.hpp"

namespace rv::daemon {

// The host name and port as a daemon name ([a-z0-9-], at most 63 characters).
std::string default_daemon_name(unsigned short port);

class SessionManager {
 public:
  SessionManager(const ServerConfig& config, JobManager& jobs, MemoryAccount& memory, std::string daemon_name);
  ~SessionManager();  // stop()
  SessionManager(const SessionManager&) = delete;
  SessionManager& operator=(const SessionManager&) = delete;

  const std::string& daemon_name() const { return name_; }

  // Called once when a creation ends: the session's status document (ready or failed), and the
  // error when it failed (nullptr when ready).
  using Created = std::function<void(const nlohmann::json& status, std::exception_ptr error)>;

  // Starts creating a session of `who` from `spec` (its outputs name the deliverables to keep;
  // `uploads`, staged under the id `upload_id`, holds its seed files until the creation ends)
  // and returns its id at once.
  // `on_created` is called on a worker thread when it is ready or failed; with `keep_failed`
  // false, a failed session is forgotten then (its creator was told), else it stays, status
  // "failed", for a poller to read until it expires. Throws rv::Error busy (sessions.max_sessions,
  // the job queue full, shutting down), QuotaExceeded (the principal's sessions or jobs).
  std::string create(JobSpec spec, std::shared_ptr<VsiMemFiles> uploads, const std::string& upload_id,
                     const auth::Principal& who, Created on_created, bool keep_failed);

  // A task on a ready session, run on a session thread in its turn; it answers its request
  // itself. What it throws goes to `fail`, as does a deletion or shutdown before its turn.
  using Task = std::function<void(Session& session)>;
  using Fail = std::function<void(std::exception_ptr error)>;
  // Queues `task` on session `id` as `who` sees it; `changes`: it edits the session (the memory
  // limits are set before and the session's bytes measured after). Throws rv::Error not_found
  // (no such session for `who`, with what became of it: expired, deleted, lost in a restart,
  // held by another daemon, still being created, failed) and busy (too many waiting).
  void run(const std::string& id, const auth::Principal& who, bool changes, Task task, Fail fail);

  // The status document of session `id` (sessionID, status "creating" / "ready" / "failed",
  // message, progress, created, lastUsed, expires, principal, daemon; a ready session's
  // Session::info() members besides, read in its turn). `reply` gets it (maybe on another
  // thread), or `fail` the error; throws as run() for a session `who` cannot see.
  void status(const std::string& id, const auth::Principal& who, std::function<void(nlohmann::json)> reply, Fail fail);
  // Deletes session `id` (a creation under way is cancelled) and returns its last status
  // (status "deleted"). Throws as run().
  nlohmann::json remove(const std::string& id, const auth::Principal& who);
  // The sessions `who` may see (an admin: every one), their status without Session::info().
  nlohmann::json list(const auth::Principal& who) const;

  int count() const;
  int64_t memory_bytes() const;

  // Fails what waits, joins the threads, deletes every session. Idempotent. Call after the job
  // manager's shutdown (creations under way end there).
  void stop();

 private:
  struct Held;
  struct Queued {
    Task task;
    Fail fail;
    bool changes = false;
  };

  std::shared_ptr<Held> find(const std::string& id, const auth::Principal& who) const;  // mutex_ held
  nlohmann::json status_of(const Held& h) const;                                        // mutex_ held
  void build(const std::shared_ptr<Held>& held, JobSpec spec, std::shared_ptr<VsiMemFiles> uploads,
             const std::string& upload_id, const auth::Principal& who, Created on_created, bool keep_failed);
  void forget(const std::string& id, const std::string& principal, std::string reason);  // mutex_ held
  void run_one(const std::shared_ptr<Held>& held, Queued q);
  void worker_loop();
  void sweep_loop();

  const ServerConfig& config_;
  JobManager& jobs_;
  MemoryAccount& memory_;
  const std::string name_;
  const std::string run_;  // this process's run, in every id it gives
  const int64_t budget_;   // every session together
  const int64_t one_;      // one session

  mutable std::mutex mutex_;
  std::condition_variable work_cv_;
  std::condition_variable sweep_cv_;
  std::map<std::string, std::shared_ptr<Held>> sessions_;
  std::deque<std::shared_ptr<Held>> ready_;  // sessions with a request to run, in turn
  // What became of ids no longer held (expired, deleted), for their owners' 404s; oldest first.
  std::map<std::string, std::pair<std::string, std::string>> gone_;  // id -> (principal, reason)
  std::deque<std::string> gone_order_;
  int64_t bytes_ = 0;  // every ready session's bytes
  bool stopping_ = false;
  std::vector<std::thread> workers_;
  std::thread sweeper_;
};

}  // namespace rv::daemon
