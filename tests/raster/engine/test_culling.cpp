// The culling skeleton of the exact methods (raster/src/engine/culling.hpp) and the cell mask it
// honours (rv/field/cell_mask.hpp): splits partition their block, a mask's queries agree with its
// cells, and a masked computation writes every masked cell -- and any other it writes -- with
// the value of the computation without the mask, planar and geodesic, for any thread count,
// skipping the tiles without a masked cell.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "engine/culling.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/cell_mask.hpp"
#include "rv/field/error.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

// ---- Splits ----

// How often each cell of `outer` is covered by the blocks, and that every block is non-empty.
std::vector<int> coverage(const detail::Block& outer, const std::vector<detail::Block>& parts) {
  std::vector<int> n(static_cast<size_t>(outer.cells()), 0);
  for (const detail::Block& p : parts) {
    EXPECT_LT(p.c0, p.c1);
    EXPECT_LT(p.r0, p.r1);
    for (int64_t r = p.r0; r < p.r1; ++r)
      for (int64_t c = p.c0; c < p.c1; ++c) {
        EXPECT_TRUE(c >= outer.c0 && c < outer.c1 && r >= outer.r0 && r < outer.r1);
        if (c >= outer.c0 && c < outer.c1 && r >= outer.r0 && r < outer.r1)
          ++n[static_cast<size_t>((r - outer.r0) * outer.width() + (c - outer.c0))];
      }
  }
  return n;
}

TEST(Culling, SplitsPartitionTheirBlock) {
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    const int64_t c0 = static_cast<int64_t>(rng() % 50), r0 = static_cast<int64_t>(rng() % 50);
    const detail::Block b{c0, r0, c0 + 1 + static_cast<int64_t>(rng() % 70), r0 + 1 + static_cast<int64_t>(rng() % 70),
                          64};
    std::vector<detail::Block> parts;
    detail::split_middle(b, [&](const detail::Block& p) { parts.push_back(p); });
    EXPECT_GE(parts.size(), 1u);
    EXPECT_LE(parts.size(), 4u);
    for (int n : coverage(b, parts)) ASSERT_EQ(n, 1) << "trial " << trial;
  }
}

TEST(Culling, AlignedSplitsStayOnTheGridForAnyWindow) {
  // A tile of level 256 clipped by windows at several offsets: every part lies inside one
  // grid-aligned square of half the level, so blocks -- and what depends on them -- are the
  // same whatever the window.
  for (int64_t col0 : {0, 1, 37, 200})
    for (int64_t row0 : {0, 5, 129}) {
      const Window w{col0, row0, 600, 500};
      const int64_t gx = (col0 / 256) * 256, gy = (row0 / 256) * 256;
      const detail::Block tile{std::max<int64_t>(gx - col0, 0), std::max<int64_t>(gy - row0, 0),
                               std::min<int64_t>(gx + 256 - col0, w.width),
                               std::min<int64_t>(gy + 256 - row0, w.height), 256};
      std::vector<detail::Block> parts;
      detail::split_aligned(w, tile, [&](const detail::Block& p) { parts.push_back(p); });
      for (int n : coverage(tile, parts)) ASSERT_EQ(n, 1);
      for (const detail::Block& p : parts) {
        EXPECT_EQ(p.level, 128);
        EXPECT_EQ((w.col0 + p.c0) / 128, (w.col0 + p.c1 - 1) / 128) << col0 << " " << row0;
        EXPECT_EQ((w.row0 + p.r0) / 128, (w.row0 + p.r1 - 1) / 128) << col0 << " " << row0;
      }
    }
}

// ---- The mask ----

TEST(CellMask, QueriesAgreeWithItsCells) {
  const Window w{0, 0, 40, 30};
  std::mt19937_64 rng(11);
  CellMask m = CellMask::none(w);
  std::vector<char> in(static_cast<size_t>(w.cell_count()), 0);
  for (int k = 0; k < 25; ++k) {
    const int64_t c0 = static_cast<int64_t>(rng() % 40), r0 = static_cast<int64_t>(rng() % 30);
    const int64_t c1 = std::min<int64_t>(40, c0 + 1 + static_cast<int64_t>(rng() % 8));
    const int64_t r1 = std::min<int64_t>(30, r0 + 1 + static_cast<int64_t>(rng() % 5));
    m.add(c0, r0, c1, r1);
    for (int64_t r = r0; r < r1; ++r)
      for (int64_t c = c0; c < c1; ++c) in[static_cast<size_t>(r * 40 + c)] = 1;
  }
  EXPECT_TRUE(m.fits(w));
  for (int k = 0; k < 2000; ++k) {
    const int64_t c0 = static_cast<int64_t>(rng() % 40), r0 = static_cast<int64_t>(rng() % 30);
    const int64_t c1 = std::min<int64_t>(40, c0 + 1 + static_cast<int64_t>(rng() % 12));
    const int64_t r1 = std::min<int64_t>(30, r0 + 1 + static_cast<int64_t>(rng() % 12));
    bool expected = false;
    for (int64_t r = r0; r < r1; ++r)
      for (int64_t c = c0; c < c1; ++c) expected = expected || in[static_cast<size_t>(r * 40 + c)];
    ASSERT_EQ(m.any(c0, r0, c1, r1), expected) << c0 << " " << r0 << " " << c1 << " " << r1;
  }
  // Overlapping and touching spans merge: a row is disjoint, sorted spans.
  for (const auto& row : m.rows)
    for (size_t i = 1; i < row.size(); ++i) EXPECT_LT(row[i - 1].second, row[i].first);
  CellMask bad = CellMask::none(w);
  bad.rows[3] = {{5, 9}, {7, 12}};
  EXPECT_FALSE(bad.fits(w));
  bad.rows[3] = {{5, 41}};
  EXPECT_FALSE(bad.fits(w));
  EXPECT_FALSE(CellMask::none(Window{0, 0, 40, 29}).fits(w));
}

// ---- Masked computations ----

// Points, lines and polygons over a planar grid of w x h unit cells (several owners).
SeedSet planar_seeds(int64_t w, int64_t h, uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(0.0, static_cast<double>(w)), uy(0.0, static_cast<double>(h));
  SeedSet s;
  for (int f = 0; f < 60; ++f) {
    const int32_t id = s.add_feature(s.owner_code(std::to_string(f % 5)));
    const Vec2 c{ux(rng), uy(rng)};
    if (f % 3 == 0) {
      s.add_point(id, c);
    } else if (f % 3 == 1) {
      const std::vector<Vec2> line{c, {c.x + 9.0, c.y + 4.0}, {c.x + 3.0, c.y + 13.0}};
      s.add_polyline(id, line);
    } else {
      s.add_polygon(id, {{{c.x, c.y}, {c.x + 11.0, c.y + 2.0}, {c.x + 5.0, c.y + 9.0}}});
    }
  }
  return s;
}

// Coastline-like lines and basepoints in degrees around 12E 55N, on a grid of 0.002 degrees.
SeedSet geodesic_seeds(uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> lon(11.9, 13.1), lat(54.6, 55.4);
  SeedSet s;
  for (int f = 0; f < 24; ++f) {
    const int32_t id = s.add_feature(s.owner_code(f % 2 ? "A" : "B"));
    const Vec2 c{lon(rng), lat(rng)};
    if (f % 2 == 0) {
      s.add_point(id, c);
    } else {
      const std::vector<Vec2> line{c, {c.x + 0.05, c.y + 0.02}, {c.x + 0.08, c.y - 0.03}};
      s.add_polyline(id, line);
    }
  }
  return s;
}

GridSpec geodesic_grid() { return test::grid_of(700, 500, 0.002, 11.8, 55.5); }

// Rectangles and single-row spans of the window, random.
CellMask random_mask(const Window& w, uint32_t seed) {
  std::mt19937_64 rng(seed);
  CellMask m = CellMask::none(w);
  for (int k = 0; k < 4; ++k) {
    const int64_t c0 = static_cast<int64_t>(rng() % static_cast<uint64_t>(w.width));
    const int64_t r0 = static_cast<int64_t>(rng() % static_cast<uint64_t>(w.height));
    m.add(c0, r0, std::min(w.width, c0 + 1 + static_cast<int64_t>(rng() % 60)),
          std::min(w.height, r0 + 1 + static_cast<int64_t>(rng() % 40)));
  }
  for (int k = 0; k < 6; ++k) {
    const int64_t c0 = static_cast<int64_t>(rng() % static_cast<uint64_t>(w.width));
    const int64_t r = static_cast<int64_t>(rng() % static_cast<uint64_t>(w.height));
    m.add(c0, r, std::min(w.width, c0 + 1 + static_cast<int64_t>(rng() % 5)), r + 1);
  }
  return m;
}

TEST(Culling, AMaskedRunVisitsExactlyTheTilesWithAMaskedCell) {
  // tiles_to_solve finds the tiles from the mask's spans; the oracle asks every tile of the
  // window. Windows off the tile grid, spans across tile edges, empty rows, an empty mask.
  std::mt19937_64 rng(21);
  for (const Window w : {Window{0, 0, 300, 260}, Window{17, 40, 250, 190}, Window{63, 1, 130, 129}}) {
    constexpr int64_t kTile = 64;
    const int64_t tx0 = w.col0 / kTile, ty0 = w.row0 / kTile;
    const int64_t ntx = (w.col0 + w.width - 1) / kTile - tx0 + 1, nty = (w.row0 + w.height - 1) / kTile - ty0 + 1;
    const SeedSet s;
    const GridSpec g = test::grid_of(400, 300);
    const std::vector<LocalSite> local;
    const std::vector<int32_t> geometric;
    for (uint32_t trial = 0; trial < 5; ++trial) {
      const CellMask mask =
          trial == 0 ? CellMask::none(w) : random_mask(w, 300 + trial + static_cast<uint32_t>(rng() % 9));
      detail::EngineContext ctx{s, g, w, local, geometric, 0.0, 1, nullptr};
      ctx.mask = &mask;
      std::vector<int64_t> expected;
      for (int64_t t = 0; t < ntx * nty; ++t) {
        const int64_t gx = (tx0 + t % ntx) * kTile - w.col0, gy = (ty0 + t / ntx) * kTile - w.row0;
        if (mask.any(std::max<int64_t>(gx, 0), std::max<int64_t>(gy, 0), std::min(gx + kTile, w.width),
                     std::min(gy + kTile, w.height)))
          expected.push_back(t);
      }
      EXPECT_EQ(detail::tiles_to_solve(ctx, kTile, tx0, ty0, ntx, nty), expected) << "trial " << trial;
      if (trial > 0) {
        EXPECT_FALSE(expected.empty());
      }
    }
  }
}

// Every masked cell, and every other cell written (not no-site), has the full computation's
// value; tiles of `tile` cells without a masked cell are left alone but for interior cells.
// Returns the number of cells written outside the mask.
int64_t check_masked(const NearestField& masked, const NearestField& full, const CellMask& mask, int64_t tile) {
  const Window w = full.site.window();
  int64_t written_outside = 0;
  for (int64_t r = 0; r < w.height; ++r)
    for (int64_t c = 0; c < w.width; ++c) {
      const bool in = mask.contains(c, r);
      const bool written = masked.site.at(c, r) != kNoSite;
      if (in || written) {
        EXPECT_EQ(masked.site.at(c, r), full.site.at(c, r)) << "cell " << c << ", " << r << (in ? " (masked)" : "");
        EXPECT_EQ(masked.distance.at(c, r), full.distance.at(c, r)) << "cell " << c << ", " << r;
      }
      if (!in && written) {
        ++written_outside;
        const int64_t gc = (w.col0 + c) / tile * tile - w.col0, gr = (w.row0 + r) / tile * tile - w.row0;
        const bool tile_masked = mask.any(std::max<int64_t>(gc, 0), std::max<int64_t>(gr, 0),
                                          std::min(gc + tile, w.width), std::min(gr + tile, w.height));
        // Outside masked tiles only interior cells (distance 0, apply_interiors) are written.
        if (!tile_masked) {
          EXPECT_EQ(masked.distance.at(c, r), 0.0f) << "cell " << c << ", " << r;
        }
      }
    }
  return written_outside;
}

TEST(MaskedCompute, PlanarMaskedCellsEqualTheFullComputation) {
  const GridSpec g = test::grid_of(300, 260);
  for (uint32_t trial = 0; trial < 4; ++trial) {
    const SeedSet s = planar_seeds(g.width, g.height, trial);
    ComputeOptions o;
    o.threads = 2;
    const NearestField full = compute(s, g, o);
    const auto mask = std::make_shared<const CellMask>(random_mask(g.full_window(), 100 + trial));
    for (int threads : {1, 2}) {
      o.threads = threads;
      o.mask = mask;
      const NearestField masked = compute(s, g, o);
      const int64_t outside = check_masked(masked, full, *mask, 64);
      // Whole tiles were skipped: far fewer cells than the grid's were computed.
      EXPECT_LT(outside, g.cell_count() / 2) << "trial " << trial;
    }
  }
}

TEST(MaskedCompute, GeodesicMaskedCellsEqualTheFullComputation) {
  const GridSpec g = geodesic_grid();
  ComputeOptions o;
  o.metric.kind = MetricSpec::geodesic;
  o.threads = 2;
  const SeedSet s = geodesic_seeds(7);
  const NearestField full = compute(s, g, o);
  for (uint32_t trial = 0; trial < 2; ++trial) {
    const auto mask = std::make_shared<const CellMask>(random_mask(g.full_window(), 200 + trial));
    o.mask = mask;
    o.threads = 1 + static_cast<int>(trial);
    const NearestField masked = compute(s, g, o);
    EXPECT_LT(check_masked(masked, full, *mask, 256), g.cell_count()) << "trial " << trial;
  }
}

TEST(MaskedCompute, AWindowAndAnEarlierFieldGiveTheWholeResult) {
  // The edits' use: `out` holds the earlier field, with the cells an edit changes spoiled; the
  // masked computation over those cells restores the full result exactly, in a window too.
  const GridSpec g = test::grid_of(300, 260);
  const SeedSet s = planar_seeds(g.width, g.height, 9);
  ComputeOptions o;
  o.threads = 2;
  o.window = Window{17, 40, 250, 190};
  const NearestField full = compute(s, g, o);
  NearestField out = full;
  const CellMask mask = random_mask(*o.window, 5);
  for (int64_t r = 0; r < o.window->height; ++r)
    for (int64_t c = 0; c < o.window->width; ++c)
      if (mask.contains(c, r)) {
        out.site.at(c, r) = 12345;
        out.distance.at(c, r) = 9.0f;
      }
  o.mask = std::make_shared<const CellMask>(mask);
  compute_into(s, g, o, out);
  EXPECT_EQ(out.site.cells(), full.site.cells());
  EXPECT_EQ(out.distance.cells(), full.distance.cells());
}

TEST(MaskedCompute, AMaskIsRefusedWhereItCannotHold) {
  const GridSpec g = test::grid_of(80, 60);
  const SeedSet s = planar_seeds(g.width, g.height, 1);
  ComputeOptions o;
  o.mask = std::make_shared<const CellMask>(CellMask::none(g.full_window()));
  auto kind_of = [&](auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      return e.kind();
    }
    return ErrorKind::internal;
  };
  o.method = Method::hv_scan;  // the scans propagate: they cannot compute part of a field
  EXPECT_EQ(kind_of([&] { compute(s, g, o); }), ErrorKind::invalid_argument);
  o.method = Method::brute_force;
  EXPECT_EQ(kind_of([&] { compute(s, g, o); }), ErrorKind::invalid_argument);
  o.method = Method::exact;
  o.mask = std::make_shared<const CellMask>(CellMask::none(Window{0, 0, 80, 59}));  // a row short
  EXPECT_EQ(kind_of([&] { compute(s, g, o); }), ErrorKind::invalid_argument);
  // compute_into needs the earlier field of this grid and window in `out`.
  o.mask = std::make_shared<const CellMask>(CellMask::none(g.full_window()));
  NearestField empty;
  EXPECT_EQ(kind_of([&] { compute_into(s, g, o, empty); }), ErrorKind::invalid_argument);
  // An empty mask computes nothing: compute() gives no site but to polygon interiors (distance
  // 0, given after every method).
  const NearestField none = compute(s, g, o);
  int64_t written = 0;
  for (size_t i = 0; i < none.site.cells().size(); ++i)
    if (none.site.cells()[i] != kNoSite) {
      ++written;
      EXPECT_EQ(none.distance.cells()[i], 0.0f);
    }
  EXPECT_LT(written, g.cell_count() / 2);
}

}  // namespace
}  // namespace rv
