// Both engines of the distance by sea on one layout: the exact engine's field must equal the
// reference's cell for cell (owner, via, distance to the bit) and agree on the counts. What
// every field test of the distance by sea checks first.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include "rv/sea/sea_field.hpp"
#include "rv/sea/visibility.hpp"

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

// The exact engine's drawing and blocks (SeaOptions::cell_by_cell false) against every cell
// answered alone:
// the same field cell for cell (owner, via, distance to the bit) and counts. Returns the blocks'
// field (the first difference fails the test and returns at once).
inline SeaField blocks_agree(const SeedSet& seeds, const Barriers& barriers, const GridSpec& g,
                             SeaOptions options = {}) {
  options.cell_by_cell = true;
  const SeaField alone = compute_sea(seeds, barriers, g, g.full_window(), options);
  options.cell_by_cell = false;
  const SeaField blocks = compute_sea(seeds, barriers, g, g.full_window(), options);
  EXPECT_EQ(alone.block_cells, 0);
  EXPECT_EQ(alone.drawn_cells, 0);  // (the reference draws nothing either)
  if (!same_cells(blocks, alone, g)) return blocks;
  EXPECT_EQ(blocks.land_cells, alone.land_cells);
  EXPECT_EQ(blocks.unreachable_cells, alone.unreachable_cells);
  EXPECT_EQ(blocks.max_detour, alone.max_detour);
  return blocks;
}

// Independently of both engines: the distance by sea is 1-Lipschitz along free paths, so two cells
// whose centres see each other (both on open sea, `reach` cells apart at most in each direction;
// every pair when reach < 0) differ by at most their distance apart (+ `slack`): a root or a bend
// wrongly left out shows as a jump. Centres within rounding of a barrier edge are left out (the
// engines decide them in the grid's frame, this check in the barriers'). Fails the test at the
// first pair that breaks it and returns false.
inline bool triangle_inequality_holds(const SeaField& f, const Barriers& barriers, const GridSpec& g, int64_t reach,
                                      double slack = 1e-4) {
  const Visibility vis(barriers);
  auto near_line = [&](Vec2 q) {
    auto off = [&](Vec2 a, Vec2 b) {  // within rounding of the segment a-b
      const double dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
      const double t = std::clamp(((q.x - a.x) * dx + (q.y - a.y) * dy) / len2, 0.0, 1.0);
      return std::hypot(q.x - a.x - t * dx, q.y - a.y - t * dy) <= 1e-9 * std::sqrt(len2);
    };
    for (const Barriers::Polygon& p : barriers.polygons())
      for (const Ring& r : p.rings)
        for (size_t i = 0; i < r.size(); ++i)
          if (off(r[i], r[(i + 1) % r.size()])) return true;
    for (const Barriers::Line& l : barriers.lines())
      for (size_t i = 0; i + 1 < l.vertices.size(); ++i)
        if (off(l.vertices[i], l.vertices[i + 1])) return true;
    return false;
  };
  std::vector<uint8_t> usable(static_cast<size_t>(g.cell_count()));
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x{g.centre_x(c), g.centre_y(r)};
      usable[static_cast<size_t>(r * g.width + c)] =
          f.field.site.at(c, r) != kNoSite && vis.classify(x) == Visibility::Ground::open_sea && !near_line(x);
    }
  const int64_t span = reach < 0 ? std::max(g.width, g.height) : reach;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      if (!usable[static_cast<size_t>(r * g.width + c)]) continue;
      for (int64_t r2 = std::max<int64_t>(0, r - span); r2 <= std::min(g.height - 1, r + span); ++r2)
        for (int64_t c2 = std::max<int64_t>(0, c - span); c2 <= std::min(g.width - 1, c + span); ++c2) {
          if (!usable[static_cast<size_t>(r2 * g.width + c2)] || (r2 == r && c2 == c)) continue;
          const Vec2 x{g.centre_x(c), g.centre_y(r)}, y{g.centre_x(c2), g.centre_y(r2)};
          const double d = f.field.distance.at(c, r), d2 = f.field.distance.at(c2, r2);
          if (d <= d2 + std::hypot(x.x - y.x, x.y - y.y) + slack) continue;
          if (!vis.sees(Visibility::Place{x}, Visibility::Place{y})) continue;
          ADD_FAILURE() << "the triangle inequality breaks: " << c << "," << r << " (" << x.x << ", " << x.y
                        << "): " << d << " by site " << f.field.site.at(c, r) << " via " << f.via.at(c, r) << "; " << c2
                        << "," << r2 << " (" << y.x << ", " << y.y << ") sees it: " << d2 << " by site "
                        << f.field.site.at(c2, r2) << " via " << f.via.at(c2, r2);
          return false;
        }
    }
  return true;
}

}  // namespace rv::test
