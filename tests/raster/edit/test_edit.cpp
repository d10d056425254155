// Edits of a finished field (rv/edit/edit.hpp): random edits of random seed sets -- remove, add, move,
// change owner, several at once, a seed outside the grid, features reordered, nothing at all --
// planar and geodesic, points, lines and polygons, with weights, reaches and a max distance. The
// edited field must equal a fresh computation of the edited seeds bit for bit (brute force, the
// exact method without a mask, is the oracle), and the plan must hold every cell that changed
// while leaving most of the grid alone.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "rv/edit/edit.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// One feature as the test edits it.
struct Spec {
  std::string owner;
  GeometryKind kind = GeometryKind::point;
  std::vector<Vec2> points;  // the point, the line's vertices, or the polygon's ring
  double weight = 1.0, reach = kInf;
};

SeedSet build(const std::vector<Spec>& specs) {
  SeedSet s;
  for (const Spec& sp : specs) {
    const int32_t f = s.add_feature(s.owner_code(sp.owner));
    if (sp.kind == GeometryKind::point)
      s.add_point(f, sp.points[0]);
    else if (sp.kind == GeometryKind::line)
      s.add_polyline(f, sp.points);
    else
      s.add_polygon(f, {Ring(sp.points)});
    if (sp.weight != 1.0 || std::isfinite(sp.reach)) s.set_adjustment(f, sp.weight, sp.reach);
  }
  return s;
}

// A random feature within [x0, x1] x [y0, y1] (lines and polygons small).
Spec random_spec(std::mt19937_64& rng, double x0, double y0, double x1, double y1, bool adjusted) {
  std::uniform_real_distribution<double> ux(x0, x1), uy(y0, y1), unit(0.0, 1.0);
  Spec sp;
  sp.owner = std::string(1, static_cast<char>('A' + static_cast<int>(unit(rng) * 4.0)));
  const double kind = unit(rng);
  const Vec2 p{ux(rng), uy(rng)};
  const double span = 0.04 * (x1 - x0);
  if (kind < 0.6) {
    sp.points = {p};
  } else if (kind < 0.85) {
    sp.kind = GeometryKind::line;
    sp.points = {p, {p.x + span * unit(rng), p.y + span * (unit(rng) - 0.5)}, {p.x + span, p.y + span * unit(rng)}};
  } else {
    sp.kind = GeometryKind::polygon;
    sp.points = {p, {p.x + span, p.y}, {p.x + 0.5 * span, p.y + span}};
  }
  if (adjusted) {
    if (unit(rng) < 0.3) sp.weight = 0.5 + 2.0 * unit(rng);
    if (unit(rng) < 0.2) sp.reach = 0.1 * (x1 - x0) + 0.3 * (x1 - x0) * unit(rng);
  }
  return sp;
}

struct Setting {
  const char* name;
  GridSpec grid;
  ComputeOptions options;
  double x0, y0, x1, y1;  // where seeds go
  bool adjusted;
};

int64_t differing(const NearestField& a, const NearestField& b) {
  int64_t n = 0;
  for (size_t i = 0; i < a.site.cells().size(); ++i)
    if (a.site.cells()[i] != b.site.cells()[i] ||
        std::memcmp(&a.distance.cells()[i], &b.distance.cells()[i], sizeof(float)) != 0)
      ++n;
  return n;
}

// Applies `edit` to `specs` many times over and checks each result against a fresh run.
void check_edits(const Setting& st, uint32_t seed, int rounds) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Spec> specs;
  for (int i = 0; i < 60; ++i) specs.push_back(random_spec(rng, st.x0, st.y0, st.x1, st.y1, st.adjusted));
  const int64_t total = st.grid.width * st.grid.height;
  for (int round = 0; round < rounds; ++round) {
    SCOPED_TRACE(std::string(st.name) + " round " + std::to_string(round));
    const SeedSet base_seeds = build(specs);
    const NearestField base = compute(base_seeds, st.grid, st.options);
    std::vector<Spec> next = specs;
    const int kind = round % 8;
    auto pick = [&] { return static_cast<size_t>(unit(rng) * static_cast<double>(next.size())) % next.size(); };
    if (kind == 0) {
      next.erase(next.begin() + static_cast<std::ptrdiff_t>(pick()));  // remove
    } else if (kind == 1) {
      next.insert(next.begin() + static_cast<std::ptrdiff_t>(pick()),
                  random_spec(rng, st.x0, st.y0, st.x1, st.y1, st.adjusted));  // add
    } else if (kind == 2) {
      Spec& s = next[pick()];  // move
      for (Vec2& p : s.points) p = Vec2{p.x + 0.02 * (st.x1 - st.x0), p.y - 0.01 * (st.y1 - st.y0)};
    } else if (kind == 3) {
      Spec& s = next[pick()];  // change owner
      s.owner = s.owner == "A" ? "E" : "A";
    } else if (kind == 4) {
      for (int k = 0; k < 3; ++k) next.erase(next.begin() + static_cast<std::ptrdiff_t>(pick()));  // several
      next.push_back(random_spec(rng, st.x0, st.y0, st.x1, st.y1, st.adjusted));
      next[pick()].weight = 1.5;
    } else if (kind == 5) {
      Spec out = random_spec(rng, st.x0, st.y0, st.x1, st.y1, st.adjusted);  // outside the grid
      for (Vec2& p : out.points) p.x += 1.5 * (st.x1 - st.x0);
      next.push_back(out);
    } else if (kind == 6) {
      std::swap(next[pick()], next[pick()]);  // reordered
    }                                         // kind 7: nothing changes
    const SeedSet edited = build(next);
    const EditPlan plan = plan_edit(base, base_seeds, edited, st.grid, st.options);
    const NearestField result = apply_edit(base, base_seeds, edited, st.grid, st.options, plan);
    ComputeOptions brute = st.options;
    brute.method = Method::brute_force;
    const NearestField fresh = compute(edited, st.grid, brute);
    ASSERT_EQ(differing(result, fresh), 0) << "edit kind " << kind;
    // The plan holds every cell that changed, and no more than the edit can reach.
    std::vector<int32_t> remap = edited_sites(base_seeds, edited, plan.match);
    int64_t changed = 0;
    for (int64_t r = 0; r < st.grid.height; ++r)
      for (int64_t c = 0; c < st.grid.width; ++c) {
        const int32_t s = base.site.at(c, r);
        const int32_t was = s == kNoSite ? kNoSite : remap[static_cast<size_t>(s)];
        const bool same = was == fresh.site.at(c, r) &&
                          std::memcmp(&base.distance.at(c, r), &fresh.distance.at(c, r), sizeof(float)) == 0;
        if (!same) {
          ++changed;
          EXPECT_TRUE(plan.mask.contains(c, r)) << c << ", " << r << " kind " << kind;
        }
      }
    if (kind == 7) {
      EXPECT_EQ(plan.cells, 0);
    }
    if (kind <= 3) {
      EXPECT_LT(plan.cells, total / 3) << "kind " << kind << ": " << changed << " changed";
    }
    EXPECT_GE(plan.cells, changed);
    specs = std::move(next);
  }
}

TEST(Edit, PlanarEditsEqualAFreshRun) {
  Setting st{"planar", test::grid_of(120, 100, 1.0), ComputeOptions{}, 0.0, 0.0, 120.0, 100.0, false};
  check_edits(st, 1, 24);
}

TEST(Edit, WeightsReachesAndAMaxDistance) {
  Setting st{"adjusted", test::grid_of(120, 100, 1.0), ComputeOptions{}, 0.0, 0.0, 120.0, 100.0, true};
  st.options.max_distance = 30.0;
  check_edits(st, 2, 24);
}

TEST(Edit, GeodesicEditsEqualAFreshRun) {
  Setting st{"geodesic", test::grid_of(100, 80, 0.01, 10.0, 55.8), ComputeOptions{}, 10.0, 55.0, 11.0, 55.8, false};
  st.options.metric = MetricSpec{MetricSpec::geodesic};
  check_edits(st, 3, 16);
}

// Over a grid of many tiles, with the base field's tile summaries: the tiles the edit reads
// (tiles_to_read) are those plan() reads, and an edit made in place with only those tiles valid --
// every other cell spoiled -- gives a fresh run's cells there, reading no spoiled cell; every other
// tile is the base's, renumbered, in the fresh run too (a file may copy it).
TEST(Edit, TileSummariesHoldEachBandsLargestDistanceAndUnownedCells) {
  // The oracle: a scan of each tile's and band's cells. A max distance leaves cells unowned; a
  // second add of some tiles (as a session after a step) keeps the largest of both.
  const GridSpec grid = test::grid_of(700, 560, 1.0);
  std::mt19937_64 rng(8);
  std::vector<Spec> specs;
  for (int i = 0; i < 40; ++i) specs.push_back(random_spec(rng, 0.0, 0.0, 700.0, 560.0, false));
  ComputeOptions options;
  options.max_distance = 60.0;
  const SeedSet seeds = build(specs);
  const NearestField field = compute(seeds, grid, options);
  TileSummaries tiles = TileSummaries::for_grid(grid);
  ASSERT_TRUE(tiles.has_bands());
  tiles.add(field.site.data(), field.distance.data(), 0, grid.height, grid.width, seeds);
  constexpr int64_t T = TileSummaries::kTile, B = T / TileSummaries::kBands;
  auto check = [&](const NearestField& f, const char* what) {
    SCOPED_TRACE(what);
    int64_t unowned_bands = 0;
    for (int64_t tr = 0; tr < tiles.rows; ++tr)
      for (int64_t tc = 0; tc < tiles.cols; ++tc) {
        const auto k = static_cast<size_t>(tr * tiles.cols + tc);
        float tile_max = -1.0f;
        for (int64_t b = 0; b < TileSummaries::kBands; ++b) {
          float most = -1.0f;
          bool none = false;
          for (int64_t r = tr * T + b * B; r < std::min(grid.height, tr * T + b * B + B); ++r)
            for (int64_t c = tc * T; c < std::min(grid.width, tc * T + T); ++c) {
              if (f.site.at(c, r) == kNoSite)
                none = true;
              else
                most = std::max(most, f.distance.at(c, r));
            }
          const size_t i = k * TileSummaries::kBands + static_cast<size_t>(b);
          EXPECT_EQ(tiles.band_max_distance[i], most) << "tile " << k << " band " << b;
          EXPECT_EQ(tiles.band_unowned[i] != 0, none) << "tile " << k << " band " << b;
          unowned_bands += none ? 1 : 0;
          tile_max = std::max(tile_max, most);
        }
        EXPECT_EQ(tiles.max_distance[k], tile_max) << "tile " << k;
      }
    EXPECT_GT(unowned_bands, 0);
  };
  check(field, "whole grid");
  // Tile (1, 1) taken in again from a field whose distances there are larger: its summaries grow
  // to the new values (the larger of both), the others' stay.
  NearestField larger = field;
  for (int64_t r = T; r < 2 * T; ++r)
    for (int64_t c = T; c < 2 * T; ++c)
      if (larger.site.at(c, r) != kNoSite) larger.distance.at(c, r) += 1.0f;
  std::vector<uint8_t> only(static_cast<size_t>(tiles.cols * tiles.rows), 0);
  only[static_cast<size_t>(tiles.cols + 1)] = 1;
  tiles.add(larger.site.data(), larger.distance.data(), 0, grid.height, grid.width, seeds, only.data());
  check(larger, "one tile again");
}

TEST(Edit, OnlyTheTilesToReadAreRead) {
  const GridSpec grid = test::grid_of(700, 560, 1.0);  // 3 x 3 tiles of 256, the last ones partial
  std::mt19937_64 rng(7);
  std::vector<Spec> specs;
  for (int i = 0; i < 150; ++i) specs.push_back(random_spec(rng, 0.0, 0.0, 700.0, 560.0, false));
  ComputeOptions options;
  const SeedSet base_seeds = build(specs);
  const NearestField base = compute(base_seeds, grid, options);
  TileSummaries tiles = TileSummaries::for_grid(grid);
  tiles.add(base.site.data(), base.distance.data(), 0, grid.height, grid.width, base_seeds);
  int64_t some_skipped = 0;
  for (int kind = 0; kind < 3; ++kind) {
    SCOPED_TRACE("kind " + std::to_string(kind));
    std::vector<Spec> next = specs;
    if (kind == 0) next[40].points[0] = Vec2{next[40].points[0].x + 3.0, next[40].points[0].y - 2.0};
    if (kind == 1) next.erase(next.begin() + 70);
    if (kind == 2) next.insert(next.begin() + 10, Spec{"B", GeometryKind::point, {{650.0, 30.0}}});
    const SeedSet edited = build(next);
    const Edit edit(base_seeds, edited, grid, options);
    const std::vector<uint8_t> to_read = edit.tiles_to_read(tiles);
    const EditPlan plan = edit.plan(base, &tiles);
    std::vector<int64_t> flagged;
    for (size_t t = 0; t < to_read.size(); ++t)
      if (to_read[t]) flagged.push_back(static_cast<int64_t>(t));
    EXPECT_EQ(plan.tiles_read, flagged);
    some_skipped += static_cast<int64_t>(to_read.size() - flagged.size());
    // Spoiled outside the tiles to read: a site no seed set has, a distance of nothing.
    NearestField field = base;
    for (int64_t r = 0; r < grid.height; ++r)
      for (int64_t c = 0; c < grid.width; ++c)
        if (!to_read[tiles.tile_of(c, r)]) {
          field.site.at(c, r) = 1 << 30;
          field.distance.at(c, r) = -7.0f;
        }
    const EditPlan spoiled_plan = edit.plan(field, &tiles);
    EXPECT_EQ(spoiled_plan.cells, plan.cells);
    edit.apply(field, spoiled_plan, field, &to_read);
    ComputeOptions brute = options;
    brute.method = Method::brute_force;
    const NearestField fresh = compute(edited, grid, brute);
    const std::vector<int32_t>& remap = edit.site_map();
    for (int64_t r = 0; r < grid.height; ++r)
      for (int64_t c = 0; c < grid.width; ++c) {
        if (to_read[tiles.tile_of(c, r)]) {
          ASSERT_EQ(field.site.at(c, r), fresh.site.at(c, r)) << c << "," << r;
          ASSERT_EQ(field.distance.at(c, r), fresh.distance.at(c, r)) << c << "," << r;
        } else {
          // Left as it was, or (a block of the engine's across a tile's edge) its fresh value.
          if (field.site.at(c, r) != 1 << 30) {
            ASSERT_EQ(field.site.at(c, r), fresh.site.at(c, r)) << c << "," << r;
            ASSERT_EQ(field.distance.at(c, r), fresh.distance.at(c, r)) << c << "," << r;
          }
          const int32_t b = base.site.at(c, r);
          ASSERT_EQ(b == kNoSite ? kNoSite : remap[static_cast<size_t>(b)], fresh.site.at(c, r)) << c << "," << r;
          ASSERT_EQ(base.distance.at(c, r), fresh.distance.at(c, r)) << c << "," << r;
        }
      }
  }
  EXPECT_GT(some_skipped, 0);
}

TEST(Edit, FeaturesMatchByGeometryOwnerAndAdjustments) {
  std::vector<Spec> specs = {{"A", GeometryKind::point, {{1, 1}}},
                             {"B", GeometryKind::line, {{2, 2}, {3, 3}}},
                             {"A", GeometryKind::polygon, {{5, 5}, {6, 5}, {5, 6}}}};
  const SeedSet base = build(specs);
  // The same: all kept.
  EXPECT_EQ(match_features(base, build(specs)).kept(), 3);
  // A reach, an owner, a vertex: each a changed feature.
  for (int k = 0; k < 3; ++k) {
    std::vector<Spec> e = specs;
    if (k == 0) e[0].reach = 5.0;
    if (k == 1) e[1].owner = "C";
    if (k == 2) e[2].points[1].x = 6.5;
    const FeatureMatch m = match_features(base, build(e));
    EXPECT_EQ(m.kept(), 2) << k;
    EXPECT_EQ(m.edited_of_base[static_cast<size_t>(k)], -1) << k;
  }
  // Removing the first feature renumbers the rest, and B now comes first: owners reordered.
  const FeatureMatch m = match_features(base, build({specs[1], specs[2]}));
  EXPECT_EQ(m.edited_of_base, (std::vector<int32_t>{-1, 0, 1}));
  EXPECT_TRUE(m.owners_reordered);
  const std::vector<int32_t> sites = edited_sites(base, build({specs[1], specs[2]}), m);
  EXPECT_EQ(sites[0], kNoSite);
  EXPECT_EQ(sites[1], 0);  // the line's segment
}

// Owners are paired by label, whatever their codes; their order is "reordered" only where two
// owners both sets hold come in the other order.
TEST(Edit, OwnersPairByLabel) {
  auto set = [](const std::vector<std::string>& owners) {
    std::vector<Spec> specs;
    for (size_t i = 0; i < owners.size(); ++i)
      specs.push_back({owners[i], GeometryKind::point, {{static_cast<double>(i), 1.0}}});
    return build(specs);
  };
  const SeedSet abc = set({"A", "B", "C"});
  EXPECT_EQ(owner_codes_in(abc, set({"C", "A", "D"})), (std::vector<int32_t>{0, 2, -1, 1}));
  EXPECT_EQ(owner_codes_in(abc, abc), (std::vector<int32_t>{0, 1, 2, 3}));
  EXPECT_EQ(owner_codes_in(abc, set({"D"})), (std::vector<int32_t>{0, -1, -1, -1}));
  EXPECT_EQ(owner_codes_in(set({"A", "A"}), abc), (std::vector<int32_t>{0, 1}));  // one code per label
  // An owner dropped or added keeps the others' order; two swapped do not.
  EXPECT_FALSE(match_features(abc, set({"A", "C"})).owners_reordered);
  EXPECT_FALSE(match_features(abc, set({"A", "D", "B", "C"})).owners_reordered);
  EXPECT_FALSE(match_features(abc, set({"D"})).owners_reordered);
  EXPECT_TRUE(match_features(abc, set({"A", "C", "B"})).owners_reordered);
  EXPECT_TRUE(match_features(abc, set({"C", "D", "A"})).owners_reordered);
}

// A caller's match (a session knows which features it changed): the match_features one, or one
// that leaves kept features unpaired, gives the fresh field; one that does not fit is refused.
TEST(Edit, AGivenMatchGivesTheSameField) {
  std::vector<Spec> specs = {{"A", GeometryKind::point, {{10, 10}}},
                             {"B", GeometryKind::line, {{40, 20}, {60, 70}}},
                             {"A", GeometryKind::polygon, {{80, 60}, {95, 60}, {85, 80}}},
                             {"C", GeometryKind::point, {{20, 80}}}};
  const GridSpec grid = test::grid_of(120, 100, 1.0);
  ComputeOptions options;
  options.threads = 2;
  const SeedSet base = build(specs);
  const NearestField before = compute(base, grid, options);
  std::vector<Spec> next = specs;
  next[0].points[0] = Vec2{30, 30};  // the first point moved
  const SeedSet edited = build(next);
  const NearestField fresh = compute(edited, grid, options);
  auto field_of = [&](FeatureMatch m) {
    const Edit edit(base, edited, grid, options, std::move(m));
    NearestField out = before;
    edit.apply(out, edit.plan(out), out);
    return out;
  };
  FeatureMatch by_geometry = match_features(base, edited);
  EXPECT_EQ(by_geometry.kept(), 3);
  EXPECT_EQ(differing(field_of(by_geometry), fresh), 0);
  FeatureMatch fewer = by_geometry;  // the polygon taken as removed and added
  fewer.edited_of_base[2] = -1;
  fewer.base_of_edited[2] = -1;
  EXPECT_EQ(differing(field_of(fewer), fresh), 0);
  FeatureMatch none;
  none.edited_of_base.assign(4, -1);
  none.base_of_edited.assign(4, -1);
  EXPECT_EQ(differing(field_of(none), fresh), 0);
  // Out of order, one-sided, a point paired with a polygon, the wrong sizes: refused.
  FeatureMatch swapped = by_geometry;
  std::swap(swapped.edited_of_base[1], swapped.edited_of_base[2]);
  std::swap(swapped.base_of_edited[1], swapped.base_of_edited[2]);
  FeatureMatch one_sided = by_geometry;
  one_sided.edited_of_base[3] = -1;
  FeatureMatch kinds = none;
  kinds.edited_of_base[0] = 2;
  kinds.base_of_edited[2] = 0;
  FeatureMatch sizes = by_geometry;
  sizes.base_of_edited.pop_back();
  for (const FeatureMatch* m : {&swapped, &one_sided, &kinds, &sizes})
    EXPECT_THROW(Edit(base, edited, grid, options, *m), Error);
}

}  // namespace
}  // namespace rv
