// The exact engine of the distance by sea: the statement of rv/sea/sea_field.hpp, with every
// search ordered by a lower bound so that the work follows what the answer needs rather than
// every pair.
//
// - Bend nodes' distances: a Dijkstra without a graph. Nodes wait in a queue keyed by a lower
//   bound of their distance (at first the straight distance to the nearest site). The node with
//   the least key is evaluated: its best path over the sites it sees and the nodes settled so
//   far (searched in order of weight plus distance, tested for visibility as they come). The
//   last bend of any better path would be a node not yet settled, r, and such a path is at least
//   key(r) + |r - v|; so when the evaluated path is shorter than the least of those (searched
//   the same way) it is final, else the node goes back with that bound as its key, which is
//   larger than the key it had: every step settles a node or raises a key. The owners'
//   settlings for the lines (sea/sea_metric.cpp) run it with near bends (sea/near_bends.hpp):
//   a node's nearby nodes that see it hand their paths over when they settle, as a graph's
//   Dijkstra relaxes edges, and its other roots are searched a reach at a time (bend_settle.cpp,
//   Settling::run_near), so a node deep in a shadow is not raised by the small gaps between
//   unsettled neighbours, each raise another search.
// - Cells: the straight field of the window first (the straight exact engine's, rv/engine), then
//   per cell its nearest site if seen (the straight field's answer, bit for bit), else the best
//   site seen and the best settled node seen, each searched in order of its bound. Before any
//   proof, every cell's ground and which cells see their straight nearest point site are drawn
//   row by row (sea_map/ground_rows.hpp, site_sight.hpp; the cells those drawings leave unknown
//   are proved as before): land and the cells that see it are answered at once. Where no
//   barrier is near a block of cells (a quadtree of 16 down to 4 cells), its proofs are made
//   once for the block, the lengths from its roots interpolated over the block's tile, and each
//   cell gets the answer it would get alone (sea_exact/sea_cells.hpp).
// - Seeds with weights or reaches: the same per class of (weight, reach) (sea::site_classes),
//   each with its own settled nodes, and the cheapest class's path (adjusted_path below).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <optional>
#include <queue>

#include "rv/field/error.hpp"
#include "rv/field/interior.hpp"
#include "rv/field/parallel.hpp"
#include "rv/sea/sea_field.hpp"
#include "sea/bend_settle.hpp"
#include "sea_exact/sea_cells.hpp"
#include "sea_map/ground_rows.hpp"
#include "sea_map/site_sight.hpp"

namespace rv {
namespace {

// The engines' shared parts (sea/sea_prepare.hpp, sea/root_tree.hpp, sea/bend_settle.hpp,
// sea_exact/sea_cells.hpp).
using namespace ::rv::sea;

// The side of a band of rows and of its largest blocks, and of the smallest blocks, in cells.
// A block not clear of barriers is tried again as four (a quadtree down to kMinBlock): large
// blocks share their proofs and their cells' interpolated lengths among many cells, small ones
// leave fewer cells near coasts to be answered alone.
constexpr int64_t kBlock = 16;
constexpr int64_t kMinBlock = 4;

// The ground under each cell of a row (Prepared::row_cells()) where it is `unknown` (the others are those
// of blocks answered at once: land or open sea).
void fill_grounds(const Prepared& p, const std::vector<Spot>& spots, Visibility::Ground* grounds,
                  Visibility::Ground unknown) {
  const auto width = static_cast<int64_t>(spots.size());
  if (std::none_of(grounds, grounds + width, [&](Visibility::Ground g) { return g == unknown; })) return;
  if (p.geodesic) {  // (a row of a longitude/latitude grid is no straight line in the plane)
    for (int64_t c = 0; c < width; ++c) {
      if (grounds[c] != unknown) continue;
      const Vec2 x = spots[static_cast<size_t>(c)].at;
      grounds[c] =
          c == 0 ? p.vis.classify(x) : p.vis.classify_next(spots[static_cast<size_t>(c - 1)].at, grounds[c - 1], x);
    }
    return;
  }
  std::vector<double> xs(spots.size());
  for (size_t c = 0; c < spots.size(); ++c) xs[c] = spots[c].at.x;
  std::vector<Visibility::Ground> row(spots.size());
  p.vis.classify_row(spots.empty() ? 0.0 : spots[0].at.y, xs.data(), width, row.data());
  for (int64_t c = 0; c < width; ++c)
    if (grounds[c] == unknown) grounds[c] = row[static_cast<size_t>(c)];
}

constexpr auto kUnknown = static_cast<Visibility::Ground>(-1);

// What the shortest-path map's parts draw before any cell is proved (sea_map/): every cell's
// ground, and which cells see their straight nearest point site. Empty for adjusted seeds (each
// class has its own straight field), for the cell-by-cell reference, and on a projected grid.
struct Drawing {
  std::optional<GroundRows> ground;
  std::optional<SiteSight> sight;
  Drawing(const PreparedSea& prepared, const SeaOptions& options, const GridSpec& grid, const Window& window,
          const NearestField& straight, bool adjusted) {
    const Prepared& p = prepared.prepared;
    if (adjusted || options.cell_by_cell || (p.geodesic && p.geolocator)) return;
    ground.emplace(p, options.metric, grid, window);
    const PreparedSea::CutEdges& cut = prepared.cut_edges();
    sight.emplace(p, options.metric, grid, window, straight.site, cut.edges, cut.index,
                  resolve_threads(options.threads));
  }
};

// A worker's band of rows: their centres, grounds (kUnknown until known), what was drawn of the
// cells' sight of their straight nearest sites, and which cells are answered. Kept from band to
// band: a band's rows are megabytes, and allocated afresh their pages went back to the kernel and
// were faulted in again every band.
struct Band {
  std::vector<std::vector<Spot>> spots;
  std::vector<Visibility::Ground> grounds;
  std::vector<SiteSight::Sight> sight;
  std::vector<uint8_t> answered;
  void start(const Prepared& p, const GridSpec& grid, const Window& window, int64_t r0, int64_t r1,
             const Drawing& drawing) {
    spots.resize(static_cast<size_t>(r1 - r0));
    for (int64_t r = r0; r < r1; ++r) p.row_cells(grid, window, r, spots[static_cast<size_t>(r - r0)]);
    grounds.assign(static_cast<size_t>((r1 - r0) * window.width), kUnknown);
    answered.assign(grounds.size(), 0);
    sight.assign(drawing.sight ? grounds.size() : 0, SiteSight::unknown);
    for (int64_t r = r0; r < r1; ++r) {
      const auto at = static_cast<size_t>((r - r0) * window.width);
      if (drawing.ground) drawing.ground->row(r, grounds.data() + at);
      if (drawing.sight) drawing.sight->row(r, sight.data() + at);
    }
  }
  const SiteSight::Sight* sight_at(size_t k) const { return sight.empty() ? nullptr : sight.data() + k; }
  // The cells answered from the drawing (sea_cells.hpp answer_drawn), rows [r0, r1).
  void answer_drawn(const CellRun& run, CellWorker& w, int64_t r0, int64_t r1) {
    for (int64_t r = r0; r < r1; ++r) {
      const auto at = static_cast<size_t>((r - r0) * run.window.width);
      sea::answer_drawn(run, w, r, grounds.data() + at, sight_at(at), answered.data() + at);
    }
  }
};

// Whether every cell of columns [c0, c1) of `rows` rows from `answered` (rows `stride` apart) is.
bool all_answered(const uint8_t* answered, int64_t stride, int64_t c0, int64_t c1, int64_t rows) {
  for (int64_t r = 0; r < rows; ++r)
    for (int64_t c = c0; c < c1; ++c)
      if (!answered[r * stride + c]) return false;
  return true;
}

// Whether any cell of [c0, c1) x [r0, r1) lies inside a seed polygon.
bool inside_any(const InteriorSpans& interiors, int64_t r0, int64_t r1, int64_t c0, int64_t c1) {
  for (int64_t r = r0; r < r1; ++r)
    for (const auto& span : interiors.rows[static_cast<size_t>(r)])
      if (span.col0 < c1 && span.col1 > c0) return true;
  return false;
}

// The straight exact engine's options for the field a computation by sea starts from.
ComputeOptions straight_options(const SeaOptions& options) {
  ComputeOptions o;
  o.method = Method::exact;
  o.metric = options.metric;
  o.geolocator = options.geolocator;
  o.grid_polygons = options.grid_polygons;
  o.threads = options.threads;
  o.max_distance = options.max_distance;
  o.cancel = options.cancel;
  return o;
}

}  // namespace

std::shared_ptr<const PreparedSeeds> prepare_straight(const SeedSet& seeds, const GridSpec& grid,
                                                      const SeaOptions& options) {
  return rv::prepare(seeds, grid, straight_options(options));
}

std::shared_ptr<const PreparedSea> prepare_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid,
                                               const SeaOptions& options) {
  return std::make_shared<const PreparedSea>(seeds, barriers, grid, options);
}

SeaPreparation preparation_of(const PreparedSea& prepared) {
  return SeaPreparation{prepared.prepared.vis.vertex_count(), static_cast<int64_t>(prepared.search.nodes.size()),
                        prepared.bend_tests, prepared.bends_seconds};
}

Vec2 via_position(const PreparedSea& prepared, const GridSpec& grid, int32_t via) {
  if (via < 0 || via >= prepared.prepared.vis.vertex_count())
    throw Error(ErrorKind::internal, "no such barrier vertex");
  const sea::Prepared& p = prepared.prepared;
  if (p.geolocator) {
    const Vec2 ll = p.vertex_ll[static_cast<size_t>(via)];
    Vec2 at;
    p.geolocator->to_grid(&ll.x, &ll.y, &at.x, &at.y, 1);
    return at;
  }
  if (p.geodesic) return p.vertex_ll[static_cast<size_t>(via)];
  const Vec2 local = p.vis.vertex(via);
  // The inverse of Barriers::translated(Vec2{grid.xmin, grid.ymax}) (sea::prepare).
  return Vec2{local.x + grid.xmin, local.y + grid.ymax};
}

SeaField compute_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const Window& window,
                     const SeaOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const bool shared = options.prepared != nullptr;
  const std::shared_ptr<const PreparedSea> prepared =
      shared ? options.prepared : prepare_sea(seeds, barriers, grid, options);
  const Prepared& p = prepared->prepared;
  const Searches& search = prepared->search;
  const int64_t bend_tests = shared ? 0 : prepared->bend_tests;

  // (Its rows emptied by the bands that answer them.)
  SeaField out = sea::empty_field(p, grid, window, options.metric, false);
  out.bend_nodes = static_cast<int64_t>(search.nodes.size());
  out.bends_seconds = shared ? 0.0 : prepared->bends_seconds;
  const InteriorSpans interiors = interiors_of(seeds, options.grid_polygons.get(), grid, window);
  out.field.contested_cells = interiors.contested_cells;
  // The straight field: each cell's nearest site and distance, as every engine of the straight
  // distance answers them (a cell that sees that site takes them as they are).
  // (Adjusted seeds: each class finds its own straight nearest site.)
  const bool adjusted = !prepared->classes.empty();
  ComputeOptions straight = straight_options(options);
  straight.window = window;
  straight.prepared = options.straight;
  const NearestField straight_field = adjusted ? NearestField{} : compute(seeds, grid, straight);
  const int workers = resolve_threads(options.threads);
  CellRun run{*prepared, seeds, straight_field, interiors, options.max_distance, out, grid, window};
  // Patches on a longitude/latitude grid over tiles of up to 4 x 4 blocks within kPatchSpan.
  if (p.geodesic && !p.geolocator)
    run.patch_tile = kBlock * std::clamp<int64_t>(static_cast<int64_t>(kPatchSpan / grid.res) / kBlock, 1, 4);
  std::vector<CellWorker> cell_workers(static_cast<size_t>(workers));
  for (CellWorker& w : cell_workers) {
    w.blockers.assign(static_cast<size_t>(search.site_items()) + search.nodes.size(), -1);
    w.classes.resize(prepared->classes.size());
  }
  // Bands of kBlock rows, each cut into blocks of kBlock columns: a block clear of barriers is
  // answered at once (answer_block), else its quarters are tried, down to kMinBlock; every other
  // cell alone.
  const bool blocks = !adjusted && !options.cell_by_cell;
  const int64_t bands = (window.height + kBlock - 1) / kBlock;
  std::atomic<int64_t> rows_done{0};
  const Drawing drawing(*prepared, options, grid, window, straight_field, adjusted);
  std::vector<Band> band_of(static_cast<size_t>(workers));
  detail::parallel_for(workers, bands, [&](int64_t band, int worker) {
    if (options.cancel && options.cancel->load(std::memory_order_relaxed))
      throw Error(ErrorKind::cancelled, "computation cancelled");
    CellWorker& w = cell_workers[static_cast<size_t>(worker)];
    const int64_t r0 = band * kBlock, r1 = std::min(r0 + kBlock, window.height);
    Band& b = band_of[static_cast<size_t>(worker)];
    sea::empty_rows(out, r0, r1);
    b.start(p, grid, window, r0, r1, drawing);
    const std::vector<std::vector<Spot>>& spots = b.spots;
    std::vector<Visibility::Ground>& grounds = b.grounds;
    std::vector<uint8_t>& answered = b.answered;
    if (drawing.ground) b.answer_drawn(run, w, r0, r1);
    auto try_block = [&](auto&& self, int64_t c0, int64_t c1, int64_t b0, int64_t b1, int64_t side) -> void {
      if (all_answered(answered.data() + (b0 - r0) * window.width, window.width, c0, c1, b1 - b0)) return;
      const auto at = static_cast<size_t>((b0 - r0) * window.width);
      if (!inside_any(interiors, b0, b1, c0, c1) &&
          answer_block(run, w, c0, c1, b0, b1, &spots[static_cast<size_t>(b0 - r0)], grounds.data() + at, window.width,
                       answered.data() + at, b.sight_at(at))) {
        for (int64_t r = b0; r < b1; ++r)
          std::fill_n(answered.begin() + (r - r0) * window.width + c0, c1 - c0, uint8_t{1});
        return;
      }
      if (side <= kMinBlock) return;
      const int64_t half = side / 2;
      for (int64_t qr = b0; qr < b1; qr += half)
        for (int64_t qc = c0; qc < c1; qc += half)
          self(self, qc, std::min(qc + half, c1), qr, std::min(qr + half, b1), half);
    };
    for (int64_t c0 = 0; blocks && c0 < window.width; c0 += kBlock)
      try_block(try_block, c0, std::min(c0 + kBlock, window.width), r0, r1, kBlock);
    for (int64_t r = r0; r < r1; ++r) {
      w.last = -1;
      for (ClassHints& h : w.classes) h.last = -1;
      const std::vector<Spot>& row = spots[static_cast<size_t>(r - r0)];
      Visibility::Ground* g = grounds.data() + (r - r0) * window.width;
      fill_grounds(p, row, g, kUnknown);
      const auto& spans = interiors.rows[static_cast<size_t>(r)];
      auto span = spans.begin();
      const uint8_t* answered_row = answered.data() + (r - r0) * window.width;
      for (int64_t c = 0; c < window.width; ++c) {
        if (answered_row[c]) continue;
        if (g[c] == Visibility::Ground::land) {
          ++w.land;
          continue;
        }
        while (span != spans.end() && span->col1 <= c) ++span;
        if (span != spans.end() && c >= span->col0) {
          out.field.site.at(c, r) = span->site;
          out.field.distance.at(c, r) = 0.0f;
          continue;
        }
        const SiteSight::Sight* sight = b.sight_at(static_cast<size_t>((r - r0) * window.width));
        answer_cell(run, w, c, r, row[static_cast<size_t>(c)], g[c], sight && sight[c] == SiteSight::hidden);
      }
      const int64_t done = rows_done.fetch_add(1) + 1;
      if (options.progress && (done * 100 / window.height) != ((done - 1) * 100 / window.height))
        options.progress(static_cast<double>(done) / static_cast<double>(window.height));
    }
  });
  out.visibility_tests = bend_tests;
  out.bend_tests = bend_tests;
  out.bend_evaluations = shared ? 0 : prepared->evaluations();
  for (const CellWorker& w : cell_workers) {
    out.land_cells += w.land;
    out.unreachable_cells += w.unreachable;
    out.visibility_tests += w.tests;
    out.block_cells += w.block_cells;
    out.drawn_cells += w.drawn;
    out.interpolated_cells += w.interpolated;
    out.length_patches += w.patches;
    out.length_retries += w.patch_retries;
    out.max_detour = std::max(out.max_detour, w.detour);
  }
  out.field.threads = workers;
  out.field.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace rv
