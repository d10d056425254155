// Lines exact along their whole length (BoundaryOptions / LimitOptions::line_tolerance): every
// sampled point of every segment within the tolerance of the exact locus, measured against
// references that share nothing with the engine -- GeographicLib's own inverse problem, the
// closed forms of a parabola and of a weighted Apollonius circle, plain planar distances -- on
// geodesic grids of 0.01 and 0.002 degrees and planar grids of 1 km and 100 m.
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/regions.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

constexpr double kTol = 1e-3;  // metres (metric units)
constexpr double kInf = std::numeric_limits<double>::infinity();
const GeographicLib::Geodesic& wgs84() { return GeographicLib::Geodesic::WGS84(); }

double geodesic(Vec2 a, Vec2 b) {
  double s12 = 0.0;
  wgs84().Inverse(a.y, a.x, b.y, b.x, s12);
  return s12;
}

// Calls f(p) at points 1/8 .. 7/8 of every segment of every line.
template <class Line, class F>
void each_sample(const std::vector<Line>& lines, F&& f) {
  for (const Line& line : lines)
    for (size_t i = 0; i + 1 < line.vertices.size(); ++i)
      for (int k = 1; k < 8; ++k) {
        const double t = k / 8.0;
        const Vec2 a = line.vertices[i].p, b = line.vertices[i + 1].p;
        f(Vec2{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)});
      }
}

// The distance from p to the zero level of f, to first order: |f| / |grad f|, the gradient by
// central differences over steps of `h_x`, `h_y` CRS units measuring `m_x`, `m_y` metres.
double offset(const std::function<double(Vec2)>& f, Vec2 p, double hx, double hy, double mx, double my) {
  const double gx = (f(Vec2{p.x + hx, p.y}) - f(Vec2{p.x - hx, p.y})) / (2.0 * mx);
  const double gy = (f(Vec2{p.x, p.y + hy}) - f(Vec2{p.x, p.y - hy})) / (2.0 * my);
  return std::abs(f(p)) / std::hypot(gx, gy);
}

// Seeds on a grid with their exact field, metric and index: geodesic (longitude/latitude, WGS84)
// or planar.
struct Scene {
  SeedSet seeds;
  GridSpec grid;
  NearestField field;
  std::unique_ptr<SiteMetric> metric;
  std::unique_ptr<OwnerIndex> index;
  Scene(SeedSet s, GridSpec g, bool geodesic) : seeds(std::move(s)), grid(g) {
    ComputeOptions o;
    o.threads = 2;
    if (geodesic) o.metric = MetricSpec{MetricSpec::geodesic};
    field = compute(seeds, grid, o);
    if (geodesic)
      metric = std::make_unique<GeodesicSiteMetric>(seeds, o.metric);
    else
      metric = std::make_unique<PlanarSiteMetric>(seeds, Vec2{grid.xmin, grid.ymax});
    index = std::make_unique<OwnerIndex>(*metric);
  }
};
struct Geo : Scene {
  Geo(SeedSet s, GridSpec g) : Scene(std::move(s), g, true) {}
};
struct Planar : Scene {
  Planar(SeedSet s, GridSpec g) : Scene(std::move(s), g, false) {}
};

// A point island at 50 N and a straight coast along the meridian 1 degree west: the analyst's
// 12 nmi limit round the island, and the equidistance line between the two.
SeedSet island_and_coast() {
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("I")), Vec2{0.0, 50.0});
  s.add_polyline(s.add_feature(s.owner_code("A")), std::vector<Vec2>{{-1.0, 49.0}, {-1.0, 51.0}});
  return s;
}

GridSpec geo_grid(double res) {
  return test::grid_of(static_cast<int64_t>(std::llround(1.0 / res)), static_cast<int64_t>(std::llround(0.6 / res)),
                       res, -0.7, 50.3);
}

// The geodesic distance from p to the meridian -1 between 49 and 51 N: the least inverse
// distance over its latitudes (golden-section search; the distance is unimodal along it).
double to_meridian(Vec2 p) {
  double lo = 49.0, hi = 51.0;
  const double r = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int i = 0; i < 80; ++i) {
    const double a = hi - r * (hi - lo), b = lo + r * (hi - lo);
    if (geodesic(p, Vec2{-1.0, a}) < geodesic(p, Vec2{-1.0, b}))
      hi = b;
    else
      lo = a;
  }
  return geodesic(p, Vec2{-1.0, 0.5 * (lo + hi)});
}

class GeodesicTolerance : public ::testing::TestWithParam<double> {};

TEST_P(GeodesicTolerance, TheLimitArcAndTheEquidistanceLineWithinAMillimetre) {
  const double res = GetParam();
  const Geo k(island_and_coast(), geo_grid(res));
  const std::vector<double> D{22224.0};
  LimitOptions per_owner;
  per_owner.per_owner = true;
  LimitResult limits = extract_limits(k.field, *k.index, D, per_owner);
  // The island's (owner 1) arc: the coast's own line is straight (an offset of the meridian).
  std::erase_if(limits.lines, [](const LimitLine& l) { return l.owner != 1; });
  ASSERT_FALSE(limits.lines.empty());
  EXPECT_EQ(limits.residual.unresolved, 0);
  EXPECT_LE(limits.residual.max_midpoint, kTol);
  EXPECT_GT(limits.residual.added, 0);
  double worst = 0.0;
  int64_t samples = 0;
  each_sample(limits.lines, [&](Vec2 p) {
    worst = std::max(worst, std::abs(geodesic(Vec2{0.0, 50.0}, p) - D[0]));
    ++samples;
  });
  EXPECT_LE(worst, kTol) << samples << " samples";

  const BoundaryResult b = extract_boundaries(k.field, *k.index);
  ASSERT_EQ(b.lines.size(), 1u);
  EXPECT_EQ(b.stats.locus.unresolved, 0);
  EXPECT_LE(b.stats.locus.max_midpoint, kTol);
  // Steps of a thousandth of a cell; a degree's metres here.
  const double h = 1e-3 * res, mx = geodesic(Vec2{-0.5, 50.0}, Vec2{-0.5 + h, 50.0}) / h,
               my = geodesic(Vec2{-0.5, 50.0}, Vec2{-0.5, 50.0 + h}) / h;
  auto locus = [](Vec2 p) { return geodesic(Vec2{0.0, 50.0}, p) - to_meridian(p); };
  worst = 0.0;
  samples = 0;
  // (A thirteenth of the segments: the meridian's golden-section reference is slow.)
  int64_t n = 0;
  each_sample(b.lines, [&](Vec2 p) {
    if (n++ % 13 != 0) return;
    worst = std::max(worst, offset(locus, p, h, h, h * mx, h * my));
    ++samples;
  });
  EXPECT_LE(worst, kTol) << samples << " samples";
}

INSTANTIATE_TEST_SUITE_P(Cells, GeodesicTolerance, ::testing::Values(0.01, 0.002));

// A coarser tolerance gives fewer vertices; 0 leaves the cell-edge vertices alone, and the
// residual measured along them shows the chords' sagitta (c^2 / 8R: metres on a 0.01 degree
// grid).
TEST(LineTolerance, ACoarserToleranceGivesFewerVertices) {
  const Geo k(island_and_coast(), geo_grid(0.01));
  const std::vector<double> D{22224.0};
  int64_t last = std::numeric_limits<int64_t>::max();
  for (const double tol : {1e-4, 1e-3, 1e-2, 1e-1, 0.0}) {
    LimitOptions o;
    o.line_tolerance = tol;
    const LimitResult r = extract_limits(k.field, *k.index, D, o);
    EXPECT_LT(r.vertices, last) << tol;
    last = r.vertices;
    if (tol > 0.0) {
      EXPECT_LE(r.residual.max_midpoint, tol) << tol;
    }
    if (tol == 0.0) {
      EXPECT_EQ(r.residual.added, 0);
      EXPECT_GT(r.residual.max_midpoint, 5.0);  // the 7.9 m between cell-edge vertices
      EXPECT_LT(r.residual.max_midpoint, 10.0);
    }
  }
}

// Simplified, a limit keeps fewer of its vertices, every one still on the level; the report's
// simplified_midpoint measures what the thinning gave up, and every sampled point stays within the
// line tolerance plus the simplification's (a tenth of a cell here).
TEST(LineTolerance, SimplifiedLimitsStateTheToleranceThatHolds) {
  const double res = 0.01;
  const Geo k(island_and_coast(), geo_grid(res));
  const std::vector<double> D{22224.0};
  LimitOptions o;
  o.per_owner = true;
  const LimitResult full = extract_limits(k.field, *k.index, D, o);
  o.simplify_cells = 0.1;
  LimitResult thin = extract_limits(k.field, *k.index, D, o);
  EXPECT_EQ(thin.vertices_before_simplify, full.vertices);
  EXPECT_LT(thin.vertices, full.vertices / 2);
  EXPECT_EQ(full.simplified_midpoint, 0.0);
  EXPECT_GT(thin.simplified_midpoint, kTol);
  std::erase_if(thin.lines, [](const LimitLine& l) { return l.owner != 1; });
  ASSERT_FALSE(thin.lines.empty());
  // A tenth of a cell in metres at 50 N (the degree's length along the meridian is the larger).
  const double bound = kTol + 0.1 * res * geodesic(Vec2{0.0, 50.0}, Vec2{0.0, 51.0});
  double worst = 0.0;
  for (const LimitLine& l : thin.lines)
    for (const LimitVertex& v : l.vertices) EXPECT_LE(std::abs(geodesic(Vec2{0.0, 50.0}, v.p) - D[0]), 1e-6);
  each_sample(thin.lines, [&](Vec2 p) { worst = std::max(worst, std::abs(geodesic(Vec2{0.0, 50.0}, p) - D[0])); });
  EXPECT_GT(worst, kTol);
  EXPECT_LE(worst, bound);
  EXPECT_LE(thin.simplified_midpoint, bound);
}

double to_segment(Vec2 p, Vec2 a, Vec2 b) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double t = std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
  return std::hypot(p.x - a.x - t * dx, p.y - a.y - t * dy);
}

// A planar grid of `res` metres over [x0, x0 + w] x [y0, y0 + h] (metres).
GridSpec planar_grid(double res, double x0, double y0, double w, double h) {
  return test::grid_of(static_cast<int64_t>(std::llround(w / res)), static_cast<int64_t>(std::llround(h / res)), res,
                       x0, y0 + h);
}

class PlanarTolerance : public ::testing::TestWithParam<double> {};

// A basepoint 10 km off a straight coast: the equidistance line is the parabola with the point as
// focus and the coast as directrix, y = x^2 / 20 km + 5 km. Its distance from a sample is found
// on the parabola itself (Newton's method on the foot's abscissa).
TEST_P(PlanarTolerance, APointAndASegmentMakeAParabola) {
  const double res = GetParam();
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("P")), Vec2{0.0, 10000.0});
  s.add_polyline(s.add_feature(s.owner_code("S")), std::vector<Vec2>{{-60000.0, 0.0}, {60000.0, 0.0}});
  const Planar k(std::move(s), planar_grid(res, -20000.0, 1000.0, 40000.0, 20000.0));
  const BoundaryResult b = extract_boundaries(k.field, *k.index);
  ASSERT_EQ(b.lines.size(), 1u);
  EXPECT_EQ(b.stats.locus.unresolved, 0);
  EXPECT_GT(b.stats.arc_points, 0);
  double worst = 0.0;
  each_sample(b.lines, [&](Vec2 p) {
    // The foot x minimises (x - px)^2 + (x^2 / 2f + f/2 - py)^2 with f = 10 km.
    const double f = 10000.0;
    double x = p.x;
    for (int i = 0; i < 50; ++i) {
      const double y = x * x / (2.0 * f) + 0.5 * f, dy = x / f;
      const double g = (x - p.x) + (y - p.y) * dy, gp = 1.0 + dy * dy + (y - p.y) / f;
      x -= g / gp;
    }
    worst = std::max(worst, std::hypot(x - p.x, x * x / (2.0 * f) + 0.5 * f - p.y));
  });
  EXPECT_LE(worst, kTol);
}

// Two coasts at an angle: the locus is the angle's bisector where both interiors hold it, a
// parabola where an end faces an interior, and straight again between two ends. Measured with
// plain planar distances to the two segments.
TEST_P(PlanarTolerance, TwoSegments) {
  const double res = GetParam();
  SeedSet s;
  const Vec2 a0{0.0, 0.0}, a1{30000.0, 0.0}, b0{5000.0, 8000.0}, b1{35000.0, 22000.0};
  s.add_polyline(s.add_feature(s.owner_code("A")), std::vector<Vec2>{a0, a1});
  s.add_polyline(s.add_feature(s.owner_code("B")), std::vector<Vec2>{b0, b1});
  const Planar k(std::move(s), planar_grid(res, -5000.0, -10000.0, 50000.0, 40000.0));
  const BoundaryResult b = extract_boundaries(k.field, *k.index);
  ASSERT_FALSE(b.lines.empty());
  EXPECT_EQ(b.stats.locus.unresolved, 0);
  auto locus = [&](Vec2 p) { return to_segment(p, a0, a1) - to_segment(p, b0, b1); };
  double worst = 0.0;
  const double h = 1e-3 * res;
  each_sample(b.lines, [&](Vec2 p) { worst = std::max(worst, offset(locus, p, h, h, h, h)); });
  EXPECT_LE(worst, kTol);
}

// Two basepoints weighted 3 : 1: the boundary is the Apollonius circle |p - A| = 3 |p - B|,
// centre (A - 9B) / (1 - 9), radius 3 |A - B| / 8.
TEST_P(PlanarTolerance, TheWeightedApolloniusCircle) {
  const double res = GetParam();
  SeedSet s;
  const Vec2 A{0.0, 0.0}, B{40000.0, 0.0};
  const int32_t fa = s.add_feature(s.owner_code("A"));
  s.add_point(fa, A);
  s.set_adjustment(fa, 3.0, kInf);
  s.add_point(s.add_feature(s.owner_code("B")), B);
  const Vec2 C{(A.x - 9.0 * B.x) / -8.0, 0.0};
  const double R = 3.0 * 40000.0 / 8.0;
  const Planar k(std::move(s), planar_grid(res, C.x - 20000.0, -20000.0, 40000.0, 40000.0));
  const BoundaryResult b = extract_boundaries(k.field, *k.index);
  ASSERT_EQ(b.lines.size(), 1u);
  EXPECT_TRUE(b.lines[0].closed);
  double worst = 0.0;
  each_sample(b.lines, [&](Vec2 p) { worst = std::max(worst, std::abs(std::hypot(p.x - C.x, p.y - C.y) - R)); });
  EXPECT_LE(worst, kTol);
  // The disc's area from the line: within what the tolerance allows (every point of the ring
  // within kTol of the circle: at most the perimeter times it).
  std::vector<Vec2> ring;
  for (const BoundaryVertex& v : b.lines[0].vertices) ring.push_back(v.p);
  const double area = ring_area(ring, MetricSpec{}, nullptr, res), exact = M_PI * R * R;
  EXPECT_LE(std::abs(area - exact), 2.0 * M_PI * R * kTol);
}

// Two islands with reaches of 20 km, 30 km apart, in a sea of a third owner: each island's
// region is its disc cut by the bisector (the lens' chord), bounded by its reach's arc.
TEST_P(PlanarTolerance, TheReachLens) {
  const double res = GetParam();
  SeedSet s;
  const Vec2 A{0.0, 0.0}, B{30000.0, 0.0};
  const int32_t fa = s.add_feature(s.owner_code("A"));
  s.add_point(fa, A);
  s.set_adjustment(fa, 1.0, 20000.0);
  const int32_t fb = s.add_feature(s.owner_code("B"));
  s.add_point(fb, B);
  s.set_adjustment(fb, 1.0, 20000.0);
  s.add_polyline(s.add_feature(s.owner_code("C")), std::vector<Vec2>{{-100000.0, 60000.0}, {100000.0, 60000.0}});
  const Planar k(std::move(s), planar_grid(res, -25000.0, -25000.0, 80000.0, 50000.0));
  const BoundaryResult b = extract_boundaries(k.field, *k.index);
  EXPECT_EQ(b.stats.locus.unresolved + b.stats.arcs.unresolved, 0);
  EXPECT_GT(b.stats.arcs.segments, 0);
  EXPECT_LE(b.stats.arcs.max_midpoint, kTol);
  double worst = 0.0;
  for (const BoundaryLine& line : b.lines) {
    auto locus = [&](Vec2 p) {
      if (line.owner_a == 1 && line.owner_b == 2) return std::abs(p.x - 15000.0);
      const Vec2 c = line.owner_a == 1 ? A : B;  // A-C or B-C: the island's arc
      return std::abs(std::hypot(p.x - c.x, p.y - c.y) - 20000.0);
    };
    each_sample(std::vector<BoundaryLine>{line}, [&](Vec2 p) { worst = std::max(worst, locus(p)); });
  }
  EXPECT_LE(worst, kTol);
}

// Straight loci get no points: two basepoints (a straight bisector) and two parallel coasts (the
// midline); simplified, each is one segment of two vertices.
TEST_P(PlanarTolerance, StraightLociStayTwoVertexSegments) {
  const double res = GetParam();
  for (int scene = 0; scene < 2; ++scene) {
    SeedSet s;
    if (scene == 0) {
      s.add_point(s.add_feature(s.owner_code("A")), Vec2{3000.0, 4000.0});
      s.add_point(s.add_feature(s.owner_code("B")), Vec2{21000.0, 13000.0});
    } else {
      s.add_polyline(s.add_feature(s.owner_code("A")), std::vector<Vec2>{{-50000.0, 2000.0}, {80000.0, 2000.0}});
      s.add_polyline(s.add_feature(s.owner_code("B")), std::vector<Vec2>{{-50000.0, 16000.0}, {80000.0, 16000.0}});
    }
    const Planar k(std::move(s), planar_grid(res, 0.0, 0.0, 24000.0, 18000.0));
    const BoundaryResult b = extract_boundaries(k.field, *k.index);
    ASSERT_EQ(b.lines.size(), 1u) << scene;
    EXPECT_EQ(b.stats.arc_points + b.stats.turning_points, 0) << scene;
    EXPECT_LE(b.stats.locus.max_midpoint, 1e-9 * res) << scene;
    BoundaryOptions o;
    o.simplify_cells = 1e-6;
    const BoundaryResult simple = extract_boundaries(k.field, *k.index, o);
    ASSERT_EQ(simple.lines.size(), 1u);
    EXPECT_EQ(simple.lines[0].vertices.size(), 2u) << scene;
  }
}

INSTANTIATE_TEST_SUITE_P(Cells, PlanarTolerance, ::testing::Values(1000.0, 100.0));

// A wedge of one owner narrower than a cell before its tip: the point B between two points A1, A2
// of the other owner, ten units either side of it and one behind. B's region is a wedge of
// half-angle 5.7 degrees whose tip T, 50.5 units behind B, is the three points' circumcentre:
// there the line turns (A's nearest changes from A1 to A2). Within about 25 units of T the wedge
// is narrower than a cell of 5, and the cells end the line across it, one chord standing for 50
// units of the locus. The line goes out to T and back: a vertex at T, and every sampled point
// within the tolerance of the two rays from T; with either owner on the side that changes, on a
// layout turned by any angle. Turned, some of the wedge's cells near T are cut off from the rest:
// the closed line they trace, refined onto the same rays, is dropped (repeated_loops), and the
// main line is the only one.
TEST(LineTolerance, ALineFollowsAWedgeNarrowerThanACellToItsTip) {
  int64_t cases = 0, repeated = 0;
  for (const double turn : {0.0, 0.3, 2.1})
    for (const double res : {3.0, 5.0, 7.0})
      for (const bool a_first : {true, false}) {
        const double c = std::cos(turn), s = std::sin(turn);
        auto at = [&](Vec2 p) { return Vec2{c * p.x - s * p.y, s * p.x + c * p.y}; };
        const Vec2 b = at({0, 0}), a1 = at({-1, 10}), a2 = at({-1, -10}), tip = at({-50.5, 0});
        SeedSet seeds;
        auto add = [&](const char* owner, Vec2 p) { seeds.add_point(seeds.add_feature(seeds.owner_code(owner)), p); };
        if (!a_first) add("B", b);
        add("A", a1);
        add("A", a2);
        if (a_first) add("B", b);
        const auto n = static_cast<int64_t>(std::ceil(160.0 / res));
        const Planar k(seeds, test::grid_of(n, n, res, -80.0, 80.0));
        const BoundaryResult r = extract_boundaries(k.field, *k.index);
        const std::string name = "turn " + std::to_string(turn) + ", cells of " + std::to_string(res) +
                                 (a_first ? ", A first" : ", B first");
        ASSERT_EQ(r.lines.size(), 1u) << name;
        EXPECT_EQ(r.stats.locus.unresolved, 0) << name;
        EXPECT_LE(r.stats.locus.max_midpoint, kTol) << name;
        EXPECT_GE(r.stats.turning_points, 1) << name;
        double nearest_tip = kInf;
        for (const BoundaryVertex& v : r.lines[0].vertices)
          nearest_tip = std::min(nearest_tip, std::hypot(v.p.x - tip.x, v.p.y - tip.y));
        EXPECT_LE(nearest_tip, 1e-6) << name;
        // The locus: the bisector of B and A_i on A_i's side of T (A_i the nearer of the two).
        auto to_ray = [&](Vec2 p, Vec2 ai, Vec2 aj) {
          Vec2 d{-(ai.y - b.y), ai.x - b.x};
          if (d.x * (ai.x - aj.x) + d.y * (ai.y - aj.y) < 0.0) d = Vec2{-d.x, -d.y};
          const double len = std::hypot(d.x, d.y), along = ((p.x - tip.x) * d.x + (p.y - tip.y) * d.y) / len;
          if (along <= 0.0) return std::hypot(p.x - tip.x, p.y - tip.y);
          return std::abs((p.x - tip.x) * d.y - (p.y - tip.y) * d.x) / len;
        };
        double worst = 0.0;
        int64_t samples = 0;
        each_sample(r.lines, [&](Vec2 p) {
          worst = std::max(worst, std::min(to_ray(p, a1, a2), to_ray(p, a2, a1)));
          ++samples;
        });
        EXPECT_LE(worst, kTol) << name << ": " << samples << " samples";
        repeated += r.stats.repeated_loops;
        ++cases;
      }
  EXPECT_EQ(cases, 18);
  EXPECT_GE(repeated, 4);
}

// Loci through cell centres: a centre on the locus is the crossing of both ways from it (each
// way's end), and lines must not repeat it as a segment of length zero, which some GIS tools
// refuse or report as invalid. A bisector along a diagonal of centres (every diagonal centre on
// it, tied and given to the lower owner), the three points' wedge at cells of 3 (its lines pass
// through two centres), and limits round a point seed at a centre: 3 (through the four nearest
// centres) and 15 (through 12 centres, a 3-4-5 triangle's multiples). Each line's vertices are
// distinct from their neighbours, on the locus or level, and nothing else of the line changes:
// samples within the tolerance.
TEST(LineTolerance, NoLineRepeatsAVertexWhereItsLocusPassesThroughCellCentres) {
  auto distinct = [](const auto& lines, const std::string& name) {
    int64_t vertices = 0;
    for (const auto& line : lines) {
      for (size_t i = 0; i + 1 < line.vertices.size(); ++i)
        EXPECT_FALSE(line.vertices[i].p.x == line.vertices[i + 1].p.x &&
                     line.vertices[i].p.y == line.vertices[i + 1].p.y)
            << name << ": " << line.vertices[i].p.x << "," << line.vertices[i].p.y;
      vertices += static_cast<int64_t>(line.vertices.size());
    }
    return vertices;
  };
  {
    SeedSet s;
    s.add_point(s.add_feature(s.owner_code("A")), Vec2{10.5, 30.5});
    s.add_point(s.add_feature(s.owner_code("B")), Vec2{30.5, 10.5});
    const Planar k(std::move(s), test::grid_of(40, 40));
    const BoundaryResult r = extract_boundaries(k.field, *k.index);
    ASSERT_EQ(r.lines.size(), 1u);
    EXPECT_GE(distinct(r.lines, "diagonal"), 2);
    each_sample(r.lines, [&](Vec2 p) { EXPECT_LE(std::abs(p.x - p.y) / std::sqrt(2.0), kTol) << p.x << "," << p.y; });
  }
  {
    SeedSet s;
    const Vec2 b{0, 0}, a1{-1, 10}, a2{-1, -10};
    s.add_point(s.add_feature(s.owner_code("A")), a1);
    s.add_point(s.add_feature(s.owner_code("A")), a2);
    s.add_point(s.add_feature(s.owner_code("B")), b);
    const Planar k(std::move(s), test::grid_of(54, 27, 3.0, -120.0, 40.0));
    const BoundaryResult r = extract_boundaries(k.field, *k.index);
    ASSERT_EQ(r.lines.size(), 1u);
    distinct(r.lines, "wedge");
    auto to_locus = [&](Vec2 p) {
      const double da = std::min(std::hypot(p.x - a1.x, p.y - a1.y), std::hypot(p.x - a2.x, p.y - a2.y));
      return std::abs(da - std::hypot(p.x - b.x, p.y - b.y));
    };
    for (const BoundaryVertex& v : r.lines[0].vertices) EXPECT_LE(to_locus(v.p), 1e-7) << v.p.x << "," << v.p.y;
    int through_centres = 0;  // (the layout's point: its locus meets centres)
    for (const BoundaryVertex& v : r.lines[0].vertices)
      through_centres += std::fmod(v.p.x + 120.0, 3.0) == 1.5 && std::fmod(40.0 - v.p.y, 3.0) == 1.5 ? 1 : 0;
    EXPECT_GE(through_centres, 2);
  }
  {
    SeedSet s;
    const Vec2 c{60.5, 60.5};
    s.add_point(s.add_feature(s.owner_code("P")), c);
    const Planar k(std::move(s), test::grid_of(121, 121));
    const std::vector<double> at{3.0, 15.0};
    const LimitResult r = extract_limits(k.field, *k.index, at);
    ASSERT_EQ(r.lines.size(), 2u);
    distinct(r.lines, "limits");
    for (const LimitLine& line : r.lines)
      for (const LimitVertex& v : line.vertices) {
        const double d = std::hypot(v.p.x - c.x, v.p.y - c.y);
        EXPECT_TRUE(std::abs(d - 3.0) <= 1e-9 || std::abs(d - 15.0) <= 1e-9) << v.p.x << "," << v.p.y;
      }
    EXPECT_LE(r.residual.max_midpoint, kTol);
  }
}

}  // namespace
}  // namespace rv
