// StripLines (rv/lines/strip_lines.hpp): boundaries, tripoints and limit lines taken in strip by
// strip equal the whole field's, vertex for vertex, for every strip height (one row, a few, more
// than the stages' lags, uneven), strips of their own or row ranges of the whole field read in
// place, planar and geodesic, with polygons, lines, points, four owners and a max distance;
// strips out of order and early requests are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "line_compare.hpp"
#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/strip_lines.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

struct Case {
  SeedSet seeds;
  GridSpec grid;
  ComputeOptions compute;
  std::unique_ptr<SiteMetric> metric;
  std::unique_ptr<OwnerIndex> index;
  NearestField whole;
  LineRequest request;

  Case(SeedSet s, GridSpec g, bool geodesic, double max_distance) : seeds(std::move(s)), grid(g) {
    compute.threads = 2;
    compute.max_distance = max_distance;
    if (geodesic) {
      compute.metric.kind = MetricSpec::geodesic;
      metric = std::make_unique<GeodesicSiteMetric>(seeds, compute.metric);
    } else {
      metric = std::make_unique<PlanarSiteMetric>(seeds, Vec2{g.xmin, g.ymax});
    }
    index = std::make_unique<OwnerIndex>(*metric);
    whole = rv::compute(seeds, grid, compute);
    request.boundaries = true;
    request.boundary.threads = 2;
    request.limit.threads = 2;
    request.limit.per_owner = false;
  }

  // The lines from strips of the given heights (cycled until the grid is covered).
  StripLines strips(const std::vector<int64_t>& heights) const {
    StripLines lines(grid, *index, request);
    NearestField strip;
    ComputeOptions o = compute;
    for (int64_t row0 = 0, k = 0; row0 < grid.height; ++k) {
      const int64_t h = std::min(heights[static_cast<size_t>(k) % heights.size()], grid.height - row0);
      o.window = Window{0, row0, grid.width, h};
      compute_into(seeds, grid, o, strip);
      lines.add(strip);
      row0 += h;
    }
    return lines;
  }
  // The lines from row ranges of the given heights of the whole field (add(strip, row0, row1):
  // read where they lie, not copied).
  StripLines ranges(const std::vector<int64_t>& heights) const {
    StripLines lines(grid, *index, request);
    for (int64_t row0 = 0, k = 0; row0 < grid.height; ++k) {
      const int64_t h = std::min(heights[static_cast<size_t>(k) % heights.size()], grid.height - row0);
      lines.add(whole, row0, row0 + h);
      row0 += h;
    }
    return lines;
  }
};

void check_every_strip_height(Case& k, std::vector<double> limits) {
  k.request.limit_distances = limits;
  for (bool per_owner : {false, true}) {
    k.request.limit.per_owner = per_owner;
    const BoundaryResult whole_b = extract_boundaries(k.whole, *k.index, k.request.boundary);
    const LimitResult whole_l = extract_limits(k.whole, *k.index, limits, k.request.limit);
    ASSERT_GT(whole_b.lines.size(), 3u);
    ASSERT_GT(whole_b.tripoints.size(), 0u);
    ASSERT_GT(whole_l.lines.size(), 0u);
    for (const std::vector<int64_t>& heights : std::vector<std::vector<int64_t>>{{1}, {2}, {3}, {5, 1, 9}, {64}}) {
      SCOPED_TRACE("strips of " + std::to_string(heights.front()) + " rows, per owner " + std::to_string(per_owner));
      StripLines lines = k.strips(heights);
      EXPECT_EQ(lines.rows(), k.grid.height);
      test::expect_same_lines(lines.take_boundaries(), whole_b);
      test::expect_same_lines(lines.take_limits(), whole_l);
      StripLines from_ranges = k.ranges(heights);
      EXPECT_EQ(from_ranges.rows(), k.grid.height);
      test::expect_same_lines(from_ranges.take_boundaries(), whole_b);
      test::expect_same_lines(from_ranges.take_limits(), whole_l);
    }
  }
}

TEST(StripLines, PlanarStripsGiveTheWholeFieldsLines) {
  for (uint32_t seed : {3u, 11u}) {
    Case k(test::mixed_seeds(seed), test::grid_of(60, 45), false, std::numeric_limits<double>::infinity());
    check_every_strip_height(k, {2.5, 6.0});
  }
}

TEST(StripLines, StripsWithAMaxDistanceGiveTheWholeFieldsLines) {
  // Cells beyond 9 units have no owner: lines stop there, limits beyond it follow the field's end.
  Case k(test::mixed_seeds(5), test::grid_of(60, 45), false, 9.0);
  check_every_strip_height(k, {4.0, 12.0});
}

TEST(StripLines, GeodesicStripsGiveTheWholeFieldsLines) {
  // Degrees around 12 E 55 N: 0.02 degree cells (about 1.3 x 2.2 km).
  Case k(test::mixed_seeds(7, {}, 0.02, {11.4, 54.6}), test::grid_of(60, 45, 0.02, 11.4, 55.5), true,
         std::numeric_limits<double>::infinity());
  check_every_strip_height(k, {3000.0, 8000.0});
}

TEST(StripLines, StripsOutOfOrderAndEarlyRequestsAreRefused) {
  Case k(test::mixed_seeds(3), test::grid_of(60, 45), false, std::numeric_limits<double>::infinity());
  k.request.limit_distances = {3.0};
  StripLines lines(k.grid, *k.index, k.request);
  NearestField strip;
  ComputeOptions o = k.compute;
  o.window = Window{0, 10, k.grid.width, 5};  // not row 0
  compute_into(k.seeds, k.grid, o, strip);
  EXPECT_THROW(lines.add(strip), Error);
  o.window = Window{0, 0, 30, 5};  // not whole rows
  compute_into(k.seeds, k.grid, o, strip);
  EXPECT_THROW(lines.add(strip), Error);
  o.window = Window{0, 0, k.grid.width, 5};
  compute_into(k.seeds, k.grid, o, strip);
  lines.add(strip);
  EXPECT_EQ(lines.rows(), 5);
  EXPECT_THROW(lines.take_boundaries(), Error);  // rows missing
  EXPECT_THROW(lines.add(strip), Error);         // the same rows again
  // Row ranges: within the strip, starting where the last ended, not empty.
  o.window = Window{0, 5, k.grid.width, 10};
  compute_into(k.seeds, k.grid, o, strip);
  EXPECT_THROW(lines.add(strip, 6, 9), Error);    // a gap before row 6
  EXPECT_THROW(lines.add(strip, 5, 5), Error);    // no rows
  EXPECT_THROW(lines.add(strip, 5, 16), Error);   // beyond the strip
  EXPECT_THROW(lines.add(k.whole, 4, 9), Error);  // rows already in
  lines.add(strip, 5, 9);
  lines.add(k.whole, 9, 12);
  EXPECT_EQ(lines.rows(), 12);
  EXPECT_THROW(StripLines(k.grid, *k.index, LineRequest{false, {}, {0.0}, {}}), Error);
}

}  // namespace
}  // namespace rv
