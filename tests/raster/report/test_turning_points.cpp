// Turning points of boundary lines: where the pair of controlling basepoints changes, against
// the geometry of simple cases and against a brute-force walk along the line.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/report/turning_points.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

struct Case {
  SeedSet seeds;
  GridSpec grid;
  NearestField field;
  PlanarSiteMetric metric;
  OwnerIndex index;
  BoundaryResult lines;
  std::vector<TurningLine> turns;
  Case(SeedSet s, const GridSpec& g)
      : seeds(std::move(s)),
        grid(g),
        field(compute(seeds, grid, ComputeOptions{})),
        metric(seeds, Vec2{g.xmin, g.ymax}),
        index(metric),
        lines(extract_boundaries(field, index)),
        turns(turning_points(lines, index)) {}
};

std::vector<TurningPoint> turns_of(const Case& c) {
  std::vector<TurningPoint> out;
  for (const TurningLine& l : c.turns)
    for (const TurningPoint& t : l.points)
      if (t.kind == TurningPoint::Kind::turn) out.push_back(t);
  return out;
}

// Two basepoints of A and one of B: the line turns at the circumcentre (18.333.., 30), where all
// three are equidistant.
TEST(TurningPoints, ThreeBasepointsTurnAtTheCircumcentre) {
  SeedSet s;
  const int32_t a = s.add_feature(s.owner_code("A"));
  s.add_point(a, {10.0, 10.0});
  s.add_point(a, {10.0, 50.0});
  const int32_t b = s.add_feature(s.owner_code("B"));
  s.add_point(b, {40.0, 30.0});
  const Case c(std::move(s), test::grid_of(60, 60, 1.0));
  const std::vector<TurningPoint> t = turns_of(c);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_NEAR(t[0].p.x, 55.0 / 3.0, 1e-7);
  EXPECT_NEAR(t[0].p.y, 30.0, 1e-7);
  ASSERT_EQ(t[0].a.size(), 2u);  // A's basepoint changes here
  ASSERT_EQ(t[0].b.size(), 1u);
  const double r = std::hypot(55.0 / 3.0 - 40.0, 0.0);
  for (const Basepoint& bp : {t[0].a[0], t[0].a[1], t[0].b[0]}) EXPECT_NEAR(bp.distance, r, 1e-6);
  EXPECT_EQ(t[0].b[0].at, (Vec2{40.0, 30.0}));
  // The line's two ends, the turning point between them.
  ASSERT_EQ(c.turns.size(), 1u);
  EXPECT_EQ(c.turns[0].points.front().kind, TurningPoint::Kind::end);
  EXPECT_EQ(c.turns[0].points.back().kind, TurningPoint::Kind::end);
}

// A straight coast ending at (50, 0) and an island point at (25, 40): the parabola hands over to
// the bisector of the coast's end and the island where the foot reaches the end, at
// (50, 27.8125), without a corner.
TEST(TurningPoints, TheFootReachingACoastsEnd) {
  SeedSet s;
  const int32_t a = s.add_feature(s.owner_code("A"));
  const std::vector<Vec2> coast{{-20.0, 0.0}, {50.0, 0.0}};
  s.add_polyline(a, coast);
  const int32_t b = s.add_feature(s.owner_code("B"));
  s.add_point(b, {25.0, 40.0});
  const Case c(std::move(s), test::grid_of(100, 60, 1.0, -25.0, 55.0));
  std::vector<TurningPoint> t = turns_of(c);
  // And at the coast's other end, (-20, 45.3125).
  ASSERT_EQ(t.size(), 2u) << t.size();
  std::sort(t.begin(), t.end(), [](const TurningPoint& x, const TurningPoint& y) { return x.p.x < y.p.x; });
  EXPECT_NEAR(t[0].p.x, -20.0, 1e-6);
  EXPECT_NEAR(t[0].p.y, 45.3125, 1e-6);
  EXPECT_NEAR(t[1].p.x, 50.0, 1e-6);
  EXPECT_NEAR(t[1].p.y, 27.8125, 1e-6);
  for (const TurningPoint& x : t) {
    ASSERT_EQ(x.a.size(), 2u);  // the coast's end, and the edge's interior from it
    EXPECT_NEAR(x.a[0].at.x, x.p.x, 1e-6);
    EXPECT_NEAR(x.a[1].at.x, x.p.x, 1e-6);
    EXPECT_NEAR(x.a[0].distance, x.p.y, 1e-6);
    EXPECT_NEAR(x.b[0].distance, x.p.y, 1e-6);
  }
}

// Random coasts: between two consecutive turning points every vertex of the line has the same
// basepoints (brute force: each owner's nearest point over all its sites), and across each
// turning point they differ.
TEST(TurningPoints, BasepointsChangeOnlyAtTurningPoints) {
  for (uint32_t trial = 0; trial < 4; ++trial) {
    SCOPED_TRACE(trial);
    std::mt19937 rng(trial + 40);
    std::uniform_real_distribution<double> u(5.0, 75.0);
    SeedSet s;
    for (int i = 0; i < 6; ++i) {
      const int32_t f = s.add_feature(s.owner_code(i % 2 == 0 ? "A" : "B"));
      if (i < 2) {
        const std::vector<Vec2> line{{u(rng), u(rng)}, {u(rng), u(rng)}, {u(rng), u(rng)}};
        s.add_polyline(f, line);
      } else {
        s.add_point(f, {u(rng), u(rng)});
      }
    }
    const Case c(std::move(s), test::grid_of(80, 80, 1.0));
    const SeedSet& seeds = c.seeds;
    // Brute force: the basepoint of owner o nearest to p.
    auto base = [&](Vec2 p, int32_t o) {
      double best = 1e300;
      Vec2 at{};
      for (int32_t k = 0; k < static_cast<int32_t>(seeds.sites().size()); ++k) {
        if (seeds.site_owner(k) != o) continue;
        const Vec2 q = c.metric.nearest_point(p, k);
        const double d = std::hypot(p.x - q.x, p.y - q.y);
        if (d < best - 1e-12) {
          best = d;
          at = q;
        }
      }
      return at;
    };
    for (const TurningLine& tl : c.turns) {
      const BoundaryLine& line = c.lines.lines[tl.line];
      // Between consecutive turning points the basepoints along the line stay put, where both
      // sides' basepoints are positions (an edge's interior moves with the point).
      for (size_t k = 0; k + 1 < tl.points.size(); ++k) {
        const TurningPoint& from = tl.points[k];
        const TurningPoint& to = tl.points[k + 1];
        const Basepoint& fa = from.a.back();
        const Basepoint& fb = from.b.back();
        for (size_t v = from.next_vertex; v < to.next_vertex && v < line.vertices.size(); ++v) {
          const Vec2 p = line.vertices[v].p;
          // (A turning point the refinement put on a vertex ties both basepoints there.)
          if (std::hypot(p.x - to.p.x, p.y - to.p.y) < 1e-6 || std::hypot(p.x - from.p.x, p.y - from.p.y) < 1e-6)
            continue;
          const Vec2 ba = base(p, line.owner_a), bb = base(p, line.owner_b);
          const bool a_fixed = c.metric.nearest_point(p, fa.site) == fa.at;
          if (a_fixed) {
            EXPECT_NEAR(ba.x, fa.at.x, 1e-6) << "line " << tl.line << " vertex " << v;
            EXPECT_NEAR(ba.y, fa.at.y, 1e-6) << "line " << tl.line << " vertex " << v;
          }
          const bool b_fixed = c.metric.nearest_point(p, fb.site) == fb.at;
          if (b_fixed) {
            EXPECT_NEAR(bb.x, fb.at.x, 1e-6) << "line " << tl.line << " vertex " << v;
            EXPECT_NEAR(bb.y, fb.at.y, 1e-6) << "line " << tl.line << " vertex " << v;
          }
        }
      }
      // At each turning point the basepoints it names are equally near (the changing side's two).
      for (const TurningPoint& t : tl.points)
        for (const auto* side : {&t.a, &t.b})
          if (side->size() == 2) {
            EXPECT_NEAR((*side)[0].distance, (*side)[1].distance, 1e-6);
          }
    }
  }
}

// The 15-unit limit of a point (50, 60) and a straight coast y = 10 from x = 10 to 90 of one
// owner: a circle of one arc round the point, and round the coast a band of four arcs -- the
// straight sides (from the edge's interior) and the half circles round its ends -- changing
// at (90, 25), (90, -5), (10, -5) and (10, 25).
TEST(TurningPoints, LimitArcsOfAPointAndACoast) {
  SeedSet s;
  const int32_t a = s.add_feature(s.owner_code("A"));
  s.add_point(a, {50.0, 60.0});
  const int32_t c = s.add_feature(s.owner_code("A"));
  const std::vector<Vec2> coast{{10.0, 10.0}, {90.0, 10.0}};
  s.add_polyline(c, coast);
  const GridSpec g = test::grid_of(120, 95, 1.0, -10.0, 82.0);
  const NearestField field = compute(s, g, ComputeOptions{});
  const PlanarSiteMetric metric(s, Vec2{g.xmin, g.ymax});
  const OwnerIndex index(metric);
  const LimitResult limits = extract_limits(field, index, std::vector<double>{15.0});
  ASSERT_EQ(limits.lines.size(), 2u);
  const std::vector<LimitArcs> arcs = limit_arcs(limits, index);
  size_t circles = 0, bands = 0;
  for (const LimitArcs& la : arcs) {
    ASSERT_TRUE(limits.lines[la.line].closed);
    if (la.arcs.size() == 1) {
      ++circles;
      EXPECT_FALSE(la.arcs[0].edge);
      EXPECT_EQ(la.arcs[0].basepoint.at, (Vec2{50.0, 60.0}));
      continue;
    }
    ++bands;
    ASSERT_EQ(la.arcs.size(), 4u);
    int edges = 0;
    for (const LimitArc& arc : la.arcs) {
      edges += arc.edge;
      for (const Vec2 end : {arc.from, arc.to}) {
        // Every change lies at one of the four corners of the band's straight sides.
        const double dx = std::min(std::abs(end.x - 10.0), std::abs(end.x - 90.0));
        const double dy = std::min(std::abs(end.y - 25.0), std::abs(end.y + 5.0));
        EXPECT_LT(std::max(dx, dy), 1e-6) << end.x << ", " << end.y;
      }
      if (!arc.edge) {
        EXPECT_EQ(arc.basepoint.at.y, 10.0);
        EXPECT_TRUE(arc.basepoint.at.x == 10.0 || arc.basepoint.at.x == 90.0);
      }
    }
    EXPECT_EQ(edges, 2);
  }
  EXPECT_EQ(circles, 1u);
  EXPECT_EQ(bands, 1u);
}

// Where a reach ends the line follows its arc. A at (10, 30) and an island of B at (40, 30) with a
// reach of 20: the bisector x = 25 up to the circle, then the arc round the island; the two
// junctions (25, 30 +- sqrt(175)) are turning points, and from one of them the line follows B's
// arc (radius 20 round the island), from the other the locus.
TEST(TurningPoints, AReachsArcTurnsAtItsJunctions) {
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A")), {10.0, 30.0});
  const int32_t island = s.add_feature(s.owner_code("B"));
  s.add_point(island, {40.0, 30.0});
  s.set_adjustment(island, 1.0, 20.0);
  const Case c(std::move(s), test::grid_of(80, 60, 1.0));
  const std::vector<TurningPoint> t = turns_of(c);
  ASSERT_EQ(t.size(), 2u);
  int arcs = 0;
  for (const TurningPoint& tp : t) {
    EXPECT_NEAR(tp.p.x, 25.0, 1e-6);
    EXPECT_NEAR(std::abs(tp.p.y - 30.0), std::sqrt(175.0), 1e-6);
    ASSERT_FALSE(tp.b.empty());
    EXPECT_EQ(tp.b.back().at, (Vec2{40.0, 30.0}));
    EXPECT_NEAR(tp.b.back().distance, 20.0, 1e-6);
    ASSERT_FALSE(tp.a.empty());  // on the locus there, A's basepoint controls too
    EXPECT_NEAR(tp.a.front().distance, 20.0, 1e-6);
    arcs += tp.arc == 2;
    EXPECT_TRUE(tp.arc == 0 || tp.arc == 2);
  }
  EXPECT_EQ(arcs, 1);
}

// An island coast from (40, 25) to (40, 35) with a reach of 10, A far off at (5, 30): the island's
// zone is a stadium, all of it arc -- two half circles round the coast's ends and two parallels
// to it. Its basepoint changes where each half circle meets a parallel, (30 or 50, 25 or 35):
// four turning points on the arc, found by bisection on it.
TEST(TurningPoints, AnArcsBasepointChangesAlongIt) {
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A")), {5.0, 30.0});
  const int32_t island = s.add_feature(s.owner_code("B"));
  s.add_polyline(island, std::vector<Vec2>{{40.0, 25.0}, {40.0, 35.0}});
  s.set_adjustment(island, 1.0, 10.0);
  const Case c(std::move(s), test::grid_of(140, 120, 0.5));
  ASSERT_EQ(c.turns.size(), 1u);
  EXPECT_EQ(c.turns[0].points.front().arc, 2);
  const std::vector<TurningPoint> t = turns_of(c);
  ASSERT_EQ(t.size(), 4u);
  for (const TurningPoint& tp : t) {
    EXPECT_NEAR(std::abs(tp.p.x - 40.0), 10.0, 1e-5);
    EXPECT_NEAR(std::abs(tp.p.y - 30.0), 5.0, 1e-5);
    EXPECT_EQ(tp.arc, 2);
    EXPECT_TRUE(tp.a.empty());  // A does not control the arc
    ASSERT_EQ(tp.b.size(), 2u);
    for (const Basepoint& bp : tp.b) EXPECT_NEAR(bp.distance, 10.0, 1e-5);
  }
}

}  // namespace
}  // namespace rv
