// Where a shortest path to a seed's edge ends, in the layouts that showed where the statement or
// its arithmetic had holes: at the edge's nearest point from the last bend, at an end of the edge
// (from any sea wedge of a barrier vertex it lies on), or where a barrier meets the edge (a boom
// across it, the coast of land it runs into). Closed forms, both engines cell for cell, the
// blocks against every cell alone, and the triangle inequality between cells that see each other.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "engines_agree.hpp"
#include "random_archipelago.hpp"
#include "relevant_strips.hpp"
#include "rounds.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "rv/field/interior.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/visibility.hpp"
#include "seed_gen.hpp"
#include "wall_sea.hpp"

namespace rv {
namespace {

Vec2 centre(const GridSpec& g, int64_t c, int64_t r) { return Vec2{g.centre_x(c), g.centre_y(r)}; }
double dist(Vec2 a, Vec2 b) { return std::hypot(a.x - b.x, a.y - b.y); }

// Where the lines through a-b and c-d cross (not parallel).
Vec2 crossing(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
  const double den = (b.x - a.x) * (d.y - c.y) - (b.y - a.y) * (d.x - c.x);
  const double t = ((c.x - a.x) * (d.y - c.y) - (c.y - a.y) * (d.x - c.x)) / den;
  return Vec2{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
}

// The position of a cell's via (kNoVia: none).
Vec2 via_at(const SeaField& f, const SeedSet& s, const Barriers& b, const GridSpec& g, int64_t c, int64_t r) {
  const int32_t via = f.via.at(c, r);
  if (via == kNoVia) return Vec2{NAN, NAN};
  return via_position(*prepare_sea(s, b, g), g, via);
}

// A boom across an island's coast that is a seed: a cell beyond the boom from the coast's nearest
// point sees the coast only from where the boom meets it, and its path ends there (no nearest
// point, no end, no bend of the path is that place). The island (0,0)-(4,4), seed and land; the
// boom from (2, 2) to (9, -1.5) meets its east coast at (4, 1). The cell at (7, 0): the coast's
// nearest point (4, 0) lies beyond the boom; the path to (4, 1) touches it there: sqrt(10).
TEST(SeaPathEnds, ASeedsCoastSeenOnlyPastABoomIsReachedWhereTheBoomMeetsIt) {
  Barriers b;
  b.add_polygon({{{0, 0}, {4, 0}, {4, 4}, {0, 4}}}, "island");
  b.add_line(std::vector<Vec2>{{2, 2}, {9, -1.5}}, "boom");
  SeedSet s;
  s.add_polygon(s.add_feature(s.owner_code("island")), {{{0, 0}, {4, 0}, {4, 4}, {0, 4}}});
  s.add_point(s.add_feature(s.owner_code("port")), {11, -4});
  const GridSpec g = test::grid_of(12, 10, 1.0, -0.5, 5.5);  // centres on whole numbers, y 5 .. -4
  const SeaField f = test::engines_agree(s, b, g);
  if (HasFailure()) return;
  ASSERT_EQ(centre(g, 7, 5).x, 7.0);
  ASSERT_EQ(centre(g, 7, 5).y, 0.0);
  EXPECT_EQ(f.field.site.at(7, 5), 1);  // the east coast (4, 0)-(4, 4)
  EXPECT_EQ(f.field.distance.at(7, 5), static_cast<float>(std::sqrt(10.0)));
  EXPECT_EQ(f.via.at(7, 5), kNoVia);  // seen directly, where the boom meets it
  EXPECT_TRUE(test::triangle_inequality_holds(f, b, g, -1, 1e-5));
  // On a grid fine enough for blocks, they answer as every cell alone.
  const SeaField fine = test::blocks_agree(s, b, test::grid_of(96, 80, 0.125, -0.5, 5.5));
  EXPECT_GT(fine.block_cells, 1000);
}

// Two islands that overlap: the coast seed D, the west island's east edge (14, 21)-(11.6, 28),
// runs through the east island's land from y = 23 to where it leaves it on that island's north
// coast, m = (12.04, 26.71). East of the islands the seed is reached at m, round the east
// island's corner (13.8, 27): along that coast to m. (The path along the coast to m, a point
// computed on it, was taken as entering the land when m rounded to the land side: the cells went
// round D's far end instead, and broke the triangle inequality.)
TEST(SeaPathEnds, ASeedRunningThroughLandIsReachedWhereItLeavesTheLand) {
  Barriers b;
  b.add_polygon({{{8, 21}, {14, 21}, {11.6, 28}, {8, 26.6}}, {{10.5, 24}, {11, 22.5}, {9.5, 22.5}}}, "west");
  b.add_polygon({{{9, 23}, {17, 23}, {13.8, 27}, {9, 26.2}}}, "east");
  b.add_polygon({{{25, 17}, {33, 17}, {29.8, 22}, {25, 21}}}, "south");
  b.add_line(std::vector<Vec2>{{11, 25}, {5, 26}}, "boom");
  SeedSet s = test::named_points({{"A", {7.25, 24.75}},
                                  {"B", {6.25, 29.75}},
                                  {"A", {8.25, 7.75}},
                                  {"B", {26.25, 3.75}},
                                  {"A", {10.25, 14.75}},
                                  {"C", {11, 21}}});
  s.add_polyline(s.add_feature(s.owner_code("D")), std::vector<Vec2>{{14, 21}, {11.6, 28}});
  const GridSpec g = test::grid_of(40, 40, 1.0, -1.0, 41.0);
  const SeaField f = test::engines_agree(s, b, g);
  if (HasFailure()) return;
  const Vec2 corner{13.8, 27}, m = crossing({14, 21}, {11.6, 28}, corner, {9, 26.2});
  // Every cell whose path bends at the corner last: D(corner) is the way along the coast to m.
  int cells = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      if (f.via.at(c, r) == kNoVia || via_at(f, s, b, g, c, r) != corner) continue;
      EXPECT_EQ(f.field.site.at(c, r), 6) << c << "," << r;
      EXPECT_NEAR(f.field.distance.at(c, r), dist(centre(g, c, r), corner) + dist(corner, m), 1e-5) << c << "," << r;
      ++cells;
    }
  EXPECT_GE(cells, 4);
  ASSERT_EQ(centre(g, 15, 14).x, 14.5);
  ASSERT_EQ(centre(g, 15, 14).y, 26.5);
  EXPECT_EQ(via_at(f, s, b, g, 15, 14), corner);
  EXPECT_TRUE(test::triangle_inequality_holds(f, b, g, 1));
  const GridSpec fine = test::grid_of(200, 200, 0.2, 0.0, 40.0);
  const SeaField blocks = test::blocks_agree(s, b, fine);
  EXPECT_GT(blocks.block_cells + blocks.drawn_cells, 20000);
  EXPECT_GT(blocks.block_cells, 2000);
  EXPECT_TRUE(test::triangle_inequality_holds(blocks, b, fine, 1));
}

// An island whose east coast (36, 28)-(33.6, 35) is a seed: west of the island the seed's nearest
// point lies on the far side, and the path ends at the seed's north end, a corner of the island
// and a bend node at D = 0 there. Measured from the corner, the seed's nearest point is the corner
// to rounding only (a hair along the coast): the path's arrival there must not be taken as a
// direction it came from (the taut rule then refused the way on round the corner to half the
// cells, which went to a farther port instead).
TEST(SeaPathEnds, ASeedsEndOnABendNodeIsReachedFromEveryDirection) {
  Barriers b;
  b.add_polygon({{{30, 28}, {36, 28}, {33.6, 35}, {30, 33.6}}, {{32.5, 31}, {33, 29.5}, {31.5, 29.5}}}, "island");
  SeedSet s = test::named_points({{"A", {34.25, 35.75}}});
  s.add_polyline(s.add_feature(s.owner_code("D")), std::vector<Vec2>{{36, 28}, {33.6, 35}});
  const GridSpec g = test::grid_of(40, 40, 1.0, -1.0, 41.0);
  const SeaField f = test::engines_agree(s, b, g);
  if (HasFailure()) return;
  const Vec2 end{33.6, 35};
  const Visibility vis(b);
  int cells = 0;
  // West of the island and above its north-west coast's line, seeing the corner: straight to it.
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, r);
      if (x.x >= 30 || vis.classify(x) != Visibility::Ground::open_sea) continue;
      if (!vis.sees(Visibility::Place{x}, Visibility::Place{end})) continue;
      if (dist(x, end) >= dist(x, {34.25, 35.75})) continue;  // (the port is nearer)
      EXPECT_EQ(f.field.site.at(c, r), 1) << c << "," << r;
      EXPECT_NEAR(f.field.distance.at(c, r), dist(x, end), 1e-5) << c << "," << r;
      ++cells;
    }
  EXPECT_GT(cells, 50);
  ASSERT_EQ(centre(g, 30, 7).x, 29.5);
  ASSERT_EQ(centre(g, 30, 7).y, 33.5);
  EXPECT_EQ(f.field.site.at(30, 7), 1);
  EXPECT_EQ(via_at(f, s, b, g, 30, 7), end);
  EXPECT_TRUE(test::triangle_inequality_holds(f, b, g, 1));
}

// Two islands sharing the corner (29, 20), their south coasts one straight line: the seed D, the
// west island's east coast from that corner to (27.8, 22), runs north of it, between the islands.
// South of the coast the seed's nearest point lies past the west island's land, and the path ends
// at the corner: no bend node (the sea there is a half-turn), no crossing, but an end of the seed
// that the south sea touches.
TEST(SeaPathEnds, ASeedsEndWhereTwoIslandsMeetIsReachedFromTheirOtherSide) {
  Barriers b;
  b.add_polygon({{{29, 20}, {34, 20}, {32, 25}, {29, 24}}}, "east");
  b.add_polygon({{{26, 20}, {29, 20}, {27.8, 22}, {26, 21.6}}}, "west");
  SeedSet s;
  s.add_polyline(s.add_feature(s.owner_code("D")), std::vector<Vec2>{{29, 20}, {27.8, 22}});
  const GridSpec g = test::grid_of(60, 40, 0.2, 23.0, 24.0);
  const SeaField f = test::engines_agree(s, b, g);
  if (HasFailure()) return;
  const Vec2 corner{29, 20};
  int cells = 0, past_the_land = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x = centre(g, c, r);
      if (x.y >= 20 || x.x <= 26.5 || x.x >= 31.5) continue;
      EXPECT_EQ(f.field.site.at(c, r), 0) << c << "," << r;
      EXPECT_EQ(f.via.at(c, r), kNoVia) << c << "," << r;
      EXPECT_NEAR(f.field.distance.at(c, r), dist(x, corner), 1e-5) << c << "," << r;
      ++cells;
      // (The foot of the perpendicular on D inside it: behind the west island's land.)
      past_the_land += (x.x - 29) * -1.2 + (x.y - 20) * 2 > 0;
    }
  EXPECT_GT(cells, 400);
  EXPECT_GT(past_the_land, 20);
  EXPECT_TRUE(test::triangle_inequality_holds(f, b, g, 1));
  EXPECT_TRUE(test::same_cells(test::blocks_agree(s, b, g), f, g));
}

// A cell, an island's corner and the cell's foot of the perpendicular on the seed D exactly in
// line: the straight path grazes the corner, and the rounded foot may put it through the corner's
// land. Then the path round the corner is the straight one (no turn), and it counts: the cell's
// distance is the straight distance to D, as for the cells beside it. (It went to a port 40 %
// farther.)
TEST(SeaPathEnds, APathGrazingACornerToTheSeedsFootIsStraight) {
  Barriers b;
  b.add_polygon({{{14, 32}, {21, 32}, {18.2, 36}, {14, 35.2}}}, "east");
  b.add_polygon({{{7, 34}, {14, 34}, {11.2, 40}, {7, 38.8}}, {{9.5, 37}, {10, 35.5}, {8.5, 35.5}}}, "west");
  SeedSet s = test::named_points({{"P", {26.25, 36.75}}});
  const Vec2 a{14, 34}, e{11.2, 40};
  s.add_polyline(s.add_feature(s.owner_code("D")), std::vector<Vec2>{a, e});
  const GridSpec g = test::grid_of(230, 230, 0.2, -1.0, 45.0);
  const SeaField f = test::blocks_agree(s, b, g);
  if (HasFailure()) return;
  // The line through the corner (14, 35.2) square to D: (15, 7) a step, cell centres every
  // 3 units of x from 15.5 on.
  const double len = dist(a, e);
  for (const auto& [c, r] : {std::pair{82, 45}, std::pair{97, 38}}) {  // (beyond: the port is nearer)
    const Vec2 x = centre(g, c, r);
    ASSERT_NEAR((x.x - 14) * 7 - (x.y - 35.2) * 15, 0.0, 1e-9) << c << "," << r;
    const double to_d = std::abs((e.x - a.x) * (x.y - a.y) - (e.y - a.y) * (x.x - a.x)) / len;
    EXPECT_EQ(f.field.site.at(c, r), 1) << c << "," << r;
    EXPECT_NEAR(f.field.distance.at(c, r), to_d, 1e-5) << c << "," << r;
  }
  EXPECT_TRUE(test::triangle_inequality_holds(f, b, g, 1));
  EXPECT_TRUE(test::same_cells(test::engines_agree(s, b, g), f, g));
}

// The relevant coast of a disproportionality test is where the paths of the relevant area's cells
// leave the coast. A coast (y = 0, x from 0 to 100) with a breakwater in front of it (y = 20, x
// from 20 to 80), and the area [40, 60] x [30, 50] behind the breakwater. In a straight line the
// area's cells are nearest to the coast under them, x = 40.5 .. 59.5 (19 long). By sea each path
// rounds an end of the breakwater, D = 20 there, and leaves the coast at that end's foot: (20, 0)
// west of x = 50, (80, 0) east of it, so the stretch is 60 long: whole or in strips, and each
// cell's distance and basepoint are the closed form's.
TEST(SeaPathEnds, TheRelevantCoastIsWhereTheAreasPathsLeaveTheCoast) {
  SeedSet s;
  s.add_polyline(s.add_feature(s.owner_code("coast")), std::vector<Vec2>{{0, 0}, {100, 0}});
  const GridSpec g = test::grid_of(100, 80, 1.0, 0.0, 79.0);  // centres x = 0.5 .. 99.5, y = 78.5 .. -0.5
  SeedSet holder;
  holder.add_polygon(holder.add_feature(holder.owner_code("area")), {{{40, 30}, {60, 30}, {60, 50}, {40, 50}}});
  const InteriorSpans area = build_interiors(holder, g, g.full_window());

  const NearestField straight = compute(s, g, ComputeOptions{});
  const PlanarSiteMetric line(s, Vec2{g.xmin, g.ymax});
  const auto direct = test::relevant_stretches(straight, line, area, g.height);
  ASSERT_EQ(direct.size(), 1u);
  EXPECT_NEAR(direct[0].length, 19.0, 1e-9);

  const test::WallSea sea(s, {20, 20}, {80, 20}, g);
  for (const int64_t rows : {g.height, int64_t{7}, int64_t{1}}) {
    SCOPED_TRACE(rows);
    const auto st = test::relevant_stretches(sea.field.field, *sea.metric, area, rows);
    ASSERT_EQ(st.size(), 1u);
    EXPECT_EQ(st[0].site, 0);
    EXPECT_NEAR(st[0].from.x, 20.0, 1e-9);
    EXPECT_NEAR(st[0].from.y, 0.0, 1e-9);
    EXPECT_NEAR(st[0].to.x, 80.0, 1e-9);
    EXPECT_NEAR(st[0].to.y, 0.0, 1e-9);
    EXPECT_NEAR(st[0].length, 60.0, 1e-9);
  }
  // Every cell of the area, not only the edge cells the stretch is taken from.
  int cells = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (const Span& span : area.rows[static_cast<size_t>(r)])
      for (int64_t c = span.col0; c < span.col1; ++c) {
        const Vec2 x = centre(g, c, r);
        ASSERT_EQ(sea.field.field.site.at(c, r), 0);
        const Vec2 end = x.x < 50.0 ? Vec2{20, 20} : Vec2{80, 20};
        EXPECT_NEAR(sea.field.field.distance.at(c, r), 20.0 + dist(x, end), 1e-4) << c << "," << r;
        const Vec2 foot = sea.metric->nearest_point(x, 0);
        EXPECT_NEAR(foot.x, end.x, 1e-9) << c << "," << r;
        EXPECT_NEAR(foot.y, 0.0, 1e-9) << c << "," << r;
        ++cells;
      }
  EXPECT_EQ(cells, 400);
}

// Random archipelagos on a grid fine enough for blocks (a fifth of a unit): islands overlapping,
// sharing corners and edges, coast seeds running into other islands' land. The blocks answer as
// every cell alone, and neighbours that see each other keep the triangle inequality.
TEST(SeaPathEnds, RandomArchipelagosOnAFineGridKeepTheTriangleInequality) {
  std::mt19937_64 rng(31);
  int rounds = 0;
  int64_t block_cells = 0, drawn_cells = 0;
  const int tried = test::rounds(200);
  for (int round = 0; round < tried; ++round) {
    const test::Archipelago a = test::random_archipelago(rng, round);
    const GridSpec g = test::grid_of(230, 230, 0.2, -1.0, 45.0);
    SeaField f;
    try {
      f = test::blocks_agree(a.seeds, a.barriers, g);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();  // a coast seed inside another island
      continue;
    }
    if (HasFailure()) return;
    ASSERT_TRUE(test::triangle_inequality_holds(f, a.barriers, g, 1)) << "round " << round;
    block_cells += f.block_cells;
    drawn_cells += f.drawn_cells;
    ++rounds;
  }
  EXPECT_GE(rounds, tried * 3 / 4);
  EXPECT_GT(block_cells + drawn_cells, rounds * 230 * 230 / 2);
  EXPECT_GT(block_cells, rounds * 230 * 230 / 20);
}

}  // namespace
}  // namespace rv
