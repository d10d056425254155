// Fuzz target: the seed loader on uploaded GeoJSON, as the daemon runs it (confined, GeoJSON
// driver only, with limits), followed by the engine on a small grid over the loaded seeds.
//
// Input: the bytes of a GeoJSON file, written to /vsimem/ (the upload path). The first byte
// also picks the conflict policy and whether polygons' owner field is used, so both paths of
// the conflict check get exercised.
// Findings: a crash, a sanitizer report, an exception other than rv::Error, or an rv::Error of
// a kind load_seeds does not document for this situation.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include <cpl_vsi.h>

#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "rv/field/grid.hpp"
#include "rv/field/text.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace {

void require(bool ok) {
  if (!ok) std::abort();
}

const char* kPath = "/vsimem/fuzz/seeds.geojson";

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  rv::gdal_init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return 0;
  // VSIFileFromMemBuffer without taking ownership: GDAL reads the fuzzer's buffer in place.
  VSILFILE* f = VSIFileFromMemBuffer(kPath, const_cast<GByte*>(data), static_cast<vsi_l_offset>(size), FALSE);
  if (f == nullptr) return 0;
  VSIFCloseL(f);

  rv::SeedReadOptions o;
  o.paths = {kPath};
  o.allowed_drivers = {"GeoJSON"};
  o.confined = true;
  o.max_features = 2000;
  o.max_vertices = 20000;
  const uint8_t mode = size > 0 ? data[0] : 0;
  o.on_conflict = mode & 1 ? rv::ConflictPolicy::lower_code : rv::ConflictPolicy::error;
  if (mode & 2) o.owner_field = "owner";
  try {
    const rv::LoadedSeeds loaded = rv::load_seeds(o);
    require(!loaded.seeds.features().empty());
    // The engine on at most 24 x 24 cells over the seeds' box.
    const rv::SeedSet::Box b = loaded.seeds.bounds();
    const double span = std::max(b.xmax - b.xmin, b.ymax - b.ymin);
    const double res = span > 0.0 && std::isfinite(span) ? span / 20.0 : 1.0;
    if (res > 0.0 && std::isfinite(res)) {
      try {
        const rv::GridSpec g = rv::make_aligned_grid(b.xmin - res, b.ymin - res, b.xmax + res, b.ymax + res, res, "");
        if (g.cell_count() <= 24 * 24) {
          rv::ComputeOptions co;
          co.threads = 1;
          co.method = rv::Method::exact;
          const rv::NearestField exact = rv::compute(loaded.seeds, g, co);
          require(exact.site.cells().size() == static_cast<size_t>(g.cell_count()));
        }
      } catch (const rv::Error& e) {
        // Seeds so far out that the box overflows, or cells too small for the coordinates.
        require(e.kind() == rv::ErrorKind::invalid_argument || e.kind() == rv::ErrorKind::too_large);
      }
    }
  } catch (const rv::Error& e) {
    // An owner field the data lacks is a bad argument; never not_found (the file is ours).
    const rv::ErrorKind k = e.kind();
    require(k == rv::ErrorKind::invalid_input || k == rv::ErrorKind::conflict || k == rv::ErrorKind::too_large ||
            k == rv::ErrorKind::invalid_argument);
    require(rv::is_valid_utf8(e.what()));
  }
  VSIUnlink(kPath);
  return 0;
}
