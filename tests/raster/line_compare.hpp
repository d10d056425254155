// Test helper: two extractions' lines compared vertex for vertex (positions, controlling sites
// and distances bit for bit), with their tripoints and statistics.
#pragma once

#include <gtest/gtest.h>

#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"

namespace rv::test {

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
