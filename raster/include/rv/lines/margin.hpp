// The margin raster: per owned cell, how much farther the nearest other owner is than its own.
// Refuses adjusted seeds, and (for now, rv::Error(unsupported)) projected geodesic fields but by
// sea.
#pragma once

#include <cstdint>
#include <functional>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/field/raster.hpp"
#include "rv/field/seeds.hpp"

namespace rv {

// For every cell owned by owner O: the distance to the nearest site of another owner, minus the
// distance to its own nearest site (>= 0, metric units, Float32). kNoDistance (-1) where the
// cell has no owner or the seed set has a single owner. A cell inside polygons of two owners
// has margin 0. Planar fields use the exact engine's tile culling with an owner filter
// (compute_other_owner, margins from double distances); other metrics run the exact engine once
// per owner, on the window of that owner's cells, over the other owners' seeds (margins from the
// Float32 distances: a few millimetres of rounding at 100 km). By sea (a metric that is not
// straight, rv/sea/sea_metric.hpp) the same per owner with `other_field`, the caller's engine of
// that metric (compute_sea with the barriers): other_field(owner, others, window) is the field of
// seed set `others` (every owner's seeds but `owner`'s, the same codes) over `window` (a window
// of the field's grid) with no maximum distance. Without it, each cell asks the index for the
// other owners' distance by sea (OwnerIndex::nearest_not_of): the same values, cell by cell.
// Projected geodesic grids included by sea.
using OtherOwnersField = std::function<NearestField(int32_t owner, const SeedSet& others, const Window& window)>;
Raster<float> margin_raster(const NearestField& field, const OwnerIndex& index, int threads = 0,
                            const OtherOwnersField& other_field = nullptr);

// The exact engine's culling, restricted per cell to sites whose owner differs from the owner
// of the cell's site in `own` (planar metric, whole-grid or windowed field as computed by
// compute()). Writes the nearest such site and its distance; kNoSite / kNoDistance where the
// cell has no owner or no other owner exists. Cells inside another owner's polygon are not
// special-cased here (see margin_raster). Result equals brute force over the filtered sites.
NearestField compute_other_owner(const SeedSet& seeds, const NearestField& own, int threads = 0);

}  // namespace rv
