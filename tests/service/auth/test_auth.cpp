// The authentication's parts (issue 52), one by one, with keys this test makes through OpenSSL:
//   - base64url as JOSE defines it: padding, foreign characters and non-canonical last
//     characters refused;
//   - the key set: RSA under 2048 bits, encryption keys, keys declared for another algorithm and
//     EC points off their curve skipped; a set of nothing usable refused;
//   - JWT verification: RS256 and ES256 accepted; a "crit" header, an ES256 signature of the wrong
//     length, a kid-less token with two candidate keys, a subject with control characters refused;
//     the role from a dotted claim, an array or a space-separated list;
//   - the configuration: principals, roles, duplicates, the token file in both forms, the JWT
//     section's mistakes, each named by its key and never quoting a token;
//   - the token file followed as it is edited: its principals replaced, the configuration's kept,
//     a broken edit keeping the set before it, each change logged once;
//   - the hourly cell allowance: the window, Retry-After, restore, refund.
#include <openssl/core_names.h>
#include <openssl/ec.h>
#include <openssl/evp.h>
#include <openssl/rsa.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>

#include "../base64_text.hpp"
#include "auth/crypto.hpp"
#include "auth/jwks.hpp"
#include "auth/jwt.hpp"
#include "auth/principal_set.hpp"
#include "runtime/principal_usage.hpp"
#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"
#include "rv/server_config.hpp"

namespace {

using nlohmann::json;
using rv::auth::base64url_decode;
namespace fs = std::filesystem;

std::string b64u(std::string_view bytes) { return rv::test::base64(bytes, true); }

using Key = std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)>;
Key rsa_key(unsigned bits) { return Key(EVP_RSA_gen(bits), EVP_PKEY_free); }
Key p256_key() { return Key(EVP_EC_gen("P-256"), EVP_PKEY_free); }

std::string bn_param(EVP_PKEY* k, const char* name) {
  BIGNUM* bn = nullptr;
  EXPECT_EQ(EVP_PKEY_get_bn_param(k, name, &bn), 1);
  std::string out(static_cast<size_t>(BN_num_bytes(bn)), '\0');
  BN_bn2bin(bn, reinterpret_cast<unsigned char*>(out.data()));
  BN_free(bn);
  return out;
}

json rsa_jwk(EVP_PKEY* k, const std::string& kid) {
  return {{"kty", "RSA"},
          {"kid", kid},
          {"n", b64u(bn_param(k, OSSL_PKEY_PARAM_RSA_N))},
          {"e", b64u(bn_param(k, OSSL_PKEY_PARAM_RSA_E))}};
}

json ec_jwk(EVP_PKEY* k, const std::string& kid) {
  unsigned char point[65];
  size_t length = 0;
  EXPECT_EQ(EVP_PKEY_get_octet_string_param(k, OSSL_PKEY_PARAM_PUB_KEY, point, sizeof point, &length), 1);
  EXPECT_EQ(length, 65u);
  const std::string p(reinterpret_cast<char*>(point), length);
  return {{"kty", "EC"}, {"kid", kid}, {"crv", "P-256"}, {"x", b64u(p.substr(1, 32))}, {"y", b64u(p.substr(33, 32))}};
}

// A compact JWS of `header` and `claims` signed with `key` (RS256, or ES256 as r || s).
std::string sign(EVP_PKEY* key, const json& header, const json& claims) {
  const std::string input = b64u(header.dump()) + "." + b64u(claims.dump());
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> md(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  EXPECT_EQ(EVP_DigestSignInit(md.get(), nullptr, EVP_sha256(), nullptr, key), 1);
  size_t length = 0;
  EXPECT_EQ(
      EVP_DigestSign(md.get(), nullptr, &length, reinterpret_cast<const unsigned char*>(input.data()), input.size()),
      1);
  std::string sig(length, '\0');
  EXPECT_EQ(EVP_DigestSign(md.get(), reinterpret_cast<unsigned char*>(sig.data()), &length,
                           reinterpret_cast<const unsigned char*>(input.data()), input.size()),
            1);
  sig.resize(length);
  if (EVP_PKEY_is_a(key, "EC")) {  // DER -> r || s
    const unsigned char* p = reinterpret_cast<const unsigned char*>(sig.data());
    ECDSA_SIG* s = d2i_ECDSA_SIG(nullptr, &p, static_cast<long>(sig.size()));
    std::string raw(64, '\0');
    BN_bn2binpad(ECDSA_SIG_get0_r(s), reinterpret_cast<unsigned char*>(raw.data()), 32);
    BN_bn2binpad(ECDSA_SIG_get0_s(s), reinterpret_cast<unsigned char*>(raw.data()) + 32, 32);
    ECDSA_SIG_free(s);
    sig = raw;
  }
  return input + "." + b64u(sig);
}

constexpr int64_t kNow = 1'800'000'000;

// `j` with member `key` set to `value`.
json with(json j, const std::string& key, json value) {
  j[key] = std::move(value);
  return j;
}

rv::JwtConfig jwt_config() {
  rv::JwtConfig c;
  c.issuer = "https://idp.test";
  c.audiences = {"rvoronoi"};
  c.jwks_file = "unused";
  c.role_claim = "realm_access.roles";
  c.admin_value = "rvoronoi-admin";
  return c;
}

json claims(const std::string& sub = "dana") {
  return {{"iss", "https://idp.test"}, {"aud", "rvoronoi"}, {"sub", sub}, {"exp", kNow + 600}};
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const rv::Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Base64Url, StrictAsJoseDefinesIt) {
  EXPECT_EQ(base64url_decode(""), std::string());
  EXPECT_EQ(base64url_decode("Zm9v"), std::string("foo"));
  EXPECT_EQ(base64url_decode("Zm8"), std::string("fo"));
  EXPECT_EQ(base64url_decode("Zg"), std::string("f"));
  EXPECT_EQ(base64url_decode("-_8"), std::string("\xfb\xff"));
  for (const char* bad : {"Zg==", "Zm9v=", "Z", "Zm9v!", "Zm+v", "Zm/v", "Zm 9v", "Zh", "Zm9"}) {
    // "Zh" and "Zm9" end in bits that are not zero: another text for the same bytes.
    EXPECT_FALSE(base64url_decode(bad).has_value()) << bad;
  }
  for (int n = 0; n < 40; ++n) {
    std::string bytes;
    for (int i = 0; i < n; ++i) bytes += static_cast<char>((i * 37 + n) & 0xff);
    EXPECT_EQ(base64url_decode(b64u(bytes)), bytes) << n;
  }
}

TEST(KeySet, SkipsWhatCannotVerifyAndRefusesAnEmptySet) {
  const Key r2048 = rsa_key(2048), r1024 = rsa_key(1024), p256 = p256_key();
  json off_curve = ec_jwk(p256.get(), "bad");
  off_curve["y"] = b64u(std::string(32, '\x01'));
  const json doc = {{"keys",
                     {rsa_jwk(r2048.get(), "r"),
                      ec_jwk(p256.get(), "e"),
                      rsa_jwk(r1024.get(), "small"),
                      with(rsa_jwk(r2048.get(), "enc"), "use", "enc"),
                      with(rsa_jwk(r2048.get(), "hs"), "alg", "RS512"),
                      off_curve,
                      {{"kty", "oct"}, {"k", "c2VjcmV0"}},
                      {{"kty", "OKP"}, {"crv", "Ed25519"}, {"x", "AA"}}}}};
  const rv::auth::KeySet set = rv::auth::parse_jwks(doc.dump());
  ASSERT_EQ(set.keys.size(), 2u);
  EXPECT_EQ(set.skipped, 6);
  EXPECT_NE(set.find("r", "RS256"), nullptr);
  EXPECT_EQ(set.find("r", "ES256"), nullptr);  // a key serves its own algorithm only
  EXPECT_NE(set.find("e", "ES256"), nullptr);
  EXPECT_NE(set.find("", "ES256"), nullptr);  // no kid: the only key for the algorithm
  EXPECT_EQ(set.find("small", "RS256"), nullptr);
  const std::vector<std::string> broken = {"[]", "{}", "{\"keys\": 3}", "not json",
                                           json{{"keys", {rsa_jwk(r1024.get(), "small")}}}.dump()};
  for (const std::string& text : broken) {
    try {
      rv::auth::parse_jwks(text);
      ADD_FAILURE() << text;
    } catch (const rv::Error& e) {
      EXPECT_EQ(e.kind(), rv::ErrorKind::invalid_input) << text;
    }
  }
}

TEST(Jwt, SignaturesHeadersAndClaims) {
  using Status = rv::auth::JwtOutcome::Status;
  const Key r = rsa_key(2048), e = p256_key(), r2 = rsa_key(2048);
  const rv::auth::KeySet set = rv::auth::parse_jwks(
      json{{"keys", {rsa_jwk(r.get(), "r"), ec_jwk(e.get(), "e"), rsa_jwk(r2.get(), "r2")}}}.dump());
  const rv::JwtConfig c = jwt_config();
  auto verify = [&](const std::string& token) { return rv::auth::verify_jwt(token, set, c, kNow); };

  const auto good = verify(sign(r.get(), {{"alg", "RS256"}, {"kid", "r"}}, claims()));
  ASSERT_EQ(good.status, Status::ok) << good.reason;
  EXPECT_EQ(good.principal.name, "dana");
  EXPECT_EQ(good.principal.role, rv::Role::user);
  EXPECT_EQ(good.principal.how, "jwt");
  EXPECT_EQ(good.principal.expires, kNow + 600);
  EXPECT_EQ(verify(sign(e.get(), {{"alg", "ES256"}, {"kid", "e"}}, claims())).status, Status::ok);
  // No kid: the only ES256 key serves; two RSA keys leave an RS256 token without a key.
  EXPECT_EQ(verify(sign(e.get(), {{"alg", "ES256"}}, claims())).status, Status::ok);
  EXPECT_EQ(verify(sign(r.get(), {{"alg", "RS256"}}, claims())).status, Status::unknown_key);
  // The key's type must fit the algorithm the header names.
  EXPECT_EQ(verify(sign(r.get(), {{"alg", "ES256"}, {"kid", "r"}}, claims())).status, Status::unknown_key);

  const auto crit =
      verify(sign(r.get(), {{"alg", "RS256"}, {"kid", "r"}, {"crit", {"b64"}}, {"b64", false}}, claims()));
  EXPECT_EQ(crit.status, Status::invalid);
  EXPECT_NE(crit.reason.find("critical"), std::string::npos);
  // An ES256 signature in DER (what OpenSSL makes) instead of r || s: refused.
  std::string es = sign(e.get(), {{"alg", "ES256"}, {"kid", "e"}}, claims());
  const std::string truncated = es.substr(0, es.rfind('.') + 1) + b64u(std::string(70, '\x30'));
  EXPECT_NE(verify(truncated).reason.find("signature"), std::string::npos);

  // Roles: a dotted path to an array, a space-separated list, a plain value; none without.
  json admin = claims("erin");
  admin["realm_access"] = {{"roles", {"offline_access", "rvoronoi-admin"}}};
  EXPECT_EQ(verify(sign(r.get(), {{"alg", "RS256"}, {"kid", "r"}}, admin)).principal.role, rv::Role::admin);
  rv::JwtConfig scope = c;
  scope.role_claim = "scope";
  json scoped = claims("erin");
  scoped["scope"] = "openid rvoronoi-admin profile";
  EXPECT_EQ(
      rv::auth::verify_jwt(sign(r.get(), {{"alg", "RS256"}, {"kid", "r"}}, scoped), set, scope, kNow).principal.role,
      rv::Role::admin);
  scoped["scope"] = "openid rvoronoi-administrator";
  EXPECT_EQ(
      rv::auth::verify_jwt(sign(r.get(), {{"alg", "RS256"}, {"kid", "r"}}, scoped), set, scope, kNow).principal.role,
      rv::Role::user);

  // Subjects that cannot name a principal; claims of the wrong type.
  for (const std::string& sub : std::vector<std::string>{"", "anonymous", "a\nb", std::string(300, 'x')})
    EXPECT_NE(verify(sign(r.get(), {{"alg", "RS256"}, {"kid", "r"}}, claims(sub))).reason.find("subject"),
              std::string::npos)
        << sub;
  json text_exp = claims();
  text_exp["exp"] = "tomorrow";
  EXPECT_NE(verify(sign(r.get(), {{"alg", "RS256"}, {"kid", "r"}}, text_exp)).reason.find("expiry"), std::string::npos);
  json wrong_aud = claims();
  wrong_aud["aud"] = {"a", "b"};
  EXPECT_NE(verify(sign(r.get(), {{"alg", "RS256"}, {"kid", "r"}}, wrong_aud)).reason.find("aud"), std::string::npos);
  // The reason never carries what the token held.
  EXPECT_EQ(verify(sign(r2.get(), {{"alg", "RS256"}, {"kid", "r"}}, claims("carol"))).reason.find("carol"),
            std::string::npos);
  EXPECT_FALSE(rv::auth::looks_like_jwt("plain-token-0123456789abcdef"));
  EXPECT_FALSE(rv::auth::looks_like_jwt("a.b"));
  EXPECT_FALSE(rv::auth::looks_like_jwt("a..c"));
  EXPECT_TRUE(rv::auth::looks_like_jwt("a.b."));
}

TEST(AuthConfig, PrincipalsTokenFilesAndTheJwtSection) {
  const std::string alice = "alice-token-0123456789abcdef";
  const json p = {{"name", "alice"}, {"role", "admin"}, {"token_sha256", rv::token_sha256_hex(alice)}};
  const rv::ServerConfig c = rv::parse_server_config(json{{"auth", {{"principals", {p}}}}});
  ASSERT_EQ(c.auth.principals.size(), 1u);
  EXPECT_EQ(c.auth.principals[0].role, rv::Role::admin);
  EXPECT_EQ(rv::auth::to_hex(c.auth.principals[0].token_sha256), rv::token_sha256_hex(alice));
  EXPECT_EQ(rv::token_sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");

  auto refused = [](const json& auth) { return error_of([&] { rv::parse_server_config(json{{"auth", auth}}); }); };
  json q = p;
  q["name"] = "anonymous";
  EXPECT_NE(refused(json{{"principals", {q}}}).find("reserved"), std::string::npos);
  q = p;
  q["role"] = "root";
  EXPECT_NE(refused(json{{"principals", {q}}}).find("auth.principals[0].role"), std::string::npos);
  q = p;
  q["token_sha256"] = alice;  // the token itself, not its hash
  const std::string plain = refused(json{{"principals", {q}}});
  EXPECT_NE(plain.find("token_sha256"), std::string::npos);
  EXPECT_EQ(plain.find(alice), std::string::npos) << "the message quotes the token";
  q = p;
  q["name"] = "bob";
  EXPECT_NE(refused(json{{"principals", {p, q}}}).find("the same token"), std::string::npos);
  q = p;
  q["role"] = "user";
  q["token_sha256"] = rv::token_sha256_hex("another-token-0123456789");
  EXPECT_NE(refused(json{{"principals", {p, q}}}).find("two roles"), std::string::npos);

  // The token file in the principals' form, and in the older one (a token a line).
  const fs::path file = fs::temp_directory_path() / ("rv_auth_principals_" + std::to_string(::getpid()));
  std::ofstream(file) << json{{"principals", {p}}}.dump(2);
  const rv::ServerConfig f = rv::parse_server_config(json{{"auth", {{"token_file", file.string()}}}});
  EXPECT_EQ(f.auth.principals.size(), 1u);
  EXPECT_EQ(f.auth.deprecated_tokens, 0);
  std::ofstream(file) << json::array({p}).dump();
  EXPECT_EQ(rv::parse_server_config(json{{"auth", {{"token_file", file.string()}}}}).auth.principals[0].name, "alice");
  std::ofstream(file) << "# the pipeline\n" << alice << "\n";
  const rv::ServerConfig old = rv::parse_server_config(json{{"auth", {{"token_file", file.string()}}}});
  EXPECT_EQ(old.auth.deprecated_tokens, 1);
  EXPECT_EQ(old.auth.principals[0].name, "token-" + rv::token_sha256_hex(alice).substr(0, 8));
  std::ofstream(file) << "{\"principals\": [";
  EXPECT_NE(refused(json{{"token_file", file.string()}}).find("not valid JSON"), std::string::npos);
  fs::remove(file);

  // The JWT section.
  const json jwt = {{"issuer", "https://idp.test"}, {"audience", "rvoronoi"}, {"jwks_url", "https://idp.test/certs"}};
  const rv::ServerConfig j = rv::parse_server_config(json{{"auth", {{"jwt", jwt}}}});
  EXPECT_TRUE(j.auth.enabled());
  EXPECT_EQ(j.auth.jwt.audiences, std::vector<std::string>{"rvoronoi"});
  EXPECT_NE(refused(json{{"jwt", with(jwt, "jwks_url", "http://idp.test/certs")}}).find("https"), std::string::npos);
  EXPECT_NE(refused(json{{"jwt", with(jwt, "jwks_file", "/k.json")}}).find("exactly one"), std::string::npos);
  EXPECT_NE(refused(json{{"jwt", with(jwt, "algorithms", json::array({"HS256"}))}}).find("auth.jwt.algorithms"),
            std::string::npos);
  EXPECT_NE(refused(json{{"jwt", with(jwt, "role_claim", "roles")}}).find("go together"), std::string::npos);
  json no_issuer = jwt;
  no_issuer.erase("issuer");
  EXPECT_NE(refused(json{{"jwt", no_issuer}}).find("auth.jwt.issuer"), std::string::npos);
  EXPECT_NE(refused(json{{"jwt", with(jwt, "clock_skew_s", -1)}}).find("clock_skew_s"), std::string::npos);

  const rv::ServerConfig l = rv::parse_server_config(
      json{{"limits", {{"jobs_per_principal", 3}, {"cells_per_principal_per_hour", 1000000000}}}});
  EXPECT_EQ(l.principal_limits.jobs, 3);
  EXPECT_EQ(l.principal_limits.cells_per_hour, 1'000'000'000);
}

// The names of a set, in order.
std::vector<std::string> names(const std::vector<rv::PrincipalConfig>& set) {
  std::vector<std::string> out;
  for (const rv::PrincipalConfig& p : set) out.push_back(p.name);
  return out;
}

TEST(TokenFile, ReadAgainAsItIsEditedKeepingTheRestAndTheLastGoodSet) {
  auto principal = [](const std::string& name, const std::string& token, const std::string& role = "user") {
    return json{{"name", name}, {"role", role}, {"token_sha256", rv::token_sha256_hex(token)}};
  };
  const json root = principal("root", "root-token-0123456789abcdef", "admin");
  const fs::path dir = fs::temp_directory_path() / ("rv_auth_token_file_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path file = dir / "tokens.json";
  // Written the safe way (a rename), as an operator's tool would.
  auto write = [&](const std::string& text) {
    std::ofstream(dir / "next") << text;
    fs::rename(dir / "next", file);
  };
  write(json::array({principal("alice", "alice-token-0123456789abcdef")}).dump());
  // The configuration's own principal and a deprecated plaintext token, then the file's.
  const rv::ServerConfig c = rv::parse_server_config(json{
      {"auth", {{"principals", {root}}, {"tokens", {"plain-token-0123456789abcdef"}}, {"token_file", file.string()}}}});
  ASSERT_EQ(names(c.auth.principals), (std::vector<std::string>{"root", c.auth.principals[1].name, "alice"}));
  EXPECT_EQ(c.auth.token_file_principals, 1);
  EXPECT_FALSE(c.auth.token_file_stamp.empty());

  // The re-read replaces the file's principals only, and counts the file's plaintext tokens.
  write("# one a line\nbob-token-0123456789abcdef01\ncarol-token-0123456789abcdef\n");
  const rv::AuthConfig again = rv::reread_token_file(c.auth);
  const std::string bob = "token-" + rv::token_sha256_hex("bob-token-0123456789abcdef01").substr(0, 8);
  const std::string carol = "token-" + rv::token_sha256_hex("carol-token-0123456789abcdef").substr(0, 8);
  EXPECT_EQ(names(again.principals), (std::vector<std::string>{"root", c.auth.principals[1].name, bob, carol}));
  EXPECT_EQ(again.deprecated_tokens, 3);
  EXPECT_EQ(again.token_file_principals, 2);
  EXPECT_NE(again.token_file_stamp, c.auth.token_file_stamp);
  // A file giving the configuration's admin a second role, or naming its token again, is refused.
  write(json::array({principal("root", "another-token-0123456789ab")}).dump());
  EXPECT_NE(error_of([&] { rv::reread_token_file(c.auth); }).find("two roles"), std::string::npos);
  write(json::array({principal("mallory", "root-token-0123456789abcdef")}).dump());
  EXPECT_NE(error_of([&] { rv::reread_token_file(c.auth); }).find("the same token"), std::string::npos);

  // The set a daemon uses, checked on every call here (interval 0).
  write(json::array({principal("alice", "alice-token-0123456789abcdef")}).dump());
  const rv::ServerConfig start =
      rv::parse_server_config(json{{"auth", {{"principals", {root}}, {"token_file", file.string()}}}});
  std::vector<std::string> log;
  rv::auth::PrincipalSet set(
      start.auth, [&](const std::string& line) { log.push_back(line); }, 0.0);
  EXPECT_EQ(names(*set.current()), (std::vector<std::string>{"root", "alice"}));
  EXPECT_TRUE(log.empty()) << "unchanged since the configuration read it: " << log.front();
  const auto held = set.current();
  write(json{{"principals", {principal("bob", "bob-token-0123456789abcdef01")}}}.dump());
  EXPECT_EQ(names(*set.current()), (std::vector<std::string>{"root", "bob"}));  // alice revoked
  EXPECT_EQ(names(*held), (std::vector<std::string>{"root", "alice"})) << "a set in use is not changed under it";
  ASSERT_EQ(log.size(), 1u);
  EXPECT_NE(log[0].find("\"event\":\"token_file_loaded\""), std::string::npos) << log[0];
  EXPECT_NE(log[0].find("\"principals\":1"), std::string::npos) << log[0];
  set.current();
  EXPECT_EQ(log.size(), 1u) << "an unchanged file is not read again";
  // Broken edits: cut short, emptied, removed. Each is logged once, and bob keeps his access.
  const std::vector<std::pair<std::function<void()>, std::string>> broken = {
      {[&] { write("[{\"name\": \"bob\", "); }, "not valid JSON"},
      {[&] { write("\n# nobody\n"); }, "holds no token"},
      {[&] { fs::remove(file); }, "cannot be opened"}};
  for (size_t i = 0; i < broken.size(); ++i) {
    const auto& [edit, why] = broken[i];
    edit();
    EXPECT_EQ(names(*set.current()), (std::vector<std::string>{"root", "bob"})) << why;
    set.current();
    ASSERT_EQ(log.size(), 2 + i) << why;
    EXPECT_NE(log.back().find("\"event\":\"token_file_failed\""), std::string::npos) << log.back();
    EXPECT_NE(log.back().find(why), std::string::npos) << log.back();
    EXPECT_NE(log.back().find("\"keeping\":1"), std::string::npos) << log.back();
  }
  // Mended: read again.
  write(json::array({principal("carol", "carol-token-0123456789abcdef")}).dump());
  EXPECT_EQ(names(*set.current()), (std::vector<std::string>{"root", "carol"}));
  EXPECT_NE(log.back().find("token_file_loaded"), std::string::npos) << log.back();
  fs::remove_all(dir);
}

TEST(CellAllowance, AnHourSlidingWindow) {
  using rv::daemon::CellAllowance;
  using rv::daemon::QuotaExceeded;
  using namespace std::chrono_literals;
  CellAllowance a(1000);
  const auto t0 = CellAllowance::Clock::time_point(std::chrono::seconds(kNow));
  a.restore("alice", t0 - 3000s, 400);  // before the start, still within the hour
  a.charge("alice", 500, t0);
  EXPECT_EQ(a.used("alice", t0), 900);
  try {
    a.charge("alice", 200, t0 + 10s);
    ADD_FAILURE() << "over the allowance";
  } catch (const QuotaExceeded& e) {
    EXPECT_EQ(e.kind(), rv::ErrorKind::over_quota);
    EXPECT_EQ(e.retry_after_s(), 590);  // when the restored 400 age out
  }
  EXPECT_EQ(a.used("alice", t0 + 10s), 900);  // a refusal charges nothing
  a.charge("bob", 1000, t0);                  // every principal its own
  a.charge("alice", 200, t0 + 600s);          // the restored charge has aged out
  EXPECT_EQ(a.used("alice", t0 + 600s), 700);
  a.refund("alice", 200);
  EXPECT_EQ(a.used("alice", t0 + 600s), 500);
  try {
    a.charge("carol", 5000, t0);
    ADD_FAILURE() << "a grid over the whole allowance";
  } catch (const QuotaExceeded& e) {
    EXPECT_EQ(e.retry_after_s(), 3600);
    EXPECT_NE(std::string(e.what()).find("exceed the allowance"), std::string::npos);
  }
  CellAllowance unlimited(0);
  unlimited.charge("alice", int64_t{1} << 40, t0);
  EXPECT_EQ(unlimited.used("alice", t0), int64_t{1} << 40);
}

TEST(Util, Rfc3339RoundTrips) {
  const auto t = std::chrono::system_clock::time_point(std::chrono::milliseconds(int64_t{kNow} * 1000 + 123));
  EXPECT_EQ(rv::daemon::parse_rfc3339(rv::daemon::rfc3339(t)), t);
  for (const char* bad : {"", "2026-01-01", "2026-01-01T00:00:00Z", "2026-01-01T00:00:00.000+01:00", "x"})
    EXPECT_FALSE(rv::daemon::parse_rfc3339(bad).has_value()) << bad;
}

}  // namespace
