// The distance by sea on the ellipsoid (SeaOptions::metric geodesic): paths and barrier edges are
// geodesics, distances GeographicLib's. Against a closed form (a port behind a wall: the straight
// geodesic where seen, else the shorter way round an end, each leg GeographicLib's inverse
// problem, the wall's shadow from an azimuth oracle), and the exact engine against the reference
// cell for cell on random archipelagos of longitude/latitude; coast lines and islands as seeds
// (against GeographicLib along the line, and the straight geodesic field where coasts are land);
// the sea metric's distance at points taken just off a coast (continuous along it).
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/UTMUPS.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <set>
#include <vector>

#include "engines_agree.hpp"
#include "geodesic_oracle.hpp"
#include "random_archipelago.hpp"
#include "rv/field/error.hpp"
#include "rv/sea/geodesic_frame.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/sea_metric.hpp"
#include "rv/sea/visibility.hpp"
#include "sea/sea_prepare.hpp"
#include "seed_gen.hpp"
#include "utm33.hpp"

namespace rv {
namespace {

using test::crosses;
using test::metres;

MetricSpec geodesic() { return test::geodesic_metric(); }

SeaOptions on_the_ellipsoid() {
  SeaOptions o;
  o.metric = geodesic();
  return o;
}

// Both engines: owners and vias cell for cell, distances to GeographicLib's rounding (and a
// micrometre: a cell centre on a port is 0 or 1e-10 m from it as its longitude and latitude round).
SeaField both(const SeedSet& seeds, const Barriers& barriers, const GridSpec& g) {
  const SeaField reference = brute_force_sea(seeds, barriers, g, g.full_window(), INFINITY, 0, geodesic());
  const SeaField exact = compute_sea(seeds, barriers, g, g.full_window(), on_the_ellipsoid());
  EXPECT_EQ(exact.land_cells, reference.land_cells);
  EXPECT_EQ(exact.unreachable_cells, reference.unreachable_cells);
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      EXPECT_EQ(exact.field.site.at(c, r), reference.field.site.at(c, r)) << c << "," << r;
      EXPECT_EQ(exact.via.at(c, r), reference.via.at(c, r)) << c << "," << r;
      EXPECT_NEAR(exact.field.distance.at(c, r), reference.field.distance.at(c, r),
                  1e-6 * std::abs(reference.field.distance.at(c, r)) + 1e-6)
          << c << "," << r;
      if (::testing::Test::HasFailure()) return exact;
    }
  return exact;
}

// A port west of a 45 km wall running north-south (a geodesic), on a 0.02-degree grid of the
// western Baltic's latitudes: in the wall's shadow the path goes round the nearer end.
TEST(SeaGeodesic, WallShadowGoesRoundTheNearerEnd) {
  const Vec2 a{10.5, 55.1}, b{10.5, 55.5}, s{10.21, 55.33};
  Barriers barriers;
  barriers.add_line(std::vector<Vec2>{a, b}, "wall");
  SeedSet seeds;
  seeds.add_point(seeds.add_feature(seeds.owner_code("P")), s);
  const GridSpec g = test::grid_of(50, 30, 0.02, 10.0, 55.6);
  const SeaField f = both(seeds, barriers, g);
  int hidden = 0;
  double worst = 0.0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x{g.centre_x(c), g.centre_y(r)};
      const bool behind = crosses(s, x, a, b);
      const double want = behind ? std::min(metres(s, a) + metres(a, x), metres(s, b) + metres(b, x)) : metres(s, x);
      EXPECT_NEAR(f.field.distance.at(c, r), want, 1e-6 * want + 1e-3) << c << "," << r;
      worst = std::max(worst, std::abs(f.field.distance.at(c, r) - want));
      EXPECT_EQ(f.via.at(c, r) != kNoVia, behind) << c << "," << r;
      EXPECT_EQ(f.field.site.at(c, r), 0);
      hidden += behind;
    }
  EXPECT_GT(hidden, 200);
  EXPECT_EQ(f.field.metric.kind, MetricSpec::geodesic);
  std::printf("closed form | a 45 km wall on the ellipsoid, one port | %lld cells | worst |d - closed form| %.3g m\n",
              static_cast<long long>(g.width * g.height), worst);
}

// Weights on the ellipsoid: a port of weight 2 west of the wall against one of weight 1 east of
// it, and a reach of 40 km on the heavy one. Cost = geodesic path / weight within the reach; the
// owners where the costs differ by more than rounding, the distances the closed form's.
TEST(SeaGeodesic, WeightsAndAReachCountThePathOnTheEllipsoid) {
  const Vec2 a{10.5, 55.1}, b{10.5, 55.5}, heavy{10.21, 55.33}, light{10.86, 55.27};
  Barriers barriers;
  barriers.add_line(std::vector<Vec2>{a, b}, "wall");
  const GridSpec g = test::grid_of(50, 30, 0.02, 10.0, 55.6);
  auto path = [&](Vec2 s, Vec2 x) {
    return crosses(s, x, a, b) ? std::min(metres(s, a) + metres(a, x), metres(s, b) + metres(b, x)) : metres(s, x);
  };
  for (const double reach : {std::numeric_limits<double>::infinity(), 40000.0}) {
    SeedSet seeds;
    seeds.add_point(seeds.add_feature(seeds.owner_code("heavy")), heavy);
    seeds.add_point(seeds.add_feature(seeds.owner_code("light")), light);
    seeds.set_adjustment(0, 2.0, reach);
    const SeaField f = both(seeds, barriers, g);
    int64_t round_the_wall = 0, beyond_reach = 0;
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        const Vec2 x{g.centre_x(c), g.centre_y(r)};
        const double dh = path(heavy, x), dl = path(light, x);
        const double ch = dh > reach ? INFINITY : dh / 2.0;
        if (std::abs(ch - dl) < 1e-6 * dl) continue;
        const int32_t want = ch < dl ? 0 : 1;
        ASSERT_EQ(f.field.site.at(c, r), want) << c << "," << r;
        const double d = want == 0 ? dh : dl;
        ASSERT_NEAR(f.field.distance.at(c, r), d, 1e-6 * d + 1e-3) << c << "," << r;
        round_the_wall += want == 0 && crosses(heavy, x, a, b);
        beyond_reach += want == 1 && dh / 2.0 < dl;  // the heavy one's by cost, but out of reach
      }
    EXPECT_GT(round_the_wall, 50) << reach;
    if (std::isfinite(reach)) {
      EXPECT_GT(beyond_reach, 50);
    }
  }
}

// The same wall and port on a projected grid (UTM 33N cells of 1 km, located on WGS84 by a
// geolocator): every cell centre located, then the same closed form; the vias' positions come
// back in the grid's CRS. Exact equals the reference cell for cell.
TEST(SeaGeodesic, OnAProjectedGridTheCellsAreLocated) {
  const Vec2 a{14.5, 55.1}, b{14.5, 55.5}, s{14.21, 55.33};
  Barriers barriers;
  barriers.add_line(std::vector<Vec2>{a, b}, "wall");
  SeedSet seeds;
  seeds.add_point(seeds.add_feature(seeds.owner_code("P")), s);
  GridSpec g;
  g.xmin = 440000.0;
  g.ymax = 6160000.0;
  g.res = 1000.0;
  g.width = 60;
  g.height = 60;
  SeaOptions options = on_the_ellipsoid();
  options.geolocator = std::make_shared<const test::Utm33>();
  const SeaField reference = brute_force_sea(seeds, barriers, g, g.full_window(), options);
  const SeaField f = compute_sea(seeds, barriers, g, g.full_window(), options);
  int hidden = 0;
  double worst = 0.0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      Vec2 x;
      GeographicLib::UTMUPS::Reverse(33, true, g.centre_x(c), g.centre_y(r), x.y, x.x);
      const bool behind = crosses(s, x, a, b);
      const double want = behind ? std::min(metres(s, a) + metres(a, x), metres(s, b) + metres(b, x)) : metres(s, x);
      ASSERT_NEAR(f.field.distance.at(c, r), want, 1e-6 * want + 1e-3) << c << "," << r;
      worst = std::max(worst, std::abs(f.field.distance.at(c, r) - want));
      ASSERT_EQ(f.via.at(c, r) != kNoVia, behind) << c << "," << r;
      ASSERT_EQ(f.field.site.at(c, r), 0);
      ASSERT_EQ(reference.field.site.at(c, r), 0);
      ASSERT_EQ(reference.via.at(c, r), f.via.at(c, r)) << c << "," << r;
      ASSERT_NEAR(reference.field.distance.at(c, r), f.field.distance.at(c, r), 1e-6 * want);
      hidden += behind;
    }
  EXPECT_GT(hidden, 200);
  // The vias are the wall's ends, given back in UTM metres.
  options.prepared = prepare_sea(seeds, barriers, g, options);
  std::set<int32_t> vias;
  for (int32_t v : f.via.cells())
    if (v != kNoVia) vias.insert(v);
  ASSERT_FALSE(vias.empty());
  for (int32_t v : vias) {
    const Vec2 at = via_position(*options.prepared, g, v);
    int zone;
    bool north;
    Vec2 utm_a, utm_b;
    GeographicLib::UTMUPS::Forward(a.y, a.x, zone, north, utm_a.x, utm_a.y, 33);
    GeographicLib::UTMUPS::Forward(b.y, b.x, zone, north, utm_b.x, utm_b.y, 33);
    const double to_end =
        std::min(std::hypot(at.x - utm_a.x, at.y - utm_a.y), std::hypot(at.x - utm_b.x, at.y - utm_b.y));
    EXPECT_LT(to_end, 1e-6) << v;
  }
  std::printf(
      "closed form | a 45 km wall on a projected grid (UTM 33N, located cells), one port | %lld cells | "
      "worst |d - closed form| %.3g m\n",
      static_cast<long long>(g.width * g.height), worst);
}

// Random islands (longitude/latitude quadrilaterals, some with a lake), a boom, ports of two
// owners at sea: the exact engine equals the reference; distances grow by at most the geodesic
// between neighbours that see each other.
TEST(SeaGeodesic, RandomArchipelagosExactEqualsTheReference) {
  std::mt19937_64 rng(56);
  std::uniform_real_distribution<double> lon(12.0, 12.9), lat(55.3, 55.8), size(0.03, 0.12);
  int rounds = 0;
  int64_t bent = 0;
  for (int round = 0; round < 6; ++round) {
    Barriers b;
    for (int k = 0; k < 6; ++k) {
      const double x = lon(rng), y = lat(rng), w = size(rng), h = size(rng) * 0.6;
      std::vector<Ring> rings{{{x, y}, {x + w, y}, {x + w * 0.6, y + h}, {x, y + h * 0.8}}};
      if (w > 0.08) rings.push_back({{x + 0.02, y + 0.01}, {x + 0.04, y + 0.01}, {x + 0.03, y + 0.025}});
      b.add_polygon(rings, "island");
    }
    b.add_line(std::vector<Vec2>{{lon(rng), lat(rng)}, {lon(rng), lat(rng)}}, "boom");
    SeedSet s;
    int ports = 0;
    for (int k = 0; k < 20 && ports < 5; ++k) {
      const Vec2 p{lon(rng), lat(rng)};
      s.add_point(s.add_feature(s.owner_code(ports % 2 ? "A" : "B")), p);
      ++ports;
    }
    const GridSpec g = test::grid_of(45, 30, 0.02, 12.0, 55.9);
    SeaField f;
    try {
      f = both(s, b, g);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();  // a port on an island
      continue;
    }
    ++rounds;
    // Independently of the engines' searches: neighbours that see each other differ by at most
    // the geodesic between them.
    const auto frame = std::make_shared<const GeodesicFrame>(geodesic(), 12.0, 55.3, 12.9 + 0.12, 55.9);
    const Visibility vis(b.mapped([&](Vec2 v) { return frame->forward(v); }), true, frame);
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        bent += f.via.at(c, r) != kNoVia;
        if (f.field.site.at(c, r) == kNoSite || c + 1 >= g.width || f.field.site.at(c + 1, r) == kNoSite) continue;
        const Vec2 x{g.centre_x(c), g.centre_y(r)}, y{g.centre_x(c + 1), g.centre_y(r)};
        if (!vis.sees(Visibility::Place{frame->forward(x)}, Visibility::Place{frame->forward(y)})) continue;
        EXPECT_LE(std::abs(f.field.distance.at(c, r) - f.field.distance.at(c + 1, r)), metres(x, y) + 1e-3)
            << round << ": " << c << "," << r;
      }
  }
  EXPECT_GE(rounds, 3);
  EXPECT_GT(bent, 100);
}

// A coast line (one geodesic segment of 27 km) west of the 45 km wall: where its nearest point is
// seen, the distance is the segment's (GeographicLib, by a search of its own along the line);
// in the wall's shadow the shorter way round an end, each end's own distance to the line added.
TEST(SeaGeodesic, ACoastLineBehindAWall) {
  const Vec2 a{10.5, 55.1}, b{10.5, 55.5}, l0{10.15, 55.2}, l1{10.25, 55.42};
  Barriers barriers;
  barriers.add_line(std::vector<Vec2>{a, b}, "wall");
  SeedSet seeds;
  seeds.add_polyline(seeds.add_feature(seeds.owner_code("C")), std::vector<Vec2>{l0, l1});
  const GridSpec g = test::grid_of(50, 30, 0.02, 10.0, 55.6);
  const SeaField f = both(seeds, barriers, g);
  // Each end of the wall's own distance to the line (it sees the whole line).
  const double via_a = test::segment_foot(a, l0, l1).metres, via_b = test::segment_foot(b, l0, l1).metres;
  int hidden = 0, inside = 0;
  double worst = 0.0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x{g.centre_x(c), g.centre_y(r)};
      const test::Foot foot = test::segment_foot(x, l0, l1);
      const bool behind = crosses(foot.at, x, a, b);
      const double want = behind ? std::min(via_a + metres(a, x), via_b + metres(b, x)) : foot.metres;
      EXPECT_NEAR(f.field.distance.at(c, r), want, 1e-6 * want + 1e-3) << c << "," << r;
      worst = std::max(worst, std::abs(f.field.distance.at(c, r) - want));
      EXPECT_EQ(f.via.at(c, r) != kNoVia, behind) << c << "," << r;
      EXPECT_EQ(f.field.site.at(c, r), 0);
      hidden += behind;
      inside += foot.at.x != l0.x && foot.at.x != l1.x;  // the nearest point inside the segment
    }
  EXPECT_GT(hidden, 200);
  EXPECT_GT(inside, 300);
  std::printf(
      "closed form | a coast line behind a 45 km wall on the ellipsoid | %lld cells | worst |d - closed form| %.3g m\n",
      static_cast<long long>(g.width * g.height), worst);
}

// Coasts as both seeds and land on the ellipsoid (islands as polygons, a coast line that is a
// barrier line too, a port): off land the field is the straight geodesic one, bit for bit; on
// land no owner. And the exact engine equals the reference cell for cell.
TEST(SeaGeodesic, CoastsAsSeedsAndBarriersChangeNothingOffLand) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> lon(12.05, 12.85), lat(55.35, 55.85), radius(0.02, 0.06);
  int rounds = 0;
  for (int round = 0; round < 6; ++round) {
    SeedSet s;
    Barriers b;
    for (int k = 0; k < 4; ++k) {
      const Vec2 centre{lon(rng), lat(rng)};
      Ring ring;
      const int n = 3 + static_cast<int>(rng() % 5);
      for (int i = 0; i < n; ++i) {
        const double t = 2 * M_PI * i / n, r = radius(rng);
        ring.push_back({centre.x + r * std::cos(t) / 0.57, centre.y + r * std::sin(t)});
      }
      const int32_t f = s.add_feature(s.owner_code(k % 2 ? "A" : "B"));
      if (k == 3) {
        s.add_polyline(f, std::vector<Vec2>(ring.begin(), ring.end()));
        b.add_line(std::vector<Vec2>(ring.begin(), ring.end()), "line");
      } else {
        s.add_polygon(f, {ring});
        b.add_polygon({ring}, "land");
      }
    }
    s.add_point(s.add_feature(s.owner_code("A")), {lon(rng), lat(rng)});
    const GridSpec g = test::grid_of(45, 30, 0.02, 12.0, 55.9);
    SeaField sea;
    try {
      sea = both(s, b, g);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();  // the port fell on land
      continue;
    }
    ASSERT_FALSE(::testing::Test::HasFailure());
    ComputeOptions o;
    o.metric = geodesic();
    const NearestField straight = compute(s, g, o);
    int64_t compared = 0, land = 0;
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        if (sea.field.site.at(c, r) == kNoSite) {
          ++land;
          continue;
        }
        ++compared;
        ASSERT_EQ(sea.field.site.at(c, r), straight.site.at(c, r)) << round << ": " << c << "," << r;
        ASSERT_EQ(sea.field.distance.at(c, r), straight.distance.at(c, r)) << round << ": " << c << "," << r;
        ASSERT_EQ(sea.via.at(c, r), kNoVia);
      }
    EXPECT_EQ(land, sea.land_cells);
    EXPECT_GT(land, 20);
    EXPECT_GT(compared, 1000);
    ++rounds;
  }
  EXPECT_GE(rounds, 3);
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// The chord's lower bound of a geodesic length (sea::Prepared::chord_below, which lets the exact
// engine skip most inverse problems) is never above GeographicLib's distance, and close to it:
// pairs from a millimetre to 2,000 km apart, at every latitude, on WGS84 and a flatter ellipsoid.
TEST(SeaGeodesic, TheChordBoundsTheGeodesicFromBelow) {
  std::mt19937_64 rng(1969);
  std::uniform_real_distribution<double> lon(-180.0, 180.0), lat(-89.9, 89.9), azimuth(0.0, 360.0), power(-3.0, 6.3);
  for (const double flattening : {1.0 / 298.257223563, 1.0 / 150.0}) {
    MetricSpec metric = geodesic();
    metric.flattening = flattening;
    const GeographicLib::Geodesic earth(metric.semi_major, metric.flattening);
    sea::Prepared p(Visibility(Barriers{}));
    p.semi_major = metric.semi_major;
    p.e2 = flattening * (2.0 - flattening);
    double worst_short = 0.0;  // the largest relative gap under 100 km, the 1e-6 m margin aside
    for (int i = 0; i < 20000; ++i) {
      const Vec2 a{lon(rng), lat(rng)};
      const double s = std::pow(10.0, power(rng));
      double lat2, lon2, d;
      earth.Direct(a.y, a.x, azimuth(rng), s, lat2, lon2);
      earth.Inverse(a.y, a.x, lat2, lon2, d);
      const double chord = sea::Prepared::chord_below(p.xyz(a), p.xyz(Vec2{lon2, lat2}));
      ASSERT_LE(chord, d) << a.x << " " << a.y << " -> " << lon2 << " " << lat2;
      if (d < 1e5) worst_short = std::max(worst_short, (d - chord - 1e-6) / d);
    }
    std::printf("flattening %.6f: worst gap under 100 km %.3g of the distance\n", flattening, worst_short);
    EXPECT_LT(worst_short, 3e-5);  // (a sphere's: 1.0e-5 at 100 km)
  }
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// On the ellipsoid too, blocks of cells answered at once give every cell's own answer to the bit:
// random islands over the Oresund's latitudes on a 0.004-degree grid (most blocks clear of land),
// ports at sea and on coasts, a coast as a line seed (geodesic), an island as a polygon seed.
TEST(SeaGeodesic, BlocksAnswerAsEveryCellAlone) {
  std::mt19937_64 rng(58);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int rounds = 0;
  int64_t block_cells = 0, drawn_cells = 0, cells = 0, via_cells = 0;
  for (int round = 0; round < 3; ++round) {
    Barriers b;
    std::vector<Ring> outlines;
    for (int k = 0; k < 6; ++k) {  // one island in each of 3 x 2 squares of 0.3 x 0.25 degrees
      const double x = 12.0 + 0.3 * (k % 3) + 0.02 + 0.1 * u(rng), y = 55.35 + 0.25 * (k / 3) + 0.02 + 0.08 * u(rng);
      const double w = 0.03 + 0.12 * u(rng), h = 0.02 + 0.1 * u(rng);
      std::vector<Ring> rings{{{x, y}, {x + w, y}, {x + w * 0.6, y + h}, {x + w * 0.1, y + h * 0.7}, {x, y + h * 0.8}}};
      outlines.push_back(rings[0]);
      b.add_polygon(rings, "island");
    }
    b.add_line(
        std::vector<Vec2>{{12.0 + 0.9 * u(rng), 55.35 + 0.5 * u(rng)}, {12.0 + 0.9 * u(rng), 55.35 + 0.5 * u(rng)}},
        "boom");
    SeedSet s;
    for (int k = 0; k < 5; ++k)
      s.add_point(s.add_feature(s.owner_code(k % 2 ? "A" : "B")), {12.0 + 0.9 * u(rng), 55.35 + 0.5 * u(rng)});
    const Ring& o = outlines[static_cast<size_t>(round % 3)];
    s.add_point(s.add_feature(s.owner_code("C")), {(o[0].x + o[1].x) / 2, (o[0].y + o[1].y) / 2});
    s.add_polyline(s.add_feature(s.owner_code("D")), std::vector<Vec2>{o[1], o[2]});
    s.add_polygon(s.add_feature(s.owner_code("E")), {outlines[static_cast<size_t>(round % 3) + 3]});
    const GridSpec g = test::grid_of(225, 125, 0.004, 12.0, 55.85);
    SeaField f;
    try {
      f = test::blocks_agree(s, b, g, on_the_ellipsoid());
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();  // a port on an island or the boom
      continue;
    }
    if (HasFailure()) return;
    ++rounds;
    block_cells += f.block_cells;
    drawn_cells += f.drawn_cells;
    cells += g.width * g.height;
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) via_cells += f.via.at(c, r) != kNoVia;
  }
  EXPECT_GE(rounds, 2);
  // Most cells drawn (land, or sea that sees its straight nearest site) or in blocks; both used.
  EXPECT_GT(block_cells + drawn_cells, cells / 2);
  EXPECT_GT(drawn_cells, cells / 4);
  EXPECT_GT(block_cells, cells / 20);
  EXPECT_GT(via_cells, 5000);
}

}  // namespace
}  // namespace rv
namespace rv {
namespace {

// The planar tests' random archipelagos (random_archipelago.hpp: islands that overlap and share
// corners and edges, coast seeds running into other islands' land) laid over 0.8 x 0.5 degrees
// of the Oresund's latitudes: both engines agree on a 0.02-degree grid, the blocks equal every
// cell alone on a 0.004-degree one, where neighbours that see each other differ by at most the
// geodesic between them (and a centimetre).
TEST(SeaGeodesic, RandomOverlappingArchipelagosKeepTheTriangleInequality) {
  std::mt19937_64 rng(31);
  int rounds = 0;
  int64_t pairs = 0;
  auto to = [](Vec2 v) { return Vec2{12.0 + 0.02 * v.x, 55.3 + 0.0125 * v.y}; };
  const auto frame = std::make_shared<const GeodesicFrame>(geodesic(), 11.9, 55.2, 12.9, 55.9);
  for (int round = 0; round < 40; ++round) {
    const test::Archipelago a = test::random_archipelago(rng, round, to);
    const GridSpec g = test::grid_of(45, 45, 0.02, 11.98, 55.85);
    SeaField f;
    try {
      f = both(a.seeds, a.barriers, g);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();  // a port or coast seed inside an island
      continue;
    }
    if (HasFailure()) return;
    const GridSpec fine = test::grid_of(225, 150, 0.004, 11.98, 55.85);
    f = test::blocks_agree(a.seeds, a.barriers, fine, on_the_ellipsoid());
    if (HasFailure()) return;
    ++rounds;
    const Visibility vis(a.barriers.mapped([&](Vec2 v) { return frame->forward(v); }), true, frame);
    for (int64_t r = 0; r < fine.height; ++r)
      for (int64_t c = 0; c < fine.width; ++c)
        for (int64_t r2 = std::max<int64_t>(0, r - 1); r2 <= std::min(fine.height - 1, r + 1); ++r2)
          for (int64_t c2 = std::max<int64_t>(0, c - 1); c2 <= std::min(fine.width - 1, c + 1); ++c2) {
            if (f.field.site.at(c, r) == kNoSite || f.field.site.at(c2, r2) == kNoSite || (c2 == c && r2 == r))
              continue;
            const Vec2 x{fine.centre_x(c), fine.centre_y(r)}, y{fine.centre_x(c2), fine.centre_y(r2)};
            ++pairs;
            if (f.field.distance.at(c, r) <= f.field.distance.at(c2, r2) + metres(x, y) + 1e-2) continue;
            if (vis.classify(frame->forward(y)) != Visibility::Ground::open_sea ||
                !vis.sees(Visibility::Place{frame->forward(x)}, Visibility::Place{frame->forward(y)}))
              continue;
            ADD_FAILURE() << "round " << round << ": " << c << "," << r << " next to " << c2 << "," << r2;
            return;
          }
  }
  EXPECT_GE(rounds, 30);
  EXPECT_GT(pairs, 100000);
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// On the ellipsoid: two islands sharing the corner (12.29 E, 55.5 N), their south coasts falling
// away from it east and west (so that the sea south of the corner is under a half-turn: no bend
// node there); the coast seed D runs from the corner north-west between them (the west island's
// east coast). South of the coasts D's nearest point lies past the west island's land: the path
// ends at D's end, the corner, a root of D from that wedge. Every cell south of both coasts within
// 1.5 km of longitude of the corner: owner D, no via, the geodesic to the corner.
TEST(SeaGeodesic, ASeedsEndWhereTwoIslandsMeetIsReachedFromTheirOtherSide) {
  const Vec2 corner{12.29, 55.5};
  Barriers b;
  b.add_polygon({{corner, {12.34, 55.4985}, {12.32, 55.55}, {12.29, 55.54}}}, "east");
  b.add_polygon({{{12.26, 55.4985}, corner, {12.278, 55.52}, {12.26, 55.516}}}, "west");
  SeedSet s;
  s.add_polyline(s.add_feature(s.owner_code("D")), std::vector<Vec2>{corner, {12.278, 55.52}});
  const GridSpec g = test::grid_of(50, 30, 0.001, 12.265, 55.505);
  const SeaField f = both(s, b, g);
  if (HasFailure()) return;
  int cells = 0, past_the_land = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      const Vec2 x{g.centre_x(c), g.centre_y(r)};
      if (x.y >= 55.4975 || std::abs(x.x - corner.x) > 0.0235) continue;
      const double want = metres(x, corner);
      EXPECT_EQ(f.field.site.at(c, r), 0) << c << "," << r;
      EXPECT_EQ(f.via.at(c, r), kNoVia) << c << "," << r;
      EXPECT_NEAR(f.field.distance.at(c, r), want, 1e-6 * want + 1e-3) << c << "," << r;
      ++cells;
      // (The foot of the perpendicular on D inside it, roughly: behind the west island.)
      past_the_land += (x.x - corner.x) * -0.012 * std::cos(55.5 * M_PI / 180) * std::cos(55.5 * M_PI / 180) +
                           (x.y - corner.y) * 0.02 >
                       0;
    }
  EXPECT_GT(cells, 500);
  EXPECT_GE(past_the_land, 5);
  EXPECT_TRUE(test::same_cells(test::blocks_agree(s, b, g, on_the_ellipsoid()), f, g));
}

// Points of a coast taken just off it (SiteMetric::domain_edge_point) on the ellipsoid: along an
// islet's edge whose points a port reaches round the edge's own end, every orientation reads them
// on the sea side alike, so the path round that end is found at every one: the distance by sea
// changes along the coast by at most the way along it (1-Lipschitz). (Points put a nanometre off
// the edge had been read on the land side by some tests: at a few in a hundred the path went round
// the far side of the archipelago instead, a kilometre longer.)
TEST(SeaGeodesic, ADistanceAlongACoastTakenJustOffItChangesNoFasterThanTheWayAlongIt) {
  // (An islet of the Archipelago Sea's GSHHG coast, 21.03 E 60.59 N, and a port north-west of it
  // that sees its north edge and reaches its north-east edge round their common corner.)
  Barriers b;
  b.add_polygon({{{21.0308385, 60.5875029},
                  {21.0308385, 60.5857786},
                  {21.0316320, 60.5853819},
                  {21.0332799, 60.5862211},
                  {21.0350042, 60.5862211},
                  {21.0358129, 60.5866331},
                  {21.0332799, 60.5878843},
                  {21.0316320, 60.5878843}}},
                "islet");
  SeedSet s;
  const Vec2 port{21.0, 60.5895};
  s.add_point(s.add_feature(s.owner_code("P")), port);
  const GridSpec g = test::grid_of(40, 20, 0.001, 21.0, 60.6);
  const std::unique_ptr<SiteMetric> m = make_sea_site_metric(s, b, g, on_the_ellipsoid());
  std::vector<int32_t> edges;
  m->domain_edges_near(Vec2{21.033, 60.587}, 0.01, edges);
  ASSERT_EQ(edges.size(), 8u);
  const Vec2 corner{21.0332799, 60.5878843}, tip{21.0358129, 60.5866331};
  int64_t samples = 0, round_the_corner = 0;
  for (const int32_t e : edges) {
    Vec2 e0, e1;
    ASSERT_TRUE(m->domain_edge_ends(e, e0, e1));
    const Vec2 mid{0.5 * (e0.x + e1.x), 0.5 * (e0.y + e1.y)};
    const Vec2 sea{mid.x + (e1.y - e0.y), mid.y - (e1.x - e0.x)};  // (counter-clockwise: sea on the right)
    constexpr int kSteps = 2000;
    double before = NAN;
    Vec2 at_before{};
    for (int k = 0; k <= kSteps; ++k) {
      Vec2 q;
      ASSERT_TRUE(m->domain_edge_point(e, static_cast<double>(k) / kSteps, sea, q)) << e << " " << k;
      ASSERT_TRUE(m->in_domain(q));
      const double d = m->distance(q, 0);
      if (k > 0) {
        EXPECT_LE(std::abs(d - before), metres(q, at_before) + 1e-6) << e << " at " << k;
      }
      before = d;
      at_before = q;
      ++samples;
      // (On the north-east edge the path bends at the corner: the corner's path and the rest.)
      if (e0 == tip && e1 == corner && k > 0 && k < kSteps) {
        EXPECT_NEAR(d, metres(port, corner) + metres(corner, q), 1e-6) << k;
        ++round_the_corner;
      }
    }
  }
  EXPECT_EQ(round_the_corner, 1999);
  EXPECT_EQ(samples, 8 * 2001);
}

// How far an edge's points (SiteMetric::domain_edge_point) lie from the chord of its ends in the
// grid's coordinates is bounded by domain_edge_bow, which the search for a line's junction on a
// coast orders the edges by: the western Baltic's 4.5-degree edge along 53.8 N (its geodesic about
// 2.4 km north of the parallel at its middle), long random edges of a few degrees, on a
// longitude/latitude grid and on a projected one (UTM 33N); on a planar metric the bow is the
// edge's rounding alone.
TEST(SeaGeodesic, AnEdgesPointsLieWithinItsBowOfItsChord) {
  auto off_chord = [](Vec2 p, Vec2 a, Vec2 b) {
    const double dx = b.x - a.x, dy = b.y - a.y;
    const double t = std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
    return std::hypot(p.x - (a.x + t * dx), p.y - (a.y + t * dy));
  };
  Barriers b;
  b.add_polygon({{{9.5, 53.8}, {14.0, 53.8}, {14.0, 54.0}, {9.5, 54.0}}}, "strip");
  std::mt19937 rng(56);
  std::uniform_real_distribution<double> lon(9.2, 15.3), lat(54.3, 56.0);
  for (int k = 0; k < 6; ++k) b.add_line(std::vector<Vec2>{{lon(rng), lat(rng)}, {lon(rng), lat(rng)}}, "boom");
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("P")), Vec2{12.0, 54.2});
  struct Case {
    const char* name;
    GridSpec g;
    SeaOptions options;
    bool planar;
  };
  std::vector<Case> cases;
  cases.push_back(Case{"lon/lat", test::grid_of(130, 48, 0.05, 9.0, 56.2), on_the_ellipsoid(), false});
  // (UTM 33N over the same sea, in 5 km cells; the barriers are given in longitude and latitude.)
  SeaOptions located = on_the_ellipsoid();
  located.geolocator = std::make_shared<const test::Utm33>();
  cases.push_back(Case{"UTM 33N", test::grid_of(90, 56, 5000.0, 180000.0, 6240000.0), located, false});
  SeaOptions planar;  // (the same numbers read as a plane)
  cases.push_back(Case{"planar", test::grid_of(130, 48, 0.05, 9.0, 56.2), planar, true});
  for (const Case& c : cases) {
    const std::unique_ptr<SiteMetric> m = make_sea_site_metric(s, b, c.g, c.options);
    std::vector<int32_t> edges;
    m->domain_edges_near(Vec2{c.g.xmin + 0.5 * c.g.res * static_cast<double>(c.g.width),
                              c.g.ymax - 0.5 * c.g.res * static_cast<double>(c.g.height)},
                         0.5 * c.g.res * std::hypot(static_cast<double>(c.g.width), static_cast<double>(c.g.height)),
                         edges);
    ASSERT_EQ(edges.size(), 10u) << c.name;
    double longest_bow = 0.0;
    for (const int32_t e : edges) {
      Vec2 e0, e1;
      ASSERT_TRUE(m->domain_edge_ends(e, e0, e1));
      const double bow = m->domain_edge_bow(e), chord = std::hypot(e1.x - e0.x, e1.y - e0.y);
      EXPECT_EQ(bow, m->domain_edge_bow(e));  // (kept once found)
      const Vec2 mid{0.5 * (e0.x + e1.x), 0.5 * (e0.y + e1.y)};
      double farthest = 0.0;
      int64_t points = 0;
      for (const double side : {-1.0, 1.0}) {
        const Vec2 toward{mid.x - side * (e1.y - e0.y), mid.y + side * (e1.x - e0.x)};
        constexpr int kSteps = 400;
        for (int k = 0; k <= kSteps; ++k) {
          Vec2 q;
          if (!m->domain_edge_point(e, static_cast<double>(k) / kSteps, toward, q)) continue;
          const double off = off_chord(q, e0, e1);
          EXPECT_LE(off, bow) << c.name << " edge " << e << " at " << k;
          farthest = std::max(farthest, off);
          ++points;
        }
      }
      EXPECT_GE(points, 401) << c.name << " edge " << e;
      if (c.planar) {
        EXPECT_LE(bow, 1e-5 * chord) << c.name << " edge " << e;  // (the move off it, a millionth)
      } else {
        // Not loose: a curve's farthest point from its chord is near its middle (and the move off
        // the edge that domain_edge_point may make is metres at most: 1e-4 degrees, 10 m).
        EXPECT_LE(bow, 2.5 * farthest + (c.options.geolocator ? 10.0 : 1e-4)) << c.name << " edge " << e;
      }
      if (std::abs(e0.y - e1.y) < 1e-9 && std::abs(e0.y - 53.8) < 1e-9 && chord > 4.0) longest_bow = bow;
    }
    if (c.options.metric.kind == MetricSpec::geodesic && !c.options.geolocator) {
      // (2.4 km north of 53.8 N at its middle: 0.021 degrees of latitude.)
      EXPECT_GT(longest_bow, 0.02) << c.name;
      EXPECT_LT(longest_bow, 0.06) << c.name;
    }
  }
}

}  // namespace
}  // namespace rv
