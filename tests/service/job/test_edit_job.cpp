// Edits of a finished job through the façade (issue 32): a run keeps its field; the user edits the
// seed file in place and runs the job again naming the earlier report; every file the edit writes
// equals a fresh run's of the edited file (rasters by content, vector deliverables byte for byte),
// and the report's area moved equals the area measured from the two ownership rasters. Random
// edits of points, lines and polygons (remove, add, move, change owner, reweight, reorder,
// several at once, a seed outside the grid, nothing), planar and geodesic. Bad bases give their
// error and write nothing.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <GeographicLib/PolygonArea.hpp>
#include <GeographicLib/Rhumb.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "geotiff_compare.hpp"
#include "rounds.hpp"
#include "rv/field/checksum.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/job.hpp"

namespace fs = std::filesystem;

namespace rv {
namespace {

using test::expect_same_geotiff;

// One seed feature as the test writes it to GeoJSON.
struct Feat {
  int id = 0;
  std::string owner;
  int kind = 0;  // 0 point, 1 line, 2 polygon
  std::vector<std::array<double, 2>> pts;
  double weight = 1.0;
};

struct Case {
  bool geodesic = false;
  std::array<double, 4> extent{};  // xmin ymin xmax ymax
  double res = 0.0;
  std::string limit;  // a limit distance
  std::optional<double> max_distance;
  bool weights = false;
  bool tiles_skipped = false;  // some round's plan must rule tiles out without reading them
  bool rows_taken = false;     // some round's lines must take rows from the base's pieces
  int slots = 5;               // the seeds' layout: slots x slots, one object each
};

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class EditJob : public ::testing::Test {
 public:
  void SetUp() override {
    gdal_init();
    dir_ = fs::temp_directory_path() / ("rv_edit_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  void write_seeds(const std::vector<Feat>& feats, const Case& c) const {
    nlohmann::json fc = {{"type", "FeatureCollection"}, {"features", nlohmann::json::array()}};
    if (!c.geodesic) fc["crs"] = {{"type", "name"}, {"properties", {{"name", "urn:ogc:def:crs:EPSG::32633"}}}};
    for (const Feat& f : feats) {
      nlohmann::json coords = nlohmann::json::array();
      for (const auto& p : f.pts) coords.push_back({p[0], p[1]});
      nlohmann::json geom;
      if (f.kind == 0) geom = {{"type", "Point"}, {"coordinates", coords[0]}};
      if (f.kind == 1) geom = {{"type", "LineString"}, {"coordinates", coords}};
      if (f.kind == 2) {
        coords.push_back(coords[0]);
        geom = {{"type", "Polygon"}, {"coordinates", {coords}}};
      }
      fc["features"].push_back({{"type", "Feature"},
                                {"id", f.id},
                                {"properties", {{"owner", f.owner}, {"w", f.weight}}},
                                {"geometry", geom}});
    }
    std::ofstream(seeds_path()) << fc.dump();
  }
  std::string seeds_path() const { return (dir_ / "seeds.geojson").string(); }

  JobSpec spec(const Case& c, const std::string& sub) const {
    fs::create_directories(dir_ / sub);
    JobSpec s;
    s.seeds.paths = {seeds_path()};
    s.seeds.owner_field = "owner";
    if (c.weights) s.seeds.weight_field = "w";
    s.grid.resolution = c.res;
    s.grid.extent = c.extent;
    s.max_distance = c.max_distance;
    if (c.geodesic) s.distance_units = DistanceUnit::km;  // converted per strip: the kept field is in metres
    s.strip_rows = 100;                                   // strips straddle the 256-row checksum bands
    s.threads = 2;
    OutputRequest& o = s.outputs;
    const fs::path d = dir_ / sub;
    o.ownership = (d / "own.tif").string();
    o.distance = (d / "dist.tif").string();
    o.nearest_feature = (d / "feat.tif").string();
    o.boundaries = (d / "boundaries.geojson").string();
    o.tripoints = (d / "tripoints.geojson").string();
    o.limits = (d / "limits.geojson").string();
    o.limit_distances = {c.limit};
    o.regions = (d / "regions.geojson").string();
    o.report = (d / "report.json").string();
    return s;
  }

  fs::path dir_;
};

// The seeds: a layout of c.slots x c.slots slots over the extent, each holding one object so that
// no two owners' seeds overlap or cross: polygons in every 8th slot, lines in every 6th, points
// elsewhere.
std::vector<Feat> initial_seeds(const Case& c, std::mt19937& rng) {
  std::vector<Feat> out;
  const int n = c.slots;
  const double w = (c.extent[2] - c.extent[0]) / n, h = (c.extent[3] - c.extent[1]) / n;
  std::uniform_real_distribution<double> u(0.2, 0.8);
  const char* owners[] = {"A", "B", "C", "D<&>"};
  int id = 1;
  for (int k = 0; k < n * n; ++k) {
    const double x0 = c.extent[0] + (k % n) * w, y0 = c.extent[1] + (k / n) * h;
    Feat f;
    f.id = id++;
    f.owner = owners[rng() % 4];
    f.weight = c.weights ? 1.0 + (rng() % 3) * 0.5 : 1.0;
    if (k % 8 == 3) {
      f.kind = 2;
      const double cx = x0 + 0.5 * w, cy = y0 + 0.5 * h;
      f.pts = {{cx - 0.2 * w, cy - 0.2 * h}, {cx + 0.25 * w, cy - 0.1 * h}, {cx + 0.1 * w, cy + 0.2 * h}};
    } else if (k % 6 == 1) {
      f.kind = 1;
      f.pts = {{x0 + u(rng) * w, y0 + u(rng) * h}, {x0 + u(rng) * w, y0 + u(rng) * h}};
    } else {
      f.pts = {{x0 + u(rng) * w, y0 + u(rng) * h}};
    }
    out.push_back(f);
  }
  return out;
}

// A random edit of `feats`; returns what it did.
std::string random_edit(std::vector<Feat>& feats, const Case& c, std::mt19937& rng, int op, int& next_id) {
  const double w = (c.extent[2] - c.extent[0]) / c.slots, h = (c.extent[3] - c.extent[1]) / c.slots;
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  auto pick = [&](int kind) {
    std::vector<size_t> of;
    for (size_t i = 0; i < feats.size(); ++i)
      if (kind < 0 || feats[i].kind == kind) of.push_back(i);
    return of.empty() ? feats.size() : of[rng() % of.size()];
  };
  switch (op) {
    case 0: {  // remove
      const size_t i = pick(-1);
      feats.erase(feats.begin() + static_cast<std::ptrdiff_t>(i));
      return "remove";
    }
    case 1: {  // add a point beside a point
      const size_t i = pick(0);
      Feat f = feats[i];
      f.id = next_id++;
      f.owner = feats[(i + 1) % feats.size()].owner;
      f.pts[0][0] += u(rng) * w;
      f.pts[0][1] += u(rng) * h;
      feats.insert(feats.begin() + static_cast<std::ptrdiff_t>(rng() % (feats.size() + 1)), f);
      return "add";
    }
    case 2: {  // move a point, a line's end or a polygon's vertex
      const size_t i = pick(-1);
      auto& p = feats[i].pts[rng() % feats[i].pts.size()];
      p[0] += u(rng) * 0.5 * w;
      p[1] += u(rng) * 0.5 * h;
      return "move";
    }
    case 3: {  // change owner
      const size_t i = pick(-1);
      feats[i].owner = feats[i].owner == "A" ? "B" : "A";
      return "owner";
    }
    case 4: {  // reweight (a no-op edit without a weight field)
      const size_t i = pick(-1);
      feats[i].weight += 0.5;
      return "weight";
    }
    case 5: {  // reorder two features
      std::swap(feats[pick(-1)], feats[pick(-1)]);
      return "reorder";
    }
    case 6: {  // a point outside the grid
      Feat f;
      f.id = next_id++;
      f.owner = "C";
      f.pts = {{c.extent[2] + 0.3 * w, c.extent[1] + 2.5 * h}};
      feats.push_back(f);
      return "outside";
    }
    default:
      return "nothing";
  }
}

// The area of each cell whose owner differs between two ownership rasters, per (from, to) label:
// planar, res^2; geodesic (longitude/latitude grid), the cell on the WGS84 ellipsoid bounded by
// its meridians and parallels (rhumb lines, GeographicLib).
std::map<std::pair<std::string, std::string>, double> moved_area(const std::string& before, const std::string& after,
                                                                 const Case& c) {
  const Raster<int32_t> a = read_int32(before), b = read_int32(after);
  const std::vector<std::string> la = read_category_labels(before), lb = read_category_labels(after);
  auto label = [](const std::vector<std::string>& l, int32_t v) { return v == 0 ? std::string() : l.at(v - 1); };
  const GeographicLib::Rhumb& rhumb = GeographicLib::Rhumb::WGS84();
  std::map<std::pair<std::string, std::string>, double> out;
  const GridSpec& g = a.grid();
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t col = 0; col < g.width; ++col) {
      const std::string x = label(la, a.at(col, r)), y = label(lb, b.at(col, r));
      if (x == y) continue;
      double area = g.res * g.res;
      if (c.geodesic) {
        GeographicLib::PolygonAreaRhumb p(rhumb);
        const double x0 = g.xmin + col * g.res, y1 = g.ymax - r * g.res;
        p.AddPoint(y1, x0);
        p.AddPoint(y1, x0 + g.res);
        p.AddPoint(y1 - g.res, x0 + g.res);
        p.AddPoint(y1 - g.res, x0);
        double perimeter = 0.0;
        p.Compute(false, true, perimeter, area);
        area = std::abs(area);
      }
      out[{x, y}] += area;
    }
  return out;
}

// The nearest site of every cell as a run keeps it: site.tif's codes through site_codes.bin
// (an edit's: the code of each site it kept is its base's), else index + 1.
std::vector<int32_t> kept_sites(const std::string& report) {
  const fs::path dir = report + ".rvbase";
  const Raster<int32_t> codes = read_int32((dir / "site.tif").string());
  std::vector<int32_t> site_of_code;
  if (fs::exists(dir / "site_codes.bin")) {
    const std::string bytes = read_text(dir / "site_codes.bin");
    site_of_code.push_back(-1);
    for (size_t k = 0; k + 4 <= bytes.size(); k += 4) {
      int32_t v;
      std::memcpy(&v, bytes.data() + k, 4);
      site_of_code.push_back(v);
    }
  }
  std::vector<int32_t> out;
  for (const int32_t c : codes.cells()) {
    if (site_of_code.empty()) {
      out.push_back(c - 1);
    } else {
      EXPECT_TRUE(c >= 0 && static_cast<size_t>(c) < site_of_code.size()) << c;
      out.push_back(c == 0 ? -1 : site_of_code.at(static_cast<size_t>(c)));
      EXPECT_TRUE(c == 0 || out.back() >= 0) << "code " << c << " of a removed site";
    }
  }
  return out;
}

// The kept fields of two runs are the same field (the next edit may start from either).
void expect_same_kept_field(const std::string& a, const std::string& b) {
  EXPECT_EQ(kept_sites(a), kept_sites(b)) << a << " vs " << b;
}

void expect_same_job_files(const JobSpec& x, const JobSpec& y) {
  expect_same_geotiff(x.outputs.ownership, y.outputs.ownership);
  expect_same_geotiff(x.outputs.distance, y.outputs.distance);
  expect_same_geotiff(x.outputs.nearest_feature, y.outputs.nearest_feature);
  for (std::string OutputRequest::*f :
       {&OutputRequest::boundaries, &OutputRequest::tripoints, &OutputRequest::limits, &OutputRequest::regions})
    EXPECT_EQ(read_text(x.outputs.*f), read_text(y.outputs.*f)) << x.outputs.*f;
}

// Each round edits the seed file in place, runs the edit against the previous round's report,
// and compares with a fresh run; the next round's base is this round's edit (a chain of edits).
void run_random_edits(EditJob& t, const Case& c, uint32_t seed, int plain_rounds) {
  const int rounds = test::rounds(plain_rounds);
  std::mt19937 rng(seed);
  std::vector<Feat> feats = initial_seeds(c, rng);
  int next_id = 100;
  t.write_seeds(feats, c);
  JobSpec base = t.spec(c, "round0");
  run_job(base);
  ASSERT_TRUE(fs::exists(base.outputs.report + ".rvbase/manifest.json"));
  int64_t tiles_skipped = 0, rows_taken = 0, tiles_unread = 0;
  for (int round = 1; round <= rounds; ++round) {
    const int ops = 1 + static_cast<int>(rng() % 3);
    std::string did;
    for (int k = 0; k < ops; ++k) did += random_edit(feats, c, rng, static_cast<int>(rng() % 8), next_id) + " ";
    SCOPED_TRACE("round " + std::to_string(round) + ": " + did);
    t.write_seeds(feats, c);
    JobSpec edit = t.spec(c, "edit" + std::to_string(round));
    edit.base_report = base.outputs.report;
    edit.outputs.changes = (fs::path(edit.outputs.report).parent_path() / "changes.tif").string();
    const JobResult r = run_job(edit);
    JobSpec fresh = t.spec(c, "fresh" + std::to_string(round));
    fresh.strip_rows = 0;
    run_job(fresh);
    expect_same_job_files(edit, fresh);
    // The kept fields are equal too: the next edit may start from either.
    expect_same_kept_field(edit.outputs.report, fresh.outputs.report);
    // What the report says moved, against the two ownership rasters.
    const nlohmann::json& e = r.report.at("edit");
    const auto expected = moved_area(base.outputs.ownership, edit.outputs.ownership, c);
    std::map<std::pair<std::string, std::string>, double> reported;
    for (const nlohmann::json& m : e.at("area_moved"))
      reported[{m["from"].is_null() ? "" : m["from"].get<std::string>(),
                m["to"].is_null() ? "" : m["to"].get<std::string>()}] = m["area"].get<double>();
    ASSERT_EQ(reported.size(), expected.size());
    for (const auto& [pair, area] : expected) {
      ASSERT_TRUE(reported.count(pair)) << pair.first << " -> " << pair.second;
      EXPECT_NEAR(reported[pair], area, 1e-9 * area + 1e-6) << pair.first << " -> " << pair.second;
    }
    // The changes raster against the two runs' rasters; its counts against the report's.
    const Raster<int32_t> changes = read_int32(edit.outputs.changes);
    const Raster<int32_t> ob = read_int32(base.outputs.ownership), oe = read_int32(edit.outputs.ownership);
    const Raster<float> db = read_float32(base.outputs.distance), de = read_float32(edit.outputs.distance);
    const auto lb = read_category_labels(base.outputs.ownership), le = read_category_labels(edit.outputs.ownership);
    int64_t owner_cells = 0, distance_cells = 0, recomputed = e.at("cells_recomputed").get<int64_t>();
    for (size_t i = 0; i < changes.cells().size(); ++i) {
      const std::string a = ob.cells()[i] ? lb.at(ob.cells()[i] - 1) : "",
                        b = oe.cells()[i] ? le.at(oe.cells()[i] - 1) : "";
      const int want = a != b ? 1 : db.cells()[i] != de.cells()[i] ? 2 : 0;
      ASSERT_EQ(changes.cells()[i], want) << "cell " << i;
      owner_cells += want == 1;
      distance_cells += want == 2;
    }
    EXPECT_EQ(e.at("owner_changed_cells").get<int64_t>(), owner_cells);
    EXPECT_EQ(e.at("distance_only_changed_cells").get<int64_t>(), distance_cells);
    EXPECT_GE(recomputed, owner_cells + distance_cells);
    if (did == "nothing ") {
      EXPECT_EQ(recomputed, 0);
    }
    tiles_skipped += e.at("tiles").get<int64_t>() - e.at("tiles_planned").get<int64_t>();
    // The lines are extracted again on the rows near the changes and taken from the base on the
    // others (every row with weights); the cells read are those rows' and the plan's tiles'.
    const nlohmann::json& lines = e.at("lines");
    const int64_t taken = lines.at("rows_taken").get<int64_t>();
    EXPECT_EQ(lines.at("rows_extracted").get<int64_t>() + taken, r.report.at("grid").at("height").get<int64_t>());
    if (c.weights) {
      EXPECT_EQ(taken, 0);
    }
    rows_taken += taken;
    EXPECT_LE(e.at("tiles_read").get<int64_t>(), e.at("tiles").get<int64_t>());
    EXPECT_GE(e.at("tiles_read").get<int64_t>(), e.at("tiles_planned").get<int64_t>());
    tiles_unread += e.at("tiles").get<int64_t>() - e.at("tiles_read").get<int64_t>();
    base = edit;
  }
  if (c.tiles_skipped) {
    EXPECT_GT(tiles_skipped, 0);
  }
  if (c.rows_taken) {
    EXPECT_GT(rows_taken, 0);
    EXPECT_GT(tiles_unread, 0);  // lines drawn, and yet cells of the kept field left unread
  }
}

// 12 km x 12 km in UTM 33N at `res` metres, limit lines at `limit`.
Case planar_case(double res, const std::string& limit) {
  Case c;
  c.extent = {400000.0, 6100000.0, 412000.0, 6112000.0};
  c.res = res;
  c.limit = limit;
  return c;
}

TEST_F(EditJob, RandomEditsEqualFreshRunsPlanar) {
  run_random_edits(*this, planar_case(40.0, "1500"), 7, 10);  // 300 x 300 cells
}

TEST_F(EditJob, RandomEditsEqualFreshRunsPlanarWeightedWithMaxDistance) {
  Case c = planar_case(40.0, "1000");
  c.max_distance = 1800.0;
  c.weights = true;
  run_random_edits(*this, c, 11, 8);
}

// 1500 x 1500 cells: 36 tiles of 256 x 256, most of them too far from an edit to read (the plan
// rules them out from the base's tile summaries; the rounds check that some are), 100 seeds whose
// regions cross tile edges.
TEST_F(EditJob, RandomEditsEqualFreshRunsOnManyTiles) {
  Case c = planar_case(8.0, "1500");
  c.weights = true;
  c.tiles_skipped = true;
  c.slots = 10;
  run_random_edits(*this, c, 23, 8);
}

// The same without weights: the lines of most rows are taken from the base's pieces (the rounds
// check that some are), and every file still equals a fresh run's.
TEST_F(EditJob, RandomEditsTakeTheBasesLinesOnManyTiles) {
  Case c = planar_case(8.0, "1500");
  c.tiles_skipped = true;
  c.rows_taken = true;
  c.slots = 10;
  run_random_edits(*this, c, 29, 6);
}

// A basepoint moved on a feature of many: only that feature's changed sites are removed and added,
// and its interior changes only between the changed edges. A polygon's vertex moved in (cells
// leave the land) and out (cells join it), a line's vertex moved: files equal fresh runs', and
// the cells recomputed are a small part of the grid.
TEST_F(EditJob, AVertexMovedRecomputesOnlyNearIt) {
  for (const bool geodesic : {false, true}) {
    SCOPED_TRACE(geodesic ? "geodesic" : "planar");
    Case c;
    c.geodesic = geodesic;
    c.extent = geodesic ? std::array<double, 4>{10.0, 55.0, 10.6, 55.6}
                        : std::array<double, 4>{400000.0, 6100000.0, 412000.0, 6112000.0};
    c.res = geodesic ? 0.002 : 40.0;
    c.limit = geodesic ? "6km" : "1500";
    std::mt19937 rng(9);
    std::vector<Feat> feats = initial_seeds(c, rng);
    // One polygon of many vertices (the slots' triangles grown to 40 vertices), and a line.
    for (Feat& f : feats)
      if (f.kind == 2) {
        std::vector<std::array<double, 2>> ring;
        const double cx = (f.pts[0][0] + f.pts[1][0] + f.pts[2][0]) / 3,
                     cy = (f.pts[0][1] + f.pts[1][1] + f.pts[2][1]) / 3;
        const double rx = (c.extent[2] - c.extent[0]) / 5 * 0.3, ry = (c.extent[3] - c.extent[1]) / 5 * 0.3;
        for (int k = 0; k < 40; ++k)
          ring.push_back({cx + rx * std::cos(k * M_PI / 20), cy + ry * std::sin(k * M_PI / 20)});
        f.pts = ring;
      }
    const auto poly =
        std::find_if(feats.begin(), feats.end(), [](const Feat& f) { return f.kind == 2; }) - feats.begin();
    const auto line =
        std::find_if(feats.begin(), feats.end(), [](const Feat& f) { return f.kind == 1; }) - feats.begin();
    write_seeds(feats, c);
    JobSpec base = spec(c, geodesic ? "g0" : "p0");
    run_job(base);
    const std::array<double, 2> centre{(feats[poly].pts[0][0] + feats[poly].pts[20][0]) / 2,
                                       (feats[poly].pts[10][1] + feats[poly].pts[30][1]) / 2};
    int round = 0;
    for (const double towards : {0.3, -0.3, 0.0}) {
      ++round;
      if (towards != 0.0) {
        auto& v = feats[poly].pts[5];
        v = {v[0] + towards * (centre[0] - v[0]), v[1] + towards * (centre[1] - v[1])};
      } else {
        feats[line].pts[1][0] += (c.extent[2] - c.extent[0]) / 100;
      }
      write_seeds(feats, c);
      const std::string sub = (geodesic ? "g" : "p") + std::to_string(round);
      JobSpec edit = spec(c, sub + "e");
      edit.base_report = base.outputs.report;
      const JobResult r = run_job(edit);
      JobSpec fresh = spec(c, sub + "f");
      run_job(fresh);
      expect_same_job_files(edit, fresh);
      const nlohmann::json& e = r.report.at("edit");
      EXPECT_EQ(e["features"]["changed"].get<int64_t>(), 1) << e.dump();
      EXPECT_GT(e["owner_changed_cells"].get<int64_t>() + e["distance_only_changed_cells"].get<int64_t>(), 0);
      EXPECT_LT(e["cells_recomputed"].get<int64_t>(), e["cells"].get<int64_t>() / 20) << e.dump();
      base = edit;
    }
  }
}

// An edit of rasters alone reads and encodes only the tiles it changes; the files copy every other
// tile's bytes from the base's files, and still equal a fresh run's. Where the codes a file gives
// the base's cells change (a removed feature renumbers the features after it), that file encodes
// every tile and the others still copy. COGs copy their full-resolution tiles. A copied tile that
// was modified since the base run is refused; a base file that is gone is encoded instead.
TEST_F(EditJob, UnchangedTilesAreCopied) {
  Case c = planar_case(8.0, "1500");  // 1500 x 1500 cells: 36 tiles
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Feat> feats;
  for (int k = 0; k < 60; ++k) {
    Feat f;
    f.id = k + 1;
    f.owner = std::string(1, static_cast<char>('A' + k % 4));
    f.pts = {{c.extent[0] + u(rng) * 12000.0, c.extent[1] + u(rng) * 12000.0}};
    feats.push_back(f);
  }
  auto rasters_only = [&](const std::string& sub, bool cog) {
    JobSpec s = spec(c, sub);
    OutputRequest& o = s.outputs;
    o.boundaries.clear();
    o.tripoints.clear();
    o.limits.clear();
    o.limit_distances.clear();
    o.regions.clear();
    o.cloud_optimized = cog;
    s.strip_rows = 0;
    return s;
  };
  auto run_pair = [&](const JobSpec& base, const std::string& sub, bool cog) {
    write_seeds(feats, c);
    JobSpec edit = rasters_only(sub + "e", cog);
    edit.base_report = base.outputs.report;
    const nlohmann::json e = run_job(edit).report.at("edit");
    JobSpec fresh = rasters_only(sub + "f", cog);
    run_job(fresh);
    expect_same_job_files(edit, fresh);
    expect_same_kept_field(edit.outputs.report, fresh.outputs.report);
    return std::make_pair(edit, e);
  };
  // An edit of `base` into `sub` that must fail with invalid_input and `words`, writing nothing.
  auto refused = [&](const std::string& sub, const JobSpec& base, const std::string& words) {
    JobSpec s = rasters_only(sub, false);
    s.base_report = base.outputs.report;
    try {
      run_job(s);
      ADD_FAILURE() << "the edit was not refused (" << words << ")";
    } catch (const Error& err) {
      EXPECT_EQ(err.kind(), ErrorKind::invalid_input) << err.what();
      EXPECT_NE(std::string(err.what()).find(words), std::string::npos) << err.what();
    }
    EXPECT_TRUE(fs::is_empty(dir_ / sub));
  };
  // The costs a base's manifest records (EditBaseWriter::set_costs) replaced, so that the choice
  // between recoding and encoding afresh does not hang on this machine's timings; null removes them.
  auto set_costs = [&](const JobSpec& b, const nlohmann::json& costs) {
    const fs::path m = fs::path(b.outputs.report + ".rvbase") / "manifest.json";
    nlohmann::json j = nlohmann::json::parse(read_text(m));
    if (costs.is_null())
      j.erase("costs");
    else
      j["costs"] = costs;
    std::ofstream(m, std::ios::trunc) << j.dump();
  };
  // Recoding a tile costs a quarter of encoding it; reading the base whole, a quarter of its two
  // rasters'.
  const nlohmann::json recode_cheaper = {
      {"engine_s", 1000.0},
      {"encode_s", {{"site", 4.0}, {"distance", 4.0}, {"ownership", 1.0}, {"nearest_feature", 1.0}}}};
  write_seeds(feats, c);
  const JobSpec base = rasters_only("b", false);
  run_job(base);
  // A run records what its engine and each file's encoding cost.
  {
    const nlohmann::json m =
        nlohmann::json::parse(read_text(fs::path(base.outputs.report + ".rvbase") / "manifest.json"));
    EXPECT_GE(m.at("costs").at("engine_s").get<double>(), 0.0) << m.dump();
    for (const char* role : {"site", "distance", "ownership", "nearest_feature", "output_distance"})
      EXPECT_GE(m.at("costs").at("encode_s").value(role, -1.0), 0.0) << role << " " << m["costs"].dump();
  }

  // A point moved: every file copies all but the tiles with changed cells.
  feats[30].pts[0][0] += 40.0;
  auto [moved, e] = run_pair(base, "move", false);
  const int64_t tiles = e.at("tiles").get<int64_t>(), encoded = e.at("tiles_encoded").get<int64_t>();
  EXPECT_EQ(tiles, 36);
  EXPECT_GT(encoded, 0) << e.dump();
  EXPECT_LT(e.at("tiles_read").get<int64_t>(), tiles) << e.dump();
  EXPECT_EQ(e.at("tiles_read").get<int64_t>(), e.at("tiles_planned").get<int64_t>()) << e.dump();
  for (const char* f : {"ownership", "distance", "nearest_feature", "edit_base_site"})
    EXPECT_EQ(e.at("tiles_copied").value(f, int64_t{-2}), tiles - encoded) << f << " " << e.dump();
  EXPECT_TRUE(e.at("tiles_recoded").empty()) << e.dump();
  EXPECT_TRUE(e.at("tiles_not_copied").empty()) << e.dump();

  // A point removed from the middle (of an owner that stays): the feature numbers after it shift,
  // so that file decodes the tiles it copies and codes them again; the owner codes, distances
  // and the kept site codes (the base's, whatever the sites' indices) are copied as they are. No
  // cell is read but in the tiles the edit may change.
  feats.erase(feats.begin() + 20);
  set_costs(moved, recode_cheaper);
  auto [removed, r] = run_pair(moved, "remove", false);
  EXPECT_EQ(r.at("files_where_codes_move").value("made", ""), "recoded") << r.dump();
  const int64_t unchanged = tiles - r.at("tiles_encoded").get<int64_t>();
  EXPECT_LT(r.at("tiles_read").get<int64_t>(), tiles) << r.dump();
  EXPECT_FALSE(r.at("tiles_copied").contains("nearest_feature")) << r.dump();
  EXPECT_EQ(r.at("tiles_recoded").value("nearest_feature", int64_t{-2}), unchanged) << r.dump();
  for (const char* f : {"ownership", "distance", "edit_base_site"})
    EXPECT_EQ(r.at("tiles_copied").value(f, int64_t{-2}), unchanged) << f << " " << r.dump();
  // The first point's owner gone: every owner code after it shifts.
  const std::string first = feats[0].owner;
  std::vector<Feat> kept;
  for (const Feat& f : feats)
    if (f.owner != first) kept.push_back(f);
  std::swap(feats, kept);
  set_costs(removed, recode_cheaper);
  auto [dropped, o] = run_pair(removed, "drop", false);
  EXPECT_GT(o.at("tiles_recoded").value("ownership", int64_t{-2}), 0) << o.dump();
  std::swap(feats, kept);
  write_seeds(feats, c);
  // An edit that patched the field carries its base's engine cost; it encoded nothing afresh, so
  // its encoding costs are its base's too.
  {
    const nlohmann::json m =
        nlohmann::json::parse(read_text(fs::path(removed.outputs.report + ".rvbase") / "manifest.json"));
    EXPECT_EQ(m.at("costs").at("engine_s").get<double>(), 1000.0) << m.dump();
    EXPECT_EQ(m.at("costs").at("encode_s").value("nearest_feature", -1.0), 1.0) << m.dump();
  }

  // The same removal where the engine is cheaper than recoding: the nearest-feature file is
  // encoded afresh from strips the engine computes whole; the base is read only where the plan
  // reads it, and the other files still copy their unchanged tiles.
  const Feat removed_feature = feats[20];
  feats.erase(feats.begin() + 20);
  set_costs(removed, {{"engine_s", 0.0},
                      {"encode_s", {{"site", 4.0}, {"distance", 4.0}, {"ownership", 1.0}, {"nearest_feature", 1.0}}}});
  {
    auto [engine, n] = run_pair(removed, "engine", false);
    EXPECT_EQ(n.at("files_where_codes_move").value("made", ""), "afresh") << n.dump();
    EXPECT_EQ(n.at("files_where_codes_move").value("every_cell_by", ""), "engine") << n.dump();
    EXPECT_EQ(n.at("strips_by_engine"), n.at("strips")) << n.dump();
    EXPECT_TRUE(n.at("tiles_recoded").empty()) << n.dump();
    EXPECT_FALSE(n.at("tiles_copied").contains("nearest_feature")) << n.dump();
    EXPECT_LT(n.at("tiles_read").get<int64_t>(), tiles) << n.dump();
    for (const char* f : {"ownership", "distance", "edit_base_site"})
      EXPECT_EQ(n.at("tiles_copied").value(f, int64_t{-2}), tiles - n.at("tiles_encoded").get<int64_t>())
          << f << " " << n.dump();
    // It computed every strip: its own engine time is what it records.
    const nlohmann::json m =
        nlohmann::json::parse(read_text(fs::path(engine.outputs.report + ".rvbase") / "manifest.json"));
    EXPECT_LT(m.at("costs").at("engine_s").get<double>(), 1000.0) << m.dump();
    EXPECT_NE(m.at("costs").at("encode_s").value("nearest_feature", 1.0), 1.0) << m.dump();
  }
  // ... where reading the base whole is the cheaper way to every cell: every tile read.
  set_costs(removed, {{"engine_s", 1000.0},
                      {"encode_s", {{"site", 1.0}, {"distance", 1.0}, {"ownership", 1.0}, {"nearest_feature", 9.0}}}});
  {
    auto [whole, n] = run_pair(removed, "whole", false);
    EXPECT_EQ(n.at("files_where_codes_move").value("made", ""), "afresh") << n.dump();
    EXPECT_EQ(n.at("files_where_codes_move").value("every_cell_by", ""), "reading the base") << n.dump();
    EXPECT_EQ(n.at("strips_by_engine"), 0) << n.dump();
    EXPECT_EQ(n.at("tiles_read").get<int64_t>(), tiles) << n.dump();
    EXPECT_TRUE(n.at("tiles_recoded").empty()) << n.dump();
  }
  // ... and with no costs recorded (a base kept before they were): recoded, as before.
  set_costs(removed, nullptr);
  {
    auto [unknown, n] = run_pair(removed, "unknown", false);
    EXPECT_EQ(n.at("files_where_codes_move").value("made", ""), "recoded") << n.dump();
    EXPECT_GT(n.at("tiles_recoded").value("nearest_feature", int64_t{-2}), 0) << n.dump();
  }
  feats.insert(feats.begin() + 20, removed_feature);
  write_seeds(feats, c);

  // COGs: a COG base and a COG edit copy their full-resolution tiles (the overviews are made
  // from every cell).
  const JobSpec cog_base = rasters_only("cb", true);
  run_job(cog_base);
  feats[10].pts[0][1] -= 40.0;
  auto [cog, ce] = run_pair(cog_base, "cog", true);
  EXPECT_GT(ce.at("tiles_copied").value("ownership", int64_t{-2}), 0) << ce.dump();
  EXPECT_LT(ce.at("tiles_read").get<int64_t>(), tiles) << ce.dump();

  // The site codes an edit keeps (its base's, and new ones for added sites), damaged: refused.
  {
    const fs::path codes = fs::path(removed.outputs.report + ".rvbase") / "site_codes.bin";
    ASSERT_TRUE(fs::exists(codes));
    const std::string saved = read_text(codes);
    std::string bytes = saved;
    bytes[0] ^= 1;
    std::ofstream(codes, std::ios::binary) << bytes;
    refused("codes", removed, "site_codes.bin was modified");
    std::ofstream(codes, std::ios::binary) << saved;
  }
  // A tile the edit copies, modified in the base's ownership raster (far from the edit: the
  // corner tile): refused, nothing written. Rewritten with one cell changed, every other tile's
  // bytes stay the same.
  feats[30].pts[0][1] += 40.0;  // near the grid's centre
  write_seeds(feats, c);
  const std::string own = removed.outputs.ownership;
  fs::copy_file(own, dir_ / "own.saved");
  {
    Raster<int32_t> o = read_int32(own);
    o.at(3, 3) = o.at(3, 3) == 1 ? 2 : 1;
    GeoTiffOptions opt;
    opt.categorical = true;
    opt.category_labels = read_category_labels(own);
    opt.max_code = static_cast<int64_t>(opt.category_labels.size());
    write_geotiff(own, o, 0.0, opt);
  }
  refused("bad", removed, "own.tif was modified since it was written (the tile of rows 0-255, columns 0-255)");
  // The base's ownership raster gone: encoded instead, and said so.
  fs::remove(own);
  fs::remove(own + ".aux.xml");
  auto [gone, g] = run_pair(removed, "gone", false);
  EXPECT_TRUE(g.at("tiles_not_copied").contains("ownership")) << g.dump();
  EXPECT_GT(g.at("tiles_copied").value("distance", int64_t{-2}), 0) << g.dump();
}

TEST_F(EditJob, RandomEditsEqualFreshRunsGeodesic) {
  Case c;
  c.geodesic = true;
  c.extent = {10.0, 55.0, 10.6, 55.6};
  c.res = 0.002;  // 300 x 300 cells
  c.limit = "6km";
  run_random_edits(*this, c, 5, 8);
}

class EditJobErrors : public EditJob {
 protected:
  // A base run of fixed seeds; returns its spec.
  JobSpec base_run(const Case& c) {
    std::mt19937 rng(3);
    write_seeds(initial_seeds(c, rng), c);
    JobSpec base = spec(c, "base");
    run_job(base);
    return base;
  }
  // Runs an edit of `base` that must fail with `kind` and a message holding `words`, and checks
  // that it wrote nothing.
  void expect_refused(JobSpec edit, const JobSpec& base, ErrorKind kind, const std::string& words) {
    edit.base_report = base.outputs.report;
    const fs::path d = fs::path(edit.outputs.report).parent_path();
    try {
      run_job(edit);
      ADD_FAILURE() << "the edit was not refused (" << words << ")";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), kind) << e.what();
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
    EXPECT_TRUE(fs::is_empty(d)) << "the refused edit left files in " << d;
  }
  Case planar() const { return planar_case(40.0, "1500"); }
};

TEST_F(EditJobErrors, ADifferentGridMetricOrMethodIsNamed) {
  const Case c = planar();
  const JobSpec base = base_run(c);
  JobSpec s = spec(c, "res");
  s.grid.resolution = 50.0;
  expect_refused(s, base, ErrorKind::invalid_argument, "grid resolution 50.0 (base: 40.0)");
  s = spec(c, "extent");
  s.grid.extent = std::array<double, 4>{400000.0, 6100000.0, 412000.0, 6112040.0};
  expect_refused(s, base, ErrorKind::invalid_argument, "grid height");
  s = spec(c, "noextent");  // the grid of the seeds' box, which an edit may move
  s.grid.extent.reset();
  expect_refused(s, base, ErrorKind::invalid_argument,
                 "the extent follows the seeds unless given: the base's was 400000 6100000 412000 6112000");
  s = spec(c, "metric");
  s.metric = MetricRequest::geodesic;
  expect_refused(s, base, ErrorKind::invalid_argument, "metric geodesic (base: planar)");
  s = spec(c, "units");
  s.distance_units = DistanceUnit::km;
  expect_refused(s, base, ErrorKind::invalid_argument, "distance_units km (base: m)");
  s = spec(c, "max");
  s.max_distance = 2000.0;
  expect_refused(s, base, ErrorKind::invalid_argument, "max_distance 2000.0 (base: none)");
  s = spec(c, "compression");
  s.outputs.compression = Compression::small;
  expect_refused(s, base, ErrorKind::invalid_argument, "compression small (base: fast)");
  s = spec(c, "method");
  s.method = Method::hv_scan;
  s.outputs.boundaries.clear();
  expect_refused(s, base, ErrorKind::invalid_argument, "only the exact method");
}

TEST_F(EditJobErrors, MissingOrModifiedBaseFilesAreRefused) {
  const Case c = planar();
  const JobSpec base = base_run(c);
  const fs::path kept = base.outputs.report + ".rvbase";
  // A modified cell of the kept field: here the job's own distance raster, which it shares (the
  // distances are in metric units).
  const nlohmann::json manifest = nlohmann::json::parse(read_text(kept / "manifest.json"));
  EXPECT_EQ(manifest["rasters"]["distance"]["file"], "../dist.tif");
  EXPECT_FALSE(fs::exists(kept / "distance.tif"));
  const fs::path distance = dir_ / "base" / "dist.tif";
  fs::copy_file(distance, dir_ / "distance.tif.saved");
  {
    Raster<float> d = read_float32(distance.string());
    d.at(10, 290) += 1.0f;
    write_geotiff(distance.string(), d, -1.0, GeoTiffOptions{});
  }
  expect_refused(spec(c, "modified"), base, ErrorKind::invalid_input,
                 "base: ../dist.tif was modified since it was written (the tile of rows 256-299, columns 0-255)");
  fs::rename(dir_ / "distance.tif.saved", distance);
  // The saved file back: the edit runs.
  JobSpec ok = spec(c, "ok");
  ok.base_report = base.outputs.report;
  EXPECT_NO_THROW(run_job(ok));
  // A modified seed archive, a missing raster, a missing directory, a report that names none.
  const std::string archive = read_text(kept / "seeds.bin");
  {
    std::string bytes = archive;
    bytes[bytes.size() / 2] ^= 1;
    std::ofstream(kept / "seeds.bin", std::ios::binary) << bytes;
  }
  expect_refused(spec(c, "seeds"), base, ErrorKind::invalid_input, "seeds.bin was modified");
  std::ofstream(kept / "seeds.bin", std::ios::binary) << archive;
  // Modified line pieces (kept per extraction: boundaries and limits).
  EXPECT_EQ(manifest["line_pieces"]["boundaries"]["file"], "lines_boundaries.bin");
  EXPECT_EQ(manifest["line_pieces"]["limits"]["file"], "lines_limits.bin");
  const std::string pieces = read_text(kept / "lines_limits.bin");
  {
    std::string bytes = pieces;
    bytes[bytes.size() - 5] ^= 4;
    std::ofstream(kept / "lines_limits.bin", std::ios::binary) << bytes;
  }
  expect_refused(spec(c, "pieces"), base, ErrorKind::invalid_input,
                 "base: report.json.rvbase/lines_limits.bin was modified since the base run");
  fs::remove(kept / "lines_limits.bin");
  expect_refused(spec(c, "pieces_gone"), base, ErrorKind::not_found, "lines_limits.bin");
  std::ofstream(kept / "lines_limits.bin", std::ios::binary) << pieces;
  // A manifest member of the wrong type.
  const std::string manifest_text = read_text(kept / "manifest.json");
  {
    nlohmann::json damaged = nlohmann::json::parse(manifest_text);
    damaged["rasters"]["site"]["tiles"][0] = 7;
    std::ofstream(kept / "manifest.json") << damaged.dump();
  }
  expect_refused(spec(c, "manifest"), base, ErrorKind::invalid_input, "manifest.json is damaged");
  std::ofstream(kept / "manifest.json") << manifest_text;
  // A base of the layout before the bands' summaries (the tiles' alone) edits as well, the tiles'
  // values standing for their bands; bands of another size are refused.
  {
    nlohmann::json older = nlohmann::json::parse(manifest_text);
    ASSERT_EQ(older["tiles"]["bands"], 8);
    for (const char* key : {"bands", "band_max_distance", "band_unowned"}) older["tiles"].erase(key);
    std::ofstream(kept / "manifest.json") << older.dump();
    JobSpec no_bands = spec(c, "no_bands");
    no_bands.base_report = base.outputs.report;
    EXPECT_NO_THROW(run_job(no_bands));
    for (const char* file : {"own.tif", "dist.tif", "boundaries.geojson", "limits.geojson"})
      EXPECT_TRUE(read_text(dir_ / "ok" / file) == read_text(dir_ / "no_bands" / file)) << file;
    nlohmann::json short_bands = nlohmann::json::parse(manifest_text);
    short_bands["tiles"]["band_unowned"].erase(0);
    std::ofstream(kept / "manifest.json") << short_bands.dump();
    expect_refused(spec(c, "short_bands"), base, ErrorKind::invalid_input, "has no tile summaries of its grid");
    std::ofstream(kept / "manifest.json") << manifest_text;
  }
  fs::remove(kept / "site.tif");
  expect_refused(spec(c, "site"), base, ErrorKind::not_found, "site.tif is missing");
  fs::remove_all(kept);
  expect_refused(spec(c, "dir"), base, ErrorKind::not_found, "manifest.json is missing");
  std::ofstream(dir_ / "other.json") << "{\"grid\": {}}";
  JobSpec other = spec(c, "other");
  JobSpec fake = base;
  fake.outputs.report = (dir_ / "other.json").string();
  expect_refused(other, fake, ErrorKind::invalid_input, "names nothing kept for edits");
  fake.outputs.report = (dir_ / "none.json").string();
  expect_refused(other, fake, ErrorKind::not_found, "none.json is missing");
  // Seeds that cannot be read and a base that is gone: the seeds' error first, as before the base
  // was read ahead on another core.
  JobSpec unread = spec(c, "unread");
  unread.seeds.paths = {(dir_ / "no_seeds.geojson").string()};
  expect_refused(unread, fake, ErrorKind::not_found, "no_seeds.geojson");
  // The changes raster without a base.
  JobSpec lone = spec(c, "lone");
  lone.outputs.changes = (dir_ / "lone" / "changes.tif").string();
  try {
    run_job(lone);
    ADD_FAILURE() << "a changes raster without a base was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::invalid_argument);
  }
  EXPECT_TRUE(fs::is_empty(dir_ / "lone"));
}

TEST_F(EditJobErrors, AnEditInPlaceReplacesTheBaseItReads) {
  // The same command again with --base naming its own report: the report, the kept field and
  // every output are replaced by the edit's, equal to a fresh run's.
  const Case c = planar();
  JobSpec base = base_run(c);
  std::mt19937 rng(3);
  std::vector<Feat> feats = initial_seeds(c, rng);
  feats.erase(feats.begin() + 4);
  write_seeds(feats, c);
  JobSpec again = base;
  again.base_report = base.outputs.report;
  const JobResult r = run_job(again);
  EXPECT_EQ(r.report["edit"]["features"]["removed"].get<int64_t>(), 1);
  JobSpec fresh = spec(c, "fresh");
  run_job(fresh);
  expect_same_job_files(again, fresh);
  expect_same_kept_field(again.outputs.report, fresh.outputs.report);
  for (const fs::directory_entry& e : fs::directory_iterator(dir_ / "base"))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

// A base someone else made: kept files changed and their checksums recomputed in the manifest
// (the checksum is no key: anyone can). Every number and index they hold is checked before it
// is used: the edit is refused with a message, never an abort, and writes nothing; a FIFO in
// place of a kept file is refused instead of waited on (issue 50).
TEST_F(EditJobErrors, CraftedFilesWithRecomputedChecksumsAreRefused) {
  const Case c = planar();
  std::mt19937 rng(3);
  std::vector<Feat> feats = initial_seeds(c, rng);
  write_seeds(feats, c);
  const JobSpec base = spec(c, "base");
  run_job(base);
  feats.erase(feats.begin() + 5);  // an edit of it keeps site codes of its own
  write_seeds(feats, c);
  JobSpec edited = spec(c, "edited");
  edited.base_report = base.outputs.report;
  run_job(edited);
  const fs::path kept = edited.outputs.report + ".rvbase";
  ASSERT_TRUE(fs::exists(kept / "site_codes.bin"));
  const std::string manifest_text = read_text(kept / "manifest.json");
  // `file` of the kept directory replaced by `bytes`, with the checksum the manifest then needs.
  auto craft = [&](const std::string& file, const std::string& bytes) {
    std::ofstream(kept / file, std::ios::binary | std::ios::trunc) << bytes;
    nlohmann::json m = nlohmann::json::parse(manifest_text);
    std::function<void(nlohmann::json&)> rehash = [&](nlohmann::json& j) {
      if (j.is_object() && j.contains("file") && j["file"] == file)
        j["hash"] = checksum_hex(checksum64(bytes.data(), bytes.size()));
      if (j.is_structured())
        for (nlohmann::json& v : j) rehash(v);
    };
    rehash(m);
    std::ofstream(kept / "manifest.json", std::ios::trunc) << m.dump();
  };
  int n = 0;
  auto refused = [&](const std::string& words) {
    expect_refused(spec(c, "crafted" + std::to_string(n++)), edited, ErrorKind::invalid_input, words);
  };
  // The seed archive's last 8 bytes are its last feature's number (the nearest-feature raster's
  // code): zero, negative, far beyond the features, or another feature's.
  const std::string archive = read_text(kept / "seeds.bin");
  const size_t features = feats.size();
  int64_t first = 0;
  std::memcpy(&first, archive.data() + archive.size() - 8 * features, 8);
  for (const int64_t number : {int64_t{0}, int64_t{-7}, int64_t{1} << 40, int64_t{2147483646}, first}) {
    std::string bytes = archive;
    std::memcpy(bytes.data() + bytes.size() - 8, &number, 8);
    craft("seeds.bin", bytes);
    refused(number == 2147483646 ? "beyond what a run reads" : "a feature's number out of range or repeated");
  }
  // The archive as it was, its checksum written anew: the edit runs (what is refused is what is
  // wrong, not what was hashed again).
  craft("seeds.bin", archive);
  EXPECT_NO_THROW(run_job([&] {
    JobSpec s = spec(c, "recrafted");
    s.base_report = edited.outputs.report;
    return s;
  }()));
  // The site codes: a site named by two codes, and one beyond the seeds.
  const std::string codes = read_text(kept / "site_codes.bin");
  ASSERT_GE(codes.size(), 8u);
  {
    std::string bytes = codes;
    std::memcpy(bytes.data() + 4, bytes.data(), 4);
    craft("site_codes.bin", bytes);
    refused("site_codes.bin does not fit its seeds");
    const int32_t beyond = 1 << 20;
    std::memcpy(bytes.data(), &beyond, 4);
    craft("site_codes.bin", bytes);
    refused("site_codes.bin does not fit its seeds");
  }
  craft("site_codes.bin", codes);
  // A FIFO in place of a kept file, and of a kept raster: refused at once.
  for (const char* file : {"lines_limits.bin", "site.tif"}) {
    const fs::path path = kept / file;
    const fs::path saved = dir_ / "saved.bin";
    fs::rename(path, saved);
    ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0);
    refused(std::string(file) + " is not a regular file");
    fs::remove(path);
    fs::rename(saved, path);
  }
}

}  // namespace
}  // namespace rv
