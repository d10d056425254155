// Live what-if sessions (issue 54, rv/session.hpp) on the two cases: what the analyst
// waits for after an edit (server time of Session::edit, median and worst of N), against a fresh
// job of the same request (rvoronoi compute with the same deliverables and an ownership raster),
// and the session's memory per cell.
//
//   session_bench baltic RES N FIXTURES_DIR   western Baltic, geodesic, boundaries, tripoints,
//                                             12/24 nmi limits, regions; N DK coast vertices
//                                             moved by about 100 m
//   session_bench points SIZE N               SIZE x SIZE planar cells, 50,000 random points of
//                                             8 owners, the field alone (the case: the
//                                             fresh job writes the ownership and distance
//                                             rasters); N points moved by 5 cells
//
// Prints one line per edit (its timings by stage) and a summary table (Markdown). With the
// environment variable SESSION_BENCH_EDITS_ONLY set, the deliverables are not read after the
// edits (their files never made): for profiling the steps alone.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/job.hpp"
#include "rv/session.hpp"

using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

double seconds_of(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: session_bench baltic RES N FIXTURES_DIR | points SIZE N\n");
    return 2;
  }
  const std::string which = argv[1];
  const bool edits_only = std::getenv("SESSION_BENCH_EDITS_ONLY") != nullptr;
  const int n = std::atoi(argv[3]);
  const fs::path dir = fs::temp_directory_path() / "rv_session_bench";
  fs::remove_all(dir);
  fs::create_directories(dir);
  rv::JobSpec spec;
  spec.threads = 0;
  rv::OutputRequest& o = spec.outputs;
  std::mt19937 rng(54);
  if (which == "baltic") {
    if (argc < 5) return 2;
    spec.seeds.paths = {(fs::path(argv[4]) / "baltic_west.gpkg").string()};
    spec.seeds.owner_field = "iso2";
    spec.seeds.border_tolerance = 10.0;
    o.boundaries = (dir / "boundaries.geojson").string();
    o.tripoints = (dir / "tripoints.geojson").string();
    spec.grid.resolution = std::atof(argv[2]);
    spec.metric = rv::MetricRequest::geodesic;
    spec.distance_units = rv::DistanceUnit::nmi;
    o.limits = (dir / "limits.geojson").string();
    o.limit_distances = {"12nmi", "24nmi"};
    o.regions = (dir / "regions.geojson").string();
  } else {
    const int64_t size = std::atoll(argv[2]);
    json fc = {{"type", "FeatureCollection"},
               {"crs", {{"type", "name"}, {"properties", {{"name", "urn:ogc:def:crs:EPSG::32633"}}}}},
               {"features", json::array()}};
    std::uniform_real_distribution<double> u(0.0, static_cast<double>(size));
    for (int i = 0; i < 50000; ++i)
      fc["features"].push_back({{"type", "Feature"},
                                {"properties", {{"owner", "O" + std::to_string(i % 8)}}},
                                {"geometry", {{"type", "Point"}, {"coordinates", {u(rng), u(rng)}}}}});
    std::ofstream(dir / "points.geojson") << fc.dump();
    spec.seeds.paths = {(dir / "points.geojson").string()};
    spec.seeds.owner_field = "owner";
    spec.grid.resolution = 1.0;
    spec.grid.extent = {0.0, 0.0, static_cast<double>(size), static_cast<double>(size)};
  }
  // The fresh job the user would otherwise run: the same deliverables and an ownership raster
  // (and the distance raster where the session keeps the field alone).
  rv::JobSpec fresh = spec;
  fresh.outputs.ownership = (dir / "ownership.tif").string();
  if (which == "points") fresh.outputs.distance = (dir / "distance.tif").string();
  fresh.outputs.report = (dir / "report.json").string();
  auto t = std::chrono::steady_clock::now();
  rv::run_job(fresh);
  const double fresh_s = seconds_of(t);
  t = std::chrono::steady_clock::now();
  std::unique_ptr<rv::Session> session = rv::Session::create(spec);
  const double create_s = seconds_of(t);
  const json features = session->features();
  std::vector<double> total, files;
  std::vector<json> stages;
  for (int k = 0; k < n; ++k) {
    json edit;
    if (which == "baltic") {
      for (const json& f : features["features"]) {
        if (f["properties"]["owner"] != "DK") continue;
        const json& parts = f["geometry"]["geometries"];
        const size_t part = std::uniform_int_distribution<size_t>(0, parts.size() - 1)(rng);
        const json& ring = parts[part]["coordinates"][0];
        const size_t v = std::uniform_int_distribution<size_t>(0, ring.size() - 2)(rng);
        json to = ring[v];
        to[0] = to[0].get<double>() + 0.0012;
        to[1] = to[1].get<double>() + 0.0005;
        edit = {{"op", "move-vertex"}, {"feature", f["id"]}, {"path", {part, 0, v}}, {"to", to}};
      }
    } else {
      const json& f = features["features"][std::uniform_int_distribution<size_t>(0, 49999)(rng)];
      json to = f["geometry"]["coordinates"];
      to[0] = to[0].get<double>() + 5.0;
      to[1] = to[1].get<double>() - 3.0;
      edit = {{"op", "move-vertex"}, {"feature", f["id"]}, {"path", json::array()}, {"to", to}};
    }
    t = std::chrono::steady_clock::now();
    json answer;
    try {
      answer = session->edit(json::array({edit}));
    } catch (const std::exception& e) {
      std::printf("edit %d refused: %s\n", k, e.what());
      continue;
    }
    total.push_back(seconds_of(t));
    stages.push_back(answer["timings"]);
    // What a map page reads next: every deliverable (their files are made on this first read).
    t = std::chrono::steady_clock::now();
    if (!edits_only)
      for (const std::string& name : session->deliverables()) (void)session->deliverable(name);
    files.push_back(seconds_of(t));
    std::printf("edit %d: %.3f s %s cells %s; files %.3f s\n", k, total.back(), answer["timings"].dump().c_str(),
                answer["recompute"].dump().c_str(), files.back());
    // Back again, so that every edit starts from the same state (its files read, as a page does).
    const json undone = session->undo();
    if (edits_only) std::printf("undo %d: %s\n", k, undone["timings"].dump().c_str());
    if (!edits_only)
      for (const std::string& name : session->deliverables()) (void)session->deliverable(name);
  }
  const json info = session->info();
  std::vector<double> field, lines, both;
  for (size_t k = 0; k < stages.size(); ++k) {
    const json& s = stages[k];
    field.push_back(s["field"].get<double>() + s["plan"].get<double>() + s["prepare"].get<double>());
    lines.push_back(s.value("lines", 0.0));
    both.push_back(total[k] + files[k]);
  }
  std::printf(
      "\n| case | cells | fresh job s | session create s | edit median s | edit worst s | of which field "
      "(median) s | lines (median) s | edit / fresh | edit and files read (median) s | bytes per cell "
      "|\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  const auto cells = session->grid().width * session->grid().height;
  std::printf("| %s %s | %lld | %.3f | %.3f | %.3f | %.3f | %.4f | %.3f | %.1f %% | %.3f | %.2f |\n", which.c_str(),
              argv[2], static_cast<long long>(cells), fresh_s, create_s, median(total),
              total.empty() ? 0.0 : *std::max_element(total.begin(), total.end()), median(field), median(lines),
              100.0 * median(total) / fresh_s, median(both), info["bytes_per_cell"].get<double>());
  fs::remove_all(dir);
  return 0;
}
