// 64-bit checksums of byte ranges: what a run records of the files it writes (per tile of its
// rasters, and of its kept seed archive), so that a later edit of the run finds a file that was
// modified or damaged since.
//
// A multiply-xorshift over 8-byte words and the tail: fast (it runs over every encoded tile a run
// writes), not cryptographic: it finds files changed by accident or by another program, not by an
// adversary who can also rewrite the record of the checksums. The value depends only on the bytes
// (and the seed), on any host of the same byte order.
// Pure functions; thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

namespace rv {

inline uint64_t checksum64(const void* data, size_t n, uint64_t seed = 0) {
  auto mix = [](uint64_t h, uint64_t v) {
    h ^= v;
    h *= 0x9e3779b97f4a7c15ULL;
    return h ^ (h >> 29);
  };
  const auto* p = static_cast<const unsigned char*>(data);
  uint64_t h = seed;
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    uint64_t w;
    std::memcpy(&w, p + i, 8);
    h = mix(h, w);
  }
  uint64_t tail = 0;
  if (n > i) std::memcpy(&tail, p + i, n - i);
  return mix(h, tail ^ (static_cast<uint64_t>(n - i) << 56));
}

// 16 lower-case hexadecimal digits.
inline std::string checksum_hex(uint64_t v) {
  char t[17];
  std::snprintf(t, sizeof t, "%016llx", static_cast<unsigned long long>(v));
  return t;
}

}  // namespace rv
