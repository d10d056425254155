// RelevantCoasts (rv/lines/relevant_coasts.hpp): the parts of the seeds nearest to the cells of a relevant
// area, strip by strip.
//
// Each row is examined once its neighbours are in (one row behind the last strip): a cell of the
// area whose site differs from a 4-neighbour's, or whose neighbour lies outside the area or the
// grid, is at the edge of its site's cells in the area, and only there can the site's extreme
// basepoints be (inside, the basepoint of a neighbour lies on both sides). Its basepoint is the
// metric's nearest point, placed along the site by its distance from the site's first end.
// By sea the basepoint is where the cell's path leaves the site: the straight foot where the cell
// sees it, else the start of the path to the last bend, the same for every cell behind that bend.
// It is not linear in the cell's position and jumps where two bends' cells meet (behind a barrier
// line, which leaves no land cells to make an edge), so the argument for the edge cells does not
// carry over, and every cell of the area is measured.
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <vector>

#include "lines/line_tools.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/lines/relevant_coasts.hpp"

namespace rv {

namespace {

// Whether the cell (c, r) lies in the area: its row's sorted spans.
bool in_spans(const std::vector<Span>& row, int64_t c) {
  auto it = std::upper_bound(row.begin(), row.end(), c, [](int64_t x, const Span& s) { return x < s.col1; });
  return it != row.end() && it->col0 <= c;
}

}  // namespace

struct RelevantCoasts::Impl {
  GridSpec g;
  const SiteMetric& metric;
  const InteriorSpans& area;
  const Geolocator* geolocator;
  int threads;
  int64_t have = 0;              // rows taken in
  std::vector<int32_t> rows[3];  // sites of rows have-3 .. have-1 (the last three)
  int64_t done = 0;              // rows examined
  struct Extent {
    double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
    Vec2 from, to;
  };
  std::unordered_map<int32_t, Extent> extents;

  Impl(const GridSpec& grid, const SiteMetric& m, const InteriorSpans& a, const Geolocator* geo, int t)
      : g(grid), metric(m), area(a), geolocator(geo), threads(resolve_threads(t)) {}

  // A site's first end where the metric's positions are (the grid's CRS on projected geodesic
  // grids, whose seeds are in longitude/latitude).
  Vec2 first_end(int32_t site) const {
    Vec2 a = metric.seeds().sites()[static_cast<size_t>(site)].a;
    if (geolocator != nullptr) {
      Vec2 x;
      geolocator->to_grid(&a.x, &a.y, &x.x, &x.y, 1);
      a = x;
    }
    return a;
  }

  const std::vector<int32_t>* row(int64_t r) const {
    if (r < 0 || r >= have || r < have - 3) return nullptr;
    return &rows[static_cast<size_t>(r % 3)];
  }

  bool inside(int64_t c, int64_t r) const {
    return c >= 0 && c < g.width && r >= 0 && r < g.height && in_spans(area.rows[static_cast<size_t>(r)], c);
  }

  // Row r's edge cells, their basepoints measured on the threads, the extents updated in order.
  void examine(int64_t r) {
    const std::vector<int32_t>& here = *row(r);
    const std::vector<int32_t>* up = row(r - 1);
    const std::vector<int32_t>* down = row(r + 1);
    const SeedSet& seeds = metric.seeds();
    const bool every_cell = !metric.straight();
    std::vector<int64_t> cols;
    for (const Span& span : area.rows[static_cast<size_t>(r)])
      for (int64_t c = span.col0; c < span.col1; ++c) {
        const int32_t s = here[static_cast<size_t>(c)];
        if (s == kNoSite || seeds.sites()[static_cast<size_t>(s)].kind == SiteKind::area) continue;
        if (every_cell) {
          cols.push_back(c);
          continue;
        }
        auto differs = [&](const std::vector<int32_t>* other, int64_t oc, int64_t orow) {
          return other == nullptr || !inside(oc, orow) || (*other)[static_cast<size_t>(oc)] != s;
        };
        if (differs(&here, c - 1, r) || differs(&here, c + 1, r) || differs(up, c, r - 1) || differs(down, c, r + 1))
          cols.push_back(c);
      }
    std::vector<std::pair<double, Vec2>> at(cols.size());
    detail::parallel_for(threads, static_cast<int64_t>(cols.size()), [&](int64_t k, int) {
      const int64_t c = cols[static_cast<size_t>(k)];
      const int32_t s = here[static_cast<size_t>(c)];
      const Vec2 foot = metric.nearest_point(Vec2{g.centre_x(c), g.centre_y(r)}, s);
      at[static_cast<size_t>(k)] = {metric.point_distance(first_end(s), foot), foot};
    });
    for (size_t k = 0; k < cols.size(); ++k) {
      Extent& e = extents[here[static_cast<size_t>(cols[k])]];
      const auto& [along, foot] = at[k];
      if (along < e.lo) {
        e.lo = along;
        e.from = foot;
      }
      if (along > e.hi) {
        e.hi = along;
        e.to = foot;
      }
    }
  }
};

RelevantCoasts::RelevantCoasts(const GridSpec& grid, const SiteMetric& metric, const InteriorSpans& area,
                               const Geolocator* geolocator, int threads)
    : impl_(std::make_unique<Impl>(grid, metric, area, geolocator, threads)) {
  if (!(area.window == grid.full_window()))
    throw Error(ErrorKind::invalid_argument, "relevant coasts: the area's spans must cover the whole grid");
}

RelevantCoasts::~RelevantCoasts() = default;

void RelevantCoasts::add(const NearestField& strip) {
  Impl& m = *impl_;
  const Window w = strip.site.window();
  if (!(strip.site.grid() == m.g) || w.col0 != 0 || w.width != m.g.width || w.row0 != m.have)
    throw Error(ErrorKind::invalid_argument, "relevant coasts: strips must be whole rows of the grid, in order");
  for (int64_t r = 0; r < w.height; ++r) {
    const int32_t* src = strip.site.row(r);
    m.rows[static_cast<size_t>(m.have % 3)].assign(src, src + m.g.width);
    ++m.have;
    // The row before this one has both its neighbours now.
    if (m.have >= 2) m.examine(m.have - 2);
    m.done = m.have - 1;
  }
}

std::vector<RelevantCoasts::Stretch> RelevantCoasts::take() {
  Impl& m = *impl_;
  if (m.have != m.g.height)
    throw Error(ErrorKind::invalid_argument, "relevant coasts asked for before the last row of the field");
  if (m.have >= 1 && m.done < m.have) {
    m.examine(m.have - 1);  // the last row: no row below
    m.done = m.have;
  }
  std::vector<Stretch> out;
  out.reserve(m.extents.size());
  for (const auto& [site, e] : m.extents)
    out.push_back(Stretch{site, e.from, e.to, m.metric.point_distance(e.from, e.to)});
  std::sort(out.begin(), out.end(), [](const Stretch& a, const Stretch& b) { return a.site < b.site; });
  m.extents.clear();
  return out;
}

}  // namespace rv
