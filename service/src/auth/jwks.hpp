// An identity provider's signing keys: a JSON Web Key Set (RFC 7517) read into OpenSSL keys.
// Keys that cannot verify RS256 or ES256 signatures (other key types or curves, keys for
// encryption, RSA keys under 2048 bits) are skipped, not fatal: providers publish those too.
// Thread safety: a KeySet is immutable once parsed and may be shared between threads.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

struct evp_pkey_st;  // OpenSSL's EVP_PKEY

namespace rv::auth {

struct VerifyKey {
  std::string kid;  // "" when the set gives none
  std::string alg;  // "RS256" (an RSA key) or "ES256" (a P-256 key)
  std::shared_ptr<evp_pkey_st> key;
};

struct KeySet {
  std::vector<VerifyKey> keys;
  int skipped = 0;  // keys of the document that cannot verify RS256 or ES256
  // The key with id `kid` for `alg`; with `kid` empty, the only key for `alg`. nullptr if none.
  const VerifyKey* find(std::string_view kid, std::string_view alg) const;
};

// Parses a JWKS document ({"keys": [...]}). Throws rv::Error(invalid_input) when it is not one,
// or holds no usable key, saying why.
KeySet parse_jwks(std::string_view text);

}  // namespace rv::auth
