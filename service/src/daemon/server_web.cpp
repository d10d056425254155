#include "daemon/server_web.hpp"

#include <sys/stat.h>

#include <cctype>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "runtime/server_util.hpp"

namespace rv::daemon {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

bool iequal(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i]))) return false;
  return true;
}

// The quality the Accept header gives each of text/html, application/json and */* (RFC 9110
// 12.5.1; a range that is not listed has quality 0; application/* counts for JSON).
struct Qualities {
  double html = 0.0, json = 0.0, any = 0.0;
};

Qualities qualities(std::string_view accept) {
  Qualities q;
  size_t start = 0;
  while (start <= accept.size()) {
    const size_t end = std::min(accept.find(',', start), accept.size());
    std::string_view item = accept.substr(start, end - start);
    start = end + 1;
    const size_t semi = item.find(';');
    const std::string_view range = trim(item.substr(0, semi));
    double quality = 1.0;
    if (semi != std::string_view::npos) {
      std::string_view params = item.substr(semi + 1);
      const size_t qpos = params.find("q=");
      if (qpos != std::string_view::npos) quality = std::atof(std::string(params.substr(qpos + 2)).c_str());
    }
    if (iequal(range, "text/html"))
      q.html = std::max(q.html, quality);
    else if (iequal(range, "application/json") || iequal(range, "application/*"))
      q.json = std::max(q.json, quality);
    else if (range == "*/*")
      q.any = std::max(q.any, quality);
    if (end == accept.size()) break;
  }
  return q;
}

// The value of query parameter `name` ("" when absent, which `present` tells apart).
std::string query_value(std::string_view target, std::string_view name, bool& present) {
  present = false;
  const size_t q = target.find('?');
  if (q == std::string_view::npos) return {};
  std::string_view rest = target.substr(q + 1);
  while (!rest.empty()) {
    const size_t amp = rest.find('&');
    const std::string_view pair = rest.substr(0, amp);
    const size_t eq = pair.find('=');
    if (pair.substr(0, eq) == name) {
      present = true;
      return eq == std::string_view::npos ? std::string() : std::string(pair.substr(eq + 1));
    }
    if (amp == std::string_view::npos) break;
    rest.remove_prefix(amp + 1);
  }
  return {};
}

const char* media_type_of(std::string_view name) {
  auto ends = [&](std::string_view ext) {
    return name.size() > ext.size() && name.compare(name.size() - ext.size(), ext.size(), ext) == 0;
  };
  if (ends(".js") || ends(".mjs")) return "text/javascript; charset=utf-8";
  if (ends(".css")) return "text/css; charset=utf-8";
  if (ends(".html")) return "text/html; charset=utf-8";
  if (ends(".map") || ends(".json")) return "application/json";
  if (ends(".svg")) return "image/svg+xml";
  if (ends(".png")) return "image/png";
  if (ends(".woff2")) return "font/woff2";
  return "application/octet-stream";
}

// Whether an Accept-Encoding header allows gzip (RFC 9110 12.5.3: listed, or "*", without q=0).
bool accepts_gzip(std::string_view header) {
  bool gzip = false, star = false;
  size_t start = 0;
  while (start <= header.size()) {
    const size_t end = std::min(header.find(',', start), header.size());
    const std::string_view item = header.substr(start, end - start);
    start = end + 1;
    const size_t semi = item.find(';');
    const std::string_view coding = trim(item.substr(0, semi));
    bool zero = false;
    if (semi != std::string_view::npos) {
      const std::string_view params = item.substr(semi + 1);
      const size_t q = params.find("q=");
      zero = q != std::string_view::npos && std::atof(std::string(params.substr(q + 2)).c_str()) <= 0.0;
    }
    if (iequal(coding, "gzip")) {
      if (zero) return false;
      gzip = true;
    } else if (coding == "*") {
      star = !zero;
    }
    if (end == header.size()) break;
  }
  return gzip || star;
}

bool plain_name(std::string_view name) {
  if (name.empty() || name.size() > 128 || name.front() == '.') return false;
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-')) return false;
  return true;
}

ApiResponse file_body(const std::string& path, std::string_view name,
                      std::string_view policy = kContentSecurityPolicy) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode))
    return problem_response(404, "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/not-found", "Not found",
                            "no asset '" + std::string(name) + "'", "/static/" + std::string(name));
  std::ifstream in(path, std::ios::binary);
  std::ostringstream body;
  body << in.rdbuf();
  ApiResponse r;
  r.headers.emplace_back("Content-Type", media_type_of(name));
  r.headers.emplace_back("Cache-Control", "no-cache");
  r.body = body.str();
  add_page_headers(r, policy);
  return r;
}

}  // namespace

bool wants_page(std::string_view method, std::string_view target, std::string_view accept) {
  if (method != "GET" && method != "HEAD") return false;
  if (is_asset(target)) return false;
  const std::vector<std::string> seg = path_segments(target.substr(0, target.find('?')));
  if (seg.size() == 4 && seg[0] == "jobs" && seg[2] == "results") return false;  // files
  bool present = false;
  const std::string f = query_value(target, "f", present);
  if (present) return f == "html";
  const Qualities q = qualities(accept);
  return q.html > 0.0 && q.html > q.json && q.html >= q.any;
}

bool is_asset(std::string_view target) {
  const std::string_view path = target.substr(0, target.find('?'));
  return path.size() > 8 && path.substr(0, 8) == "/static/";
}

bool is_app(std::string_view target) {
  const std::string_view path = target.substr(0, target.find('?'));
  return path == "/app" || path == "/app/";
}

ApiResponse app_response(const std::string& web_dir) {
  return file_body(web_dir + "/app.html", "app.html", kAppContentSecurityPolicy);
}

void add_page_headers(ApiResponse& r, std::string_view policy) {
  r.headers.emplace_back("Content-Security-Policy", std::string(policy));
  r.headers.emplace_back("X-Content-Type-Options", "nosniff");
  r.headers.emplace_back("X-Frame-Options", "DENY");
  r.headers.emplace_back("Referrer-Policy", "no-referrer");
}

ApiResponse page_response(const std::string& web_dir) { return file_body(web_dir + "/page.html", "page.html"); }

bool if_none_match_matches(std::string_view header, std::string_view etag) {
  // RFC 9110 13.1.2: If-None-Match = "*" / #entity-tag. A field that is neither is no condition
  // at all: it matches nothing (the asset is sent), never a tag found somewhere inside it.
  auto ows = [](char c) { return c == ' ' || c == '\t'; };
  while (!header.empty() && ows(header.front())) header.remove_prefix(1);
  while (!header.empty() && ows(header.back())) header.remove_suffix(1);
  if (header == "*") return true;  // any current representation: the asset exists
  // Weak comparison (8.8.3.2): the opaque-tags, quotes included, equal; W/ on either is ignored.
  auto opaque = [](std::string_view tag) { return tag.substr(tag.starts_with("W/") ? 2 : 0); };
  const std::string_view current = opaque(etag);
  // etagc = %x21 / %x23-7E / obs-text: anything visible but the double quote.
  auto etagc = [](char c) { return c == 0x21 || (c >= 0x23 && c <= 0x7E) || static_cast<unsigned char>(c) >= 0x80; };
  bool matched = false;
  size_t i = 0;
  while (i < header.size()) {
    if (ows(header[i]) || header[i] == ',') {  // separators; empty list elements are allowed (5.6.1)
      ++i;
      continue;
    }
    const size_t start = i;
    if (header.substr(i, 2) == "W/") i += 2;
    if (i >= header.size() || header[i] != '"') return false;
    size_t close = i + 1;
    while (close < header.size() && etagc(header[close])) ++close;
    if (close >= header.size() || header[close] != '"') return false;
    matched = matched || opaque(header.substr(start, close + 1 - start)) == current;
    i = close + 1;
    while (i < header.size() && ows(header[i])) ++i;
    if (i < header.size() && header[i] != ',') return false;  // a tag runs into something else
  }
  return matched;
}

ApiResponse asset_response(const std::string& web_dir, const ApiRequest& request) {
  const std::string_view target = request.target;
  const std::string_view path = target.substr(0, target.find('?'));
  const std::string_view name = path.substr(8);
  if (!plain_name(name))
    return problem_response(404, "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/not-found", "Not found",
                            "no asset of that name", std::string(path.substr(0, 200)));
  const std::string file = web_dir + "/" + std::string(name);
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return file_body(file, name);
  // Weak (RFC 9110 8.8.1): one validator for the file and its gzip copy, which carry the same content.
  const std::string etag = "W/\"" + std::to_string(st.st_size) + "-" + std::to_string(st.st_mtim.tv_sec) + "." +
                           std::to_string(st.st_mtim.tv_nsec) + "\"";
  const bool safe = request.method == "GET" || request.method == "HEAD";  // 304 answers only these (13.1.2)
  if (safe && if_none_match_matches(request.if_none_match, etag)) {
    ApiResponse r;
    r.status = 304;
    r.headers.emplace_back("ETag", etag);
    r.headers.emplace_back("Cache-Control", "no-cache");
    r.headers.emplace_back("Vary", "Accept-Encoding");
    add_page_headers(r);
    return r;
  }
  struct stat gz {};
  const std::string packed = file + ".gz";
  const bool use_gzip = accepts_gzip(request.accept_encoding) && ::stat(packed.c_str(), &gz) == 0 &&
                        S_ISREG(gz.st_mode) && gz.st_mtim.tv_sec >= st.st_mtim.tv_sec;
  ApiResponse r = file_body(use_gzip ? packed : file, name);
  if (use_gzip) r.headers.emplace_back("Content-Encoding", "gzip");
  r.headers.emplace_back("Vary", "Accept-Encoding");
  r.headers.emplace_back("ETag", etag);
  return r;
}

}  // namespace rv::daemon
