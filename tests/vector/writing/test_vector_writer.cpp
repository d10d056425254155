#include <gtest/gtest.h>

#include <gdal_alg.h>
#include <gdal_priv.h>
#include <ogr_api.h>
#include <ogrsf_frmts.h>
#include <unistd.h>

#include <filesystem>
#include <map>
#include <random>
#include <set>
#include <span>
#include <sstream>

#include "rv/engine/engine.hpp"
#include "rv/engine/outputs.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/gdal/vector_writer.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/region_check.hpp"
#include "rv/lines/regions.hpp"

namespace rv {
namespace {

namespace fs = std::filesystem;

class VectorWriter : public ::testing::Test {
 protected:
  void SetUp() override {
    gdal_init();
    dir_ = fs::temp_directory_path() / ("rv_vw_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

struct Opened {
  GDALDataset* ds = nullptr;
  explicit Opened(const std::string& p) { ds = GDALDataset::Open(p.c_str(), GDAL_OF_VECTOR); }
  ~Opened() {
    if (ds) GDALClose(GDALDataset::ToHandle(ds));
  }
};

// Three owners on a UTM-like grid: points and a line.
struct Scene {
  SeedSet seeds;
  GridSpec g;
  NearestField field;
  std::unique_ptr<PlanarSiteMetric> metric;
  std::unique_ptr<OwnerIndex> index;
  Scene() {
    const int32_t a = seeds.add_feature(seeds.owner_code("DK"));
    seeds.add_point(a, {500100.0, 6100800.0});
    const int32_t b = seeds.add_feature(seeds.owner_code("SE"));
    const std::vector<Vec2> coast{{501500.0, 6100100.0}, {501700.0, 6100900.0}};
    seeds.add_polyline(b, coast);
    const int32_t c = seeds.add_feature(seeds.owner_code("DE"));
    seeds.add_point(c, {500600.0, 6100050.0});
    const int32_t d = seeds.add_feature(seeds.owner_code("DK"));
    seeds.add_point(d, {500900.0, 6100950.0});
    g.xmin = 500000.0;
    g.ymax = 6101000.0;
    g.res = 20.0;
    g.width = 90;
    g.height = 50;
    g.crs = "EPSG:32633";
    ComputeOptions o;
    o.threads = 2;
    field = compute(seeds, g, o);
    metric = std::make_unique<PlanarSiteMetric>(seeds, Vec2{g.xmin, g.ymax});
    index = std::make_unique<OwnerIndex>(*metric);
  }
};

// 60 x 45 unit cells, south-west corner at the origin, no CRS.
GridSpec grid_60x45() {
  GridSpec g;
  g.xmin = 0;
  g.ymax = 45;
  g.res = 1.0;
  g.width = 60;
  g.height = 45;
  return g;
}

TEST_F(VectorWriter, BoundariesAndTripointsRoundTrip) {
  Scene s;
  const BoundaryResult b = extract_boundaries(s.field, *s.index);
  ASSERT_EQ(b.tripoints.size(), 1u);
  VectorOutputOptions o;
  o.crs = "EPSG:32633";
  o.distance_units = "m";
  for (const std::string ext : {"geojson", "gpkg"}) {
    const std::string bp = path("boundaries." + ext), tp = path("tripoints." + ext);
    write_boundaries(bp, b, *s.metric, o);
    write_tripoints(tp, b, *s.metric, o);
    Opened in(bp);
    ASSERT_NE(in.ds, nullptr) << bp;
    OGRLayer* l = in.ds->GetLayer(0);
    ASSERT_EQ(l->GetFeatureCount(), static_cast<GIntBig>(b.lines.size()));
    l->ResetReading();
    size_t i = 0;
    for (OGRFeature* f; (f = l->GetNextFeature()) != nullptr; ++i) {
      const BoundaryLine& line = b.lines[i];
      EXPECT_EQ(f->GetFieldAsInteger("owner_a"), line.owner_a);
      EXPECT_EQ(f->GetFieldAsInteger("owner_b"), line.owner_b);
      EXPECT_EQ(std::string(f->GetFieldAsString("label_a")), s.seeds.owner_labels()[line.owner_a - 1]);
      EXPECT_EQ(std::string(f->GetFieldAsString("label_b")), s.seeds.owner_labels()[line.owner_b - 1]);
      auto* ls = f->GetGeometryRef()->toLineString();
      ASSERT_EQ(ls->getNumPoints(), static_cast<int>(line.vertices.size()));
      EXPECT_NEAR(ls->getX(0), line.vertices[0].p.x, 1e-6);
      EXPECT_NEAR(ls->getY(0), line.vertices[0].p.y, 1e-6);
      // Owner DK (1) has two features: the basepoint feature list names the controlling one.
      // GeoJSON keeps integer lists; GeoPackage stores them as JSON text.
      std::vector<int> fa;
      const int idx = f->GetFieldIndex("features_a");
      if (f->GetFieldDefnRef(idx)->GetType() == OFTIntegerList) {
        int n = 0;
        const int* list = f->GetFieldAsIntegerList(idx, &n);
        fa.assign(list, list + n);
      } else {
        std::string text = f->GetFieldAsString(idx);
        // "[1,2]" (JSON) or OGR's "(2:1,2)" rendering of a list.
        if (text.front() == '(') text = text.substr(text.find(':') + 1);
        for (char& ch : text)
          if (ch == '[' || ch == ']' || ch == ',' || ch == ')') ch = ' ';
        std::istringstream in(text);
        for (int v; in >> v;) fa.push_back(v);
      }
      ASSERT_EQ(fa.size(), line.vertices.size());
      for (size_t k = 0; k < fa.size(); ++k) EXPECT_EQ(fa[k], s.seeds.site_feature(line.vertices[k].site_a) + 1);
      OGRFeature::DestroyFeature(f);
    }
    if (ext == "gpkg") {
      OGRLayer* v = in.ds->GetLayerByName("boundary_vertices");
      ASSERT_NE(v, nullptr);
      GIntBig n = 0;
      for (const auto& line : b.lines) n += static_cast<GIntBig>(line.vertices.size());
      EXPECT_EQ(v->GetFeatureCount(), n);
    }
    Opened tin(tp);
    ASSERT_NE(tin.ds, nullptr);
    OGRLayer* tl = tin.ds->GetLayer(0);
    ASSERT_EQ(tl->GetFeatureCount(), 1);
    tl->ResetReading();
    OGRFeature* f = tl->GetNextFeature();
    ASSERT_NE(f, nullptr);
    EXPECT_EQ(f->GetFieldAsInteger("owner_1"), 1);
    EXPECT_EQ(f->GetFieldAsInteger("owner_2"), 2);
    EXPECT_EQ(f->GetFieldAsInteger("owner_3"), 3);
    EXPECT_EQ(std::string(f->GetFieldAsString("label_3")), "DE");
    OGRFeature::DestroyFeature(f);
  }
  // No temporary files are left next to the outputs.
  for (const auto& e : fs::directory_iterator(dir_)) EXPECT_NE(e.path().filename().string()[0], '.');
  EXPECT_THROW(write_boundaries(path("b.shp"), b, *s.metric, o), Error);
  EXPECT_THROW(write_boundaries(path("missing/dir/b.geojson"), b, *s.metric, o), Error);
}

TEST_F(VectorWriter, LimitsRoundTrip) {
  Scene s;
  const std::vector<double> d{100.0, 250.0};
  LimitOptions lo;
  lo.per_owner = true;
  const LimitResult r = extract_limits(s.field, *s.index, d, lo);
  VectorOutputOptions o;
  o.crs = "EPSG:32633";
  o.distance_factor = 1.0 / 1852.0;
  o.distance_units = "nmi";
  write_limits(path("limits.gpkg"), r, s.seeds, o);
  Opened in(path("limits.gpkg"));
  ASSERT_NE(in.ds, nullptr);
  OGRLayer* l = in.ds->GetLayer(0);
  EXPECT_EQ(l->GetFeatureCount(), static_cast<GIntBig>(r.lines.size()));
  l->ResetReading();
  OGRFeature* f = l->GetNextFeature();
  ASSERT_NE(f, nullptr);
  EXPECT_NEAR(f->GetFieldAsDouble("distance"), 100.0 / 1852.0, 1e-12);
  EXPECT_EQ(std::string(f->GetFieldAsString("units")), "nmi");
  EXPECT_EQ(f->GetFieldAsInteger("owner"), 1);
  EXPECT_EQ(std::string(f->GetFieldAsString("label")), "DK");
  OGRFeature::DestroyFeature(f);
}

// Regions along the boundary lines: the faces cover the grid once (areas add up to the grid's),
// every cell centre lies in the region of its exact owner, a region's outline is made of the
// boundary lines' own vertices and the grid's edge, and an island's land is its polygon (within
// the grid), the rest of its owner's region its sea. With a max distance (odd trials) the regions
// end at the line at that distance: cells beyond it lie in none.
TEST_F(VectorWriter, LineRegionsFollowTheBoundaryLines) {
  // Random points of four owners and an island; odd trials with max distances from 3 to 12
  // cells (discs overlapping by less than a cell, tripoints beyond the max distance or between the
  // outermost centres and the grid's edge, one-cell holes in the owned area all occur).
  // Scene 40 (seed 5049): a crossing beside a one-cell hole was joined to a tripoint two cells
  // away, its line cutting a cell off its owner's region.
  for (uint32_t trial = 0; trial <= 40; ++trial) {
    const uint32_t t = trial == 40 ? 9 : trial;
    const double reach = t % 2 ? 3.0 + std::fmod(0.37 * t, 9.0) : std::numeric_limits<double>::infinity();
    SCOPED_TRACE("trial " + std::to_string(trial));
    std::mt19937 rng(trial == 40 ? 5049 : trial + 40);
    std::uniform_real_distribution<double> ux(0, 60), uy(0, 45);
    SeedSet seeds;
    for (int i = 0; i < 18; ++i) {
      const int32_t f = seeds.add_feature(seeds.owner_code("o" + std::to_string(1 + i % 4)));
      seeds.add_point(f, {ux(rng), uy(rng)});
    }
    // An island of owner o2 reaching over the grid's west edge: its land is clipped there.
    const int32_t island = seeds.add_feature(seeds.owner_code("o2"));
    seeds.add_polygon(island, {{{-2.0, 20.0}, {4.5, 20.0}, {4.5, 24.0}, {-2.0, 24.0}, {-2.0, 20.0}}});
    const GridSpec g = grid_60x45();
    ComputeOptions co;
    co.threads = 2;
    co.max_distance = reach;
    const NearestField field = compute(seeds, g, co);
    const PlanarSiteMetric metric(seeds, Vec2{g.xmin, g.ymax});
    const OwnerIndex index(metric);
    const BoundaryResult b = extract_boundaries(field, index);
    // The max-distance lines as region_edges reads them: on cell edges (rv/lines/regions.hpp).
    LimitOptions cell_level;
    cell_level.line_tolerance = 0.0;
    const LimitResult reach_lines =
        std::isfinite(reach) ? extract_limits(field, index, std::vector<double>{reach}, cell_level) : LimitResult{};
    LineRegions lr;
    const RegionEdges re = region_edges(b, index, g, reach, std::isfinite(reach) ? &reach_lines : nullptr);
    EXPECT_EQ(re.dangling_ends, 0);
    lr.edges = re.edges;
    lr.grid = g;
    lr.owner_of = [&](Vec2 p) { return owner_at(index, p, reach); };
    lr.area = [](std::span<const Vec2> ring) { return ring_area(ring, MetricSpec{}, nullptr, 1.0); };
    lr.area_units = "m^2";
    // The faces handed to the check: every owned centre clear of their edges in its owner's.
    const Raster<int32_t> owners = owner_raster(seeds, field, 2);
    CellOwners cells(g);
    for (int64_t r = 0; r < g.height; ++r)
      cells.add_row(r, std::span<const int32_t>(owners.row(r), static_cast<size_t>(g.width)));
    int64_t faces_seen = 0;
    lr.verify = [&](std::span<const OwnedFace> faces) {
      faces_seen = static_cast<int64_t>(faces.size());
      const RegionCellCheck c = check_regions_against_cells(faces, cells, 1e-3);
      EXPECT_EQ(c.misplaced, 0);
      EXPECT_EQ(c.checked + c.near_edges,
                std::count_if(owners.cells().begin(), owners.cells().end(), [](int32_t v) { return v != 0; }));
    };
    const std::string p = path("line_regions_" + std::to_string(trial) + ".gpkg");
    const RegionStats st = write_line_regions(p, lr, seeds, seeds.polygons(), {});
    EXPECT_EQ(st.owners, seeds.owner_count());
    EXPECT_GE(faces_seen, st.polygons);

    Opened in(p);
    ASSERT_NE(in.ds, nullptr);
    OGRLayer* l = in.ds->GetLayerByName("regions");
    ASSERT_NE(l, nullptr);
    std::vector<std::pair<int32_t, std::unique_ptr<OGRGeometry>>> regions;
    double total = 0.0;
    l->ResetReading();
    for (OGRFeature* f; (f = l->GetNextFeature()) != nullptr; OGRFeature::DestroyFeature(f)) {
      const double area = f->GetFieldAsDouble("area");
      EXPECT_NEAR(area, f->GetGeometryRef()->toMultiPolygon()->get_Area(), 1e-9 * area);
      EXPECT_NEAR(f->GetFieldAsDouble("land_area") + f->GetFieldAsDouble("sea_area"), area, 1e-9 * area);
      EXPECT_EQ(std::string(f->GetFieldAsString("area_units")), "m^2");
      if (f->GetFieldAsInteger("owner") == 2) {
        EXPECT_NEAR(f->GetFieldAsDouble("land_area"), 4.5 * 4.0, 1e-9);  // the island within the grid
      } else {
        EXPECT_EQ(f->GetFieldAsDouble("land_area"), 0.0);
      }
      total += area;
      regions.emplace_back(f->GetFieldAsInteger("owner"), std::unique_ptr<OGRGeometry>(f->StealGeometry()));
    }
    if (std::isfinite(reach)) {
      // The owned area: about one cell per owned cell (the regions end between cells).
      const auto owned = static_cast<double>(
          std::count_if(owners.cells().begin(), owners.cells().end(), [](int32_t v) { return v != 0; }));
      EXPECT_LT(total, 60.0 * 45.0);
      EXPECT_NEAR(total, owned, 0.05 * owned);
    } else {
      EXPECT_NEAR(total, 60.0 * 45.0, 1e-9 * total);
    }
    // Every cell centre in exactly one region, its owner's; beyond the max distance in none.
    // (GEOS's prepared geometries: the same predicate, each region converted and indexed once
    // rather than once per centre.)
    ASSERT_TRUE(OGRHasPreparedGeometrySupport());
    std::vector<OGRPreparedGeometryUniquePtr> prepared;
    for (const auto& region : regions)
      prepared.emplace_back(OGRCreatePreparedGeometry(OGRGeometry::ToHandle(region.second.get())));
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        OGRPoint centre(g.centre_x(c), g.centre_y(r));
        int holders = 0;
        for (size_t k = 0; k < regions.size(); ++k)
          if (OGRPreparedGeometryContains(prepared[k].get(), OGRGeometry::ToHandle(&centre))) {
            ++holders;
            EXPECT_EQ(regions[k].first, owners.at(c, r)) << c << ", " << r;
          }
        // A centre exactly at the max distance (a tie: its crossing is the centre itself) lies on
        // its region's edge, in none.
        const bool at_reach = std::abs(index.nearest(Vec2{centre.getX(), centre.getY()}).distance - reach) <= 1e-9;
        if (holders == 0 && at_reach) continue;
        ASSERT_EQ(holders, owners.at(c, r) == 0 ? 0 : 1) << c << ", " << r;
      }
    // The outlines are the lines themselves, no staircase: every vertex is a vertex of the lines
    // (or a grid corner), or, where GEOS nodes two lines that cross (a boundary line through a
    // max-distance chord, short of a tripoint just beyond it), a point on both.
    std::set<std::pair<double, double>> line_vertices;
    for (const auto& e : lr.edges)
      for (const Vec2& v : e) line_vertices.insert({v.x, v.y});
    auto on_lines = [&](double x, double y) {
      // (The grid's outline is one of the lines noded.)
      int on = std::abs(x) <= 1e-9 || std::abs(x - 60.0) <= 1e-9 || std::abs(y) <= 1e-9 || std::abs(y - 45.0) <= 1e-9;
      for (const auto& e : lr.edges)
        for (size_t i = 0; i + 1 < e.size(); ++i) {
          const Vec2 a = e[i], b = e[i + 1];
          const double dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
          const double t = len2 > 0.0 ? std::clamp(((x - a.x) * dx + (y - a.y) * dy) / len2, 0.0, 1.0) : 0.0;
          if (std::hypot(a.x + t * dx - x, a.y + t * dy - y) <= 1e-9) {
            ++on;
            break;
          }
        }
      return on >= 2;
    };
    for (const auto& [owner, geom] : regions)
      for (const OGRPolygon* poly : *geom->toMultiPolygon())
        for (const OGRLinearRing* ring : *poly)
          for (const OGRPoint& v : *ring) {
            const bool corner = (v.getX() == 0.0 || v.getX() == 60.0) && (v.getY() == 0.0 || v.getY() == 45.0);
            ASSERT_TRUE(corner || line_vertices.count({v.getX(), v.getY()}) == 1 ||
                        (std::isfinite(reach) && on_lines(v.getX(), v.getY())))
                << "owner " << owner << ": " << v.getX() << ", " << v.getY();
          }
    // The land and sea layers of the GeoPackage: the island alone is land.
    OGRLayer* land = in.ds->GetLayerByName("regions_land");
    OGRLayer* sea = in.ds->GetLayerByName("regions_sea");
    ASSERT_TRUE(land && sea);
    EXPECT_EQ(land->GetFeatureCount(), 1);
    EXPECT_EQ(sea->GetFeatureCount(), seeds.owner_count());
  }
}

// A boundary line lost merges two owners' faces: the faces the regions are about to write put
// one owner's cells in the other's region, the check finds them, and what it throws leaves no
// file behind.
TEST_F(VectorWriter, LineRegionsWithALineLostAreFoundByTheirCellsAndNotWritten) {
  SeedSet seeds;
  for (const auto& [owner, p] : std::vector<std::pair<std::string, Vec2>>{
           {"A", {12.3, 30.1}}, {"B", {47.9, 28.7}}, {"C", {30.2, 8.4}}, {"A", {9.1, 10.2}}})
    seeds.add_point(seeds.add_feature(seeds.owner_code(owner)), p);
  const GridSpec g = grid_60x45();
  ComputeOptions co;
  co.threads = 2;
  const NearestField field = compute(seeds, g, co);
  const PlanarSiteMetric metric(seeds, Vec2{g.xmin, g.ymax});
  const OwnerIndex index(metric);
  const BoundaryResult b = extract_boundaries(field, index);
  const RegionEdges re = region_edges(b, index, g);
  ASSERT_EQ(re.dangling_ends, 0);
  const Raster<int32_t> owners = owner_raster(seeds, field, 2);
  CellOwners cells(g);
  for (int64_t r = 0; r < g.height; ++r)
    cells.add_row(r, std::span<const int32_t>(owners.row(r), static_cast<size_t>(g.width)));
  LineRegions lr;
  lr.grid = g;
  lr.owner_of = [&](Vec2 p) { return owner_at(index, p); };
  lr.area = [](std::span<const Vec2> ring) { return ring_area(ring, MetricSpec{}, nullptr, 1.0); };
  lr.area_units = "m^2";
  RegionCellCheck found;
  lr.verify = [&](std::span<const OwnedFace> faces) {
    found = check_regions_against_cells(faces, cells, 1e-3);
    if (found.misplaced > 0) throw Error(ErrorKind::internal, "regions: cells in another owner's region");
  };
  // Whole, the regions pass.
  lr.edges = re.edges;
  const std::string whole = path("regions_whole.gpkg");
  EXPECT_NO_THROW(write_line_regions(whole, lr, seeds, seeds.polygons(), {}));
  EXPECT_EQ(found.misplaced, 0);
  EXPECT_GT(found.checked, 2000);
  EXPECT_TRUE(fs::exists(whole));
  // Each line lost in turn: its two owners' faces merge into one.
  ASSERT_GE(re.edges.size(), 3u);
  for (size_t lost = 0; lost < re.edges.size(); ++lost) {
    SCOPED_TRACE("line " + std::to_string(lost) + " lost");
    lr.edges = re.edges;
    lr.edges.erase(lr.edges.begin() + static_cast<std::ptrdiff_t>(lost));
    const std::string broken = path("regions_broken_" + std::to_string(lost) + ".gpkg");
    EXPECT_THROW(write_line_regions(broken, lr, seeds, seeds.polygons(), {}), Error);
    EXPECT_GT(found.misplaced, 0);
    ASSERT_FALSE(found.first.empty());
    const RegionCellCheck::Misplaced& m = found.first.front();
    EXPECT_EQ(owners.at(m.col, m.row), m.owner);
    EXPECT_NE(m.region, m.owner);
    EXPECT_FALSE(fs::exists(broken));
  }
}

}  // namespace
}  // namespace rv
