#include "rv/sea/snap.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
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
  auto place = [&](Vec2 given_v, int32_t feature) -> Vec2 {
    const auto key = std::make_pair(given_v.x, given_v.y);
    if (const auto it = moved.find(key); it != moved.end()) return it->second;
    const Vec2 v = to_plane(given_v);
    if (!vis.on_land(v)) return given_v;
    // The nearest point of every barrier polygon's boundary (lines have no inside to leave).
    Vec2 best = v;
    double best_d = std::numeric_limits<double>::infinity();
    for (const Barriers::Polygon& p : barriers.polygons())
      for (const Ring& r : p.rings)
        for (size_t i = 0; i < r.size(); ++i) {
          const Vec2 f = foot(r[i], r[(i + 1) % r.size()], v);
          const double d = length(f, v);
          if (d < best_d) {
            best_d = d;
            best = f;
          }
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
    s.a = place(s.a, s.feature);
    s.b = s.kind == SiteKind::point ? s.a : place(s.b, s.feature);
  }
  std::vector<Polygon> polygons = seeds.polygons();
  for (Polygon& p : polygons)
    for (Ring& r : p.rings)
      for (Vec2& v : r) v = place(v, p.feature);
  if (out.moved == 0) {
    out.seeds = seeds;
    return out;
  }
  out.seeds = SeedSet::from_parts(std::move(sites), std::move(polygons), seeds.features(), seeds.owner_labels());
  return out;
}

}  // namespace rv
