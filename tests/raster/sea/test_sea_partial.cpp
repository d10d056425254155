// Partial effect by sea (rv/lines/partial_effect.hpp with the engines by sea as its
// PartialEngines): the two fields and their lines by sea, the rule between the lines, and the
// partial line followed through the band where land cuts it (lines/locus_follow.hpp).
// - The rays of the straight case (test_partial_effect.cpp) with land beyond a coast they meet:
//   the sea is convex, so every sea cell is the straight rule's; the partial line is the ray at
//   220 degrees (half effect; 209.69 at a quarter) and ends on the coast where that ray meets it.
// - An island of B's astride the nil-effect line (coasts as seeds, land as barriers): the nil
//   line stops at the island's coasts; every cell is the rule at its centre (fields computed
//   alone, distances to the lines measured here), the reference engines give the same field, and
//   the partial line lies on the locus, ends on coasts only on a barrier's edge and never crosses
//   land.
// - A port of X's that the island shuts in at full effect: the full line wholly in the band, the
//   locus found where the rule's cells change owner and followed from there.
// - A small island whose zone at full effect takes a stretch of X's coast: the full line in two
//   pieces, the locus one line through both bands, in front of the coast.
// Every layout also checks that each two neighbouring cells the rule gives to B and to X have a
// B-X line between them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include "line_compare.hpp"
#include "partial_rays.hpp"
#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/partial_effect.hpp"
#include "rv/lines/regions.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/sea_metric.hpp"
#include "rv/sea/visibility.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

using namespace test::rays;

// The engines by sea over `barriers` and `grid`: exact, or the reference (brute force).
PartialEngines by_sea(const Barriers& barriers, const GridSpec& grid, bool reference = false) {
  PartialEngines e;
  e.field = [&barriers, &grid, reference](const SeedSet& s, bool) {
    return (reference ? brute_force_sea(s, barriers, grid, grid.full_window())
                      : compute_sea(s, barriers, grid, grid.full_window()))
        .field;
  };
  e.metric = [&barriers, &grid](const SeedSet& s, const NearestField&, bool) {
    return make_sea_site_metric(s, barriers, grid);
  };
  return e;
}

// Land beyond the coast 40 km from O across azimuth 220: the points p with (p - O).u >= 40 km.
constexpr double kCoast = 40000.0;
Barriers land_at_220() {
  const Vec2 u{std::sin(220.0 * kDeg), std::cos(220.0 * kDeg)}, v{u.y, -u.x};
  auto at = [&](double along, double across) {
    return Vec2{kO.x + along * u.x + across * v.x, kO.y + along * u.y + across * v.y};
  };
  Barriers b;
  b.add_polygon({{at(kCoast, -300000.0), at(kCoast, 300000.0), at(400000.0, 300000.0), at(400000.0, -300000.0)}},
                "coast");
  return b;
}

void check_rays_to_the_coast(double e, double island_azimuth = 170.0) {
  const Barriers land = land_at_220();
  const SeedSet s = rays(e, island_azimuth);
  const PartialEffectResult sea =
      compute_partial_effect(s, kGrid, ComputeOptions{}, BoundaryOptions{}, true, by_sea(land, kGrid));
  const PartialEffectResult straight = compute_partial_effect(s, kGrid, ComputeOptions{}, BoundaryOptions{});
  ASSERT_TRUE(sea.rule);
  EXPECT_EQ(sea.stats.coast_ends, 1);
  // The partial ray and where it meets the coast (the coast's normal is the ray at 220).
  const double full = (310.0 + island_azimuth) / 2.0, az = locus_azimuth(e, full - 200.0);
  const Vec2 end = toward(az, kCoast / std::cos((220.0 - az) * kDeg));
  const Vec2 u{std::sin(az * kDeg), std::cos(az * kDeg)};
  // The rule measures distances to the lines as drawn, which stop at the coast: the partial ray
  // is the closed form where a point's feet on both rays lie before their ends on the coast.
  auto feet_on_both = [&](Vec2 p) {
    const double r = std::hypot(p.x - kO.x, p.y - kO.y), a = azimuth_of(p);
    return r * std::cos((a - 200.0) * kDeg) <= kCoast / std::cos(20.0 * kDeg) &&
           r * std::cos((full - a) * kDeg) <= kCoast / std::cos((220.0 - full) * kDeg);
  };
  int64_t on_ray = 0, ends_on_coast = 0;
  for (const BoundaryLine& line : sea.boundaries.lines)
    for (const BoundaryVertex& v : line.vertices) {
      const Vec2 q{v.p.x - kO.x, v.p.y - kO.y};
      if (std::hypot(q.x, q.y) < 1e-6 || q.x * u.x + q.y * u.y <= 0.0) continue;
      if (v.on_barrier) ++ends_on_coast;
      if (!feet_on_both(v.p)) continue;
      ++on_ray;
      EXPECT_LT(std::abs(q.x * u.y - q.y * u.x), 1e-5) << "vertex at azimuth " << azimuth_of(v.p);
      if (v.on_barrier) {
        EXPECT_LT(std::hypot(v.p.x - end.x, v.p.y - end.y), 1e-4) << v.p.x << ", " << v.p.y;
      }
    }
  EXPECT_GT(on_ray, 40);
  EXPECT_EQ(ends_on_coast, 1);
  EXPECT_LT(sea.stats.max_residual, 1e-6);
  EXPECT_EQ(sea.stats.residual.unresolved, 0);
  // The sea is convex: every sea cell is the straight rule's, land cells are no one's.
  const Visibility vis(land);
  int64_t sea_cells = 0, land_cells = 0;
  for (int64_t row = 0; row < kGrid.height; ++row)
    for (int64_t col = 0; col < kGrid.width; ++col) {
      const Vec2 p{kGrid.centre_x(col), kGrid.centre_y(row)};
      if (vis.on_land(p)) {
        ++land_cells;
        ASSERT_EQ(sea.field.site.at(col, row), kNoSite) << col << "," << row;
        continue;
      }
      ++sea_cells;
      ASSERT_EQ(sea.field.site.at(col, row), straight.field.site.at(col, row)) << col << "," << row;
      ASSERT_EQ(sea.field.distance.at(col, row), straight.field.distance.at(col, row)) << col << "," << row;
    }
  EXPECT_GT(land_cells, 1000);
  EXPECT_GT(sea_cells, 5000);
}

TEST(SeaPartial, HalfEffectIsTheMedianRayToTheCoast) { check_rays_to_the_coast(0.5); }

TEST(SeaPartial, QuarterEffectIsItsRayToTheCoast) { check_rays_to_the_coast(0.25); }

// The two lines parting at 3 degrees (the island at azimuth 96, beside B's mainland): the locus
// is found in the narrow wedge between them, the ray at 201.5 degrees as far as the full line
// runs (it meets the coast first; beyond, the rule measures to its end).
TEST(SeaPartial, LinesPartingAtASmallAngleGiveTheirRayToo) {
  EXPECT_NEAR(locus_azimuth(0.5, 3.0), 201.5, 1e-9);
  check_rays_to_the_coast(0.5, 96.0);
}

// The distance from p to a polyline (straight).
double to_polyline(Vec2 p, const std::vector<BoundaryVertex>& v) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k + 1 < v.size(); ++k) {
    const Vec2 a = v[k].p, b = v[k + 1].p;
    const double dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
    const double t = len2 > 0.0 ? std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / len2, 0.0, 1.0) : 0.0;
    best = std::min(best, std::hypot(a.x + t * dx - p.x, a.y + t * dy - p.y));
  }
  if (v.size() == 1) best = std::hypot(v[0].p.x - p.x, v[0].p.y - p.y);
  return best;
}

double to_lines(Vec2 p, const BoundaryResult& r, int32_t a, int32_t b) {
  double best = std::numeric_limits<double>::infinity();
  for (const BoundaryLine& l : r.lines)
    if ((l.owner_a == a && l.owner_b == b) || (l.owner_a == b && l.owner_b == a))
      best = std::min(best, to_polyline(p, l.vertices));
  return best;
}

// X's coast in the west, B's in the east (both seeds and land), B's island of half effect astride
// the median between them (land, and a seed at full effect).
struct Strait {
  SeedSet seeds;
  Barriers land;
  std::vector<std::vector<Vec2>> coasts;  // the three outlines
};

// The distance from p to the nearest coast (the outlines' edges).
double to_coast(Vec2 p, const Strait& s) {
  double best = std::numeric_limits<double>::infinity();
  for (const std::vector<Vec2>& ring : s.coasts) {
    std::vector<BoundaryVertex> closed;
    for (const Vec2 q : ring) closed.push_back(BoundaryVertex{q});
    closed.push_back(BoundaryVertex{ring.front()});
    best = std::min(best, to_polyline(p, closed));
  }
  return best;
}
// `ports`: X's and B's mainland seeds are ports on their coasts, not the coasts (X's: one, or
// with `two_ports` two, north and south).
Strait strait(const std::vector<Vec2>& island, bool ports = false, double effect = 0.5, bool two_ports = false) {
  Strait s;
  const int32_t x = s.seeds.owner_code("X"), b = s.seeds.owner_code("B");
  const std::vector<Vec2> west{{0, 0}, {8, 0}, {9, 20}, {7, 40}, {0, 40}};
  const std::vector<Vec2> east{{40, 0}, {32, 0}, {31, 18}, {33, 40}, {40, 40}};
  if (ports) {
    if (two_ports) {
      const int32_t f = s.seeds.add_feature(x);
      s.seeds.add_point(f, {8.25, 4});
      s.seeds.add_point(f, {7.45, 36});
    } else {
      s.seeds.add_point(s.seeds.add_feature(x), {9, 20});
    }
    s.seeds.add_point(s.seeds.add_feature(b), {31, 18});
  } else {
    s.seeds.add_polygon(s.seeds.add_feature(x), {west});
    s.seeds.add_polygon(s.seeds.add_feature(b), {east});
  }
  const int32_t f = s.seeds.add_feature(b);
  s.seeds.add_polygon(f, {island});
  s.seeds.set_effect(f, effect);
  s.land.add_polygon({west}, "west");
  s.land.add_polygon({east}, "east");
  s.land.add_polygon({island}, "island");
  s.coasts = {west, east, island};
  return s;
}

// Every cell is the rule at its centre (the two fields computed alone, the distances to the two
// lines measured here), the reference engines give the same field, and the partial line lies on
// the locus, ends on a coast only on a barrier's edge and never crosses land. Returns the lines'
// statistics, and how many ends of nil-effect lines lie on barriers.
struct Checked {
  PartialLineStats stats;
  int64_t nil_ends_on_land = 0;
  int64_t closed_lines = 0;      // rings among the lines
  int64_t bx_lines = 0;          // B-X lines drawn
  int64_t full_bx_on_coast = 0;  // ends of the full-effect B-X lines on a coast
};
Checked check_rule_and_line(const Strait& s) {
  const GridSpec g = test::grid_of(160, 160, 0.25);
  const PartialEffectResult r =
      compute_partial_effect(s.seeds, g, ComputeOptions{}, BoundaryOptions{}, true, by_sea(s.land, g));
  if (!r.rule) {
    ADD_FAILURE() << "no rule";
    return {};
  }
  const int32_t B = 2, X = 1;

  // Every cell: the rule at its centre from the two fields computed alone and the distances to
  // the two lines measured here.
  std::vector<bool> partial(s.seeds.features().size(), false);
  partial[2] = true;
  std::vector<int32_t> site_of;
  const SeedSet nil_seeds = s.seeds.without(partial, site_of);
  const NearestField full = compute_sea(s.seeds, s.land, g, g.full_window()).field;
  const NearestField nil = compute_sea(nil_seeds, s.land, g, g.full_window()).field;
  int64_t band = 0, given_back = 0;
  for (int64_t row = 0; row < g.height; ++row)
    for (int64_t col = 0; col < g.width; ++col) {
      const int32_t fs = full.site.at(col, row), ns = nil.site.at(col, row);
      const int32_t got = r.field.site.at(col, row);
      if (fs == kNoSite) {
        EXPECT_EQ(got, kNoSite);
        continue;
      }
      const bool in_band = s.seeds.site_owner(fs) == B && nil_seeds.site_owner(ns) == X;
      if (!in_band) {
        EXPECT_EQ(got, fs) << col << "," << row;
        continue;
      }
      ++band;
      const Vec2 p{g.centre_x(col), g.centre_y(row)};
      const double d0 = to_lines(p, r.rule->nil_lines(), X, B), d1 = to_lines(p, r.rule->full_lines(), X, B);
      const double e = r.rule->effect().effect, balance = e * d1 - (1.0 - e) * d0;
      if (std::abs(balance) < 1e-9) continue;
      const int32_t expected = balance > 0.0 ? fs : site_of[static_cast<size_t>(ns)];
      given_back += balance < 0.0;
      EXPECT_EQ(got, expected) << col << "," << row << " balance " << balance;
    }
  EXPECT_GT(band, 200);
  EXPECT_GT(given_back, 50);
  EXPECT_LT(given_back, band);

  // The reference engines give the same field.
  const PartialEffectResult ref =
      compute_partial_effect(s.seeds, g, ComputeOptions{}, BoundaryOptions{}, false, by_sea(s.land, g, true));
  EXPECT_EQ(ref.field.site.cells(), r.field.site.cells());
  EXPECT_EQ(ref.field.distance.cells(), r.field.distance.cells());

  // The partial line: on the locus in the band, on a barrier's edge where it ends on a coast,
  // never across land.
  int64_t on_locus = 0, coast_ends = 0;
  for (const BoundaryLine& l : r.boundaries.lines) {
    for (size_t k = 0; k < l.vertices.size(); ++k) {
      const BoundaryVertex& v = l.vertices[k];
      if (k > 0) {
        EXPECT_TRUE(r.metric->open_between(l.vertices[k - 1].p, v.p)) << v.p.x << ", " << v.p.y;
      }
      if (v.on_barrier) {
        ++coast_ends;
        EXPECT_LT(to_coast(v.p, s), 1e-9) << v.p.x << ", " << v.p.y;
      }
      if (owner_at(*r.index, v.p) == B && owner_at(*r.nil_index, v.p) == X && !v.on_barrier) {
        ++on_locus;
        EXPECT_LT(std::abs(r.rule->balance(v.p, X)), 1e-6) << v.p.x << ", " << v.p.y;
      }
    }
  }
  EXPECT_GT(on_locus, 20);
  // Every two neighbouring sea cells the rule gives to B and to X, in sight of each other, have a
  // B-X line between their centres (no piece of the locus left undrawn).
  const int64_t pairs = test::expect_lines_between(r.field, s.seeds, g, r.boundaries, B, X,
                                                   [&](Vec2 p, Vec2 q) { return r.metric->open_between(p, q); });
  EXPECT_GT(pairs, 20);
  // (Each coast end of a partial stretch is a line's end on a barrier; the full lines' own such
  // ends outside the bands stay.)
  EXPECT_LE(r.stats.coast_ends, coast_ends);
  EXPECT_EQ(r.stats.residual.unresolved, 0);
  Checked out{r.stats};
  auto bx = [&](const BoundaryLine& l) { return std::minmax(l.owner_a, l.owner_b) == std::minmax(B, X); };
  for (const BoundaryLine& l : r.boundaries.lines) {
    out.closed_lines += l.closed;
    out.bx_lines += bx(l);
  }
  for (const BoundaryLine& l : r.rule->full_lines().lines)
    if (bx(l)) out.full_bx_on_coast += l.vertices.front().on_barrier + l.vertices.back().on_barrier;
  for (const BoundaryLine& l : r.rule->nil_lines().lines)
    out.nil_ends_on_land += l.vertices.front().on_barrier + l.vertices.back().on_barrier;
  return out;
}

// The nil line stops at the island's coasts; the partial line passes the island at sea.
TEST(SeaPartial, AnIslandAstrideTheNilLineCutsItAndTheRuleHoldsEverywhere) {
  const Strait s = strait({{18, 17}, {23, 18}, {22, 23}, {17, 22}});
  const Checked c = check_rule_and_line(s);
  EXPECT_GE(c.nil_ends_on_land, 2);
  EXPECT_EQ(c.stats.coast_ends, 0);
  EXPECT_EQ(c.stats.stretches, 1);
}

// A wide island: the partial locus meets its coast, and the line is cut there into two, each
// ending on the coast.
TEST(SeaPartial, AWideIslandCutsThePartialLineAtItsCoast) {
  const Strait s = strait({{13, 16}, {23, 18}, {22, 24}, {14, 23}});
  const PartialLineStats st = check_rule_and_line(s).stats;
  EXPECT_EQ(st.coast_ends, 2);
  EXPECT_EQ(st.stretches, 2);
}

// Ports as seeds: the island's zone at full effect reaches X's coast between X's two ports, so
// the full line comes in two pieces, each from X's coast to where it rejoins the nil line; each
// band's locus runs from that turning point to X's coast.
TEST(SeaPartial, AFullLineEndingOnTheNeighboursCoastGivesLociEndingThere) {
  const Strait s = strait({{11, 17}, {15, 18}, {14, 23}, {11, 22}}, true, 0.5, true);
  const PartialLineStats st = check_rule_and_line(s).stats;
  EXPECT_EQ(st.coast_ends, 2);
  EXPECT_EQ(st.stretches, 2);
}

// A small island near X's coast between X's two ports: at full effect its zone takes a stretch of
// that coast, so the full line comes in two pieces, each from a turning point to X's coast; at
// effect 0.3 the locus passes in front of the coast, from one piece's band into the other's (the
// band is one). It is one line from turning point to turning point, through both bands, with no
// end on a coast (before, the walk from the first turning point left the first piece's band and
// the lines were refused, as Fehmarn's by sea between DE and DK).
TEST(SeaPartial, ALocusPassingWhereACoastCutTheFullLineRunsOnIntoItsOtherPiece) {
  const Strait s = strait({{12.5, 19.5}, {13, 19.5}, {13, 20.5}, {12.5, 20.5}}, true, 0.3, true);
  const Checked c = check_rule_and_line(s);
  EXPECT_EQ(c.full_bx_on_coast, 2);
  EXPECT_EQ(c.bx_lines, 1);
  EXPECT_EQ(c.stats.stretches, 1);
  EXPECT_EQ(c.stats.coast_ends, 0);
  EXPECT_EQ(c.closed_lines, 0);
}

// One port of X's, shut in by the island at full effect: the full line is an arc from X's coast
// to X's coast round the port, wholly in the band, with no turning point to follow the locus
// from. The arc is no boundary under the rule (the cells beside it go back to X); the locus,
// near the nil line at effect 0.1, is found where the rule's cells change owner and followed both
// ways to the frame: every cell is the rule's, every vertex on the locus, and every pair of
// neighbouring cells the rule gives to B and to X has a B-X line between their centres.
TEST(SeaPartial, AFullLineWhollyInTheBandGivesTheLocusFoundFromTheCells) {
  const Strait s = strait({{11, 17}, {15, 18}, {14, 23}, {11, 22}}, true, 0.1);
  const Checked c = check_rule_and_line(s);
  EXPECT_EQ(c.stats.stretches, 1);
  EXPECT_EQ(c.stats.coast_ends, 0);
  EXPECT_GT(c.stats.points, 100);
}

// The same island shutting in the port, at effect 0.6: the locus now lies nearer the arc, and
// runs from X's coast to the island's on either side of it (two lines, four ends on coasts).
TEST(SeaPartial, ALocusFoundFromTheCellsEndsOnTheCoast) {
  const Strait s = strait({{11, 17}, {15, 18}, {14, 23}, {11, 22}}, true, 0.6);
  const Checked c = check_rule_and_line(s);
  EXPECT_EQ(c.stats.stretches, 2);
  EXPECT_EQ(c.stats.coast_ends, 4);
}

// An enclave: the island lies between X's coast and an islet of X's, so at full effect its zone
// is a ring round it inside X's zone (a closed full line, all band). At effect 0.95 the locus is
// a smaller ring round the island, found from the cells and followed round to where it began.
TEST(SeaPartial, AnEnclaveGivesAClosedLocus) {
  Strait s = strait({{11.5, 19}, {12.5, 19}, {12.5, 21}, {11.5, 21}}, false, 0.95);
  s.seeds.add_point(s.seeds.add_feature(s.seeds.owner_code("X")), {16, 20});
  const Checked c = check_rule_and_line(s);
  EXPECT_EQ(c.stats.stretches, 1);
  EXPECT_EQ(c.stats.coast_ends, 0);
  EXPECT_EQ(c.closed_lines, 1);
}

// The same enclave at half effect: the rule gives the whole ring back to X, so the ring is no
// line and nothing is drawn in its place (only the B-X line between the mainlands, far east);
// every cell is still the rule's, and every B-X change of owner has its line.
TEST(SeaPartial, AnEnclaveGivenBackWholeDrawsNoRing) {
  Strait s = strait({{11.5, 19}, {12.5, 19}, {12.5, 21}, {11.5, 21}}, false, 0.5);
  s.seeds.add_point(s.seeds.add_feature(s.seeds.owner_code("X")), {16, 20});
  const GridSpec g = test::grid_of(160, 160, 0.25);
  const PartialEffectResult r =
      compute_partial_effect(s.seeds, g, ComputeOptions{}, BoundaryOptions{}, true, by_sea(s.land, g));
  ASSERT_TRUE(r.rule);
  const int32_t B = 2, X = 1;
  int64_t enclave = 0;
  for (size_t i = 0; i < r.field.site.cells().size(); ++i) {
    const int32_t fs = r.full.site.cells()[i];
    if (fs == kNoSite || !r.rule->effect().partial[static_cast<size_t>(s.seeds.site_feature(fs))]) continue;
    ++enclave;
    EXPECT_EQ(s.seeds.site_owner(r.field.site.cells()[i]), X) << i;
  }
  EXPECT_GT(enclave, 100);
  EXPECT_EQ(r.stats.stretches, 0);
  for (const BoundaryLine& l : r.boundaries.lines) {
    EXPECT_FALSE(l.closed);
    for (const BoundaryVertex& v : l.vertices) EXPECT_GT(v.p.x, 17.0) << v.p.x << ", " << v.p.y;
  }
  EXPECT_GT(test::expect_lines_between(r.field, s.seeds, g, r.boundaries, B, X,
                                       [&](Vec2 p, Vec2 q) { return r.metric->open_between(p, q); }),
            100);
}

// An island far from its owner's nil-effect lines, by sea (as Bornholm): three neighbours' ports
// round it, B's mainland coast far north, the island land in both runs. At half effect the rule
// gives its whole zone back, so the result is the nil-effect run's: the same owner in every cell,
// the neighbours' lines their nil-effect lines by sea (ending on the island's coast, where the
// island is land), the same tripoints, and no line left round the island.
TEST(SeaPartial, AnIslandGivenBackWholeHasTheNilEffectLinesBySea) {
  SeedSet s;
  const int32_t x = s.owner_code("X"), y = s.owner_code("Y"), z = s.owner_code("Z"), b = s.owner_code("B");
  s.add_point(s.add_feature(x), Vec2{20.0, 30.0});
  s.add_point(s.add_feature(y), Vec2{11.0, 15.0});
  s.add_point(s.add_feature(z), Vec2{29.0, 15.0});
  s.add_polyline(s.add_feature(b), std::vector<Vec2>{{-80.0, 50.0}, {120.0, 50.0}});
  const std::vector<Vec2> ring{{19.0, 19.0}, {21.0, 19.0}, {21.0, 21.0}, {19.0, 21.0}};
  const int32_t island = s.add_feature(b);
  s.add_polygon(island, {ring});
  s.set_effect(island, 0.5);
  Barriers land;
  land.add_polygon({ring}, "island");
  const GridSpec g = test::grid_of(160, 160, 0.25);
  const PartialEffectResult r =
      compute_partial_effect(s, g, ComputeOptions{}, BoundaryOptions{}, true, by_sea(land, g));
  ASSERT_TRUE(r.rule);
  const NearestField nil = compute_sea(*r.nil_seeds, land, g, g.full_window()).field;
  int64_t taken = 0;
  for (size_t i = 0; i < nil.site.cells().size(); ++i) {
    const int32_t ns = nil.site.cells()[i];
    if (ns == kNoSite) {
      EXPECT_EQ(r.field.site.cells()[i], kNoSite);
      continue;
    }
    ASSERT_EQ(s.site_owner(r.field.site.cells()[i]), r.nil_seeds->site_owner(ns)) << i;
    taken += s.site_owner(r.full.site.cells()[i]) == b && r.nil_seeds->site_owner(ns) != b;
  }
  EXPECT_GT(taken, 500);
  const BoundaryResult& nil_lines = r.rule->nil_lines();
  int64_t on_coast = 0;
  for (const BoundaryLine& l : r.boundaries.lines)
    for (const BoundaryVertex& v : l.vertices) {
      double best = std::numeric_limits<double>::infinity();
      for (const BoundaryLine& n : nil_lines.lines)
        if (n.owner_a == l.owner_a && n.owner_b == l.owner_b) best = std::min(best, to_polyline(v.p, n.vertices));
      EXPECT_LT(best, 1e-6) << l.owner_a << "-" << l.owner_b << " " << v.p.x << ", " << v.p.y;
      on_coast += v.on_barrier;
    }
  EXPECT_GE(on_coast, 3);  // the three neighbours' lines end on the island's coast
  for (const auto& [o1, o2] : {std::pair{x, y}, std::pair{y, z}, std::pair{x, z}})
    EXPECT_GT(test::expect_lines_between(r.field, s, g, r.boundaries, o1, o2,
                                         [&](Vec2 p, Vec2 q) { return r.metric->open_between(p, q); }),
              20);
  EXPECT_EQ(r.boundaries.tripoints.size(), nil_lines.tripoints.size());
}

// A neighbour's line that the island holds from a tripoint to the coast: B's mainland at
// (-50, 0), its island at (-10, 0), X at (50, 0), Y at (10, 50), land below y = -12 (no seeds
// beyond it see round it: every distance is straight). At full effect the B-X line is x = 20 from
// the B-X-Y tripoint (20, 17) to the coast, every vertex the island's; at nil effect x = 0 from
// (0, 1). The half-effect line runs from the partial tripoint on the X-Y nil line down to the
// coast; below y = 1 both lines' nearest points are their feet, so it is x = 10 there, and it ends
// on the coast at (10, -12).
TEST(SeaPartial, ALineTheIslandHoldsFromATripointToTheCoastEndsThere) {
  SeedSet s;
  const int32_t b = s.owner_code("B"), x = s.owner_code("X"), y = s.owner_code("Y");
  s.add_point(s.add_feature(b), Vec2{-50.0, 0.0});
  const int32_t island = s.add_feature(b);
  s.add_point(island, Vec2{-10.0, 0.0});
  s.add_point(s.add_feature(x), Vec2{50.0, 0.0});
  s.add_point(s.add_feature(y), Vec2{10.0, 50.0});
  s.set_effect(island, 0.5);
  Barriers land;
  land.add_polygon({{{-100.0, -12.0}, {100.0, -12.0}, {100.0, -40.0}, {-100.0, -40.0}}}, "land");
  const GridSpec g = test::grid_of(240, 140, 0.5, -60.0, 50.0);
  const PartialEffectResult r =
      compute_partial_effect(s, g, ComputeOptions{}, BoundaryOptions{}, true, by_sea(land, g));
  ASSERT_TRUE(r.rule);
  const NearestField nil = compute_sea(*r.nil_seeds, land, g, g.full_window()).field;
  int64_t band = 0, returned = 0;
  for (int64_t row = 0; row < g.height; ++row)
    for (int64_t col = 0; col < g.width; ++col) {
      const int32_t fs = r.full.site.at(col, row), ns = nil.site.at(col, row);
      if (fs == kNoSite) {
        EXPECT_EQ(r.field.site.at(col, row), kNoSite);
        continue;
      }
      const int32_t full_owner = s.site_owner(fs), nil_owner = r.nil_seeds->site_owner(ns);
      const int32_t expected = r.rule->owner(Vec2{g.centre_x(col), g.centre_y(row)}, full_owner, nil_owner);
      ASSERT_EQ(s.site_owner(r.field.site.at(col, row)), expected) << col << "," << row;
      band += full_owner == b && nil_owner == x;
      returned += full_owner == b && expected == x;
    }
  EXPECT_GT(band, 1000);
  EXPECT_GT(returned, 100);
  const BoundaryLine* bx = nullptr;
  for (const BoundaryLine& l : r.boundaries.lines)
    if ((l.owner_a == b && l.owner_b == x) || (l.owner_a == x && l.owner_b == b)) {
      ASSERT_EQ(bx, nullptr) << "one B-X line";
      bx = &l;
    }
  ASSERT_NE(bx, nullptr);
  const BoundaryVertex& coast_end =
      bx->vertices.front().p.y < bx->vertices.back().p.y ? bx->vertices.front() : bx->vertices.back();
  EXPECT_TRUE(coast_end.on_barrier);
  EXPECT_NEAR(coast_end.p.x, 10.0, 1e-6);
  EXPECT_NEAR(coast_end.p.y, -12.0, 1e-6);
  int64_t below = 0;
  for (const BoundaryVertex& v : bx->vertices)
    if (v.p.y <= 1.0) {
      ++below;
      EXPECT_NEAR(v.p.x, 10.0, 1e-6) << v.p.y;
    }
  EXPECT_GE(below, 2);
  const bool at_tripoint =
      std::any_of(r.boundaries.tripoints.begin(), r.boundaries.tripoints.end(), [&](const Tripoint& t) {
        const Vec2 top = coast_end.p == bx->vertices.front().p ? bx->vertices.back().p : bx->vertices.front().p;
        return t.p == top;
      });
  EXPECT_TRUE(at_tripoint);
  for (const auto& [o1, o2] : {std::pair{b, x}, std::pair{b, y}, std::pair{x, y}})
    EXPECT_GT(test::expect_lines_between(r.field, s, g, r.boundaries, o1, o2,
                                         [&](Vec2 p, Vec2 q) { return r.metric->open_between(p, q); }),
              10)
        << o1 << "-" << o2;
}

// Without the fields the line wholly in the band is still refused in one line, and the rasters
// alone are the rule's.
TEST(SeaPartial, AFullLineWhollyInTheBandWithoutTheFieldsIsRefusedInOneLine) {
  const Strait s = strait({{11, 17}, {15, 18}, {14, 23}, {11, 22}}, true, 0.1);
  const GridSpec g = test::grid_of(160, 160, 0.25);
  const PartialEffectResult r =
      compute_partial_effect(s.seeds, g, ComputeOptions{}, BoundaryOptions{}, false, by_sea(s.land, g));
  ASSERT_TRUE(r.rule);
  EXPECT_NE(r.field.site.cells(), r.full.site.cells());
  PartialLineStats stats;
  try {
    partial_boundaries(*r.rule, s.seeds, *r.index, g, 1e-9, 1e-3, 0.0, stats, r.nil_index.get());
    FAIL() << "taken";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::unsupported);
    EXPECT_NE(std::string(e.what()).find("wholly in the band"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rv
