#include "rv/field/text.hpp"

namespace rv {
namespace {

// Length of the valid UTF-8 sequence starting at s[i], or 0 when s[i] does not start one.
// The second-byte ranges are RFC 3629's table: they exclude overlong forms (C0, C1, E0 80..9F,
// F0 80..8F), surrogates (ED A0..BF) and code points above U+10FFFF (F4 90.., F5..FF).
size_t sequence_length(std::string_view s, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char b0 = byte(i);
  if (b0 < 0x80) return 1;
  size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // range of the second byte
  if (b0 >= 0xC2 && b0 <= 0xDF) {
    n = 2;
  } else if (b0 >= 0xE0 && b0 <= 0xEF) {
    n = 3;
    if (b0 == 0xE0) lo = 0xA0;
    if (b0 == 0xED) hi = 0x9F;
  } else if (b0 >= 0xF0 && b0 <= 0xF4) {
    n = 4;
    if (b0 == 0xF0) lo = 0x90;
    if (b0 == 0xF4) hi = 0x8F;
  } else {
    return 0;
  }
  if (i + n > s.size()) return 0;
  if (byte(i + 1) < lo || byte(i + 1) > hi) return 0;
  for (size_t k = 2; k < n; ++k)
    if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
  return n;
}

constexpr char kHexDigits[] = "0123456789ABCDEF";

void append_hex(std::string& out, std::string_view prefix, unsigned char b) {
  out += prefix;
  out += kHexDigits[b >> 4];
  out += kHexDigits[b & 15];
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

}  // namespace

bool is_valid_utf8(std::string_view bytes) {
  for (size_t i = 0; i < bytes.size();) {
    const size_t n = sequence_length(bytes, i);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

std::string escape_utf8(std::string_view bytes) {
  std::string out;
  out.reserve(bytes.size());
  for (size_t i = 0; i < bytes.size();) {
    const size_t n = sequence_length(bytes, i);
    if (n == 0) {
      append_hex(out, "\\x", static_cast<unsigned char>(bytes[i]));
      ++i;
      continue;
    }
    if (bytes[i] == '\\') {
      // Doubled when what follows in the output begins with '\' (a backslash, or an escaped
      // byte) or 'x': otherwise the decoder could not tell "\x80" typed by someone from 0x80.
      const size_t next = i + 1;
      const bool ambiguous =
          next < bytes.size() && (bytes[next] == '\\' || bytes[next] == 'x' || sequence_length(bytes, next) == 0);
      out += ambiguous ? "\\\\" : "\\";
      ++i;
      continue;
    }
    out.append(bytes.substr(i, n));
    i += n;
  }
  return out;
}

std::string replace_invalid_utf8(std::string_view bytes, std::string_view prefix) {
  std::string out;
  out.reserve(bytes.size());
  for (size_t i = 0; i < bytes.size();) {
    const size_t n = sequence_length(bytes, i);
    if (n == 0) {
      append_hex(out, prefix, static_cast<unsigned char>(bytes[i]));
      ++i;
      continue;
    }
    out.append(bytes.substr(i, n));
    i += n;
  }
  return out;
}

std::string unescape_utf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\\' || i + 1 >= text.size()) {
      out += text[i];
      continue;
    }
    if (text[i + 1] == '\\') {
      out += '\\';
      ++i;
      continue;
    }
    if (text[i + 1] == 'x' && i + 3 < text.size() && hex_value(text[i + 2]) >= 0 && hex_value(text[i + 3]) >= 0) {
      out += static_cast<char>(hex_value(text[i + 2]) * 16 + hex_value(text[i + 3]));
      i += 3;
      continue;
    }
    out += '\\';
  }
  return out;
}

std::string valid_utf8(std::string_view bytes) {
  return is_valid_utf8(bytes) ? std::string(bytes) : escape_utf8(bytes);
}

std::string quote_input(std::string_view bytes, size_t max_bytes) {
  std::string text = valid_utf8(bytes);
  if (text.size() <= max_bytes) return text;
  size_t cut = max_bytes;
  // Back to the start of a character: continuation bytes are 10xxxxxx.
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  return text.substr(0, cut) + "... (" + std::to_string(bytes.size()) + " bytes)";
}

}  // namespace rv
