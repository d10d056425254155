// The interpolated distances of the exact geodesic method (geodesic_interpolant.hpp), on their
// own: the cubic weights and the bicubic evaluation reproduce what they must, the forms' values
// are what their contract says, the shared store builds each interpolant once, and the values
// the solver takes from its interpolants stay within the accuracy the method relies on (the
// close calls it decides exactly are kInterpTie wide: every interpolated value must be far
// closer to the geodesic distance than that).
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <random>
#include <thread>
#include <vector>

#include "geodesic/geodesic_solver.hpp"
#include "rv/engine/engine.hpp"
#include "seed_gen.hpp"

namespace rv::detail {
namespace {

TEST(GeodesicInterpolant, CubicWeightsInterpolateCubicsExactly) {
  const double nodes[4] = {0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0};
  for (int k = 0; k < 4; ++k) {  // a node's weights pick that node
    double w[4];
    cubic_weights(nodes[k], w);
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(w[j], j == k ? 1.0 : 0.0, 1e-15);
  }
  auto cubic = [](double t) { return 2.0 - 3.0 * t + 0.5 * t * t + 7.0 * t * t * t; };
  for (double t = -0.25; t <= 1.25; t += 0.01) {
    double w[4];
    cubic_weights(t, w);
    EXPECT_NEAR(w[0] + w[1] + w[2] + w[3], 1.0, 1e-13);
    const double v = w[0] * cubic(0.0) + w[1] * cubic(1.0 / 3.0) + w[2] * cubic(2.0 / 3.0) + w[3] * cubic(1.0);
    EXPECT_NEAR(v, cubic(t), 1e-12) << t;
  }
}

TEST(GeodesicInterpolant, EvalIsTheBicubicRowsFirst) {
  // A product of cubics in the row and column parameters is reproduced at any cell.
  auto f = [](double s, double t) { return (1.0 + s - 2.0 * s * s * s) * (3.0 - t + t * t); };
  Interpolant it{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) it.q[i][j] = f(i / 3.0, j / 3.0);
  for (double s = 0.0; s <= 1.0; s += 0.125)
    for (double t = 0.0; t <= 1.0; t += 0.125) {
      double wt[4], wc[4];
      cubic_weights(s, wt);
      cubic_weights(t, wc);
      EXPECT_NEAR(eval(it, wt, wc), f(s, t), 1e-12);
    }
}

TEST(GeodesicInterpolant, TheFormsGiveTheirValues) {
  Interpolant p{};
  p.sx = 1000.0;
  p.sy = -2000.0;
  p.sz = 500.0;
  // Point form: q times the chord, as root(q^2 chord^2).
  EXPECT_DOUBLE_EQ(apply(p, 1.25, 1000.0 + 3.0, -2000.0 + 4.0, 500.0), 1.25 * 5.0);
  EXPECT_DOUBLE_EQ(normaliser(p, 1000.0, -2000.0 + 12.0, 500.0), 12.0);
  // Additive form: |g + k3 g^3 + q|, g the signed distance to the plane.
  Interpolant a = p;
  a.additive = true;
  a.nx = 0.0;
  a.ny = 0.0;
  a.nz = 1.0;
  a.k3 = 1e-3;
  EXPECT_DOUBLE_EQ(normaliser(a, 7.0, 8.0, 500.0 + 10.0), 10.0 + 1e-3 * 1000.0);
  EXPECT_DOUBLE_EQ(apply(a, -30.0, 7.0, 8.0, 500.0 + 10.0), 19.0);
}

TEST(GeodesicInterpolant, TheSharedStoreBuildsEachOnceForAllThreads) {
  SharedInterpolants shared;
  std::atomic<int> builds{0};
  std::vector<const Interpolant*> seen(8, nullptr);
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&, t] {
      auto e = shared.entry(512, 1024, 7, 0);
      std::call_once(e->built, [&] {
        ++builds;
        e->it = std::make_unique<Interpolant>();
      });
      seen[static_cast<size_t>(t)] = e->it.get();
    });
  for (auto& th : threads) th.join();
  EXPECT_EQ(builds.load(), 1);
  for (const Interpolant* it : seen) EXPECT_EQ(it, seen[0]);
  // Another block, site or kind is another entry; dropped rows are forgotten.
  EXPECT_NE(shared.entry(512, 1024, 7, 1), shared.entry(512, 1024, 7, 0));
  EXPECT_NE(shared.entry(0, 1024, 7, 0), shared.entry(512, 1024, 7, 0));
  const auto kept = shared.entry(512, 1024, 7, 0);
  shared.drop_rows_before(1025);
  EXPECT_NE(shared.entry(512, 1024, 7, 0), kept);
}

// The values the solver takes from its interpolants, against the exact geodesic distance (the
// per-cell method's brute force) at every cell of a geographic grid around 55N: basepoints and
// a coastline of long and short edges.
TEST(GeodesicInterpolant, TheSolversValuesAreWithinTheirAccuracy) {
  SeedSet seeds;
  const int32_t a = seeds.add_feature(seeds.owner_code("A"));
  seeds.add_point(a, {12.31, 55.02});
  seeds.add_point(a, {12.95, 55.33});
  const int32_t b = seeds.add_feature(seeds.owner_code("B"));
  const std::vector<Vec2> coast{{12.1, 54.7}, {12.5, 54.82}, {12.52, 54.83}, {12.9, 54.75}, {13.2, 54.9}};
  seeds.add_polyline(b, coast);
  const GridSpec g = test::grid_of(600, 400, 0.002, 12.0, 55.5);
  MetricSpec m;
  m.kind = MetricSpec::geodesic;
  const GeoSites geo(m, seeds);
  const std::vector<LocalSite> local;  // (the scans' seeding; not the exact method's)
  const std::vector<int32_t> geometric = geometric_sites(seeds);
  Progress progress(nullptr, nullptr, g.cell_count());
  EngineContext ctx{seeds,     g,   g.full_window(), local, geometric, std::numeric_limits<double>::infinity(), 1,
                    &progress, &geo};
  Raster<int32_t> site(g);
  Raster<float> distance(g);
  const GeodesicExactSolver solver(ctx, site, distance);
  GeoWorker wk;
  double worst_point = 0.0, worst_additive = 0.0;
  int64_t point_values = 0, additive_values = 0;
  constexpr int64_t kTileCells = GeodesicExactSolver::kTile;
  for (int64_t tr = 0; tr < g.height; tr += kTileCells)
    for (int64_t tc = 0; tc < g.width; tc += kTileCells) {
      wk.cache.clear();
      wk.held.clear();
      for (int64_t r = tr; r < std::min(tr + kTileCells, g.height); r += 3)
        for (int64_t c = tc; c < std::min(tc + kTileCells, g.width); c += 3) {
          const GeoCell p = geo.cell(g.centre_x(c), g.centre_y(r));
          for (int32_t id : geometric) {
            bool exact = false, additive = false;
            const double v = solver.value_at(wk, c, r, id, exact, &additive);
            const double d = geo.distance(p, id);
            if (exact) {
              ASSERT_EQ(v, d);
            } else if (additive) {
              worst_additive = std::max(worst_additive, std::abs(v - d));
              ++additive_values;
            } else {
              worst_point = std::max(worst_point, std::abs(v - d));
              ++point_values;
            }
          }
        }
    }
  char text[64];
  std::snprintf(text, sizeof(text), "%.3g", worst_point);
  RecordProperty("worst_point_form_error_m", text);
  std::snprintf(text, sizeof(text), "%.3g", worst_additive);
  RecordProperty("worst_additive_form_error_m", text);
  // Both forms served most values; each is within twice its block's accepted centre error,
  // thousands of times inside the band of close calls decided exactly.
  EXPECT_GT(point_values, 50000);
  EXPECT_GT(additive_values, 10000);
  EXPECT_LE(worst_point, 2.0 * kInterpCheck);
  EXPECT_LE(worst_additive, 2.0 * kInterpCheckAdditive);
  EXPECT_LT(std::max(worst_point, worst_additive), kInterpTie / 10.0);
}

}  // namespace
}  // namespace rv::detail
