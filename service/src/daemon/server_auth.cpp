#include "daemon/server_auth.hpp"

#include <cctype>

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

}  // namespace

bool equal_constant_time(std::string_view presented, std::string_view expected) {
  // Every byte of `presented` is looked at, whatever matched before: an attacker timing the
  // answers learns nothing about how many leading characters were right. The expected length
  // leaks only as "lengths differ", which is folded into the same accumulator.
  if (expected.empty()) return false;
  unsigned diff = presented.size() == expected.size() ? 0u : 1u;
  for (size_t i = 0; i < presented.size(); ++i) {
    diff |= static_cast<unsigned char>(presented[i]) ^ static_cast<unsigned char>(expected[i % expected.size()]);
  }
  return diff == 0;
}

bool Authenticator::is_open(std::string_view target) {
  const std::vector<std::string> seg = path_segments(target.substr(0, target.find('?')));
  if (seg.empty()) return true;
  return seg.size() == 1 && (seg[0] == "conformance" || seg[0] == "api" || seg[0] == "health");
}

std::optional<ApiResponse> Authenticator::check(std::string_view target, std::string_view authorization,
                                                std::string_view method, std::string_view accept) const {
  if (tokens_.empty() || is_open(target) || is_asset(target) || is_app(target) || wants_page(method, target, accept))
    return std::nullopt;
  if (authorization.empty()) {
    return unauthorized("this server needs a bearer token: send 'Authorization: Bearer <token>'", kRealm, target);
  }
  const std::string_view scheme = "Bearer ";
  if (!starts_with_ci(authorization, scheme)) {
    return unauthorized("only bearer tokens are accepted: send 'Authorization: Bearer <token>'",
                        std::string(kRealm) + ", error=\"invalid_request\"", target);
  }
  std::string_view token = authorization.substr(scheme.size());
  while (!token.empty() && token.front() == ' ') token.remove_prefix(1);
  while (!token.empty() && (token.back() == ' ' || token.back() == '\t')) token.remove_suffix(1);
  // Every configured token is compared, also after a match: which one matched (and whether an
  // early one did) must not show in the time taken.
  bool match = false;
  for (const std::string& t : tokens_) match |= equal_constant_time(token, t);
  if (match) return std::nullopt;
  return unauthorized("the bearer token is not valid for this server",
                      std::string(kRealm) + ", error=\"invalid_token\"", target);
}

}  // namespace rv::daemon
