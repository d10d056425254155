#include "auth/jwt.hpp"

#include <openssl/bn.h>
#include <openssl/ec.h>
#include <openssl/evp.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "auth/crypto.hpp"

namespace rv::auth {
namespace {

using nlohmann::json;

JwtOutcome refuse(std::string reason, JwtOutcome::Status status = JwtOutcome::Status::invalid) {
  JwtOutcome o;
  o.status = status;
  o.reason = std::move(reason);
  return o;
}

// A base64url part decoded and parsed as a JSON object; discarded json when it is not one.
json json_part(std::string_view part) {
  const auto bytes = base64url_decode(part);
  if (!bytes) return json(json::value_t::discarded);
  json doc = json::parse(*bytes, nullptr, false);
  return doc.is_object() ? doc : json(json::value_t::discarded);
}

// ES256 signatures are r || s, 32 bytes each (RFC 7518 3.4); OpenSSL verifies DER.
std::string ecdsa_der(std::string_view raw) {
  std::unique_ptr<ECDSA_SIG, decltype(&ECDSA_SIG_free)> sig(ECDSA_SIG_new(), ECDSA_SIG_free);
  BIGNUM* r = BN_bin2bn(reinterpret_cast<const unsigned char*>(raw.data()), 32, nullptr);
  BIGNUM* s = BN_bin2bn(reinterpret_cast<const unsigned char*>(raw.data()) + 32, 32, nullptr);
  if (!sig || !r || !s || ECDSA_SIG_set0(sig.get(), r, s) != 1) {
    BN_free(r);
    BN_free(s);
    return {};
  }
  unsigned char* der = nullptr;
  const int length = i2d_ECDSA_SIG(sig.get(), &der);
  if (length <= 0) return {};
  std::string out(reinterpret_cast<const char*>(der), static_cast<size_t>(length));
  OPENSSL_free(der);
  return out;
}

bool signature_holds(const VerifyKey& key, std::string_view signing_input, std::string_view signature) {
  std::string der;
  if (key.alg == "ES256") {
    if (signature.size() != 64) return false;
    der = ecdsa_der(signature);
    if (der.empty()) return false;
    signature = der;
  }
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> md(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  if (!md || EVP_DigestVerifyInit(md.get(), nullptr, EVP_sha256(), nullptr, key.key.get()) != 1) return false;
  return EVP_DigestVerify(md.get(), reinterpret_cast<const unsigned char*>(signature.data()), signature.size(),
                          reinterpret_cast<const unsigned char*>(signing_input.data()), signing_input.size()) == 1;
}

// A NumericDate claim (RFC 7519 2): a number of seconds. nullopt when absent; NaN when present but
// not a number.
std::optional<double> numeric_date(const json& claims, const char* name) {
  if (!claims.contains(name)) return std::nullopt;
  const json& v = claims.at(name);
  return v.is_number() ? v.get<double>() : std::nan("");
}

bool audience_fits(const json& claims, const std::vector<std::string>& audiences) {
  if (!claims.contains("aud")) return false;
  const json& aud = claims.at("aud");
  auto ours = [&](const json& v) {
    return v.is_string() && std::find(audiences.begin(), audiences.end(), v.get<std::string>()) != audiences.end();
  };
  if (aud.is_string()) return ours(aud);
  return aud.is_array() && std::any_of(aud.begin(), aud.end(), ours);
}

// The value at a dotted path ("realm_access.roles"), or null.
json at_path(const json& claims, const std::string& path) {
  const json* v = &claims;
  std::stringstream parts(path);
  std::string key;
  while (std::getline(parts, key, '.')) {
    if (!v->is_object() || !v->contains(key)) return nullptr;
    v = &v->at(key);
  }
  return *v;
}

// The role claim holds the admin value: equal to it, an array holding it, or a space-separated
// list (OAuth's "scope") naming it.
bool is_admin(const json& claims, const JwtConfig& config) {
  if (config.role_claim.empty()) return false;
  const json v = at_path(claims, config.role_claim);
  if (v.is_array()) return std::any_of(v.begin(), v.end(), [&](const json& x) { return x == config.admin_value; });
  if (!v.is_string()) return false;
  std::stringstream words(v.get<std::string>());
  std::string w;
  while (words >> w)
    if (w == config.admin_value) return true;
  return false;
}

}  // namespace

bool looks_like_jwt(std::string_view token) {
  if (std::count(token.begin(), token.end(), '.') != 2) return false;
  const size_t a = token.find('.'), b = token.rfind('.');
  // The signature may be empty (an unsecured JWS, "alg": "none"): it is a JWT, and refused as one.
  if (a == 0 || b == a + 1) return false;
  return std::all_of(token.begin(), token.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_' ||
           c == '.';
  });
}

JwtOutcome verify_jwt(std::string_view token, const KeySet& keys, const JwtConfig& config, int64_t now_s) {
  if (!looks_like_jwt(token)) return refuse("the token is not a JWT (three base64url parts)");
  const size_t a = token.find('.'), b = token.rfind('.');
  const json header = json_part(token.substr(0, a));
  if (header.is_discarded()) return refuse("the token's header is not base64url JSON");
  if (!header.contains("alg") || !header.at("alg").is_string()) return refuse("the token's header names no algorithm");
  const std::string alg = header.at("alg").get<std::string>();
  if (std::find(config.algorithms.begin(), config.algorithms.end(), alg) == config.algorithms.end())
    return refuse("the token's algorithm is not accepted here (accepted: RS256, ES256 as configured)");
  if (header.contains("crit")) return refuse("the token names critical header extensions this server does not know");
  std::string kid;
  if (header.contains("kid")) {
    if (!header.at("kid").is_string()) return refuse("the token's key id is not a string");
    kid = header.at("kid").get<std::string>();
  }
  const VerifyKey* key = keys.find(kid, alg);
  if (key == nullptr)
    return refuse(kid.empty() ? "the token names no key id and the key set has no single key for its algorithm"
                              : "the token's key id is not in the identity provider's key set",
                  JwtOutcome::Status::unknown_key);
  const auto signature = base64url_decode(token.substr(b + 1));
  if (!signature || !signature_holds(*key, token.substr(0, b), *signature))
    return refuse("the token's signature does not verify");

  // Only a verified token's claims are looked at.
  const json claims = json_part(token.substr(a + 1, b - a - 1));
  if (claims.is_discarded()) return refuse("the token's claims are not base64url JSON");
  const double skew = config.clock_skew_s, now = static_cast<double>(now_s);
  const auto exp = numeric_date(claims, "exp");
  if (!exp || std::isnan(*exp)) return refuse("the token has no expiry (exp)");
  if (now > *exp + skew) return refuse("the token has expired");
  if (const auto nbf = numeric_date(claims, "nbf")) {
    if (std::isnan(*nbf)) return refuse("the token's nbf is not a number");
    if (now + skew < *nbf) return refuse("the token is not valid yet (nbf)");
  }
  if (!claims.contains("iss") || claims.at("iss") != config.issuer) return refuse("the token's issuer is not accepted");
  if (!audience_fits(claims, config.audiences)) return refuse("the token is not meant for this server (aud)");
  if (!claims.contains("sub") || !claims.at("sub").is_string()) return refuse("the token names no subject (sub)");
  const std::string sub = claims.at("sub").get<std::string>();
  const bool printable = std::all_of(sub.begin(), sub.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return u >= 0x20 && u != 0x7f;
  });
  if (sub.empty() || sub.size() > 256 || !printable || sub == kAnonymous)
    return refuse("the token's subject (sub) cannot name a principal here");
  JwtOutcome o;
  o.status = JwtOutcome::Status::ok;
  o.principal.name = sub;
  o.principal.role = is_admin(claims, config) ? Role::admin : Role::user;
  o.principal.how = "jwt";
  o.principal.expires = static_cast<int64_t>(std::floor(*exp));
  return o;
}

}  // namespace rv::auth
