// The size of a seed input as it really is, found before any driver builds a geometry from it.
//
// OGR builds a whole geometry per feature, and an archive's headers may lie about what it holds:
// a zipped Shapefile of a few hundred kilobytes can inflate to hundreds of megabytes holding one
// MultiPoint of twenty million points. So before a zip archive (or a Shapefile) is opened:
//  - every member of a zip archive is inflated once, in chunks, through the same /vsizip/ reader
//    GDAL uses, and the bytes that come out are counted: over the byte limit, reading stops;
//  - the record headers of every Shapefile (.shp, in an archive or not) are read as the bytes
//    stream past: the number of records and the vertex count each record declares (numPoints)
//    are added up, and reading stops as soon as a limit is passed.
// Nothing is kept in memory but one chunk.
//
// Untrusted SQLite files (GeoPackage uploads) are checked too: SQLite computes views and
// generated columns when a row is read, so a file of a few kilobytes can make GDAL run a
// recursive query without end, or build gigabyte values, inside one call that no time limit
// interrupts. An untrusted file with a view or a generated column is refused before GDAL opens
// it (uploads hold plain tables; GDAL lists views as layers).
// Internal to rv_vector.
#pragma once

#include <cstdint>
#include <string>

namespace rv::detail {

struct InputLimits {
  int64_t max_bytes = 0;          // > 0: inflated bytes of an archive's members, all archives together
  int64_t max_features = 0;       // > 0: records declared by Shapefiles, together with earlier inputs
  int64_t max_vertices = 0;       // > 0: vertices declared by Shapefiles, together with earlier inputs
  int64_t max_reading_bytes = 0;  // > 0: reading_bytes() of the declared counts (seed_reader.hpp)
  bool untrusted = false;         // the SQLite schema check above (confined reading)
};

// Running totals over the inputs of one load_seeds() call.
struct InputTally {
  int64_t inflated_bytes = 0;     // bytes inflated from archives
  int64_t declared_features = 0;  // Shapefile records
  int64_t declared_vertices = 0;  // Shapefile vertices (numPoints of each record; 1 per point record)
  int64_t declared_points = 0;    // of those, the vertices of point and multipoint records
};

// Scans the input GDAL will open as `name` (after open_name()): a "/vsizip/..." name is an
// archive whose members are all inflated and counted; a name ending in ".shp" is scanned as a
// Shapefile; anything else is left alone. `label` names the input in messages.
// Throws rv::Error: too_large (a limit passed; the message names the limit and what exceeded
// it), invalid_input (more than kMaxArchiveMembers members; untrusted: an SQLite file with a
// view or a generated column).
void scan_input(const std::string& name, const std::string& label, const InputLimits& limits, InputTally& tally);

// An archive with more members than this is refused: seed uploads hold a few files.
inline constexpr int kMaxArchiveMembers = 10000;

}  // namespace rv::detail
