// Per-cell products derived from a nearest-site field. Pure; `threads` only splits the work
// (0 = all cores) and never changes the values.
#pragma once

#include <span>

#include "rv/engine.hpp"

namespace rv {

// Owner code (1..K) of each cell's nearest site; 0 where the cell has no owner.
Raster<int32_t> owner_raster(const SeedSet& seeds, const NearestField& field, int threads = 0);

// Number of each cell's nearest seed feature; 0 where the cell has no owner. The number is
// `numbering[feature index]` when given (e.g. the feature's 1-based position in the input, when
// the reader stored features in another order), else the 1-based feature index.
Raster<int32_t> feature_raster(const SeedSet& seeds, const NearestField& field, int threads = 0,
                               std::span<const int64_t> numbering = {});

// The distance raster multiplied by `factor` (unit conversion); kNoDistance stays kNoDistance.
Raster<float> scaled_distance(const NearestField& field, double factor, int threads = 0);

}  // namespace rv
