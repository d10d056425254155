#include "auth/jwks.hpp"

#include <openssl/bn.h>
#include <openssl/core_names.h>
#include <openssl/evp.h>
#include <openssl/param_build.h>

#include <nlohmann/json.hpp>

#include "auth/crypto.hpp"
#include "rv/field/error.hpp"

namespace rv::auth {
namespace {

using nlohmann::json;

struct BnFree {
  void operator()(BIGNUM* b) const { BN_free(b); }
};
struct BldFree {
  void operator()(OSSL_PARAM_BLD* b) const { OSSL_PARAM_BLD_free(b); }
};
struct ParamFree {
  void operator()(OSSL_PARAM* p) const { OSSL_PARAM_free(p); }
};
struct CtxFree {
  void operator()(EVP_PKEY_CTX* c) const { EVP_PKEY_CTX_free(c); }
};

// A member of a key as bytes (base64url), or "" when absent or malformed.
std::string member_bytes(const json& jwk, const char* name) {
  if (!jwk.contains(name) || !jwk.at(name).is_string()) return {};
  return base64url_decode(jwk.at(name).get<std::string>()).value_or(std::string());
}

// The public key OpenSSL builds from `params` for the algorithm `type` ("RSA", "EC"), checked
// (an EC point on its curve); nullptr when it cannot.
std::shared_ptr<evp_pkey_st> from_params(const char* type, OSSL_PARAM_BLD* bld) {
  std::unique_ptr<OSSL_PARAM, ParamFree> params(OSSL_PARAM_BLD_to_param(bld));
  std::unique_ptr<EVP_PKEY_CTX, CtxFree> ctx(EVP_PKEY_CTX_new_from_name(nullptr, type, nullptr));
  if (!params || !ctx || EVP_PKEY_fromdata_init(ctx.get()) != 1) return nullptr;
  EVP_PKEY* key = nullptr;
  if (EVP_PKEY_fromdata(ctx.get(), &key, EVP_PKEY_PUBLIC_KEY, params.get()) != 1 || key == nullptr) return nullptr;
  std::shared_ptr<evp_pkey_st> owned(key, EVP_PKEY_free);
  std::unique_ptr<EVP_PKEY_CTX, CtxFree> check(EVP_PKEY_CTX_new_from_pkey(nullptr, key, nullptr));
  if (!check || EVP_PKEY_public_check(check.get()) != 1) return nullptr;
  return owned;
}

std::shared_ptr<evp_pkey_st> rsa_key(const json& jwk) {
  const std::string n = member_bytes(jwk, "n"), e = member_bytes(jwk, "e");
  if (n.empty() || e.empty()) return nullptr;
  std::unique_ptr<BIGNUM, BnFree> bn(
      BN_bin2bn(reinterpret_cast<const unsigned char*>(n.data()), static_cast<int>(n.size()), nullptr));
  std::unique_ptr<BIGNUM, BnFree> be(
      BN_bin2bn(reinterpret_cast<const unsigned char*>(e.data()), static_cast<int>(e.size()), nullptr));
  // RFC 7518 3.3: 2048 bits at least.
  if (!bn || !be || BN_num_bits(bn.get()) < 2048) return nullptr;
  std::unique_ptr<OSSL_PARAM_BLD, BldFree> bld(OSSL_PARAM_BLD_new());
  if (!bld || OSSL_PARAM_BLD_push_BN(bld.get(), OSSL_PKEY_PARAM_RSA_N, bn.get()) != 1 ||
      OSSL_PARAM_BLD_push_BN(bld.get(), OSSL_PKEY_PARAM_RSA_E, be.get()) != 1)
    return nullptr;
  return from_params("RSA", bld.get());
}

std::shared_ptr<evp_pkey_st> p256_key(const json& jwk) {
  if (!jwk.contains("crv") || jwk.at("crv") != "P-256") return nullptr;
  const std::string x = member_bytes(jwk, "x"), y = member_bytes(jwk, "y");
  if (x.size() != 32 || y.size() != 32) return nullptr;
  // The uncompressed point (SEC 1 2.3.3): 0x04, x, y.
  std::string point = "\x04" + x + y;
  std::unique_ptr<OSSL_PARAM_BLD, BldFree> bld(OSSL_PARAM_BLD_new());
  if (!bld || OSSL_PARAM_BLD_push_utf8_string(bld.get(), OSSL_PKEY_PARAM_GROUP_NAME, "P-256", 0) != 1 ||
      OSSL_PARAM_BLD_push_octet_string(bld.get(), OSSL_PKEY_PARAM_PUB_KEY, point.data(), point.size()) != 1)
    return nullptr;
  return from_params("EC", bld.get());
}

}  // namespace

const VerifyKey* KeySet::find(std::string_view kid, std::string_view alg) const {
  const VerifyKey* only = nullptr;
  int count = 0;
  for (const VerifyKey& k : keys) {
    if (k.alg != alg) continue;
    if (!kid.empty() && k.kid == kid) return &k;
    only = &k;
    ++count;
  }
  return kid.empty() && count == 1 ? only : nullptr;
}

KeySet parse_jwks(std::string_view text) {
  const json doc = json::parse(text, nullptr, false);
  if (doc.is_discarded() || !doc.is_object() || !doc.contains("keys") || !doc.at("keys").is_array())
    throw Error(ErrorKind::invalid_input, "not a JSON Web Key Set (an object with a \"keys\" array)");
  KeySet set;
  for (const json& jwk : doc.at("keys")) {
    if (!jwk.is_object() || !jwk.contains("kty") || !jwk.at("kty").is_string()) {
      ++set.skipped;
      continue;
    }
    // A key for encryption, or declared for another algorithm, never verifies our signatures.
    const bool for_signing = !jwk.contains("use") || jwk.at("use") == "sig";
    const std::string kty = jwk.at("kty").get<std::string>();
    const std::string alg = kty == "RSA" ? "RS256" : kty == "EC" ? "ES256" : "";
    const bool alg_fits = !jwk.contains("alg") || jwk.at("alg") == alg;
    std::shared_ptr<evp_pkey_st> key;
    if (for_signing && alg_fits) key = kty == "RSA" ? rsa_key(jwk) : kty == "EC" ? p256_key(jwk) : nullptr;
    if (!key) {
      ++set.skipped;
      continue;
    }
    VerifyKey k;
    k.alg = alg;
    k.key = std::move(key);
    if (jwk.contains("kid") && jwk.at("kid").is_string()) k.kid = jwk.at("kid").get<std::string>();
    set.keys.push_back(std::move(k));
  }
  if (set.keys.empty())
    throw Error(ErrorKind::invalid_input, "the key set holds no RSA (2048 bits or more) or P-256 signing key (" +
                                              std::to_string(set.skipped) + " others skipped)");
  return set;
}

}  // namespace rv::auth
