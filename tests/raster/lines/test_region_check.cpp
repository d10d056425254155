// The regions' faces against the cells (rv/lines/region_check.hpp): hand-made faces with known
// answers (two owners' halves, a lost change of owner, a face missing, a hole with another
// owner's island, an edge through centres, rows not fed), and random tilings of slanted
// triangles with some cells given another owner, against a brute force that tests every centre
// against every face (even-odd) and every edge (distance).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "deliverables_check.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/region_check.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

GridSpec grid(int64_t w, int64_t h) { return test::grid_of(w, h); }

OwnedFace box(int32_t owner, double x0, double y0, double x1, double y1) {
  return OwnedFace{owner, {{Vec2{x0, y0}, Vec2{x1, y0}, Vec2{x1, y1}, Vec2{x0, y1}, Vec2{x0, y0}}}};
}

// Every row fed, owner by `owner_of(col, row)`.
template <class F>
CellOwners cells(const GridSpec& g, F owner_of) {
  CellOwners c(g);
  std::vector<int32_t> row(static_cast<size_t>(g.width));
  for (int64_t r = 0; r < g.height; ++r) {
    for (int64_t col = 0; col < g.width; ++col) row[static_cast<size_t>(col)] = owner_of(col, r);
    c.add_row(r, row);
  }
  return c;
}

TEST(RegionCheck, TwoOwnersHalvesAgreeWithTheirCells) {
  const GridSpec g = grid(10, 10);
  const std::vector<OwnedFace> faces{box(1, 0, 0, 5, 10), box(2, 5, 0, 10, 10)};
  const RegionCellCheck c =
      check_regions_against_cells(faces, cells(g, [](int64_t col, int64_t) { return col < 5 ? 1 : 2; }), 0.1);
  EXPECT_EQ(c.rows, 10);
  EXPECT_EQ(c.checked, 100);
  EXPECT_EQ(c.near_edges, 0);
  EXPECT_EQ(c.misplaced, 0);
  EXPECT_TRUE(c.first.empty());
}

TEST(RegionCheck, CellsOfAnOwnerTheLinesMissAreFoundWhereTheyLie) {
  const GridSpec g = grid(10, 10);
  const std::vector<OwnedFace> faces{box(1, 0, 0, 5, 10), box(2, 5, 0, 10, 10)};
  // Owner 2 holds four cells of owner 1's face (columns 2-3, rows 6-7), and one unowned cell
  // there is no one's concern.
  const RegionCellCheck c = check_regions_against_cells(faces,
                                                        cells(g,
                                                              [](int64_t col, int64_t r) {
                                                                if (col == 0 && r == 0) return 0;
                                                                if (col >= 2 && col < 4 && r >= 6 && r < 8) return 2;
                                                                return col < 5 ? 1 : 2;
                                                              }),
                                                        0.1);
  EXPECT_EQ(c.checked, 99);
  EXPECT_EQ(c.misplaced, 4);
  ASSERT_EQ(c.first.size(), 4u);
  const int64_t want[4][2] = {{2, 6}, {3, 6}, {2, 7}, {3, 7}};
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(c.first[i].col, want[i][0]);
    EXPECT_EQ(c.first[i].row, want[i][1]);
    EXPECT_EQ(c.first[i].owner, 2);
    EXPECT_EQ(c.first[i].region, 1);
  }
}

TEST(RegionCheck, OwnedCellsInNoFaceOrANobodysFaceAreMisplaced) {
  const GridSpec g = grid(10, 4);
  // Columns 5-7 in a face of nobody's, columns 8-9 in none.
  const std::vector<OwnedFace> faces{box(1, 0, 0, 5, 4), box(0, 5, 0, 8, 4)};
  const RegionCellCheck c =
      check_regions_against_cells(faces, cells(g, [](int64_t col, int64_t) { return col < 5 ? 1 : 3; }), 0.1);
  EXPECT_EQ(c.misplaced, 20);
  ASSERT_EQ(c.first.size(), RegionCellCheck::kFirst);
  EXPECT_EQ(c.first[0].col, 5);
  EXPECT_EQ(c.first[0].region, 0);
  EXPECT_EQ(c.first[0].owner, 3);
  // Unowned cells in a nobody's face are in their place: nothing is checked there.
  const RegionCellCheck land =
      check_regions_against_cells(faces, cells(g, [](int64_t col, int64_t) { return col < 5 ? 1 : 0; }), 0.1);
  EXPECT_EQ(land.checked, 20);
  EXPECT_EQ(land.misplaced, 0);
}

TEST(RegionCheck, AnIslandFaceInsideAHoleKeepsItsOwnersCells) {
  const GridSpec g = grid(10, 10);
  OwnedFace outer = box(1, 0, 0, 10, 10);
  outer.rings.push_back({Vec2{3, 3}, Vec2{3, 7}, Vec2{7, 7}, Vec2{7, 3}, Vec2{3, 3}});
  const std::vector<OwnedFace> faces{outer, box(2, 3, 3, 7, 7)};
  auto inner = [](int64_t col, int64_t r) { return col >= 3 && col < 7 && r >= 3 && r < 7; };
  const RegionCellCheck c =
      check_regions_against_cells(faces, cells(g, [&](int64_t col, int64_t r) { return inner(col, r) ? 2 : 1; }), 0.1);
  EXPECT_EQ(c.checked, 100);
  EXPECT_EQ(c.misplaced, 0);
  // Without the island's face its cells lie in the hole: in no face.
  const std::vector<OwnedFace> holed{outer};
  const RegionCellCheck lost =
      check_regions_against_cells(holed, cells(g, [&](int64_t col, int64_t r) { return inner(col, r) ? 2 : 1; }), 0.1);
  EXPECT_EQ(lost.misplaced, 16);
  EXPECT_EQ(lost.first[0].region, 0);
}

TEST(RegionCheck, CentresWithinTheMarginOfAnEdgeAreNotChecked) {
  const GridSpec g = grid(10, 10);
  // A diagonal through ten centres (those at x + y = 10): they are on it; every other centre is
  // at least half a diagonal from it. The faces reach well beyond the grid, so that no other
  // edge comes near a centre.
  const std::vector<OwnedFace> faces{OwnedFace{1, {{Vec2{-5, -5}, Vec2{15, -5}, Vec2{-5, 15}}}},
                                     OwnedFace{2, {{Vec2{15, -5}, Vec2{15, 15}, Vec2{-5, 15}}}}};
  auto side = [&](int64_t col, int64_t r) {
    const double x = g.centre_x(col), y = g.centre_y(r);
    return x + y < 10.0 ? 1 : x + y > 10.0 ? 2 : 3;  // the centres on the edge: an owner of neither
  };
  const RegionCellCheck c = check_regions_against_cells(faces, cells(g, side), 0.1);
  EXPECT_EQ(c.near_edges, 10);
  EXPECT_EQ(c.checked, 90);
  EXPECT_EQ(c.misplaced, 0);
  // With a margin of 0.7 the centres 0.707 from it stay checked; at 0.71 they are not.
  EXPECT_EQ(check_regions_against_cells(faces, cells(g, side), 0.7).near_edges, 10);
  EXPECT_EQ(check_regions_against_cells(faces, cells(g, side), 0.71).near_edges, 10 + 2 * 9);
  // A margin of 0 still leaves out the centres on the edge (at distance 0); everything else is
  // checked, and a cell one off the diagonal given the other side's owner is found.
  const RegionCellCheck exact = check_regions_against_cells(
      faces, cells(g, [&](int64_t col, int64_t r) { return col == 3 && r == 4 ? 2 : side(col, r); }), 0.0);
  EXPECT_EQ(exact.near_edges, 10);
  EXPECT_EQ(exact.misplaced, 1);
  ASSERT_EQ(exact.first.size(), 1u);
  EXPECT_EQ(exact.first[0].region, 1);
}

TEST(RegionCheck, ACentreBeyondACornerIsWithinTheMarginByItsDistanceToTheCorner) {
  const GridSpec g = grid(10, 10);
  // Owner 1's face has a corner at (5.2, 4.8); the centre (5.5, 5.5) (column 5, row 4) is 0.76
  // from it and beside neither of its edges. That cell given owner 1 is misplaced unless the
  // margin reaches the corner.
  const std::vector<OwnedFace> faces{
      box(1, -5, -5, 5.2, 4.8),
      OwnedFace{2, {{Vec2{5.2, -5}, Vec2{15, -5}, Vec2{15, 15}, Vec2{-5, 15}, Vec2{-5, 4.8}, Vec2{5.2, 4.8}}}}};
  const CellOwners c = cells(g, [&](int64_t col, int64_t r) {
    if (col == 5 && r == 4) return 1;
    return g.centre_x(col) < 5.2 && g.centre_y(r) < 4.8 ? 1 : 2;
  });
  EXPECT_EQ(check_regions_against_cells(faces, c, 0.75).misplaced, 1);
  EXPECT_EQ(check_regions_against_cells(faces, c, 0.77).misplaced, 0);
}

TEST(RegionCheck, RowsNotFedAreNotChecked) {
  const GridSpec g = grid(6, 6);
  CellOwners c(g);
  const std::vector<int32_t> wrong(6, 2);
  for (int64_t r = 0; r < 3; ++r) c.add_row(r, std::vector<int32_t>(6, 1));
  c.add_row(4, wrong);
  EXPECT_EQ(c.rows_fed(), 4);
  const std::vector<OwnedFace> faces{box(1, 0, 0, 6, 6)};
  const RegionCellCheck k = check_regions_against_cells(faces, c, 0.1);
  EXPECT_EQ(k.rows, 4);
  EXPECT_EQ(k.checked, 24);
  EXPECT_EQ(k.misplaced, 6);
  // A row fed again replaces what it held.
  c.add_row(4, std::vector<int32_t>(6, 1));
  EXPECT_EQ(check_regions_against_cells(faces, c, 0.1).misplaced, 0);
  EXPECT_THROW(c.add_row(6, wrong), Error);
  EXPECT_THROW(c.add_row(0, std::vector<int32_t>(5, 1)), Error);
}

TEST(RegionCheck, RowsOfSitesGiveTheRunsOfTheirOwners) {
  // Sites 0 and 2 of owner A, 1 of B, 3 of C; kNoSite no owner.
  SeedSet seeds;
  for (const char* owner : {"A", "B", "A", "C"})
    seeds.add_point(seeds.add_feature(seeds.owner_code(owner)), Vec2{0.0, 0.0});
  const SiteCodes codes = SiteCodes::owners(seeds);
  const GridSpec g = grid(12, 2);
  const std::vector<int32_t> sites{0, 0, 2, 2, 1, kNoSite, kNoSite, 3, 3, 0, 2, 1};
  std::vector<int32_t> owners(sites.size());
  codes.apply(sites.data(), owners.data(), static_cast<int64_t>(sites.size()));
  CellOwners from_sites(g), from_owners(g);
  from_sites.add_sites(1, sites, codes);
  from_owners.add_row(1, owners);
  EXPECT_FALSE(from_sites.has(0));
  ASSERT_TRUE(from_sites.has(1));
  const std::vector<CellOwners::Run>&a = from_sites.row(1), &b = from_owners.row(1);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), 6u);  // A (0-3), B, none, C, A (9-10), B
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].col0, b[k].col0) << k;
    EXPECT_EQ(a[k].owner, b[k].owner) << k;
  }
  EXPECT_EQ(a[4].col0, 9);
  EXPECT_EQ(a[4].owner, seeds.owner_code("A"));
  EXPECT_THROW(from_sites.add_sites(0, std::vector<int32_t>(11, 0), codes), Error);
}

bool holds(const OwnedFace& f, Vec2 p) { return test::inside_polygon(p, Polygon{0, 0, f.rings}); }

TEST(RegionCheck, RandomTilingsOfSlantedTrianglesAgreeWithBruteForce) {
  std::mt19937_64 rng(56);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int64_t total_misplaced = 0, total_near = 0;
  for (int round = 0; round < 12; ++round) {
    const int64_t W = 23 + round, H = 17 + round % 5;
    const double res = 0.37 + 0.05 * round;
    GridSpec g = grid(W, H);
    g.res = res;
    g.xmin = -3.1 * round;
    g.ymax = 2.0 + static_cast<double>(H) * res;
    // A lattice of 6 x 5 quads over the grid, inner nodes jittered, each quad two triangles of
    // random owners (0 among them: nobody's).
    const int nx = 6, ny = 5;
    std::vector<Vec2> node((nx + 1) * (ny + 1));
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        double x = g.xmin + g.width * res * i / nx, y = g.ymax - g.height * res * j / ny;
        if (i > 0 && i < nx) x += (u(rng) - 0.5) * 0.6 * g.width * res / nx;
        if (j > 0 && j < ny) y += (u(rng) - 0.5) * 0.6 * g.height * res / ny;
        node[static_cast<size_t>(j * (nx + 1) + i)] = Vec2{x, y};
      }
    std::vector<OwnedFace> faces;
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        auto at = [&](int a, int b) { return node[static_cast<size_t>((j + b) * (nx + 1) + i + a)]; };
        faces.push_back(OwnedFace{static_cast<int32_t>(rng() % 4), {{at(0, 0), at(1, 0), at(1, 1)}}});
        faces.push_back(OwnedFace{static_cast<int32_t>(rng() % 4), {{at(0, 0), at(1, 1), at(0, 1), at(0, 0)}}});
      }
    // Cells owned as the face holding their centre, but one in twelve another owner.
    auto face_owner = [&](Vec2 p) {
      for (const OwnedFace& f : faces)
        if (holds(f, p)) return f.owner;
      return int32_t{0};
    };
    std::vector<std::vector<int32_t>> owner(static_cast<size_t>(H), std::vector<int32_t>(static_cast<size_t>(W)));
    CellOwners co(g);
    for (int64_t r = 0; r < H; ++r) {
      for (int64_t c = 0; c < W; ++c) {
        const Vec2 p{g.centre_x(c), g.centre_y(r)};
        owner[r][c] = rng() % 12 == 0 ? static_cast<int32_t>(rng() % 4) : face_owner(p);
      }
      if (r % 7 != 3) co.add_row(r, owner[r]);  // some rows not fed
    }
    const double margin = res * (0.05 + 0.3 * u(rng));
    const RegionCellCheck got = check_regions_against_cells(faces, co, margin);
    RegionCellCheck want;
    for (int64_t r = 0; r < H; ++r) {
      if (r % 7 == 3) continue;
      ++want.rows;
      for (int64_t c = 0; c < W; ++c) {
        const int32_t o = owner[r][c];
        if (o == 0) continue;
        const Vec2 p{g.centre_x(c), g.centre_y(r)};
        double d = HUGE_VAL;
        bool placed = false;
        for (const OwnedFace& f : faces) {
          for (const auto& ring : f.rings)
            for (size_t i = 0; i < ring.size(); ++i)
              d = std::min(d, test::segment_distance(p, ring[i], ring[(i + 1) % ring.size()]));
          placed = placed || (f.owner == o && holds(f, p));
        }
        if (d <= margin) {
          ++want.near_edges;
          continue;
        }
        ++want.checked;
        if (!placed) {
          ++want.misplaced;
          if (want.first.size() < RegionCellCheck::kFirst) want.first.push_back({c, r, o, face_owner(p)});
        }
      }
    }
    EXPECT_EQ(got.rows, want.rows) << round;
    EXPECT_EQ(got.checked, want.checked) << round;
    EXPECT_EQ(got.near_edges, want.near_edges) << round;
    EXPECT_EQ(got.misplaced, want.misplaced) << round;
    ASSERT_EQ(got.first.size(), want.first.size()) << round;
    for (size_t i = 0; i < got.first.size(); ++i) {
      EXPECT_EQ(got.first[i].col, want.first[i].col) << round;
      EXPECT_EQ(got.first[i].row, want.first[i].row) << round;
      EXPECT_EQ(got.first[i].owner, want.first[i].owner) << round;
      EXPECT_EQ(got.first[i].region, want.first[i].region) << round;
    }
    total_misplaced += want.misplaced;
    total_near += want.near_edges;
  }
  // The layouts exercise both: cells given another owner, and centres near slanted edges.
  EXPECT_GT(total_misplaced, 100);
  EXPECT_GT(total_near, 100);
}

}  // namespace
}  // namespace rv
