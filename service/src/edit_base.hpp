// Internal to run_job: what a run keeps for later edits of it (issue 32), and the edit of a
// finished run.
//
// Every streamed run that writes a report keeps, in a directory its report names ("edit_base"),
// what an edit needs of it, whatever outputs the user asked for:
//   manifest.json  the request's parameters an edit must repeat (grid, metric, method, distance
//                  units, max distance, compression), and a checksum of every file below: of
//                  seeds.bin whole, of the rasters per band of 256 rows of cell values;
//   seeds.bin      the seed set it computed from (rv/seed_archive.hpp), since users edit their
//                  files in place;
//                  Per tile of 256 x 256 cells, the field's largest distance and cost and
//                  whether it has unowned cells (rv::TileSummaries): an edit reads no cell of a
//                  tile it cannot change;
//   site.tif       the nearest site of every cell (index + 1, 0 = none), Int32 codes;
//   distance.tif   the distance to it in metric units, Float32, as the engine computed it; or,
//                  when the job writes its distance raster in metric units, that file (the
//                  manifest names it relative to the directory, e.g. "../distance.tif").
// An edit (`--base REPORT`) reads that directory strip by strip in place of computing: each strip
// of the base field is checked against its band checksums, planned and recomputed where the
// edit can change it (rv::Edit), and the edited strip goes on to the writers and deliverables
// like a computed one. The files are then those of a fresh run, cell for cell.
// Not part of the public API. Thread safety: one object per job, used from its computing thread.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/edit.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/job.hpp"

namespace rv::detail {

inline constexpr int64_t kBandRows = 256;

// Checksums of a raster's cell values per band of kBandRows rows, rows added in order (any number
// at a time). 64-bit, over the values' bytes; not cryptographic: it finds files changed by
// accident or by another program, not by an adversary who can also rewrite the manifest.
class BandHasher {
 public:
  explicit BandHasher(int64_t width = 0) : width_(width) {}
  template <class T>
  void add_rows(const T* rows, int64_t count) {
    add_bytes(reinterpret_cast<const unsigned char*>(rows), count, static_cast<int64_t>(sizeof(T)));
  }
  // Bands completed so far (a last partial band once finish() is called).
  const std::vector<uint64_t>& bands() const { return bands_; }
  void finish();

 private:
  void add_bytes(const unsigned char* rows, int64_t count, int64_t cell_bytes);
  int64_t width_ = 0;
  int64_t rows_in_band_ = 0;
  uint64_t h_ = 0;
  std::vector<uint64_t> bands_;
};

// The directory a report's run keeps for edits: the report's path with ".rvbase".
std::string edit_base_dir(const std::string& report);

// The base a run keeps, written beside its outputs (see above). Created before the first strip
// (an unwritable directory fails at once), its two rasters written as the streamed job's
// targets, then committed after them, before the report: the directory is built under a
// temporary name and renamed into place, so a failed job leaves none and the previous run's
// stays whole until the new one is complete.
class EditBaseWriter {
 public:
  EditBaseWriter(const JobSpec& spec, const PreparedJob& job);
  ~EditBaseWriter();
  EditBaseWriter(const EditBaseWriter&) = delete;
  EditBaseWriter& operator=(const EditBaseWriter&) = delete;
  // The temporary paths of the two rasters, their options, and hashers the writers fill.
  const std::string& temp_dir() const { return temp_; }
  const std::string& site_path() const { return site_path_; }
  const std::string& distance_path() const { return distance_path_; }
  // Whether the job's own distance raster (in metric units) serves as the kept distance: its
  // writer then feeds the hasher and the tile summaries, and nothing is written twice.
  bool shares_distance() const { return !shared_distance_.empty(); }
  GeoTiffOptions site_options() const;
  GeoTiffOptions distance_options() const;
  BandHasher site_hash, distance_hash;
  // Fed by the distance's writer (StreamTarget::observe): what the manifest records per tile.
  TileSummaries tiles;
  // Writes the manifest and renames the directory into place (the old one, if any, removed).
  // Returns the directory's path.
  std::string commit();

 private:
  std::string dir_, temp_, site_path_, distance_path_, shared_distance_;
  nlohmann::json manifest_;
  std::string seeds_hash_;
  int64_t sites_ = 0;
  bool committed_ = false;
};

// A finished run opened as the base of an edit. The constructor reads the report, its kept
// directory's manifest and seed set, and opens the two rasters (held open: the base may be
// replaced or deleted while the edit runs). Throws rv::Error: not_found (report, directory or
// file missing), invalid_input (a report without a kept base, a damaged manifest or seed
// archive, a seed archive whose checksum differs), invalid_argument (a parameter of the new job
// that differs from the base's, named with both values; a method other than exact; partial
// effect; --validate).
class EditBase {
 public:
  EditBase(const std::string& report, const JobSpec& spec, const PreparedJob& job);
  ~EditBase();
  const SeedSet& seeds() const;
  // The base field's per-tile summaries (from the manifest).
  const TileSummaries& tiles() const;
  const std::string& report_path() const { return report_; }
  // Reads the base field's rows [row0, row0 + rows) into `out` (site indices and metric
  // distances, with the job's metric and geolocator), in order from the first row. Throws
  // rv::Error(invalid_input) when a band's checksum differs (the file was modified), io.
  void read(int64_t row0, int64_t rows, NearestField& out);

 private:
  struct State;
  std::unique_ptr<State> st_;
  std::string report_;
};

// The report's "edit" entry: what the edit matched, recomputed and changed.
struct EditTally {
  int64_t cells_recomputed = 0, cells_of_removed = 0, blocks_measured = 0, strips = 0;
  std::vector<bool> tiles_read;  // per tile of the grid (TileSummaries order)
  double read_seconds = 0.0, plan_seconds = 0.0, apply_seconds = 0.0, tally_seconds = 0.0;
  EditChanges changes;
};
nlohmann::json edit_report(const EditBase& base, const Edit& edit, const SeedSet& edited, const EditTally& tally,
                           const GridSpec& grid, bool geodesic);

}  // namespace rv::detail
