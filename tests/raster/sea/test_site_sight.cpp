// Which cells see their straight nearest site, drawn from the sites' visible regions
// (raster/src/sea_map/site_sight.hpp), against Visibility::sees() from every sea cell's centre as
// Prepared::row_cells() holds it, cell for cell: random archipelagos whose whole-number corners
// fall on cell centres (sight lines grazing corners, ports on coasts), in the plane and on the
// ellipsoid, over whole grids and offset windows. Every cell the drawing decides must agree, and
// it must decide nearly all of them.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <random>
#include <vector>

#include "geodesic_oracle.hpp"
#include "lattice_grids.hpp"
#include "random_archipelago.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "sea/sea_prepare.hpp"
#include "sea/visible_region.hpp"
#include "sea_map/site_sight.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

using sea::SiteSight;

struct Counts {
  int64_t layouts = 0, cells = 0, seen = 0, hidden = 0, unknown = 0, regions = 0, undrawn = 0;
  void print(const char* what) const {
    std::printf(
        "%s: %lld layouts, %lld regions (%lld undrawn); %lld sea cells with a point site: %lld seen, %lld "
        "hidden, %lld unknown\n",
        what, static_cast<long long>(layouts), static_cast<long long>(regions), static_cast<long long>(undrawn),
        static_cast<long long>(cells), static_cast<long long>(seen), static_cast<long long>(hidden),
        static_cast<long long>(unknown));
  }
};

void check_window(const sea::Prepared& p, const SeedSet& seeds, const MetricSpec& metric, const GridSpec& grid,
                  const Window& window, Counts& counts) {
  ComputeOptions o;
  o.metric = metric;
  o.window = window;
  o.threads = 1;
  const NearestField straight = compute(seeds, grid, o);
  const std::vector<sea::EdgeIndex::Segment> edges = sea::barrier_edges(p.vis);
  const sea::EdgeIndex index(edges, {});
  const SiteSight sight(p, metric, grid, window, straight.site, edges, index);
  const SiteSight on_two(p, metric, grid, window, straight.site, edges, index, 2);  // the same on two threads
  counts.regions += sight.regions();
  counts.undrawn += sight.undrawn();
  EXPECT_EQ(on_two.regions(), sight.regions());
  std::vector<SiteSight::Sight> row(static_cast<size_t>(window.width)), row_two(row.size());
  std::vector<sea::Spot> spots;
  for (int64_t r = 0; r < window.height; ++r) {
    sight.row(r, row.data());
    on_two.row(r, row_two.data());
    ASSERT_EQ(row, row_two) << "row " << r;
    p.row_cells(grid, window, r, spots);
    for (int64_t c = 0; c < window.width; ++c) {
      const int32_t site = straight.site.at(c, r);
      const SiteSight::Sight drawn = row[static_cast<size_t>(c)];
      if (site == kNoSite || p.segment(site)) {
        ASSERT_EQ(drawn, SiteSight::unknown) << r << " " << c;
        continue;
      }
      const sea::Spot& spot = spots[static_cast<size_t>(c)];
      const Visibility::Ground ground = p.vis.classify(spot.at);
      if (ground == Visibility::Ground::land) continue;
      ++counts.cells;
      if (drawn == SiteSight::unknown) {
        ++counts.unknown;
        continue;
      }
      Visibility::Place at{spot.at};
      at.open = ground == Visibility::Ground::open_sea;
      const bool sees = p.vis.sees(at, p.site_place(site, spot));
      ASSERT_EQ(drawn == SiteSight::seen, sees)
          << "row " << r << " col " << c << " of window (" << window.col0 << ", " << window.row0 << "), site " << site
          << ", at (" << spot.at.x << ", " << spot.at.y << ")";
      (sees ? counts.seen : counts.hidden) += 1;
    }
  }
}

void check_layout(const test::Archipelago& layout, const MetricSpec& metric, const GridSpec& grid, Counts& counts) {
  std::optional<sea::Prepared> p;
  try {
    p.emplace(sea::prepare(layout.seeds, layout.barriers, grid, metric));
  } catch (const Error& e) {  // a port on land
    ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
    return;
  }
  ++counts.layouts;
  check_window(*p, layout.seeds, metric, grid, grid.full_window(), counts);
  if (testing::Test::HasFatalFailure()) return;
  check_window(
      *p, layout.seeds, metric, grid,
      Window{grid.width / 10 + 7, grid.height / 10 + 3, grid.width - grid.width / 4, grid.height - grid.height / 4},
      counts);
  if (testing::Test::HasFatalFailure()) return;
  // A strip of five rows, as the streamed jobs compute.
  check_window(*p, layout.seeds, metric, grid, Window{0, grid.height / 2, grid.width, 5}, counts);
}

// Every layout of `rounds` from `seed` on `grid` (mapped by `to`).
void check_layouts(const MetricSpec& metric, const GridSpec& grid, int rounds, uint64_t seed,
                   const std::function<Vec2(Vec2)>& to, int at_least, const char* what) {
  Counts counts;
  for (int round = 0; round < rounds; ++round) {
    std::mt19937_64 rng(seed + static_cast<uint64_t>(round));
    check_layout(test::random_archipelago(rng, round, to), metric, grid, counts);
    if (testing::Test::HasFatalFailure()) return;
  }
  counts.print(what);
  EXPECT_GE(counts.layouts, at_least);
  EXPECT_GT(counts.seen, 100000);
  EXPECT_GT(counts.hidden, 20000);
  EXPECT_LT(counts.unknown, counts.cells / 50);
}

TEST(SiteSight, AgreesWithSeesAtEveryDecidedCellPlanar) {
  check_layouts(
      MetricSpec{}, test::planar_lattice_grid(), 16, 7600, [](Vec2 v) { return v; }, 8, "planar");
}

TEST(SiteSight, AgreesWithSeesAtEveryDecidedCellOnTheEllipsoid) {
  check_layouts(test::geodesic_metric(), test::ellipsoid_lattice_grid(), 6, 7700, test::lattice_ll, 3, "ellipsoid");
}

TEST(SiteSight, LeavesCellsOnGrazingRaysToTheExactRule) {
  // Ports and corners on whole numbers, cell centres on every quarter: the rays from a port past
  // an island's corners run through cell centres (from (0, 0) past (3, 1): (4.5, 1.5), (6, 2),
  // ...), which the floating-point ring cannot place on either side; they must be left unknown
  // and every other cell agree.
  const GridSpec grid = test::grid_of(96, 96, 0.25, -2.125, 21.875);
  test::Archipelago layout;
  layout.barriers.add_polygon({{{3, 1}, {4, 1}, {4, 2}, {3, 2}}}, "square");
  layout.barriers.add_polygon({{{6, 6}, {9, 7}, {7, 9}}}, "triangle");
  layout.barriers.add_polygon({{{1, 12}, {5, 12}, {5, 14}, {1, 14}}}, "slab");
  for (const Vec2 at : {Vec2{0, 0}, Vec2{12, 3}, Vec2{0, 18}, Vec2{14, 14}})
    layout.seeds.add_point(layout.seeds.add_feature(layout.seeds.owner_code("A")), at);
  Counts counts;
  check_layout(layout, MetricSpec{}, grid, counts);
  if (HasFatalFailure()) return;
  counts.print("grazing rays");
  EXPECT_EQ(counts.layouts, 1);
  EXPECT_GT(counts.unknown, 20);
  EXPECT_LT(counts.unknown, counts.cells / 25);  // (the strip's sites have too few cells to sweep)
}

}  // namespace
}  // namespace rv
