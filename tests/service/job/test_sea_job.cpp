// The distance by sea in a job (JobSpec::barriers, service/src/job/job_sea.hpp): the files are
// the core engine's field cell for cell, streamed or whole, for any strip height and thread count;
// validation runs the brute-force oracle by sea; coasts as both seeds and land change nothing off
// the land; seeds just inland are moved onto the coast, deeper ones refused; cells no seed reaches
// have no owner; partial effect and the relevant area by sea; and every combination the distance
// by sea does not do is refused in one line, with nothing written.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/engine/outputs.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/job.hpp"

namespace fs = std::filesystem;

#include "fixtures.hpp"
#include "geotiff_compare.hpp"
#include "sea_ports.hpp"

namespace rv {
namespace {

using test::expect_same_geotiff;
using test::fixture;

constexpr const char* kUtm33 = R"("crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}})";

nlohmann::json read_json(const std::string& path) { return nlohmann::json::parse(std::ifstream(path)); }

class SeaJob : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rv_sea_job_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Twelve ports on the Øresund's coasts (fixtures/oresund_ports.geojson, owners DK and SE) and
  // the two states' land as barriers, in UTM 33N: 160 x 280 cells of 250 m over the strait.
  JobSpec ports_spec(const std::string& sub) const {
    JobSpec s = test::oresund_ports_by_sea();
    return with_outputs(s, sub);
  }
  JobSpec with_outputs(JobSpec s, const std::string& sub) const {
    fs::create_directories(dir_ / sub);
    s.outputs.ownership = (dir_ / sub / "own.tif").string();
    s.outputs.distance = (dir_ / sub / "dist.tif").string();
    s.outputs.nearest_feature = (dir_ / sub / "feat.tif").string();
    s.outputs.via = (dir_ / sub / "via.tif").string();
    s.outputs.report = (dir_ / sub / "report.json").string();
    return s;
  }
  // The states of fixture `states` (owner field iso2, overlaps to the lower code) as seeds at 0.02
  // deg over `extent`: straight (boundaries in straight/lines.geojson), and by sea with the same
  // file as the land (sea/lines.geojson); both with with_outputs' rasters and report.
  std::pair<JobSpec, JobSpec> states_straight_and_by_sea(const std::string& states,
                                                         std::array<double, 4> extent) const {
    JobSpec sea;
    sea.seeds.paths = {fixture(states)};
    sea.seeds.owner_field = "iso2";
    sea.seeds.on_conflict = ConflictPolicy::lower_code;
    sea.grid.resolution = 0.02;
    sea.grid.extent = extent;
    JobSpec straight = with_outputs(sea, "straight");
    straight.outputs.via.clear();
    straight.outputs.boundaries = (dir_ / "straight" / "lines.geojson").string();
    sea.barriers = {fixture(states)};
    sea = with_outputs(sea, "sea");
    sea.outputs.boundaries = (dir_ / "sea" / "lines.geojson").string();
    return {straight, sea};
  }
  // states_straight_and_by_sea's two runs, by sea with regions: its report and lines, and the
  // straight lines.
  struct StatesRun {
    JobSpec sea;
    nlohmann::json report, lines, straight_lines;
  };
  StatesRun run_states_with_regions(const std::string& states, std::array<double, 4> extent) const {
    auto [straight, sea] = states_straight_and_by_sea(states, extent);
    sea.outputs.regions = (dir_ / "sea" / "regions.geojson").string();
    run_job(straight);
    StatesRun r{sea, run_job(sea).report, {}, {}};
    r.lines = read_json(sea.outputs.boundaries);
    r.straight_lines = read_json(straight.outputs.boundaries);
    return r;
  }
  std::string write(const std::string& name, const std::string& text) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }
  // The refusal of `spec`: its kind and message, and nothing left in its outputs' folder.
  Error refused(const JobSpec& spec) const {
    const fs::path folder = fs::path(spec.outputs.ownership).parent_path();
    try {
      run_job(spec);
    } catch (const Error& e) {
      EXPECT_TRUE(fs::is_empty(folder)) << e.what();
      return e;
    }
    ADD_FAILURE() << "not refused";
    return Error(ErrorKind::internal, "not refused");
  }

  // Runs both; off land the files agree bit for bit, on land the run by sea has no owner.
  void expect_coasts_change_nothing(const JobSpec& straight, const JobSpec& sea);

  fs::path dir_;
};

// The two regions of `spec` (GeoJSON) against its ownership raster (cells of `cell` x `cell`):
// each owner's sea area within `relative` of its cells' area.
void expect_regions_match_cells(const JobSpec& spec, double cell, double relative) {
  const Raster<int32_t> own = read_int32(spec.outputs.ownership);
  std::map<int32_t, double> cells;
  for (const int32_t o : own.cells())
    if (o != 0) cells[o] += cell * cell;
  const nlohmann::json regions = read_json(spec.outputs.regions);
  ASSERT_EQ(regions.at("features").size(), 2u);
  for (const nlohmann::json& f : regions.at("features")) {
    const int32_t owner = f.at("properties").at("owner").get<int32_t>();
    EXPECT_NEAR(f.at("properties").at("sea_area").get<double>(), cells[owner], relative * cells[owner]) << owner;
  }
}

// An island of SE's in the strait (the partial-effect tests' feature) of effect `effect`.
nlohmann::json strait_island(double effect) {
  return {{"type", "Feature"},
          {"properties", {{"owner", "SE"}, {"effect", effect}}},
          {"geometry",
           {{"type", "Polygon"}, {"coordinates", {{{12.66, 55.88}, {12.72, 55.88}, {12.69, 55.93}, {12.66, 55.88}}}}}}};
}

std::string feature_collection(const nlohmann::json& features) {
  return nlohmann::json{{"type", "FeatureCollection"}, {"features", features}}.dump();
}

TEST_F(SeaJob, FilesAreTheEngineFieldCellForCell) {
  const JobSpec spec = ports_spec("a");
  const JobResult result = run_job(spec);
  const PreparedJob job = prepare_job(spec);
  ASSERT_TRUE(job.sea);
  SeaOptions options;
  options.prepared = job.sea->prepared;
  const SeaField f = compute_sea(job.loaded.seeds, job.sea->loaded.barriers, job.grid, job.grid.full_window(), options);

  const Raster<int32_t> own = read_int32(spec.outputs.ownership);
  const Raster<float> dist = read_float32(spec.outputs.distance);
  const Raster<int32_t> via = read_int32(spec.outputs.via);
  const Raster<int32_t> expected_owner = owner_raster(job.loaded.seeds, f.field, 1);
  ASSERT_EQ(own.cells().size(), f.field.site.cells().size());
  int64_t land = 0, bent = 0, direct = 0;
  std::set<int32_t> vias;
  for (size_t c = 0; c < own.cells().size(); ++c) {
    ASSERT_EQ(own.cells()[c], expected_owner.cells()[c]) << c;
    ASSERT_EQ(dist.cells()[c], f.field.distance.cells()[c]) << c;  // metres both: bit for bit
    ASSERT_EQ(via.cells()[c], f.via.cells()[c] + 1) << c;
    land += own.cells()[c] == 0;
    if (via.cells()[c] > 0) {
      ++bent;
      vias.insert(via.cells()[c]);
    } else if (own.cells()[c] != 0) {
      ++direct;
    }
  }
  // The strait bends paths round Zealand's and Scania's headlands; land has no owner.
  EXPECT_GT(bent, 1000);
  EXPECT_GT(direct, 1000);
  EXPECT_EQ(land, f.land_cells);
  EXPECT_GT(land, 5000);

  const nlohmann::json sea = read_json(spec.outputs.report).at("sea");
  EXPECT_EQ(sea.at("land_cells").get<int64_t>(), f.land_cells);
  EXPECT_EQ(sea.at("unreachable_cells").get<int64_t>(), 0);
  EXPECT_EQ(sea.at("barriers").at("features").get<int64_t>(), 2);
  EXPECT_EQ(sea.at("barriers").at("vertices").get<int32_t>(), f.barrier_vertices);
  EXPECT_EQ(sea.at("bend_nodes").get<int64_t>(), f.bend_nodes);
  EXPECT_GT(sea.at("visibility_tests").at("all").get<int64_t>(), sea.at("visibility_tests").at("bends").get<int64_t>());
  EXPECT_GT(sea.at("max_detour").get<double>(), 1.0);
  EXPECT_EQ(sea.at("snap").at("moved").get<int64_t>(), 0);  // the ports are the land's own vertices
  // The via vertices listed are those the raster names, each at a vertex of the land.
  std::set<int32_t> listed;
  const Barriers& barriers = job.sea->loaded.barriers;
  for (const nlohmann::json& v : sea.at("via_vertices")) {
    listed.insert(v.at(0).get<int32_t>());
    const Vec2 at{v.at(1).get<double>(), v.at(2).get<double>()};
    double nearest = INFINITY;
    for (const Barriers::Polygon& p : barriers.polygons())
      for (const Ring& r : p.rings)
        for (const Vec2& q : r) nearest = std::min(nearest, std::hypot(q.x - at.x, q.y - at.y));
    EXPECT_LT(nearest, 1e-6) << v;
  }
  EXPECT_EQ(listed, vias);
  EXPECT_TRUE(result.report.at("streaming").at("streamed").get<bool>());
}

// On the ellipsoid (a longitude/latitude grid, the metric geodesic by default): the files are
// the core engine's geodesic field, and validation by the oracle finds nothing.
TEST_F(SeaJob, OnTheEllipsoidTheFilesAreTheGeodesicField) {
  JobSpec spec = ports_spec("geo");
  spec.seeds.target_crs.clear();
  spec.metric = MetricRequest::automatic;
  spec.grid.extent = std::array<double, 4>{12.3, 55.4, 13.0, 56.15};
  spec.grid.resolution = 0.005;
  const nlohmann::json report = run_job(spec).report;
  EXPECT_EQ(report.at("metric"), "geodesic");
  const PreparedJob job = prepare_job(spec);
  SeaOptions options;
  options.metric = job.metric;
  options.prepared = job.sea->prepared;
  const SeaField f = compute_sea(job.loaded.seeds, job.sea->loaded.barriers, job.grid, job.grid.full_window(), options);
  const Raster<float> dist = read_float32(spec.outputs.distance);
  const Raster<int32_t> via = read_int32(spec.outputs.via);
  int64_t bent = 0;
  for (size_t c = 0; c < dist.cells().size(); ++c) {
    ASSERT_EQ(dist.cells()[c], f.field.distance.cells()[c]) << c;
    ASSERT_EQ(via.cells()[c], f.via.cells()[c] + 1) << c;
    bent += via.cells()[c] > 0;
  }
  EXPECT_GT(bent, 1000);
  // The via vertices are given in longitude and latitude.
  for (const nlohmann::json& v : report.at("sea").at("via_vertices")) {
    EXPECT_GT(v.at(1).get<double>(), 12.0);
    EXPECT_LT(v.at(2).get<double>(), 56.3);
  }
  JobSpec checked = ports_spec("geo_checked");
  checked.seeds.target_crs.clear();
  checked.metric = MetricRequest::automatic;
  checked.grid.extent = std::array<double, 4>{12.3, 55.4, 13.0, 56.15};
  checked.grid.resolution = 0.02;
  checked.validate = true;
  const nlohmann::json v = run_job(checked).report.at("validation");
  EXPECT_EQ(v.at("wrong_owner_cells").get<int64_t>(), 0);
  EXPECT_EQ(v.at("nodata_mismatch").get<int64_t>(), 0);
  EXPECT_LT(v.at("max_error").get<double>(), 1e-2);
}

// The geodesic metric on the projected grid (UTM 33N): every cell centre located on WGS84 (the
// job's geolocator), the seeds and barriers read in longitude/latitude; the files are the core
// engine's field with that geolocator, the vias' positions are UTM metres, and the oracle by sea
// agrees.
TEST_F(SeaJob, OnAProjectedGridTheGeodesicFieldIsLocated) {
  JobSpec spec = ports_spec("projected");
  spec.metric = MetricRequest::geodesic;
  const nlohmann::json report = run_job(spec).report;
  EXPECT_EQ(report.at("metric"), "geodesic");
  const PreparedJob job = prepare_job(spec);
  ASSERT_TRUE(job.compute.geolocator);
  SeaOptions options;
  options.metric = job.metric;
  options.geolocator = job.compute.geolocator;
  options.grid_polygons = job.compute.grid_polygons;
  const SeaField f = compute_sea(job.loaded.seeds, job.sea->loaded.barriers, job.grid, job.grid.full_window(), options);
  const Raster<float> dist = read_float32(spec.outputs.distance);
  const Raster<int32_t> via = read_int32(spec.outputs.via);
  int64_t bent = 0, land = 0;
  for (size_t c = 0; c < dist.cells().size(); ++c) {
    ASSERT_EQ(dist.cells()[c], f.field.distance.cells()[c]) << c;
    ASSERT_EQ(via.cells()[c], f.via.cells()[c] + 1) << c;
    bent += via.cells()[c] > 0;
    land += f.field.site.cells()[c] == kNoSite;
  }
  EXPECT_GT(bent, 1000);
  EXPECT_GT(land, 10000);
  // Against the planar run of the same grid: within the scale error of UTM (under 0.1 % here).
  JobSpec planar = ports_spec("projected_planar");
  run_job(planar);
  const Raster<float> flat = read_float32(planar.outputs.distance);
  for (size_t c = 0; c < dist.cells().size(); ++c)
    if (flat.cells()[c] > 1000.0f) {
      ASSERT_NEAR(dist.cells()[c] / flat.cells()[c], 1.0, 2e-3) << c;
    }
  // The vias' positions in the grid's CRS: UTM metres inside the grid.
  ASSERT_FALSE(report.at("sea").at("via_vertices").empty());
  for (const nlohmann::json& v : report.at("sea").at("via_vertices")) {
    EXPECT_GT(v.at(1).get<double>(), 330000.0);
    EXPECT_LT(v.at(1).get<double>(), 370000.0);
    EXPECT_GT(v.at(2).get<double>(), 6150000.0);
    EXPECT_LT(v.at(2).get<double>(), 6220000.0);
  }
  JobSpec checked = ports_spec("projected_checked");
  checked.metric = MetricRequest::geodesic;
  checked.grid.resolution = 1000.0;
  checked.validate = true;
  const nlohmann::json v = run_job(checked).report.at("validation");
  EXPECT_EQ(v.at("wrong_owner_cells").get<int64_t>(), 0);
  EXPECT_EQ(v.at("nodata_mismatch").get<int64_t>(), 0);
  EXPECT_LT(v.at("max_error").get<double>(), 1e-2);
}

TEST_F(SeaJob, StreamedEqualsWholeForAnyStripHeightAndThreads) {
  JobSpec whole = ports_spec("whole");
  whole.strip_rows = -1;
  whole.threads = 1;
  run_job(whole);
  for (const auto& [rows, threads] : {std::pair<int64_t, int>{256, 2}, {0, 1}, {1, 2}}) {
    JobSpec s = ports_spec("s" + std::to_string(rows) + "_" + std::to_string(threads));
    s.strip_rows = rows;
    s.threads = threads;
    const JobResult r = run_job(s);
    EXPECT_TRUE(r.report.at("streaming").at("streamed").get<bool>());
    // A source's strips hold whole bands of tiles: 256 rows, then the last 24 (the automatic
    // height: the whole grid).
    EXPECT_EQ(r.report.at("streaming").at("rows_per_strip").get<int64_t>(), rows == 0 ? 280 : 256);
    for (auto member :
         {&OutputRequest::ownership, &OutputRequest::distance, &OutputRequest::nearest_feature, &OutputRequest::via})
      expect_same_geotiff(whole.outputs.*member, s.outputs.*member);
  }
}

// A front end that keeps a prepared job (the Python module's, by move assignment) and runs it
// later, whole and streamed: the seeds have moved since the bend nodes were settled, and the run
// is still the job's own, file for file.
TEST_F(SeaJob, APreparedJobMovedBeforeItRunsGivesTheSameFiles) {
  for (const int64_t rows : {int64_t{-1}, int64_t{64}}) {
    JobSpec direct = ports_spec("direct" + std::to_string(rows));
    direct.strip_rows = rows;
    run_job(direct);
    JobSpec later = ports_spec("later" + std::to_string(rows));
    later.strip_rows = rows;
    PreparedJob kept;
    {
      PreparedJob made = prepare_job(later);
      kept = std::move(made);
    }
    ASSERT_TRUE(kept.sea);
    run_prepared(later, kept);
    for (auto member :
         {&OutputRequest::ownership, &OutputRequest::distance, &OutputRequest::nearest_feature, &OutputRequest::via})
      expect_same_geotiff(direct.outputs.*member, later.outputs.*member);
  }
}

// Partial effect by sea: an island of SE's in the strait given effect 0 is no seed but stays
// land (it is among the barriers): the run equals one without it among the seeds, file for file
// (the same grid, the same feature numbers).
TEST_F(SeaJob, AnIslandOfNilEffectIsNoSeedButStaysLand) {
  nlohmann::json ports = read_json(fixture("oresund_ports.geojson"));
  for (nlohmann::json& f : ports.at("features")) f["properties"]["effect"] = 1.0;
  // A fish farm at sea (a polygon seed of full effect, no barrier): its interior is owned, so the
  // polygons' numbering must survive the island's removal.
  ports["features"].push_back(
      {{"type", "Feature"},
       {"properties", {{"owner", "DK"}, {"effect", 1.0}}},
       {"geometry",
        {{"type", "Polygon"},
         {"coordinates", {{{12.74, 55.74}, {12.77, 55.74}, {12.77, 55.755}, {12.74, 55.755}, {12.74, 55.74}}}}}}});
  const std::string ports_and_farm = write("ports_and_farm.geojson", ports.dump());
  const nlohmann::json island = strait_island(0.0);
  const std::string island_only = write("island.geojson", feature_collection(nlohmann::json::array({island})));
  nlohmann::json with_island = ports;
  with_island["features"].push_back(island);
  const std::string seeds = write("ports_and_island.geojson", with_island.dump());
  // Planar in UTM 33N, and geodesic on that projected grid (the island's polygon in the grid's
  // CRS for its interior goes too).
  for (const MetricRequest metric : {MetricRequest::planar, MetricRequest::geodesic}) {
    const std::string name = metric == MetricRequest::planar ? "planar" : "geodesic";
    SCOPED_TRACE(name);
    JobSpec nil = ports_spec("nil_" + name);
    nil.metric = metric;
    nil.seeds.paths = {seeds};
    nil.seeds.effect_field = "effect";
    nil.barriers.push_back(island_only);
    JobSpec without = ports_spec("without_" + name);
    without.metric = metric;
    without.seeds.paths = {ports_and_farm};
    without.barriers.push_back(island_only);
    const nlohmann::json report = run_job(nil).report;
    run_job(without);
    for (auto member :
         {&OutputRequest::ownership, &OutputRequest::distance, &OutputRequest::nearest_feature, &OutputRequest::via})
      expect_same_geotiff(without.outputs.*member, nil.outputs.*member);
    // The island is land: more land than without it among the barriers.
    JobSpec open_strait = ports_spec("open_" + name);
    open_strait.metric = metric;
    open_strait.seeds.paths = {ports_and_farm};
    const nlohmann::json open_report = run_job(open_strait).report;
    EXPECT_GT(report.at("sea").at("land_cells").get<int64_t>(), open_report.at("sea").at("land_cells").get<int64_t>());
  }
}

// Partial effect above 0 by sea: the same island at half effect. Each cell is the full-effect
// run's (effect 1), or where the rule hands it back to the neighbour the nil-effect run's (effect
// 0: the island no seed but land), owner, distance and via alike; the lines by sea are drawn
// between them, and the report says what the rule did.
TEST_F(SeaJob, AnIslandOfHalfEffectTakesEachCellFromTheFullOrTheNilRun) {
  nlohmann::json ports = read_json(fixture("oresund_ports.geojson"));
  for (nlohmann::json& f : ports.at("features")) f["properties"]["effect"] = 1.0;
  const nlohmann::json island = strait_island(0.5);
  const std::string island_only = write("island.geojson", feature_collection(nlohmann::json::array({island})));
  auto run_at = [&](double effect, const std::string& name) {
    nlohmann::json seeds = ports;
    seeds["features"].push_back(island);
    seeds["features"].back()["properties"]["effect"] = effect;
    JobSpec s = ports_spec(name);
    s.seeds.paths = {write(name + ".geojson", seeds.dump())};
    s.seeds.effect_field = "effect";
    s.barriers.push_back(island_only);
    s.outputs.boundaries = (dir_ / name / "lines.gpkg").string();
    s.outputs.regions = (dir_ / name / "regions.gpkg").string();
    run_job(s);
    return s;
  };
  const JobSpec half = run_at(0.5, "half"), full = run_at(1.0, "full"), nil = run_at(0.0, "nil");
  const Raster<int32_t> own = read_int32(half.outputs.ownership), own1 = read_int32(full.outputs.ownership),
                        own0 = read_int32(nil.outputs.ownership);
  const Raster<float> dist = read_float32(half.outputs.distance), dist1 = read_float32(full.outputs.distance),
                      dist0 = read_float32(nil.outputs.distance);
  const Raster<int32_t> via = read_int32(half.outputs.via), via1 = read_int32(full.outputs.via),
                        via0 = read_int32(nil.outputs.via);
  int64_t kept = 0, given_back = 0;
  for (size_t i = 0; i < own.cells().size(); ++i) {
    if (own.cells()[i] == own1.cells()[i]) {
      ++kept;
      ASSERT_EQ(dist.cells()[i], dist1.cells()[i]) << i;
      ASSERT_EQ(via.cells()[i], via1.cells()[i]) << i;
    } else {
      ++given_back;
      ASSERT_EQ(own.cells()[i], own0.cells()[i]) << i;
      ASSERT_EQ(dist.cells()[i], dist0.cells()[i]) << i;
      ASSERT_EQ(via.cells()[i], via0.cells()[i]) << i;
    }
  }
  EXPECT_GT(given_back, 100);
  const nlohmann::json report = read_json(half.outputs.report);
  EXPECT_EQ(report.at("partial_effect").at("cells_to_neighbours").get<int64_t>(), given_back);
  const nlohmann::json& lines = report.at("deliverables").at("boundaries").at("partial_effect");
  EXPECT_GE(lines.at("stretches").get<int64_t>(), 1);
  EXPECT_GE(lines.at("coast_ends").get<int64_t>(), 1);
  EXPECT_EQ(lines.at("along_lines").at("unresolved_segments").get<int64_t>(), 0);
  EXPECT_GT(report.at("sea").at("land_cells").get<int64_t>(), 0);
  EXPECT_TRUE(report.contains("partial_effect_by_sea"));
  // The rule's regions checked against the rule's cells: every sea cell checked or on an edge,
  // none in the other owner's region.
  const nlohmann::json& check = report.at("deliverables").at("regions").at("against_cells");
  EXPECT_EQ(check.at("rows").get<int64_t>(), own.height());
  EXPECT_EQ(check.at("cells_checked").get<int64_t>() + check.at("cells_near_edges").get<int64_t>(),
            std::count_if(own.cells().begin(), own.cells().end(), [](int32_t o) { return o != 0; }));
  EXPECT_EQ(check.at("cells_in_another_region").get<int64_t>(), 0);
}

// A port of X's that an island of B's shuts in at full effect (a synthetic strait in UTM 33N:
// X's and B's coasts as barriers, one port on each, the island a seed and land, effect 0.1). The
// full line is an arc round the port wholly in the band; the job draws the locus found from the
// rule's cells instead of refusing, and the regions built on it agree with the cells: each
// owner's sea area within 0.5 % of its cells' area.
TEST_F(SeaJob, APortShutInByTheIslandHasItsLinesAndRegions) {
  auto polygon = [](const std::vector<std::array<double, 2>>& pts) {
    nlohmann::json ring = nlohmann::json::array();
    for (const auto& p : pts) ring.push_back({1000.0 * p[0], 1000.0 * p[1]});
    ring.push_back(ring.front());
    return nlohmann::json{{"type", "Polygon"}, {"coordinates", nlohmann::json::array({ring})}};
  };
  auto feature = [](const std::string& owner, double effect, nlohmann::json geometry) {
    return nlohmann::json{
        {"type", "Feature"}, {"properties", {{"owner", owner}, {"effect", effect}}}, {"geometry", std::move(geometry)}};
  };
  auto point = [](double x, double y) {
    return nlohmann::json{{"type", "Point"}, {"coordinates", {x * 1000.0, y * 1000.0}}};
  };
  const nlohmann::json west = polygon({{0, 0}, {8, 0}, {9, 20}, {7, 40}, {0, 40}});
  const nlohmann::json east = polygon({{40, 0}, {32, 0}, {31, 18}, {33, 40}, {40, 40}});
  const nlohmann::json island = polygon({{11, 17}, {15, 18}, {14, 23}, {11, 22}});
  const std::string crs = std::string(R"({"type": "FeatureCollection", )") + kUtm33 + R"(, "features": )";
  const std::string seeds =
      write("shut_in.geojson", crs +
                                   nlohmann::json::array({feature("X", 1.0, point(9, 20)),
                                                          feature("B", 1.0, point(31, 18)), feature("B", 0.1, island)})
                                       .dump() +
                                   "}");
  const std::string land = write(
      "shut_in_land.geojson",
      crs +
          nlohmann::json::array({feature("X", 1.0, west), feature("B", 1.0, east), feature("B", 1.0, island)}).dump() +
          "}");
  JobSpec s;
  s.seeds.paths = {seeds};
  s.seeds.owner_field = "owner";
  s.seeds.effect_field = "effect";
  s.metric = MetricRequest::planar;
  s.barriers = {land};
  s.grid.resolution = 250.0;
  s.grid.extent = std::array<double, 4>{0.0, 0.0, 40000.0, 40000.0};
  s = with_outputs(s, "shut_in");
  s.outputs.boundaries = (dir_ / "shut_in" / "lines.geojson").string();
  s.outputs.regions = (dir_ / "shut_in" / "regions.geojson").string();
  const nlohmann::json report = run_job(s).report;
  const nlohmann::json& lines = report.at("deliverables").at("boundaries").at("partial_effect");
  EXPECT_EQ(lines.at("stretches").get<int64_t>(), 1);
  EXPECT_EQ(lines.at("along_lines").at("unresolved_segments").get<int64_t>(), 0);
  EXPECT_GT(report.at("partial_effect").at("cells_to_neighbours").get<int64_t>(), 1000);
  const nlohmann::json drawn = read_json(s.outputs.boundaries);
  EXPECT_EQ(drawn.at("features").size(), 1u);
  expect_regions_match_cells(s, 250.0, 0.005);
}

// At 750 m the Øresund's DK-SE line by sea passes Ven's coast closer than a cell: the cells on
// either side of it there are parted by the island's land, so extraction breaks the line in two,
// though the locus stays at sea. The two ends are joined (boundaries.ends_joined) and the joining
// chord refined onto the locus; the regions, which need every line to end on a tripoint, a coast
// or the frame, are drawn, each owner's sea area within 1 % of its cells'.
TEST_F(SeaJob, ALinePassingACoastCloserThanACellIsJoinedAndBoundsTheRegions) {
  JobSpec s = ports_spec("ven");
  s.grid.resolution = 750.0;
  s.outputs.boundaries = (dir_ / "ven" / "lines.geojson").string();
  s.outputs.regions = (dir_ / "ven" / "regions.geojson").string();
  const nlohmann::json report = run_job(s).report;
  const nlohmann::json& b = report.at("deliverables").at("boundaries");
  EXPECT_EQ(b.at("ends_joined").get<int64_t>(), 1);
  EXPECT_EQ(b.at("along_lines").at("unresolved_segments").get<int64_t>(), 0);
  EXPECT_LT(b.at("max_residual_cells").get<double>(), 1e-6);
  expect_regions_match_cells(s, 750.0, 0.01);
}

TEST_F(SeaJob, ValidationRunsTheOracleBySea) {
  JobSpec s = ports_spec("v");
  s.grid.resolution = 1000.0;
  s.validate = true;
  const nlohmann::json v = run_job(s).report.at("validation");
  EXPECT_EQ(v.at("cells").get<int64_t>(), 40 * 70);
  EXPECT_EQ(v.at("wrong_cells").get<int64_t>(), 0);
  EXPECT_EQ(v.at("wrong_owner_cells").get<int64_t>(), 0);
  EXPECT_EQ(v.at("nodata_mismatch").get<int64_t>(), 0);
}

// Coasts as both seeds and land: off the land the field is the straight one, bit for bit; the
// cells without an owner are land, where the straight field says 0 (inside a seed polygon). In
// UTM 33N (planar), and on the ellipsoid (the coasts' edges geodesics for both).
TEST_F(SeaJob, CoastsAsSeedsAndLandChangeNothingOffLand) {
  for (const bool geodesic : {false, true}) {
    SCOPED_TRACE(geodesic ? "geodesic" : "planar");
    JobSpec sea;
    sea.seeds.paths = {fixture("oresund.gpkg")};
    sea.seeds.owner_field = "iso2";
    if (geodesic) {
      sea.metric = MetricRequest::automatic;
      sea.grid.resolution = 0.005;
    } else {
      sea.seeds.target_crs = "EPSG:32633";
      sea.metric = MetricRequest::planar;
      sea.grid.resolution = 500.0;
    }
    const std::string name = geodesic ? "geodesic" : "planar";
    JobSpec straight = with_outputs(sea, "straight_" + name);
    straight.outputs.via.clear();
    sea.barriers = {fixture("oresund.gpkg")};
    sea = with_outputs(sea, "sea_" + name);
    expect_coasts_change_nothing(straight, sea);
  }
}

// The same on the western Baltic, four states whose land overlaps along their land borders
// (DK-DE, DE-PL: accepted with the lower code taking the overlap, as the straight run needs): each
// state's vertices under its neighbour's land lie on a land border no path reaches and stay
// where they are (snap: on_land_borders), the field off land is the straight one bit for bit, and
// the lines by sea lie on the straight lines (to a millionth of a degree) with every chord within
// the tolerance. Before, the run was refused: a seed with a vertex inside a barrier.
// The farthest (CRS units) that a vertex of `sea_lines` lies from every straight line of the same
// two owners in `straight_lines` (GeoJSON boundaries); `vertices` counts the vertices measured.
double worst_off_straight(const nlohmann::json& straight_lines, const nlohmann::json& sea_lines, int64_t& vertices);
// GeoJSON lines without their vertices inside box {x0, y0, x1, y1} (Usedom's slivers, where the
// straight line crosses land by a chord).
nlohmann::json outside(nlohmann::json lines, std::array<double, 4> box) {
  for (nlohmann::json& f : lines.at("features")) {
    nlohmann::json kept = nlohmann::json::array();
    for (const nlohmann::json& p : f.at("geometry").at("coordinates")) {
      const double x = p[0].get<double>(), y = p[1].get<double>();
      if (!(x > box[0] && x < box[2] && y > box[1] && y < box[3])) kept.push_back(p);
    }
    f["geometry"]["coordinates"] = kept;
  }
  return lines;
}

TEST_F(SeaJob, CoastsAsSeedsAndLandWhoseBordersOverlapChangeNothingOffLand) {
  auto [straight, sea] = states_straight_and_by_sea("baltic_west.gpkg", {9.0, 53.8, 15.5, 56.2});
  expect_coasts_change_nothing(straight, sea);
  const nlohmann::json report = read_json(sea.outputs.report);
  EXPECT_EQ(report.at("sea").at("snap").at("on_land_borders").get<int64_t>(), 4);
  EXPECT_EQ(report.at("sea").at("snap").at("moved").get<int64_t>(), 0);
  const nlohmann::json& along = report.at("deliverables").at("boundaries").at("along_lines");
  // (One chord into the point where the two coasts meet in Usedom's sliver of sea stays 1.25 mm
  // off the locus: the search across it runs onto land.)
  EXPECT_LE(along.at("unresolved_segments").get<int64_t>(), 1);
  EXPECT_LE(along.at("max_midpoint").get<double>(), 1.5 * along.at("tolerance").get<double>());
  EXPECT_EQ(report.at("deliverables").at("boundaries").at("ends_on_barriers").get<int64_t>(), 3);
  // Every vertex by sea on a straight line of the same two owners, but in the slivers of sea along
  // the land border across Usedom, where the straight line crosses land by a chord (see
  // StatesAsSeedsAndLandWhoseBorderIsASliverOfSeaMeetUpIt).
  int64_t vertices = 0;
  const double worst =
      worst_off_straight(read_json(straight.outputs.boundaries),
                         outside(read_json(sea.outputs.boundaries), {14.17, 53.905, 14.22, 53.918}), vertices);
  EXPECT_GT(vertices, 10000);
  EXPECT_LT(worst, 1e-6);
  std::printf("western Baltic coasts as seeds and land: %lld line vertices by sea, worst %.3g deg off the straight\n",
              static_cast<long long>(vertices), worst);
}

// The Flensburg Fjord, narrower than two cells at 0.02 deg, with Denmark and Germany as seeds and
// land: the cells show the Danish-German line in pieces that land parts (a peninsula's tip, the
// fjord's bends), which only following the locus from their ends joins. One line from the grid's
// west edge to its east edge, on the straight line of the same seeds, and regions bounded by it
// (refused before: ends inside the grid).
TEST_F(SeaJob, StatesAsSeedsAndLandInAFjordNarrowerThanTwoCellsMeetInOneLine) {
  const StatesRun run = run_states_with_regions("flensburg_fjord_states.geojson", {9.5, 54.75, 9.9, 54.95});
  const nlohmann::json &report = run.report, &lines = run.lines;
  ASSERT_EQ(lines.at("features").size(), 1u);
  const auto v = lines.at("features")[0].at("geometry").at("coordinates").get<std::vector<std::array<double, 2>>>();
  EXPECT_NEAR(std::min(v.front()[0], v.back()[0]), 9.51, 1e-9);  // the frames of the cell centres
  EXPECT_NEAR(std::max(v.front()[0], v.back()[0]), 9.89, 1e-9);
  const nlohmann::json& st = report.at("deliverables").at("boundaries");
  EXPECT_GE(st.at("ends_joined").get<int64_t>(), 2);
  EXPECT_EQ(st.at("along_lines").at("unresolved_segments").get<int64_t>(), 0);
  int64_t vertices = 0;
  const double worst = worst_off_straight(run.straight_lines, lines, vertices);
  EXPECT_GT(vertices, 100);
  EXPECT_LT(worst, 1e-6);
  EXPECT_EQ(read_json(run.sea.outputs.regions).at("features").size(), 2u);
  std::printf("Flensburg Fjord, states as seeds and land: one line of %lld vertices, worst %.3g deg off the straight\n",
              static_cast<long long>(vertices), worst);
}

// Usedom, with Germany and Poland as seeds and land: their polygons leave a sliver of sea 10 to 20
// m wide along the land border across the island, which narrows to where the two coasts meet
// (their land overlapping beyond, towards the middle of the island). The German-Polish line from
// the open sea north of the island, and the one from the lagoon south of it, each end there: the
// follower walks up the sliver in steps under half its width. Before, both stopped a cell short of
// the coast and regions were refused. Off the island every vertex lies on the straight line of
// the same seeds; on it the straight line crosses the land between the slivers by a chord (both
// distances 0 there), which the line by sea does not follow.
TEST_F(SeaJob, StatesAsSeedsAndLandWhoseBorderIsASliverOfSeaMeetUpIt) {
  const StatesRun run = run_states_with_regions("usedom_states.geojson", {14.0, 53.8, 14.4, 54.0});
  const nlohmann::json &report = run.report, &lines = run.lines;
  ASSERT_EQ(lines.at("features").size(), 2u);
  const nlohmann::json& st = report.at("deliverables").at("boundaries");
  EXPECT_EQ(st.at("ends_on_barriers").get<int64_t>(), 2);
  // Within the line tolerance along their whole length, up to where the coasts cross: the ends
  // lie on the crossing of the two coasts' geodesic edges (their chords' crossing in longitude
  // and latitude was millimetres off it, and the last chord 1.25 mm off the locus).
  const nlohmann::json& along = st.at("along_lines");
  EXPECT_EQ(along.at("unresolved_segments").get<int64_t>(), 0);
  EXPECT_LE(along.at("max_midpoint").get<double>(), along.at("tolerance").get<double>());
  // Each line's end on the island lies in its middle, where its sliver closes (53.91-53.92 N).
  for (const nlohmann::json& f : lines.at("features")) {
    const auto v = f.at("geometry").at("coordinates").get<std::vector<std::array<double, 2>>>();
    const auto& inland = v.front()[1] > 53.85 && v.front()[1] < 53.95 ? v.front() : v.back();
    EXPECT_GT(inland[1], 53.91) << inland[0] << "," << inland[1];
    EXPECT_LT(inland[1], 53.92) << inland[0] << "," << inland[1];
  }
  int64_t vertices = 0;
  const double worst = worst_off_straight(run.straight_lines, outside(lines, {14.17, 53.905, 14.22, 53.918}), vertices);
  EXPECT_GT(vertices, 100);
  EXPECT_LT(worst, 1e-6);
  EXPECT_EQ(read_json(run.sea.outputs.regions).at("features").size(), 2u);
  std::printf("Usedom, states as seeds and land: %lld line vertices, worst %.3g deg off the straight\n",
              static_cast<long long>(vertices), worst);
}

double worst_off_straight(const nlohmann::json& straight_lines, const nlohmann::json& sea_lines, int64_t& vertices) {
  std::map<std::pair<int, int>, std::vector<std::vector<std::array<double, 2>>>> by_pair;
  for (const nlohmann::json& f : straight_lines.at("features"))
    by_pair[{f.at("properties").at("owner_a").get<int>(), f.at("properties").at("owner_b").get<int>()}].push_back(
        f.at("geometry").at("coordinates").get<std::vector<std::array<double, 2>>>());
  double worst = 0.0;
  for (const nlohmann::json& f : sea_lines.at("features")) {
    const auto& lines =
        by_pair[{f.at("properties").at("owner_a").get<int>(), f.at("properties").at("owner_b").get<int>()}];
    for (const auto& p : f.at("geometry").at("coordinates").get<std::vector<std::array<double, 2>>>()) {
      double best = INFINITY;
      for (const auto& line : lines)
        for (size_t k = 1; k < line.size(); ++k) {
          const double ax = line[k - 1][0], ay = line[k - 1][1], dx = line[k][0] - ax, dy = line[k][1] - ay;
          const double l2 = dx * dx + dy * dy;
          const double t = l2 > 0 ? std::clamp(((p[0] - ax) * dx + (p[1] - ay) * dy) / l2, 0.0, 1.0) : 0.0;
          best = std::min(best, std::hypot(p[0] - ax - t * dx, p[1] - ay - t * dy));
        }
      worst = std::max(worst, best);
      ++vertices;
    }
  }
  return worst;
}

void SeaJob::expect_coasts_change_nothing(const JobSpec& straight, const JobSpec& sea) {
  run_job(straight);
  const nlohmann::json report = run_job(sea).report;
  const Raster<int32_t> own_sea = read_int32(sea.outputs.ownership), own = read_int32(straight.outputs.ownership);
  const Raster<float> dist_sea = read_float32(sea.outputs.distance), dist = read_float32(straight.outputs.distance);
  const Raster<int32_t> via = read_int32(sea.outputs.via);
  int64_t land = 0, compared = 0;
  for (size_t c = 0; c < own.cells().size(); ++c) {
    EXPECT_EQ(via.cells()[c], 0) << c;  // no path bends: it would meet a seed first
    if (own_sea.cells()[c] == 0) {
      ++land;
      EXPECT_EQ(dist.cells()[c], 0.0f) << c;
      EXPECT_EQ(dist_sea.cells()[c], static_cast<float>(kNoDistance)) << c;
      continue;
    }
    ++compared;
    ASSERT_EQ(own_sea.cells()[c], own.cells()[c]) << c;
    ASSERT_EQ(dist_sea.cells()[c], dist.cells()[c]) << c;
  }
  EXPECT_EQ(land, report.at("sea").at("land_cells").get<int64_t>());
  EXPECT_GT(land, 10000);
  EXPECT_GT(compared, 10000);
  EXPECT_EQ(report.at("sea").at("unreachable_cells").get<int64_t>(), 0);
  EXPECT_EQ(report.at("metric"), sea.metric == MetricRequest::planar ? "planar" : "geodesic");
}

// An island with a lagoon (a polygon with a hole) in UTM 33N, 10 km across, the lagoon 2 km.
std::string island_with_lagoon() {
  return std::string(R"({"type": "FeatureCollection", )") + kUtm33 + R"(, "features": [
    {"type": "Feature", "properties": {"name": "island"}, "geometry": {"type": "Polygon", "coordinates": [
      [[400000, 6200000], [410000, 6200000], [410000, 6210000], [400000, 6210000], [400000, 6200000]],
      [[404000, 6204000], [404000, 6206000], [406000, 6206000], [406000, 6204000], [404000, 6204000]]]}}]})";
}

std::string points(const std::string& features) {
  return std::string(R"({"type": "FeatureCollection", )") + kUtm33 + R"(, "features": [)" + features + "]}";
}

std::string point(const char* owner, double x, double y) {
  return std::string(R"({"type": "Feature", "properties": {"owner": ")") + owner +
         R"("}, "geometry": {"type": "Point", "coordinates": [)" + std::to_string(x) + ", " + std::to_string(y) + "]}}";
}

TEST_F(SeaJob, CellsNoSeedReachesHaveNoOwnerAndAreCounted) {
  JobSpec s;
  s.seeds.paths = {write("lagoon_port.geojson", points(point("L", 405300.0, 6205200.0)))};
  s.seeds.owner_field = "owner";
  s.barriers = {write("island.geojson", island_with_lagoon())};
  s.grid.resolution = 250.0;
  s.grid.extent = std::array<double, 4>{398000.0, 6198000.0, 412000.0, 6212000.0};
  s = with_outputs(s, "l");
  const nlohmann::json sea = run_job(s).report.at("sea");
  const Raster<int32_t> own = read_int32(s.outputs.ownership);
  const Raster<float> dist = read_float32(s.outputs.distance);
  const GridSpec& g = own.grid();
  int64_t outside = 0, lagoon = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const double x = g.centre_x(c), y = g.centre_y(r);
      const size_t i = static_cast<size_t>(r * g.width + c);
      const bool in_lagoon = x > 404000 && x < 406000 && y > 6204000 && y < 6206000;
      const bool in_island = x > 400000 && x < 410000 && y > 6200000 && y < 6210000;
      if (in_lagoon) {
        ++lagoon;
        EXPECT_EQ(own.cells()[i], 1);
        EXPECT_NEAR(dist.cells()[i], std::hypot(x - 405300.0, y - 6205200.0), 1e-2);
      } else if (!in_island) {
        ++outside;
        EXPECT_EQ(own.cells()[i], 0);
        EXPECT_EQ(dist.cells()[i], static_cast<float>(kNoDistance));
      }
    }
  EXPECT_EQ(lagoon, 64);
  EXPECT_EQ(sea.at("unreachable_cells").get<int64_t>(), outside);
  EXPECT_GT(outside, 1000);
}

// Barriers are read as seeds are, so a self-intersecting polygon is repaired (GEOS MakeValid) and
// said so: a bow tie of two triangles pinched at (405000, 6205000) is the land its two lobes are.
// Its field is that of the two triangles given as a valid multipolygon, cell for cell; the report
// counts the repair and warns of it by name; the cells in the lobes are land, those in the two
// wedges of sea between them are not.
TEST_F(SeaJob, ASelfIntersectingBarrierIsRepairedAsASeedIsAndSaidSo) {
  const std::string seeds =
      write("ports.geojson", points(point("W", 397000.0, 6205000.0) + ", " + point("E", 413000.0, 6203000.0)));
  auto run = [&](const std::string& name, const std::string& geometry) {
    JobSpec s;
    s.seeds.paths = {seeds};
    s.seeds.owner_field = "owner";
    s.barriers = {write(name + ".geojson", std::string(R"({"type": "FeatureCollection", )") + kUtm33 +
                                               R"(, "features": [{"type": "Feature", "properties": {"name": "bow tie"},
                                                  "geometry": )" +
                                               geometry + "}]}")};
    s.grid.resolution = 250.0;
    s.grid.extent = std::array<double, 4>{395000.0, 6197000.0, 415000.0, 6213000.0};
    s = with_outputs(s, name);
    return std::make_pair(s, run_job(s).report);
  };
  const auto [tie, tie_report] =
      run("bowtie", R"({"type": "Polygon", "coordinates": [[[400000, 6200000], [410000, 6210000], [410000, 6200000],
                   [400000, 6210000], [400000, 6200000]]]})");
  const auto [valid, valid_report] = run("triangles", R"({"type": "MultiPolygon", "coordinates": [
                      [[[400000, 6200000], [405000, 6205000], [400000, 6210000], [400000, 6200000]]],
                      [[[410000, 6200000], [410000, 6210000], [405000, 6205000], [410000, 6200000]]]]})");
  const nlohmann::json& barriers = tie_report.at("sea").at("barriers");
  EXPECT_EQ(barriers.at("polygons_repaired").get<int64_t>(), 1) << barriers.dump();
  EXPECT_EQ(valid_report.at("sea").at("barriers").at("polygons_repaired").get<int64_t>(), 0);
  const auto& warnings = barriers.at("warnings");
  ASSERT_EQ(warnings.size(), 1u) << barriers.dump();
  EXPECT_NE(warnings[0].get<std::string>().find("repaired into 2 polygon(s)"), std::string::npos) << warnings[0];
  const Raster<int32_t> own = read_int32(tie.outputs.ownership), own_valid = read_int32(valid.outputs.ownership);
  const Raster<float> dist = read_float32(tie.outputs.distance), dist_valid = read_float32(valid.outputs.distance);
  ASSERT_EQ(own.cells().size(), own_valid.cells().size());
  for (size_t i = 0; i < own.cells().size(); ++i) {
    ASSERT_EQ(own.cells()[i], own_valid.cells()[i]) << i;
    ASSERT_EQ(dist.cells()[i], dist_valid.cells()[i]) << i;
  }
  const GridSpec& g = own.grid();
  int64_t lobes = 0, wedges = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const double x = g.centre_x(c) - 405000.0, y = g.centre_y(r) - 6205000.0;
      if (std::abs(std::abs(x) - std::abs(y)) < 1.0 || std::abs(x) >= 5000.0 || std::abs(y) >= 5000.0) continue;
      const int32_t o = own.cells()[static_cast<size_t>(r * g.width + c)];
      if (std::abs(y) < std::abs(x)) {  // in a lobe: land
        ++lobes;
        EXPECT_EQ(o, 0) << x << " " << y;
      } else {  // in the sea between the lobes, above or below the pinch
        ++wedges;
        EXPECT_NE(o, 0) << x << " " << y;
      }
    }
  EXPECT_GT(lobes, 600);
  EXPECT_GT(wedges, 600);
  EXPECT_EQ(tie_report.at("sea").at("land_cells").get<int64_t>(), lobes);
}

TEST_F(SeaJob, SeedsJustInlandMoveOntoTheCoastDeeperOnesAreRefused) {
  // The island's west edge is x = 400000: one port 0.4 m inside it, one at sea.
  const std::string ports =
      write("ports.geojson", points(point("A", 400000.4, 6203000.0) + ", " + point("B", 412000.0, 6205000.0)));
  JobSpec s;
  s.seeds.paths = {ports};
  s.seeds.owner_field = "owner";
  s.barriers = {write("island.geojson", island_with_lagoon())};
  s.grid.resolution = 500.0;
  s.grid.extent = std::array<double, 4>{395000.0, 6195000.0, 415000.0, 6215000.0};
  s = with_outputs(s, "snap");
  const nlohmann::json snap = run_job(s).report.at("sea").at("snap");
  EXPECT_EQ(snap.at("moved").get<int64_t>(), 1);
  EXPECT_NEAR(snap.at("largest_move").get<double>(), 0.4, 1e-6);
  EXPECT_EQ(snap.at("tolerance").get<double>(), 1.0);
  // West of the island the cells are A's: it stands on the coast now.
  EXPECT_EQ(read_int32(s.outputs.ownership).cells()[static_cast<size_t>(20 * 40 + 2)], 1);

  JobSpec strict = with_outputs(s, "strict");
  strict.snap_tolerance = "10cm";
  const Error e = refused(strict);
  EXPECT_EQ(e.kind(), ErrorKind::invalid_input);
  EXPECT_EQ(std::string(e.what()).find("the seed "), 0u) << e.what();
  EXPECT_NE(std::string(e.what()).find("inside a barrier"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("ports.geojson"), std::string::npos) << e.what();
}

// The disproportionality test by sea (--relevant-area): each owner's relevant coast is where the
// paths of its cells in the area leave its coast. A's coast runs along y = 6200000 (x 400 to 410
// km), B's along y = 6208000; a breakwater lies in front of A's, y = 6202000 from x = 402 to 408
// km; the area is [404, 406] x [6203, 6205] km. In a straight line the area's lower half is A's and
// its upper half B's, each cell nearest to the coast straight below or above it: 1,750 m each (the
// first column's centre to the last's). By sea A's paths round the breakwater's ends and leave A's
// coast at their feet, 402 and 408 km: 6,000 m, though A keeps only the area's lower corners, the
// nearest to those ends; B sees its coast. The areas add up to the relevant area either way.
TEST_F(SeaJob, TheRelevantCoastBySeaIsWhereTheAreasPathsLeaveIt) {
  auto line = [](const char* owner, double x0, double y0, double x1, double y1) {
    return std::string(R"({"type": "Feature", "properties": {"owner": ")") + owner +
           R"("}, "geometry": {"type": "LineString", "coordinates": [[)" + std::to_string(x0) + ", " +
           std::to_string(y0) + "], [" + std::to_string(x1) + ", " + std::to_string(y1) + "]]}}";
  };
  JobSpec s;
  s.seeds.paths = {write("coasts.geojson", points(line("A", 400000, 6200000, 410000, 6200000) + ", " +
                                                  line("B", 400000, 6208000, 410000, 6208000)))};
  s.seeds.owner_field = "owner";
  s.grid.resolution = 250.0;
  s.grid.extent = std::array<double, 4>{398000.0, 6198000.0, 412000.0, 6212000.0};
  s.outputs.relevant_area = write("area.geojson", points(R"({"type": "Feature", "properties": {}, "geometry": {
      "type": "Polygon", "coordinates": [[[404000, 6203000], [406000, 6203000], [406000, 6205000],
      [404000, 6205000], [404000, 6203000]]]}})"));
  JobSpec sea = with_outputs(s, "sea");
  sea.barriers = {write("breakwater.geojson", points(line("-", 402000, 6202000, 408000, 6202000)))};
  struct Owner {
    double coast, sea_area;
  };
  auto relevance = [](const JobSpec& spec) {
    const nlohmann::json r = run_job(spec).report.at("deliverables").at("regions").at("relevant_area");
    EXPECT_NEAR(r.at("area").get<double>(), 4e6, 1e-3);
    std::map<std::string, Owner> out;
    double total = 0.0;
    for (const nlohmann::json& o : r.at("owners")) {
      out[o.at("label").get<std::string>()] = {o.at("coast_length").get<double>(), o.at("sea_area").get<double>()};
      total += o.at("sea_area").get<double>();
    }
    EXPECT_NEAR(total, 4e6, 1e-3);
    return out;
  };
  JobSpec plain = with_outputs(s, "straight");
  plain.outputs.via.clear();  // the distance by sea's
  const auto straight = relevance(plain);
  ASSERT_EQ(straight.size(), 2u);
  EXPECT_NEAR(straight.at("A").coast, 1750.0, 1e-6);
  EXPECT_NEAR(straight.at("B").coast, 1750.0, 1e-6);
  const auto by_sea = relevance(sea);
  ASSERT_EQ(by_sea.size(), 2u);
  EXPECT_NEAR(by_sea.at("A").coast, 6000.0, 1e-6);
  EXPECT_NEAR(by_sea.at("B").coast, 1750.0, 1e-6);
  // The breakwater lengthens A's ways: B takes more of the area by sea.
  EXPECT_GT(by_sea.at("B").sea_area, straight.at("B").sea_area + 1e5);
}

TEST_F(SeaJob, WhatTheDistanceBySeaDoesNotDoIsRefusedInOneLine) {
  auto expect = [&](JobSpec s, ErrorKind kind, const std::string& words) {
    const Error e = refused(s);
    EXPECT_EQ(e.kind(), kind) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  };
  JobSpec scan = ports_spec("scan");
  scan.method = Method::hv_scan;
  expect(scan, ErrorKind::invalid_argument, "barriers: the distance by sea needs the exact");
  JobSpec via = ports_spec("via");
  via.barriers.clear();
  expect(via, ErrorKind::invalid_argument, "the via raster needs barriers");
  JobSpec point_barriers = ports_spec("points");
  point_barriers.barriers = {fixture("oresund_ports.geojson")};
  expect(point_barriers, ErrorKind::invalid_input, "barriers: ");
  JobSpec inland = ports_spec("inland");
  inland.seeds.paths = {write("inland.geojson", R"({"type": "FeatureCollection", "features": [
      {"type": "Feature", "properties": {"owner": "DK"}, "geometry": {"type": "Point", "coordinates": [12.3, 55.6]}}]})")};
  expect(inland, ErrorKind::invalid_input, "inland.geojson");
  JobSpec tolerance = ports_spec("tolerance");
  tolerance.snap_tolerance = "1 furlong";
  expect(tolerance, ErrorKind::invalid_argument, "snap tolerance: length '1 furlong'");
}

}  // namespace
}  // namespace rv
