// The daemon's configuration: one JSON file parsed once, at startup, into these typed structs.
// Every field has a default that works out of the box (`rvoronoi serve` with no file).
//
// File format (service/serve-config.example.json has every key with its default; all keys optional; unknown keys are an
// error so that a typo is not silently ignored):
//   {
//     "listen": "127.0.0.1:8080",          host:port; port 0 = an ephemeral port
//     "data_dir": "./rvoronoi-data",        job store (jobs.sqlite) and result files
//     "public_url": "",                     base of absolute links; "" = from the Host header
//     "web_dir": "",                        the HTML pages' assets; "" = the build's web/
//     "http": { "max_body_bytes": 67108864, "max_header_bytes": 16384,
//               "request_timeout_s": 30, "min_send_bytes_per_s": 16384, "io_threads": 2,
//               "max_connections": 0 },
//     "jobs": { "workers": 2, "queue_length": 16, "threads_per_job": 0,
//               "job_timeout_s": 3600, "shutdown_grace_s": 20, "describe_workers": 2 },
//     "limits": { "max_cells": 17179869184, "max_memory_bytes": 0, "total_memory_bytes": 0,
//                 "validate_max_cells": 4000000, "max_features": 10000000,
//                 "max_vertices": 100000000, "max_input_bytes": 2147483648,
//                 "preview_max_vertices": 2000000,
//                 "jobs_per_principal": 0, "cells_per_principal_per_hour": 0,
//                 "retained_free_bytes": 1073741824, "min_free_disk_bytes": 536870912 },
//     "auth": { "principals": [], "token_file": "", "tokens": [], "jwt": {...} },
//     "sessions": { "max_sessions": 16, "max_per_principal": 0, "max_memory_bytes": 0,
//                   "session_memory_bytes": 0, "undo_depth": 50, "idle_expiry_s": 3600,
//                   "workers": 2, "pending_per_session": 8 },
//     "daemon_name": "",
//     "store": "sqlite", "store_password_file": "", "store_connections": 8,
//     "results": "", "results_shared": false
//   }
// jobs also takes, for a shared store: "lease_s": 30, "max_attempts": 3, "retry_backoff_s": 10,
// "poll_s": 2, "retention_s": 0, "orphan_grace_s": 3600, "split_cells": 0.
// Authentication (AuthConfig below): with no principal configured (the default) every route is
// open and every job belongs to the principal "anonymous". With principals (hashed tokens, the
// deprecated plaintext tokens, or an identity provider's JWTs), every route except /,
// /conformance, /api and /health needs "Authorization: Bearer <token>", and every job belongs
// to the principal that submitted it: only it and the admins see it.
// Memory: one account for everything the daemon runs at once (limits.total_memory_bytes, default
// 80 % of physical memory): each job and each description of seed files reserves its estimate
// in it before allocating and returns it when done; a job waits there for memory, a description
// that does not fit is answered 503 (server_capacity.hpp). One job may use at most
// limits.max_memory_bytes (0 = the whole account). Besides, a queued job keeps its uploaded seed
// data in memory until it runs, so uploads can hold up to about (workers + queue_length) x
// max_body_bytes.
// Units: bytes, seconds, cells. Thread safety: plain data, immutable after parsing.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/job.hpp"

namespace rv {

struct HttpConfig {
  int64_t max_body_bytes = int64_t{64} << 20;  // request bodies above this: 413
  int64_t max_header_bytes = 16 * 1024;        // request headers above this: 431
  // A request must arrive whole within request_timeout_s. A response goes out in pieces, each within
  // request_timeout_s of the last, and the whole within request_timeout_s + its length /
  // min_send_bytes_per_s (0 = no such bound): a slow link downloads a large file, a client that
  // stops reading or reads a trickle to hold the connection is dropped.
  double request_timeout_s = 30.0;
  int64_t min_send_bytes_per_s = 16 * 1024;
  int io_threads = 2;  // threads running the network event loop
  // Connections open at once; beyond it a new connection replaces the one that has waited
  // longest for its request (503 when every one is busy). 0 = from the open-file limit.
  int64_t max_connections = 0;
};

struct JobsConfig {
  int workers = 2;                // jobs computed at the same time
  int queue_length = 16;          // jobs waiting for a worker; one more is refused with 503
  int threads_per_job = 0;        // engine threads per job; 0 = hardware threads / workers
  double job_timeout_s = 3600.0;  // a job running longer is cancelled and marked failed
  // Descriptions of seed files (describe-seeds) computed at once, each on a thread of its own
  // off the network threads; one more is answered 503 with Retry-After.
  int describe_workers = 2;
  // SIGTERM: running jobs get this long, then are cancelled. Below the 30 s a container runtime
  // (docker stop, compose stop_grace_period) waits before SIGKILL, so cancellation finishes.
  double shutdown_grace_s = 20.0;
  // With a shared store (StoreConfig): a claimed job's lease; heartbeats renew it every third of
  // it, and a job whose lease expires (its daemon died or lost the database) is queued again.
  double lease_s = 30.0;
  int max_attempts = 3;           // claims of one job before it fails (its daemons kept dying)
  double retry_backoff_s = 10.0;  // attempt n waits retry_backoff_s x 2^(n-1) before it runs again
  double poll_s = 2.0;            // how often an idle worker looks at the shared queue unprompted
  // Finished jobs (with their inputs and results) are deleted this long after they ended;
  // 0 = kept until dismissed. Applies to a shared store.
  double retention_s = 0.0;
  // The sweep removes job folders no job names (and attempts a finished job does not name) once
  // untouched this long: well above the seconds between a request's write and its row's commit.
  double orphan_grace_s = 3600.0;
  // A shared store's job of more cells than this whose plan streams (the exact or brute-force
  // method, no validation, no partial effect, not an edit) is split into bands of whole rows, each
  // about this many cells (at least 256 rows), that any daemon claims; the daemon that claims the
  // job once they are computed assembles them (its files a one-daemon run's, byte for byte).
  // 0 = never split.
  int64_t split_cells = 0;
};

// Where jobs are kept (the top-level `store`, `store_password_file`, `results`, `results_shared`).
// "sqlite" (the default): the embedded store in data_dir, results in data_dir/jobs, one daemon.
// A postgresql:// URI: the shared store and queue of several daemons (issue 55); its password
// comes from store_password_file or the environment (RVORONOI_STORE_PASSWORD, or libpq's own
// PGPASSWORD / ~/.pgpass), never from the URI, and is never logged.
struct StoreConfig {
  std::string uri = "sqlite";
  std::string password;       // read from password_file or the environment; never logged
  std::string password_file;  // as configured, for messages
  int connections = 8;        // the pool of connections to PostgreSQL
  // Where a shared store keeps its jobs' files (stored requests, edit bases, results): an
  // s3://bucket/prefix (GDAL's /vsis3/ with its AWS_* settings), or a folder every daemon mounts,
  // said so with results_shared. The embedded store keeps them in data_dir/jobs ("" only).
  std::string results;
  bool results_shared = false;
  bool shared() const { return uri != "sqlite"; }
};

// Who may use the server, and with which rights. A principal's name owns its jobs; "anonymous"
// is reserved (the owner of every job on a server without authentication and of jobs stored
// before principals existed).
enum class Role { user, admin };

struct PrincipalConfig {
  std::string name;  // 1..128 printable characters, not "anonymous"
  Role role = Role::user;
  std::array<unsigned char, 32> token_sha256{};  // SHA-256 of the bearer token's bytes
};

// Bearer JWTs of an identity provider (auth.jwt). Keys: a JWKS from `jwks_file` (read again when
// it changes) or `jwks_url` (https only; fetched every `jwks_refresh_s`, and again, at most every
// `jwks_min_interval_s`, when a token names a key id the set lacks). Claims checked: the signature
// (RS256 or ES256, `algorithms`), "iss" equal to `issuer`, "aud" naming one of `audiences`,
// "exp" and "nbf" with `clock_skew_s` of slack, "sub" present (the principal's name). The role is
// admin when the claim at `role_claim` (a dotted path, e.g. "realm_access.roles"; a string, an
// array of strings or a space-separated list) holds `admin_value`.
struct JwtConfig {
  std::string issuer;
  std::vector<std::string> audiences;
  std::string jwks_file;
  std::string jwks_url;
  std::string jwks_ca_file;  // PEM certificates trusted for jwks_url besides the system's; "" = none
  double jwks_refresh_s = 300.0;
  double jwks_min_interval_s = 10.0;
  double clock_skew_s = 60.0;
  std::vector<std::string> algorithms{"RS256", "ES256"};
  std::string role_claim;   // "" = every principal of the provider is a user
  std::string admin_value;  // with role_claim
  bool enabled() const { return !jwks_file.empty() || !jwks_url.empty(); }
};

struct AuthConfig {
  // Every principal with a token: auth.principals, one per plaintext token of the deprecated
  // auth.tokens (a user named "token-" and the first 8 hex digits of its hash), and last
  // auth.token_file's (read by parse_server_config). Only hashes are kept.
  std::vector<PrincipalConfig> principals;
  std::string token_file;     // as configured; "" = none
  int deprecated_tokens = 0;  // how many came from plaintext tokens (auth.tokens, a plain token_file)
  // The token file's part: its principals are the last `token_file_principals`, of which
  // `token_file_deprecated` plaintext tokens; `token_file_stamp` is the file's as it was read
  // (auth/file_stamp.hpp). The daemon reads the file again when the stamp changes (reread_token_file).
  int token_file_principals = 0;
  int token_file_deprecated = 0;
  std::string token_file_stamp;
  JwtConfig jwt;
  bool enabled() const { return !principals.empty() || jwt.enabled(); }
};

// What one principal may use (limits.jobs_per_principal, limits.cells_per_principal_per_hour);
// 0 = no limit. Over either a submission is answered 429 with Retry-After.
struct PrincipalLimits {
  int jobs = 0;                // jobs accepted and not yet finished (waiting or running)
  int64_t cells_per_hour = 0;  // grid cells of the jobs submitted within the last hour
};

// Live what-if sessions (the "sessions" object; issue 54). A session holds its field and lines in
// memory until it is deleted or has been idle for idle_expiry_s; a restart loses every session.
struct SessionsConfig {
  int max_sessions = 16;             // held at once (creating or ready); one more: 503 with Retry-After
  int max_per_principal = 0;         // held by one principal (admins signed in as such aside); 0 = no
                                     // limit of its own; one more: 429
  int64_t max_memory_bytes = 0;      // every session's memory together; 0 = half the memory account;
                                     // a session or an edit that would pass it: 503 with Retry-After
  int64_t session_memory_bytes = 0;  // one session; 0 = max_memory_bytes; past it: 422 too large
  int undo_depth = 50;               // steps each session keeps for undo
  double idle_expiry_s = 3600.0;     // a session unused this long is deleted (then 404, saying so)
  int workers = 2;                   // threads running sessions' edits and reads, beside the job workers
  int pending_per_session = 8;       // requests waiting behind a session's running one; one more: 503
};

struct ServerConfig {
  std::string host = "127.0.0.1";
  int port = 8080;  // 0 = ephemeral (tests)
  std::string data_dir = "./rvoronoi-data";
  std::string public_url;  // e.g. "https://voronoi.example.org"; empty = http://<Host header>
  // The pages' assets (page.html, pages.js, rvoronoi.css, the map page's bundle): "" = those of
  // the build this daemon comes from (its web/ directory).
  std::string web_dir;
  HttpConfig http;
  JobsConfig jobs;
  JobLimits limits;  // per job; max_memory_bytes 0 = the whole account (memory_budget())
  // The daemon's one memory account (limits.total_memory_bytes); 0 = 80 % of physical memory.
  int64_t total_memory_bytes = 0;
  // describe-seeds returns the features (for drawing) of uploads of at most this many vertices
  // (limits.preview_max_vertices); larger ones are described without them.
  int64_t preview_max_vertices = 2'000'000;
  // Freed memory the C library keeps for reuse at the top of each allocator arena instead of
  // handing it back to the system (limits.retained_free_bytes; glibc's M_TRIM_THRESHOLD, with
  // M_MMAP_THRESHOLD fixed at its largest, 32 MiB, so that blocks above that, rasters, go back at
  // once). A session's steps free and allocate again tens of megabytes each on the sessions'
  // threads: given back and faulted in again every step, they cost more than the step's own work.
  // Outside the memory account. 0 = the C library's adaptive defaults; see AllocatorSettings.
  int64_t retained_free_bytes = int64_t{1} << 30;
  // The free space data_dir's file system must keep (limits.min_free_disk_bytes): below it the
  // daemon takes no job to run (a submission is answered 503 with Retry-After, a daemon of a
  // shared store claims nothing from the queue) and /health says "degraded", so that a job is not
  // refused at the end of its work with "No space left on device". 0 = no floor.
  int64_t min_free_disk_bytes = int64_t{512} << 20;
  AuthConfig auth;
  PrincipalLimits principal_limits;
  SessionsConfig sessions;
  StoreConfig store;
  // Names this daemon in its session ids ([a-z0-9-], 1..63 characters), so that a shared service
  // can tell which daemon holds a session; "" = the host name and the port listened on.
  std::string daemon_name;

  // The bytes of the memory account: total_memory_bytes, else 80 % of physical memory.
  int64_t memory_budget() const;
};

// What the daemon sets in the C library's allocator at start (apply_allocator_settings): nothing
// when retained_free_bytes is 0 or when the environment's GLIBC_TUNABLES (`tunables`, null when
// unset) sets a malloc tunable itself (the operator's word wins); else the two thresholds.
struct AllocatorSettings {
  bool apply = false;
  int64_t mmap_threshold = 0, trim_threshold = 0;
};
AllocatorSettings allocator_settings(const ServerConfig& config, const char* tunables);
// Applies allocator_settings(config, getenv("GLIBC_TUNABLES")) (mallopt); returns them. Call
// before any thread starts.
AllocatorSettings apply_allocator_settings(const ServerConfig& config);
// What apply_allocator_settings last set in this process (the allocator is the process's): none
// before it ran. The daemon's "listening" line reports it.
AllocatorSettings applied_allocator_settings();

// The bytes every session together may hold (sessions.max_memory_bytes, else half of
// memory_budget()), and one session (sessions.session_memory_bytes, else that).
int64_t sessions_memory_budget(const ServerConfig& config);
int64_t session_memory_limit(const ServerConfig& config);

// Parses "host:port" (IPv6 as "[::1]:8080") into config.host/config.port.
// Throws rv::Error(invalid_argument).
void parse_listen(const std::string& listen, ServerConfig& config);

// Parses a configuration document (and reads auth.token_file). Throws rv::Error naming the key at
// fault: invalid_argument, or not_found when the token file cannot be read. Messages never
// contain a token.
ServerConfig parse_server_config(const nlohmann::json& document);

// The "auth" object of a configuration document into `auth` (auth_config.cpp). Throws as above.
void parse_auth_config(const nlohmann::json& object, AuthConfig& auth);

// `auth` with its token file read again as the file is now: the file's principals replaced, the
// others kept. Throws as parse_auth_config for a file that cannot be used (missing, not valid,
// holding no token, a token or name clashing with another principal's); `auth` is left as it was.
AuthConfig reread_token_file(const AuthConfig& auth);

// The lower-case hex SHA-256 of `token`'s bytes: what auth.principals[].token_sha256 holds
// (`printf %s "$TOKEN" | sha256sum`).
std::string token_sha256_hex(std::string_view token);

// Reads and parses a configuration file. Throws rv::Error(not_found / invalid_argument).
ServerConfig load_server_config(const std::string& path);

// The per-job limits the server actually applies (max_memory_bytes resolved when 0, and never
// above the account's total).
JobLimits effective_limits(const ServerConfig& config);

}  // namespace rv
