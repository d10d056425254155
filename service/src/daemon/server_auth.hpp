// Who a request comes from. With authentication configured (AuthConfig), every route except the
// open ones needs "Authorization: Bearer <token>": a configured principal's token (compared by
// its SHA-256, in constant time, with every principal's; auth.token_file's followed as it is
// edited, auth/principal_set.hpp) or an identity provider's JWT (auth/jwt.hpp).
// Without it, every request is the anonymous admin (auth/principal.hpp): the server is open.
// Refusals are 401 problem+json with a WWW-Authenticate challenge (RFC 6750 3) whose
// error_description says why a token was refused; never what it held.
// Thread safety: check() may be called from any thread at once; start() and stop() once each.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "auth/jwks_source.hpp"
#include "auth/principal.hpp"
#include "auth/principal_set.hpp"
#include "daemon/server_api.hpp"
#include "rv/server_config.hpp"

namespace rv::daemon {

class Authenticator {
 public:
  // `log` receives the key source's and the token file's log lines (JSON objects).
  Authenticator(const AuthConfig& config, std::function<void(const std::string&)> log);
  ~Authenticator();

  // Loads the identity provider's keys (auth/jwks_source.hpp). Throws rv::Error for a key file
  // that cannot be used.
  void start();
  // Ends the key source's thread (those waiting on a refresh are called). Idempotent.
  void stop();

  bool enabled() const { return enabled_; }

  // True when the request target (origin form, query allowed) names an open resource.
  static bool is_open(std::string_view target);

  struct Outcome {
    auth::Principal principal;           // who asks (the anonymous admin without authentication)
    std::optional<ApiResponse> refusal;  // set: answer this instead
    std::string reason;                  // refused: why, for the log
    // The token names a key the provider's set lacks and the set may be fetched again: call
    // refresh_keys_then() and check once more (with `keys_refreshed`).
    bool needs_keys = false;
  };
  // `authorization` is the Authorization header's value ("" when absent). The HTML pages and
  // their assets are open too (server_web.hpp: they hold no data; their script sends the token
  // for the data), so `method` and `accept` (the Accept header) count. On an open route a valid
  // token still names its principal (for the log); an invalid one is not refused there.
  Outcome check(std::string_view target, std::string_view authorization, std::string_view method = "",
                std::string_view accept = "", bool keys_refreshed = false) const;
  // See Outcome::needs_keys: `done` runs once the provider's keys were fetched again (on the key
  // source's thread), or at once when they were fetched moments ago.
  void refresh_keys_then(std::function<void()> done) const;

 private:
  // The principal of a presented token, or the refusal's reason.
  Outcome identify(std::string_view token, bool keys_refreshed) const;

  bool enabled_ = false;
  auth::PrincipalSet principals_;  // auth.token_file read again when it changes
  JwtConfig jwt_;
  std::unique_ptr<auth::JwksSource> keys_;
};

}  // namespace rv::daemon
