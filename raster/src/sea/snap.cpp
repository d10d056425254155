#include "rv/sea/snap.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <utility>

#include "rv/field/error.hpp"
#include "rv/sea/visibility.hpp"
#include "sea/sea_prepare.hpp"

namespace rv {
namespace {

using sea::length;

// The nearest point of segment a-b to p.
Vec2 foot(Vec2 a, Vec2 b, Vec2 p) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double len2 = dx * dx + dy * dy;
  double t = len2 > 0.0 ? ((p.x - a.x) * dx + (p.y - a.y) * dy) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return Vec2{a.x + t * dx, a.y + t * dy};
}

// Whether p lies strictly inside ring r (even-odd; on an edge: either answer).
bool in_ring(const Ring& r, Vec2 p) {
  bool in = false;
  for (size_t i = 0, j = r.size() - 1; i < r.size(); j = i++)
    if ((r[i].y > p.y) != (r[j].y > p.y) && p.x < (r[j].x - r[i].x) * (p.y - r[i].y) / (r[j].y - r[i].y) + r[i].x)
      in = !in;
  return in;
}

// Whether p, a point of polygon `own`'s boundary, lies inside another barrier polygon (under its
// land: no coast there).
bool under_another(const Barriers& barriers, size_t own, Vec2 p) {
  for (size_t k = 0; k < barriers.polygons().size(); ++k) {
    if (k == own) continue;
    const std::vector<Ring>& rings = barriers.polygons()[k].rings;
    if (rings.empty() || !in_ring(rings[0], p)) continue;
    bool in_hole = false;
    for (size_t h = 1; h < rings.size() && !in_hole; ++h) in_hole = in_ring(rings[h], p);
    if (!in_hole) return true;
  }
  return false;
}

// A length for a message: four significant digits ("1351", "0.4", "12.35").
std::string short_number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.4g", v);
  return text;
}

}  // namespace

SnappedSeeds snap_to_sea(const SeedSet& seeds, const Barriers& given, double tolerance,
                         std::shared_ptr<const GeodesicFrame> frame) {
  SnappedSeeds out;
  if (!(tolerance >= 0.0) || !std::isfinite(tolerance))
    throw Error(ErrorKind::invalid_argument, "the snapping tolerance must be a finite number of metres, 0 or more");
  // Everything below in the plane (geodesic: the frame's), back to longitude/latitude at the end.
  const GeodesicFrame* f = frame.get();
  auto to_plane = [&](Vec2 v) { return f ? f->forward(v) : v; };
  const Barriers barriers = f ? given.mapped(to_plane) : given;
  const Visibility vis(barriers, true, frame);
  std::map<std::pair<double, double>, Vec2> moved;  // position -> where it goes
  // Per feature: its vertices, and those left on a land border (below).
  std::map<int32_t, std::pair<int64_t, int64_t>> vertices;
  std::set<std::pair<double, double>> bordered;  // positions left on a land border
  auto place = [&](Vec2 given_v, int32_t feature, bool point) -> Vec2 {
    std::pair<int64_t, int64_t>& counted = vertices[feature];
    ++counted.first;
    const auto key = std::make_pair(given_v.x, given_v.y);
    if (const auto it = moved.find(key); it != moved.end()) return it->second;
    if (bordered.count(key) != 0) {
      ++counted.second;
      return given_v;
    }
    const Vec2 v = to_plane(given_v);
    if (!vis.on_land(v)) return given_v;
    // The nearest point of the land's boundary: of every barrier polygon's boundary (lines have
    // no inside to leave) where no other polygon covers it.
    Vec2 best = v;
    double best_d = std::numeric_limits<double>::infinity(), own = best_d;
    for (size_t k = 0; k < barriers.polygons().size(); ++k)
      for (const Ring& r : barriers.polygons()[k].rings)
        for (size_t i = 0; i < r.size(); ++i) {
          const Vec2 f = foot(r[i], r[(i + 1) % r.size()], v);
          const double d = length(f, v);
          own = std::min(own, d);
          if (d < best_d && !under_another(barriers, k, f)) {
            best_d = d;
            best = f;
          }
        }
    // A line's or a polygon's vertex on a barrier polygon's boundary (to rounding) that another
    // barrier covers lies on a land border where two barriers overlap (the western Baltic's
    // states): no path reaches it, the seed is reached where it is at sea, and it stays.
    const double rounding = 16.0 * std::numeric_limits<double>::epsilon() * std::max(std::abs(v.x), std::abs(v.y));
    if (!point && own <= rounding && best_d > tolerance) {
      ++counted.second;
      bordered.insert(key);
      return given_v;
    }
    if (!(best_d <= tolerance))
      throw Error(ErrorKind::invalid_input, "the seed " + seeds.feature_name(feature) + " lies " +
                                                short_number(best_d) +
                                                " inside a barrier (more than the snapping tolerance of " +
                                                short_number(tolerance) + "): a seed may lie on a barrier's boundary");
    // Onto the boundary; where rounding left the point on land, out along the same direction by
    // growing steps of a unit in the last place (geodesic: from a micrometre, and judged after
    // the round trip to longitude/latitude and back) until it is sea.
    Vec2 to = best, result = best;
    const double dx = best.x - v.x, dy = best.y - v.y, len = std::hypot(dx, dy);
    const double ulp = std::numeric_limits<double>::epsilon() * std::max({std::abs(best.x), std::abs(best.y), 1e-300});
    const double first = f ? std::max(ulp, 1e-6) : ulp;
    auto land_after = [&](Vec2 p) {
      result = f ? f->reverse(p) : p;
      return vis.on_land(f ? f->forward(result) : p);
    };
    bool on_land = f ? true : land_after(to);  // (geodesic: onto the boundary is not enough)
    for (double step = first; on_land && step < 1e6 * first; step *= 2.0) {
      to = len > 0.0 ? Vec2{best.x + dx / len * step, best.y + dy / len * step} : Vec2{best.x + step, best.y};
      on_land = land_after(to);
    }
    if (on_land)
      throw Error(ErrorKind::internal, "the seed " + seeds.feature_name(feature) + " could not be moved off land");
    moved.emplace(key, result);
    ++out.moved;
    out.largest_move = std::max(out.largest_move, length(to, v));
    return result;
  };
  std::vector<Site> sites = seeds.sites();
  for (Site& s : sites) {
    if (s.kind == SiteKind::area) continue;
    const bool point = s.kind == SiteKind::point;
    s.a = place(s.a, s.feature, point);
    s.b = point ? s.a : place(s.b, s.feature, false);
  }
  std::vector<Polygon> polygons = seeds.polygons();
  for (Polygon& p : polygons)
    for (Ring& r : p.rings)
      for (Vec2& v : r) v = place(v, p.feature, false);
  // A seed whose every vertex lies on land borders is inside the barriers, not on their boundary.
  for (const auto& [feature, counted] : vertices)
    if (counted.second > 0 && counted.second == counted.first)
      throw Error(ErrorKind::invalid_input, "the seed " + seeds.feature_name(feature) +
                                                " lies inside the barriers (each of its vertices on a border between "
                                                "two barriers that overlap): a seed may lie on a barrier's boundary");
  out.on_land_borders = static_cast<int64_t>(bordered.size());
  if (out.moved == 0) {
    out.seeds = seeds;
    return out;
  }
  out.seeds = SeedSet::from_parts(std::move(sites), std::move(polygons), seeds.features(), seeds.owner_labels());
  return out;
}

}  // namespace rv
