// The core's part of the regions' measures (rv/lines/regions.hpp): the owner of a position by
// the engine's rule (owner_at) and the area a ring encloses (ring_area). Their edges come from
// region_edges (region_edges.cpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/PolygonArea.hpp>

#include "lines/line_tools.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/field/geolocate.hpp"
#include "rv/lines/regions.hpp"

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

namespace {

// F(lat): the ellipsoid's area between the equator and latitude `lat` (radians) per radian of
// longitude, b^2/2 (sin(lat) / (1 - e^2 sin^2(lat)) + atanh(e sin(lat)) / e) (the authalic
// function q times a^2 / 2), so that a region's area is the line integral of -F d(lon) around it
// (Green's theorem over dA = M N cos(lat) d(lat) d(lon) = F'(lat) d(lat) d(lon)).
struct ZoneArea {
  double a2, b2_half, e2, e;
  explicit ZoneArea(const MetricSpec& m)
      : a2(m.semi_major * m.semi_major),
        b2_half(0.5 * a2 * (1.0 - m.flattening) * (1.0 - m.flattening)),
        e2(m.flattening * (2.0 - m.flattening)),
        e(std::sqrt(std::abs(e2))) {}
  double operator()(double lat) const {
    const double s = std::sin(lat);
    // The sphere's a^2 sin(lat) is the limit of both branches; below e^2 ~ 1e-12 their atanh / atan
    // terms lose every digit.
    if (std::abs(e2) < 1e-12) return a2 * s;
    const double odd = e2 > 0.0 ? std::atanh(e * s) / e : std::atan(e * s) / e;
    return b2_half * (s / (1.0 - e2 * s * s) + odd);
  }
};

}  // namespace

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
  // Edges closing the ring: the last vertex back to the first unless it repeats it.
  const size_t edges = ring[n - 1] == ring[0] ? n - 1 : n;
  if (geolocator == nullptr) {
    // Longitude/latitude grids: an edge is straight in degrees, and its share of the integral is
    // exact up to the quadrature's error: 3-point Gauss-Legendre on pieces of at most a degree of
    // latitude (F is smooth; its error there is below a square millimetre per piece). Measured
    // from F at the first vertex: the constant integrates to zero around the ring, and the terms
    // stay the size of the area, not of the zone from the equator.
    const ZoneArea zone(metric);
    constexpr double kRad = std::numbers::pi / 180.0;
    const double f0 = zone(ring[0].y * kRad);
    const double g = std::sqrt(0.6);
    double sum = 0.0;
    for (size_t i = 0; i < edges; ++i) {
      const Vec2 a = ring[i], b = ring[(i + 1) % n];
      if (a.x == b.x) continue;  // along a meridian: no share
      const auto pieces = static_cast<int>(std::max(1.0, std::ceil(std::abs(b.y - a.y))));
      const double dlat = (b.y - a.y) / pieces;
      double mean = 0.0;  // the mean of F - f0 along the edge
      for (int k = 0; k < pieces; ++k) {
        const double mid = a.y + (k + 0.5) * dlat;
        mean += (8.0 / 18.0) * (zone(mid * kRad) - f0) +
                (5.0 / 18.0) * (zone((mid - 0.5 * g * dlat) * kRad) - f0 + zone((mid + 0.5 * g * dlat) * kRad) - f0);
      }
      sum -= (b.x - a.x) * kRad * mean / pieces;
    }
    return std::abs(sum);
  }
  // Projected grids: the edges are straight in the grid's CRS, followed in steps of at most
  // `step` located on the ellipsoid and measured there as geodesics.
  std::vector<double> xs, ys;
  for (size_t i = 0; i < edges; ++i) {
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
  geolocator->to_lonlat(xs.data(), ys.data(), lon.data(), lat.data(), xs.size());
  const GeographicLib::Geodesic geod(metric.semi_major, metric.flattening);
  GeographicLib::PolygonArea polygon(geod);
  for (size_t i = 0; i < lon.size(); ++i) polygon.AddPoint(lat[i], lon[i]);
  double perimeter = 0.0, area = 0.0;
  polygon.Compute(false, true, perimeter, area);
  return std::abs(area);
}

SegmentBows::SegmentBows(const RegionEdges& e) {
  for (size_t k = 0; k < e.edges.size() && k < e.bows.size(); ++k) add(e.edges[k], e.bows[k]);
}

void SegmentBows::add(std::span<const Vec2> pts, std::span<const Bow> bows) {
  for (size_t i = 0; i + 1 < pts.size() && i < bows.size(); ++i)
    if (std::isfinite(bows[i].left)) bows_.emplace(Key{pts[i].x, pts[i].y, pts[i + 1].x, pts[i + 1].y}, bows[i]);
}

size_t SegmentBows::Hash::operator()(const Key& k) const {
  const std::hash<double> h;
  size_t x = h(k.px);
  for (const double v : {k.py, k.qx, k.qy}) x = x * 1000003u ^ h(v);
  return x;
}

std::optional<Bow> SegmentBows::of(Vec2 p, Vec2 q) const {
  auto it = bows_.find(Key{p.x, p.y, q.x, q.y});
  if (it != bows_.end()) return it->second;
  it = bows_.find(Key{q.x, q.y, p.x, p.y});
  if (it == bows_.end()) return std::nullopt;
  return Bow{-it->second.left, it->second.length};  // left of q -> p is right of p -> q
}

double ring_area(std::span<const Vec2> ring, const MetricSpec& metric, const Geolocator* geolocator, double step,
                 const SegmentBows& bows) {
  const double area = ring_area(ring, metric, geolocator, step);
  const size_t n = ring.size();
  if (n < 3 || bows.empty()) return area;
  // The ring's turn in the grid's CRS (every metric here keeps it): interior on the left of a
  // counter-clockwise ring, where a bow to the left takes area away.
  double twice = 0.0;
  const Vec2 o = ring[0];
  for (size_t i = 1; i + 1 < n; ++i)
    twice += (ring[i].x - o.x) * (ring[i + 1].y - o.y) - (ring[i + 1].x - o.x) * (ring[i].y - o.y);
  const double ccw = twice >= 0.0 ? 1.0 : -1.0;
  const size_t edges = ring[n - 1] == ring[0] ? n - 1 : n;
  double slivers = 0.0;
  for (size_t i = 0; i < edges; ++i) {
    const std::optional<Bow> b = bows.of(ring[i], ring[(i + 1) % n]);
    if (b) slivers -= ccw * (2.0 / 3.0) * b->left * b->length;
  }
  return area + slivers;
}

}  // namespace rv
