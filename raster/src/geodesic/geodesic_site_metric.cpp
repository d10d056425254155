#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <utility>

#include "engine/engine_internal.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/geodesic/geodesic.hpp"

namespace rv {

struct GeodesicSiteMetric::Impl {
  Impl(const SeedSet& seeds, const MetricSpec& m, std::shared_ptr<const PreparedSeeds> p)
      : spec(m),
        measure(m),
        prepared(std::move(p)),
        geod(m.semi_major, m.flattening),
        earth(m.semi_major, m.flattening),
        // The largest radius of curvature of the ellipsoid (a^2/b at the poles when oblate,
        // a when prolate): no path moves faster in latitude or along a parallel than this.
        k_max(m.flattening >= 0.0 ? m.semi_major / (1.0 - m.flattening) : m.semi_major) {
    if (!prepared) own.emplace(m, seeds);
    sites = prepared ? &*prepared->geo : &*own;
  }
  MetricSpec spec;
  GeodesicMeasure measure;
  // Every site prepared once, as the engine prepares them (its segments' geodesic lines and
  // pieces): a segment's distance is then its search alone, where GeodesicMeasure prepares the
  // edge on every call (most of the boundaries' time went there), and the lines are measured by
  // the very arithmetic that decided the field. Its own, or the engine's, shared.
  std::optional<detail::GeoSites> own;
  std::shared_ptr<const PreparedSeeds> prepared;
  const detail::GeoSites* sites = nullptr;
  GeographicLib::Geodesic geod;
  GeographicLib::Geocentric earth;
  double k_max;
};

GeodesicSiteMetric::GeodesicSiteMetric(const SeedSet& seeds, const MetricSpec& metric)
    : SiteMetric(seeds), impl_(std::make_unique<Impl>(seeds, metric, nullptr)) {}

GeodesicSiteMetric::GeodesicSiteMetric(const SeedSet& seeds, const MetricSpec& metric,
                                       std::shared_ptr<const PreparedSeeds> prepared)
    : SiteMetric(seeds) {
  if (!prepared || prepared->seeds != &seeds || prepared->site_count != seeds.sites().size() || !prepared->geo ||
      !(prepared->metric == metric))
    throw Error(ErrorKind::invalid_argument, "a geodesic metric shares the sites prepared for its own seeds only");
  impl_ = std::make_unique<Impl>(seeds, metric, std::move(prepared));
}

GeodesicSiteMetric::~GeodesicSiteMetric() = default;

MetricSpec GeodesicSiteMetric::spec() const { return impl_->spec; }

double GeodesicSiteMetric::distance(Vec2 p, int32_t site) const {
  const Site& s = seeds().sites()[static_cast<size_t>(site)];
  switch (s.kind) {
    case SiteKind::point:
      return impl_->measure.point_distance(p, s.a);
    case SiteKind::segment:
      if (!(p.y >= -90.0 && p.y <= 90.0)) throw Error(ErrorKind::invalid_argument, "latitude outside [-90, 90]");
      return impl_->sites->distance(impl_->sites->cell(p.x, p.y), site);
    case SiteKind::area:
      break;
  }
  return inside_area(p, site) ? 0.0 : std::numeric_limits<double>::infinity();
}

bool GeodesicSiteMetric::ties_at_vertex(Vec2 p, int32_t site, const VertexHit& hit, double d) const {
  if (!hit.valid || seeds().sites()[static_cast<size_t>(site)].kind != SiteKind::segment) return false;
  if (!(p.y >= -90.0 && p.y <= 90.0)) return false;
  detail::GeoEnd end;
  end.valid = true;
  end.lat = hit.vertex.y;
  end.lon = hit.vertex.x;
  end.azi_to_cell = hit.direction;
  return impl_->sites->attains_at_vertex(impl_->sites->cell(p.x, p.y), site, end, d);
}

double GeodesicSiteMetric::distance_at_vertex(Vec2 p, int32_t site, Vec2& gradient, VertexHit& hit) const {
  hit = VertexHit{};
  const Site& s = seeds().sites()[static_cast<size_t>(site)];
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  gradient = Vec2{nan, nan};
  double d = 0.0, azi = nan;  // azi: the direction at p in which d grows fastest (degrees)
  switch (s.kind) {
    case SiteKind::point: {
      if (!(p.y >= -90.0 && p.y <= 90.0)) throw Error(ErrorKind::invalid_argument, "latitude outside [-90, 90]");
      // The inverse problem of distance() (GeodesicMeasure::point_distance), with its azimuths:
      // the same distance, to the bit; away from the point is the reverse of the way to it.
      double azi1 = 0.0, azi2 = 0.0;
      impl_->geod.Inverse(p.y, p.x, s.a.y, s.a.x, d, azi1, azi2);
      azi = azi1 + 180.0;
      break;
    }
    case SiteKind::segment: {
      if (!(p.y >= -90.0 && p.y <= 90.0)) throw Error(ErrorKind::invalid_argument, "latitude outside [-90, 90]");
      detail::GeoEnd end;
      d = impl_->sites->distance(impl_->sites->cell(p.x, p.y), site, &end);
      azi = end.azi_at_cell;
      if (end.valid) hit = VertexHit{true, Vec2{end.lon, end.lat}, end.azi_to_cell};
      break;
    }
    case SiteKind::area:
      return distance(p, site);
  }
  if (!(d > 0.0) || !std::isfinite(azi)) return d;
  gradient = impl_->measure.gradient(p, azi);
  return d;
}

double GeodesicSiteMetric::point_distance(Vec2 a, Vec2 b) const { return impl_->measure.point_distance(a, b); }

Vec3 GeodesicSiteMetric::embed(Vec2 p) const {
  Vec3 q;
  impl_->earth.Forward(std::clamp(p.y, -90.0, 90.0), p.x, 0.0, q.x, q.y, q.z);
  return q;
}

namespace {
Box3 ball_box(const Vec3& c, double r) { return Box3{c.x - r, c.y - r, c.z - r, c.x + r, c.y + r, c.z + r}; }
}  // namespace

Box3 GeodesicSiteMetric::site_bounds(int32_t site) const {
  const Site& s = seeds().sites()[static_cast<size_t>(site)];
  if (s.kind == SiteKind::point) return ball_box(embed(s.a), 0.0);
  if (s.kind == SiteKind::segment) {
    // Every point of the edge is within arc length l/2 of its middle point, and a chord is
    // never longer than the arc: the edge lies in the ball (middle, l/2).
    const GeographicLib::GeodesicLine line = impl_->geod.InverseLine(s.a.y, s.a.x, s.b.y, s.b.x);
    const double l = line.Distance();
    double lat = 0.0, lon = 0.0;
    line.Position(0.5 * l, lat, lon);
    return ball_box(embed(Vec2{lon, lat}), 0.5 * l * (1.0 + 1e-9) + 1e-6);
  }
  // An area: inside its vertices' longitude/latitude box (edges are straight in degrees). From
  // the box's centre C, any position Q of the box is reached by a meridian arc (at most
  // k_max * dlat) and a parallel arc (at most k_max * cos(lat) * dlon, lat the box's latitude
  // nearest the equator), so the box lies in the ball (C, that length).
  const Box3 v = vertex_box(site);
  const double rad = M_PI / 180.0;
  const double lat_c = 0.5 * (v.y0 + v.y1), lon_c = 0.5 * (v.x0 + v.x1);
  const double min_abs_lat = (v.y0 <= 0.0 && v.y1 >= 0.0) ? 0.0 : std::min(std::abs(v.y0), std::abs(v.y1));
  const double r = impl_->k_max * (0.5 * (v.y1 - v.y0) * rad + std::cos(min_abs_lat * rad) * 0.5 * (v.x1 - v.x0) * rad);
  return ball_box(embed(Vec2{lon_c, lat_c}), r * (1.0 + 1e-9) + 1e-6);
}

double GeodesicSiteMetric::distance_lower_bound(Vec2 p, int32_t site) const {
  double lb = 0.0;
  distance_lower_bounds(p, std::span<const int32_t>(&site, 1), std::span<double>(&lb, 1));
  return lb;
}

void GeodesicSiteMetric::distance_lower_bounds(Vec2 p, std::span<const int32_t> sites, std::span<double> out) const {
  // The chord bounds of the prepared sites (a point, or an edge's capsule: within millimetres of
  // the distance near a coast), less the engines' slack for their rounding; areas 0.
  const detail::GeoCell cell = impl_->sites->cell(p.x, std::clamp(p.y, -90.0, 90.0));
  for (size_t i = 0; i < sites.size(); ++i) {
    const int32_t site = sites[i];
    out[i] = seeds().sites()[static_cast<size_t>(site)].kind == SiteKind::area
                 ? 0.0
                 : std::max(impl_->sites->lower_bound(cell, site) - detail::kGeoSlack, 0.0);
  }
}

Vec2 GeodesicSiteMetric::nearest_point(Vec2 p, int32_t site) const {
  const Site& s = seeds().sites()[static_cast<size_t>(site)];
  if (s.kind == SiteKind::area) return p;
  if (s.kind == SiteKind::point) return s.a;
  if (!(p.y >= -90.0 && p.y <= 90.0)) throw Error(ErrorKind::invalid_argument, "latitude outside [-90, 90]");
  // Where distance()'s own search found the minimum: a vertex as given, or the foot on the edge.
  detail::GeoEnd end;
  impl_->sites->distance(impl_->sites->cell(p.x, p.y), site, &end);
  if (end.valid) return Vec2{end.lon, end.lat};
  double lat = 0.0, lon = 0.0;
  impl_->sites->position(site, end.foot, lat, lon);
  return Vec2{lon, lat};
}

}  // namespace rv

namespace rv {

LocatedGeodesicSiteMetric::LocatedGeodesicSiteMetric(const SeedSet& seeds, const MetricSpec& metric,
                                                     std::shared_ptr<const Geolocator> geolocator,
                                                     std::shared_ptr<const std::vector<Polygon>> grid_polygons)
    : SiteMetric(seeds, grid_polygons ? *grid_polygons : seeds.polygons()),
      grid_polygons_(std::move(grid_polygons)),
      geolocator_(std::move(geolocator)),
      geodesic_(seeds, metric),
      earth_radius_(std::max(metric.semi_major, metric.semi_major * (1.0 - metric.flattening))) {
  if (!geolocator_) throw Error(ErrorKind::invalid_argument, "LocatedGeodesicSiteMetric needs a geolocator");
  // Without grid polygons the base would test degrees against grid coordinates.
  if (!grid_polygons_ && !seeds.polygons().empty())
    throw Error(ErrorKind::invalid_argument,
                "LocatedGeodesicSiteMetric: the seeds have polygons, so their copies in "
                "the grid's CRS are needed");
}

Vec2 LocatedGeodesicSiteMetric::locate(Vec2 p) const {
  Vec2 q;
  detail::locate_centres(*geolocator_, &p.x, &p.y, &q.x, &q.y, 1);
  return q;
}

double LocatedGeodesicSiteMetric::distance(Vec2 p, int32_t site) const {
  if (seeds().sites()[static_cast<size_t>(site)].kind == SiteKind::area)
    return inside_area(p, site) ? 0.0 : std::numeric_limits<double>::infinity();  // grid polygons
  return geodesic_.distance(locate(p), site);
}

Vec2 LocatedGeodesicSiteMetric::nearest_point(Vec2 p, int32_t site) const {
  if (seeds().sites()[static_cast<size_t>(site)].kind == SiteKind::area) return p;
  const Vec2 q = geodesic_.nearest_point(locate(p), site);
  Vec2 out;
  geolocator_->to_grid(&q.x, &q.y, &out.x, &out.y, 1);
  return out;
}

double LocatedGeodesicSiteMetric::point_distance(Vec2 a, Vec2 b) const {
  return geodesic_.point_distance(locate(a), locate(b));
}

Vec3 LocatedGeodesicSiteMetric::embed(Vec2 p) const { return geodesic_.embed(locate(p)); }

double LocatedGeodesicSiteMetric::distance_lower_bound(Vec2 p, int32_t site) const {
  double lb = 0.0;
  distance_lower_bounds(p, std::span<const int32_t>(&site, 1), std::span<double>(&lb, 1));
  return lb;
}

void LocatedGeodesicSiteMetric::distance_lower_bounds(Vec2 p, std::span<const int32_t> sites,
                                                      std::span<double> out) const {
  // Located once for all the sites (areas: 0 there too, their inside test being in grid
  // coordinates).
  geodesic_.distance_lower_bounds(locate(p), sites, out);
}

Box3 LocatedGeodesicSiteMetric::site_bounds(int32_t site) const {
  if (seeds().sites()[static_cast<size_t>(site)].kind == SiteKind::area) {
    // The whole ellipsoid (every embedded position has |x|, |y|, |z| <= max(a, b)): a bound of
    // 0 that still has a finite centre for the index's tree building.
    const double r = earth_radius_ * 1.01;
    return Box3{-r, -r, -r, r, r, r};
  }
  // Points and edges are where the geodesic metric puts them, in longitude/latitude.
  return geodesic_.site_bounds(site);
}

}  // namespace rv
