// Test helper: a window's result against the same cells of the whole grid's result.
#pragma once

#include <gtest/gtest.h>

#include "rv/engine/engine.hpp"

namespace rv::test {

// Success when every cell of `part` (computed for a window of the grid) equals the cell at the
// same grid position in `whole` (computed for the whole grid), site and distance bit for bit;
// the failure names the first cell that differs.
inline ::testing::AssertionResult window_matches(const NearestField& part, const NearestField& whole) {
  const Window& w = part.site.window();
  const Window& all = whole.site.window();
  for (int64_t r = 0; r < w.height; ++r)
    for (int64_t c = 0; c < w.width; ++c) {
      const int64_t gc = w.col0 + c - all.col0, gr = w.row0 + r - all.row0;
      if (part.site.at(c, r) != whole.site.at(gc, gr) || part.distance.at(c, r) != whole.distance.at(gc, gr))
        return ::testing::AssertionFailure() << "window cell (" << c << ", " << r << "): site " << part.site.at(c, r)
                                             << " distance " << part.distance.at(c, r) << ", whole grid: site "
                                             << whole.site.at(gc, gr) << " distance " << whole.distance.at(gc, gr);
    }
  return ::testing::AssertionSuccess();
}

}  // namespace rv::test
