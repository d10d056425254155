#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "engine/bucket_index.hpp"
#include "rv/engine/engine.hpp"
#include "rv/engine/outputs.hpp"
#include "rv/engine/validate.hpp"
#include "rv/field/error.hpp"
#include "seed_gen.hpp"
#include "window_check.hpp"

namespace rv {
namespace {

NearestField run(const SeedSet& s, const GridSpec& g, Method m, int threads = 2,
                 double max_distance = std::numeric_limits<double>::infinity()) {
  ComputeOptions o;
  o.method = m;
  o.threads = threads;
  o.max_distance = max_distance;
  return compute(s, g, o);
}

GridSpec grid(int64_t w, int64_t h, double res = 1.0, double xmin = 0.0, double ymax = 0.0) {
  GridSpec g;
  g.xmin = xmin;
  g.ymax = ymax == 0.0 ? static_cast<double>(h) * res : ymax;
  g.res = res;
  g.width = w;
  g.height = h;
  return g;
}

// The exact engine skips the duplicate check for entries not marked `shared`: a range query must
// meet such an entry exactly once, and a point's entry must carry the point's own coordinates.
TEST(BucketIndex, EntriesCarryTheirSitesAndOnlySharedOnesRepeat) {
  std::vector<LocalSite> local;
  auto point = [&](double x, double y) { local.push_back(LocalSite{x, y, 0.0, 0.0, 0.0}); };
  auto segment = [&](double ax, double ay, double bx, double by) {
    const double dx = bx - ax, dy = by - ay;
    local.push_back(LocalSite{ax, ay, dx, dy, 1.0 / (dx * dx + dy * dy)});
  };
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 100.0);
  for (int i = 0; i < 200; ++i) point(u(rng), -u(rng));
  segment(0.0, -50.0, 100.0, -50.0);   // horizontal, across every bucket column
  segment(10.0, -90.0, 90.0, -10.0);   // diagonal
  segment(40.0, -40.0, 40.5, -40.25);  // short: may stay in one bucket
  point(100.0, -100.0);                // on the extent's corner
  std::vector<int32_t> ids(local.size());
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<int32_t>(i);
  const detail::BucketIndex index(local, ids);

  std::vector<int> seen(local.size(), 0);
  std::vector<bool> shared(local.size(), false);
  index.for_range(0, 0, 1 << 20, 1 << 20, [&](const detail::BucketIndex::Entry& e) {
    ASSERT_GE(e.id, 0);
    ASSERT_LT(e.id, static_cast<int32_t>(local.size()));
    const LocalSite& s = local[static_cast<size_t>(e.id)];
    EXPECT_EQ(e.point, s.inv_len2 == 0.0);
    if (e.point) {
      EXPECT_EQ(e.ax, s.ax);
      EXPECT_EQ(e.ay, s.ay);
    }
    ++seen[static_cast<size_t>(e.id)];
    shared[static_cast<size_t>(e.id)] = e.shared;
  });
  for (size_t i = 0; i < local.size(); ++i) {
    ASSERT_GE(seen[i], 1) << "site " << i;
    EXPECT_EQ(shared[i], seen[i] > 1) << "site " << i;
    if (local[i].inv_len2 == 0.0) {
      EXPECT_EQ(seen[i], 1) << "point " << i;
    }
  }
  EXPECT_TRUE(shared[200]);  // the horizontal segment crosses several buckets
  EXPECT_TRUE(shared[201]);
}

TEST(Engine, ExactMatchesBruteForceOnRandomPoints) {
  for (uint32_t trial = 0; trial < 40; ++trial) {
    std::mt19937 rng(trial);
    const int w = 20 + static_cast<int>(rng() % 120), h = 20 + static_cast<int>(rng() % 120);
    const int n = 1 + static_cast<int>(rng() % 200);
    const GridSpec g = grid(w, h, 1.0 + (trial % 3));
    // Seeds somewhat beyond the grid too.
    SeedSet s = test::random_points(n, g.xmin - 10, g.ymin() - 10, g.xmax() + 10, g.ymax + 10, trial);
    const NearestField exact = run(s, g, Method::exact);
    const NearestField brute = run(s, g, Method::brute_force);
    EXPECT_EQ(exact.site.cells(), brute.site.cells()) << "trial " << trial;
    EXPECT_EQ(exact.distance.cells(), brute.distance.cells()) << "trial " << trial;
  }
}

// Points on a half-cell lattice, duplicates included: many cell centres are exactly equidistant
// from two or more points (ties the lower index must win), and many blocks have points equally
// near at some corners, which is where the dominance test's margin decides. Grids of several
// 64x64 tiles, so the point-only path runs its tile, quadrant and leaf culls; with and without a
// distance limit; on a UTM-like origin too, where the keys' rounding is largest.
TEST(Engine, ExactMatchesBruteForceOnLatticePointsWithTies) {
  for (uint32_t trial = 0; trial < 12; ++trial) {
    std::mt19937 rng(500 + trial);
    const int w = 130 + static_cast<int>(rng() % 90), h = 130 + static_cast<int>(rng() % 90);
    const bool utm = trial % 3 == 2;
    const GridSpec g = grid(w, h, 1.0, utm ? 500000.0 : 0.0, utm ? 6000000.0 : 0.0);
    const int n = 20 + static_cast<int>(rng() % 300);
    SeedSet s;
    for (int i = 0; i < n; ++i) {
      const double x = g.xmin + 0.5 * static_cast<double>(static_cast<int>(rng() % (2 * w + 20)) - 10);
      const double y = g.ymin() + 0.5 * static_cast<double>(static_cast<int>(rng() % (2 * h + 20)) - 10);
      s.add_point(s.add_feature(s.owner_code("p" + std::to_string(i % 7))), {x, y});
    }
    const double limit = trial % 2 == 0 ? std::numeric_limits<double>::infinity() : 9.0;
    const NearestField exact = run(s, g, Method::exact, 2, limit);
    const NearestField brute = run(s, g, Method::brute_force, 2, limit);
    EXPECT_EQ(exact.site.cells(), brute.site.cells()) << "trial " << trial;
    EXPECT_EQ(exact.distance.cells(), brute.distance.cells()) << "trial " << trial;
  }
}

TEST(Engine, HvScanErrorBelowOneCellAndHScanMeasured) {
  int h_trials_over_one = 0;
  double worst_hv = 0.0;
  for (uint32_t trial = 0; trial < 30; ++trial) {
    const GridSpec g = grid(100, 100);
    SeedSet s = test::random_points(20, 0.0, 0.0, 100.0, 100.0, 1000 + trial);
    const NearestField brute = run(s, g, Method::brute_force);
    const ValidationStats hv = compare_fields(s, run(s, g, Method::hv_scan), brute);
    const ValidationStats hs = compare_fields(s, run(s, g, Method::h_scan), brute);
    EXPECT_LT(hv.max_error_cells, 1.0) << "trial " << trial;
    EXPECT_EQ(hv.nodata_mismatch, 0);
    worst_hv = std::max(worst_hv, hv.max_error_cells);
    if (hs.max_error_cells > 1.0) ++h_trials_over_one;
  }
  RecordProperty("hv_worst_error_cells", std::to_string(worst_hv));
  RecordProperty("h_trials_over_one_cell", h_trials_over_one);
}

// Each method computes the same owners and distances on 1, 2 and 7 threads.
void expect_same_for_any_thread_count(const SeedSet& s, const GridSpec& g, std::initializer_list<Method> methods) {
  for (Method m : methods) {
    const NearestField one = run(s, g, m, 1);
    for (int t : {2, 7}) {
      const NearestField many = run(s, g, m, t);
      EXPECT_EQ(one.site.cells(), many.site.cells()) << to_string(m) << " threads " << t;
      EXPECT_EQ(one.distance.cells(), many.distance.cells()) << to_string(m) << " threads " << t;
    }
  }
}

TEST(Engine, IdenticalForAnyThreadCount) {
  const GridSpec g = grid(173, 129, 0.5);
  SeedSet s = test::random_points(300, -5, -5, 90, 70, 7);
  expect_same_for_any_thread_count(s, g, {Method::exact, Method::hv_scan, Method::h_scan});
}

TEST(Engine, TiesGoToLowerSeedIndex) {
  // Two seeds mirrored about the column of centres x = 5.5: that column is a tie.
  const GridSpec g = grid(11, 5);
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("b")), {8.5, 2.5});
  s.add_point(s.add_feature(s.owner_code("a")), {2.5, 2.5});
  for (Method m : {Method::exact, Method::hv_scan, Method::h_scan, Method::brute_force}) {
    const NearestField f = run(s, g, m);
    for (int64_t r = 0; r < 5; ++r) {
      EXPECT_EQ(f.site.at(5, r), 0) << to_string(m);  // the tie column: lower index 0
      EXPECT_EQ(f.site.at(4, r), 1) << to_string(m);
      EXPECT_EQ(f.site.at(6, r), 0) << to_string(m);
    }
  }
}

TEST(Engine, SeedsOutsideTheGridAndSharingACell) {
  const GridSpec g = grid(40, 30);
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("far west")), {-3.0, 25.0});
  s.add_point(s.add_feature(s.owner_code("north")), {30.0, 34.0});
  s.add_point(s.add_feature(s.owner_code("in1")), {10.2, 10.2});
  s.add_point(s.add_feature(s.owner_code("in2")), {10.7, 10.4});  // same cell as in1
  s.add_point(s.add_feature(s.owner_code("east")), {45.0, 5.0});
  const NearestField brute = run(s, g, Method::brute_force);
  EXPECT_EQ(run(s, g, Method::exact).site.cells(), brute.site.cells());
  const ValidationStats hv = compare_fields(s, run(s, g, Method::hv_scan), brute);
  EXPECT_LT(hv.max_error_cells, 1.0);
  // Every seed owns something: the far ones enter through the border.
  std::vector<int> owned(5, 0);
  for (int32_t id : brute.site.cells()) ++owned[id];
  for (int i = 0; i < 5; ++i) EXPECT_GT(owned[i], 0) << i;
}

TEST(Engine, OneSeed) {
  const GridSpec g = grid(17, 9, 2.0);
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("only")), {3.0, 4.0});
  for (Method m : {Method::exact, Method::hv_scan, Method::h_scan, Method::brute_force}) {
    const NearestField f = run(s, g, m);
    for (int32_t id : f.site.cells()) EXPECT_EQ(id, 0);
    // Distance at cell (0, 0): centre (1, 17).
    EXPECT_FLOAT_EQ(f.distance.at(0, 0), static_cast<float>(std::hypot(1.0 - 3.0, 17.0 - 4.0)));
  }
}

TEST(Engine, MaxDistanceLeavesFarCellsWithoutOwner) {
  const GridSpec g = grid(50, 50);
  SeedSet s = test::random_points(3, 10, 10, 40, 40, 5);
  for (Method m : {Method::exact, Method::hv_scan, Method::brute_force}) {
    const NearestField f = run(s, g, m, 2, 6.0);
    int64_t none = 0;
    for (size_t i = 0; i < f.site.size(); ++i) {
      if (f.site.cells()[i] == kNoSite) {
        ++none;
        EXPECT_EQ(f.distance.cells()[i], kNoDistance);
      } else {
        EXPECT_LE(f.distance.cells()[i], 6.0f);
      }
    }
    EXPECT_GT(none, 1000) << to_string(m);
  }
  EXPECT_EQ(run(s, g, Method::exact, 2, 6.0).site.cells(), run(s, g, Method::brute_force, 2, 6.0).site.cells());
}

// The owner codes written over the field's site raster equal those made beside it, unowned cells
// (a max distance) included, for any thread count.
TEST(Engine, OwnerCodesInPlaceEqualACopy) {
  const GridSpec g = grid(61, 47);
  SeedSet s = test::random_points(30, 0, 0, 61, 47, 9);
  const NearestField f = run(s, g, Method::exact, 2, 9.0);
  const Raster<int32_t> beside = owner_raster(s, f, 1);
  for (int threads : {1, 3}) {
    Raster<int32_t> sites = f.site;
    const Raster<int32_t> in_place = owner_raster(s, std::move(sites), threads);
    EXPECT_EQ(in_place.cells(), beside.cells());
    EXPECT_EQ(in_place.window(), beside.window());
  }
  EXPECT_TRUE(std::count(beside.cells().begin(), beside.cells().end(), 0) > 0);
  EXPECT_TRUE(std::count(beside.cells().begin(), beside.cells().end(), 2) > 0);
}

TEST(Engine, LargeCoordinatesKeepPrecision) {
  // A UTM-like grid: northings of 6e6 m, 0.1 m cells. Seeds 0.01 m apart must be told apart.
  const GridSpec g = grid(64, 64, 0.1, 500000.0, 6000000.0);
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("a")), {500003.20, 5999996.80});
  s.add_point(s.add_feature(s.owner_code("b")), {500003.21, 5999996.80});
  const NearestField f = run(s, g, Method::exact);
  EXPECT_EQ(f.site.cells(), run(s, g, Method::brute_force).site.cells());
  // The bisector x = 500003.205 splits columns: col 32 has centre 500003.25 -> b; col 31 -> a.
  EXPECT_EQ(f.site.at(31, 10), 0);
  EXPECT_EQ(f.site.at(32, 10), 1);
  // Distance at cell (32, 32): centre (500003.25, 5999996.75); to b: hypot(0.04, 0.05).
  EXPECT_NEAR(f.distance.at(32, 32), std::hypot(0.04, 0.05), 1e-7);
}

TEST(Engine, LinesAndPolygonsExactMatchesBruteForce) {
  for (uint32_t trial = 0; trial < 15; ++trial) {
    std::mt19937_64 rng(trial);
    std::uniform_real_distribution<double> u(-10.0, 110.0);
    SeedSet s;
    for (int f = 0; f < 12; ++f) {
      const int32_t id = s.add_feature(s.owner_code(std::to_string(f % 4)));
      std::vector<Vec2> pts;
      const int k = 2 + static_cast<int>(rng() % 5);
      const Vec2 c{u(rng), u(rng)};
      for (int i = 0; i < k; ++i) pts.push_back({c.x + u(rng) / 8, c.y + u(rng) / 8});
      if (f % 3 == 0) {
        s.add_point(id, c);
      } else if (f % 3 == 1) {
        s.add_polyline(id, pts);
      } else {
        pts.push_back({c.x + 12, c.y});
        s.add_polygon(id, {pts});
      }
    }
    const GridSpec g = grid(100, 100, 1.0);
    const NearestField brute = run(s, g, Method::brute_force);
    const NearestField exact = run(s, g, Method::exact);
    EXPECT_EQ(exact.site.cells(), brute.site.cells()) << trial;
    EXPECT_EQ(exact.distance.cells(), brute.distance.cells()) << trial;
    const ValidationStats hv = compare_fields(s, run(s, g, Method::hv_scan), brute);
    RecordProperty("hv_lines_max_error_cells_" + std::to_string(trial), std::to_string(hv.max_error_cells));
  }
}

TEST(Engine, ThinDiagonalLineSeedsEveryCellItCrosses) {
  // A single long diagonal line and a point: the scans must not lose the line.
  const GridSpec g = grid(64, 64);
  SeedSet s;
  const std::vector<Vec2> line{{0.3, 0.1}, {63.9, 63.7}};
  s.add_polyline(s.add_feature(s.owner_code("line")), line);
  s.add_point(s.add_feature(s.owner_code("pt")), {50.0, 10.0});
  const NearestField brute = run(s, g, Method::brute_force);
  for (Method m : {Method::exact, Method::hv_scan}) {
    const ValidationStats v = compare_fields(s, run(s, g, m), brute);
    EXPECT_EQ(v.wrong_cells, 0) << to_string(m);
  }
}

TEST(Engine, PolygonInteriorsAreOwnedAtDistanceZero) {
  const GridSpec g = grid(30, 30);
  SeedSet s;
  // A square 5..15 x 5..15 with a hole 8..12 x 8..12, and a point seed inside the hole.
  s.add_polygon(s.add_feature(s.owner_code("land")),
                {{{5, 5}, {15, 5}, {15, 15}, {5, 15}}, {{8, 8}, {12, 8}, {12, 12}, {8, 12}}});
  s.add_point(s.add_feature(s.owner_code("rock")), {10.0, 10.0});
  const NearestField f = run(s, g, Method::exact);
  // Cell (6, 23): centre (6.5, 6.5) inside the ring, outside the hole.
  EXPECT_EQ(s.site_feature(f.site.at(6, 23)), 0);
  EXPECT_EQ(f.distance.at(6, 23), 0.0f);
  // Cell (10, 19): centre (10.5, 10.5) in the hole: nearest is the rock at 0.707, not the land.
  EXPECT_EQ(s.site_feature(f.site.at(10, 19)), 1);
  EXPECT_NEAR(f.distance.at(10, 19), std::sqrt(0.5), 1e-6);
  // Cell (20, 10): centre (20.5, 19.5), outside: distance to the boundary corner (15, 15).
  EXPECT_NEAR(f.distance.at(20, 10), std::hypot(5.5, 4.5), 1e-5);
  EXPECT_EQ(f.site.cells(), run(s, g, Method::brute_force).site.cells());
}

// Interior cells are given their area site by a pass over rows split between threads. Two
// overlapping polygons over many row blocks, a line inside one of them through cell centres
// (added first: a lower site at distance exactly 0, which keeps its cells), a point outside.
TEST(Engine, PolygonInteriorsIdenticalForAnyThreadCountAndTieRule) {
  const GridSpec g = grid(150, 300);
  SeedSet s;
  // Row 100's centres are at y = 199.5; the line runs along it from x = 30 to x = 90.
  const std::vector<Vec2> road{{30.0, 199.5}, {90.0, 199.5}};
  s.add_polyline(s.add_feature(s.owner_code("road")), road);
  s.add_polygon(s.add_feature(s.owner_code("a")), {{{10, 10}, {100, 10}, {100, 250}, {10, 250}}});
  s.add_polygon(s.add_feature(s.owner_code("b")), {{{60, 40}, {140, 40}, {140, 290}, {60, 290}}});
  s.add_point(s.add_feature(s.owner_code("rock")), {5.0, 295.0});
  const NearestField brute = run(s, g, Method::brute_force, 1);
  expect_same_for_any_thread_count(s, g, {Method::exact, Method::hv_scan, Method::brute_force});
  const NearestField exact = run(s, g, Method::exact, 7);
  EXPECT_EQ(exact.site.cells(), brute.site.cells());
  EXPECT_EQ(exact.distance.cells(), brute.distance.cells());
  // (column, row) -> centre (c + 0.5, 299.5 - r).
  EXPECT_EQ(s.site_feature(exact.site.at(50, 100)), 0);  // on the line, inside a: the line
  EXPECT_EQ(exact.distance.at(50, 100), 0.0f);
  EXPECT_EQ(s.site_feature(exact.site.at(50, 101)), 1);  // a cell below the line: a
  EXPECT_EQ(exact.distance.at(50, 101), 0.0f);
  EXPECT_EQ(s.site_feature(exact.site.at(80, 150)), 1);  // in a and b: the lower polygon
  EXPECT_EQ(s.site_feature(exact.site.at(120, 20)), 2);  // in b only
  EXPECT_EQ(exact.distance.at(120, 20), 0.0f);
  EXPECT_EQ(s.site_feature(exact.site.at(2, 2)), 3);  // outside: the rock
  EXPECT_GT(exact.distance.at(2, 2), 0.0f);
}

TEST(Engine, WindowsAgreeWithTheWholeGrid) {
  const GridSpec g = grid(200, 150);
  SeedSet s = test::random_points(500, -20, -20, 220, 170, 3);
  const NearestField whole = run(s, g, Method::exact);
  ComputeOptions o;
  o.window = Window{37, 61, 90, 50};
  EXPECT_TRUE(test::window_matches(compute(s, g, o), whole));
}

// More than 4 MiB of results (site ids and distances): the exact method writes such windows with
// non-temporal stores. An odd width puts rows at every alignment, so the unaligned head and tail
// of each row's store are exercised as well as the aligned body; a window from an odd column
// and a distance limit take the other paths through the same stores.
TEST(Engine, LargeWindowsMatchBruteForceThroughTheStreamingStores) {
  const GridSpec g = grid(1023, 601, 2.0, 1000.0, 5000.0);
  SeedSet s = test::random_points(150, g.xmin - 50, g.ymin() - 50, g.xmax() + 50, g.ymax + 50, 77);
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> ux(g.xmin, g.xmax()), uy(g.ymin(), g.ymax);
  for (int f = 0; f < 6; ++f) {
    std::vector<Vec2> line;
    for (int i = 0; i < 4; ++i) line.push_back({ux(rng), uy(rng)});
    s.add_polyline(s.add_feature(s.owner_code("line" + std::to_string(f))), line);
  }
  ASSERT_GT(g.width * g.height * 8, int64_t{4} << 20);
  const NearestField brute = run(s, g, Method::brute_force);
  const NearestField exact = run(s, g, Method::exact);
  EXPECT_EQ(exact.site.cells(), brute.site.cells());
  EXPECT_EQ(exact.distance.cells(), brute.distance.cells());

  ComputeOptions o;
  o.window = Window{3, 1, 1019, 597};
  o.max_distance = 40.0;
  const NearestField part = compute(s, g, o);
  EXPECT_TRUE(test::window_matches(part, run(s, g, Method::brute_force, 2, 40.0)));
  // The limit leaves some cells without an owner.
  EXPECT_GT(std::count(part.site.cells().begin(), part.site.cells().end(), kNoSite), 0);
}

// prepare() once, then any window from it: the cells equal the whole grid's; a preparation for
// another seed set, grid or metric is refused, not silently used.
TEST(Engine, PreparedSeedsServeEveryWindowOfTheirGridOnly) {
  const GridSpec g = grid(300, 200);
  SeedSet s = test::random_points(400, -20, -20, 320, 220, 5);
  const NearestField whole = run(s, g, Method::exact);
  ComputeOptions o;
  o.threads = 2;
  o.prepared = prepare(s, g, o);
  NearestField strip;
  for (int64_t row0 = 0; row0 < g.height; row0 += 37) {
    o.window = Window{0, row0, g.width, std::min<int64_t>(37, g.height - row0)};
    compute_into(s, g, o, strip);
    EXPECT_TRUE(test::window_matches(strip, whole)) << "strip at row " << row0;
  }
  // Brute force with a preparation made for the exact method (no index needed): same cells.
  o.window.reset();
  o.method = Method::brute_force;
  EXPECT_EQ(compute(s, g, o).site.cells(), whole.site.cells());

  auto refused = [](const SeedSet& seeds, const GridSpec& gs, const ComputeOptions& opt) {
    try {
      compute(seeds, gs, opt);
    } catch (const Error& e) {
      return e.kind() == ErrorKind::invalid_argument;
    }
    return false;
  };
  o.method = Method::exact;
  const SeedSet copy = s;
  EXPECT_TRUE(refused(copy, g, o));            // another seed set object
  EXPECT_TRUE(refused(s, grid(300, 201), o));  // another grid

  // Geodesic: the prepared sites (with their geodesic preparation) serve a window too.
  const GridSpec lonlat = grid(40, 30, 0.05, 10.0, 56.0);
  const SeedSet near_sea = test::random_points(30, 9.9, 54.4, 12.1, 56.1, 6);
  ComputeOptions geo;
  geo.metric.kind = MetricSpec::geodesic;
  const NearestField geo_whole = compute(near_sea, lonlat, geo);
  geo.prepared = prepare(near_sea, lonlat, geo);
  geo.window = Window{5, 7, 30, 20};
  EXPECT_TRUE(test::window_matches(compute(near_sea, lonlat, geo), geo_whole));
  ComputeOptions other_ellipsoid = geo;
  other_ellipsoid.metric.semi_major = 6378000.0;
  EXPECT_TRUE(refused(near_sea, lonlat, other_ellipsoid));  // another metric
  SeedSet more = s;
  ComputeOptions for_more = o;
  for_more.prepared = prepare(more, g, o);
  more.add_point(more.add_feature(more.owner_code("late")), {5.0, 5.0});
  EXPECT_TRUE(refused(more, g, for_more));  // the seed set changed size after prepare()
}

TEST(Engine, BadInputIsRejectedWithAClearError) {
  SeedSet empty;
  EXPECT_THROW(run(empty, grid(5, 5), Method::exact), Error);
  SeedSet s = test::random_points(2, 0, 0, 5, 5, 1);
  GridSpec bad = grid(5, 5);
  bad.res = -1;
  EXPECT_THROW(run(s, bad, Method::exact), Error);
  EXPECT_THROW(run(s, grid(5, 5), Method::exact, 1, -3.0), Error);
  ComputeOptions o;
  o.window = Window{3, 3, 5, 5};
  EXPECT_THROW(compute(s, grid(5, 5), o), Error);
  SeedSet nan;
  const int32_t f = nan.add_feature(nan.owner_code("x"));
  try {
    nan.add_point(f, {std::nan(""), 1.0});
    FAIL() << "NaN accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::invalid_input);
  }
  EXPECT_EQ(parse_method("hv_scan"), Method::hv_scan);
  EXPECT_THROW(parse_method("magic"), Error);
}

TEST(Engine, CancellationStopsTheComputation) {
  SeedSet s = test::random_points(50, 0, 0, 300, 300, 9);
  std::atomic<bool> cancel{true};
  for (Method m : {Method::exact, Method::hv_scan, Method::brute_force}) {
    ComputeOptions o;
    o.method = m;
    o.cancel = &cancel;
    try {
      compute(s, grid(300, 300), o);
      FAIL() << "not cancelled";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::cancelled);
    }
  }
}

}  // namespace
}  // namespace rv
