// The engine façade: one computation from seed layers to result files, exactly as both the CLI
// (`rvoronoi compute`) and the daemon (`POST /processes/voronoi/execution`) run it.
//
// Units: extent, margin and resolution are in grid-CRS units (degrees on geographic grids);
// max_distance is in `distance_units` (metres/km/nmi on geodesic grids, CRS units or m/km/nmi
// on projected grids with metric units).
// Thread safety: run_job() is reentrant; jobs may run concurrently (each owns its data).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/engine/engine.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/lines/partial_effect.hpp"
#include "rv/sea/sea_field.hpp"

namespace rv {

struct GridRequest {
  std::optional<double> resolution;             // cell size; required unless `like` is given
  std::optional<std::array<double, 4>> extent;  // xmin, ymin, xmax, ymax; default: from seeds
  std::string like;                             // raster whose grid (extent, res, CRS) to reuse
  std::optional<double> margin;                 // growth of the seeds' box; default 5 % of it
};

struct OutputRequest {
  // The code rasters (ownership, nearest feature) are written in the narrowest integer type that
  // holds every code: Byte up to 255 owners / features, UInt16 up to 65535, else Int32.
  std::string ownership;                        // owner codes GeoTIFF, nodata 0 (required by the CLI)
  std::string distance;                         // Float32 distance GeoTIFF
  std::string nearest_feature;                  // 1-based feature position GeoTIFF, nodata 0
  std::string report;                           // JSON report file
  bool cloud_optimized = false;                 // write COGs (the daemon does)
  Compression compression = Compression::fast;  // every GeoTIFF of the job (rv/gdal/raster_io.hpp)

  // Maritime deliverables (rv/lines/, rv/report/). They are always computed from an exact field:
  // with a scan method the job also runs the exact method for them.
  std::string boundaries;  // boundary lines between owners (.geojson/.json/.gpkg)
  std::string tripoints;   // points where three owners meet (.geojson/.json/.gpkg)
  std::string limits;      // distance-limit lines (.geojson/.json/.gpkg); needs limit_distances
  // Each "12nmi", "24 nmi", "500m", "3.5km" or a plain number in the job's distance units.
  std::vector<std::string> limit_distances;
  bool limits_per_owner = false;  // one line set per owner instead of one for all seeds
  std::string regions;            // one multipolygon per owner (.geojson/.json/.gpkg)
  std::string margin;             // Float32 GeoTIFF: other owner's distance minus own (-1 = none)
  std::string preview;            // PNG quicklook of ownership with boundary lines
  std::string turning_points;     // the boundary lines' turning points, a treaty table (.json/.csv)
  // An edit's changes (JobSpec::base_report): Byte GeoTIFF, 1 where the owner changed, 2 where
  // only the distance did, 0 elsewhere.
  std::string changes;
  // The directory where the run keeps its field for later edits (service/src/job/edit_base.hpp):
  // streamed runs only; "" = the report's path with ".rvbase" when there is a report, else none.
  std::string edit_base;
  bool keep_for_edits = true;  // false: keep nothing (no later edit can name this run as its base)
  // The distance by sea (JobSpec::barriers): Int32 GeoTIFF of the last barrier vertex on each
  // cell's path (1-based, numbered as rv/sea/sea_field.hpp's SeaField::via, plus one), 0 where
  // the seed is seen directly or no seed is reached; the report lists the vertices it names.
  std::string via;
  // Rasters handed to the caller in memory (JobResult::rasters) instead of, or besides, files:
  // front ends that give arrays to their users (the Python module). A job with any of them
  // computes its field whole (JobPlan::why_whole), of JobSpec::window when set.
  struct InMemory {
    bool ownership = false, distance = false, nearest_feature = false;
    bool via = false;  // the distance by sea's (OutputRequest::via's codes); needs barriers
    bool any() const { return ownership || distance || nearest_feature || via; }
  } in_memory;
  // false: no report is assembled (JobResult::report holds nothing) and the job's memory is not
  // watched: the pieces of a grid computed in chunks, many small runs whose callers keep only
  // the rasters (the report of a grid of 5,000 owners costs milliseconds a piece). Needs no
  // report file.
  bool describe = true;
  double simplify_cells = 0.0;  // Douglas-Peucker tolerance of boundary and limit lines, cells
  // The largest distance between any point of an output line and its exact locus (parse_length;
  // "1mm" by default: 0.001 CRS units where the seeds have no CRS).
  std::string line_tolerance = "1mm";
  // The disproportionality test (regions within a relevant area): a vector file of the relevant
  // area's polygons, and optionally of each owner's relevant coasts (lines, owned through the
  // seeds' owner field; by default the parts of the seeds nearest to the area's cells).
  std::string relevant_area;
  std::string relevant_coasts;
  // Whether the regions are made (written, or measured for the relevant area alone).
  bool regions_wanted() const { return !regions.empty() || !relevant_area.empty(); }
  bool any_deliverable() const {
    return !boundaries.empty() || !tripoints.empty() || !limits.empty() || regions_wanted() || !margin.empty() ||
           !preview.empty() || !turning_points.empty();
  }
};

// A limit distance as given (e.g. "12nmi"): its value and unit ("" when plain). Throws
// rv::Error(invalid_argument) for a malformed, non-positive or unknown-unit value.
struct LimitDistance {
  double value = 0.0;
  std::string unit;  // "", "m", "km", "nmi"
  std::string text;  // as given
};
LimitDistance parse_limit_distance(const std::string& text);
// A length as given (e.g. "1mm", "0.5 m", "0.002"): its value and unit ("" when plain: the job's
// distance units), and the unit in metres. Units: mm, cm, m, km, nmi. Throws
// rv::Error(invalid_argument) for a malformed, negative or unknown-unit value.
struct Length {
  double value = 0.0;
  std::string unit;
  double metres_per_unit = 1.0;
  std::string text;
};
Length parse_length(const std::string& text);

struct JobSpec {
  SeedReadOptions seeds;
  GridRequest grid;
  Method method = Method::exact;
  int threads = 0;  // 0 = all cores
  MetricRequest metric = MetricRequest::automatic;
  std::optional<DistanceUnit> distance_units;  // none: CRS units (planar) or metres (geodesic)
  std::optional<double> max_distance;
  bool validate = false;  // also run brute force and report the differences
  OutputRequest outputs;
  // Rows per strip on the streaming path (see JobPlan): 0 = chosen by run_job, > 0 = this many
  // (clamped to the grid's height), < 0 = never stream (compute the whole field, then write;
  // for comparisons). Never changes a cell of the outputs.
  int64_t strip_rows = 0;
  // An edit of a finished run: the report of that run (its kept base, see service/src/job/edit_base.hpp).
  // The job then reads the base's field instead of computing it, recomputes the cells the edited
  // seeds can change, and writes what a fresh run of this spec writes, file for file; its report
  // says what changed ("edit"). The base's grid, metric, method, distance units, max distance and
  // compression must equal this job's (else invalid_argument naming the difference).
  std::string base_report;
  std::string base_name;  // how the report names the base ("" = base_report)
  // Only these cells of the grid (relative to it; the grid is planned as without it): one chunk
  // of a grid cut into pieces that are computed apart (the Python module's Dask chunks). The exact
  // and brute-force methods compute any window as the same cells of the whole grid. Outputs in
  // memory only: a window with an output file, a deliverable, validation, partial effect, a base
  // or a scan method is invalid_argument, and so is a window outside the grid.
  std::optional<Window> window;
  // One band of a grid split across hosts (a shared service's split job): rows [row0, row0 +
  // rows) of the planned grid, whole width, computed and their field written into the folder
  // `dir` (site.tif, distance.tif, band.json; service/src/job/job_bands.hpp) for an assembling
  // run (`bands`) to read. row0 is a multiple of 256, and so is rows unless the band ends at the
  // grid's last row. A band writes nothing else (an output file, a deliverable or a report is
  // invalid_argument) and needs a streamed plan (JobPlan); its report says which rows it holds.
  struct Band {
    int64_t row0 = 0;
    int64_t rows = 0;
    std::string dir;
  };
  std::optional<Band> band;
  // An assembling run of a split job: its field read from these bands' folders (written by band
  // runs of the same request, in any order; together every row of the grid once) instead of
  // computed. Everything else is a fresh run's, and so are its files, byte for byte. Needs a
  // streamed plan; not with a base or a window (invalid_argument).
  std::vector<std::string> bands;
  // The distance by sea (rv/sea/sea_field.hpp): vector files of land polygons and barrier lines
  // (read as the seeds are, rv::load_barriers) that no path may cross; empty = straight
  // distances. Geodesic on a longitude/latitude grid (point seeds), planar on a projected one;
  // the exact or brute-force method; not with weights, reaches,
  // partial effect, deliverables, an edit, a window of a split job's band (invalid_argument or
  // unsupported naming the conflict).
  std::vector<std::string> barriers;
  // How far inland a seed vertex may lie and be moved onto the coast (rv/sea/snap.hpp); a length
  // (parse_length) in metres unless it names its unit; CRS units where the seeds have no CRS.
  std::string snap_tolerance = "1m";
};

// How run_job computes and writes a job, decided from the request and the grid alone, before
// anything grid-sized is allocated.
//
// Streamed: the grid is computed in strips of whole rows (ComputeOptions::window, into the same
// buffers each time), its distances converted to the requested unit, and handed to the writer
// threads, one per file, that make their codes from its sites (owner codes, feature numbers) and
// encode it into the GeoTIFFs (GeoTiffStripWriter) side by side while the engine computes the
// next strip; two strips are in flight at most. The deliverables take each strip in on the
// computing thread before the writers see it (rv::StripLines for the lines, a strip of margin, the
// preview's sample) and are written after the last strip; regions are polygonized from the
// lines (with a max distance, the line at that distance too).
// A COG is written strip by strip too: its writer makes the overviews as the strips pass and
// assembles the file from the encoded tiles after the last one.
// Memory is O(strip) plus the lines' length, not O(grid), and every file is identical to the
// whole-field path's for any strip height and thread count. A job is streamed when:
//   - method exact or brute-force: a window of these equals the same cells of the whole grid
//     (the scans propagate inside the window, so a strip of them would differ);
//   - no validate (it compares two whole fields; brute force is limited to small grids anyway);
//   - at least one raster output (ownership, distance or nearest feature) or deliverable;
//   - JobSpec::strip_rows >= 0.
// Otherwise (the "whole" path) the field is computed whole, then each raster is made and written.
struct JobPlan {
  bool streamed = false;
  int64_t strip_rows = 0;    // rows per strip when streamed; the grid's height otherwise
  int64_t strips = 1;        // number of strips
  int64_t memory_bytes = 0;  // estimated peak for the grid and the seeds, checked against the memory limit
  std::string why_whole;     // the first rule above the job breaks; "" when streamed
};
// `sites`: SeedSet::sites().size(); `metric`: the resolved metric's kind; `seed_bytes`: what the
// loaded seeds hold (seed_memory_bytes), part of the estimate since they live as long as the job.
JobPlan plan_job(const JobSpec& spec, const GridSpec& grid, int64_t sites, MetricSpec::Kind metric,
                 int64_t seed_bytes = 0);

// The memory the loaded seeds hold: the SeedSet, the grid-CRS copy of the polygons (projected
// geodesic grids) and the input positions.
int64_t seed_memory_bytes(const LoadedSeeds& loaded);

// Limits decided before anything big is allocated (the daemon's come from its configuration,
// rv/server_config.hpp).
// Each limit refused is an rv::Error(too_large) whose message names the limit and the value.
// The feature, vertex and input-byte limits are enforced by load_seeds while it reads (the
// stricter of these and spec.seeds' own applies), and so is the memory limit for reading (at
// kReadingBytesPerVertex a vertex); the cell and memory limits once the grid is planned, before
// anything grid-sized is allocated.
struct JobLimits {
  int64_t max_cells = int64_t{1} << 34;
  int64_t max_memory_bytes = 0;            // 0 = 80 % of physical memory
  int64_t validate_max_cells = 4'000'000;  // brute-force validation refused above this
  int64_t max_features = 10'000'000;       // seed features read (empty ones included); 0 = none
  int64_t max_vertices = 100'000'000;      // seed vertices after linearising curves; 0 = none
  // Bytes inflated from zip archives of seeds, counted while inflating (a 300 KB zip can hold
  // gigabytes); 0 = none.
  int64_t max_input_bytes = int64_t{2} << 30;
};

struct JobHooks {
  // stage: "read", "compute", "validate", "write", "deliver"; fraction in [0, 1] of that stage.
  std::function<void(const std::string& stage, double fraction)> progress;
  const std::atomic<bool>* cancel = nullptr;
  // The job's memory estimate so far, in bytes, before it allocates what the estimate covers:
  // called while the seeds are read (SeedReadOptions::on_reading_bytes) and once planned
  // (JobPlan::memory_bytes, before the field's buffers), from the job's thread. May block until
  // the memory is free; whatever it throws stops the job (a daemon's memory account).
  std::function<void(int64_t bytes)> reserve_memory;
  // The grid's cell count, once planned (before reserve_memory's plan call and before any
  // grid-sized allocation), from the job's thread. Whatever it throws stops the job (a daemon
  // charging a principal's hourly allowance).
  std::function<void(int64_t cells)> planned;
};

// The rasters of OutputRequest::in_memory, over the job's window (JobSpec::window, else the
// grid); a raster not asked for is empty. Values as the files hold them: owner codes 1..K in the
// order of SeedSet::owner_labels() (0 = none), distances in the job's distance units
// (kNoDistance = none), 1-based input positions of the nearest feature (0 = none).
struct MemoryRasters {
  Raster<int32_t> ownership;
  Raster<float> distance;
  Raster<int32_t> nearest_feature;
  Raster<int32_t> via;  // as OutputRequest::via codes them
};

struct JobResult {
  nlohmann::json report;           // what --report writes (also returned to HTTP clients)
  std::vector<std::string> files;  // outputs written, in the order of OutputRequest
  MemoryRasters rasters;           // OutputRequest::in_memory
  GridSpec grid;                   // the job's grid (its CRS as WKT)
};

// Runs the whole job, as a pipeline of stages: prepare_job (read the seeds, plan), compute (the
// whole field, or strips streamed to the writers), validate, write the rasters, the deliverables,
// the report; each stage reports progress, honours cancellation and records its time. On any
// failure no output file of this job is left behind, and the error is an rv::Error (kinds as in
// rv/field/error.hpp).
JobResult run_job(const JobSpec& spec, const JobLimits& limits = {}, const JobHooks& hooks = {});

// A job read and planned: everything decided before anything grid-sized is allocated. The first
// stage of run_job, and all of `rvoronoi validate`'s set-up.
struct PreparedJob {
  LoadedSeeds loaded;
  GridSpec grid;
  MetricSpec metric;                    // resolved (auto made planar or geodesic)
  double to_output = 1.0;               // metric units -> the requested distance units
  std::string unit;                     // name of the output unit ("m", "nmi", "crs-units")
  ComputeOptions compute;               // method, metric, threads, max distance (metric units), geolocator
  std::vector<double> limit_distances;  // the limit lines' distances in metric units
  double line_tolerance = 1e-3;         // OutputRequest::line_tolerance in metric units
  // OutputRequest::relevant_area's polygons in the grid's CRS (as a seed set of polygons, for the
  // interior rule), and relevant_coasts' lines in the seeds' CRS; empty without them.
  std::optional<LoadedSeeds> relevant_area;
  std::optional<LoadedSeeds> relevant_coasts;
  JobPlan plan;
  double read_seconds = 0.0;
  PartialEffect
      partial;  // the seeds' partial effect (rv/lines/partial_effect.hpp); partial.any(): computed by its rule
  bool located() const { return compute.geolocator != nullptr; }  // geodesic on a projected grid
  // The distance by sea (JobSpec::barriers); null without barriers. The seeds above are already
  // moved onto the coast.
  struct Sea {
    LoadedBarriers loaded;        // in the grid's CRS
    double snap_tolerance = 0.0;  // CRS units
    int64_t snapped = 0;          // seed positions moved onto the coast
    double largest_snap = 0.0;    // CRS units
    int64_t on_land_borders = 0;  // seed vertices left on a border between overlapping barriers
    // The bend nodes settled once for every strip and window (prepare_sea).
    std::shared_ptr<const PreparedSea> prepared;
  };
  std::shared_ptr<Sea> sea;
};

// run_job on a job prepare_job already read and planned, from a spec that differs from `spec` at
// most in its window (JobSpec::window): the plan is made and checked again for this one. Front
// ends that compute one grid in pieces (the Python module's chunks) read and prepare the seeds
// once, set PreparedJob::compute.prepared once, and run each piece from here, concurrently if
// they like: `job` is only read.
JobResult run_prepared(const JobSpec& spec, const PreparedJob& job, const JobLimits& limits = {},
                       const JobHooks& hooks = {});

// Reads the seeds with the job's limits (and the memory limit for reading), then plans the grid,
// the metric and units, the limit distances and the memory, and checks every limit (cells,
// memory, validation size). Progress stage "read". Throws rv::Error as run_job does.
PreparedJob prepare_job(const JobSpec& spec, const JobLimits& limits = {}, const JobHooks& hooks = {});

// How distances are measured and reported: the metric the request and CRS resolve to
// (--metric auto|planar|geodesic, see rv/field/metric.hpp) and the factor from metric units (CRS units
// for planar, metres for geodesic) to the requested output units (--distance-units m|km|nmi).
// Geodesic on a projected CRS measures metres on that CRS's ellipsoid (cells located by
// geolocate_grid below). Throws rv::Error(invalid_argument) for geodesic without any CRS (no
// ellipsoid to measure on) and the resolve_metric refusals.
struct MetricPlan {
  MetricSpec metric;
  double to_output = 1.0;
  std::string unit;  // name written into the distance raster's metadata and the report
};
MetricPlan plan_metric(MetricRequest request, std::optional<DistanceUnit> units, const CrsInfo& crs);

// The grid a job would compute on, without computing it (for limits and dry runs). Its CRS is
// seeds.crs; a default extent comes from the seeds' box in that CRS (grid_bounds when the seeds
// were read in its geographic base).
GridSpec plan_grid(const GridRequest& request, const LoadedSeeds& seeds);

// Seed reading as a metric request needs it: geodesic reads the seeds in the geographic base of
// the grid CRS (SeedReadOptions::geographic_seeds), which matters only when that CRS is
// projected.
SeedReadOptions seed_options_for_metric(SeedReadOptions read, MetricRequest metric_request);

// Geodesic metric on a projected grid: sets options.geolocator (an OsrGeolocator from the grid
// CRS to its geographic base) and options.grid_polygons from seeds read with
// seed_options_for_metric. Does nothing for the planar metric or a geographic grid. Throws
// rv::Error(internal) when the seeds were not read in the geographic base, and OsrGeolocator's
// errors.
void geolocate_grid(ComputeOptions& options, const LoadedSeeds& loaded);

// What seed files hold (layers, fields and their values, CRS, box; with_features, every feature
// in the target CRS), read under the job limits' features, vertices, input bytes and memory:
// describe_seed_files() in rv/gdal/seed_reader.hpp. For a person choosing the owner field and
// the grid before a job (the map page). Throws its rv::Error.
SeedInventory describe_seeds(const SeedReadOptions& seeds, const JobLimits& limits = {}, bool with_features = false);

// Physical memory in bytes (0 if unknown).
int64_t physical_memory_bytes();

}  // namespace rv
