// The real data set: Danish and Swedish land around the Øresund (fixtures/oresund.gpkg,
// DCW polygons, EPSG:4326), reprojected to UTM 33N, 200 m cells. Land cells must belong to their
// state (checked against GDAL's own rasteriser), sea cells to the nearer state (checked against
// GEOS distances), and the exact method must equal brute force.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>

#include <gdal_alg.h>
#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include "rv/engine/engine.hpp"
#include "rv/engine/validate.hpp"
#include "rv/gdal/seed_reader.hpp"

#include "fixtures.hpp"

namespace rv {
namespace {

std::string oresund_path() { return test::fixture("oresund.gpkg"); }

struct Oresund {
  LoadedSeeds loaded;
  double load_seconds = 0.0;
  GridSpec grid;
};

class OresundTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = oresund_path();
    gdal_init();
  }

  LoadedSeeds load(double* seconds = nullptr) const {
    SeedReadOptions o;
    o.paths = {path_};
    o.layers = {"states"};
    o.owner_field = "iso2";
    o.target_crs = "EPSG:32633";
    const auto t0 = std::chrono::steady_clock::now();
    LoadedSeeds l = load_seeds(o);
    if (seconds != nullptr) *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return l;
  }

  // The two states' geometry reprojected by OGR directly (an independent path), by label.
  std::map<std::string, std::unique_ptr<OGRGeometry>> reference_geometry() const {
    std::map<std::string, std::unique_ptr<OGRGeometry>> out;
    std::unique_ptr<GDALDataset> ds(GDALDataset::Open(path_.c_str(), GDAL_OF_VECTOR));
    OGRLayer* layer = ds->GetLayerByName("states");
    OGRSpatialReference utm;
    utm.importFromEPSG(32633);
    utm.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    for (auto& f : *layer) {
      std::unique_ptr<OGRGeometry> g(f->GetGeometryRef()->clone());
      OGRSpatialReference src(*layer->GetSpatialRef());
      src.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
      std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&src, &utm));
      EXPECT_EQ(g->transform(ct.get()), OGRERR_NONE);
      out[f->GetFieldAsString("iso2")] = std::move(g);
    }
    return out;
  }

  std::string path_;
};

NearestField run(const SeedSet& s, const GridSpec& g, Method m) {
  ComputeOptions o;
  o.method = m;
  o.threads = 2;
  return compute(s, g, o);
}

TEST_F(OresundTest, ReadsTwoStatesWithoutConflict) {
  double seconds = 0.0;
  const LoadedSeeds l = load(&seconds);  // policy error: throws if DK and SE overlapped
  RecordProperty("load_seconds", std::to_string(seconds));
  std::printf("oresund.gpkg read, reprojected and checked in %.3f s: %zu sites, %zu polygons\n", seconds,
              l.seeds.sites().size(), l.seeds.polygons().size());
  EXPECT_EQ(l.seeds.owner_labels(), (std::vector<std::string>{"DK", "SE"}));
  EXPECT_EQ(l.report.features_read, 2);
  EXPECT_EQ(l.report.conflicts, 0);
  EXPECT_EQ(l.report.polygons_repaired, 0);
  EXPECT_EQ(l.crs.name, "WGS 84 / UTM zone 33N");
  EXPECT_GT(l.seeds.polygons().size(), 2u);  // MultiPolygons: islands are parts
}

TEST_F(OresundTest, LandBelongsToItsStateAndSeaToTheNearer) {
  const LoadedSeeds l = load();
  const SeedSet::Box b = l.seeds.bounds();
  const GridSpec g = make_aligned_grid(b.xmin, b.ymin, b.xmax, b.ymax, 200.0, l.crs.wkt);
  const NearestField f = run(l.seeds, g, Method::exact);
  RecordProperty("grid", std::to_string(g.width) + "x" + std::to_string(g.height));
  RecordProperty("exact_seconds", std::to_string(f.seconds));

  // GDAL's rasteriser (cell centre inside, its default) burns 1 = DK, 2 = SE on the same grid.
  auto reference = reference_geometry();
  std::unique_ptr<GDALDataset> mem(GetGDALDriverManager()->GetDriverByName("MEM")->Create(
      "", static_cast<int>(g.width), static_cast<int>(g.height), 1, GDT_Int32, nullptr));
  double gt[6] = {g.xmin, g.res, 0.0, g.ymax, 0.0, -g.res};
  mem->SetGeoTransform(gt);
  int band = 1;
  std::vector<OGRGeometryH> geoms = {OGRGeometry::ToHandle(reference.at("DK").get()),
                                     OGRGeometry::ToHandle(reference.at("SE").get())};
  std::vector<double> burn = {1.0, 2.0};
  ASSERT_EQ(GDALRasterizeGeometries(GDALDataset::ToHandle(mem.get()), 1, &band, 2, geoms.data(), nullptr, nullptr,
                                    burn.data(), nullptr, nullptr, nullptr),
            CE_None);
  std::vector<int32_t> land(static_cast<size_t>(g.cell_count()));
  ASSERT_EQ(
      mem->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, static_cast<int>(g.width), static_cast<int>(g.height), land.data(),
                                      static_cast<int>(g.width), static_cast<int>(g.height), GDT_Int32, 0, 0, nullptr),
      CE_None);

  int64_t land_cells[3] = {0, 0, 0}, land_wrong = 0, sea_cells[3] = {0, 0, 0}, unowned = 0;
  int64_t sea_checked = 0, sea_wrong = 0;
  double worst_distance_diff = 0.0;
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
      // Every 23rd sea cell: the owner is the state at the smaller GEOS distance.
      if ((row * g.width + col) % 23 != 0) continue;
      OGRPoint centre(g.centre_x(col), g.centre_y(row));
      const double d_dk = reference.at("DK")->Distance(&centre);
      const double d_se = reference.at("SE")->Distance(&centre);
      ++sea_checked;
      if (std::abs(d_dk - d_se) > 1e-6 && owner != (d_dk < d_se ? 1 : 2)) ++sea_wrong;
      worst_distance_diff = std::max(worst_distance_diff, std::abs(f.distance.at(col, row) - std::min(d_dk, d_se)));
    }
  }
  std::printf(
      "oresund %lldx%lld at 200 m: land DK %lld SE %lld, sea DK %lld SE %lld, sea cells checked %lld, "
      "worst distance difference to GEOS %.4f m\n",
      static_cast<long long>(g.width), static_cast<long long>(g.height), static_cast<long long>(land_cells[1]),
      static_cast<long long>(land_cells[2]), static_cast<long long>(sea_cells[1]), static_cast<long long>(sea_cells[2]),
      static_cast<long long>(sea_checked), worst_distance_diff);
  EXPECT_EQ(unowned, 0);
  EXPECT_EQ(land_wrong, 0);
  EXPECT_GT(land_cells[1], 10000);  // Zealand's north-east and Skåne's west: both substantial
  EXPECT_GT(land_cells[2], 10000);
  EXPECT_GT(sea_cells[1], 1000);  // the strait is split between them
  EXPECT_GT(sea_cells[2], 1000);
  EXPECT_GT(sea_checked, 500);
  EXPECT_EQ(sea_wrong, 0);
  // Float32 distances of up to ~60 km: a few millimetres of rounding.
  EXPECT_LT(worst_distance_diff, 0.02);
}

TEST_F(OresundTest, ExactEqualsBruteForce) {
  const LoadedSeeds l = load();
  const SeedSet::Box b = l.seeds.bounds();
  const GridSpec g = make_aligned_grid(b.xmin, b.ymin, b.xmax, b.ymax, 200.0, l.crs.wkt);
  const NearestField exact = run(l.seeds, g, Method::exact);
  const NearestField brute = run(l.seeds, g, Method::brute_force);
  EXPECT_EQ(exact.site.cells(), brute.site.cells());
  EXPECT_EQ(exact.distance.cells(), brute.distance.cells());
  const ValidationStats hv = compare_fields(l.seeds, run(l.seeds, g, Method::hv_scan), brute);
  EXPECT_EQ(hv.nodata_mismatch, 0);
  RecordProperty("brute_force_seconds", std::to_string(brute.seconds));
  RecordProperty("hv_max_error_cells", std::to_string(hv.max_error_cells));
  RecordProperty("hv_wrong_cells", std::to_string(hv.wrong_cells));
  std::printf(
      "oresund 200 m: exact %.3f s, brute force %.3f s; hv-scan %lld wrong cells (%lld with another owner), "
      "max error %.4f cells\n",
      exact.seconds, brute.seconds, static_cast<long long>(hv.wrong_cells),
      static_cast<long long>(hv.wrong_owner_cells), hv.max_error_cells);
}

}  // namespace
}  // namespace rv
