// Boundaries where a reach ends (Feature::reach, BoundaryVertex::arc): an island enclaved in a
// 12 nmi arc on the ellipsoid (every vertex 22,224 m from it by GeographicLib, the chords within
// the refinement's tolerance), and in the plane an island whose disc is cut by the bisector with
// its neighbour (vertices on the bisector or the circle, the junctions exact, the region's area
// the analytic one).
#include <gtest/gtest.h>
#include <GeographicLib/Geodesic.hpp>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/regions.hpp"
#include "rv/lines/strip_lines.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

TEST(ReachArcs, AnIslandEnclavedInA12NmiArcOnTheEllipsoid) {
  SeedSet s;
  const int32_t a = s.owner_code("A"), b = s.owner_code("B");
  s.add_polyline(s.add_feature(a), std::vector<Vec2>{{10.0, 55.0}, {10.0, 56.0}});
  const int32_t island = s.add_feature(b);
  const Vec2 at{11.0, 55.5};
  s.add_point(island, at);
  s.set_adjustment(island, 1.0, 22224.0);
  const GridSpec g = test::grid_of(200, 120, 0.005, 10.5, 55.8);
  ComputeOptions o;
  o.metric = MetricSpec{MetricSpec::geodesic};
  const NearestField field = compute(s, g, o);
  const GeodesicSiteMetric metric(s, o.metric);
  const OwnerIndex index(metric);
  const BoundaryResult r = extract_boundaries(field, index);
  ASSERT_EQ(r.lines.size(), 1u);
  const BoundaryLine& line = r.lines[0];
  EXPECT_TRUE(line.closed);
  EXPECT_EQ(r.stats.unresolved_tripoints, 0);
  EXPECT_GT(r.stats.arc_points, 0);
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  auto from_island = [&](Vec2 p) {
    double s12 = 0.0;
    geod.Inverse(at.y, at.x, p.y, p.x, s12);
    return s12;
  };
  // The line tolerance (BoundaryOptions::line_tolerance): 1 mm between the arc and every chord.
  for (size_t i = 0; i < line.vertices.size(); ++i) {
    const BoundaryVertex& v = line.vertices[i];
    EXPECT_EQ(v.arc, 2);  // B's reach (owner_b) ends there
    EXPECT_EQ(v.site_b, 1);
    EXPECT_NEAR(from_island(v.p), 22224.0, 1e-3) << i;
    EXPECT_NEAR(v.distance_b, 22224.0, 1e-3);
    if (i + 1 < line.vertices.size()) {
      // The chord strays from the arc by at most the line tolerance.
      const Vec2 q = line.vertices[i + 1].p;
      const double sag = 22224.0 - from_island(Vec2{0.5 * (v.p.x + q.x), 0.5 * (v.p.y + q.y)});
      EXPECT_LT(sag, 1e-3) << i;
    }
  }
}

// A at the origin, B's island 30 km east with a reach of 20 km: B's region is its disc cut by
// the bisector x = 15 km, whose stretch |y| <= 13.229 km meets the circle at two junctions.
TEST(ReachArcs, TheBisectorAndTheArcMeetExactly) {
  SeedSet s;
  const int32_t a = s.owner_code("A"), b = s.owner_code("B");
  const Vec2 A{500000.0, 6000000.0}, I{530000.0, 6000000.0};
  s.add_point(s.add_feature(a), A);
  const int32_t island = s.add_feature(b);
  s.add_point(island, I);
  s.set_adjustment(island, 1.0, 20000.0);
  const GridSpec g = test::grid_of(60, 60, 1000.0, 505000.0, 6030000.0);
  const NearestField field = compute(s, g, ComputeOptions{});
  const PlanarSiteMetric metric(s, Vec2{g.xmin, g.ymax});
  const OwnerIndex index(metric);
  const BoundaryResult r = extract_boundaries(field, index);
  ASSERT_EQ(r.lines.size(), 1u);
  const BoundaryLine& line = r.lines[0];
  EXPECT_TRUE(line.closed);
  const double half_chord = std::sqrt(20000.0 * 20000.0 - 15000.0 * 15000.0);
  int on_bisector = 0, on_arc = 0;
  bool north = false, south = false;
  std::vector<Vec2> ring;
  for (const BoundaryVertex& v : line.vertices) {
    ring.push_back(v.p);
    const double x = v.p.x - A.x, y = v.p.y - A.y;
    const double from_island = std::hypot(v.p.x - I.x, v.p.y - I.y);
    const bool bisector = std::abs(x - 15000.0) < 1e-6, arc = std::abs(from_island - 20000.0) < 1e-6;
    EXPECT_TRUE(bisector || arc) << x << "," << y;
    if (bisector && arc) {
      (y > 0.0 ? north : south) = true;
      EXPECT_NEAR(std::abs(y), half_chord, 1e-6);
    } else if (bisector) {
      ++on_bisector;
      EXPECT_EQ(v.arc, 0);
      EXPECT_LE(std::abs(y), half_chord);
    } else {
      ++on_arc;
      EXPECT_EQ(v.arc, 2);
      EXPECT_GE(x, 15000.0);
    }
  }
  EXPECT_TRUE(north && south);  // both junctions are vertices
  EXPECT_GT(on_bisector, 10);
  EXPECT_GT(on_arc, 50);
  // B's region: the disc without the cap beyond the bisector, to 0.01 %.
  const double R = 20000.0, h = 15000.0;
  const double expected = std::numbers::pi * R * R - (R * R * std::acos(h / R) - h * half_chord);
  EXPECT_NEAR(ring_area(ring, MetricSpec{}, nullptr, 0.0) / expected, 1.0, 1e-4);
  EXPECT_EQ(owner_at(index, Vec2{I.x + 19000.0, I.y}), 2);
  EXPECT_EQ(owner_at(index, Vec2{I.x + 21000.0, I.y}), 1);
}

// A at the origin and C 60 km east: their line is x = 30 km. B's island at (30, 20) km with a
// reach of 10 km takes its disc out of both, so the A-C line stops at the disc's two points on it,
// (30, 10) and (30, 30) km: tripoints where an arc meets the locus of the other two.
TEST(ReachArcs, AnArcMeetsTheOthersLocusAtTripoints) {
  SeedSet s;
  const int32_t a = s.owner_code("A"), b = s.owner_code("B"), c = s.owner_code("C");
  const Vec2 O{500000.0, 6000000.0};
  s.add_point(s.add_feature(a), O);
  const int32_t island = s.add_feature(b);
  s.add_point(island, Vec2{O.x + 30000.0, O.y + 20000.0});
  s.set_adjustment(island, 1.0, 10000.0);
  s.add_point(s.add_feature(c), Vec2{O.x + 60000.0, O.y});
  const GridSpec g = test::grid_of(50, 60, 1000.0, O.x + 5000.0, O.y + 45000.0);
  const NearestField field = compute(s, g, ComputeOptions{});
  const PlanarSiteMetric metric(s, Vec2{g.xmin, g.ymax});
  const OwnerIndex index(metric);
  const BoundaryResult r = extract_boundaries(field, index);
  EXPECT_EQ(r.stats.unresolved_tripoints, 0);
  ASSERT_EQ(r.tripoints.size(), 2u);
  for (const Tripoint& t : r.tripoints) {
    EXPECT_NEAR(t.p.x, O.x + 30000.0, 1e-6);
    EXPECT_NEAR(std::abs(t.p.y - (O.y + 20000.0)), 10000.0, 1e-6);
    EXPECT_EQ(t.owners[1], 2);
    EXPECT_NEAR(t.distances[1], 10000.0, 1e-6);
  }
  // Every line ends at the tripoints or the grid's frame: the A-C line in two pieces, B's arcs
  // against A and against C each from one tripoint to the other.
  int arcs = 0;
  for (const BoundaryLine& line : r.lines) {
    ASSERT_FALSE(line.closed);
    if (line.owner_b == 2 || line.owner_a == 2) {
      ++arcs;
      for (const BoundaryVertex& v : line.vertices)
        EXPECT_NEAR(std::hypot(v.p.x - O.x - 30000.0, v.p.y - O.y - 20000.0), 10000.0, 1e-6);
      for (const Vec2 end : {line.vertices.front().p, line.vertices.back().p})
        EXPECT_TRUE(end == r.tripoints[0].p || end == r.tripoints[1].p);
    }
  }
  EXPECT_EQ(arcs, 2);
}

// OwnerIndex::deepest against brute force (the least d - min(reach, cap) over every site, and
// per owner), at random positions among random points and polylines with reaches and a cap.
TEST(ReachArcs, DeepestIsTheLeastDistanceLessReach) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 100.0), r(5.0, 30.0);
  SeedSet s;
  for (int i = 0; i < 40; ++i) {
    const int32_t f = s.add_feature(s.owner_code(std::to_string(i % 3)));
    if (i % 4 == 0)
      s.add_polyline(f, std::vector<Vec2>{{u(rng), u(rng)}, {u(rng), u(rng)}});
    else
      s.add_point(f, {u(rng), u(rng)});
    s.set_adjustment(f, 1.0, i % 5 == 0 ? std::numeric_limits<double>::infinity() : r(rng));
  }
  const PlanarSiteMetric metric(s, Vec2{0.0, 100.0});
  const double cap = 25.0;
  const OwnerIndex index(metric, OwnerIndex::Measure::adjusted, cap);
  for (int k = 0; k < 500; ++k) {
    const Vec2 p{u(rng) * 1.4 - 20.0, u(rng) * 1.4 - 20.0};
    for (int32_t owner = 0; owner <= s.owner_count(); ++owner) {
      double best = std::numeric_limits<double>::infinity();
      int32_t site = kNoSite;
      for (int32_t i = 0; i < static_cast<int32_t>(s.sites().size()); ++i) {
        if (owner != 0 && s.site_owner(i) != owner) continue;
        const double c =
            metric.distance(p, i) - std::min(s.features()[static_cast<size_t>(s.site_feature(i))].reach, cap);
        if (c < best) {
          best = c;
          site = i;
        }
      }
      const OwnerIndex::Hit h = index.deepest(p, owner);
      EXPECT_EQ(h.site, site) << k << " owner " << owner;
      EXPECT_EQ(h.cost, best);
      // The owned area is where it is <= 0: where the adjusted nearest exists.
      if (owner == 0) {
        EXPECT_EQ(h.cost <= 0.0, index.nearest(p).site != kNoSite) << k;
      }
    }
  }
}

// Region edges where reaches leave the sea unowned: two points 40 km apart with reaches of 30 and
// 25 km, and again with a max distance of 28 km (the cap ends A's reach first: where its arc
// meets B's a wedge of unowned sea thinner than a cell pokes between A's and B's cells). The
// owned area's edge (StripLines with owned_edge) has its vertices on the two circles, its
// corners where they cross are vertices too (d_A = r_A, d_B = 25 km, exactly), the boundary ends
// on them, and no line stops in the open.
TEST(ReachArcs, TheOwnedAreasEdgeBoundsTheRegions) {
  SeedSet s;
  const Vec2 A{500000.0, 6000000.0}, B{540000.0, 6000000.0};
  const int32_t fa = s.add_feature(s.owner_code("A"));
  s.add_point(fa, A);
  s.set_adjustment(fa, 1.0, 30000.0);
  const int32_t fb = s.add_feature(s.owner_code("B"));
  s.add_point(fb, B);
  s.set_adjustment(fb, 1.0, 25000.0);
  const GridSpec g = test::grid_of(120, 80, 1000.0, 460000.0, 6040000.0);
  const PlanarSiteMetric metric(s, Vec2{g.xmin, g.ymax});
  for (const double cap : {std::numeric_limits<double>::infinity(), 28000.0}) {
    SCOPED_TRACE(cap);
    ComputeOptions o;
    o.max_distance = cap;
    const NearestField field = compute(s, g, o);
    const OwnerIndex index(metric, OwnerIndex::Measure::adjusted, cap);
    LineRequest request;
    request.boundaries = true;
    request.owned_edge = true;
    StripLines lines(g, index, request);
    lines.add(field);
    const BoundaryResult b = lines.take_boundaries();
    const LimitResult edge = lines.take_limits();
    ASSERT_EQ(edge.lines.size(), 1u);
    EXPECT_EQ(edge.lines[0].owner, kOwnedEdge);
    EXPECT_TRUE(edge.lines[0].closed);
    const double ra = std::min(30000.0, cap), rb = 25000.0;
    for (const LimitVertex& v : edge.lines[0].vertices) {
      const double da = std::hypot(v.p.x - A.x, v.p.y - A.y), db = std::hypot(v.p.x - B.x, v.p.y - B.y);
      EXPECT_TRUE(std::abs(da - ra) < 1e-5 || std::abs(db - rb) < 1e-5) << da << ", " << db;
      EXPECT_LT(v.residual, 1e-5);
    }
    const RegionEdges re = region_edges(b, index, g, cap, &edge);
    EXPECT_EQ(re.dangling_ends, 0);
    // The circles cross at x = (d^2 + r_A^2 - r_B^2) / 2d from A.
    const double x = (1600e6 + ra * ra - rb * rb) / 80000.0, y = std::sqrt(ra * ra - x * x);
    for (const double side : {1.0, -1.0}) {
      const Vec2 j{A.x + x, A.y + side * y};
      double on_edge = std::numeric_limits<double>::infinity(), on_line = on_edge;
      for (const LimitVertex& v : edge.lines[0].vertices)
        on_edge = std::min(on_edge, std::hypot(v.p.x - j.x, v.p.y - j.y));
      for (const std::vector<Vec2>& e : re.edges)
        for (const Vec2 p : {e.front(), e.back()}) on_line = std::min(on_line, std::hypot(p.x - j.x, p.y - j.y));
      EXPECT_LT(on_edge, 1e-4) << side;
      EXPECT_LT(on_line, 1e-4) << side;
    }
  }
}

}  // namespace
}  // namespace rv
