#include "daemon/server_sessions.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>

#include "runtime/principal_usage.hpp"
#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"

namespace rv::daemon {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

constexpr size_t kGoneKept = 4096;  // ids whose fate is remembered for their owners' 404s
constexpr int64_t kSessionsRetryAfterS = 30;

bool is_hex(std::string_view s) {
  return std::all_of(s.begin(), s.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

}  // namespace

std::string default_daemon_name(unsigned short port) {
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  std::string name;
  for (const char* c = host; *c != '\0'; ++c) {
    const char l = static_cast<char>(std::tolower(static_cast<unsigned char>(*c)));
    name += (l >= 'a' && l <= 'z') || (l >= '0' && l <= '9') ? l : '-';
  }
  if (name.empty()) name = "rvoronoi";
  const std::string suffix = "-" + std::to_string(port);
  return name.substr(0, 63 - suffix.size()) + suffix;
}

struct SessionManager::Held {
  std::string id;
  std::string principal;
  std::string status = "creating";  // "creating", "ready", "failed"
  std::string message = "queued";
  std::string error_kind;  // a failed creation's
  int progress = 0;
  std::chrono::system_clock::time_point created = std::chrono::system_clock::now();
  std::chrono::system_clock::time_point last_used = created;
  Clock::time_point last_used_steady = Clock::now();
  std::unique_ptr<Session> session;
  MemoryAccount::Reservation memory;
  int64_t bytes = 0;  // counted in bytes_ (ready sessions)
  std::shared_ptr<std::atomic<bool>> cancel = std::make_shared<std::atomic<bool>>(false);
  std::deque<Queued> queued;
  bool active = false;  // on ready_ or running
  bool gone = false;    // deleted, expired or shutting down: its requests fail
  std::string gone_reason;
};

SessionManager::SessionManager(const ServerConfig& config, JobManager& jobs, MemoryAccount& memory,
                               std::string daemon_name)
    : config_(config),
      jobs_(jobs),
      memory_(memory),
      name_(std::move(daemon_name)),
      run_(new_job_id().substr(0, 8)),
      budget_(sessions_memory_budget(config)),
      one_(session_memory_limit(config)) {
  for (int i = 0; i < std::max(1, config_.sessions.workers); ++i) workers_.emplace_back([this] { worker_loop(); });
  sweeper_ = std::thread([this] { sweep_loop(); });
}

SessionManager::~SessionManager() { stop(); }

int SessionManager::count() const {
  std::lock_guard lock(mutex_);
  int n = 0;
  for (const auto& [id, h] : sessions_) n += h->status != "failed";
  return n;
}

int64_t SessionManager::memory_bytes() const {
  std::lock_guard lock(mutex_);
  return bytes_;
}

json SessionManager::status_of(const Held& h) const {
  const auto expires = h.last_used + std::chrono::duration_cast<std::chrono::system_clock::duration>(
                                         std::chrono::duration<double>(config_.sessions.idle_expiry_s));
  json s = {{"sessionID", h.id},
            {"status", h.status},
            {"message", h.message},
            {"progress", h.progress},
            {"created", rfc3339(h.created)},
            {"lastUsed", rfc3339(h.last_used)},
            {"expires", rfc3339(expires)},
            {"principal", h.principal},
            {"daemon", name_}};
  if (h.status == "ready") s["memoryBytes"] = h.bytes;
  if (h.status == "failed") s["errorKind"] = h.error_kind;
  return s;
}

std::shared_ptr<SessionManager::Held> SessionManager::find(const std::string& id, const auth::Principal& who) const {
  const std::string shown = "'" + id.substr(0, 128) + "'";
  // <daemon>.<run: 8 hex>.<24 hex>
  const size_t second = id.rfind('.');
  const size_t first = second == std::string::npos || second == 0 ? std::string::npos : id.rfind('.', second - 1);
  if (first == std::string::npos || second - first != 9 || id.size() - second != 25 || first == 0 ||
      !is_hex(std::string_view(id).substr(first + 1, 8)) || !is_hex(std::string_view(id).substr(second + 1)))
    throw Error(ErrorKind::not_found, "no session " + shown);
  const std::string daemon = id.substr(0, first);
  if (daemon != name_) {
    // On a shared service the daemons announce where they answer: point there. No redirect: a
    // browser drops Authorization when a redirect crosses origins, and the client must know.
    const std::string url = jobs_.daemon_url(daemon);
    throw Error(ErrorKind::not_found, "session " + shown + " is held by the daemon '" + daemon.substr(0, 63) +
                                          "', not by this one ('" + name_ + "'); ask that daemon" +
                                          (url.empty() ? std::string() : ", at " + url + "/sessions/" + id) +
                                          ", with the same token");
  }
  if (id.compare(first + 1, 8, run_) != 0)
    throw Error(ErrorKind::not_found, "session " + shown +
                                          " was lost when this daemon restarted: sessions live in memory and a "
                                          "restart loses them (jobs saved from a session survive); create it again");
  if (const auto it = sessions_.find(id); it != sessions_.end() && auth::may_see(who, it->second->principal))
    return it->second;
  if (const auto it = gone_.find(id); it != gone_.end() && auth::may_see(who, it->second.first))
    throw Error(ErrorKind::not_found, it->second.second);
  throw Error(ErrorKind::not_found, "no session " + shown);
}

void SessionManager::forget(const std::string& id, const std::string& principal, std::string reason) {
  const auto it = sessions_.find(id);
  if (it != sessions_.end()) {
    Held& h = *it->second;
    h.gone = true;
    h.gone_reason = reason;
    h.cancel->store(true);
    if (h.status == "ready") bytes_ -= h.bytes;
    sessions_.erase(it);
  }
  if (gone_.emplace(id, std::make_pair(principal, std::move(reason))).second) gone_order_.push_back(id);
  while (gone_order_.size() > kGoneKept) {
    gone_.erase(gone_order_.front());
    gone_order_.pop_front();
  }
}

std::string SessionManager::create(JobSpec spec, std::shared_ptr<VsiMemFiles> uploads, const std::string& upload_id,
                                   const auth::Principal& who, Created on_created, bool keep_failed) {
  auto held = std::make_shared<Held>();
  {
    std::lock_guard lock(mutex_);
    if (stopping_) throw Error(ErrorKind::busy, "the server is shutting down; retry later");
    int all = 0, mine = 0;
    for (const auto& [id, h] : sessions_) {
      if (h->status == "failed") continue;
      ++all;
      mine += h->principal == who.name;
    }
    if (all >= config_.sessions.max_sessions)
      throw Error(ErrorKind::busy, "this daemon holds " + std::to_string(all) + " sessions, its most (sessions." +
                                       "max_sessions = " + std::to_string(config_.sessions.max_sessions) +
                                       "); retry when one is deleted or expires");
    const bool exempt = who.role == Role::admin && who.how != "none";
    const int per = config_.sessions.max_per_principal;
    if (!exempt && per > 0 && mine >= per)
      throw QuotaExceeded("this principal holds " + std::to_string(mine) +
                              " sessions, the most this server allows "
                              "each (sessions.max_per_principal = " +
                              std::to_string(per) + "); delete one or let one expire",
                          kSessionsRetryAfterS);
    std::string id;
    do {
      id = name_ + "." + run_ + "." + new_job_id().substr(0, 24);
    } while (sessions_.count(id));
    held->id = id;
    held->principal = who.name;
    sessions_.emplace(id, held);
  }
  try {
    jobs_.submit_work(
        held->id, who, held->cancel,
        [this, held, spec = std::move(spec), uploads, upload_id, who, on_created, keep_failed]() mutable {
          build(held, std::move(spec), std::move(uploads), upload_id, who, std::move(on_created), keep_failed);
        },
        [this, held, on_created] {
          json status;
          {
            std::lock_guard lock(mutex_);
            forget(held->id, held->principal,
                   "session '" + held->id + "' was not created: the server shut down first; create it again");
            status = status_of(*held);
          }
          try {
            on_created(status, std::make_exception_ptr(
                                   Error(ErrorKind::busy, "the server shut down before the session was created")));
          } catch (...) {
          }
        });
  } catch (...) {
    std::lock_guard lock(mutex_);
    sessions_.erase(held->id);
    throw;
  }
  return held->id;
}

void SessionManager::build(const std::shared_ptr<Held>& held, JobSpec spec, std::shared_ptr<VsiMemFiles> uploads,
                           const std::string& upload_id, const auth::Principal& who, Created on_created,
                           bool keep_failed) {
  const std::string what = "session " + held->id;
  MemoryAccount::Reservation memory = memory_.open();
  std::unique_ptr<Session> session;
  std::exception_ptr error;
  json status;
  try {
    {
      std::lock_guard lock(mutex_);
      if (held->gone) throw Error(ErrorKind::cancelled, held->gone_reason);
      held->message = "running: read";
    }
    JobHooks hooks;
    hooks.cancel = held->cancel.get();
    int last = 0;
    hooks.progress = [&](const std::string& stage, double fraction) {
      const double lo = stage == "compute" ? 10 : stage == "deliver" ? 90 : 0;
      const double hi = stage == "compute" ? 90 : stage == "deliver" ? 99 : 10;
      const int p = static_cast<int>(lo + (hi - lo) * (std::isfinite(fraction) ? std::clamp(fraction, 0.0, 1.0) : 0));
      if (p <= last) return;
      last = p;
      std::lock_guard lock(mutex_);
      held->progress = p;
      held->message = "running: " + stage;
    };
    hooks.reserve_memory = [&](int64_t bytes) { memory.need(bytes, true, held->cancel.get(), what); };
    hooks.planned = [&](int64_t cells) { jobs_.charge_cells(who, cells); };
    int64_t room = 0;
    {
      std::lock_guard lock(mutex_);
      room = budget_ - bytes_;
    }
    SessionLimits limits;
    limits.undo_depth = config_.sessions.undo_depth;
    limits.max_memory_bytes = std::max<int64_t>(1, std::min(one_, room));
    try {
      session = Session::create(spec, limits, effective_limits(config_), hooks);
    } catch (const Error& e) {
      // Over what the other sessions leave, not over one session's limit: come back later.
      if (e.kind() == ErrorKind::too_large && room < one_)
        throw Error(ErrorKind::busy, std::string(e.what()) + "; the sessions on this daemon hold " +
                                         mib_text(budget_ - room) + " of their " + mib_text(budget_) +
                                         ", retry when one is deleted or expires");
      throw;
    }
    session->set_memory_limit(one_);
    const int64_t bytes = session->memory_bytes();
    json info = session->info();
    std::lock_guard lock(mutex_);
    if (held->gone) throw Error(ErrorKind::cancelled, held->gone_reason);
    if (bytes_ + bytes > budget_)
      throw Error(ErrorKind::busy, "the session takes " + mib_text(bytes) + " and the sessions on this daemon hold " +
                                       mib_text(bytes_) + " of their " + mib_text(budget_) +
                                       "; retry when one is deleted or expires");
    memory.settle(bytes);
    held->memory = std::move(memory);
    held->session = std::move(session);
    held->bytes = bytes;
    bytes_ += bytes;
    held->status = "ready";
    held->message = "ready";
    held->progress = 100;
    held->last_used = std::chrono::system_clock::now();
    held->last_used_steady = Clock::now();
    status = status_of(*held);
    for (auto& [key, value] : info.items()) status[key] = value;
  } catch (...) {
    error = std::current_exception();
    std::string message = "unknown error", kind = std::string(to_string(ErrorKind::internal));
    try {
      throw;
    } catch (const Error& e) {
      // The uploads' paths in the names the client knows (seeds[n], ...); an error that names
      // none is passed on as it is (a QuotaExceeded keeps its Retry-After).
      message = client_names(valid_utf8(e.what()), upload_id);
      kind = std::string(to_string(e.kind()));
      if (message != e.what()) error = std::make_exception_ptr(Error(e.kind(), message));
    } catch (const std::bad_alloc&) {
      message = "the session ran out of memory; use a coarser resolution or a smaller extent";
      kind = std::string(to_string(ErrorKind::too_large));
      error = std::make_exception_ptr(Error(ErrorKind::too_large, message));
    } catch (const std::exception& e) {
      message = valid_utf8(e.what());
    } catch (...) {
    }
    std::lock_guard lock(mutex_);
    held->status = "failed";
    held->error_kind = kind;
    held->message = message;
    held->last_used = std::chrono::system_clock::now();
    held->last_used_steady = Clock::now();
    status = status_of(*held);
    if (!keep_failed && !held->gone) {
      sessions_.erase(held->id);
      held->gone = true;
    }
  }
  session.reset();  // a session refused after it was made is freed here, off the lock
  uploads.reset();
  log_event("{\"event\":\"session\",\"session\":\"" + held->id + "\",\"status\":\"" +
            status["status"].get<std::string>() + "\",\"message\":" + json(status["message"]).dump() + "}");
  try {
    on_created(status, error);
  } catch (...) {
  }
}

void SessionManager::run(const std::string& id, const auth::Principal& who, bool changes, Task task, Fail fail) {
  std::lock_guard lock(mutex_);
  if (stopping_) throw Error(ErrorKind::busy, "the server is shutting down; retry later");
  const std::shared_ptr<Held> held = find(id, who);
  if (held->status == "creating")
    throw Error(ErrorKind::not_found, "session '" + id + "' is still being created (" + std::to_string(held->progress) +
                                          " %); poll GET /sessions/" + id);
  if (held->status == "failed")
    throw Error(ErrorKind::not_found, "session '" + id + "' could not be created: " + held->message);
  if (static_cast<int>(held->queued.size()) > config_.sessions.pending_per_session)
    throw Error(ErrorKind::busy, "session '" + id + "' has " + std::to_string(held->queued.size()) +
                                     " requests waiting, the most this server queues (sessions.pending_per_session); "
                                     "retry when they are answered");
  held->queued.push_back(Queued{std::move(task), std::move(fail), changes});
  if (!held->active) {
    held->active = true;
    ready_.push_back(held);
    work_cv_.notify_one();
  }
}

void SessionManager::status(const std::string& id, const auth::Principal& who, std::function<void(json)> reply,
                            Fail fail) {
  json now;
  {
    std::lock_guard lock(mutex_);
    const std::shared_ptr<Held> held = find(id, who);
    if (held->status != "ready") now = status_of(*held);
  }
  if (!now.is_null()) return reply(std::move(now));
  run(
      id, who, false,
      [this, id, reply](Session& session) {
        json info = session.info();
        json s;
        {
          std::lock_guard lock(mutex_);
          const auto it = sessions_.find(id);
          if (it == sessions_.end()) throw Error(ErrorKind::not_found, "session '" + id + "' is gone");
          s = status_of(*it->second);
        }
        for (auto& [key, value] : info.items()) s[key] = value;
        reply(std::move(s));
      },
      std::move(fail));
}

json SessionManager::remove(const std::string& id, const auth::Principal& who) {
  std::shared_ptr<Held> held;
  json status;
  {
    std::lock_guard lock(mutex_);
    held = find(id, who);
    status = status_of(*held);
    status["status"] = "deleted";
    status["message"] = "deleted";
    forget(id, held->principal, "session '" + id + "' was deleted");
  }
  // Its memory returns now unless a request of it is running (then when that ends).
  std::unique_ptr<Session> session;
  {
    std::lock_guard lock(mutex_);
    if (!held->active) {
      session = std::move(held->session);
      held->memory.release();
    }
  }
  session.reset();
  log_event("{\"event\":\"session\",\"session\":\"" + id + "\",\"status\":\"deleted\"}");
  return status;
}

json SessionManager::list(const auth::Principal& who) const {
  std::lock_guard lock(mutex_);
  json out = json::array();
  for (const auto& [id, h] : sessions_)
    if (auth::may_see(who, h->principal)) out.push_back(status_of(*h));
  return out;
}

void SessionManager::run_one(const std::shared_ptr<Held>& held, Queued q) {
  std::exception_ptr error;
  try {
    int64_t room = 0;
    {
      std::lock_guard lock(mutex_);
      if (held->gone) throw Error(ErrorKind::not_found, held->gone_reason);
      room = budget_ - (bytes_ - held->bytes);
    }
    Session& session = *held->session;
    int64_t limit = one_;
    if (q.changes) {
      limit = std::min(one_, room);
      // Room for the step in the daemon's account (the grant is rounded up; an edit grows a
      // session by its undo step and its lines, far below the quarter).
      held->memory.need(std::min(limit, held->bytes + held->bytes / 8 + (int64_t{1} << 20)), false, nullptr,
                        "session " + held->id);
      session.set_memory_limit(std::max<int64_t>(1, std::min(limit, held->memory.held())));
    }
    try {
      q.task(session);
    } catch (const Error& e) {
      if (q.changes && e.kind() == ErrorKind::too_large && limit < one_)
        throw Error(ErrorKind::busy, std::string(e.what()) + "; the sessions on this daemon hold nearly their " +
                                         mib_text(budget_) + ", retry when one is deleted or expires");
      throw;
    }
    if (q.changes) {
      session.set_memory_limit(one_);
      const int64_t bytes = session.memory_bytes();
      std::lock_guard lock(mutex_);
      if (!held->gone) bytes_ += bytes - held->bytes;
      held->bytes = bytes;
    }
  } catch (...) {
    error = std::current_exception();
  }
  if (error) {
    try {
      q.fail(error);
    } catch (...) {
    }
  }
}

void SessionManager::worker_loop() {
  for (;;) {
    std::shared_ptr<Held> held;
    Queued q;
    {
      std::unique_lock lock(mutex_);
      work_cv_.wait(lock, [this] { return stopping_ || !ready_.empty(); });
      if (ready_.empty()) return;
      held = std::move(ready_.front());
      ready_.pop_front();
      q = std::move(held->queued.front());
      held->queued.pop_front();
    }
    run_one(held, std::move(q));
    std::unique_ptr<Session> freed;
    {
      std::lock_guard lock(mutex_);
      held->last_used = std::chrono::system_clock::now();
      held->last_used_steady = Clock::now();
      if (!held->queued.empty()) {
        ready_.push_back(held);  // its next request, after the other sessions' (in turn)
        work_cv_.notify_one();
      } else {
        held->active = false;
        if (held->gone) freed = std::move(held->session);
      }
    }
    if (freed) {
      freed.reset();
      std::lock_guard lock(mutex_);
      held->memory.release();
    }
  }
}

void SessionManager::sweep_loop() {
  const double idle = config_.sessions.idle_expiry_s;
  const auto every =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::clamp(idle / 4, 0.05, 5.0)));
  const auto limit = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(idle));
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    sweep_cv_.wait_for(lock, every);
    const auto now = Clock::now();
    std::vector<std::shared_ptr<Held>> expired;
    for (const auto& [id, h] : sessions_)
      if (h->status != "creating" && !h->active && now - h->last_used_steady > limit) expired.push_back(h);
    for (const auto& h : expired) {
      forget(h->id, h->principal,
             "session '" + h->id + "' expired after " + seconds_text(idle) +
                 " s without use (sessions.idle_expiry_s) and was deleted; create it again (jobs saved from it "
                 "survive)");
      log_event("{\"event\":\"session\",\"session\":\"" + h->id + "\",\"status\":\"expired\"}");
    }
    // Freed off the lock: a large session's buffers take a moment to give back.
    lock.unlock();
    for (const auto& h : expired) {
      h->session.reset();
      h->memory.release();
    }
    expired.clear();
    lock.lock();
  }
}

void SessionManager::stop() {
  std::deque<std::shared_ptr<Held>> waiting;
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && workers_.empty()) return;
    stopping_ = true;
    for (auto& [id, h] : sessions_) {
      h->gone = true;
      h->gone_reason = "the server shut down; sessions live in memory and are lost";
    }
  }
  work_cv_.notify_all();
  sweep_cv_.notify_all();
  for (std::thread& w : workers_) w.join();
  workers_.clear();
  if (sweeper_.joinable()) sweeper_.join();
  std::map<std::string, std::shared_ptr<Held>> sessions;
  {
    std::lock_guard lock(mutex_);
    waiting.swap(ready_);
    sessions.swap(sessions_);
    bytes_ = 0;
  }
  for (const auto& h : waiting) {
    for (Queued& q : h->queued) {
      try {
        q.fail(std::make_exception_ptr(Error(ErrorKind::busy, h->gone_reason)));
      } catch (...) {
      }
    }
    h->queued.clear();
  }
  for (auto& [id, h] : sessions) {
    h->session.reset();
    h->memory.release();
  }
}

}  // namespace rv::daemon
