// Lines by sea in a job: the Øresund's ports (DK and SE) with the land as barriers. The boundary
// file's vertices are equidistant by sea (each owner's distance measured by the exact engine on
// that owner's ports alone, at the vertex), its lines keep to the sea and end on the grid's edge
// or on a coast; the margin raster is the difference of the two owners' own fields by sea; the
// preview is drawn; the regions are each owner's sea; limits by sea lie at their distance by sea
// and end on the coasts, and with a max distance the regions are each owner's sea within it;
// the report says what the lines by sea cost; with weights and reaches the lines are at equal
// cost by sea or on a reach's arc by sea; the turning points name each side's last bend; the
// relevant area gives each owner's sea within it.
#include <gtest/gtest.h>
#include <ogrsf_frmts.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fixtures.hpp"
#include "geodesic_oracle.hpp"
#include "rv/engine/outputs.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/job.hpp"
#include "rv/lines/regions.hpp"
#include "rv/sea/sea_metric.hpp"
#include "rv/sea/visibility.hpp"
#include "sea_ports.hpp"

namespace fs = std::filesystem;

namespace rv {
namespace {

using test::fixture;

// (The checks, below the fixture.)
void expect_lines_by_sea(const JobSpec& s, double on_coast);

class SeaLinesJob : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rv_sea_lines_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The ports and the land in UTM 33N, 250 m cells over the strait, with boundaries, tripoints,
  // the margin and the preview.
  JobSpec spec(const std::string& sub) const {
    JobSpec s = test::oresund_ports_by_sea();
    fs::create_directories(dir_ / sub);
    s.outputs.ownership = (dir_ / sub / "own.tif").string();
    s.outputs.distance = (dir_ / sub / "dist.tif").string();
    s.outputs.boundaries = (dir_ / sub / "boundaries.geojson").string();
    s.outputs.tripoints = (dir_ / sub / "tripoints.geojson").string();
    s.outputs.margin = (dir_ / sub / "margin.tif").string();
    s.outputs.preview = (dir_ / sub / "preview.png").string();
    s.outputs.regions = (dir_ / sub / "regions.gpkg").string();
    s.outputs.report = (dir_ / sub / "report.json").string();
    return s;
  }
  // `s` with the ownership, the regions and the report in folder `sub`, within `max_distance`.
  JobSpec within(JobSpec s, const std::string& sub, double max_distance) const {
    fs::create_directories(dir_ / sub);
    s.outputs.ownership = (dir_ / sub / "own.tif").string();
    s.outputs.regions = (dir_ / sub / "regions.gpkg").string();
    s.outputs.report = (dir_ / sub / "report.json").string();
    s.max_distance = max_distance;
    return s;
  }
  fs::path dir_;
};

// One owner's distance by sea at p: the exact engine on that owner's seeds alone, over a grid
// of one cell centred on p (metres, Float32 as the engine's rasters hold it).
double owner_distance_at(const PreparedJob& job, int32_t owner, Vec2 p) {
  std::vector<bool> drop(job.loaded.seeds.features().size());
  for (size_t f = 0; f < drop.size(); ++f) drop[f] = job.loaded.seeds.features()[f].owner != owner;
  std::vector<int32_t> site_of;
  const SeedSet alone = job.loaded.seeds.without(drop, site_of);
  GridSpec g;
  g.res = job.loaded.crs.geographic ? 1e-6 : 1.0;
  g.width = g.height = 1;
  g.xmin = p.x - 0.5 * g.res;
  g.ymax = p.y + 0.5 * g.res;
  SeaOptions options;
  options.metric = job.metric;
  const SeaField f = compute_sea(alone, job.sea->loaded.barriers, g, g.full_window(), options);
  const float d = f.field.distance.at(0, 0);
  return d == kNoDistance ? INFINITY : static_cast<double>(d);
}

// The nearest distance from p to an edge of the barriers in metres: straight edges of a
// projected grid, or (`geodesic`, longitude/latitude) geodesic ones, measured along
// GeographicLib's geodesic (edges farther than 0.01 degrees left out).
double to_coast(const Barriers& barriers, Vec2 p, bool geodesic) {
  double best = INFINITY;
  auto edge = [&](Vec2 a, Vec2 b) {
    const double dx = b.x - a.x, dy = b.y - a.y, l2 = dx * dx + dy * dy;
    const double t = l2 > 0 ? std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / l2, 0.0, 1.0) : 0.0;
    const double chord = std::hypot(p.x - a.x - t * dx, p.y - a.y - t * dy);
    if (!geodesic)
      best = std::min(best, chord);
    else if (chord < 0.01)
      best = std::min(best, test::segment_foot(p, a, b).metres);
  };
  for (const Barriers::Polygon& poly : barriers.polygons())
    for (const Ring& r : poly.rings)
      for (size_t i = 0; i < r.size(); ++i) edge(r[i], r[(i + 1) % r.size()]);
  return best;
}

// Runs `s` and checks its boundaries, margin and preview (see the file's head); `on_coast`: how
// near a coast an end must lie (metres).
void expect_lines_by_sea(const JobSpec& s, double on_coast) {
  const nlohmann::json report = run_job(s).report;
  const PreparedJob job = prepare_job(s);
  ASSERT_TRUE(job.sea);
  const Barriers& land = job.sea->loaded.barriers;
  const Visibility vis(land);
  const GridSpec& g = job.grid;
  const bool geodesic = job.metric.kind == MetricSpec::geodesic;

  GDALDataset* ds = GDALDataset::Open(s.outputs.boundaries.c_str(), GDAL_OF_VECTOR);
  ASSERT_NE(ds, nullptr);
  OGRLayer* layer = ds->GetLayer(0);
  int lines = 0, checked = 0, ends_on_coast = 0, ends_on_frame = 0;
  double worst = 0.0;
  for (OGRFeature* f; (f = layer->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(f)) {
    ++lines;
    const OGRLineString* ls = f->GetGeometryRef()->toLineString();
    const int n = ls->getNumPoints();
    ASSERT_GE(n, 2);
    for (int i = 0; i < n; ++i) {
      const Vec2 p{ls->getX(i), ls->getY(i)};
      // (On the ellipsoid the coast's edges are geodesics, which the planar reading here does
      // not follow: a point on one may read as inland by centimetres.)
      EXPECT_TRUE(!vis.on_land(p) || (geodesic && to_coast(land, p, true) < on_coast)) << p.x << "," << p.y;

      if (i % 20 == 0 || i == n - 1) {
        const double dk = owner_distance_at(job, 1, p), se = owner_distance_at(job, 2, p);
        EXPECT_NEAR(dk, se, 2e-7 * dk + 5e-3) << p.x << "," << p.y;
        worst = std::max(worst, std::abs(dk - se));
        ++checked;
      }
    }
    for (const int i : {0, n - 1}) {
      const Vec2 p{ls->getX(i), ls->getY(i)};
      const bool frame =
          p.x <= g.xmin + g.res || p.x >= g.xmax() - g.res || p.y <= g.ymin() + g.res || p.y >= g.ymax - g.res;
      const bool coast = to_coast(land, p, geodesic) < on_coast;
      ends_on_frame += frame;
      ends_on_coast += coast;
      EXPECT_TRUE(frame || coast) << "an end in the open sea at " << p.x << "," << p.y;
    }
  }
  GDALClose(GDALDataset::ToHandle(ds));
  EXPECT_GE(lines, 1);
  EXPECT_GT(checked, 30);
  std::printf("deliverables: %s\n", report.at("timings_s").at("deliverables").dump().c_str());
  EXPECT_GT(ends_on_coast, 0);
  std::printf(
      "boundaries by sea: %d lines, %d vertices checked, worst |d_DK - d_SE| %.3g m, %d ends on the coast, %d on the "
      "frame\n",
      lines, checked, worst, ends_on_coast, ends_on_frame);

  const nlohmann::json& b = report.at("deliverables").at("boundaries");
  EXPECT_EQ(b.at("ends_on_barriers").get<int>(), ends_on_coast);
  EXPECT_EQ(report.at("deliverables").at("by_sea").at("owners_settled").get<int>(), 2);

  // The margin: the other owner's distance by sea minus the own, cell for cell against the two
  // owners' own fields by sea (Float32 both).
  auto alone = [&](int32_t owner) {
    std::vector<bool> drop(job.loaded.seeds.features().size());
    for (size_t f = 0; f < drop.size(); ++f) drop[f] = job.loaded.seeds.features()[f].owner != owner;
    std::vector<int32_t> site_of;
    const SeedSet seeds = job.loaded.seeds.without(drop, site_of);
    SeaOptions options;
    options.metric = job.metric;
    return compute_sea(seeds, land, g, g.full_window(), options).field.distance;
  };
  const Raster<float> dk = alone(1), se = alone(2);
  const Raster<float> margin = read_float32(s.outputs.margin);
  const Raster<int32_t> own = read_int32(s.outputs.ownership);
  int64_t cells = 0;
  for (size_t i = 0; i < margin.cells().size(); ++i) {
    if (own.cells()[i] == 0) continue;
    const double want = std::abs(static_cast<double>(dk.cells()[i]) - static_cast<double>(se.cells()[i]));
    ASSERT_NEAR(margin.cells()[i], want, 1e-6 * std::max(dk.cells()[i], se.cells()[i]) + 1e-2) << i;
    ++cells;
  }
  EXPECT_GT(cells, 10000);
  EXPECT_GT(fs::file_size(s.outputs.preview), 1000u);

  // The regions: each owner's sea, bounded by the boundaries, the coasts and the grid's edge.
  // Areas within 2 % of the owner's cells (a cell's area each), the land outside them all.
  std::map<int32_t, int64_t> cells_of;
  for (int32_t o : own.cells())
    if (o > 0) ++cells_of[o];
  const nlohmann::json& regions = report.at("deliverables").at("regions");
  ASSERT_EQ(regions.at("owners").get<int>(), 2);
  const OGRGeometry* land_union = nullptr;
  OGRMultiPolygon land_polygons;
  for (const Barriers::Polygon& poly : land.polygons()) {
    OGRPolygon p;
    for (const Ring& r : poly.rings) {
      // (On the ellipsoid the coast's edges are geodesics: followed in steps of 50 m. The ring's
      // points set at once: OGR's addPoint grows it a point at a time.)
      std::vector<OGRRawPoint> points;
      for (size_t i = 0; i < r.size(); ++i) {
        const Vec2 u = r[i], w = r[(i + 1) % r.size()];
        points.emplace_back(u.x, u.y);
        if (!geodesic) continue;
        const GeographicLib::GeodesicLine gl = test::wgs84().InverseLine(u.y, u.x, w.y, w.x);
        const int n = static_cast<int>(std::ceil(gl.Distance() / 50.0));
        for (int k = 1; k < n; ++k) {
          double lat, lon;
          gl.Position(gl.Distance() * k / n, lat, lon);
          points.emplace_back(lon, lat);
        }
      }
      OGRLinearRing lr;
      lr.setPoints(static_cast<int>(points.size()), points.data());
      lr.closeRings();
      p.addRing(&lr);
    }
    land_polygons.addGeometry(&p);
  }
  std::unique_ptr<OGRGeometry> merged(land_polygons.UnionCascaded());
  land_union = merged.get();
  GDALDataset* rd = GDALDataset::Open(s.outputs.regions.c_str(), GDAL_OF_VECTOR);
  ASSERT_NE(rd, nullptr);
  OGRLayer* rl = rd->GetLayerByName("regions");
  ASSERT_NE(rl, nullptr);
  int owners = 0;
  for (OGRFeature* f; (f = rl->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(f)) {
    ++owners;
    const int32_t owner = f->GetFieldAsInteger("owner");
    const double area = f->GetFieldAsDouble("area");
    const double cell_area = geodesic ? area / static_cast<double>(cells_of[owner]) : g.res * g.res;
    if (!geodesic) {
      EXPECT_NEAR(area, static_cast<double>(cells_of[owner]) * cell_area, 0.02 * area) << owner;
    }
    EXPECT_EQ(f->GetFieldAsDouble("land_area"), 0.0);
    // (Areas in the grid's plane, square degrees on the ellipsoid: the regions follow the coast's
    // geodesics within the line tolerance, the land here in steps of 50 m.)
    // (The intersection may be a polygon, lines where a region runs along the coast, or a
    // collection of both; OGR_G_Area gives any of them its area, none for lines.)
    std::unique_ptr<OGRGeometry> wet(f->GetGeometryRef()->Intersection(land_union));
    const double on_land = wet ? OGR_G_Area(OGRGeometry::ToHandle(wet.get())) : 0.0;
    const double plane_area = OGR_G_Area(OGRGeometry::ToHandle(f->GetGeometryRef()));
    ASSERT_GT(plane_area, 0.0) << owner;
    EXPECT_LT(on_land, (geodesic ? 1e-7 : 1e-9) * plane_area) << owner;
  }
  GDALClose(GDALDataset::ToHandle(rd));
  EXPECT_EQ(owners, 2);
}

TEST_F(SeaLinesJob, BoundariesBySeaAreEquidistantBySeaAndEndOnTheCoast) { expect_lines_by_sea(spec("utm"), 1e-6); }

// The same on the ellipsoid (a longitude/latitude grid of 0.005 degrees, geodesic paths): an end
// on a coast lies on its geodesic edge within a millimetre.
TEST_F(SeaLinesJob, OnTheEllipsoidToo) {
  JobSpec s = spec("geo");
  s.seeds.target_crs.clear();
  s.metric = MetricRequest::automatic;
  s.grid.extent = std::array<double, 4>{12.3, 55.4, 13.0, 56.15};
  s.grid.resolution = 0.005;
  expect_lines_by_sea(s, 1e-3);
}

// On the ellipsoid the regions' coasts are the barriers' geodesic edges, followed by chords within
// the line tolerance (1 mm) of them: every chord between two points of a coast has its midpoint
// within the tolerance of it. The chords follow the geodesic, not the grid: a grid of half the
// cell gives the same coast points, fewer than one every 60 m.
TEST_F(SeaLinesJob, OnTheEllipsoidTheRegionsCoastsFollowTheGeodesicsWithinTheLineTolerance) {
  std::map<double, std::set<std::pair<double, double>>> coast_points;
  for (const double res : {0.005, 0.0025}) {
    JobSpec s = spec(res == 0.005 ? "geo" : "fine");
    s.seeds.target_crs.clear();
    s.metric = MetricRequest::automatic;
    s.grid.extent = std::array<double, 4>{12.3, 55.4, 13.0, 56.15};
    s.grid.resolution = res;
    s.outputs.margin.clear();
    s.outputs.preview.clear();
    run_job(s);
    const PreparedJob job = prepare_job(s);
    ASSERT_EQ(job.metric.kind, MetricSpec::geodesic);
    const Barriers& land = job.sea->loaded.barriers;
    GDALDataset* rd = GDALDataset::Open(s.outputs.regions.c_str(), GDAL_OF_VECTOR);
    ASSERT_NE(rd, nullptr);
    OGRLayer* rl = rd->GetLayerByName("regions");
    ASSERT_NE(rl, nullptr);
    int64_t chords = 0;
    double worst = 0.0, coast_length = 0.0;
    auto ring = [&](const OGRLinearRing* r) {
      for (int i = 0; i + 1 < r->getNumPoints(); ++i) {
        const Vec2 u{r->getX(i), r->getY(i)}, w{r->getX(i + 1), r->getY(i + 1)};
        if (to_coast(land, u, true) > 1e-6 || to_coast(land, w, true) > 1e-6) continue;
        coast_points[res].insert({u.x, u.y});
        const double off = to_coast(land, Vec2{0.5 * (u.x + w.x), 0.5 * (u.y + w.y)}, true);
        worst = std::max(worst, off);
        coast_length += test::metres(u, w);
        ++chords;
      }
    };
    for (OGRFeature* f; (f = rl->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(f)) {
      const OGRGeometry* g = f->GetGeometryRef();
      std::vector<const OGRPolygon*> polys;
      if (wkbFlatten(g->getGeometryType()) == wkbPolygon)
        polys.push_back(g->toPolygon());
      else
        for (const OGRGeometry* part : *g->toMultiPolygon()) polys.push_back(part->toPolygon());
      for (const OGRPolygon* poly : polys) {
        ring(poly->getExteriorRing());
        for (int k = 0; k < poly->getNumInteriorRings(); ++k) ring(poly->getInteriorRing(k));
      }
    }
    GDALClose(GDALDataset::ToHandle(rd));
    std::printf("%.4f deg: %lld chords along the coasts (%.0f km), worst midpoint %.2e m off its geodesic\n", res,
                static_cast<long long>(chords), coast_length / 1000.0, worst);
    EXPECT_GT(chords, 500) << res;
    EXPECT_LE(worst, 1e-3 + 1e-6) << res;
    // (The former rule, a point every fifth of a cell, takes more on the finer grid.)
    EXPECT_LT(static_cast<double>(chords), coast_length / 60.0) << res;
  }
  EXPECT_EQ(coast_points[0.005], coast_points[0.0025]);
}

// A 5 km limit by sea: every vertex is 5 km by sea from the nearest port (the exact engine at
// the vertex), and the open ends lie on a coast or the grid's edge.
// A run settles each owner's bend nodes only as far by sea as its lines need (half as far again as
// the field's largest distance or the limit, and 16 cells); a streamed one raises that strip by
// strip, going on from where it stopped. Both settle the same nodes with the same tests, and draw
// the same lines, byte for byte.
TEST_F(SeaLinesJob, ARunSettlesTheOwnersOnlyAsFarAsItsLinesNeed) {
  std::map<std::string, nlohmann::json> reports;
  std::map<std::string, JobSpec> specs;
  for (const std::string name : {"whole", "streamed"}) {
    JobSpec s = spec(name);
    s.strip_rows = name == "whole" ? -1 : 64;
    s.outputs.margin.clear();
    s.outputs.preview.clear();
    s.outputs.limits = (fs::path(s.outputs.ownership).parent_path() / "limits.geojson").string();
    s.outputs.limit_distances = {"5km"};
    reports[name] = run_job(s).report;
    specs[name] = s;
  }
  EXPECT_FALSE(reports["whole"].at("streaming").at("streamed").get<bool>());
  EXPECT_TRUE(reports["streamed"].at("streaming").at("streamed").get<bool>());
  const nlohmann::json& whole = reports["whole"].at("deliverables").at("by_sea");
  const nlohmann::json& streamed = reports["streamed"].at("deliverables").at("by_sea");
  EXPECT_GE(reports["streamed"].at("timings_s").at("streamed").at("strips").get<int64_t>(), 2);
  ASSERT_TRUE(whole.contains("settled_within"));
  ASSERT_TRUE(streamed.contains("settled_within"));
  EXPECT_EQ(whole.at("settled_within").get<double>(), streamed.at("settled_within").get<double>());
  EXPECT_EQ(whole.at("bend_tests").get<int64_t>(), streamed.at("bend_tests").get<int64_t>());
  float farthest = 0.0f;
  {
    const Raster<float> d = read_float32(specs["whole"].outputs.distance);
    for (float v : d.cells())
      if (std::isfinite(v) && v != kNoDistance) farthest = std::max(farthest, v);
  }
  EXPECT_GT(farthest, 1000.0f);
  // (Metres in UTM: 250 m cells; the 5 km limit when it is the larger.)
  const double want = 1.5 * std::max(static_cast<double>(farthest), 5000.0) + 16.0 * 250.0 * std::sqrt(2.0) * 1.01;
  EXPECT_DOUBLE_EQ(whole.at("settled_within").get<double>(), want);
  for (auto member : {&OutputRequest::boundaries, &OutputRequest::tripoints, &OutputRequest::limits}) {
    std::ifstream a(specs["whole"].outputs.*member), b(specs["streamed"].outputs.*member);
    const std::string ta((std::istreambuf_iterator<char>(a)), {}), tb((std::istreambuf_iterator<char>(b)), {});
    EXPECT_GT(ta.size(), 100u) << specs["whole"].outputs.*member;
    EXPECT_EQ(ta, tb) << specs["whole"].outputs.*member;
  }
}

TEST_F(SeaLinesJob, ALimitBySeaLiesAtItsDistanceBySeaAndEndsOnTheCoasts) {
  JobSpec s = spec("limits");
  const fs::path folder = fs::path(s.outputs.ownership).parent_path();
  s.outputs.limits = (folder / "limits.geojson").string();
  s.outputs.limit_distances = {"5km"};
  const nlohmann::json report = run_job(s).report;
  const PreparedJob job = prepare_job(s);
  const Barriers& land = job.sea->loaded.barriers;
  const GridSpec& g = job.grid;
  GDALDataset* ds = GDALDataset::Open(s.outputs.limits.c_str(), GDAL_OF_VECTOR);
  ASSERT_NE(ds, nullptr);
  int checked = 0, on_coast = 0;
  double worst = 0.0;
  for (OGRFeature* f; (f = ds->GetLayer(0)->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(f)) {
    const OGRLineString* ls = f->GetGeometryRef()->toLineString();
    const int n = ls->getNumPoints();
    for (int i = 0; i < n; i += 100) {
      const Vec2 p{ls->getX(i), ls->getY(i)};
      GridSpec one;
      one.res = 1.0;
      one.width = one.height = 1;
      one.xmin = p.x - 0.5;
      one.ymax = p.y + 0.5;
      const double d = compute_sea(job.loaded.seeds, land, one, one.full_window()).field.distance.at(0, 0);
      EXPECT_NEAR(d, 5000.0, 2e-3) << p.x << "," << p.y;
      worst = std::max(worst, std::abs(d - 5000.0));
      ++checked;
    }
    const bool closed = ls->get_IsClosed();
    if (closed) continue;
    for (const int i : {0, n - 1}) {
      const Vec2 p{ls->getX(i), ls->getY(i)};
      const bool frame =
          p.x <= g.xmin + g.res || p.x >= g.xmax() - g.res || p.y <= g.ymin() + g.res || p.y >= g.ymax - g.res;
      const bool coast = to_coast(land, p, false) < 1e-6;
      on_coast += coast;
      EXPECT_TRUE(frame || coast) << "a limit's end in the open sea at " << p.x << "," << p.y;
    }
  }
  GDALClose(GDALDataset::ToHandle(ds));
  EXPECT_GT(checked, 100);
  EXPECT_GT(on_coast, 4);
  EXPECT_EQ(report.at("deliverables").at("limits").at("ends_on_barriers").get<int>(), on_coast);
  std::printf("a 5 km limit by sea: %d vertices checked, worst |d - 5 km| %.3g m (Float32), %d ends on a coast\n",
              checked, worst, on_coast);
}

// Runs `s` (ownership, regions and report set, a max distance) and checks that every cell centre
// inside a region is that owner's (but within a metre of the region's edge) and that each
// owner's area is its cells' within `area_tolerance` (a fraction; a cell's area: res^2, or on a
// longitude/latitude grid the ellipsoid's area of its row's cell). Returns the cell centres
// inside the regions.
int64_t expect_regions_are_the_owned_cells(const JobSpec& s, int owners_wanted, double area_tolerance) {
  run_job(s);
  const Raster<int32_t> own = read_int32(s.outputs.ownership);
  const GridSpec& g = own.grid();
  const bool geographic = s.grid.resolution < 1.0;
  std::vector<double> cell_area(static_cast<size_t>(g.height), g.res * g.res);
  if (geographic)
    for (int64_t r = 0; r < g.height; ++r) {
      const double x0 = g.centre_x(0) - 0.5 * g.res, y0 = g.centre_y(r) - 0.5 * g.res;
      const std::vector<Vec2> ring{{x0, y0}, {x0 + g.res, y0}, {x0 + g.res, y0 + g.res}, {x0, y0 + g.res}};
      cell_area[static_cast<size_t>(r)] = ring_area(ring, test::geodesic_metric(), nullptr, g.res);
    }
  std::map<int32_t, double> area_of;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) area_of[own.at(c, r)] += cell_area[static_cast<size_t>(r)];
  EXPECT_GT(area_of[0], 0.0);  // land and the sea beyond the max distance
  GDALDataset* rd = GDALDataset::Open(s.outputs.regions.c_str(), GDAL_OF_VECTOR);
  EXPECT_NE(rd, nullptr);
  if (rd == nullptr) return 0;
  OGRLayer* rl = rd->GetLayerByName("regions");
  EXPECT_NE(rl, nullptr);
  int owners = 0;
  int64_t inside = 0, near_edge = 0;
  const double metre = geographic ? 1e-5 : 1.0;
  for (OGRFeature* f; rl != nullptr && (f = rl->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(f)) {
    ++owners;
    const int32_t owner = f->GetFieldAsInteger("owner");
    EXPECT_NEAR(f->GetFieldAsDouble("area"), area_of[owner], area_tolerance * area_of[owner]) << owner;
    const OGRGeometry* region = f->GetGeometryRef();
    const OGRPreparedGeometryUniquePtr prepared(
        OGRCreatePreparedGeometry(OGRGeometry::ToHandle(const_cast<OGRGeometry*>(region))));
    std::unique_ptr<OGRGeometry> edge(region->Boundary());
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        OGRPoint centre(g.centre_x(c), g.centre_y(r));
        if (!OGRPreparedGeometryContains(prepared.get(), OGRGeometry::ToHandle(&centre))) continue;
        ++inside;
        if (own.at(c, r) == owner) continue;
        EXPECT_LT(edge->Distance(&centre), metre) << owner << ": cell " << c << "," << r << " is " << own.at(c, r);
        ++near_edge;
      }
  }
  GDALClose(GDALDataset::ToHandle(rd));
  EXPECT_EQ(owners, owners_wanted);
  std::printf("%lld cell centres inside the regions, %lld of another owner within a metre of the edge\n",
              static_cast<long long>(inside), static_cast<long long>(near_edge));
  return inside;
}

// Regions by sea within a max distance of 8 km: the faces are closed by the line at 8 km by sea
// where it meets the coasts, also where it crosses the channel, narrower than a cell, between an
// islet off the Swedish coast and the coast (one crossing, drawn as a line of its own). Before,
// the sea beyond 8 km behind the islet was one face with Sweden's (21 % too much).
TEST_F(SeaLinesJob, RegionsWithinAMaxDistanceAreEachOwnersSeaWithinIt) {
  EXPECT_GT(expect_regions_are_the_owned_cells(within(test::oresund_ports_by_sea(), "max", 8000.0), 2, 0.01), 8000);
}

// The western Baltic's 200 ports by sea, geodesic, within 12 nmi, south of Langeland: where the
// Danish and German discs meet, the distance along their boundary peaks above 12 nmi (the Danish
// ports' paths switch from one bend to another there), leaving a pocket of unowned sea one cell
// wide between the two owners and a sliver from it to the discs' cusp. The boundary's piece
// between the pocket and the cusp is one crossing, whose two ends go to the pocket and to the
// cusp (both went to the pocket before, and the regions were refused).
TEST_F(SeaLinesJob, RegionsWithinAMaxDistanceCloseRoundAPocketBetweenTwoOwnersDiscs) {
  JobSpec s;
  s.seeds.paths = {fixture("baltic_west_ports.geojson")};
  s.seeds.owner_field = "owner";
  s.barriers = {fixture("baltic_west.gpkg")};
  s.grid.resolution = 0.005;
  s.grid.extent = std::array<double, 4>{10.5, 54.4, 11.1, 54.9};
  EXPECT_GT(expect_regions_are_the_owned_cells(within(s, "pocket", 22224.0), 2, 0.01), 5000);
}

// The western Baltic's ports by sea with the land as barriers on `extent` at `resolution` deg
// (folder `sub`): the regions are the owned cells of two owners (their areas within
// `area_tolerance`, 5 % unless told: at these grids the cells' staircase along the detailed coast
// is up to 4 % off the regions' exact areas),
// over `cells` cell centres at least, with `found` lines (or ends) counted in the report's
// boundaries.`counter` (the lines found from the coasts unless told) and no change of owner along a
// coast unexplained.
void expect_regions_split_from_the_coasts(const fs::path& dir, const std::string& sub, double resolution,
                                          std::array<double, 4> extent, int64_t cells, int64_t found,
                                          const char* counter = "channels_crossed", double area_tolerance = 0.05) {
  JobSpec s;
  s.seeds.paths = {fixture("baltic_west_ports.geojson")};
  s.seeds.owner_field = "owner";
  s.barriers = {fixture("baltic_west.gpkg")};
  s.grid.resolution = resolution;
  s.grid.extent = extent;
  fs::create_directories(dir / sub);
  s.outputs.ownership = (dir / sub / "own.tif").string();
  s.outputs.regions = (dir / sub / "regions.gpkg").string();
  s.outputs.report = (dir / sub / "report.json").string();
  EXPECT_GT(expect_regions_are_the_owned_cells(s, 2, area_tolerance), cells);
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(s.outputs.report));
  const nlohmann::json& b = report.at("deliverables").at("boundaries");
  EXPECT_EQ(b.at(counter).get<int64_t>(), found);
  EXPECT_EQ(b.at("coast_changes_unexplained").get<int64_t>(), 0);
}

// The western Baltic's ports by sea at 0.01 deg by the Flensburg Fjord: between the Danish and
// German land polygons a sliver of sea runs east from the grid's edge along their land border, up
// to 30 m wide, holding two cell centres (Danish). Inside it the owner changes to German (the
// paths come in from the west, round the polygons' ends), where no cell lies. The line across it
// is found from its coasts, so the sliver's two parts are two owners' faces; before, the whole
// sliver was one face, its owner taken at a point in the German part, and the two Danish cells
// lay in Germany's region.
TEST_F(SeaLinesJob, RegionsSplitWhereTheOwnerChangesInASliverOfSeaWithNoCell) {
  expect_regions_split_from_the_coasts(dir_, "sliver", 0.01, {9.0, 54.6, 10.0, 55.0}, 400, 1);
}

// The same ports at 0.02 deg over the Szczecin Lagoon's north: the German and Polish waters of the
// lagoon meet only in the strip between the last row of centres and the grid's southern edge (the
// land there stops 800 m short of it), where the owner changes. The line from the coast to the
// grid's edge is found from the coast (before, the two were one face: 4,918 German cells of the
// whole western Baltic's grid lay in Poland's region).
TEST_F(SeaLinesJob, RegionsSplitWhereTheOwnerChangesBetweenTheLastCellsAndTheGridsEdge) {
  expect_regions_split_from_the_coasts(dir_, "strip", 0.02, {13.8, 53.8, 14.8, 54.2}, 600, 1);
}

// The same ports at 0.02 deg over the inner Flensburg Fjord, narrower than a cell, with an islet in
// it: the Danish-German line runs from the north bank round the islet's east and back to the south
// bank, but the cells show only two crossings of it, near the south bank. The far one's nearest
// junction with the coast lies behind it (the south bank again): the line is followed on along
// the locus round the islet to the north bank instead. Before, both ends went to the same
// junction, the line was an out-and-back ring, and 14 of the 82 sea cells lay in the other
// owner's region. (Areas within 15 %: a 0.02-deg cell is 2.8 km2, and the staircase of so few
// along a fjord's coasts is that far off the regions' exact areas.)
TEST_F(SeaLinesJob, RegionsFollowALineOnRoundAnIsletWhereItsCellsStop) {
  expect_regions_split_from_the_coasts(dir_, "islet", 0.02, {9.2, 54.7, 9.9, 55.0}, 60, 1, "ends_followed", 0.15);
  // The followed stretch is on the locus like every other: round the tip east of the islet, where
  // the Danish side's nearest port changes and the line turns back, too (the turning point put
  // between the walk's points; it was 6.9 m off).
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(dir_ / "islet" / "report.json"));
  const nlohmann::json& along = report.at("deliverables").at("boundaries").at("along_lines");
  EXPECT_EQ(along.at("unresolved_segments").get<int64_t>(), 0);
  EXPECT_LE(along.at("max_midpoint").get<double>(), along.at("tolerance").get<double>());
}

// The same ports at 0.02 deg over the Fehmarn Belt: the Danish-German line comes north to Lolland,
// where the Danish side's nearest port changes and its locus would turn -- on land, about 100 m inside
// the coast. Two cell crossings a cell apart, across the coast's corner of their square, stood for
// both stretches, linked by one chord 325 m off the locus (unresolved). The line is parted where
// it meets the coast, each part ending on it, and every segment is within the tolerance.
TEST_F(SeaLinesJob, ALineWhoseLocusWouldTurnOnLandEndsOnTheCoastBothWays) {
  expect_regions_split_from_the_coasts(dir_, "turn", 0.02, {10.8, 54.4, 11.6, 54.8}, 400, 1, "turns_on_land");
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(dir_ / "turn" / "report.json"));
  const nlohmann::json& b = report.at("deliverables").at("boundaries");
  EXPECT_EQ(b.at("lines").get<int64_t>(), 2);
  EXPECT_EQ(b.at("along_lines").at("unresolved_segments").get<int64_t>(), 0);
  EXPECT_LE(b.at("along_lines").at("max_midpoint").get<double>(), b.at("along_lines").at("tolerance").get<double>());
}

// A piece of the Archipelago Sea (GSHHG's full coast, the islands between Aland and Finland) with
// the ports of both near it: the Aland-Finland line runs through chains of islets whose sounds hold
// no cell, found from their coasts.
// - At 0.02 deg a change of owner on an islet's coast was walked along the locus towards the next
//   islet, 95 m away across a sound narrower than the walk's first step; the coast was looked for
//   round the walk's point, and the nearest was the junction it had left. The walk ended where it
//   began, the line was left out, and the regions were refused (45 cells in the other's region).
// - At 0.005 deg two such changes 1 km apart, in sight of each other, were joined by a chord that
//   cut past an islet the locus goes round: 100 m off the locus, beyond what the refinement could
//   mend (unresolved), and 0.04 km2 of Finland's sea in Aland's region. A pair more than a cell
//   apart is now joined along the locus walked between them.
TEST_F(SeaLinesJob, ChangesOfOwnerInTheSoundsOfAChainOfIsletsAreJoinedAlongTheLocus) {
  for (const double res : {0.02, 0.005}) {
    JobSpec s;
    s.seeds.paths = {fixture("archipelago_islets_ports.geojson")};
    s.seeds.owner_field = "owner";
    s.barriers = {fixture("archipelago_islets.geojson")};
    s.grid.resolution = res;
    s.grid.extent = std::array<double, 4>{20.95, 60.33, 21.25, 60.52};
    const fs::path sub = dir_ / ("islets" + std::to_string(res));
    fs::create_directories(sub);
    s.outputs.ownership = (sub / "own.tif").string();
    s.outputs.regions = (sub / "regions.gpkg").string();
    s.outputs.report = (sub / "report.json").string();
    EXPECT_GT(expect_regions_are_the_owned_cells(s, 2, 0.05), res > 0.01 ? 100 : 1500) << res;
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(s.outputs.report));
    const nlohmann::json& b = report.at("deliverables").at("boundaries");
    EXPECT_GE(b.at("channels_crossed").get<int64_t>(), 10) << res;
    EXPECT_EQ(b.at("coast_changes_unexplained").get<int64_t>(), 0) << res;
    EXPECT_EQ(b.at("along_lines").at("unresolved_segments").get<int64_t>(), 0) << res;
    EXPECT_LE(b.at("along_lines").at("max_midpoint").get<double>(), b.at("along_lines").at("tolerance").get<double>())
        << res;
  }
}

// Partial effect by sea on Wolin: the western Baltic's ports at 0.01 deg round the Szczecin
// Lagoon's mouths, Wolin's four Polish ports at half effect. In the Swina, the channel between
// Usedom and Wolin (a third of a cell wide), the rule's cells change owner from Polish to German,
// but the Polish cells there meet the German ones only across corners and a knight's move away:
// no two 4-neighbours show the change. The locus between them is found from such a pair in sight
// of each other and followed across the channel from coast to coast (a third stretch, two more
// ends on coasts); before, the four Polish cells lay in Germany's region.
TEST_F(SeaLinesJob, APartialLocusInAChannelWhoseCellsMeetOnlyAcrossCornersIsDrawn) {
  const std::vector<std::array<double, 2>> wolin{{14.2065348732, 53.9164494805},
                                                 {14.6922026416, 53.9911224649},
                                                 {14.5756056537, 53.8448915789},
                                                 {14.2900807464, 53.8577079195}};
  nlohmann::json ports = nlohmann::json::parse(std::ifstream(fixture("baltic_west_ports.geojson")));
  int halved = 0;
  for (nlohmann::json& f : ports.at("features")) {
    const double x = f.at("geometry").at("coordinates")[0], y = f.at("geometry").at("coordinates")[1];
    const bool on_wolin = std::any_of(wolin.begin(), wolin.end(), [&](const std::array<double, 2>& p) {
      return std::abs(p[0] - x) < 1e-9 && std::abs(p[1] - y) < 1e-9;
    });
    f["properties"]["effect"] = on_wolin ? 0.5 : 1.0;
    halved += on_wolin;
  }
  ASSERT_EQ(halved, 4);
  fs::create_directories(dir_ / "swina");
  const std::string seeds = (dir_ / "swina" / "ports.geojson").string();
  std::ofstream(seeds) << ports.dump();
  JobSpec s;
  s.seeds.paths = {seeds};
  s.seeds.owner_field = "owner";
  s.seeds.effect_field = "effect";
  s.barriers = {fixture("baltic_west.gpkg")};
  s.grid.resolution = 0.01;
  s.grid.extent = std::array<double, 4>{14.0, 53.7, 14.6, 54.1};
  s.outputs.ownership = (dir_ / "swina" / "own.tif").string();
  s.outputs.regions = (dir_ / "swina" / "regions.gpkg").string();
  s.outputs.report = (dir_ / "swina" / "report.json").string();
  EXPECT_GT(expect_regions_are_the_owned_cells(s, 2, 0.05), 600);
  const nlohmann::json report = nlohmann::json::parse(std::ifstream(s.outputs.report));
  const nlohmann::json& partial = report.at("deliverables").at("boundaries").at("partial_effect");
  EXPECT_EQ(partial.at("stretches").get<int64_t>(), 3);
  EXPECT_EQ(partial.at("coast_ends").get<int64_t>(), 4);
  EXPECT_EQ(partial.at("along_lines").at("unresolved_segments").get<int64_t>(), 0);
}

// Weights and reaches by sea in a job: the Danish ports weigh 1.5, and DK6 (mid-strait off
// Amager) reaches only 5 km by sea. The files are the core engine's field cell for cell, other
// than the unweighted run's; every boundary vertex is at equal cost by sea (each owner's cheapest
// path: the engine on that owner's ports alone) or on DK6's reach (its path by sea 5 km long);
// the regions are each owner's cells.
TEST_F(SeaLinesJob, WeightsAndReachesCountThePathBySea) {
  nlohmann::json ports = nlohmann::json::parse(std::ifstream(fixture("oresund_ports.geojson")));
  for (nlohmann::json& f : ports.at("features")) {
    nlohmann::json& p = f.at("properties");
    p["w"] = p.at("owner") == "DK" ? 1.5 : 1.0;
    p["reach"] = p.at("port") == "DK6" ? nlohmann::json(5000.0) : nlohmann::json(nullptr);
  }
  JobSpec s = spec("weighted");
  s.outputs.margin.clear();  // (the margin measures unweighted distances: refused with weights)
  s.seeds.paths = {(dir_ / "weighted_ports.geojson").string()};
  std::ofstream(s.seeds.paths[0]) << ports.dump();
  s.seeds.weight_field = "w";
  s.seeds.reach_field = "reach";
  expect_regions_are_the_owned_cells(s, 2, 0.01);
  const PreparedJob job = prepare_job(s);
  ASSERT_TRUE(job.sea);
  const SeedSet& seeds = job.loaded.seeds;
  ASSERT_TRUE(seeds.adjusted());
  const Barriers& land = job.sea->loaded.barriers;
  SeaOptions options;
  options.metric = job.metric;
  const SeaField f = compute_sea(seeds, land, job.grid, job.grid.full_window(), options);
  const Raster<int32_t> own = read_int32(s.outputs.ownership);
  const Raster<float> dist = read_float32(s.outputs.distance);
  const Raster<int32_t> want = owner_raster(seeds, f.field, 1);
  JobSpec plain = spec("plain");
  plain.outputs = OutputRequest{};
  plain.outputs.ownership = (dir_ / "plain" / "own.tif").string();
  run_job(plain);
  const Raster<int32_t> unweighted = read_int32(plain.outputs.ownership);
  int64_t differ = 0;
  for (size_t c = 0; c < own.cells().size(); ++c) {
    ASSERT_EQ(own.cells()[c], want.cells()[c]) << c;
    ASSERT_EQ(dist.cells()[c], f.field.distance.cells()[c]) << c;
    differ += own.cells()[c] != unweighted.cells()[c];
  }
  EXPECT_GT(differ, 500);

  // One owner's cheapest cost by sea at p, and DK6's own path length (reach left out).
  auto cost_at = [&](int32_t owner, Vec2 p, bool dk6_alone) {
    std::vector<bool> drop(seeds.features().size());
    for (size_t k = 0; k < drop.size(); ++k)
      drop[k] = dk6_alone ? std::isinf(seeds.features()[k].reach) : seeds.features()[k].owner != owner;
    std::vector<int32_t> site_of;
    SeedSet alone = seeds.without(drop, site_of);
    if (dk6_alone) alone.set_adjustment(0, 1.0, INFINITY);
    GridSpec g;
    g.res = 1.0;
    g.width = g.height = 1;
    g.xmin = p.x - 0.5;
    g.ymax = p.y + 0.5;
    const SeaField one = compute_sea(alone, land, g, g.full_window(), options);
    const int32_t site = one.field.site.at(0, 0);
    if (site == kNoSite) return static_cast<double>(INFINITY);
    return static_cast<double>(one.field.distance.at(0, 0)) /
           alone.features()[static_cast<size_t>(alone.site_feature(site))].weight;
  };
  Vec2 dk6;
  for (size_t k = 0; k < seeds.features().size(); ++k)
    if (std::isfinite(seeds.features()[k].reach)) dk6 = seeds.sites()[k].a;  // (one point site per port)
  GDALDataset* ds = GDALDataset::Open(s.outputs.boundaries.c_str(), GDAL_OF_VECTOR);
  ASSERT_NE(ds, nullptr);
  int64_t equal = 0, on_reach = 0;
  for (OGRFeature* feature; (feature = ds->GetLayer(0)->GetNextFeature()) != nullptr;
       OGRFeature::DestroyFeature(feature)) {
    const OGRLineString* ls = feature->GetGeometryRef()->toLineString();
    for (int i = 0; i < ls->getNumPoints(); ++i) {
      const Vec2 p{ls->getX(i), ls->getY(i)};
      // (Each check runs the engine on one owner's ports: every 120th vertex, and every 30th near
      // DK6, where its reach's arc may be the line.)
      if (i % (std::hypot(p.x - dk6.x, p.y - dk6.y) < 6000.0 ? 30 : 120) != 0) continue;
      const double dk = cost_at(1, p, false), se = cost_at(2, p, false);
      if (std::abs(dk - se) < 2e-7 * se + 5e-3) {
        ++equal;
        continue;
      }
      EXPECT_NEAR(cost_at(1, p, true), 5000.0, 5e-3) << p.x << "," << p.y << ": " << dk << " " << se;
      ++on_reach;
    }
  }
  GDALClose(GDALDataset::ToHandle(ds));
  EXPECT_GT(equal, 20);
  EXPECT_GT(on_reach, 5);
  std::printf("boundaries by sea with weights: %lld vertices at equal cost, %lld on DK6's 5 km reach by sea\n",
              static_cast<long long>(equal), static_cast<long long>(on_reach));
}

// A tie region in the files: two ports 10 km from a breakwater's end, both hidden from the sea
// behind it (UTM 33N, 1 km cells). The boundary's vertices along the tie region's edge are counted
// in the report, per line in the GeoJSON file and flagged per vertex in the GeoPackage; the sea
// behind the breakwater's end is the first port's owner's.
TEST_F(SeaLinesJob, ATieRegionIsSaidInTheFilesAndTheReport) {
  auto at = [](double x, double y) {
    return "[" + std::to_string(400000 + x * 1000) + ", " + std::to_string(6000000 + y * 1000) + "]";
  };
  const std::string crs = R"("crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}})";
  const fs::path seeds = dir_ / "tie_ports.geojson", wall = dir_ / "tie_wall.geojson";
  std::ofstream(seeds) << R"({"type": "FeatureCollection", )" << crs << R"(, "features": [
      {"type": "Feature", "properties": {"owner": "lo"}, "geometry": {"type": "Point", "coordinates": )"
                       << at(14, 28) << R"(}},
      {"type": "Feature", "properties": {"owner": "hi"}, "geometry": {"type": "Point", "coordinates": )"
                       << at(12, 26) << "}}]}";
  std::ofstream(wall) << R"({"type": "FeatureCollection", )" << crs << R"(, "features": [
      {"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": [)"
                      << at(20, 20) << ", " << at(20, 45) << "]}}]}";
  int64_t counted[2] = {0, 0};
  for (const char* ext : {"geojson", "gpkg"}) {
    JobSpec s;
    s.seeds.paths = {seeds.string()};
    s.seeds.owner_field = "owner";
    s.barriers = {wall.string()};
    s.grid.resolution = 1000.0;
    s.grid.extent = std::array<double, 4>{400000.0, 6000000.0, 440000.0, 6050000.0};
    fs::create_directories(dir_ / ext);
    s.outputs.ownership = (dir_ / ext / "own.tif").string();
    s.outputs.boundaries = (dir_ / ext / (std::string("b.") + ext)).string();
    s.outputs.report = (dir_ / ext / "report.json").string();
    const nlohmann::json report = run_job(s).report;
    const int64_t ties = report.at("deliverables").at("boundaries").at("tie_vertices").get<int64_t>();
    EXPECT_GT(ties, 15) << ext;
    const Raster<int32_t> own = read_int32(s.outputs.ownership);
    EXPECT_EQ(own.at(30, 20), 1);  // (30.5, 29.5) km: behind the breakwater's end, tied: "lo"'s
    GDALDataset* ds = GDALDataset::Open(s.outputs.boundaries.c_str(), GDAL_OF_VECTOR);
    ASSERT_NE(ds, nullptr);
    OGRLayer* lines = ds->GetLayerByName("boundaries");
    ASSERT_NE(lines, nullptr);
    int64_t per_line = 0;
    for (OGRFeature* f; (f = lines->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(f))
      per_line += f->GetFieldAsInteger64("tie_vertices");
    EXPECT_EQ(per_line, ties) << ext;
    if (std::string(ext) == "gpkg") {
      OGRLayer* verts = ds->GetLayerByName("boundary_vertices");
      ASSERT_NE(verts, nullptr);
      int64_t flagged = 0;
      for (OGRFeature* f; (f = verts->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(f))
        flagged += f->GetFieldAsInteger("tie");
      EXPECT_EQ(flagged, ties);
    }
    GDALClose(GDALDataset::ToHandle(ds));
    counted[std::string(ext) == "gpkg"] = ties;
  }
  EXPECT_EQ(counted[0], counted[1]);
}

// The treaty table by sea: at each turning point both sides are equidistant by sea; a side seen
// directly is at its straight distance from its basepoint; a side whose path bends names its last
// bend, a vertex of the land that the point sees, with the path no shorter than the two straight
// legs through it; the sides' last bends change at turning points (the locus passes between a
// bisector and hyperbola branches round the headlands); the CSV carries the bends in via_*
// columns.
TEST_F(SeaLinesJob, TurningPointsBySeaNameEachSidesLastBend) {
  JobSpec s = spec("t");
  const fs::path folder = fs::path(s.outputs.ownership).parent_path();
  s.outputs.turning_points = (folder / "turning.json").string();
  run_job(s);
  const PreparedJob job = prepare_job(s);
  ASSERT_TRUE(job.sea);
  const Barriers& land = job.sea->loaded.barriers;
  const std::unique_ptr<SiteMetric> metric = make_sea_site_metric(job.loaded.seeds, land, job.grid);
  auto on_a_vertex = [&](Vec2 p) {
    double best = INFINITY;
    for (const Barriers::Polygon& poly : land.polygons())
      for (const Ring& r : poly.rings)
        for (const Vec2 v : r) best = std::min(best, std::hypot(v.x - p.x, v.y - p.y));
    return best;
  };
  const nlohmann::json table = nlohmann::json::parse(std::ifstream(s.outputs.turning_points));
  EXPECT_TRUE(table.value("by_sea", false));
  int64_t points = 0, bent = 0, bend_changes = 0;
  for (const nlohmann::json& line : table.at("lines"))
    for (const nlohmann::json& tp : line.at("points")) {
      ++points;
      const Vec2 p{tp.at("x").get<double>(), tp.at("y").get<double>()};
      double d0 = -1.0;
      for (const char* side : {"a", "b"}) {
        const nlohmann::json& list = tp.at(side);
        if (list.size() == 2 && list[0].contains("via") != list[1].contains("via")) ++bend_changes;
        if (list.size() == 2 && list[0].contains("via") && list[1].contains("via") &&
            list[0].at("via").at("vertex") != list[1].at("via").at("vertex"))
          ++bend_changes;
        for (const nlohmann::json& b : list) {
          const double d = b.at("distance").get<double>();
          if (d0 < 0.0) d0 = d;
          EXPECT_NEAR(d, d0, 1e-6 * d0 + 1e-6) << tp.dump();
          const Vec2 base{b.at("x").get<double>(), b.at("y").get<double>()};
          const double straight = std::hypot(p.x - base.x, p.y - base.y);
          if (!b.contains("via")) {
            EXPECT_NEAR(d, straight, 1e-6 * d + 1e-6) << tp.dump();
            continue;
          }
          ++bent;
          const Vec2 v{b.at("via").at("x").get<double>(), b.at("via").at("y").get<double>()};
          EXPECT_GE(b.at("via").at("vertex").get<int64_t>(), 1);
          EXPECT_LT(on_a_vertex(v), 1e-6) << tp.dump();
          // (Where a side's bend changes, the path round the far bend grazes the near one: both
          // in line with the point.)
          bool grazing = false;
          for (const nlohmann::json& o : list)
            if (o.contains("via") && o.at("via").at("vertex") != b.at("via").at("vertex")) {
              const Vec2 u{o.at("via").at("x").get<double>(), o.at("via").at("y").get<double>()};
              const double along = std::hypot(u.x - p.x, u.y - p.y) + std::hypot(v.x - u.x, v.y - u.y);
              grazing = grazing || along - std::hypot(v.x - p.x, v.y - p.y) < 1e-6;
            }
          EXPECT_TRUE(grazing || metric->open_between(p, v)) << tp.dump();
          EXPECT_GE(d, std::hypot(p.x - v.x, p.y - v.y) + std::hypot(v.x - base.x, v.y - base.y) - 1e-6) << tp.dump();
          // (Equal where the path only grazes its bend: a turning point on the bend's shadow edge.)
          EXPECT_GE(d, straight - 1e-6 * d) << tp.dump();
        }
      }
    }
  EXPECT_GT(points, 10);
  EXPECT_GT(bent, 10);
  EXPECT_GT(bend_changes, 15);

  JobSpec c = spec("c");
  c.outputs.turning_points = (fs::path(c.outputs.ownership).parent_path() / "turning.csv").string();
  run_job(c);
  std::ifstream csv(c.outputs.turning_points);
  std::string head, row;
  std::getline(csv, head);
  EXPECT_NE(head.find("a1_via_vertex,a1_via_lon,a1_via_lat,a1_via_x,a1_via_y"), std::string::npos) << head;
  // (Fields split at commas outside quotes.)
  auto fields = [](const std::string& text) {
    std::vector<std::string> out(1);
    bool quoted = false;
    for (const char ch : text) {
      if (ch == '"') quoted = !quoted;
      if (ch == ',' && !quoted)
        out.emplace_back();
      else
        out.back() += ch;
    }
    return out;
  };
  const std::vector<std::string> cols = fields(head);
  const auto a_via = std::find(cols.begin(), cols.end(), "a1_via_vertex") - cols.begin();
  const auto b_via = std::find(cols.begin(), cols.end(), "b1_via_vertex") - cols.begin();
  int64_t rows = 0, rows_with_a_bend = 0;
  while (std::getline(csv, row)) {
    const std::vector<std::string> f = fields(row);
    if (f.size() != cols.size() || f[0].rfind('L', 0) == 0) continue;
    ++rows;
    rows_with_a_bend += !f[static_cast<size_t>(a_via)].empty() || !f[static_cast<size_t>(b_via)].empty();
  }
  EXPECT_EQ(rows, points);
  EXPECT_GT(rows_with_a_bend, 5);
}

// The disproportionality test by sea on the Øresund (ports as seeds, the land as barriers), over a
// box of 20 x 30 km across the strait with land on both sides: it runs; the ports are points, so
// each owner's relevant coast is a point (length 0) and the coast shares are absent; each owner's
// sea area within the box is its cells' there to 3 % (the regions follow the exact lines and the
// coasts, the cells their centres), and the two add up to the box less its land.
TEST_F(SeaLinesJob, TheRelevantAreaBySeaGivesEachOwnersSeaWithinIt) {
  JobSpec s = spec("relevant");
  const double x0 = 340000, x1 = 360000, y0 = 6170000, y1 = 6200000;
  s.outputs.relevant_area = (dir_ / "box.geojson").string();
  std::ofstream(s.outputs.relevant_area)
      << R"({"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
      "features": [{"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [[)"
      << "[" << x0 << ", " << y0 << "], [" << x1 << ", " << y0 << "], [" << x1 << ", " << y1 << "], [" << x0 << ", "
      << y1 << "], [" << x0 << ", " << y0 << "]]]}}]}";
  const nlohmann::json r = run_job(s).report.at("deliverables").at("regions").at("relevant_area");
  const double box = (x1 - x0) * (y1 - y0);
  EXPECT_NEAR(r.at("area").get<double>(), box, 1e-3);
  const Raster<int32_t> own = read_int32(s.outputs.ownership);
  const GridSpec& g = own.grid();
  std::map<int64_t, double> cells;  // owner code: the area of its cells whose centres lie in the box
  for (int64_t row = 0; row < g.height; ++row)
    for (int64_t c = 0; c < g.width; ++c) {
      const double x = g.centre_x(c), y = g.centre_y(row);
      const int32_t o = own.cells()[static_cast<size_t>(row * g.width + c)];
      if (o > 0 && x > x0 && x < x1 && y > y0 && y < y1) cells[o] += g.res * g.res;
    }
  ASSERT_EQ(r.at("owners").size(), 2u);
  double sea = 0.0;
  for (const nlohmann::json& o : r.at("owners")) {
    SCOPED_TRACE(o.dump());
    EXPECT_EQ(o.at("coast_length").get<double>(), 0.0);
    EXPECT_TRUE(o.at("coast_share").is_null());
    const double a = o.at("sea_area").get<double>();
    EXPECT_GT(a, 0.0);
    EXPECT_NEAR(a, cells.at(o.at("owner").get<int64_t>()), 0.03 * a);
    sea += a;
  }
  EXPECT_LT(sea, 0.95 * box);  // land on both sides
  EXPECT_NEAR(sea, cells.at(1) + cells.at(2), 0.03 * sea);
}

}  // namespace
}  // namespace rv
