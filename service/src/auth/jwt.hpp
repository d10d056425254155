// Bearer JWTs of an identity provider (RFC 7519, JWS compact serialisation, RFC 7515): the
// signature checked with OpenSSL against the provider's keys (RS256: RSASSA-PKCS1-v1_5 with
// SHA-256; ES256: ECDSA P-256 with SHA-256), then the claims against JwtConfig. The header's
// "alg" must be one the configuration allows and fit the key ("none" never does); a "crit"
// header is refused (no extension is understood).
// Thread safety: a pure function of its arguments.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "auth/jwks.hpp"
#include "auth/principal.hpp"
#include "rv/server_config.hpp"

namespace rv::auth {

struct JwtOutcome {
  enum class Status { ok, invalid, unknown_key };
  Status status = Status::invalid;
  Principal principal;  // ok: named by "sub", role from the role claim, how "jwt", expires "exp"
  // invalid / unknown_key: why, in words fit for WWW-Authenticate's error_description and the
  // log ("the token has expired"). Never a claim's value nor any part of the token.
  std::string reason;
};

// True when `token` has the shape of a JWS compact serialisation: three base64url parts
// separated by dots, the last possibly empty.
bool looks_like_jwt(std::string_view token);

// Verifies `token` at `now_s` (seconds since 1970). unknown_key: the header names a key id
// (or, without one, an algorithm) that `keys` lacks: the caller may fetch the set again.
JwtOutcome verify_jwt(std::string_view token, const KeySet& keys, const JwtConfig& config, int64_t now_s);

}  // namespace rv::auth
