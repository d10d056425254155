// Fuzz target: what a client's bearer token and an identity provider's key set bring in
// (issue 52): base64url, the JWKS parser (service/src/auth/jwks.hpp) and JWT verification
// (auth/jwt.hpp), both untrusted: the token comes from any client, the key set over the network.
//
// Input: a key set and a token separated by the first "\n--\n" (no separator: the whole input is
// the token, checked against the corpus' own key set). A key set that parse_jwks refuses is
// replaced by that one, so that tokens always reach the signature and claims checks.
// Findings: a crash or sanitizer report; an exception leaving verify_jwt (it answers, never
// throws) or parse_jwks throwing anything but rv::Error(invalid_input); a refusal whose reason is
// empty, not printable ASCII, or quotes a claim (the subject); an accepted token whose principal
// is empty, "anonymous", or not its "sub"; base64url_decode accepting text outside its alphabet.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "auth/crypto.hpp"
#include "auth/jwks.hpp"
#include "auth/jwt.hpp"
#include "rv/field/error.hpp"

namespace {

void require(bool ok) {
  if (!ok) std::abort();
}

// The key set a token is checked against when the input brings none that parses: the P-256
// public key of RFC 7517's example (appendix A.1).
constexpr const char* kFallbackJwks =
    R"({"keys":[{"kty":"EC","kid":"e1","crv":"P-256","x":"f83OJ3D2xF1Bg8vub9tLe1gHMzV76e8Tus9uPHvRVEU","y":"x_FEzRu9m36HLN_tue659LNpXW6pCyStikYjKIWI5a0"}]})";

rv::JwtConfig config() {
  rv::JwtConfig c;
  c.issuer = "https://idp.test";
  c.audiences = {"rvoronoi"};
  c.jwks_file = "fuzz";
  c.role_claim = "realm_access.roles";
  c.admin_value = "rvoronoi-admin";
  return c;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const size_t cut = input.find("\n--\n");
  const std::string_view jwks = cut == std::string_view::npos ? std::string_view() : input.substr(0, cut);
  const std::string_view token = cut == std::string_view::npos ? input : input.substr(cut + 4);

  if (const auto bytes = rv::auth::base64url_decode(token)) {
    for (const char c : token)
      require((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_');
  }
  rv::auth::KeySet keys;
  try {
    keys = rv::auth::parse_jwks(jwks.empty() ? std::string_view(kFallbackJwks) : jwks);
  } catch (const rv::Error& e) {
    require(e.kind() == rv::ErrorKind::invalid_input);
    keys = rv::auth::parse_jwks(kFallbackJwks);
  }
  for (const rv::auth::VerifyKey& k : keys.keys) require(k.key != nullptr && (k.alg == "RS256" || k.alg == "ES256"));

  const rv::JwtConfig c = config();
  rv::auth::JwtOutcome out;
  try {
    out = rv::auth::verify_jwt(token, keys, c, 1'800'000'000);
  } catch (...) {
    std::abort();
  }
  if (out.status == rv::auth::JwtOutcome::Status::ok) {
    require(!out.principal.name.empty() && out.principal.name != rv::auth::kAnonymous);
    require(out.principal.how == "jwt");
  } else {
    require(!out.reason.empty());
    for (const char ch : out.reason) require(ch >= 0x20 && ch < 0x7f);
  }
  return 0;
}
