// The maritime deliverables on real coastlines: Danish and Swedish land around the Øresund
// (fixtures/oresund.gpkg), reprojected to UTM 33N, planar metric, 200 m cells. The DK-SE
// median line must exist, run continuously through the strait and be equidistant at every
// vertex; the 12 nmi limit must lie at 12 nmi at every vertex. The same again on the geographic
// grid with the geodesic metric, within 1 cm.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <limits>

#include "deliverables_check.hpp"
#include "rv/engine/engine.hpp"
#include "rv/engine/outputs.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/geodesic/geodesic.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/margin.hpp"

#include "fixtures.hpp"

namespace rv {
namespace {

std::string oresund_path() { return test::fixture("oresund.gpkg"); }

double since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

TEST(OresundDeliverables, MedianLineAndTwelveMileLimitOnUtm) {
  const std::string path = oresund_path();
  gdal_init();
  SeedReadOptions o;
  o.paths = {path};
  o.layers = {"states"};
  o.owner_field = "iso2";
  o.target_crs = "EPSG:32633";
  const LoadedSeeds l = load_seeds(o);
  const SeedSet& s = l.seeds;
  ASSERT_EQ(s.owner_count(), 2);
  const SeedSet::Box b = s.bounds();
  const GridSpec g = make_aligned_grid(b.xmin, b.ymin, b.xmax, b.ymax, 200.0, l.crs.wkt);
  ComputeOptions co;
  co.threads = 2;
  const NearestField f = compute(s, g, co);
  const PlanarSiteMetric metric(s, Vec2{g.xmin, g.ymax});
  const OwnerIndex index(metric);

  auto t = std::chrono::steady_clock::now();
  const BoundaryResult r = extract_boundaries(f, index);
  const double tb = since(t);
  const int32_t dk = s.owner_labels()[0] == "DK" ? 1 : 2, se = 3 - dk;
  // The longest DK-SE line: through the strait, north to south, without gaps.
  const BoundaryLine* median = nullptr;
  for (const BoundaryLine& line : r.lines) {
    ASSERT_EQ(line.owner_a, 1);
    ASSERT_EQ(line.owner_b, 2);
    if (!median || line.vertices.size() > median->vertices.size()) median = &line;
  }
  ASSERT_NE(median, nullptr) << "no DK-SE boundary";
  double ymin = 1e300, ymax = -1e300;
  for (size_t i = 0; i < median->vertices.size(); ++i) {
    const Vec2 p = median->vertices[i].p;
    ymin = std::min(ymin, p.y);
    ymax = std::max(ymax, p.y);
    if (i > 0) {
      const Vec2 q = median->vertices[i - 1].p;
      ASSERT_LE(std::hypot(p.x - q.x, p.y - q.y), std::sqrt(2.0) * g.res + 1e-6) << "gap in the median line";
    }
  }
  const double height = g.ymax - g.ymin();
  EXPECT_GT(ymax - ymin, 0.8 * height) << "the median line does not cross the strait";
  // Every vertex of every line equidistant (brute force over the seeds), within 1e-3 cell.
  test::check_boundaries(s, f, r, 1e-3 * g.res);
  test::check_no_crossings(r);

  // 12 nmi from both states' coasts together.
  t = std::chrono::steady_clock::now();
  const std::vector<double> twelve{12 * 1852.0};
  const LimitResult lim = extract_limits(f, index, twelve);
  const double tl = since(t);
  ASSERT_FALSE(lim.lines.empty());
  for (const LimitLine& line : lim.lines)
    for (const LimitVertex& v : line.vertices)
      ASSERT_NEAR(test::brute_owner_distance(s, v.p, 0), 12 * 1852.0, 1e-3 * g.res);

  t = std::chrono::steady_clock::now();
  const Raster<float> m = margin_raster(f, index, 2);
  const double tm = since(t);
  std::printf(
      "oresund UTM 200 m (%lldx%lld, %zu sites): boundaries %.3f s (%zu lines, %zu vertices on the median, "
      "max residual %.2e m), 12 nmi limit %.3f s (%zu lines, %lld vertices), margin %.3f s\n",
      static_cast<long long>(g.width), static_cast<long long>(g.height), s.sites().size(), tb, r.lines.size(),
      median->vertices.size(), r.stats.max_residual, tl, lim.lines.size(), static_cast<long long>(lim.vertices), tm);
  (void)dk;
  (void)se;
}

// The same on the geographic grid (longitude/latitude, geodesic metric): the DK-SE median line
// equidistant within 1 cm at every vertex, the 12 nmi limit within 1 cm of 12 nmi.
TEST(OresundDeliverables, MedianLineAndTwelveMileLimitGeodesic) {
  const std::string path = oresund_path();
  gdal_init();
  SeedReadOptions o;
  o.paths = {path};
  o.layers = {"states"};
  o.owner_field = "iso2";
  const LoadedSeeds l = load_seeds(o);
  ASSERT_TRUE(l.crs.geographic);
  const SeedSet& s = l.seeds;
  const SeedSet::Box b = s.bounds();
  const GridSpec g = make_aligned_grid(b.xmin, b.ymin, b.xmax, b.ymax, 0.005, l.crs.wkt);
  MetricSpec geodesic;
  geodesic.kind = MetricSpec::geodesic;
  ComputeOptions co;
  co.threads = 2;
  co.metric = geodesic;
  const NearestField f = compute(s, g, co);
  const GeodesicSiteMetric metric(s, geodesic);
  const OwnerIndex index(metric);
  const GeodesicMeasure measure(geodesic);
  auto brute = [&](Vec2 p, int32_t owner) {
    double best = test::inside_any(s, p, owner) ? 0.0 : std::numeric_limits<double>::infinity();
    for (const Site& site : s.sites()) {
      if (owner != 0 && s.features()[site.feature].owner != owner) continue;
      if (site.kind == SiteKind::point) best = std::min(best, measure.point_distance(p, site.a));
      if (site.kind == SiteKind::segment) best = std::min(best, measure.segment_distance(p, site.a, site.b));
    }
    return best;
  };

  auto t = std::chrono::steady_clock::now();
  const BoundaryResult r = extract_boundaries(f, index);
  const double tb = since(t);
  const BoundaryLine* median = nullptr;
  for (const BoundaryLine& line : r.lines)
    if (!median || line.vertices.size() > median->vertices.size()) median = &line;
  ASSERT_NE(median, nullptr) << "no DK-SE boundary";
  double ymin = 1e300, ymax = -1e300;
  for (size_t i = 0; i < median->vertices.size(); ++i) {
    const Vec2 p = median->vertices[i].p;
    ymin = std::min(ymin, p.y);
    ymax = std::max(ymax, p.y);
    if (i > 0) {
      const Vec2 q = median->vertices[i - 1].p;
      ASSERT_LE(std::hypot(p.x - q.x, p.y - q.y), std::sqrt(2.0) * g.res + 1e-9) << "gap in the median line";
    }
  }
  EXPECT_GT(ymax - ymin, 0.8 * (g.ymax - g.ymin())) << "the median line does not cross the strait";
  for (const BoundaryLine& line : r.lines)
    for (size_t i = 0; i < line.vertices.size(); i += 2) {
      const Vec2 p = line.vertices[i].p;
      ASSERT_LE(std::abs(brute(p, line.owner_a) - brute(p, line.owner_b)), 0.01) << p.x << " " << p.y;
    }
  test::check_no_crossings(r);

  t = std::chrono::steady_clock::now();
  const std::vector<double> twelve{12 * 1852.0};
  const LimitResult lim = extract_limits(f, index, twelve);
  const double tl = since(t);
  ASSERT_FALSE(lim.lines.empty());
  for (const LimitLine& line : lim.lines)
    for (const LimitVertex& v : line.vertices) ASSERT_NEAR(brute(v.p, 0), 12 * 1852.0, 0.01);
  // Margin on the geodesic grid (exact per-cell queries): non-negative where owned, checked
  // against brute force on a sample of cells.
  t = std::chrono::steady_clock::now();
  const Raster<float> margin = margin_raster(f, index, 2);
  const double tm = since(t);
  for (int64_t row = 0; row < g.height; row += 23)
    for (int64_t c = 0; c < g.width; c += 23) {
      const int32_t site = f.site.at(c, row);
      if (site == kNoSite) continue;
      const Vec2 p{g.centre_x(c), g.centre_y(row)};
      const int32_t own = s.site_owner(site);
      ASSERT_NEAR(margin.at(c, row), brute(p, 3 - own) - brute(p, own), 0.05) << c << "," << row;
    }
  std::printf(
      "oresund geodesic 0.005 deg (%lldx%lld): compute %.3f s, boundaries %.3f s (%zu lines, %zu vertices on "
      "the median, max residual %.2e m), 12 nmi limit %.3f s (%lld vertices), margin %.3f s\n",
      static_cast<long long>(g.width), static_cast<long long>(g.height), f.seconds, tb, r.lines.size(),
      median->vertices.size(), r.stats.max_residual, tl, static_cast<long long>(lim.vertices), tm);
}

// The geographic grid of 0.002 degrees (600 x 501 cells), geodesic metric, owners by iso2: the
// DK-SE boundary has no end in the open: it runs from grid edge to grid edge (two owners, no
// tripoints), every vertex equidistant within 1 cm.
TEST(OresundDeliverables, NoDanglingEndsOnTheFineGeographicGrid) {
  const std::string path = oresund_path();
  gdal_init();
  SeedReadOptions o;
  o.paths = {path};
  o.layers = {"states"};
  o.owner_field = "iso2";
  const LoadedSeeds l = load_seeds(o);
  const SeedSet& s = l.seeds;
  const SeedSet::Box b = s.bounds();
  const GridSpec g = make_aligned_grid(b.xmin, b.ymin, b.xmax, b.ymax, 0.002, l.crs.wkt);
  MetricSpec geodesic;
  geodesic.kind = MetricSpec::geodesic;
  ComputeOptions co;
  co.threads = 2;
  co.metric = geodesic;
  const NearestField f = compute(s, g, co);
  const GeodesicSiteMetric metric(s, geodesic);
  const OwnerIndex index(metric);
  BoundaryOptions bo;
  bo.threads = 2;
  const BoundaryResult r = extract_boundaries(f, index, bo);
  ASSERT_FALSE(r.lines.empty());
  int ends = 0;
  EXPECT_EQ(test::dangling_ends(r, g, &ends), 0);
  EXPECT_GE(ends, 2);
  EXPECT_TRUE(r.tripoints.empty());
  EXPECT_LT(r.stats.max_residual, 0.01);  // metres
  std::printf("oresund geodesic 0.002 deg (%lldx%lld): %zu lines, %d ends, max residual %.2e m\n",
              static_cast<long long>(g.width), static_cast<long long>(g.height), r.lines.size(), ends,
              r.stats.max_residual);
}

}  // namespace
}  // namespace rv
