// Which cells of a window a computation must produce (ComputeOptions::mask): the edits of a
// finished job recompute only the cells an edit can change.
//
// Spans [col0, col1) of window-relative columns per window row, disjoint and sorted by col0 (the
// shape rv::InteriorSpans has). A value type; pure, thread-safe for concurrent reads.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "rv/field/grid.hpp"

namespace rv {

struct CellMask {
  std::vector<std::vector<std::pair<int64_t, int64_t>>> rows;  // per window row

  // A mask of `window` without any cell.
  static CellMask none(const Window& window) {
    CellMask m;
    m.rows.resize(static_cast<size_t>(window.height));
    return m;
  }

  // Adds the cells [c0, c1) x [r0, r1) (window-relative), merging spans that overlap or touch.
  void add(int64_t c0, int64_t r0, int64_t c1, int64_t r1) {
    for (int64_t r = r0; r < r1; ++r) {
      auto& row = rows[static_cast<size_t>(r)];
      row.emplace_back(c0, c1);
      std::sort(row.begin(), row.end());
      std::vector<std::pair<int64_t, int64_t>> merged;
      for (const auto& s : row) {
        if (!merged.empty() && s.first <= merged.back().second)
          merged.back().second = std::max(merged.back().second, s.second);
        else
          merged.push_back(s);
      }
      row = std::move(merged);
    }
  }

  // True when a cell of columns [c0, c1) x rows [r0, r1) is in the mask.
  bool any(int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
    for (int64_t r = r0; r < r1; ++r) {
      const auto& row = rows[static_cast<size_t>(r)];
      // The first span ending after c0 must start before c1.
      auto it = std::upper_bound(row.begin(), row.end(), c0,
                                 [](int64_t c, const std::pair<int64_t, int64_t>& s) { return c < s.second; });
      if (it != row.end() && it->first < c1) return true;
    }
    return false;
  }

  bool contains(int64_t c, int64_t r) const { return any(c, r, c + 1, r + 1); }

  // Whether the mask fits `window`: one list per row, each span non-empty, inside the window's
  // columns, and after the previous one.
  bool fits(const Window& window) const {
    if (rows.size() != static_cast<size_t>(window.height)) return false;
    for (const auto& row : rows) {
      int64_t end = 0;
      for (const auto& s : row) {
        if (s.first < end || s.second <= s.first || s.second > window.width) return false;
        end = s.second;
      }
    }
    return true;
  }
};

}  // namespace rv
