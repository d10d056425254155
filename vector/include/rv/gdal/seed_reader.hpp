// Reading seed layers through GDAL/OGR into the core's SeedSet (GDAL types stay behind this
// header). Thread safety: load_seeds() may run concurrently with itself (GDAL datasets, CRS
// objects and GEOS contexts are created per call); call rv::gdal_init() once before the first
// use (load_seeds and describe_crs also call it; it is idempotent).
//
// Formats: any vector format GDAL/OGR reads (GeoJSON, GeoPackage, Shapefile, FlatGeobuf, KML,
// ...). A plain path ending in ".zip" is opened through /vsizip/ (a zipped Shapefile, or several).
// Geometry: Point, LineString, Polygon (holes), their Multi* forms and GeometryCollections of
// them; curves are linearised (1 degree steps: chords within 3.8e-5 x radius of the arc), Z and
// M dropped. A multi-part feature is one feature with several parts: points -> point sites,
// lines -> segment sites per part, polygons -> one SeedSet polygon per part (its ring edges plus
// an area site).
//
// Input order (owner codes by first appearance, position labels): files in the order given; in
// each file its layers in dataset order, or, when layers are named, the named layers in the order
// the names are given; features in the layer's reading order.
// Stored order: SeedSet features are grouped by owner code, in input order within an owner
// (Feature::source says where each came from). The engines break distance ties and resolve
// overlapping polygon interiors towards the lower feature index; with this order that is always
// the lower owner code, even where owners interleave in the input.
//
// Units: coordinates of the result are in the target CRS's units (metres for UTM, degrees with
// x = longitude for geographic CRSs).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rv/edit/feature_parts.hpp"
#include "rv/field/seeds.hpp"
#include "rv/sea/barriers.hpp"

namespace rv {

// Registers GDAL's drivers; changes no process-wide GDAL option (every CRS this library
// creates sets its own axis order). Idempotent, thread-safe.
void gdal_init();

enum class ConflictPolicy {
  error,       // geometry of two owners that overlaps or crosses is an error naming both features
  lower_code,  // the lower owner code wins inside the overlap; the cells it decided are reported
};

struct SeedReadOptions {
  std::vector<std::string> paths;          // GDAL-openable names (files, /vsizip/..., /vsimem/...);
                                           // a plain "x.zip" is opened as "/vsizip/x.zip"
  std::vector<std::string> layers;         // layer names to read; empty = every layer. A name is
                                           // read from every file that has it and must exist in
                                           // at least one (else not_found).
  std::optional<std::string> owner_field;  // must exist in every layer read; null values are errors.
                                           // Values are compared as text (GDAL's string form).
  // The delimitation adjustments (rv/field/seeds.hpp, Feature): numeric attributes, each of which must
  // exist in every layer read. weight_field: the feature's weight (> 0, finite; a null value is
  // an error). reach_field: its reach, in the units the caller scales it from (SeedSet::
  // scale_reaches; > 0; null: no reach). effect_field: its partial effect (SeedSet::set_effect;
  // in [0, 1]; null: 1). Bad values are invalid_input naming the feature.
  std::optional<std::string> weight_field;
  std::optional<std::string> reach_field;
  std::optional<std::string> effect_field;
  std::string target_crs;  // any definition OSR understands; empty = first layer's CRS.
                           // Layers without a CRS are accepted only when no layer
                           // has one and target_crs is empty (with a warning).
  ConflictPolicy on_conflict = ConflictPolicy::error;
  // Overlaps of two owners' polygons that hold no disc of this diameter (metres; CRS units when
  // the data has no CRS) are land-border slivers, not conflicts: two countries' polygons that
  // share a border overlap by such slivers once reprojected. They are listed in
  // SeedReadReport::slivers and resolved as lower_code resolves overlaps. 0: every overlap is a
  // conflict.
  double border_tolerance = 0.01;
  // A layer reprojected to the target CRS goes through the coordinate operation PROJ ranks first
  // for its extent, stated in SeedReadReport::transformations. A ballpark one (the datum shift
  // ignored or guessed), one of unknown accuracy or one less accurate than transform_accuracy
  // metres is refused (rv::Error(invalid_input), naming the operation and the grids a better one
  // needs) unless allow_ballpark, which turns the refusal into a warning. Conversions (no datum
  // change) are exact.
  double transform_accuracy = 1.0;
  bool allow_ballpark = false;
  std::vector<std::string> allowed_drivers;  // empty = any vector driver (confined: kConfinedDrivers)
  bool confined = false;                     // untrusted data (daemon uploads): see "Confinement" below
  int64_t max_features = 0;                  // > 0: more features than this (empty ones included) is too_large
  int64_t max_vertices = 0;                  // > 0: more vertices than this (after linearising curves) is too_large
  int64_t max_input_bytes = 0;               // > 0: zip archives whose members inflate to more than this
                                             // (all together, counted while inflating) are too_large
  int64_t max_memory_bytes = 0;              // > 0: seeds whose reading would need more than this
                                             // (reading_bytes(), from declared counts and while reading) are
                                             // too_large
  // Called, when set, each time the reading's memory estimate (SeedReadReport::reading_bytes)
  // grows, with the new estimate in bytes, before the reader copies the feature that grew it;
  // on the reading thread. Whatever it throws stops the reading (a daemon's memory account
  // reserves the bytes here, or refuses them).
  std::function<void(int64_t)> on_reading_bytes;
  // For the geodesic metric on a projected grid: when the target CRS (the grid's: target_crs, or
  // the first layer's) is projected, the seeds are read into its geographic base CRS instead
  // (OSRCloneGeogCS: the same datum's longitude/latitude in degrees, x = longitude), which is
  // where the engine measures. LoadedSeeds::crs still describes the target (grid) CRS, and
  // LoadedSeeds::grid_polygons / grid_bounds give the seeds in it. No effect when the target is
  // geographic or there is no CRS at all (LoadedSeeds::geographic_base stays false).
  bool geographic_seeds = false;
};

// Confinement (SeedReadOptions::confined = true), for data a remote client uploaded. The CLI
// leaves it off: it opens whatever local files and URLs its user names.
//  - Paths: each must be an in-memory file, "/vsimem/..." or "/vsizip//vsimem/..." (a zip held in
//    memory), without ".." components; anything else is invalid_argument before GDAL sees it.
//  - Drivers: only kConfinedDrivers (the intersection with allowed_drivers when that is given).
//    They read self-contained files; VRT, SQLite (VirtualOGR tables), GML (xlink resolution),
//    WFS/OAPIF/ESRIJSON-over-HTTP and every other driver that dereferences paths or URLs named
//    in the data are thereby excluded. KML means GDAL's "KML" driver (it ignores NetworkLinks),
//    not "LIBKML".
//  - Network: for the whole call the calling thread refuses every HTTP fetch GDAL attempts, and
//    /vsicurl/-style access goes nowhere (details: ConfinedScope in vector/src/common/gdal_util.hpp).
//    GDAL 3.6's GeoJSON driver fetches the URL of a "crs" member of type "link" or "url"; such a
//    fetch, once refused, makes the input invalid_input (it would otherwise silently get a
//    default CRS).
//  - SQLite (GPKG): extension loading and the VirtualOGR module stay off for this thread.
//  - Errors reading the data are invalid_input (it is the data that is broken), not io.
// Limits (max_features, max_vertices, max_input_bytes, max_memory_bytes) apply with or without
// confinement, in this order, each before the work it bounds:
//  - before a driver opens a zip archive, its members are inflated once and counted (bytes), and
//    the record headers of every Shapefile in it (or of a plain .shp) are read for the features
//    and vertices they declare (vector/src/reading/input_scan.hpp): a bomb is refused having used one
//    chunk of memory;
//  - a layer that reports its feature count cheaply (GPKG, Shapefile, FlatGeobuf) is refused
//    before its first feature is read;
//  - each feature's vertices are counted on the geometry the driver returned, before it is
//    copied, linearised (a circular arc counts as the 361 vertices it may become) or split.
// The GeoJSON driver parses a whole file when it is opened, so the byte size of uploads must be
// bounded by the caller (the daemon's body limit). What a driver builds for one feature is not
// bounded by anything but the bytes it reads (uncompressed formats: the file's size).
inline constexpr const char* kConfinedDrivers[] = {"GeoJSON", "GPKG", "ESRI Shapefile", "FlatGeobuf", "KML"};

// The memory seed reading needs at its peak, for SeedReadOptions::max_memory_bytes and the job's
// memory estimate: the geometry the driver built, the reader's copies of it (checked parts, the
// conflict check's index) and the SeedSet. A point (alone or in a multipoint) is a part of its
// own, with its own copies: it costs more than a vertex of a line or polygon ring. The figures
// are the measured peaks rounded up (bench/README.md, "Seed reading memory").
inline constexpr int64_t kReadingBytesPerPoint = 700;
inline constexpr int64_t kReadingBytesPerVertex = 320;  // of lines and polygon rings
inline constexpr int64_t kReadingBytesPerFeature = 200;
constexpr int64_t reading_bytes(int64_t features, int64_t points, int64_t vertices) {
  return features * kReadingBytesPerFeature + points * kReadingBytesPerPoint + vertices * kReadingBytesPerVertex;
}

// Seed coordinates beyond this magnitude (in the CRS's units) are invalid_input: far beyond any
// planet, they would overflow squared distances (at 1.3e154) and the grid's cell arithmetic.
inline constexpr double kMaxSeedCoordinate = 1e12;

struct CrsInfo {
  std::string wkt;                // the grid/seed CRS as WKT2 (empty: unknown, no CRS anywhere)
  bool geographic = false;        // longitude/latitude
  double semi_major = 6378137.0;  // metres, of the CRS's ellipsoid
  double flattening = 1.0 / 298.257223563;
  double linear_unit = 1.0;  // metres per CRS unit (projected); 1 for unknown
  std::string name;          // human-readable name, e.g. "WGS 84 / UTM zone 33N"
};

// How one layer was taken to the target CRS.
struct TransformStatement {
  std::string layer;        // file:layer
  std::string from, to;     // CRS names
  std::string operation;    // the coordinate operation (PROJ's / EPSG's name)
  double accuracy = -1.0;   // metres; 0 for a conversion, -1 unknown
  bool conversion = false;  // no datum change
  bool ballpark = false;
  std::vector<std::string> missing_grids;  // what a more accurate operation would need
};

// An overlap of two owners' polygons narrower than SeedReadOptions::border_tolerance.
struct BorderSliver {
  int32_t feature_a = 0, feature_b = 0;  // SeedSet feature indices, feature_a < feature_b
  double x = 0.0, y = 0.0;               // a point inside it (the parts' CRS)
  double area = 0.0;                     // square metres (CRS units squared without a CRS)
  double mean_width = 0.0;               // metres: twice its area over its perimeter
};

struct SeedReadReport {
  int64_t features_read = 0;                        // features that became seeds
  int64_t features_skipped_empty = 0;               // null or empty geometry
  int64_t vertices_removed = 0;                     // duplicate vertices / zero-length segments dropped
  int64_t points_removed = 0;                       // a point repeated inside one feature (multipoint)
  int64_t polygons_repaired = 0;                    // invalid polygon parts repaired (MakeValid), unclosed
                                                    // rings closed, degenerate holes dropped
  int64_t vertices_read = 0;                        // vertices of the features as read (curves: the bound of
                                                    // what linearising makes of them), before any cleaning
  int64_t reading_bytes = 0;                        // reading_bytes() of what was read: the reading's peak
  int64_t conflicts = 0;                            // pairs of parts of two owners that overlap or cross
                                                    // (only non-zero with ConflictPolicy::lower_code)
  std::vector<std::string> warnings;                // one line each
  std::vector<TransformStatement> transformations;  // one per layer reprojected
  int64_t sliver_count = 0;                         // land-border slivers found (the first kMaxSlivers listed)
  std::vector<BorderSliver> slivers;
  static constexpr size_t kMaxSlivers = 1000;
};

struct LoadedSeeds {
  SeedSet seeds;  // in the target CRS, or in its geographic base when geographic_base is true
  CrsInfo crs;    // the target (grid) CRS
  // SeedReadOptions::geographic_seeds took effect: `seeds` are longitude/latitude degrees of
  // the target CRS's geographic base (described by seed_crs), and the two members below hold
  // what the grid needs in the target CRS.
  bool geographic_base = false;
  CrsInfo seed_crs;  // the CRS of `seeds`' coordinates (equal to crs unless geographic_base)
  // geographic_base only: seeds.polygons() with every vertex transformed into the target CRS
  // (same order, rings and area sites: ComputeOptions::grid_polygons), and the box of every
  // vertex of the seeds in the target CRS (what seeds.bounds() gives otherwise).
  std::shared_ptr<const std::vector<Polygon>> grid_polygons;
  std::optional<SeedSet::Box> grid_bounds;
  SeedReadReport report;
  // SeedSet feature index -> 1-based position of that feature in the input (the numbering of
  // position labels, counting skipped empty features). Features are stored grouped by owner, so
  // this differs from index + 1 when an owner field interleaves owners.
  std::vector<int64_t> input_position;
};

// Reads, reprojects into the target CRS (traditional GIS axis order), assigns owners (codes in
// order of first appearance; without an owner field each feature is its own owner labelled by
// its 1-based position in the input, counting every feature read including skipped empty ones),
// normalises and checks the seeds. Feature::source is "<path as given>:<layer>:fid <fid>".
// Text read from the data (owner values, layer and field names, GDAL's messages) is outside text:
// it is escaped where it is read (escape_utf8, rv/field/text.hpp), so owner labels, sources, warnings
// and messages are valid UTF-8, and owners whose raw values differ stay distinct.
//
// Normalisation (reported in SeedReadReport): consecutive duplicate vertices / zero-length
// segments and points repeated inside a feature are removed; unclosed rings are closed;
// invalid polygons (self-intersection, holes outside the shell, ...) are repaired with GEOS
// MakeValid when the result still has area (lower-dimensional leftovers such as collapsed
// spikes are dropped), with a warning naming the feature. Null/empty geometries are skipped
// with a warning. Same-owner geometry may cross or overlap freely. Geometry of two owners whose
// interiors meet (polygons overlapping with positive area, crossing or collinear-overlapping
// lines, a line or point inside another owner's polygon, coincident points) is a conflict;
// merely touching (shared edge, line ending on a boundary) is not.
//
// geographic_seeds: normalisation and the conflict check run on the longitude/latitude
// coordinates; the grid polygons are the normalised polygons transformed vertex by vertex (a
// vertex that cannot be placed in the target CRS is invalid_input).
//
// Throws rv::Error: not_found (a file; never when confined: an in-memory file that does not
// open is invalid_input), invalid_argument (a layer or owner field the data does not have),
// invalid_input (not a vector dataset, NaN/inf coordinate or one beyond kMaxSeedCoordinate,
// latitude beyond ±90 on a geographic CRS, null owner value, unrepairable
// polygon, a layer without CRS among layers with one, no features at all; confined: data that
// tries to reach the network, unreadable data), invalid_argument (unparsable target CRS, no
// paths; confined: a path outside /vsimem/, no allowed driver left), too_large (over
// max_features, max_vertices, max_input_bytes or max_memory_bytes: the message names the
// limit), conflict (two owners overlap, with policy error: the message
// names both features, their owners and a coordinate inside the intersection), io (reading a
// local file failed; never when confined).
LoadedSeeds load_seeds(const SeedReadOptions& options);

// What seed files hold, for a person choosing how to read them (the map page's field list and
// its picture of the seeds before anything is computed): their layers, fields, feature counts,
// geometry types and CRS, and optionally every feature in the target CRS.
struct SeedFieldSummary {
  static constexpr int64_t kMaxDistinct = 1000;  // distinct values counted exactly up to this
  static constexpr size_t kMaxValues = 50;       // values listed
  std::string name;                              // escaped (escape_utf8), as every text from the data
  std::string type;                 // "integer", "integer64", "real", "string", "date", "time", "datetime", "binary" or
                                    // "list" (GDAL's list types)
  int64_t non_null = 0;             // features with a value
  int64_t distinct = 0;             // distinct non-null values, in GDAL's string form
  bool distinct_exact = true;       // false: more than kMaxDistinct (distinct stops there)
  std::vector<std::string> values;  // the first kMaxValues distinct values in reading order, escaped
};

struct SeedLayerSummary {
  std::string source;  // "<path as given>:<layer>", escaped
  std::string name;    // the layer's name, escaped
  int64_t features = 0;
  int64_t empty = 0;                        // null or empty geometries (a seed run skips them)
  std::vector<std::string> geometry_types;  // OGR's names of the flattened types seen, sorted
  std::vector<SeedFieldSummary> fields;     // in the layer's order
};

// One feature as read, for drawing: not normalised, not checked against other owners.
struct SeedPreviewFeature {
  size_t layer = 0;                                // index into SeedInventory::layers
  int64_t position = 0;                            // 1-based in the input, as load_seeds counts
  std::string geometry;                            // GeoJSON geometry in the target CRS; "null" when empty
  std::vector<std::optional<std::string>> values;  // per field of its layer: GDAL's string form, escaped
};

struct SeedInventory {
  CrsInfo crs;           // the target CRS (options.target_crs, else the first layer's)
  std::string crs_code;  // "EPSG:25833" when the target CRS has an authority code, else ""
  std::vector<SeedLayerSummary> layers;
  std::optional<SeedSet::Box> bounds;        // of every non-empty geometry, in the target CRS
  std::vector<SeedPreviewFeature> features;  // with_features only
  std::vector<std::string> warnings;
};

// Opens the files as load_seeds() does, with the same options' paths, layers, target CRS,
// drivers, confinement and limits (features, vertices, input bytes, memory), and describes them
// without reading them as seeds: no owner field is needed (owner_field and the adjustment fields
// are ignored), and nothing is normalised or checked for conflicts, so data a seed run would
// refuse until the right options are chosen (overlapping land borders without an owner field)
// is described all the same. Layers are taken to the target CRS by PROJ's default operation
// (the operation checks of load_seeds are its own). Curves are linearised as load_seeds does.
// Throws rv::Error as load_seeds() does for opening, limits and reprojection; never conflict.
// Thread safety: as load_seeds().
SeedInventory describe_seed_files(const SeedReadOptions& options, bool with_features);

// Describes a CRS given as any definition OSR understands (EPSG:32633, WKT, PROJ string).
// Throws rv::Error(invalid_argument) if it cannot be parsed.
CrsInfo describe_crs(const std::string& definition);

}  // namespace rv

namespace rv {

// The checks load_seeds makes of a file's features, for features edited in memory (a session's
// edits, service/include/rv/session.hpp), where a refusal must leave the seeds as they were:
//  - every polygon part of `features` is valid as it stands (OGR/GEOS IsValid): an edit is
//    refused, not repaired (the reader repairs a file's polygons with MakeValid; an editor's
//    polygon is the analyst's to fix);
//  - no part of `features` meets a part of another owner beyond touching (ConflictPolicy::error's
//    rule, land-border slivers narrower than `border_tolerance` metres allowed; with
//    ConflictPolicy::lower_code nothing is refused, as the reader refuses nothing).
// `seeds`: the whole edited set, in `crs` (its WKT; empty: no CRS, the tolerance in CRS units).
// Returns the land-border slivers found between `features` and their neighbours (feature
// indices of `seeds`). Throws rv::Error(invalid_input) naming the feature for an invalid polygon,
// rv::Error(conflict) naming both features for a conflict. Thread-safe (GEOS contexts per call).
std::vector<BorderSliver> check_edited_features(const SeedSet& seeds, const std::vector<int32_t>& features,
                                                const std::string& crs_wkt, ConflictPolicy policy,
                                                double border_tolerance);
// The same checks with each feature's parts as the caller keeps them: `parts_of(f)` returns
// what rv::feature_parts(seeds)[f] would (a session holds its features' parts, and making them
// for every feature of a large set costs more than the checks).
using FeaturePartsOf = std::function<const std::vector<FeaturePart>&(int32_t feature)>;
std::vector<BorderSliver> check_edited_features(const SeedSet& seeds, const std::vector<int32_t>& features,
                                                const FeaturePartsOf& parts_of, const std::string& crs_wkt,
                                                ConflictPolicy policy, double border_tolerance);

}  // namespace rv

namespace rv {

// Barriers for the distance by sea (rv/sea/barriers.hpp), read as seeds are read: the same
// formats, confinement, limits, reprojection into options.target_crs and normalisation
// (invalid polygons repaired), with every feature a barrier of its own: owner_field and the
// adjustment fields are ignored, and barriers may overlap and cross freely (land polygons that
// share a border, a boom across a bay). Polygons become land; lines, barrier lines (rebuilt from
// their segments, one line per run of connected segments). A point feature is
// rv::Error(invalid_input) naming it: a point bars no path. Throws as load_seeds otherwise.
struct LoadedBarriers {
  Barriers barriers;
  CrsInfo crs;
  SeedReadReport report;
};
LoadedBarriers load_barriers(const SeedReadOptions& options);

}  // namespace rv
