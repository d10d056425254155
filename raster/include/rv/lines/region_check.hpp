// Regions against their cells: every owned cell's centre in its owner's region.
//
// The regions' faces are bounded by the lines, which follow the exact loci; the ownership
// raster gives each cell centre's owner by the engine's exact rule. So an owned centre farther
// than the lines' tolerance from every face edge lies in a face of its own owner. One that lies
// in another owner's face, or in none, shows a change of owner the lines miss: the faces of two
// owners have run into each other, and the regions' areas hand that sea to the wrong owner. The
// check is made before the regions are written.
//
// Pure value types and functions; thread-safe for concurrent reads.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rv/engine/outputs.hpp"
#include "rv/field/error.hpp"
#include "rv/field/grid.hpp"
#include "rv/field/seeds.hpp"

namespace rv {

// The owner codes of a grid's cells, row by row as runs, fed strip by strip. Rows never fed are
// not checked. Memory: 16 bytes a run (a change of owner, or of owned and unowned, along a row).
// Thread safety: rows may be fed from several threads at once, each row by one.
class CellOwners {
 public:
  struct Run {
    int64_t col0;   // first column of the run; it lasts to the next run's col0 or the row's end
    int32_t owner;  // owner code, 0: no owner
  };
  explicit CellOwners(const GridSpec& grid);
  // Row `row` (in [0, grid.height)) of owner codes, `owners.size()` == grid.width (0: no owner).
  // A row fed again replaces the earlier one.
  void add_row(int64_t row, std::span<const int32_t> owners);
  // The same from a row of a field's sites (kNoSite: no owner), each site's owner by `codes`: the
  // owner looked up only where the site changes along the row.
  void add_sites(int64_t row, std::span<const int32_t> sites, const SiteCodes& codes);
  const GridSpec& grid() const { return grid_; }
  bool has(int64_t row) const { return fed_[static_cast<size_t>(row)] != 0; }
  const std::vector<Run>& row(int64_t r) const { return rows_[static_cast<size_t>(r)]; }
  int64_t rows_fed() const;

 private:
  // Row `row`'s runs from `keys` (a whole row), each key's owner by `owner_of`: looked up only
  // where the key changes along the row.
  template <class OwnerOf>
  void store(int64_t row, std::span<const int32_t> keys, OwnerOf&& owner_of) {
    if (row < 0 || row >= grid_.height || static_cast<int64_t>(keys.size()) != grid_.width)
      throw Error(ErrorKind::internal, "CellOwners: a whole row of the grid is needed");
    std::vector<Run>& runs = rows_[static_cast<size_t>(row)];
    runs.clear();
    for (size_t c = 0; c < keys.size();) {
      const int32_t key = keys[c], owner = owner_of(key);
      if (runs.empty() || runs.back().owner != owner) runs.push_back(Run{static_cast<int64_t>(c), owner});
      while (++c < keys.size() && keys[c] == key) {
      }
    }
    runs.shrink_to_fit();
    fed_[static_cast<size_t>(row)] = 1;
  }

  GridSpec grid_;
  std::vector<std::vector<Run>> rows_;
  std::vector<uint8_t> fed_;
};

// One face of the regions: its owner (0: nobody's, e.g. land, or sea beyond the max distance) and
// its rings (outer ring first, then holes; either orientation, closed or not), in grid-CRS
// positions.
struct OwnedFace {
  int32_t owner = 0;
  std::vector<std::vector<Vec2>> rings;
};

struct RegionCellCheck {
  int64_t rows = 0;  // the rows checked (those fed)
  // Owned cells whose centre is farther than the margin from every face edge; those within it
  // (not checked); and of the checked, those in another owner's face or in no face.
  int64_t checked = 0, near_edges = 0, misplaced = 0;
  // The first misplaced cells in row-major order (at most kFirst): the cell, its owner, and the
  // owner of the face its centre lies in (0: a face of nobody's, or none).
  struct Misplaced {
    int64_t col = 0, row = 0;
    int32_t owner = 0, region = 0;
  };
  static constexpr size_t kFirst = 16;
  std::vector<Misplaced> first;
};

// Checks the faces against `cells`. Faces are read by the even-odd rule, as polygons of the
// grid's CRS with straight edges; a centre on a ring's edge belongs to the face whose span
// starts there (it is within any margin of that edge anyway). `margin` (grid CRS units, >= 0):
// centres within it of a face edge are not checked (the lines' tolerance: their chords and the
// loci part such centres either way). Faces of one owner may overlap; a centre in faces of two
// owners is in its place if one of them is its owner's.
RegionCellCheck check_regions_against_cells(std::span<const OwnedFace> faces, const CellOwners& cells, double margin);

}  // namespace rv
