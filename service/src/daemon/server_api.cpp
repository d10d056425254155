#include "daemon/server_api.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <filesystem>

#include "../common/atomic_file.hpp"
#include "auth/crypto.hpp"
#include "daemon/server_seeds.hpp"
#include "daemon/server_web.hpp"
#include "runtime/principal_usage.hpp"
#include "runtime/server_util.hpp"
#include "rv/error_map.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/json_text.hpp"
#include "rv/options.hpp"
#include "rv/version.hpp"

namespace rv::daemon {
namespace {

using nlohmann::json;

constexpr const char* kJson = kMediaJson;
constexpr const char* kOgcExceptions = "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/";
constexpr const char* kOgcRel = "http://www.opengis.net/def/rel/ogc/1.0/";

// A not-found refined to one of the OGC exception types (no-such-process, no-such-job,
// result-not-ready). Still an rv::Error(not_found): status and title come from the one table.
class OgcNotFound : public Error {
 public:
  OgcNotFound(std::string ogc_type, const std::string& message)
      : Error(ErrorKind::not_found, message), ogc_type_(std::move(ogc_type)) {}
  const std::string& ogc_type() const { return ogc_type_; }

 private:
  std::string ogc_type_;
};

// A description with its validator: clients that cache descriptions (the QGIS provider) ask
// again with If-None-Match and get 304 while nothing changed. A strong ETag: the body's SHA-256.
ApiResponse validated(const ApiRequest& request, ApiResponse r) {
  const std::string etag = "\"" + auth::to_hex(auth::sha256(r.body)).substr(0, 32) + "\"";
  r.headers.emplace_back("ETag", etag);
  r.headers.emplace_back("Cache-Control", "no-cache");
  if (if_none_match_matches(request.if_none_match, etag)) {
    ApiResponse not_modified;
    not_modified.status = 304;
    not_modified.headers.emplace_back("ETag", etag);
    not_modified.headers.emplace_back("Cache-Control", "no-cache");
    return not_modified;
  }
  return r;
}

ApiResponse problem_from(const Error& e, const std::string& instance) {
  const ErrorInfo& info = error_info(e.kind());
  std::string type(info.type);
  if (const auto* ogc = dynamic_cast<const OgcNotFound*>(&e)) type = kOgcExceptions + ogc->ogc_type();
  ApiResponse r =
      problem_response(static_cast<unsigned>(info.http_status), type, std::string(info.title), e.what(), instance);
  // RFC 6585 4: a client over its allowance is told when it may come back.
  if (const auto* quota = dynamic_cast<const QuotaExceeded*>(&e))
    r.headers.emplace_back("Retry-After", std::to_string(quota->retry_after_s()));
  return r;
}

ErrorKind parse_error_kind(const std::string& name) {
  for (int k = 0; k <= static_cast<int>(ErrorKind::internal); ++k) {
    if (to_string(static_cast<ErrorKind>(k)) == name) return static_cast<ErrorKind>(k);
  }
  return ErrorKind::internal;
}

std::vector<std::string> split(std::string_view s, char sep) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    const size_t end = s.find(sep, start);
    parts.emplace_back(s.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start));
    if (end == std::string_view::npos) return parts;
    start = end + 1;
  }
}

// A Host header is echoed into links: accept only what a host[:port] can contain.
bool plausible_host(const std::string& h) {
  return !h.empty() && h.size() < 256 && std::all_of(h.begin(), h.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == ':' || c == '[' || c == ']' ||
           c == '_';
  });
}

// The media type output `id` of job `r` was written as (the ownership raster's sidecar too).
std::string media_of(const JobRecord& r, const std::string& id) {
  if (id == "ownership.aux.xml") return "application/xml";
  for (size_t i = 0; i < r.outputs.size() && i < r.formats.size(); ++i)
    if (r.outputs[i] == id) return r.formats[i];
  return output_media_type(id, "");
}

// The file of output `id` of job `r` inside its directory.
std::string file_of(const JobRecord& r, const std::string& id) { return output_file_name(id, media_of(r, id)); }

}  // namespace

ApiResponse json_response(unsigned status, const json& body, const char* type) {
  ApiResponse r;
  r.status = status;
  r.headers.emplace_back("Content-Type", type);
  r.body = json_text(body);
  return r;
}

ApiResponse problem_response(unsigned status, const std::string& type, const std::string& title,
                             const std::string& detail, const std::string& instance) {
  // A detail may quote what a client sent or a file held: one line a person can read, not an
  // echo of the upload (quote_input makes it valid UTF-8 and cuts it at kMaxProblemDetail).
  json p = {{"type", type}, {"title", title}, {"status", status}, {"detail", quote_input(detail, kMaxProblemDetail)}};
  if (!instance.empty()) p["instance"] = quote_input(instance, 256);
  ApiResponse r = json_response(status, p, "application/problem+json");
  // RFC 9110 10.2.3: a client told to come back later is told when.
  if (status == 503) r.headers.emplace_back("Retry-After", std::to_string(kRetryAfterSeconds));
  return r;
}

Api::Api(const ServerConfig& config, const JobRecords& store, JobManager& jobs, MemoryAccount& memory,
         RequestPool& describe_pool, SessionManager& sessions)
    : config_(config),
      store_(store),
      jobs_(jobs),
      memory_(memory),
      describe_pool_(describe_pool),
      sessions_(sessions) {}

ApiResponse problem_of_current_exception(const std::string& path) {
  try {
    try {
      throw;
    } catch (const Error& e) {
      return problem_from(e, path);
    } catch (const json::exception& e) {
      return problem_from(Error(ErrorKind::invalid_argument, std::string("malformed JSON value: ") + e.what()), path);
    } catch (const std::bad_alloc&) {
      return problem_from(Error(ErrorKind::too_large, "the server ran out of memory for this request"), path);
    } catch (const std::exception& e) {
      return problem_from(Error(ErrorKind::internal, e.what()), path);
    } catch (...) {
      return problem_from(Error(ErrorKind::internal, "unknown exception"), path);
    }
  } catch (...) {
    return last_resort_problem();
  }
}

std::string Api::web_dir() const {
  if (!config_.web_dir.empty()) return config_.web_dir;
  // The build's copy for a binary run from its build tree; an installed binary's beside it
  // (<prefix>/bin/rvoronoi -> <prefix>/share/rvoronoi/web), where its package put them.
  static const std::string dir = [] {
    std::error_code ec;
    if (std::filesystem::is_directory(RV_WEB_DIR, ec)) return std::string(RV_WEB_DIR);
    const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    const std::filesystem::path installed = exe.parent_path().parent_path() / "share" / "rvoronoi" / "web";
    return !ec && std::filesystem::is_directory(installed, ec) ? installed.string() : std::string(RV_WEB_DIR);
  }();
  return dir;
}

void Api::handle(const ApiRequest& request, Respond respond) {
  auto shared = std::make_shared<Respond>(std::move(respond));
  const std::string& target = request.target;
  const size_t q = target.find('?');
  Context ctx{request, target.substr(0, q), {}, {}};
  if (q != std::string::npos) {
    for (const std::string& pair : split(std::string_view(target).substr(q + 1), '&')) {
      if (pair.empty()) continue;
      const size_t eq = pair.find('=');
      ctx.query[percent_decode(pair.substr(0, eq))].push_back(
          eq == std::string::npos ? std::string() : percent_decode(pair.substr(eq + 1)));
    }
  }
  if (!config_.public_url.empty()) {
    ctx.base = config_.public_url;
  } else if (plausible_host(request.host)) {
    ctx.base = "http://" + request.host;
  } else {
    ctx.base = "http://" + config_.host + ":" + std::to_string(config_.port);
  }
  // The pages for people and their assets (server_web.hpp), before the resources' JSON.
  if (is_asset(target)) return (*shared)(asset_response(web_dir(), request));
  if (is_app(target) && (request.method == "GET" || request.method == "HEAD"))
    return (*shared)(app_response(web_dir()));
  if (wants_page(request.method, target, request.accept)) return (*shared)(page_response(web_dir()));
  // Exactly one response: the handler either answered, or handed `shared` to a job. Whatever
  // the handler throws becomes a problem here; nothing leaves this function but the answer.
  ApiResponse problem;
  try {
    route(ctx, shared);
    return;
  } catch (...) {
    problem = problem_of_current_exception(ctx.path);
  }
  (*shared)(std::move(problem));
}

ApiResponse last_resort_problem() {
  ApiResponse r;
  r.status = 500;
  r.headers.emplace_back("Content-Type", "application/problem+json");
  r.body = R"({"type":"https://rvoronoi.dev/problems/internal","title":"Internal error","status":500,)"
           R"("detail":"the server could not describe this error"})";
  return r;
}

namespace {

json status_info(const JobRecord& r, const std::string& base) {
  const std::string self = base + "/jobs/" + r.id;
  json s = {{"processID", r.process_id},
            {"type", "process"},
            {"jobID", r.id},
            {"status", std::string(to_string(r.status))},
            {"message", r.message},
            {"created", r.created},
            {"updated", r.updated},
            {"progress", r.progress},
            {"principal", r.principal}};
  if (!r.started.empty()) s["started"] = r.started;
  if (!r.finished.empty()) s["finished"] = r.finished;
  json links = json::array({link(self, "self", kJson, "job status"), link(base + "/jobs", "up", kJson, "job list")});
  // An edit names the job it edits (its input baseJob, a checked job id).
  if (r.inputs.is_object() && r.inputs.contains("baseJob") && r.inputs["baseJob"].is_string() &&
      is_job_id(r.inputs["baseJob"].get<std::string>()))
    links.push_back(
        link(base + "/jobs/" + r.inputs["baseJob"].get<std::string>(), "via", kJson, "the base job this job edits"));
  if (r.status == JobStatus::successful) {
    links.push_back(link(self + "/results", std::string(kOgcRel) + "results", kJson, "job results"));
    for (const std::string& o : r.outputs) {
      links.push_back(link(self + "/results/" + o, "enclosure", media_of(r, o), o));
      if (o == "ownership") {
        links.push_back(link(self + "/results/ownership.aux.xml", "describedby", "application/xml",
                             "raster attribute table of ownership (GDAL PAM sidecar)"));
      }
    }
  }
  s["links"] = links;
  return s;
}

json results_document(const JobRecord& r, const std::string& base) {
  json doc = json::object();
  for (size_t i = 0; i < r.outputs.size(); ++i) {
    const std::string& o = r.outputs[i];
    const bool by_value = i < r.transmission.size() && r.transmission[i] == "value";
    if (by_value) {
      doc[o] = {{"value", r.report}, {"mediaType", kJson}};
    } else {
      doc[o] = {{"href", base + "/jobs/" + r.id + "/results/" + o}, {"type", media_of(r, o)}};
    }
  }
  return doc;
}

// The answer about a job that has no results to give. A job that failed over its principal's
// hourly allowance answers 429 with the Retry-After its grid needs now (`jobs`).
[[noreturn]] void throw_no_results(const JobRecord& r, const JobManager& jobs) {
  if (r.status == JobStatus::failed && r.error_kind == to_string(ErrorKind::over_quota))
    throw QuotaExceeded(r.message, jobs.cells_retry_after(r.principal, r.cells));
  switch (r.status) {
    case JobStatus::accepted:
    case JobStatus::running:
      throw OgcNotFound("result-not-ready",
                        "job " + r.id + " is " + std::string(to_string(r.status)) + "; its results are not ready yet");
    case JobStatus::failed:
      throw Error(parse_error_kind(r.error_kind), r.message);
    case JobStatus::dismissed:
      throw OgcNotFound("no-such-job", "job " + r.id + " was dismissed; its results were deleted");
    case JobStatus::successful:
      break;
  }
  throw Error(ErrorKind::internal, "throw_no_results on a successful job");
}

// The job `id` as `who` may see it. Another principal's job is answered exactly as one that does
// not exist: the same problem, word for word.
JobRecord find_job(const JobRecords& store, const std::string& id, const auth::Principal& who) {
  if (!is_job_id(id)) throw OgcNotFound("no-such-job", "no job '" + id.substr(0, 64) + "'");
  auto r = store.get(id);
  if (!r || !auth::may_see(who, r->principal)) throw OgcNotFound("no-such-job", "no job '" + id + "'");
  return *r;
}

// Parses a single "bytes=" range against a file of `size` bytes. Returns nullopt for a header
// to ignore (several ranges, other units: the whole file is sent), throws the 416 marker
// (length 0, offset size) for an unsatisfiable one.
struct ByteRange {
  uint64_t first = 0, last = 0;  // inclusive
  bool satisfiable = true;
};

std::optional<ByteRange> parse_range(const std::string& header, uint64_t size) {
  if (header.rfind("bytes=", 0) != 0) return std::nullopt;
  const std::string spec = header.substr(6);
  if (spec.find(',') != std::string::npos) return std::nullopt;
  const size_t dash = spec.find('-');
  if (dash == std::string::npos) return std::nullopt;
  auto number = [](std::string_view s, uint64_t& v) {
    if (s.empty()) return false;
    const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    return ec == std::errc() && p == s.data() + s.size();
  };
  const std::string_view a = std::string_view(spec).substr(0, dash);
  const std::string_view b = std::string_view(spec).substr(dash + 1);
  ByteRange r;
  uint64_t x = 0, y = 0;
  if (a.empty()) {  // suffix: the last y bytes
    if (!number(b, y)) return std::nullopt;
    if (y == 0 || size == 0) return ByteRange{0, 0, false};
    r.first = y >= size ? 0 : size - y;
    r.last = size - 1;
    return r;
  }
  if (!number(a, x)) return std::nullopt;
  if (b.empty()) {
    y = size == 0 ? 0 : size - 1;
  } else if (!number(b, y) || y < x) {
    return std::nullopt;  // syntactically invalid: ignored (RFC 9110 14.2)
  }
  if (x >= size) return ByteRange{0, 0, false};
  r.first = x;
  r.last = std::min(y, size - 1);
  return r;
}

ApiResponse file_response(std::unique_ptr<store::ObjectReader> reader, const std::string& media_type,
                          const std::string& range_header, const std::string& not_found_message) {
  if (!reader) throw Error(ErrorKind::not_found, not_found_message);
  std::shared_ptr<store::ObjectReader> handle = std::move(reader);
  const uint64_t size = handle->size();
  ApiResponse r;
  r.headers.emplace_back("Content-Type", media_type);
  r.headers.emplace_back("Accept-Ranges", "bytes");
  const auto mtime = handle->modified();
  r.headers.emplace_back("Last-Modified", http_date(mtime));
  // Result files never change once written (renamed into place, or one upload): size and time
  // identify them.
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(mtime.time_since_epoch()).count();
  r.headers.emplace_back("ETag", "\"" + std::to_string(size) + "-" + std::to_string(ns / 1000000000) + "." +
                                     std::to_string(ns % 1000000000) + "\"");
  FileSlice slice{handle, 0, size};
  if (!range_header.empty()) {
    if (const auto range = parse_range(range_header, size)) {
      if (!range->satisfiable) {
        ApiResponse p =
            problem_response(416, "https://rvoronoi.dev/problems/range-not-satisfiable", "Range not satisfiable",
                             "the file has " + std::to_string(size) + " bytes; requested " + range_header, "");
        p.headers.emplace_back("Content-Range", "bytes */" + std::to_string(size));
        p.headers.emplace_back("Accept-Ranges", "bytes");
        return p;
      }
      r.status = 206;
      slice.offset = range->first;
      slice.length = range->last - range->first + 1;
      r.headers.emplace_back("Content-Range", "bytes " + std::to_string(range->first) + "-" +
                                                  std::to_string(range->last) + "/" + std::to_string(size));
    }
  }
  r.file = slice;
  return r;
}

ApiResponse method_not_allowed(const std::string& allow, const std::string& path) {
  ApiResponse r = problem_response(405, "https://rvoronoi.dev/problems/method-not-allowed", "Method not allowed",
                                   "allowed here: " + allow, path);
  r.headers.emplace_back("Allow", allow);
  return r;
}

}  // namespace

namespace {

// The resources of the API: a path pattern ("*" matches one segment), the methods it answers,
// and its action. route() finds the resource, answers 405 with Allow for another method, and
// runs the action; one thin action per resource.
struct Resource {
  std::vector<std::string_view> pattern;
  std::string_view allow;
  void (Api::*action)(const Api::Request&, const std::vector<std::string>&) const;
};

bool matches(const std::vector<std::string_view>& pattern, const std::vector<std::string>& seg) {
  if (pattern.size() != seg.size()) return false;
  for (size_t i = 0; i < seg.size(); ++i)
    if (pattern[i] != "*" && pattern[i] != seg[i]) return false;
  return true;
}

bool allowed(std::string_view allow, const std::string& method) {
  size_t start = 0;
  while (start < allow.size()) {
    const size_t end = std::min(allow.find(',', start), allow.size());
    std::string_view m = allow.substr(start, end - start);
    while (!m.empty() && m.front() == ' ') m.remove_prefix(1);
    if (m == method) return true;
    start = end + 1;
  }
  return false;
}

// A query parameter as an integer in [lo, hi], or `fallback` when it is absent.
int int_param(const std::map<std::string, std::vector<std::string>>& query, const char* name, int lo, int hi,
              int fallback) {
  const auto it = query.find(name);
  if (it == query.end()) return fallback;
  const std::string& v = it->second.front();
  int x = 0;
  const auto [p, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  if (ec != std::errc() || p != v.data() + v.size() || x < lo || x > hi) {
    throw Error(ErrorKind::invalid_argument, std::string("parameter '") + name + "' must be an integer in " +
                                                 std::to_string(lo) + ".." + std::to_string(hi));
  }
  return x;
}

}  // namespace

void Api::route(const Context& ctx, const std::shared_ptr<Respond>& respond) {
  static const std::vector<Resource> resources = {
      {{}, "GET, HEAD", &Api::landing},
      {{"conformance"}, "GET, HEAD", &Api::conformance},
      {{"api"}, "GET, HEAD", &Api::api_document},
      {{"health"}, "GET, HEAD", &Api::health},
      {{"me"}, "GET, HEAD", &Api::me},
      {{"processes"}, "GET, HEAD", &Api::process_list},
      {{"processes", "*"}, "GET, HEAD", &Api::process},
      {{"processes", "*", "execution"}, "POST", &Api::execute},
      {{"jobs"}, "GET, HEAD", &Api::job_list},
      {{"jobs", "*"}, "GET, HEAD, DELETE", &Api::job},
      {{"jobs", "*", "results"}, "GET, HEAD", &Api::results},
      {{"jobs", "*", "results", "*"}, "GET, HEAD", &Api::result_file},
      {{"sessions"}, "GET, HEAD, POST", &Api::session_list},
      {{"sessions", "*"}, "GET, HEAD, DELETE", &Api::session},
      {{"sessions", "*", "features"}, "GET, HEAD", &Api::session_features},
      {{"sessions", "*", "deliverables"}, "GET, HEAD", &Api::session_deliverables},
      {{"sessions", "*", "lines"}, "GET, HEAD", &Api::session_lines},
      {{"sessions", "*", "deliverables", "*"}, "GET, HEAD", &Api::session_deliverable},
      {{"sessions", "*", "edits"}, "POST", &Api::session_step},
      {{"sessions", "*", "undo"}, "POST", &Api::session_step},
      {{"sessions", "*", "redo"}, "POST", &Api::session_step},
      {{"sessions", "*", "jobs"}, "POST", &Api::session_jobs},
  };
  const Request req{ctx, respond};
  const std::vector<std::string> seg = path_segments(ctx.path);
  // An unknown process is "no such process" whatever follows it (OGC's exception type).
  if (seg.size() >= 2 && seg[0] == "processes" && seg[1] != "voronoi" && seg[1] != kDescribeSeedsId)
    throw OgcNotFound("no-such-process", "no process '" + seg[1].substr(0, 64) + "'");
  for (const Resource& r : resources) {
    if (!matches(r.pattern, seg)) continue;
    if (!allowed(r.allow, ctx.request.method)) return req.reply(method_not_allowed(std::string(r.allow), ctx.path));
    return (this->*r.action)(req, seg);
  }
  throw Error(ErrorKind::not_found, "no resource " + ctx.path.substr(0, 200));
}

void Api::landing(const Request& req, const std::vector<std::string>&) const {
  const std::string& base = req.ctx.base;
  req.reply(json_response(
      200,
      {{"title", "rvoronoi"},
       {"description", "Raster Voronoi diagrams for maritime boundary delimitation (OGC API - Processes 1.0)"},
       {"version", kVersion},
       {"links",
        {link(base + "/", "self", kJson, "this document"),
         link(base + "/api", "service-desc", "application/vnd.oai.openapi;version=3.0", "the API definition"),
         link(base + "/conformance", std::string(kOgcRel) + "conformance", kJson, "conformance classes"),
         link(base + "/processes", std::string(kOgcRel) + "processes", kJson, "processes"),
         link(base + "/jobs", std::string(kOgcRel) + "job-list", kJson, "jobs"),
         link(base + "/sessions", "related", kJson, "live what-if sessions: edit seeds, see what changes"),
         link(base + "/health", "status", kJson, "health"), link(base + "/me", "related", kJson, "who is signed in"),
         link(base + "/app", "related", "text/html", "map page: run a delimitation and look at it")}}}));
}

void Api::conformance(const Request& req, const std::vector<std::string>&) const {
  const std::string c = "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/";
  req.reply(json_response(
      200, {{"conformsTo",
             {c + "core", c + "ogc-process-description", c + "json", c + "oas30", c + "job-list", c + "dismiss"}}}));
}

void Api::api_document(const Request& req, const std::vector<std::string>&) const {
  ApiResponse r;
  r.headers.emplace_back("Content-Type", "application/vnd.oai.openapi;version=3.0");
  r.body.assign(kOpenApiYaml, kOpenApiYamlSize);
  req.reply(std::move(r));
}

void Api::health(const Request& req, const std::vector<std::string>&) const {
  const bool store_reachable = jobs_.store_reachable(), results_reachable = jobs_.results_reachable();
  const int64_t free = jobs_.disk_free_bytes();
  const bool disk_low = jobs_.disk_low(free);
  json disk = {{"minFreeBytes", config_.min_free_disk_bytes}, {"low", disk_low}};
  disk["freeBytes"] = free >= 0 ? json(free) : json(nullptr);
  // Still 200: the daemon is up and answers; "degraded" tells a monitor that it is refusing work.
  req.reply(json_response(
      200, {{"status", store_reachable && results_reachable && !disk_low ? "ok" : "degraded"},
            {"jobs", {{"running", jobs_.running_count()}, {"queued", jobs_.queued_count()}}},
            {"workers", config_.jobs.workers},
            {"queueLength", config_.jobs.queue_length},
            {"describing", describe_pool_.busy()},
            {"sessions", {{"held", sessions_.count()}, {"memoryBytes", sessions_.memory_bytes()}}},
            {"memory",
             {{"budgetBytes", memory_.total()}, {"reservedBytes", memory_.reserved()}, {"waiting", memory_.waiting()}}},
            {"store", {{"kind", config_.store.shared() ? "postgresql" : "sqlite"}, {"reachable", store_reachable}}},
            {"results", {{"kind", jobs_.results_kind()}, {"reachable", results_reachable}}},
            {"disk", std::move(disk)}}));
}

void Api::me(const Request& req, const std::vector<std::string>&) const {
  const auth::Principal& who = req.ctx.request.principal;
  json doc = {{"name", who.name}, {"role", std::string(auth::to_string(who.role))}, {"authentication", who.how}};
  if (who.expires > 0) doc["expires"] = rfc3339(std::chrono::system_clock::from_time_t(who.expires));
  doc["links"] = json::array({link(req.ctx.base + "/me", "self", kJson, "who is signed in"),
                              link(req.ctx.base + "/jobs", std::string(kOgcRel) + "job-list", kJson, "their jobs")});
  req.reply(json_response(200, doc));
}

void Api::process_list(const Request& req, const std::vector<std::string>&) const {
  const std::string& base = req.ctx.base;
  req.reply(
      validated(req.ctx.request,
                json_response(200, {{"processes", json::array({process_summary(base), describe_seeds_summary(base)})},
                                    {"links", json::array({link(base + "/processes", "self", kJson, "processes")})}})));
}

void Api::process(const Request& req, const std::vector<std::string>& seg) const {
  req.reply(validated(req.ctx.request,
                      json_response(200, seg[1] == kDescribeSeedsId ? describe_seeds_description(req.ctx.base, config_)
                                                                    : process_description(req.ctx.base))));
}

void Api::execute(const Request& req, const std::vector<std::string>& seg) const {
  if (seg[1] == kDescribeSeedsId) return describe(req);
  const json body = parse_body_json(req.ctx.request.body);
  const std::string id = new_job_id();
  Execution ex = parse_execution(body, id, config_);
  // A shared store keeps the request for whichever daemon claims the job.
  if (config_.store.shared()) ex.request = req.ctx.request.body;
  submit_job(JobAnswer::of(req), id, std::move(ex));
}

Api::JobAnswer Api::JobAnswer::of(const Request& req) {
  return {req.respond, req.ctx.base, req.ctx.path, prefers_respond_async(req.ctx.request.prefer),
          req.ctx.request.principal};
}

void Api::submit_job(const JobAnswer& to, const std::string& id, Execution ex) const {
  const std::string& base = to.base;
  if (to.async) {
    const JobRecord rec = jobs_.submit(id, std::move(ex), to.who);
    ApiResponse r = json_response(201, status_info(rec, base));
    r.headers.emplace_back("Location", base + "/jobs/" + id);
    r.headers.emplace_back("Preference-Applied", "respond-async");
    return (*to.respond)(std::move(r));
  }
  const bool raw = ex.raw;
  auto on_done = [respond = to.respond, raw, base, path = to.path, &jobs = jobs_](const JobRecord& rec) {
    ApiResponse r;
    try {
      // The client waiting here asked for this job; if someone dismissed it meanwhile, say so
      // (409) rather than "no such job".
      if (rec.status == JobStatus::dismissed) throw Error(ErrorKind::cancelled, rec.message);
      if (rec.status != JobStatus::successful) throw_no_results(rec, jobs);
      if (raw) {
        const std::string& o = rec.outputs.front();
        r = file_response(jobs.open_result(rec, file_of(rec, o)), media_of(rec, o), "",
                          "the result file of job " + rec.id + " is missing");
      } else {
        r = json_response(200, results_document(rec, base));
      }
    } catch (const Error& e) {
      r = problem_from(e, path);
    }
    r.headers.emplace_back("Link", "<" + base + "/jobs/" + rec.id + ">; rel=\"monitor\"");
    (*respond)(std::move(r));
  };
  jobs_.submit(id, std::move(ex), to.who, on_done);  // answered by on_done
}

void Api::describe(const Request& req) const {
  // Reading uploads takes seconds and gigabytes at the limits: a thread of the pool does it, the
  // network threads go on serving (503 when every thread of the pool is taken).
  describe_pool_.try_run(
      [this, body = req.ctx.request.body, path = req.ctx.path, respond = req.respond]() -> std::function<void()> {
        ApiResponse r;
        // Held until the answer is handed on (the description with its features is large too).
        auto memory = std::make_shared<MemoryAccount::Reservation>(memory_.open());
        try {
          // The request's own bytes (its body, parsed, the uploads staged from it) are held
          // throughout; the reading's estimate comes on top as it grows. Answered at once: no wait.
          const int64_t request_bytes = 4 * static_cast<int64_t>(body.size());
          const std::string what = "describing these seeds";
          memory->need(request_bytes, false, nullptr, what);
          const json doc = parse_body_json(body);
          r = json_response(200, describe_seeds_execute(doc, config_, [&](int64_t reading_bytes) {
                              memory->need(request_bytes + reading_bytes, false, nullptr, what);
                            }));
        } catch (...) {
          r = problem_of_current_exception(path);
        }
        // The answer is handed on once the worker is free again (RequestPool::Task).
        return [respond, memory, r = std::make_shared<ApiResponse>(std::move(r))] { (*respond)(std::move(*r)); };
      });
}

void Api::job_list(const Request& req, const std::vector<std::string>&) const {
  const std::string& base = req.ctx.base;
  const int limit = int_param(req.ctx.query, "limit", 1, 1000, 100);
  const int offset = int_param(req.ctx.query, "offset", 0, 1'000'000'000, 0);
  std::vector<JobStatus> statuses;
  std::string status_filter;  // the filter as the next page's link repeats it
  if (const auto it = req.ctx.query.find("status"); it != req.ctx.query.end()) {
    for (const std::string& v : it->second) {
      for (const std::string& s : split(v, ',')) {
        statuses.push_back(parse_job_status(s));
        status_filter += (status_filter.empty() ? "" : ",") + std::string(to_string(statuses.back()));
      }
    }
  }
  // A user lists its own jobs; an admin everyone's, or one principal's with ?principal=.
  const auth::Principal& who = req.ctx.request.principal;
  std::string principal = who.role == Role::admin ? std::string() : who.name;
  std::string principal_filter;  // as the next page's link repeats it
  bool others = false;
  if (const auto it = req.ctx.query.find("principal"); it != req.ctx.query.end()) {
    principal_filter = it->second.front();
    if (principal_filter.empty()) throw Error(ErrorKind::invalid_argument, "parameter 'principal' must not be empty");
    // A user naming someone else sees nothing, exactly as for a principal without jobs.
    others = !principal.empty() && principal_filter != principal;
    principal = principal_filter;
  }
  json list = json::array();
  const auto records = others ? std::vector<JobRecord>() : store_.list(limit, offset, statuses, principal);
  for (const JobRecord& r : records) list.push_back(status_info(r, base));
  json links = json::array({link(base + "/jobs", "self", kJson, "job list")});
  if (static_cast<int>(records.size()) == limit) {
    std::string next = base + "/jobs?limit=" + std::to_string(limit);
    if (!status_filter.empty()) next += "&status=" + status_filter;
    if (!principal_filter.empty()) next += "&principal=" + percent_encode(principal_filter);
    links.push_back(link(next + "&offset=" + std::to_string(offset + limit), "next", kJson, "next page"));
  }
  req.reply(json_response(200, {{"jobs", list}, {"links", links}}));
}

void Api::job(const Request& req, const std::vector<std::string>& seg) const {
  const std::string& id = seg[1];
  if (req.ctx.request.method == "DELETE") {
    find_job(store_, id, req.ctx.request.principal);  // 404 for unknown ids and others' jobs, first
    const auto rec = jobs_.dismiss(id);
    if (!rec) throw OgcNotFound("no-such-job", "no job '" + id + "'");
    return req.reply(json_response(200, status_info(*rec, req.ctx.base)));
  }
  req.reply(json_response(200, status_info(find_job(store_, id, req.ctx.request.principal), req.ctx.base)));
}

void Api::results(const Request& req, const std::vector<std::string>& seg) const {
  const JobRecord rec = find_job(store_, seg[1], req.ctx.request.principal);
  if (rec.status != JobStatus::successful) throw_no_results(rec, jobs_);
  req.reply(json_response(200, results_document(rec, req.ctx.base)));
}

void Api::result_file(const Request& req, const std::vector<std::string>& seg) const {
  const std::string& id = seg[1];
  const JobRecord rec = find_job(store_, id, req.ctx.request.principal);
  if (rec.status != JobStatus::successful) throw_no_results(rec, jobs_);
  const std::string& output = seg[3];
  const bool sidecar = output == "ownership.aux.xml";
  const std::string output_id = sidecar ? "ownership" : output;
  if (std::find(rec.outputs.begin(), rec.outputs.end(), output_id) == rec.outputs.end()) {
    throw Error(ErrorKind::not_found,
                "job " + id + " has no output '" + output.substr(0, 64) + "' (requested outputs only)");
  }
  // The file name is ours, never the client's: only the id (checked hex) and a fixed name.
  std::string file = file_of(rec, output_id);
  if (sidecar) file += ".aux.xml";
  req.reply(file_response(jobs_.open_result(rec, file), media_of(rec, output), req.ctx.request.range,
                          "job " + id + " has no file for output '" + output + "'"));
}

}  // namespace rv::daemon
