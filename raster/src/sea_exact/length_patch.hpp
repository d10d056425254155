// The geodesic length from one fixed point (a root of paths by sea: a bend node's vertex or a
// point site) to the cells of one block of a longitude/latitude grid, interpolated (internal to
// rv_raster; sea_cells.cpp uses it for the cells whose path bends).
//
// The quantity interpolated is the straight geodesic engine's point form (geodesic/
// geodesic_interpolant.hpp): q = length / chord to the point, a bicubic over 4 x 4 nodes at
// thirds of the block, so that a cell's length is q times its chord. Building takes 16 inverse
// problems at the nodes and one at the block's centre, where the patch must agree with
// GeographicLib within kPatchCheck or it is not used. A length taken from a patch is within
// kPatchError of GeographicLib's (a margin 100 times the check, and 1,000 times the worst cell
// measured within kPatchSpan); callers decide anything closer than that with GeographicLib's own
// length, so that every answer is the one it would be without patches, to the bit.
//
// Units: metres (lengths, ECEF positions), degrees (longitude, latitude). Thread safety: a built
// patch is immutable; build on one thread.
#pragma once

#include <cstdint>
#include <memory>
#include <unordered_map>

#include "sea/sea_prepare.hpp"

namespace rv::sea {

inline constexpr double kPatchCheck = 1e-7;  // metres: accepted error at the block's centre
inline constexpr double kPatchError = 1e-5;  // metres: the margin every decision keeps
// Degrees: the largest span of a block in longitude and in latitude. Beyond, the cubics stray
// from the quantity away from the centre while the centre still checks (6.7e-7 m measured on a
// block 1.55 degrees long whose centre was within 1e-7 m); within it, the worst cell measured is
// 1.05e-8 m (tests/raster/sea/test_sea_blocks.cpp).
inline constexpr double kPatchSpan = 0.4;

// The block's cells: columns c0 .. c1 and rows r0 .. r1 of the window, both ends included
// (c1 - c0 >= 3, r1 - r0 >= 3), whose centres' longitudes and latitudes are linear in the column
// and the row from ll0 (cell c0, r0) to ll1 (cell c1, r1).
struct PatchBlock {
  int64_t c0, r0, c1, r1;
  Vec2 ll0, ll1;
};

class LengthPatch {
 public:
  // Builds the patch of the length from `ll` (its ECEF position `xyz`) over `block`; usable()
  // says whether the centre's check held, the block spans at most kPatchSpan each way and no
  // node lay within a millimetre of the point.
  LengthPatch(const Prepared& p, Vec2 ll, const Prepared::Xyz& xyz, const PatchBlock& block);
  bool usable() const { return usable_; }
  // The length to cell (c, r) of the block, whose ECEF position is `at` (Prepared::spot_xyz),
  // within kPatchError of the inverse problem's. Only when usable().
  double length(int64_t c, int64_t r, const Prepared::Xyz& at) const;

 private:
  Prepared::Xyz xyz_;
  PatchBlock block_;
  double q_[4][4] = {};
  bool usable_ = false;
};

// One worker's patches over the tiles of a window (square tiles of `side` cells from its first
// cell, a whole number of the engine's blocks): one per (root, tile), shared by every block of
// the tile, built once the root's length has been measured exactly for a few cells there, and
// kept while the worker stays in the tile's row of tiles. Not thread-safe: one per worker.
class PatchTiles {
 public:
  struct Entry {
    int uses = 0;
    std::unique_ptr<LengthPatch> patch;
  };
  // The entry of root `item` in tile (tx, ty), made empty on first use; entries of other rows of
  // tiles are dropped first (references to them with them).
  Entry& at(int32_t item, int64_t tx, int64_t ty) {
    if (ty != row_) {
      entries_.clear();
      row_ = ty;
    }
    return entries_[(static_cast<uint64_t>(static_cast<uint32_t>(item)) << 32) | static_cast<uint64_t>(tx)];
  }

 private:
  int64_t row_ = -1;
  std::unordered_map<uint64_t, Entry> entries_;
};

}  // namespace rv::sea
