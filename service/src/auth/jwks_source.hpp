// The identity provider's keys, kept fresh for the daemon: read from JwtConfig::jwks_file (again
// whenever its size or modification time changed) or fetched from JwtConfig::jwks_url, every
// jwks_refresh_s and on demand. A load that fails keeps the last good set (and is retried, with
// a growing pause up to jwks_refresh_s, when there is none): a provider that is down for a while
// does not lock out tokens signed with keys already known.
// Thread safety: every member may be called from any thread; loads run on the source's own
// thread, never on a caller's (a network thread is never held by a slow provider).
#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "auth/jwks.hpp"
#include "rv/server_config.hpp"

namespace rv::auth {

class JwksSource {
 public:
  // `log` receives one JSON object (a log line) per load that changed or failed.
  JwksSource(JwtConfig config, std::function<void(const std::string&)> log);
  ~JwksSource();
  JwksSource(const JwksSource&) = delete;
  JwksSource& operator=(const JwksSource&) = delete;

  // The first load, on the caller's thread, then the refreshing thread. Throws rv::Error for a
  // key file that cannot be read or holds no usable key (a configuration error); a URL that
  // cannot be fetched yet is logged and retried.
  void start();
  // Ends the refreshing thread; whoever waits in refresh_then is called first. Idempotent; the
  // destructor calls it.
  void stop();
  // The current set; nullptr before any load succeeded.
  std::shared_ptr<const KeySet> keys() const;
  // Asks for a load now (a token named a key the set lacks) and calls `done` once it ended, on the
  // source's thread. When the last load ended less than jwks_min_interval_s ago, `done` runs at
  // once on this thread instead: unknown key ids cannot make the server hammer its provider. (From
  // its end, not its start: the provider then sees requests at least that far apart however long
  // a fetch's connection took.)
  void refresh_then(std::function<void()> done);

 private:
  void loop();
  bool load();  // true when a usable set is current afterwards

  JwtConfig config_;
  std::function<void(const std::string&)> log_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::shared_ptr<const KeySet> keys_;
  std::vector<std::function<void()>> waiting_;
  bool requested_ = false;
  bool stopping_ = false;
  std::chrono::steady_clock::time_point last_load_{};  // when the last load ended
  std::string file_stamp_;                             // the key file's size and modification time at its last read
  std::thread thread_;
};

}  // namespace rv::auth
