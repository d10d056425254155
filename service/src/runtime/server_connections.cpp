#include "runtime/server_connections.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <vector>

namespace rv::daemon {

ConnectionTable::Id ConnectionTable::add(std::function<void()> close) {
  std::lock_guard lock(mutex_);
  const Id id = next_++;
  entries_.emplace(id, Entry{std::move(close), true, false, std::chrono::steady_clock::now()});
  return id;
}

void ConnectionTable::remove(Id id) {
  std::lock_guard lock(mutex_);
  entries_.erase(id);
}

void ConnectionTable::set_waiting(Id id, bool waiting) {
  std::lock_guard lock(mutex_);
  const auto it = entries_.find(id);
  if (it == entries_.end() || it->second.waiting == waiting) return;
  it->second.waiting = waiting;
  it->second.since = std::chrono::steady_clock::now();
}

std::size_t ConnectionTable::size() const {
  std::lock_guard lock(mutex_);
  return entries_.size();
}

bool ConnectionTable::make_room() {
  {
    std::lock_guard lock(mutex_);
    // Connections already asked to close are on their way out: they do not count.
    std::size_t live = 0;
    for (const auto& [id, e] : entries_) live += e.evicted ? 0 : 1;
    if (live < cap_) return true;
  }
  return evict_oldest_waiting();
}

bool ConnectionTable::evict_oldest_waiting() {
  std::function<void()> close;
  {
    std::lock_guard lock(mutex_);
    Entry* oldest = nullptr;
    for (auto& [id, e] : entries_)
      if (e.waiting && !e.evicted && (oldest == nullptr || e.since < oldest->since)) oldest = &e;
    if (oldest == nullptr) return false;
    oldest->evicted = true;
    close = oldest->close;
  }
  close();  // outside the lock: it posts to the connection's strand
  return true;
}

std::size_t connection_cap(int64_t configured) {
  if (configured > 0) return static_cast<std::size_t>(configured);
  rlimit r{};
  if (::getrlimit(RLIMIT_NOFILE, &r) != 0 || r.rlim_cur == RLIM_INFINITY) return 4096;
  const auto soft = static_cast<int64_t>(r.rlim_cur);
  // Descriptors besides connections: stdio, the listener, the store (database, WAL, shared
  // memory), the data directory's lock, result files of running jobs, GDAL's own.
  const int64_t reserve = std::min<int64_t>(128, soft / 2);
  return static_cast<std::size_t>(std::clamp<int64_t>(soft - reserve, 8, 1 << 20));
}

}  // namespace rv::daemon
