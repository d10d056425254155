#include "daemon/server_auth.hpp"

#include <chrono>

#include "auth/crypto.hpp"
#include "auth/jwt.hpp"
#include "daemon/server_web.hpp"
#include "runtime/server_util.hpp"

namespace rv::daemon {
namespace {

constexpr const char* kRealm = "Bearer realm=\"rvoronoi\"";

ApiResponse unauthorized(const std::string& detail, const std::string& challenge, std::string_view target) {
  // The path (not the query) as the instance, like every other problem of this server.
  const std::string path(target.substr(0, target.find('?')));
  ApiResponse r =
      problem_response(401, "https://rvoronoi.dev/problems/unauthorized", "Unauthorized", detail, path.substr(0, 200));
  r.headers.emplace_back("WWW-Authenticate", challenge);
  return r;
}

// RFC 6750 3: error_description is a quoted string of printable ASCII without '"' and '\'.
std::string described(const std::string& error, const std::string& why) {
  std::string text;
  for (const char c : why)
    if (c >= 0x20 && c < 0x7f && c != '"' && c != '\\') text += c;
  return std::string(kRealm) + ", error=\"" + error + "\", error_description=\"" + text + "\"";
}

int64_t now_seconds() {
  return std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace

Authenticator::Authenticator(const AuthConfig& config, std::function<void(const std::string&)> log)
    : enabled_(config.enabled()), principals_(config, log), jwt_(config.jwt) {
  if (jwt_.enabled()) keys_ = std::make_unique<auth::JwksSource>(jwt_, std::move(log));
}

Authenticator::~Authenticator() { stop(); }

void Authenticator::start() {
  if (keys_) keys_->start();
}

void Authenticator::stop() {
  if (keys_) keys_->stop();
}

bool Authenticator::is_open(std::string_view target) {
  const std::vector<std::string> seg = path_segments(target.substr(0, target.find('?')));
  if (seg.empty()) return true;
  return seg.size() == 1 && (seg[0] == "conformance" || seg[0] == "api" || seg[0] == "health");
}

void Authenticator::refresh_keys_then(std::function<void()> done) const {
  if (keys_)
    keys_->refresh_then(std::move(done));
  else
    done();
}

Authenticator::Outcome Authenticator::identify(std::string_view token, bool keys_refreshed) const {
  Outcome out;
  // Every principal's hash is compared, also after a match: which one matched (and whether an
  // early one did) must not show in the time taken. Comparing hashes, not the tokens, keeps
  // the configured secrets out of memory and the comparison's length fixed. A configured token
  // is looked up first whatever its shape, so that one shaped like a JWT still works.
  const auth::Sha256 presented = auth::sha256(token);
  const PrincipalConfig* found = nullptr;
  const auto principals = principals_.current();
  for (const PrincipalConfig& p : *principals)
    if (auth::digests_equal(presented, p.token_sha256) && found == nullptr) found = &p;
  if (found != nullptr) {
    out.principal.name = found->name;
    out.principal.role = found->role;
    out.principal.how = "token";
    return out;
  }
  if (keys_ && auth::looks_like_jwt(token)) {
    const auto keys = keys_->keys();
    if (!keys) {
      out.reason = "the identity provider's keys are not available yet";
      return out;
    }
    auth::JwtOutcome v = auth::verify_jwt(token, *keys, jwt_, now_seconds());
    if (v.status == auth::JwtOutcome::Status::ok) {
      out.principal = std::move(v.principal);
      return out;
    }
    out.needs_keys = v.status == auth::JwtOutcome::Status::unknown_key && !keys_refreshed;
    out.reason = std::move(v.reason);
    return out;
  }
  out.reason = "the bearer token is not valid for this server";
  return out;
}

Authenticator::Outcome Authenticator::check(std::string_view target, std::string_view authorization,
                                            std::string_view method, std::string_view accept,
                                            bool keys_refreshed) const {
  Outcome out;
  if (!enabled_) return out;  // the anonymous admin
  const bool open = is_open(target) || is_asset(target) || is_app(target) || wants_page(method, target, accept);
  out.principal.role = Role::user;  // anonymous, and (open routes) no right to see any job
  const std::string_view scheme = "Bearer ";
  if (authorization.empty() || !starts_with_ci(authorization, scheme)) {
    if (open) return out;
    out.reason = authorization.empty() ? "no token" : "not a bearer token";
    out.refusal =
        authorization.empty()
            ? unauthorized("this server needs a bearer token: send 'Authorization: Bearer <token>'", kRealm, target)
            : unauthorized("only bearer tokens are accepted: send 'Authorization: Bearer <token>'",
                           std::string(kRealm) + ", error=\"invalid_request\"", target);
    return out;
  }
  std::string_view token = authorization.substr(scheme.size());
  while (!token.empty() && token.front() == ' ') token.remove_prefix(1);
  while (!token.empty() && (token.back() == ' ' || token.back() == '\t')) token.remove_suffix(1);
  Outcome who = identify(token, keys_refreshed);
  if (who.reason.empty() || open) {
    if (!who.reason.empty()) who = Outcome{out.principal, std::nullopt, "", false};  // open: ignored
    return who;
  }
  if (who.needs_keys) return who;
  who.refusal = unauthorized(who.reason, described("invalid_token", who.reason), target);
  return who;
}

}  // namespace rv::daemon
