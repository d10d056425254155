#include <gtest/gtest.h>

#include "rv/field/error.hpp"
#include "rv/field/grid.hpp"

namespace rv {
namespace {

TEST(Grid, CellCentresFollowGdalConvention) {
  const GridSpec g = make_grid(100.0, 200.0, 110.0, 205.0, 0.5, "");
  EXPECT_EQ(g.width, 20);
  EXPECT_EQ(g.height, 10);
  EXPECT_DOUBLE_EQ(g.centre_x(0), 100.25);
  EXPECT_DOUBLE_EQ(g.centre_y(0), 204.75);  // row 0 is the northern row
  EXPECT_DOUBLE_EQ(g.centre_y(9), 200.25);
  EXPECT_DOUBLE_EQ(g.xmax(), 110.0);
  EXPECT_DOUBLE_EQ(g.ymin(), 200.0);
}

TEST(Grid, PartialCellsGrowTheGridButRoundingNoiseDoesNot) {
  EXPECT_EQ(make_grid(0, 0, 10.1, 1, 1.0, "").width, 11);
  EXPECT_EQ(make_grid(0, 0, 0.3, 1, 0.1, "").width, 3);  // 0.3/0.1 = 2.9999999999999996
}

TEST(Grid, AlignedGridSnapsOutward) {
  const GridSpec g = make_aligned_grid(3.2, 7.9, 17.1, 12.0, 2.0, "");
  EXPECT_DOUBLE_EQ(g.xmin, 2.0);
  EXPECT_DOUBLE_EQ(g.ymax, 12.0);
  EXPECT_EQ(g.width, 8);   // 2..18
  EXPECT_EQ(g.height, 3);  // 6..12
}

TEST(Grid, InvalidExtentsAreRefused) {
  EXPECT_THROW(make_grid(5, 0, 5, 1, 1, ""), Error);   // xmin == xmax
  EXPECT_THROW(make_grid(6, 0, 5, 1, 1, ""), Error);   // xmin > xmax
  EXPECT_THROW(make_grid(0, 0, 5, 1, 0, ""), Error);   // res 0
  EXPECT_THROW(make_grid(0, 0, 5, 1, -2, ""), Error);  // res < 0
  EXPECT_THROW(make_grid(0, 0, std::numeric_limits<double>::infinity(), 1, 1, ""), Error);
  EXPECT_THROW(make_grid(0, 0, 1e12, 1, 1e-3, ""), Error);  // 1e15 columns
}

}  // namespace
}  // namespace rv
