// Partial effect (rv/lines/partial_effect.hpp) against the analytic case of the issue: nil- and
// full-effect lines that are rays from a common point at 200 and 240 degrees, whose e : (1 - e)
// locus is the ray at 200 + theta with sin(theta) / sin(40 - theta) = e / (1 - e) (220 degrees at
// half effect, 209.69 at a quarter). Lines to the micrometre, every cell of the band by the rule,
// e = 1 and e = 0 as the full and nil fields, and the input rules.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>
#include <vector>

#include "line_compare.hpp"
#include "partial_rays.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/partial_effect.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

using namespace test::rays;

void check_rays(double e, double expected_azimuth) {
  const SeedSet s = rays(e);
  const PartialEffectResult r = compute_partial_effect(s, kGrid, ComputeOptions{}, BoundaryOptions{});
  ASSERT_TRUE(r.rule);
  EXPECT_NEAR(locus_azimuth(e), expected_azimuth, 0.005);
  EXPECT_EQ(r.stats.stretches, 1);
  // The A-B line: the common ray at 20 degrees, O, then the partial ray.
  ASSERT_EQ(r.boundaries.lines.size(), 1u);
  const BoundaryLine& line = r.boundaries.lines[0];
  int64_t on_ray = 0;
  const double az = locus_azimuth(e);
  const Vec2 u{std::sin(az * kDeg), std::cos(az * kDeg)};
  for (const BoundaryVertex& v : line.vertices) {
    const Vec2 q{v.p.x - kO.x, v.p.y - kO.y};
    const double along = q.x * u.x + q.y * u.y;
    if (std::hypot(q.x, q.y) < 1e-6) continue;  // O itself
    if (along <= 0.0) continue;                 // the common ray, on the other side of O
    ++on_ray;
    EXPECT_LT(std::abs(q.x * u.y - q.y * u.x), 1e-5) << "vertex at azimuth " << azimuth_of(v.p);
    // The vertex's distances are the true ones to each owner's nearest.
    EXPECT_NEAR(v.distance_a, std::hypot(v.p.x - toward(310.0, 30000.0).x, v.p.y - toward(310.0, 30000.0).y), 1e-6);
  }
  EXPECT_GT(on_ray, 30);
  EXPECT_LT(r.stats.max_residual, 1e-6);
  // Every cell: in the band (200 to 240 degrees) by the side of the partial ray, elsewhere the
  // full-effect owner; a band cell the neighbour keeps carries its distance.
  int64_t band = 0, to_b = 0;
  for (int64_t row = 0; row < kGrid.height; ++row)
    for (int64_t col = 0; col < kGrid.width; ++col) {
      const Vec2 p{kGrid.centre_x(col), kGrid.centre_y(row)};
      const double a = azimuth_of(p);
      const int32_t owner = s.site_owner(r.field.site.at(col, row));
      const int32_t full_owner = s.site_owner(r.full.site.at(col, row));
      if (a > 200.0 + 1e-6 && a < 240.0 - 1e-6) {
        if (std::abs(a - az) < 1e-6) continue;
        ++band;
        const int32_t expected = a < az ? 2 : 1;
        to_b += expected == 2;
        ASSERT_EQ(owner, expected) << "cell " << col << "," << row << " at azimuth " << a;
        if (expected == 1) {
          const Vec2 A = toward(310.0, 30000.0);
          EXPECT_NEAR(r.field.distance.at(col, row), std::hypot(p.x - A.x, p.y - A.y), 0.01);
        }
      } else if (std::abs(a - 200.0) > 1e-6 && std::abs(a - 240.0) > 1e-6) {
        ASSERT_EQ(owner, full_owner) << "cell " << col << "," << row;
      }
    }
  EXPECT_GT(band, 500);
  EXPECT_GT(to_b, 0);
  EXPECT_LT(to_b, band);
  // The owner at any position follows the same rule (regions' faces).
  EXPECT_EQ(partial_owner_at(r, toward(az - 1.0, 20000.0)), 2);
  EXPECT_EQ(partial_owner_at(r, toward(az + 1.0, 20000.0)), 1);
  EXPECT_EQ(partial_owner_at(r, toward(60.0, 20000.0)), 2);
}

TEST(PartialEffect, HalfEffectIsTheMedianRayAt220) { check_rays(0.5, 220.0); }

TEST(PartialEffect, QuarterEffectIsTheRayAt209_69) { check_rays(0.25, 209.69); }

// The band's turning point O is where B's two sites (the island and the mainland) change along the
// full-effect line. With O half a cell off the rows of cell centres and moved in small steps, the
// line has a vertex at O, and rounding decides which of B's sites it carries: where it is the
// mainland's, the turning point is the common vertex itself and shows by itself no direction along
// the nil-effect line (the band's chain of it once ran the wrong way there: k 5 to 8 turned about x
// below). Turned about either axis the lines run the other way (the band first or last along the
// line): in each of the 40 layouts every vertex is on the common ray or on the locus ray, and the
// locus ray runs from O out to the frame (turned about both axes L0 and L1 end on two sides of the
// frame: the locus point on the chord between their ends once stopped 3.3 km short of it).
TEST(PartialEffect, ABandFromATurningPointOnAVertexRunsToTheFrameWhicheverWayTheLinesRun) {
  const double az = locus_azimuth(0.5);
  for (int k = 0; k < 10; ++k)
    for (const double sx : {1.0, -1.0})
      for (const double sy : {1.0, -1.0}) {
        const Vec2 o{kO.x + 37.0 * k, kO.y + 500.0 - 13.0 * (k % 7)};
        SCOPED_TRACE(testing::Message() << "k " << k << ", x turned " << (sx < 0.0) << ", y turned " << (sy < 0.0));
        auto dir = [&](double azimuth) { return Vec2{sx * std::sin(azimuth * kDeg), sy * std::cos(azimuth * kDeg)}; };
        auto at = [&](double azimuth) { return Vec2{o.x + 30000.0 * dir(azimuth).x, o.y + 30000.0 * dir(azimuth).y}; };
        SeedSet s;
        const int32_t a = s.owner_code("A"), b = s.owner_code("B");
        s.add_point(s.add_feature(a), at(310.0));
        const int32_t island = s.add_feature(b);
        s.add_point(island, at(170.0));
        s.set_effect(island, 0.5);
        s.add_point(s.add_feature(b), at(90.0));
        const PartialEffectResult r = compute_partial_effect(s, kGrid, ComputeOptions{}, BoundaryOptions{});
        ASSERT_TRUE(r.rule);
        ASSERT_EQ(r.boundaries.lines.size(), 1u);
        const Vec2 common = dir(20.0), locus = dir(az);
        double farthest = 0.0;
        Vec2 end = o;
        for (const BoundaryVertex& v : r.boundaries.lines[0].vertices) {
          const Vec2 q{v.p.x - o.x, v.p.y - o.y};
          if (std::hypot(q.x, q.y) < 1e-6) continue;
          const bool locus_side = q.x * locus.x + q.y * locus.y > 0.0;
          const Vec2 u = locus_side ? locus : common;
          EXPECT_LT(std::abs(q.x * u.y - q.y * u.x), 1e-5) << "vertex at " << q.x << ", " << q.y << " from O";
          if (locus_side && q.x * u.x + q.y * u.y > farthest) {
            farthest = q.x * u.x + q.y * u.y;
            end = v.p;
          }
        }
        // The locus ray's last vertex is on the frame of cell centres (37.8 km or more from O).
        const double off_frame = std::min({std::abs(end.x - kGrid.centre_x(0)), std::abs(end.x - kGrid.centre_x(119)),
                                           std::abs(end.y - kGrid.centre_y(0)), std::abs(end.y - kGrid.centre_y(99))});
        EXPECT_LT(off_frame, 1e-6) << "the locus ends at " << end.x << ", " << end.y;
        EXPECT_GT(farthest, 37000.0);
      }
}

// e = 1 is no adjustment at all; e = 0 is the island absent: the nil-effect field's owners and
// the line on the 200-degree ray.
TEST(PartialEffect, FullAndNilEffectAreTheTwoRuns) {
  const PartialEffectResult full = compute_partial_effect(rays(1.0), kGrid, ComputeOptions{}, BoundaryOptions{});
  EXPECT_FALSE(full.rule);
  const NearestField plain = compute(rays(1.0), kGrid, ComputeOptions{});
  EXPECT_EQ(full.field.site.cells(), plain.site.cells());
  EXPECT_EQ(full.field.distance.cells(), plain.distance.cells());

  const SeedSet s = rays(0.0);
  const PartialEffectResult nil = compute_partial_effect(s, kGrid, ComputeOptions{}, BoundaryOptions{});
  ASSERT_TRUE(nil.rule);
  SeedSet without_island;
  const int32_t a = without_island.owner_code("A"), b = without_island.owner_code("B");
  without_island.add_point(without_island.add_feature(a), toward(310.0, 30000.0));
  without_island.add_point(without_island.add_feature(b), toward(90.0, 30000.0));
  const NearestField reference = compute(without_island, kGrid, ComputeOptions{});
  for (int64_t row = 0; row < kGrid.height; ++row)
    for (int64_t col = 0; col < kGrid.width; ++col) {
      const double az = azimuth_of(Vec2{kGrid.centre_x(col), kGrid.centre_y(row)});
      if (std::abs(az - 200.0) < 1e-6) continue;
      const int32_t site = nil.field.site.at(col, row);
      // The island's own cells stay B's (its zone beyond the band is between owners B and B).
      if (s.site_feature(site) == 2) continue;
      ASSERT_EQ(s.site_owner(site), without_island.site_owner(reference.site.at(col, row)));
    }
  ASSERT_EQ(nil.boundaries.lines.size(), 1u);
  for (const BoundaryVertex& v : nil.boundaries.lines[0].vertices) {
    const Vec2 q{v.p.x - kO.x, v.p.y - kO.y};
    EXPECT_LT(std::abs(q.x * std::cos(200.0 * kDeg) - q.y * std::sin(200.0 * kDeg)), 1e-5);
  }
}

// On the ellipsoid, every cell of the rule's field is the rule at its centre (the field decides
// blocks at once where the balance's size rules the block out; this checks each cell alone).
// Every cell of `r` the rule at its centre, from the full-effect field and the nil-effect field
// computed here; returns the band's cells (full owner b, nil owner x) and those given back to x.
std::pair<int64_t, int64_t> expect_rule_at_every_cell(const SeedSet& s, const PartialEffectResult& r, const GridSpec& g,
                                                      const ComputeOptions& o, int32_t b, int32_t x) {
  const NearestField nil = compute(*r.nil_seeds, g, o);
  int64_t band = 0, returned = 0;
  for (int64_t row = 0; row < g.height; ++row)
    for (int64_t col = 0; col < g.width; ++col) {
      const int32_t full_owner = s.site_owner(r.full.site.at(col, row));
      const int32_t nil_owner = r.nil_seeds->site_owner(nil.site.at(col, row));
      const int32_t expected = r.rule->owner(Vec2{g.centre_x(col), g.centre_y(row)}, full_owner, nil_owner);
      EXPECT_EQ(s.site_owner(r.field.site.at(col, row)), expected) << col << "," << row;
      band += full_owner == b && nil_owner == x;
      returned += expected == x && full_owner == b;
    }
  return {band, returned};
}

// Partial effect over `s` on `g`, planar or geodesic (no barriers), every cell checked by the rule:
// the band (full owner b, nil owner x) holds over 1,000 cells, over 100 of them, not all, go back.
PartialEffectResult computed_and_checked(const SeedSet& s, const GridSpec& g, bool geodesic, int32_t b, int32_t x) {
  ComputeOptions opt;
  if (geodesic) opt.metric = MetricSpec{MetricSpec::geodesic};
  PartialEffectResult r = compute_partial_effect(s, g, opt, BoundaryOptions{});
  if (!r.rule) {
    ADD_FAILURE() << "no rule";
    return r;
  }
  const auto [band, returned] = expect_rule_at_every_cell(s, r, g, opt, b, x);
  EXPECT_GT(band, 1000);
  EXPECT_GT(returned, 100);
  EXPECT_LT(returned, band);
  return r;
}

TEST(PartialEffect, GeodesicFieldIsTheRuleAtEveryCell) {
  SeedSet s;
  const int32_t a = s.owner_code("A"), b = s.owner_code("B");
  s.add_polyline(s.add_feature(a), std::vector<Vec2>{{10.0, 55.0}, {10.0, 55.6}});
  s.add_polyline(s.add_feature(b), std::vector<Vec2>{{10.8, 55.0}, {10.8, 55.6}});
  const int32_t island = s.add_feature(b);
  s.add_point(island, Vec2{10.3, 55.3});
  s.set_effect(island, 0.3);
  const GridSpec g = test::grid_of(200, 150, 0.005, 9.9, 55.7);
  ComputeOptions o;
  o.metric = MetricSpec{MetricSpec::geodesic};
  const PartialEffectResult r = compute_partial_effect(s, g, o, BoundaryOptions{});
  ASSERT_TRUE(r.rule);
  const auto [band, returned] = expect_rule_at_every_cell(s, r, g, o, 2, 1);
  EXPECT_GT(band, 1000);
  EXPECT_GT(returned, 0);
  EXPECT_LT(returned, band);
  // The traced line: each vertex between the two lines, on the locus of the drawn lines.
  EXPECT_EQ(r.stats.stretches, 1);
  EXPECT_GT(r.stats.points, 20);
  EXPECT_LT(r.stats.max_residual, 1e-3 * 556.0);
}

// The partial features' zone meets two neighbours: A at (-40, 0) km and C at (40, 0) km from O,
// B's mainland at (0, 60) and its island at (0, 28). At nil effect the A-C line (the y axis) runs
// up to the tripoint T0 = (0, 16.67); at full effect the island cuts it at T1 = (0, -14.57), and
// the A-B line leaves the A-B bisector at Pt = (-41, 44) along the A-island bisector to T1. A's
// band is the triangle T1, Pt, T0 between the straight nil line (Pt-T0) and full line (Pt-T1); at
// half effect its line is where the distances to those two lines (segments: the lines end at
// their tripoints) agree, and it ends on the axis at the partial tripoint, to which the A-C line
// runs up the axis. C's side is the mirror image.
double to_segment(Vec2 p, Vec2 a, Vec2 b) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  const double t = std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
  return std::hypot(a.x + t * dx - p.x, a.y + t * dy - p.y);
}

TEST(PartialEffect, TwoNeighboursMeetAtThePartialTripoint) {
  const auto at = [](double x_km, double y_km) { return Vec2{kO.x + 1000.0 * x_km, kO.y + 1000.0 * y_km}; };
  SeedSet s;
  const int32_t a = s.owner_code("A"), b = s.owner_code("B"), c = s.owner_code("C");
  s.add_point(s.add_feature(a), at(-40.0, 0.0));
  s.add_point(s.add_feature(b), at(0.0, 60.0));
  const int32_t island = s.add_feature(b);
  s.add_point(island, at(0.0, 28.0));
  s.add_point(s.add_feature(c), at(40.0, 0.0));
  s.set_effect(island, 0.5);
  const GridSpec g = test::grid_of(120, 110, 1000.0, kO.x - 60000.0, kO.y + 70000.0);
  const PartialEffectResult r = compute_partial_effect(s, g, ComputeOptions{}, BoundaryOptions{});
  ASSERT_TRUE(r.rule);
  EXPECT_EQ(r.stats.stretches, 2);
  const Vec2 pt = at(-41.0, 44.0), t0 = at(0.0, 50.0 / 3.0), t1 = at(0.0, -14.0 - 4.0 / 7.0);
  // The balance of a point west of the axis (mirrored from the east): d(L0) - d(L1), L0 and L1
  // the segments (the stretch beyond Pt, common to both, is never nearer here).
  auto balance = [&](Vec2 p) {
    const Vec2 q{kO.x - std::abs(p.x - kO.x), p.y};
    return to_segment(q, pt, t0) - to_segment(q, pt, t1);
  };
  // The partial tripoint: where the balance changes sign on the axis between T1 and T0.
  double lo = t1.y, hi = t0.y;
  for (int k = 0; k < 100; ++k) {
    const double mid = 0.5 * (lo + hi);
    (balance(Vec2{kO.x, mid}) > 0.0 ? lo : hi) = mid;
  }
  ASSERT_EQ(r.boundaries.tripoints.size(), 1u);
  const Tripoint& tri = r.boundaries.tripoints[0];
  EXPECT_NEAR(tri.p.x, kO.x, 1e-5);
  EXPECT_NEAR(tri.p.y, 0.5 * (lo + hi), 1e-5);
  EXPECT_EQ(tri.owners[0], 1);
  EXPECT_EQ(tri.owners[2], 3);
  int64_t on_locus = 0;
  for (const BoundaryLine& line : r.boundaries.lines) {
    ASSERT_FALSE(line.closed);
    const bool ends_at_m = line.vertices.front().p == tri.p || line.vertices.back().p == tri.p;
    EXPECT_TRUE(ends_at_m) << line.owner_a << "-" << line.owner_b;
    if (line.owner_a == 1 && line.owner_b == 3) {
      for (const BoundaryVertex& v : line.vertices) EXPECT_NEAR(v.p.x, kO.x, 1e-5);
      continue;
    }
    for (const BoundaryVertex& v : line.vertices) {
      if (v.p.y >= pt.y - 1e-6) continue;  // the common stretch, north-west of Pt
      ++on_locus;
      EXPECT_LT(std::abs(balance(v.p)), 1e-5) << v.p.x << "," << v.p.y;
    }
  }
  EXPECT_GT(on_locus, 40);
  // The cells of the two bands: B's where the nil line is nearer, the neighbour's elsewhere.
  int64_t band = 0, kept = 0;
  for (int64_t row = 0; row < g.height; ++row)
    for (int64_t col = 0; col < g.width; ++col) {
      const Vec2 p{g.centre_x(col), g.centre_y(row)};
      const int32_t full_owner = s.site_owner(r.full.site.at(col, row));
      const Vec2 q{kO.x - std::abs(p.x - kO.x) - pt.x, p.y - pt.y};
      const Vec2 u0{t0.x - pt.x, t0.y - pt.y}, u1{t1.x - pt.x, t1.y - pt.y};
      const bool in_band = std::abs(p.x - kO.x) > 1e-6 && full_owner == 2 && u0.x * q.y - u0.y * q.x < 0.0 &&
                           u1.x * q.y - u1.y * q.x > 0.0 && q.x < -pt.x + kO.x;
      const double f = balance(p);
      if (!in_band || std::abs(f) < 1e-6) continue;
      ++band;
      kept += f < 0.0;
      ASSERT_EQ(s.site_owner(r.field.site.at(col, row)), f < 0.0 ? 2 : (p.x < kO.x ? 1 : 3)) << col << "," << row;
    }
  EXPECT_GT(band, 100);
  EXPECT_GT(kept, 0);
  EXPECT_LT(kept, band);
}

// A port of A's shut in by an island of B's at full effect (no land: the straight metric): the
// A-B full line is the bisector of the port and the island, frame to frame, every vertex the
// island's -- wholly in the band, with no turning point. The line is dropped (the rule gives the
// cells beside it back to A) and the locus, between it and the nil line halfway to B's port, is
// found where the rule's cells change owner and followed to the frame: every cell by the rule,
// every A-B vertex on the locus, and a line between every two neighbouring cells of A and B.
// Planar in units of 1, and geodesic on a longitude/latitude grid in units of 0.01 degree.
void check_shut_in(bool geodesic) {
  const double u = geodesic ? 0.01 : 1.0;
  const Vec2 o = geodesic ? Vec2{10.0, 55.0} : Vec2{0.0, 0.0};
  auto at = [&](double x, double y) { return Vec2{o.x + x * u, o.y + y * u}; };
  SeedSet s;
  const int32_t a = s.owner_code("A"), b = s.owner_code("B");
  s.add_point(s.add_feature(a), at(0.0, 0.0));
  s.add_point(s.add_feature(b), at(20.0, 0.0));
  const int32_t island = s.add_feature(b);
  s.add_polygon(island, {{at(2.0, -1.0), at(3.0, -1.0), at(3.0, 1.0), at(2.0, 1.0)}});
  s.set_effect(island, 0.5);
  const GridSpec g = test::grid_of(160, 120, 0.25 * u, o.x - 10.0 * u, o.y + 15.0 * u);
  const PartialEffectResult r = computed_and_checked(s, g, geodesic, b, a);
  ASSERT_TRUE(r.rule);
  EXPECT_EQ(r.stats.stretches, 1);
  // (Metric units: 1e-6 of a unit, planar; a millimetre, geodesic.)
  const double on_locus = geodesic ? 1e-3 : 1e-6;
  int64_t vertices = 0;
  for (const BoundaryLine& l : r.boundaries.lines) {
    EXPECT_FALSE(l.closed);
    for (const BoundaryVertex& v : l.vertices) {
      ++vertices;
      EXPECT_LT(std::abs(r.rule->balance(v.p, a)), on_locus) << v.p.x << ", " << v.p.y;
    }
  }
  EXPECT_GT(vertices, 20);
  EXPECT_GT(test::expect_lines_between(r.field, s, g, r.boundaries, a, b, [](Vec2, Vec2) { return true; }), 50);
}

TEST(PartialEffect, AFullLineWhollyInTheBandGivesTheLocusFoundFromTheCells) { check_shut_in(false); }

TEST(PartialEffect, OnTheEllipsoidTooTheLocusIsFoundFromTheCells) { check_shut_in(true); }

// An island far from its owner's nil-effect lines (as Bornholm): three neighbours X, Y and Z round
// it, B's mainland a line far north. At half effect the balance stays below 0 over the island's
// whole zone, so no partial line reaches the neighbours' nil-effect lines at the full-effect
// tripoints: the rule gives the zone back whole, and the result's lines there are the nil-effect
// ones, meeting at the nil-effect tripoint of X, Y and Z inside the zone. Every cell is the
// nil-effect run's owner; the lines of every two owners lie on their nil-effect lines (none is
// left round the island) and separate every two neighbouring cells of theirs; the tripoints are
// the nil-effect run's.
TEST(PartialEffect, AnIslandGivenBackWholeAtItsTripointsHasTheNilEffectLines) {
  SeedSet s;
  const int32_t x = s.owner_code("X"), y = s.owner_code("Y"), z = s.owner_code("Z"), b = s.owner_code("B");
  s.add_point(s.add_feature(x), Vec2{0.0, 10.0});
  s.add_point(s.add_feature(y), Vec2{-9.0, -5.0});
  s.add_point(s.add_feature(z), Vec2{9.0, -5.0});
  s.add_polyline(s.add_feature(b), std::vector<Vec2>{{-100.0, 30.0}, {100.0, 30.0}});
  const int32_t island = s.add_feature(b);
  s.add_polygon(island, {{{-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}}});
  s.set_effect(island, 0.5);
  const GridSpec g = test::grid_of(320, 220, 0.25, -40.0, 25.0);
  const PartialEffectResult r = compute_partial_effect(s, g, ComputeOptions{}, BoundaryOptions{});
  ASSERT_TRUE(r.rule);
  const NearestField nil = compute(*r.nil_seeds, g, ComputeOptions{});
  int64_t taken = 0;
  for (size_t i = 0; i < nil.site.cells().size(); ++i) {
    ASSERT_EQ(s.site_owner(r.field.site.cells()[i]), r.nil_seeds->site_owner(nil.site.cells()[i])) << i;
    taken += s.site_owner(r.full.site.cells()[i]) == b && r.nil_seeds->site_owner(nil.site.cells()[i]) != b;
  }
  EXPECT_GT(taken, 500);  // the island's zone at full effect
  const BoundaryResult& nil_lines = r.rule->nil_lines();
  auto to_nil_line = [&](Vec2 p, int32_t o1, int32_t o2) {
    double best = std::numeric_limits<double>::infinity();
    for (const BoundaryLine& l : nil_lines.lines)
      if ((l.owner_a == o1 && l.owner_b == o2) || (l.owner_a == o2 && l.owner_b == o1))
        for (size_t k = 0; k + 1 < l.vertices.size(); ++k)
          best = std::min(best, to_segment(p, l.vertices[k].p, l.vertices[k + 1].p));
    return best;
  };
  for (const BoundaryLine& l : r.boundaries.lines)
    for (const BoundaryVertex& v : l.vertices) {
      EXPECT_LT(to_nil_line(v.p, l.owner_a, l.owner_b), 1e-6)
          << l.owner_a << "-" << l.owner_b << " " << v.p.x << ", " << v.p.y;
    }
  for (const auto& [o1, o2] : {std::pair{x, y}, std::pair{y, z}, std::pair{x, z}})
    EXPECT_GT(test::expect_lines_between(r.field, s, g, r.boundaries, o1, o2, [](Vec2, Vec2) { return true; }), 20);
  ASSERT_EQ(r.boundaries.tripoints.size(), nil_lines.tripoints.size());
  bool inner = false;
  for (const Tripoint& t : r.boundaries.tripoints) {
    const bool found = std::any_of(nil_lines.tripoints.begin(), nil_lines.tripoints.end(), [&](const Tripoint& n) {
      return n.p == t.p && std::equal(n.owners, n.owners + 3, t.owners);
    });
    EXPECT_TRUE(found) << t.p.x << ", " << t.p.y;
    inner = inner || (t.owners[0] == x && t.owners[1] == y && t.owners[2] == z && std::hypot(t.p.x, t.p.y) < 1.0);
  }
  EXPECT_TRUE(inner);
}

// A neighbour's line that the island holds between two of its tripoints (Rügen between Bornholm
// and Poland): B's mainland at (-50, 0), its island at (-10, 0), X at (50, 0), Y at (10, 50) and
// Z at (10, -50). At full effect the B-X line is the island's bisector with X (x = 20) from the
// B-X-Y tripoint (20, 17) to the B-X-Z one (20, -17), every vertex the island's; at nil effect it
// is the mainland's (x = 0) from (0, 1) to (0, -1). The half-effect line runs between the two, from
// the partial tripoint on the X-Y nil line to the one on the X-Z nil line. Every cell by the rule,
// every B-X vertex off those nil lines on the locus, a line between every two neighbouring cells
// of two owners, and (planar) the mirror image about y = 0. Planar in units of 1, and geodesic in
// units of 0.01 degree.
void check_held_between_tripoints(bool geodesic) {
  const double u = geodesic ? 0.01 : 1.0;
  const Vec2 o = geodesic ? Vec2{10.0, 55.0} : Vec2{0.0, 0.0};
  auto at = [&](double x, double y) { return Vec2{o.x + x * u, o.y + y * u}; };
  SeedSet s;
  const int32_t b = s.owner_code("B"), x = s.owner_code("X"), y = s.owner_code("Y"), z = s.owner_code("Z");
  s.add_point(s.add_feature(b), at(-50.0, 0.0));
  const int32_t island = s.add_feature(b);
  s.add_point(island, at(-10.0, 0.0));
  s.add_point(s.add_feature(x), at(50.0, 0.0));
  s.add_point(s.add_feature(y), at(10.0, 50.0));
  s.add_point(s.add_feature(z), at(10.0, -50.0));
  s.set_effect(island, 0.5);
  const GridSpec g = test::grid_of(240, 200, 0.5 * u, o.x - 60.0 * u, o.y + 50.0 * u);
  const PartialEffectResult r = computed_and_checked(s, g, geodesic, b, x);
  ASSERT_TRUE(r.rule);
  const BoundaryResult& nil_lines = r.rule->nil_lines();
  auto on_nil_line = [&](Vec2 p, int32_t o1, int32_t o2) {
    for (const BoundaryLine& l : nil_lines.lines)
      if ((l.owner_a == o1 && l.owner_b == o2) || (l.owner_a == o2 && l.owner_b == o1))
        for (size_t k = 0; k + 1 < l.vertices.size(); ++k)
          if (to_segment(p, l.vertices[k].p, l.vertices[k + 1].p) < 1e-9 * u) return true;
    return false;
  };
  const double on_locus = geodesic ? 1e-3 : 1e-6;  // metric units: a millimetre, geodesic
  const BoundaryLine* bx = nullptr;
  int64_t checked = 0;
  for (const BoundaryLine& l : r.boundaries.lines) {
    if (!((l.owner_a == b && l.owner_b == x) || (l.owner_a == x && l.owner_b == b))) continue;
    ASSERT_EQ(bx, nullptr) << "one B-X line";
    bx = &l;
    for (const BoundaryVertex& v : l.vertices) {
      if (on_nil_line(v.p, x, y) || on_nil_line(v.p, x, z)) continue;  // along S to a partial tripoint
      ++checked;
      EXPECT_LT(std::abs(r.rule->balance(v.p, x)), on_locus) << v.p.x << ", " << v.p.y;
      EXPECT_GT(v.p.x, at(0.0, 0.0).x);  // strictly between the nil line and the full one
      EXPECT_LT(v.p.x, at(20.0, 0.0).x);
    }
  }
  ASSERT_NE(bx, nullptr);
  EXPECT_GT(checked, 20);
  // Its ends are tripoints of the result, one with Y, one with Z.
  std::array<bool, 2> ends{false, false};
  for (const Tripoint& t : r.boundaries.tripoints)
    for (const Vec2 end : {bx->vertices.front().p, bx->vertices.back().p})
      if (std::hypot(t.p.x - end.x, t.p.y - end.y) < 1e-9 * u) {
        const bool with_y = std::find(t.owners, t.owners + 3, y) != t.owners + 3;
        ends[with_y ? 0 : 1] = true;
        if (!geodesic) {
          EXPECT_NEAR(t.p.y, (with_y ? 1.0 : -1.0) * std::abs(end.y), 1e-9);
        }
      }
  EXPECT_TRUE(ends[0] && ends[1]);
  if (!geodesic) {
    // The mirror image about y = 0: each vertex's mirror on the line.
    std::vector<Vec2> pts;
    for (const BoundaryVertex& v : bx->vertices) pts.push_back(v.p);
    for (const Vec2 p : pts) {
      double best = std::numeric_limits<double>::infinity();
      for (size_t k = 0; k + 1 < pts.size(); ++k)
        best = std::min(best, to_segment(Vec2{p.x, -p.y}, pts[k], pts[k + 1]));
      EXPECT_LT(best, 1e-3) << p.x << ", " << p.y;
    }
  }
  for (const auto& [o1, o2] : {std::pair{b, x}, std::pair{b, y}, std::pair{b, z}, std::pair{x, y}, std::pair{x, z}})
    EXPECT_GT(test::expect_lines_between(r.field, s, g, r.boundaries, o1, o2, [](Vec2, Vec2) { return true; }), 10)
        << o1 << "-" << o2;
}

TEST(PartialEffect, ALineTheIslandHoldsBetweenTwoTripointsRunsBetweenThePartialTripoints) {
  check_held_between_tripoints(false);
}

TEST(PartialEffect, OnTheEllipsoidTooALineHeldBetweenTwoTripointsRunsBetweenThem) {
  check_held_between_tripoints(true);
}

TEST(PartialEffect, InputRules) {
  SeedSet s = rays(0.5);
  EXPECT_THROW(s.set_effect(2, 1.5), Error);
  EXPECT_THROW(s.set_effect(2, std::nan("")), Error);
  EXPECT_THROW(s.set_effect(2, -0.1), Error);
  const PartialEffect pe = partial_effect_of(s);
  EXPECT_EQ(pe.owner, 2);
  EXPECT_EQ(pe.effect, 0.5);
  EXPECT_EQ(pe.partial, (std::vector<bool>{false, false, true}));
  // Two effects within one owner.
  SeedSet mixed = rays(0.5);
  const int32_t extra = mixed.add_feature(2);
  mixed.add_point(extra, toward(130.0, 30000.0));
  mixed.set_effect(extra, 0.25);
  try {
    partial_effect_of(mixed);
    ADD_FAILURE() << "mixed effects accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::invalid_input);
    EXPECT_NE(std::string(e.what()).find("share one effect"), std::string::npos) << e.what();
  }
  // Partial features of two owners.
  SeedSet two = rays(0.5);
  two.set_effect(0, 0.5);
  EXPECT_THROW(partial_effect_of(two), Error);
  // An owner all of whose features are partial.
  SeedSet all = rays(0.5);
  all.set_effect(1, 0.5);
  try {
    partial_effect_of(all);
    ADD_FAILURE() << "an owner without full-effect features accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("every feature of owner 'B'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rv
