// Comparing a computed nearest-site field with a reference (normally brute force).
//
// The error of a cell is the paper's formula (2): Δd = Dist(assigned site, cell) − Dist(true
// nearest site, cell), evaluated with exact (double) distances to the real geometry, not with
// the Float32 distances stored in the rasters, in the fields' metric (NearestField::metric; both
// fields must have the same). For the geodesic metric distances are metres and "one cell" means
// res degrees of latitude on a sphere of radius a (res * pi/180 * a); on a projected grid
// (NearestField::geolocator set, in both fields or neither, else rv::Error(invalid_argument))
// cells are located with the test field's geolocator and "one cell" is the geodesic distance
// between two neighbouring located centres in the middle of the window. Pure, thread-safe.
#pragma once

#include <cstdint>
#include <vector>

#include "rv/engine/engine.hpp"

namespace rv {

struct WrongCell {
  int64_t col, row;   // window-relative
  int32_t site;       // assigned by the method under test
  int32_t reference;  // assigned by the reference
  double error;       // Δd, metric units
};

struct ValidationStats {
  int64_t cells = 0;                // cells compared
  int64_t wrong_cells = 0;          // Δd above the tolerance (an owner that is not the nearest)
  int64_t wrong_owner_cells = 0;    // wrong cells whose owner code also differs
  int64_t tie_cells = 0;            // different site, |Δd| within the tolerance (a legitimate tie)
  int64_t nodata_mismatch = 0;      // one field has an owner there and the other has none
  double max_error = 0.0;           // largest Δd, metric units
  double max_error_cells = 0.0;     // largest Δd in cells (max_error / res)
  std::vector<WrongCell> examples;  // the first few wrong cells, in row-major order
};

// `tolerance_cells`: Δd up to this many cells counts as a tie (default: 1e-6 of a cell).
ValidationStats compare_fields(const SeedSet& seeds, const NearestField& test, const NearestField& reference,
                               double tolerance_cells = 1e-6, int max_examples = 20);

}  // namespace rv
