// Per-cell products derived from a nearest-site field. Pure; `threads` only splits the work
// (0 = all cores) and never changes the values.
#pragma once

#include "rv/engine.hpp"

namespace rv {

// Owner code (1..K) of each cell's nearest site; 0 where the cell has no owner.
Raster<int32_t> owner_raster(const SeedSet& seeds, const NearestField& field, int threads = 0);

// 1-based index of each cell's nearest seed feature; 0 where the cell has no owner.
Raster<int32_t> feature_raster(const SeedSet& seeds, const NearestField& field, int threads = 0);

// The distance raster multiplied by `factor` (unit conversion); kNoDistance stays kNoDistance.
Raster<float> scaled_distance(const NearestField& field, double factor, int threads = 0);

}  // namespace rv
