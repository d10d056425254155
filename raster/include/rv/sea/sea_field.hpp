// The distance by sea: for every cell, the nearest seed along a path that crosses no barrier
// (rv/sea/visibility.hpp), the length of that path, and the last barrier vertex on it.
//
// The statement (planar metric): a cell x on land (Visibility::on_land) has no owner. Elsewhere
// its distance is the least, over the seed sites whose nearest point x sees, of the straight
// distance, over the points where a site's edge meets a barrier (crosses it, touches it, or
// leaves it: away from the edge's own ends) and the edge's ends on a barrier vertex (seen from a
// sea wedge there that the edge does not bound) that x sees, of the straight distance to them,
// and over the barrier vertices v that x sees (in a wedge of v), of D(v) + |v - x|, where D(v) is
// v's own distance by sea: a shortest path bends only at barrier vertices, and its last leg ends
// at the nearest point of a site, at an end of it, or where a barrier stops it from sliding along
// the site's edge towards that point (a coast seen only past a boom that meets it). So a seed's
// edge that runs into land is reached only where it is at sea (from where it leaves the land),
// and the distance keeps the triangle inequality between cells that see each other. A cell inside
// a seed polygon that is not land has distance 0 (the half-open interior of rv/field/interior.hpp).
//
// Ties: a cell that sees the straight field's nearest site (the lowest site index at the least
// distance) takes the straight field's answer bit for bit: the distance is the same float,
// computed the same way. Otherwise candidates compare by (distance, site, vertex), a site seen
// directly before any vertex. D(v) keeps the lowest site among equal paths, so a vertex
// equidistant from two owners hands the region behind it to the lower site, hence the lower
// owner code, as every engine's tie rule does.
//
// Invariant: when every barrier is also a seed, no path to the nearest site is blocked (it would
// meet a seed on the way), so the field off land equals the straight one bit for bit.
//
// Geodesic metric (SeaOptions::metric): the same statement on the ellipsoid, every straight path
// and barrier edge the geodesic between its ends (visibility decided in a GeodesicFrame,
// rv/sea/geodesic_frame.hpp), every length GeographicLib's; grid, barriers and seeds in
// longitude/latitude degrees. A line's or polygon's edges are geodesics: a path ends at the
// edge's point nearest to it (the straight geodesic engine's measure), which, computed, counts
// as on a barrier edge within the frame's deviation() of it. Where a seed's edge crosses a
// barrier edge, the point is where their images cross in the frame's plane (within its
// deviation() of the geodesics' crossing: millimetres over hundreds of kilometres).
//
// Weights and reaches (Feature, rv/field/seeds.hpp): a path from a site costs its length over the
// site's weight, and only where the length is within the site's reach (adjusted_distance); the
// cell's site is the cheapest path's (ties to the lower site), its distance and via that path's.
// Paths are still shortest paths: the sites of one (weight, reach) class are compared by length
// and searched as above over that class alone, bend nodes settled per class, and the classes
// compared by cost. A heavier seed's region may so reach round a lighter one's land; a reach
// ends where the path by sea reaches it, not the straight line. The straight field's bit for bit
// answer (Ties, above) is for unadjusted seeds: adjusted ones are measured as the oracle measures
// them (the straight distance to a seen site, the sum of the legs of a bent path), which may
// differ from the straight engines' float in the last place.
//
// Partial effect is not read here (Feature::effect): the field is every feature's at full
// effect, as the straight engines' is; the partial-effect stage compares two whole fields
// (rv/lines/partial_effect.hpp, with these engines as its PartialEngines). Seeds with a vertex
// strictly on land are refused (rv::Error(invalid_input), the feature named). Pure; deterministic
// for any thread count.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>

#include "rv/engine/engine.hpp"
#include "rv/field/grid.hpp"
#include "rv/field/raster.hpp"
#include "rv/field/seeds.hpp"
#include "rv/sea/barriers.hpp"

namespace rv {

inline constexpr int32_t kNoVia = -1;

struct SeaField {
  // site and distance as the straight field's (kNoSite / kNoDistance on land, beyond the maximum
  // distance, and where no seed can be reached).
  NearestField field;
  // The last barrier vertex on the cell's path (an index of Visibility(barriers translated to
  // the grid's local frame).vertex, i.e. of the barriers' distinct vertex positions in
  // first-appearance order), kNoVia where the seed is seen directly or there is none.
  Raster<int32_t> via;
  int64_t land_cells = 0;  // cells on land
  // Sea cells that some seed lies within the maximum distance of (and within its reach, with
  // reaches) in a straight line, and that no path by sea from those seeds reaches at all (a sea
  // enclosed by land without a seed); cells beyond every seed's maximum distance or reach are
  // not counted, whatever the land between.
  int64_t unreachable_cells = 0;
  int32_t barrier_vertices = 0;  // distinct barrier vertices
  int64_t bend_nodes = 0;        // (vertex, sea wedge) pairs wider than a half-turn: where paths may bend
  int64_t visibility_tests = 0;  // straight paths tested, all told (a block's proof for a root counts one)
  int64_t block_cells = 0;       // the exact engine: cells answered in blocks clear of barriers (proofs per block)
  // The exact engine: cells answered from what was drawn row by row before any proof (land, and
  // sea that sees its straight nearest site: raster/src/sea_map), before the blocks.
  int64_t drawn_cells = 0;
  // The exact engine on a longitude/latitude grid: cells of such blocks whose path bends answered
  // with the length from their last bend interpolated over the block (each such answer is the
  // one the inverse problem gives, to the bit), and the interpolations built.
  int64_t interpolated_cells = 0;
  int64_t length_patches = 0;
  int64_t length_retries = 0;    // such cells weighed again exactly: two roots within the error
  int64_t bend_tests = 0;        // of which while settling the bend nodes
  int64_t bend_evaluations = 0;  // the exact engine: bend nodes evaluated (a node may be more than once)
  double max_detour = 1.0;       // the largest path length over straight distance to the nearest site
  double bends_seconds = 0.0;    // the exact engine: wall time settling the bend nodes
};

// How the exact engine runs. Progress in [0, 1] is called from worker threads, never
// concurrently... at most about 100 times; when `cancel` becomes true the engine throws
// rv::Error(cancelled).
class PreparedSea;  // see prepare_sea() below

struct SeaOptions {
  // Planar: the grid's CRS units. Geodesic: metres on the metric's ellipsoid, paths and barrier
  // edges geodesics (rv/sea/geodesic_frame.hpp); the grid, the barriers and the seeds in
  // longitude/latitude degrees.
  MetricSpec metric;
  // Geodesic on a projected grid (as ComputeOptions' fields, rv/engine/engine.hpp): what locates
  // the grid's cell centres on the ellipsoid (the seeds and barriers are then in longitude/
  // latitude, the barriers' edges and paths geodesics as on a geographic grid), and the seed
  // polygons in the grid's CRS for their interiors (needed when the seeds have polygons).
  std::shared_ptr<const Geolocator> geolocator;
  std::shared_ptr<const std::vector<Polygon>> grid_polygons;
  double max_distance = std::numeric_limits<double>::infinity();  // metric units
  int threads = 0;                                                // 0: every hardware thread
  const std::atomic<bool>* cancel = nullptr;
  std::function<void(double)> progress;
  // Optional: what prepare_sea() made for these seeds, barriers and grid. Windows of one grid
  // computed one after the other (a streamed job's strips) share it instead of settling the
  // bend nodes again; the field then reports bends_seconds 0 and bend_tests 0.
  std::shared_ptr<const PreparedSea> prepared;
  // Optional: the straight exact engine's preparation of the same seeds for the same grid and
  // metric (rv::prepare with Method::exact; rv/engine/engine.hpp), for the straight field every
  // window starts from. Without it each call prepares its own. It names the seed set object it
  // was made for: one made before that object was moved is refused (rv::Error(invalid_argument)).
  std::shared_ptr<const PreparedSeeds> straight;
  // The exact engine answers blocks of cells clear of barriers at once (proofs made per block);
  // true: every cell alone, the reference those proofs are tested against. The same field.
  bool cell_by_cell = false;
};

// The part of compute_sea that does not depend on the window: the checked seeds and barriers,
// the bend nodes and their distances by sea. Throws as compute_sea. Immutable; shared by any
// number of computations at once.
std::shared_ptr<const PreparedSea> prepare_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid,
                                               const SeaOptions& options = {});

// The straight engine's preparation SeaOptions::straight takes, for `seeds` (this object: keep it
// in place while the result is used) over `grid` with options.metric. Throws as rv::prepare.
std::shared_ptr<const PreparedSeeds> prepare_straight(const SeedSet& seeds, const GridSpec& grid,
                                                      const SeaOptions& options = {});

// What preparing measured: the distinct barrier vertices (SeaField::barrier_vertices), the bend
// nodes, the straight paths tested while settling them, and its wall time in seconds.
struct SeaPreparation {
  int32_t barrier_vertices = 0;
  int64_t bend_nodes = 0;
  int64_t bend_tests = 0;
  double seconds = 0.0;
};
SeaPreparation preparation_of(const PreparedSea& prepared);

// The position of vertex `via` (SeaField::via, 0 <= via < barrier_vertices) in the grid's CRS
// (`grid`: the one prepared for; a projected geodesic grid's through its geolocator's to_grid).
// Throws rv::Error(internal) for any other index.
Vec2 via_position(const PreparedSea& prepared, const GridSpec& grid, int32_t via);

// The exact engine: the same field as brute_force_sea (owners and vias cell for cell; distances
// to the last bit of the float but where two paths tie to rounding), with every search ordered by
// a lower bound: bend nodes settled by a Dijkstra that finds each node's last bend in a tree of
// the settled ones rather than over a visibility graph, and cells searched the same way. Throws
// as brute_force_sea, and rv::Error(cancelled). With options.prepared, `seeds`, `barriers` and
// `grid` must be those it was prepared for (the interiors are read from `seeds`).
SeaField compute_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const Window& window,
                     const SeaOptions& options = {});

// The reference: every cell against every site and every vertex, shortest paths between vertices
// by Dijkstra over the full visibility graph. For small grids and the tests' oracle only: O(V^2
// (E + V)) to prepare and O(cells (S + V) (E + V)) to fill. Throws rv::Error(invalid_input) for
// seeds without sites or with a vertex on land, rv::Error(unsupported) for the cases above.
SeaField brute_force_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const Window& window,
                         double max_distance = std::numeric_limits<double>::infinity(), int threads = 0,
                         const MetricSpec& metric = {});
// The same with the options compute_sea takes (metric, geolocator and grid polygons, maximum
// distance, threads; not prepared, straight, cancel or progress).
SeaField brute_force_sea(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const Window& window,
                         const SeaOptions& options);

}  // namespace rv
