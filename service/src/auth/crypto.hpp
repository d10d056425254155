// The few cryptographic primitives authentication needs, all from OpenSSL (libcrypto): SHA-256,
// a constant-time comparison, and base64url decoding as JOSE (RFC 7515 2) defines it. Nothing
// cryptographic is written here; only the encodings around OpenSSL's calls are.
// Thread safety: free functions, reentrant.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>

namespace rv::auth {

using Sha256 = std::array<unsigned char, 32>;

// SHA-256 of `bytes`. Throws rv::Error(internal) if OpenSSL fails.
Sha256 sha256(std::string_view bytes);
std::string to_hex(const Sha256& digest);
// 64 hex digits (either case) into a digest; nullopt for anything else.
std::optional<Sha256> sha256_from_hex(std::string_view hex);

// Equal contents, in time that does not depend on where they differ (CRYPTO_memcmp).
bool digests_equal(const Sha256& a, const Sha256& b);

// Base64url without padding (RFC 7515 2): the alphabet A-Z a-z 0-9 - _, no '=', no white
// space, and the unused bits of the last character zero (one encoding per byte string).
// nullopt for anything else.
std::optional<std::string> base64url_decode(std::string_view text);

}  // namespace rv::auth
