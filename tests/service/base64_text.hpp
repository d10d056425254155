// Base64 for the service's tests: the standard alphabet with padding (uploads in execute
// requests), or base64url without padding (JOSE, RFC 7515 2: tokens and key sets).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace rv::test {

inline std::string base64(std::string_view bytes, bool url = false) {
  const char* const alphabet = url ? "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_"
                                   : "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t n = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
    for (int k = 18; k >= 0; k -= 6) out += alphabet[(n >> k) & 63];
  }
  if (i < bytes.size()) {
    uint32_t n = uint8_t(bytes[i]) << 16;
    if (i + 1 < bytes.size()) n |= uint8_t(bytes[i + 1]) << 8;
    out += alphabet[(n >> 18) & 63];
    out += alphabet[(n >> 12) & 63];
    if (i + 1 < bytes.size())
      out += alphabet[(n >> 6) & 63];
    else if (!url)
      out += '=';
    if (!url) out += '=';
  }
  return out;
}

}  // namespace rv::test
