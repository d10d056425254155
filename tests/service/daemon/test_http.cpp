// HTTP contract tests of the daemon: a real rv::Server on an ephemeral port, run_job behind it,
// a Beast client in front. Results are read back through GDAL and compared, cell by cell, with
// what the façade writes for the same inputs.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "http_client.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/job.hpp"
#include "rv/server.hpp"
#include "rv/store_jobs.hpp"

namespace {

using nlohmann::json;
using rv::test::http_request;
using rv::test::Reply;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

const std::string kOgc = "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/";

std::string source_dir() {
  const char* s = std::getenv("RV_SOURCE_DIR");
  return s ? s : RV_TEST_SOURCE_DIR;
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_file(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out << bytes;
}

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("rv_service_http_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

json demo_seeds() { return json::parse(read_file(source_dir() + "/fixtures/demo_basepoints.geojson")); }

json demo_request(double resolution = 2000) {
  return {{"inputs", {{"seeds", demo_seeds()}, {"ownerField", "state"}, {"resolution", resolution}}}};
}

rv::ServerConfig test_config(const fs::path& data_dir) {
  rv::ServerConfig c;
  c.port = 0;
  c.data_dir = data_dir.string();
  c.jobs.workers = 1;
  c.jobs.queue_length = 4;
  c.jobs.threads_per_job = 1;
  c.jobs.shutdown_grace_s = 0.5;
  c.http.request_timeout_s = 5;
  return c;
}

rv::JobRunner real_runner() {
  return [](const rv::JobSpec& s, const rv::JobLimits& l, const rv::JobHooks& h) { return rv::run_job(s, l, h); };
}

Reply get(unsigned short port, const std::string& target, const std::map<std::string, std::string>& h = {}) {
  return http_request(port, "GET", target, "", h);
}

std::string path_of(const std::string& href) {
  const auto p = href.find("://");
  return href.substr(href.find('/', p + 3));
}

json wait_for(unsigned short port, const std::string& id, const std::set<std::string>& states, double seconds) {
  const auto until = Clock::now() + std::chrono::duration<double>(seconds);
  json s;
  while (Clock::now() < until) {
    s = get(port, "/jobs/" + id).json();
    if (states.count(s["status"].get<std::string>())) return s;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ADD_FAILURE() << "job " << id << " still " << s.dump();
  return s;
}

void expect_problem(const Reply& r, unsigned status, const std::string& type, const std::string& detail_part = "") {
  EXPECT_EQ(r.status, status) << r.body;
  EXPECT_EQ(r.header("content-type"), "application/problem+json");
  const json p = json::parse(r.body, nullptr, false);
  ASSERT_TRUE(p.is_object()) << r.body;
  EXPECT_EQ(p["status"], status);
  EXPECT_EQ(p["type"], type) << r.body;
  EXPECT_TRUE(p.contains("title"));
  if (!detail_part.empty()) {
    EXPECT_NE(p["detail"].get<std::string>().find(detail_part), std::string::npos) << p["detail"];
  }
}

// The same job through the façade directly: the reference the daemon's files must equal.
struct Reference {
  rv::Raster<int32_t> ownership;
  rv::Raster<float> distance;
};

Reference facade_reference(const fs::path& dir, double resolution) {
  rv::JobSpec spec;
  spec.seeds.paths = {source_dir() + "/fixtures/demo_basepoints.geojson"};
  spec.seeds.owner_field = "state";
  spec.grid.resolution = resolution;
  spec.threads = 1;
  spec.outputs.ownership = (dir / "ref_ownership.tif").string();
  spec.outputs.distance = (dir / "ref_distance.tif").string();
  spec.outputs.cloud_optimized = true;
  rv::run_job(spec);
  return {rv::read_int32(spec.outputs.ownership), rv::read_float32(spec.outputs.distance)};
}

class Daemon : public ::testing::Test {
 protected:
  void start(rv::ServerConfig config, rv::JobRunner runner = real_runner()) {
    config_ = config;
    server_ = std::make_unique<rv::Server>(config, std::move(runner));
    server_->start();
    port_ = server_->port();
  }
  void SetUp() override {
    rv::gdal_init();
    dir_ = fresh_dir(::testing::UnitTest::GetInstance()->current_test_info()->name());
  }
  void TearDown() override {
    server_.reset();
    fs::remove_all(dir_);
  }
  fs::path dir_;
  rv::ServerConfig config_;
  std::unique_ptr<rv::Server> server_;
  unsigned short port_ = 0;
};

TEST_F(Daemon, DiscoveryEndpoints) {
  start(test_config(dir_ / "data"));
  const Reply landing = get(port_, "/");
  ASSERT_EQ(landing.status, 200);
  EXPECT_EQ(landing.header("content-type"), "application/json");
  std::set<std::string> rels;
  const json landing_doc = landing.json();
  for (const json& l : landing_doc["links"]) rels.insert(l["rel"].get<std::string>());
  for (const char* rel :
       {"self", "service-desc", "http://www.opengis.net/def/rel/ogc/1.0/conformance",
        "http://www.opengis.net/def/rel/ogc/1.0/processes", "http://www.opengis.net/def/rel/ogc/1.0/job-list"}) {
    EXPECT_TRUE(rels.count(rel)) << rel;
  }
  const json conf = get(port_, "/conformance").json();
  EXPECT_NE(std::find(conf["conformsTo"].begin(), conf["conformsTo"].end(),
                      "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/core"),
            conf["conformsTo"].end());
  const Reply api = get(port_, "/api");
  EXPECT_EQ(api.status, 200);
  EXPECT_EQ(api.body, read_file(source_dir() + "/openapi.yaml"));  // the repository's document, verbatim
  const json processes = get(port_, "/processes").json();
  ASSERT_EQ(processes["processes"].size(), 2u);
  EXPECT_EQ(processes["processes"][0]["id"], "voronoi");
  EXPECT_EQ(processes["processes"][1]["id"], "describe-seeds");
  const json describe = get(port_, "/processes/describe-seeds").json();
  for (const char* input : {"seeds", "crs", "features"}) EXPECT_TRUE(describe["inputs"].contains(input)) << input;
  EXPECT_EQ(describe["jobControlOptions"], json::array({"sync-execute"}));
  const json process = get(port_, "/processes/voronoi").json();
  for (const char* input : {"seeds", "ownerField", "resolution", "extent", "crs", "metric", "method", "maxDistance",
                            "distanceUnits", "validate"}) {
    EXPECT_TRUE(process["inputs"].contains(input)) << input;
    EXPECT_TRUE(process["inputs"][input].contains("schema")) << input;
  }
  for (const char* output : {"ownership", "distance", "report"}) EXPECT_TRUE(process["outputs"].contains(output));
  const json health = get(port_, "/health").json();
  EXPECT_EQ(health["status"], "ok");
  EXPECT_EQ(health["jobs"]["running"], 0);
  EXPECT_EQ(health["results"], json({{"kind", "folder"}, {"reachable", true}}));
  EXPECT_EQ(health["store"], json({{"kind", "sqlite"}, {"reachable", true}}));
  EXPECT_GT(health["disk"]["freeBytes"].get<int64_t>(), 0);
  EXPECT_EQ(health["disk"]["low"], false);

  expect_problem(get(port_, "/processes/nope"), 404, kOgc + "no-such-process");
  expect_problem(get(port_, "/jobs/0123456789abcdef0123456789abcdef"), 404, kOgc + "no-such-job");
  expect_problem(get(port_, "/jobs/..%2F..%2Fetc"), 404, kOgc + "no-such-job");
  expect_problem(get(port_, "/nothing/here"), 404,
                 "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/not-found");
  const Reply wrong = http_request(port_, "DELETE", "/processes");
  EXPECT_EQ(wrong.status, 405);
  EXPECT_EQ(wrong.header("allow"), "GET, HEAD");
  EXPECT_EQ(http_request(port_, "GET", "/processes/voronoi/execution").status, 405);
}

// If-None-Match on an asset is RFC 9110's weak comparison of a list: the ETag (weak) or its
// strong form, or "*", answers 304; a field that merely contains the ETag is no list, 200.
TEST_F(Daemon, StaticAssetsAnswer304OnlyToAnIfNoneMatchThatNamesThem) {
  rv::ServerConfig c = test_config(dir_ / "data");
  c.web_dir = (dir_ / "web").string();
  fs::create_directories(c.web_dir);
  write_file(dir_ / "web" / "a.js", "console.log(1);\n");
  start(c);
  const Reply first = get(port_, "/static/a.js");
  ASSERT_EQ(first.status, 200);
  EXPECT_EQ(first.body, "console.log(1);\n");
  const std::string etag = first.header("etag");
  ASSERT_EQ(etag.rfind("W/\"", 0), 0u) << etag;
  const std::string strong = etag.substr(2);
  for (const std::string& h : {etag, strong, std::string("*"), "\"x\", " + etag, "\"x\"," + strong}) {
    const Reply r = get(port_, "/static/a.js", {{"If-None-Match", h}});
    EXPECT_EQ(r.status, 304) << h;
    EXPECT_TRUE(r.body.empty()) << h;
    EXPECT_EQ(r.header("etag"), etag) << h;
  }
  // A list split over two header lines is one list (RFC 9110 5.3).
  {
    namespace net = boost::asio;
    net::io_context ioc;
    net::ip::tcp::socket socket(ioc);
    socket.connect({net::ip::make_address("127.0.0.1"), port_});
    const std::string request =
        "GET /static/a.js HTTP/1.1\r\nHost: 127.0.0.1\r\nIf-None-Match: \"x\"\r\nIf-None-Match: " + etag +
        "\r\nConnection: close\r\n\r\n";
    net::write(socket, net::buffer(request));
    std::string answer;
    boost::system::error_code ec;
    net::read(socket, net::dynamic_buffer(answer), ec);  // to the end: the server closes
    EXPECT_EQ(answer.rfind("HTTP/1.1 304", 0), 0u) << answer.substr(0, 200);
  }
  for (const std::string& h : {"\"x\", garbage" + etag, "xx" + etag + "xx", etag + "x", std::string("\"x\"")}) {
    const Reply r = get(port_, "/static/a.js", {{"If-None-Match", h}});
    EXPECT_EQ(r.status, 200) << h;
    EXPECT_EQ(r.body, "console.log(1);\n") << h;
  }
}

// Process descriptions carry a strong ETag (issue 53: the QGIS provider caches them) and answer
// 304 to an If-None-Match that names it; another process or a changed tag gets the document.
TEST_F(Daemon, ProcessDescriptionsAreValidated) {
  start(test_config(dir_ / "data"));
  for (const std::string path : {"/processes", "/processes/voronoi", "/processes/describe-seeds"}) {
    const Reply first = get(port_, path);
    ASSERT_EQ(first.status, 200) << path;
    const std::string etag = first.header("etag");
    ASSERT_EQ(etag.size(), 34u) << etag;
    ASSERT_EQ(etag.front(), '"');
    EXPECT_EQ(get(port_, path).header("etag"), etag) << "the same document, the same tag";
    const Reply again = get(port_, path, {{"If-None-Match", etag}});
    EXPECT_EQ(again.status, 304) << path;
    EXPECT_TRUE(again.body.empty());
    EXPECT_EQ(get(port_, path, {{"If-None-Match", "\"0123\""}}).status, 200) << path;
  }
  EXPECT_NE(get(port_, "/processes/voronoi").header("etag"), get(port_, "/processes/describe-seeds").header("etag"));
}

TEST_F(Daemon, SyncExecutionEqualsTheFacade) {
  start(test_config(dir_ / "data"));
  const Reference ref = facade_reference(dir_, 2000);

  const Reply r = http_request(port_, "POST", "/processes/voronoi/execution", demo_request().dump());
  ASSERT_EQ(r.status, 200) << r.body;
  const json doc = r.json();
  ASSERT_TRUE(doc.contains("ownership") && doc.contains("distance") && doc.contains("report")) << doc;
  EXPECT_EQ(doc["report"]["mediaType"], "application/json");
  EXPECT_EQ(doc["report"]["value"]["grid"]["width"], ref.ownership.width());
  EXPECT_EQ(doc["report"]["value"]["outputs"]["ownership"], "ownership.tif");  // no server paths
  EXPECT_NE(r.header("link").find("rel=\"monitor\""), std::string::npos);

  const Reply own = get(port_, path_of(doc["ownership"]["href"]));
  ASSERT_EQ(own.status, 200);
  EXPECT_EQ(own.header("content-type"), "image/tiff; application=geotiff; profile=cloud-optimized");
  EXPECT_EQ(own.header("accept-ranges"), "bytes");
  write_file(dir_ / "own.tif", own.body);
  EXPECT_EQ(rv::read_int32((dir_ / "own.tif").string()), ref.ownership);
  const Reply dist = get(port_, path_of(doc["distance"]["href"]));
  write_file(dir_ / "dist.tif", dist.body);
  EXPECT_EQ(rv::read_float32((dir_ / "dist.tif").string()), ref.distance);

  // The attribute table's sidecar sits next to the file, for /vsicurl/ readers.
  const std::string id = path_of(doc["ownership"]["href"]).substr(6, 32);
  const Reply aux = get(port_, "/jobs/" + id + "/results/ownership.aux.xml");
  ASSERT_EQ(aux.status, 200);
  EXPECT_NE(aux.body.find("GDALRasterAttributeTable"), std::string::npos);
  write_file(dir_ / "own.tif.aux.xml", aux.body);
  EXPECT_EQ(rv::read_category_labels((dir_ / "own.tif").string()), (std::vector<std::string>{"A", "B", "C"}));

  // Raw: the one requested output's bytes as the response body.
  json raw = demo_request();
  raw["outputs"] = {{"ownership", json::object()}};
  raw["response"] = "raw";
  const Reply bytes = http_request(port_, "POST", "/processes/voronoi/execution", raw.dump());
  ASSERT_EQ(bytes.status, 200);
  EXPECT_EQ(bytes.header("content-type"), "image/tiff; application=geotiff; profile=cloud-optimized");
  write_file(dir_ / "raw.tif", bytes.body);
  EXPECT_EQ(rv::read_int32((dir_ / "raw.tif").string()), ref.ownership);
}

TEST_F(Daemon, AsyncExecutionRangesAndJobList) {
  start(test_config(dir_ / "data"));
  const Reference ref = facade_reference(dir_, 2000);
  const Reply created =
      http_request(port_, "POST", "/processes/voronoi/execution", demo_request().dump(), {{"Prefer", "respond-async"}});
  ASSERT_EQ(created.status, 201) << created.body;
  const json s0 = created.json();
  const std::string id = s0["jobID"];
  EXPECT_EQ(created.header("location"), "http://127.0.0.1:" + std::to_string(port_) + "/jobs/" + id);
  EXPECT_TRUE(s0["status"] == "accepted" || s0["status"] == "running") << s0;
  EXPECT_EQ(s0["type"], "process");
  EXPECT_EQ(s0["processID"], "voronoi");

  const json done = wait_for(port_, id, {"successful", "failed"}, 60);
  ASSERT_EQ(done["status"], "successful") << done;
  EXPECT_EQ(done["progress"], 100);
  for (const char* t : {"created", "started", "finished", "updated"}) EXPECT_TRUE(done.contains(t)) << t;
  EXPECT_LE(done["created"].get<std::string>(), done["started"].get<std::string>());
  EXPECT_LE(done["started"].get<std::string>(), done["finished"].get<std::string>());
  bool results_link = false;
  for (const json& l : done["links"]) results_link |= l["rel"] == "http://www.opengis.net/def/rel/ogc/1.0/results";
  EXPECT_TRUE(results_link);

  const json results = get(port_, "/jobs/" + id + "/results").json();
  const std::string own_path = path_of(results["ownership"]["href"]);
  const Reply whole = get(port_, own_path);
  ASSERT_EQ(whole.status, 200);
  write_file(dir_ / "own.tif", whole.body);
  EXPECT_EQ(rv::read_int32((dir_ / "own.tif").string()), ref.ownership);
  EXPECT_FALSE(whole.header("etag").empty());
  EXPECT_FALSE(whole.header("last-modified").empty());

  const size_t size = whole.body.size();
  const Reply part = get(port_, own_path, {{"Range", "bytes=100-299"}});
  EXPECT_EQ(part.status, 206);
  EXPECT_EQ(part.body, whole.body.substr(100, 200));
  EXPECT_EQ(part.header("content-range"), "bytes 100-299/" + std::to_string(size));
  const Reply tail = get(port_, own_path, {{"Range", "bytes=-10"}});
  EXPECT_EQ(tail.status, 206);
  EXPECT_EQ(tail.body, whole.body.substr(size - 10));
  const Reply open_end = get(port_, own_path, {{"Range", "bytes=" + std::to_string(size - 5) + "-"}});
  EXPECT_EQ(open_end.body, whole.body.substr(size - 5));
  const Reply outside =
      get(port_, own_path, {{"Range", "bytes=" + std::to_string(size) + "-" + std::to_string(size + 10)}});
  EXPECT_EQ(outside.status, 416);
  EXPECT_EQ(outside.header("content-range"), "bytes */" + std::to_string(size));
  const Reply head = http_request(port_, "HEAD", own_path);
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(head.header("content-length"), std::to_string(size));
  EXPECT_TRUE(head.body.empty());

  const json report = get(port_, "/jobs/" + id + "/results/report").json();
  EXPECT_EQ(report["grid"]["height"], ref.ownership.height());

  const json list = get(port_, "/jobs").json();
  ASSERT_FALSE(list["jobs"].empty());
  EXPECT_EQ(list["jobs"][0]["jobID"], id);
  EXPECT_EQ(get(port_, "/jobs?status=failed").json()["jobs"].size(), 0u);
  EXPECT_EQ(get(port_, "/jobs?limit=0").status, 400);
}

TEST_F(Daemon, ErrorsAreProblemsNamingTheInput) {
  rv::ServerConfig c = test_config(dir_ / "data");
  c.limits.max_cells = 1'000'000;
  c.limits.validate_max_cells = 1000;
  start(c);
  const std::string exec = "/processes/voronoi/execution";
  expect_problem(http_request(port_, "POST", exec, "{not json"), 400,
                 "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/invalid-parameter");
  json bad = demo_request();
  bad["inputs"]["resolution"] = -5;
  expect_problem(http_request(port_, "POST", exec, bad.dump()), 400,
                 "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/invalid-parameter",
                 "input 'resolution'");
  json bad_compression = demo_request();
  bad_compression["inputs"]["compression"] = "lzw";
  expect_problem(http_request(port_, "POST", exec, bad_compression.dump()), 400,
                 "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/invalid-parameter",
                 "input 'compression': must be one of fast, small, deflate, none, got 'lzw'");
  // The feature at fault, named by the seed reader, reaches the client with the input's name.
  json null_owner = {{"inputs",
                      {{"seeds", json::parse(read_file(source_dir() + "/fixtures/null_owner.geojson"))},
                       {"ownerField", "owner"},
                       {"resolution", 1000}}}};
  const Reply r = http_request(port_, "POST", exec, null_owner.dump());
  expect_problem(r, 400, "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/invalid-input", "seeds[0]");
  EXPECT_NE(r.body.find("fid"), std::string::npos) << r.body;
  EXPECT_EQ(r.body.find("/vsimem"), std::string::npos) << r.body;
  // Over the grid limits: 422, from the estimate, before any allocation.
  expect_problem(http_request(port_, "POST", exec, demo_request(1).dump()), 422,
                 "https://rvoronoi.dev/problems/too-large");
  // Async: the job fails, its results answer with the same problem.
  const Reply a = http_request(port_, "POST", exec, demo_request(1).dump(), {{"Prefer", "respond-async"}});
  ASSERT_EQ(a.status, 201);
  const std::string id = a.json()["jobID"];
  const json failed = wait_for(port_, id, {"failed"}, 30);
  EXPECT_NE(failed["message"].get<std::string>().find("cells"), std::string::npos) << failed;
  expect_problem(get(port_, "/jobs/" + id + "/results"), 422, "https://rvoronoi.dev/problems/too-large");
  expect_problem(get(port_, "/jobs/" + id + "/results/ownership"), 422, "https://rvoronoi.dev/problems/too-large");
  // validate over its own limit.
  json v = demo_request(200);
  v["inputs"]["validate"] = true;
  expect_problem(http_request(port_, "POST", exec, v.dump()), 422, "https://rvoronoi.dev/problems/too-large",
                 "validate");
  // Known before queuing when the extent is given: refused without creating a job.
  v["inputs"]["extent"] = {330000, 6140000, 380000, 6200000};
  const size_t jobs_before = get(port_, "/jobs").json()["jobs"].size();
  expect_problem(http_request(port_, "POST", exec, v.dump(), {{"Prefer", "respond-async"}}), 422,
                 "https://rvoronoi.dev/problems/too-large", "input 'validate'");
  EXPECT_EQ(get(port_, "/jobs").json()["jobs"].size(), jobs_before);
}

// A baseJob that names no job is a bad input of the execution request (400, naming it), not a
// missing resource: the resource requested (the process) exists. A job resource that does not
// exist stays 404.
TEST_F(Daemon, AnUnknownBaseJobIsABadInputNamedInThe400) {
  start(test_config(dir_ / "data"));
  const std::string unknown(32, 'f');
  json edit = demo_request();
  edit["inputs"]["baseJob"] = unknown;
  for (const char* prefer : {"", "respond-async"}) {
    std::map<std::string, std::string> headers;
    if (*prefer) headers["Prefer"] = prefer;
    expect_problem(http_request(port_, "POST", "/processes/voronoi/execution", edit.dump(), headers), 400,
                   kOgc + "invalid-parameter", "input 'baseJob': no job " + unknown);
  }
  EXPECT_EQ(get(port_, "/jobs").json()["jobs"].size(), 0u) << "a refused edit leaves no job";
  expect_problem(get(port_, "/jobs/" + unknown), 404, kOgc + "no-such-job");
}

TEST_F(Daemon, DismissCancelsARunningJobAndAFullQueueIsBusy) {
  rv::ServerConfig c = test_config(dir_ / "data");
  c.jobs.queue_length = 0;  // one worker, nothing waits: a second job is refused
  start(c);
  json slow = demo_request(10);  // ~21 million cells
  slow["inputs"]["method"] = "brute-force";
  const Reply created =
      http_request(port_, "POST", "/processes/voronoi/execution", slow.dump(), {{"Prefer", "respond-async"}});
  ASSERT_EQ(created.status, 201) << created.body;
  const std::string id = created.json()["jobID"];
  const json running = wait_for(port_, id, {"running", "successful", "failed"}, 30);
  ASSERT_EQ(running["status"], "running") << running;
  // Progress moves while the engine computes (JobHooks.progress, stage "compute" from 10 %).
  json later = running;
  for (auto until = Clock::now() + std::chrono::seconds(20); Clock::now() < until && later["progress"] <= 10;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    later = get(port_, "/jobs/" + id).json();
  }
  EXPECT_GT(later["progress"], 10) << later;
  EXPECT_LT(later["progress"], 100) << later;
  EXPECT_EQ(later["status"], "running");
  expect_problem(get(port_, "/jobs/" + id + "/results"), 404, kOgc + "result-not-ready");
  expect_problem(http_request(port_, "POST", "/processes/voronoi/execution", demo_request().dump()), 503,
                 "https://rvoronoi.dev/problems/busy");

  const auto t0 = Clock::now();
  const Reply dismissed = http_request(port_, "DELETE", "/jobs/" + id);
  ASSERT_EQ(dismissed.status, 200) << dismissed.body;
  EXPECT_EQ(dismissed.json()["status"], "dismissed");
  // The computation stops through JobHooks::cancel: the worker is free again soon.
  while (get(port_, "/health").json()["jobs"]["running"] != 0 && Clock::now() - t0 < std::chrono::seconds(20)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(get(port_, "/health").json()["jobs"]["running"], 0);
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(5)) << "cancellation took too long";
  EXPECT_FALSE(fs::exists(dir_ / "data" / "jobs" / id));
  EXPECT_EQ(get(port_, "/jobs/" + id).json()["status"], "dismissed");
  expect_problem(get(port_, "/jobs/" + id + "/results"), 404, kOgc + "no-such-job");
  // The worker takes jobs again; dismissing a finished job deletes its files.
  const Reply ok = http_request(port_, "POST", "/processes/voronoi/execution", demo_request().dump());
  ASSERT_EQ(ok.status, 200) << ok.body;
  const std::string done_id = path_of(ok.json()["ownership"]["href"]).substr(6, 32);
  EXPECT_TRUE(fs::exists(dir_ / "data" / "jobs" / done_id / "ownership.tif"));
  EXPECT_EQ(http_request(port_, "DELETE", "/jobs/" + done_id).json()["status"], "dismissed");
  EXPECT_FALSE(fs::exists(dir_ / "data" / "jobs" / done_id));
  expect_problem(http_request(port_, "DELETE", "/jobs/0123456789abcdef0123456789abcdef"), 404, kOgc + "no-such-job");
}

TEST_F(Daemon, DismissingASynchronousJobAnswersItsClientWith409) {
  start(test_config(dir_ / "data"));
  json slow = demo_request(10);
  slow["inputs"]["method"] = "brute-force";
  Reply sync_reply;
  std::thread client([&] { sync_reply = http_request(port_, "POST", "/processes/voronoi/execution", slow.dump()); });
  std::string id;
  for (auto until = Clock::now() + std::chrono::seconds(30); Clock::now() < until && id.empty();) {
    const json list = get(port_, "/jobs?status=running").json();
    if (!list["jobs"].empty()) id = list["jobs"][0]["jobID"];
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_FALSE(id.empty());
  EXPECT_EQ(http_request(port_, "DELETE", "/jobs/" + id).status, 200);
  client.join();
  expect_problem(sync_reply, 409, "https://rvoronoi.dev/problems/dismissed", "dismissed");
}

TEST_F(Daemon, TimeLimitAndShutdownCancelRunningJobs) {
  rv::ServerConfig c = test_config(dir_ / "data");
  c.jobs.job_timeout_s = 0.3;
  c.jobs.queue_length = 1;
  start(c);
  json slow = demo_request(10);
  slow["inputs"]["method"] = "brute-force";
  const auto t0 = Clock::now();
  const Reply r = http_request(port_, "POST", "/processes/voronoi/execution", slow.dump());
  expect_problem(r, 422, "https://rvoronoi.dev/problems/too-large", "time limit");
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(10));
  server_.reset();

  // Shutdown: the running job gets the grace period, then is cancelled; the queued one fails.
  c.jobs.job_timeout_s = 3600;
  c.jobs.shutdown_grace_s = 0.2;
  start(c);
  const std::string a =
      http_request(port_, "POST", "/processes/voronoi/execution", slow.dump(), {{"Prefer", "respond-async"}})
          .json()["jobID"];
  const std::string b =
      http_request(port_, "POST", "/processes/voronoi/execution", slow.dump(), {{"Prefer", "respond-async"}})
          .json()["jobID"];
  wait_for(port_, a, {"running"}, 30);
  const auto t1 = Clock::now();
  server_->stop();
  EXPECT_LT(Clock::now() - t1, std::chrono::seconds(10));
  rv::JobStore store(dir_ / "data" / "jobs.sqlite");
  const auto ra = store.get(a);
  const auto rb = store.get(b);
  EXPECT_EQ(ra->status, rv::JobStatus::failed);
  EXPECT_NE(ra->message.find("shut down while the job was running"), std::string::npos) << ra->message;
  EXPECT_EQ(rb->status, rv::JobStatus::failed);
  EXPECT_NE(rb->message.find("before the job started"), std::string::npos) << rb->message;
  EXPECT_FALSE(fs::exists(dir_ / "data" / "jobs" / a));
}

TEST_F(Daemon, RestartServesFinishedJobsAndFailsInterruptedOnes) {
  const fs::path data = dir_ / "data";
  start(test_config(data));
  const Reply r = http_request(port_, "POST", "/processes/voronoi/execution", demo_request().dump());
  ASSERT_EQ(r.status, 200);
  const std::string own_path = path_of(r.json()["ownership"]["href"]);
  const std::string id = own_path.substr(6, 32);
  const std::string before = get(port_, own_path).body;
  server_.reset();

  // What a SIGKILL leaves behind: a job recorded as running, with a partial file.
  rv::JobRecord ghost;
  ghost.id = "00112233445566778899aabbccddeeff";
  ghost.process_id = "voronoi";
  ghost.status = rv::JobStatus::running;
  ghost.created = ghost.started = ghost.updated = "2026-01-01T00:00:00.000Z";
  ghost.outputs = {"ownership"};
  ghost.transmission = {"reference"};
  {
    rv::JobStore store(data / "jobs.sqlite");
    store.insert(ghost);
  }
  fs::create_directories(data / "jobs" / ghost.id);
  write_file(data / "jobs" / ghost.id / ".ownership.tif.tmp", "partial");

  start(test_config(data));
  const json finished = get(port_, "/jobs/" + id).json();
  EXPECT_EQ(finished["status"], "successful");
  EXPECT_EQ(get(port_, own_path).body, before);
  const json interrupted = get(port_, "/jobs/" + ghost.id).json();
  EXPECT_EQ(interrupted["status"], "failed");
  EXPECT_NE(interrupted["message"].get<std::string>().find("server stopped"), std::string::npos) << interrupted;
  EXPECT_TRUE(interrupted.contains("finished"));
  EXPECT_FALSE(fs::exists(data / "jobs" / ghost.id));
  EXPECT_EQ(get(port_, "/jobs/" + ghost.id + "/results").status, 500);
}

TEST_F(Daemon, BodyAndHeaderLimits) {
  rv::ServerConfig c = test_config(dir_ / "data");
  c.http.max_body_bytes = 4096;
  c.http.max_header_bytes = 2048;
  start(c);
  const Reply big = http_request(port_, "POST", "/processes/voronoi/execution", std::string(100'000, ' '));
  expect_problem(big, 413, "https://rvoronoi.dev/problems/payload-too-large");
  const Reply fat = http_request(port_, "GET", "/", "", {{"X-Padding", std::string(4096, 'x')}});
  expect_problem(fat, 431, "https://rvoronoi.dev/problems/request-header-fields-too-large");
  EXPECT_EQ(get(port_, "/health").status, 200);  // and the server is fine
}

// A raw connection for exchanges the Beast client would smooth over.
// A TCP socket connected to the daemon on the loopback; `connected` tells whether it is. With
// `receive_buffer` > 0 the socket's receive buffer is set first (before connecting: it sets the
// window the server sees).
int loopback_socket(unsigned short port, bool& connected, int receive_buffer = 0) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (receive_buffer > 0) ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &receive_buffer, sizeof receive_buffer);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  connected = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  return fd;
}

class RawConnection {
 public:
  explicit RawConnection(unsigned short port) {
    fd_ = loopback_socket(port, connected_);
    timeval tv{5, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  }
  ~RawConnection() { ::close(fd_); }
  bool connected() const { return connected_; }
  void send(const std::string& text) {
    ASSERT_EQ(::send(fd_, text.data(), text.size(), MSG_NOSIGNAL), static_cast<ssize_t>(text.size()));
  }
  // Reads until `marker` has arrived (or the peer closes / 5 s pass).
  std::string read_until(const std::string& marker) {
    std::string out;
    char buf[4096];
    while (out.find(marker) == std::string::npos) {
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) break;
      out.append(buf, static_cast<size_t>(n));
    }
    return out;
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
};

TEST_F(Daemon, ExpectContinueAndOneServerPerDataDirectory) {
  rv::ServerConfig c = test_config(dir_ / "data");
  c.http.max_body_bytes = 1 << 20;
  start(c);
  const std::string body = demo_request().dump();
  RawConnection conn(port_);
  ASSERT_TRUE(conn.connected());
  conn.send(
      "POST /processes/voronoi/execution HTTP/1.1\r\nHost: t\r\nContent-Type: application/json\r\n"
      "Expect: 100-continue\r\nContent-Length: " +
      std::to_string(body.size()) + "\r\n\r\n");
  EXPECT_EQ(conn.read_until("\r\n\r\n").rfind("HTTP/1.1 100 Continue", 0), 0u);
  conn.send(body);
  const std::string answer = conn.read_until("\"report\"");
  EXPECT_EQ(answer.rfind("HTTP/1.1 200", 0), 0u) << answer.substr(0, 200);
  // Over the limit: refused from the header, before the client sends its body.
  RawConnection big(port_);
  big.send(
      "POST /processes/voronoi/execution HTTP/1.1\r\nHost: t\r\nExpect: 100-continue\r\n"
      "Content-Length: 5000000\r\n\r\n");
  EXPECT_EQ(big.read_until("\r\n\r\n").rfind("HTTP/1.1 413", 0), 0u);

  rv::Server second(c, real_runner());
  try {
    second.start();
    ADD_FAILURE() << "a second server started on the same data directory";
  } catch (const rv::Error& e) {
    EXPECT_EQ(e.kind(), rv::ErrorKind::io);
    EXPECT_NE(std::string(e.what()).find("in use"), std::string::npos) << e.what();
  }
  EXPECT_EQ(get(port_, "/health").status, 200);
}

// Opens a connection and sends `text` one byte per `interval`, on its own thread.
class Dribbler {
 public:
  Dribbler(unsigned short port, std::string text, std::chrono::milliseconds interval) {
    fd_ = loopback_socket(port, connected_);
    thread_ = std::thread([this, text, interval] {
      for (char ch : text) {
        if (stop_ || ::send(fd_, &ch, 1, MSG_NOSIGNAL) != 1) {
          closed_by_server_ = !stop_;
          return;
        }
        for (int i = 0; i < 10 && !stop_; ++i) std::this_thread::sleep_for(interval / 10);
      }
    });
  }
  ~Dribbler() {
    stop_ = true;
    thread_.join();
    ::close(fd_);
  }
  bool connected() const { return connected_; }
  // True when the server closes the connection within `timeout` (recv sees end of stream or
  // a reset), false when it is still open then.
  bool closed_by_server(std::chrono::seconds timeout) {
    timeval tv{static_cast<time_t>(timeout.count()), 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    char buf[4096];
    for (;;) {
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n == 0) return true;
      if (n < 0) return errno == ECONNRESET;
    }
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
  std::atomic<bool> stop_{false};
  std::atomic<bool> closed_by_server_{false};
  std::thread thread_;
};

TEST_F(Daemon, SlowClientsDoNotBlockOthersAndAreCutOff) {
  rv::ServerConfig c = test_config(dir_ / "data");
  c.http.io_threads = 1;           // even one network thread serves everybody
  c.http.request_timeout_s = 2.5;  // a request must arrive whole within this
  start(c);
  std::vector<std::unique_ptr<Dribbler>> slow;
  for (int i = 0; i < 5; ++i) {
    slow.push_back(
        std::make_unique<Dribbler>(port_, "GET /health HTTP/1.1\r\nHost: x\r\n\r\n", std::chrono::milliseconds(1000)));
    ASSERT_TRUE(slow.back()->connected());
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  for (int i = 0; i < 5; ++i) {
    const auto t0 = Clock::now();
    const Reply r = get(port_, "/processes");
    EXPECT_EQ(r.status, 200);
    EXPECT_LT(Clock::now() - t0, std::chrono::milliseconds(1000)) << "a normal request waited for slow clients";
  }
  // The deadline covers the whole request, however steadily the bytes come: cut off.
  for (auto& d : slow) EXPECT_TRUE(d->closed_by_server(std::chrono::seconds(5)));
}

// Asks for `target` on a connection whose receive buffer is small, reads the answer `chunk`
// bytes at a time with `pause` between reads, and after `stall_after` bytes (0 = never) stops
// reading for `stall`. Ends when the answer is whole (its Content-Length) or the server ends the
// connection.
struct SlowRead {
  std::string bytes;  // what arrived, header and body
  bool whole = false;
  double seconds = 0.0;
};

SlowRead slow_read(unsigned short port, const std::string& target, size_t chunk, std::chrono::milliseconds pause,
                   size_t stall_after = 0, std::chrono::milliseconds stall = {}) {
  SlowRead out;
  bool connected = false;
  const int fd = loopback_socket(port, connected, 32 * 1024);
  if (!connected) {
    ::close(fd);
    ADD_FAILURE() << "cannot connect";
    return out;
  }
  const std::string request = "GET " + target + " HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n";
  EXPECT_EQ(::send(fd, request.data(), request.size(), MSG_NOSIGNAL), static_cast<ssize_t>(request.size()));
  timeval tv{30, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  const auto t0 = Clock::now();
  std::vector<char> buf(chunk);
  size_t expected = 0;  // header and body, once the header is in
  bool stalled = false;
  for (;;) {
    const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
    if (n <= 0) break;  // the end, or a reset
    out.bytes.append(buf.data(), static_cast<size_t>(n));
    if (expected == 0) {
      const size_t end = out.bytes.find("\r\n\r\n");
      const size_t cl = out.bytes.find("Content-Length: ");
      if (end != std::string::npos && cl != std::string::npos && cl < end)
        expected = end + 4 + std::stoull(out.bytes.substr(cl + 16, out.bytes.find("\r\n", cl) - cl - 16));
    }
    if (expected != 0 && out.bytes.size() >= expected) break;
    if (stall_after != 0 && !stalled && out.bytes.size() >= stall_after) {
      stalled = true;
      std::this_thread::sleep_for(stall);
    }
    std::this_thread::sleep_for(pause);
  }
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  out.whole = expected != 0 && out.bytes.size() == expected;
  ::close(fd);
  return out;
}

// A finished job's ownership file replaced by `bytes` pseudo-random bytes: a large result to
// download. Returns its path on the server.
std::string large_result(unsigned short port, const fs::path& data_dir, size_t bytes) {
  const Reply created =
      http_request(port, "POST", "/processes/voronoi/execution", demo_request().dump(), {{"Prefer", "respond-async"}});
  EXPECT_EQ(created.status, 201) << created.body;
  const std::string id = created.json()["jobID"];
  EXPECT_EQ(wait_for(port, id, {"successful", "failed"}, 60)["status"], "successful");
  const std::string target = path_of(get(port, "/jobs/" + id + "/results").json()["ownership"]["href"]);
  const size_t size = get(port, target).body.size();
  std::vector<fs::path> files;
  for (const auto& e : fs::recursive_directory_iterator(data_dir))
    if (e.is_regular_file() && e.path().string().find(id) != std::string::npos &&
        e.path().filename().string().find("ownership") != std::string::npos && e.file_size() == size)
      files.push_back(e.path());
  EXPECT_EQ(files.size(), 1u);
  std::string text(bytes, '\0');
  uint64_t x = 88172645463325252ull;
  for (char& c : text) {
    x ^= x << 13, x ^= x >> 7, x ^= x << 17;
    c = static_cast<char>(x);
  }
  if (!files.empty()) write_file(files[0], text);
  return target;
}

TEST_F(Daemon, ALargeResultDownloadsOverASlowLinkAndAStalledReaderIsDropped) {
  rv::ServerConfig c = test_config(dir_ / "data");
  // Each piece of a response within this of the last. Two seconds, not one: under the sanitizers,
  // with the suite running beside it, this reader once paused past one second (and was dropped).
  c.http.request_timeout_s = 2.0;
  start(c);
  const size_t size = 16u << 20;  // far more than the kernel's buffers hold on the way
  const std::string target = large_result(port_, dir_ / "data", size);
  const std::string body = get(port_, target).body;
  ASSERT_EQ(body.size(), size);
  // About 1.6 MB/s: several times the timeout, and every byte arrives.
  const SlowRead slow = slow_read(port_, target, 32 * 1024, std::chrono::milliseconds(20));
  EXPECT_TRUE(slow.whole) << slow.bytes.size() << " bytes in " << slow.seconds << " s";
  EXPECT_GT(slow.seconds, 3.0 * c.http.request_timeout_s);
  // (Compared as a truth, not with EXPECT_EQ: on a failure GoogleTest diffs the two 16 MB strings
  // line by line, in memory quadratic in their lines; such a failure once took 24 GB and was
  // killed.)
  const bool same_body =
      slow.bytes.size() >= body.size() && slow.bytes.compare(slow.bytes.size() - body.size(), body.size(), body) == 0;
  EXPECT_TRUE(same_body) << "the slow reader's last " << body.size() << " bytes differ from the body";
  // A reader that stops for three timeouts is dropped: it finds the answer cut short.
  const SlowRead stalled =
      slow_read(port_, target, 64 * 1024, std::chrono::milliseconds(0), 1u << 20, std::chrono::milliseconds(6000));
  EXPECT_FALSE(stalled.whole) << stalled.bytes.size() << " bytes";
  EXPECT_LT(stalled.bytes.size(), size);
  EXPECT_EQ(get(port_, "/health").status, 200);
}

TEST_F(Daemon, AResponseBelowTheLeastRateIsDroppedAtItsDeadline) {
  rv::ServerConfig c = test_config(dir_ / "data");
  c.http.request_timeout_s = 1.0;
  c.http.min_send_bytes_per_s = 4 << 20;  // 16 MiB: within 1 + 4 s
  start(c);
  const size_t size = 16u << 20;
  const std::string target = large_result(port_, dir_ / "data", size);
  // About 1.6 MB/s: never stalls, yet would need some 10 s.
  const SlowRead trickle = slow_read(port_, target, 32 * 1024, std::chrono::milliseconds(20));
  EXPECT_FALSE(trickle.whole) << trickle.bytes.size() << " bytes in " << trickle.seconds << " s";
  EXPECT_LT(trickle.seconds, 9.0);
  // A reader at full speed is within it.
  const SlowRead fast = slow_read(port_, target, 256 * 1024, std::chrono::milliseconds(0));
  EXPECT_TRUE(fast.whole) << fast.bytes.size() << " bytes in " << fast.seconds << " s";
}

}  // namespace
