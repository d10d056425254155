// The principals with tokens a daemon accepts: those of its configuration (AuthConfig), with
// auth.token_file read again whenever the file changes (auth/file_stamp.hpp), so that a token is
// added or revoked by editing the file, with no restart and no signal: on one daemon, in a
// container, on every daemon of a shared service that mounts the file.
//
// The file is checked at most once per `check_interval_s` (1 s), by the request that finds the
// check due; other requests meanwhile go on with the set they have. A change takes effect for
// requests that arrive after the check that sees it, so a revoked token is refused within about
// the interval of the edit (plus the read). A file that cannot be used (missing, not valid,
// holding no token, a name given two roles) is logged and the set before it kept: a broken edit
// neither opens the server nor locks everyone out. Each change is logged once:
//   {"event":"token_file_loaded","path":...,"principals":<the file's>}
//   {"event":"token_file_failed","path":...,"error":...,"keeping":<the file's before>}
// Thread safety: current() may be called from any thread at once.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "rv/server_config.hpp"

namespace rv::auth {

class PrincipalSet {
 public:
  // `log` receives one JSON object (a log line) per change of the file; it may be empty.
  PrincipalSet(const AuthConfig& config, std::function<void(const std::string&)> log, double check_interval_s = 1.0);

  // The principals now (the file checked first when a check is due). Never null.
  std::shared_ptr<const std::vector<PrincipalConfig>> current() const;

 private:
  void check_file() const;

  std::function<void(const std::string&)> log_;
  const std::string path_;  // auth.token_file; "" = none
  std::chrono::steady_clock::duration interval_;
  mutable std::mutex mutex_;   // guards the members below
  mutable AuthConfig config_;  // as last read well (its principals are the set)
  mutable std::shared_ptr<const std::vector<PrincipalConfig>> set_;
  mutable std::string stamp_;  // the file's at its last read, good or not
  mutable std::chrono::steady_clock::time_point next_check_;
  mutable bool reading_ = false;  // a request reads the file now
};

}  // namespace rv::auth
