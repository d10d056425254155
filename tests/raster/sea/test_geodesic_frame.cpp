// The geodesic reading of the distance by sea's visibility (rv/sea/geodesic_frame.hpp): the
// frame's orientation predicate against GeographicLib's geodesics, down to points a tenth of a
// millimetre off them; the western Baltic's 428 km clip edge along 53.8 N read as its geodesic
// (2.4 km north of the parallel at its middle), land on one side of it to the millimetre; and
// whole paths against barrier lines, against an oracle that tests crossings with GeographicLib's
// azimuths directly, near-degenerate ones included.
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <thread>
#include <vector>

#include "geodesic_oracle.hpp"
#include "rv/field/error.hpp"
#include "rv/sea/geodesic_frame.hpp"
#include "rv/sea/visibility.hpp"

namespace rv {
namespace {

using test::crosses;
using test::geodesic_metric;
using test::side;
using test::wgs84;

// The western Baltic's box (fixtures/baltic_west.gpkg).
std::shared_ptr<const GeodesicFrame> baltic_frame() {
  return std::make_shared<const GeodesicFrame>(geodesic_metric(), 9.0, 53.8, 15.5, 56.2);
}

// The point `offset` metres to the left (positive) or right of the geodesic from a to b, beside
// its point at fraction t of the way (t may lie outside [0, 1]: beyond the ends).
Vec2 beside(Vec2 a, Vec2 b, double t, double offset) {
  const GeographicLib::GeodesicLine line = wgs84().InverseLine(a.y, a.x, b.y, b.x);
  double lat, lon, azi;
  line.Position(t * line.Distance(), lat, lon, azi);
  double lat2, lon2;
  wgs84().Direct(lat, lon, azi + (offset > 0 ? -90.0 : 90.0), std::abs(offset), lat2, lon2);
  return Vec2{lon2, lat2};
}

TEST(GeodesicFrame, RoundTripsAndMeasuresItsBending) {
  const auto frame = baltic_frame();
  for (const Vec2 p : {Vec2{9.0, 53.8}, Vec2{15.5, 56.2}, Vec2{12.25, 55.0}, Vec2{10.1, 55.9}}) {
    const Vec2 back = frame->reverse(frame->forward(p));
    EXPECT_NEAR(back.x, p.x, 1e-11);
    EXPECT_NEAR(back.y, p.y, 1e-11);
  }
  // The clip edge's image bends off its chord by millimetres: the frame allows for more.
  const Vec2 a{9.0, 53.8}, b{15.5, 53.8};
  const Vec2 pa = frame->forward(a), pb = frame->forward(b);
  const GeographicLib::GeodesicLine line = wgs84().InverseLine(a.y, a.x, b.y, b.x);
  double worst = 0.0;
  for (int i = 1; i < 100; ++i) {
    double lat, lon;
    line.Position(line.Distance() * i / 100.0, lat, lon);
    const Vec2 p = frame->forward(Vec2{lon, lat});
    worst = std::max(worst, std::abs((pb.x - pa.x) * (p.y - pa.y) - (pb.y - pa.y) * (p.x - pa.x)) /
                                std::hypot(pb.x - pa.x, pb.y - pa.y));
  }
  EXPECT_GT(worst, 1e-3);
  EXPECT_LT(worst, 1e-2);
  EXPECT_GT(frame->deviation(), worst);
  EXPECT_LT(frame->deviation(), 5.0);
  // Refusals: a box too large for one frame, a planar metric.
  EXPECT_THROW(GeodesicFrame(geodesic_metric(), -60.0, -10.0, 60.0, 10.0), Error);
  EXPECT_THROW(GeodesicFrame(MetricSpec{}, 9.0, 53.8, 15.5, 56.2), Error);
}

// The worst distance between rows projected as one and the exact forward problem of their
// points, on rows of `n` cells of `res` degrees from lon0 at each of `lats` (at most 64 cells
// share a knot).
double worst_row_error(const GeodesicFrame& frame, double lon0, double res, int64_t n,
                       std::initializer_list<double> lats) {
  double worst = 0.0;
  for (const double lat : lats) {
    std::vector<Vec2> row(static_cast<size_t>(n));
    frame.forward_row(lat, lon0 + res / 2, res, n, row.data());
    // (Every point of the first and last 130, where the knots are those at the row's ends.)
    for (int64_t i = 0; i < n; i += (i < 130 || i >= n - 131 || i % 97 == 0 ? 1 : 7)) {
      const Vec2 exact = frame.forward(Vec2{lon0 + res / 2 + static_cast<double>(i) * res, lat});
      worst =
          std::max(worst, std::hypot(row[static_cast<size_t>(i)].x - exact.x, row[static_cast<size_t>(i)].y - exact.y));
    }
  }
  return worst;
}

// Rows of cells projected as one: within 10 nm of the exact forward problem each, on rows of
// the western Baltic's grids at several cell sizes, and on a frame near the largest one allows
// (its rows far from the centre are where the projection bends most).
TEST(GeodesicFrame, RowsProjectAsTheirPointsDo) {
  const auto frame = baltic_frame();
  double worst = 0.0;
  for (const double res : {0.001, 0.005, 0.02})
    worst =
        std::max(worst, worst_row_error(*frame, 9.0, res, static_cast<int64_t>(6.5 / res), {53.8005, 55.0, 56.1995}));
  std::printf("rows projected as one: worst distance from the exact forward problem %.3g m\n", worst);
  EXPECT_LT(worst, 1e-8);  // (forward() itself is GeographicLib's, to about 15 nm)
  const GeodesicFrame wide(geodesic_metric(), -25.0, 45.0, 25.0, 75.0);
  double wide_worst = 0.0;
  for (const double res : {0.0005, 0.002, 0.01})
    wide_worst =
        std::max(wide_worst, worst_row_error(wide, -25.0, res, static_cast<int64_t>(50.0 / res), {45.0, 60.0, 75.0}));
  std::printf("a frame 50 by 30 degrees: worst %.3g m\n", wide_worst);
  EXPECT_LT(wide_worst, 1e-8);
}

TEST(GeodesicFrame, OrientationIsTheGeodesicOneDownToATenthOfAMillimetre) {
  const auto frame = baltic_frame();
  std::mt19937_64 rng(56);
  std::uniform_real_distribution<double> lon(9.0, 15.5), lat(53.8, 56.2), t(-0.3, 1.3);
  const double offsets[] = {1e-4, -1e-4, 1e-3, -1e-3, 1e-2, -1e-2, 1.0, -1.0, 100.0, -100.0};
  int checked = 0;
  const int64_t exact_before = frame->exact_tests();
  for (int i = 0; i < 300; ++i) {
    const Vec2 a{lon(rng), lat(rng)}, b{lon(rng), lat(rng)};
    const double along = t(rng);
    for (double offset : offsets) {
      const Vec2 c = beside(a, b, along, offset);
      if (c.x < 9.0 || c.x > 15.5 || c.y < 53.8 || c.y > 56.2) continue;
      const int want = side(a, b, c);
      ASSERT_EQ(want, offset > 0 ? 1 : -1) << "the oracle's own construction";
      ASSERT_EQ(frame->orient(frame->forward(a), frame->forward(b), frame->forward(c)), want)
          << a.x << " " << a.y << " -> " << b.x << " " << b.y << ", " << offset << " m at " << along;
      ++checked;
    }
  }
  EXPECT_GT(checked, 1500);
  // Points within the bending of the chord went to the exact test.
  EXPECT_GT(frame->exact_tests() - exact_before, 500);
  // Ends and repeated points are on the line.
  const Vec2 a = frame->forward(Vec2{10, 54}), b = frame->forward(Vec2{14, 56});
  EXPECT_EQ(frame->orient(a, b, a), 0);
  EXPECT_EQ(frame->orient(a, b, b), 0);
  EXPECT_EQ(frame->orient(a, a, b), 0);
}

// The exact test remembers, per thread, the points it located and the azimuths it measured;
// frames are told apart there though they share plane coordinates, and a frame made where a
// freed one lay (often the same address) does not inherit its memory.
TEST(GeodesicFrame, TheExactTestsMemoryTellsFramesApart) {
  // Triples of plane points, the third on the straight line through the other two: each
  // frame's answer is the side its geodesic image bends to there (by millimetres), read by the
  // exact test, and depends on which points of the earth the plane points are in that frame.
  std::mt19937_64 rng(66);
  std::uniform_real_distribution<double> x(-150e3, 150e3), y(-100e3, 100e3), t(0.1, 0.9);
  std::vector<std::array<Vec2, 3>> triples;
  for (int i = 0; i < 300; ++i) {
    const Vec2 a{x(rng), y(rng)}, b{x(rng), y(rng)};
    const double u = t(rng);
    triples.push_back({a, b, Vec2{a.x + u * (b.x - a.x), a.y + u * (b.y - a.y)}});
  }
  // Frames over the western Baltic's box on three ellipsoids (plane points are other places on
  // each, and a sphere's geodesics are straight), and one over a shifted box.
  struct Kind {
    double flattening, shift;
  };
  const Kind kinds[] = {{kWgs84Flattening, 0.0}, {0.0, 0.0}, {1.0 / 150.0, 0.0}, {kWgs84Flattening, 0.4}};
  auto make = [&](size_t k) {
    MetricSpec m = geodesic_metric();
    m.flattening = kinds[k].flattening;
    const double d = kinds[k].shift;
    return std::make_unique<GeodesicFrame>(m, 9.0 + d, 53.8 + d, 15.5 + d, 56.2 + d);
  };
  // Each frame's answers from a thread that never saw another frame.
  std::vector<std::vector<int>> want(std::size(kinds));
  for (size_t k = 0; k < want.size(); ++k)
    std::thread([&] {
      const auto f = make(k);
      for (const auto& q : triples) want[k].push_back(f->orient(q[0], q[1], q[2]));
    }).join();
  int telling = 0;  // answers a frame reading another's memory would get wrong
  for (size_t k = 1; k < want.size(); ++k)
    for (size_t i = 0; i < triples.size(); ++i) telling += want[k][i] != want[0][i] ? 1 : 0;
  EXPECT_GT(telling, 30);
  // One thread, the frames interleaved, twice over.
  std::vector<std::unique_ptr<GeodesicFrame>> frames;
  for (size_t k = 0; k < want.size(); ++k) frames.push_back(make(k));
  for (int round = 0; round < 2; ++round)
    for (size_t i = 0; i < triples.size(); ++i)
      for (size_t k = 0; k < frames.size(); ++k)
        ASSERT_EQ(frames[k]->orient(triples[i][0], triples[i][1], triples[i][2]), want[k][i]) << k << " " << i;
  EXPECT_GE(frames[0]->exact_tests(), static_cast<int64_t>(triples.size()));  // (the exact test's)
  // Each frame made again where the western Baltic's was just freed.
  for (size_t k = 1; k < want.size(); ++k) {
    auto f = make(0);
    for (const auto& q : triples) (void)f->orient(q[0], q[1], q[2]);
    f.reset();
    f = make(k);
    for (size_t i = 0; i < triples.size(); ++i)
      ASSERT_EQ(f->orient(triples[i][0], triples[i][1], triples[i][2]), want[k][i]) << k << " " << i;
  }
}

// A 4.5-degree clip edge (9.0 E to 13.5 E along 53.8 N, as the western Baltic's) of a land
// polygon north of it: read as the geodesic between its ends, which runs 2.4 km north of the
// parallel at 11.25 E. A point a millimetre north of the geodesic is land, a millimetre south
// sea; the parallel is sea.
TEST(GeodesicFrame, TheClipEdgeIsItsGeodesicForTheLandTest) {
  const auto frame = baltic_frame();
  const Vec2 sw{9.0, 53.8}, se{13.5, 53.8}, ne{13.5, 55.0}, nw{9.0, 55.0};
  Barriers barriers;
  barriers.add_polygon({Ring{frame->forward(sw), frame->forward(se), frame->forward(ne), frame->forward(nw)}},
                       SourceText{"clip"});
  const Visibility vis(barriers, true, frame);
  const Visibility reference(barriers, false, frame);
  // The geodesic's middle, where it crosses 11.25 E, heading east.
  const GeographicLib::GeodesicLine line = wgs84().InverseLine(sw.y, sw.x, se.y, se.x);
  double lat_mid, lon_mid, azi_mid;
  line.Position(0.5 * line.Distance(), lat_mid, lon_mid, azi_mid);
  EXPECT_NEAR(lon_mid, 11.25, 1e-9);
  EXPECT_NEAR(azi_mid, 90.0, 1e-9);
  double north_of_parallel;
  wgs84().Inverse(53.8, 11.25, lat_mid, lon_mid, north_of_parallel);
  EXPECT_GT(north_of_parallel, 2200.0);
  EXPECT_LT(north_of_parallel, 2600.0);
  for (const double metres : {1e-3, 1e-2, 1.0, 100.0}) {
    double lat_n, lon_n, lat_s, lon_s;
    wgs84().Direct(lat_mid, lon_mid, 0.0, metres, lat_n, lon_n);
    wgs84().Direct(lat_mid, lon_mid, 180.0, metres, lat_s, lon_s);
    for (const Visibility* v : {&vis, &reference}) {
      EXPECT_EQ(v->classify(frame->forward(Vec2{lon_n, lat_n})), Visibility::Ground::land) << metres;
      EXPECT_EQ(v->classify(frame->forward(Vec2{lon_s, lat_s})), Visibility::Ground::open_sea) << metres;
    }
  }
  EXPECT_EQ(vis.classify(frame->forward(Vec2{11.25, 53.8})), Visibility::Ground::open_sea);
  // A row of centres across the edge, classified at once, as point by point.
  std::vector<double> xs;
  const Vec2 mid = frame->forward(Vec2{lon_mid, lat_mid});
  for (int i = -50; i <= 50; ++i) xs.push_back(mid.x + 4000.0 * i);
  for (double dy : {-1e-3, 1e-3, -5.0, 5.0}) {
    std::vector<Visibility::Ground> row(xs.size());
    vis.classify_row(mid.y + dy, xs.data(), static_cast<int64_t>(xs.size()), row.data());
    for (size_t i = 0; i < xs.size(); ++i) EXPECT_EQ(row[i], vis.classify(Vec2{xs[i], mid.y + dy})) << i << " " << dy;
  }
}

// Paths across barrier lines, each decided against crossings tested with GeographicLib's azimuths
// in longitude and latitude: random ones, and ones ending a millimetre either side of a barrier.
TEST(GeodesicFrame, PathsAreBlockedExactlyWhenTheirGeodesicsCross) {
  const auto frame = baltic_frame();
  std::mt19937_64 rng(4956);
  std::uniform_real_distribution<double> lon(9.2, 15.3), lat(53.9, 56.1), u(0.05, 0.95);
  std::vector<std::pair<Vec2, Vec2>> walls;
  Barriers barriers;
  for (int i = 0; i < 12; ++i) {
    const Vec2 a{lon(rng), lat(rng)}, b{lon(rng), lat(rng)};
    walls.emplace_back(a, b);
    const std::vector<Vec2> plane{frame->forward(a), frame->forward(b)};
    barriers.add_line(plane);
  }
  const Visibility vis(barriers, true, frame);
  const Visibility reference(barriers, false, frame);
  int blocked = 0, free_paths = 0;
  auto check = [&](Vec2 p, Vec2 q) {
    bool want = true;
    for (const auto& [a, b] : walls) want = want && !crosses(p, q, a, b);
    const Visibility::Place from{frame->forward(p)}, to{frame->forward(q)};
    ASSERT_EQ(vis.sees(from, to), want) << p.x << " " << p.y << " -> " << q.x << " " << q.y;
    ASSERT_EQ(reference.sees(from, to), want);
    (want ? free_paths : blocked) += 1;
  };
  for (int i = 0; i < 400; ++i) check(Vec2{lon(rng), lat(rng)}, Vec2{lon(rng), lat(rng)});
  // Ends a millimetre (and a tenth of one) either side of a wall, the path running across it.
  for (int i = 0; i < 200; ++i) {
    const auto& [a, b] = walls[static_cast<size_t>(i) % walls.size()];
    const double at = u(rng);
    for (double offset : {1e-3, -1e-3, 1e-4, -1e-4}) {
      const Vec2 near = beside(a, b, at, offset), far = beside(a, b, at, offset > 0 ? 20000.0 : -20000.0);
      check(near, far);
      check(far, near);
      const Vec2 other = beside(a, b, at, offset > 0 ? -20000.0 : 20000.0);
      check(near, other);
    }
  }
  EXPECT_GT(blocked, 300);
  EXPECT_GT(free_paths, 300);
}

// The next cell's ground from the last one's (classify_next) is classify()'s, on the geodesic
// reading: steps along rows of a 0.002-degree grid over islands with holes, two polygons sharing
// a border and a line; steps ending exactly on every vertex; and steps across every edge ending a
// millimetre and a tenth of one either side of its geodesic.
TEST(GeodesicFrame, TheNextCellsGroundIsItsOwn) {
  const auto frame = baltic_frame();
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> lon(11.0, 11.4), lat(54.9, 55.2), size(0.01, 0.08), u(0.05, 0.95);
  Barriers barriers;
  std::vector<std::pair<Vec2, Vec2>> edges;  // in longitude and latitude
  auto add_ring = [&](const std::vector<Vec2>& ll) {
    Ring plane;
    for (size_t i = 0; i < ll.size(); ++i) {
      plane.push_back(frame->forward(ll[i]));
      edges.emplace_back(ll[i], ll[(i + 1) % ll.size()]);
    }
    return plane;
  };
  for (int k = 0; k < 10; ++k) {
    const double x = lon(rng), y = lat(rng), w = size(rng), h = size(rng);
    std::vector<Ring> rings{add_ring({{x, y}, {x + w, y}, {x + w, y + h}, {x + 0.3 * w, y + 1.2 * h}})};
    if (w > 0.04 && h > 0.04)
      rings.push_back(add_ring({{x + 0.01, y + 0.01}, {x + 0.02, y + 0.01}, {x + 0.02, y + 0.02}}));
    barriers.add_polygon(rings, SourceText{"island"});
  }
  barriers.add_polygon({add_ring({{11.1, 55.0}, {11.15, 55.0}, {11.15, 55.05}, {11.1, 55.05}})}, SourceText{"west"});
  barriers.add_polygon({add_ring({{11.15, 55.0}, {11.2, 55.0}, {11.2, 55.05}, {11.15, 55.05}})}, SourceText{"east"});
  const Vec2 l0{11.05, 54.95}, l1{11.3, 55.12};
  barriers.add_line(std::vector<Vec2>{frame->forward(l0), frame->forward(l1)});
  edges.emplace_back(l0, l1);
  const Visibility vis(barriers, true, frame);
  int64_t steps = 0, changes = 0;
  std::map<Visibility::Ground, int64_t> seen;
  auto step = [&](Vec2 p_ll, Vec2 q_ll) {
    const Vec2 p = frame->forward(p_ll), q = frame->forward(q_ll);
    const Visibility::Ground from = vis.classify(p), want = vis.classify(q);
    ++seen[want];
    if (from == Visibility::Ground::on_barrier) return;  // (not asked of it)
    ASSERT_EQ(vis.classify_next(p, from, q), want) << p_ll.x << " " << p_ll.y << " -> " << q_ll.x << " " << q_ll.y;
    ++steps;
    changes += from != want;
  };
  for (double y = 54.88; y < 55.3; y += 0.002)
    for (double x = 10.98; x < 11.5; x += 0.002) step(Vec2{x, y}, Vec2{x + 0.002, y});
  for (const auto& [a, b] : edges) {
    for (const Vec2& d : {Vec2{0.002, 0.0}, Vec2{-0.002, 0.001}, Vec2{0.0, -0.002}})
      step(Vec2{a.x + d.x, a.y + d.y}, a);
    const double at = u(rng);
    for (double offset : {1e-3, -1e-3, 1e-4, -1e-4}) {
      step(beside(a, b, at, offset > 0 ? -150.0 : 150.0), beside(a, b, at, offset));
      step(beside(a, b, at, offset > 0 ? 150.0 : -150.0), beside(a, b, at, offset));
    }
  }
  std::printf("%lld steps, %lld change the ground; land %lld, open sea %lld, on a barrier %lld\n",
              static_cast<long long>(steps), static_cast<long long>(changes),
              static_cast<long long>(seen[Visibility::Ground::land]),
              static_cast<long long>(seen[Visibility::Ground::open_sea]),
              static_cast<long long>(seen[Visibility::Ground::on_barrier]));
  EXPECT_GT(changes, 500);
  EXPECT_GT(seen[Visibility::Ground::land], 1000);
  EXPECT_GT(seen[Visibility::Ground::on_barrier], 40);
}

}  // namespace
}  // namespace rv
