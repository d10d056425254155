// Per-cell products derived from a nearest-site field. Pure; `threads` only splits the work
// (0 = all cores) and never changes the values.
//
// Each product is a per-cell function of the field's cell alone, so it can be made for any run
// of cells (a strip of rows on the job façade's streaming path) with the same functions the
// whole-raster versions use: strips and whole rasters agree cell for cell.
#pragma once

#include <span>
#include <vector>

#include "rv/engine/engine.hpp"

namespace rv {

// A table from site index to an Int32 code (owner code, feature number), built once per seed
// set. Immutable after construction: apply() may run concurrently.
class SiteCodes {
 public:
  // Owner code (1..K) of each site.
  static SiteCodes owners(const SeedSet& seeds);
  // Number of each site's seed feature: `numbering[feature index]` when given (e.g. the
  // feature's 1-based position in the input, when the reader stored features in another
  // order), else the 1-based feature index.
  static SiteCodes features(const SeedSet& seeds, std::span<const int64_t> numbering = {});

  // out[i] = code of site[i] for i in [0, n); 0 where site[i] == kNoSite. site[i] must be
  // kNoSite or a site index of the seed set. `out` may be `site` (in place), but may not
  // otherwise overlap it.
  void apply(const int32_t* site, int32_t* out, int64_t n) const;
  // The code of one site (kNoSite: 0).
  int32_t code(int32_t site) const { return site == kNoSite ? 0 : code_[static_cast<size_t>(site)]; }

 private:
  std::vector<int32_t> code_;
};

// out[i] = in[i] * factor rounded to float, kNoDistance stays kNoDistance; in place allowed.
void scale_distances(const float* in, float* out, int64_t n, double factor);

// Owner code (1..K) of each cell's nearest site; 0 where the cell has no owner.
Raster<int32_t> owner_raster(const SeedSet& seeds, const NearestField& field, int threads = 0);
// The same, written over a field's site raster (NearestField::site, taken): no second buffer.
Raster<int32_t> owner_raster(const SeedSet& seeds, Raster<int32_t>&& sites, int threads = 0);

// Number of each cell's nearest seed feature (SiteCodes::features); 0 where the cell has no owner.
Raster<int32_t> feature_raster(const SeedSet& seeds, const NearestField& field, int threads = 0,
                               std::span<const int64_t> numbering = {});

// The distance raster multiplied by `factor` (unit conversion); kNoDistance stays kNoDistance.
Raster<float> scaled_distance(const NearestField& field, double factor, int threads = 0);

}  // namespace rv
