// The "auth" section of the daemon's configuration: principals with hashed tokens, the token
// file in the same form (or the older one token per line), the deprecated plaintext tokens, and
// an identity provider's JWTs.
#include <fstream>
#include <map>
#include <sstream>

#include "auth/crypto.hpp"
#include "auth/file_stamp.hpp"
#include "auth/principal.hpp"
#include "runtime/config_read.hpp"
#include "rv/field/error.hpp"
#include "rv/server_config.hpp"

namespace rv {
namespace {

using config_read::bad;
using config_read::check_keys;
using config_read::get_seconds;
using config_read::get_string;
using nlohmann::json;

// A name goes into job records, logs and pages: printable, no control characters, short.
void check_name(const std::string& name, const std::string& where) {
  if (name.empty() || name.size() > 128) bad(where, "a principal's name must have 1 to 128 characters");
  for (const unsigned char ch : name)
    if (ch < 0x20 || ch == 0x7f) bad(where, "a principal's name may not contain control characters");
  if (name == auth::kAnonymous) bad(where, "the name 'anonymous' is reserved (jobs without a principal)");
}

// A token goes into an HTTP header: printable ASCII without spaces. A short one could be
// guessed online, so 16 characters is the least accepted (`openssl rand -hex 32` gives 64). The
// messages say where the token is, never what it is: the error ends up in logs.
void check_token(const std::string& token, const std::string& where) {
  if (token.size() < 16 || token.size() > 4096) bad(where, "a token must have 16 to 4096 characters");
  for (const char ch : token)
    if (ch < 0x21 || ch > 0x7e) bad(where, "a token may contain printable ASCII characters only, no spaces");
}

// The deprecated plaintext token: a user named by its hash's first 8 hex digits (never by its
// text), and only the hash is kept.
PrincipalConfig from_plain_token(const std::string& token, const std::string& where) {
  check_token(token, where);
  PrincipalConfig p;
  p.token_sha256 = auth::sha256(token);
  p.name = "token-" + auth::to_hex(p.token_sha256).substr(0, 8);
  return p;
}

PrincipalConfig parse_principal(const json& entry, const std::string& where) {
  check_keys(entry, where, {"name", "role", "token_sha256"});
  PrincipalConfig p;
  if (!entry.contains("name")) bad(where + ".name", "is required");
  p.name = get_string(entry, where, "name", "");
  check_name(p.name, where + ".name");
  const std::string role = get_string(entry, where, "role", "user");
  if (role != "user" && role != "admin") bad(where + ".role", "must be \"user\" or \"admin\"");
  p.role = role == "admin" ? Role::admin : Role::user;
  if (!entry.contains("token_sha256")) bad(where + ".token_sha256", "is required (the SHA-256 of the token, in hex)");
  const auto digest = auth::sha256_from_hex(get_string(entry, where, "token_sha256", ""));
  if (!digest) bad(where + ".token_sha256", "must be 64 hex digits (`printf %s \"$TOKEN\" | sha256sum`)");
  p.token_sha256 = *digest;
  return p;
}

void parse_principal_list(const json& list, const std::string& where, AuthConfig& auth) {
  if (!list.is_array()) bad(where, "must be an array of {\"name\", \"role\", \"token_sha256\"}");
  for (size_t i = 0; i < list.size(); ++i)
    auth.principals.push_back(parse_principal(list[i], where + "[" + std::to_string(i) + "]"));
}

// auth.token_file: JSON (an array of principals, or {"principals": [...]}) as auth.principals, or
// the older form, one plaintext token per line ('#' comments and blank lines ignored; deprecated).
void read_token_file(const std::string& path, AuthConfig& auth) {
  // Stamped before the read: a change made while it reads shows as a change at the next check.
  auth.token_file_stamp = auth::file_stamp(path);
  const int deprecated_before = auth.deprecated_tokens;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorKind::not_found, "configuration key 'auth.token_file': '" + path + "' cannot be opened");
  std::stringstream text;
  text << in.rdbuf();
  const std::string content = text.str();
  const size_t before = auth.principals.size();
  const size_t first = content.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && (content[first] == '[' || content[first] == '{')) {
    const json doc = json::parse(content, nullptr, false);
    if (doc.is_discarded()) bad("auth.token_file", "'" + path + "' is not valid JSON");
    if (doc.is_object()) {
      check_keys(doc, "auth.token_file", {"principals"});
      if (!doc.contains("principals")) bad("auth.token_file", "'" + path + "' has no \"principals\"");
      parse_principal_list(doc.at("principals"), "auth.token_file principals", auth);
    } else {
      parse_principal_list(doc, "auth.token_file principals", auth);
    }
  } else {
    std::istringstream lines(content);
    std::string line;
    int number = 0;
    while (std::getline(lines, line)) {
      ++number;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      const size_t a = line.find_first_not_of(" \t");
      if (a == std::string::npos || line[a] == '#') continue;
      const size_t b = line.find_last_not_of(" \t");
      auth.principals.push_back(
          from_plain_token(line.substr(a, b - a + 1), "auth.token_file line " + std::to_string(number)));
      ++auth.deprecated_tokens;
    }
  }
  // A configured but empty file would silently leave the server open: refuse it.
  if (auth.principals.size() == before) bad("auth.token_file", "'" + path + "' holds no token");
  auth.token_file_principals = static_cast<int>(auth.principals.size() - before);
  auth.token_file_deprecated = auth.deprecated_tokens - deprecated_before;
}

std::vector<std::string> string_or_list(const json& v, const std::string& where) {
  std::vector<std::string> out;
  if (v.is_string()) out.push_back(v.get<std::string>());
  if (v.is_array())
    for (const json& x : v) {
      if (!x.is_string()) bad(where, "must be a string or an array of strings");
      out.push_back(x.get<std::string>());
    }
  if (out.empty() || (!v.is_string() && !v.is_array())) bad(where, "must be a string or a non-empty array of strings");
  for (const std::string& s : out)
    if (s.empty()) bad(where, "must not be empty");
  return out;
}

void parse_jwt(const json& j, JwtConfig& jwt) {
  const std::string w = "auth.jwt";
  check_keys(j, w,
             {"issuer", "audience", "jwks_file", "jwks_url", "jwks_ca_file", "jwks_refresh_s", "jwks_min_interval_s",
              "clock_skew_s", "algorithms", "role_claim", "admin_value"});
  jwt.issuer = get_string(j, w, "issuer", "");
  if (jwt.issuer.empty()) bad(w + ".issuer", "is required (the identity provider's \"iss\")");
  if (!j.contains("audience")) bad(w + ".audience", "is required (the \"aud\" tokens for this server carry)");
  jwt.audiences = string_or_list(j.at("audience"), w + ".audience");
  jwt.jwks_file = get_string(j, w, "jwks_file", "");
  jwt.jwks_url = get_string(j, w, "jwks_url", "");
  if (jwt.jwks_file.empty() == jwt.jwks_url.empty()) bad(w, "needs exactly one of jwks_file and jwks_url");
  if (!jwt.jwks_url.empty() && jwt.jwks_url.rfind("https://", 0) != 0)
    bad(w + ".jwks_url", "must be an https:// URL (keys are never fetched in the clear)");
  jwt.jwks_ca_file = get_string(j, w, "jwks_ca_file", "");
  jwt.jwks_refresh_s = get_seconds(j, w, "jwks_refresh_s", jwt.jwks_refresh_s);
  jwt.jwks_min_interval_s = get_seconds(j, w, "jwks_min_interval_s", jwt.jwks_min_interval_s);
  if (j.contains("clock_skew_s")) {
    const json& v = j.at("clock_skew_s");
    if (!v.is_number() || v.get<double>() < 0.0 || v.get<double>() > 3600.0)
      bad(w + ".clock_skew_s", "must be a number of seconds in 0..3600");
    jwt.clock_skew_s = v.get<double>();
  }
  if (j.contains("algorithms")) {
    jwt.algorithms = string_or_list(j.at("algorithms"), w + ".algorithms");
    for (const std::string& a : jwt.algorithms)
      if (a != "RS256" && a != "ES256") bad(w + ".algorithms", "may hold \"RS256\" and \"ES256\" only");
  }
  jwt.role_claim = get_string(j, w, "role_claim", "");
  jwt.admin_value = get_string(j, w, "admin_value", "");
  if (jwt.role_claim.empty() != jwt.admin_value.empty()) bad(w, "role_claim and admin_value go together");
}

// One token is one principal; one name is one principal (several tokens may share it: a person's
// laptop and their pipeline), with one role.
void check_unique(const AuthConfig& auth) {
  std::map<std::string, Role> roles;
  for (size_t i = 0; i < auth.principals.size(); ++i) {
    const PrincipalConfig& p = auth.principals[i];
    for (size_t k = 0; k < i; ++k)
      if (auth::digests_equal(auth.principals[k].token_sha256, p.token_sha256))
        bad("auth", "principals '" + auth.principals[k].name + "' and '" + p.name + "' have the same token");
    const auto [it, fresh] = roles.emplace(p.name, p.role);
    if (!fresh && it->second != p.role) bad("auth", "principal '" + p.name + "' is given two roles");
  }
}

}  // namespace

std::string token_sha256_hex(std::string_view token) { return auth::to_hex(auth::sha256(token)); }

void parse_auth_config(const json& a, AuthConfig& auth) {
  check_keys(a, "auth", {"principals", "token_file", "tokens", "jwt"});
  if (a.contains("principals")) parse_principal_list(a.at("principals"), "auth.principals", auth);
  if (a.contains("tokens")) {
    const json& list = a.at("tokens");
    if (!list.is_array()) bad("auth.tokens", "must be an array of strings");
    for (size_t i = 0; i < list.size(); ++i) {
      const std::string where = "auth.tokens[" + std::to_string(i) + "]";
      if (!list[i].is_string()) bad(where, "must be a string");
      auth.principals.push_back(from_plain_token(list[i].get<std::string>(), where));
      ++auth.deprecated_tokens;
    }
  }
  auth.token_file = get_string(a, "auth", "token_file", "");
  if (!auth.token_file.empty()) read_token_file(auth.token_file, auth);
  if (a.contains("jwt")) parse_jwt(a.at("jwt"), auth.jwt);
  check_unique(auth);
}

AuthConfig reread_token_file(const AuthConfig& auth) {
  if (auth.token_file.empty()) throw Error(ErrorKind::internal, "no token file to read again");
  AuthConfig fresh = auth;
  fresh.principals.resize(fresh.principals.size() - static_cast<size_t>(auth.token_file_principals));
  fresh.deprecated_tokens -= auth.token_file_deprecated;
  fresh.token_file_principals = fresh.token_file_deprecated = 0;
  read_token_file(fresh.token_file, fresh);
  check_unique(fresh);
  return fresh;
}

}  // namespace rv
