// Small helpers of the daemon: job ids, timestamps, base64, request log lines.
// All functions are thread-safe.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace rv::daemon {

// 128 random bits from the kernel's CSPRNG (getrandom), as 32 lower-case hex digits.
std::string new_job_id();
// Bytes as whole MiB, rounded up ("12 MiB"), and seconds as "%g" ("3600", "0.5"): the forms
// messages give limits in.
std::string mib_text(int64_t bytes);
std::string seconds_text(double seconds);
// Lower-case hex of `bytes` (two digits a byte).
std::string hex(std::span<const unsigned char> bytes);
// True iff `id` has the shape new_job_id() produces. Checked before an id reaches the file
// system, so a crafted id can never name a path outside the data directory.
bool is_job_id(std::string_view id);

// RFC 3339 UTC with milliseconds: "2026-11-22T10:44:26.123Z".
std::string rfc3339(std::chrono::system_clock::time_point t);
std::string now_rfc3339();
// The time rfc3339() wrote (milliseconds and 'Z' as it writes them); nullopt for other text.
std::optional<std::chrono::system_clock::time_point> parse_rfc3339(std::string_view text);
// IMF-fixdate for HTTP headers (Last-Modified): "Sun, 22 Nov 2026 10:44:26 GMT".
std::string http_date(std::chrono::system_clock::time_point t);

// A request body as JSON, nesting at most kMaxBodyDepth levels: nlohmann's dump() and the
// execute parser recurse once per level, so a body of '[' would overflow the stack. GeoJSON
// needs about 10 levels. Throws rv::Error(invalid_argument) for invalid JSON or deeper nesting.
inline constexpr int kMaxBodyDepth = 64;
nlohmann::json parse_body_json(std::string_view body);

// An OGC API link object: href, rel, type and (when not empty) title.
nlohmann::json link(const std::string& href, const std::string& rel, const std::string& type,
                    const std::string& title = "");

// Decodes standard base64 (RFC 4648, padding optional, whitespace ignored).
// Throws rv::Error(invalid_argument) naming `what` on any other character.
std::string base64_decode(std::string_view text, const std::string& what);

// Decodes %XX escapes (and '+' as a space) of a URL path segment or query part; a malformed
// escape is kept as it is.
std::string percent_decode(std::string_view s);
// Every byte but RFC 3986's unreserved characters as %XX: a value safe in a query.
std::string percent_encode(std::string_view s);

// True when `s` begins with `prefix`, ASCII letters compared without case (HTTP scheme names,
// CRS prefixes such as "epsg:").
bool starts_with_ci(std::string_view s, std::string_view prefix);

// True when a Prefer header (RFC 7240; several headers joined with ',') holds the preference
// respond-async, its name compared without case as the RFC requires.
bool prefers_respond_async(std::string_view prefer);

// The request target as the request log shows it: the query's secrets (access_token, token,
// api_key, key, password, ...) replaced by "REDACTED", the whole cut to 512 bytes and valid UTF-8.
std::string loggable_target(std::string_view target);

// The decoded, non-empty segments of a request path (no query): "/jobs//x/" -> {"jobs", "x"}.
// The one spelling rule of the router and of the authentication's open resources.
std::vector<std::string> path_segments(std::string_view path);

// One structured (JSON) line on stderr, written with a single write() so that lines from
// concurrent threads never interleave.
void log_line(const std::string& json_line);
// The same for an event object written without its time ("{\"event\":...}"): the time goes first.
void log_event(const std::string& json_object);

}  // namespace rv::daemon
