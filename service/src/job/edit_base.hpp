// Internal to run_job: what a run keeps for later edits of it (issue 32), and the edit of a
// finished run.
//
// Every streamed run that writes a report keeps, in a directory its report names ("edit_base"),
// what an edit needs of it, whatever outputs the user asked for:
//   manifest.json  the request's parameters an edit must repeat (grid, metric, method, distance
//                  units, max distance, compression); a checksum of seeds.bin; every raster the
//                  run wrote (the two below and the job's ownership, distance and nearest-feature
//                  rasters), named relative to the directory, with a checksum of each 256 x 256
//                  tile's bytes as stored (rv/field/checksum.hpp); and per tile, the field's largest
//                  distance and cost and whether it has unowned cells (rv::TileSummaries): an
//                  edit reads no cell of a tile it cannot change;
//   seeds.bin      the seed set it computed from (rv/edit/seed_archive.hpp), since users edit their
//                  files in place;
//   site.tif       the nearest site of every cell as a site code (0 = none): a fresh run's codes
//                  are its sites' indices + 1; an edit's are its base's, whose sites are then
//                  other indices (a removed site shifts the later ones), with new codes for the
//                  sites it added, so that its unchanged tiles are the base's bytes;
//   site_codes.bin an edit's site of each code (int32 little-endian, code 1 first; -1 for a site
//                  removed since): absent for a fresh run's (code = index + 1);
//   distance.tif   the distance to it in metric units, Float32, as the engine computed it; or,
//                  when the job writes its distance raster in metric units, that file (the
//                  manifest names it relative to the directory, e.g. "../distance.tif");
//   lines_*.bin    per line extraction of the run (boundaries, limits, the owned area's edge for
//                  regions), its pieces by row (rv::LinePieces), named in the manifest with their
//                  key and checksum: an edit extracts again only the rows near its changes
//                  (rv::Edit::line_rows) and takes the others' pieces from here.
// An edit (`--base REPORT`) reads that directory strip by strip in place of computing: of each
// strip of the base field it reads the tiles the edit may change (every tile when a file or a
// deliverable needs every cell), each checked against its checksum, plans and recomputes them
// (rv::Edit); the writers copy the other tiles' bytes from the base's files, checked likewise,
// and encode the rest. The files are then those of a fresh run, byte for byte.
// Not part of the public API. Thread safety: one object per job, used from its computing thread.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/edit/edit.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/job.hpp"
#include "rv/lines/strip_lines.hpp"

namespace rv::detail {

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
  // The temporary paths of the two rasters and their options.
  const std::string& temp_dir() const { return temp_; }
  const std::string& site_path() const { return site_path_; }
  const std::string& distance_path() const { return distance_path_; }
  // Whether the job's own distance raster (in metric units) serves as the kept distance: its
  // writer then feeds the tile summaries, and nothing is written twice.
  bool shares_distance() const { return !shared_distance_.empty(); }
  GeoTiffOptions site_options() const;
  GeoTiffOptions distance_options() const;
  // An edit's site codes (site_codes.bin): per code 1..K, its site's index in this run's seeds or
  // -1 (`site_of_code[0]` unused). Call before site_options(), which then states K codes.
  void set_site_codes(std::vector<int32_t> site_of_code);
  // Records a raster of the run in the manifest under `role` ("site" and "distance", the kept
  // field; "ownership", "output_distance" and "nearest_feature", the job's files): its path as
  // written (site_path() and distance_path() are named as they will be after commit()). Returns
  // where its writer leaves the tile checksums (StreamTarget::checksums); valid until commit().
  std::vector<uint64_t>* record(const std::string& role, const std::string& path);
  // Fed by the distance's writer (StreamTarget::observe): what the manifest records per tile.
  TileSummaries tiles;
  // The run's line pieces by extraction ("boundaries", "limits", "reach"), kept as lines_<name>.bin.
  void set_line_pieces(const std::map<std::string, LinePieces>& pieces);
  // What producing this run's field and files cost, for an edit of it to weigh recoding against
  // encoding afresh (EditBase::costs): kept in the manifest as given.
  void set_costs(const nlohmann::json& costs) { manifest_["costs"] = costs; }
  // Writes the manifest and renames the directory into place (the old one, if any, removed).
  // Returns the directory's path.
  std::string commit();

 private:
  std::string dir_, temp_, site_path_, distance_path_, shared_distance_;
  std::map<std::string, std::pair<std::string, std::vector<uint64_t>>> rasters_;  // role -> path, checksums
  std::vector<int32_t> site_of_code_;                                             // empty: index + 1
  std::map<std::string, std::pair<std::string, std::string>> lines_;              // name -> key, bytes
  nlohmann::json manifest_;
  std::string seeds_hash_;
  int64_t sites_ = 0;
  bool committed_ = false;
};

struct EditBaseFiles;

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
  // The same from files read ahead (read_files), while the job's seeds were being read: the
  // errors are those, in the same order, that the constructor above throws.
  EditBase(std::shared_ptr<EditBaseFiles> files, const JobSpec& spec, const PreparedJob& job);
  // What of the base can be read before the job is known (the report, the manifest, the seed
  // archive, the site codes, the line pieces, the rasters' entries), parsed and decoded. Never
  // throws: a failure is kept for the constructor. Thread-safe (reads files only).
  static std::shared_ptr<EditBaseFiles> read_files(const std::string& report);
  // The seconds read_files took.
  double files_seconds() const;
  ~EditBase();
  const SeedSet& seeds() const;
  // Per base feature, its number in the nearest-feature raster (empty: its index + 1).
  const std::vector<int64_t>& numbering() const;
  // Per code of the base's site raster, the base site it stands for (kNoSite: removed, and code
  // 0); index + 1 for a fresh run's.
  const std::vector<int32_t>& site_of_code() const;
  // The base field's per-tile summaries (from the manifest).
  const TileSummaries& tiles() const;
  // What making the base's field and files cost, as its run measured them (EditBaseWriter::
  // set_costs; an edit that copied a file or patched the field carries its own base's figures):
  // the engine's wall time over the whole grid, and per raster role (record's) the
  // writer's time to encode every tile afresh. Seconds; negative or absent where not known (a
  // base kept before they were recorded).
  struct Costs {
    double engine_s = -1.0;
    std::map<std::string, double> encode_s;
    double encode(const std::string& role) const {
      const auto i = encode_s.find(role);
      return i == encode_s.end() ? -1.0 : i->second;
    }
  };
  const Costs& costs() const;
  const std::string& report_path() const { return report_; }
  // A raster the base run wrote (EditBaseWriter::record's roles), for a writer to copy tiles from:
  // its path, its name in messages, its tile checksums. Empty when the base did not write one.
  struct Earlier {
    std::string path, display;
    std::vector<uint64_t> checksums;
  };
  std::optional<Earlier> earlier(const std::string& role) const;
  // The base's line pieces of extraction `name` (EditBaseWriter::set_line_pieces) when their key
  // is `key` (StripLines::key), checked against their checksum when the base was opened; else
  // empty (the base ran without that extraction, or with other lines' options).
  LinePieces line_pieces(const std::string& name, const std::string& key) const;
  // Reads the base field's rows [row0, row0 + rows) into `out` (site indices and metric
  // distances, with the job's metric and geolocator), in order from the first row, strips of
  // whole 256-row bands of tiles (but the last). `tiles`, when not null: per tile of the grid
  // (TileSummaries order), only the cells of the tiles flagged 1 are read; the others' are left
  // as they were. Every tile read is checked against its checksum. Throws
  // rv::Error(invalid_input) when one differs (the file was modified), io.
  void read(int64_t row0, int64_t rows, NearestField& out, const std::vector<uint8_t>* tiles = nullptr);

 private:
  struct State;
  std::unique_ptr<State> st_;
  std::string report_;
};

// What the edit's code rasters give what the base's rasters coded, per value of the base's
// rasters: owner codes, feature numbers; 0 stays 0 (none), -1 for what the edit removed. `identity`: every kept value
// is unchanged, so an unchanged tile's bytes are the same in both runs; else the tile is decoded and coded again.
struct CodeMap {
  std::vector<int32_t> to;
  bool identity = true;
  bool valid = true;  // false: no one code for each of the base's (nothing is copied)
};
struct EditCodes {
  CodeMap owners, features;
};
EditCodes code_maps(const EditBase& base, const Edit& edit, const LoadedSeeds& edited);

// An edit's site codes: the base's codes of the sites it kept, new codes (after the base's last)
// for those it added. `site_of_code` as EditBaseWriter::set_site_codes takes it; `code_of_site`,
// per edited site, its code.
struct SiteCodeTable {
  std::vector<int32_t> site_of_code, code_of_site;
};
SiteCodeTable edit_site_codes(const EditBase& base, const Edit& edit, size_t edited_sites);

// The report's "edit" entry: what the edit matched, recomputed and changed.
struct EditTally {
  int64_t cells_recomputed = 0, cells_of_removed = 0, blocks_measured = 0, strips = 0;
  int64_t tiles_encoded = 0;                      // tiles whose cells changed or may have (StreamJob::source's fresh)
  std::map<std::string, int64_t> tiles_copied;    // per file copying from the base's
  std::map<std::string, int64_t> tiles_recoded;   // per file copying with other codes
  std::map<std::string, std::string> not_copied;  // per file that could not, why
  std::vector<bool> tiles_read;                   // per tile of the grid (TileSummaries order): its cells read
  std::vector<bool> tiles_planned;                // ... the plan could not rule it out (a subset)
  double read_seconds = 0.0, plan_seconds = 0.0, apply_seconds = 0.0, tally_seconds = 0.0;
  double engine_seconds = 0.0;  // strips computed whole by the engine (attach_edit's choice)
  int64_t strips_by_engine = 0;
  nlohmann::json choice;  // how the files are made where their codes move, and why (attach_edit)
  EditChanges changes;
};
nlohmann::json edit_report(const EditBase& base, const Edit& edit, const SeedSet& edited, const EditTally& tally,
                           const GridSpec& grid, bool geodesic);

}  // namespace rv::detail
