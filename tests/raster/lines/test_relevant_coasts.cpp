// RelevantCoasts: the parts of the seeds nearest to the cells of a relevant area, against the
// geometry of simple cases, whole or in strips.
#include <gtest/gtest.h>

#include <cmath>

#include "relevant_strips.hpp"
#include "rv/engine/engine.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/interior.hpp"
#include "rv/lines/relevant_coasts.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

// The relevant area as a polygon seed set, its interiors over the whole grid.
InteriorSpans area_of(const std::vector<Vec2>& ring, const GridSpec& g, SeedSet& holder) {
  const int32_t f = holder.add_feature(holder.owner_code("area"));
  holder.add_polygon(f, {Ring(ring.begin(), ring.end())});
  return build_interiors(holder, g, g.full_window());
}

// A straight coast (y = 0, x from 0 to 100) and an island point far out: the cells of the area
// [20, 70] x [5, 25] are all nearest to the coast, whose relevant part runs from the first
// column's centre to the last's (x = 20.5 .. 69.5); the island has none.
TEST(RelevantCoasts, TheStretchUnderTheArea) {
  SeedSet s;
  const int32_t a = s.add_feature(s.owner_code("A"));
  const std::vector<Vec2> coast{{0.0, 0.0}, {100.0, 0.0}};
  s.add_polyline(a, coast);
  const int32_t b = s.add_feature(s.owner_code("B"));
  s.add_point(b, {50.0, 60.0});
  const GridSpec g = test::grid_of(100, 80, 1.0, 0.0, 79.0);  // rows from y = 79 down to y = -1
  const NearestField field = compute(s, g, ComputeOptions{});
  const PlanarSiteMetric m(s, Vec2{g.xmin, g.ymax});
  SeedSet holder;
  const InteriorSpans area = area_of({{20, 5}, {70, 5}, {70, 25}, {20, 25}}, g, holder);
  for (const int64_t rows : {int64_t{80}, int64_t{7}, int64_t{1}}) {
    SCOPED_TRACE(rows);
    const auto st = test::relevant_stretches(field, m, area, rows);
    ASSERT_EQ(st.size(), 1u);
    EXPECT_EQ(st[0].site, 0);
    EXPECT_NEAR(st[0].from.x, 20.5, 1e-9);
    EXPECT_NEAR(st[0].to.x, 69.5, 1e-9);
    EXPECT_NEAR(st[0].length, 49.0, 1e-9);
  }
  // An area reaching the island's side: its point counts, with length 0.
  SeedSet holder2;
  const InteriorSpans wide = area_of({{20, 5}, {70, 5}, {70, 75}, {20, 75}}, g, holder2);
  const auto st = test::relevant_stretches(field, m, wide, 13);
  ASSERT_EQ(st.size(), 2u);
  EXPECT_EQ(st[1].site, 1);
  EXPECT_EQ(st[1].length, 0.0);
  EXPECT_NEAR(st[0].length, 49.0, 1e-9);
}

}  // namespace
}  // namespace rv
