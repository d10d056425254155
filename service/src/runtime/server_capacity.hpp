// What the daemon may take on at once, beside its job queue: one account of its memory for
// everything it runs (jobs, descriptions of seed files, later sessions), and a small pool of
// threads for requests that compute before they answer (describe-seeds), off the network threads.
//
// MemoryAccount: a fixed total of bytes (ServerConfig::memory_budget()). Every piece of work
// holds a Reservation and raises it to its estimate before it allocates (Reservation::need);
// the bytes return when the reservation is destroyed. When the account cannot grant a request:
//  - need(..., wait = true) (jobs, which are already accepted) waits until other work returns
//    memory. A wait can only end in a deadlock when every holder is waiting: then the youngest
//    waiter gives up (rv::Error busy) so that the others go on. A cancel flag ends the wait
//    (rv::Error cancelled);
//  - need(..., wait = false) (requests answered at once) throws rv::Error busy (503 with
//    Retry-After) at once.
// A request above the whole total can never be granted: rv::Error too_large.
//
// RequestPool: `workers` threads and no waiting room. try_run() hands a task to an idle thread,
// or throws rv::Error busy when every thread has one (503: the client retries later; a request
// queued behind minutes of work would outlive its client's patience anyway).
//
// Units: bytes. Thread safety: every public member may be called from any thread; a
// Reservation is used by one thread at a time.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace rv::daemon {

class MemoryAccount {
 public:
  explicit MemoryAccount(int64_t total_bytes);

  class Reservation {
   public:
    Reservation() = default;
    ~Reservation() { release(); }
    Reservation(Reservation&& o) noexcept : account_(o.account_), held_(o.held_), standing_(o.standing_) {
      o.account_ = nullptr;
    }
    Reservation& operator=(Reservation&& o) noexcept;
    Reservation(const Reservation&) = delete;
    Reservation& operator=(const Reservation&) = delete;

    // Holds at least `bytes` (a no-op when it already does; a grant is rounded up so that a
    // slowly growing estimate asks the account rarely). `what` names the work in messages.
    // Throws rv::Error: too_large (bytes above the account's total), busy (not granted: no wait,
    // or this waiter gave way in a deadlock), cancelled (*cancel became true while waiting).
    void need(int64_t bytes, bool wait, const std::atomic<bool>* cancel, const std::string& what);
    int64_t held() const { return held_; }
    void release();
    // Keeps `bytes` (at most what it holds), gives the rest back, and makes the reservation a
    // standing one: memory held until the work is deleted, by work that never waits for more
    // (a live session; its need() calls are then wait = false). Standing reservations do not
    // count as holders in the deadlock rule: a job that waits only for them gives way.
    void settle(int64_t bytes);

   private:
    friend class MemoryAccount;
    explicit Reservation(MemoryAccount* a) : account_(a) {}
    MemoryAccount* account_ = nullptr;
    int64_t held_ = 0;
    bool standing_ = false;
  };

  // An empty reservation on this account (holds nothing until need()).
  Reservation open() { return Reservation(this); }

  int64_t total() const { return total_; }
  int64_t reserved() const;
  int waiting() const;

 private:
  void grow(Reservation& r, int64_t bytes, bool wait, const std::atomic<bool>* cancel, const std::string& what);
  void give_back(int64_t bytes, bool holder_ends);
  void settle(Reservation& r, int64_t bytes);

  const int64_t total_;
  mutable std::mutex mutex_;
  std::condition_variable freed_;
  int64_t reserved_ = 0;
  int holders_ = 0;  // reservations holding bytes
  struct Waiter {
    bool holds;    // holds bytes already (a job's grown estimate), which it gives back only when it ends
    int64_t more;  // the bytes it waits for
  };
  std::map<uint64_t, Waiter> waiting_;  // by ticket, oldest first
  uint64_t next_ticket_ = 0;
  uint64_t give_way_ = 0;  // ticket that must give up (0: none)
};

class RequestPool {
 public:
  explicit RequestPool(int workers);
  ~RequestPool();  // stop()
  RequestPool(const RequestPool&) = delete;
  RequestPool& operator=(const RequestPool&) = delete;

  // A request's work: runs on a worker and returns the hand-over of its answer (or an empty
  // function), which the worker runs once it counts as idle again: a client that sends its next
  // request as soon as it has the answer finds the worker free, not busy.
  using Task = std::function<std::function<void()>()>;
  // Runs `task` on an idle worker thread. Throws rv::Error busy when every worker has a task or
  // the pool is stopping. Neither `task` nor its hand-over may throw (they answer the request).
  void try_run(Task task);
  // Lets the tasks that run finish, then joins the threads. Idempotent.
  void stop();
  int busy() const;
  int workers() const { return static_cast<int>(threads_.size()); }

 private:
  void loop();

  mutable std::mutex mutex_;
  std::condition_variable work_;
  std::deque<Task> tasks_;
  int busy_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace rv::daemon
