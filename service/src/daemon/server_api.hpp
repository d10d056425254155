// The OGC API - Processes resources, independent of the HTTP transport: a request in, exactly
// one response out (possibly later, from a worker thread, for synchronous execution).
// rv::Error is translated into problem+json here, once, through error_info().
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "auth/principal.hpp"
#include "daemon/server_jobs.hpp"
#include "daemon/server_sessions.hpp"
#include "rv/server_config.hpp"
#include "rv/store_jobs.hpp"
#include "store/object_store.hpp"

namespace rv::daemon {

// Bytes [offset, offset + length) of an open result file (local, or an object on a bucket): the
// body of a (partial) file response. The reader is closed when the last owner lets go.
struct FileSlice {
  std::shared_ptr<store::ObjectReader> file;
  uint64_t offset = 0;
  uint64_t length = 0;
};

struct ApiRequest {
  std::string method;           // "GET", "HEAD", "POST", "DELETE", ...
  std::string target;           // origin-form request target, query included
  std::string host;             // Host header
  std::string prefer;           // Prefer header
  std::string range;            // Range header
  std::string accept;           // Accept header (HTML pages, server_web.hpp)
  std::string accept_encoding;  // Accept-Encoding header (the pages' assets, server_web.hpp)
  std::string if_none_match;    // If-None-Match header (the pages' assets)
  std::string body;
  auth::Principal principal;  // who asks (server_auth.hpp); the anonymous admin without authentication
};

struct ApiResponse {
  unsigned status = 200;
  std::vector<std::pair<std::string, std::string>> headers;  // Content-Type included
  std::string body;
  std::optional<FileSlice> file;  // when set, the body comes from here instead of `body`
};

// Builds an RFC 7807 problem response (Content-Type application/problem+json). The detail is
// made valid UTF-8 and cut to kMaxProblemDetail bytes; a 503 carries Retry-After.
inline constexpr std::size_t kMaxProblemDetail = 2048;
inline constexpr int kRetryAfterSeconds = 5;
ApiResponse problem_response(unsigned status, const std::string& type, const std::string& title,
                             const std::string& detail, const std::string& instance);
// A fixed 500 problem that cannot fail to build: for when describing an error failed too.
ApiResponse last_resort_problem();
// The problem for the exception being handled (call inside a catch block): rv::Error through
// the error table, JSON errors as invalid_argument, bad_alloc as too_large, anything else as
// internal; never throws.
ApiResponse problem_of_current_exception(const std::string& path);
// A JSON document as the response body (Content-Type `type`).
ApiResponse json_response(unsigned status, const nlohmann::json& body, const char* type = kMediaJson);

using Respond = std::function<void(ApiResponse)>;

class Api {
 public:
  // Descriptions of seed files run on `describe_pool`, each reserving its memory in `memory`.
  Api(const ServerConfig& config, const JobRecords& store, JobManager& jobs, MemoryAccount& memory,
      RequestPool& describe_pool, SessionManager& sessions);
  // Calls `respond` exactly once, on this thread or (synchronous execution) a worker thread.
  void handle(const ApiRequest& request, Respond respond);

  // The request as an action reads it.
  struct Context {
    const ApiRequest& request;
    std::string path;
    std::map<std::string, std::vector<std::string>> query;
    std::string base;  // scheme://host[:port], no trailing slash
  };
  // What an action answers to: the parsed request and the one way to answer it.
  struct Request {
    const Context& ctx;
    std::shared_ptr<Respond> respond;
    void reply(ApiResponse r) const { (*respond)(std::move(r)); }
  };

 private:
  void route(const Context& ctx, const std::shared_ptr<Respond>& respond);
  // Where the pages' assets are (ServerConfig::web_dir, else the build's).
  std::string web_dir() const;
  // One action per resource (the paths are in route()).
  void landing(const Request& req, const std::vector<std::string>& seg) const;
  void conformance(const Request& req, const std::vector<std::string>& seg) const;
  void api_document(const Request& req, const std::vector<std::string>& seg) const;
  void health(const Request& req, const std::vector<std::string>& seg) const;
  void me(const Request& req, const std::vector<std::string>& seg) const;
  void process_list(const Request& req, const std::vector<std::string>& seg) const;
  void process(const Request& req, const std::vector<std::string>& seg) const;
  void execute(const Request& req, const std::vector<std::string>& seg) const;
  void describe(const Request& req) const;
  void job_list(const Request& req, const std::vector<std::string>& seg) const;
  void job(const Request& req, const std::vector<std::string>& seg) const;
  void results(const Request& req, const std::vector<std::string>& seg) const;
  void result_file(const Request& req, const std::vector<std::string>& seg) const;
  // Live what-if sessions (server_api_sessions.cpp).
  void session_list(const Request& req, const std::vector<std::string>& seg) const;
  void session(const Request& req, const std::vector<std::string>& seg) const;
  void session_features(const Request& req, const std::vector<std::string>& seg) const;
  void session_lines(const Request& req, const std::vector<std::string>& seg) const;
  void session_deliverables(const Request& req, const std::vector<std::string>& seg) const;
  void session_deliverable(const Request& req, const std::vector<std::string>& seg) const;
  void session_step(const Request& req, const std::vector<std::string>& seg) const;  // edits, undo, redo
  void session_jobs(const Request& req, const std::vector<std::string>& seg) const;
  void create_session(const Request& req) const;
  // Whom a submitted job answers, copied out of the request (a session submits from its thread,
  // after the request's context is gone).
  struct JobAnswer {
    std::shared_ptr<Respond> respond;
    std::string base, path;
    bool async = false;  // Prefer: respond-async
    auth::Principal who;
    static JobAnswer of(const Request& req);
  };
  // Submits job `id` and answers as an execution does: 201 with its status for respond-async,
  // else its results (or raw output) once it ends.
  void submit_job(const JobAnswer& to, const std::string& id, Execution ex) const;

  const ServerConfig& config_;
  const JobRecords& store_;
  JobManager& jobs_;
  MemoryAccount& memory_;
  RequestPool& describe_pool_;
  SessionManager& sessions_;
};

// The repository's openapi.yaml, embedded at build time.
extern const char* const kOpenApiYaml;
extern const std::size_t kOpenApiYamlSize;

}  // namespace rv::daemon
