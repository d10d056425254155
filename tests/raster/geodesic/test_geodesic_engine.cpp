// The engine with the geodesic metric: distances at cells against GeographicLib directly,
// geodesic vs planar ownership, exact == brute force (points, lines, polygons; any thread
// count; across the antimeridian; up to a pole), scans, validation and refusals.
#include <gtest/gtest.h>

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/Geodesic.hpp>

#include <algorithm>
#include <cmath>
#include <random>

#include "rv/engine/engine.hpp"
#include "rv/engine/validate.hpp"
#include "rv/field/error.hpp"
#include "rv/geodesic/geodesic.hpp"
#include "window_check.hpp"

namespace rv {
namespace {

MetricSpec wgs84() {
  MetricSpec m;
  m.kind = MetricSpec::geodesic;
  return m;
}

NearestField run(const SeedSet& s, const GridSpec& g, Method m, int threads = 2,
                 double max_distance = std::numeric_limits<double>::infinity(), MetricSpec metric = wgs84()) {
  ComputeOptions o;
  o.method = m;
  o.threads = threads;
  o.max_distance = max_distance;
  o.metric = metric;
  return compute(s, g, o);
}

GridSpec geo_grid(double xmin, double ymax, double res, int64_t w, int64_t h) {
  GridSpec g;
  g.xmin = xmin;
  g.ymax = ymax;
  g.res = res;
  g.width = w;
  g.height = h;
  return g;
}

// Random features (points, lines, polygons) around a box of lon/lat, owners cycling over 4.
SeedSet random_features(uint32_t seed, double lon0, double lat0, double lon1, double lat1, int features) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ulon(lon0, lon1), ulat(lat0, lat1), off(-1.0, 1.0);
  const double span = std::max(lon1 - lon0, lat1 - lat0) / 8.0;
  SeedSet s;
  for (int f = 0; f < features; ++f) {
    const int32_t id = s.add_feature(s.owner_code(std::to_string(f % 4)));
    const Vec2 c{ulon(rng), ulat(rng)};
    std::vector<Vec2> pts;
    const int k = 2 + static_cast<int>(rng() % 4);
    for (int i = 0; i < k; ++i) pts.push_back({c.x + off(rng) * span, std::clamp(c.y + off(rng) * span, -90.0, 90.0)});
    if (f % 3 == 0) {
      s.add_point(id, c);
    } else if (f % 3 == 1) {
      s.add_polyline(id, pts);
    } else {
      pts.push_back({c.x + span, c.y});
      s.add_polygon(id, {pts});
    }
  }
  return s;
}

void expect_within_one_ulp(const Raster<float>& a, const Raster<float>& b, const std::string& what) {
  ASSERT_EQ(a.cells().size(), b.cells().size()) << what;
  int64_t off = 0;
  for (size_t i = 0; i < a.cells().size(); ++i) {
    const float x = a.cells()[i], y = b.cells()[i];
    if (x == y) continue;
    if (x == std::nextafter(y, x)) {
      ++off;
      continue;
    }
    ADD_FAILURE() << what << ": cell " << i << " distance " << x << " vs brute force " << y;
    return;
  }
  EXPECT_LE(off, static_cast<int64_t>(a.cells().size() / 20)) << what << ": too many last-bit differences";
}

void expect_exact_equals_brute(const SeedSet& s, const GridSpec& g, const std::string& what,
                               double max_distance = std::numeric_limits<double>::infinity()) {
  const NearestField brute = run(s, g, Method::brute_force, 2, max_distance);
  const NearestField exact = run(s, g, Method::exact, 2, max_distance);
  EXPECT_EQ(exact.site.cells(), brute.site.cells()) << what;
  // Point sites' distances are interpolated to ~1e-8 m: the float32 written may differ from
  // brute force's by the last bit, never more.
  expect_within_one_ulp(exact.distance, brute.distance, what);
  const ValidationStats st = compare_fields(s, exact, brute);
  EXPECT_EQ(st.wrong_cells, 0) << what;
  EXPECT_EQ(st.nodata_mismatch, 0) << what;
}

TEST(GeodesicEngine, CellDistancesMatchGeographicLib) {
  // Point seeds spread over a wide area (equator to 70N): every cell's owner must be the argmin
  // of GeographicLib's distances, and its distance that distance (to float rounding).
  SeedSet s;
  const Vec2 seeds[] = {{-5, 0.2}, {8, 12}, {20, 45}, {-12, 66}, {30, 70}, {2, 30}, {25, 5}};
  for (int i = 0; i < 7; ++i) s.add_point(s.add_feature(s.owner_code(std::to_string(i))), seeds[i]);
  const GridSpec g = geo_grid(-15.0, 75.0, 1.25, 40, 60);  // 15W..35E, 75N..0
  const NearestField f = run(s, g, Method::exact);
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  for (int64_t r = 0; r < g.height; r += 3) {
    for (int64_t c = 0; c < g.width; c += 3) {
      double best = std::numeric_limits<double>::infinity();
      int32_t best_id = -1;
      for (int i = 0; i < 7; ++i) {
        double d;
        geod.Inverse(g.centre_y(r), g.centre_x(c), seeds[i].y, seeds[i].x, d);
        if (d < best) {
          best = d;
          best_id = i;
        }
      }
      EXPECT_EQ(f.site.at(c, r), best_id) << c << "," << r;
      EXPECT_NEAR(f.distance.at(c, r), best, best * 1e-7 + 1e-3) << c << "," << r;
    }
  }
}

// Many basepoints on a fine grid: the interpolated path (64-cell blocks at 0.002 deg). Every
// sampled cell's owner is GeographicLib's argmin, and its distance the float nearest to
// GeographicLib's (or the next one: double rounding of a value within ~1e-8 m of it).
TEST(GeodesicEngine, InterpolatedDistancesMatchGeographicLib) {
  struct Case {
    double lon0, lat0;
    const char* what;
  } cases[] = {{10.0, 55.0, "55N"}, {-0.3, 0.3, "equator"}, {20.0, 84.0, "84N"}, {179.5, -40.0, "antimeridian"}};
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  for (const Case& k : cases) {
    const GridSpec g = geo_grid(k.lon0, k.lat0 + 0.35, 0.002, 330, 350);
    SeedSet s;
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-0.1, 0.8);
    std::vector<Vec2> pts;
    for (int i = 0; i < 12; ++i) {
      pts.push_back({g.xmin + u(rng), std::min(89.9, g.ymin() + u(rng) * 0.9)});
      s.add_point(s.add_feature(s.owner_code(std::to_string(i % 5))), pts.back());
    }
    pts.push_back({g.centre_x(100), g.centre_y(200)});  // a seed exactly at a cell centre
    s.add_point(s.add_feature(s.owner_code("centre")), pts.back());
    const NearestField f = run(s, g, Method::exact);
    int64_t checked = 0;
    for (int64_t r = 0; r < g.height; r += 7)
      for (int64_t c = 0; c < g.width; c += 5) {
        double best = std::numeric_limits<double>::infinity();
        int32_t best_id = -1;
        for (int32_t i = 0; i < static_cast<int32_t>(pts.size()); ++i) {
          double d;
          geod.Inverse(g.centre_y(r), g.centre_x(c), pts[i].y, pts[i].x, d);
          if (d < best) {
            best = d;
            best_id = i;
          }
        }
        ASSERT_EQ(f.site.at(c, r), best_id) << k.what << " " << c << "," << r;
        const float want = static_cast<float>(best), got = f.distance.at(c, r);
        ASSERT_TRUE(got == want || got == std::nextafter(want, got))
            << k.what << " " << c << "," << r << ": " << got << " vs " << best;
        ASSERT_NEAR(got, best, std::max(1e-3, best * 1.2e-7)) << k.what;
        ++checked;
      }
    EXPECT_EQ(f.distance.at(100, 200), 0.0f) << k.what;
    EXPECT_GT(checked, 3000);
    // The same bits for any window and thread count (blocks are aligned to the grid).
    ComputeOptions o;
    o.metric = wgs84();
    o.threads = 3;
    o.window = Window{37, 61, 150, 119};
    const NearestField part = compute(s, g, o);
    for (int64_t r = 0; r < 119; ++r)
      for (int64_t c = 0; c < 150; ++c) {
        ASSERT_EQ(part.site.at(c, r), f.site.at(37 + c, 61 + r)) << k.what;
        ASSERT_EQ(part.distance.at(c, r), f.distance.at(37 + c, 61 + r)) << k.what;
      }
  }
}

// Equidistant basepoints: cells on the perpendicular bisector are exact ties, decided by exact
// distances (lower site index), never by the interpolants' last bits. Dyadic cells (2^-9
// degrees) put a column of cell centres exactly on the bisector meridian of two basepoints
// 0.25 degrees either side of it on one parallel, so every cell of that column is a tie.
TEST(GeodesicEngine, InterpolatedTiesGoToTheLowerSite) {
  const double res = 1.0 / 512.0;
  const GridSpec g = geo_grid(4.0, 1.0, res, 1024, 200);  // 4E .. 6E, 1N .. 0.61N
  const double mid = 4.0 + 512.5 * res;                   // column 512's centre, exact
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("B")), {mid + 0.25, 0.8});
  s.add_point(s.add_feature(s.owner_code("A")), {mid - 0.25, 0.8});
  s.add_point(s.add_feature(s.owner_code("C")), {mid + 0.25, 0.8});  // same place as site 0
  const NearestField f = run(s, g, Method::exact);
  const NearestField b = run(s, g, Method::brute_force);
  EXPECT_EQ(f.site.cells(), b.site.cells());
  expect_within_one_ulp(f.distance, b.distance, "ties");
  for (int64_t r = 0; r < g.height; ++r) {
    ASSERT_EQ(b.site.at(512, r), 0) << "brute force: the bisector is a tie, row " << r;
    EXPECT_EQ(f.site.at(512, r), 0) << "row " << r;
    EXPECT_EQ(f.site.at(513, r), 0) << "row " << r;  // east of the bisector: site 0, never 2
    EXPECT_EQ(f.site.at(511, r), 1) << "row " << r;
  }
  for (int32_t v : f.site.cells()) EXPECT_NE(v, 2);  // never the duplicate
}

// A coastline seen from offshore (20 .. 120 km): cells whose nearest point is inside an edge
// use the edge's line interpolant, cells nearest at a vertex the vertex's. Owners equal brute
// force's, distances to the last float bit, and match GeodesicMeasure's segment distance.
TEST(GeodesicEngine, OffshoreCellsOfACoastline) {
  SeedSet s;
  std::vector<Vec2> coast_a, coast_b;
  for (int i = 0; i <= 40; ++i) {
    const double t = i / 40.0;
    coast_a.push_back({3.0 + 2.0 * t, 60.0 + 0.02 * std::sin(9.0 * t)});       // ~5.6 km edges
    coast_b.push_back({3.0 + 2.0 * t, 62.2 + 0.015 * std::cos(7.0 * t + 1)});  // opposite shore
  }
  s.add_polyline(s.add_feature(s.owner_code("south")), coast_a);
  s.add_polyline(s.add_feature(s.owner_code("north")), coast_b);
  const GridSpec g = geo_grid(3.1, 61.9, 0.006, 300, 267);  // 60.3N .. 61.9N
  expect_exact_equals_brute(s, g, "offshore");
  const NearestField f = run(s, g, Method::exact);
  const GeodesicMeasure m(wgs84());
  for (int64_t r = 0; r < g.height; r += 37)
    for (int64_t c = 0; c < g.width; c += 41) {
      const Vec2 p{g.centre_x(c), g.centre_y(r)};
      double best = std::numeric_limits<double>::infinity();
      for (const auto* line : {&coast_a, &coast_b})
        for (size_t i = 0; i + 1 < line->size(); ++i)
          best = std::min(best, m.segment_distance(p, (*line)[i], (*line)[i + 1]));
      EXPECT_NEAR(f.distance.at(c, r), best, best * 1.2e-7) << c << "," << r;
    }
}

TEST(GeodesicEngine, GeodesicOwnerDiffersFromPlanarDegrees) {
  // At 60N a degree of longitude is ~55.8 km and a degree of latitude ~111.4 km. The cell at
  // (0.05, 59.95) is 1.0 degree below seed A and 1.4 degrees west of seed B: planar in degrees
  // gives A; on the ellipsoid B is ~78 km away and A ~111 km, so B owns it.
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A")), {0.05, 60.95});
  s.add_point(s.add_feature(s.owner_code("B")), {1.45, 59.95});
  const GridSpec g = geo_grid(0.0, 60.0, 0.1, 1, 1);
  const NearestField geo = run(s, g, Method::exact);
  const NearestField planar = run(s, g, Method::exact, 2, std::numeric_limits<double>::infinity(), MetricSpec{});
  EXPECT_EQ(planar.site.at(0, 0), 0);
  EXPECT_EQ(geo.site.at(0, 0), 1);
  double dB;
  GeographicLib::Geodesic::WGS84().Inverse(59.95, 0.05, 59.95, 1.45, dB);
  EXPECT_NEAR(geo.distance.at(0, 0), dB, 0.01);
  EXPECT_EQ(run(s, g, Method::brute_force).site.at(0, 0), 1);
  EXPECT_EQ(run(s, g, Method::hv_scan).site.at(0, 0), 1);
}

TEST(GeodesicEngine, ExactMatchesBruteForceOnRandomFeatures) {
  for (uint32_t trial = 0; trial < 8; ++trial) {
    std::mt19937 rng(trial);
    const double lat_top = -60.0 + static_cast<double>(rng() % 120);
    const double res = 0.05 * (1 + trial % 3);
    const GridSpec g = geo_grid(-20.0 + trial * 7.0, lat_top, res, 30 + rng() % 40, 20 + rng() % 40);
    const SeedSet s = random_features(trial, g.xmin - 1, std::max(-89.0, g.ymin() - 1), g.xmax() + 1,
                                      std::min(89.0, g.ymax + 1), 6 + static_cast<int>(rng() % 12));
    expect_exact_equals_brute(s, g, "trial " + std::to_string(trial));
  }
}

TEST(GeodesicEngine, ManyPointsExactMatchesBruteForce) {
  // Enough sites for the culling to matter (most blocks end with one candidate).
  SeedSet s;
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> lon(-5, 15), lat(50, 62);
  for (int i = 0; i < 150; ++i) s.add_point(s.add_feature(s.owner_code(std::to_string(i % 9))), {lon(rng), lat(rng)});
  expect_exact_equals_brute(s, geo_grid(-3.0, 61.0, 0.15, 100, 70), "150 points");
  expect_exact_equals_brute(s, geo_grid(-3.0, 61.0, 0.15, 100, 70), "150 points, 60 km limit", 60e3);
}

TEST(GeodesicEngine, IdenticalForAnyThreadCount) {
  const GridSpec g = geo_grid(170.0, 20.0, 0.1, 97, 71);
  const SeedSet s = random_features(5, 168, 10, 182, 22, 25);
  for (Method m : {Method::exact, Method::hv_scan, Method::h_scan}) {
    const NearestField one = run(s, g, m, 1);
    for (int t : {2, 7}) {
      const NearestField many = run(s, g, m, t);
      EXPECT_EQ(one.site.cells(), many.site.cells()) << to_string(m) << " threads " << t;
      EXPECT_EQ(one.distance.cells(), many.distance.cells()) << to_string(m) << " threads " << t;
    }
  }
}

TEST(GeodesicEngine, AntimeridianCrossingGrid) {
  // Grid 175E .. 185E (= 175W); seeds given with longitudes in [-180, 180].
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("west")), {178.0, -17.0});
  s.add_point(s.add_feature(s.owner_code("east")), {-178.0, -17.0});
  s.add_polyline(s.add_feature(s.owner_code("reef")),
                 std::vector<Vec2>{{179.5, -19.5}, {-179.5, -19.0}, {-177.0, -19.8}});
  // A polygon straddling the antimeridian, written with longitudes in [-180, 180].
  s.add_polygon(s.add_feature(s.owner_code("island")),
                {{{179.8, -15.2}, {-179.7, -15.2}, {-179.7, -15.6}, {179.8, -15.6}}});
  const GridSpec g = geo_grid(175.0, -14.0, 0.05, 200, 140);
  expect_exact_equals_brute(s, g, "antimeridian");
  const NearestField f = run(s, g, Method::exact);
  // Cell at lon 181.025 (= -178.975), lat -17.025: nearest is "east" (~1 degree away), not
  // "west" (3 degrees away; 177 degrees in raw longitude differences).
  const int64_t c = 120, r = 60;
  ASSERT_NEAR(g.centre_x(c), 181.025, 1e-9);
  ASSERT_NEAR(g.centre_y(r), -17.025, 1e-9);
  EXPECT_EQ(f.site.at(c, r), 1);
  double d;
  GeographicLib::Geodesic::WGS84().Inverse(-17.025, -178.975, -17.0, -178.0, d);
  EXPECT_NEAR(f.distance.at(c, r), d, d * 1e-7 + 1e-3);
  // The polygon's interior is owned on both sides of the antimeridian, at distance 0.
  const int32_t island = s.polygons()[0].area_site;
  ASSERT_EQ(s.sites()[island].kind, SiteKind::area);
  const int64_t rp = 28;                  // lat -15.425
  EXPECT_EQ(f.site.at(97, rp), island);   // lon 179.875
  EXPECT_EQ(f.site.at(103, rp), island);  // lon 180.175 = -179.825
  EXPECT_EQ(f.distance.at(103, rp), 0.0f);
  // The reef segment crossing the antimeridian is measured as the short geodesic.
  const GeodesicMeasure measure(wgs84());
  const int64_t rr = 104;  // lat -19.225
  const Vec2 p{g.centre_x(100), g.centre_y(rr)};
  const double dr = std::min(measure.segment_distance(p, {179.5, -19.5}, {-179.5, -19.0}),
                             measure.segment_distance(p, {-179.5, -19.0}, {-177.0, -19.8}));
  EXPECT_EQ(s.site_owner(f.site.at(100, rr)), 3);
  EXPECT_NEAR(f.distance.at(100, rr), dr, dr * 1e-7 + 1e-3);
}

TEST(GeodesicEngine, GridReachingThePoles) {
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("a")), {0.0, 85.0});
  s.add_point(s.add_feature(s.owner_code("b")), {120.0, 86.0});
  s.add_point(s.add_feature(s.owner_code("c")), {-120.0, 84.0});
  s.add_polyline(s.add_feature(s.owner_code("d")), std::vector<Vec2>{{60.0, 80.0}, {-150.0, 82.0}});
  const GridSpec north = geo_grid(-180.0, 90.0, 2.0, 180, 8);  // the whole cap 74N .. 90N
  expect_exact_equals_brute(s, north, "north cap");
  const NearestField f = run(s, north, Method::exact);
  // The row next to the pole: every cell at lat 89 is within ~1 degree of the pole; compare
  // with GeographicLib directly at a few cells.
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  for (int64_t c : {0, 45, 90, 135}) {
    double da, db, dc;
    geod.Inverse(89.0, north.centre_x(c), 85.0, 0.0, da);
    geod.Inverse(89.0, north.centre_x(c), 86.0, 120.0, db);
    geod.Inverse(89.0, north.centre_x(c), 84.0, -120.0, dc);
    const double dd =
        GeodesicMeasure(wgs84()).segment_distance({north.centre_x(c), 89.0}, {60.0, 80.0}, {-150.0, 82.0});
    const double ref = std::min({da, db, dc, dd});
    EXPECT_NEAR(f.distance.at(c, 0), ref, ref * 1e-7 + 1e-3) << c;
  }
  SeedSet south;
  south.add_point(south.add_feature(south.owner_code("x")), {10.0, -80.0});
  south.add_point(south.add_feature(south.owner_code("y")), {-170.0, -81.0});
  south.add_polygon(south.add_feature(south.owner_code("z")), {{{40, -85}, {60, -85}, {60, -87}, {40, -87}}});
  expect_exact_equals_brute(south, geo_grid(-180.0, -78.0, 0.5, 720, 24), "south pole");
}

TEST(GeodesicEngine, PolygonEnclosingAPole) {
  // An Antarctica-like ring drawn the way EPSG:4326 data draws it: along the coast from -180 to
  // 180, down the antimeridian to the pole and back. Its interior is everything south of the
  // coast, at distance 0, and the ring must not be "unwrapped" into something else.
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("ship")), {0.0, -60.0});
  s.add_polygon(s.add_feature(s.owner_code("ice")),
                {{{-180, -75}, {-90, -74}, {0, -76}, {90, -75}, {180, -75}, {180, -90}, {-180, -90}}});
  const GridSpec g = geo_grid(-180.0, -60.0, 2.0, 180, 15);  // 60S .. 90S
  expect_exact_equals_brute(s, g, "pole-enclosing polygon");
  const NearestField f = run(s, g, Method::exact);
  const int32_t ice = s.polygons()[0].area_site;
  for (int64_t c = 0; c < g.width; c += 7) {
    EXPECT_EQ(f.site.at(c, 14), ice) << c;  // lat -89
    EXPECT_EQ(f.site.at(c, 9), ice) << c;   // lat -79
    EXPECT_EQ(f.distance.at(c, 9), 0.0f) << c;
    EXPECT_NE(f.site.at(c, 0), ice) << c;  // lat -61, open sea
  }
}

TEST(GeodesicEngine, EdgesMeetingAtAVertexTieToTheLowerSite) {
  // Two owners' lines meet at an apex; north of it both are nearest at the apex itself, at the
  // same distance: the lower site (the first feature's edge) must own those cells in every
  // method, which needs both edges to report bit-identical distances there.
  SeedSet s;
  s.add_polyline(s.add_feature(s.owner_code("west")), std::vector<Vec2>{{12.0, 55.0}, {12.5, 55.5}});
  s.add_polyline(s.add_feature(s.owner_code("east")), std::vector<Vec2>{{12.5, 55.5}, {13.0, 55.0}});
  const GridSpec g = geo_grid(12.3, 55.8, 0.01, 40, 40);
  expect_exact_equals_brute(s, g, "apex");
  const NearestField f = run(s, g, Method::exact);
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  int checked = 0;
  for (int64_t r = 0; r < 20; ++r)       // lat 55.795 .. 55.605
    for (int64_t c = 17; c < 23; ++c) {  // lon 12.475 .. 12.525
      EXPECT_EQ(f.site.at(c, r), 0) << c << "," << r;
      double d;
      geod.Inverse(g.centre_y(r), g.centre_x(c), 55.5, 12.5, d);
      EXPECT_NEAR(f.distance.at(c, r), d, d * 1e-7) << c << "," << r;
      ++checked;
    }
  EXPECT_EQ(checked, 120);
  EXPECT_EQ(run(s, g, Method::hv_scan).site.at(20, 5), 0);
}

TEST(GeodesicEngine, VertexSwitchesAtFineAndCoarseResolution) {
  // Edges meeting at turns from 0.05 to 60 degrees: every vertex has a wedge of cells nearest at
  // it, bounded by the perpendiculars where the nearest point switches to an edge's interior;
  // the exact method decides those regimes per cell and interpolates each part. At 0.0001
  // degrees (~6 x 11 m) many cells lie within metres of the switches and of the edges (the
  // additive interpolant across an edge); at 0.01 degrees the same switches run 100 km out.
  SeedSet s;
  s.add_polyline(s.add_feature(s.owner_code("A")), std::vector<Vec2>{{12.000, 55.5000},
                                                                     {12.004, 55.5010},
                                                                     {12.008, 55.50195},
                                                                     {12.012, 55.50290},
                                                                     {12.014, 55.4990},
                                                                     {12.019, 55.4995}});
  s.add_polyline(s.add_feature(s.owner_code("B")), std::vector<Vec2>{{12.003, 55.4930}, {12.010, 55.4950}});
  s.add_point(s.add_feature(s.owner_code("B")), {12.0165, 55.5040});
  expect_exact_equals_brute(s, geo_grid(11.998, 55.5060, 0.0001, 240, 140), "fine");
  expect_exact_equals_brute(s, geo_grid(11.0, 56.0, 0.01, 200, 100), "coarse");
  // And inside a distance limit that cuts through the wedges.
  expect_exact_equals_brute(s, geo_grid(11.998, 55.5060, 0.0001, 240, 140), "fine, limited", 300.0);
}

TEST(GeodesicEngine, VertexMarginHoldsRightAtTheSwitches) {
  // The per-cell test of which part of an edge is nearest (geodesic_exact.cpp, kVertexStop4)
  // leaves a band of |cos w| ~ 1.1e-4 / sqrt(d / 1 m) around each switch between a vertex and an
  // edge's interior: outside it the cell is taken as nearest at the vertex (a tie between the
  // two edges there, to the lower id) or at the interior without measuring, which holds only
  // if brute force's search returns the vertex's canonical distance there too. Grids of
  // millimetre to metre cells straddle the perpendicular to the second edge at its first vertex,
  // 3 m to 300 km out, so that the band and both sides of it are many cells wide.
  SeedSet s;
  const Vec2 v0{12.0, 55.5}, v{12.01, 55.502}, v2{12.02, 55.499};
  s.add_polyline(s.add_feature(s.owner_code("A")), std::vector<Vec2>{v0, v, v2});
  s.add_point(s.add_feature(s.owner_code("B")), {11.0, 50.0});  // far: no effect but a candidate
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  double s12, azi1, azi2;
  geod.Inverse(v.y, v.x, v2.y, v2.x, s12, azi1, azi2);
  for (const double d : {3.0, 100.0, 2e3, 3e4, 3e5}) {
    double lat, lon;
    geod.Direct(v.y, v.x, azi1 - 90.0, d, lat, lon);  // on the perpendicular, north of the line
    const double band = 1.1e-4 * std::sqrt(d);        // metres either side of it
    const double res = band / 4.0 / 111e3;            // degrees: ~4 cells per band
    const GridSpec g = geo_grid(lon - 20.5 * res, lat + 20.5 * res, res, 41, 41);
    const std::string what = "perpendicular at " + std::to_string(d) + " m";
    expect_exact_equals_brute(s, g, what);
    // Both sides of the switch are in the grid: the vertex (the lower edge, id 0, ties) and the
    // second edge's interior (id 1).
    const NearestField f = run(s, g, Method::exact);
    const auto& sites = f.site.cells();
    EXPECT_GT(std::count(sites.begin(), sites.end(), 0), 100) << what;
    EXPECT_GT(std::count(sites.begin(), sites.end(), 1), 100) << what;
  }
}

TEST(GeodesicEngine, DominanceKeepsASiteNearerByGeodesicThanByChord) {
  // A leaf's candidates of point form are dropped where another beats them everywhere
  // (drop_dominated), with geodesic distance bounded above by beta x chord. 300 km north and east
  // of a millimetre block, the geodesic exceeds the chord by ~27.6 m, 0.11 m more to the north
  // (the meridian's smaller radius of curvature): B, east, is 30 mm nearer by geodesic yet ~80 mm
  // farther by chord. Measured by chords alone (beta = 1) B would be dropped and A win.
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  const double lat0 = 55.0, lon0 = 12.0;
  double lat_a, lon_a, lat_b, lon_b, d_a, d_b;
  geod.Direct(lat0, lon0, 0.0, 300e3, lat_a, lon_a);
  geod.Direct(lat0, lon0, 90.0, 300e3 - 30e-3, lat_b, lon_b);
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A")), {lon_a, lat_a});
  s.add_point(s.add_feature(s.owner_code("B")), {lon_b, lat_b});
  const double res = 1e-8;  // ~1 mm
  const GridSpec g = geo_grid(lon0 - 1.5 * res, lat0 + 1.5 * res, res, 3, 3);
  geod.Inverse(g.centre_y(1), g.centre_x(1), lat_a, lon_a, d_a);
  geod.Inverse(g.centre_y(1), g.centre_x(1), lat_b, lon_b, d_b);
  ASSERT_LT(d_b, d_a - 25e-3);
  // The chords say the opposite.
  const GeographicLib::Geocentric& ecef = GeographicLib::Geocentric::WGS84();
  double px, py, pz, ax, ay, az, bx, by, bz;
  ecef.Forward(g.centre_y(1), g.centre_x(1), 0.0, px, py, pz);
  ecef.Forward(lat_a, lon_a, 0.0, ax, ay, az);
  ecef.Forward(lat_b, lon_b, 0.0, bx, by, bz);
  ASSERT_GT(std::hypot(bx - px, by - py, bz - pz), std::hypot(ax - px, ay - py, az - pz) + 50e-3);
  expect_exact_equals_brute(s, g, "north and east");
  const NearestField f = run(s, g, Method::exact);
  for (const int32_t site : f.site.cells()) EXPECT_EQ(site, 1);
}

TEST(GeodesicEngine, CellsNearAnEdgeAreMeasuredExactly) {
  // The additive interpolant of an edge's interior is within ~3e-8 m on 0.2-degree blocks
  // (geodesic_exact.cpp), more than the float32 written resolves near the edge: under
  // kAdditiveMinValue (2 m) cells are measured exactly. 30 short oblique edges, each between two
  // cell centres of a 0.0004-degree grid moved 1.5e-7 degrees north, pass about 1.2 cm from the
  // centres along their diagonals, over line blocks 512 cells wide: to the last bit those
  // distances must be brute force's. (Interpolated there, as with kAdditiveMinValue at 1 cm,
  // 5 of them are off by more than one unit in the last place.)
  const double res = 0.0004;
  const GridSpec g = geo_grid(12.0, 55.5, res, 1024, 64);
  SeedSet s;
  for (int i = 0; i < 30; ++i) {
    const int64_t c = 8 + 34 * i, r = 8 + 17 * (i % 2);
    s.add_polyline(
        s.add_feature(s.owner_code("A")),
        std::vector<Vec2>{{g.centre_x(c), g.centre_y(r) + 1.5e-7}, {g.centre_x(c + 20), g.centre_y(r + 20) + 1.5e-7}});
  }
  expect_exact_equals_brute(s, g, "diagonal edges");
  const NearestField f = run(s, g, Method::brute_force);
  int64_t close = 0;
  for (const float d : f.distance.cells()) close += d < 0.1f;
  EXPECT_GT(close, 500);
}

TEST(GeodesicEngine, EdgesLongerThanAPiece) {
  // Edges of 150 and 260 km (two and three pieces of kGeoPieceLength) meeting at a vertex,
  // with short edges at their far ends: the exact method decides the vertex and interior
  // regimes of the long edges per cell and interpolates them, as for short ones.
  SeedSet s;
  s.add_polyline(s.add_feature(s.owner_code("A")),
                 std::vector<Vec2>{{10.00, 55.00}, {10.02, 55.01}, {12.40, 55.20}, {13.00, 56.50}, {13.02, 56.52}});
  s.add_polyline(s.add_feature(s.owner_code("B")), std::vector<Vec2>{{11.50, 56.20}, {11.60, 56.25}});
  s.add_point(s.add_feature(s.owner_code("B")), {12.20, 55.90});
  expect_exact_equals_brute(s, geo_grid(9.8, 57.0, 0.02, 190, 110), "long edges");
  expect_exact_equals_brute(s, geo_grid(12.30, 55.30, 0.001, 200, 200), "at the vertex of the long edges");
}

TEST(GeodesicEngine, InsidePolygonsALowerSiteAtDistanceZeroWins) {
  // Inside a polygon every cell gets distance 0 and the polygon's site, unless a lower site is
  // at distance exactly 0 there: a basepoint exactly on a cell centre, and a line through cell
  // centres (a meridian through them: the search meets them exactly). The exact method skips
  // the work inside polygons but must still report those.
  const GridSpec g = geo_grid(12.0, 56.0, 0.01, 120, 80);
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A")), {g.centre_x(30), g.centre_y(20)});
  s.add_polyline(s.add_feature(s.owner_code("A")),
                 std::vector<Vec2>{{g.centre_x(50), g.centre_y(10)}, {g.centre_x(50), g.centre_y(40)}});
  s.add_polygon(s.add_feature(s.owner_code("B")),
                {std::vector<Vec2>{{12.05, 55.95}, {12.95, 55.97}, {12.90, 55.45}, {12.08, 55.40}}});
  s.add_point(s.add_feature(s.owner_code("C")), {g.centre_x(70), g.centre_y(30)});  // higher: loses
  s.add_point(s.add_feature(s.owner_code("C")), {13.15, 55.3});
  expect_exact_equals_brute(s, g, "interior");
  const NearestField f = run(s, g, Method::exact);
  EXPECT_EQ(f.site.at(30, 20), 0);
  EXPECT_EQ(f.distance.at(30, 20), 0.0f);
  EXPECT_EQ(s.site_owner(f.site.at(50, 25)), s.site_owner(1));
  EXPECT_EQ(f.distance.at(50, 25), 0.0f);
  EXPECT_EQ(s.site_owner(f.site.at(70, 30)), s.owner_code("B"));
  EXPECT_EQ(s.site_owner(f.site.at(60, 60)), s.owner_code("B"));
}

TEST(GeodesicEngine, InsidePolygonsALowerSiteAtDistanceZeroWinsOnAFineGrid) {
  // The same rule where the interpolated row kernels run (cells of 0.001 deg: line blocks of 128
  // cells). Cells within metres of the line are flagged for exact treatment; inside the polygon
  // they only need to know whether a lower site is at distance exactly 0, and the line, added
  // first, is at distance 0 on its own column.
  const GridSpec g = geo_grid(12.0, 56.0, 0.001, 300, 200);
  SeedSet s;
  s.add_polyline(s.add_feature(s.owner_code("line")),
                 std::vector<Vec2>{{g.centre_x(150), g.centre_y(40)}, {g.centre_x(150), g.centre_y(160)}});
  s.add_polyline(s.add_feature(s.owner_code("diagonal")),
                 std::vector<Vec2>{{12.02, 55.85}, {12.09, 55.98}, {12.13, 55.86}});
  s.add_polygon(s.add_feature(s.owner_code("land")),
                {std::vector<Vec2>{{12.05, 55.99}, {12.28, 55.985}, {12.27, 55.83}, {12.06, 55.82}}});
  s.add_point(s.add_feature(s.owner_code("buoy")), {12.25, 55.81});
  expect_exact_equals_brute(s, g, "fine interior");
  const NearestField f = run(s, g, Method::exact);
  int64_t line_cells = 0, land_cells = 0;
  for (int64_t r = 40; r <= 160; ++r) {
    // The polygon spans rows 10 .. 170 at this column. The line's cells inside it keep the line
    // where the search measures it at exactly 0 (most rows; elsewhere it finds a few nanometres,
    // as brute force does, and the polygon wins), at distance 0 either way.
    EXPECT_EQ(f.distance.at(150, r), 0.0f) << "row " << r;
    line_cells += f.site.at(150, r) == 0;
    // Their neighbours are inside too, a cell (about 63 m) from the line: the polygon's.
    land_cells += s.site_owner(f.site.at(151, r)) == s.owner_code("land");
  }
  RecordProperty("line_cells_at_zero", static_cast<int>(line_cells));
  EXPECT_GT(line_cells, 90);
  EXPECT_EQ(land_cells, 121);
}

TEST(GeodesicEngine, SyntheticCoastlines) {
  // Two states facing each other across a strait (Oresund-like, 55.5N 12.7E): land polygons
  // whose sea-facing edges are wiggly coastlines of many short edges, at 0.002 degrees.
  SeedSet s;
  auto coast = [&](const std::string& owner, double lon0, double sign, uint32_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> wig(-0.004, 0.004);
    std::vector<Vec2> line;
    for (int i = 0; i <= 40; ++i) {
      const double lat = 55.3 + i * 0.01;
      line.push_back({lon0 + 0.03 * std::sin(i * 0.6) + wig(rng), lat});
    }
    std::vector<Vec2> ring = line;
    ring.push_back({lon0 + sign * 0.3, line.back().y});
    ring.push_back({lon0 + sign * 0.3, line.front().y});
    s.add_polygon(s.add_feature(s.owner_code(owner)), {ring});
  };
  coast("DK", 12.6, -1.0, 1);
  coast("SE", 12.9, 1.0, 2);
  s.add_point(s.add_feature(s.owner_code("DK")), {12.72, 55.50});  // an island
  const GridSpec g = geo_grid(12.5, 55.65, 0.002, 200, 100);
  expect_exact_equals_brute(s, g, "coastlines");
  const NearestField exact = run(s, g, Method::exact);
  const ValidationStats hv = compare_fields(s, run(s, g, Method::hv_scan), exact);
  RecordProperty("hv_coast_max_error_cells", std::to_string(hv.max_error_cells));
  EXPECT_LT(hv.max_error_cells, 2.0);
}

TEST(GeodesicEngine, WholeGlobeWithFewSeeds) {
  // A global 2-degree grid and a handful of seeds: nearest distances of thousands of km, cells
  // nearly antipodal to some edges (the non-convex search path), both poles, the seam at 180.
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("a")), {10.0, 50.0});
  s.add_point(s.add_feature(s.owner_code("b")), {-170.0, -50.5});  // ~antipodal to a
  s.add_polyline(s.add_feature(s.owner_code("c")), std::vector<Vec2>{{100, 0}, {140, 20}, {-170, 10}});
  s.add_polyline(s.add_feature(s.owner_code("d")), std::vector<Vec2>{{-60, -60}, {-20, -75}});
  s.add_polygon(s.add_feature(s.owner_code("e")), {{{-100, 40}, {-80, 40}, {-80, 60}, {-100, 60}}});
  const GridSpec g = geo_grid(-180.0, 90.0, 2.0, 180, 90);
  expect_exact_equals_brute(s, g, "globe");
  const NearestField f = run(s, g, Method::exact);
  // Spot checks against GeographicLib at cells whose nearest seed is a point.
  const GeographicLib::Geodesic& geod = GeographicLib::Geodesic::WGS84();
  int checked = 0;
  for (int64_t r = 0; r < g.height; r += 7)
    for (int64_t c = 0; c < g.width; c += 11) {
      const int32_t id = f.site.at(c, r);
      if (id != 0 && id != 1) continue;
      const Vec2 q = s.sites()[static_cast<size_t>(id)].a;
      double d;
      geod.Inverse(g.centre_y(r), g.centre_x(c), q.y, q.x, d);
      EXPECT_NEAR(f.distance.at(c, r), d, d * 1e-7) << c << "," << r;
      ++checked;
    }
  EXPECT_GT(checked, 20);
}

TEST(GeodesicEngine, ScansAreNearlyExact) {
  SeedSet s;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> lon(0, 10), lat(40, 48);
  for (int i = 0; i < 20; ++i) s.add_point(s.add_feature(s.owner_code(std::to_string(i))), {lon(rng), lat(rng)});
  const GridSpec g = geo_grid(0.0, 48.0, 0.1, 100, 80);
  const NearestField brute = run(s, g, Method::brute_force);
  const ValidationStats hv = compare_fields(s, run(s, g, Method::hv_scan), brute);
  EXPECT_LT(hv.max_error_cells, 1.0);
  EXPECT_EQ(hv.nodata_mismatch, 0);
  const ValidationStats self = compare_fields(s, brute, brute);
  EXPECT_EQ(self.wrong_cells + self.tie_cells, 0);
}

TEST(GeodesicEngine, ScansAcrossTheAntimeridian) {
  // Point seeds on both sides of 180, written in [-180, 180]: the scans must seed them into the
  // right cells of a grid running 175 .. 185 (longitudes unwrapped around the grid).
  SeedSet s;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> lon(176, 184), lat(-20, -12);
  for (int i = 0; i < 25; ++i) {
    double x = lon(rng);
    if (x > 180.0) x -= 360.0;
    s.add_point(s.add_feature(s.owner_code(std::to_string(i))), {x, lat(rng)});
  }
  const GridSpec g = geo_grid(175.0, -11.0, 0.1, 100, 100);
  const NearestField brute = run(s, g, Method::brute_force);
  const ValidationStats hv = compare_fields(s, run(s, g, Method::hv_scan), brute);
  EXPECT_LT(hv.max_error_cells, 1.0);
  EXPECT_EQ(hv.nodata_mismatch, 0);
  RecordProperty("hv_antimeridian_wrong_cells", std::to_string(hv.wrong_cells));
  // Each seed's own cell is owned by it (it was seeded there, not only via the border).
  const NearestField h = run(s, g, Method::h_scan);
  for (int32_t id = 0; id < 25; ++id) {
    const Vec2 p = s.sites()[static_cast<size_t>(id)].a;
    const double x = p.x < 0.0 ? p.x + 360.0 : p.x;
    const auto c = static_cast<int64_t>((x - g.xmin) / g.res), r = static_cast<int64_t>((g.ymax - p.y) / g.res);
    EXPECT_EQ(brute.site.at(c, r), id);
    EXPECT_EQ(h.site.at(c, r), id);
  }
}

TEST(GeodesicEngine, WindowsAgreeWithTheWholeGrid) {
  const GridSpec g = geo_grid(178.0, 64.0, 0.05, 90, 70);
  const SeedSet s = random_features(17, 176, 59, 184, 66, 15);
  for (Method m : {Method::exact, Method::hv_scan}) {
    const NearestField whole = run(s, g, m);
    ComputeOptions o;
    o.method = m;
    o.metric = wgs84();
    o.window = Window{20, 15, 41, 33};
    const NearestField part = compute(s, g, o);
    for (int64_t r = 0; r < 33; ++r)
      for (int64_t c = 0; c < 41; ++c) {
        if (m == Method::exact) {
          ASSERT_EQ(part.site.at(c, r), whole.site.at(20 + c, 15 + r)) << c << "," << r;
          ASSERT_EQ(part.distance.at(c, r), whole.distance.at(20 + c, 15 + r)) << c << "," << r;
        }
      }
    if (m == Method::hv_scan) {
      ComputeOptions b = o;
      b.method = Method::brute_force;
      EXPECT_LT(compare_fields(s, part, compute(s, g, b)).max_error_cells, 1.0);
    }
  }
}

// On fine grids (line interpolation blocks of 128 cells or more) leaves of segments are solved by
// the row kernels, and cells whose call is close by the per-cell method; windows cut those leaves
// anywhere, so every cell must get the same bits whichever path and block shape solve it.
// The exact method on each window (with `threads`) equals the whole grid's result (2 threads),
// without and with a distance limit.
void expect_windows_match(const SeedSet& s, const GridSpec& g, std::initializer_list<Window> windows, int threads) {
  for (double limit : {std::numeric_limits<double>::infinity(), 2500.0}) {
    const NearestField whole = run(s, g, Method::exact, 2, limit);
    for (const Window& w : windows) {
      ComputeOptions o;
      o.method = Method::exact;
      o.metric = wgs84();
      o.threads = threads;
      o.max_distance = limit;
      o.window = w;
      EXPECT_TRUE(test::window_matches(compute(s, g, o), whole)) << "limit " << limit;
    }
  }
}

TEST(GeodesicEngine, FineGridWindowsAgreeWithTheWholeGrid) {
  const GridSpec g = geo_grid(11.90, 55.60, 0.0005, 420, 300);  // 0.0005 deg: 256-cell line blocks
  SeedSet s = random_features(29, 11.95, 55.47, 12.08, 55.58, 14);
  s.add_polyline(s.add_feature(s.owner_code("coast")), std::vector<Vec2>{{11.90, 55.52},
                                                                         {11.93, 55.5230},
                                                                         {11.95, 55.5205},
                                                                         {11.97, 55.5260},
                                                                         {11.99, 55.5240},
                                                                         {12.02, 55.5290},
                                                                         {12.06, 55.5270},
                                                                         {12.11, 55.5310}});
  expect_windows_match(s, g, {Window{37, 61, 211, 150}, Window{129, 0, 291, 97}, Window{0, 203, 420, 97}}, 1);
}

// A whole grid with more than 4 MiB of results writes its rows with non-temporal stores; its
// windows here are smaller and do not. Their cells must be the same bits.
TEST(GeodesicEngine, StreamedWholeGridEqualsItsUnstreamedWindows) {
  const GridSpec g = geo_grid(11.90, 55.60, 0.0005, 1031, 521);
  ASSERT_GT(g.width * g.height * 8, int64_t{4} << 20);
  SeedSet s = random_features(40, 11.92, 55.36, 12.40, 55.59, 21);
  s.add_polyline(s.add_feature(s.owner_code("coast")),
                 std::vector<Vec2>{{11.90, 55.52}, {11.97, 55.5260}, {12.06, 55.5270}, {12.31, 55.5310}});
  expect_windows_match(s, g, {Window{3, 5, 517, 260}, Window{514, 260, 517, 261}}, 2);
}

// On fine grids a point-form interpolation block is 512 x 512 cells, 16 tiles that any thread
// may take, all using the interpolants the first of them built, and a line block up to that.
// Windows of the whole grid's result straddling block edges against brute force on those
// windows: points, a coastline offshore and a polygon; owners equal, distances within the last
// bit. 0.0004 deg: blocks of 0.2 and 0.2 deg (512 cells both); 0.00064 deg: 0.33 and 0.16 deg
// (512 and 256 cells); near the largest spans allowed (kPointSpan 0.35, kLineSpan 0.21).
TEST(GeodesicEngine, InterpolationBlocksSharedByTilesMatchBruteForce) {
  struct Case {
    double res;
    int64_t w, h;
    std::vector<Window> windows;
  } cases[] = {
      {0.0004, 1300, 1100, {Window{470, 480, 90, 70}, Window{990, 500, 70, 60}, Window{480, 1000, 80, 60}}},
      {0.00064, 800, 680, {Window{470, 480, 90, 70}, Window{200, 230, 100, 60}, Window{720, 600, 70, 60}}},
  };
  for (const Case& k : cases) {
    const GridSpec g = geo_grid(12.0, 56.0, k.res, k.w, k.h);  // 12.0 .. 12.52E, 55.56 .. 56.0N
    SeedSet s;
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> lon(11.95, 12.57), lat(55.5, 56.05);
    for (int i = 0; i < 14; ++i) s.add_point(s.add_feature(s.owner_code(std::to_string(i % 3))), {lon(rng), lat(rng)});
    std::vector<Vec2> coast;
    for (int i = 0; i <= 30; ++i)
      coast.push_back({12.05 + 0.015 * i, 55.74 + 0.01 * std::sin(0.9 * i) + 0.002 * (i % 3)});  // ~1 km edges
    s.add_polyline(s.add_feature(s.owner_code("coast")), coast);
    s.add_polygon(s.add_feature(s.owner_code("island")),
                  {{{12.30, 55.90}, {12.33, 55.905}, {12.335, 55.92}, {12.31, 55.93}, {12.30, 55.90}}});
    for (int threads : {2, 3}) {
      const NearestField whole = run(s, g, Method::exact, threads);
      for (const Window& w : k.windows) {
        ComputeOptions o;
        o.method = Method::brute_force;
        o.metric = wgs84();
        o.threads = 2;
        o.window = w;
        const NearestField brute = compute(s, g, o);
        o.method = Method::exact;
        o.threads = threads;
        const NearestField part = compute(s, g, o);
        const std::string what =
            "res " + std::to_string(k.res) + " window " + std::to_string(w.col0) + "," + std::to_string(w.row0);
        EXPECT_EQ(part.site.cells(), brute.site.cells()) << what;
        expect_within_one_ulp(part.distance, brute.distance, what);
        EXPECT_TRUE(test::window_matches(part, whole)) << what;
      }
    }
  }
}

TEST(GeodesicEngine, MemoryEstimateCountsPreparedEdges) {
  const int64_t planar = estimate_memory(Method::exact, 1000, 100000);
  const int64_t geodesic = estimate_memory(Method::exact, 1000, 100000, MetricSpec::geodesic);
  EXPECT_GT(geodesic - planar, 100000 * 500);  // a GeographicLib::GeodesicLine alone is ~0.5 KB
}

TEST(GeodesicEngine, RefusesWhatItCannotMeasure) {
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("a")), {0.0, 0.0});
  auto kind = [](auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      return e.kind();
    }
    return ErrorKind::internal;
  };
  EXPECT_EQ(kind([&] { run(s, geo_grid(0, 91, 1, 5, 5), Method::exact); }), ErrorKind::invalid_argument);
  EXPECT_EQ(kind([&] { run(s, geo_grid(0, -85, 1, 5, 6), Method::exact); }), ErrorKind::invalid_argument);
  EXPECT_EQ(kind([&] { run(s, geo_grid(0, 10, 1, 361, 5), Method::exact); }), ErrorKind::invalid_argument);
  SeedSet bad;
  bad.add_point(bad.add_feature(bad.owner_code("a")), {0.0, 95.0});
  EXPECT_EQ(kind([&] { run(bad, geo_grid(0, 10, 1, 5, 5), Method::exact); }), ErrorKind::invalid_input);
  MetricSpec flat = wgs84();
  flat.flattening = 0.2;
  EXPECT_EQ(kind([&] { run(s, geo_grid(0, 10, 1, 5, 5), Method::exact, 1, INFINITY, flat); }),
            ErrorKind::invalid_argument);
  // Fields of different metrics cannot be compared.
  const NearestField geo = run(s, geo_grid(0, 10, 1, 5, 5), Method::exact);
  const NearestField planar = run(s, geo_grid(0, 10, 1, 5, 5), Method::exact, 1, INFINITY, MetricSpec{});
  EXPECT_EQ(kind([&] { compare_fields(s, geo, planar); }), ErrorKind::invalid_argument);
}

}  // namespace
}  // namespace rv
