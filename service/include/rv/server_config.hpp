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
//               "request_timeout_s": 30, "io_threads": 2, "max_connections": 0 },
//     "jobs": { "workers": 2, "queue_length": 16, "threads_per_job": 0,
//               "job_timeout_s": 3600, "shutdown_grace_s": 20, "describe_workers": 2 },
//     "limits": { "max_cells": 17179869184, "max_memory_bytes": 0, "total_memory_bytes": 0,
//                 "validate_max_cells": 4000000, "max_features": 10000000,
//                 "max_vertices": 100000000, "max_input_bytes": 2147483648,
//                 "preview_max_vertices": 2000000 },
//     "auth": { "tokens": [], "token_file": "" }
//   }
// Authentication: with no token configured (the default) every route is open. With at least one
// (auth.tokens, and/or auth.token_file: one token per line, '#' comments and blank lines
// ignored, read once at startup), every route except /, /conformance, /api and /health needs
// "Authorization: Bearer <token>" naming one of them.
// Memory: one account for everything the daemon runs at once (limits.total_memory_bytes, default
// 80 % of physical memory): each job and each description of seed files reserves its estimate
// in it before allocating and returns it when done; a job waits there for memory, a description
// that does not fit is answered 503 (server_capacity.hpp). One job may use at most
// limits.max_memory_bytes (0 = the whole account). Besides, a queued job keeps its uploaded seed
// data in memory until it runs, so uploads can hold up to about (workers + queue_length) x
// max_body_bytes.
// Units: bytes, seconds, cells. Thread safety: plain data, immutable after parsing.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/job.hpp"

namespace rv {

struct HttpConfig {
  int64_t max_body_bytes = int64_t{64} << 20;  // request bodies above this: 413
  int64_t max_header_bytes = 16 * 1024;        // request headers above this: 431
  double request_timeout_s = 30.0;             // reading one request / writing one response, whole
  int io_threads = 2;                          // threads running the network event loop
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
};

struct AuthConfig {
  // Accepted bearer tokens, file tokens included (the file is read by parse_server_config).
  // Empty = no authentication. Each is 16..4096 printable ASCII characters without spaces.
  std::vector<std::string> tokens;
  std::string token_file;  // as configured, for messages; "" = none
  bool enabled() const { return !tokens.empty(); }
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
  AuthConfig auth;

  // The bytes of the memory account: total_memory_bytes, else 80 % of physical memory.
  int64_t memory_budget() const;
};

// Parses "host:port" (IPv6 as "[::1]:8080") into config.host/config.port.
// Throws rv::Error(invalid_argument).
void parse_listen(const std::string& listen, ServerConfig& config);

// Parses a configuration document (and reads auth.token_file). Throws rv::Error naming the key at
// fault: invalid_argument, or not_found when the token file cannot be read. Messages never
// contain a token.
ServerConfig parse_server_config(const nlohmann::json& document);

// Reads and parses a configuration file. Throws rv::Error(not_found / invalid_argument).
ServerConfig load_server_config(const std::string& path);

// The per-job limits the server actually applies (max_memory_bytes resolved when 0, and never
// above the account's total).
JobLimits effective_limits(const ServerConfig& config);

}  // namespace rv
