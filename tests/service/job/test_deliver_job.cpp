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
#include "rv/engine/outputs.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/job.hpp"
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
  // The regions checked against the cells before they were written: every row, every cell (all
  // owned) either checked or on an edge, none in another owner's region.
  const auto& check = d["regions"]["against_cells"];
  EXPECT_EQ(check["rows"], grid["height"]);
  EXPECT_EQ(check["cells_checked"].get<int64_t>() + check["cells_near_edges"].get<int64_t>(),
            grid["width"].get<int64_t>() * grid["height"].get<int64_t>());
  EXPECT_GT(check["cells_checked"].get<int64_t>(), 0);
  EXPECT_EQ(check["cells_in_another_region"], 0);
  EXPECT_TRUE(check["first"].empty());
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
  EXPECT_GT(img.cols, own.width());  // the legend beside the map
  EXPECT_GE(img.rows, own.height());
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
  const PreviewInfo info = write_preview(path("big.png"), owners, PreviewLayers{}, o);
  EXPECT_EQ(info.step, 3);
  const cv::Mat img = cv::imread(path("big.png"), cv::IMREAD_COLOR);
  ASSERT_EQ(info.width, 1367);
  ASSERT_EQ(info.height, 17);
  ASSERT_EQ(img.cols, info.image_width);  // the map, then the legend beside it
  ASSERT_EQ(img.rows, info.image_height);
  ASSERT_GT(img.cols, info.width);
  const auto c1 = owner_colour(1), c2 = owner_colour(2);
  EXPECT_EQ(img.at<cv::Vec3b>(5, 10), cv::Vec3b(c1[0], c1[1], c1[2]));
  EXPECT_EQ(img.at<cv::Vec3b>(5, 1300), cv::Vec3b(c2[0], c2[1], c2[2]));
  EXPECT_NE(c1, c2);
  // The palette: 64 owners, pairwise distinct colours, none of them land's or no owner's.
  std::set<std::array<uint8_t, 3>> seen;
  for (int32_t k = 1; k <= 64; ++k) seen.insert(owner_colour(k));
  EXPECT_EQ(seen.size(), 64u);
  EXPECT_FALSE(seen.count(kLandColour));
  EXPECT_FALSE(seen.count(kNoOwnerColour));
  EXPECT_EQ(owner_colour(0), kNoOwnerColour);
}

// The quicklook for people, checked by content: land where the island is, sea in the owner's
// colour, the boundary and limit lines where the line files put them, the legend's swatches and
// text beside the map, the scale bar's length from the CRS.
TEST_F(DeliverJob, QuicklookShowsLandLinesLegendAndScale) {
  {
    std::ofstream f(path("isles.geojson"));
    f << R"({"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32633"}},
      "features":[
      {"type":"Feature","properties":{"state":"\u00c5land <script>"},"geometry":{"type":"Polygon","coordinates":
        [[[405000,6105000],[412000,6105000],[412000,6112000],[405000,6112000],[405000,6105000]]]}},
      {"type":"Feature","properties":{"state":"B"},"geometry":{"type":"Point","coordinates":[432000,6125000]}}]})";
  }
  JobSpec spec;
  spec.seeds.paths = {path("isles.geojson")};
  spec.seeds.owner_field = "state";
  spec.grid.resolution = 100.0;
  spec.grid.extent = std::array<double, 4>{400000, 6100000, 440000, 6130000};
  spec.outputs.boundaries = path("b.geojson");
  spec.outputs.limits = path("l.geojson");
  spec.outputs.limit_distances = {"3km"};
  spec.outputs.regions = path("r.geojson");
  spec.outputs.preview = path("p.png");
  const JobResult r = run_job(spec);
  const cv::Mat img = cv::imread(path("p.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  const int mw = r.report["deliverables"]["preview"]["width"].get<int>();
  const int mh = r.report["deliverables"]["preview"]["height"].get<int>();
  ASSERT_EQ(mw, 400);
  ASSERT_EQ(mh, 300);
  ASSERT_EQ(img.cols, mw + 260);
  auto px = [&](double x, double y) {  // the pixel of a point (1 cell per pixel here)
    return cv::Point(static_cast<int>((x - 400000) / 100), static_cast<int>((6130000 - y) / 100));
  };
  auto is = [](const cv::Vec3b& v, const std::array<uint8_t, 3>& c) { return v == cv::Vec3b(c[0], c[1], c[2]); };
  EXPECT_TRUE(is(img.at<cv::Vec3b>(px(408500, 6108500)), kLandColour)) << "land inside the island";
  EXPECT_TRUE(is(img.at<cv::Vec3b>(px(403000, 6128000)), owner_colour(1))) << "the island's sea";
  EXPECT_TRUE(is(img.at<cv::Vec3b>(px(437000, 6102000)), owner_colour(2))) << "B's sea";
  // Lines: near each vertex of the line files, a dark (boundary) or navy (limit) pixel.
  auto near = [&](cv::Point p, auto&& test) {
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const cv::Point q = p + cv::Point(dx, dy);
        if (q.x >= 0 && q.y >= 0 && q.x < mw && q.y < mh && test(img.at<cv::Vec3b>(q))) return true;
      }
    return false;
  };
  auto vertices = [&](const std::string& file) {
    std::vector<cv::Point> out;
    const nlohmann::json doc = nlohmann::json::parse(std::ifstream(file));
    for (const auto& feat : doc["features"]) {
      const auto& g = feat["geometry"];
      const auto& lines = g["type"] == "LineString" ? nlohmann::json::array({g["coordinates"]}) : g["coordinates"];
      for (const auto& line : lines)
        for (const auto& c : line) out.push_back(px(c[0].get<double>(), c[1].get<double>()));
    }
    return out;
  };
  int dark = 0, total = 0;
  for (const cv::Point p : vertices(path("b.geojson"))) {
    if (p.x < 2 || p.y < 2 || p.x >= mw - 2 || p.y >= mh - 2) continue;
    ++total;
    dark += near(p, [](const cv::Vec3b& v) { return v[0] < 150 && v[1] < 150 && v[2] < 150; });
  }
  ASSERT_GT(total, 10);
  EXPECT_GE(dark, total * 9 / 10) << "boundary pixels at the line's vertices";
  int navy = 0, limit_total = 0;
  for (const cv::Point p : vertices(path("l.geojson"))) {
    if (p.x < 2 || p.y < 2 || p.x >= mw - 2 || p.y >= mh - 2) continue;
    ++limit_total;
    navy += near(p, [](const cv::Vec3b& v) { return v[0] > v[2] + 40 && v[2] < 140; });
  }
  ASSERT_GT(limit_total, 10);
  EXPECT_GE(navy, limit_total / 3) << "a dashed limit line: ink at most of its vertices";
  EXPECT_LT(navy, limit_total) << "dashed: some vertices fall in the gaps";
  // The legend: each owner's swatch, then land, beside the map; text to the right of each.
  const int x0 = mw + 12;
  EXPECT_TRUE(is(img.at<cv::Vec3b>(37, x0 + 7), owner_colour(1)));
  EXPECT_TRUE(is(img.at<cv::Vec3b>(57, x0 + 7), owner_colour(2)));
  EXPECT_TRUE(is(img.at<cv::Vec3b>(77, x0 + 7), kLandColour));
  for (int row : {37, 57, 77}) {
    int ink = 0;
    for (int x = x0 + 20; x < x0 + 200; ++x) ink += img.at<cv::Vec3b>(row - 2, x)[0] < 128;
    EXPECT_GT(ink, 3) << "legend text on row " << row;
  }
  // The scale bar: 100 m cells, 400 px: a fifth is 8 km, rounded down to 5 km = 50 px of ink.
  int bar = 0;
  for (int x = 10; x < 10 + 60; ++x) bar += img.at<cv::Vec3b>(mh - 12, x) == cv::Vec3b(20, 20, 20);
  EXPECT_EQ(bar, 51);
}

TEST(Quicklook, LabelsAreAsciiForTheFont) {
  EXPECT_EQ(ascii_label("\u00d8resund"), "Oresund");
  EXPECT_EQ(ascii_label("Gda\u0144sk"), "Gdansk");
  EXPECT_EQ(ascii_label("\u4e2d<b>"), "?<b>");
  EXPECT_EQ(ascii_label(std::string("a\x01\xff")), "a??");
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
  const std::string gpkg = test::fixture("oresund.gpkg");
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
  // Checked against the cells (the states' land is owned too): the rows, all owned cells, none
  // in the other state's region.
  const Raster<int32_t> own = read_int32(path("own.tif"));
  const auto& check = d["regions"]["against_cells"];
  EXPECT_EQ(check["rows"].get<int64_t>(), own.height());
  EXPECT_EQ(check["cells_checked"].get<int64_t>() + check["cells_near_edges"].get<int64_t>(),
            std::count_if(own.cells().begin(), own.cells().end(), [](int32_t o) { return o != 0; }));
  EXPECT_EQ(check["cells_in_another_region"], 0);
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
