// Test helpers: two extractions' lines compared vertex for vertex (positions, controlling sites
// and distances bit for bit), with their tripoints and statistics; and a field's owner changes
// checked to have a line between them.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <functional>

#include "rv/engine/engine.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"

namespace rv::test {

// Whether a line of owners a and b crosses or touches segment p-q.
inline bool line_between(const BoundaryResult& r, int32_t a, int32_t b, Vec2 p, Vec2 q) {
  auto side = [](Vec2 u, Vec2 v, Vec2 w) { return (v.x - u.x) * (w.y - u.y) - (v.y - u.y) * (w.x - u.x); };
  auto apart = [](double s1, double s2) { return (s1 <= 0.0 && s2 >= 0.0) || (s1 >= 0.0 && s2 <= 0.0); };
  for (const BoundaryLine& l : r.lines) {
    if (!((l.owner_a == a && l.owner_b == b) || (l.owner_a == b && l.owner_b == a))) continue;
    for (size_t k = 0; k + 1 < l.vertices.size(); ++k) {
      const Vec2 u = l.vertices[k].p, v = l.vertices[k + 1].p;
      if (apart(side(u, v, p), side(u, v, q)) && apart(side(p, q, u), side(p, q, v))) return true;
    }
  }
  return false;
}

// Whether lines part a from b across segment p-q: a line of owners a and b crosses it, or a
// sliver of a third owner k lies between (lines of a and k and of k and b both cross it: near a
// tripoint where two lines meet at a small angle).
inline bool parted(const BoundaryResult& r, int32_t a, int32_t b, Vec2 p, Vec2 q) {
  if (line_between(r, a, b, p, q)) return true;
  for (const BoundaryLine& l : r.lines)
    for (const int32_t k : {l.owner_a, l.owner_b})
      if (k != a && k != b && line_between(r, a, k, p, q) && line_between(r, k, b, p, q)) return true;
  return false;
}

// Every two 4-neighbouring cells of `field` (of grid g, sites of `seeds`) owned by a and b, whose
// centres `open` joins, are parted by lines between their centres (no piece of the boundary left
// undrawn). Returns how many such pairs there are.
inline int64_t expect_lines_between(const NearestField& field, const SeedSet& seeds, const GridSpec& g,
                                    const BoundaryResult& r, int32_t a, int32_t b,
                                    const std::function<bool(Vec2, Vec2)>& open) {
  int64_t pairs = 0;
  for (int64_t row = 0; row < g.height; ++row)
    for (int64_t col = 0; col < g.width; ++col)
      for (int d = 0; d < 2; ++d) {
        const int64_t c2 = col + (d == 0), r2 = row + (d == 1);
        if (c2 >= g.width || r2 >= g.height) continue;
        const int32_t s1 = field.site.at(col, row), s2 = field.site.at(c2, r2);
        if (s1 == kNoSite || s2 == kNoSite) continue;
        const int32_t o1 = seeds.site_owner(s1), o2 = seeds.site_owner(s2);
        if (!((o1 == a && o2 == b) || (o1 == b && o2 == a))) continue;
        const Vec2 p{g.centre_x(col), g.centre_y(row)}, q{g.centre_x(c2), g.centre_y(r2)};
        if (!open(p, q)) continue;
        ++pairs;
        EXPECT_TRUE(parted(r, a, b, p, q))
            << "no line between cells " << col << "," << row << " and " << c2 << "," << r2;
      }
  return pairs;
}

inline void expect_same_lines(const BoundaryResult& a, const BoundaryResult& b) {
  ASSERT_EQ(a.lines.size(), b.lines.size());
  for (size_t i = 0; i < a.lines.size(); ++i) {
    ASSERT_EQ(a.lines[i].owner_a, b.lines[i].owner_a);
    ASSERT_EQ(a.lines[i].owner_b, b.lines[i].owner_b);
    ASSERT_EQ(a.lines[i].closed, b.lines[i].closed);
    ASSERT_EQ(a.lines[i].vertices.size(), b.lines[i].vertices.size()) << "line " << i;
    for (size_t k = 0; k < a.lines[i].vertices.size(); ++k) {
      const BoundaryVertex &u = a.lines[i].vertices[k], &v = b.lines[i].vertices[k];
      ASSERT_EQ(u.p, v.p) << "line " << i << " vertex " << k;
      ASSERT_EQ(u.site_a, v.site_a);
      ASSERT_EQ(u.site_b, v.site_b);
      ASSERT_EQ(u.distance, v.distance);
    }
  }
  ASSERT_EQ(a.tripoints.size(), b.tripoints.size());
  for (size_t i = 0; i < a.tripoints.size(); ++i) {
    ASSERT_EQ(a.tripoints[i].p, b.tripoints[i].p);
    ASSERT_EQ(a.tripoints[i].sites[0], b.tripoints[i].sites[0]);
    ASSERT_EQ(a.tripoints[i].sites[2], b.tripoints[i].sites[2]);
  }
  ASSERT_EQ(a.lone_crossings.size(), b.lone_crossings.size());
  const BoundaryStats &s = a.stats, &t = b.stats;
  EXPECT_EQ(s.crossings, t.crossings);
  EXPECT_EQ(s.sliver_crossings, t.sliver_crossings);
  EXPECT_EQ(s.unresolved_slivers, t.unresolved_slivers);
  EXPECT_EQ(s.saddles, t.saddles);
  EXPECT_EQ(s.multi_owner_squares, t.multi_owner_squares);
  EXPECT_EQ(s.unresolved_tripoints, t.unresolved_tripoints);
  EXPECT_EQ(s.repeated_loops, t.repeated_loops);
  EXPECT_EQ(s.vertices, t.vertices);
  EXPECT_EQ(s.vertices_before_simplify, t.vertices_before_simplify);
  EXPECT_EQ(s.max_residual, t.max_residual);
}

inline void expect_same_lines(const LimitResult& a, const LimitResult& b) {
  ASSERT_EQ(a.lines.size(), b.lines.size());
  for (size_t i = 0; i < a.lines.size(); ++i) {
    ASSERT_EQ(a.lines[i].distance, b.lines[i].distance);
    ASSERT_EQ(a.lines[i].owner, b.lines[i].owner);
    ASSERT_EQ(a.lines[i].closed, b.lines[i].closed);
    ASSERT_EQ(a.lines[i].vertices.size(), b.lines[i].vertices.size()) << "line " << i;
    for (size_t k = 0; k < a.lines[i].vertices.size(); ++k) {
      ASSERT_EQ(a.lines[i].vertices[k].p, b.lines[i].vertices[k].p) << "line " << i << " vertex " << k;
      ASSERT_EQ(a.lines[i].vertices[k].site, b.lines[i].vertices[k].site);
    }
  }
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.max_residual, b.max_residual);
}

}  // namespace rv::test
