// Positions along polylines. See polyline_along.hpp.
#include "lines/partial/polyline_along.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "lines/line_tools.hpp"

namespace rv::polyline_along {

using line_tools::lerp;

Along project(const std::vector<Vec2>& pts, Vec2 p) {
  Along best;
  for (size_t k = 0; k + 1 < pts.size(); ++k) {
    const Vec2 a = pts[k], b = pts[k + 1];
    const double t = line_tools::nearest_t(a, b, p);
    const double d = std::hypot(a.x + t * (b.x - a.x) - p.x, a.y + t * (b.y - a.y) - p.y);
    if (d < best.distance) best = Along{k, t, d};
  }
  return best;
}

double length(const std::vector<Vec2>& pts) {
  double s = 0.0;
  for (size_t k = 0; k + 1 < pts.size(); ++k) s += std::hypot(pts[k + 1].x - pts[k].x, pts[k + 1].y - pts[k].y);
  return s;
}

std::vector<Vec2> stretch(const std::vector<Vec2>& pts, bool closed, Along u, Along v) {
  auto point = [&](const Along& a) { return lerp(pts[a.k], pts[a.k + 1], a.t); };
  auto straight = [&](const Along& from, const Along& to) {
    std::vector<Vec2> out{point(from)};
    if (from.at() <= to.at()) {
      for (size_t m = from.k + 1 + (from.t >= 1.0 ? 1 : 0); static_cast<double>(m) < to.at(); ++m)
        out.push_back(pts[m]);
    } else {
      for (size_t m = from.t > 0.0 ? from.k : from.k - 1; static_cast<double>(m) > to.at() && m < pts.size(); --m)
        out.push_back(pts[m]);
    }
    out.push_back(point(to));
    return out;
  };
  std::vector<Vec2> direct = straight(u, v);
  if (!closed) return direct;
  // The other way round: through the closing vertex (pts.front() == pts.back()).
  const size_t last = pts.size() - 2;  // the last segment
  std::vector<Vec2> round;
  if (u.at() <= v.at()) {
    round = straight(u, Along{0, 0.0, 0.0});
    const std::vector<Vec2> tail = straight(Along{last, 1.0, 0.0}, v);
    round.insert(round.end(), tail.begin() + 1, tail.end());
  } else {
    round = straight(u, Along{last, 1.0, 0.0});
    const std::vector<Vec2> tail = straight(Along{0, 0.0, 0.0}, v);
    round.insert(round.end(), tail.begin() + 1, tail.end());
  }
  return length(round) < length(direct) ? round : direct;
}

Vec2 at_fraction(const std::vector<Vec2>& pts, const std::vector<double>& cum, double s) {
  const double target = s * cum.back();
  const size_t k = std::min<size_t>(static_cast<size_t>(std::upper_bound(cum.begin(), cum.end(), target) - cum.begin()),
                                    pts.size() - 1);
  if (k == 0) return pts.front();
  const double seg = cum[k] - cum[k - 1];
  return seg > 0.0 ? lerp(pts[k - 1], pts[k], (target - cum[k - 1]) / seg) : pts[k];
}

std::vector<double> cumulative(const std::vector<Vec2>& pts) {
  std::vector<double> cum(pts.size(), 0.0);
  for (size_t k = 1; k < pts.size(); ++k)
    cum[k] = cum[k - 1] + std::hypot(pts[k].x - pts[k - 1].x, pts[k].y - pts[k - 1].y);
  return cum;
}

std::vector<std::vector<Vec2>> round_rectangle(Vec2 a, Vec2 b, double x0, double y0, double x1, double y1, double eps) {
  const double w = x1 - x0, h = y1 - y0, perimeter = 2.0 * (w + h);
  // The position along the boundary anticlockwise from (x0, y0); -1 off it.
  auto position = [&](Vec2 p) {
    if (std::abs(p.y - y0) <= eps) return std::clamp(p.x - x0, 0.0, w);
    if (std::abs(p.x - x1) <= eps) return w + std::clamp(p.y - y0, 0.0, h);
    if (std::abs(p.y - y1) <= eps) return w + h + std::clamp(x1 - p.x, 0.0, w);
    if (std::abs(p.x - x0) <= eps) return 2.0 * w + h + std::clamp(y1 - p.y, 0.0, h);
    return -1.0;
  };
  const double pa = position(a), pb = position(b);
  if (pa < 0.0 || pb < 0.0) return {};
  const std::array<double, 4> corner_at{w, w + h, 2.0 * w + h, perimeter};
  const std::array<Vec2, 4> corners{Vec2{x1, y0}, Vec2{x1, y1}, Vec2{x0, y1}, Vec2{x0, y0}};
  // Anticlockwise from a to b: the corners at positions in (pa, pb], round through the start.
  std::vector<Vec2> ccw{a};
  const double span = pb >= pa ? pb - pa : pb + perimeter - pa;
  for (int lap = 0; lap < 2; ++lap)
    for (size_t k = 0; k < 4; ++k) {
      const double c = corner_at[k] + lap * perimeter;
      if (c > pa && c < pa + span) ccw.push_back(corners[k]);
    }
  ccw.push_back(b);
  // Clockwise from a: the corners anticlockwise from b to a, in reverse.
  std::vector<Vec2> back{b};
  for (int lap = 0; lap < 2; ++lap)
    for (size_t k = 0; k < 4; ++k) {
      const double c = corner_at[k] + lap * perimeter;
      if (c > pa + span && c < pa + perimeter) back.push_back(corners[k]);
    }
  back.push_back(a);
  return {ccw, std::vector<Vec2>(back.rbegin(), back.rend())};
}

}  // namespace rv::polyline_along
