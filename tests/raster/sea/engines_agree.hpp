// Both engines of the distance by sea on one layout: the exact engine's field must equal the
// reference's cell for cell (owner, via, distance to the bit) and agree on the counts. What
// every field test of the distance by sea checks first.
#pragma once

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>

#include "rv/sea/sea_field.hpp"

namespace rv::test {

// Whether two fields of grid g are the same cell for cell: owner, via and distance to the bit
// (the first difference fails the test and returns false at once).
inline bool same_cells(const SeaField& got, const SeaField& want, const GridSpec& g) {
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      EXPECT_EQ(got.field.site.at(c, r), want.field.site.at(c, r)) << c << "," << r;
      EXPECT_EQ(got.via.at(c, r), want.via.at(c, r)) << c << "," << r;
      EXPECT_EQ(std::bit_cast<uint32_t>(got.field.distance.at(c, r)),
                std::bit_cast<uint32_t>(want.field.distance.at(c, r)))
          << c << "," << r;
      if (::testing::Test::HasFailure()) return false;
    }
  return true;
}

// Returns the exact engine's field (the first difference fails the test and returns at once).
inline SeaField engines_agree(const SeedSet& seeds, const Barriers& barriers, const GridSpec& g,
                              const SeaOptions& options = {}) {
  const SeaField reference = brute_force_sea(seeds, barriers, g, g.full_window(), options);
  const SeaField exact = compute_sea(seeds, barriers, g, g.full_window(), options);
  EXPECT_EQ(exact.land_cells, reference.land_cells);
  EXPECT_EQ(exact.unreachable_cells, reference.unreachable_cells);
  EXPECT_EQ(exact.barrier_vertices, reference.barrier_vertices);
  EXPECT_EQ(exact.max_detour, reference.max_detour);
  same_cells(exact, reference, g);
  return exact;
}

// The exact engine's blocks (SeaOptions::cell_by_cell false) against every cell answered alone:
// the same field cell for cell (owner, via, distance to the bit) and counts. Returns the blocks'
// field (the first difference fails the test and returns at once).
inline SeaField blocks_agree(const SeedSet& seeds, const Barriers& barriers, const GridSpec& g,
                             SeaOptions options = {}) {
  options.cell_by_cell = true;
  const SeaField alone = compute_sea(seeds, barriers, g, g.full_window(), options);
  options.cell_by_cell = false;
  const SeaField blocks = compute_sea(seeds, barriers, g, g.full_window(), options);
  EXPECT_EQ(alone.block_cells, 0);
  if (!same_cells(blocks, alone, g)) return blocks;
  EXPECT_EQ(blocks.land_cells, alone.land_cells);
  EXPECT_EQ(blocks.unreachable_cells, alone.unreachable_cells);
  EXPECT_EQ(blocks.max_detour, alone.max_detour);
  return blocks;
}

}  // namespace rv::test
