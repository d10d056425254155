// Internal: a minimal fork-join pool for the engines. Tasks are handed out dynamically; results
// must not depend on which thread runs which task (the engines guarantee that by writing
// disjoint cells with order-independent values, or by the scans' explicit wavefront).
#pragma once

#include <atomic>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

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
