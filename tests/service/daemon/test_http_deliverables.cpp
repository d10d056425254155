// The maritime deliverables as outputs of the daemon's `voronoi` process (issue 6): a real
// rv::Server on an ephemeral port, run_job behind it, a Beast client in front. Every result is
// fetched over HTTP and checked by content against geometry computed here independently from
// the seed coordinates (point seeds, planar UTM grid), never against bytes.
#include <gdal_priv.h>
#include <ogr_api.h>
#include <ogrsf_frmts.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include "http_client.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/job.hpp"
#include "rv/preview.hpp"
#include "rv/server.hpp"

namespace {

using nlohmann::json;
using rv::test::http_request;
using rv::test::Reply;
namespace fs = std::filesystem;

const std::string kExec = "/processes/voronoi/execution";
const std::string kInvalidParameter = "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/invalid-parameter";

// The grid every test computes on: 40 x 30 cells of 100 m in UTM 33N.
constexpr double kX0 = 500000.0, kY0 = 6100000.0, kRes = 100.0;
constexpr int kWidth = 40, kHeight = 30;
// Geometric tolerance of the acceptance criteria: 1e-3 of a cell.
constexpr double kTol = 1e-3 * kRes;

struct Seed {
  std::string owner;
  double x, y;
};

json seed_collection(const std::vector<Seed>& seeds) {
  json features = json::array();
  for (const Seed& s : seeds) {
    features.push_back({{"type", "Feature"},
                        {"properties", {{"owner", s.owner}}},
                        {"geometry", {{"type", "Point"}, {"coordinates", {s.x, s.y}}}}});
  }
  return {{"type", "FeatureCollection"},
          {"crs", {{"type", "name"}, {"properties", {{"name", "urn:ogc:def:crs:EPSG::32633"}}}}},
          {"features", features}};
}

json inputs_for(const std::vector<Seed>& seeds) {
  return {{"seeds", seed_collection(seeds)},
          {"ownerField", "owner"},
          {"resolution", kRes},
          {"extent", {kX0, kY0, kX0 + kWidth * kRes, kY0 + kHeight * kRes}}};
}

// Distance from (x, y) to the nearest seed of `owner` ("" = of any owner), by brute force.
double owner_distance(const std::vector<Seed>& seeds, double x, double y, const std::string& owner = "") {
  double best = std::numeric_limits<double>::infinity();
  for (const Seed& s : seeds)
    if (owner.empty() || s.owner == owner) best = std::min(best, std::hypot(x - s.x, y - s.y));
  return best;
}

std::string owner_at(const std::vector<Seed>& seeds, double x, double y) {
  std::string owner;
  double best = std::numeric_limits<double>::infinity();
  for (const Seed& s : seeds) {
    const double d = std::hypot(x - s.x, y - s.y);
    if (d < best) {
      best = d;
      owner = s.owner;
    }
  }
  return owner;
}

double centre_x(int c) { return kX0 + (c + 0.5) * kRes; }
double centre_y(int r) { return kY0 + kHeight * kRes - (r + 0.5) * kRes; }

void write_file(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out << bytes;
}

std::string path_of(const std::string& href) {
  const auto p = href.find("://");
  return href.substr(href.find('/', p + 3));
}

void expect_problem_400(const Reply& r, const std::string& detail_part) {
  EXPECT_EQ(r.status, 400u) << r.body;
  EXPECT_EQ(r.header("content-type"), "application/problem+json");
  const json p = json::parse(r.body, nullptr, false);
  ASSERT_TRUE(p.is_object()) << r.body;
  EXPECT_EQ(p["type"], kInvalidParameter) << r.body;
  EXPECT_EQ(p["status"], 400);
  EXPECT_NE(p["detail"].get<std::string>().find(detail_part), std::string::npos) << p["detail"];
}

// The vertices of a GeoJSON LineString or MultiLineString as (x, y) pairs.
std::vector<std::pair<double, double>> line_vertices(const json& geometry) {
  std::vector<std::pair<double, double>> out;
  auto add = [&](const json& coords) {
    for (const json& c : coords) out.emplace_back(c[0].get<double>(), c[1].get<double>());
  };
  if (geometry["type"] == "LineString") add(geometry["coordinates"]);
  if (geometry["type"] == "MultiLineString")
    for (const json& part : geometry["coordinates"]) add(part);
  return out;
}

class DaemonDeliverables : public ::testing::Test {
 protected:
  void SetUp() override {
    rv::gdal_init();
    dir_ = fs::temp_directory_path() / ("rv_http_deliver_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    start();
  }
  void TearDown() override {
    server_.reset();
    fs::remove_all(dir_);
  }
  void start() {
    rv::ServerConfig c;
    c.port = 0;
    c.data_dir = (dir_ / "data").string();
    c.jobs.workers = 1;
    c.jobs.queue_length = 4;
    c.jobs.threads_per_job = 2;
    c.jobs.shutdown_grace_s = 0.5;
    c.http.request_timeout_s = 10;
    server_ = std::make_unique<rv::Server>(
        c, [](const rv::JobSpec& s, const rv::JobLimits& l, const rv::JobHooks& h) { return rv::run_job(s, l, h); });
    server_->start();
    port_ = server_->port();
  }
  Reply get(const std::string& target) { return http_request(port_, "GET", target); }
  Reply post(const json& body, bool async = false) {
    return http_request(
        port_, "POST", kExec, body.dump(),
        async ? std::map<std::string, std::string>{{"Prefer", "respond-async"}} : std::map<std::string, std::string>{});
  }
  json wait_done(const std::string& id) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    json s;
    while (std::chrono::steady_clock::now() < until) {
      s = get("/jobs/" + id).json();
      if (s["status"] == "successful" || s["status"] == "failed") return s;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "job " << id << " did not finish: " << s.dump();
    return s;
  }
  // Fetches a result, checks its Content-Type, and stores it under dir_/name.
  std::string fetch(const json& results, const std::string& output, const std::string& media_type,
                    const std::string& name) {
    EXPECT_EQ(results[output]["type"], media_type) << output;
    const Reply r = get(path_of(results[output]["href"].get<std::string>()));
    EXPECT_EQ(r.status, 200u) << output << ": " << r.body.substr(0, 300);
    EXPECT_EQ(r.header("content-type"), media_type) << output;
    write_file(dir_ / name, r.body);
    return r.body;
  }

  fs::path dir_;
  std::unique_ptr<rv::Server> server_;
  unsigned short port_ = 0;
};

// Three point seeds of three owners (an acute triangle, so the circumcentre lies inside the
// grid), every output of the process requested at once, asynchronously.
TEST_F(DaemonDeliverables, EveryOutputAsyncCheckedByContent) {
  const std::vector<Seed> seeds = {
      {"A", kX0 + 1000.0, kY0 + 900.0}, {"B", kX0 + 3100.0, kY0 + 1200.0}, {"C", kX0 + 1900.0, kY0 + 2500.0}};
  json body = {{"inputs", inputs_for(seeds)}};
  body["inputs"]["limitDistances"] = {"300m", {{"value", 0.4}, {"unit", "km"}}, 250};
  body["outputs"] = {{"ownership", json::object()},
                     {"nearestFeature", json::object()},
                     {"report", json::object()},
                     {"boundaries", json::object()},
                     {"tripoints", {{"format", {{"mediaType", "application/geopackage+sqlite3"}}}}},
                     {"limits", json::object()},
                     {"regions", {{"format", {{"mediaType", "application/geo+json"}}}}},
                     {"margin", json::object()},
                     {"preview", json::object()}};
  const Reply created = post(body, true);
  ASSERT_EQ(created.status, 201u) << created.body;
  const std::string id = created.json()["jobID"];
  const json status = wait_done(id);
  ASSERT_EQ(status["status"], "successful") << status;
  std::set<std::string> enclosures;
  for (const json& l : status["links"])
    if (l["rel"] == "enclosure") enclosures.insert(l["title"].get<std::string>());
  EXPECT_EQ(enclosures, (std::set<std::string>{"ownership", "nearestFeature", "report", "boundaries", "tripoints",
                                               "limits", "regions", "margin", "preview"}));

  const json results = get("/jobs/" + id + "/results").json();
  EXPECT_EQ(results.size(), 9u) << results;
  EXPECT_FALSE(results.contains("distance"));  // not requested: not computed, not listed
  EXPECT_EQ(get("/jobs/" + id + "/results/distance").status, 404u);
  const json report = results["report"]["value"];
  ASSERT_TRUE(report.contains("deliverables")) << report;
  EXPECT_EQ(report["outputs"]["tripoints"], "tripoints.gpkg");  // file names, not server paths

  const std::string geotiff = "image/tiff; application=geotiff; profile=cloud-optimized";
  fetch(results, "ownership", geotiff, "own.tif");
  const rv::Raster<int32_t> own = rv::read_int32((dir_ / "own.tif").string());
  ASSERT_EQ(own.width(), kWidth);
  ASSERT_EQ(own.height(), kHeight);
  // Owner codes by label, from the report.
  std::map<std::string, int32_t> code;
  for (const json& o : report["seeds"]["owners"]) code[o["label"].get<std::string>()] = o["code"].get<int32_t>();
  ASSERT_EQ(code.size(), 3u);
  for (int r = 0; r < kHeight; ++r)
    for (int c = 0; c < kWidth; ++c) ASSERT_EQ(own.at(c, r), code[owner_at(seeds, centre_x(c), centre_y(r))]);

  // Nearest feature: the 1-based position of the nearest seed in the input.
  fetch(results, "nearestFeature", geotiff, "nf.tif");
  const rv::Raster<int32_t> nf = rv::read_int32((dir_ / "nf.tif").string());
  for (int r = 0; r < kHeight; ++r)
    for (int c = 0; c < kWidth; ++c) {
      const std::string o = owner_at(seeds, centre_x(c), centre_y(r));
      ASSERT_EQ(nf.at(c, r), o == "A" ? 1 : o == "B" ? 2 : 3);
    }

  // Boundaries (GeoJSON): three lines, each carrying both owners; every vertex equidistant
  // from the two owners' seeds, and no third owner nearer.
  const json lines = json::parse(fetch(results, "boundaries", "application/geo+json", "b.geojson"));
  ASSERT_EQ(lines["type"], "FeatureCollection");
  std::set<std::pair<std::string, std::string>> pairs;
  int vertices = 0;
  for (const json& f : lines["features"]) {
    const std::string a = f["properties"]["label_a"], b = f["properties"]["label_b"];
    EXPECT_NE(a, b);
    EXPECT_EQ(f["properties"]["owner_a"], code[a]);
    EXPECT_EQ(f["properties"]["owner_b"], code[b]);
    pairs.emplace(a, b);
    for (const auto& [x, y] : line_vertices(f["geometry"])) {
      ++vertices;
      const double da = owner_distance(seeds, x, y, a), db = owner_distance(seeds, x, y, b);
      EXPECT_LE(std::abs(da - db), kTol) << a << "-" << b << " at " << x << ", " << y;
      EXPECT_LE(std::min(da, db), owner_distance(seeds, x, y) + kTol);
    }
  }
  EXPECT_EQ(pairs, (std::set<std::pair<std::string, std::string>>{{"A", "B"}, {"A", "C"}, {"B", "C"}}));
  EXPECT_GT(vertices, 30);

  // Tripoints (GeoPackage, as requested): one, at the circumcentre of the three seeds.
  fetch(results, "tripoints", "application/geopackage+sqlite3", "t.gpkg");
  {
    const double ax = seeds[0].x, ay = seeds[0].y, bx = seeds[1].x, by = seeds[1].y, cx = seeds[2].x, cy = seeds[2].y;
    const double d = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by));
    const double ux =
        ((ax * ax + ay * ay) * (by - cy) + (bx * bx + by * by) * (cy - ay) + (cx * cx + cy * cy) * (ay - by)) / d;
    const double uy =
        ((ax * ax + ay * ay) * (cx - bx) + (bx * bx + by * by) * (ax - cx) + (cx * cx + cy * cy) * (bx - ax)) / d;
    GDALDataset* ds = GDALDataset::Open((dir_ / "t.gpkg").c_str(), GDAL_OF_VECTOR);
    ASSERT_NE(ds, nullptr);
    OGRLayer* l = ds->GetLayerByName("tripoints");
    ASSERT_NE(l, nullptr);
    EXPECT_EQ(l->GetFeatureCount(), 1);
    l->ResetReading();
    OGRFeature* f = l->GetNextFeature();
    ASSERT_NE(f, nullptr);
    const OGRPoint* p = f->GetGeometryRef()->toPoint();
    EXPECT_NEAR(p->getX(), ux, kTol);
    EXPECT_NEAR(p->getY(), uy, kTol);
    std::set<std::string> owners{f->GetFieldAsString("label_1"), f->GetFieldAsString("label_2"),
                                 f->GetFieldAsString("label_3")};
    EXPECT_EQ(owners, (std::set<std::string>{"A", "B", "C"}));
    OGRFeature::DestroyFeature(f);
    GDALClose(GDALDataset::ToHandle(ds));
  }

  // Limits: one set per requested distance (300 m, 0.4 km, 250 in the CRS's metres), every
  // vertex at that distance from the nearest seed.
  const json limits = json::parse(fetch(results, "limits", "application/geo+json", "l.geojson"));
  std::set<double> distances;
  int limit_vertices = 0;
  for (const json& f : limits["features"]) {
    const double want = f["properties"]["distance"].get<double>();
    distances.insert(want);
    for (const auto& [x, y] : line_vertices(f["geometry"])) {
      ++limit_vertices;
      EXPECT_NEAR(owner_distance(seeds, x, y), want, kTol) << "limit " << want;
    }
  }
  ASSERT_EQ(distances.size(), 3u);
  auto it = distances.begin();
  for (const double want : {250.0, 300.0, 400.0}) EXPECT_NEAR(*it++, want, 1e-9);
  EXPECT_GT(limit_vertices, 50);

  // Regions (bounded by the boundary lines): every owned cell's centre inside exactly one region,
  // its owner's, or, equidistant from two owners, on its owner's region's edge (the line).
  fetch(results, "regions", "application/geo+json", "r.geojson");
  {
    GDALDataset* ds = GDALDataset::Open((dir_ / "r.geojson").c_str(), GDAL_OF_VECTOR);
    ASSERT_NE(ds, nullptr);
    OGRLayer* l = ds->GetLayer(0);
    std::vector<std::pair<int32_t, std::unique_ptr<OGRGeometry>>> regions;
    l->ResetReading();
    for (OGRFeature* f; (f = l->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(f))
      regions.emplace_back(f->GetFieldAsInteger("owner"), std::unique_ptr<OGRGeometry>(f->StealGeometry()));
    GDALClose(GDALDataset::ToHandle(ds));
    ASSERT_EQ(regions.size(), 3u);
    // (GEOS's prepared geometries: the same predicate, each region converted once.)
    std::vector<OGRPreparedGeometryUniquePtr> prepared;
    for (const auto& region : regions)
      prepared.emplace_back(OGRCreatePreparedGeometry(OGRGeometry::ToHandle(region.second.get())));
    for (int r = 0; r < kHeight; ++r)
      for (int c = 0; c < kWidth; ++c) {
        OGRPoint centre(centre_x(c), centre_y(r));
        int holders = 0;
        for (size_t k = 0; k < regions.size(); ++k)
          if (OGRPreparedGeometryContains(prepared[k].get(), OGRGeometry::ToHandle(&centre))) {
            ++holders;
            EXPECT_EQ(regions[k].first, own.at(c, r)) << "cell " << c << ", " << r;
          }
        if (holders == 0) {
          int close = 0;
          for (const Seed& sd : seeds)
            close += std::abs(std::hypot(centre_x(c) - sd.x, centre_y(r) - sd.y) -
                              owner_distance(seeds, centre_x(c), centre_y(r))) <= kTol;
          EXPECT_GE(close, 2) << "cell " << c << ", " << r << " lies in no region and is no tie";
          for (const auto& [owner, geom] : regions) {
            if (owner == own.at(c, r)) {
              EXPECT_TRUE(geom->Intersects(&centre)) << "cell " << c << ", " << r;
            }
          }
          continue;
        }
        ASSERT_EQ(holders, 1) << "cell " << c << ", " << r;
      }
  }

  // Margin: distance to the nearest other owner's seed minus the own one's, >= 0.
  fetch(results, "margin", geotiff, "m.tif");
  const rv::Raster<float> margin = rv::read_float32((dir_ / "m.tif").string());
  ASSERT_EQ(margin.width(), kWidth);
  for (int r = 0; r < kHeight; r += 3)
    for (int c = 0; c < kWidth; c += 3) {
      const double x = centre_x(c), y = centre_y(r);
      const std::string o = owner_at(seeds, x, y);
      double other = std::numeric_limits<double>::infinity();
      for (const Seed& s : seeds)
        if (s.owner != o) other = std::min(other, std::hypot(x - s.x, y - s.y));
      const float m = margin.at(c, r);
      EXPECT_GE(m, 0.0f);
      EXPECT_NEAR(m, other - owner_distance(seeds, x, y, o), 1e-2) << "cell " << c << ", " << r;
    }

  // Preview: a PNG whose map is the grid's size (the legend beside it), each seed's cell in its
  // owner's colour.
  const std::string png = fetch(results, "preview", "image/png", "p.png");
  ASSERT_GE(png.size(), 8u);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  {
    GDALDataset* ds = GDALDataset::Open((dir_ / "p.png").c_str(), GDAL_OF_RASTER);
    ASSERT_NE(ds, nullptr);
    EXPECT_EQ(std::string(ds->GetDriver()->GetDescription()), "PNG");
    EXPECT_EQ(ds->GetRasterXSize(), kWidth + 260);
    EXPECT_GE(ds->GetRasterYSize(), kHeight);
    ASSERT_EQ(ds->GetRasterCount(), 3);
    for (const Seed& s : seeds) {
      const int c = static_cast<int>((s.x - kX0) / kRes), r = static_cast<int>((kY0 + kHeight * kRes - s.y) / kRes);
      const auto bgr = rv::owner_colour(code[s.owner]);
      for (int band = 1; band <= 3; ++band) {
        uint8_t v = 0;
        ASSERT_EQ(ds->GetRasterBand(band)->RasterIO(GF_Read, c, r, 1, 1, &v, 1, 1, GDT_Byte, 0, 0), CE_None);
        EXPECT_EQ(v, bgr[static_cast<size_t>(3 - band)]) << s.owner << " band " << band;
      }
    }
    GDALClose(GDALDataset::ToHandle(ds));
  }

  // The files live in the job's directory, survive a restart with their formats, and go with
  // the job.
  const fs::path job_dir = dir_ / "data" / "jobs" / id;
  for (const char* f : {"boundaries.geojson", "tripoints.gpkg", "limits.geojson", "regions.geojson", "margin.tif",
                        "preview.png", "nearest_feature.tif"})
    EXPECT_TRUE(fs::exists(job_dir / f)) << f;
  EXPECT_FALSE(fs::exists(job_dir / "distance.tif"));
  server_.reset();
  start();
  const Reply again = get("/jobs/" + id + "/results/tripoints");
  EXPECT_EQ(again.status, 200u);
  EXPECT_EQ(again.header("content-type"), "application/geopackage+sqlite3");
  EXPECT_EQ(get("/jobs/" + id + "/results").json()["tripoints"]["type"], "application/geopackage+sqlite3");
  ASSERT_EQ(http_request(port_, "DELETE", "/jobs/" + id).status, 200u);
  EXPECT_FALSE(fs::exists(job_dir));
}

// Two point seeds, synchronous: the boundary is their perpendicular bisector, from grid edge to
// grid edge; raw responses carry the one output's bytes with its media type.
TEST_F(DaemonDeliverables, TwoSeedsBisectorSyncRawAndDocument) {
  const std::vector<Seed> seeds = {{"P", kX0 + 1030.0, kY0 + 1270.0}, {"Q", kX0 + 2710.0, kY0 + 1820.0}};
  json body = {{"inputs", inputs_for(seeds)}, {"outputs", {{"boundaries", json::object()}}}, {"response", "raw"}};
  const Reply raw = post(body);
  ASSERT_EQ(raw.status, 200u) << raw.body;
  EXPECT_EQ(raw.header("content-type"), "application/geo+json");
  const json fc = json::parse(raw.body);
  ASSERT_EQ(fc["features"].size(), 1u);
  const json& f = fc["features"][0];
  EXPECT_EQ(f["properties"]["label_a"], "P");
  EXPECT_EQ(f["properties"]["label_b"], "Q");
  const auto v = line_vertices(f["geometry"]);
  ASSERT_GT(v.size(), 20u);
  // The bisector: (p - m) . (q - p0) = 0 is the same as |p - p0| = |p - q|.
  for (const auto& [x, y] : v)
    EXPECT_NEAR(owner_distance(seeds, x, y, "P"), owner_distance(seeds, x, y, "Q"), kTol) << x << ", " << y;
  auto on_edge = [](double x, double y) {
    return x <= centre_x(0) + 1e-6 || x >= centre_x(kWidth - 1) - 1e-6 || y >= centre_y(0) - 1e-6 ||
           y <= centre_y(kHeight - 1) + 1e-6;
  };
  EXPECT_TRUE(on_edge(v.front().first, v.front().second));
  EXPECT_TRUE(on_edge(v.back().first, v.back().second));

  // Document response, GeoPackage boundaries and the preview.
  body["outputs"] = {{"boundaries", {{"format", {{"mediaType", "application/geopackage+sqlite3"}}}}},
                     {"preview", {{"transmissionMode", "reference"}}}};
  body["response"] = "document";
  const Reply doc = post(body);
  ASSERT_EQ(doc.status, 200u) << doc.body;
  const json results = doc.json();
  fetch(results, "boundaries", "application/geopackage+sqlite3", "b.gpkg");
  GDALDataset* ds = GDALDataset::Open((dir_ / "b.gpkg").c_str(), GDAL_OF_VECTOR);
  ASSERT_NE(ds, nullptr);
  OGRLayer* l = ds->GetLayerByName("boundaries");
  ASSERT_NE(l, nullptr);
  EXPECT_EQ(l->GetFeatureCount(), 1);
  // The vertex layer names the basepoints: here always the two seeds.
  OGRLayer* bv = ds->GetLayerByName("boundary_vertices");
  ASSERT_NE(bv, nullptr);
  bv->ResetReading();
  int n = 0;
  for (OGRFeature* p; (p = bv->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(p), ++n) {
    EXPECT_NEAR(p->GetFieldAsDouble("basepoint_a_x"), seeds[0].x, 1e-6);
    EXPECT_NEAR(p->GetFieldAsDouble("basepoint_b_y"), seeds[1].y, 1e-6);
  }
  EXPECT_EQ(n, static_cast<int>(v.size()));
  GDALClose(GDALDataset::ToHandle(ds));
  const std::string png = fetch(results, "preview", "image/png", "p.png");
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
}

TEST_F(DaemonDeliverables, BadOutputsAndLimitDistancesAre400) {
  const std::vector<Seed> seeds = {{"P", kX0 + 1030.0, kY0 + 1270.0}, {"Q", kX0 + 2710.0, kY0 + 1820.0}};
  auto with = [&](const json& outputs, const json& extra_inputs) {
    json body = {{"inputs", inputs_for(seeds)}, {"outputs", outputs}};
    for (const auto& [k, v] : extra_inputs.items()) body["inputs"][k] = v;
    return post(body);
  };
  const json limits = {{"limits", json::object()}};
  expect_problem_400(with({{"nearest", json::object()}}, json::object()), "output 'nearest'");
  expect_problem_400(with({{"Boundaries", json::object()}}, json::object()), "no such output");
  expect_problem_400(with(limits, {{"limitDistances", {"12 parsecs"}}}), "limitDistances[0]");
  expect_problem_400(with(limits, {{"limitDistances", {"12nmi", -3}}}), "limitDistances[1]");
  expect_problem_400(with(limits, {{"limitDistances", {"nmi"}}}), "limitDistances[0]");
  expect_problem_400(with(limits, {{"limitDistances", json::array()}}), "limitDistances");
  expect_problem_400(with(limits, {{"limitDistances", {{{"value", 12}, {"unit", "furlong"}}}}}), "limitDistances[0]");
  expect_problem_400(with(limits, {{"limitDistances", {true}}}), "limitDistances[0]");
  expect_problem_400(with(limits, json::object()), "input 'limitDistances': is required");
  expect_problem_400(with({{"boundaries", json::object()}}, {{"limitDistances", {"12nmi"}}}), "not requested");
  expect_problem_400(with({{"boundaries", {{"format", {{"mediaType", "image/png"}}}}}}, json::object()),
                     "format 'image/png'");
  expect_problem_400(with({{"boundaries", {{"transmissionMode", "value"}}}}, json::object()), "by reference");
  expect_problem_400(with({{"boundaries", json::object()}}, {{"simplify", -1}}), "input 'simplify'");
  // Nothing was queued for any of them.
  EXPECT_TRUE(get("/jobs").json()["jobs"].empty());
}

}  // namespace

// The distance by sea over HTTP: the barriers uploaded as a layer or an array of layers, the via
// raster returned, every cell checked against the closed form of one point behind a wall
// (d = |s - x| where x sees s, else the least of |s - v| + |v - x| over the wall's ends v); and
// the pairings and barriers the daemon refuses, each a 400 naming the input.
TEST_F(DaemonDeliverables, TheDistanceBySeaGoesAroundUploadedBarriers) {
  const std::vector<Seed> seeds = {{"W", kX0 + 1030.0, kY0 + 1470.0}};
  const double wx = kX0 + 2000.0, wy0 = kY0 + 600.0, wy1 = kY0 + 2400.0;  // the wall, north-south
  json wall = seed_collection({});
  json feature = json::object();
  feature["type"] = "Feature";
  feature["properties"] = json::object();
  feature["geometry"] = {{"type", "LineString"},
                         {"coordinates", json::array({json::array({wx, wy0}), json::array({wx, wy1})})}};
  wall["features"].push_back(feature);
  for (const json& barriers : {wall, json::array({wall})}) {
    json body = {
        {"inputs", inputs_for(seeds)},
        {"outputs",
         {{"distance", json::object()}, {"via", json::object()}, {"report", {{"transmissionMode", "reference"}}}}}};
    body["inputs"]["barriers"] = barriers;
    const Reply r = post(body);
    ASSERT_EQ(r.status, 200u) << r.body;
    const json results = r.json();
    fetch(results, "distance", "image/tiff; application=geotiff; profile=cloud-optimized", "d.tif");
    fetch(results, "via", "image/tiff; application=geotiff; profile=cloud-optimized", "v.tif");
    const rv::Raster<float> d = rv::read_float32((dir_ / "d.tif").string());
    const rv::Raster<int32_t> via = rv::read_int32((dir_ / "v.tif").string());
    const Seed& s = seeds[0];
    int shadow = 0;
    for (int row = 0; row < kHeight; ++row)
      for (int col = 0; col < kWidth; ++col) {
        const double x = centre_x(col), y = centre_y(row);
        // The straight path from s crosses the wall's line x = wx between its ends.
        const double t = (wx - s.x) / (x - s.x);
        const bool hidden = x > wx && t > 0.0 && t < 1.0 && s.y + t * (y - s.y) > wy0 && s.y + t * (y - s.y) < wy1;
        double expected = std::hypot(x - s.x, y - s.y);
        if (hidden) {
          ++shadow;
          expected = std::min(std::hypot(wx - s.x, wy0 - s.y) + std::hypot(x - wx, y - wy0),
                              std::hypot(wx - s.x, wy1 - s.y) + std::hypot(x - wx, y - wy1));
        }
        const size_t i = static_cast<size_t>(row * kWidth + col);
        EXPECT_NEAR(d.cells()[i], expected, 1e-3 * expected) << col << ", " << row;
        EXPECT_EQ(via.cells()[i] != 0, hidden) << col << ", " << row;
      }
    EXPECT_GT(shadow, 200);
    const json report = get(path_of(results["report"]["href"].get<std::string>())).json();
    EXPECT_EQ(report["sea"]["barriers"]["lines"], 1);
    EXPECT_EQ(report["sea"]["via_vertices"].size(), 2u);
  }
  // Refused before any job: a point as a barrier, the via raster without barriers, a scan by sea.
  json points = seed_collection(seeds);
  json body = {{"inputs", inputs_for(seeds)}, {"outputs", {{"ownership", json::object()}}}};
  body["inputs"]["barriers"] = json::array({wall, points});
  const Reply point_barrier = post(body);  // invalid input (its data), not an invalid parameter
  EXPECT_EQ(point_barrier.status, 400u);
  EXPECT_NE(point_barrier.json()["detail"].get<std::string>().find(
                "input 'barriers': the barrier barriers[1]:barriers_1:fid 0 is a point"),
            std::string::npos)
      << point_barrier.body;
  body["inputs"].erase("barriers");
  body["outputs"]["via"] = json::object();
  expect_problem_400(post(body), "output 'via': needs the input barriers");
  body["inputs"]["barriers"] = wall;
  body["inputs"]["method"] = "hv-scan";
  expect_problem_400(post(body), "needs the exact");
}
