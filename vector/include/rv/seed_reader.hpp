// Reading seed layers through GDAL/OGR into the core's SeedSet (GDAL types stay behind this
// header). Thread safety: load_seeds() may run concurrently with itself (GDAL datasets are
// opened per call); call rv::gdal_init() once before the first use.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "rv/seeds.hpp"

namespace rv {

// Registers GDAL's drivers and sets process-wide GDAL options. Idempotent, thread-safe.
void gdal_init();

enum class ConflictPolicy {
  error,       // geometry of two owners that overlaps or crosses is an error naming both features
  lower_code,  // the lower owner code wins inside the overlap; the cells it decided are reported
};

struct SeedReadOptions {
  std::vector<std::string> paths;        // GDAL-openable names (files, /vsizip/..., /vsimem/...)
  std::vector<std::string> layers;       // layer names to read; empty = every layer
  std::optional<std::string> owner_field;
  std::string target_crs;                // any definition OSR understands; empty = first layer's CRS
  ConflictPolicy on_conflict = ConflictPolicy::error;
  std::vector<std::string> allowed_drivers;  // empty = any vector driver
};

struct CrsInfo {
  std::string wkt;            // the grid/seed CRS as WKT2 (empty: unknown, no CRS anywhere)
  bool geographic = false;    // longitude/latitude
  double semi_major = 6378137.0;       // metres, of the CRS's ellipsoid
  double flattening = 1.0 / 298.257223563;
  double linear_unit = 1.0;   // metres per CRS unit (projected); 1 for unknown
  std::string name;           // human-readable name, e.g. "WGS 84 / UTM zone 33N"
};

struct SeedReadReport {
  int64_t features_read = 0;
  int64_t features_skipped_empty = 0;
  int64_t vertices_removed = 0;        // duplicate vertices / zero-length segments dropped
  int64_t polygons_repaired = 0;
  std::vector<std::string> warnings;   // one line each
};

struct LoadedSeeds {
  SeedSet seeds;
  CrsInfo crs;
  SeedReadReport report;
};

// Reads, reprojects into the target CRS (traditional GIS axis order), assigns owners (codes in
// order of first appearance; without an owner field each feature is its own owner labelled by
// its 1-based position), normalises and checks the seeds.
// Throws rv::Error: not_found (file, layer, field), invalid_input (not a vector dataset, NaN,
// latitude beyond ±90, missing owner value, unrepairable polygon, no features at all),
// conflict (two owners overlap, with policy error).
LoadedSeeds load_seeds(const SeedReadOptions& options);

// Describes a CRS given as any definition OSR understands (EPSG:32633, WKT, PROJ string).
// Throws rv::Error(invalid_argument) if it cannot be parsed.
CrsInfo describe_crs(const std::string& definition);

}  // namespace rv
