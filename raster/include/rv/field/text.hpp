// Text that enters the product from outside — GDAL's messages, field and layer names, owner
// values read from seed files, file names, records of an older job store — is bytes, not
// necessarily UTF-8. Everything the product shows (JSON, problem+json, GeoJSON, raster attribute
// tables, logs, terminal lines) must be valid UTF-8. This header is the one rule between the two.
//
// The rule (escape_utf8): valid UTF-8 sequences are copied; every byte that is not part of a
// valid sequence becomes the four characters `\xHH` (upper-case hex); a backslash is doubled
// when the next character of the output would otherwise be `\` or `x`, so that a literal `\x80`
// in the input stays distinguishable from an escaped byte 0x80. Consequences:
//   - text that is valid UTF-8 and has no backslash followed by `\` or `x` is unchanged;
//   - the rule is injective: two different byte strings never give the same text (owner labels
//     that differ only in invalid bytes stay two owners), and unescape_utf8 inverts it;
//   - the result is valid UTF-8 as RFC 3629 defines it (no overlong forms, no surrogates, nothing
//     above U+10FFFF), which is exactly what JSON libraries accept.
// Apply it once, where the bytes enter; escaping escaped text again doubles its backslashes.
//
// Thread safety: pure functions.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace rv {

// True when `bytes` is valid UTF-8 (RFC 3629).
bool is_valid_utf8(std::string_view bytes);

// The rule above. Never throws except std::bad_alloc.
std::string escape_utf8(std::string_view bytes);

// The inverse of escape_utf8: `\\` -> `\`, `\xHH` -> byte 0xHH; any other backslash stays.
std::string unescape_utf8(std::string_view text);

// Every byte not part of a valid sequence written as `prefix` followed by two upper-case hex
// digits; everything else copied, backslashes included. For text in a syntax with escapes of
// its own (JSON text, where the prefix is "\\\\x" so that the string reads `\xHH`).
std::string replace_invalid_utf8(std::string_view bytes, std::string_view prefix);

// `bytes` made valid UTF-8 only if it is not already: the form for text that may or may not have
// passed through escape_utf8 (a message assembled from escaped parts). Valid input is returned
// unchanged, so this never escapes twice.
std::string valid_utf8(std::string_view bytes);

// For echoing a client's input in a message: valid_utf8(bytes), cut at a character boundary to
// at most `max_bytes` bytes, followed by "... (N bytes)" when it was cut.
std::string quote_input(std::string_view bytes, std::size_t max_bytes = 80);

}  // namespace rv
