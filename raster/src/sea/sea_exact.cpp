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
//   larger than the key it had: every step settles a node or raises a key.
// - Cells: the straight field of the window first (the straight exact engine's, rv/engine), then
//   per cell its nearest site if seen (the straight field's answer, bit for bit), else the best
//   site seen and the best settled node seen, each searched in order of its bound.
// - Seeds with weights or reaches: the same per class of (weight, reach) (sea::site_classes),
//   each with its own settled nodes, and the cheapest class's path (adjusted_path below).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <queue>

#include "rv/field/error.hpp"
#include "rv/field/interior.hpp"
#include "rv/field/parallel.hpp"
#include "rv/sea/sea_field.hpp"
#include "sea/bend_settle.hpp"

namespace rv {
namespace {

// The engines' shared parts (sea/sea_prepare.hpp, sea/root_tree.hpp, sea/bend_settle.hpp).
using namespace ::rv::sea;

// The cells of row r of the window where the engines hold them (on the ellipsoid the row is one
// parallel, projected as one: GeodesicFrame::forward_row).
std::vector<Spot> row_spots(const Prepared& p, const GridSpec& grid, const Window& window, int64_t r) {
  std::vector<Spot> spots(static_cast<size_t>(window.width));
  if (!p.geodesic) {
    for (int64_t c = 0; c < window.width; ++c)
      spots[static_cast<size_t>(c)] = p.cell(grid, window.col0 + c, window.row0 + r);
    return spots;
  }
  if (p.geolocator) {  // a projected grid's row, located as one batch
    std::vector<double> x(static_cast<size_t>(window.width)), y(x.size(), grid.centre_y(window.row0 + r));
    std::vector<double> lon(x.size()), lat(x.size());
    for (int64_t c = 0; c < window.width; ++c) x[static_cast<size_t>(c)] = grid.centre_x(window.col0 + c);
    p.geolocator->to_lonlat(x.data(), y.data(), lon.data(), lat.data(), x.size());
    for (size_t c = 0; c < x.size(); ++c) {
      const Vec2 ll{lon[c], lat[c]};
      spots[c] = Spot{p.vis.frame()->forward(ll), ll};
    }
    return spots;
  }
  std::vector<Vec2> plane(static_cast<size_t>(window.width));
  const double lat = grid.centre_y(window.row0 + r);
  p.vis.frame()->forward_row(lat, grid.centre_x(window.col0), grid.res, window.width, plane.data());
  for (int64_t c = 0; c < window.width; ++c)
    spots[static_cast<size_t>(c)] = Spot{plane[static_cast<size_t>(c)], Vec2{grid.centre_x(window.col0 + c), lat}};
  return spots;
}

// The ground under each cell of a row (row_spots()).
std::vector<Visibility::Ground> row_grounds(const Prepared& p, const std::vector<Spot>& spots) {
  const auto width = static_cast<int64_t>(spots.size());
  std::vector<Visibility::Ground> grounds(spots.size());
  if (p.geodesic) {  // (a row of a longitude/latitude grid is no straight line in the plane)
    for (int64_t c = 0; c < width; ++c)
      grounds[static_cast<size_t>(c)] =
          c == 0 ? p.vis.classify(spots[0].at)
                 : p.vis.classify_next(spots[static_cast<size_t>(c - 1)].at, grounds[static_cast<size_t>(c - 1)],
                                       spots[static_cast<size_t>(c)].at);
    return grounds;
  }
  std::vector<double> xs(spots.size());
  for (size_t c = 0; c < spots.size(); ++c) xs[c] = spots[c].at.x;
  p.vis.classify_row(spots.empty() ? 0.0 : spots[0].at.y, xs.data(), width, grounds.data());
  return grounds;
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

// A cell's answer over the classes of adjusted seeds (PreparedSea::classes): per class its
// shortest path (its straight nearest site where seen, else the search), the cheapest by
// adjusted_distance, ties to the lower site. A class whose straight distance already costs more
// than the best so far cannot win (no path by sea is shorter than the straight line), and its
// search stops at the length that would tie. `d0`: the winning class's straight distance, 0 where
// its path is that class's straight nearest site seen (no detour). `unreachable`: some class is
// within its reach of the cell in a straight line, and none of those has any path to it at all
// (as opposed to none within the reach).
struct ClassHints {
  std::vector<int32_t> blockers;  // Searches::best_path's hints, per item of the class's tree
  int32_t last = -1;              // the root of the row's previous bent cell
};
Best adjusted_path(const PreparedSea& prepared, const SeedSet& seeds, const Place& at, const Spot& spot,
                   double max_distance, std::vector<ClassHints>& hints, int64_t& tests, double& d0, bool& unreachable) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Prepared& p = prepared.prepared;
  Best won;
  double won_cost = kInf;
  unreachable = false;
  std::vector<size_t> unanswered;  // classes searched within their reach that found no path
  bool found = false;              // some class searched found a path (within its reach or not)
  for (size_t k = 0; k < prepared.classes.size(); ++k) {
    const PreparedSea::Class& cls = prepared.classes[k];
    const Searches& s = *cls.search;
    const auto [k0, nearest] = s.straight(spot);
    if (nearest == kNoSite) continue;
    const double straight = std::sqrt(k0);
    const double cap = std::min(max_distance, cls.reach);
    const double limit = won.site == kNoSite ? cap : std::min(cap, won_cost * cls.weight * (1.0 + 1e-12));
    if (straight > limit) continue;
    ClassHints& h = hints[k];
    if (h.blockers.empty()) h.blockers.assign(static_cast<size_t>(s.site_items()) + s.nodes.size(), -1);
    Best b;
    ++tests;
    const bool seen = p.vis.sees(at, p.site_place(nearest, spot));
    if (seen)
      b = Best{straight, nearest, kNoVia};
    else
      b = s.best_path(at, spot, Best{}, tests, -1, &h.blockers, h.last, &h.last, 0, kInf, limit);
    if (b.site == kNoSite) {
      unanswered.push_back(k);
      continue;
    }
    found = true;
    const double cost =
        adjusted_distance(seeds.features()[static_cast<size_t>(seeds.site_feature(b.site))], b.d, max_distance);
    if (cost < won_cost || (cost == won_cost && cost < kInf && b.site < won.site)) {
      won = b;
      won_cost = cost;
      d0 = seen ? 0.0 : straight;
    }
  }
  if (won.site != kNoSite) return won;
  // (Only cells no class reaches within its reach ask whether any path reaches them at all.)
  unreachable = !found && !unanswered.empty();
  for (size_t k : unanswered)
    if (prepared.classes[k].search->best_path(at, spot, Best{}, tests).site != kNoSite) unreachable = false;
  return won;
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

  SeaField out = sea::empty_field(p, grid, window, options.metric);
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
  struct Tally {
    int64_t land = 0, unreachable = 0, tests = 0;
    double detour = 1.0;
  };
  std::vector<Tally> tally(static_cast<size_t>(workers));
  // Per worker, the edge that last hid each root (see best_path): neighbouring cells are mostly
  // hidden from the same roots by the same edges.
  std::vector<std::vector<int32_t>> blockers(static_cast<size_t>(workers));
  std::vector<std::vector<ClassHints>> class_hints(static_cast<size_t>(workers),
                                                   std::vector<ClassHints>(prepared->classes.size()));
  std::atomic<int64_t> rows_done{0};
  detail::parallel_for(workers, window.height, [&](int64_t r, int worker) {
    if (options.cancel && options.cancel->load(std::memory_order_relaxed))
      throw Error(ErrorKind::cancelled, "computation cancelled");
    Tally& t = tally[static_cast<size_t>(worker)];
    std::vector<int32_t>& hint = blockers[static_cast<size_t>(worker)];
    int32_t last = -1;  // the root of the row's previous bent cell
    if (hint.empty()) hint.assign(static_cast<size_t>(search.site_items()) + search.nodes.size(), -1);
    std::vector<ClassHints>& hints = class_hints[static_cast<size_t>(worker)];
    for (ClassHints& h : hints) h.last = -1;
    const auto& spans = interiors.rows[static_cast<size_t>(r)];
    auto span = spans.begin();
    const std::vector<Spot> spots = row_spots(p, grid, window, r);
    const std::vector<Visibility::Ground> grounds = row_grounds(p, spots);
    for (int64_t c = 0; c < window.width; ++c) {
      const Spot& spot = spots[static_cast<size_t>(c)];
      const Vec2 x = spot.at;
      const Visibility::Ground ground = grounds[static_cast<size_t>(c)];
      if (ground == Visibility::Ground::land) {
        ++t.land;
        continue;
      }
      while (span != spans.end() && span->col1 <= c) ++span;
      if (span != spans.end() && c >= span->col0) {
        out.field.site.at(c, r) = span->site;
        out.field.distance.at(c, r) = 0.0f;
        continue;
      }
      Place at{x};
      at.open = ground == Visibility::Ground::open_sea;
      if (adjusted) {
        double d0 = 0.0;
        bool unreachable = false;
        const Best best =
            adjusted_path(*prepared, seeds, at, spot, options.max_distance, hints, t.tests, d0, unreachable);
        t.unreachable += unreachable ? 1 : 0;
        if (best.site == kNoSite) continue;
        out.field.site.at(c, r) = best.site;
        out.field.distance.at(c, r) = static_cast<float>(best.d);
        out.via.at(c, r) = best.via;
        // (Over the straight distance as a float, as the reference.)
        if (d0 > 0.0) t.detour = std::max(t.detour, best.d / static_cast<double>(static_cast<float>(d0)));
        continue;
      }
      // The straight field's answer where its nearest site is seen; else the best path. (None
      // within the maximum distance: no path by sea is shorter than the straight line.)
      const int32_t nearest = straight_field.site.at(c, r);
      if (nearest == kNoSite) continue;
      const float d0 = straight_field.distance.at(c, r);
      ++t.tests;
      if (p.vis.sees(at, p.site_place(nearest, spot))) {
        out.field.site.at(c, r) = nearest;
        out.field.distance.at(c, r) = d0;
        continue;
      }
      const Best best = search.best_path(at, spot, Best{}, t.tests, -1, &hint, last, &last);
      if (best.site == kNoSite) {
        ++t.unreachable;
        continue;
      }
      if (best.d > options.max_distance) continue;
      out.field.site.at(c, r) = best.site;
      out.field.distance.at(c, r) = static_cast<float>(best.d);
      out.via.at(c, r) = best.via;
      if (d0 > 0.0f) t.detour = std::max(t.detour, best.d / static_cast<double>(d0));
    }
    const int64_t done = rows_done.fetch_add(1) + 1;
    if (options.progress && (done * 100 / window.height) != ((done - 1) * 100 / window.height))
      options.progress(static_cast<double>(done) / static_cast<double>(window.height));
  });
  out.visibility_tests = bend_tests;
  out.bend_tests = bend_tests;
  out.bend_evaluations = shared ? 0 : prepared->evaluations();
  for (const Tally& t : tally) {
    out.land_cells += t.land;
    out.unreachable_cells += t.unreachable;
    out.visibility_tests += t.tests;
    out.max_detour = std::max(out.max_detour, t.detour);
  }
  out.field.threads = workers;
  out.field.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace rv
