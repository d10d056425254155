// The distance by sea on a real coast: the western Baltic's land (fixtures/baltic_west.gpkg, four
// states, about 7,300 vertices) as barriers, and ports on its coasts as seeds (every k-th coast
// vertex, owned by its state), in UTM 33N with the planar metric. Times the straight exact field
// of the same ports and grid against the exact engine of the distance by sea, alternating, and
// prints medians, the engine's counts (bend nodes, visibility tests, land, unreachable cells,
// largest detour), the share of cells whose path bends, and a digest of the field by sea (to
// check that an optimisation changes no cell).
//
//   sea_bench [--data fixtures/baltic_west.gpkg | --wiggly N] [--ports 200] [--res 1000] [--runs 3] [--threads 0]
//             [--geodesic 1] [--ports-out FILE.geojson] [--cell-by-cell 1] [--sweeps 1] [--grounds 1]
//             [--paint 1|2]
//
// --geodesic 1: the fixture in longitude/latitude, the grid in degrees (--res 0.01), both fields
// geodesic (the straight one the exact geodesic engine's). --ports-out: the ports chosen, as a
// GeoJSON file (owner field "owner"), for timing whole jobs with the CLI. --cell-by-cell 1: the
// exact engine answers every cell alone (SeaOptions::cell_by_cell), the reference of its blocks.
// --sweeps 1: afterwards, what a shortest-path-map engine's visibility sweeps would cost: from
// every bend node of every last bend the field uses, the region it sees (sea/visible_region.hpp)
// within a square of k times that bend's region's radius (its farthest cell), k = 1, 2, 4, one
// thread, timed with the edges gathered from an index.
// --grounds 1: afterwards, every cell's ground drawn row by row (sea_map/ground_rows.hpp) against
// each row's cells projected into the frame and classified along the row (Visibility::
// classify_next, as the engine does where no block proves them at once), one thread, three rounds
// in turn; every cell compared. Then which cells see their straight nearest site, drawn from the
// sites' regions (sea_map/site_sight.hpp), against the field by sea, three rounds. The exit status
// is 1 where any cell differs.
//
// --paint 1 (or 2, planar only): afterwards, the field painted root by root in increasing order
// of distance, each root's square grown while it still wins on its sides, compared with the field
// cell by cell (paint_measure.cpp); the exit status is 1 where a cell it decided differs.
//
// --wiggly N: instead of the fixture, a synthetic archipelago of nine fractal-like islands of
// N vertices in all (each island's radius a sum of random harmonics), over the fixture's box in
// UTM 33N, four owners: how the engine's time grows with the coast's vertex count.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "paint_measure.hpp"
#include "rv/engine/engine.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/sea/geodesic_frame.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/visibility.hpp"
#include "sea/edge_index.hpp"
#include "sea/sea_prepare.hpp"
#include "sea/visible_region.hpp"
#include "sea_map/ground_rows.hpp"
#include "sea_map/site_sight.hpp"

using namespace rv;

namespace {

// A closed ring round (cx, cy) of n vertices whose radius is a sum of random harmonics.
Ring wiggly_ring(double cx, double cy, double radius, int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> phase(0.0, 2.0 * M_PI);
  std::vector<std::pair<double, double>> harmonics;  // (k, phase)
  for (int k = 2; k <= 256; k *= 2) harmonics.emplace_back(k, phase(rng));
  Ring ring;
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * M_PI * i / n;
    double r = 1.0;
    for (const auto& [k, ph] : harmonics) r += 0.25 / std::sqrt(k) * std::sin(k * t + ph) / 2.0;
    ring.push_back({cx + radius * r * std::cos(t), cy + radius * r * std::sin(t)});
  }
  return ring;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The grounds of --grounds (see the head of this file). Returns whether every cell agreed.
bool measure_grounds(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const MetricSpec& metric,
                     const SeaField& field) {
  using Ground = Visibility::Ground;
  const sea::Prepared p = sea::prepare(seeds, barriers, grid, metric);
  const Window window = grid.full_window();
  const auto width = static_cast<size_t>(window.width);
  std::vector<Ground> by_cells(width * static_cast<size_t>(window.height)), drawn(by_cells.size());
  std::vector<double> cells_s, drawn_s;
  int64_t exact = 0, pieces = 0;
  std::vector<sea::Spot> spots;
  for (int round = 0; round < 3; ++round) {
    auto t0 = std::chrono::steady_clock::now();
    for (int64_t r = 0; r < window.height; ++r) {
      p.row_cells(grid, window, r, spots);
      Ground* g = by_cells.data() + static_cast<size_t>(r) * width;
      for (size_t c = 0; c < width; ++c)
        g[c] = c == 0 ? p.vis.classify(spots[c].at) : p.vis.classify_next(spots[c - 1].at, g[c - 1], spots[c].at);
    }
    auto t1 = std::chrono::steady_clock::now();
    const sea::GroundRows rows(p, metric, grid, window);
    exact = 0;
    for (int64_t r = 0; r < window.height; ++r) exact += rows.row(r, drawn.data() + static_cast<size_t>(r) * width);
    auto t2 = std::chrono::steady_clock::now();
    pieces = rows.piece_count();
    cells_s.push_back(std::chrono::duration<double>(t1 - t0).count());
    drawn_s.push_back(std::chrono::duration<double>(t2 - t1).count());
  }
  int64_t differ = 0, land = 0;
  for (size_t i = 0; i < drawn.size(); ++i) {
    differ += drawn[i] != by_cells[i];
    land += by_cells[i] == Ground::land;
  }
  std::printf(
      "grounds, one thread: projected and classified cell by cell median %.3f s; drawn row by row median %.3f s "
      "(%lld pieces, %lld cells classified exactly); %lld land cells; %lld cells differ\n",
      median(cells_s), median(drawn_s), static_cast<long long>(pieces), static_cast<long long>(exact),
      static_cast<long long>(land), static_cast<long long>(differ));
  // Which cells see their straight nearest site, drawn from the sites' regions, against the field
  // by sea (a cell sees its straight nearest point site exactly when its answer is that site,
  // reached directly).
  ComputeOptions o;
  o.metric = metric;
  o.threads = 1;
  const NearestField straight = compute(seeds, grid, o);
  std::vector<sea::SiteSight::Sight> sight(width);
  std::vector<double> sight_s;
  int64_t seen = 0, hidden = 0, unknown = 0, wrong = 0, regions = 0;
  for (int round = 0; round < 3; ++round) {
    seen = hidden = unknown = wrong = 0;
    auto t0 = std::chrono::steady_clock::now();
    const auto edges = sea::barrier_edges(p.vis);
    const sea::SiteSight sites(p, metric, grid, window, straight.site, edges, sea::EdgeIndex(edges, {}));
    for (int64_t r = 0; r < window.height; ++r) {
      sites.row(r, sight.data());
      for (size_t c = 0; c < width; ++c) {
        const int32_t s = straight.site.at(static_cast<int64_t>(c), r);
        if (s == kNoSite || drawn[static_cast<size_t>(r) * width + c] == Ground::land) continue;
        const bool direct =
            field.via.at(static_cast<int64_t>(c), r) == kNoVia && field.field.site.at(static_cast<int64_t>(c), r) == s;
        if (sight[c] == sea::SiteSight::unknown) {
          ++unknown;
        } else {
          ((sight[c] == sea::SiteSight::seen) ? seen : hidden) += 1;
          wrong += (sight[c] == sea::SiteSight::seen) != direct;
        }
      }
    }
    sight_s.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    regions = sites.regions();
  }
  std::printf(
      "sites' sight, one thread: drawn from %lld regions with the rows compared, median %.3f s; sea cells: %lld "
      "seen, %lld hidden, %lld unknown; %lld disagree with the field\n",
      static_cast<long long>(regions), median(sight_s), static_cast<long long>(seen), static_cast<long long>(hidden),
      static_cast<long long>(unknown), static_cast<long long>(wrong));
  return differ == 0 && wrong == 0;
}

// The sweeps of --sweeps (see the head of this file).
void measure_sweeps(const Visibility& vis, const GeodesicFrame* frame, const GridSpec& grid, const SeaField& field) {
  std::vector<double> radius(static_cast<size_t>(vis.vertex_count()), 0.0);
  std::vector<Vec2> row(static_cast<size_t>(grid.width));
  for (int64_t r = 0; r < grid.height; ++r) {
    bool bent = false;
    for (int64_t c = 0; c < grid.width && !bent; ++c) bent = field.via.at(c, r) != kNoVia;
    if (!bent) continue;
    if (frame) {
      frame->forward_row(grid.centre_y(r), grid.centre_x(0), grid.res, grid.width, row.data());
    } else {
      for (int64_t c = 0; c < grid.width; ++c) row[static_cast<size_t>(c)] = {grid.centre_x(c), grid.centre_y(r)};
    }
    for (int64_t c = 0; c < grid.width; ++c) {
      const int32_t v = field.via.at(c, r);
      if (v == kNoVia) continue;
      const Vec2 a = row[static_cast<size_t>(c)], b = vis.vertex(v);
      radius[static_cast<size_t>(v)] = std::max(radius[static_cast<size_t>(v)], std::hypot(a.x - b.x, a.y - b.y));
    }
  }
  auto t0 = std::chrono::steady_clock::now();
  const auto edges = sea::barrier_edges(vis);
  const sea::EdgeIndex index(edges, {});
  const auto nodes = sea::bend_nodes(vis);
  const double prepare_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("sweeps: %zu barrier edges once cut where they cross, %zu bend nodes; edges cut and indexed in %.3f s\n",
              edges.size(), nodes.size(), prepare_s);
  std::vector<int32_t> near;
  sea::EdgeIndex::Stamps stamps;
  for (const double k : {1.0, 2.0, 4.0}) {
    int64_t roots = 0, read = 0, corners = 0, blurred = 0;
    t0 = std::chrono::steady_clock::now();
    for (const sea::Node& node : nodes) {
      const double reach = k * radius[static_cast<size_t>(node.vertex)];
      if (reach <= 0.0) continue;
      const Vec2 o = vis.vertex(node.vertex), lo{o.x - reach, o.y - reach}, hi{o.x + reach, o.y + reach};
      index.edges_in_box(lo, hi, stamps, near);
      const auto region = sea::visible_region(vis, vis.at_vertex(node.vertex, node.wedge), lo, hi, edges, &near);
      ++roots;
      read += static_cast<int64_t>(near.size());
      corners += static_cast<int64_t>(region.ring.size());
      blurred += region.blurred;
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf(
        "sweeps at %g x the region radius: %lld roots, %lld edges read, %lld ring corners, %lld blurred, %.3f s\n", k,
        static_cast<long long>(roots), static_cast<long long>(read), static_cast<long long>(corners),
        static_cast<long long>(blurred), s);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string data = "fixtures/baltic_west.gpkg", ports_out;
  int ports = 200, runs = 3, threads = 0, wiggly = 0, geodesic = 0, cell_by_cell = 0, sweeps = 0, grounds = 0,
      paint = 0;
  double res = 1000.0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--data")
      data = argv[i + 1];
    else if (a == "--wiggly")
      wiggly = std::atoi(argv[i + 1]);
    else if (a == "--ports")
      ports = std::atoi(argv[i + 1]);
    else if (a == "--res")
      res = std::atof(argv[i + 1]);
    else if (a == "--runs")
      runs = std::atoi(argv[i + 1]);
    else if (a == "--threads")
      threads = std::atoi(argv[i + 1]);
    else if (a == "--geodesic")
      geodesic = std::atoi(argv[i + 1]);
    else if (a == "--cell-by-cell")
      cell_by_cell = std::atoi(argv[i + 1]);
    else if (a == "--paint")
      paint = std::atoi(argv[i + 1]);
    else if (a == "--sweeps")
      sweeps = std::atoi(argv[i + 1]);
    else if (a == "--grounds")
      grounds = std::atoi(argv[i + 1]);
    else if (a == "--ports-out")
      ports_out = argv[i + 1];
    else {
      std::fprintf(stderr, "sea_bench: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  SeedSet land_seeds;
  if (wiggly > 0) {
    std::mt19937_64 rng(7);
    for (int i = 0; i < 9; ++i) {
      const int32_t f = land_seeds.add_feature(land_seeds.owner_code(std::string(1, static_cast<char>('A' + i % 4))),
                                               "island " + std::to_string(i + 1));
      land_seeds.add_polygon(
          f, {wiggly_ring(330000 + 130000 * (i % 3), 6020000 + 90000 * (i / 3), 38000, wiggly / 9, rng)});
    }
    data = "synthetic archipelago";
  } else {
    gdal_init();
    SeedReadOptions read;
    read.paths = {data};
    read.owner_field = "iso2";
    read.target_crs = geodesic ? "" : "EPSG:32633";
    read.on_conflict = ConflictPolicy::lower_code;
    land_seeds = load_seeds(read).seeds;
  }
  // The land as barriers; ports every k-th coast vertex that is not inside another state's land.
  Barriers barriers;
  int64_t coast_vertices = 0;
  for (const Polygon& p : land_seeds.polygons()) {
    barriers.add_polygon(p.rings, land_seeds.features()[static_cast<size_t>(p.feature)].source);
    for (const Ring& r : p.rings) coast_vertices += static_cast<int64_t>(r.size());
  }
  MetricSpec metric;
  if (geodesic) metric.kind = MetricSpec::geodesic;
  const SeedSet::Box box = land_seeds.bounds();
  std::shared_ptr<const GeodesicFrame> frame;
  if (geodesic) frame = std::make_shared<const GeodesicFrame>(metric, box.xmin, box.ymin, box.xmax, box.ymax);
  const Visibility vis(frame ? barriers.mapped([&](Vec2 v) { return frame->forward(v); }) : barriers, true, frame);
  auto plane = [&](Vec2 v) { return frame ? frame->forward(v) : v; };
  const int64_t step = std::max<int64_t>(1, coast_vertices / ports);
  SeedSet seeds;
  int64_t k = 0;
  for (const Polygon& p : land_seeds.polygons()) {
    const std::string& owner =
        land_seeds.owner_labels()[static_cast<size_t>(land_seeds.features()[static_cast<size_t>(p.feature)].owner - 1)];
    for (const Ring& r : p.rings)
      for (const Vec2& v : r)
        if (k++ % step == 0 && !vis.on_land(plane(v)) && seeds.features().size() < static_cast<size_t>(ports))
          seeds.add_point(seeds.add_feature(seeds.owner_code(owner)), v);
  }
  if (!ports_out.empty()) {
    FILE* f = std::fopen(ports_out.c_str(), "w");
    if (!f) return 2;
    std::fprintf(f,
                 "{\"type\": \"FeatureCollection\", \"crs\": {\"type\": \"name\", \"properties\": {\"name\": \"%s\"}}, "
                 "\"features\": [\n",
                 geodesic ? "urn:ogc:def:crs:OGC:1.3:CRS84" : "urn:ogc:def:crs:EPSG::32633");
    for (size_t i = 0; i < seeds.sites().size(); ++i) {
      const Site& s = seeds.sites()[i];
      const std::string& owner =
          seeds.owner_labels()[static_cast<size_t>(seeds.features()[static_cast<size_t>(s.feature)].owner - 1)];
      std::fprintf(f,
                   "%s{\"type\": \"Feature\", \"properties\": {\"owner\": \"%s\"}, \"geometry\": {\"type\": \"Point\", "
                   "\"coordinates\": [%.17g, %.17g]}}\n",
                   i ? "," : "", owner.c_str(), s.a.x, s.a.y);
    }
    std::fprintf(f, "]}\n");
    std::fclose(f);
  }
  const GridSpec grid =
      make_aligned_grid(box.xmin, box.ymin, box.xmax, box.ymax, res, geodesic ? "EPSG:4326" : "EPSG:32633");
  std::printf(
      "sea_bench: %s, %lld barrier vertices, %zu ports, grid %lld x %lld (%.2e cells) at %g %s, %s, threads "
      "%d\n",
      data.c_str(), static_cast<long long>(coast_vertices), seeds.features().size(), static_cast<long long>(grid.width),
      static_cast<long long>(grid.height), static_cast<double>(grid.width * grid.height), res,
      geodesic ? "degrees" : "m", geodesic ? "geodesic" : "planar", threads);

  ComputeOptions straight_options;
  straight_options.threads = threads;
  straight_options.metric = metric;
  SeaOptions sea_options;
  sea_options.threads = threads;
  sea_options.metric = metric;
  sea_options.cell_by_cell = cell_by_cell != 0;
  std::vector<double> straight_s, sea_s, bends_s;
  SeaField last;
  for (int run = 0; run < runs; ++run) {
    auto t0 = std::chrono::steady_clock::now();
    const NearestField straight = compute(seeds, grid, straight_options);
    auto t1 = std::chrono::steady_clock::now();
    last = compute_sea(seeds, barriers, grid, grid.full_window(), sea_options);
    auto t2 = std::chrono::steady_clock::now();
    straight_s.push_back(std::chrono::duration<double>(t1 - t0).count());
    sea_s.push_back(std::chrono::duration<double>(t2 - t1).count());
    bends_s.push_back(last.bends_seconds);
    (void)straight;
  }
  int64_t bent = 0, sea_cells = 0;
  for (int64_t r = 0; r < grid.height; ++r)
    for (int64_t c = 0; c < grid.width; ++c) {
      sea_cells += last.field.site.at(c, r) != kNoSite;
      bent += last.via.at(c, r) != kNoVia;
    }
  const double cells = static_cast<double>(grid.width * grid.height);
  std::printf("straight exact   median %.3f s (%.0f ns/cell)\n", median(straight_s), median(straight_s) / cells * 1e9);
  std::printf("by sea, exact    median %.3f s (%.0f ns/cell), of which bend nodes %.3f s: %.1fx the straight field\n",
              median(sea_s), median(sea_s) / cells * 1e9, median(bends_s), median(sea_s) / median(straight_s));
  std::printf("bend nodes: %lld evaluations, %lld visibility tests\n", static_cast<long long>(last.bend_evaluations),
              static_cast<long long>(last.bend_tests));
  std::printf(
      "bend nodes %lld of %d vertices; visibility tests %lld (%.1f per sea cell); land %lld, unreachable %lld; "
      "cells whose path bends %.1f%%; largest detour %.3f\n",
      static_cast<long long>(last.bend_nodes), last.barrier_vertices, static_cast<long long>(last.visibility_tests),
      static_cast<double>(last.visibility_tests) / std::max<int64_t>(1, sea_cells),
      static_cast<long long>(last.land_cells), static_cast<long long>(last.unreachable_cells),
      100.0 * static_cast<double>(bent) / std::max<int64_t>(1, sea_cells), last.max_detour);
  std::printf("cells in blocks %lld; bent cells' lengths interpolated %lld, from %lld patches\n",
              static_cast<long long>(last.block_cells), static_cast<long long>(last.interpolated_cells),
              static_cast<long long>(last.length_patches));
  // The field's fingerprint (owners, distances' bits, vias): an optimisation of the engine must
  // leave it unchanged.
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](uint32_t v) {
    for (int k = 0; k < 4; ++k) {
      h ^= (v >> (8 * k)) & 0xffu;
      h *= 1099511628211ull;
    }
  };
  for (size_t c = 0; c < last.field.site.cells().size(); ++c) {
    mix(static_cast<uint32_t>(last.field.site.cells()[c]));
    uint32_t bits;
    std::memcpy(&bits, &last.field.distance.cells()[c], sizeof bits);
    mix(bits);
    mix(static_cast<uint32_t>(last.via.cells()[c]));
  }
  std::printf("field digest %016llx\n", static_cast<unsigned long long>(h));
  if (sweeps) measure_sweeps(vis, frame.get(), grid, last);
  if (grounds && !measure_grounds(seeds, barriers, grid, metric, last)) return 1;
  if (paint && !measure_paint(seeds, barriers, grid, metric, last, paint == 2)) return 1;
  return 0;
}
