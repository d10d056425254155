// The resident memory one job adds while it runs, for its report (peak_memory_bytes).
//
// The process's own high-water mark (getrusage, VmHWM) is the peak of everything the process
// ever did: in the daemon, of the largest job since it started. A watch records the resident
// size when its job starts and samples it every kSamplePeriod while the job runs. When no other
// watch is active at any time during its life, it also resets the kernel's high-water mark at
// the start (/proc/self/clear_refs, Linux 4.0+) and reads it at the end, which catches spikes
// shorter than a sample; with concurrent jobs it cannot, and says so (shared()).
//
// Thread safety: construct and read a watch on one thread; any number of watches may be alive
// in a process at once.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>

namespace rv::detail {

class MemoryWatch {
 public:
  static constexpr std::chrono::milliseconds kSamplePeriod{5};

  MemoryWatch();
  ~MemoryWatch();
  MemoryWatch(const MemoryWatch&) = delete;
  MemoryWatch& operator=(const MemoryWatch&) = delete;

  // Resident bytes when the watch started.
  int64_t resident_at_start() const { return start_; }
  // The highest resident size seen so far minus resident_at_start() (>= 0).
  int64_t peak_growth() const;
  // True when another watch was active at some time during this one's life: the growth may
  // include the other jobs' memory, and no kernel high-water mark was used.
  bool shared() const { return shared_.load(); }

 private:
  friend struct WatchRegistry;
  void sample_loop();

  int64_t start_ = 0;
  std::atomic<int64_t> peak_{0};
  std::atomic<bool> shared_{false};
  bool hwm_reset_ = false;
  std::mutex mutex_;
  std::condition_variable stop_cv_;
  bool stop_ = false;
  std::thread sampler_;
};

// Resident set size of this process now (VmRSS), bytes; 0 if unknown.
int64_t resident_bytes();

}  // namespace rv::detail
