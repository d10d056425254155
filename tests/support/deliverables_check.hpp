// Test helpers for the deliverables: an independent brute-force planar distance to an owner's
// seeds (not the OwnerIndex under test), and the checks the acceptance criteria name.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "rv/lines/boundaries.hpp"
#include "rv/lines/regions.hpp"

namespace rv::test {

inline double segment_distance(Vec2 p, Vec2 a, Vec2 b) {
  const double dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
  double t = len2 > 0 ? ((p.x - a.x) * dx + (p.y - a.y) * dy) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(p.x - (a.x + t * dx), p.y - (a.y + t * dy));
}

inline bool inside_polygon(Vec2 p, const Polygon& poly) {
  bool in = false;
  for (const Ring& ring : poly.rings)
    for (size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
      const Vec2 a = ring[i], b = ring[j];
      if ((a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y)) in = !in;
    }
  return in;
}

// Is p inside a polygon of `owner` (0: of any owner)?
inline bool inside_any(const SeedSet& s, Vec2 p, int32_t owner) {
  for (const Polygon& poly : s.polygons()) {
    if (owner != 0 && s.features()[poly.feature].owner != owner) continue;
    if (inside_polygon(p, poly)) return true;
  }
  return false;
}

// Planar distance from p to the nearest seed of `owner` (0: of any owner), by brute force.
inline double brute_owner_distance(const SeedSet& s, Vec2 p, int32_t owner) {
  if (inside_any(s, p, owner)) return 0.0;
  double best = std::numeric_limits<double>::infinity();
  for (const Site& site : s.sites()) {
    if (owner != 0 && s.features()[site.feature].owner != owner) continue;
    if (site.kind == SiteKind::area) continue;
    best = std::min(best, segment_distance(p, site.a, site.b));
  }
  return best;
}

// Every vertex equidistant from the two owners within tol, and on a cell-centre segment whose
// two cells have different owners (tripoint vertices excepted: they are checked separately),
// but for the vertices refinement added between them (BoundaryOptions::line_tolerance): at most
// as many as BoundaryStats counts, equidistant like every other.
// `sliver_vertices` (optional) counts the vertices on segments whose cells have other owners
// than the line's (sides of regions thinner than a cell, see BoundaryStats::sliver_crossings).
inline void check_boundaries(const SeedSet& s, const NearestField& field, const BoundaryResult& b, double tol,
                             int64_t* sliver_vertices = nullptr) {
  const GridSpec& g = field.site.grid();
  auto owner_at = [&](int64_t c, int64_t r) {
    const int32_t site = field.site.at(c, r);
    return site == kNoSite ? 0 : s.site_owner(site);
  };
  auto is_tripoint = [&](Vec2 p) {
    for (const Tripoint& t : b.tripoints)
      if (t.p == p) return true;
    return false;
  };
  int64_t refined = 0;
  for (const BoundaryLine& line : b.lines) {
    ASSERT_LT(line.owner_a, line.owner_b);
    ASSERT_GE(line.vertices.size(), 2u);
    for (const BoundaryVertex& v : line.vertices) {
      const double da = brute_owner_distance(s, v.p, line.owner_a);
      const double db = brute_owner_distance(s, v.p, line.owner_b);
      ASSERT_LE(std::abs(da - db), tol) << "vertex (" << v.p.x << ", " << v.p.y << ")";
      ASSERT_LE(da, brute_owner_distance(s, v.p, 0) + tol) << "a third owner is nearer";
      if (is_tripoint(v.p)) continue;
      // On a horizontal or vertical segment between two cell centres of the line's owners.
      const double fc = (v.p.x - g.xmin) / g.res - 0.5, fr = (g.ymax - v.p.y) / g.res - 0.5;
      const bool on_row = std::abs(fr - std::round(fr)) < 1e-9, on_col = std::abs(fc - std::round(fc)) < 1e-9;
      if (!on_row && !on_col) {
        ++refined;  // off the cell-centre lines
        continue;
      }
      int64_t c0, r0, c1, r1;
      if (on_row) {
        r0 = r1 = static_cast<int64_t>(std::llround(fr));
        c0 = static_cast<int64_t>(std::floor(fc));
        c1 = c0 + 1;
        if (on_col) c1 = c0 = static_cast<int64_t>(std::llround(fc));  // exactly on a centre
      } else {
        c0 = c1 = static_cast<int64_t>(std::llround(fc));
        r0 = static_cast<int64_t>(std::floor(fr));
        r1 = r0 + 1;
      }
      if (c0 == c1 && r0 == r1) continue;  // a root at a cell centre (a tie there)
      const int32_t o0 = owner_at(c0, r0), o1 = owner_at(c1, r1);
      if (o0 == o1) {
        ++refined;  // on a cell-centre line by chance, between cells of one owner
        continue;
      }
      if (std::min(o0, o1) == line.owner_a && std::max(o0, o1) == line.owner_b) continue;
      // Otherwise an owner passes between the two centres without holding one (a region
      // thinner than a cell): the vertex is one of its sides, so it shares an owner with one
      // of the two cells, or (several owners between) lies between two of them. The checks
      // above already hold it equidistant with nobody nearer.
      if (sliver_vertices) ++*sliver_vertices;
    }
  }
  EXPECT_LE(refined, b.stats.turning_points + b.stats.arc_points) << "vertices off the cell-centre segments";
  for (const Tripoint& t : b.tripoints) {
    const double d0 = brute_owner_distance(s, t.p, t.owners[0]);
    const double d1 = brute_owner_distance(s, t.p, t.owners[1]);
    const double d2 = brute_owner_distance(s, t.p, t.owners[2]);
    EXPECT_LE(std::max({std::abs(d0 - d1), std::abs(d0 - d2), std::abs(d1 - d2)}), tol);
    EXPECT_LE(d0, brute_owner_distance(s, t.p, 0) + tol);
  }
}

// Ends of open lines that are neither on the grid's border band (on or beyond the outermost
// cell-centre lines) nor at a tripoint: a boundary that stops in the open. Closed lines have no
// ends. Adds the number of ends examined to *ends when given.
inline int dangling_ends(const BoundaryResult& b, const GridSpec& g, int* ends = nullptr) {
  const double eps = 1e-9 * g.res;
  auto on_border = [&](Vec2 p) {
    return p.x <= g.centre_x(0) + eps || p.x >= g.centre_x(g.width - 1) - eps || p.y >= g.centre_y(0) - eps ||
           p.y <= g.centre_y(g.height - 1) + eps;
  };
  auto at_tripoint = [&](Vec2 p) {
    return std::any_of(b.tripoints.begin(), b.tripoints.end(), [&](const Tripoint& t) { return t.p == p; });
  };
  int dangling = 0;
  for (const BoundaryLine& line : b.lines) {
    if (line.closed) continue;
    for (const Vec2 end : {line.vertices.front().p, line.vertices.back().p}) {
      if (ends) ++*ends;
      if (!on_border(end) && !at_tripoint(end)) ++dangling;
    }
  }
  return dangling;
}

// No two segments of the lines cross (they may only share end points: consecutive segments of
// one line, or lines meeting at a tripoint). Quadratic: for small scenes.
inline void check_no_crossings(const BoundaryResult& b) {
  struct Seg {
    Vec2 a, b;
  };
  std::vector<Seg> segs;
  for (const BoundaryLine& line : b.lines)
    for (size_t i = 1; i < line.vertices.size(); ++i) segs.push_back({line.vertices[i - 1].p, line.vertices[i].p});
  auto orient = [](Vec2 p, Vec2 q, Vec2 r) { return (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x); };
  for (size_t i = 0; i < segs.size(); ++i)
    for (size_t j = i + 1; j < segs.size(); ++j) {
      const Seg &s = segs[i], &t = segs[j];
      if (s.a == t.a || s.a == t.b || s.b == t.a || s.b == t.b) continue;
      const double o1 = orient(s.a, s.b, t.a), o2 = orient(s.a, s.b, t.b);
      const double o3 = orient(t.a, t.b, s.a), o4 = orient(t.a, t.b, s.b);
      const bool cross = ((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0));
      ASSERT_FALSE(cross) << "segments (" << s.a.x << "," << s.a.y << ")-(" << s.b.x << "," << s.b.y << ") and ("
                          << t.a.x << "," << t.a.y << ")-(" << t.b.x << "," << t.b.y << ") cross";
    }
}

}  // namespace rv::test
