// The one way the product runs work in parallel, and the one rule for how many threads: a
// minimal fork-join (parallel_for) over tasks handed out dynamically, on threads started for the
// call. Results must not depend on which thread runs which task (the engines write disjoint
// cells with order-independent values, or follow the scans' explicit wavefront; the GeoTIFF
// encoder gives each worker its own codec and scratch, indexed by the worker number).
// Long-lived threads (the daemon's workers, a streamed job's writers) are not this: they are
// roles, not shares of one computation.
// Thread safety: parallel_for may be called from any thread, also from inside a task.
#pragma once

#include <atomic>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace rv {

// The threads a computation uses: `requested` when > 0 (at most 256), else every hardware thread
// (1 when unknown). Every option "threads = 0 means all cores" resolves through here.
int resolve_threads(int requested);

}  // namespace rv

namespace rv::detail {

// Runs f(task, worker) for task in [0, n) on `threads` threads (the caller is worker 0), then
// finish(worker) once on each worker's own thread after its last task (also when a task threw;
// finish must not throw). The first exception thrown by any task is rethrown after all workers
// have stopped; once one task has thrown, no new tasks start.
template <class F, class Finish>
void parallel_for(int threads, int64_t n, F&& f, Finish&& finish) {
  if (threads <= 1 || n <= 1) {
    struct AtEnd {
      Finish& finish;
      ~AtEnd() { finish(0); }
    } at_end{finish};
    for (int64_t i = 0; i < n; ++i) f(i, 0);
    return;
  }
  std::atomic<int64_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto work = [&](int worker) {
    try {
      for (int64_t i; !failed.load(std::memory_order_relaxed) && (i = next.fetch_add(1)) < n;) f(i, worker);
    } catch (...) {
      std::lock_guard lock(error_mutex);
      if (!error) error = std::current_exception();
      failed = true;
    }
    finish(worker);
  };
  const int extra = static_cast<int>(std::min<int64_t>(threads, n)) - 1;
  std::vector<std::thread> pool;
  pool.reserve(extra);
  for (int w = 1; w <= extra; ++w) pool.emplace_back(work, w);
  work(0);
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

template <class F>
void parallel_for(int threads, int64_t n, F&& f) {
  parallel_for(threads, n, std::forward<F>(f), [](int) {});
}

}  // namespace rv::detail
