// Internal to run_job (rv/job.hpp): the streaming path. The grid is computed in strips of whole
// rows on the calling thread and encoded into GeoTIFFs by one writer thread per file, two strips
// in flight at most (a bounded hand-off), so that encoding strip k overlaps computing strip k+1
// and the files are encoded side by side.
// Not part of the public API.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/gdal/raster_io.hpp"

namespace rv::detail {

// One GeoTIFF of a streamed job.
// site: the field's site index + 1 (0 = none); metric_distance: the distance in metric units,
// before the job's unit conversion; codes: the codes the strip source left in Strip::codes (an
// edit's changes, the vias of the distance by sea).
struct StreamTarget {
  enum class Product { ownership, distance, nearest_feature, site, metric_distance, codes };
  Product product = Product::ownership;
  std::string path;
  GeoTiffOptions options;
  std::string name;  // key in the report's write timings
  // When set, receives the file's tile checksums once it is in place
  // (GeoTiffStripWriter::tile_checksums).
  std::vector<uint64_t>* checksums = nullptr;
  // An edit's earlier file of the same product, whose tiles the strips mark unchanged are copied
  // as they are (GeoTiffStripWriter::take_tiles_from, checked against `earlier_checksums`; named
  // `earlier_display` in errors). Empty, or a file whose layout differs: every tile is encoded.
  // `earlier_remap`, when not empty (code rasters): the earlier file's codes -> this file's
  // (GeoTiffStripWriter::take_tiles_from); its copied tiles are then decoded and encoded again.
  std::string earlier, earlier_display;
  std::vector<uint64_t> earlier_checksums;
  std::vector<int32_t> earlier_remap;
  // A site raster's code of each site (empty: index + 1); 0 stays none.
  std::vector<int32_t> site_codes;
  // When set, called on the writer's thread with each strip's sites and metric distances (rows
  // [row0, row0 + rows), whole rows), before its values are written. `fresh`: null when every
  // tile is new, else the source's flags (one per tile of the strip's bands, row-major): the
  // tiles flagged 0 are the earlier files' (their cells need not be valid).
  std::function<void(const int32_t* site, const float* distance, int64_t row0, int64_t rows, const uint8_t* fresh)>
      observe;
};

struct StreamJob {
  const SeedSet* seeds = nullptr;
  GridSpec grid;
  ComputeOptions compute;                      // window and progress are set per strip
  int64_t strip_rows = 0;                      // > 0
  std::vector<StreamTarget> targets;           // written in this order; none: on_strip alone
  double distance_factor = 1.0;                // metric units -> output units
  std::span<const int64_t> feature_numbering;  // LoadedSeeds::input_position
  // Job progress: ("compute", fraction of the grid computed), then ("write", fraction written).
  // Called on the calling thread or the engine's workers, never concurrently.
  std::function<void(const char* stage, double fraction)> progress;
  // Called with each target's path before anything may appear under it (the job's guard).
  std::function<void(const std::string& path)> will_write;
  // Called with each strip as computed (distances in metric units), on the computing thread,
  // before the writers see it; may be empty. What it throws stops the job as a failed strip would.
  std::function<void(const NearestField& strip)> on_strip;
  // Whether on_strip reads every cell of a source's strips (else only those the source reads).
  bool on_strip_every_cell = true;
  // When set, produces each strip's field instead of the engine (an edit of a finished run, the
  // distance by sea): fills `field` over `window` (distances in metric units) and, when a target
  // is a codes raster, `codes` with one code per cell. Called on the computing thread, strips in
  // order.
  // Strips then start on a 256-row band of tiles and hold whole bands (but the last). `fresh`:
  // one flag per 256 x 256 tile of the strip (tiles across the grid, row-major over its bands),
  // 1 where the tile's cells may differ from the earlier files' (encoded again), 0 where they do
  // not (copied from each target's earlier file); or left empty: every tile encoded.
  // `all_cells`: some target encodes every tile or on_strip reads every cell, so every cell of
  // `field` must be valid; otherwise only those of the tiles flagged 1.
  std::function<void(const Window& window, NearestField& field, std::vector<int32_t>& codes,
                     std::vector<uint8_t>& fresh, bool all_cells)>
      source;
};

// What the streamed run measured; every time in seconds.
struct StreamStats {
  double compute = 0.0;                 // the engine's own time, summed over strips
  double convert = 0.0;                 // distance unit scaling, on the computing thread
  double deliverables = 0.0;            // on_strip, on the computing thread
  std::map<std::string, double> write;  // per target: site ids -> codes (code rasters), encoding
                                        // and finishing, on its writer thread
  // Per target with an earlier file: the tiles copied from it, or -1 where none could be (its
  // layout differs, or it is missing), with the reason in `not_copied`; in `tiles_recoded`
  // instead of `tiles_copied` where they were decoded and coded again (StreamTarget::earlier_remap).
  std::map<std::string, int64_t> tiles_copied, tiles_recoded;
  std::map<std::string, std::string> not_copied;
  bool all_cells = true;        // every cell of every strip was produced
  double compute_waited = 0.0;  // the computing thread waiting for a free strip buffer
  double write_waited = 0.0;    // the writer threads waiting for a computed strip (the longest)
  double wall = 0.0;            // from the first strip's start to the last file in place
  int64_t strips = 0;
  int64_t contested_cells = 0;
  int threads = 1;  // the engine's
};

// Computes and writes. Throws what compute_into() and GeoTiffStripWriter throw; on any failure
// (cancellation included) the writer threads are stopped and no target's file is left, apart from
// those already renamed into place, which will_write() has announced to the caller's guard.
StreamStats run_streamed(const StreamJob& job);

}  // namespace rv::detail
