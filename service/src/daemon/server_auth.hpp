// Optional bearer-token authentication of the daemon (RFC 6750, "Authorization: Bearer <token>").
//
// Decided from the request head alone, before the body is read: a client without a valid token
// cannot make the server buffer an upload. Open resources (no token needed): the landing page
// `/`, `/conformance`, `/api` (the OpenAPI document) and `/health`, in every spelling the router
// accepts for them (path_segments()), so that no spelling of a protected resource counts as open.
// With no token configured every resource is open.
// Tokens are compared in time independent of their contents, and never logged or echoed.
// Thread safety: immutable after construction; check() may be called from any thread.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/server_api.hpp"
#include "rv/server_config.hpp"

namespace rv::daemon {

class Authenticator {
 public:
  explicit Authenticator(const AuthConfig& config) : tokens_(config.tokens) {}

  bool enabled() const { return !tokens_.empty(); }

  // True when the request target (origin form, query allowed) names an open resource.
  static bool is_open(std::string_view target);

  // nullopt when the request may go on; otherwise the 401 problem+json to answer with, carrying
  // "WWW-Authenticate: Bearer" (with error="invalid_token" when a token was sent but is wrong).
  // `authorization` is the Authorization header's value ("" when absent). The HTML pages and
  // their assets are open too (server_web.hpp: they hold no data; their script sends the token
  // for the data), so `method` and `accept` (the Accept header) count.
  std::optional<ApiResponse> check(std::string_view target, std::string_view authorization,
                                   std::string_view method = "", std::string_view accept = "") const;

 private:
  std::vector<std::string> tokens_;
};

// Compares a presented secret with an expected one in time that depends on the length of
// `presented` only, never on where the two differ. Exposed for the unit tests.
bool equal_constant_time(std::string_view presented, std::string_view expected);

}  // namespace rv::daemon
