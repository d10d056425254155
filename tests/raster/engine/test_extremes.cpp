// The engines on extreme but finite input: seeds whose coordinates are huge against the cell
// size or the grid (the seed reader accepts any finite coordinate in a projected CRS), polygons
// far larger than the grid. Every method must agree with brute force, and no double -> integer
// conversion may overflow (the sanitizer build checks float-cast-overflow).
#include <gtest/gtest.h>

#include <limits>

#include "rv/engine/engine.hpp"
#include "rv/engine/validate.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

GridSpec grid16() { return test::grid_of(16, 16); }

NearestField run(const SeedSet& s, const GridSpec& g, Method m) {
  ComputeOptions o;
  o.method = m;
  o.threads = 2;
  return compute(s, g, o);
}

void expect_all_methods_agree(const SeedSet& s, const GridSpec& g, const char* what) {
  const NearestField brute = run(s, g, Method::brute_force);
  const NearestField exact = run(s, g, Method::exact);
  EXPECT_EQ(exact.site.cells(), brute.site.cells()) << what;
  EXPECT_EQ(exact.distance.cells(), brute.distance.cells()) << what;
  for (Method m : {Method::hv_scan, Method::h_scan}) {
    const NearestField f = run(s, g, m);  // approximate methods: must run and cover every cell
    EXPECT_EQ(compare_fields(s, f, brute).nodata_mismatch, 0) << what << " " << to_string(m);
  }
}

TEST(Extremes, FarAwayPointsOnAThinLine) {
  // The exact method's bucket grid spans 1e30 in x and 1e-8 in y: w / size ~ 1e19 buckets.
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("near")), {8.25, 8.5});
  s.add_point(s.add_feature(s.owner_code("far")), {1e30, 8.5 + 1e-8});
  expect_all_methods_agree(s, grid16(), "thin line");
}

TEST(Extremes, SeedsAtTheEndsOfTheDoubleRange) {
  // Local extents overflow to infinity (1e308 - -1e308).
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("west")), {-1e308, -1e308});
  s.add_point(s.add_feature(s.owner_code("east")), {1e308, 1e308});
  s.add_point(s.add_feature(s.owner_code("here")), {3.5, 12.5});
  expect_all_methods_agree(s, grid16(), "double range");
}

TEST(Extremes, PolygonFarLargerThanTheGridOwnsEveryCellAtDistanceZero) {
  // Edges 1e20 cells away: their row range is far outside any integer-convertible window.
  SeedSet s;
  const int32_t f = s.add_feature(s.owner_code("ocean"));
  s.add_polygon(f, {{{-1e20, -1e20}, {1e20, -1e20}, {1e20, 1e20}, {-1e20, 1e20}}});
  const GridSpec g = grid16();
  for (Method m : {Method::exact, Method::brute_force, Method::hv_scan}) {
    const NearestField field = run(s, g, m);
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        ASSERT_EQ(field.distance.at(c, r), 0.0f) << to_string(m) << " cell " << c << "," << r;
        ASSERT_EQ(s.site_owner(field.site.at(c, r)), s.owner_code("ocean")) << to_string(m);
      }
  }
}

}  // namespace
}  // namespace rv
