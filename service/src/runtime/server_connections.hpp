// The daemon's open connections, for its connection cap (http.max_connections).
//
// Every connection costs a file descriptor. Without a cap, enough idle or slow clients use up
// the process's descriptors, accept() fails (EMFILE) and nothing more is served. With the cap,
// a new connection beyond it takes the place of the connection that has waited longest for its
// request (idle keep-alive clients and slow senders: they are cut off first, as they would be by
// the request timeout later); only when every connection is busy with a request being computed
// or answered is the new one refused (503). The same eviction frees a descriptor when accept()
// fails for lack of one.
//
// Thread safety: every member may be called from any thread.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>

namespace rv::daemon {

class ConnectionTable {
 public:
  using Id = uint64_t;
  explicit ConnectionTable(std::size_t cap) : cap_(cap) {}

  // Registers a connection; `close` asks it to close (it must not block, and may be called from
  // any thread, also after the connection ended).
  Id add(std::function<void()> close);
  void remove(Id id);
  // Waiting: reading (or waiting for) a request, so it may be evicted. Busy otherwise.
  void set_waiting(Id id, bool waiting);

  std::size_t size() const;
  std::size_t cap() const { return cap_; }

  // Makes room for one more connection: below the cap, nothing to do (true); at it, closes the
  // connection that has waited longest (true), or finds every connection busy (false).
  bool make_room();
  // Closes the connection that has waited longest, if any; true when one was asked to close.
  bool evict_oldest_waiting();

 private:
  struct Entry {
    std::function<void()> close;
    bool waiting = true;
    bool evicted = false;
    std::chrono::steady_clock::time_point since;
  };
  const std::size_t cap_;
  mutable std::mutex mutex_;
  std::map<Id, Entry> entries_;
  Id next_ = 1;
};

// The cap for a configured value: > 0 as given; 0 = from the open-file limit (RLIMIT_NOFILE),
// keeping a reserve of descriptors for the job store, result files and GDAL.
std::size_t connection_cap(int64_t configured);

}  // namespace rv::daemon
