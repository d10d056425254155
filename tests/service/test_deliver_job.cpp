// The maritime deliverables through the façade (run_job): every file written, read back with
// OGR / GDAL / OpenCV, checked against brute-force distances.
#include <gtest/gtest.h>
#include <ogrsf_frmts.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>

#include <opencv2/imgcodecs.hpp>

#include "deliverables_check.hpp"
#include "fixtures.hpp"
#include "rv/error.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/job.hpp"
#include "rv/outputs.hpp"
#include "rv/preview.hpp"

namespace fs = std::filesystem;

namespace rv {
namespace {

std::string source(const std::string& rel) { return (test::source_dir() / rel).string(); }

class DeliverJob : public ::testing::Test {
 protected:
  void SetUp() override {
    gdal_init();
    dir_ = fs::temp_directory_path() / ("rv_deliver_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  JobSpec demo() const {
    JobSpec spec;
    spec.seeds.paths = {source("fixtures/demo_basepoints.geojson")};
    spec.seeds.owner_field = "state";
    spec.grid.resolution = 250.0;
    spec.threads = 2;
    spec.outputs.ownership = path("own.tif");
    return spec;
  }
  fs::path dir_;
};

TEST_F(DeliverJob, WritesEveryDeliverableAndTheyPassTheChecks) {
  JobSpec spec = demo();
  spec.method = Method::hv_scan;  // the deliverables still come from an exact field
  spec.outputs.boundaries = path("b.gpkg");
  spec.outputs.tripoints = path("t.geojson");
  spec.outputs.limits = path("l.geojson");
  spec.outputs.limit_distances = {"1nmi", "3000m", "4.5km"};
  spec.outputs.regions = path("r.gpkg");
  spec.outputs.margin = path("m.tif");
  spec.outputs.preview = path("p.png");
  spec.outputs.report = path("report.json");
  const JobResult r = run_job(spec);
  for (const char* f : {"b.gpkg", "t.geojson", "l.geojson", "r.gpkg", "m.tif", "p.png", "report.json"})
    EXPECT_TRUE(fs::exists(path(f))) << f;
  const auto& d = r.report["deliverables"];
  EXPECT_GE(d["boundaries"]["lines"].get<int>(), 2);
  EXPECT_GE(d["boundaries"]["tripoints"].get<int>(), 1);
  EXPECT_LE(d["boundaries"]["max_residual_cells"].get<double>(), 1e-3);
  EXPECT_LE(d["limits"]["max_residual_cells"].get<double>(), 1e-3);
  EXPECT_NEAR(d["limits"]["distances"][0].get<double>(), 1852.0, 1e-9);
  EXPECT_EQ(d["regions"]["owners"].get<int>(), 3);
  // Each owner's areas in the report: land and sea add up to its region, and the regions tile
  // the grid (no max distance), in the job's distance units squared (metres here).
  ASSERT_EQ(d["regions"]["areas"].size(), 3u);
  EXPECT_EQ(d["regions"]["area_units"].get<std::string>(), "m^2");
  double total = 0.0;
  for (const auto& a : d["regions"]["areas"]) {
    EXPECT_NEAR(a["land_area"].get<double>() + a["sea_area"].get<double>(), a["area"].get<double>(),
                1e-9 * a["area"].get<double>());
    EXPECT_GT(a["sea_area"].get<double>(), 0.0) << a["label"];
    total += a["area"].get<double>();
  }
  const auto& grid = r.report["grid"];
  const double grid_area = grid["width"].get<double>() * grid["height"].get<double>() * 250.0 * 250.0;
  EXPECT_NEAR(total, grid_area, 1e-6 * grid_area);
  const auto& times = r.report["timings_s"]["deliverables"];
  for (const char* k : {"boundaries", "limits", "regions", "margin", "preview", "exact_field", "wall"})
    EXPECT_TRUE(times.contains(k)) << k;
  // Files written side by side overlap; the wall time holds each deliverable's.
  for (const char* k : {"boundaries", "limits", "regions", "margin"})
    EXPECT_LE(times[k].get<double>(), times["wall"].get<double>()) << k;

  // Boundary vertices read back from the file: equidistant from the two owners' seeds.
  SeedReadOptions ro = spec.seeds;
  const LoadedSeeds seeds = load_seeds(ro);
  GDALDataset* ds = GDALDataset::Open(path("b.gpkg").c_str(), GDAL_OF_VECTOR);
  ASSERT_NE(ds, nullptr);
  OGRLayer* l = ds->GetLayerByName("boundaries");
  ASSERT_NE(l, nullptr);
  int checked = 0;
  l->ResetReading();
  for (OGRFeature* f; (f = l->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(f)) {
    const int a = f->GetFieldAsInteger("owner_a"), b = f->GetFieldAsInteger("owner_b");
    const OGRLineString* ls = f->GetGeometryRef()->toLineString();
    for (int i = 0; i < ls->getNumPoints(); ++i, ++checked) {
      const Vec2 p{ls->getX(i), ls->getY(i)};
      EXPECT_LE(std::abs(test::brute_owner_distance(seeds.seeds, p, a) - test::brute_owner_distance(seeds.seeds, p, b)),
                1e-3 * 250.0);
    }
  }
  GDALClose(GDALDataset::ToHandle(ds));
  EXPECT_GT(checked, 50);

  // Margin: non-negative where owned, and 0 nowhere far from a boundary.
  const Raster<float> margin = read_float32(path("m.tif"));
  const Raster<int32_t> own = read_int32(path("own.tif"));
  for (size_t i = 0; i < margin.size(); ++i) {
    if (own.cells()[i] == 0) continue;
    EXPECT_GE(margin.cells()[i], 0.0f);
  }

  // Preview: readable, the grid's shape, and each owner's seed cell in its own colour.
  const cv::Mat img = cv::imread(path("p.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, own.width());
  EXPECT_EQ(img.rows, own.height());
  std::set<std::array<uint8_t, 3>> colours;
  const GridSpec& g = own.grid();
  for (int32_t owner = 1; owner <= 3; ++owner) {
    // A seed of this owner, and the cell under it.
    for (size_t s = 0; s < seeds.seeds.sites().size(); ++s) {
      if (seeds.seeds.site_owner(static_cast<int32_t>(s)) != owner) continue;
      const Vec2 p = seeds.seeds.sites()[s].a;
      const int c = static_cast<int>((p.x - g.xmin) / g.res), row = static_cast<int>((g.ymax - p.y) / g.res);
      ASSERT_EQ(own.at(c, row), owner);
      const cv::Vec3b px = img.at<cv::Vec3b>(row, c);
      const auto expect = owner_colour(owner);
      // A boundary line may pass over the seed's cell only if it is next to a boundary: the seed
      // cells of the demo are not.
      EXPECT_EQ(px[0], expect[0]);
      EXPECT_EQ(px[1], expect[1]);
      EXPECT_EQ(px[2], expect[2]);
      colours.insert(expect);
      break;
    }
  }
  EXPECT_EQ(colours.size(), 3u);
}

TEST_F(DeliverJob, PreviewDownscalesLargeRasters) {
  GridSpec g;
  g.xmin = 0;
  g.ymax = 5000;
  g.res = 1;
  g.width = 4100;
  g.height = 50;
  Raster<int32_t> owners(g, 0);
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) owners.at(c, r) = c < 2050 ? 1 : 2;
  PreviewOptions o;
  o.max_side = 2000;
  const PreviewInfo info = write_preview(path("big.png"), owners, nullptr, o);
  EXPECT_EQ(info.step, 3);
  const cv::Mat img = cv::imread(path("big.png"), cv::IMREAD_COLOR);
  ASSERT_EQ(img.cols, 1367);
  ASSERT_EQ(img.rows, 17);
  const auto c1 = owner_colour(1), c2 = owner_colour(2);
  EXPECT_EQ(img.at<cv::Vec3b>(5, 10), cv::Vec3b(c1[0], c1[1], c1[2]));
  EXPECT_EQ(img.at<cv::Vec3b>(5, 1300), cv::Vec3b(c2[0], c2[1], c2[2]));
  EXPECT_NE(c1, c2);
  // The palette: 64 owners, pairwise distinct colours, nodata black.
  std::set<std::array<uint8_t, 3>> seen;
  for (int32_t k = 1; k <= 64; ++k) seen.insert(owner_colour(k));
  EXPECT_EQ(seen.size(), 64u);
  EXPECT_EQ(owner_colour(0), (std::array<uint8_t, 3>{0, 0, 0}));
}

TEST_F(DeliverJob, RefusesBadRequestsAndLeavesNothingBehind) {
  JobSpec spec = demo();
  spec.outputs.limits = path("l.geojson");
  EXPECT_THROW(run_job(spec), Error);  // no distances
  spec.outputs.limit_distances = {"12 parsecs"};
  EXPECT_THROW(run_job(spec), Error);
  spec.outputs.limit_distances = {"-3nmi"};
  EXPECT_THROW(run_job(spec), Error);
  spec.outputs.limit_distances = {"1nmi"};
  spec.max_distance = 1000.0;  // metres (the CRS's unit): the 1 nmi line would lie beyond it
  EXPECT_THROW(run_job(spec), Error);
  spec.max_distance.reset();
  spec.outputs.limits = path("l.shp");  // unknown vector format: fails after the ownership file was written
  EXPECT_THROW(run_job(spec), Error);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 0);

  EXPECT_EQ(parse_limit_distance("12nmi").unit, "nmi");
  EXPECT_DOUBLE_EQ(parse_limit_distance("24 nmi").value, 24.0);
  EXPECT_EQ(parse_limit_distance("500").unit, "");
  EXPECT_DOUBLE_EQ(parse_limit_distance("3.5km").value, 3.5);
}

// The geographic Øresund fixture through the façade: geodesic metric chosen automatically, the
// deliverables measured in metres, residuals below 1 cm.
TEST_F(DeliverJob, GeodesicOresund) {
  const std::string gpkg = test::shared_fixture("oresund.gpkg");
  if (gpkg.empty()) GTEST_SKIP() << "shared fixture missing";
  JobSpec spec;
  spec.seeds.paths = {gpkg};
  spec.seeds.layers = {"states"};
  spec.seeds.owner_field = "iso2";
  spec.grid.resolution = 0.01;
  spec.threads = 2;
  spec.distance_units = DistanceUnit::nmi;
  spec.outputs.ownership = path("own.tif");
  spec.outputs.boundaries = path("b.geojson");
  spec.outputs.limits = path("l.gpkg");
  spec.outputs.limit_distances = {"12nmi", "20000m"};
  spec.outputs.margin = path("m.tif");
  spec.outputs.regions = path("r.gpkg");
  const JobResult r = run_job(spec);
  EXPECT_EQ(r.report["metric"], "geodesic");
  const auto& d = r.report["deliverables"];
  EXPECT_GE(d["boundaries"]["lines"].get<int>(), 1);
  EXPECT_LT(d["boundaries"]["max_residual"].get<double>() * 1852.0, 0.01);  // reported in nmi
  EXPECT_LT(d["limits"]["max_residual"].get<double>() * 1852.0, 0.01);
  EXPECT_NEAR(d["limits"]["distances"][0].get<double>(), 12.0, 1e-12);
  EXPECT_NEAR(d["limits"]["distances"][1].get<double>(), 20000.0 / 1852.0, 1e-12);
  EXPECT_EQ(d["regions"]["owners"].get<int>(), 2);
  const Raster<float> m = read_float32(path("m.tif"));
  float largest = 0.0f;
  for (float v : m.cells()) largest = std::max(largest, v);
  EXPECT_GT(largest, 1.0f);  // nmi: land far from the other state
  EXPECT_LT(largest, 100.0f);
}

TEST_F(DeliverJob, CommandLineOptions) {
  const std::string cmd = std::string(RV_BINARY) + " compute " + source("fixtures/demo_basepoints.geojson") +
                          " --owner-field state --resolution 500 --threads 2 --quiet --ownership " + path("o.tif") +
                          " --boundaries " + path("b.geojson") + " --tripoints " + path("t.gpkg") + " --limits " +
                          path("l.geojson") + " --limit-distances 1nmi,2500 --limits-per-owner --regions " +
                          path("r.geojson") + " --margin-raster " + path("m.tif") + " --preview " + path("p.png") +
                          " --simplify 0.5 --report " + path("rep.json") + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  for (const char* f : {"o.tif", "b.geojson", "t.gpkg", "l.geojson", "r.geojson", "m.tif", "p.png", "rep.json"})
    EXPECT_TRUE(fs::exists(path(f))) << f;
  std::ifstream in(path("rep.json"));
  const nlohmann::json rep = nlohmann::json::parse(in);
  EXPECT_TRUE(rep["deliverables"]["limits"]["per_owner"].get<bool>());
  EXPECT_DOUBLE_EQ(rep["deliverables"]["limits"]["distances"][1].get<double>(), 2500.0);
  EXPECT_LT(rep["deliverables"]["boundaries"]["vertices"].get<int>(),
            rep["deliverables"]["boundaries"]["vertices_before_simplify"].get<int>());
}

}  // namespace
}  // namespace rv
