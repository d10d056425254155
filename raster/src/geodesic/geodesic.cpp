// Geodesic measuring: prepared sites, the point-to-geodesic-segment iteration, and the bounds.
// See rv/geodesic/geodesic.hpp for the contract and geodesic_sites.hpp for the proofs of the bounds.
#include <GeographicLib/GeodesicLine.hpp>
#include <GeographicLib/Math.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "field/geodesic_sites.hpp"
#include "rv/field/error.hpp"
#include "rv/geodesic/geodesic.hpp"

namespace rv {

GeodesicSegmentCounters& geodesic_segment_counters() {
  thread_local GeodesicSegmentCounters counters;
  return counters;
}

namespace detail {
namespace {

using GeographicLib::Geodesic;
using GeographicLib::Math;

constexpr unsigned kLineCaps =
    Geodesic::LATITUDE | Geodesic::LONGITUDE | Geodesic::AZIMUTH | Geodesic::DISTANCE_IN | Geodesic::DISTANCE;
constexpr int kMaxIterations = 100;
// Cosine of the largest central angle between a cell and a piece's middle for which the fast
// (convex) path is used. The distance along a geodesic is convex while the geodesic scale M12
// stays positive (~90 degrees on the sphere; ellipsoidal corrections are ~f, i.e. ~0.2 degree).
// 80 degrees, minus the piece's half-length (< 0.45 degree), leaves a wide margin.
const double kConvexCos = std::cos(80.0 * Math::pi() / 180.0);
// attains_at_vertex() needs the distance to grow into the edge with at least this slope
// (|cos w| > 0.01: the geodesic to the cell leaves the vertex > 0.57 degree beyond square), and
// the cell at least this far from the vertex, so that the search cannot stop before reaching
// the vertex (its convergence test needs |step cos w| ~ s cos^2 w < 2e-10 m).
constexpr double kVertexMinSlope = 0.01;
constexpr double kVertexMinDistance = 1e-3;  // metres
// Chord length beyond which the angular (far-field) lower bound is also computed.
constexpr double kFarChord = 1e6;  // metres

void check_metric(const MetricSpec& metric) {
  if (metric.kind != MetricSpec::geodesic)
    throw Error(ErrorKind::invalid_argument, "geodesic measuring needs a geodesic metric spec");
  validate_metric(metric);
}

}  // namespace

GeoSites::GeoSites(const MetricSpec& metric, const SeedSet& seeds)
    : geod_((check_metric(metric), metric.semi_major), metric.flattening),
      a_(metric.semi_major),
      e2_(metric.flattening * (2.0 - metric.flattening)) {
  prepare(seeds.sites(), &seeds);
}

GeoSites::GeoSites(const MetricSpec& metric, const std::vector<Site>& sites)
    : geod_((check_metric(metric), metric.semi_major), metric.flattening),
      a_(metric.semi_major),
      e2_(metric.flattening * (2.0 - metric.flattening)) {
  prepare(sites, nullptr);
}

void GeoSites::ecef(double lat, double lon, double& x, double& y, double& z) const {
  double sphi, cphi, slam, clam;
  Math::sincosd(lat, sphi, cphi);
  Math::sincosd(lon, slam, clam);
  const double n = a_ / std::sqrt(1.0 - e2_ * sphi * sphi);
  x = n * cphi * clam;
  y = n * cphi * slam;
  z = n * (1.0 - e2_) * sphi;
}

GeoCell GeoSites::cell(double lon, double lat) const {
  GeoCell c{lat, lon, 0.0, 0.0, 0.0};
  ecef(lat, lon, c.x, c.y, c.z);
  return c;
}

void GeoSites::prepare(const std::vector<Site>& sites, const SeedSet* seeds) {
  // Meridional radius of curvature a(1-e^2)/(1-e^2 sin^2)^(3/2): largest at the poles for an
  // oblate ellipsoid (a^2/b), at the equator for a prolate one (a(1-e^2) = b^2/a).
  const double b = a_ * std::sqrt(1.0 - e2_);
  max_meridian_radius_ = std::max(a_ * a_ / b, b * b / a_) * (1.0 + 1e-12);
  inner_radius_ = std::min(a_, b) * (1.0 - 1e-12);
  sites_.resize(sites.size());
  for (size_t i = 0; i < sites.size(); ++i) {
    const Site& s = sites[i];
    GeoSite& g = sites_[i];
    if (s.kind == SiteKind::area) continue;
    for (const Vec2& v : {s.a, s.b}) {
      if (!(v.y >= -90.0 && v.y <= 90.0) || !std::isfinite(v.x)) {
        std::string where = seeds ? seeds->features()[static_cast<size_t>(s.feature)].source.str() : std::string();
        if (where.empty()) where = "feature " + std::to_string(s.feature);
        throw Error(ErrorKind::invalid_input,
                    where + ": latitude " + std::to_string(v.y) +
                        " outside [-90, 90] (geodesic metric: coordinates must be longitude, latitude in degrees)");
      }
    }
    g.lat = s.a.y;
    g.lon = s.a.x;
    ecef(g.lat, g.lon, g.x, g.y, g.z);
    if (s.kind != SiteKind::segment) continue;
    GeographicLib::GeodesicLine line = geod_.InverseLine(s.a.y, s.a.x, s.b.y, s.b.x, kLineCaps);
    const double length = line.Distance();
    if (!(length > 0.0)) continue;  // the two ends are one place (e.g. lon 180 and -180): a point
    g.segment = true;
    g.lat_b = s.b.y;
    g.lon_b = s.b.x;
    g.length = length;
    g.azi_a = line.Azimuth();
    {
      double lat_end, lon_end;
      line.Position(length, lat_end, lon_end, g.azi_b);
    }
    g.line = static_cast<int32_t>(lines_.size());
    lines_.push_back(line);
    const int n = std::max(1, static_cast<int>(std::ceil(length / kGeoPieceLength)));
    g.piece0 = static_cast<int32_t>(pieces_.size());
    g.piece_count = n;
    double prev_x = g.x, prev_y = g.y, prev_z = g.z;
    for (int k = 0; k < n; ++k) {
      GeoPiece p;
      p.ta = length * k / n;
      p.tb = k + 1 == n ? length : length * (k + 1) / n;
      p.ax = prev_x;
      p.ay = prev_y;
      p.az = prev_z;
      double lat, lon;
      line.Position(p.tb, lat, lon);
      ecef(lat, lon, p.bx, p.by, p.bz);
      prev_x = p.bx;
      prev_y = p.by;
      prev_z = p.bz;
      line.Position(0.5 * (p.ta + p.tb), lat, lon);
      ecef(lat, lon, p.ball.x, p.ball.y, p.ball.z);
      // Half the arc length, plus room for rounding of the middle point's ECEF position.
      const double l = (p.tb - p.ta) * (1.0 + 1e-12) + 1e-6;
      p.ball.r = 0.5 * l;
      const double ux = p.bx - p.ax, uy = p.by - p.ay, uz = p.bz - p.az;
      const double c2 = ux * ux + uy * uy + uz * uz;
      p.inv_len2 = c2 > 0.0 ? 1.0 / c2 : 0.0;
      // Capsule radius (see geodesic_sites.hpp); l - c gets 1e-6 m of room for the rounding of
      // c (ECEF ends, ~1e-9 m) and of the arc length (GeographicLib, ~1e-8 m).
      const double c = std::sqrt(c2);
      const double excess = std::max(l - c, 0.0) + 1e-6;
      p.capsule = std::sqrt(0.25 * excess * excess + 0.25 * excess * (l + c)) + 1e-6;
      pieces_.push_back(p);
    }
  }
}

double GeoSites::angular_bound(double x, double y, double z, double qx, double qy, double qz, double h,
                               double radius) const {
  const double cx = y * qz - z * qy, cy = z * qx - x * qz, cz = x * qy - y * qx;
  const double angle = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), x * qx + y * qy + z * qz);
  const double norm = std::sqrt(x * x + y * y + z * z);
  const double spread = h > 0.0 ? std::asin(std::min(1.0, h / norm)) : 0.0;
  // 1e-12 rad of room for the rounding of atan2 and asin (6e-6 m at the Earth's radius).
  return inner_radius_ * (angle - spread - 1e-12) - radius;
}

double GeoSites::point_lower_bound(double sx, double sy, double sz, double x, double y, double z, double h) const {
  const double chord = std::sqrt((x - sx) * (x - sx) + (y - sy) * (y - sy) + (z - sz) * (z - sz)) - h;
  if (!(chord > kFarChord)) return chord;
  return std::max(chord, angular_bound(x, y, z, sx, sy, sz, h, 0.0));
}

double GeoSites::piece_lower_bound(const GeoPiece& p, double x, double y, double z, double h) const {
  const double chord = piece_chord_bound(p, x, y, z) - h;
  if (!(chord > kFarChord)) return chord;
  return std::max(chord, angular_bound(x, y, z, p.ball.x, p.ball.y, p.ball.z, h, p.ball.r));
}

double GeoSites::lower_bound(const GeoCell& p, int32_t id) const {
  const GeoSite& s = sites_[static_cast<size_t>(id)];
  if (!s.segment) return std::max(point_lower_bound(s.x, s.y, s.z, p.x, p.y, p.z, 0.0), 0.0);
  double lb = std::numeric_limits<double>::infinity();
  for (int32_t k = s.piece0; k < s.piece0 + s.piece_count; ++k)
    lb = std::min(lb, piece_lower_bound(pieces_[static_cast<size_t>(k)], p.x, p.y, p.z, 0.0));
  return std::max(lb, 0.0);
}

double GeoSites::lower_bound(const EcefBox& box, const BoxBall& ball, int32_t id) const {
  const GeoSite& s = sites_[static_cast<size_t>(id)];
  // The box is also used as a ball around its centre (half-diagonal h): every cell of it is
  // within h of the centre. The direct box distance is another valid chord bound.
  const double cx = ball.x, cy = ball.y, cz = ball.z, half = ball.half;
  if (!s.segment)
    return std::max(std::max(box_distance(box, s.x, s.y, s.z), point_lower_bound(s.x, s.y, s.z, cx, cy, cz, half)),
                    0.0);
  double lb = std::numeric_limits<double>::infinity();
  for (int32_t k = s.piece0; k < s.piece0 + s.piece_count; ++k) {
    const GeoPiece& piece = pieces_[static_cast<size_t>(k)];
    const double from_ball = box_distance(box, piece.ball.x, piece.ball.y, piece.ball.z) - piece.ball.r;
    const double from_centre = piece_lower_bound(piece, cx, cy, cz, half);
    lb = std::min(lb, std::max(from_ball, from_centre));
  }
  return std::max(lb, 0.0);
}

double GeoSites::distance(const GeoCell& p, int32_t id, GeoEnd* end) const {
  const GeoSite& s = sites_[static_cast<size_t>(id)];
  if (end) *end = GeoEnd{};
  if (!s.segment) {
    double d;
    geod_.Inverse(p.lat, p.lon, s.lat, s.lon, d);
    return d;
  }
  if (s.piece_count == 1) return piece_distance(p, s, pieces_[static_cast<size_t>(s.piece0)], end);
  // Several pieces: search the one whose bound is nearest first, then only the pieces that can
  // still be nearer (their lower bound below the best distance so far).
  int32_t first = s.piece0;
  double first_lb = std::numeric_limits<double>::infinity();
  for (int32_t k = s.piece0; k < s.piece0 + s.piece_count; ++k) {
    const double lb = piece_lower_bound(pieces_[static_cast<size_t>(k)], p.x, p.y, p.z, 0.0);
    if (lb < first_lb) {
      first_lb = lb;
      first = k;
    }
  }
  GeoEnd piece_end;
  double best = piece_distance(p, s, pieces_[static_cast<size_t>(first)], end);
  for (int32_t k = s.piece0; k < s.piece0 + s.piece_count; ++k) {
    if (k == first) continue;
    const GeoPiece& piece = pieces_[static_cast<size_t>(k)];
    if (piece_lower_bound(piece, p.x, p.y, p.z, 0.0) > best + kGeoSlack) continue;
    const double d = piece_distance(p, s, piece, end ? &piece_end : nullptr);
    if (d < best) {
      best = d;
      if (end) *end = piece_end;
    }
  }
  return best;
}

bool GeoSites::convex_regime(const GeoCell& p, const GeoPiece& piece) const {
  // Central angle between the cell and the piece's middle.
  const GeoBall& mid = piece.ball;
  const double dot = p.x * mid.x + p.y * mid.y + p.z * mid.z;
  // Plain square roots: ECEF coordinates (~6.4e6 m) square without overflow, and the three-
  // argument std::hypot costs more than the rest of this test.
  const double norms = std::sqrt((p.x * p.x + p.y * p.y + p.z * p.z) * (mid.x * mid.x + mid.y * mid.y + mid.z * mid.z));
  return dot > kConvexCos * norms;
}

void GeoSites::position(int32_t id, double t, double& lat, double& lon) const {
  const GeoSite& s = sites_[static_cast<size_t>(id)];
  if (!s.segment || t <= 0.0) {
    lat = s.lat;
    lon = s.lon;
  } else if (t >= s.length) {
    lat = s.lat_b;
    lon = s.lon_b;
  } else {
    lines_[static_cast<size_t>(s.line)].Position(t, lat, lon);
  }
}

bool GeoSites::attains_at_vertex(const GeoCell& p, int32_t id, const GeoEnd& end, double s) const {
  const GeoSite& k = sites_[static_cast<size_t>(id)];
  if (!end.valid || !k.segment || k.piece_count != 1 || !(s > kVertexMinDistance)) return false;
  double azi;
  double sign;
  if (k.lat == end.lat && k.lon == end.lon) {
    azi = k.azi_a;  // leaving the vertex into the edge
    sign = -1.0;
  } else if (k.lat_b == end.lat && k.lon_b == end.lon) {
    azi = k.azi_b;  // arriving at the vertex along the edge
    sign = 1.0;
  } else {
    return false;
  }
  if (!convex_regime(p, pieces_[static_cast<size_t>(k.piece0)])) return false;
  double sin_w, cos_w;
  Math::sincosd(Math::AngDiff(azi, end.azi_to_cell), sin_w, cos_w);
  // The distance grows into the edge from the vertex with slope >= kVertexMinSlope; by
  // convexity it grows everywhere along the edge, and the search (see piece_distance) then
  // always ends by evaluating that vertex and returns its canonical distance.
  return sign * cos_w > kVertexMinSlope;
}

// The minimum over t in [ta, tb] of the geodesic distance from X(t) (on the site's line) to p.
//
// One evaluation at t: X(t) and its azimuth from the line, then the inverse problem X -> P,
// giving s, the azimuth w of the geodesic to P relative to the line, m12 and M12. By the first
// variation formula ds/dt = -cos w; the interception step dt = m12 cos w / M12 is the foot of the
// perpendicular in the plane (m12 = s, M12 = 1) and Newton-like on the ellipsoid. The bracket
// [lo, hi] holds the minimiser of the convex function (cos w > 0: it lies ahead); steps leaving
// it, or unusable steps (m12 <= 0 or M12 <= 0), become bisections.
//
// Canonical ends: at the segment's own ends X is the vertex as given (not a position computed
// along the line), and when the minimiser is pinned at such an end the result is the distance
// evaluated there. Two edges sharing a vertex then return the same bits when both are nearest
// at it, which lets the exact method settle such ties without searching the second edge.
double GeoSites::piece_distance(const GeoCell& p, const GeoSite& site, const GeoPiece& piece, GeoEnd* end) const {
  GeodesicSegmentCounters& counters = geodesic_segment_counters();
  ++counters.calls;
  if (end) *end = GeoEnd{};
  const GeographicLib::GeodesicLine& line = lines_[static_cast<size_t>(site.line)];
  const bool first_piece = piece.ta == 0.0;
  const bool last_piece = piece.tb == site.length;
  double best = std::numeric_limits<double>::infinity();
  struct Eval {
    double s, cos_w, step, azi_to_cell;
    bool usable;
  };
  auto eval = [&](double t) {
    ++counters.evaluations;
    double lat, lon, azi;
    if (t == piece.ta && first_piece) {
      lat = site.lat;
      lon = site.lon;
      azi = site.azi_a;
    } else if (t == piece.tb && last_piece) {
      lat = site.lat_b;
      lon = site.lon_b;
      azi = site.azi_b;
    } else {
      line.Position(t, lat, lon, azi);
    }
    double s, azi1, azi2, m12, M12, M21;
    geod_.Inverse(lat, lon, p.lat, p.lon, s, azi1, azi2, m12, M12, M21);
    double sin_w, cos_w;
    Math::sincosd(Math::AngDiff(azi, azi1), sin_w, cos_w);
    const bool usable = m12 > 0.0 && M12 > 0.0;
    const double step = usable ? m12 * cos_w / M12 : 0.0;
    if (s < best && end) {
      end->sin_w = sin_w;
      end->azi_at_cell = azi2;
      // The nearest point: this one moved by its own interception step (the search stops before
      // taking the last, millimetres at most), kept on the piece.
      end->foot = std::clamp(t + step, piece.ta, piece.tb);
    }
    best = std::min(best, s);
    return Eval{s, cos_w, step, azi1, usable};
  };
  // The result when the minimiser is pinned at an end: that end's value (canonical at vertices).
  auto at_end = [&](const Eval& e, bool second) {
    if (end && (second ? last_piece : first_piece)) {
      end->valid = true;
      end->lat = second ? site.lat_b : site.lat;
      end->lon = second ? site.lon_b : site.lon;
      end->azi_to_cell = e.azi_to_cell;
    }
    return e.s;
  };

  double lo = piece.ta, hi = piece.tb;
  bool lo_seen = false, hi_seen = false;
  Eval e_lo{}, e_hi{};
  double t;
  if (convex_regime(p, piece)) {
    // Start at the projection of P on the chord of the piece (a close guess for short pieces).
    const double ux = piece.bx - piece.ax, uy = piece.by - piece.ay, uz = piece.bz - piece.az;
    const double len2 = ux * ux + uy * uy + uz * uz;
    double u = len2 > 0.0 ? ((p.x - piece.ax) * ux + (p.y - piece.ay) * uy + (p.z - piece.az) * uz) / len2 : 0.0;
    u = std::clamp(u, 0.0, 1.0);
    t = piece.ta + u * (piece.tb - piece.ta);
  } else {
    // Far from the piece (beyond ~80 degrees) the distance along it need not be convex: the
    // minimum is at an end unless the ends' slopes bracket an interior critical point.
    const Eval ea = eval(piece.ta);
    const Eval eb = eval(piece.tb);
    if (ea.s == 0.0 || eb.s == 0.0) return 0.0;
    if (!(ea.cos_w > 0.0 && eb.cos_w < 0.0)) return eb.s < ea.s ? at_end(eb, true) : at_end(ea, false);
    lo_seen = hi_seen = true;
    e_lo = ea;
    e_hi = eb;
    t = 0.5 * (lo + hi);
  }
  for (int it = 0; it < kMaxIterations; ++it) {
    const Eval e = eval(t);
    if (e.s == 0.0) return 0.0;
    if (e.cos_w > 0.0) {
      lo = t;
      lo_seen = true;
      e_lo = e;
    } else if (e.cos_w < 0.0) {
      hi = t;
      hi_seen = true;
      e_hi = e;
    } else {
      return best;  // stationary
    }
    if (hi - lo <= 1e-9 + 1e-15 * hi) break;  // minimiser pinned to a nanometre (or at an end)
    if (e.usable && std::abs(e.step * e.cos_w) < 2.0 * kGeoConvergence) return best;
    double next = t + e.step;
    if (!e.usable || !(next > lo && next < hi)) {
      // Outside the bracket: try the bracket's end once (the minimum may sit at a segment end),
      // otherwise bisect.
      if (e.usable && next >= hi && !hi_seen) {
        next = hi;
      } else if (e.usable && next <= lo && !lo_seen) {
        next = lo;
      } else {
        next = 0.5 * (lo + hi);
      }
    }
    t = next;
  }
  if (hi_seen && hi == piece.ta) return at_end(e_hi, false);  // collapsed at the first end
  if (lo_seen && lo == piece.tb) return at_end(e_lo, true);   // collapsed at the second end
  // Pinned next to an end that was not evaluated yet: evaluate it, so that a minimiser at the
  // end gives the end's (canonical) value.
  if (lo == piece.ta && !lo_seen) {
    const Eval e = eval(piece.ta);
    if (e.cos_w <= 0.0) return at_end(e, false);
  } else if (hi == piece.tb && !hi_seen) {
    const Eval e = eval(piece.tb);
    if (e.cos_w >= 0.0) return at_end(e, true);
  }
  return best;
}

}  // namespace detail

struct GeodesicMeasure::Impl {
  MetricSpec metric;
  GeographicLib::Geodesic geod;
};

namespace {

constexpr double kRad = std::numbers::pi / 180.0;

// The radii of curvature at latitude `lat` (degrees), metres: across the meridian (N: a degree of
// longitude is N cos(lat) kRad metres) and along it (M: a degree of latitude is M kRad metres).
Vec2 radii(const GeographicLib::Geodesic& g, double lat) {
  const double a = g.EquatorialRadius(), f = g.Flattening(), e2 = f * (2.0 - f);
  const double sphi = std::sin(lat * kRad), w2 = 1.0 - e2 * sphi * sphi;
  return Vec2{a / std::sqrt(w2), a * (1.0 - e2) / (w2 * std::sqrt(w2))};
}

}  // namespace

GeodesicMeasure::GeodesicMeasure(const MetricSpec& metric) {
  if (metric.kind != MetricSpec::geodesic)
    throw Error(ErrorKind::invalid_argument, "GeodesicMeasure needs a geodesic metric spec");
  validate_metric(metric);
  impl_ = std::make_unique<Impl>(Impl{metric, GeographicLib::Geodesic(metric.semi_major, metric.flattening)});
}
GeodesicMeasure::~GeodesicMeasure() = default;
GeodesicMeasure::GeodesicMeasure(GeodesicMeasure&&) noexcept = default;
GeodesicMeasure& GeodesicMeasure::operator=(GeodesicMeasure&&) noexcept = default;

double GeodesicMeasure::point_distance(Vec2 p, Vec2 q) const {
  if (!(p.y >= -90.0 && p.y <= 90.0 && q.y >= -90.0 && q.y <= 90.0))
    throw Error(ErrorKind::invalid_argument, "latitude outside [-90, 90]");
  double d;
  impl_->geod.Inverse(p.y, p.x, q.y, q.x, d);
  return d;
}

double GeodesicMeasure::point_distance(Vec2 p, Vec2 q, Vec2& gradient) const {
  if (!(p.y >= -90.0 && p.y <= 90.0 && q.y >= -90.0 && q.y <= 90.0))
    throw Error(ErrorKind::invalid_argument, "latitude outside [-90, 90]");
  double d, azi1, azi2;
  impl_->geod.Inverse(p.y, p.x, q.y, q.x, d, azi1, azi2);
  gradient = d > 0.0 ? this->gradient(p, azi1 + 180.0)
                     : Vec2{std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  return d;
}

std::vector<Vec2> GeodesicMeasure::chords(Vec2 a, Vec2 b, double tolerance, const Geolocator* grid) const {
  if (!(a.y >= -90.0 && a.y <= 90.0 && b.y >= -90.0 && b.y <= 90.0))
    throw Error(ErrorKind::invalid_argument, "latitude outside [-90, 90]");
  if (!(tolerance > 0.0)) throw Error(ErrorKind::invalid_argument, "a chord tolerance must be above 0");
  const GeographicLib::Geodesic& g = impl_->geod;
  const GeographicLib::GeodesicLine line = g.InverseLine(a.y, a.x, b.y, b.x);
  const double length = line.Distance();
  auto at = [&](double s) {
    if (s <= 0.0) return a;
    if (s >= length) return b;
    double lat, lon;
    line.Position(s, lat, lon);
    return Vec2{a.x + std::remainder(lon - a.x, 360.0), lat};
  };
  // How far m (on the geodesic) lies from the chord p-q: the chord's point nearest to m in the
  // plane the chord is straight in (longitude/latitude scaled to metres at m, or the grid's CRS),
  // measured back on the ellipsoid. (Not the distance to the chord's midpoint: along a meridian
  // the geodesic's middle is not the latitudes' middle, though the chord is the geodesic.)
  auto off_chord = [&](Vec2 p, Vec2 q, Vec2 m) {
    Vec2 pp, qq, mm;
    if (grid) {
      const double lon[3] = {p.x, q.x, m.x}, lat[3] = {p.y, q.y, m.y};
      double x[3], y[3];
      grid->to_grid(lon, lat, x, y, 3);
      pp = {x[0], y[0]};
      qq = {x[1], y[1]};
      mm = {x[2], y[2]};
    } else {
      const Vec2 r = radii(g, m.y);
      const double sx = r.x * std::cos(m.y * kRad) * kRad, sy = r.y * kRad;
      pp = {(p.x - m.x) * sx, (p.y - m.y) * sy};
      qq = {(q.x - m.x) * sx, (q.y - m.y) * sy};
      mm = {0.0, 0.0};
    }
    const double dx = qq.x - pp.x, dy = qq.y - pp.y, l2 = dx * dx + dy * dy;
    const double u = l2 > 0.0 ? std::clamp(((mm.x - pp.x) * dx + (mm.y - pp.y) * dy) / l2, 0.0, 1.0) : 0.0;
    Vec2 foot;
    if (grid) {
      const double fx = pp.x + u * dx, fy = pp.y + u * dy;
      grid->to_lonlat(&fx, &fy, &foot.x, &foot.y, 1);
      foot.x = m.x + std::remainder(foot.x - m.x, 360.0);
    } else {
      foot = {p.x + u * (q.x - p.x), p.y + u * (q.y - p.y)};
    }
    return point_distance(m, foot);
  };
  std::vector<Vec2> out{a};
  if (a == b) return out;
  // Depth first from the start, so the points come out in order: (s0, s1, its end point).
  struct Piece {
    double s0, s1;
    Vec2 p, q;
    int depth;
  };
  std::vector<Piece> stack{{0.0, length, a, b, 0}};
  while (!stack.empty()) {
    const Piece piece = stack.back();
    stack.pop_back();
    const double sm = 0.5 * (piece.s0 + piece.s1);
    const Vec2 m = at(sm);
    // (A piece shorter than the tolerance cannot stray farther than that; depth 60 is far below
    // a millimetre on any geodesic.)
    const bool flat =
        piece.s1 - piece.s0 <= tolerance || piece.depth >= 60 || off_chord(piece.p, piece.q, m) <= 0.5 * tolerance;
    if (flat) {
      out.push_back(piece.q);
      continue;
    }
    stack.push_back({sm, piece.s1, m, piece.q, piece.depth + 1});
    stack.push_back({piece.s0, sm, piece.p, m, piece.depth + 1});
  }
  return out;
}

Vec2 GeodesicMeasure::gradient(Vec2 p, double azimuth) const {
  // Moving p by (dlon, dlat) degrees moves it N cos(lat) dlon east and M dlat north (N, M the
  // radii of curvature across and along the meridian); the distance grows by the move's
  // component along the azimuth.
  const Vec2 r = radii(impl_->geod, p.y);
  return Vec2{r.x * std::cos(p.y * kRad) * std::sin(azimuth * kRad) * kRad, r.y * std::cos(azimuth * kRad) * kRad};
}

double GeodesicMeasure::segment_distance(Vec2 p, Vec2 a, Vec2 b) const {
  Site s{a, b, 0, SiteKind::segment};
  const detail::GeoSites sites(impl_->metric, std::vector<Site>{s});
  if (!(p.y >= -90.0 && p.y <= 90.0)) throw Error(ErrorKind::invalid_argument, "latitude outside [-90, 90]");
  return sites.distance(sites.cell(p.x, p.y), 0);
}

}  // namespace rv
