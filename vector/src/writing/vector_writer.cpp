#include "rv/gdal/vector_writer.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <map>
#include <sstream>

#include <ogr_api.h>
#include <ogrsf_frmts.h>

#include "common/gdal_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "writing/geojson_text.hpp"

namespace rv {
namespace {

std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

const char* driver_for(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == "geojson" || ext == "json") return "GeoJSON";
  if (ext == "gpkg") return "GPKG";
  throw Error(ErrorKind::invalid_argument,
              "cannot tell the vector format of '" + path + "': use .geojson, .json or .gpkg");
}

// The file is built under a hidden temporary name in the same directory (keeping the
// extension, which GeoPackage checks) and renamed into place only once GDAL closed it, so a
// reader never sees a half-written file and a failure leaves nothing behind.
class VectorFile {
 public:
  explicit VectorFile(const std::string& path) : target_(path) {
    temp_ = writing::hidden_temporary(path, lower_extension(path));
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName(driver_for(path));
    if (driver == nullptr)
      throw Error(ErrorKind::unsupported, std::string("GDAL has no ") + driver_for(path) + " driver");
    ds_.reset(driver->Create(temp_.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
    if (!ds_) throw Error(ErrorKind::io, "cannot create " + path + capture_.suffix());
  }
  ~VectorFile() {
    ds_.reset();
    if (!committed_) VSIUnlink(temp_.c_str());
  }
  VectorFile(const VectorFile&) = delete;
  VectorFile& operator=(const VectorFile&) = delete;

  OGRLayer* layer(const char* name, OGRwkbGeometryType type, const std::string& crs) {
    gdal::SrsPtr srs;
    if (!crs.empty()) {
      srs = gdal::parse_srs(crs);
      if (!srs) throw Error(ErrorKind::invalid_argument, "cannot parse the output CRS");
    }
    OGRLayer* l = ds_->CreateLayer(name, srs.get(), type, nullptr);
    if (l == nullptr) fail("cannot create layer " + std::string(name));
    return l;
  }
  void field(OGRLayer* l, const char* name, OGRFieldType type) {
    OGRFieldDefn def(name, type);
    if (l->CreateField(&def) != OGRERR_NONE) fail(std::string("cannot create field ") + name);
  }
  void add(OGRLayer* l, OGRFeature* f) {
    if (l->CreateFeature(f) != OGRERR_NONE) fail("cannot write a feature");
  }
  void begin() { ds_->StartTransaction(); }
  void end() {
    if (ds_->CommitTransaction() != OGRERR_NONE && ds_->TestCapability(ODsCTransactions)) fail("cannot commit");
  }

  void commit() {
    // Closing flushes; a failure there (disk full) must not be renamed into place.
    GDALDataset* raw = ds_.release();
    CPLErrorReset();
    const std::string before = capture_.last_error();
    GDALClose(GDALDataset::ToHandle(raw));
    if (capture_.last_error() != before || CPLGetLastErrorType() >= CE_Failure) fail("cannot finish the file");
    if (VSIRename(temp_.c_str(), target_.c_str()) != 0)
      throw Error(ErrorKind::io, "cannot rename " + temp_ + " to " + target_ + ": " + std::strerror(errno));
    committed_ = true;
  }

 private:
  [[noreturn]] void fail(const std::string& what) {
    throw Error(ErrorKind::io, "writing " + target_ + ": " + what + capture_.suffix());
  }
  gdal::ErrorCapture capture_;
  std::string target_, temp_;
  gdal::DatasetPtr ds_;
  bool committed_ = false;
};

struct FeatureDeleter {
  void operator()(OGRFeature* f) const { OGRFeature::DestroyFeature(f); }
};
using FeaturePtr = std::unique_ptr<OGRFeature, FeatureDeleter>;

std::string label_of(const SeedSet& s, int32_t owner) {
  return owner >= 1 && owner <= s.owner_count() ? s.owner_labels()[static_cast<size_t>(owner - 1)] : std::string();
}

int feature_of(const SeedSet& s, int32_t site) { return site == kNoSite ? 0 : s.site_feature(site) + 1; }

}  // namespace

namespace {

bool geojson(const std::string& path) { return std::string(driver_for(path)) == "GeoJSON"; }

// A line's vertices on the edge of a tie region by sea (BoundaryVertex::tie); and whether any
// line has one (the field `tie_vertices` is written only then).
int64_t tie_vertices(const BoundaryLine& line) {
  int64_t n = 0;
  for (const BoundaryVertex& v : line.vertices) n += v.tie ? 1 : 0;
  return n;
}
bool any_tie(const BoundaryResult& b) {
  for (const BoundaryLine& line : b.lines)
    if (tie_vertices(line) > 0) return true;
  return false;
}

// The GeoJSON files, written as GDAL writes them (writing/geojson_text.hpp), fields in the order
// of the GeoPackage layers' below.
void geojson_boundaries(const std::string& path, const BoundaryResult& b, const SeedSet& s,
                        const VectorOutputOptions& o) {
  writing::GeoJsonText text("boundaries", o.crs, resolve_threads(o.threads));
  const bool ties = any_tie(b);
  std::vector<Vec2> pts;
  std::vector<int> fa, fb;
  for (const BoundaryLine& line : b.lines) {
    pts.clear();
    fa.clear();
    fb.clear();
    double worst = 0.0;
    for (const BoundaryVertex& v : line.vertices) {
      pts.push_back(v.p);
      fa.push_back(feature_of(s, v.site_a));
      fb.push_back(feature_of(s, v.site_b));
      worst = std::max(worst, v.residual);
    }
    text.begin_feature();
    text.property("owner_a", int64_t{line.owner_a});
    text.property("owner_b", int64_t{line.owner_b});
    text.property("label_a", label_of(s, line.owner_a));
    text.property("label_b", label_of(s, line.owner_b));
    text.property("closed", int64_t{line.closed ? 1 : 0});
    text.property("vertex_count", static_cast<int64_t>(line.vertices.size()));
    text.property("max_residual", worst * o.distance_factor);
    text.property("units", o.distance_units);
    text.property("features_a", std::span<const int>(fa));
    text.property("features_b", std::span<const int>(fb));
    if (ties) text.property("tie_vertices", tie_vertices(line));
    text.line(pts);
    text.end_feature();
  }
  writing::write_text_file(path, text.finish());
}

}  // namespace

void write_boundaries(const std::string& path, const BoundaryResult& b, const SiteMetric& metric,
                      const VectorOutputOptions& o) {
  const SeedSet& s = metric.seeds();
  if (geojson(path)) {
    geojson_boundaries(path, b, s, o);
    return;
  }
  VectorFile file(path);
  const bool gpkg = std::string(driver_for(path)) == "GPKG";
  bool weighted = false;
  for (const Feature& f : s.features()) weighted = weighted || f.weight != 1.0;
  OGRLayer* lines = file.layer("boundaries", wkbLineString, o.crs);
  file.field(lines, "owner_a", OFTInteger);
  file.field(lines, "owner_b", OFTInteger);
  file.field(lines, "label_a", OFTString);
  file.field(lines, "label_b", OFTString);
  file.field(lines, "closed", OFTInteger);
  file.field(lines, "vertex_count", OFTInteger);
  file.field(lines, "max_residual", OFTReal);
  file.field(lines, "units", OFTString);
  file.field(lines, "features_a", OFTIntegerList);
  file.field(lines, "features_b", OFTIntegerList);
  const bool ties = any_tie(b);
  if (ties) file.field(lines, "tie_vertices", OFTInteger);
  OGRLayer* verts = nullptr;
  if (gpkg) {
    verts = file.layer("boundary_vertices", wkbPoint, o.crs);
    for (const char* name : {"line", "owner_a", "owner_b", "feature_a", "feature_b"})
      file.field(verts, name, OFTInteger);
    for (const char* name :
         {"basepoint_a_x", "basepoint_a_y", "basepoint_b_x", "basepoint_b_y", "distance", "residual"})
      file.field(verts, name, OFTReal);
    // Weighted lines: the two true distances differ (d_a / w_a = d_b / w_b), each side's its own.
    if (weighted)
      for (const char* name : {"distance_a", "distance_b"}) file.field(verts, name, OFTReal);
    if (ties) file.field(verts, "tie", OFTInteger);
  }
  // The basepoints (each vertex's controlling positions): geodesic projections onto segments,
  // the dearest part of the file, measured on the threads before the serial writing.
  std::vector<std::array<Vec2, 2>> basepoints;
  if (verts) {
    std::vector<const BoundaryVertex*> all;
    for (const BoundaryLine& line : b.lines)
      for (const BoundaryVertex& v : line.vertices) all.push_back(&v);
    basepoints.resize(all.size());
    detail::parallel_for(resolve_threads(o.threads), static_cast<int64_t>(all.size()), [&](int64_t i, int) {
      const BoundaryVertex& v = *all[static_cast<size_t>(i)];
      auto& q = basepoints[static_cast<size_t>(i)];
      if (v.site_a != kNoSite) q[0] = metric.nearest_point(v.p, v.site_a);
      if (v.site_b != kNoSite) q[1] = metric.nearest_point(v.p, v.site_b);
    });
  }
  size_t vertex_id = 0;
  file.begin();
  int64_t line_id = 0;
  for (const BoundaryLine& line : b.lines) {
    ++line_id;
    FeaturePtr f(OGRFeature::CreateFeature(lines->GetLayerDefn()));
    OGRLineString ls;
    std::vector<int> fa, fb;
    double worst = 0.0;
    gdal::set_points(ls, line.vertices, [](const BoundaryVertex& v) { return v.p; });
    for (const BoundaryVertex& v : line.vertices) {
      fa.push_back(feature_of(s, v.site_a));
      fb.push_back(feature_of(s, v.site_b));
      worst = std::max(worst, v.residual);
    }
    f->SetGeometry(&ls);
    f->SetField("owner_a", line.owner_a);
    f->SetField("owner_b", line.owner_b);
    f->SetField("label_a", label_of(s, line.owner_a).c_str());
    f->SetField("label_b", label_of(s, line.owner_b).c_str());
    f->SetField("closed", line.closed ? 1 : 0);
    f->SetField("vertex_count", static_cast<int>(line.vertices.size()));
    f->SetField("max_residual", worst * o.distance_factor);
    f->SetField("units", o.distance_units.c_str());
    f->SetField("features_a", static_cast<int>(fa.size()), fa.data());
    f->SetField("features_b", static_cast<int>(fb.size()), fb.data());
    if (ties) f->SetField("tie_vertices", static_cast<int>(tie_vertices(line)));
    file.add(lines, f.get());
    if (!verts) continue;
    for (const BoundaryVertex& v : line.vertices) {
      FeaturePtr pf(OGRFeature::CreateFeature(verts->GetLayerDefn()));
      OGRPoint pt(v.p.x, v.p.y);
      pf->SetGeometry(&pt);
      pf->SetField("line", static_cast<int>(line_id));
      pf->SetField("owner_a", line.owner_a);
      pf->SetField("owner_b", line.owner_b);
      pf->SetField("feature_a", feature_of(s, v.site_a));
      pf->SetField("feature_b", feature_of(s, v.site_b));
      const auto& q = basepoints[vertex_id++];
      if (v.site_a != kNoSite) {
        pf->SetField("basepoint_a_x", q[0].x);
        pf->SetField("basepoint_a_y", q[0].y);
      }
      if (v.site_b != kNoSite) {
        pf->SetField("basepoint_b_x", q[1].x);
        pf->SetField("basepoint_b_y", q[1].y);
      }
      pf->SetField("distance", v.distance * o.distance_factor);
      pf->SetField("residual", v.residual * o.distance_factor);
      if (weighted) {
        pf->SetField("distance_a", v.distance_a * o.distance_factor);
        pf->SetField("distance_b", v.distance_b * o.distance_factor);
      }
      if (ties) pf->SetField("tie", v.tie ? 1 : 0);
      file.add(verts, pf.get());
    }
  }
  file.end();
  file.commit();
}

void write_tripoints(const std::string& path, const BoundaryResult& b, const SiteMetric& metric,
                     const VectorOutputOptions& o) {
  const SeedSet& s = metric.seeds();
  if (geojson(path)) {
    writing::GeoJsonText text("tripoints", o.crs);
    for (const Tripoint& t : b.tripoints) {
      text.begin_feature();
      for (int i = 0; i < 3; ++i) text.property(("owner_" + std::to_string(i + 1)).c_str(), int64_t{t.owners[i]});
      for (int i = 0; i < 3; ++i) text.property(("label_" + std::to_string(i + 1)).c_str(), label_of(s, t.owners[i]));
      for (int i = 0; i < 3; ++i)
        text.property(("feature_" + std::to_string(i + 1)).c_str(), int64_t{feature_of(s, t.sites[i])});
      text.property("distance", t.distance * o.distance_factor);
      text.property("residual", t.residual * o.distance_factor);
      text.property("units", o.distance_units);
      text.point(t.p);
      text.end_feature();
    }
    writing::write_text_file(path, text.finish());
    return;
  }
  VectorFile file(path);
  OGRLayer* l = file.layer("tripoints", wkbPoint, o.crs);
  for (const char* name : {"owner_1", "owner_2", "owner_3"}) file.field(l, name, OFTInteger);
  for (const char* name : {"label_1", "label_2", "label_3"}) file.field(l, name, OFTString);
  for (const char* name : {"feature_1", "feature_2", "feature_3"}) file.field(l, name, OFTInteger);
  file.field(l, "distance", OFTReal);
  file.field(l, "residual", OFTReal);
  file.field(l, "units", OFTString);
  file.begin();
  for (const Tripoint& t : b.tripoints) {
    FeaturePtr f(OGRFeature::CreateFeature(l->GetLayerDefn()));
    OGRPoint pt(t.p.x, t.p.y);
    f->SetGeometry(&pt);
    for (int i = 0; i < 3; ++i) {
      const std::string k = std::to_string(i + 1);
      f->SetField(("owner_" + k).c_str(), t.owners[i]);
      f->SetField(("label_" + k).c_str(), label_of(s, t.owners[i]).c_str());
      f->SetField(("feature_" + k).c_str(), feature_of(s, t.sites[i]));
    }
    f->SetField("distance", t.distance * o.distance_factor);
    f->SetField("residual", t.residual * o.distance_factor);
    f->SetField("units", o.distance_units.c_str());
    file.add(l, f.get());
  }
  file.end();
  file.commit();
}

void write_limits(const std::string& path, const LimitResult& limits, const SeedSet& s, const VectorOutputOptions& o) {
  if (geojson(path)) {
    writing::GeoJsonText text("limits", o.crs, resolve_threads(o.threads));
    std::vector<Vec2> pts;
    for (const LimitLine& line : limits.lines) {
      pts.clear();
      double worst = 0.0;
      for (const LimitVertex& v : line.vertices) {
        pts.push_back(v.p);
        worst = std::max(worst, v.residual);
      }
      text.begin_feature();
      text.property("distance", line.distance * o.distance_factor);
      text.property("units", o.distance_units);
      text.property("owner", int64_t{line.owner});
      text.property("label", line.owner == 0 ? std::string("all") : label_of(s, line.owner));
      text.property("closed", int64_t{line.closed ? 1 : 0});
      text.property("max_residual", worst * o.distance_factor);
      text.line(pts);
      text.end_feature();
    }
    writing::write_text_file(path, text.finish());
    return;
  }
  VectorFile file(path);
  OGRLayer* l = file.layer("limits", wkbLineString, o.crs);
  file.field(l, "distance", OFTReal);
  file.field(l, "units", OFTString);
  file.field(l, "owner", OFTInteger);
  file.field(l, "label", OFTString);
  file.field(l, "closed", OFTInteger);
  file.field(l, "max_residual", OFTReal);
  file.begin();
  for (const LimitLine& line : limits.lines) {
    FeaturePtr f(OGRFeature::CreateFeature(l->GetLayerDefn()));
    OGRLineString ls;
    double worst = 0.0;
    gdal::set_points(ls, line.vertices, [](const LimitVertex& v) { return v.p; });
    for (const LimitVertex& v : line.vertices) worst = std::max(worst, v.residual);
    f->SetGeometry(&ls);
    f->SetField("distance", line.distance * o.distance_factor);
    f->SetField("units", o.distance_units.c_str());
    f->SetField("owner", line.owner);
    f->SetField("label", line.owner == 0 ? "all" : label_of(s, line.owner).c_str());
    f->SetField("closed", line.closed ? 1 : 0);
    f->SetField("max_residual", worst * o.distance_factor);
    file.add(l, f.get());
  }
  file.end();
  file.commit();
}

namespace {

using GeometryPtr = std::unique_ptr<OGRGeometry>;

std::vector<Vec2> ring_points(const OGRLinearRing& ring) {
  std::vector<Vec2> pts(static_cast<size_t>(ring.getNumPoints()));
  for (int i = 0; i < ring.getNumPoints(); ++i) pts[static_cast<size_t>(i)] = Vec2{ring.getX(i), ring.getY(i)};
  return pts;
}

// The area of a polygonal geometry: its outer rings' less its holes'.
double area_of(const OGRGeometry* g, const LineRegions& r) {
  if (g == nullptr || g->IsEmpty()) return 0.0;
  double total = 0.0;
  auto polygon = [&](const OGRPolygon& p) {
    if (p.IsEmpty()) return;
    total += r.area(ring_points(*p.getExteriorRing()));
    for (int k = 0; k < p.getNumInteriorRings(); ++k) total -= r.area(ring_points(*p.getInteriorRing(k)));
  };
  const OGRwkbGeometryType t = wkbFlatten(g->getGeometryType());
  if (t == wkbPolygon) {
    polygon(*g->toPolygon());
  } else if (t == wkbMultiPolygon || t == wkbGeometryCollection) {
    for (const OGRGeometry* part : *g->toGeometryCollection()) total += area_of(part, r);
  }
  return total;
}

// The parts of type `single` of a geometry, gathered into `out` (an overlay may return a
// collection mixing polygons, lines and points where shapes only touch; Polygonize takes lines
// alone).
template <class Multi>
void gather(const OGRGeometry* g, OGRwkbGeometryType single, OGRwkbGeometryType multi, Multi& out) {
  if (g == nullptr) return;
  const OGRwkbGeometryType t = wkbFlatten(g->getGeometryType());
  if (t == single) {
    out.addGeometry(g);
  } else if (t == multi || t == wkbGeometryCollection) {
    for (const OGRGeometry* part : *g->toGeometryCollection()) gather(part, single, multi, out);
  }
}

std::unique_ptr<OGRMultiPolygon> polygons_of(const OGRGeometry* g) {
  auto out = std::make_unique<OGRMultiPolygon>();
  gather(g, wkbPolygon, wkbMultiPolygon, *out);
  return out;
}

std::unique_ptr<OGRMultiLineString> lines_of(const OGRGeometry* g) {
  auto out = std::make_unique<OGRMultiLineString>();
  gather(g, wkbLineString, wkbMultiLineString, *out);
  return out;
}

GeometryPtr checked(OGRGeometry* g, const char* what, const gdal::ErrorCapture& capture) {
  if (g == nullptr) throw Error(ErrorKind::io, std::string("regions: ") + what + " failed" + capture.suffix());
  return GeometryPtr(g);
}

// Whether p lies inside the polygon (even-odd over all its rings; a point on an edge may go
// either way).
bool polygon_holds(const OGRPolygon& poly, Vec2 p) {
  bool in = false;
  for (const OGRLinearRing* ring : poly) {
    const int n = ring->getNumPoints();
    for (int i = 0, j = n - 1; i < n; j = i++) {
      const double xi = ring->getX(i), yi = ring->getY(i), xj = ring->getX(j), yj = ring->getY(j);
      if ((yi > p.y) != (yj > p.y) && p.x < xj + (p.y - yj) * (xi - xj) / (yi - yj)) in = !in;
    }
  }
  return in;
}

// The owner of a face: of the cell centres inside it near `inside` (a point inside it), by
// majority; of `inside` itself when the face holds none of them. The lines are chords between
// exact points, so the face's edges depart from the exact loci by a fraction of a cell where
// they bend (across a notch where two owners' discs meet, the max-distance line does not show a
// wedge of unowned sea thinner than a cell); an interior point may fall in such a sliver, but the
// lines part every dual square's corners as the raster does, so the centres inside the face all
// carry its owner.
int32_t face_owner(const OGRPolygon& face, Vec2 inside, const LineRegions& r) {
  const GridSpec& g = r.grid;
  const auto c0 = static_cast<int64_t>(std::floor((inside.x - g.xmin) / g.res));
  const auto r0 = static_cast<int64_t>(std::floor((g.ymax - inside.y) / g.res));
  std::map<int32_t, int> votes;
  for (int64_t row = std::max<int64_t>(r0 - 2, 0); row <= std::min(r0 + 2, g.height - 1); ++row)
    for (int64_t col = std::max<int64_t>(c0 - 2, 0); col <= std::min(c0 + 2, g.width - 1); ++col) {
      const Vec2 centre{g.centre_x(col), g.centre_y(row)};
      if (polygon_holds(face, centre)) ++votes[r.owner_of(centre)];
    }
  if (votes.empty()) return r.owner_of(inside);
  return std::max_element(votes.begin(), votes.end(), [](const auto& a, const auto& b) { return a.second < b.second; })
      ->first;
}

// One owner's region split into its land (the interiors of its seed polygons within it) and its
// sea, with their areas.
struct OwnerParts {
  int32_t owner = 0;
  const OGRMultiPolygon* region = nullptr;
  std::unique_ptr<OGRMultiPolygon> land, sea;
  double land_area = 0.0, sea_area = 0.0;
  double relevant_land = 0.0, relevant_sea = 0.0;  // within the relevant area
};

void geojson_regions(const std::string& path, const std::vector<OwnerParts>& parts, const SeedSet& s,
                     const std::string& area_units, const VectorOutputOptions& o) {
  writing::GeoJsonText text("regions", o.crs, resolve_threads(o.threads));
  for (const OwnerParts& part : parts) {
    text.begin_feature();
    text.property("owner", int64_t{part.owner});
    text.property("label", label_of(s, part.owner));
    text.property("area", part.land_area + part.sea_area);
    text.property("land_area", part.land_area);
    text.property("sea_area", part.sea_area);
    text.property("area_units", area_units);
    text.polygons(*part.region);
    text.end_feature();
  }
  writing::write_text_file(path, text.finish());
}

// The grid's outline, closed, as the vertices of a line or ring (replacing any it had).
void add_outline(OGRLineString& line, const GridSpec& g) {
  gdal::set_points(line, std::array<Vec2, 5>{Vec2{g.xmin, g.ymax}, Vec2{g.xmax(), g.ymax}, Vec2{g.xmax(), g.ymin()},
                                             Vec2{g.xmin, g.ymin()}, Vec2{g.xmin, g.ymax}});
}

// A polygon of the core as OGR's.
OGRPolygon ogr_polygon(const Polygon& poly) {
  OGRPolygon p;
  for (const Ring& ring : poly.rings) {
    OGRLinearRing lr;
    gdal::set_points(lr, ring);
    lr.closeRings();
    p.addRing(&lr);
  }
  return p;
}

// Polygons as one valid, merged multipolygon.
GeometryPtr merged_polygons(const std::vector<Polygon>& polygons, const char* what, const gdal::ErrorCapture& capture) {
  OGRMultiPolygon all;
  for (const Polygon& poly : polygons) {
    const OGRPolygon p = ogr_polygon(poly);
    all.addGeometry(&p);
  }
  const GeometryPtr valid = checked(all.MakeValid(), what, capture);
  return checked(polygons_of(valid.get())->UnionCascaded(), what, capture);
}

// The owners' parts, the overlays of the owners side by side on `threads` threads (GEOS works in
// a context per call; each task captures its own GDAL errors).
std::vector<OwnerParts> land_and_sea(const std::map<int32_t, std::unique_ptr<OGRMultiPolygon>>& by_owner,
                                     const std::map<int32_t, OGRMultiPolygon>& land_of, const LineRegions& r,
                                     const OGRGeometry* relevant, int threads) {
  std::vector<OwnerParts> parts;
  for (const auto& [owner, region] : by_owner) parts.push_back(OwnerParts{owner, region.get(), nullptr, nullptr});
  detail::parallel_for(resolve_threads(threads), static_cast<int64_t>(parts.size()), [&](int64_t k, int) {
    OwnerParts& part = parts[static_cast<size_t>(k)];
    const gdal::ErrorCapture capture;
    const OGRMultiPolygon* region = part.region;
    part.land = std::make_unique<OGRMultiPolygon>();
    const auto own_land = land_of.find(part.owner);
    if (own_land != land_of.end()) {
      const GeometryPtr valid = checked(own_land->second.MakeValid(), "making the seed polygons valid", capture);
      const GeometryPtr merged =
          checked(polygons_of(valid.get())->UnionCascaded(), "merging the seed polygons", capture);
      part.land = polygons_of(checked(region->Intersection(merged.get()), "land within the region", capture).get());
      part.sea = polygons_of(checked(region->Difference(merged.get()), "sea of the region", capture).get());
    } else {
      part.sea = std::make_unique<OGRMultiPolygon>(*region);
    }
    part.land_area = area_of(part.land.get(), r);
    part.sea_area = area_of(part.sea.get(), r);
    if (relevant != nullptr) {
      const GeometryPtr land_in = checked(part.land->Intersection(relevant), "land within the relevant area", capture);
      const GeometryPtr sea_in = checked(part.sea->Intersection(relevant), "sea within the relevant area", capture);
      part.relevant_land = area_of(polygons_of(land_in.get()).get(), r);
      part.relevant_sea = area_of(polygons_of(sea_in.get()).get(), r);
    }
  });
  return parts;
}

// The regions' linework before noding: the grid's outline, every edge, and the outline's lines
// clipped to the grid.
OGRMultiLineString region_linework(const LineRegions& r, const gdal::ErrorCapture& capture) {
  const GridSpec& g = r.grid;
  OGRMultiLineString lines;
  {
    OGRLineString frame;
    add_outline(frame, g);
    lines.addGeometry(&frame);
  }
  for (const std::vector<Vec2>& edge : r.edges) {
    if (edge.size() < 2) continue;
    OGRLineString ls;
    gdal::set_points(ls, edge);
    lines.addGeometry(&ls);
  }
  if (!r.outline.empty()) {
    OGRMultiLineString outline;
    for (const std::vector<Vec2>& edge : r.outline) {
      if (edge.size() < 2) continue;
      OGRLineString ls;
      gdal::set_points(ls, edge);
      outline.addGeometry(&ls);
    }
    OGRPolygon frame;
    OGRLinearRing ring;
    add_outline(ring, g);
    frame.addRing(&ring);
    const GeometryPtr inside = checked(outline.Intersection(&frame), "clipping the barriers to the grid", capture);
    const std::unique_ptr<OGRMultiLineString> clipped = lines_of(inside.get());
    for (const OGRLineString* ls : *clipped) lines.addGeometry(ls);
  }
  return lines;
}

}  // namespace

RegionStats write_line_regions(const std::string& path, const LineRegions& r, const SeedSet& s,
                               const std::vector<Polygon>& polygons, const VectorOutputOptions& o) {
  gdal::ErrorCapture capture;
  if (!OGRGeometryFactory::haveGEOS())
    throw Error(ErrorKind::unsupported, "regions along the boundary lines need GDAL built with GEOS");
  const GridSpec& g = r.grid;
  // The linework: the grid's outline, every edge and the outline's; noded by a union, then
  // polygonized.
  const OGRMultiLineString lines = region_linework(r, capture);
  // A union with a point on the lines nodes every edge of both (GDAL 3.6 has no unary union).
  const OGRPoint corner(g.xmin, g.ymax);
  const GeometryPtr noded = checked(lines.Union(&corner), "noding the lines", capture);
  const GeometryPtr faces = checked(lines_of(noded.get())->Polygonize(), "polygonizing the lines", capture);
  std::map<int32_t, std::unique_ptr<OGRMultiPolygon>> by_owner;
  RegionStats stats;
  const std::unique_ptr<OGRMultiPolygon> face_list = polygons_of(faces.get());
  std::vector<OwnedFace> owned;
  for (const OGRPolygon* face : *face_list) {
    // A point strictly inside the face (GEOS); OGRSurface::PointOnSurface fails on GDAL 3.6.
    const GeometryPtr inside(
        OGRGeometry::FromHandle(OGR_G_PointOnSurface(OGRGeometry::ToHandle(const_cast<OGRPolygon*>(face)))));
    const bool has_inside = inside && wkbFlatten(inside->getGeometryType()) == wkbPoint && !inside->IsEmpty();
    const int32_t owner =
        has_inside ? face_owner(*face, Vec2{inside->toPoint()->getX(), inside->toPoint()->getY()}, r) : 0;
    if (r.verify) {
      OwnedFace f{owner, {ring_points(*face->getExteriorRing())}};
      for (int k = 0; k < face->getNumInteriorRings(); ++k) f.rings.push_back(ring_points(*face->getInteriorRing(k)));
      owned.push_back(std::move(f));
    }
    if (owner == 0) continue;
    auto& mp = by_owner[owner];
    if (!mp) mp = std::make_unique<OGRMultiPolygon>();
    mp->addGeometry(face);
    ++stats.polygons;
  }
  if (r.verify) r.verify(owned);
  // Each owner's land: its seed polygons, made valid and merged.
  std::map<int32_t, OGRMultiPolygon> land_of;
  for (const Polygon& poly : polygons) {
    const OGRPolygon p = ogr_polygon(poly);
    land_of[s.features()[static_cast<size_t>(poly.feature)].owner].addGeometry(&p);
  }
  // The relevant area within the grid, and each owner's parts within it.
  GeometryPtr relevant;
  if (r.relevant != nullptr) {
    OGRPolygon frame;
    OGRLinearRing ring;
    add_outline(ring, g);
    frame.addRing(&ring);
    const GeometryPtr merged = merged_polygons(*r.relevant, "merging the relevant area", capture);
    relevant = checked(merged->Intersection(&frame), "the relevant area within the grid", capture);
    stats.relevant_total = area_of(polygons_of(relevant.get()).get(), r);
  }
  const std::vector<OwnerParts> parts = land_and_sea(by_owner, land_of, r, relevant.get(), o.threads);
  for (const OwnerParts& part : parts)
    stats.areas.push_back({part.owner, part.land_area + part.sea_area, part.land_area, part.sea_area,
                           part.relevant_land + part.relevant_sea, part.relevant_land, part.relevant_sea});
  stats.owners = static_cast<int64_t>(parts.size());
  if (path.empty()) return stats;
  if (geojson(path)) {
    geojson_regions(path, parts, s, r.area_units, o);
    return stats;
  }
  VectorFile file(path);
  const bool gpkg = std::string(driver_for(path)) == "GPKG";
  OGRLayer* l = file.layer("regions", wkbMultiPolygon, o.crs);
  for (const char* name : {"owner", "label", "area", "land_area", "sea_area", "area_units"})
    file.field(l, name,
               std::string(name) == "owner"                                          ? OFTInteger
               : (std::string(name) == "label" || std::string(name) == "area_units") ? OFTString
                                                                                     : OFTReal);
  OGRLayer* land_layer = nullptr;
  OGRLayer* sea_layer = nullptr;
  if (gpkg) {
    land_layer = file.layer("regions_land", wkbMultiPolygon, o.crs);
    sea_layer = file.layer("regions_sea", wkbMultiPolygon, o.crs);
    for (OGRLayer* x : {land_layer, sea_layer}) {
      file.field(x, "owner", OFTInteger);
      file.field(x, "label", OFTString);
      file.field(x, "area", OFTReal);
    }
  }
  file.begin();
  auto add = [&](OGRLayer* layer, int32_t owner, const OGRGeometry& geom, double area) {
    FeaturePtr f(OGRFeature::CreateFeature(layer->GetLayerDefn()));
    f->SetField("owner", owner);
    f->SetField("label", label_of(s, owner).c_str());
    f->SetField("area", area);
    f->SetGeometry(&geom);
    return f;
  };
  for (const OwnerParts& part : parts) {
    FeaturePtr f = add(l, part.owner, *part.region, part.land_area + part.sea_area);
    f->SetField("land_area", part.land_area);
    f->SetField("sea_area", part.sea_area);
    f->SetField("area_units", r.area_units.c_str());
    file.add(l, f.get());
    if (gpkg) {
      if (!part.land->IsEmpty()) file.add(land_layer, add(land_layer, part.owner, *part.land, part.land_area).get());
      file.add(sea_layer, add(sea_layer, part.owner, *part.sea, part.sea_area).get());
    }
  }
  file.end();
  file.commit();
  return stats;
}

}  // namespace rv
