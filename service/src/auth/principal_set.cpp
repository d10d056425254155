#include "auth/principal_set.hpp"

#include "auth/file_stamp.hpp"
#include "rv/json_text.hpp"

namespace rv::auth {

PrincipalSet::PrincipalSet(const AuthConfig& config, std::function<void(const std::string&)> log,
                           double check_interval_s)
    : log_(std::move(log)),
      path_(config.token_file),
      interval_(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::duration<double>(check_interval_s))),
      config_(config),
      set_(std::make_shared<const std::vector<PrincipalConfig>>(config.principals)),
      stamp_(config.token_file_stamp),
      next_check_(std::chrono::steady_clock::now() + interval_) {}

std::shared_ptr<const std::vector<PrincipalConfig>> PrincipalSet::current() const {
  if (!path_.empty()) check_file();
  std::lock_guard lock(mutex_);
  return set_;
}

void PrincipalSet::check_file() const {
  AuthConfig before;
  {
    std::lock_guard lock(mutex_);
    const auto now = std::chrono::steady_clock::now();
    if (now < next_check_ || reading_) return;
    // Due: this request checks; those arriving meanwhile find the next check a period away.
    next_check_ = now + interval_;
    reading_ = true;
  }
  // Stat and read outside the lock (the file may sit on a network mount): other requests go on
  // with the set they have.
  const std::string stamp = file_stamp(path_);
  {
    std::lock_guard lock(mutex_);
    if (stamp == stamp_) {
      reading_ = false;
      return;
    }
    before = config_;  // copied only when the file changed
  }
  const std::string path = json_text(nlohmann::json(path_));
  std::string line;
  try {
    AuthConfig fresh = reread_token_file(before);
    line = "{\"event\":\"token_file_loaded\",\"path\":" + path +
           ",\"principals\":" + std::to_string(fresh.token_file_principals) + "}";
    std::lock_guard lock(mutex_);
    set_ = std::make_shared<const std::vector<PrincipalConfig>>(fresh.principals);
    stamp_ = fresh.token_file_stamp;
    config_ = std::move(fresh);
    reading_ = false;
  } catch (const std::exception& e) {
    line = "{\"event\":\"token_file_failed\",\"path\":" + path + ",\"error\":" + json_text(nlohmann::json(e.what())) +
           ",\"keeping\":" + std::to_string(before.token_file_principals) + "}";
    std::lock_guard lock(mutex_);
    stamp_ = stamp;  // logged once: read again when the file changes again
    reading_ = false;
  }
  if (log_) log_(line);
}

}  // namespace rv::auth
