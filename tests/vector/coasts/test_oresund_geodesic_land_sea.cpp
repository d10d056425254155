// The Oresund data set (fixtures/oresund.gpkg, EPSG:4326) read in its own geographic CRS
// and computed with the geodesic metric at 0.002 degrees, over the whole grid: land cells belong
// to their state (GDAL's rasteriser in the same lon/lat grid), sampled sea cells to the state
// whose coastline is geodesically nearer (brute force over every edge with rv::GeodesicMeasure,
// whose segment distance test_raster_geodesic checks against GeographicLib sampling), with the
// distance to within Float32 rounding. (test_oresund_geodesic.cpp checks exact == brute force on
// windows across the strait and distances against dense sampling.)
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>

#include <gdal_alg.h>
#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include "rv/engine/engine.hpp"
#include "rv/field/metric.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/geodesic/geodesic.hpp"

#include "fixtures.hpp"

namespace rv {
namespace {

std::string oresund_path() { return test::fixture("oresund.gpkg"); }

TEST(OresundGeodesicLandSea, OwnershipAndDistanceOnTheEllipsoid) {
  const std::string path = oresund_path();
  gdal_init();
  SeedReadOptions ro;
  ro.paths = {path};
  ro.layers = {"states"};
  ro.owner_field = "iso2";
  const LoadedSeeds l = load_seeds(ro);
  ASSERT_TRUE(l.crs.geographic);
  ASSERT_EQ(l.seeds.owner_labels(), (std::vector<std::string>{"DK", "SE"}));

  ComputeOptions o;
  o.threads = 2;
  o.metric = resolve_metric(MetricRequest::automatic, l.crs.geographic, l.crs.semi_major, l.crs.flattening);
  ASSERT_EQ(o.metric.kind, MetricSpec::geodesic);
  const SeedSet::Box b = l.seeds.bounds();
  const GridSpec g = make_aligned_grid(b.xmin, b.ymin, b.xmax, b.ymax, 0.002, l.crs.wkt);
  const NearestField f = compute(l.seeds, g, o);
  RecordProperty("grid", std::to_string(g.width) + "x" + std::to_string(g.height));
  RecordProperty("exact_geodesic_seconds", std::to_string(f.seconds));

  // GDAL's rasteriser on the same lon/lat grid: 1 = DK, 2 = SE.
  std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path.c_str(), GDAL_OF_VECTOR));
  OGRLayer* layer = ds->GetLayerByName("states");
  std::map<std::string, std::unique_ptr<OGRGeometry>> geometry;
  OGRSpatialReference lonlat;
  lonlat.importFromEPSG(4326);
  lonlat.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  for (auto& feature : *layer) {
    std::unique_ptr<OGRGeometry> geom(feature->GetGeometryRef()->clone());
    geom->assignSpatialReference(&lonlat);
    geometry[feature->GetFieldAsString("iso2")] = std::move(geom);
  }
  std::unique_ptr<GDALDataset> mem(GetGDALDriverManager()->GetDriverByName("MEM")->Create(
      "", static_cast<int>(g.width), static_cast<int>(g.height), 1, GDT_Int32, nullptr));
  double gt[6] = {g.xmin, g.res, 0.0, g.ymax, 0.0, -g.res};
  mem->SetGeoTransform(gt);
  int band = 1;
  std::vector<OGRGeometryH> geoms = {OGRGeometry::ToHandle(geometry.at("DK").get()),
                                     OGRGeometry::ToHandle(geometry.at("SE").get())};
  std::vector<double> burn = {1.0, 2.0};
  ASSERT_EQ(GDALRasterizeGeometries(GDALDataset::ToHandle(mem.get()), 1, &band, 2, geoms.data(), nullptr, nullptr,
                                    burn.data(), nullptr, nullptr, nullptr),
            CE_None);
  std::vector<int32_t> land(static_cast<size_t>(g.cell_count()));
  ASSERT_EQ(
      mem->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, static_cast<int>(g.width), static_cast<int>(g.height), land.data(),
                                      static_cast<int>(g.width), static_cast<int>(g.height), GDT_Int32, 0, 0, nullptr),
      CE_None);

  // Edges per owner, for the brute-force reference.
  std::vector<std::pair<Vec2, Vec2>> edges[3];
  for (const Site& s : l.seeds.sites())
    if (s.kind == SiteKind::segment)
      edges[l.seeds.features()[static_cast<size_t>(s.feature)].owner].push_back({s.a, s.b});
  const GeodesicMeasure measure(o.metric);

  int64_t land_cells[3] = {0, 0, 0}, land_wrong = 0, sea_cells[3] = {0, 0, 0}, unowned = 0;
  int64_t sea_checked = 0, sea_wrong = 0;
  double worst_relative = 0.0;
  for (int64_t row = 0; row < g.height; ++row) {
    for (int64_t col = 0; col < g.width; ++col) {
      const int32_t site = f.site.at(col, row);
      if (site == kNoSite) {
        ++unowned;
        continue;
      }
      const int32_t owner = l.seeds.site_owner(site);
      const int32_t burned = land[static_cast<size_t>(row * g.width + col)];
      if (burned != 0) {
        ++land_cells[burned];
        if (owner != burned || f.distance.at(col, row) != 0.0f) ++land_wrong;
        continue;
      }
      ++sea_cells[owner];
      if ((row * g.width + col) % 401 != 0) continue;  // ~300 sea cells: brute force is slow
      const Vec2 p{g.centre_x(col), g.centre_y(row)};
      double d[3] = {0.0, 1e300, 1e300};
      for (int k = 1; k <= 2; ++k)
        for (const auto& [a, e] : edges[k]) d[k] = std::min(d[k], measure.segment_distance(p, a, e));
      ++sea_checked;
      if (std::abs(d[1] - d[2]) > 1e-3 && owner != (d[1] < d[2] ? 1 : 2)) ++sea_wrong;
      const double nearest = std::min(d[1], d[2]);
      worst_relative = std::max(worst_relative, std::abs(f.distance.at(col, row) - nearest) / nearest);
    }
  }
  std::printf(
      "oresund geodesic %lldx%lld at 0.002 deg: exact %.2f s; land DK %lld SE %lld, sea DK %lld SE %lld, "
      "sea cells checked %lld, worst relative distance difference %.2e\n",
      static_cast<long long>(g.width), static_cast<long long>(g.height), f.seconds,
      static_cast<long long>(land_cells[1]), static_cast<long long>(land_cells[2]),
      static_cast<long long>(sea_cells[1]), static_cast<long long>(sea_cells[2]), static_cast<long long>(sea_checked),
      worst_relative);
  EXPECT_EQ(unowned, 0);
  EXPECT_EQ(land_wrong, 0);
  EXPECT_GT(land_cells[1], 10000);
  EXPECT_GT(land_cells[2], 10000);
  EXPECT_GT(sea_cells[1], 1000);
  EXPECT_GT(sea_cells[2], 1000);
  EXPECT_GT(sea_checked, 200);
  EXPECT_EQ(sea_wrong, 0);
  EXPECT_LT(worst_relative, 1e-7);  // Float32 rounding of the stored distance
}

}  // namespace
}  // namespace rv
