// The session resources of the API (/sessions...): thin actions over the SessionManager. Every
// request that reads or changes a session runs on the session's thread in its turn and answers
// from there; its errors go through the one error table (problem_of_current_exception).
#include <algorithm>
#include <chrono>

#include "daemon/server_api.hpp"
#include "daemon/server_execute.hpp"
#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/options.hpp"

namespace rv::daemon {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

// The deliverables a session keeps, by output id (the process's) and by the session's name.
struct Kept {
  const char* output;
  const char* name;
  const char* media;
};
constexpr Kept kKept[] = {{"boundaries", "boundaries", kMediaGeoJson},
                          {"tripoints", "tripoints", kMediaGeoJson},
                          {"limits", "limits", kMediaGeoJson},
                          {"regions", "regions", kMediaGeoJson},
                          {"turningPoints", "turning_points", kMediaJson}};

const Kept* kept_by_output(std::string_view id) {
  for (const Kept& k : kKept)
    if (id == k.output) return &k;
  return nullptr;
}

const Kept* kept_by_name(std::string_view name) {
  for (const Kept& k : kKept)
    if (name == k.name) return &k;
  return nullptr;
}

ApiResponse problem_of(std::exception_ptr error, const std::string& path) {
  try {
    std::rethrow_exception(error);
  } catch (...) {
    return problem_of_current_exception(path);
  }
}

SessionManager::Fail answer_failure(const std::shared_ptr<Respond>& respond, const std::string& path) {
  return [respond, path](std::exception_ptr error) { (*respond)(problem_of(error, path)); };
}

// The status document's links: the session's resources.
json with_links(json status, const std::string& base) {
  const std::string self = base + "/sessions/" + status.value("sessionID", std::string());
  json links = json::array(
      {link(self, "self", kMediaJson, "session status"), link(base + "/sessions", "up", kMediaJson, "sessions")});
  if (status.value("status", std::string()) == "ready") {
    links.push_back(link(self + "/features", "related", kMediaGeoJson, "the seed features, with their ids"));
    links.push_back(link(self + "/deliverables", "related", kMediaJson, "the deliverables kept"));
    if (status.contains("deliverables") && status["deliverables"].is_array()) {
      for (const json& name : status["deliverables"]) {
        const Kept* k = kept_by_name(name.get<std::string>());
        if (k != nullptr) links.push_back(link(self + "/deliverables/" + k->output, "item", k->media, k->output));
      }
    }
    links.push_back(link(self + "/edits", "edit", kMediaJson, "POST {\"edits\": [...]}: one step"));
    links.push_back(link(self + "/undo", "related", kMediaJson, "POST: undo the last step"));
    links.push_back(link(self + "/redo", "related", kMediaJson, "POST: redo the step undone"));
    links.push_back(link(self + "/jobs", "related", kMediaJson, "POST {\"outputs\": ...}: save as a job"));
  }
  status["links"] = links;
  return status;
}

// A request body that is one JSON object with members among `allowed`.
json body_object(const std::string& text, std::initializer_list<std::string_view> allowed, const char* what) {
  const json body = parse_body_json(text.empty() ? "{}" : text);
  if (!body.is_object()) throw Error(ErrorKind::invalid_argument, std::string(what) + ": the body must be an object");
  for (const auto& [key, value] : body.items()) {
    bool ok = false;
    for (std::string_view a : allowed) ok = ok || key == a;
    if (!ok)
      throw Error(ErrorKind::invalid_argument, std::string(what) + ": unknown member '" + key.substr(0, 64) + "'");
  }
  return body;
}

}  // namespace

void Api::session_list(const Request& req, const std::vector<std::string>&) const {
  if (req.ctx.request.method == "POST") return create_session(req);
  const std::string& base = req.ctx.base;
  json list = json::array();
  for (json& s : sessions_.list(req.ctx.request.principal)) list.push_back(with_links(std::move(s), base));
  req.reply(json_response(200, {{"sessions", list},
                                {"daemon", sessions_.daemon_name()},
                                {"links", json::array({link(base + "/sessions", "self", kMediaJson, "sessions"),
                                                       link(base + "/", "up", kMediaJson, "landing page")})}}));
}

void Api::create_session(const Request& req) const {
  const json body = parse_body_json(req.ctx.request.body);
  check_body_members(body);
  if (body.contains("response"))
    throw Error(ErrorKind::invalid_argument,
                "\"response\": a session answers with its status; results come from its jobs (POST "
                "/sessions/{id}/jobs)");
  std::vector<const Kept*> keep;
  if (body.contains("outputs")) {
    const json& outputs = body.at("outputs");
    if (!outputs.is_object()) throw Error(ErrorKind::invalid_argument, "input 'outputs': must be an object");
    for (const auto& [id, options] : outputs.items()) {
      const Kept* k = kept_by_output(id);
      if (k == nullptr)
        throw Error(ErrorKind::invalid_argument,
                    "output '" + id.substr(0, 64) +
                        "': a session keeps boundaries, tripoints, limits, regions and turningPoints; rasters and "
                        "other files come from its jobs (POST /sessions/{id}/jobs)");
      if (options.is_object() && options.contains("format") && options["format"].is_object() &&
          options["format"].contains("mediaType") &&
          output_media_type(id, options["format"]["mediaType"].get<std::string>()) != k->media)
        throw Error(ErrorKind::invalid_argument, "output '" + id + "': a session keeps it as " + k->media);
      keep.push_back(k);
    }
  }
  const std::string upload_id = new_job_id();
  Execution ex = parse_execution(body, upload_id, config_);
  if (!ex.spec.base_name.empty())
    throw Error(ErrorKind::invalid_argument,
                "input 'baseJob': a session starts from seeds; edit it with POST /sessions/{id}/edits");
  for (const Kept* k : keep)
    if (std::string* path = output_path(ex.spec.outputs, k->output)) *path = k->name;
  // The analyst waits for every step: a session's work runs on every hardware thread (a job's on
  // its share, jobs.threads_per_job), and so do the jobs saved from it.
  ex.spec.threads = config_.jobs.threads_per_job > 0 ? config_.jobs.threads_per_job : resolve_threads(0);
  const bool async = prefers_respond_async(req.ctx.request.prefer);
  const std::string base = req.ctx.base;
  const std::string path = req.ctx.path;
  auto respond = req.respond;
  SessionManager::Created on_created = [respond, base, path, async](const json& status, std::exception_ptr error) {
    if (async) return;  // answered 202 already; the poller reads the status
    if (error) return (*respond)(problem_of(error, path));
    ApiResponse r = json_response(201, with_links(status, base));
    r.headers.emplace_back("Location", base + "/sessions/" + status.value("sessionID", std::string()));
    (*respond)(std::move(r));
  };
  const std::string id =
      sessions_.create(std::move(ex.spec), ex.uploads, upload_id, req.ctx.request.principal, on_created, async);
  if (!async) return;
  sessions_.status(
      id, req.ctx.request.principal,
      [respond, base, id](json status) {
        ApiResponse r = json_response(202, with_links(std::move(status), base));
        r.headers.emplace_back("Location", base + "/sessions/" + id);
        r.headers.emplace_back("Preference-Applied", "respond-async");
        (*respond)(std::move(r));
      },
      answer_failure(respond, path));
}

void Api::session(const Request& req, const std::vector<std::string>& seg) const {
  const std::string& base = req.ctx.base;
  if (req.ctx.request.method == "DELETE")
    return req.reply(json_response(200, with_links(sessions_.remove(seg[1], req.ctx.request.principal), base)));
  sessions_.status(
      seg[1], req.ctx.request.principal,
      [respond = req.respond, base](json status) {
        (*respond)(json_response(200, with_links(std::move(status), base)));
      },
      answer_failure(req.respond, req.ctx.path));
}

void Api::session_features(const Request& req, const std::vector<std::string>& seg) const {
  sessions_.run(
      seg[1], req.ctx.request.principal, false,
      [respond = req.respond](Session& s) { (*respond)(json_response(200, s.features(), kMediaGeoJson)); },
      answer_failure(req.respond, req.ctx.path));
}

void Api::session_lines(const Request& req, const std::vector<std::string>& seg) const {
  sessions_.run(
      seg[1], req.ctx.request.principal, false,
      [respond = req.respond](Session& s) { (*respond)(json_response(200, s.line_ids())); },
      answer_failure(req.respond, req.ctx.path));
}

void Api::session_deliverables(const Request& req, const std::vector<std::string>& seg) const {
  const std::string self = req.ctx.base + "/sessions/" + seg[1];
  sessions_.run(
      seg[1], req.ctx.request.principal, false,
      [respond = req.respond, self](Session& s) {
        json list = json::array();
        for (const std::string& name : s.deliverables()) {
          const Kept* k = kept_by_name(name);
          if (k == nullptr) continue;
          list.push_back({{"id", k->output}, {"type", k->media}, {"href", self + "/deliverables/" + k->output}});
        }
        (*respond)(json_response(200, {{"deliverables", list},
                                       {"links", json::array({link(self + "/deliverables", "self", kMediaJson),
                                                              link(self, "up", kMediaJson, "session status")})}}));
      },
      answer_failure(req.respond, req.ctx.path));
}

void Api::session_deliverable(const Request& req, const std::vector<std::string>& seg) const {
  const Kept* k = kept_by_output(seg[3]);
  if (k == nullptr)
    throw Error(ErrorKind::not_found, "no deliverable '" + seg[3].substr(0, 64) +
                                          "' (a session keeps boundaries, tripoints, limits, regions, turningPoints)");
  sessions_.run(
      seg[1], req.ctx.request.principal, false,
      [respond = req.respond, k, output = seg[3]](Session& s) {
        const auto names = s.deliverables();
        if (std::find(names.begin(), names.end(), k->name) == names.end())
          throw Error(ErrorKind::not_found, "the session keeps no '" + output +
                                                "' (the outputs given at its creation are the ones it keeps)");
        ApiResponse r;
        r.headers.emplace_back("Content-Type", k->media);
        r.body = s.deliverable(k->name);
        (*respond)(std::move(r));
      },
      answer_failure(req.respond, req.ctx.path));
}

void Api::session_step(const Request& req, const std::vector<std::string>& seg) const {
  const auto arrived = Clock::now();
  const std::string& what = seg[2];
  json edits;
  if (what == "edits") {
    json body = body_object(req.ctx.request.body, {"edits"}, "edits");
    if (!body.contains("edits") || !body["edits"].is_array() || body["edits"].empty())
      throw Error(ErrorKind::invalid_argument, "edits: the body must be {\"edits\": [operation, ...]}, one or more");
    edits = std::move(body["edits"]);
  } else {
    body_object(req.ctx.request.body, {}, what.c_str());
  }
  sessions_.run(
      seg[1], req.ctx.request.principal, true,
      [respond = req.respond, what, edits = std::move(edits), arrived](Session& s) {
        json answer = what == "edits" ? s.edit(edits) : what == "undo" ? s.undo() : s.redo();
        // From the request's arrival here to its answer, waiting in the session's turn included.
        answer["timings"]["server_s"] = std::chrono::duration<double>(Clock::now() - arrived).count();
        (*respond)(json_response(200, answer));
      },
      answer_failure(req.respond, req.ctx.path));
}

void Api::session_jobs(const Request& req, const std::vector<std::string>& seg) const {
  const json body = body_object(req.ctx.request.body, {"outputs", "response"}, "a session's job");
  Execution ex;
  parse_outputs(body, ex);
  if (std::find(ex.outputs.begin(), ex.outputs.end(), "changes") != ex.outputs.end())
    throw Error(ErrorKind::invalid_argument, "output 'changes': needs a base job; a session's job has none");
  const std::string id = seg[1];
  sessions_.run(
      id, req.ctx.request.principal, false,
      [this, to = JobAnswer::of(req), ex = std::move(ex), id](Session& s) mutable {
        std::shared_ptr<const SessionSnapshot> snapshot = s.snapshot();
        if (std::find(ex.outputs.begin(), ex.outputs.end(), "limits") != ex.outputs.end() &&
            snapshot->spec().outputs.limit_distances.empty())
          throw Error(ErrorKind::invalid_argument, "output 'limits': the session was created without limitDistances");
        ex.spec = snapshot->spec();
        ex.spec.outputs = OutputRequest{};
        ex.inputs_summary = {{"session", id}};
        ex.cells = snapshot->job().grid.cell_count();
        ex.run = [snapshot](const JobSpec& spec, const JobLimits&, const JobHooks& hooks) {
          return snapshot->save(spec.outputs, hooks);
        };
        submit_job(to, new_job_id(), std::move(ex));
      },
      answer_failure(req.respond, req.ctx.path));
}

}  // namespace rv::daemon
