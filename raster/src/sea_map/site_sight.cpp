#include "sea_map/site_sight.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "sea/visible_region.hpp"

namespace rv::sea {

namespace {

constexpr double kRadian = std::numbers::pi / 180.0;

// A site's region is drawn when it has at least this many cells per edge its sweep reads (a
// sweep and its drawing cost a few times a cell's proof per edge).
constexpr int64_t kCellsPerEdge = 4;
// Fewer cells than this many edges' worth: no sweep, whatever the edges (its box and its edges
// cost more than a few cells' proofs).
constexpr int64_t kFewestEdges = 64;

// Each site's cells in the window: the least and greatest column and row.
struct CellBox {
  int64_t c0 = std::numeric_limits<int64_t>::max(), c1 = -1, r0 = std::numeric_limits<int64_t>::max(), r1 = -1;
  int64_t cells = 0;
  bool empty() const { return c1 < 0; }
};

std::vector<CellBox> cell_boxes(const Raster<int32_t>& nearest, size_t sites) {
  std::vector<CellBox> boxes(sites);
  const Window w = nearest.window();
  for (int64_t r = 0; r < w.height; ++r) {
    int64_t c = 0;
    while (c < w.width) {
      const int32_t s = nearest.at(c, r);
      int64_t end = c + 1;
      while (end < w.width && nearest.at(end, r) == s) ++end;
      if (s >= 0 && static_cast<size_t>(s) < sites) {
        CellBox& b = boxes[static_cast<size_t>(s)];
        b.c0 = std::min(b.c0, c);
        b.c1 = std::max(b.c1, end - 1);
        b.r0 = std::min(b.r0, r);
        b.r1 = std::max(b.r1, r);
        b.cells += end - c;
      }
      c = end;
    }
  }
  return boxes;
}

}  // namespace

SiteSight::SiteSight(const Prepared& p, const MetricSpec& metric, const GridSpec& grid, const Window& window,
                     const Raster<int32_t>& nearest, const std::vector<EdgeIndex::Segment>& edges,
                     const EdgeIndex& index, int threads)
    : nearest_(&nearest), window_(window) {
  const size_t sites = p.local.size();
  rings_.resize(sites);
  if (p.geodesic && p.geolocator) return;
  const bool geodesic = p.geodesic != nullptr;
  const GeodesicFrame* frame = p.vis.frame();
  const std::vector<CellBox> boxes = cell_boxes(nearest, sites);
  // Each worker's edges near a box.
  struct Scratch {
    std::vector<int32_t> near;
    EdgeIndex::Stamps stamps;
  };
  std::vector<Scratch> scratch(static_cast<size_t>(std::max(1, threads)));
  enum : uint8_t { none, drawn, undrawn };
  std::vector<uint8_t> status(sites, none);
  // Plane units to cells: planar, the resolution; geodesic, a plane distance is at least the
  // distance on the ellipsoid (the gnomonic projection stretches), and a cell is at least this
  // many metres a side over the window (a sphere of the semi-minor axis, cos of the largest
  // latitude).
  double plane_per_cell = grid.res;
  if (geodesic) {
    const double lat =
        std::max(std::abs(grid.centre_y(window.row0)), std::abs(grid.centre_y(window.row0 + window.height - 1)));
    const double minor = metric.semi_major * (1.0 - metric.flattening);
    plane_per_cell = minor * grid.res * kRadian * std::cos(std::min(89.0, lat + grid.res) * kRadian);
  }
  // Each site's region on its own: the sites are shared out among the workers.
  detail::parallel_for(std::max(1, threads), static_cast<int64_t>(sites), [&](int64_t task, int worker) {
    const auto s = static_cast<size_t>(task);
    const CellBox& cells = boxes[s];
    if (cells.empty() || p.segment(static_cast<int32_t>(s))) return;
    status[s] = undrawn;
    if (cells.cells < kCellsPerEdge * kFewestEdges) return;  // (fewer cells than any sweep's worth)
    const Vec2 at{p.local[s].ax, p.local[s].ay};
    // The box round the site's cells (one cell more all round) and the site itself, in the plane:
    // geodesic, the images of points along its sides (parallels bend in the plane), widened by a
    // hundredth of its size.
    Vec2 lo = at, hi = at;
    auto take = [&](Vec2 x) {
      lo = {std::min(lo.x, x.x), std::min(lo.y, x.y)};
      hi = {std::max(hi.x, x.x), std::max(hi.y, x.y)};
    };
    const int64_t c0 = window.col0 + cells.c0 - 1, c1 = window.col0 + cells.c1 + 1;
    const int64_t r0 = window.row0 + cells.r0 - 1, r1 = window.row0 + cells.r1 + 1;
    if (!geodesic) {
      take({grid.local_x(c0), grid.local_y(r0)});
      take({grid.local_x(c1), grid.local_y(r1)});
    } else {
      // (Between samples a parallel's image strays from their chord by metres; the box is widened
      // by a hundredth of its size.)
      constexpr int kSides = 8;
      for (int k = 0; k <= kSides; ++k) {
        const double f = static_cast<double>(k) / kSides;
        const double lon = grid.centre_x(c0) + f * (grid.centre_x(c1) - grid.centre_x(c0));
        const double lat = grid.centre_y(r0) + f * (grid.centre_y(r1) - grid.centre_y(r0));
        take(frame->forward({lon, grid.centre_y(r0)}));
        take(frame->forward({lon, grid.centre_y(r1)}));
        take(frame->forward({grid.centre_x(c0), lat}));
        take(frame->forward({grid.centre_x(c1), lat}));
      }
    }
    const double widen = 0.01 * std::max(hi.x - lo.x, hi.y - lo.y) + 2.0 * plane_per_cell;
    lo = {lo.x - widen, lo.y - widen};
    hi = {hi.x + widen, hi.y + widen};
    Scratch& sc = scratch[static_cast<size_t>(worker)];
    index.edges_in_box(lo, hi, sc.stamps, sc.near);
    if (cells.cells < kCellsPerEdge * static_cast<int64_t>(sc.near.size())) return;  // (not worth a sweep)
    // A path to the site may reach it in any of its sea wedges (Place::wedge -1): drawn where
    // there is one (a port on a coast's edge or corner; its land wedges see nothing).
    Place from{at};
    from.vertex = p.vis.vertex_at(at);
    const Visibility::Star star = from.vertex >= 0 ? p.vis.vertex_star(from.vertex) : p.vis.star_at(at);
    if (star.wedges() > 1) {
      if (std::count(star.sea.begin(), star.sea.end(), uint8_t{1}) != 1) return;
      from.wedge = static_cast<int>(std::find(star.sea.begin(), star.sea.end(), uint8_t{1}) - star.sea.begin());
    }
    const VisibleRegion region = visible_region(p.vis, from, lo, hi, edges, &sc.near);
    if (region.blurred) return;
    // Twice the ring's margin and the frame's deviation, in cells.
    const double band = 2.0 * (region.margin + (frame ? frame->deviation() : 0.0)) / plane_per_cell;
    auto ring = std::make_unique<RowPieces>(grid, window, metric, geodesic);
    std::vector<Vec2> corners = region.ring;
    if (geodesic)
      for (Vec2& x : corners) x = frame->reverse(x);
    for (size_t k = 0; k < corners.size(); ++k)
      ring->add_edge(corners[k], corners[(k + 1) % corners.size()], true, band);
    ring->index();
    rings_[s] = std::move(ring);
    status[s] = drawn;
  });
  regions_ = std::count(status.begin(), status.end(), drawn);
  undrawn_ = std::count(status.begin(), status.end(), undrawn);
}

void SiteSight::row(int64_t r, Sight* out) const {
  thread_local std::vector<RowPieces::Crossing> crossings;
  thread_local std::vector<std::pair<int64_t, int64_t>> bands;
  const int64_t width = window_.width;
  int64_t c = 0;
  while (c < width) {
    const int32_t s = nearest_->at(c, r);
    int64_t end = c + 1;
    while (end < width && nearest_->at(end, r) == s) ++end;
    const RowPieces* ring =
        s >= 0 && static_cast<size_t>(s) < rings_.size() ? rings_[static_cast<size_t>(s)].get() : nullptr;
    if (!ring) {
      std::fill(out + c, out + end, unknown);
    } else {
      ring->row(r, c, end, crossings, bands);
      for_each_span(crossings, c, end, [&](int64_t first, int64_t stop, int winding) {
        std::fill(out + first, out + stop, winding >= 1 ? seen : hidden);
      });
      for (const auto& [first, last] : bands) std::fill(out + first, out + last + 1, unknown);
    }
    c = end;
  }
}

}  // namespace rv::sea
