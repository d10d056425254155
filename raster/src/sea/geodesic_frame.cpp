#include "rv/sea/geodesic_frame.hpp"

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>
#include <GeographicLib/Gnomonic.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <vector>

#include "sea/orient.hpp"

#include "rv/field/error.hpp"

namespace rv {

struct GeodesicFrame::Impl {
  GeographicLib::Geodesic earth;
  GeographicLib::Gnomonic gnomonic;
  double lon0, lat0;
  Impl(double a, double f, double lon, double lat) : earth(a, f), gnomonic(earth), lon0(lon), lat0(lat) {}
};

namespace {

// How far past its ends the straight line through two points of a geodesic may be used: the
// bending measured between a box's points, end to end, grows about with the square of the
// length, and a line through two nearby points of a geodesic is followed across the whole box:
// up to four times the end-to-end figure. Twice that again for what sampling may miss.
constexpr double kSafety = 8.0;
constexpr int kSamples = 48;  // points along each measured geodesic
constexpr int kSide = 5;      // box points a side: corners, edges and inside

// Frames are told apart in the memos below by a number never given twice (an address may be).
std::atomic<uint64_t> next_frame_id{1};

// Each thread's memo of the exact orientation test's inverse projections and azimuths: the same
// points come back test after test (a coast edge's ends, a line's end tested against every edge
// near it), and each answer costs GeographicLib iterations. Direct-mapped on the points' bits; an
// answer is GeographicLib's own, so a memo changes no result. 96 KB a thread.
constexpr size_t kMemo = 1024;
struct ReverseMemo {
  uint64_t frame = 0, x = 0, y = 0;
  Vec2 ll;
};
struct AzimuthMemo {
  uint64_t frame = 0, ax = 0, ay = 0, bx = 0, by = 0;
  double azimuth = 0.0;
};
thread_local std::array<ReverseMemo, kMemo> reverse_memo;
thread_local std::array<AzimuthMemo, kMemo> azimuth_memo;

uint64_t bits(double v) { return std::bit_cast<uint64_t>(v); }
size_t memo_slot(uint64_t a, uint64_t b) {
  const uint64_t h = (a * 0x9E3779B97F4A7C15ULL) ^ ((b + 0x632BE59BD9B4E019ULL) * 0xC2B2AE3D27D4EB4FULL);
  return static_cast<size_t>((h ^ (h >> 29)) % kMemo);
}

}  // namespace

GeodesicFrame::GeodesicFrame(const MetricSpec& metric, double lon_min, double lat_min, double lon_max, double lat_max) {
  if (metric.kind != MetricSpec::geodesic)
    throw Error(ErrorKind::invalid_argument, "a geodesic frame needs the geodesic metric");
  if (!(std::isfinite(lon_min) && std::isfinite(lat_min) && std::isfinite(lon_max) && std::isfinite(lat_max)) ||
      lon_min > lon_max || lat_min > lat_max || lat_min < -90.0 || lat_max > 90.0)
    throw Error(ErrorKind::invalid_argument, "a geodesic frame needs a box of longitudes and latitudes");
  id_ = next_frame_id.fetch_add(1, std::memory_order_relaxed);
  impl_ = std::make_unique<Impl>(metric.semi_major, metric.flattening, 0.5 * (lon_min + lon_max),
                                 0.5 * (lat_min + lat_max));
  const Impl& m = *impl_;
  // The box's reach from its centre: at most 40 degrees of arc (its enlargement below, 80).
  const double quarter = m.earth.EquatorialRadius() * M_PI / 2.0;
  for (double lon : {lon_min, lon_max})
    for (double lat : {lat_min, lat_max}) {
      double s12;
      m.earth.Inverse(m.lat0, m.lon0, lat, lon, s12);
      if (s12 > quarter * (40.0 / 90.0))
        throw Error(ErrorKind::invalid_argument,
                    "the data reach more than 40 degrees of arc from their middle: too far for one geodesic frame");
    }
  // The bending of geodesics between points of the box (enlarged by half its size each way, for
  // the reference directions the predicates draw from its points), end to end.
  const double w = lon_max - lon_min, h = lat_max - lat_min;
  std::vector<Vec2> points;
  for (int i = 0; i < kSide; ++i)
    for (int j = 0; j < kSide; ++j)
      points.push_back(Vec2{lon_min - 0.5 * w + 2.0 * w * i / (kSide - 1),
                            std::clamp(lat_min - 0.5 * h + 2.0 * h * j / (kSide - 1), -89.0, 89.0)});
  // The scale grows away from the centre (radially 1 / rk^2, rk the reciprocal azimuthal scale
  // GeographicLib gives): its largest is at the enlarged box's farthest points.
  for (const Vec2& q : points) {
    double x, y, azi, rk;
    m.gnomonic.Forward(m.lat0, m.lon0, q.y, q.x, x, y, azi, rk);
    if (rk > 0.0) max_scale_ = std::max(max_scale_, 1.0 / (rk * rk));
  }
  max_scale_ *= 1.0 + 1e-6;
  double worst = 0.0;
  for (size_t i = 0; i < points.size(); ++i)
    for (size_t k = i + 1; k < points.size(); ++k) {
      const Vec2 a = forward(points[i]), b = forward(points[k]);
      const double len = std::hypot(b.x - a.x, b.y - a.y);
      if (!(len > 0.0)) continue;
      const GeographicLib::GeodesicLine line = m.earth.InverseLine(points[i].y, points[i].x, points[k].y, points[k].x);
      for (int s = 1; s < kSamples; ++s) {
        double lat, lon;
        line.Position(line.Distance() * s / kSamples, lat, lon);
        const Vec2 p = forward(Vec2{lon, lat});
        worst = std::max(worst, std::abs((b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x)) / len);
      }
    }
  // (Plus a micrometre: the floor for a box too small to bend anything measurably.)
  deviation_ = kSafety * worst + 1e-6;
  const Vec2 west = forward(Vec2{lon_min, impl_->lat0}), east = forward(Vec2{lon_max, impl_->lat0});
  reach_ = std::max(1.0, 0.5 * (east.x - west.x));
}

GeodesicFrame::~GeodesicFrame() = default;

Vec2 GeodesicFrame::forward(Vec2 lonlat) const {
  double x, y;
  impl_->gnomonic.Forward(impl_->lat0, impl_->lon0, lonlat.y, lonlat.x, x, y);
  if (!std::isfinite(x) || !std::isfinite(y))
    throw Error(ErrorKind::invalid_argument, "a point beyond the geodesic frame's reach");
  return Vec2{x, y};
}

namespace {

// Rows: exact points (knots) about kRowSpacing apart, at most kRowMaxStep cells; between, Lagrange's
// quintic through six knots around the point. Its error falls as the sixth power of the spacing
// (RowsProjectAsTheirPointsDo measures it): one forward problem serves dozens of cells.
constexpr double kRowSpacing = 4000.0;  // metres
constexpr int64_t kRowMaxStep = 64;     // cells

// Lagrange's weights of six knots (at 0 .. 5) at u in [0, 5].
void lagrange_weights(double u, std::array<double, 6>& w) {
  for (int k = 0; k < 6; ++k) {
    double p = 1.0;
    for (int m = 0; m < 6; ++m)
      if (m != k) p *= (u - m) / static_cast<double>(k - m);
    w[static_cast<size_t>(k)] = p;
  }
}

Vec2 weighted(const std::array<double, 6>& w, const Vec2* knots) {
  Vec2 p{0.0, 0.0};
  for (int k = 0; k < 6; ++k) {
    p.x += w[static_cast<size_t>(k)] * knots[k].x;
    p.y += w[static_cast<size_t>(k)] * knots[k].y;
  }
  return p;
}

}  // namespace

int64_t GeodesicFrame::row_step(double lat, double lon0, double dlon, int64_t n) const {
  if (n <= 1) return 1;
  const Vec2 a = forward(Vec2{lon0, lat}), b = forward(Vec2{lon0 + dlon, lat});
  const double spacing = std::hypot(b.x - a.x, b.y - a.y);
  return spacing > 0.0 ? std::clamp<int64_t>(static_cast<int64_t>(kRowSpacing / spacing), 1, kRowMaxStep) : 1;
}

void GeodesicFrame::forward_row(double lat, double lon0, double dlon, int64_t n, Vec2* out) const {
  if (n <= 0) return;
  const int64_t step = row_step(lat, lon0, dlon, n);
  // (The last knot at or past the row's last point: no point lies beyond the knots.)
  const int64_t knots = (n - 1 + step - 1) / step + 1;
  std::vector<Vec2> at(static_cast<size_t>(knots));
  for (int64_t j = 0; j < knots; ++j)
    at[static_cast<size_t>(j)] = forward(Vec2{lon0 + static_cast<double>(j * step) * dlon, lat});
  // Inside the row the knots j-2 .. j+3 (u in [2, 3)); within two knots of its ends the six
  // knots at that end.
  std::vector<std::array<double, 6>> middle(static_cast<size_t>(step));
  for (int64_t r = 0; r < step; ++r)
    lagrange_weights(2.0 + static_cast<double>(r) / static_cast<double>(step), middle[static_cast<size_t>(r)]);
  std::array<double, 6> edge{};
  for (int64_t i = 0; i < n; ++i) {
    const int64_t j = i / step, r = i % step;
    if (r == 0) {
      out[i] = at[static_cast<size_t>(j)];
      continue;
    }
    if (knots < 6) {
      out[i] = forward(Vec2{lon0 + static_cast<double>(i) * dlon, lat});
      continue;
    }
    const int64_t first = std::clamp<int64_t>(j - 2, 0, knots - 6);
    const std::array<double, 6>* w = &middle[static_cast<size_t>(r)];
    if (first != j - 2) {
      lagrange_weights(static_cast<double>(i - first * step) / static_cast<double>(step), edge);
      w = &edge;
    }
    out[i] = weighted(*w, &at[static_cast<size_t>(first)]);
  }
}

Vec2 GeodesicFrame::forward_row_point(double lat, double lon0, double dlon, int64_t n, int64_t i) const {
  // forward_row()'s arithmetic for the one point, operation for operation.
  const int64_t step = row_step(lat, lon0, dlon, n);
  const int64_t knots = (n - 1 + step - 1) / step + 1;
  const int64_t j = i / step, r = i % step;
  auto knot = [&](int64_t k) { return forward(Vec2{lon0 + static_cast<double>(k * step) * dlon, lat}); };
  if (r == 0) return knot(j);
  if (knots < 6) return forward(Vec2{lon0 + static_cast<double>(i) * dlon, lat});
  const int64_t first = std::clamp<int64_t>(j - 2, 0, knots - 6);
  std::array<double, 6> w{};
  if (first != j - 2)
    lagrange_weights(static_cast<double>(i - first * step) / static_cast<double>(step), w);
  else
    lagrange_weights(2.0 + static_cast<double>(r) / static_cast<double>(step), w);
  std::array<Vec2, 6> at{};
  for (int k = 0; k < 6; ++k) at[static_cast<size_t>(k)] = knot(first + k);
  return weighted(w, at.data());
}

Vec2 GeodesicFrame::reverse(Vec2 plane) const {
  double lat, lon;
  impl_->gnomonic.Reverse(impl_->lat0, impl_->lon0, plane.x, plane.y, lat, lon);
  return Vec2{lon, lat};
}

int GeodesicFrame::orient(const Vec2& a, const Vec2& b, const Vec2& c) const {
  if (a == b || c == a || c == b) return 0;
  const double l = (b.x - a.x) * (c.y - a.y);
  const double r = (b.y - a.y) * (c.x - a.x);
  // The determinant is |b - a| times c's distance from the straight line through a and b; the
  // geodesic's image lies within deviation() of that line, and the rounding of the determinant
  // within the planar predicate's bound (rv/sea orient.hpp) of it.
  const double dx = b.x - a.x, dy = b.y - a.y;
  if (const int sign = sea::filtered_sign(l, r, std::sqrt(dx * dx + dy * dy) * deviation_)) return sign;
  return orient_exact(a, b, c);
}

int GeodesicFrame::orient_exact(const Vec2& a, const Vec2& b, const Vec2& c) const {
  exact_tests_.fetch_add(1, std::memory_order_relaxed);
  auto located = [&](const Vec2& p) {
    ReverseMemo& m = reverse_memo[memo_slot(bits(p.x), bits(p.y))];
    if (m.frame != id_ || m.x != bits(p.x) || m.y != bits(p.y)) m = ReverseMemo{id_, bits(p.x), bits(p.y), reverse(p)};
    return m.ll;
  };
  const Vec2 pa = located(a);
  auto azimuth = [&](const Vec2& q) {
    AzimuthMemo& m = azimuth_memo[memo_slot(bits(a.x) ^ (bits(q.y) << 1), bits(a.y) ^ (bits(q.x) << 1))];
    if (m.frame != id_ || m.ax != bits(a.x) || m.ay != bits(a.y) || m.bx != bits(q.x) || m.by != bits(q.y)) {
      const Vec2 pq = located(q);
      double azi, back;
      impl_->earth.Inverse(pa.y, pa.x, pq.y, pq.x, azi, back);
      m = AzimuthMemo{id_, bits(a.x), bits(a.y), bits(q.x), bits(q.y), azi};
    }
    return m.azimuth;
  };
  const double azi_b = azimuth(b), azi_c = azimuth(c);
  // Azimuths turn clockwise: c is left of the way to b when its azimuth is smaller, by less than
  // a half-turn (the sine's sign, which also reads a point behind a correctly).
  const double s = std::sin((azi_c - azi_b) * (M_PI / 180.0));
  return s < 0.0 ? 1 : s > 0.0 ? -1 : 0;
}

std::shared_ptr<const GeodesicFrame> frame_for(const MetricSpec& metric, const Barriers& barriers, const SeedSet& seeds,
                                               LonLatBox box) {
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  auto cover = [&](Vec2 v) {
    x0 = std::min(x0, v.x);
    x1 = std::max(x1, v.x);
    y0 = std::min(y0, v.y);
    y1 = std::max(y1, v.y);
  };
  if (box.xmin <= box.xmax) {
    cover({box.xmin, box.ymin});
    cover({box.xmax, box.ymax});
  }
  for (const Barriers::Polygon& p : barriers.polygons())
    for (const Ring& r : p.rings)
      for (const Vec2& v : r) cover(v);
  for (const Barriers::Line& l : barriers.lines())
    for (const Vec2& v : l.vertices) cover(v);
  for (const Site& s : seeds.sites()) {
    cover(s.a);
    cover(s.b);
  }
  for (const Polygon& p : seeds.polygons())
    for (const Ring& r : p.rings)
      for (const Vec2& v : r) cover(v);
  return std::make_shared<const GeodesicFrame>(metric, x0, y0, x1, y1);
}

}  // namespace rv
