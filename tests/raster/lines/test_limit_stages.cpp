// The stages of distance-limit lines (raster/src/lines/limit_stages.hpp), each on its own, on fields
// whose limits are known in closed form: circles around basepoints. Every stage also runs over
// strips of rows, the shape streaming feeds it: the strips' pieces together are the whole's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "lines/limit_stages.hpp"
#include "lines/line_tools.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/limits.hpp"
#include "seed_gen.hpp"

namespace rv::limit_stages {
namespace {

// Basepoints on a grid of 120 x 100 unit cells (owner A: the first, B: the others), and what the
// stages read.
struct Case : test::PointsField {
  LimitGrid lg;
  explicit Case(const std::vector<Vec2>& points, double max_distance = std::numeric_limits<double>::infinity())
      : PointsField(points, {"A", "B", "B"}, test::grid_of(120, 100), max_distance),
        lg{field, index, metric, grid, grid.width, grid.height, 2, 1.0, 1e-9, line_tools::owner_of_sites(seeds)} {}
  double d(Vec2 p, int32_t owner) const { return distance(p, owner); }
};

const std::vector<Vec2> kPoints{{40.3, 50.2}, {85.6, 47.1}};

TEST(LimitStages, InsideIsWithinTheDistanceForAllSeedsAndPerOwner) {
  const Case k(kPoints);
  for (int32_t owner : {0, 1, 2}) {
    const Target t{k.lg, owner, 17.25};
    InsideRows inside;
    inside_flags(t, 0, k.grid.height, inside);
    int64_t in = 0;
    for (int64_t r = 0; r < k.grid.height; ++r)
      for (int64_t c = 0; c < k.grid.width; ++c) {
        const bool expected = k.d(line_tools::centre(k.grid, c, r), owner) <= 17.25;
        ASSERT_EQ(inside.at(c, r), expected) << owner << ": " << c << ", " << r;
        in += expected;
      }
    EXPECT_GT(in, 800);
    // Strips of rows appended one after another make the same flags.
    InsideRows strips;
    for (int64_t r0 = 0; r0 < k.grid.height; r0 += 11) inside_flags(t, r0, std::min<int64_t>(r0 + 11, 100), strips);
    EXPECT_EQ(strips.flags, inside.flags) << owner;
    // Rows dropped from the front keep the others where they were.
    strips.drop_before(40);
    EXPECT_EQ(strips.row0, 40);
    EXPECT_EQ(strips.row1(), 100);
    for (int64_t c = 0; c < k.grid.width; ++c) ASSERT_EQ(strips.at(c, 57), inside.at(c, 57));
    // Flags are appended in row order only.
    EXPECT_THROW(inside_flags(t, 10, 20, strips), Error);
  }
}

TEST(LimitStages, CellsBeyondTheFieldsMaxDistanceAreOutsideInEveryStrip) {
  // The field has no site beyond 20: a limit at 25 is drawn where the field ends.
  const Case k(kPoints, 20.0);
  const Target t{k.lg, 0, 25.0};
  InsideRows strips;
  for (int64_t r0 = 0; r0 < k.grid.height; r0 += 13) inside_flags(t, r0, std::min<int64_t>(r0 + 13, 100), strips);
  int64_t in = 0;
  for (int64_t r = 0; r < k.grid.height; ++r)
    for (int64_t c = 0; c < k.grid.width; ++c) {
      const bool expected = k.field.site.at(c, r) != kNoSite;  // within 20, hence within 25
      ASSERT_EQ(strips.at(c, r), expected) << c << ", " << r;
      in += expected;
    }
  EXPECT_GT(in, 1000);
  EXPECT_LT(in, k.grid.cell_count() / 2);
}

TEST(LimitStages, CrossingsLieAtTheDistanceOnTheirEdges) {
  const Case k(kPoints);
  const Target t{k.lg, 0, 17.25};
  InsideRows inside;
  inside_flags(t, 0, 100, inside);
  const LimitCrossings x = limit_crossings(t, inside, 0, 100);
  ASSERT_GT(x.edges.size(), 100u);
  ASSERT_EQ(x.verts.size(), x.edges.size());
  for (size_t i = 0; i < x.edges.size(); ++i) {
    EXPECT_NEAR(k.d(x.verts[i].p, 0), 17.25, 1e-6);
    EXPECT_EQ(x.at.at(x.edges[i]), static_cast<int32_t>(i));
  }
  // Strips' crossings are the whole's, in the same order.
  std::vector<int64_t> edges;
  for (int64_t r0 = 0; r0 < 100; r0 += 9) {
    const LimitCrossings part = limit_crossings(t, inside, r0, std::min<int64_t>(r0 + 9, 100));
    edges.insert(edges.end(), part.edges.begin(), part.edges.end());
  }
  EXPECT_EQ(edges, x.edges);
}

TEST(LimitStages, LinksAndChainsCloseEachCircle) {
  const Case k(kPoints);
  for (int32_t owner : {0, 1}) {
    const Target t{k.lg, owner, 17.25};
    InsideRows inside;
    inside_flags(t, 0, 100, inside);
    const LimitCrossings x = limit_crossings(t, inside, 0, 100);
    const auto links = limit_links(t, inside, x, 0, 100);
    // Every crossing of a circle inside the grid has two links.
    std::vector<int> degree(x.verts.size(), 0);
    for (const auto& l : links) {
      ++degree[static_cast<size_t>(l[0])];
      ++degree[static_cast<size_t>(l[1])];
    }
    for (int n : degree) EXPECT_EQ(n, 2);
    // Links of strips of squares, together, are the whole's.
    std::vector<std::array<int32_t, 2>> joined;
    for (int64_t r0 = 0; r0 < 100; r0 += 7) {
      const auto part = limit_links(t, inside, x, r0, std::min<int64_t>(r0 + 7, 100));
      joined.insert(joined.end(), part.begin(), part.end());
    }
    EXPECT_EQ(joined, links);
    LimitResult result;
    chain_limit_lines(t, x, links, 0.0, result);
    // Owner A's circle alone; all seeds: two circles (17.25 apart of 45.4: disjoint).
    ASSERT_EQ(result.lines.size(), owner == 0 ? 2u : 1u);
    for (const LimitLine& line : result.lines) {
      EXPECT_TRUE(line.closed);
      EXPECT_EQ(line.owner, owner);
      EXPECT_EQ(line.distance, 17.25);
      EXPECT_GT(line.vertices.size(), 40u);
      for (const LimitVertex& v : line.vertices) EXPECT_NEAR(k.d(v.p, owner), 17.25, 1e-6);
    }
    EXPECT_LE(result.max_residual, 1e-6);
    // Simplified at a cell, a circle of radius 17 keeps fewer vertices, each still on it.
    LimitResult coarse;
    chain_limit_lines(t, x, links, 1.0, coarse);
    ASSERT_EQ(coarse.lines.size(), result.lines.size());
    EXPECT_LT(coarse.vertices, result.vertices / 2);
  }
}

}  // namespace
}  // namespace rv::limit_stages
