#include "runtime/server_util.hpp"

#include <cstdio>

#include <sys/random.h>
#include <unistd.h>

#include <array>
#include <cctype>
#include <cerrno>
#include <ctime>

#include "rv/field/error.hpp"
#include "rv/field/text.hpp"

namespace rv::daemon {

std::string new_job_id() {
  std::array<unsigned char, 16> bytes{};
  size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t n = getrandom(bytes.data() + got, bytes.size() - got, 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw Error(ErrorKind::internal, "getrandom failed");
    }
    got += static_cast<size_t>(n);
  }
  return hex(bytes);
}

std::string mib_text(int64_t bytes) { return std::to_string((bytes + (int64_t{1} << 20) - 1) >> 20) + " MiB"; }

std::string seconds_text(double seconds) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", seconds);
  return buf;
}

std::string hex(std::span<const unsigned char> bytes) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(2 * bytes.size());
  for (const unsigned char b : bytes) {
    out += kHex[b >> 4];
    out += kHex[b & 15];
  }
  return out;
}

bool is_job_id(std::string_view id) {
  if (id.size() != 32) return false;
  for (char c : id) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

std::string rfc3339(std::chrono::system_clock::time_point t) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count();
  const std::time_t secs = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[96];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
                tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(ms % 1000));
  return buf;
}

std::string now_rfc3339() { return rfc3339(std::chrono::system_clock::now()); }

std::optional<std::chrono::system_clock::time_point> parse_rfc3339(std::string_view text) {
  std::tm tm{};
  int ms = 0;
  char z = 0;
  const std::string s(text.substr(0, 40));
  if (std::sscanf(s.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d.%3d%c", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour,
                  &tm.tm_min, &tm.tm_sec, &ms, &z) != 8 ||
      z != 'Z' || s.size() != 24)
    return std::nullopt;
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  const std::time_t secs = timegm(&tm);
  if (secs == static_cast<std::time_t>(-1)) return std::nullopt;
  return std::chrono::system_clock::from_time_t(secs) + std::chrono::milliseconds(ms);
}

std::string http_date(std::chrono::system_clock::time_point t) {
  const std::time_t secs = std::chrono::system_clock::to_time_t(t);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  static constexpr const char* kDays[] = {"Sun", "Mon", "Tue", "Wed", "Thu", "Fri", "Sat"};
  static constexpr const char* kMonths[] = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                            "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
  char buf[96];
  std::snprintf(buf, sizeof buf, "%s, %02d %s %04d %02d:%02d:%02d GMT", kDays[tm.tm_wday], tm.tm_mday,
                kMonths[tm.tm_mon], tm.tm_year + 1900, tm.tm_hour, tm.tm_min, tm.tm_sec);
  return buf;
}

std::string base64_decode(std::string_view text, const std::string& what) {
  // Sextet value per input byte; -1 invalid, -2 skipped (whitespace).
  static const auto table = [] {
    std::array<int8_t, 256> t{};
    t.fill(-1);
    for (int i = 0; i < 26; ++i) {
      t[static_cast<size_t>('A' + i)] = static_cast<int8_t>(i);
      t[static_cast<size_t>('a' + i)] = static_cast<int8_t>(26 + i);
    }
    for (int i = 0; i < 10; ++i) t[static_cast<size_t>('0' + i)] = static_cast<int8_t>(52 + i);
    t['+'] = 62;
    t['/'] = 63;
    for (char c : {' ', '\n', '\r', '\t'}) t[static_cast<size_t>(c)] = -2;
    return t;
  }();
  std::string out;
  out.reserve(text.size() / 4 * 3 + 3);
  uint32_t acc = 0;
  int bits = 0;
  size_t padding = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c == '=') {
      ++padding;
      continue;
    }
    const int8_t v = table[c];
    if (v == -2) continue;
    if (v < 0 || padding > 0) {
      throw Error(ErrorKind::invalid_argument,
                  what + ": not valid base64 (unexpected character at offset " + std::to_string(i) + ")");
    }
    acc = (acc << 6) | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((acc >> bits) & 0xFF);
    }
  }
  if (padding > 2 || bits >= 6) {
    throw Error(ErrorKind::invalid_argument, what + ": not valid base64 (truncated)");
  }
  return out;
}

std::string percent_encode(std::string_view s) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u) || c == '-' || c == '.' || c == '_' || c == '~') {
      out += c;
    } else {
      out += '%';
      out += kHex[u >> 4];
      out += kHex[u & 15];
    }
  }
  return out;
}

void log_event(const std::string& json_object) {
  const std::string rest = json_object.size() > 2 ? "," + json_object.substr(1) : "}";
  log_line("{\"time\":\"" + now_rfc3339() + "\"" + rest);
}

void log_line(const std::string& json_line) {
  std::string line = json_line;
  line += '\n';
  const char* p = line.data();
  size_t left = line.size();
  while (left > 0) {
    const ssize_t n = ::write(STDERR_FILENO, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      return;  // a closed stderr must not take the server down
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
}

nlohmann::json parse_body_json(std::string_view body) {
  nlohmann::json doc = nlohmann::json::parse(
      body,
      [](int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
        if (depth > kMaxBodyDepth)
          throw Error(ErrorKind::invalid_argument,
                      "the request body nests deeper than " + std::to_string(kMaxBodyDepth) + " levels");
        return true;
      },
      /*allow_exceptions=*/false);
  if (doc.is_discarded()) throw Error(ErrorKind::invalid_argument, "the request body is not valid JSON");
  return doc;
}

std::string percent_decode(std::string_view s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out += static_cast<char>(std::stoi(std::string(s.substr(i + 1, 2)), nullptr, 16));
      i += 2;
    } else {
      out += s[i] == '+' ? ' ' : s[i];
    }
  }
  return out;
}

std::vector<std::string> path_segments(std::string_view path) {
  std::vector<std::string> seg;
  size_t start = 0;
  while (start <= path.size()) {
    size_t end = path.find('/', start);
    if (end == std::string_view::npos) end = path.size();
    if (end > start) seg.push_back(percent_decode(path.substr(start, end - start)));
    start = end + 1;
  }
  return seg;
}

namespace {
std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}
bool equals_ci(std::string_view a, std::string_view b) { return a.size() == b.size() && starts_with_ci(a, b); }
}  // namespace

bool prefers_respond_async(std::string_view prefer) {
  size_t start = 0;
  while (start <= prefer.size()) {
    const size_t end = std::min(prefer.find(',', start), prefer.size());
    // A preference is a token, optionally "=value", then ";parameters".
    std::string_view item = prefer.substr(start, end - start);
    item = item.substr(0, std::min(item.find(';'), item.find('=')));
    if (equals_ci(trim(item), "respond-async")) return true;
    start = end + 1;
  }
  return false;
}

std::string loggable_target(std::string_view target) {
  static constexpr std::string_view kSecrets[] = {"access_token", "token",  "api_key", "apikey",       "key",
                                                  "password",     "secret", "auth",    "authorization"};
  std::string out(target.substr(0, target.find('?')));
  const size_t q = target.find('?');
  if (q != std::string_view::npos) {
    out += '?';
    const std::string_view query = target.substr(q + 1);
    size_t start = 0;
    bool first = true;
    while (start <= query.size()) {
      const size_t end = std::min(query.find('&', start), query.size());
      const std::string_view pair = query.substr(start, end - start);
      const size_t eq = pair.find('=');
      const std::string name = percent_decode(pair.substr(0, eq));
      bool secret = false;
      for (std::string_view s : kSecrets) secret = secret || equals_ci(name, s);
      if (!first) out += '&';
      first = false;
      if (secret && eq != std::string_view::npos) {
        out.append(pair.substr(0, eq));
        out += "=REDACTED";
      } else {
        out.append(pair);
      }
      start = end + 1;
    }
  }
  return quote_input(out, 512);
}

bool starts_with_ci(std::string_view s, std::string_view prefix) {
  if (s.size() < prefix.size()) return false;
  for (size_t i = 0; i < prefix.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[i])) != std::tolower(static_cast<unsigned char>(prefix[i])))
      return false;
  return true;
}

nlohmann::json link(const std::string& href, const std::string& rel, const std::string& type,
                    const std::string& title) {
  nlohmann::json l = {{"href", href}, {"rel", rel}, {"type", type}};
  if (!title.empty()) l["title"] = title;
  return l;
}

}  // namespace rv::daemon
