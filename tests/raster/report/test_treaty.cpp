// Treaty tables: degrees-minutes-seconds both ways, and segments on the ellipsoid against
// GeographicLib used independently (dense sampling).
#include <gtest/gtest.h>
#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>
#include <GeographicLib/Rhumb.hpp>

#include <cmath>
#include <random>

#include "rv/field/error.hpp"
#include "rv/report/treaty.hpp"

namespace rv {
namespace {

TEST(Treaty, DegreesMinutesSeconds) {
  EXPECT_EQ(to_dms(55.0 + 30.0 / 60.0 + 12.125 / 3600.0, true), "55\u00b030'12.125\"N");
  EXPECT_EQ(to_dms(-(12.0 + 5.0 / 60.0), false), "012\u00b005'00.000\"W");
  // Rounding carries: 59.9996" is the next minute, and the next degree.
  EXPECT_EQ(to_dms(10.0 + 59.0 / 60.0 + 59.9996 / 3600.0, true), "11\u00b000'00.000\"N");
  EXPECT_EQ(to_dms(std::nan(""), true), "");
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> lat(-90.0, 90.0), lon(-180.0, 180.0);
  for (int i = 0; i < 10000; ++i) {
    const double y = lat(rng), x = lon(rng);
    ASSERT_LE(std::abs(from_dms(to_dms(y, true)) - y) * 3600.0, 0.0005) << to_dms(y, true);
    ASSERT_LE(std::abs(from_dms(to_dms(x, false)) - x) * 3600.0, 0.0005) << to_dms(x, false);
  }
  EXPECT_NEAR(from_dms("55\u00b0 30' 12.5\" S"), -(55.0 + 30.0 / 60.0 + 12.5 / 3600.0), 1e-12);
  for (const char* bad : {"", "55", "55\u00b030'12\"X", "55\u00b061'00\"N", "abc"})
    EXPECT_THROW(from_dms(bad), Error) << bad;
}

// The distance from p to the geodesic from a to b by dense sampling (the reference).
double to_geodesic_sampled(Vec2 a, Vec2 b, Vec2 p) {
  const GeographicLib::Geodesic& g = GeographicLib::Geodesic::WGS84();
  double s12 = 0.0;
  g.Inverse(a.y, a.x, b.y, b.x, s12);
  const GeographicLib::GeodesicLine line = g.InverseLine(a.y, a.x, b.y, b.x);
  double best = 1e300;
  constexpr int kSamples = 20000;
  for (int k = 0; k <= kSamples; ++k) {
    double lat = 0.0, lon = 0.0, d = 0.0;
    line.Position(s12 * k / kSamples, lat, lon);
    g.Inverse(p.y, p.x, lat, lon, d);
    best = std::min(best, d);
  }
  return best;
}

// Along 60 N from 0 to 10 E the rhumb line is the parallel and the geodesic bulges north: the
// separation against a dense sampling of both, within 1 cm; the rhumb line as the "true line"
// strays from the geodesic by the same.
TEST(Treaty, GeodesicAgainstRhumbOnTheParallel) {
  const Vec2 a{0.0, 60.0}, b{10.0, 60.0};
  const GeographicLib::Rhumb& rhumb = GeographicLib::Rhumb::WGS84();
  double rhumb_length = 0.0, azimuth = 0.0;
  rhumb.Inverse(a.y, a.x, b.y, b.x, rhumb_length, azimuth);
  double reference = 0.0;
  std::vector<Vec2> parallel;
  for (int k = 0; k <= 100; ++k) {
    double lat = 0.0, lon = 0.0;
    rhumb.Direct(a.y, a.x, azimuth, rhumb_length * k / 100, lat, lon);
    reference = std::max(reference, to_geodesic_sampled(a, b, Vec2{lon, lat}));
    parallel.push_back(Vec2{lon, lat});
  }
  const SegmentOnEllipsoid s = segment_on_ellipsoid(a, b, parallel, MetricSpec{MetricSpec::geodesic});
  double length = 0.0, azi1 = 0.0, azi2 = 0.0;
  GeographicLib::Geodesic::WGS84().Inverse(a.y, a.x, b.y, b.x, length, azi1, azi2);
  EXPECT_DOUBLE_EQ(s.length, length);
  EXPECT_DOUBLE_EQ(s.azimuth, azi1);
  EXPECT_NEAR(s.rhumb_length, rhumb_length, 1e-6);
  EXPECT_GT(reference, 1000.0);  // kilometres apart at 60 N over 10 degrees
  EXPECT_NEAR(s.rhumb_separation, reference, 0.01);
  EXPECT_NEAR(s.deviation, reference, 0.01);
  // A true line that is the geodesic itself does not stray.
  const GeographicLib::GeodesicLine line = GeographicLib::Geodesic::WGS84().InverseLine(a.y, a.x, b.y, b.x);
  std::vector<Vec2> on;
  for (int k = 0; k <= 10; ++k) {
    double lat = 0.0, lon = 0.0;
    line.Position(length * k / 10, lat, lon);
    on.push_back(Vec2{lon, lat});
  }
  EXPECT_LT(segment_on_ellipsoid(a, b, on, MetricSpec{MetricSpec::geodesic}).deviation, 1e-4);
}

}  // namespace
}  // namespace rv
