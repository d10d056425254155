// The description of seed files (rv::describe_seeds, rv/job.hpp) as JSON, for every front end
// that shows it: the daemon's process describe-seeds and the Python module's rvoronoi.describe.
//   crs {name, wkt, geographic, metresPerUnit (0 on geographic CRSs), code ("EPSG:25833" or null)},
//   bbox [xmin, ymin, xmax, ymax] in that CRS or null, layers [{source, name, features, empty,
//   geometryTypes, fields [{name, type, nonNull, distinct, distinctExact, values}]}],
//   commonFields (the fields every layer has: an owner field must be one), warnings, and with
//   with_features "features": a GeoJSON FeatureCollection, each feature's id its 1-based position
//   in the input, its properties the layer's fields (numeric fields as numbers), "layer" its
//   layer's index.
// Thread safety: a pure function.
#pragma once

#include <nlohmann/json.hpp>

#include "rv/gdal/seed_reader.hpp"

namespace rv {

nlohmann::json seed_description(const SeedInventory& inventory, bool with_features);

}  // namespace rv
