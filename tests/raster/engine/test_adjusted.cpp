// The adjusted method (weights and reaches, raster/src/engine/adjusted.cpp): the exact method against
// brute force cell for cell, planar and geodesic; analytic references (the Apollonius circle of
// two weighted points, a reach's arc on the ellipsoid); the rules for bad adjustments and methods.
#include <gtest/gtest.h>
#include <GeographicLib/Geodesic.hpp>

#include <cmath>
#include <cstring>
#include <random>

#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Points, polylines and a polygon of four owners over [0, 100]^2, each feature with a weight in
// [0.4, 3] and every third with a reach in [8, 40].
SeedSet adjusted_seeds(uint32_t seed, bool reaches) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 100.0), w(0.4, 3.0), r(8.0, 40.0);
  SeedSet s;
  for (int i = 0; i < 24; ++i) {
    const int32_t f = s.add_feature(s.owner_code(std::to_string(i % 4)));
    if (i % 3 == 1) {
      const std::vector<Vec2> line{{u(rng), u(rng)}, {u(rng), u(rng)}, {u(rng), u(rng)}};
      s.add_polyline(f, line);
    } else {
      s.add_point(f, {u(rng), u(rng)});
    }
    s.set_adjustment(f, w(rng), reaches && i % 3 == 0 ? r(rng) : kInf);
  }
  const int32_t f = s.add_feature(s.owner_code("0"));
  s.add_polygon(f, {Ring{{40, 40}, {55, 42}, {50, 58}}});
  s.set_adjustment(f, 2.0, kInf);
  return s;
}

void expect_same(const NearestField& a, const NearestField& b) {
  ASSERT_EQ(a.site.window(), b.site.window());
  int64_t differ = 0;
  for (int64_t r = 0; r < a.site.window().height; ++r)
    for (int64_t c = 0; c < a.site.window().width; ++c) {
      const bool same = a.site.at(c, r) == b.site.at(c, r) &&
                        std::memcmp(&a.distance.at(c, r), &b.distance.at(c, r), sizeof(float)) == 0;
      if (!same && differ++ < 5)
        ADD_FAILURE() << "cell (" << c << ", " << r << "): site " << a.site.at(c, r) << " / " << b.site.at(c, r)
                      << ", distance " << a.distance.at(c, r) << " / " << b.distance.at(c, r);
    }
  EXPECT_EQ(differ, 0);
}

ComputeOptions with(Method m, int threads, double max_distance = kInf) {
  ComputeOptions o;
  o.method = m;
  o.threads = threads;
  o.max_distance = max_distance;
  return o;
}

TEST(Adjusted, ExactEqualsBruteForcePlanar) {
  const GridSpec g = test::grid_of(230, 190, 0.5, -7.0);
  for (const bool reaches : {false, true})
    for (const double cap : {kInf, 21.0}) {
      SCOPED_TRACE(testing::Message() << "reaches " << reaches << ", cap " << cap);
      const SeedSet s = adjusted_seeds(reaches ? 7 : 3, reaches);
      ASSERT_TRUE(s.adjusted());
      const NearestField brute = compute(s, g, with(Method::brute_force, 2, cap));
      expect_same(compute(s, g, with(Method::exact, 1, cap)), brute);
      expect_same(compute(s, g, with(Method::exact, 2, cap)), brute);
      if (std::isfinite(cap)) {  // some cells are beyond every reach
        int64_t none = 0;
        for (int64_t r = 0; r < g.height; ++r)
          for (int64_t c = 0; c < g.width; ++c) none += brute.site.at(c, r) == kNoSite;
        EXPECT_GT(none, 0);
      }
    }
}

TEST(Adjusted, WindowsAndMaskEqualTheWholeGrid) {
  const GridSpec g = test::grid_of(200, 200, 0.5);
  const SeedSet s = adjusted_seeds(11, true);
  const NearestField whole = compute(s, g, with(Method::exact, 2));
  ComputeOptions o = with(Method::exact, 2);
  o.window = Window{37, 51, 90, 77};
  const NearestField part = compute(s, g, o);
  for (int64_t r = 0; r < 77; ++r)
    for (int64_t c = 0; c < 90; ++c) {
      ASSERT_EQ(part.site.at(c, r), whole.site.at(c + 37, r + 51));
      ASSERT_EQ(part.distance.at(c, r), whole.distance.at(c + 37, r + 51));
    }
  // A mask: an earlier field of the grid whose masked cells were lost gets them back.
  ComputeOptions m = with(Method::exact, 2);
  auto mask = std::make_shared<CellMask>(CellMask::none(g.full_window()));
  mask->add(10, 20, 150, 33);
  mask->add(120, 90, 121, 190);
  m.mask = mask;
  NearestField masked = whole;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c)
      if (mask->contains(c, r)) {
        masked.site.at(c, r) = 12345;
        masked.distance.at(c, r) = 99.0f;
      }
  compute_into(s, g, m, masked);
  expect_same(masked, whole);
}

// Two points 100 km apart on a 1 km grid, weights 3 : 1: A's region is the disc where
// d_A / 3 < d_B, bounded by the Apollonius circle d_A = 3 d_B (centre 112.5 km from A on the
// axis, radius 37.5 km), and it is B's region that is the disc: B is an enclave.
TEST(Adjusted, WeightedPointsMakeTheApolloniusCircle) {
  SeedSet s;
  const int32_t a = s.add_feature(s.owner_code("A"));
  s.add_point(a, {0.0, 0.0});
  s.set_adjustment(a, 3.0, kInf);
  const int32_t b = s.add_feature(s.owner_code("B"));
  s.add_point(b, {100.0, 0.0});
  const GridSpec g = test::grid_of(300, 200, 1.0, -100.0, 100.0);
  const NearestField f = compute(s, g, with(Method::exact, 2));
  int64_t b_cells = 0, checked = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const double x = g.centre_x(c), y = g.centre_y(r);
      const double from_circle = std::hypot(x - 112.5, y) - 37.5;
      const int32_t expected = from_circle < 0.0 ? 1 : 0;  // site 1 (B) inside the circle
      b_cells += f.site.at(c, r) == 1;
      if (std::abs(from_circle) < 1e-9) continue;  // e.g. (112.5, 37.5)
      ++checked;
      ASSERT_EQ(f.site.at(c, r), expected) << "cell centre (" << x << ", " << y << ")";
      const double d = expected == 1 ? std::hypot(x - 100.0, y) : std::hypot(x, y);
      ASSERT_EQ(f.distance.at(c, r), static_cast<float>(d));  // the true distance, not d / w
    }
  // Only centres on the circle itself (to rounding) are left to the tie rule.
  EXPECT_GE(checked, g.width * g.height - 16);
  // The cells approximate the disc's area: pi 37.5^2 = 4417.86 km^2.
  EXPECT_NEAR(static_cast<double>(b_cells), M_PI * 37.5 * 37.5, 60.0);
}

// A point island with a reach of 12 nmi on a geodesic grid, a mainland coast 150 km away: the
// island's cells are those within 22,224 m of it on the ellipsoid (GeographicLib's inverse).
TEST(Adjusted, ReachEnclavesAnIslandOnTheEllipsoid) {
  SeedSet s;
  const int32_t main = s.add_feature(s.owner_code("mainland"));
  const std::vector<Vec2> coast{{10.0, 54.0}, {10.0, 56.0}};
  s.add_polyline(main, coast);
  const int32_t island = s.add_feature(s.owner_code("island"));
  s.add_point(island, {12.3, 55.0});
  s.set_adjustment(island, 1.0, 22224.0);
  GridSpec g = test::grid_of(160, 120, 0.005, 11.9, 55.3);
  ComputeOptions o = with(Method::exact, 2);
  o.metric = MetricSpec{MetricSpec::geodesic};
  const NearestField f = compute(s, g, o);
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  int64_t island_cells = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      double d = 0.0;
      geod.Inverse(55.0, 12.3, g.centre_y(r), g.centre_x(c), d);
      if (std::abs(d - 22224.0) < 1e-6) continue;
      const bool inside = d < 22224.0;
      island_cells += inside;
      ASSERT_EQ(f.site.at(c, r), inside ? 1 : 0) << "cell (" << c << ", " << r << ") at " << d << " m";
      if (inside) {
        EXPECT_NEAR(f.distance.at(c, r), d, 1e-3 + 1e-7 * d);
      }
    }
  EXPECT_GT(island_cells, 1000);
  // And brute force agrees to the bit.
  o.method = Method::brute_force;
  expect_same(f, compute(s, g, o));
}

TEST(Adjusted, GeodesicExactEqualsBruteForce) {
  SeedSet s = adjusted_seeds(5, true);
  // Move the seeds to degrees around the Baltic: x in [10, 11], y in [54, 55], reaches in metres.
  SeedSet geo;
  for (size_t i = 0; i < s.features().size(); ++i) {
    const Feature& f = s.features()[i];
    const int32_t k = geo.add_feature(geo.owner_code(s.owner_labels()[static_cast<size_t>(f.owner - 1)]));
    std::vector<Vec2> line;
    for (const Site& site : s.sites())
      if (site.feature == static_cast<int32_t>(i) && site.kind != SiteKind::area) {
        if (line.empty()) line.push_back({10.0 + site.a.x / 100.0, 54.0 + site.a.y / 100.0});
        line.push_back({10.0 + site.b.x / 100.0, 54.0 + site.b.y / 100.0});
      }
    if (line.size() == 2 && line[0] == line[1])
      geo.add_point(k, line[0]);
    else
      geo.add_polyline(k, line);
    geo.set_adjustment(k, f.weight, std::isfinite(f.reach) ? f.reach * 1000.0 : kInf);
  }
  const GridSpec g = test::grid_of(90, 80, 0.0125, 9.9, 55.05);
  ComputeOptions o = with(Method::brute_force, 2, 30000.0);
  o.metric = MetricSpec{MetricSpec::geodesic};
  const NearestField brute = compute(geo, g, o);
  o.method = Method::exact;
  expect_same(compute(geo, g, o), brute);
}

// Every weight 1 and no reach is no adjustment: the unadjusted engines run, and a reach beyond
// the grid changes no owner.
TEST(Adjusted, UnitWeightsAreTheUnadjustedField) {
  SeedSet s = test::random_points(40, 0, 0, 100, 100, 9);
  for (int32_t f = 0; f < 40; ++f) s.set_adjustment(f, 1.0, kInf);
  EXPECT_FALSE(s.adjusted());
  const GridSpec g = test::grid_of(120, 120, 1.0);
  const NearestField plain = compute(s, g, with(Method::exact, 2));
  for (int32_t f = 0; f < 40; ++f) s.set_adjustment(f, 1.0, 1e6);
  ASSERT_TRUE(s.adjusted());
  const NearestField adjusted = compute(s, g, with(Method::exact, 2));
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      ASSERT_EQ(adjusted.site.at(c, r), plain.site.at(c, r));
      ASSERT_NEAR(adjusted.distance.at(c, r), plain.distance.at(c, r), 1e-5);
    }
}

TEST(Adjusted, BadAdjustmentsAndScansAreRefused) {
  SeedSet s = test::random_points(5, 0, 0, 10, 10, 1);
  for (const double w : {0.0, -1.0, kInf, std::nan("")}) {
    try {
      s.set_adjustment(2, w, kInf);
      FAIL() << "weight " << w << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::invalid_input);
      EXPECT_NE(std::string(e.what()).find("feature 3: the weight"), std::string::npos) << e.what();
    }
  }
  for (const double r : {0.0, -5.0, std::nan("")}) EXPECT_THROW(s.set_adjustment(0, 1.0, r), Error);
  EXPECT_FALSE(s.adjusted());
  s.set_adjustment(1, 2.0, kInf);
  const GridSpec g = test::grid_of(20, 20, 0.5);
  for (const Method m : {Method::hv_scan, Method::h_scan}) {
    try {
      compute(s, g, with(m, 1));
      FAIL() << "a scan accepted weights";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::invalid_argument);
      EXPECT_NE(std::string(e.what()).find("weights and reaches need the exact or brute-force method"),
                std::string::npos);
    }
  }
}

}  // namespace
}  // namespace rv
