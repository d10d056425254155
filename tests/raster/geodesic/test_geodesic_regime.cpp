// Which part of a geodesic segment is nearest from a cell (geodesic_regime.hpp), on its own:
// a regime the per-cell test calls certain is the truth brute force finds, and a block's
// certain regime and possible regimes hold at every cell of the block.
#include <gtest/gtest.h>

#include <GeographicLib/Geodesic.hpp>

#include <cmath>
#include <random>
#include <vector>

#include "geodesic/geodesic_regime.hpp"
#include "rv/field/metric.hpp"

namespace rv::detail {
namespace {

MetricSpec wgs84() {
  MetricSpec m;
  m.kind = MetricSpec::geodesic;
  return m;
}

// Segments of several lengths and headings, at several latitudes (site ids 0..n-1).
std::vector<Site> segments() {
  std::vector<Site> s;
  const double lats[] = {0.0, 35.0, 55.7, 70.0};
  const double lengths[] = {0.01, 0.2, 1.5};  // degrees
  int32_t f = 0;
  for (double lat : lats)
    for (double len : lengths)
      for (double heading : {0.0, 0.6, 1.7}) {
        const Vec2 a{12.0, lat};
        const Vec2 b{12.0 + len * std::cos(heading), lat + len * std::sin(heading)};
        s.push_back(Site{a, b, f++, SiteKind::segment});
      }
  return s;
}

double vertex_distance(const GeographicLib::Geodesic& g, const GeoCell& p, Vec2 v) {
  double d;
  g.Inverse(v.y, v.x, p.lat, p.lon, d);
  return d;
}

TEST(GeodesicRegime, ACertainRegimeIsWhereBruteForceFindsTheNearestPoint) {
  const std::vector<Site> sites = segments();
  const GeoSites geo(wgs84(), sites);
  const SegmentRegimes regimes(geo);
  const GeographicLib::Geodesic& g = geo.geodesic();
  std::mt19937_64 rng(5);
  int counts[4] = {0, 0, 0, 0};
  for (int32_t id = 0; id < static_cast<int32_t>(sites.size()); ++id) {
    const Site& s = sites[static_cast<size_t>(id)];
    std::uniform_real_distribution<double> dx(-2.0, 2.0), dy(-1.5, 1.5);
    for (int k = 0; k < 400; ++k) {
      const GeoCell p = geo.cell(s.a.x + 0.5 * (s.b.x - s.a.x) + dx(rng), s.a.y + 0.5 * (s.b.y - s.a.y) + dy(rng));
      const Regime r = regimes.at(p, id);
      ++counts[index_of(r)];
      const double d = geo.distance(p, id);  // brute force's distance to the segment
      const double da = vertex_distance(g, p, s.a), db = vertex_distance(g, p, s.b);
      switch (r) {
        case Regime::first_end:
          EXPECT_NEAR(d, da, 1e-6) << "segment " << id << " at (" << p.lon << ", " << p.lat << ")";
          break;
        case Regime::second_end:
          EXPECT_NEAR(d, db, 1e-6) << "segment " << id << " at (" << p.lon << ", " << p.lat << ")";
          break;
        case Regime::interior:
          // Nearest at an interior point: strictly nearer than both ends.
          EXPECT_LT(d, std::min(da, db)) << "segment " << id << " at (" << p.lon << ", " << p.lat << ")";
          break;
        case Regime::uncertain:
          break;
      }
    }
  }
  // Every regime occurs, and the uncertain band is narrow.
  for (int r = 1; r < 4; ++r) EXPECT_GT(counts[r], 100) << "regime " << r;
  EXPECT_LT(counts[0], (counts[1] + counts[2] + counts[3]) / 10);
}

TEST(GeodesicRegime, ABlocksRegimesHoldAtEveryCellOfIt) {
  const std::vector<Site> sites = segments();
  const GeoSites geo(wgs84(), sites);
  const SegmentRegimes regimes(geo);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0), size(0.001, 0.3);
  int certain_blocks = 0;
  for (int32_t id = 0; id < static_cast<int32_t>(sites.size()); ++id) {
    const Site& s = sites[static_cast<size_t>(id)];
    for (int k = 0; k < 60; ++k) {
      // A block of 9 x 9 cells of `step` degrees around a centre near the segment.
      const double step = size(rng) / 8.0;
      const double lon0 = s.a.x + 0.5 * (s.b.x - s.a.x) + 2.0 * u(rng), lat0 = s.a.y + 0.5 * (s.b.y - s.a.y) + u(rng);
      std::vector<GeoCell> cells;
      for (int i = -4; i <= 4; ++i)
        for (int j = -4; j <= 4; ++j) cells.push_back(geo.cell(lon0 + i * step, lat0 + j * step));
      const GeoCell& c = cells[cells.size() / 2];
      double radius = 0.0;
      for (const GeoCell& p : cells)
        radius = std::max(radius,
                          std::sqrt((p.x - c.x) * (p.x - c.x) + (p.y - c.y) * (p.y - c.y) + (p.z - c.z) * (p.z - c.z)));
      const BlockRegime b = regimes.over_block(c.x, c.y, c.z, radius, id);
      certain_blocks += b.certain != Regime::uncertain;
      for (const GeoCell& p : cells) {
        const Regime r = regimes.at(p, id);
        if (b.certain != Regime::uncertain) {
          ASSERT_EQ(r, b.certain) << "segment " << id << " block at (" << lon0 << ", " << lat0 << ")";
        }
        if (r != Regime::uncertain) {
          ASSERT_TRUE(b.possible & (1u << (index_of(r) - 1)))
              << "regime " << index_of(r) << " was not possible, segment " << id;
        }
      }
    }
  }
  EXPECT_GT(certain_blocks, 200);
}

}  // namespace
}  // namespace rv::detail
