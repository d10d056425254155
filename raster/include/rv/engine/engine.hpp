// The engine: for every cell of a window of a grid, the nearest site and the distance to it.
//
// Methods:
//   exact        tile culling with provably safe distance bounds, then an exact argmin per cell.
//                Zero cells whose site is farther than the true nearest. The default.
//   hv_scan      the horizontal-vertical 3x3 scan of Liu, Zhao, Wang, Sun (2019): a horizontal
//                cycle (forward rows top->bottom, left->right, neighbours Q1-Q4; backward rows
//                bottom->top, right->left, Q5-Q8) then a vertical cycle (forward columns
//                left->right, each top->bottom, neighbours Q1, Q4, Q6, Q2; backward columns
//                right->left, each bottom->top, Q3, Q5, Q8, Q7). Exact distances to the
//                candidates' real geometry; ownership not guaranteed exact (3x3 propagation
//                cannot be), measured by validate().
//   h_scan       the horizontal cycle alone (Shih & Wu 2004, the paper's baseline).
//   brute_force  every cell against every site: the reference for validation.
//
// Determinism: the result is identical, cell for cell, for any thread count (the scans run a
// pipelined wavefront that preserves the sequential order's semantics; the exact method's
// result does not depend on order at all).
// Ties (equal computed distance) go to the lower site index, in every method.
//
// Metric (ComputeOptions::metric, see rv/field/metric.hpp): planar measures Euclidean distance in CRS
// units; geodesic measures metres on the ellipsoid, with seeds in longitude/latitude degrees
// (see rv/geodesic/geodesic.hpp) and the grid either in longitude/latitude too (a geographic grid) or in
// a projected CRS whose cell centres a Geolocator locates on the ellipsoid (a projected geodesic
// grid, below). Every method works with both metrics on geographic grids. Projected geodesic
// grids (ComputeOptions::geolocator set):
//   - each cell centre (x, y) of the grid is taken to (lon, lat) by the geolocator and measured
//     there exactly as on a geographic grid; distances are metres on the ellipsoid;
//   - the geographic-grid checks below (degrees) do not apply; a located latitude outside
//     [-90, 90] or a non-finite position is rv::Error(invalid_input);
//   - polygon interiors are tested in the grid's plane on ComputeOptions::grid_polygons (the
//     seeds' polygons in the grid's CRS), as on planar grids;
//   - every method works: brute force (one batch transformation per row), the scans (one per
//     cell and pass), and exact (one batch per row of each 256 x 256 tile, plus 17 single points
//     per interpolation block and site; its interpolation blocks are sized from the cell size
//     measured at the grid's centre to at most 38 km on the ellipsoid for points and 23 km for
//     edges, as 0.35 and 0.21 degrees are on geographic grids).
// Geographic geodesic grids:
//   - cell centres must lie within latitudes [-90, 90] (grids may reach a pole);
//   - longitudes may run past 180 (a grid across the antimeridian has xmin + width*res > 180),
//     the grid may span at most 360 degrees of longitude;
//   - polygon interiors are tested on longitude/latitude as given (edges are straight in
//     degrees, not geodesics: exact for meridians and the equator, otherwise a difference of
//     the order of the edge's sagitta, about L^2 tan(lat) / (8 R): 7 mm for a 500 m edge at
//     55 degrees, 280 m for a 100 km one, growing towards the poles). Rings are unwrapped so that
//     each edge goes the short way round (as its geodesic does), except rings that wind round a
//     pole, which are taken as given; each polygon is also matched one turn east and west, so
//     interiors work across the antimeridian;
//   - the exact method culls with chord (lower) and path-length (upper) bounds that are proven
//     safe. Distances to point sites, and to segments from cells where a segment is certainly
//     nearest at one of its ends, are interpolated on grid-aligned blocks (d / chord, bicubic
//     from 16 inverse problems per block and site, checked at the block's centre; ~1e-8 m),
//     other segment distances are exact; every close call (two candidates within 1e-4 m, or a
//     distance within 1e-4 m of max_distance) is decided with exact distances and brute force's
//     tie rule. So the owners equal brute force's cell for cell, and distances equal them to
//     the last bit of the float32 (which may differ by one unit in the last place). Costs: a
//     few tens of flops per cell and candidate where interpolated, one GeographicLib inverse
//     problem (thousands of flops) per cell where a segment's interior is nearest. The scans
//     solve one for every neighbour candidate they compare.
//
// Thread safety: compute() is reentrant; any number of computations may run at once.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "rv/field/cell_mask.hpp"
#include "rv/field/geolocate.hpp"
#include "rv/field/grid.hpp"
#include "rv/field/metric.hpp"
#include "rv/field/parallel.hpp"
#include "rv/field/raster.hpp"
#include "rv/field/seeds.hpp"

namespace rv {

enum class Method { exact, hv_scan, h_scan, brute_force };

std::string_view to_string(Method m);
// Throws rv::Error(invalid_argument) for an unknown name. Accepts "hv-scan" and "hv_scan".
Method parse_method(std::string_view name);

inline constexpr float kNoDistance = -1.0f;  // distance value of cells with no owner
inline constexpr int32_t kNoSite = -1;

class PreparedSeeds;  // see prepare() below

struct ComputeOptions {
  Method method = Method::exact;
  int threads = 0;  // 0 = all hardware threads
  // The distance measured (default planar). Geodesic: seeds in lon/lat degrees, and the grid
  // too unless a geolocator is given (below).
  MetricSpec metric;
  // Cells farther than this from every seed get no owner (metric units: CRS units for planar,
  // metres for geodesic).
  double max_distance = std::numeric_limits<double>::infinity();
  std::optional<Window> window;  // default: the whole grid
  // Progress in [0, 1]; called from worker threads, never concurrently, at most ~100 times.
  std::function<void(double)> progress;
  // Polled by the workers; when it becomes true compute() throws rv::Error(cancelled).
  const std::atomic<bool>* cancel = nullptr;
  // Geodesic metric on a projected grid (rv/field/geolocate.hpp): the grid is in the projected CRS,
  // the seeds in longitude/latitude degrees of its geographic base; every cell centre is located
  // on the ellipsoid with this before measuring. Null for geographic grids and the planar metric
  // (setting it with the planar metric is rv::Error(invalid_argument)). Shared: compute() only
  // reads it, from several threads at once.
  std::shared_ptr<const Geolocator> geolocator;
  // With a geolocator: the seeds' polygons in the grid's CRS (same order and area_site indices as
  // SeedSet::polygons(), else rv::Error(invalid_argument); required when the seeds have
  // polygons), for the interior test, which is done in the grid's plane. Ignored otherwise.
  std::shared_ptr<const std::vector<Polygon>> grid_polygons;
  // Optional: what prepare() made for these seeds, grid and metric. Windows of one grid computed
  // one after the other (a streamed job's strips, a tiled job's tiles) share it instead of each
  // preparing again.
  std::shared_ptr<const PreparedSeeds> prepared;
  // Optional: the cells to compute (rv/field/cell_mask.hpp, window-relative; CellMask::fits the window,
  // else rv::Error(invalid_argument)). compute_into then writes at least these cells, each with
  // the value it gets without the mask, and may leave any other cell as `out` held it: pass the
  // field of an earlier computation of this grid and window, which `out` must already hold (else
  // invalid_argument). compute() starts from no site everywhere. Only the exact method takes a
  // mask (others: invalid_argument). The edits of a finished job recompute only what changes.
  std::shared_ptr<const CellMask> mask;
};

struct NearestField {
  Raster<int32_t> site;    // nearest site index (into SeedSet::sites()), kNoSite where none
  Raster<float> distance;  // distance to it in metric units, kNoDistance where none (geodesic:
                           // metres, rounded to float: relative rounding 6e-8, i.e. 6 mm at 100 km)
  MetricSpec metric;       // the metric the distances were measured in
  // The geolocator the cells were located with (projected geodesic grids), null otherwise.
  // The deliverables measure such fields with LocatedGeodesicSiteMetric (rv/engine/site_metric.hpp).
  std::shared_ptr<const Geolocator> geolocator;
  double seconds = 0.0;  // wall time of the computation
  // Cells whose centre lies inside polygons of two or more owners (decided for the lower code),
  // in the window's rows (with a mask: in the bands of 256 grid rows that hold its spans).
  int64_t contested_cells = 0;
  int threads = 1;  // threads actually used
};

// Bytes the method needs for a window of `cells` cells and `sites` sites (result included).
// Used to refuse a job before allocating anything.
// `metric`: geodesic adds ~0.7 KB per site (a prepared GeographicLib::GeodesicLine per edge).
int64_t estimate_memory(Method m, int64_t cells, int64_t sites, MetricSpec::Kind metric = MetricSpec::planar);

// Throws rv::Error(invalid_argument) when `seeds` have weights or reaches (SeedSet::adjusted) and
// `method` is a scan: a weighted region can be disconnected, which 3x3 propagation cannot find.
// compute() and prepare() check it; callers may check it before any other work.
void check_method_for(const SeedSet& seeds, Method method);

// Computes the nearest-site field. Throws rv::Error(invalid_argument) for an invalid grid,
// window or metric (geodesic: latitudes beyond +-90 or more than 360 degrees of longitude; a
// geolocator without the geodesic metric; missing or mismatched grid_polygons),
// rv::Error(invalid_input) when the seed set has no sites (or, geodesic, a seed latitude beyond
// +-90; projected geodesic: a cell centre the geolocator cannot locate),
// rv::Error(cancelled).
NearestField compute(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options);

// The same, writing into `out` and reusing its buffers whenever they are at least the window's
// size, whatever grid or window they held before (a fresh buffer costs the kernel's page
// zeroing, about half the time of a large exact run; a job streamed in strips computes every
// strip into the same buffers). For the exact and brute-force methods the cells of a window
// equal the same cells of the whole grid's result, bit for bit; the scans' do not (they
// propagate inside the window).
void compute_into(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options, NearestField& out);

// Prepares `seeds` for computing windows of `grid` with options.metric (and options.geolocator):
// the sites placed in the grid's frame and the spatial index the exact method culls with. Pass
// the result as ComputeOptions::prepared to every compute()/compute_into() over that grid. The
// seed set must outlive the result and stay unchanged while it is used; compute() refuses a
// prepared set made for another seed set object, site count, grid, metric or geolocator
// (rv::Error(invalid_argument)). Same errors as compute() for the seeds and metric. The result is
// immutable: any number of threads and computations may share it.
std::shared_ptr<const PreparedSeeds> prepare(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options);

}  // namespace rv
