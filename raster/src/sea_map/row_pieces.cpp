#include "sea_map/row_pieces.hpp"

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "rv/field/error.hpp"

namespace rv::sea {

namespace {

// How far rounding may move a piece's end or a crossing, in cells: the coordinates' own rounding
// (a billionth of their magnitude covers it many times over), the cell positions' (row_cells()'s
// quintic, 1e-8 m), and GeographicLib's (15 nm): all far below a micro-cell at any sensible cell
// size.
double rounding_band(double u1, double v1, double u2, double v2) {
  const double magnitude = std::max({1.0, std::abs(u1), std::abs(v1), std::abs(u2), std::abs(v2)});
  return 1e-6 + 1e-9 * magnitude;
}

constexpr double kRadian = std::numbers::pi / 180.0;

// How far (degrees) the geodesic from a to b (longitude, latitude) may lie from the chord between
// them in longitude/latitude. On a sphere, along a geodesic by its arc sigma (radians) at azimuth
// az, d2 lat / d sigma2 = -sin^2(az) tan(lat) and d2 lon / d sigma2 = 2 sin(az) cos(az) tan(lat) /
// cos(lat), so the arc lies within sigma^2 / 8 tan(lat) sqrt(1 + 1 / cos^2(lat)) radians of its
// chord, lat the largest on the arc. sigma is at most sqrt(2) times the ends' spread in degrees
// (the way along a meridian, then a parallel, is no shorter); the arc's largest latitude exceeds
// its ends' by at most sigma^2 / 4 tan(lat). The ellipsoid moves these by under one per cent:
// twice the bound is taken.
double geodesic_bend(Vec2 a, Vec2 b) {
  const double sigma = std::sqrt(2.0) * std::hypot(b.x - a.x, b.y - a.y) * kRadian;
  const double ends = std::max(std::abs(a.y), std::abs(b.y));
  const double top =
      std::min(89.99, ends + sigma * sigma / 4.0 * std::tan(std::min(ends + 1.0, 89.0) * kRadian) / kRadian);
  const double t = std::tan(top * kRadian), c = std::cos(top * kRadian);
  return 2.0 * sigma * sigma / 8.0 * t * std::sqrt(1.0 + 1.0 / (c * c)) / kRadian;
}

}  // namespace

RowPieces::RowPieces(const GridSpec& grid, const Window& window, const MetricSpec& metric, bool geodesic)
    : grid_(grid), window_(window), geodesic_(geodesic) {
  if (geodesic) geod_ = std::make_unique<GeographicLib::Geodesic>(metric.semi_major, metric.flattening);
}
RowPieces::~RowPieces() = default;
RowPieces::RowPieces(RowPieces&&) noexcept = default;
RowPieces& RowPieces::operator=(RowPieces&&) noexcept = default;

void RowPieces::push(double u1, double v1, double u2, double v2, double band, bool counted) {
  // (A level piece crosses no row: the half-open rule of row() counts none.)
  const int8_t north = !counted || v1 == v2 ? int8_t{0} : (v2 < v1 ? int8_t{1} : int8_t{-1});
  pieces_.push_back(Piece{u1, v1, u2, v2, band + rounding_band(u1, v1, u2, v2), north});
}

void RowPieces::add_edge(Vec2 a, Vec2 b, bool counted, double band) {
  if (!row_start_.empty()) throw Error(ErrorKind::internal, "RowPieces::add_edge after index");
  if (!geodesic_) {
    // The local frame: a cell's centre at ((col + 0.5) res, -(row + 0.5) res).
    auto u = [&](Vec2 x) { return x.x / grid_.res - 0.5 - static_cast<double>(window_.col0); };
    auto v = [&](Vec2 x) { return -x.y / grid_.res - 0.5 - static_cast<double>(window_.row0); };
    push(u(a), v(a), u(b), v(b), band, counted);
    return;
  }
  const double lon0 = grid_.centre_x(window_.col0), lat0 = grid_.centre_y(window_.row0);
  const double mid_lon = lon0 + 0.5 * static_cast<double>(window_.width - 1) * grid_.res;
  a.x = mid_lon + std::remainder(a.x - mid_lon, 360.0);
  b.x = a.x + std::remainder(b.x - a.x, 360.0);
  auto cell = [&](Vec2 ll) { return Vec2{(ll.x - lon0) / grid_.res, (lat0 - ll.y) / grid_.res}; };
  const Vec2 ca = cell(a), cb = cell(b);
  // How far the geodesic may stray from the chord in cells (geodesic_bend), and so from the rows of
  // its ends: an edge that cannot come within a band of the window's rows is left out before any
  // geodesic is solved (a strip's window holds a few of the edges).
  const double bend = geodesic_bend(a, b) / grid_.res;
  const double lo = std::min(ca.y, cb.y) - bend - band - 1.0, hi = std::max(ca.y, cb.y) + bend + band + 1.0;
  if (hi < 0.0 || lo > static_cast<double>(window_.height)) return;
  // Pieces of equal length along the geodesic, few enough that each one's bound (which falls as
  // the square of its length) is within the tolerance: most edges are one piece, with no
  // geodesic solved.
  const auto n = static_cast<int64_t>(std::min(1e5, std::ceil(std::sqrt(bend / kChordTolerance))));
  if (n <= 1 || a == b) {
    push(ca.x, ca.y, cb.x, cb.y, band + bend, counted);
    return;
  }
  const GeographicLib::GeodesicLine line = geod_->InverseLine(a.y, a.x, b.y, b.x);
  const double piece_bend = bend / static_cast<double>(n * n);
  Vec2 p = ca;
  for (int64_t k = 1; k <= n; ++k) {
    Vec2 q = cb;
    if (k < n) {
      double lat, lon;
      line.Position(line.Distance() * static_cast<double>(k) / static_cast<double>(n), lat, lon);
      q = cell(Vec2{a.x + std::remainder(lon - a.x, 360.0), lat});
    }
    push(p.x, p.y, q.x, q.y, band + piece_bend, counted);
    p = q;
  }
}

void RowPieces::index() {
  const int64_t height = window_.height;
  auto rows_of = [&](const Piece& q, int64_t& r0, int64_t& r1) {
    const double lo = std::min(q.v1, q.v2) - q.band, hi = std::max(q.v1, q.v2) + q.band;
    r0 = std::max<int64_t>(0, static_cast<int64_t>(std::ceil(std::max(lo, -1.0))));
    r1 = std::min<int64_t>(height - 1, static_cast<int64_t>(std::floor(std::min(hi, static_cast<double>(height)))));
  };
  row_start_.assign(static_cast<size_t>(height) + 1, 0);
  for (const Piece& q : pieces_) {
    int64_t r0, r1;
    rows_of(q, r0, r1);
    for (int64_t r = r0; r <= r1; ++r) ++row_start_[static_cast<size_t>(r) + 1];
  }
  for (int64_t r = 0; r < height; ++r) row_start_[static_cast<size_t>(r) + 1] += row_start_[static_cast<size_t>(r)];
  row_pieces_.resize(static_cast<size_t>(row_start_.back()));
  std::vector<int64_t> fill(row_start_.begin(), row_start_.end() - 1);
  for (size_t i = 0; i < pieces_.size(); ++i) {
    int64_t r0, r1;
    rows_of(pieces_[i], r0, r1);
    for (int64_t r = r0; r <= r1; ++r)
      row_pieces_[static_cast<size_t>(fill[static_cast<size_t>(r)]++)] = static_cast<int32_t>(i);
  }
}

void RowPieces::row(int64_t r, int64_t c0, int64_t c1, std::vector<Crossing>& crossings,
                    std::vector<std::pair<int64_t, int64_t>>& bands) const {
  if (row_start_.empty()) throw Error(ErrorKind::internal, "RowPieces::row before index");
  crossings.clear();
  bands.clear();
  const auto y = static_cast<double>(r);
  for (int64_t k = row_start_[static_cast<size_t>(r)]; k < row_start_[static_cast<size_t>(r) + 1]; ++k) {
    const Piece& q = pieces_[static_cast<size_t>(row_pieces_[static_cast<size_t>(k)])];
    const double dv = q.v2 - q.v1, du = q.u2 - q.u1;
    if (q.north != 0 && std::min(q.v1, q.v2) <= y && y < std::max(q.v1, q.v2))
      crossings.push_back(Crossing{q.u1 + (y - q.v1) / dv * du, q.north});
    // The piece's points within the band of the row, and the cells within the band of those.
    double t0 = 0.0, t1 = 1.0;
    if (dv != 0.0) {
      t0 = (y - q.band - q.v1) / dv;
      t1 = (y + q.band - q.v1) / dv;
      if (t0 > t1) std::swap(t0, t1);
      t0 = std::max(t0, 0.0);
      t1 = std::min(t1, 1.0);
      if (t0 > t1) continue;
    } else if (std::abs(q.v1 - y) > q.band) {
      continue;
    }
    const double ua = q.u1 + t0 * du, ub = q.u1 + t1 * du;
    const double lo = std::min(ua, ub) - q.band, hi = std::max(ua, ub) + q.band;
    if (hi < static_cast<double>(c0) || lo > static_cast<double>(c1 - 1)) continue;
    const int64_t first = std::max<int64_t>(c0, static_cast<int64_t>(std::ceil(lo)));
    const int64_t last = std::min<int64_t>(c1 - 1, static_cast<int64_t>(std::floor(hi)));
    if (first <= last) bands.emplace_back(first, last);
  }
  std::sort(crossings.begin(), crossings.end(), [](const Crossing& a, const Crossing& b) { return a.u < b.u; });
  std::sort(bands.begin(), bands.end());
  size_t merged = 0;
  for (const auto& b : bands) {
    if (merged > 0 && b.first <= bands[merged - 1].second + 1)
      bands[merged - 1].second = std::max(bands[merged - 1].second, b.second);
    else
      bands[merged++] = b;
  }
  bands.resize(merged);
}

}  // namespace rv::sea
