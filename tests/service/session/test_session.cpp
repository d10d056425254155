// Live what-if sessions through the façade (issue 54, rv/session.hpp). After every step of
// randomised edit sequences (all five operations, undo and redo), on points, lines and polygons
// planar and on the western Baltic's coasts geodesic, with weights and reaches:
//  - the session's field equals compute() on its seeds, cell for cell;
//  - its deliverables equal, byte for byte, the files of a fresh job run on its features written
//    to a seed file (so "the edited seeds" are what a user saving them would have);
//  - its areas equal that job's to 1e-9 relative, and its cell areas the fresh field's;
//  - the answer's moved areas and box agree with the two fields.
// Bad edits are refused and leave the session as it was.
#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fixtures.hpp"
#include "rv/edit/edit.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/job.hpp"
#include "rv/lines/partial_effect.hpp"
#include "rv/lines/regions.hpp"
#include "rv/session.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace rv {
namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// A turning-point table without its "feature" members (names, not geometry).
json without_feature_names(json j) {
  if (j.is_object()) {
    j.erase("feature");
    for (auto& [k, v] : j.items()) v = without_feature_names(v);
  } else if (j.is_array()) {
    for (json& v : j) v = without_feature_names(v);
  }
  return j;
}

const char* ext_of(const std::string& name) { return name == "turning_points" ? ".json" : ".geojson"; }

class SessionTest : public ::testing::Test {
 public:
  void SetUp() override {
    gdal_init();
    dir_ = fs::temp_directory_path() / ("rv_session_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A session's spec: `seeds`, every deliverable, the limits given.
  JobSpec spec(const std::string& seeds, double res, std::array<double, 4> extent, const std::string& limit) const {
    JobSpec s;
    s.seeds.paths = {seeds};
    s.seeds.owner_field = "owner";
    s.seeds.weight_field = "weight";
    s.seeds.reach_field = "reach";
    s.grid.resolution = res;
    s.grid.extent = extent;
    s.threads = 2;
    OutputRequest& o = s.outputs;
    for (const char* name : kSessionDeliverables) {
      const std::string path = (dir_ / (std::string(name) + ext_of(name))).string();
      if (std::string(name) == "boundaries") o.boundaries = path;
      if (std::string(name) == "tripoints") o.tripoints = path;
      if (std::string(name) == "limits") o.limits = path;
      if (std::string(name) == "regions") o.regions = path;
      if (std::string(name) == "turning_points") o.turning_points = path;
    }
    o.limit_distances = {limit};
    return s;
  }

  // The western Baltic's coasts (fixtures/baltic_west.gpkg), geodesic, distances in nautical
  // miles, at `res` degrees; with `lines`, boundaries, tripoints, 12 nmi limits and regions.
  static JobSpec baltic_spec(double res, bool lines = false) {
    JobSpec s;
    s.seeds.paths = {test::fixture("baltic_west.gpkg")};
    s.seeds.owner_field = "iso2";
    s.seeds.border_tolerance = 10.0;
    s.grid.resolution = res;
    s.metric = MetricRequest::geodesic;
    s.distance_units = DistanceUnit::nmi;
    s.threads = 2;
    if (lines) {
      s.outputs.boundaries = "b.geojson";
      s.outputs.tripoints = "t.geojson";
      s.outputs.limits = "l.geojson";
      s.outputs.regions = "r.geojson";
      s.outputs.limit_distances = {"12nmi"};  // (turning points: the planar case; here they cost seconds a step)
    }
    return s;
  }

  // Everything a step must leave: the field of compute(), the files of a fresh job on the
  // features as a file, its areas.
  void check_fresh(const Session& session, const JobSpec& base, const json& answer, const std::string& what) {
    SCOPED_TRACE(what);
    // The field.
    ComputeOptions co = session.job().compute;
    co.prepared = nullptr;
    const NearestField fresh = compute(session.seeds(), session.grid(), co);
    const NearestField& field = session.field();
    ASSERT_EQ(fresh.site.cells().size(), field.site.cells().size());
    int64_t site_diff = 0, dist_diff = 0;
    for (size_t i = 0; i < fresh.site.cells().size(); ++i) {
      site_diff += fresh.site.cells()[i] != field.site.cells()[i];
      const bool differs =
          std::bit_cast<uint32_t>(fresh.distance.cells()[i]) != std::bit_cast<uint32_t>(field.distance.cells()[i]);
      dist_diff += differs;
    }
    EXPECT_EQ(site_diff, 0) << "cells whose site differs from a fresh computation";
    EXPECT_EQ(dist_diff, 0) << "cells whose distance differs";
    // The features written as a seed file, run as an ordinary job.
    const fs::path run = dir_ / ("fresh_" + std::to_string(++runs_));
    fs::create_directories(run);
    const json features = session.features();
    std::ofstream(run / "seeds.geojson") << features.dump();
    JobSpec s = base;
    s.seeds.owner_field = "owner";
    s.seeds.weight_field = "weight";
    s.seeds.reach_field = "reach";
    s.seeds.layers.clear();
    // A GeoJSON field of nulls alone reads as text: without any reach, none is read.
    bool reaches = false;
    for (const json& f : features["features"]) reaches |= f["properties"]["reach"].is_number();
    if (!reaches) s.seeds.reach_field.reset();
    s.seeds.paths = {(run / "seeds.geojson").string()};
    s.seeds.target_crs = session.job().loaded.crs.wkt;
    OutputRequest& o = s.outputs;
    o.boundaries = (run / "boundaries.geojson").string();
    o.tripoints = (run / "tripoints.geojson").string();
    o.limits = (run / "limits.geojson").string();
    o.regions = (run / "regions.geojson").string();
    o.turning_points = (run / "turning_points.json").string();
    o.report = (run / "report.json").string();
    // An owner left without features keeps its code in the session; a file of the features
    // numbers the owners afresh. Then the fresh job runs on the session's seed set itself (its
    // owner table), read from nowhere: still computed from scratch.
    // So does an owner whose first feature in the file comes after another owner's first: a file
    // numbers owners by first appearance, the session keeps its codes.
    std::vector<std::string> appearance;
    for (const json& f : features["features"]) {
      const std::string label = f["properties"]["owner"].get<std::string>();
      if (std::find(appearance.begin(), appearance.end(), label) == appearance.end()) appearance.push_back(label);
    }
    // A reach in other units than the metric's (nautical miles) does not come back from the text
    // bit for bit (written as reach * k, read as value * (1 / k)): the same path then.
    const bool codes_kept = appearance != session.seeds().owner_labels() || (reaches && session.job().to_output != 1.0);
    JobResult r;
    if (codes_kept) {
      PreparedJob j = session.job();
      j.compute.prepared = nullptr;
      JobSpec ps = base;
      ps.outputs = o;
      r = run_prepared(ps, j);
    } else {
      r = run_job(s);
    }
    for (const std::string& name : session.deliverables()) {
      std::string mine = session.deliverable(name), theirs = read_text(run / (name + ext_of(name)));
      if (name == "turning_points") {
        // The report names each basepoint's feature by its source: the session's ids, the fresh
        // job's file. Everything else is compared as written.
        mine = without_feature_names(json::parse(mine)).dump(1);
        theirs = without_feature_names(json::parse(theirs)).dump(1);
      }
      size_t at = 0;
      while (at < mine.size() && at < theirs.size() && mine[at] == theirs[at]) ++at;
      EXPECT_TRUE(mine == theirs) << name << " differs from a fresh job's at byte " << at << " of " << mine.size()
                                  << " / " << theirs.size() << ": ..." << mine.substr(at > 80 ? at - 80 : 0, 160)
                                  << "... vs ..." << theirs.substr(at > 80 ? at - 80 : 0, 160);
    }
    // The areas: the regions' as the fresh job's, the cells' as the fresh field's.
    const json info = session.info();
    // The regions checked against every row of the session's field, whatever the step took from
    // the one before.
    const std::vector<std::string> made = session.deliverables();
    if (std::find(made.begin(), made.end(), "regions") != made.end()) {
      EXPECT_EQ(info.at("regions_check").at("rows").get<int64_t>(), session.grid().height);
      EXPECT_EQ(info.at("regions_check").at("cells_in_another_region").get<int64_t>(), 0);
      ++regions_checked;
    }
    std::map<std::string, double> region_area, cells;
    for (const json& a : r.report["deliverables"]["regions"]["areas"])
      region_area[a["label"].get<std::string>()] = a["area"].get<double>();
    const GridSpec& g = session.grid();
    // A cell's area: its square's (on longitude/latitude grids the same along a row).
    const bool per_row = fresh.metric.kind == MetricSpec::geodesic;
    for (int64_t row = 0; row < g.height; ++row) {
      double row_area = -1.0;
      for (int64_t c = 0; c < g.width; ++c) {
        const int32_t site = fresh.site.at(c, row);
        if (site == kNoSite) continue;
        const double x0 = g.xmin + static_cast<double>(c) * g.res, y1 = g.ymax - static_cast<double>(row) * g.res;
        const std::array<Vec2, 4> ring{Vec2{x0, y1}, Vec2{x0 + g.res, y1}, Vec2{x0 + g.res, y1 - g.res},
                                       Vec2{x0, y1 - g.res}};
        if (!per_row || row_area < 0.0) row_area = ring_area(ring, fresh.metric, nullptr, g.res);
        cells[session.seeds().owner_labels()[static_cast<size_t>(session.seeds().site_owner(site) - 1)]] += row_area;
      }
    }
    // Kept by the changes' sums: 1e-9 of the owned area (an owner's sum may end near 0 when its
    // cells are all gone, with the rounding of the sums it went through).
    double total = 0.0;
    for (const auto& [label, area] : cells) total += area * session.job().to_output * session.job().to_output;
    const double to_area = session.job().to_output * session.job().to_output;
    for (const json& a : info["areas"]) {
      const std::string label = a["label"].get<std::string>();
      const double want = cells[label] * to_area;
      EXPECT_NEAR(a["cells_area"].get<double>(), want, 1e-9 * std::max(want, total)) << label << " cells' area";
      if (region_area.count(label)) {
        EXPECT_NEAR(a["area"].get<double>(), region_area[label], 1e-9 * region_area[label]) << label << " region area";
      }
    }
    if (!answer.is_null() && previous_.site.cells().size() == fresh.site.cells().size()) {
      // The answer against the two fields: owners changed, the box, the area moved per owner.
      int64_t owners_changed = 0;
      int64_t c0 = g.width, r0 = g.height, c1 = 0, r1 = 0;
      for (int64_t row = 0; row < g.height; ++row)
        for (int64_t c = 0; c < g.width; ++c) {
          const int32_t a = previous_.site.at(c, row), b = fresh.site.at(c, row);
          const std::string la =
              a == kNoSite ? "" : previous_labels_[static_cast<size_t>(previous_owner_[static_cast<size_t>(a)] - 1)];
          const std::string lb =
              b == kNoSite ? ""
                           : session.seeds().owner_labels()[static_cast<size_t>(session.seeds().site_owner(b) - 1)];
          const bool changed = la != lb || std::bit_cast<uint32_t>(previous_.distance.at(c, row)) !=
                                               std::bit_cast<uint32_t>(fresh.distance.at(c, row));
          owners_changed += la != lb;
          if (changed) {
            c0 = std::min(c0, c);
            r0 = std::min(r0, row);
            c1 = std::max(c1, c + 1);
            r1 = std::max(r1, row + 1);
          }
        }
      EXPECT_EQ(answer["cells"]["owner_changed"].get<int64_t>(), owners_changed);
      if (c1 > c0)
        EXPECT_EQ(answer["cells"]["box"], json::array({c0, r0, c1, r1}));
      else
        EXPECT_TRUE(answer["cells"]["box"].is_null());
    }
    previous_ = fresh;
    previous_labels_ = session.seeds().owner_labels();
    previous_owner_.clear();
    for (size_t i = 0; i < session.seeds().sites().size(); ++i)
      previous_owner_.push_back(session.seeds().site_owner(static_cast<int32_t>(i)));
  }

  fs::path dir_;
  int runs_ = 0;
  int64_t regions_checked = 0;  // check_fresh's: steps whose regions' check was read
  NearestField previous_;
  std::vector<std::string> previous_labels_;
  std::vector<int32_t> previous_owner_;
};

// A random edit of the session's current features.
json random_edit(const json& features, std::mt19937& rng, double x0, double y0, double size, int& added,
                 bool polygons_move) {
  const json& fs_ = features["features"];
  std::uniform_int_distribution<size_t> pick(0, fs_.size() - 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const json& f = fs_[pick(rng)];
  const std::string id = f["id"].get<std::string>();
  const std::string kind = f["properties"]["kind"].get<std::string>();
  const char* owners[] = {"A", "B", "C", "D"};
  auto pos = [&] { return json::array({x0 + size * (0.05 + 0.9 * u(rng)), y0 + size * (0.05 + 0.9 * u(rng))}); };
  switch (std::uniform_int_distribution<int>(0, 5)(rng)) {
    case 0:
      if (kind == "point") return {{"op", "move-vertex"}, {"feature", id}, {"path", json::array()}, {"to", pos()}};
      if (kind == "line") {
        const auto& c = f["geometry"]["coordinates"];
        const size_t v = std::uniform_int_distribution<size_t>(0, c.size() - 1)(rng);
        json to = c[v];
        to[0] = to[0].get<double>() + size * 0.02 * (u(rng) - 0.5);
        to[1] = to[1].get<double>() + size * 0.02 * (u(rng) - 0.5);
        return {{"op", "move-vertex"}, {"feature", id}, {"path", {0, v}}, {"to", to}};
      }
      if (kind == "polygon" && polygons_move) {
        // A small move of one vertex keeps a convex-ish ring valid.
        const auto& ring = f["geometry"]["coordinates"][0];
        const size_t v = std::uniform_int_distribution<size_t>(0, ring.size() - 1)(rng);
        json to = ring[v];
        to[0] = to[0].get<double>() + size * 0.004 * (u(rng) - 0.5);
        to[1] = to[1].get<double>() + size * 0.004 * (u(rng) - 0.5);
        return {{"op", "move-vertex"}, {"feature", id}, {"path", {0, 0, v}}, {"to", to}};
      }
      return {{"op", "set"}, {"feature", id}, {"properties", {{"weight", 0.7 + 0.6 * u(rng)}}}};
    case 1:
      ++added;
      return {{"op", "add"},
              {"properties", {{"owner", owners[std::uniform_int_distribution<int>(0, 3)(rng)]}}},
              {"geometry", {{"type", "Point"}, {"coordinates", pos()}}}};
    case 2:
      if (fs_.size() > 4 && kind == "point") return {{"op", "remove"}, {"feature", id}};
      return {{"op", "add"},
              {"properties", {{"owner", "E"}}},
              {"geometry", {{"type", "LineString"}, {"coordinates", {pos(), pos()}}}}};
    case 3:
      if (kind == "point")
        return {{"op", "set"},
                {"feature", id},
                {"properties", {{"owner", owners[std::uniform_int_distribution<int>(0, 3)(rng)]}}}};
      return {{"op", "set"}, {"feature", id}, {"properties", {{"reach", size * (0.2 + 0.5 * u(rng))}}}};
    case 4:
      if (kind == "point")
        return {{"op", "replace"}, {"feature", id}, {"geometry", {{"type", "Point"}, {"coordinates", pos()}}}};
      return {{"op", "set"}, {"feature", id}, {"properties", {{"reach", nullptr}, {"weight", 1.0}}}};
    default:
      return {{"op", "set"}, {"feature", id}, {"properties", {{"weight", 0.8 + 0.4 * u(rng)}}}};
  }
}

// Points of four owners, a line and an island, planar (UTM 33N metres). Under AddressSanitizer
// (GCC defines __SANITIZE_ADDRESS__, clang answers __has_feature) on cells of 100 m instead of 50 m: a quarter of the
// cells, the same edits and checks, inside CI's time for the sanitizer stage.
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RV_TEST_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(RV_TEST_ASAN)
constexpr double kPlanarCell = 100.0;
#else
constexpr double kPlanarCell = 50.0;
#endif

TEST_F(SessionTest, RandomEditsPlanarEqualFreshRuns) {
  std::mt19937 rng(20261129);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  json fc = {{"type", "FeatureCollection"},
             {"crs", {{"type", "name"}, {"properties", {{"name", "urn:ogc:def:crs:EPSG::32633"}}}}},
             {"features", json::array()}};
  const double x0 = 500000.0, y0 = 6000000.0, size = 30000.0;
  auto feature = [](const char* owner, const char* type, json coordinates) {
    return json{{"type", "Feature"},
                {"properties", {{"owner", owner}, {"weight", 1.0}}},
                {"geometry", {{"type", type}, {"coordinates", std::move(coordinates)}}}};
  };
  auto at = [&](double x, double y) { return json::array({x0 + x, y0 + y}); };
  const char* owners[] = {"A", "B", "C", "D"};
  for (int i = 0; i < 14; ++i)
    fc["features"].push_back(
        feature(owners[i % 4], "Point", at(size * (0.1 + 0.8 * u(rng)), size * (0.1 + 0.8 * u(rng)))));
  fc["features"].push_back(feature("C", "LineString", json::array({at(2000, 3000), at(6000, 4200), at(9000, 2500)})));
  const json ring = json::array({at(20000, 20000), at(23000, 20500), at(22500, 23500), at(20000, 20000)});
  fc["features"].push_back(feature("B", "Polygon", json::array({ring})));
  const fs::path seeds = dir_ / "seeds.geojson";
  std::ofstream(seeds) << fc.dump();
  JobSpec s = spec(seeds.string(), kPlanarCell, {x0, y0, x0 + size, y0 + size}, "2500");
  s.seeds.reach_field.reset();  // the file has none; edits give reaches
  std::unique_ptr<Session> session = Session::create(s);
  check_fresh(*session, s, nullptr, "created");
  int added = 0, undos = 0, redos = 0, taken_rows = 0, owners_moved = 0, taken_vertices = 0;
  bool adjusted = false;
  for (int step = 0; step < 24; ++step) {
    json answer;
    const int what = std::uniform_int_distribution<int>(0, 9)(rng);
    if (what == 0 && session->info()["undo"].get<int>() > 0) {
      answer = session->undo();
      ++undos;
    } else if (what == 1 && session->info()["redo"].get<int>() > 0) {
      answer = session->redo();
      ++redos;
    } else {
      json edits = json::array();
      const int n = std::uniform_int_distribution<int>(1, 3)(rng);
      const json features = session->features();
      for (int k = 0; k < n; ++k) edits.push_back(random_edit(features, rng, x0, y0, size, added, true));
      try {
        answer = session->edit(edits);
      } catch (const Error& e) {
        // Random edits may put a point inside the island of another owner, or touch a feature an
        // earlier edit of the step removed: refused (and nothing changed, BadEditsAreRefused...).
        const bool removed_before = std::string(e.what()).find("was removed") != std::string::npos;
        ASSERT_TRUE(e.kind() == ErrorKind::conflict || (e.kind() == ErrorKind::invalid_argument && removed_before))
            << e.what() << "\n"
            << edits.dump();
        continue;
      }
    }
    check_fresh(*session, s, answer, "step " + std::to_string(step) + ": " + answer.dump().substr(0, 200));
    taken_rows += answer["recompute"]["rows_taken"].get<int64_t>() > 0;
    taken_vertices += answer["recompute"]["vertices_taken"].get<int64_t>() > 0;
    owners_moved += answer["cells"]["owner_changed"].get<int64_t>() > 0;
    adjusted |= session->seeds().adjusted();
  }
  // The sequence exercised what it is meant to: additions, undo, owners moving, lines taken from
  // the kept pieces (no weights yet) and weights or reaches later.
  EXPECT_GT(added, 0);
  EXPECT_GT(undos, 0);
  EXPECT_GT(owners_moved, 5);
  EXPECT_GT(taken_rows, 0);
  EXPECT_GT(taken_vertices, 0) << "no step took a vertex of its rows from the kept pieces";
  EXPECT_TRUE(adjusted);
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// What a session holds, to compare before and after a refused edit.
struct Snapshot {
  json features, info;
  std::map<std::string, std::string> texts;
  std::vector<int32_t> sites;
  std::vector<float> distances;
};
Snapshot snapshot(const Session& s) {
  const auto& sites = s.field().site.cells();
  const auto& distances = s.field().distance.cells();
  Snapshot out{s.features(), s.info(), {}, {sites.begin(), sites.end()}, {distances.begin(), distances.end()}};
  for (const std::string& name : s.deliverables()) out.texts[name] = s.deliverable(name);
  out.info.erase("memory_bytes");
  out.info.erase("bytes_per_cell");
  return out;
}
void expect_same(const Snapshot& a, const Snapshot& b) {
  EXPECT_EQ(a.features, b.features);
  EXPECT_EQ(a.info, b.info);
  EXPECT_TRUE(a.texts == b.texts) << "a deliverable changed";
  EXPECT_TRUE(a.sites == b.sites) << "the field's sites changed";
  EXPECT_TRUE(a.distances == b.distances) << "the field's distances changed";
}

// Bad edits get one line each and leave the session as it was; undo back to the start gives the
// start's deliverables; a memory limit refuses.
TEST_F(SessionTest, BadEditsAreRefusedAndChangeNothing) {
  const json fc = {
      {"type", "FeatureCollection"},
      {"crs", {{"type", "name"}, {"properties", {{"name", "urn:ogc:def:crs:EPSG::32633"}}}}},
      {"features",
       {{{"type", "Feature"},
         {"properties", {{"owner", "A"}, {"weight", 1.0}}},
         {"geometry", {{"type", "Point"}, {"coordinates", {502000.0, 6002000.0}}}}},
        {{"type", "Feature"},
         {"properties", {{"owner", "B"}, {"weight", 1.0}}},
         {"geometry", {{"type", "Point"}, {"coordinates", {508000.0, 6007000.0}}}}},
        {{"type", "Feature"},
         {"properties", {{"owner", "C"}, {"weight", 1.0}}},
         {"geometry",
          {{"type", "Polygon"},
           {"coordinates",
            {{{504000.0, 6008000.0},
              {506000.0, 6008000.0},
              {506000.0, 6009000.0},
              {504000.0, 6009000.0},
              {504000.0, 6008000.0}}}}}}},
        {{"type", "Feature"},
         {"properties", {{"owner", "C"}, {"weight", 1.0}}},
         {"geometry", {{"type", "LineString"}, {"coordinates", {{501000.0, 6008000.0}, {502000.0, 6009000.0}}}}}}}}};
  const fs::path seeds = dir_ / "seeds.geojson";
  std::ofstream(seeds) << fc.dump();
  JobSpec s = spec(seeds.string(), 100.0, {500000.0, 6000000.0, 510000.0, 6010000.0}, "1500");
  s.seeds.reach_field.reset();
  std::unique_ptr<Session> session = Session::create(s);
  const Snapshot start = snapshot(*session);
  EXPECT_EQ(session->features()["features"][0]["id"], "1");
  const double nan = std::nan("");
  const std::vector<std::pair<json, ErrorKind>> bad = {
      {json::array(), ErrorKind::invalid_argument},
      {{{{"op", "explode"}, {"feature", "1"}}}, ErrorKind::invalid_argument},
      {{{{"op", "remove"}, {"feature", "99"}}}, ErrorKind::invalid_argument},
      {{{{"op", "move-vertex"}, {"feature", "1"}, {"path", json::array()}, {"to", {nan, 6002000.0}}}},
       ErrorKind::invalid_argument},
      {{{{"op", "move-vertex"}, {"feature", "1"}, {"path", json::array()}, {"to", {5e12, 6002000.0}}}},
       ErrorKind::invalid_argument},
      {{{{"op", "move-vertex"}, {"feature", "4"}, {"path", {0, 7}}, {"to", {501000.0, 6008000.0}}}},
       ErrorKind::invalid_argument},
      {{{{"op", "move-vertex"}, {"feature", "3"}, {"path", {0, 0}}, {"to", {501000.0, 6008000.0}}}},
       ErrorKind::invalid_argument},
      {{{{"op", "set"}, {"feature", "1"}, {"properties", {{"weight", "heavy"}}}}}, ErrorKind::invalid_argument},
      {{{{"op", "set"}, {"feature", "1"}, {"properties", {{"weight", -1.0}}}}}, ErrorKind::invalid_argument},
      {{{{"op", "set"}, {"feature", "1"}, {"properties", {{"colour", "red"}}}}}, ErrorKind::invalid_argument},
      {{{{"op", "add"}, {"properties", {{"weight", 1.0}}}, {"geometry", {{"type", "Point"}, {"coordinates", {1, 2}}}}}},
       ErrorKind::invalid_argument},
      // A point of A inside C's island: a conflict between owners.
      {{{{"op", "move-vertex"}, {"feature", "1"}, {"path", json::array()}, {"to", {505500.0, 6008200.0}}}},
       ErrorKind::conflict},
      // The island's ring made to cross itself (a bow tie).
      {{{{"op", "move-vertex"}, {"feature", "3"}, {"path", {0, 0, 1}}, {"to", {504500.0, 6009500.0}}}},
       ErrorKind::invalid_input},
      // Every feature removed.
      {{{{"op", "remove"}, {"feature", "1"}},
        {{"op", "remove"}, {"feature", "2"}},
        {{"op", "remove"}, {"feature", "3"}},
        {{"op", "remove"}, {"feature", "4"}}},
       ErrorKind::invalid_input},
      // A good edit then a bad one in the same step: the whole step is refused.
      {{{{"op", "move-vertex"}, {"feature", "1"}, {"path", json::array()}, {"to", {503000.0, 6002000.0}}},
        {{"op", "remove"}, {"feature", "nope"}}},
       ErrorKind::invalid_argument},
  };
  for (const auto& [edits, kind] : bad) {
    SCOPED_TRACE(edits.dump());
    try {
      session->edit(edits);
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), kind) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << "one line: " << e.what();
    }
    expect_same(start, snapshot(*session));
  }
  EXPECT_THROW(session->undo(), Error);
  EXPECT_THROW(session->redo(), Error);
  // Good steps, then undo back to the start: the start's field and deliverables.
  const json moved = session->edit(
      {{{"op", "move-vertex"}, {"feature", "1"}, {"path", json::array()}, {"to", {503000.0, 6002500.0}}}});
  EXPECT_GT(moved["cells"]["owner_changed"].get<int64_t>(), 0);
  session->edit({{{"op", "add"},
                  {"properties", {{"owner", "D"}}},
                  {"geometry", {{"type", "Point"}, {"coordinates", {507000.0, 6001000.0}}}}}});
  session->edit({{{"op", "set"}, {"feature", "2"}, {"properties", {{"weight", 1.5}, {"reach", 3000.0}}}}});
  session->edit({{{"op", "move-vertex"}, {"feature", "3"}, {"path", {0, 0, 3}}, {"to", {504100.0, 6008050.0}}}});
  EXPECT_EQ(session->info()["owners"].size(), 4u) << "a new owner takes the next code";
  EXPECT_EQ(session->info()["owners"][3]["label"], "D");
  for (int i = 0; i < 4; ++i) session->undo();
  Snapshot back = snapshot(*session);
  back.info["owners"] = start.info["owners"];  // the new owner's code stays, without features
  back.info["areas"] = start.info["areas"];
  EXPECT_EQ(back.info["redo"], 4);
  back.info["redo"] = 0;
  expect_same(start, back);
  // Redo everything, then a memory limit the session is already over refuses creation.
  for (int i = 0; i < 4; ++i) session->redo();
  EXPECT_EQ(session->steps(), 4);
  SessionLimits tight;
  tight.max_memory_bytes = 1000;
  try {
    Session::create(s, tight);
    ADD_FAILURE() << "a session over its memory limit was created";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::too_large) << e.what();
  }
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// The western Baltic's coasts (four states, land borders, tripoints), geodesic: DK coast
// vertices moved by about 100 m, a weight (the adjusted method, every cell computed again), a
// state removed and put back by undo.
TEST_F(SessionTest, BalticGeodesicEditsEqualFreshRuns) {
  JobSpec s = baltic_spec(0.01, true);
  std::unique_ptr<Session> session = Session::create(s);
  check_fresh(*session, s, nullptr, "created");
  const json features = session->features();
  std::string dk;
  for (const json& f : features["features"])
    if (f["properties"]["owner"] == "DK") dk = f["id"].get<std::string>();
  ASSERT_FALSE(dk.empty());
  // DK's parts and their outer rings, from the features' GeoJSON.
  const json& dk_geometry = [&]() -> const json& {
    for (const json& f : features["features"])
      if (f["id"] == dk) return f["geometry"];
    throw std::runtime_error("no DK");
  }();
  ASSERT_EQ(dk_geometry["type"], "GeometryCollection");
  std::mt19937 rng(54);
  int moved = 0, refused = 0, taken = 0, taken_vertices = 0;
  for (int step = 0; step < 3; ++step) {
    const size_t part = std::uniform_int_distribution<size_t>(0, dk_geometry["geometries"].size() - 1)(rng);
    const json& ring = dk_geometry["geometries"][part]["coordinates"][0];
    const size_t v = std::uniform_int_distribution<size_t>(0, ring.size() - 2)(rng);
    json to = ring[v];
    to[0] = to[0].get<double>() + 0.0012;  // about 80 m east
    to[1] = to[1].get<double>() + 0.0005;  // about 55 m north
    json answer;
    try {
      answer = session->edit({{{"op", "move-vertex"}, {"feature", dk}, {"path", {part, 0, v}}, {"to", to}}});
    } catch (const Error& e) {
      // A vertex of a narrow spit may cross the coast's next edge: refused, as it should be.
      EXPECT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
      ++refused;
      continue;
    }
    ++moved;
    taken += answer["recompute"]["rows_taken"].get<int64_t>() > 0;
    taken_vertices += answer["recompute"]["vertices_taken"].get<int64_t>() > 0;
    check_fresh(*session, s, answer, "move " + std::to_string(step));
  }
  EXPECT_GE(moved, 2);
  EXPECT_GT(taken, 0) << "no step took lines from the kept pieces";
  EXPECT_GT(taken_vertices, 0) << "no step took a vertex of its rows from the kept pieces";
  std::string se, de;
  for (const json& f : features["features"]) {
    if (f["properties"]["owner"] == "SE") se = f["id"].get<std::string>();
    if (f["properties"]["owner"] == "DE") de = f["id"].get<std::string>();
  }
  json answer = session->edit({{{"op", "set"}, {"feature", se}, {"properties", {{"weight", 1.2}}}}});
  check_fresh(*session, s, answer, "weight");
  // (Reaches: the planar random sequences.)
  answer = session->edit({{{"op", "remove"}, {"feature", de}}});
  EXPECT_GT(answer["cells"]["owner_changed"].get<int64_t>(), 0);
  check_fresh(*session, s, answer, "remove");
  answer = session->undo();
  check_fresh(*session, s, answer, "undo");
  EXPECT_GT(regions_checked, 2);
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// A session with partial effect (an island of B at half effect): every step computes the whole
// job again and says so; after each step, undo and redo included, its field is
// compute_partial_effect's on its seeds, cell for cell, its deliverables a fresh job's on its
// features (with their effect) byte for byte, and its regions' areas that job's. "set" changes
// an effect there and is refused one in a session without partial effect.
TEST_F(SessionTest, PartialEffectStepsComputeTheWholeJob) {
  const double x0 = 500000.0, y0 = 6000000.0, size = 30000.0;
  auto at = [&](double x, double y) { return json::array({x0 + x, y0 + y}); };
  auto feature = [](const char* owner, double effect, const char* type, json coordinates) {
    return json{{"type", "Feature"},
                {"properties", {{"owner", owner}, {"weight", 1.0}, {"effect", effect}}},
                {"geometry", {{"type", type}, {"coordinates", std::move(coordinates)}}}};
  };
  json fc = {{"type", "FeatureCollection"},
             {"crs", {{"type", "name"}, {"properties", {{"name", "urn:ogc:def:crs:EPSG::32633"}}}}},
             {"features", json::array()}};
  fc["features"].push_back(
      feature("A", 1.0, "LineString", json::array({at(3000, 2000), at(4000, 15000), at(2500, 28000)})));
  fc["features"].push_back(
      feature("B", 1.0, "LineString", json::array({at(27000, 2000), at(26000, 15000), at(27500, 28000)})));
  fc["features"].push_back(
      feature("B", 0.5, "Polygon",
              json::array({json::array({at(13000, 14000), at(14500, 14000), at(14500, 15500), at(13000, 14000)})})));
  fc["features"].push_back(feature("A", 1.0, "Point", at(8000, 6000)));
  const fs::path seeds = dir_ / "partial.geojson";
  std::ofstream(seeds) << fc.dump();
  JobSpec s = spec(seeds.string(), kPlanarCell, {x0, y0, x0 + size, y0 + size}, "2500");
  s.seeds.reach_field.reset();
  s.seeds.effect_field = "effect";
  s.outputs.turning_points.clear();  // (not with partial effect)
  std::unique_ptr<Session> session = Session::create(s);
  auto check = [&](const json& answer, const std::string& what) {
    SCOPED_TRACE(what);
    if (!answer.is_null()) {
      EXPECT_TRUE(answer["recompute"]["whole"].is_string()) << answer["recompute"].dump();
      EXPECT_EQ(answer["recompute"]["cells"], session->grid().cell_count());
    }
    BoundaryOptions lines;
    lines.simplify_cells = s.outputs.simplify_cells;
    lines.line_tolerance = session->job().line_tolerance;
    lines.threads = 2;
    ComputeOptions co = session->job().compute;
    co.prepared = nullptr;
    const PartialEffectResult fresh = compute_partial_effect(session->seeds(), session->grid(), co, lines, true);
    const NearestField& field = session->field();
    ASSERT_EQ(fresh.field.site.cells().size(), field.site.cells().size());
    int64_t differ = 0;
    for (size_t i = 0; i < field.site.cells().size(); ++i)
      differ += fresh.field.site.cells()[i] != field.site.cells()[i] ||
                std::bit_cast<uint32_t>(fresh.field.distance.cells()[i]) !=
                    std::bit_cast<uint32_t>(field.distance.cells()[i]);
    EXPECT_EQ(differ, 0) << "cells that differ from compute_partial_effect's field";
    const fs::path run = dir_ / ("partial_" + std::to_string(++runs_));
    fs::create_directories(run);
    std::ofstream(run / "seeds.geojson") << session->features().dump();
    JobSpec f = s;
    f.seeds.paths = {(run / "seeds.geojson").string()};
    f.seeds.target_crs = session->job().loaded.crs.wkt;
    f.outputs.boundaries = (run / "boundaries.geojson").string();
    f.outputs.tripoints = (run / "tripoints.geojson").string();
    f.outputs.limits = (run / "limits.geojson").string();
    f.outputs.regions = (run / "regions.geojson").string();
    const JobResult r = run_job(f);
    for (const std::string& name : session->deliverables())
      EXPECT_TRUE(session->deliverable(name) == read_text(run / (name + ext_of(name)))) << name << " differs";
    std::map<std::string, double> fresh_area;
    for (const json& a : r.report["deliverables"]["regions"]["areas"])
      fresh_area[a["label"].get<std::string>()] = a["area"].get<double>();
    const json info = session->info();  // the loop below must not outlive a temporary
    for (const json& a : info["areas"]) {
      const std::string label = a["label"].get<std::string>();
      ASSERT_TRUE(fresh_area.count(label)) << label;
      EXPECT_NEAR(a["area"].get<double>(), fresh_area[label], 1e-9 * fresh_area[label]) << label;
    }
  };
  check(nullptr, "created");
  EXPECT_EQ(session->features()["features"][2]["properties"]["effect"], 0.5);
  json answer =
      session->edit({{{"op", "move-vertex"}, {"feature", "3"}, {"path", {0, 0, 1}}, {"to", at(15500, 13500)}}});
  check(answer, "island vertex moved");
  EXPECT_GT(answer["cells"]["owner_changed"].get<int64_t>(), 0);
  answer = session->edit({{{"op", "set"}, {"feature", "3"}, {"properties", {{"effect", 0.25}}}}});
  check(answer, "effect set");
  EXPECT_GT(answer["cells"]["owner_changed"].get<int64_t>(), 0);
  answer = session->edit({{{"op", "remove"}, {"feature", "4"}}});
  check(answer, "point removed");
  check(session->undo(), "undo");
  check(session->redo(), "redo");
  // The rule refuses an owner all of whose features are partial: refused, nothing changed.
  const std::string before = session->deliverable("boundaries");
  EXPECT_THROW(session->edit({{{"op", "set"}, {"feature", "2"}, {"properties", {{"effect", 0.5}}}}}), Error);
  EXPECT_EQ(session->deliverable("boundaries"), before);
  check(nullptr, "after the refused edit");
  // Without partial effect, no effect is set.
  JobSpec plain = s;
  plain.seeds.effect_field.reset();
  std::unique_ptr<Session> other = Session::create(plain);
  EXPECT_FALSE(other->features()["features"][0]["properties"].contains("effect"));
  try {
    other->edit({{{"op", "set"}, {"feature", "3"}, {"properties", {{"effect", 0.5}}}}});
    ADD_FAILURE() << "an effect set in a session without partial effect";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("effect"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// Random edit sequences on the western Baltic, geodesic (0.02 degree cells): points and lines
// added for new owners at sea, moved, replaced, given owners, weights and reaches, removed;
// the states given weights and reaches; undo and redo. After every step the session equals a
// fresh computation and a fresh job (check_fresh).
TEST_F(SessionTest, BalticGeodesicRandomEditsEqualFreshRuns) {
  JobSpec s = baltic_spec(0.02, true);
  std::unique_ptr<Session> session = Session::create(s);
  check_fresh(*session, s, nullptr, "created");
  const GridSpec& g = session->grid();
  const double size = std::min(g.width, g.height) * g.res;
  std::mt19937 rng(41);
  std::map<std::string, int> ops;
  int added = 0, done = 0;
  for (int step = 0; step < 5; ++step) {
    json answer;
    const int what = std::uniform_int_distribution<int>(0, 7)(rng);
    if (what == 0 && session->info()["undo"].get<int>() > 0) {
      answer = session->undo();
      ++ops["undo"];
    } else if (what == 1 && session->info()["redo"].get<int>() > 0) {
      answer = session->redo();
      ++ops["redo"];
    } else {
      json edit = random_edit(session->features(), rng, g.xmin, g.ymin(), size, added, false);
      // Reaches in nautical miles that span cells (random_edit scales them by the box's size in
      // degrees: 0.6-2 nmi, one or two of these cells).
      if (edit["op"] == "set" && edit["properties"].contains("reach") && edit["properties"]["reach"].is_number())
        edit["properties"]["reach"] = edit["properties"]["reach"].get<double>() * 10.0;
      try {
        answer = session->edit(json::array({edit}));
      } catch (const Error& e) {
        // A point or line put on another owner's land is a conflict, refused.
        ASSERT_EQ(e.kind(), ErrorKind::conflict) << e.what() << "\n" << edit.dump();
        continue;
      }
      ++ops[edit["op"].get<std::string>()];
    }
    ++done;
    check_fresh(*session, s, answer, "step " + std::to_string(step) + ": " + answer.dump().substr(0, 200));
  }
  if (session->info()["undo"].get<int>() > 0) {
    check_fresh(*session, s, session->undo(), "undo at the end");
    check_fresh(*session, s, session->redo(), "redo at the end");
  }
  EXPECT_GE(done, 4);
  EXPECT_GT(ops["add"], 0);
  EXPECT_GT(ops["set"], 0);
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// A reach's arc that ends just short of a square where three owners meet: the tripoint search
// found the point from the arc and took the third owner's nearest site there, which no site of
// it reaches (none), and measured it (a crash). The western Baltic at 0.03 degrees, DE weighted,
// DK given a reach of about 20 nmi: the job of those seeds runs, its boundaries and tripoints
// as a fresh job's.
TEST_F(SessionTest, AReachArcShortOfATripointSquareIsNoTripoint) {
  JobSpec s = baltic_spec(0.03);
  s.outputs.boundaries = "b.geojson";
  s.outputs.tripoints = "t.geojson";
  std::unique_ptr<Session> session = Session::create(s);
  session->edit({{{"op", "set"}, {"feature", "3"}, {"properties", {{"weight", 1.1060897462518382}}}}});
  session->edit({{{"op", "set"}, {"feature", "1"}, {"properties", {{"reach", 20.395116876380737}}}}});
  // The job of the session's seeds (the path that met the arc's end), streamed as a job runs.
  const fs::path run = dir_ / "fresh";
  fs::create_directories(run);
  PreparedJob j = session->job();
  j.compute.prepared = nullptr;
  JobSpec ps = s;
  ps.outputs.boundaries = (run / "boundaries.geojson").string();
  ps.outputs.tripoints = (run / "tripoints.geojson").string();
  const JobResult r = run_prepared(ps, j);
  EXPECT_GT(r.report["deliverables"]["boundaries"]["lines"].get<int64_t>(), 0) << r.report["deliverables"].dump();
  EXPECT_TRUE(session->deliverable("boundaries") == read_text(run / "boundaries.geojson"));
  EXPECT_TRUE(session->deliverable("tripoints") == read_text(run / "tripoints.geojson"));
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// A step that fails after its cells were made (here the regions its answer needs, with a
// relevant area: a reach of two cells on the western Baltic at 0.02 degrees leaves line ends
// the regions cannot join, which a fresh job refuses too) rolls back: the error is the job's,
// and the session is as it was (field, features, files).
TEST_F(SessionTest, AStepThatFailsAfterItsCellsRollsBack) {
  JobSpec s = baltic_spec(0.02);
  s.outputs.boundaries = "b.geojson";
  s.outputs.regions = "r.geojson";
  const json area = {
      {"type", "FeatureCollection"},
      {"features",
       {{{"type", "Feature"},
         {"properties", json::object()},
         {"geometry",
          {{"type", "Polygon"},
           {"coordinates", {{{10.5, 54.2}, {13.5, 54.2}, {13.5, 55.8}, {10.5, 55.8}, {10.5, 54.2}}}}}}}}}};
  std::ofstream(dir_ / "area.geojson") << area.dump();
  s.outputs.relevant_area = (dir_ / "area.geojson").string();
  std::unique_ptr<Session> session = Session::create(s);
  session->edit({{{"op", "set"}, {"feature", "3"}, {"properties", {{"weight", 1.1060897462518382}}}}});
  const Snapshot before = snapshot(*session);
  try {
    session->edit({{{"op", "set"}, {"feature", "1"}, {"properties", {{"reach", 2.0395116876380737}}}}});
    ADD_FAILURE() << "the step was expected to fail in its regions";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("regions"), std::string::npos) << e.what();
  }
  expect_same(before, snapshot(*session));
  // And it goes on: the step before undone, its field compute()'s on the seeds.
  session->undo();
  ComputeOptions co = session->job().compute;
  co.prepared = nullptr;
  const NearestField fresh = compute(session->seeds(), session->grid(), co);
  EXPECT_TRUE(fresh.site.cells() == session->field().site.cells());
  EXPECT_TRUE(fresh.distance.cells() == session->field().distance.cells());
}

}  // namespace
}  // namespace rv
