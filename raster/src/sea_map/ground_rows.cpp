#include "sea_map/ground_rows.hpp"

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>

#include <algorithm>
#include <cmath>
#include <memory>

#include "rv/field/error.hpp"

namespace rv::sea {

namespace {

// How far rounding may move a piece's end or a crossing, in cells: the coordinates' own rounding
// (a billionth of their magnitude covers it many times over), the cell positions' (row_cells()'s
// quintic, 1e-8 m), and GeographicLib's (15 nm), far below a micro-cell at any sensible cell size.
double rounding_band(double u1, double v1, double u2, double v2) {
  const double magnitude = std::max({1.0, std::abs(u1), std::abs(v1), std::abs(u2), std::abs(v2)});
  return 1e-6 + 1e-9 * magnitude;
}

// The distance from m to the line through p and q (to p when they coincide).
double off_line(double pu, double pv, double qu, double qv, double mu, double mv) {
  const double du = qu - pu, dv = qv - pv, len = std::hypot(du, dv);
  if (len == 0.0) return std::hypot(mu - pu, mv - pv);
  return std::abs(du * (mv - pv) - dv * (mu - pu)) / len;
}

}  // namespace

GroundRows::GroundRows(const Prepared& p, const MetricSpec& metric, const GridSpec& grid, const Window& window)
    : p_(&p), grid_(grid), window_(window) {
  if (p.geodesic && p.geolocator) return;
  drawn_ = true;
  std::unique_ptr<GeographicLib::Geodesic> geod;
  if (p.geodesic) geod = std::make_unique<GeographicLib::Geodesic>(metric.semi_major, metric.flattening);
  const Barriers& barriers = p.vis.barriers();
  for (const Barriers::Polygon& polygon : barriers.polygons())
    for (const Ring& ring : polygon.rings)
      for (size_t k = 0; k < ring.size(); ++k) add_edge(grid, geod.get(), ring[k], ring[(k + 1) % ring.size()], true);
  for (const Barriers::Line& line : barriers.lines())
    for (size_t k = 0; k + 1 < line.vertices.size(); ++k)
      add_edge(grid, geod.get(), line.vertices[k], line.vertices[k + 1], false);
  index_rows();
}

void GroundRows::add_edge(const GridSpec& grid, const GeographicLib::Geodesic* geod, Vec2 a, Vec2 b, bool polygon) {
  auto push = [&](double u1, double v1, double u2, double v2, double band) {
    const int8_t north = !polygon || v1 == v2 ? int8_t{0} : (v2 < v1 ? int8_t{1} : int8_t{-1});
    // (A horizontal polygon piece crosses no row: the half-open rule below counts none.)
    pieces_.push_back(Piece{u1, v1, u2, v2, band + rounding_band(u1, v1, u2, v2), north});
  };
  if (!p_->geodesic) {
    // The local frame: a cell's centre at ((col + 0.5) res, -(row + 0.5) res) (GridSpec::local_x/y).
    auto u = [&](Vec2 x) { return x.x / grid.res - 0.5 - static_cast<double>(window_.col0); };
    auto v = [&](Vec2 x) { return -x.y / grid.res - 0.5 - static_cast<double>(window_.row0); };
    push(u(a), v(a), u(b), v(b), 0.0);
    return;
  }
  const int32_t ia = p_->vis.vertex_at(a), ib = p_->vis.vertex_at(b);
  if (ia < 0 || ib < 0) throw Error(ErrorKind::internal, "a barrier edge's end is no barrier vertex");
  const double lon0 = grid.centre_x(window_.col0), lat0 = grid.centre_y(window_.row0);
  const double mid_lon = lon0 + 0.5 * static_cast<double>(window_.width - 1) * grid.res;
  Vec2 la = p_->vertex_ll[static_cast<size_t>(ia)], lb = p_->vertex_ll[static_cast<size_t>(ib)];
  la.x = mid_lon + std::remainder(la.x - mid_lon, 360.0);
  lb.x = la.x + std::remainder(lb.x - la.x, 360.0);
  auto cell = [&](Vec2 ll) { return Vec2{(ll.x - lon0) / grid.res, (lat0 - ll.y) / grid.res}; };
  const Vec2 ca = cell(la), cb = cell(lb);
  if (la == lb) {
    push(ca.x, ca.y, cb.x, cb.y, 0.0);
    return;
  }
  const GeographicLib::GeodesicLine line = geod->InverseLine(la.y, la.x, lb.y, lb.x);
  const double length = line.Distance();
  auto at = [&](double s) {
    double lat, lon;
    line.Position(s, lat, lon);
    return cell(Vec2{la.x + std::remainder(lon - la.x, 360.0), lat});
  };
  // Depth first from a, so the pieces follow the edge.
  struct Part {
    double s0, s1;
    Vec2 p, q;
    int depth;
  };
  std::vector<Part> stack{{0.0, length, ca, cb, 0}};
  while (!stack.empty()) {
    const Part part = stack.back();
    stack.pop_back();
    const double s = 0.5 * (part.s0 + part.s1);
    const Vec2 m = at(s);
    const double off = off_line(part.p.x, part.p.y, part.q.x, part.q.y, m.x, m.y);
    if (off <= 0.25 * kChordTolerance || part.depth >= 40) {
      push(part.p.x, part.p.y, part.q.x, part.q.y, std::max(kChordTolerance, 4.0 * off));
      continue;
    }
    stack.push_back(Part{s, part.s1, m, part.q, part.depth + 1});
    stack.push_back(Part{part.s0, s, part.p, m, part.depth + 1});
  }
}

void GroundRows::index_rows() {
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

int64_t GroundRows::row(int64_t r, Visibility::Ground* out) const {
  if (!drawn_) throw Error(ErrorKind::internal, "GroundRows::row on a grid it does not draw");
  struct Crossing {
    double u;
    int north;
  };
  thread_local std::vector<Crossing> crossings;
  thread_local std::vector<std::pair<int64_t, int64_t>> bands;  // cells [first, last]
  crossings.clear();
  bands.clear();
  const auto y = static_cast<double>(r);
  const int64_t width = window_.width;
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
    if (hi < 0.0 || lo > static_cast<double>(width - 1)) continue;
    bands.emplace_back(std::max<int64_t>(0, static_cast<int64_t>(std::ceil(lo))),
                       std::min<int64_t>(width - 1, static_cast<int64_t>(std::floor(hi))));
  }
  // The fill: a cell's winding number is the sum over the crossings east of it, minus the sum
  // over those west of it (every ring crosses the row as often heading north as south).
  std::sort(crossings.begin(), crossings.end(), [](const Crossing& a, const Crossing& b) { return a.u < b.u; });
  int west = 0;
  int64_t c = 0;
  for (const Crossing& x : crossings) {
    const int64_t end = std::clamp<int64_t>(static_cast<int64_t>(std::ceil(x.u)), 0, width);
    if (end > c) {
      std::fill(out + c, out + end, -west >= 1 ? Visibility::Ground::land : Visibility::Ground::open_sea);
      c = end;
    }
    west += x.north;
  }
  if (c < width) std::fill(out + c, out + width, -west >= 1 ? Visibility::Ground::land : Visibility::Ground::open_sea);
  // The cells in bands, exactly.
  std::sort(bands.begin(), bands.end());
  int64_t exact = 0, done = -1;
  for (const auto& [first, last] : bands)
    for (int64_t cell = std::max(first, done + 1); cell <= last; ++cell) {
      out[cell] = p_->vis.classify(p_->cell_spot(grid_, window_, r, cell).at);
      ++exact;
      done = cell;
    }
  return exact;
}

}  // namespace rv::sea
