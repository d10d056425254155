// The core's part of the regions' measures (rv/deliverables.hpp): the owner of a position by
// the engine's rule (owner_at) and the area a ring encloses (ring_area). Their edges come from
// region_edges (region_edges.cpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/PolygonArea.hpp>

#include "line_tools.hpp"
#include "rv/deliverables.hpp"
#include "rv/geolocate.hpp"

namespace rv {

using namespace line_tools;

int32_t owner_at(const OwnerIndex& index, Vec2 p, double max_distance) {
  const OwnerIndex::Hit hit = index.nearest(p);
  if (hit.site == kNoSite || hit.distance > max_distance) return 0;
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
