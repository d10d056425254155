// The core's part of regions bounded by the refined lines (rv/deliverables.hpp: region_edges,
// owner_at): the boundary lines carried from the outermost cell centres, where extraction stops,
// to the grid's edge, and the owner of a position by the engine's rule. The polygons themselves
// are made by the vector adaptor (write_line_regions), which has a geometry engine.
#include <algorithm>
#include <cmath>
#include <vector>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/PolygonArea.hpp>

#include "line_tools.hpp"
#include "rv/deliverables.hpp"
#include "rv/geolocate.hpp"

namespace rv {

using namespace line_tools;

namespace {

// The vertex on the grid's edge that continues a line ending at `end`, a point of the frame of
// the outermost cell centres: on the edge beyond it, where owners a and b are equidistant.
Vec2 edge_vertex(const OwnerIndex& index, const GridSpec& g, Vec2 end, int32_t a, int32_t b, double ftol) {
  const double x0 = g.xmin, x1 = g.xmax(), y0 = g.ymin(), y1 = g.ymax;
  Vec2 foot = end, along{0.0, 0.0};
  if (end.x == g.centre_x(0)) {
    foot.x = x0;
    along = {0.0, g.res};
  } else if (end.x == g.centre_x(g.width - 1)) {
    foot.x = x1;
    along = {0.0, g.res};
  } else if (end.y == g.centre_y(0)) {
    foot.y = y1;
    along = {g.res, 0.0};
  } else {
    foot.y = y0;
    along = {g.res, 0.0};
  }
  // The locus meets the edge within a cell of the foot (it crosses the half cell between the
  // centre frame and the edge): search that stretch, clamped to the edge.
  auto clamp = [&](Vec2 p) { return Vec2{std::clamp(p.x, x0, x1), std::clamp(p.y, y0, y1)}; };
  const Vec2 p0 = clamp(Vec2{foot.x - along.x, foot.y - along.y});
  const Vec2 p1 = clamp(Vec2{foot.x + along.x, foot.y + along.y});
  auto f = [&](double t) {
    const Vec2 p = lerp(p0, p1, t);
    return index.nearest_of(p, a).distance - index.nearest_of(p, b).distance;
  };
  const double f0 = f(0.0), f1 = f(1.0);
  if ((f0 < 0.0) == (f1 < 0.0) && f0 != 0.0 && f1 != 0.0) return foot;  // not bracketed: the foot
  return lerp(p0, p1, find_root(f, f0, f1, ftol, 1e-15));
}

bool on_centre_frame(const GridSpec& g, Vec2 p) {
  return p.x == g.centre_x(0) || p.x == g.centre_x(g.width - 1) || p.y == g.centre_y(0) ||
         p.y == g.centre_y(g.height - 1);
}

}  // namespace

RegionEdges region_edges(const BoundaryResult& boundaries, const OwnerIndex& index, const GridSpec& g) {
  const double ftol = 1e-9 * cell_metric(g, index.metric());
  auto at_tripoint = [&](Vec2 p) {
    return std::any_of(boundaries.tripoints.begin(), boundaries.tripoints.end(),
                       [&](const Tripoint& t) { return t.p == p; });
  };
  RegionEdges out;
  out.edges.reserve(boundaries.lines.size());
  for (const BoundaryLine& line : boundaries.lines) {
    std::vector<Vec2> pts;
    pts.reserve(line.vertices.size() + 2);
    for (const BoundaryVertex& v : line.vertices) pts.push_back(v.p);
    if (!line.closed && !pts.empty()) {
      const Vec2 first = pts.front(), last = pts.back();
      for (const Vec2 end : {first, last})
        if (!at_tripoint(end) && !on_centre_frame(g, end)) ++out.dangling_ends;
      if (on_centre_frame(g, last) && !at_tripoint(last))
        pts.push_back(edge_vertex(index, g, last, line.owner_a, line.owner_b, ftol));
      if (on_centre_frame(g, first) && !at_tripoint(first))
        pts.insert(pts.begin(), edge_vertex(index, g, first, line.owner_a, line.owner_b, ftol));
    }
    out.edges.push_back(std::move(pts));
  }
  return out;
}

int32_t owner_at(const OwnerIndex& index, Vec2 p) {
  const OwnerIndex::Hit hit = index.nearest(p);
  if (hit.site == kNoSite) return 0;
  const SeedSet& seeds = index.metric().seeds();
  const int32_t owner = seeds.site_owner(hit.site);
  // Inside polygons of several owners the engine decides for the lowest code.
  if (hit.distance == 0.0)
    for (int32_t o = 1; o < owner; ++o)
      if (index.nearest_of(p, o).distance == 0.0) return o;
  return owner;
}

double ring_area(std::span<const Vec2> ring, const MetricSpec& metric, const Geolocator* geolocator, double step) {
  const size_t n = ring.size();
  if (n < 3) return 0.0;
  if (metric.kind == MetricSpec::planar) {
    // Shoelace about the first vertex: large coordinates keep their precision.
    double twice = 0.0;
    const Vec2 o = ring[0];
    for (size_t i = 1; i + 1 < n; ++i)
      twice += (ring[i].x - o.x) * (ring[i + 1].y - o.y) - (ring[i + 1].x - o.x) * (ring[i].y - o.y);
    return std::abs(0.5 * twice);
  }
  // The edges are straight in the grid's CRS: followed in steps of at most `step` (a long edge of
  // the grid's outline along a parallel is not a geodesic).
  std::vector<double> xs, ys;
  for (size_t i = 0; i + 1 < n || (i + 1 == n && !(ring[n - 1] == ring[0])); ++i) {
    const Vec2 a = ring[i], b = ring[(i + 1) % n];
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    const auto pieces = static_cast<int64_t>(std::max(1.0, std::ceil(len / step)));
    for (int64_t k = 0; k < pieces; ++k) {
      const double t = static_cast<double>(k) / static_cast<double>(pieces);
      xs.push_back(a.x + t * (b.x - a.x));
      ys.push_back(a.y + t * (b.y - a.y));
    }
  }
  std::vector<double> lon(xs.size()), lat(ys.size());
  if (geolocator != nullptr) {
    geolocator->to_lonlat(xs.data(), ys.data(), lon.data(), lat.data(), xs.size());
  } else {
    lon = xs;
    lat = ys;
  }
  const GeographicLib::Geodesic geod(metric.semi_major, metric.flattening);
  GeographicLib::PolygonArea polygon(geod);
  for (size_t i = 0; i < lon.size(); ++i) polygon.AddPoint(lat[i], lon[i]);
  double perimeter = 0.0, area = 0.0;
  polygon.Compute(false, true, perimeter, area);
  return std::abs(area);
}

}  // namespace rv
