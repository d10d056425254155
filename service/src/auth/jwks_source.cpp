#include "auth/jwks_source.hpp"

#include <fstream>
#include <sstream>

#include "auth/file_stamp.hpp"
#include "auth/https_get.hpp"
#include "rv/field/error.hpp"
#include "rv/json_text.hpp"

namespace rv::auth {
namespace {

constexpr std::size_t kMaxKeySetBytes = 1 << 20;
constexpr double kFetchTimeoutS = 10.0;

std::string read_whole(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorKind::not_found, "the key file '" + path + "' cannot be opened");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

JwksSource::JwksSource(JwtConfig config, std::function<void(const std::string&)> log)
    : config_(std::move(config)), log_(std::move(log)) {}

JwksSource::~JwksSource() { stop(); }

void JwksSource::stop() {
  std::vector<std::function<void()>> done;
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    done.swap(waiting_);
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  for (auto& d : done) d();
}

void JwksSource::start() {
  if (!config_.jwks_file.empty()) {
    // A configuration error shows at start: the file must be there and usable.
    auto set = std::make_shared<const KeySet>(parse_jwks(read_whole(config_.jwks_file)));
    std::lock_guard lock(mutex_);
    file_stamp_ = file_stamp(config_.jwks_file);
    keys_ = std::move(set);
    last_load_ = std::chrono::steady_clock::now();
  } else {
    load();
  }
  thread_ = std::thread([this] { loop(); });
}

std::shared_ptr<const KeySet> JwksSource::keys() const {
  std::lock_guard lock(mutex_);
  return keys_;
}

void JwksSource::refresh_then(std::function<void()> done) {
  {
    std::lock_guard lock(mutex_);
    const auto since = std::chrono::steady_clock::now() - last_load_;
    if (!stopping_ && since >= std::chrono::duration<double>(config_.jwks_min_interval_s)) {
      waiting_.push_back(std::move(done));
      requested_ = true;
      wake_.notify_all();
      return;
    }
  }
  done();
}

bool JwksSource::load() {
  const bool from_file = !config_.jwks_file.empty();
  const std::string where = from_file ? config_.jwks_file : config_.jwks_url;
  std::string error;
  std::shared_ptr<const KeySet> fresh;
  std::string stamp;
  try {
    std::string text;
    if (from_file) {
      stamp = file_stamp(config_.jwks_file);
      std::lock_guard lock(mutex_);
      if (stamp == file_stamp_ && keys_) {
        last_load_ = std::chrono::steady_clock::now();
        return true;  // unchanged: nothing to read
      }
    }
    if (from_file) {
      text = read_whole(config_.jwks_file);
    } else {
      const HttpsReply r = https_get(config_.jwks_url, config_.jwks_ca_file, kFetchTimeoutS, kMaxKeySetBytes);
      if (r.status != 200) throw Error(ErrorKind::io, "HTTP status " + std::to_string(r.status));
      text = r.body;
    }
    fresh = std::make_shared<const KeySet>(parse_jwks(text));
  } catch (const std::exception& e) {
    error = e.what();
  }
  std::lock_guard lock(mutex_);
  last_load_ = std::chrono::steady_clock::now();
  if (!fresh) {
    log_("{\"event\":\"jwks_failed\",\"source\":" + json_text(nlohmann::json(where)) + ",\"error\":" +
         json_text(nlohmann::json(error)) + ",\"keeping\":" + std::to_string(keys_ ? keys_->keys.size() : 0) + "}");
    return keys_ != nullptr;
  }
  if (from_file) file_stamp_ = stamp;
  log_("{\"event\":\"jwks_loaded\",\"source\":" + json_text(nlohmann::json(where)) +
       ",\"keys\":" + std::to_string(fresh->keys.size()) + ",\"skipped\":" + std::to_string(fresh->skipped) + "}");
  keys_ = std::move(fresh);
  return true;
}

void JwksSource::loop() {
  // Without a usable set, fetch again after 1, 2, 4 ... seconds, up to the refresh period.
  double retry_s = 1.0;
  bool usable = keys() != nullptr;
  for (;;) {
    std::vector<std::function<void()>> done;
    {
      std::unique_lock lock(mutex_);
      const double pause = usable ? config_.jwks_refresh_s : std::min(retry_s, config_.jwks_refresh_s);
      wake_.wait_for(lock, std::chrono::duration<double>(pause), [&] { return stopping_ || requested_; });
      if (stopping_) return;
      requested_ = false;
      done.swap(waiting_);
    }
    usable = load();
    retry_s = usable ? 1.0 : std::min(2.0 * retry_s, config_.jwks_refresh_s);
    // Those waiting for this load learn its outcome (their next check sees the new set). Callers
    // that asked while it ran wait for the next one (requested_ is set again).
    for (auto& d : done) d();
  }
}

}  // namespace rv::auth
