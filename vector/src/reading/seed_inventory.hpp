// describe_seed_files()' second half (rv/gdal/seed_reader.hpp): given the layers the seed reader
// opened and chose, and the target CRS it chose, counts, summarises and (optionally) exports their
// features. The reader keeps what it owns (datasets, limits, confinement); it lends them here
// through the hooks. Internal to rv_vector.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <ogrsf_frmts.h>

#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace rv::detail {

// Curves become line strings with this angular step (degrees), in seed runs and inventories
// alike (why 1 degree: seed_reader.cpp).
inline constexpr double kArcStepDegrees = 1.0;

struct InventoryLayer {
  OGRLayer* layer = nullptr;                 // owned by the reader's dataset
  std::string label;                         // "<path>:<layer>", escaped
  std::string name;                          // the layer's name, escaped
  const OGRSpatialReference* srs = nullptr;  // null: the layer has no CRS
};

struct InventoryHooks {
  // Throws when the confined reading was refused a network access (the reader's rule).
  std::function<void(const std::string& where)> check_network;
  // The reader's feature limit: a layer's declared count before it is read, then each feature
  // (throw too_large).
  std::function<void(OGRLayer& layer, const std::string& label)> check_declared_features;
  std::function<void(const std::string& label)> count_feature;
  // Counts a feature's vertices against the reader's limits (throws too_large).
  std::function<void(const OGRGeometry& geometry, const std::string& source)> count_vertices;
  // Reading errors are invalid_input for uploads, io for local files.
  ErrorKind read_error_kind = ErrorKind::io;
};

// Fills `out.layers`, `out.bounds` and (with_features) `out.features`; `target` null means no
// reprojection (no CRS anywhere). Throws rv::Error: too_large (the hooks' limits), invalid_input
// (a geometry that cannot be reprojected), the read error kind.
void take_inventory(const std::vector<InventoryLayer>& layers, const OGRSpatialReference* target, bool with_features,
                    const InventoryHooks& hooks, SeedInventory& out);

// Whether a geometry counts as empty (a seed run skips it; an inventory counts it as empty).
// OGR flags a point whose coordinate is NaN as empty (WKB writes POINT EMPTY as (NaN, NaN)), so a
// data error such as [NaN, 1.0] would pass for an empty geometry. A point counts as empty here
// only when OGR says so and its coordinates are not half NaN; a partly-NaN point is kept so that
// the coordinate check reports it.
bool truly_empty(const OGRGeometry& g);

}  // namespace rv::detail
