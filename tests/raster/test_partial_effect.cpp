// Partial effect (rv/partial_effect.hpp) against the analytic case of the issue: nil- and
// full-effect lines that are rays from a common point at 200 and 240 degrees, whose e : (1 - e)
// locus is the ray at 200 + theta with sin(theta) / sin(40 - theta) = e / (1 - e) (220 degrees at
// half effect, 209.69 at a quarter). Lines to the micrometre, every cell of the band by the rule,
// e = 1 and e = 0 as the full and nil fields, and the input rules.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "rv/engine.hpp"
#include "rv/error.hpp"
#include "rv/partial_effect.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
const Vec2 kO{500000.0, 6000000.0};

Vec2 toward(double azimuth_deg, double r) {
  return Vec2{kO.x + r * std::sin(azimuth_deg * kDeg), kO.y + r * std::cos(azimuth_deg * kDeg)};
}

double azimuth_of(Vec2 p) {
  const double az = std::atan2(p.x - kO.x, p.y - kO.y) / kDeg;
  return az < 0.0 ? az + 360.0 : az;
}

// A at azimuth 310, B's mainland at 90 and its island at 170, all 30 km from O: the A-B line is
// the ray at 20 degrees and, at nil effect, the ray at 200; at full effect the ray at 240.
SeedSet rays(double effect) {
  SeedSet s;
  const int32_t a = s.owner_code("A"), b = s.owner_code("B");
  s.add_point(s.add_feature(a), toward(310.0, 30000.0));
  s.add_point(s.add_feature(b), toward(90.0, 30000.0));
  const int32_t island = s.add_feature(b);
  s.add_point(island, toward(170.0, 30000.0));
  s.set_effect(island, effect);
  return s;
}

const GridSpec kGrid = test::grid_of(120, 100, 1000.0, 420000.0, 6030000.0);

// The partial line's azimuth for effect e: 200 + theta, sin(theta) / sin(40 - theta) = e / (1 - e).
double locus_azimuth(double e) {
  const double k = e / (1.0 - e);
  return 200.0 + std::atan(k * std::sin(40.0 * kDeg) / (1.0 + k * std::cos(40.0 * kDeg))) / kDeg;
}

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
  const NearestField nil = compute(r.nil_seeds, g, o);
  int64_t band = 0, returned = 0;
  for (int64_t row = 0; row < g.height; ++row)
    for (int64_t col = 0; col < g.width; ++col) {
      const int32_t full_owner = s.site_owner(r.full.site.at(col, row));
      const int32_t nil_owner = r.nil_seeds.site_owner(nil.site.at(col, row));
      const int32_t expected = r.rule->owner(Vec2{g.centre_x(col), g.centre_y(row)}, full_owner, nil_owner);
      ASSERT_EQ(s.site_owner(r.field.site.at(col, row)), expected) << col << "," << row;
      band += full_owner == 2 && nil_owner == 1;
      returned += expected == 1 && full_owner == 2;
    }
  EXPECT_GT(band, 1000);
  EXPECT_GT(returned, 0);
  EXPECT_LT(returned, band);
  // The traced line: each vertex between the two lines, on the locus of the drawn lines.
  EXPECT_EQ(r.stats.stretches, 1);
  EXPECT_GT(r.stats.points, 20);
  EXPECT_LT(r.stats.max_residual, 1e-3 * 556.0);
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
