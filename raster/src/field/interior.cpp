#include "rv/field/interior.hpp"

#include <algorithm>
#include <cmath>
#include <map>

namespace rv {

int64_t first_column_at_or_after(const GridSpec& g, double x) {
  double c = std::ceil(x / g.res - 0.5);
  c = std::clamp(c, -1.0, static_cast<double>(g.width) + 1.0);
  auto col = static_cast<int64_t>(c);
  // The floating estimate corrected, so that the test is exactly the one brute force uses.
  while (col > -1 && g.local_x(col - 1) >= x) --col;
  while (col <= g.width && g.local_x(col) < x) ++col;
  return col;
}

void ring_spans(std::span<const Ring> rings, const GridSpec& g, const Window& w, std::vector<RingCrossing>& scratch,
                const std::function<void(int64_t row, int64_t c0, int64_t c1)>& add) {
  scratch.clear();
  for (const Ring& ring : rings) {
    for (size_t i = 0; i < ring.size(); ++i) {
      const Vec2 a{ring[i].x - g.xmin, ring[i].y - g.ymax};
      const Vec2& rb = ring[(i + 1) % ring.size()];
      const Vec2 b{rb.x - g.xmin, rb.y - g.ymax};
      if (a.y == b.y) continue;  // horizontal edges never cross a row centre line
      // Rows whose centre y satisfies (a.y <= y) != (b.y <= y): y in [lo, hi).
      const double lo = std::min(a.y, b.y), hi = std::max(a.y, b.y);
      // local_y(row) = -(row + 0.5) * res, decreasing with row.
      // Clamped to the window while still doubles: an edge far away against the cell size
      // (1e20 cells) must not overflow the integer conversion.
      const double window_first = static_cast<double>(w.row0);
      const double window_last = static_cast<double>(w.row0 + w.height - 1);
      const auto r_first =
          static_cast<int64_t>(std::clamp(std::floor(-hi / g.res - 0.5) - 1.0, window_first, window_last + 1.0));
      const auto r_last =
          static_cast<int64_t>(std::clamp(std::ceil(-lo / g.res - 0.5) + 1.0, window_first - 1.0, window_last));
      for (int64_t r = r_first; r <= r_last; ++r) {
        const double y = g.local_y(r);
        if ((a.y <= y) == (b.y <= y)) continue;
        const double x = a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
        scratch.push_back(RingCrossing{r - w.row0, x});
      }
    }
  }
  std::sort(scratch.begin(), scratch.end(),
            [](const RingCrossing& p, const RingCrossing& q) { return p.row != q.row ? p.row < q.row : p.x < q.x; });
  for (size_t i = 0; i + 1 < scratch.size();) {
    const int64_t row = scratch[i].row;
    size_t j = i;
    while (j < scratch.size() && scratch[j].row == row) ++j;
    // Even-odd: centres in [x0, x1), [x2, x3), ... are inside.
    for (size_t k = i; k + 1 < j; k += 2) {
      int64_t c0 = first_column_at_or_after(g, scratch[k].x) - w.col0;
      int64_t c1 = first_column_at_or_after(g, scratch[k + 1].x) - w.col0;
      c0 = std::max<int64_t>(c0, 0);
      c1 = std::min<int64_t>(c1, w.width);
      if (c0 < c1) add(row, c0, c1);
    }
    i = j;
  }
}

int64_t InteriorSpans::cell_count() const {
  int64_t n = 0;
  for (const auto& row : rows)
    for (const Span& s : row) n += s.col1 - s.col0;
  return n;
}

bool InteriorSpans::empty() const {
  for (const auto& row : rows)
    if (!row.empty()) return false;
  return true;
}

bool InteriorSpans::covers(int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
  for (int64_t r = r0; r < r1; ++r) {
    const std::vector<Span>& row = rows[static_cast<size_t>(r)];
    // The last span starting at or before c0 must reach c1 (spans are disjoint and sorted).
    auto it = std::upper_bound(row.begin(), row.end(), c0, [](int64_t c, const Span& s) { return c < s.col0; });
    if (it == row.begin() || std::prev(it)->col1 < c1) return false;
  }
  return true;
}

InteriorSpans build_interiors(const SeedSet& seeds, const GridSpec& grid, const Window& window) {
  return build_interiors(seeds, seeds.polygons(), grid, window);
}

InteriorSpans build_interiors(const SeedSet& seeds, const std::vector<Polygon>& polygons, const GridSpec& grid,
                              const Window& window) {
  InteriorSpans result;
  result.window = window;
  result.rows.resize(static_cast<size_t>(window.height));
  if (polygons.empty()) return result;

  // (Unresolved: a polygon's spans may overlap other polygons'.)
  std::vector<RingCrossing> scratch;
  for (const Polygon& poly : polygons)
    ring_spans(poly.rings, grid, window, scratch, [&](int64_t row, int64_t c0, int64_t c1) {
      result.rows[static_cast<size_t>(row)].push_back(Span{c0, c1, poly.area_site});
    });

  // Resolve overlaps per row: the lowest area site wins each cell.
  for (auto& row : result.rows) {
    if (row.size() < 2) continue;
    std::sort(row.begin(), row.end(),
              [](const Span& a, const Span& b) { return a.site != b.site ? a.site < b.site : a.col0 < b.col0; });
    std::map<int64_t, Span> covered;  // col0 -> span, disjoint
    for (const Span& s : row) {
      int64_t c = s.col0;
      auto it = covered.upper_bound(c);
      if (it != covered.begin() && std::prev(it)->second.col1 > c) it = std::prev(it);
      while (c < s.col1) {
        if (it == covered.end() || it->second.col0 >= s.col1) {
          covered.emplace(c, Span{c, s.col1, s.site});
          break;
        }
        if (it->second.col0 > c) covered.emplace(c, Span{c, it->second.col0, s.site});
        const int64_t overlap_end = std::min(it->second.col1, s.col1);
        const int64_t overlap_begin = std::max(it->second.col0, c);
        if (overlap_end > overlap_begin && seeds.site_owner(it->second.site) != seeds.site_owner(s.site))
          result.contested_cells += overlap_end - overlap_begin;
        c = std::max(c, it->second.col1);
        ++it;
      }
    }
    row.clear();
    for (auto& [col0, span] : covered) {
      if (!row.empty() && row.back().col1 == span.col0 && row.back().site == span.site)
        row.back().col1 = span.col1;
      else
        row.push_back(span);
    }
  }
  return result;
}

}  // namespace rv
