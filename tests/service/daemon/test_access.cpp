// Access and per-job limits from the daemon's configuration (issue 8):
//   - auth: bearer tokens from auth.tokens / auth.token_file; every protected route refuses a
//     request without a token, with a wrong one and with another scheme (401 problem+json and
//     WWW-Authenticate: Bearer), and works with a right one; the open routes need none; with no
//     token configured nothing changes; tokens never reach the request log;
//   - limits.max_features / limits.max_vertices: an upload over either is refused with its own
//     422 problem+json while the seeds are read, before any grid is planned or computed.
// A real rv::Server on an ephemeral port with rv::run_job behind it.
#include <fcntl.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "../base64_text.hpp"
#include "daemon/server_auth.hpp"
#include "http_client.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/job.hpp"
#include "rv/server.hpp"
#include "rv/server_config.hpp"

namespace {

using nlohmann::json;
using rv::test::http_request;
using rv::test::Reply;
namespace fs = std::filesystem;

const std::string kToken = "s3cr3t-token-0123456789abcdef";
const std::string kOtherToken = "another-token-from-the-file-42";

std::string source_dir() { return std::getenv("RV_SOURCE_DIR"); }

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string base64(const std::string& bytes) { return rv::test::base64(bytes); }

json demo_seeds() { return json::parse(read_file(source_dir() + "/fixtures/demo_basepoints.geojson")); }

json demo_request(const json& seeds, double resolution = 2000) {
  return {{"inputs", {{"seeds", seeds}, {"ownerField", "state"}, {"resolution", resolution}}}};
}

// The first n demo points.
json first_points(size_t n) {
  json seeds = demo_seeds();
  json& f = seeds["features"];
  f.erase(f.begin() + static_cast<std::ptrdiff_t>(n), f.end());
  return seeds;
}

// One polygon (a regular n-gon around the demo points' centre) owned by "A", and a point of "B".
json polygon_seeds(int vertices) {
  json ring = json::array();
  for (int i = 0; i < vertices; ++i) {
    const double a = 2.0 * 3.141592653589793 * i / vertices;
    ring.push_back({355000.0 + 5000.0 * std::cos(a), 6165000.0 + 5000.0 * std::sin(a)});
  }
  ring.push_back(ring[0]);
  json seeds = demo_seeds();
  seeds["features"] = json::array({{{"type", "Feature"},
                                    {"properties", {{"state", "A"}}},
                                    {"geometry", {{"type", "Polygon"}, {"coordinates", {ring}}}}},
                                   {{"type", "Feature"},
                                    {"properties", {{"state", "B"}}},
                                    {"geometry", {{"type", "Point"}, {"coordinates", {340000.0, 6150000.0}}}}}});
  return seeds;
}

void expect_problem(const Reply& r, unsigned status, const std::string& type_part, const std::string& detail_part) {
  EXPECT_EQ(r.status, status) << r.body;
  EXPECT_EQ(r.header("content-type"), "application/problem+json");
  const json p = json::parse(r.body, nullptr, false);
  ASSERT_TRUE(p.is_object()) << r.body;
  EXPECT_EQ(p["status"], status);
  EXPECT_NE(p["type"].get<std::string>().find(type_part), std::string::npos) << r.body;
  EXPECT_NE(p["detail"].get<std::string>().find(detail_part), std::string::npos) << r.body;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const rv::Error& e) {
    return e.what();
  }
  return "(no error)";
}

class Access : public ::testing::Test {
 protected:
  void SetUp() override {
    rv::gdal_init();
    dir_ = fs::temp_directory_path() / ("rv_access_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    server_.reset();
    fs::remove_all(dir_);
  }
  // A server from a configuration document, exactly as `rvoronoi serve --config` reads it.
  void start(json config) {
    config["listen"] = "127.0.0.1:0";
    config["data_dir"] = (dir_ / "data").string();
    if (!config.contains("jobs")) config["jobs"] = {{"workers", 1}, {"queue_length", 4}, {"threads_per_job", 1}};
    rv::ServerConfig c = rv::parse_server_config(config);
    server_ = std::make_unique<rv::Server>(
        c, [](const rv::JobSpec& s, const rv::JobLimits& l, const rv::JobHooks& h) { return rv::run_job(s, l, h); });
    server_->start();
    port_ = server_->port();
  }
  Reply call(const std::string& method, const std::string& target, const std::string& authorization,
             const std::string& body = "", std::map<std::string, std::string> headers = {}) {
    if (!authorization.empty()) headers["Authorization"] = authorization;
    return http_request(port_, method, target, body, headers);
  }
  fs::path dir_;
  std::unique_ptr<rv::Server> server_;
  unsigned short port_ = 0;
};

TEST(AccessConfig, TokensFromTheListAndTheFile) {
  const fs::path file = fs::temp_directory_path() / ("rv_tokens_" + std::to_string(::getpid()));
  {
    std::ofstream out(file);
    out << "# tokens of the GIS pipeline\n\n  " << kOtherToken << "  \r\n";
  }
  const rv::ServerConfig c =
      rv::parse_server_config(json{{"auth", {{"tokens", {kToken}}, {"token_file", file.string()}}}});
  EXPECT_TRUE(c.auth.enabled());
  // Each plaintext token is one user named by its hash's first 8 hex digits; only hashes are kept.
  ASSERT_EQ(c.auth.principals.size(), 2u);
  EXPECT_EQ(c.auth.deprecated_tokens, 2);
  for (size_t i = 0; i < 2; ++i) {
    const std::string hex = rv::token_sha256_hex(i == 0 ? kToken : kOtherToken);
    EXPECT_EQ(c.auth.principals[i].name, "token-" + hex.substr(0, 8));
    EXPECT_EQ(c.auth.principals[i].role, rv::Role::user);
    std::string stored;
    for (const unsigned char b : c.auth.principals[i].token_sha256) {
      char two[3];
      std::snprintf(two, sizeof two, "%02x", b);
      stored += two;
    }
    EXPECT_EQ(stored, hex);
  }
  EXPECT_FALSE(rv::parse_server_config(json::object()).auth.enabled());
  EXPECT_FALSE(rv::parse_server_config(json{{"auth", {{"tokens", json::array()}}}}).auth.enabled());

  // Mistakes are refused, naming the key, never the token.
  const std::string short_token = error_of([] {
    rv::parse_server_config(json{{"auth", {{"tokens", {"shortsecret"}}}}});
  });
  EXPECT_NE(short_token.find("auth.tokens[0]"), std::string::npos) << short_token;
  EXPECT_EQ(short_token.find("shortsecret"), std::string::npos) << short_token;
  const std::string spaced = error_of([] {
    rv::parse_server_config(json{{"auth", {{"tokens", {"a token with spaces in it"}}}}});
  });
  EXPECT_EQ(spaced.find("with spaces"), std::string::npos) << spaced;
  EXPECT_NE(error_of([] {
              rv::parse_server_config(json{{"auth", {{"token", "x"}}}});
            }).find("auth.token"),
            std::string::npos);
  {
    std::ofstream out(file);
    out << "# only a comment\n";
  }
  EXPECT_NE(error_of([&] {
              rv::parse_server_config(json{{"auth", {{"token_file", file.string()}}}});
            }).find("no token"),
            std::string::npos);
  fs::remove(file);
  try {
    rv::parse_server_config(json{{"auth", {{"token_file", file.string()}}}});
    ADD_FAILURE() << "a missing token file must be refused";
  } catch (const rv::Error& e) {
    EXPECT_EQ(e.kind(), rv::ErrorKind::not_found);
  }
}

TEST(AccessConfig, FeatureAndVertexLimitsAreParsedAndExampleHoldsDefaults) {
  const rv::ServerConfig c = rv::parse_server_config(json{{"limits", {{"max_features", 7}, {"max_vertices", 0}}}});
  EXPECT_EQ(c.limits.max_features, 7);
  EXPECT_EQ(c.limits.max_vertices, 0);
  EXPECT_EQ(rv::effective_limits(c).max_features, 7);
  EXPECT_NE(error_of([] {
              rv::parse_server_config(json{{"limits", {{"max_features", -1}}}});
            }).find("limits.max_features"),
            std::string::npos);
  const rv::ServerConfig e = rv::load_server_config(source_dir() + "/service/serve-config.example.json");
  const rv::ServerConfig d;
  EXPECT_EQ(e.limits.max_features, d.limits.max_features);
  EXPECT_EQ(e.limits.max_vertices, d.limits.max_vertices);
  EXPECT_EQ(e.auth.principals.size(), d.auth.principals.size());
  EXPECT_EQ(e.principal_limits.jobs, d.principal_limits.jobs);
  EXPECT_EQ(e.principal_limits.cells_per_hour, d.principal_limits.cells_per_hour);
}

TEST(AccessUnits, OpenPaths) {
  using rv::daemon::Authenticator;
  for (const char* open : {"/", "", "/conformance", "/api", "/api?f=yaml", "/health", "//health/", "/%61pi"}) {
    EXPECT_TRUE(Authenticator::is_open(open)) << open;
  }
  for (const char* closed : {"/processes", "/jobs", "/api/x", "/healthz", "/conformance/../jobs", "/jobs?x=/api",
                             "/%2Fapi", "/processes/voronoi/execution"}) {
    EXPECT_FALSE(Authenticator::is_open(closed)) << closed;
  }
}

TEST_F(Access, BearerTokensGuardEveryRouteButTheOpenOnes) {
  const fs::path file = dir_ / "tokens";
  {
    std::ofstream out(file);
    out << kOtherToken << "\n";
  }
  // The request log goes to stderr: capture it, to show that no token is ever written.
  const fs::path log = dir_ / "stderr.log";
  fflush(stderr);
  const int saved = ::dup(2);
  const int log_fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  ASSERT_GE(log_fd, 0);
  ::dup2(log_fd, 2);
  ::close(log_fd);

  start({{"auth", {{"tokens", {kToken}}, {"token_file", file.string()}}}, {"http", {{"max_body_bytes", 1 << 20}}}});
  const std::string good = "Bearer " + kToken;
  const std::string body = demo_request(demo_seeds()).dump();

  // A finished job, made with the token, for the job routes.
  const Reply made = call("POST", "/processes/voronoi/execution", good, body, {{"Prefer", "respond-async"}});
  ASSERT_EQ(made.status, 201) << made.body;
  const std::string id = made.json()["jobID"];
  for (int i = 0; i < 500; ++i) {
    const Reply s = call("GET", "/jobs/" + id, good);
    if (s.json()["status"] != "accepted" && s.json()["status"] != "running") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_EQ(call("GET", "/jobs/" + id, good).json()["status"], "successful");

  struct Route {
    std::string method, target, body;
    unsigned ok;  // the status with a valid token
  };
  const std::vector<Route> protected_routes = {
      {"GET", "/processes", "", 200},
      {"GET", "/processes/voronoi", "", 200},
      {"POST", "/processes/voronoi/execution", body, 200},
      {"GET", "/jobs", "", 200},
      {"GET", "/jobs?limit=1", "", 200},
      {"GET", "/jobs/" + id, "", 200},
      {"HEAD", "/jobs/" + id, "", 200},
      {"GET", "/jobs/" + id + "/results", "", 200},
      {"GET", "/jobs/" + id + "/results/ownership", "", 200},
      {"GET", "/jobs/" + id + "/results/ownership.aux.xml", "", 200},
      {"GET", "/jobs/0123456789abcdef0123456789abcdef", "", 404},  // no hint without a token
      {"GET", "/no/such/resource", "", 404},
      {"DELETE", "/jobs/" + id, "", 200},  // last: it dismisses the job
  };
  for (const Route& r : protected_routes) {
    SCOPED_TRACE(r.method + " " + r.target);
    for (const std::string& auth : {std::string(), "Bearer " + kToken.substr(0, kToken.size() - 1) + "X",
                                    std::string("Bearer"), "Basic " + kToken, "Bearer " + kToken + kToken}) {
      SCOPED_TRACE("Authorization: " + auth);
      const Reply refused = call(r.method, r.target, auth, r.body);
      EXPECT_EQ(refused.status, 401u) << refused.body;
      const std::string challenge = refused.header("www-authenticate");
      EXPECT_EQ(challenge.rfind("Bearer realm=\"rvoronoi\"", 0), 0u) << challenge;
      if (auth.rfind("Bearer ", 0) == 0) {
        EXPECT_NE(challenge.find("invalid_token"), std::string::npos) << challenge;
      }
      if (r.method != "HEAD") {
        expect_problem(refused, 401, "unauthorized", auth.empty() ? "needs a bearer token" : "");
        EXPECT_EQ(refused.body.find(kToken), std::string::npos);
      }
    }
    EXPECT_EQ(call(r.method, r.target, good, r.body).status, r.ok);
    // Any configured token works, also with the scheme in another case and extra spaces; each
    // is its own principal (issue 52), to which the first token's job does not exist.
    if (r.method == "GET") {
      const bool its_job = r.target.rfind("/jobs/" + id, 0) == 0;
      EXPECT_EQ(call(r.method, r.target, "bearer   " + kOtherToken, r.body).status, its_job ? 404u : r.ok);
    }
  }
  // An unauthenticated upload is refused from its header: 401, not the 413 of its size.
  EXPECT_EQ(call("POST", "/processes/voronoi/execution", "", std::string(4 << 20, 'x')).status, 401u);
  EXPECT_EQ(call("POST", "/processes/voronoi/execution", good, std::string(4 << 20, 'x')).status, 413u);

  for (const char* target : {"/", "/conformance", "/api", "/health", "/health?x=1"}) {
    SCOPED_TRACE(target);
    EXPECT_EQ(call("GET", target, "").status, 200u);
    EXPECT_EQ(call("GET", target, "Bearer wrong-but-ignored-here").status, 200u);
  }

  server_.reset();  // stops: every log line is written
  fflush(stderr);
  ::dup2(saved, 2);
  ::close(saved);
  const std::string logged = read_file(log);
  EXPECT_NE(logged.find("\"status\":401"), std::string::npos) << "the refusals are logged";
  EXPECT_NE(logged.find("\"auth\":\"bearer\""), std::string::npos) << "startup says authentication is on";
  EXPECT_EQ(logged.find(kToken.substr(0, 12)), std::string::npos) << "a token was logged";
  EXPECT_EQ(logged.find(kOtherToken.substr(0, 12)), std::string::npos) << "a token was logged";
}

TEST_F(Access, WithoutTokensNothingChanges) {
  start(json::object());
  const std::string body = demo_request(demo_seeds()).dump();
  for (const std::string& auth : {std::string(), std::string("Bearer whatever-the-client-sends")}) {
    SCOPED_TRACE(auth);
    EXPECT_EQ(call("GET", "/processes", auth).status, 200u);
    EXPECT_EQ(call("GET", "/jobs", auth).status, 200u);
    const Reply r = call("POST", "/processes/voronoi/execution", auth, body);
    ASSERT_EQ(r.status, 200u) << r.body;
    const std::string href = r.json()["ownership"]["href"];
    const std::string path = href.substr(href.find("/jobs/"));
    EXPECT_EQ(call("GET", path, auth).status, 200u);
    EXPECT_EQ(call("GET", "/", auth).status, 200u);
  }
}

TEST_F(Access, FeatureAndVertexLimitsFromTheConfigRefuseUploadsBeforeComputing) {
  // A grid of 1e8 cells (10 km x 10 km at 1 m) is within max_cells: had the seed limits not
  // stopped the reading, these jobs would go on to plan and compute that grid (or be refused
  // for its memory, with another message) instead of failing in the read stage.
  const json huge_grid = {{"bbox", {340000, 6150000, 350000, 6160000}}};
  start({{"limits", {{"max_features", 5}, {"max_vertices", 40}}}});

  json over_features = demo_request(demo_seeds(), 1.0);  // 28 points
  over_features["inputs"]["extent"] = huge_grid;
  const Reply f = call("POST", "/processes/voronoi/execution", "", over_features.dump());
  expect_problem(f, 422, "too-large", "more than 5 features, the limit");

  json over_vertices = demo_request(polygon_seeds(60), 1.0);  // 2 features, 62 vertices
  over_vertices["inputs"]["extent"] = huge_grid;
  const Reply v = call("POST", "/processes/voronoi/execution", "", over_vertices.dump());
  expect_problem(v, 422, "too-large", "more than 40 vertices, the limit");

  // A binary upload (GeoPackage: the count is known before any feature is read).
  const json gpkg = {{"inputs",
                      {{"seeds",
                        {{"value", base64(read_file(source_dir() + "/fixtures/coast.gpkg"))},
                         {"mediaType", "application/geopackage+sqlite3"},
                         {"encoding", "base64"}}},
                       {"ownerField", "owner"},
                       {"resolution", 1.0}}}};
  expect_problem(call("POST", "/processes/voronoi/execution", "", gpkg.dump()), 422, "too-large",
                 "features, the limit");

  // Asynchronously: the job fails in its read stage, its status naming the limit.
  const Reply a = call("POST", "/processes/voronoi/execution", "", over_features.dump(), {{"Prefer", "respond-async"}});
  ASSERT_EQ(a.status, 201u) << a.body;
  const std::string id = a.json()["jobID"];
  json st;
  for (int i = 0; i < 500; ++i) {
    st = call("GET", "/jobs/" + id, "").json();
    if (st["status"] == "failed" || st["status"] == "successful") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(st["status"], "failed");
  EXPECT_LT(st["progress"].get<int>(), 10) << "failed in the read stage, before computing";
  EXPECT_NE(st["message"].get<std::string>().find("more than 5 features"), std::string::npos) << st;
  expect_problem(call("GET", "/jobs/" + id + "/results", ""), 422, "too-large", "more than 5 features");

  // Within both limits the same kind of job computes.
  EXPECT_EQ(call("POST", "/processes/voronoi/execution", "", demo_request(first_points(5)).dump()).status, 200u);
  EXPECT_EQ(call("POST", "/processes/voronoi/execution", "", demo_request(polygon_seeds(30)).dump()).status, 200u);
}

}  // namespace
