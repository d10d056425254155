#include <gtest/gtest.h>

#include "rv/field/interior.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

GridSpec grid10() { return test::grid_of(10, 10); }

TEST(Interior, SquareWithHole) {
  SeedSet s;
  s.add_polygon(s.add_feature(s.owner_code("a")), {{{1, 1}, {9, 1}, {9, 9}, {1, 9}}, {{4, 4}, {6, 4}, {6, 6}, {4, 6}}});
  const InteriorSpans sp = build_interiors(s, grid10(), grid10().full_window());
  // 8x8 cells minus the 2x2 hole.
  EXPECT_EQ(sp.cell_count(), 64 - 4);
  // Row 5 (centre y = 4.5) crosses the hole: two spans.
  ASSERT_EQ(sp.rows[5].size(), 2u);
  EXPECT_EQ(sp.rows[5][0].col0, 1);
  EXPECT_EQ(sp.rows[5][0].col1, 4);
  EXPECT_EQ(sp.rows[5][1].col0, 6);
  EXPECT_EQ(sp.rows[5][1].col1, 9);
}

TEST(Interior, SharedEdgeClaimsEachCellOnce) {
  // Two squares sharing the edge x = 5 exactly through cell centres? No: x = 5.5 is a centre
  // line; with the half-open rule the centre on the shared edge goes to exactly one polygon.
  SeedSet s;
  s.add_polygon(s.add_feature(s.owner_code("w")), {{{0.5, 0}, {5.5, 0}, {5.5, 10}, {0.5, 10}}});
  s.add_polygon(s.add_feature(s.owner_code("e")), {{{5.5, 0}, {9.5, 0}, {9.5, 10}, {5.5, 10}}});
  const InteriorSpans sp = build_interiors(s, grid10(), grid10().full_window());
  EXPECT_EQ(sp.contested_cells, 0);
  for (const auto& row : sp.rows) {
    ASSERT_EQ(row.size(), 2u);
    EXPECT_EQ(row[0].col1, 5);  // centre 5.5 not in the west square (right edge is open)
    EXPECT_EQ(row[1].col0, 5);  // but in the east one (left edge is closed)
  }
}

TEST(Interior, OverlapGoesToTheLowerFeatureAndIsCounted) {
  SeedSet s;
  s.add_polygon(s.add_feature(s.owner_code("a")), {{{0, 0}, {6, 0}, {6, 10}, {0, 10}}});
  s.add_polygon(s.add_feature(s.owner_code("b")), {{{4, 0}, {10, 0}, {10, 10}, {4, 10}}});
  const InteriorSpans sp = build_interiors(s, grid10(), grid10().full_window());
  EXPECT_EQ(sp.contested_cells, 20);  // columns 4 and 5, ten rows
  EXPECT_EQ(sp.cell_count(), 100);
  for (const auto& row : sp.rows) {
    ASSERT_EQ(row.size(), 2u);
    EXPECT_EQ(s.site_feature(row[0].site), 0);
    EXPECT_EQ(row[0].col1, 6);
    EXPECT_EQ(s.site_feature(row[1].site), 1);
  }
}

TEST(Interior, WindowClipsSpans) {
  SeedSet s;
  s.add_polygon(s.add_feature(s.owner_code("a")), {{{1, 1}, {9, 1}, {9, 9}, {1, 9}}});
  const InteriorSpans sp = build_interiors(s, grid10(), Window{5, 0, 5, 3});
  EXPECT_EQ(sp.rows.size(), 3u);
  EXPECT_TRUE(sp.rows[0].empty());  // row 0: centre y 9.5, outside
  ASSERT_EQ(sp.rows[1].size(), 1u);
  EXPECT_EQ(sp.rows[1][0].col0, 0);
  EXPECT_EQ(sp.rows[1][0].col1, 4);  // columns 5..8 of the grid
}

}  // namespace
}  // namespace rv
