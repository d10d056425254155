// LinePieces and StripLines::take_rows (rv/lines/strip_lines.hpp), Edit::line_rows (rv/edit/edit.hpp):
// an extraction that takes any rows' pieces from an earlier one of the same field gives the same
// lines; the pieces survive their bytes, and damaged bytes are refused; an edit that extracts
// only Edit::line_rows and takes every other row from its base gives a fresh extraction's lines,
// vertex for vertex, for moves, removals, additions and owner changes, planar and geodesic, with
// boundaries, limits for all owners and per owner, and a max distance; and leaves rows to take;
// and so does one that also takes the base's refined segments away from those rows
// (StripLines::keep_refined), taking some and refining the others; and one that also takes the
// fed rows' vertices on edges the edit left unchanged (StripLines::take_measured).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "line_compare.hpp"
#include "rv/edit/edit.hpp"
#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/strip_lines.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Spec {
  int owners = 4;
  int features = 40;
  double w = 80.0, h = 700.0;  // extent in cells; three bands of 256-row tiles
};

// Points, short coastlines and two islands of four owners over the grid's extent (`scale` units
// per cell from `origin`).
SeedSet make_seeds(uint32_t seed, const Spec& s, double scale, Vec2 origin) {
  return test::mixed_seeds(seed, {s.features, s.owners, s.w - 6, s.h - 6, 5, {7, 22}}, scale, origin);
}

// One field's lines: the request, its index, and strips from any seed set.
struct Lines {
  GridSpec grid;
  ComputeOptions compute;
  LineRequest request;

  std::unique_ptr<SiteMetric> metric_of(const SeedSet& seeds) const { return make_site_metric(seeds, grid, compute); }
  NearestField rows(const SeedSet& seeds, int64_t row0, int64_t row1) const {
    ComputeOptions o = compute;
    o.window = Window{0, row0, grid.width, row1 - row0};
    return rv::compute(seeds, grid, o);
  }
  // Extracts rows `fed` (sorted, disjoint ranges) from strips of `seeds`' field and takes the
  // others from `base` (none: every row fed).
  // With `unchanged`, the fed rows' vertices on edges in its unflagged tiles are taken from
  // `base` (StripLines::take_measured).
  StripLines extract(const OwnerIndex& index, const SeedSet& seeds, const std::vector<std::pair<int64_t, int64_t>>& fed,
                     const LinePieces* base = nullptr, std::span<const int32_t> site_map = {},
                     const ChangedTiles* unchanged = nullptr) const {
    StripLines lines(grid, index, request);
    if (unchanged != nullptr) lines.take_measured(*base, *unchanged, {site_map.begin(), site_map.end()});
    for (const auto& [a, b] : fed) {
      if (lines.rows() < a) lines.take_rows(*base, a, site_map);
      for (int64_t r = a; r < b; r += 37) lines.add(rows(seeds, r, std::min(b, r + 37)));
    }
    if (lines.rows() < grid.height) lines.take_rows(*base, grid.height, site_map);
    return lines;
  }
};

void expect_same(StripLines& a, StripLines& b) {
  test::expect_same_lines(a.take_boundaries(), b.take_boundaries());
  test::expect_same_lines(a.take_limits(), b.take_limits());
}

Lines planar_lines(const Spec& s, double max_distance = kInf) {
  Lines l;
  l.grid = test::grid_of(static_cast<int64_t>(s.w), static_cast<int64_t>(s.h));
  l.compute.threads = 2;
  l.compute.max_distance = max_distance;
  l.request.boundaries = true;
  l.request.boundary.threads = 2;
  l.request.boundary.simplify_cells = 0.2;
  l.request.boundary.max_distance = max_distance;
  l.request.limit_distances = {3.0, 7.5};
  l.request.limit.threads = 2;
  return l;
}

// One planar field's lines: its seeds (from `seed`), metric and index.
struct PlanarField {
  Spec spec;
  Lines l = planar_lines(spec);
  SeedSet seeds;
  std::unique_ptr<SiteMetric> metric;
  std::unique_ptr<OwnerIndex> index;
  int64_t H = l.grid.height;
  explicit PlanarField(uint32_t seed)
      : seeds(make_seeds(seed, spec, 1.0, {0.0, 0.0})),
        metric(l.metric_of(seeds)),
        index(std::make_unique<OwnerIndex>(*metric)) {}
  StripLines whole() const { return l.extract(*index, seeds, {{0, H}}); }
};

TEST(LinePieces, AnyRowsTakenFromTheSameFieldGiveTheSameLines) {
  const Spec spec;
  const Lines l = planar_lines(spec);
  const SeedSet seeds = make_seeds(3, spec, 1.0, {0.0, 0.0});
  const auto metric = l.metric_of(seeds);
  const OwnerIndex index(*metric);
  const int64_t H = l.grid.height;
  StripLines whole = l.extract(index, seeds, {{0, H}});
  const LinePieces pieces = whole.pieces();
  // Through their bytes: decoded pieces encode to the same bytes.
  const std::string bytes = pieces.encode();
  const LinePieces back = LinePieces::decode(bytes);
  EXPECT_EQ(back.encode(), bytes);
  EXPECT_EQ(back.key(), whole.key());
  for (const auto& fed : std::vector<std::vector<std::pair<int64_t, int64_t>>>{
           {}, {{0, 1}}, {{H - 1, H}}, {{5, 12}, {300, 301}, {600, H}}, {{0, 256}, {512, 520}}, {{1, 2}, {3, 4}}}) {
    SCOPED_TRACE("ranges fed: " + std::to_string(fed.size()));
    StripLines taken = l.extract(index, seeds, fed, &back);
    StripLines fresh = l.extract(index, seeds, {{0, H}});
    expect_same(taken, fresh);
  }
}

// Pieces kept as the lines are taken (StripLines::keep_pieces, moved rather than copied) equal
// those copied before, byte for byte, and leave the lines as they are without; they are refused
// before the last row, after a take, and before every take.
TEST(LinePieces, PiecesKeptAsTheLinesAreTakenEqualACopyBefore) {
  const PlanarField f(7);
  const Lines& l = f.l;
  StripLines copied = f.whole();
  const std::string before = copied.pieces().encode();
  StripLines kept = f.whole();
  kept.keep_pieces();
  EXPECT_THROW(kept.kept_pieces(), Error);  // no line taken yet
  test::expect_same_lines(kept.take_boundaries(), copied.take_boundaries());
  EXPECT_THROW(kept.kept_pieces(), Error);  // the limits not taken yet
  test::expect_same_lines(kept.take_limits(), copied.take_limits());
  const LinePieces pieces = kept.kept_pieces();
  EXPECT_EQ(pieces.encode(), before);
  EXPECT_EQ(pieces.key(), kept.key());
  // The kept pieces serve an edit as the copied ones do.
  StripLines taken = l.extract(*f.index, f.seeds, {{300, 340}}, &pieces);
  StripLines fresh = f.whole();
  expect_same(taken, fresh);
  StripLines partial(l.grid, *f.index, l.request);
  partial.add(l.rows(f.seeds, 0, 10));
  EXPECT_THROW(partial.keep_pieces(), Error);  // rows missing
  StripLines late = f.whole();
  late.take_boundaries();
  EXPECT_THROW(late.keep_pieces(), Error);  // a take before
}

TEST(LinePieces, DamagedOrForeignPiecesAreRefused) {
  const Spec spec;
  Lines l = planar_lines(spec);
  const SeedSet seeds = make_seeds(4, spec, 1.0, {0.0, 0.0});
  const auto metric = l.metric_of(seeds);
  const OwnerIndex index(*metric);
  StripLines whole = l.extract(index, seeds, {{0, l.grid.height}});
  const std::string bytes = whole.pieces().encode();
  EXPECT_THROW(LinePieces::decode(bytes.substr(0, bytes.size() - 3)), Error);
  EXPECT_THROW(LinePieces::decode(bytes + "x"), Error);
  EXPECT_THROW(LinePieces::decode("rvoronoi-seeds"), Error);
  std::string bad = bytes;
  bad[14] = static_cast<char>(bad[14] + 1);  // the version
  EXPECT_THROW(LinePieces::decode(bad), Error);
  // Pieces of another request (other limit distances) are not taken.
  l.request.limit_distances = {3.0};
  StripLines other(l.grid, index, l.request);
  EXPECT_THROW(other.take_rows(LinePieces::decode(bytes), 10), Error);
  EXPECT_THROW(other.take_rows(LinePieces(), 10), Error);
  // Nor rows already in, nor rows beyond the grid.
  l.request.limit_distances = {3.0, 7.5};
  StripLines same(l.grid, index, l.request);
  EXPECT_THROW(same.take_rows(LinePieces::decode(bytes), l.grid.height + 1), Error);
  same.take_rows(LinePieces::decode(bytes), 10);
  EXPECT_THROW(same.take_rows(LinePieces::decode(bytes), 10), Error);
  EXPECT_THROW(same.pieces(), Error);  // rows missing
}

// Pieces whose numbers were changed with care (the bytes still decode: a base's checksum can be
// written anew by anyone) are refused when taken, since each vertex taken must be what the seeds
// measure at it: a crossing moved along its edge or off it, a distance or a residual changed.
TEST(LinePieces, PiecesThatAreNotWhatTheSeedsMeasureAreRefused) {
  const PlanarField f(4);
  const Lines& l = f.l;
  const OwnerIndex& index = *f.index;
  const int64_t H = f.H;
  StripLines whole = f.whole();
  const std::string bytes = whole.pieces().encode();
  // The layout (line_pieces.cpp): magic, version, key, width, height, one boundary, then its
  // crossings (count, then 73 bytes each: edge, two owners, vertex p.x p.y, sites, distance,
  // residual, distance_a, distance_b, arc).
  const size_t crossings = 14 + 4 + 8 + whole.key().size() + 8 + 8 + 8;
  uint64_t n = 0;
  std::memcpy(&n, bytes.data() + crossings, 8);
  ASSERT_GT(n, 10u);
  auto at = [&](size_t i, size_t field) { return crossings + 8 + 73 * i + field; };
  auto taken = [&](const std::string& b) {
    StripLines lines(l.grid, index, l.request);
    lines.take_rows(LinePieces::decode(b), H);
    return true;
  };
  EXPECT_TRUE(taken(bytes));
  struct Change {
    size_t field;  // offset in the crossing's record
    double delta;
    const char* what;
  };
  for (const Change& c : {Change{16, 3.0, "p.x, off its edge or along it"}, Change{24, 0.25, "p.y"},
                          Change{16, 1e-6, "p.x by a millionth of a cell"}, Change{56, 1e-3, "distance_a"},
                          Change{48, 0.5, "residual"}}) {
    for (const size_t i : {size_t{0}, static_cast<size_t>(n / 2), static_cast<size_t>(n - 1)}) {
      SCOPED_TRACE(std::string(c.what) + ", crossing " + std::to_string(i));
      std::string bad = bytes;
      double v = 0.0;
      std::memcpy(&v, bad.data() + at(i, c.field), 8);
      v += c.delta;
      std::memcpy(bad.data() + at(i, c.field), &v, 8);
      try {
        taken(bad);
        ADD_FAILURE() << "taken";
      } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
        EXPECT_NE(std::string(e.what()).find("do not fit its seeds"), std::string::npos) << e.what();
      }
    }
  }
}

// The base's lines and pieces, an edit of its seeds, and the edit's lines taken from the base
// where Edit::line_rows allows, against a fresh extraction of the edited seeds.
void check_edit(const Lines& l, const SeedSet& base, const SeedSet& edited, const std::string& what,
                bool expect_rows_taken = true) {
  SCOPED_TRACE(what);
  const int64_t H = l.grid.height;
  const auto base_metric = l.metric_of(base);
  const OwnerIndex base_index(*base_metric);
  StripLines base_lines = l.extract(base_index, base, {{0, H}});
  const LinePieces pieces = base_lines.pieces();
  // Their bytes in memory, counted without encoding: none for no pieces; a decoded copy holds the
  // same arrays at their sizes, never more than the extraction's capacities.
  EXPECT_EQ(LinePieces().memory_bytes(), 0);
  EXPECT_GT(pieces.memory_bytes(), static_cast<int64_t>(pieces.key().size()));
  EXPECT_LE(LinePieces::decode(pieces.encode()).memory_bytes(), pieces.memory_bytes());
  base_lines.keep_refined();
  base_lines.take_boundaries();
  base_lines.take_limits();
  const RefinedSegments refined = base_lines.refined();
  EXPECT_GT(refined.segments(), 100);
  EXPECT_EQ(refined.segments_taken(), 0);
  const NearestField base_field = rv::compute(base, l.grid, l.compute);
  TileSummaries tiles = TileSummaries::for_grid(l.grid);
  tiles.add(base_field.site.data(), base_field.distance.data(), 0, H, l.grid.width, base);
  const Edit edit(base, edited, l.grid, l.compute);
  double floor = 0.0;
  if (l.request.limit.per_owner)
    for (double d : l.request.limit_distances) floor = std::max(floor, d);
  const std::vector<LinePieces> kept{LinePieces::decode(pieces.encode())};
  const auto fed = edit.line_rows(tiles, kept, floor);
  // The bands from the edit's plan (what a session passes: those its mask meets) are among the
  // bands worked out without it (every band of a tile the plan reads), and the rows from given
  // bands the rows.
  const EditPlan plan = edit.plan(base_field, &tiles);
  const std::vector<uint8_t> near = edit.line_tiles(tiles, floor, &plan);
  const std::vector<uint8_t> without_plan = edit.line_tiles(tiles, floor);
  ASSERT_EQ(near.size(), without_plan.size());
  for (size_t k = 0; k < near.size(); ++k) ASSERT_EQ(near[k] & ~without_plan[k], 0) << "tile " << k;
  EXPECT_EQ(edit.line_rows(without_plan, kept), fed);
  EXPECT_THROW(edit.line_rows(std::vector<uint8_t>(near.size() + 1, 0), kept), Error);
  // The rows of the plan's bands, taken where the others are not, give the fresh lines too.
  {
    const std::vector<std::pair<int64_t, int64_t>> fed_by_plan = edit.line_rows(near, kept);
    int64_t rows_by_plan = 0, rows_without = 0;
    for (const auto& [a, b] : fed_by_plan) rows_by_plan += b - a;
    for (const auto& [a, b] : fed) rows_without += b - a;
    EXPECT_LE(rows_by_plan, rows_without);
    const auto metric = l.metric_of(edited);
    const OwnerIndex index(*metric);
    const ChangedTiles by_plan{TileSummaries::kTile, near};
    StripLines banded = l.extract(index, edited, fed_by_plan, &pieces, edit.site_map(), &by_plan);
    banded.keep_refined(refined, by_plan, edit.site_map());
    StripLines fresh = l.extract(index, edited, {{0, H}});
    expect_same(banded, fresh);
  }
  int64_t fed_rows = 0;
  for (const auto& [a, b] : fed) fed_rows += b - a;
  if (expect_rows_taken) {
    EXPECT_LT(fed_rows, H);
  }
  const auto metric = l.metric_of(edited);
  const OwnerIndex index(*metric);
  StripLines taken = l.extract(index, edited, fed, &pieces, edit.site_map());
  // The refinement too: the segments away from the rows fed taken from the base's.
  taken.keep_refined(refined, ChangedTiles{TileSummaries::kTile, edit.line_tiles(tiles, floor)}, edit.site_map());
  StripLines fresh = l.extract(index, edited, {{0, H}});
  expect_same(taken, fresh);
  // And the fed rows' crossings and limit vertices on edges the edit left unchanged taken from the
  // base's pieces instead of placed again: the same lines.
  const ChangedTiles changed{TileSummaries::kTile, near};
  StripLines measured = l.extract(index, edited, fed, &pieces, edit.site_map(), &changed);
  StripLines fresh_again = l.extract(index, edited, {{0, H}});
  expect_same(measured, fresh_again);
  if (expect_rows_taken && !fed.empty()) {
    EXPECT_GT(measured.vertices_taken(), 0);
  }
  // Decoded pieces are placed, not taken; a base of another extraction, tiles that do not cover
  // the grid, and a call after the first row are refused.
  StripLines decoded(l.grid, index, l.request);
  decoded.take_measured(kept.front(), changed, edit.site_map());
  decoded.add(l.rows(edited, 0, 2));
  EXPECT_EQ(decoded.vertices_taken(), 0);
  EXPECT_THROW(decoded.take_measured(pieces, changed, edit.site_map()), Error);
  StripLines uncovered_tiles(l.grid, index, l.request);
  EXPECT_THROW(uncovered_tiles.take_measured(pieces, ChangedTiles{TileSummaries::kTile, {}}), Error);
  const RefinedSegments now = taken.refined();
  if (expect_rows_taken) {
    EXPECT_GT(now.segments_taken(), 0);
  }
  // Every segment where no row is fed (nothing changed); else those near the changed tiles
  // refined.
  if (fed.empty()) {
    EXPECT_EQ(now.segments_taken(), now.segments());
  } else {
    EXPECT_LT(now.segments_taken(), now.segments());
  }
  // Refined segments of another extraction are refused.
  LineRequest other = l.request;
  other.limit_distances = {3.0};
  StripLines foreign(l.grid, index, other);
  EXPECT_THROW(foreign.keep_refined(refined, ChangedTiles{TileSummaries::kTile, edit.line_tiles(tiles, floor)}), Error);
  EXPECT_THROW(foreign.take_measured(pieces, changed), Error);
  StripLines uncovered(l.grid, index, l.request);
  EXPECT_THROW(uncovered.keep_refined(refined, ChangedTiles{TileSummaries::kTile, {}}), Error);
}

// Edits of one kind each, and several at once, of seed sets spread over three bands of tiles.
void check_edits(const Lines& l, uint32_t seed, double scale, Vec2 origin) {
  const Spec spec;
  const SeedSet base = make_seeds(seed, spec, scale, origin);
  auto rebuild = [&](auto&& change) {
    SeedSet out;
    for (size_t f = 0; f < base.features().size(); ++f) change(out, static_cast<int32_t>(f));
    return out;
  };
  // Copies feature f of the base into `out` (its sites moved by `shift`, its owner `owner`).
  auto copy = [&](SeedSet& out, int32_t f, Vec2 shift = {0.0, 0.0}, std::string owner = "") {
    const Feature& feat = base.features()[static_cast<size_t>(f)];
    const int32_t nf = out.add_feature(
        out.owner_code(owner.empty() ? base.owner_labels()[static_cast<size_t>(feat.owner - 1)] : owner));
    bool island = false;
    for (const Polygon& p : base.polygons())
      if (p.feature == f) {
        std::vector<std::vector<Vec2>> rings = p.rings;
        for (auto& r : rings)
          for (Vec2& v : r) v = Vec2{v.x + shift.x, v.y + shift.y};
        out.add_polygon(nf, rings);
        island = true;
      }
    if (island) return;
    std::vector<Vec2> line;
    for (const Site& s : base.sites()) {
      if (s.feature != f) continue;
      const Vec2 a{s.a.x + shift.x, s.a.y + shift.y}, b{s.b.x + shift.x, s.b.y + shift.y};
      if (s.kind == SiteKind::point) out.add_point(nf, a);
      if (s.kind == SiteKind::segment) {
        if (line.empty()) line.push_back(a);
        line.push_back(b);
      }
    }
    if (!line.empty()) out.add_polyline(nf, line);
  };
  const double step = 1.5 * scale;
  // A point feature in the grid's top band (not its owner's first feature: the owners keep their
  // order of codes).
  int32_t point = -1;
  for (const Site& s : base.sites())
    if (point < 0 && s.feature >= 8 && s.kind == SiteKind::point &&
        std::abs(s.a.y - (origin.y + 600.0 * scale)) < 60.0 * scale)
      point = s.feature;
  ASSERT_GE(point, 0);
  check_edit(l, base, rebuild([&](SeedSet& o, int32_t f) {
               copy(o, f, f == point ? Vec2{step, -step} : Vec2{});
             }),
             "a point moved");
  check_edit(l, base, rebuild([&](SeedSet& o, int32_t f) {
               if (f != point) copy(o, f);
             }),
             "a point removed");
  check_edit(l, base, rebuild([&](SeedSet& o, int32_t f) {
               copy(o, f);
               if (f == point) copy(o, f, Vec2{2.0 * step, step}, "o3");
             }),
             "a point added");
  check_edit(l, base, rebuild([&](SeedSet& o, int32_t f) { copy(o, f, {}, f == point ? "o2" : ""); }),
             "an owner changed");
  const int32_t line = 1;  // a coastline (features 1, 6, 11, ... are lines)
  check_edit(l, base, rebuild([&](SeedSet& o, int32_t f) {
               if (f != line) copy(o, f);
             }),
             "a coastline removed", false);
  check_edit(l, base, rebuild([&](SeedSet& o, int32_t f) {
               if (f == 7) return;  // an island removed, one point moved, another added
               copy(o, f, f == point + 4 ? Vec2{-step, 0.0} : Vec2{});
               if (f == 3) copy(o, f, Vec2{step, step}, "o4");
             }),
             "several at once", false);
  check_edit(l, base, base, "nothing changed");
}

TEST(LinePieces, PlanarEditsTakeTheBasesRowsAndEqualAFreshExtraction) {
  Lines l = planar_lines(Spec{});
  for (uint32_t seed : {5u, 9u}) check_edits(l, seed, 1.0, {0.0, 0.0});
  l.request.limit.per_owner = true;
  check_edits(l, 13u, 1.0, {0.0, 0.0});
}

TEST(LinePieces, EditsWithAMaxDistanceTakeTheBasesRows) {
  const Lines l = planar_lines(Spec{}, 14.0);
  check_edits(l, 21u, 1.0, {0.0, 0.0});
}

TEST(LinePieces, GeodesicEditsTakeTheBasesRows) {
  // 0.005 degree cells around 12 E 55 N.
  const Spec spec;
  Lines l = planar_lines(spec);
  l.grid = test::grid_of(static_cast<int64_t>(spec.w), static_cast<int64_t>(spec.h), 0.005, 11.0, 57.0);
  l.compute.metric.kind = MetricSpec::geodesic;
  l.request.limit_distances = {1500.0, 4000.0};
  check_edits(l, 31u, 0.005, {11.0, 57.0 - 0.005 * spec.h});
}

TEST(LinePieces, WeightedSeedsExtractEveryRow) {
  const Spec spec;
  const Lines l = planar_lines(spec);
  SeedSet base = make_seeds(41, spec, 1.0, {0.0, 0.0});
  SeedSet weighted = base;
  weighted.set_adjustment(0, 2.0, kInf);
  const Edit edit(base, weighted, l.grid, l.compute);
  const auto metric = l.metric_of(base);
  const OwnerIndex index(*metric);
  const LinePieces pieces = l.extract(index, base, {{0, l.grid.height}}).pieces();
  TileSummaries tiles = TileSummaries::for_grid(l.grid);
  const auto fed = edit.line_rows(tiles, std::vector<LinePieces>{pieces}, 0.0);
  ASSERT_EQ(fed.size(), 1u);
  EXPECT_EQ(fed[0], (std::pair<int64_t, int64_t>{0, l.grid.height}));
}

}  // namespace
}  // namespace rv
