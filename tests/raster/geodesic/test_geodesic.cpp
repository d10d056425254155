// Geodesic measuring: the metric helpers, point distances and point-to-geodesic-segment
// distances against GeographicLib used directly (dense sampling along GeodesicLine).
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>

#include <cmath>
#include <random>

#include "error_kind.hpp"
#include "rv/field/error.hpp"
#include "rv/field/metric.hpp"
#include "rv/geodesic/geodesic.hpp"
#include "utm33.hpp"

namespace rv {
namespace {

using GeographicLib::Geodesic;
using GeographicLib::GeodesicLine;

MetricSpec wgs84() {
  MetricSpec m;
  m.kind = MetricSpec::geodesic;
  return m;
}

using test::kind_of;

TEST(Metric, DistanceUnits) {
  EXPECT_EQ(parse_distance_unit("m"), DistanceUnit::m);
  EXPECT_EQ(parse_distance_unit("km"), DistanceUnit::km);
  EXPECT_EQ(parse_distance_unit("nmi"), DistanceUnit::nmi);
  EXPECT_EQ(metres_per_unit(DistanceUnit::m), 1.0);
  EXPECT_EQ(metres_per_unit(DistanceUnit::km), 1000.0);
  EXPECT_EQ(metres_per_unit(DistanceUnit::nmi), 1852.0);
  EXPECT_EQ(to_string(DistanceUnit::nmi), "nmi");
  EXPECT_EQ(kind_of([] { parse_distance_unit("mi"); }), ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of([] { parse_distance_unit("KM"); }), ErrorKind::invalid_argument);
}

TEST(Metric, ResolvePolicy) {
  EXPECT_EQ(resolve_metric(MetricRequest::automatic, true).kind, MetricSpec::geodesic);
  EXPECT_EQ(resolve_metric(MetricRequest::automatic, false).kind, MetricSpec::planar);
  EXPECT_EQ(resolve_metric(MetricRequest::planar, false).kind, MetricSpec::planar);
  EXPECT_EQ(resolve_metric(MetricRequest::geodesic, true).kind, MetricSpec::geodesic);
  const MetricSpec grs = resolve_metric(MetricRequest::automatic, true, 6378137.0, 1 / 298.257222101);
  EXPECT_EQ(grs.flattening, 1 / 298.257222101);
  EXPECT_EQ(kind_of([] { resolve_metric(MetricRequest::planar, true); }), ErrorKind::invalid_argument);
  try {
    resolve_metric(MetricRequest::planar, true);
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("degrees"), std::string::npos) << e.what();
  }
  // Geodesic on a projected CRS is allowed (cell centres located by a Geolocator), with the
  // CRS's ellipsoid; auto on a projected CRS stays planar (checked above).
  const MetricSpec projected = resolve_metric(MetricRequest::geodesic, false, 6378388.0, 1 / 297.0);
  EXPECT_EQ(projected.kind, MetricSpec::geodesic);
  EXPECT_EQ(projected.semi_major, 6378388.0);
  EXPECT_EQ(projected.flattening, 1 / 297.0);
  EXPECT_EQ(kind_of([] { resolve_metric(MetricRequest::geodesic, false, 6e6, 0.5); }), ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of([] { resolve_metric(MetricRequest::geodesic, true, -1.0, 0.0); }), ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of([] { resolve_metric(MetricRequest::geodesic, true, 6e6, 0.5); }), ErrorKind::invalid_argument);
  EXPECT_EQ(parse_metric_request("auto"), MetricRequest::automatic);
  EXPECT_EQ(parse_metric_request("geodesic"), MetricRequest::geodesic);
  EXPECT_EQ(kind_of([] { parse_metric_request("great-circle"); }), ErrorKind::invalid_argument);
  EXPECT_EQ(unwrap_east_longitude(170.0, -170.0), 190.0);
  EXPECT_EQ(unwrap_east_longitude(-10.0, 10.0), 10.0);
}

TEST(GeodesicMeasure, PointDistancesMatchGeographicLib) {
  const GeodesicMeasure measure(wgs84());
  const Geodesic& g = Geodesic::WGS84();
  struct Case {
    Vec2 p, q;
    const char* what;
  };
  const Case cases[] = {
      {{0, 0}, {1, 0}, "equator, one degree"},
      {{-45, 0}, {135, 0}, "equator, antipodal"},
      {{10, 0.5}, {-169.5, -0.4}, "near-antipodal"},
      {{0, 30}, {179.9, -30.05}, "near-antipodal, mid latitude"},
      {{179.5, 10}, {-179.5, 10.5}, "across the antimeridian"},
      {{359.5, 10}, {0.5, 10}, "longitude beyond 180"},
      {{20, 89.9}, {-160, 89.9}, "across the north pole"},
      {{0, 90}, {77, 80}, "from the pole"},
      {{12.6, 55.7}, {12.65, 55.71}, "short, high latitude"},
      {{-70, -85}, {110, -86}, "antarctic, across the pole"},
  };
  for (const Case& c : cases) {
    double ref;
    g.Inverse(c.p.y, c.p.x, c.q.y, c.q.x, ref);
    EXPECT_NEAR(measure.point_distance(c.p, c.q), ref, 1e-9) << c.what;
  }
  // Independent values: a degree of the equator is a*pi/180; pole to equator is the quarter
  // meridian of WGS84, 10001965.729 m.
  EXPECT_NEAR(measure.point_distance({0, 0}, {1, 0}), 6378137.0 * M_PI / 180.0, 1e-6);
  EXPECT_NEAR(measure.point_distance({0, 0}, {0, 90}), 10001965.729, 1e-3);
  EXPECT_EQ(kind_of([&] { measure.point_distance({0, 91}, {0, 0}); }), ErrorKind::invalid_argument);
}

// Reference: the minimum over a dense sampling of the geodesic a-b, refined around the best
// sample (four levels of 2000 samples each: the final spacing is L / 1.6e13).
double sampled_segment_distance(Vec2 p, Vec2 a, Vec2 b) {
  const Geodesic& g = Geodesic::WGS84();
  const GeodesicLine line = g.InverseLine(a.y, a.x, b.y, b.x);
  const double length = line.Distance();
  auto dist_at = [&](double t) {
    double lat, lon, s;
    line.Position(t, lat, lon);
    g.Inverse(lat, lon, p.y, p.x, s);
    return s;
  };
  double lo = 0.0, hi = length, best = std::min(dist_at(0.0), dist_at(length));
  constexpr int kSamples = 2000;
  for (int level = 0; level < 4; ++level) {
    const double step = (hi - lo) / kSamples;
    double best_t = lo, level_best = std::numeric_limits<double>::infinity();
    for (int i = 0; i <= kSamples; ++i) {
      const double t = lo + step * i;
      const double s = dist_at(t);
      if (s < level_best) {
        level_best = s;
        best_t = t;
      }
    }
    best = std::min(best, level_best);
    lo = std::max(0.0, best_t - step);
    hi = std::min(length, best_t + step);
  }
  return best;
}

struct SegmentCase {
  Vec2 p, a, b;
  const char* what;
};

void check_segment_cases(const std::vector<SegmentCase>& cases) {
  const GeodesicMeasure measure(wgs84());
  for (const SegmentCase& c : cases) {
    const double got = measure.segment_distance(c.p, c.a, c.b);
    const double ref = sampled_segment_distance(c.p, c.a, c.b);
    // Never below the true minimum (beyond GeographicLib's error), at most 1e-6 m above it.
    EXPECT_GE(got, ref - 1e-6) << c.what;
    EXPECT_LE(got, ref + 1e-6) << c.what;
  }
}

TEST(GeodesicMeasure, SegmentDistanceMatchesDenseSampling) {
  check_segment_cases({
      {{1.0, 1.0}, {0, 0}, {2, 0}, "equator, foot inside"},
      {{3.0, 0.5}, {0, 0}, {2, 0}, "equator, beyond the end"},
      {{-0.001, 0.0005}, {0, 0}, {2, 0}, "just before the first end"},
      {{1.0, 0.0}, {0, 0}, {2, 0}, "on the segment"},
      {{1.0, 1e-9}, {0, 0}, {2, 0}, "a nanodegree off the segment"},
      {{0.5, 0.3}, {0, 0}, {1, 1}, "diagonal"},
      {{12.6, 55.8}, {12.5, 55.6}, {12.7, 55.65}, "Oresund scale"},
      {{15.0, 81.0}, {10, 80}, {30, 80.5}, "high latitude, geodesic bulges poleward"},
      {{20.0, 80.8}, {10, 80}, {30, 80}, "north of a high-latitude chord"},
      {{0.0, 89.0}, {-60, 88}, {120, 88}, "segment across the pole"},
      {{179.8, -16.9}, {179.5, -17}, {-179.5, -16.5}, "segment across the antimeridian"},
      {{-179.9, -16.6}, {179.5, -17}, {-179.5, -16.5}, "cell across the antimeridian"},
      {{10, 10}, {0, 0}, {20, 25}, "long (3000 km, several pieces)"},
      {{-40, 20}, {-60, 0}, {60, 10}, "longer than a quarter meridian"},
      {{0.0, -70.0}, {-60, 0}, {60, 10}, "far from a long segment"},
      {{-179.0, -1.0}, {0, 0}, {2, 0.5}, "near-antipodal to the segment"},
      {{-178.0, 0.3}, {0, -1}, {3, 1}, "near-antipodal to the middle"},
      {{100.0, 5.0}, {0, 0}, {2, 0}, "beyond 90 degrees away"},
  });
}

TEST(GeodesicMeasure, SegmentDistanceRandomRegional) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> lon(-20, 20), lat(40, 75), off(-3, 3);
  std::vector<SegmentCase> cases;
  for (int i = 0; i < 40; ++i) {
    const Vec2 a{lon(rng), lat(rng)};
    const Vec2 b{a.x + off(rng), std::clamp(a.y + off(rng), -89.0, 89.0)};
    const Vec2 p{a.x + off(rng), std::clamp(a.y + off(rng), -89.0, 89.0)};
    cases.push_back({p, a, b, "random"});
  }
  GeodesicSegmentCounters& counters = geodesic_segment_counters();
  counters = {};
  check_segment_cases(cases);
  const double per_call = static_cast<double>(counters.evaluations) / static_cast<double>(counters.calls);
  RecordProperty("evaluations_per_piece_search", std::to_string(per_call));
  EXPECT_LT(per_call, 6.0);  // the interception iteration converges in a few steps
}

TEST(GeodesicMeasure, DegenerateSegmentIsAPoint) {
  const GeodesicMeasure measure(wgs84());
  const double as_point = measure.point_distance({5, 5}, {180, 10});
  EXPECT_NEAR(measure.segment_distance({5, 5}, {180, 10}, {-180, 10}), as_point, 1e-9);
}

// The least distance (metres) from g to the straight chord p-q, the chord straight in
// longitude/latitude or, with a grid, in the grid's CRS: a golden-section search along it.
double chord_distance(const Geodesic& geod, Vec2 g, Vec2 p, Vec2 q, const test::Utm33* grid) {
  Vec2 gp = p, gq = q;
  if (grid) {
    const double lon[2] = {p.x, q.x}, lat[2] = {p.y, q.y};
    double x[2], y[2];
    grid->to_grid(lon, lat, x, y, 2);
    gp = {x[0], y[0]};
    gq = {x[1], y[1]};
  }
  auto at = [&](double u) {
    Vec2 c{gp.x + u * (gq.x - gp.x), gp.y + u * (gq.y - gp.y)};
    if (grid) {
      Vec2 ll;
      grid->to_lonlat(&c.x, &c.y, &ll.x, &ll.y, 1);
      c = ll;
    }
    double s12;
    geod.Inverse(g.y, g.x, c.y, c.x, s12);
    return s12;
  };
  double lo = 0.0, hi = 1.0;
  const double r = (std::sqrt(5.0) - 1.0) / 2.0;
  for (int i = 0; i < 40; ++i) {  // (to a ten-millionth of the chord)
    const double m1 = hi - r * (hi - lo), m2 = lo + r * (hi - lo);
    if (at(m1) < at(m2))
      hi = m2;
    else
      lo = m1;
  }
  return at(0.5 * (lo + hi));
}

// Chords along a geodesic: each within the tolerance of the geodesic between its ends (8 points
// sampled along each, GeographicLib's), every point on the geodesic, the ends as given; not four
// times as many as a uniform split needs; none added where the geodesic is straight already
// (a meridian, the equator); straight in a grid's CRS with a Geolocator.
TEST(GeodesicMeasure, ChordsFollowTheGeodesicWithinTheTolerance) {
  const GeodesicMeasure measure(wgs84());
  const Geodesic& geod = Geodesic::WGS84();
  const test::Utm33 utm;
  std::mt19937_64 rng(71);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int64_t chords = 0, edges_split = 0;
  double worst = 0.0;
  for (int round = 0; round < 120; ++round) {
    const bool projected = round % 3 == 2;
    const double tolerance = round % 2 == 0 ? 1e-3 : 2e-2;
    // Regional edges 10 m to 300 km long; projected ones within UTM 33N's reach.
    const Vec2 a = projected ? Vec2{12.0 + 6.0 * unit(rng), 50.0 + 10.0 * unit(rng)}
                             : Vec2{-180.0 + 360.0 * unit(rng), -70.0 + 140.0 * unit(rng)};
    const double length = std::exp(std::log(10.0) + unit(rng) * std::log(3e4)), azimuth = 360.0 * unit(rng);
    Vec2 b;
    geod.Direct(a.y, a.x, azimuth, length, b.y, b.x);
    const std::vector<Vec2> pts = measure.chords(a, b, tolerance, projected ? &utm : nullptr);
    ASSERT_GE(pts.size(), 2u);
    ASSERT_TRUE(pts.front() == a) << round;
    ASSERT_TRUE(pts.back() == b) << round;
    chords += static_cast<int64_t>(pts.size()) - 1;
    edges_split += pts.size() > 2;
    for (size_t k = 0; k + 1 < pts.size(); ++k) {
      const Vec2 p = pts[k], q = pts[k + 1];
      ASSERT_LT(measure.segment_distance(p, a, b), 1e-6) << round;
      const GeodesicLine line = geod.InverseLine(p.y, p.x, q.y, q.x);
      for (int i = 1; i <= 8; ++i) {
        Vec2 g;
        line.Position(line.Distance() * i / 9.0, g.y, g.x);
        const double off = chord_distance(geod, g, p, q, projected ? &utm : nullptr);
        worst = std::max(worst, off / tolerance);
        ASSERT_LE(off, tolerance) << round << " piece " << k << " of " << pts.size() - 1;
      }
    }
    // A uniform split into a quarter as many pieces strays beyond the tolerance somewhere.
    const auto quarter = static_cast<int>((pts.size() - 1) / 4);
    if (quarter < 2) continue;
    const GeodesicLine whole = geod.InverseLine(a.y, a.x, b.y, b.x);
    double beyond = 0.0;
    for (int k = 0; k < quarter; ++k) {
      Vec2 p, q, g;
      whole.Position(whole.Distance() * k / quarter, p.y, p.x);
      whole.Position(whole.Distance() * (k + 1) / quarter, q.y, q.x);
      whole.Position(whole.Distance() * (k + 0.5) / quarter, g.y, g.x);
      beyond = std::max(beyond, chord_distance(geod, g, p, q, projected ? &utm : nullptr));
    }
    EXPECT_GT(beyond, tolerance) << round << ": " << pts.size() - 1 << " chords where fewer would do";
  }
  EXPECT_GT(edges_split, 30);  // (the cases reach the refinement)
  RecordProperty("chords", std::to_string(chords));
  RecordProperty("worst_over_tolerance", std::to_string(worst));
  // Straight already: a meridian and the equator keep their ends alone; so does a point.
  EXPECT_EQ(measure.chords({10.0, 40.0}, {10.0, 45.0}, 1e-3).size(), 2u);
  EXPECT_EQ(measure.chords({10.0, 0.0}, {13.0, 0.0}, 1e-3).size(), 2u);
  EXPECT_EQ(measure.chords({10.0, 40.0}, {10.0, 40.0}, 1e-3).size(), 1u);
  // A clip edge along 53.8 N, 4.5 degrees long: its geodesic bows kilometres north of the
  // parallel, and the chords follow it there (their northmost point at its middle).
  const std::vector<Vec2> clip = measure.chords({9.0, 53.8}, {13.5, 53.8}, 1e-3);
  EXPECT_GT(clip.size(), 100u);
  Vec2 north{0.0, 0.0};
  for (const Vec2& p : clip)
    if (p.y > north.y) north = p;
  const GeodesicLine edge = geod.InverseLine(53.8, 9.0, 53.8, 13.5);
  Vec2 middle;
  edge.Position(0.5 * edge.Distance(), middle.y, middle.x);
  double bow, off;
  geod.Inverse(53.8, middle.x, middle.y, middle.x, bow);
  geod.Inverse(north.y, north.x, middle.y, middle.x, off);
  EXPECT_GT(bow, 2000.0);
  EXPECT_LT(off, 1e-3 * edge.Distance() / static_cast<double>(clip.size()) + 1.0);
  EXPECT_EQ(kind_of([&] { measure.chords({0, 0}, {1, 1}, 0.0); }), ErrorKind::invalid_argument);
  EXPECT_EQ(kind_of([&] { measure.chords({0, 91}, {1, 1}, 1e-3); }), ErrorKind::invalid_argument);
}

}  // namespace
}  // namespace rv

// The culling bounds (internal): never above the distance they bound.
#include "field/geodesic_sites.hpp"

namespace rv {
namespace {

TEST(GeodesicBounds, LowerBoundsNeverExceedTheDistance) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> lon(-180, 180), lat(-89, 89), unit(0, 1);
  std::vector<Site> sites;
  for (int i = 0; i < 60; ++i) {
    const Vec2 a{lon(rng), lat(rng)};
    // Lengths from ~1 m to ~3000 km.
    const double span = std::pow(10.0, -5.0 + 6.5 * unit(rng));
    const Vec2 b{a.x + span * (unit(rng) - 0.5), std::clamp(a.y + span * (unit(rng) - 0.5), -90.0, 90.0)};
    sites.push_back(Site{a, b, i, i % 4 == 0 ? SiteKind::point : SiteKind::segment});
  }
  const detail::GeoSites geo(wgs84(), sites);
  int checked = 0;
  for (size_t id = 0; id < sites.size(); ++id) {
    const Site& s = sites[id];
    for (int k = 0; k < 20; ++k) {
      // Cells near the site (within a few times its size) and far away.
      const double r = k < 15 ? std::pow(10.0, -4.0 + 5.0 * unit(rng)) : 60.0;
      const double clon = s.a.x + r * (unit(rng) - 0.5);
      const double clat = std::clamp(s.a.y + r * (unit(rng) - 0.5), -90.0, 90.0);
      // A 4x4 block of cells around it, 0.001 degree apart.
      detail::EcefBox box{1e300, -1e300, 1e300, -1e300, 1e300, -1e300};
      double block_min = 1e300;
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
          const detail::GeoCell c = geo.cell(clon + 0.001 * i, std::clamp(clat - 0.001 * j, -90.0, 90.0));
          const double d = geo.distance(c, static_cast<int32_t>(id));
          EXPECT_LE(geo.lower_bound(c, static_cast<int32_t>(id)), d + 1e-8) << id;
          block_min = std::min(block_min, d);
          box = {std::min(box.x0, c.x), std::max(box.x1, c.x), std::min(box.y0, c.y),
                 std::max(box.y1, c.y), std::min(box.z0, c.z), std::max(box.z1, c.z)};
          ++checked;
        }
      EXPECT_LE(geo.lower_bound(box, static_cast<int32_t>(id)), block_min + 1e-8) << id;
    }
  }
  EXPECT_EQ(checked, 60 * 20 * 16);
}

TEST(GeodesicBounds, CapsuleBoundIsTightForShortEdges) {
  // A 500 m coastline edge: the lower bound from a cell 20 km away is within 1 m of the
  // distance (chord vs arc over 20 km is ~2 cm; the capsule radius a few mm).
  const std::vector<Site> sites{Site{{12.60, 55.60}, {12.605, 55.603}, 0, SiteKind::segment}};
  const detail::GeoSites geo(wgs84(), sites);
  const detail::GeoCell c = geo.cell(12.9, 55.55);
  const double d = geo.distance(c, 0), lb = geo.lower_bound(c, 0);
  EXPECT_LE(lb, d);
  EXPECT_GT(lb, d - 1.0);
}

}  // namespace
}  // namespace rv
