// The regions' faces against the cells (rv/lines/region_check.hpp). Each face is put on the
// rows as spans of the centres it holds, as the interiors of seed polygons are (ring_spans);
// every face edge marks the centres within the margin of it; then each run of one owner is
// compared with its owner's spans, all by column intervals, so that the work grows with the runs
// and the faces' edges, not with the cells.
#include "rv/lines/region_check.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <utility>

#include "rv/field/error.hpp"
#include "rv/field/interior.hpp"

namespace rv {

CellOwners::CellOwners(const GridSpec& grid)
    : grid_(grid), rows_(static_cast<size_t>(grid.height)), fed_(static_cast<size_t>(grid.height), 0) {}

void CellOwners::add_row(int64_t row, std::span<const int32_t> owners) {
  store(row, owners, [](int32_t owner) { return owner; });
}

void CellOwners::add_sites(int64_t row, std::span<const int32_t> sites, const SiteCodes& codes) {
  store(row, sites, [&codes](int32_t site) { return codes.code(site); });
}

int64_t CellOwners::rows_fed() const {
  int64_t n = 0;
  for (uint8_t f : fed_) n += f;
  return n;
}

namespace {

struct Interval {
  int64_t c0, c1;  // columns [c0, c1)
};
struct OwnerSpan {
  int32_t owner;
  int64_t c0, c1;
};

// Sorts and merges touching or overlapping intervals.
void merge(std::vector<Interval>& v) {
  std::sort(v.begin(), v.end(), [](const Interval& a, const Interval& b) { return a.c0 < b.c0; });
  size_t n = 0;
  for (const Interval& x : v) {
    if (n > 0 && x.c0 <= v[n - 1].c1)
      v[n - 1].c1 = std::max(v[n - 1].c1, x.c1);
    else
      v[n++] = x;
  }
  v.resize(n);
}

// Per row: the faces' spans by owner, and the centres near a face edge.
struct RowFaces {
  std::vector<std::vector<OwnerSpan>> spans;  // sorted by (owner, c0) when checked
  std::vector<std::vector<Interval>> near;    // merged
};

// The points of the line at height y within distance m of segment ab: [x0, x1], or none. The
// set within m of the segment is convex (the segment's two discs and the band between them), so
// its cut by the line is one interval: the hull of the discs' and the band's cuts.
std::optional<std::pair<double, double>> near_on_row(Vec2 a, Vec2 b, double m, double y) {
  double x0 = HUGE_VAL, x1 = -HUGE_VAL;
  auto take = [&](double x) {
    x0 = std::min(x0, x);
    x1 = std::max(x1, x);
  };
  for (const Vec2& p : {a, b}) {
    const double dy = std::abs(y - p.y);
    if (dy > m) continue;
    const double half = std::sqrt(m * m - dy * dy);
    take(p.x - half);
    take(p.x + half);
  }
  const double len = std::hypot(b.x - a.x, b.y - a.y);
  if (len > 0.0) {
    const Vec2 n{-(b.y - a.y) / len * m, (b.x - a.x) / len * m};
    const std::array<Vec2, 4> q{Vec2{a.x + n.x, a.y + n.y}, Vec2{b.x + n.x, b.y + n.y}, Vec2{b.x - n.x, b.y - n.y},
                                Vec2{a.x - n.x, a.y - n.y}};
    for (size_t i = 0; i < 4; ++i) {
      const Vec2 p = q[i], s = q[(i + 1) % 4];
      if (std::min(p.y, s.y) > y || std::max(p.y, s.y) < y) continue;
      if (p.y == s.y) {
        take(p.x);
        take(s.x);
      } else {
        take(p.x + (y - p.y) * (s.x - p.x) / (s.y - p.y));
      }
    }
  }
  if (x0 > x1) return std::nullopt;
  return std::pair<double, double>{x0, x1};
}

void add_face(const OwnedFace& face, const GridSpec& g, double margin, RowFaces& out,
              std::vector<RingCrossing>& scratch) {
  const double last_row = static_cast<double>(g.height - 1);
  // The rows whose centre's local y is in [lo, hi], and one more on each side.
  auto rows_between = [&](double lo, double hi) {
    const double first = std::clamp(std::floor(-hi / g.res - 0.5), -1.0, last_row + 1.0);
    const double last = std::clamp(std::ceil(-lo / g.res - 0.5), -1.0, last_row + 1.0);
    return std::pair<int64_t, int64_t>{static_cast<int64_t>(first), static_cast<int64_t>(last)};
  };
  for (const std::vector<Vec2>& ring : face.rings) {
    for (size_t i = 0; i < ring.size(); ++i) {
      const Vec2 a{ring[i].x - g.xmin, ring[i].y - g.ymax};
      const Vec2& rb = ring[(i + 1) % ring.size()];
      const Vec2 b{rb.x - g.xmin, rb.y - g.ymax};
      const double lo = std::min(a.y, b.y), hi = std::max(a.y, b.y);
      // The centres within the margin of the edge: on each row, an interval.
      const auto [n0, n1] = rows_between(lo - margin, hi + margin);
      for (int64_t r = std::max<int64_t>(n0, 0); r <= std::min(n1, g.height - 1); ++r) {
        const std::optional<std::pair<double, double>> x = near_on_row(a, b, margin, g.local_y(r));
        if (!x) continue;
        const int64_t c0 = std::max<int64_t>(first_column_at_or_after(g, x->first), 0);
        const int64_t c1 = std::min(first_column_at_or_after(g, std::nextafter(x->second, HUGE_VAL)), g.width);
        if (c0 < c1) out.near[static_cast<size_t>(r)].push_back(Interval{c0, c1});
      }
    }
  }
  // The centres inside the face, as seed polygons' interiors are found.
  ring_spans(face.rings, g, g.full_window(), scratch, [&](int64_t row, int64_t c0, int64_t c1) {
    out.spans[static_cast<size_t>(row)].push_back(OwnerSpan{face.owner, c0, c1});
  });
}

// The cells of [c0, c1) not in `near` (merged, sorted).
int64_t clear_cells(const std::vector<Interval>& near, int64_t c0, int64_t c1) {
  int64_t n = c1 - c0;
  auto it = std::upper_bound(near.begin(), near.end(), c0, [](int64_t c, const Interval& x) { return c < x.c1; });
  for (; it != near.end() && it->c0 < c1; ++it) n -= std::min(c1, it->c1) - std::max(c0, it->c0);
  return n;
}

bool in(const std::vector<Interval>& v, int64_t c) {
  auto it = std::upper_bound(v.begin(), v.end(), c, [](int64_t x, const Interval& i) { return x < i.c1; });
  return it != v.end() && it->c0 <= c;
}

// The owner of the first face span holding column c (0: none).
int32_t face_at(const std::vector<OwnerSpan>& spans, int64_t c) {
  for (const OwnerSpan& s : spans)
    if (s.c0 <= c && c < s.c1) return s.owner;
  return 0;
}

}  // namespace

RegionCellCheck check_regions_against_cells(std::span<const OwnedFace> faces, const CellOwners& cells, double margin) {
  const GridSpec& g = cells.grid();
  RowFaces rf;
  rf.spans.resize(static_cast<size_t>(g.height));
  rf.near.resize(static_cast<size_t>(g.height));
  std::vector<RingCrossing> scratch;
  for (const OwnedFace& f : faces) add_face(f, g, std::max(margin, 0.0), rf, scratch);
  RegionCellCheck out;
  std::vector<Interval> own;
  for (int64_t r = 0; r < g.height; ++r) {
    if (!cells.has(r)) continue;
    ++out.rows;
    std::vector<Interval>& near = rf.near[static_cast<size_t>(r)];
    merge(near);
    std::vector<OwnerSpan>& spans = rf.spans[static_cast<size_t>(r)];
    std::sort(spans.begin(), spans.end(), [](const OwnerSpan& a, const OwnerSpan& b) {
      return a.owner != b.owner ? a.owner < b.owner : a.c0 < b.c0;
    });
    const std::vector<CellOwners::Run>& runs = cells.row(r);
    for (size_t k = 0; k < runs.size(); ++k) {
      const int32_t o = runs[k].owner;
      if (o == 0) continue;
      const int64_t c0 = runs[k].col0, c1 = k + 1 < runs.size() ? runs[k + 1].col0 : g.width;
      const int64_t clear = clear_cells(near, c0, c1);
      out.near_edges += (c1 - c0) - clear;
      out.checked += clear;
      // The clear cells of the run inside its owner's faces (merged spans of that owner).
      own.clear();
      for (auto it = std::lower_bound(spans.begin(), spans.end(), o,
                                      [](const OwnerSpan&s, int32_t v) { return s.owner < v; });
           it != spans.end() && it->owner == o; ++it)
        if (it->c1 > c0 && it->c0 < c1) own.push_back(Interval{std::max(c0, it->c0), std::min(c1, it->c1)});
      merge(own);
      int64_t placed = 0;
      for (const Interval& x : own) placed += clear_cells(near, x.c0, x.c1);
      if (placed == clear) continue;
      out.misplaced += clear - placed;
      for (int64_t c = c0; c < c1 && out.first.size() < RegionCellCheck::kFirst; ++c)
        if (!in(near, c) && !in(own, c)) out.first.push_back({c, r, o, face_at(spans, c)});
    }
  }
  return out;
}

}  // namespace rv
