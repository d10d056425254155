// The ground drawn row by row (raster/src/sea_map/ground_rows.hpp) against Visibility::classify() at
// every cell's centre as Prepared::row_cells() holds it, cell for cell: random archipelagos whose
// whole-number corners fall on cell centres (cells on edges, at vertices, on a shared border,
// on the boom), in the plane and on the ellipsoid, over whole grids and offset windows; and a
// geodesic edge 6.5 degrees long along 53.8 N, which bulges 2.4 km north of the parallel: the
// cells between are land, as the exact predicates read the edge. Also Prepared::cell_spot()
// against row_cells(), to the bit.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <random>
#include <vector>

#include "geodesic_oracle.hpp"
#include "lattice_grids.hpp"
#include "random_archipelago.hpp"
#include "sea/sea_prepare.hpp"
#include "sea_map/ground_rows.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

using Ground = Visibility::Ground;
using sea::GroundRows;
using sea::Prepared;

struct Counts {
  int64_t cells = 0, land = 0, sea = 0, on_barrier = 0, exact = 0;
};

// One port where no layout has land (prepare() asks for a site).
SeedSet one_port(Vec2 at) {
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A")), at);
  return s;
}

// Every cell of `window`: drawn against classify(), and cell_spot() against row_cells().
void check_window(const Prepared& p, const MetricSpec& metric, const GridSpec& grid, const Window& window,
                  Counts& counts) {
  const GroundRows rows(p, metric, grid, window);
  ASSERT_TRUE(rows.drawn());
  std::vector<Ground> drawn(static_cast<size_t>(window.width));
  std::vector<sea::Spot> spots;
  for (int64_t r = 0; r < window.height; ++r) {
    counts.exact += rows.row(r, drawn.data());
    p.row_cells(grid, window, r, spots);
    for (int64_t c = 0; c < window.width; ++c) {
      const sea::Spot& s = spots[static_cast<size_t>(c)];
      const Ground want = p.vis.classify(s.at);
      ASSERT_EQ(static_cast<int>(drawn[static_cast<size_t>(c)]), static_cast<int>(want))
          << "row " << r << " col " << c << " of window (" << window.col0 << ", " << window.row0 << ") at (" << s.at.x
          << ", " << s.at.y << ")";
      ++counts.cells;
      counts.land += want == Ground::land;
      counts.sea += want == Ground::open_sea;
      counts.on_barrier += want == Ground::on_barrier;
      if (c % 37 == r % 37) {  // cell_spot() for a sample of cells, to the bit
        const sea::Spot alone = p.cell_spot(grid, window, r, c);
        ASSERT_EQ(std::bit_cast<uint64_t>(alone.at.x), std::bit_cast<uint64_t>(s.at.x)) << r << " " << c;
        ASSERT_EQ(std::bit_cast<uint64_t>(alone.at.y), std::bit_cast<uint64_t>(s.at.y)) << r << " " << c;
        ASSERT_EQ(alone.ll, s.ll);
      }
    }
  }
}

// The grid, the whole window, two offset ones and a strip.
void check_grid(const Prepared& p, const MetricSpec& metric, const GridSpec& grid, Counts& counts) {
  check_window(p, metric, grid, grid.full_window(), counts);
  if (testing::Test::HasFatalFailure()) return;
  check_window(
      p, metric, grid,
      Window{grid.width / 10 + 7, grid.height / 10 + 3, grid.width - grid.width / 4, grid.height - grid.height / 4},
      counts);
  if (testing::Test::HasFatalFailure()) return;
  check_window(p, metric, grid, Window{grid.width / 2, grid.height / 3, grid.width / 2, grid.height / 2}, counts);
  if (testing::Test::HasFatalFailure()) return;
  // A strip of three rows, as the streamed jobs compute: edges beyond it are left out.
  check_window(p, metric, grid, Window{0, grid.height / 2, grid.width, 3}, counts);
}

// Every layout of `rounds` from `seed` on `grid` (mapped by `to`), with one port at `port`.
Counts check_layouts(const MetricSpec& metric, const GridSpec& grid, int rounds, uint64_t seed, Vec2 port,
                     const std::function<Vec2(Vec2)>& to, const char* what) {
  Counts counts;
  for (int round = 0; round < rounds; ++round) {
    std::mt19937_64 rng(seed + static_cast<uint64_t>(round));
    const auto layout = test::random_archipelago(rng, round, to);
    const Prepared p = sea::prepare(one_port(port), layout.barriers, grid, metric);
    check_grid(p, metric, grid, counts);
    if (testing::Test::HasFatalFailure()) return counts;
  }
  std::printf("%s: %lld cells, %lld land, %lld open sea, %lld on a barrier, %lld classified exactly\n", what,
              static_cast<long long>(counts.cells), static_cast<long long>(counts.land),
              static_cast<long long>(counts.sea), static_cast<long long>(counts.on_barrier),
              static_cast<long long>(counts.exact));
  EXPECT_GT(counts.land, counts.cells / 25);
  EXPECT_GT(counts.sea, counts.cells / 4);
  EXPECT_LT(counts.exact, counts.cells / 20);
  return counts;
}

TEST(GroundRows, AreClassifysAtEveryCellPlanar) {
  // Corners, edges and the boom pass through cell centres.
  const Counts counts = check_layouts(
      MetricSpec{}, test::planar_lattice_grid(), 12, 7400, {-1.5, -1.5}, [](Vec2 v) { return v; }, "planar");
  EXPECT_GT(counts.on_barrier, 1000);
}

TEST(GroundRows, AreClassifysAtEveryCellOnTheEllipsoid) {
  const Counts counts = check_layouts(test::geodesic_metric(), test::ellipsoid_lattice_grid(), 5, 7500, {11.96, 54.995},
                                      test::lattice_ll, "ellipsoid");
  EXPECT_GT(counts.on_barrier, 20);
}

TEST(GroundRows, ReadALongEdgeAsItsGeodesic) {
  // Land south of the geodesic from (9.0 E, 53.8 N) to (15.5 E, 53.8 N): in the middle it runs
  // about 2.4 km north of the parallel, so the cells between are land.
  const MetricSpec metric = test::geodesic_metric();
  Barriers barriers;
  barriers.add_polygon({{{9.0, 53.8}, {9.0, 53.5}, {15.5, 53.5}, {15.5, 53.8}}}, "south");
  barriers.add_polygon({{{12.0, 53.83}, {12.01, 53.83}, {12.01, 53.835}}}, "islet");
  const GridSpec grid = test::grid_of(3300, 28, 0.002, 8.9, 53.848);
  const Prepared p = sea::prepare(one_port({12.0, 53.845}), barriers, grid, metric);
  Counts counts;
  check_grid(p, metric, grid, counts);
  if (HasFatalFailure()) return;
  const GroundRows rows(p, metric, grid, grid.full_window());
  EXPECT_GT(rows.piece_count(), 30);  // the long edges were cut
  std::vector<Ground> row(static_cast<size_t>(grid.width));
  // The row at 53.811 N: land in the middle (the geodesic above it), sea near the ends.
  const auto r = static_cast<int64_t>((grid.ymax - 53.811) / grid.res);
  EXPECT_NEAR(grid.centre_y(r), 53.811, 1e-9);
  rows.row(r, row.data());
  const auto at = [&](double lon) { return row[static_cast<size_t>((lon - grid.xmin) / grid.res)]; };
  EXPECT_EQ(at(12.251), Ground::land);
  EXPECT_EQ(at(9.101), Ground::open_sea);
  EXPECT_EQ(at(15.401), Ground::open_sea);
  std::printf("a long edge: %lld cells, %lld land, %lld classified exactly, %lld pieces\n",
              static_cast<long long>(counts.cells), static_cast<long long>(counts.land),
              static_cast<long long>(counts.exact), static_cast<long long>(rows.piece_count()));
}

}  // namespace
}  // namespace rv
