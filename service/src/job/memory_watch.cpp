#include "job/memory_watch.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <set>

namespace rv::detail {
namespace {

// A field of /proc/self/status in kB ("VmRSS:", "VmHWM:"), as bytes; 0 if unknown.
int64_t status_field(const char* name) {
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (f == nullptr) return 0;
  char line[256];
  int64_t value = 0;
  const size_t n = std::strlen(name);
  while (std::fgets(line, sizeof line, f) != nullptr) {
    if (std::strncmp(line, name, n) == 0) {
      value = std::strtoll(line + n, nullptr, 10) * 1024;
      break;
    }
  }
  std::fclose(f);
  return value;
}

// Resets the kernel's VmHWM to the current resident size.
bool reset_high_water_mark() {
  const int fd = ::open("/proc/self/clear_refs", O_WRONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::write(fd, "5", 1) == 1;
  ::close(fd);
  return ok;
}

}  // namespace

// The watches alive in this process: a watch that starts beside others marks them all shared.
struct WatchRegistry {
  std::mutex mutex;
  std::set<MemoryWatch*> active;

  static WatchRegistry& get() {
    static WatchRegistry r;
    return r;
  }
  // True when `w` is alone (then it may reset the process's high-water mark).
  bool enter(MemoryWatch* w) {
    std::lock_guard lock(mutex);
    if (!active.empty()) {
      for (MemoryWatch* other : active) other->shared_ = true;
      w->shared_ = true;
    }
    active.insert(w);
    return active.size() == 1;
  }
  void leave(MemoryWatch* w) {
    std::lock_guard lock(mutex);
    active.erase(w);
  }
};

int64_t resident_bytes() {
  // statm's second field is resident pages: one read, no parsing of the whole status file.
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (f == nullptr) return 0;
  long long size = 0, resident = 0;
  const int got = std::fscanf(f, "%lld %lld", &size, &resident);
  std::fclose(f);
  return got == 2 ? static_cast<int64_t>(resident) * ::sysconf(_SC_PAGESIZE) : 0;
}

MemoryWatch::MemoryWatch() {
  const bool alone = WatchRegistry::get().enter(this);
  if (alone) hwm_reset_ = reset_high_water_mark();
  start_ = resident_bytes();
  peak_ = start_;
  sampler_ = std::thread([this] { sample_loop(); });
}

MemoryWatch::~MemoryWatch() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  sampler_.join();
  WatchRegistry::get().leave(this);
}

void MemoryWatch::sample_loop() {
  std::unique_lock lock(mutex_);
  while (!stop_) {
    const int64_t now = resident_bytes();
    int64_t seen = peak_.load();
    while (now > seen && !peak_.compare_exchange_weak(seen, now)) {
    }
    stop_cv_.wait_for(lock, kSamplePeriod);
  }
}

int64_t MemoryWatch::peak_growth() const {
  int64_t peak = std::max(peak_.load(), resident_bytes());
  if (hwm_reset_ && !shared_) peak = std::max(peak, status_field("VmHWM:"));
  return std::max<int64_t>(0, peak - start_);
}

}  // namespace rv::detail
