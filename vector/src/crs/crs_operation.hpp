// Internal: the coordinate operation a layer is reprojected with, chosen and stated (PROJ's
// operations between its CRS and the target CRS over the layer's extent), so that the report can
// say what was done to the data and with what accuracy, and a ballpark operation (a datum shift
// ignored or guessed: errors of ~100 m) or an inaccurate one is refused rather than used silently.
// Thread safety: each call uses a PROJ context of its own.
#pragma once

#include <string>
#include <vector>

#include <ogr_spatialref.h>

namespace rv::detail {

struct ChosenOperation {
  std::string name;         // PROJ's (EPSG's) name, e.g. "ED50 to WGS 84 (18)"
  std::string definition;   // as a PROJ pipeline, which the transformation is then made from
  double accuracy = -1.0;   // metres; 0 for a conversion (no datum change), -1 unknown
  bool conversion = false;  // no datum change: exact
  bool ballpark = false;    // contains a ballpark transformation
  // Grids of the operations more accurate than this one that are not installed (PROJ's short
  // names, e.g. "us_noaa_conus.tif"): installing them would give the better one.
  std::vector<std::string> missing_grids;
};

// The most relevant operation PROJ can carry out from `from` to `to` for data within the
// longitude/latitude box (degrees, west <= east): among those whose area of use holds the box,
// else those that meet it, the first PROJ ranks (by accuracy and area) that needs nothing
// missing. Throws rv::Error(invalid_input) when there is none.
ChosenOperation choose_operation(const OGRSpatialReference& from, const OGRSpatialReference& to, double west,
                                 double south, double east, double north);

}  // namespace rv::detail
