// The stages of boundary extraction (raster/src/lines/boundary_stages.hpp), each on its own, on fields
// whose lines are known in closed form: three basepoints (three bisectors meeting at the
// circumcentre) and two (one bisector). Every stage also runs over strips of rows, the shape
// streaming feeds it: the strips' pieces together are the whole field's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/line_tools.hpp"
#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/regions.hpp"
#include "rv/lines/strip_lines.hpp"
#include "seed_gen.hpp"

namespace rv::boundary_stages {
namespace {

// Basepoints (owners A, B, C in order) on a grid of 100 x 100 unit cells, and what the stages read.
struct Case : test::PointsField {
  BoundaryGrid b;
  explicit Case(const std::vector<Vec2>& points)
      : PointsField(points, {"A", "B", "C"}, test::grid_of(100, 100)),
        b{field, index, grid, grid.width, grid.height, 2, 1e-9, line_tools::owner_of_sites(seeds)} {}
  // Distance to point i.
  double d(Vec2 p, size_t i) const { return distance(p, static_cast<int32_t>(i + 1)); }
};

const std::vector<Vec2> kThree{{20.3, 40.1}, {81.7, 44.6}, {47.2, 88.9}};

// The circumcentre of the three points: equidistant from all.
Vec2 circumcentre(const std::vector<Vec2>& p) {
  const double ax = p[0].x, ay = p[0].y, bx = p[1].x, by = p[1].y, cx = p[2].x, cy = p[2].y;
  const double d = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by));
  const double a2 = ax * ax + ay * ay, b2 = bx * bx + by * by, c2 = cx * cx + cy * cy;
  return Vec2{(a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / d,
              (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / d};
}

// The crossings of rows [r0, r1) alone.
CrossingSet crossings_of(const BoundaryGrid& b, int64_t r0, int64_t r1, BoundaryStats& stats) {
  CrossingSet x;
  find_crossings(b, r0, r1, x, stats);
  return x;
}

// The tripoints of the squares of rows [r0, r1) alone.
TripointSet tripoints_of(const BoundaryGrid& b, const CrossingSet& x, int64_t r0, int64_t r1, BoundaryStats& stats) {
  TripointSet t;
  std::vector<std::array<int64_t, 2>> unplaced;
  find_tripoints(b, x, r0, r1, t, unplaced, stats);
  count_unresolved(b, x, t, unplaced, stats);
  return t;
}

// The first three stages over the whole field.
struct Stages {
  BoundaryStats stats;
  CrossingSet x;
  TripointSet t;
  Links links;
  explicit Stages(const Case& k)
      : x(crossings_of(k.b, 0, 100, stats)),
        t(tripoints_of(k.b, x, 0, 100, stats)),
        links(link_squares(k.b, x, t, 0, 100, stats)) {}
};

// A crossing as comparable data: edge, owners, position.
using Key = std::tuple<int64_t, int32_t, int32_t, double, double>;
std::vector<Key> keys(const CrossingSet& x) {
  std::vector<Key> k;
  for (const Crossing& c : x.crossings) k.emplace_back(c.edge, c.owner_lo, c.owner_hi, c.v.p.x, c.v.p.y);
  std::sort(k.begin(), k.end());
  return k;
}

TEST(BoundaryStages, NewtonRootsConvergeOrHandTheBracketOver) {
  using line_tools::newton_root;
  // Smooth, with its slope (and curved as no cell edge is): five positions from mid-bracket, the
  // last one the root.
  int measured = 0;
  auto smooth = [&](double t) {
    ++measured;
    return std::pair{t * t + t - 0.5, 2.0 * t + 1.0};
  };
  const auto r = newton_root(smooth, 0.5, 0.0, 1.0, true, 1e-13, line_tools::kNewtonSteps);
  EXPECT_NEAR(r.t, 0.5 * (std::sqrt(3.0) - 1.0), 1e-13);
  EXPECT_LE(measured, 5);
  // Falling (f > 0 at lo): the same root of -f.
  auto falling = [&](double t) {
    const auto [v, dv] = smooth(t);
    return std::pair{-v, -dv};
  };
  EXPECT_NEAR(newton_root(falling, 0.5, 0.0, 1.0, false, 1e-13, 6).t, 0.5 * (std::sqrt(3.0) - 1.0), 1e-13);
  // No slope: no step, and the bracket narrowed by the one position measured, with its value.
  auto no_slope = [](double t) { return std::pair{t - 0.3, std::numeric_limits<double>::quiet_NaN()}; };
  const auto n = newton_root(no_slope, 0.5, 0.0, 1.0, true, 1e-13, 6);
  EXPECT_TRUE(std::isnan(n.t));
  EXPECT_EQ(n.lo, 0.0);
  EXPECT_EQ(n.hi, 0.5);
  EXPECT_TRUE(std::isnan(n.f_lo));
  EXPECT_NEAR(n.f_hi, 0.2, 1e-15);
  // A kink (the controlling site changes) whose step leaves the bracket: handed over with the
  // root still inside, and the Illinois method finds it there.
  auto kinked = [](double t) {
    return t < 0.6 ? std::pair{0.1 * (t - 5.0), 0.1} : std::pair{50.0 * (t - 0.6) - 0.1, 50.0};
  };
  const auto k = newton_root(kinked, 0.1, 0.0, 1.0, true, 1e-12, 6);
  ASSERT_TRUE(std::isnan(k.t));
  EXPECT_EQ(k.lo, 0.1);
  EXPECT_EQ(k.hi, 1.0);
  EXPECT_TRUE(std::isnan(k.f_hi));
  auto value = [&](double t) { return kinked(t).first; };
  const double fa = std::isnan(k.f_lo) ? value(k.lo) : k.f_lo, fb = std::isnan(k.f_hi) ? value(k.hi) : k.f_hi;
  const double t =
      k.lo + (k.hi - k.lo) *
                 line_tools::find_root([&](double u) { return value(k.lo + (k.hi - k.lo) * u); }, fa, fb, 1e-12, 1e-15);
  EXPECT_NEAR(t, 0.602, 1e-12);
}

TEST(BoundaryStages, CrossingsLieOnTheBisectorsOfTheirOwners) {
  const Case k(kThree);
  BoundaryStats stats;
  const CrossingSet x = crossings_of(k.b, 0, k.grid.height, stats);
  ASSERT_GT(x.crossings.size(), 100u);
  for (const Crossing& c : x.crossings) {
    ASSERT_LT(c.owner_lo, c.owner_hi);
    // Owners are codes 1..3 of points 0..2: equidistant from the two, to the tolerance.
    const double da = k.d(c.v.p, static_cast<size_t>(c.owner_lo - 1)),
                 db = k.d(c.v.p, static_cast<size_t>(c.owner_hi - 1));
    EXPECT_NEAR(da, db, 1e-6) << "edge " << c.edge;
    // And on its edge, between the two cell centres.
    const int64_t cell = c.edge / 2, col = cell % 100, row = cell / 100;
    const Vec2 p0 = line_tools::centre(k.grid, col, row);
    const Vec2 p1 =
        c.edge % 2 == 0 ? line_tools::centre(k.grid, col + 1, row) : line_tools::centre(k.grid, col, row + 1);
    EXPECT_GE(c.v.p.x, std::min(p0.x, p1.x) - 1e-9);
    EXPECT_LE(c.v.p.x, std::max(p0.x, p1.x) + 1e-9);
    EXPECT_GE(c.v.p.y, std::min(p0.y, p1.y) - 1e-9);
    EXPECT_LE(c.v.p.y, std::max(p0.y, p1.y) + 1e-9);
    // Every edge between differently owned cells has its crossing, filed under it.
    ASSERT_NE(x.on_edge.find(c.edge), x.on_edge.end());
  }
  int64_t changes = 0;
  for (int64_t r = 0; r < 100; ++r)
    for (int64_t c = 0; c < 100; ++c) {
      changes += c + 1 < 100 && k.b.owner(c, r) != k.b.owner(c + 1, r);
      changes += r + 1 < 100 && k.b.owner(c, r) != k.b.owner(c, r + 1);
    }
  EXPECT_EQ(static_cast<int64_t>(x.crossings.size()), changes);
  EXPECT_EQ(stats.crossings, changes);
}

TEST(BoundaryStages, StripsOfCrossingsAreTheWholeFieldsCrossings) {
  const Case k(kThree);
  BoundaryStats whole_stats, strip_stats;
  const std::vector<Key> whole = keys(crossings_of(k.b, 0, 100, whole_stats));
  std::vector<Key> strips;
  for (int64_t r0 = 0; r0 < 100; r0 += 37) {
    const std::vector<Key> part = keys(crossings_of(k.b, r0, std::min<int64_t>(r0 + 37, 100), strip_stats));
    strips.insert(strips.end(), part.begin(), part.end());
  }
  std::sort(strips.begin(), strips.end());
  EXPECT_EQ(strips, whole);
  EXPECT_EQ(strip_stats.crossings, whole_stats.crossings);
}

TEST(BoundaryStages, TheTripointIsTheCircumcentreInItsSquare) {
  const Case k(kThree);
  BoundaryStats stats;
  const CrossingSet x = crossings_of(k.b, 0, 100, stats);
  const TripointSet t = tripoints_of(k.b, x, 0, 100, stats);
  ASSERT_EQ(t.tripoints.size(), 1u);
  const Tripoint& tp = t.tripoints[0];
  const Vec2 cc = circumcentre(kThree);
  EXPECT_NEAR(tp.p.x, cc.x, 1e-6);
  EXPECT_NEAR(tp.p.y, cc.y, 1e-6);
  EXPECT_EQ(tp.owners[0], 1);
  EXPECT_EQ(tp.owners[1], 2);
  EXPECT_EQ(tp.owners[2], 3);
  EXPECT_NEAR(tp.distance, k.d(cc, 0), 1e-6);
  // Filed under the square holding it, and by its owners.
  const int64_t c = static_cast<int64_t>(std::floor(cc.x - 0.5)), r = static_cast<int64_t>(std::floor(99.5 - cc.y));
  ASSERT_EQ(t.in_square.count(r * 100 + c), 1u);
  EXPECT_EQ(t.by_owners.count({1, 2, 3}), 1u);
  // A strip of rows without the tripoint's square finds none; the strip holding it finds it.
  BoundaryStats s2;
  EXPECT_TRUE(tripoints_of(k.b, x, 0, r, s2).tripoints.empty());
  EXPECT_EQ(tripoints_of(k.b, x, r, r + 1, s2).tripoints.size(), 1u);
}

TEST(BoundaryStages, LinksJoinEachCrossingToItsNeighboursAlongTheLine) {
  const Case k(kThree);
  const Stages st(k);
  const CrossingSet& x = st.x;
  const TripointSet& t = st.t;
  const Links& links = st.links;
  const auto n = static_cast<int32_t>(x.crossings.size());
  std::vector<int> degree(static_cast<size_t>(n) + t.tripoints.size(), 0);
  for (size_t i = 0; i < links.links.size(); ++i) {
    // Tripoints are the negative nodes; numbered after the crossings here, as the chains do.
    auto [a, b] = links.links[i];
    if (a < 0) a = n + tripoint_node(a);
    if (b < 0) b = n + tripoint_node(b);
    ++degree[static_cast<size_t>(a)];
    ++degree[static_cast<size_t>(b)];
    // A link joins two nodes of one owner pair (a tripoint belongs to three).
    if (a < n && b < n) {
      EXPECT_EQ(x.crossings[static_cast<size_t>(a)].owner_lo, x.crossings[static_cast<size_t>(b)].owner_lo);
      EXPECT_EQ(x.crossings[static_cast<size_t>(a)].owner_hi, x.crossings[static_cast<size_t>(b)].owner_hi);
    }
  }
  // The tripoint ends three lines; a crossing is inside a line (2) or at the grid's edge (1).
  EXPECT_EQ(degree[static_cast<size_t>(n)], 3);
  int ends = 0;
  for (int32_t i = 0; i < n; ++i) {
    EXPECT_TRUE(degree[static_cast<size_t>(i)] == 1 || degree[static_cast<size_t>(i)] == 2) << i;
    ends += degree[static_cast<size_t>(i)] == 1;
  }
  EXPECT_EQ(ends, 3);  // the three bisectors each reach the grid's edge once
}

// Links of strips of squares, joined as the last stage joins pieces (each link once).
Links strip_links(const Case& k, const CrossingSet& x, const TripointSet& t, int64_t rows) {
  Links joined;
  BoundaryStats stats;
  for (int64_t r0 = 0; r0 < 100; r0 += rows) {
    const Links part = link_squares(k.b, x, t, r0, std::min<int64_t>(r0 + rows, 100), stats);
    for (size_t i = 0; i < part.links.size(); ++i)
      joined.add(part.links[i][0], part.links[i][1], part.pair[i], part.row[i]);
  }
  return joined;
}

TEST(BoundaryStages, ChainsAreTheBisectorsFromTheTripointToTheGridsEdge) {
  const Case k(kThree);
  Stages st(k);
  const CrossingSet& x = st.x;
  const TripointSet& t = st.t;
  const Links& links = st.links;
  BoundaryStats& stats = st.stats;
  const std::vector<BoundaryLine> lines = chain_lines(x, t, links, 0.0, stats);
  ASSERT_EQ(lines.size(), 3u);
  const Vec2 cc = circumcentre(kThree);
  for (const BoundaryLine& line : lines) {
    EXPECT_FALSE(line.closed);
    ASSERT_GE(line.vertices.size(), 10u);
    for (const BoundaryVertex& v : line.vertices)
      EXPECT_NEAR(k.d(v.p, static_cast<size_t>(line.owner_a - 1)), k.d(v.p, static_cast<size_t>(line.owner_b - 1)),
                  1e-6);
    // One end at the tripoint, the other on the grid's outermost cell centres.
    const Vec2 a = line.vertices.front().p, b = line.vertices.back().p;
    const bool a_tri = std::hypot(a.x - cc.x, a.y - cc.y) < 1e-6, b_tri = std::hypot(b.x - cc.x, b.y - cc.y) < 1e-6;
    EXPECT_NE(a_tri, b_tri);
    const Vec2 e = a_tri ? b : a;
    EXPECT_TRUE(e.x <= 0.5 + 1e-9 || e.x >= 99.5 - 1e-9 || e.y <= 0.5 + 1e-9 || e.y >= 99.5 - 1e-9)
        << e.x << ", " << e.y;
  }
  // Simplified at half a cell, a straight bisector keeps its two ends alone.
  BoundaryStats s2;
  for (const BoundaryLine& line : chain_lines(x, t, links, 0.5, s2)) EXPECT_EQ(line.vertices.size(), 2u);
}

TEST(BoundaryStages, PiecesOfStripsChainIntoTheWholeFieldsLines) {
  for (const std::vector<Vec2>& points : {kThree, std::vector<Vec2>{{30.0, 35.5}, {64.2, 61.0}}}) {
    const Case k(points);
    const Stages st(k);
    const CrossingSet& x = st.x;
    const TripointSet& t = st.t;
    const Links& whole = st.links;
    for (int64_t rows : {1, 13, 50}) {
      const Links joined = strip_links(k, x, t, rows);
      EXPECT_EQ(joined.linked, whole.linked) << rows << " rows a strip";
      BoundaryStats s1, s2;
      const std::vector<BoundaryLine> a = chain_lines(x, t, whole, 0.0, s1), b = chain_lines(x, t, joined, 0.0, s2);
      ASSERT_EQ(a.size(), b.size());
      ASSERT_EQ(a.size(), points.size() == 3 ? 3u : 1u);
      for (size_t i = 0; i < a.size(); ++i) {
        ASSERT_EQ(a[i].vertices.size(), b[i].vertices.size());
        for (size_t j = 0; j < a[i].vertices.size(); ++j) {
          EXPECT_EQ(a[i].vertices[j].p.x, b[i].vertices[j].p.x);
          EXPECT_EQ(a[i].vertices[j].p.y, b[i].vertices[j].p.y);
        }
      }
    }
  }
}

// end_at_owned_edge: two points 100 km apart and a max distance of 60 km, compared through an
// index with that cap (as with weights or reaches). Extraction stops at the last pair of cells
// both own; the line then ends at (50, +-33.166) km, where both are at 60 km, exactly -- whole
// and in strips alike. With a plain index nothing moves.
TEST(EndAtOwnedEdge, ALineEndsWhereBothOwnersAreAtTheMaxDistance) {
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A")), {500000.0, 6000000.0});
  s.add_point(s.add_feature(s.owner_code("B")), {600000.0, 6000000.0});
  const GridSpec g = test::grid_of(480, 280, 500.0, 430000.0, 6070000.0);
  ComputeOptions o;
  o.max_distance = 60000.0;
  const NearestField field = compute(s, g, o);
  const PlanarSiteMetric metric(s, Vec2{g.xmin, g.ymax});
  const OwnerIndex index(metric, OwnerIndex::Measure::adjusted, 60000.0);
  BoundaryOptions bo;
  bo.max_distance = 60000.0;
  const BoundaryResult whole = extract_boundaries(field, index, bo);
  ASSERT_EQ(whole.lines.size(), 1u);
  EXPECT_EQ(whole.stats.ends_on_owned_edge, 2);
  const double y = std::sqrt(60000.0 * 60000.0 - 50000.0 * 50000.0);
  for (const BoundaryVertex& v : {whole.lines[0].vertices.front(), whole.lines[0].vertices.back()}) {
    EXPECT_NEAR(v.p.x, 550000.0, 1e-6);
    EXPECT_NEAR(std::abs(v.p.y - 6000000.0), y, 1e-6);
    EXPECT_NEAR(v.distance_a, 60000.0, 1e-6);
    EXPECT_NEAR(v.distance_b, 60000.0, 1e-6);
  }
  // Strips of 7 rows: the same vertices.
  LineRequest request;
  request.boundaries = true;
  request.boundary = bo;
  StripLines lines(g, index, request);
  for (int64_t r0 = 0; r0 < g.height; r0 += 7) {
    ComputeOptions strip = o;
    strip.window = Window{0, r0, g.width, std::min<int64_t>(7, g.height - r0)};
    lines.add(compute(s, g, strip));
  }
  const BoundaryResult strips = lines.take_boundaries();
  ASSERT_EQ(strips.lines.size(), 1u);
  ASSERT_EQ(strips.lines[0].vertices.size(), whole.lines[0].vertices.size());
  for (size_t i = 0; i < strips.lines[0].vertices.size(); ++i)
    EXPECT_EQ(strips.lines[0].vertices[i].p, whole.lines[0].vertices[i].p) << i;
  // With a plain index the line stops at the last cells, as extracted.
  const OwnerIndex plain(metric);
  const BoundaryResult short_of = extract_boundaries(field, plain, bo);
  EXPECT_EQ(short_of.stats.ends_on_owned_edge, 0);
  EXPECT_NEAR(std::abs(short_of.lines[0].vertices.front().p.y - 6000000.0), 33250.0, 1e-6);
}

// Points of one owner each (named by the numbers), on a grid of 1 m cells in UTM metres, and the
// lines extracted from their field.
struct NamedPointLines : test::PointsField {
  BoundaryResult r;
  NamedPointLines(const std::vector<std::pair<Vec2, int>>& named, const GridSpec& g)
      : PointsField(positions(named), names(named), g), r(extract_boundaries(field, index)) {}
  static std::vector<Vec2> positions(const std::vector<std::pair<Vec2, int>>& named) {
    std::vector<Vec2> out;
    for (const auto& n : named) out.push_back(n.first);
    return out;
  }
  static std::vector<std::string> names(const std::vector<std::pair<Vec2, int>>& named) {
    std::vector<std::string> out;
    for (const auto& n : named) out.push_back(std::to_string(n.second));
    return out;
  }
};

// close_missing_tripoints: eleven basepoints from a random set (1 m cells) where one dual square
// holds two tripoints and the meeting of 686, 7528 and 8248 between them, which its search
// misses. The tripoint is found from its lines' ends: every line ends at a tripoint or on the
// frame, the three owners are equidistant there and no other is nearer, and the regions close.
TEST(CloseMissingTripoints, ATripointACrowdedSquareMissed) {
  const std::vector<std::pair<Vec2, int>> points = {
      {{400638.24720255716, 6001625.698194801}, 686},  {{400646.4424630304, 6001633.527788706}, 1543},
      {{400622.3603533263, 6001612.716984124}, 2512},  {{400631.74422859953, 6001633.950451598}, 7229},
      {{400620.0586528782, 6001627.760388389}, 7528},  {{400654.94277616823, 6001612.895611136}, 7593},
      {{400616.49730679387, 6001603.452812286}, 7719}, {{400629.4328741445, 6001634.248928863}, 8248},
      {{400615.7515478986, 6001635.583983469}, 8264},  {{400629.02444605, 6001634.267238516}, 8676},
      {{400643.505823071, 6001646.051668534}, 9298}};
  NamedPointLines run(points, test::grid_of(60, 60, 1.0, 400600.0, 6001660.0));
  SeedSet& s = run.seeds;
  const GridSpec& g = run.grid;
  const OwnerIndex& index = run.index;
  const BoundaryResult& r = run.r;
  EXPECT_EQ(r.stats.missing_tripoints_found, 1);
  for (const BoundaryLine& l : r.lines) {
    if (l.closed) continue;
    for (const Vec2 e : {l.vertices.front().p, l.vertices.back().p}) {
      const bool at_tripoint =
          std::any_of(r.tripoints.begin(), r.tripoints.end(), [&](const Tripoint& t) { return t.p == e; });
      EXPECT_TRUE(at_tripoint || line_tools::on_centre_frame(g, e)) << e.x << ", " << e.y;
    }
  }
  const int32_t a = s.owner_code("686"), b = s.owner_code("7528"), c = s.owner_code("8248");
  const auto found = std::find_if(r.tripoints.begin(), r.tripoints.end(), [&](const Tripoint& t) {
    std::array<int32_t, 3> o{a, b, c};
    std::sort(o.begin(), o.end());
    return t.owners[0] == o[0] && t.owners[1] == o[1] && t.owners[2] == o[2];
  });
  ASSERT_NE(found, r.tripoints.end());
  const double d = std::hypot(found->p.x - points[0].first.x, found->p.y - points[0].first.y);
  for (const Vec2 q : {points[4].first, points[7].first})
    EXPECT_NEAR(std::hypot(found->p.x - q.x, found->p.y - q.y), d, 1e-8);
  for (const auto& [q, id] : points) EXPECT_GE(std::hypot(found->p.x - q.x, found->p.y - q.y), d - 1e-8) << id;
  EXPECT_EQ(region_edges(r, index, g).dangling_ends, 0);
}

// Two tripoints two millimetres apart in metres of UTM (six million in y): the line between them is
// kept (a line of no length is dropped, but only within a millionth of a cell: a billionth of the
// coordinates is six millimetres here).
TEST(ShortLines, TheLineBetweenTwoTripointsMillimetresApartIsKept) {
  const std::vector<std::pair<Vec2, int>> points = {
      {{400723.5677488056, 6000359.763453556}, 469},  {{400689.67887646385, 6000369.549684629}, 525},
      {{400705.751226474, 6000347.602094712}, 4895},  {{400685.1036223742, 6000346.716062125}, 5119},
      {{400703.7996344647, 6000373.183815254}, 5547}, {{400702.2968966066, 6000370.000563763}, 6032},
      {{400692.2898739421, 6000382.433297586}, 8813}};
  NamedPointLines run(points, test::grid_of(60, 60, 1.0, 400670.0, 6000400.0));
  SeedSet& s = run.seeds;
  const BoundaryResult& r = run.r;
  const int32_t a = std::min(s.owner_code("525"), s.owner_code("5547")),
                b = std::max(s.owner_code("525"), s.owner_code("5547"));
  int found = 0;
  for (const BoundaryLine& l : r.lines) {
    if (l.owner_a != a || l.owner_b != b) continue;
    ++found;
    const Vec2 u = l.vertices.front().p, w = l.vertices.back().p;
    EXPECT_GT(std::hypot(w.x - u.x, w.y - u.y), 1e-3);
    EXPECT_LT(std::hypot(w.x - u.x, w.y - u.y), 3e-3);
    for (const Vec2 e : {u, w})
      EXPECT_TRUE(std::any_of(r.tripoints.begin(), r.tripoints.end(), [&](const Tripoint& t) { return t.p == e; }))
          << e.x << ", " << e.y;
  }
  EXPECT_EQ(found, 1);
  EXPECT_EQ(region_edges(r, run.index, run.grid).dangling_ends, 0);
}

// repeated_loops: a closed line whose every vertex and every segment's middle lies within twice
// the tolerance of another line of the same two owners goes (the stretches a thin wedge's cut-off
// cells traced, refined onto the main line's); one a hair farther off anywhere, one of other
// owners, and the line it runs along stay. (The lines are laid out by hand: the stage reads only
// their vertices, owners and the refiner's tolerance.)
TEST(RepeatedLoops, AClosedLineAlongAnotherOfTheSameOwnersGoes) {
  const Case c(kThree);
  const line_tools::CrsScale scale(c.metric, Vec2{50.0, 50.0}, 1.0);
  const double tol = 1e-3;
  const LineRefiner refiner(c.index, tol, 1e-9, scale, std::max(scale.at0.x, scale.at0.y));
  auto line = [](int32_t a, int32_t b, bool closed, std::vector<Vec2> pts) {
    BoundaryLine l{a, b, closed, {}, {}};
    for (const Vec2 p : pts) l.vertices.push_back(BoundaryVertex{p, 0, 1, 1.0, 0.0});
    return l;
  };
  // A V: out along one side to the tip at (0, 0) and back along the other.
  const BoundaryLine main = line(1, 2, false, {{40, 4}, {20, 2}, {0, 0}, {20, -2}, {40, -4}});
  // Round the tip and back, both sides of it, every point on the V within 1.5 thousandths.
  const BoundaryLine along = line(1, 2, true, {{15, 1.5015}, {0, 0}, {10, -1}, {12, -1.2}, {0, 0.0005}, {10, 1}});
  BoundaryLine off_vertex = along;
  off_vertex.vertices[3].p.y -= 0.003;  // a vertex 3 thousandths off the V
  // Every vertex on the V, but a chord across it from side to side (its middle a unit off).
  const BoundaryLine off_middle = line(1, 2, true, {{0, 0}, {10, 1}, {10, -1}});
  BoundaryLine others = along;
  others.owner_b = 3;
  const std::vector<BoundaryLine> lines{main, along, off_vertex, off_middle, others};
  const std::vector<bool> drop = repeated_loops(lines, refiner);
  EXPECT_EQ(drop, (std::vector<bool>{false, true, false, false, false}));
  // Two copies of one loop along nothing else: one goes, not both.
  const std::vector<bool> pair = repeated_loops({along, along}, refiner);
  EXPECT_EQ(pair, (std::vector<bool>{true, false}));
  // Measure only (tolerance 0): twice nothing is the coordinates' rounding alone, and the loop
  // 1.5 thousandths off stays.
  const LineRefiner measure(c.index, 0.0, 1e-9, scale, std::max(scale.at0.x, scale.at0.y));
  EXPECT_EQ(repeated_loops(lines, measure), (std::vector<bool>(5, false)));
}

}  // namespace
}  // namespace rv::boundary_stages
