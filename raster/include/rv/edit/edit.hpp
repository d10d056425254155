// Edits of a finished field: which features an edit kept, and which cells it can change (seed
// paper 004: removing a site changes only the cells it owned; adding one, only the cells where it
// is nearer than the owner they had).
//
// An edit is a new seed set for the same grid and options. A cell can change only where
//   - its base nearest feature is not kept (removed, or changed: a changed feature is removed
//     and added again), or
//   - an added feature counts there at a cost no higher than the base winner's (ties included:
//     the lower site index wins them, and indices move), the base's Float32 distance widened by
//     its rounding; on unowned cells, wherever an added feature counts at all.
// Every other cell keeps its base nearest feature, at the same distance: its site is the same
// site of the kept feature, renumbered. Recomputing the cells of the mask (ComputeOptions::mask)
// over the renumbered base field gives the fresh field of the edited seeds, cell for cell.
//
// One exception: on a geodesic field, an edit that gives the first weight or reach, or takes the
// last away, changes the method every cell is computed by (the adjusted method's distances agree
// with the exact kernels' to one float ulp, not bit for bit): its plan is every cell.
//
// Units: metric units (the field's). Pure functions over value types; thread-safe.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/field/cell_mask.hpp"
#include "rv/field/geolocate.hpp"
#include "rv/field/seeds.hpp"
#include "rv/lines/strip_lines.hpp"

namespace rv {

// Which features of the base are in the edited set unchanged: the same owner label, geometry
// (every site's kind and coordinates, and for polygons every ring, bit for bit) and adjustments
// (weight, reach, effect). Equal features pair in order of appearance. A kept feature whose
// place among the kept ones changed (the file's features reordered) counts as changed: the tie
// rule follows indices.
// A feature's identity across edits of its file: its source without the directory
// ("file.gpkg:layer:fid 7"; the daemon stages every job's uploads in a directory of its own).
std::string source_key(const std::string& source);

struct FeatureMatch {
  std::vector<int32_t> edited_of_base;  // per base feature: its index in the edited set, or -1
  std::vector<int32_t> base_of_edited;  // per edited feature: its base feature, or -1 (added)
  // The owners' codes (first appearance) order their labels differently: the lower code decides
  // cells inside polygons of two owners, so every polygon's interior may change.
  bool owners_reordered = false;
  int64_t kept() const;
};
FeatureMatch match_features(const SeedSet& base, const SeedSet& edited);

// Owners by label: per owner code of `from` (1..n; index 0 is 0), the code of the owner with the
// same label in `to`, or -1 where `to` has none. O(owners) time and memory; the labels are not
// copied (the sets must stay alive only during the call). Thread-safe.
std::vector<int32_t> owner_codes_in(const SeedSet& from, const SeedSet& to);

// Per base site, the same site of its kept feature in the edited set; kNoSite for the sites of
// features not kept.
std::vector<int32_t> edited_sites(const SeedSet& base, const SeedSet& edited, const FeatureMatch& match);

// Per tile of 256 x 256 cells of a grid (tiles from the grid's top-left corner), what a field
// holds in it, so that an edit's plan can rule a tile out without reading its cells: the largest
// distance and the largest cost (distance / the feature's weight) of its owned cells, and whether
// any cell is unowned. A run records them as its strips pass; an edit of it reads them back.
// Units: metric units. Thread safety: add() from one thread at a time.
struct TileSummaries {
  static constexpr int64_t kTile = 256;
  int64_t cols = 0, rows = 0;       // tiles across and down the grid
  std::vector<float> max_distance;  // per tile, row-major; -1 while the tile has no owned cell
  std::vector<float> max_cost;      // rounded up to float
  std::vector<uint8_t> unowned;     // 1 where some cell has no owner
  // The same largest distance and unowned flag per band of kTile / kBands rows of each tile
  // (index tile * kBands + band), which rv::Edit::line_tiles reads; empty (a base saved without
  // them): each tile's values stand for its bands.
  static constexpr int64_t kBands = 8;
  std::vector<float> band_max_distance;
  std::vector<uint8_t> band_unowned;
  bool has_bands() const {
    return band_max_distance.size() == max_distance.size() * kBands && band_unowned.size() == band_max_distance.size();
  }

  static TileSummaries for_grid(const GridSpec& grid);
  // Takes in whole rows [row0, row0 + rows) of the grid: sites and distances (metric units) of
  // the field of `seeds`, rows * grid width values each. `only`, when not null: one flag per tile
  // of those rows' tile rows (cols per tile row, from row0's), and only the tiles flagged 1 are
  // read (the others' cells may hold anything; their summaries are left as they are).
  void add(const int32_t* site, const float* distance, int64_t row0, int64_t rows, int64_t width, const SeedSet& seeds,
           const uint8_t* only = nullptr);
  size_t tile_of(int64_t col, int64_t row) const { return static_cast<size_t>((row / kTile) * cols + col / kTile); }
};

struct EditPlan {
  FeatureMatch match;
  Window window;                // the base field's window
  CellMask mask;                // window-relative
  int64_t cells = 0;            // cells in the mask
  int64_t removed_cells = 0;    // of them, cells whose base feature is not kept
  int64_t blocks_measured = 0;  // blocks of cells an added feature could not be ruled out of
  // The tiles (TileSummaries order: row-major over the grid) whose cells in the window were read:
  // those the summaries could not rule out (every tile of the window without summaries).
  std::vector<int64_t> tiles_read;
};

// An edit prepared once for a grid: the features matched, the base sites renumbered, the added
// features indexed. plan() and apply() then take any window of the base field (a streamed job's
// strips one after the other, or the whole grid). Both seed sets and the options' shared parts
// (geolocator, prepared, grid_polygons) are kept by reference and must outlive the Edit.
// `options`: the job's (metric, max distance, threads, geolocator; `prepared`, when set, must be
// the edited seeds' preparation for `grid`); its window and mask are ignored.
// Thread safety: plan() and apply() are const and may be called from one thread at a time or
// several (each call uses options.threads threads of its own).
class Edit {
 public:
  Edit(const SeedSet& base_seeds, const SeedSet& edited, const GridSpec& grid, const ComputeOptions& options);
  // The same with the features matched by the caller, who knows which it changed (a session),
  // instead of by their geometry (match_features, which hashes every feature): `match` pairs only
  // features that are the same in both sets (geometry, owner, weight, reach), in the same order;
  // any it leaves unpaired is taken as removed and added (more cells computed, the same field).
  // Its owners_reordered is worked out here. Throws rv::Error(invalid_argument) for a match that
  // does not fit the sets (sizes, a pair whose parts or sites differ in number, pairs out of order).
  Edit(const SeedSet& base_seeds, const SeedSet& edited, const GridSpec& grid, const ComputeOptions& options,
       FeatureMatch match);
  ~Edit();
  Edit(Edit&&) noexcept;
  Edit& operator=(Edit&&) = delete;
  Edit(const Edit&) = delete;
  Edit& operator=(const Edit&) = delete;

  const FeatureMatch& match() const;
  // Per base site, its site in the edited set (edited_sites).
  const std::vector<int32_t>& site_map() const;
  // Whether every kept site has the same index in both sets (a site raster of the base is then
  // that of the edited set wherever the edit changes nothing).
  bool keeps_indices() const;

  // Per tile of the grid (TileSummaries order), 1 where plan() with these summaries reads the
  // base's cells (the tiles it cannot rule out), 0 where it reads none: a tile flagged 0 keeps
  // every cell of the base, renumbered. Throws as plan() where the summaries do not fit the grid.
  std::vector<uint8_t> tiles_to_read(const TileSummaries& tiles) const;
  // The rows of the grid whose line pieces (rv::StripLines) an edit extracts again, as sorted,
  // disjoint [row0, row1) ranges; the pieces of every other row are its base's (`base_pieces`,
  // the base run's extractions with the same keys), renumbered by site_map() (StripLines::take_rows).
  // A row is extracted again when it lies within 2 * StripLines::kDependRows rows of a band of
  // 32 rows of a tile (line_tiles) where the edit may change a cell (tiles_to_read) or where a
  // removed or an added site may be measured by the extraction: within the band's largest
  // distance, or `reach_floor` (metric units: the largest limit distance drawn per owner,
  // measured from a cell of any owner), or the max distance where the band has unowned cells,
  // of a point a few cells from it; or of a piece that names a removed site. Every row (one
  // range over the grid) where pieces cannot be taken: seeds with weights or reaches, owners in
  // another order, a projected geodesic grid.
  std::vector<std::pair<int64_t, int64_t>> line_rows(const TileSummaries& tiles,
                                                     std::span<const LinePieces> base_pieces, double reach_floor) const;
  // The same rows from line_tiles()' flags, made once by the caller (who also passes them to
  // rv::StripLines::keep_refined).
  std::vector<std::pair<int64_t, int64_t>> line_rows(std::span<const uint8_t> line_tiles,
                                                     std::span<const LinePieces> base_pieces) const;
  // Per tile of the grid (TileSummaries order), the bands of its rows (bit b: the tile's rows
  // [32 b, 32 b + 32)) where the edit may change a cell or a measurement by the metric, as
  // line_rows reads them (before its rows are widened): bands it may change, bands its changed
  // features' box meets (widened by 3 cells), and bands where a removed or an added site may be
  // measured; 0xFF (every band of every tile) where line_rows gives every row. A line segment
  // whose tiles (its ends' cells widened by two) are all 0 measures as it did before the edit
  // (rv::StripLines::keep_refined, which reads a tile's flag as a whole).
  // `plan`, when given, is this edit's plan of the whole grid with the same summaries: the bands
  // its mask meets are those the edit may change; without it, every band of each tile the plan
  // would read (tiles_to_read), a superset.
  std::vector<uint8_t> line_tiles(const TileSummaries& tiles, double reach_floor, const EditPlan* plan = nullptr) const;

  // The plan for `base`, the base field over any window of the grid (the field of the base seeds
  // computed with the same options). With `tiles` (the base field's summaries over the whole
  // grid), the cells of tiles that no removed feature can have owned and no added feature can
  // win are not read: a removed feature owned no cell of a tile it is farther from than the
  // tile's largest distance; an added one wins no cell of a tile where its cost exceeds the
  // tile's largest cost (and its reach, where the tile has unowned cells). Throws
  // rv::Error(invalid_argument) where the field does not fit the base seeds (a site index out of
  // range) or the summaries do not fit the grid.
  EditPlan plan(const NearestField& base, const TileSummaries* tiles = nullptr) const;

  // The edited field over base's window into `out` (its buffers reused as compute_into does; `out`
  // may be `base` itself: the edit is then made in place, and only the mask's cells are touched
  // when no kept site changes its index): the base's cells renumbered to the edited sites, the
  // plan's cells computed again. Equal to
  // compute(edited, grid, options) over that window, cell for cell. Needs options.method exact
  // (else rv::Error(invalid_argument), thrown by the constructor).
  // `valid`, when not null (in place only): per tile of the grid, whether base's cells in it are
  // the base field's (tiles_to_read with the plan's summaries, or more); the others are neither
  // read nor written, and the plan must have no cell there.
  void apply(const NearestField& base, const EditPlan& plan, NearestField& out,
             const std::vector<uint8_t>* valid = nullptr) const;

 private:
  struct State;
  std::unique_ptr<State> st_;
};

// What an edit changed over a window, and where. Owners are compared by label (an edit may
// renumber their codes); "" stands for no owner (cells beyond the max distance or every reach).
struct EditChanges {
  int64_t owner_cells = 0;          // cells whose owner changed
  int64_t distance_only_cells = 0;  // cells whose owner stayed and whose distance changed (bit for bit)
  // Area that went from one owner to another, keyed (from, to): square metres on the metric's
  // ellipsoid for geodesic fields, CRS units squared for planar ones. A cell's area is its
  // square's (ring_area, rv/lines/regions.hpp).
  std::map<std::pair<std::string, std::string>, double> moved;
  // The box of the cells whose owner or distance changed, grid columns [col0, col1) and rows
  // [row0, row1); col1 == 0 when none did.
  int64_t col0 = 0, row0 = 0, col1 = 0, row1 = 0;
  bool any() const { return col1 > col0; }
  void add(const EditChanges& other);
  // Widens the box to take in cell (col, row).
  void take_cell(int64_t col, int64_t row);
};

// The changes from `base` (a field of `base_seeds`) to `edited` (of `edited_seeds`) over the same
// window of `grid`. `codes`, when not null, receives one value per cell of the window, row-major:
// 1 where the owner changed, 2 where only the distance did, 0 elsewhere. `geolocator`: the
// projected geodesic grid's (cell areas located on the ellipsoid); null otherwise. `only`: the
// edit's mask (Edit::plan), outside which Edit::apply changes no owner and no distance: only its
// cells are compared (null: every cell).
// Throws rv::Error(invalid_argument) when the windows differ.
EditChanges tally_changes(const NearestField& base, const SeedSet& base_seeds, const NearestField& edited,
                          const SeedSet& edited_seeds, const GridSpec& grid, const Geolocator* geolocator,
                          int32_t* codes, const CellMask* only = nullptr);

// tally_changes for many windows of one edit (a streamed job's strips): the owners' labels are
// matched once. Keeps the seed sets and geolocator by reference. Thread safety: measure() is const.
class ChangeTally {
 public:
  ChangeTally(const SeedSet& base_seeds, const SeedSet& edited_seeds, const GridSpec& grid,
              const Geolocator* geolocator);
  EditChanges measure(const NearestField& base, const NearestField& edited, int32_t* codes,
                      const CellMask* only = nullptr) const;
  // The base's sites and distances of the cells of `mask`, in the mask's order (row by row, span
  // by span): what measure_masked needs of a base that an edit then changes in place.
  struct MaskedCells {
    std::vector<int32_t> site;
    std::vector<float> distance;
  };
  static MaskedCells masked_cells(const CellMask& mask, const NearestField& base);
  // measure() over `mask` alone, the base's cells given by masked_cells: for an edit applied in
  // place (Edit::apply with out == base).
  EditChanges measure_masked(const CellMask& mask, const MaskedCells& base, const NearestField& edited,
                             int32_t* codes) const;

 private:
  // One cell: counts its change into `out` and returns its code (0, 1 owner, 2 distance only).
  int32_t count(int32_t sb, float db, int32_t se, float de, int64_t col, int64_t row, const MetricSpec& metric,
                EditChanges& out, std::unordered_map<int64_t, double>& rows) const;
  const SeedSet& base_seeds_;
  const SeedSet& edited_seeds_;
  GridSpec grid_;
  const Geolocator* geolocator_;
  std::vector<int32_t> code_in_edited_;  // per base owner code, its edited code (-1: dropped)
};

// One-shot forms of Edit over a base field of any window.
EditPlan plan_edit(const NearestField& base, const SeedSet& base_seeds, const SeedSet& edited, const GridSpec& grid,
                   const ComputeOptions& options);
NearestField apply_edit(const NearestField& base, const SeedSet& base_seeds, const SeedSet& edited,
                        const GridSpec& grid, const ComputeOptions& options, const EditPlan& plan);

}  // namespace rv
