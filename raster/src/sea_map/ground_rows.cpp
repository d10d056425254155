#include "sea_map/ground_rows.hpp"

#include <algorithm>
#include <utility>
#include <vector>

#include "rv/field/error.hpp"

namespace rv::sea {

GroundRows::GroundRows(const Prepared& p, const MetricSpec& metric, const GridSpec& grid, const Window& window)
    : p_(&p), grid_(grid), window_(window) {
  if (p.geodesic && p.geolocator) return;
  const bool geodesic = p.geodesic != nullptr;
  pieces_.emplace(grid, window, metric, geodesic);
  // Geodesic: the ends' longitudes and latitudes, which the exact predicates read the edge by.
  auto end = [&](Vec2 at) {
    if (!geodesic) return at;
    const int32_t v = p.vis.vertex_at(at);
    if (v < 0) throw Error(ErrorKind::internal, "a barrier edge's end is no barrier vertex");
    return p.vertex_ll[static_cast<size_t>(v)];
  };
  const Barriers& barriers = p.vis.barriers();
  for (const Barriers::Polygon& polygon : barriers.polygons())
    for (const Ring& ring : polygon.rings)
      for (size_t k = 0; k < ring.size(); ++k) pieces_->add_edge(end(ring[k]), end(ring[(k + 1) % ring.size()]), true);
  for (const Barriers::Line& line : barriers.lines())
    for (size_t k = 0; k + 1 < line.vertices.size(); ++k)
      pieces_->add_edge(end(line.vertices[k]), end(line.vertices[k + 1]), false);
  pieces_->index();
}

int64_t GroundRows::row(int64_t r, Visibility::Ground* out) const {
  if (!pieces_) throw Error(ErrorKind::internal, "GroundRows::row on a grid it does not draw");
  thread_local std::vector<RowPieces::Crossing> crossings;
  thread_local std::vector<std::pair<int64_t, int64_t>> bands;
  pieces_->row(r, 0, window_.width, crossings, bands);
  for_each_span(crossings, 0, window_.width, [&](int64_t first, int64_t end, int winding) {
    std::fill(out + first, out + end, winding >= 1 ? Visibility::Ground::land : Visibility::Ground::open_sea);
  });
  int64_t exact = 0;
  for (const auto& [first, last] : bands)
    for (int64_t c = first; c <= last; ++c, ++exact) out[c] = p_->vis.classify(p_->cell_spot(grid_, window_, r, c).at);
  return exact;
}

}  // namespace rv::sea
