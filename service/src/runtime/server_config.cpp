#include "rv/server_config.hpp"

#include <malloc.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <mutex>
#include <set>
#include <sstream>
#include <string_view>
#include <thread>

#include <unistd.h>

#include "runtime/config_read.hpp"
#include "rv/field/error.hpp"

namespace rv {

using config_read::bad;
using config_read::check_keys;
using config_read::get_int;
using config_read::get_seconds;
using config_read::get_string;
using nlohmann::json;

namespace config_read {

[[noreturn]] void bad(const std::string& key, const std::string& why) {
  throw Error(ErrorKind::invalid_argument, "configuration key '" + key + "': " + why);
}

// Rejects keys we do not know: a misspelt limit would otherwise silently keep its default.
void check_keys(const json& object, const std::string& where, const std::set<std::string>& known) {
  if (!object.is_object()) bad(where.empty() ? "(document)" : where, "must be a JSON object");
  for (const auto& [key, value] : object.items()) {
    if (!known.count(key)) bad(where.empty() ? key : where + "." + key, "unknown key");
  }
}

int64_t get_int(const json& object, const std::string& where, const char* key, int64_t fallback, int64_t min_value) {
  if (!object.contains(key)) return fallback;
  const json& v = object.at(key);
  const std::string name = where.empty() ? std::string(key) : where + "." + key;
  if (!v.is_number_integer()) bad(name, "must be an integer");
  const int64_t x = v.get<int64_t>();
  if (x < min_value) bad(name, "must be >= " + std::to_string(min_value));
  return x;
}

double get_seconds(const json& object, const std::string& where, const char* key, double fallback) {
  if (!object.contains(key)) return fallback;
  const json& v = object.at(key);
  const std::string name = where.empty() ? std::string(key) : where + "." + key;
  if (!v.is_number()) bad(name, "must be a number of seconds");
  const double x = v.get<double>();
  if (!(x > 0.0) || x > 1e7) bad(name, "must be > 0 and at most 1e7 seconds");
  return x;
}

std::string get_string(const json& object, const char* key, const std::string& fallback) {
  if (!object.contains(key)) return fallback;
  if (!object.at(key).is_string()) bad(key, "must be a string");
  return object.at(key).get<std::string>();
}

std::string get_string(const json& object, const std::string& where, const char* key, const std::string& fallback) {
  if (!object.contains(key)) return fallback;
  if (!object.at(key).is_string()) bad(where + "." + key, "must be a string");
  return object.at(key).get<std::string>();
}

}  // namespace config_read

void parse_listen(const std::string& listen, ServerConfig& config) {
  std::string host;
  std::string port;
  if (!listen.empty() && listen.front() == '[') {
    const auto close = listen.find(']');
    if (close == std::string::npos || close + 1 >= listen.size() || listen[close + 1] != ':') {
      bad("listen", "expected [ipv6]:port, got '" + listen + "'");
    }
    host = listen.substr(1, close - 1);
    port = listen.substr(close + 2);
  } else {
    const auto colon = listen.rfind(':');
    if (colon == std::string::npos) bad("listen", "expected host:port, got '" + listen + "'");
    host = listen.substr(0, colon);
    port = listen.substr(colon + 1);
  }
  if (host.empty()) bad("listen", "missing host in '" + listen + "'");
  if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
      std::stoi(port) > 65535) {
    bad("listen", "port must be 0..65535 in '" + listen + "'");
  }
  config.host = host;
  config.port = std::stoi(port);
}

namespace {

// The top-level keys of the store: what it is, its password, where results go.
void parse_store_config(const json& doc, ServerConfig& c) {
  StoreConfig& st = c.store;
  st.uri = get_string(doc, "store", st.uri);
  st.connections = static_cast<int>(get_int(doc, "", "store_connections", st.connections, 2));
  st.results = get_string(doc, "results", st.results);
  if (doc.contains("results_shared")) {
    if (!doc.at("results_shared").is_boolean()) bad("results_shared", "must be true or false");
    st.results_shared = doc.at("results_shared").get<bool>();
  }
  st.password_file = get_string(doc, "store_password_file", st.password_file);
  if (!st.shared()) {
    if (st.uri != "sqlite") bad("store", "must be \"sqlite\" or a postgresql:// URI");
    if (!st.results.empty())
      bad("results", "goes with a postgresql:// store; the embedded store keeps results in data_dir/jobs");
    return;
  }
  if (st.uri.rfind("postgresql://", 0) != 0 && st.uri.rfind("postgres://", 0) != 0)
    bad("store", "must be \"sqlite\" or a postgresql:// URI");
  // A password in the URI would be in every place the URI is shown: refused, never echoed.
  const std::string rest = st.uri.substr(st.uri.find("://") + 3);
  const size_t at = rest.find('@'), slash = rest.find('/');
  if (at != std::string::npos && (slash == std::string::npos || at < slash) &&
      rest.substr(0, at).find(':') != std::string::npos)
    bad("store", "must not contain a password; give it in store_password_file or RVORONOI_STORE_PASSWORD");
  if (st.uri.find("password=") != std::string::npos)
    bad("store", "must not contain a password; give it in store_password_file or RVORONOI_STORE_PASSWORD");
  if (!st.password_file.empty()) {
    std::ifstream in(st.password_file, std::ios::binary);
    if (!in) throw Error(ErrorKind::not_found, "store_password_file '" + st.password_file + "' cannot be read");
    std::getline(in, st.password);
    while (!st.password.empty() && (st.password.back() == '\r' || st.password.back() == ' ')) st.password.pop_back();
    if (st.password.empty()) bad("store_password_file", "holds no password on its first line");
  } else if (const char* env = std::getenv("RVORONOI_STORE_PASSWORD"); env && *env) {
    st.password = env;
  }
  if (st.results.empty())
    bad("results",
        "a shared store needs results every daemon reaches: an s3://bucket/prefix, or a folder all of them mount");
  // A bucket is shared by every daemon that names it (its form is checked, and the bucket asked,
  // when the daemon starts).
  if (st.results.rfind("s3://", 0) == 0) return;
  if (!st.results_shared)
    bad("results",
        "a shared store needs results every daemon reaches: a folder all of them mount, with "
        "\"results_shared\": true");
}

}  // namespace

ServerConfig parse_server_config(const json& doc) {
  ServerConfig c;
  check_keys(doc, "",
             {"listen", "data_dir", "public_url", "web_dir", "http", "jobs", "limits", "auth", "sessions",
              "daemon_name", "store", "store_password_file", "store_connections", "results", "results_shared"});
  if (doc.contains("listen")) parse_listen(get_string(doc, "listen", ""), c);
  c.data_dir = get_string(doc, "data_dir", c.data_dir);
  if (c.data_dir.empty()) bad("data_dir", "must not be empty");
  c.web_dir = get_string(doc, "web_dir", c.web_dir);
  c.public_url = get_string(doc, "public_url", c.public_url);
  while (!c.public_url.empty() && c.public_url.back() == '/') c.public_url.pop_back();
  if (!c.public_url.empty() && c.public_url.rfind("http://", 0) != 0 && c.public_url.rfind("https://", 0) != 0) {
    bad("public_url", "must start with http:// or https://");
  }

  if (doc.contains("http")) {
    const json& h = doc.at("http");
    check_keys(h, "http",
               {"max_body_bytes", "max_header_bytes", "request_timeout_s", "min_send_bytes_per_s", "io_threads",
                "max_connections"});
    c.http.max_body_bytes = get_int(h, "http", "max_body_bytes", c.http.max_body_bytes, 1024);
    c.http.max_header_bytes = get_int(h, "http", "max_header_bytes", c.http.max_header_bytes, 512);
    c.http.max_connections = get_int(h, "http", "max_connections", c.http.max_connections, 0);
    c.http.request_timeout_s = get_seconds(h, "http", "request_timeout_s", c.http.request_timeout_s);
    c.http.min_send_bytes_per_s = get_int(h, "http", "min_send_bytes_per_s", c.http.min_send_bytes_per_s, 0);
    c.http.io_threads = static_cast<int>(get_int(h, "http", "io_threads", c.http.io_threads, 1));
  }
  if (doc.contains("jobs")) {
    const json& j = doc.at("jobs");
    check_keys(
        j, "jobs",
        {"workers", "queue_length", "threads_per_job", "job_timeout_s", "shutdown_grace_s", "describe_workers",
         "lease_s", "max_attempts", "retry_backoff_s", "poll_s", "retention_s", "orphan_grace_s", "split_cells"});
    c.jobs.workers = static_cast<int>(get_int(j, "jobs", "workers", c.jobs.workers, 1));
    c.jobs.queue_length = static_cast<int>(get_int(j, "jobs", "queue_length", c.jobs.queue_length, 0));
    c.jobs.threads_per_job = static_cast<int>(get_int(j, "jobs", "threads_per_job", c.jobs.threads_per_job, 0));
    c.jobs.job_timeout_s = get_seconds(j, "jobs", "job_timeout_s", c.jobs.job_timeout_s);
    c.jobs.shutdown_grace_s = get_seconds(j, "jobs", "shutdown_grace_s", c.jobs.shutdown_grace_s);
    c.jobs.describe_workers = static_cast<int>(get_int(j, "jobs", "describe_workers", c.jobs.describe_workers, 1));
    c.jobs.lease_s = get_seconds(j, "jobs", "lease_s", c.jobs.lease_s);
    c.jobs.max_attempts = static_cast<int>(get_int(j, "jobs", "max_attempts", c.jobs.max_attempts, 1));
    c.jobs.retry_backoff_s = get_seconds(j, "jobs", "retry_backoff_s", c.jobs.retry_backoff_s);
    c.jobs.poll_s = get_seconds(j, "jobs", "poll_s", c.jobs.poll_s);
    c.jobs.orphan_grace_s = get_seconds(j, "jobs", "orphan_grace_s", c.jobs.orphan_grace_s);
    c.jobs.split_cells = get_int(j, "jobs", "split_cells", c.jobs.split_cells, 0);
    if (j.contains("retention_s") && j.at("retention_s") == 0) {
      c.jobs.retention_s = 0;
    } else {
      c.jobs.retention_s = get_seconds(j, "jobs", "retention_s", c.jobs.retention_s);
    }
  }
  if (doc.contains("limits")) {
    const json& l = doc.at("limits");
    check_keys(l, "limits",
               {"max_cells", "max_memory_bytes", "total_memory_bytes", "validate_max_cells", "max_features",
                "max_vertices", "max_input_bytes", "preview_max_vertices", "jobs_per_principal",
                "cells_per_principal_per_hour", "retained_free_bytes", "min_free_disk_bytes"});
    c.limits.max_cells = get_int(l, "limits", "max_cells", c.limits.max_cells, 1);
    c.limits.max_memory_bytes = get_int(l, "limits", "max_memory_bytes", c.limits.max_memory_bytes, 0);
    c.total_memory_bytes = get_int(l, "limits", "total_memory_bytes", c.total_memory_bytes, 0);
    c.limits.validate_max_cells = get_int(l, "limits", "validate_max_cells", c.limits.validate_max_cells, 0);
    // 0 = no limit of the server's own (the seed reader's limits, if any, still apply).
    c.limits.max_features = get_int(l, "limits", "max_features", c.limits.max_features, 0);
    c.limits.max_vertices = get_int(l, "limits", "max_vertices", c.limits.max_vertices, 0);
    c.limits.max_input_bytes = get_int(l, "limits", "max_input_bytes", c.limits.max_input_bytes, 0);
    c.preview_max_vertices = get_int(l, "limits", "preview_max_vertices", c.preview_max_vertices, 1);
    c.principal_limits.jobs = static_cast<int>(get_int(l, "limits", "jobs_per_principal", c.principal_limits.jobs, 0));
    c.principal_limits.cells_per_hour =
        get_int(l, "limits", "cells_per_principal_per_hour", c.principal_limits.cells_per_hour, 0);
    c.retained_free_bytes = get_int(l, "limits", "retained_free_bytes", c.retained_free_bytes, 0);
    if (c.retained_free_bytes > std::numeric_limits<int>::max())
      bad("limits.retained_free_bytes", "must be at most 2147483647 (the C library takes an int)");
    c.min_free_disk_bytes = get_int(l, "limits", "min_free_disk_bytes", c.min_free_disk_bytes, 0);
  }
  if (doc.contains("auth")) parse_auth_config(doc.at("auth"), c.auth);
  if (doc.contains("sessions")) {
    const json& s = doc.at("sessions");
    check_keys(s, "sessions",
               {"max_sessions", "max_per_principal", "max_memory_bytes", "session_memory_bytes", "undo_depth",
                "idle_expiry_s", "workers", "pending_per_session"});
    SessionsConfig& z = c.sessions;
    z.max_sessions = static_cast<int>(get_int(s, "sessions", "max_sessions", z.max_sessions, 0));
    z.max_per_principal = static_cast<int>(get_int(s, "sessions", "max_per_principal", z.max_per_principal, 0));
    z.max_memory_bytes = get_int(s, "sessions", "max_memory_bytes", z.max_memory_bytes, 0);
    z.session_memory_bytes = get_int(s, "sessions", "session_memory_bytes", z.session_memory_bytes, 0);
    z.undo_depth = static_cast<int>(get_int(s, "sessions", "undo_depth", z.undo_depth, 0));
    if (z.undo_depth > 100000) bad("sessions.undo_depth", "must be at most 100000");
    z.idle_expiry_s = get_seconds(s, "sessions", "idle_expiry_s", z.idle_expiry_s);
    z.workers = static_cast<int>(get_int(s, "sessions", "workers", z.workers, 1));
    z.pending_per_session = static_cast<int>(get_int(s, "sessions", "pending_per_session", z.pending_per_session, 0));
  }
  c.daemon_name = get_string(doc, "daemon_name", c.daemon_name);
  if (!c.daemon_name.empty() &&
      (c.daemon_name.size() > 63 ||
       c.daemon_name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789-") != std::string::npos))
    bad("daemon_name", "must be 1..63 characters of a-z, 0-9 and '-'");
  parse_store_config(doc, c);
  return c;
}

ServerConfig load_server_config(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorKind::not_found, "configuration file '" + path + "' cannot be opened");
  std::stringstream text;
  text << in.rdbuf();
  json doc = json::parse(text.str(), nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) {
    throw Error(ErrorKind::invalid_argument, "configuration file '" + path + "' is not valid JSON");
  }
  return parse_server_config(doc);
}

int64_t ServerConfig::memory_budget() const {
  if (total_memory_bytes > 0) return total_memory_bytes;
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page_size = sysconf(_SC_PAGE_SIZE);
  const int64_t physical = pages > 0 && page_size > 0 ? int64_t{pages} * page_size : 0;
  return physical / 10 * 8;
}

AllocatorSettings allocator_settings(const ServerConfig& config, const char* tunables) {
  AllocatorSettings s;
  if (config.retained_free_bytes <= 0) return s;
  if (tunables != nullptr && std::string_view(tunables).find("glibc.malloc.") != std::string_view::npos) return s;
  s.apply = true;
  s.mmap_threshold = int64_t{32} << 20;  // glibc's largest (HEAP_MAX_SIZE / 2 on 64-bit hosts)
  s.trim_threshold = config.retained_free_bytes;
  return s;
}

namespace {
std::mutex applied_mutex;
AllocatorSettings applied;
}  // namespace

AllocatorSettings apply_allocator_settings(const ServerConfig& config) {
  AllocatorSettings s = allocator_settings(config, std::getenv("GLIBC_TUNABLES"));
  // Setting either threshold ends glibc's adaptive ones, which raise the mmap threshold to the
  // largest block freed and trim above twice that: both are set, the trim one first.
  if (s.apply && (mallopt(M_TRIM_THRESHOLD, static_cast<int>(s.trim_threshold)) != 1 ||
                  mallopt(M_MMAP_THRESHOLD, static_cast<int>(s.mmap_threshold)) != 1))
    s.apply = false;
  std::lock_guard lock(applied_mutex);
  if (s.apply) applied = s;
  return s;
}

AllocatorSettings applied_allocator_settings() {
  std::lock_guard lock(applied_mutex);
  return applied;
}

int64_t sessions_memory_budget(const ServerConfig& config) {
  return config.sessions.max_memory_bytes > 0 ? config.sessions.max_memory_bytes : config.memory_budget() / 2;
}

int64_t session_memory_limit(const ServerConfig& config) {
  const int64_t all = sessions_memory_budget(config);
  const int64_t one = config.sessions.session_memory_bytes;
  return one > 0 ? std::min(one, all) : all;
}

JobLimits effective_limits(const ServerConfig& config) {
  JobLimits limits = config.limits;
  // One job alone may take the whole account; jobs side by side wait in it for each other
  // (server_capacity.hpp) instead of each being held to a fixed share.
  const int64_t budget = config.memory_budget();
  if (limits.max_memory_bytes == 0 || (budget > 0 && limits.max_memory_bytes > budget))
    limits.max_memory_bytes = budget;
  return limits;
}

}  // namespace rv
