// load_seeds(): GDAL/OGR datasets -> SeedSet. See rv/gdal/seed_reader.hpp for the contract.
//
// The pipeline per feature: owner label -> geometry linearised, 2D -> split into simple parts
// (points, line strings, polygons) -> coordinates checked in the source CRS (finite, latitude)
// -> reprojected -> checked again -> duplicates removed, polygons validated / repaired -> added
// to the SeedSet. Conflicts between owners are looked for once every feature is in
// (normalise.cpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <cpl_string.h>
#include <ogr_api.h>
#include <ogrsf_frmts.h>

#include "common/gdal_util.hpp"
#include "crs/crs_operation.hpp"
#include "reading/input_scan.hpp"
#include "reading/normalise.hpp"
#include "reading/seed_inventory.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace rv {
namespace {

using detail::SeedPart;

using detail::kArcStepDegrees;

using detail::truly_empty;
using gdal::CtPtr;

struct LayerRef {
  size_t file = 0;            // index into options.paths
  OGRLayer* layer = nullptr;  // owned by the dataset
  std::string name;
  gdal::SrsPtr srs;  // null: the layer has no CRS
};

std::string format_number(double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::string list_fields(OGRFeatureDefn* defn) {
  std::string out;
  for (int i = 0; i < defn->GetFieldCount(); ++i) {
    if (!out.empty()) out += ", ";
    out += escape_utf8(defn->GetFieldDefn(i)->GetNameRef());
  }
  return out.empty() ? "(none)" : out;
}

std::string list_layers(GDALDataset& ds) {
  std::string out;
  for (int i = 0; i < ds.GetLayerCount(); ++i) {
    if (!out.empty()) out += ", ";
    out += escape_utf8(ds.GetLayer(i)->GetName());
  }
  return out.empty() ? "(none)" : out;
}

// Splits a (linear, 2D) geometry into owned clones of its simple parts: points, line strings
// and polygons, in the order they appear.
void split_parts(const OGRGeometry& g, const std::string& source, std::vector<std::unique_ptr<OGRGeometry>>& out) {
  if (truly_empty(g)) return;
  const OGRwkbGeometryType type = wkbFlatten(g.getGeometryType());
  switch (type) {
    case wkbPoint:
      out.emplace_back(g.clone());
      return;
    case wkbLineString:
      out.emplace_back(g.clone());
      return;
    case wkbLinearRing: {
      auto line = std::make_unique<OGRLineString>();
      line->addSubLineString(g.toLineString());
      out.push_back(std::move(line));
      return;
    }
    case wkbPolygon:
      out.emplace_back(g.clone());
      return;
    case wkbTriangle:
      out.emplace_back(OGRGeometryFactory::forceToPolygon(g.clone()));
      return;
    case wkbPolyhedralSurface:
    case wkbTIN: {
      std::unique_ptr<OGRGeometry> multi(OGRGeometryFactory::forceToMultiPolygon(g.clone()));
      split_parts(*multi, source, out);
      return;
    }
    default:
      break;
  }
  if (OGR_GT_IsSubClassOf(type, wkbGeometryCollection)) {
    const OGRGeometryCollection* c = g.toGeometryCollection();
    for (int i = 0; i < c->getNumGeometries(); ++i) split_parts(*c->getGeometryRef(i), source, out);
    return;
  }
  throw Error(ErrorKind::invalid_input,
              source + ": unsupported geometry type " + OGRGeometryTypeToName(g.getGeometryType()));
}

template <class F>
void for_each_vertex(const OGRGeometry& g, F&& f) {
  switch (wkbFlatten(g.getGeometryType())) {
    case wkbPoint:  // split_parts keeps only non-empty (or partly NaN) points
      f(g.toPoint()->getX(), g.toPoint()->getY());
      return;
    case wkbLineString: {
      const OGRLineString* l = g.toLineString();
      for (int i = 0; i < l->getNumPoints(); ++i) f(l->getX(i), l->getY(i));
      return;
    }
    case wkbPolygon:
      for (const OGRLinearRing* r : *g.toPolygon())
        for (int i = 0; i < r->getNumPoints(); ++i) f(r->getX(i), r->getY(i));
      return;
    default:
      return;  // split_parts leaves only the three types above
  }
}

// An upper bound of the vertices `g` has once linearised with kArcStepDegrees: a circular arc
// (three control points of a CircularString) becomes at most 360 / kArcStepDegrees + 1 vertices.
// Points are counted apart (`points`), as they cost more to read (seed_reader.hpp).
int64_t vertex_bound(const OGRGeometry& g, int64_t& points) {
  constexpr auto kArcVertices = static_cast<int64_t>(360.0 / kArcStepDegrees) + 1;
  const OGRwkbGeometryType type = wkbFlatten(g.getGeometryType());
  switch (type) {
    case wkbPoint:
      ++points;
      return 1;
    case wkbLineString:
    case wkbLinearRing:
      return g.toSimpleCurve()->getNumPoints();
    case wkbCircularString: {
      const int64_t points = g.toSimpleCurve()->getNumPoints();
      return points < 3 ? points : (points - 1) / 2 * kArcVertices + 1;
    }
    case wkbCompoundCurve: {
      int64_t n = 0;
      for (const OGRCurve* c : *g.toCompoundCurve()) n += vertex_bound(*c, points);
      return n;
    }
    case wkbPolygon:
    case wkbCurvePolygon:
    case wkbTriangle: {
      int64_t n = 0;
      for (const OGRCurve* ring : *g.toCurvePolygon()) n += vertex_bound(*ring, points);
      return n;
    }
    case wkbPolyhedralSurface:
    case wkbTIN: {
      int64_t n = 0;
      for (const OGRPolygon* p : *g.toPolyhedralSurface()) n += vertex_bound(*p, points);
      return n;
    }
    default:
      break;
  }
  if (OGR_GT_IsSubClassOf(type, wkbGeometryCollection)) {
    int64_t n = 0;
    for (const OGRGeometry* part : *g.toGeometryCollection()) n += vertex_bound(*part, points);
    return n;
  }
  return 0;
}

std::vector<Vec2> vertices_of(const OGRSimpleCurve& c) {
  std::vector<Vec2> v(static_cast<size_t>(c.getNumPoints()));
  for (int i = 0; i < c.getNumPoints(); ++i) v[static_cast<size_t>(i)] = Vec2{c.getX(i), c.getY(i)};
  return v;
}

bool has_dotdot_component(const std::string& path) {
  size_t start = 0;
  while (start <= path.size()) {
    const size_t end = std::min(path.find('/', start), path.size());
    if (path.compare(start, end - start, "..") == 0) return true;
    start = end + 1;
  }
  return false;
}

// A confined path names an in-memory file: "/vsimem/..." or a zip in memory, "/vsizip//vsimem/...".
// Checked before GDAL sees the name, so that no other file system (disk, /vsicurl/, /vsistdin/,
// /vsisubfile/ of a disk file, ...) can be reached through it.
void check_confined_path(const std::string& path) {
  std::string_view rest = path;
  if (rest.rfind("/vsizip/", 0) == 0) rest.remove_prefix(std::strlen("/vsizip/"));
  if (rest.rfind("/vsimem/", 0) != 0 || has_dotdot_component(path))
    throw Error(
        ErrorKind::invalid_argument,
        "confined seed reading accepts only in-memory files (/vsimem/... or /vsizip//vsimem/...), not '" + path + "'");
}

std::vector<std::string> effective_drivers(const SeedReadOptions& options) {
  if (!options.confined) return options.allowed_drivers;
  std::vector<std::string> out;
  for (const char* d : kConfinedDrivers)
    if (options.allowed_drivers.empty() ||
        std::find(options.allowed_drivers.begin(), options.allowed_drivers.end(), d) != options.allowed_drivers.end())
      out.emplace_back(d);
  if (out.empty())
    throw Error(ErrorKind::invalid_argument, "none of the allowed drivers may read confined (uploaded) data");
  return out;
}

// A feature read and checked, waiting to be added to the SeedSet in owner order.
struct PendingPart {
  int dimension = 0;           // 0 point, 1 line, 2 polygon
  std::vector<Vec2> vertices;  // point (1) or line vertices
  std::vector<Ring> rings;     // polygon: outer ring first
};

struct PendingFeature {
  int32_t owner = 0;
  int64_t position = 0;  // 1-based, in the input
  std::string source;
  std::vector<PendingPart> parts;
  double weight = 1.0;
  double reach = std::numeric_limits<double>::infinity();
  double effect = 1.0;
};

class Reader {
 public:
  Reader(const SeedReadOptions& options, LoadedSeeds& out, const gdal::ConfinedScope* confinement)
      : options_(options), out_(out), confinement_(confinement), drivers_(effective_drivers(options)) {}

  void run() {
    if (options_.paths.empty()) throw Error(ErrorKind::invalid_argument, "no seed files given");
    if (!(options_.border_tolerance >= 0.0 && std::isfinite(options_.border_tolerance)))
      throw Error(ErrorKind::invalid_argument, "the land-border tolerance must be a finite number >= 0");
    if (!(options_.transform_accuracy >= 0.0 && std::isfinite(options_.transform_accuracy)))
      throw Error(ErrorKind::invalid_argument, "the accepted transformation accuracy must be a finite number >= 0");
    open_all();
    select_layers();
    choose_target();
    for (LayerRef& layer : layers_) read_layer(layer);
    check_network(options_.paths.front());
    if (out_.report.features_read == 0)
      throw Error(ErrorKind::invalid_input, "no seed features: the layers read hold no non-empty geometry (" +
                                                std::to_string(out_.report.features_skipped_empty) + " empty skipped)");
    add_to_seed_set();
    detail::check_conflicts(parts_, out_.seeds, options_.on_conflict, options_.border_tolerance, target_.get(),
                            out_.report);
    if (grid_) place_in_grid();
  }

  // describe_seed_files(): the same opening, choice of layers and target CRS, then the inventory.
  void describe(SeedInventory& inventory, bool with_features) {
    if (options_.paths.empty()) throw Error(ErrorKind::invalid_argument, "no seed files given");
    open_all();
    select_layers();
    choose_target();
    inventory.crs = out_.crs;
    if (target_) {
      const char* authority = target_->GetAuthorityName(nullptr);
      const char* code = target_->GetAuthorityCode(nullptr);
      if (authority != nullptr && code != nullptr) inventory.crs_code = std::string(authority) + ":" + code;
    }
    std::vector<detail::InventoryLayer> layers;
    for (const LayerRef& l : layers_) layers.push_back({l.layer, layer_label(l), l.name, l.srs.get()});
    detail::InventoryHooks hooks{
        [this](const std::string& where) { check_network(where); },
        [this](OGRLayer& layer, const std::string& label) { check_declared_features(layer, label); },
        [this](const std::string& label) { count_feature(label); },
        [this](const OGRGeometry& g, const std::string& source) { count_vertices(g, source); }, read_error_kind()};
    detail::take_inventory(layers, target_.get(), with_features, hooks, inventory);
    inventory.warnings = out_.report.warnings;
  }

 private:
  // Confined: a refused network access makes the input invalid, even when the driver carried on
  // without what it wanted to fetch.
  void check_network(const std::string& where) const {
    if (confinement_ == nullptr || confinement_->refused_urls().empty()) return;
    throw Error(ErrorKind::invalid_input, where + ": the data refers to a network resource (" +
                                              confinement_->refused_urls().front() +
                                              "); uploaded data must be self-contained");
  }

  // Reading errors: a broken upload is bad input; a failing local file is an I/O error.
  ErrorKind read_error_kind() const { return options_.confined ? ErrorKind::invalid_input : ErrorKind::io; }

  void open_all() {
    CPLStringList drivers;
    for (const std::string& d : drivers_) drivers.AddString(d.c_str());
    for (const std::string& path : options_.paths) {
      if (options_.confined) check_confined_path(path);
      const std::string name = gdal::open_name(path);
      const std::string label = valid_utf8(path);
      // The name as given: for a plain "x.zip" that is the archive itself, for /vsi names
      // VSIStatL knows the virtual file system. Confined paths are the caller's own in-memory
      // files: one that does not open is a damaged upload (a truncated zip), not a missing file.
      if (!gdal::path_exists(path)) {
        if (options_.confined)
          throw Error(ErrorKind::invalid_input, label + ": the data cannot be opened (a truncated or damaged file?)");
        throw Error(ErrorKind::not_found, "seed file not found: " + label);
      }
      gdal::ErrorCapture capture;
      // Before any driver builds a geometry: what the input really holds (input_scan.hpp).
      detail::scan_input(name, label,
                         {options_.max_input_bytes, options_.max_features, options_.max_vertices,
                          options_.max_memory_bytes, options_.confined},
                         tally_);
      GDALDataset* ds =
          GDALDataset::FromHandle(GDALOpenEx(name.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY,
                                             drivers_.empty() ? nullptr : drivers.List(), nullptr, nullptr));
      if (ds != nullptr) datasets_.emplace_back(ds);
      check_network(path);
      if (ds == nullptr) {
        std::string why = drivers_.empty()
                              ? "not a vector dataset GDAL can read"
                              : "not a vector dataset readable by the allowed drivers (" + join(drivers_) + ")";
        throw Error(ErrorKind::invalid_input, label + ": " + why + capture.suffix());
      }
      for (std::string& w : capture.take_warnings()) gdal_warning(label, w);
    }
  }

  // GDAL repeats some warnings (once when a driver sniffs the file, once when it reads it):
  // each distinct text is reported once.
  void gdal_warning(const std::string& where, const std::string& text) {
    if (gdal_warnings_seen_.insert(text).second) out_.report.warnings.push_back(where + ": GDAL: " + text);
  }

  static std::string join(const std::vector<std::string>& v) {
    std::string out;
    for (const std::string& s : v) out += (out.empty() ? "" : ", ") + s;
    return out;
  }

  void add_layer(size_t file, OGRLayer* layer) {
    LayerRef ref;
    ref.file = file;
    ref.layer = layer;
    ref.name = escape_utf8(layer->GetName());  // for messages and Feature::source only
    if (const OGRSpatialReference* s = layer->GetSpatialRef()) {
      ref.srs.reset(s->Clone());
      ref.srs->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    }
    layers_.push_back(std::move(ref));
  }

  // Every layer of every file in dataset order, or the named ones: per file, in the order the
  // names are given. A name found in no file is an error.
  void select_layers() {
    std::vector<bool> found(options_.layers.size(), false);
    for (size_t f = 0; f < datasets_.size(); ++f) {
      GDALDataset& ds = *datasets_[f];
      if (options_.layers.empty()) {
        if (ds.GetLayerCount() == 0)
          throw Error(ErrorKind::invalid_input, valid_utf8(options_.paths[f]) + ": the dataset has no vector layers");
        for (int i = 0; i < ds.GetLayerCount(); ++i) add_layer(f, ds.GetLayer(i));
        continue;
      }
      for (size_t n = 0; n < options_.layers.size(); ++n) {
        OGRLayer* layer = ds.GetLayerByName(options_.layers[n].c_str());
        if (layer == nullptr) continue;
        found[n] = true;
        // A name given twice (or two names GDAL matches case-insensitively) reads the layer once.
        bool already = false;
        for (const LayerRef& l : layers_) already |= l.layer == layer;
        if (!already) add_layer(f, layer);
      }
    }
    for (size_t n = 0; n < options_.layers.size(); ++n) {
      if (found[n]) continue;
      std::string available;
      for (size_t f = 0; f < datasets_.size(); ++f)
        available += (f ? "; " : "") + valid_utf8(options_.paths[f]) + ": " + list_layers(*datasets_[f]);
      // The data is there; the name asked for does not match it: a bad argument, not a missing file.
      throw Error(ErrorKind::invalid_argument,
                  "layer '" + quote_input(options_.layers[n]) + "' not found (layers: " + available + ")");
    }
  }

  // The operation a layer goes to the target CRS through (crs_operation.hpp), stated in the
  // report, refused when it is a ballpark one or less accurate than asked (unless allowed).
  detail::ChosenOperation stated_operation(const LayerRef& l) {
    double west = -180.0, south = -90.0, east = 180.0, north = 90.0;
    lonlat_extent(l, west, south, east, north);
    detail::ChosenOperation op = detail::choose_operation(*l.srs, *target_, west, south, east, north);
    // Names from the data (a layer's WKT may name its CRS anything) escaped, as every message's.
    TransformStatement t{layer_label(l),
                         escape_utf8(l.srs->GetName() ? l.srs->GetName() : "?"),
                         escape_utf8(out_.seed_crs.name),
                         escape_utf8(op.name),
                         op.accuracy,
                         op.conversion,
                         op.ballpark,
                         op.missing_grids};
    std::string problem;
    char bound[64];
    std::snprintf(bound, sizeof bound, "%g m", options_.transform_accuracy);
    if (op.ballpark) {
      problem = "is a ballpark one (a datum shift ignored or guessed: errors of the order of 100 m)";
    } else if (op.accuracy < 0.0) {
      problem = "has no stated accuracy";
    } else if (op.accuracy > options_.transform_accuracy) {
      char acc[64];
      std::snprintf(acc, sizeof acc, "%g m", op.accuracy);
      problem = std::string("is accurate to ") + acc + ", worse than the " + bound + " accepted (transform-accuracy)";
    }
    if (!problem.empty()) {
      std::string grids;
      for (const std::string& g : op.missing_grids) grids += (grids.empty() ? "" : ", ") + g;
      const std::string message =
          "layer " + layer_label(l) + ": the operation PROJ can use from " + t.from + " to " + t.to + " here, '" +
          t.operation + "', " + problem +
          (grids.empty() ? std::string(" (no more accurate operation is known for this area)")
                         : " (a more accurate one needs the PROJ grid(s) " + grids + ", not installed)");
      if (!options_.allow_ballpark) throw Error(ErrorKind::invalid_input, message + "; allow-ballpark accepts it");
      out_.report.warnings.push_back(message + "; accepted (allow-ballpark)");
    }
    out_.report.transformations.push_back(std::move(t));
    return op;
  }

  // The layer's extent in longitude/latitude on its own datum (its CRS's geographic base), for
  // PROJ's choice of operation; the whole world when it cannot be had.
  void lonlat_extent(const LayerRef& l, double& west, double& south, double& east, double& north) const {
    OGREnvelope e;
    if (l.layer->GetExtent(&e, TRUE) != OGRERR_NONE) return;
    OGRSpatialReference from(*l.srs), geog;
    from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    if (geog.CopyGeogCSFrom(l.srs.get()) != OGRERR_NONE) return;
    geog.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    CtPtr ct(OGRCreateCoordinateTransformation(&from, &geog));
    if (!ct) return;
    // The box's corners and edge midpoints (a projected box's edges bend in longitude/latitude).
    double xs[8] = {e.MinX, e.MaxX, e.MaxX, e.MinX, 0.5 * (e.MinX + e.MaxX), e.MaxX, 0.5 * (e.MinX + e.MaxX), e.MinX};
    double ys[8] = {e.MinY, e.MinY, e.MaxY, e.MaxY, e.MinY, 0.5 * (e.MinY + e.MaxY), e.MaxY, 0.5 * (e.MinY + e.MaxY)};
    int ok[8] = {0};
    if (!ct->Transform(8, xs, ys, nullptr, ok)) return;
    double w = 180.0, s = 90.0, x = -180.0, n = -90.0;
    for (int k = 0; k < 8; ++k) {
      if (!ok[k]) return;
      w = std::min(w, xs[k]);
      x = std::max(x, xs[k]);
      s = std::min(s, ys[k]);
      n = std::max(n, ys[k]);
    }
    if (!(w <= x && s <= n && w >= -180.0 && x <= 180.0 && s >= -90.0 && n <= 90.0)) return;
    west = w;
    east = x;
    south = s;
    north = n;
  }

  // File names are bytes too (the CLI's user may name any file): valid_utf8 keeps the common
  // case as typed.
  std::string layer_label(const LayerRef& l) const { return valid_utf8(options_.paths[l.file]) + ":" + l.name; }

  void choose_target() {
    size_t without = 0;
    for (const LayerRef& l : layers_) without += l.srs ? 0 : 1;
    if (!options_.target_crs.empty()) {
      target_ = gdal::parse_srs(options_.target_crs);
      if (!target_)
        throw Error(ErrorKind::invalid_argument,
                    "cannot parse the target CRS '" + quote_input(options_.target_crs) + "'");
    } else if (without == 0) {
      target_.reset(layers_.front().srs->Clone());
      target_->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    }
    if (without > 0) {
      const LayerRef* bare = nullptr;
      for (const LayerRef& l : layers_)
        if (!l.srs) {
          bare = &l;
          break;
        }
      if (target_ || without < layers_.size())
        throw Error(ErrorKind::invalid_input,
                    "layer " + layer_label(*bare) + " has no CRS, so it cannot be placed in the " +
                        (options_.target_crs.empty() ? "other layers' CRS" : "target CRS") +
                        " (layers without a CRS are accepted only when no layer has one and no target CRS is given)");
      out_.report.warnings.push_back("no layer has a CRS: coordinates are used as they are, in unknown units");
      return;  // out_.crs stays the default "unknown" description
    }
    out_.crs = gdal::crs_info(*target_);
    out_.seed_crs = out_.crs;
    if (options_.geographic_seeds && !target_->IsGeographic()) {
      // The seeds go to the grid CRS's geographic base; the grid CRS is kept for place_in_grid.
      gdal::SrsPtr base(target_->CloneGeogCS());
      if (!base || !base->IsGeographic())
        throw Error(ErrorKind::invalid_input, "the CRS " + out_.crs.name +
                                                  " has no geographic base, so the seeds cannot be read in "
                                                  "longitude/latitude on its ellipsoid");
      base->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
      grid_ = std::move(target_);
      target_ = std::move(base);
      out_.geographic_base = true;
      out_.seed_crs = gdal::crs_info(*target_);
    }
  }

  // geographic_seeds: the polygons and the bounding box of the (normalised) seeds in the grid
  // CRS, transformed vertex by vertex from the geographic base, so that the polygons match the
  // SeedSet's one for one.
  void place_in_grid() {
    gdal::ErrorCapture capture;
    CtPtr ct(OGRCreateCoordinateTransformation(target_.get(), grid_.get()));
    if (!ct)
      throw Error(ErrorKind::invalid_input,
                  "no transformation from longitude/latitude to the grid CRS " + out_.crs.name + capture.suffix());
    auto transform = [&](std::vector<Vec2>& v, const std::string& what) {
      std::vector<double> x(v.size()), y(v.size());
      std::vector<int> ok(v.size(), TRUE);
      for (size_t i = 0; i < v.size(); ++i) {
        x[i] = v[i].x;
        y[i] = v[i].y;
      }
      if (!v.empty()) ct->Transform(static_cast<int>(v.size()), x.data(), y.data(), nullptr, nullptr, ok.data());
      for (size_t i = 0; i < v.size(); ++i) {
        if (!ok[i] || !std::isfinite(x[i]) || !std::isfinite(y[i]))
          throw Error(ErrorKind::invalid_input, what + ": the vertex (" + format_number(v[i].x) + ", " +
                                                    format_number(v[i].y) + ") cannot be placed in the grid CRS " +
                                                    out_.crs.name + capture.suffix());
        v[i] = Vec2{x[i], y[i]};
      }
    };
    SeedSet::Box box{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    auto include = [&](const std::vector<Vec2>& v) {
      for (const Vec2& p : v) {
        box.xmin = std::min(box.xmin, p.x);
        box.ymin = std::min(box.ymin, p.y);
        box.xmax = std::max(box.xmax, p.x);
        box.ymax = std::max(box.ymax, p.y);
      }
    };
    const SeedSet& seeds = out_.seeds;
    auto polygons = std::make_shared<std::vector<Polygon>>(seeds.polygons());
    for (Polygon& poly : *polygons)
      for (Ring& ring : poly.rings) {
        transform(ring, seeds.features()[static_cast<size_t>(poly.feature)].source);
        include(ring);
      }
    // Points and segment ends (polygon rings are segments too, already included above).
    std::vector<Vec2> ends;
    for (const Site& site : seeds.sites()) {
      if (site.kind == SiteKind::area) continue;
      ends.push_back(site.a);
      if (site.kind == SiteKind::segment) ends.push_back(site.b);
    }
    transform(ends, "a seed");
    include(ends);
    out_.grid_polygons = std::move(polygons);
    out_.grid_bounds = box;
  }

  void read_layer(LayerRef& l) {
    gdal::ErrorCapture capture;
    OGRFeatureDefn* defn = l.layer->GetLayerDefn();
    int owner_index = -1;
    if (options_.owner_field) {
      owner_index = defn->GetFieldIndex(options_.owner_field->c_str());
      if (owner_index < 0)
        throw Error(ErrorKind::invalid_argument, "owner field '" + quote_input(*options_.owner_field) +
                                                     "' not found in layer " + layer_label(l) +
                                                     " (fields: " + list_fields(defn) + ")");
    }
    weight_index_ = numeric_field(l, defn, options_.weight_field, "weight");
    reach_index_ = numeric_field(l, defn, options_.reach_field, "reach");
    effect_index_ = numeric_field(l, defn, options_.effect_field, "effect");
    CtPtr ct;
    if (target_ && l.srs && !l.srs->IsSame(target_.get())) {
      const detail::ChosenOperation op = stated_operation(l);
      OGRCoordinateTransformationOptions chosen;
      chosen.SetCoordinateOperation(op.definition.c_str(), false);
      ct.reset(OGRCreateCoordinateTransformation(l.srs.get(), target_.get(), chosen));
      if (!ct)
        throw Error(ErrorKind::invalid_input, "layer " + layer_label(l) + ": no transformation from its CRS (" +
                                                  escape_utf8(l.srs->GetName() ? l.srs->GetName() : "?") +
                                                  ") to the target CRS" + capture.suffix());
    }
    const bool source_geographic = l.srs && l.srs->IsGeographic();
    const bool target_geographic = target_ && target_->IsGeographic();
    check_declared_features(*l.layer, layer_label(l));
    l.layer->ResetReading();
    while (true) {
      std::unique_ptr<OGRFeature> feature(l.layer->GetNextFeature());
      check_network(layer_label(l));
      if (!feature) break;
      count_feature(layer_label(l));
      read_feature(l, *feature, owner_index, ct.get(), source_geographic, target_geographic);
    }
    if (!capture.last_error().empty())
      throw Error(read_error_kind(), "reading layer " + layer_label(l) + " failed: " + capture.last_error());
    for (std::string& w : capture.take_warnings()) gdal_warning(layer_label(l), w);
  }

  // The index of an adjustment's field in the layer (-1 without one): it must exist and hold
  // numbers.
  int numeric_field(const LayerRef& l, OGRFeatureDefn* defn, const std::optional<std::string>& name,
                    const char* what) const {
    if (!name) return -1;
    const int index = defn->GetFieldIndex(name->c_str());
    if (index < 0)
      throw Error(ErrorKind::invalid_argument, std::string(what) + " field '" + quote_input(*name) +
                                                   "' not found in layer " + layer_label(l) +
                                                   " (fields: " + list_fields(defn) + ")");
    const OGRFieldType type = defn->GetFieldDefn(index)->GetType();
    if (type != OFTInteger && type != OFTInteger64 && type != OFTReal)
      throw Error(ErrorKind::invalid_argument, std::string(what) + " field '" + quote_input(*name) + "' of layer " +
                                                   layer_label(l) + " is not numeric (" +
                                                   OGRFieldDefn::GetFieldTypeName(type) + ")");
    return index;
  }

  // A feature's adjustment from its field: `absent` where the field is null, an error when
  // `required`.
  double adjustment(OGRFeature& f, int index, const std::string& source, const char* what, bool required,
                    double absent) const {
    if (index < 0) return absent;
    if (!f.IsFieldSetAndNotNull(index)) {
      if (!required) return absent;
      throw Error(ErrorKind::invalid_input,
                  source + ": the " + what + " field '" +
                      valid_utf8(what[0] == 'w' ? *options_.weight_field : *options_.reach_field) +
                      "' is null or missing");
    }
    return f.GetFieldAsDouble(index);
  }

  // The feature limit (max_features), over every layer read: a layer is refused up front when
  // its driver knows the count cheaply (GPKG, Shapefile, FlatGeobuf), else at the feature over it.
  void check_declared_features(OGRLayer& layer, const std::string& label) const {
    if (options_.max_features <= 0) return;
    const GIntBig count = layer.GetFeatureCount(FALSE);
    if (count >= 0 && features_seen_ + count > options_.max_features) too_many_features(label);
  }
  void count_feature(const std::string& label) {
    if (options_.max_features > 0 && ++features_seen_ > options_.max_features) too_many_features(label);
  }
  [[noreturn]] void too_many_features(const std::string& label) const {
    throw Error(ErrorKind::too_large, "the seed data has more than " + std::to_string(options_.max_features) +
                                          " features, the limit (reached in layer " + label + ")");
  }

  // Counted on the geometry as the driver returned it, before anything is copied: a feature over
  // the limit costs what the driver built, nothing more.
  void count_vertices(const OGRGeometry& geometry, const std::string& source) {
    SeedReadReport& r = out_.report;
    int64_t points = 0;
    r.vertices_read += vertex_bound(geometry, points);
    points_seen_ += points;
    r.reading_bytes = reading_bytes(features_seen_for_memory_ += 1, points_seen_, r.vertices_read - points_seen_);
    if (options_.max_vertices > 0 && r.vertices_read > options_.max_vertices)
      throw Error(ErrorKind::too_large, "the seed data has more than " + std::to_string(options_.max_vertices) +
                                            " vertices, the limit (reached at " + source + ")");
    if (options_.max_memory_bytes > 0 && r.reading_bytes > options_.max_memory_bytes)
      throw Error(ErrorKind::too_large, "reading the seed data needs more than the memory limit of " +
                                            std::to_string(options_.max_memory_bytes >> 20) + " MiB (" +
                                            std::to_string(r.vertices_read) + " vertices, reached at " + source + ")");
    if (options_.on_reading_bytes) options_.on_reading_bytes(r.reading_bytes);
  }

  static void check_vertices(const OGRGeometry& part, const std::string& source, bool geographic, const char* stage) {
    for_each_vertex(part, [&](double x, double y) {
      if (!std::isfinite(x) || !std::isfinite(y))
        throw Error(ErrorKind::invalid_input,
                    source + ": non-finite coordinate (" + format_number(x) + ", " + format_number(y) + ")" + stage);
      if (std::abs(x) > kMaxSeedCoordinate || std::abs(y) > kMaxSeedCoordinate)
        throw Error(ErrorKind::invalid_input, source + ": coordinate (" + format_number(x) + ", " + format_number(y) +
                                                  ")" + stage + " is beyond ±" + format_number(kMaxSeedCoordinate) +
                                                  " CRS units, where no grid can hold it (is the CRS right?)");
      if (geographic && std::abs(y) > 90.0)
        throw Error(ErrorKind::invalid_input, source + ": latitude " + format_number(y) + " is beyond ±90" + stage +
                                                  " (coordinate (" + format_number(x) + ", " + format_number(y) + "))");
    });
  }

  void read_feature(const LayerRef& l, OGRFeature& f, int owner_index, OGRCoordinateTransformation* ct,
                    bool source_geographic, bool target_geographic) {
    ++position_;
    const std::string source = layer_label(l) + ":fid " + std::to_string(f.GetFID());
    const OGRGeometry* geometry = f.GetGeometryRef();
    if (geometry == nullptr || truly_empty(*geometry)) {
      ++out_.report.features_skipped_empty;
      out_.report.warnings.push_back(source + ": " + (geometry ? "empty" : "null") + " geometry, skipped");
      return;
    }
    std::string label;
    if (owner_index >= 0) {
      if (!f.IsFieldSetAndNotNull(owner_index))
        throw Error(ErrorKind::invalid_input,
                    source + ": the owner field '" + valid_utf8(*options_.owner_field) + "' is null or missing");
      // Owner values are outside text: escaped here, once. The escape is injective, so owners
      // still differ exactly when their raw bytes differ, and every later use (raster
      // attribute table, report, vector outputs) has valid UTF-8.
      label = escape_utf8(f.GetFieldAsString(owner_index));
    } else {
      label = std::to_string(position_);
    }

    // Curves become line strings with a 1 degree angular step: the chords stay within
    // 3.8e-5 x radius of the arc (4 cm for a 1 km radius), where GDAL's default 4 degrees
    // would leave 0.6 m - a visible shift of a boundary at fine cell sizes. Z and M are dropped.
    count_vertices(*geometry, source);
    std::unique_ptr<OGRGeometry> linear(geometry->hasCurveGeometry(TRUE) ? geometry->getLinearGeometry(kArcStepDegrees)
                                                                         : geometry->clone());
    if (!linear) throw Error(ErrorKind::invalid_input, source + ": the curve geometry cannot be linearised");
    linear->flattenTo2D();
    linear->setMeasured(FALSE);
    std::vector<std::unique_ptr<OGRGeometry>> parts;
    split_parts(*linear, source, parts);

    gdal::ErrorCapture capture;
    for (auto& part : parts) {
      check_vertices(*part, source, source_geographic, "");
      if (ct != nullptr) {
        if (part->transform(ct) != OGRERR_NONE)
          throw Error(ErrorKind::invalid_input,
                      source + ": cannot be reprojected into the target CRS" + capture.suffix());
        check_vertices(*part, source, target_geographic, " after reprojection");
      }
    }

    const int32_t owner = out_.seeds.owner_code(label);
    const auto index = static_cast<int32_t>(pending_.size());
    pending_.push_back(
        PendingFeature{owner,
                       position_,
                       source,
                       {},
                       adjustment(f, weight_index_, source, "weight", true, 1.0),
                       adjustment(f, reach_index_, source, "reach", false, std::numeric_limits<double>::infinity()),
                       adjustment(f, effect_index_, source, "effect", false, 1.0)});
    std::set<std::pair<double, double>> seen_points;
    for (auto& part : parts) {
      switch (wkbFlatten(part->getGeometryType())) {
        case wkbPoint: {
          const OGRPoint* p = part->toPoint();
          if (!seen_points.emplace(p->getX(), p->getY()).second) {
            ++out_.report.points_removed;
            continue;
          }
          pending_.back().parts.push_back(PendingPart{0, {Vec2{p->getX(), p->getY()}}, {}});
          keep_part(std::move(part), index, owner, 0, 1);
          break;
        }
        case wkbLineString:
          add_line(std::move(part), index, owner);
          break;
        case wkbPolygon:
          add_polygon(std::move(part), index, owner, source);
          break;
        default:
          throw Error(ErrorKind::internal, source + ": unexpected part type after splitting");
      }
    }
    ++out_.report.features_read;
  }

  // Features go into the SeedSet grouped by owner code (stable: input order within an owner).
  // The engines break ties, and the interior spans resolve overlaps, towards the lower feature
  // index; with this order a lower feature index always means a lower or equal owner code, so
  // "ties and overlaps go to the lower owner code" holds even when owners interleave in the
  // input. Without an owner field every feature is its own owner and the order is the input's.
  void add_to_seed_set() {
    std::vector<size_t> order(pending_.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return pending_[a].owner < pending_[b].owner; });
    std::vector<int32_t> final_index(pending_.size());
    SeedSet& seeds = out_.seeds;
    for (size_t k : order) {
      PendingFeature& f = pending_[k];
      const int32_t index = seeds.add_feature(f.owner, std::move(f.source));
      seeds.set_adjustment(index, f.weight, f.reach);  // refuses bad values, naming the feature
      seeds.set_effect(index, f.effect);
      final_index[k] = index;
      out_.input_position.push_back(f.position);
      for (PendingPart& part : f.parts) {
        if (part.dimension == 0)
          seeds.add_point(index, part.vertices.front());
        else if (part.dimension == 1)
          seeds.add_polyline(index, part.vertices);
        else
          seeds.add_polygon(index, std::move(part.rings));
      }
    }
    pending_.clear();
    for (SeedPart& part : parts_) part.feature = final_index[static_cast<size_t>(part.feature)];
  }

  void keep_part(std::unique_ptr<OGRGeometry> g, int32_t feature, int32_t owner, int dimension, int64_t vertices) {
    SeedPart part;
    g->getEnvelope(&part.envelope);
    part.geometry = std::move(g);
    part.feature = feature;
    part.owner = owner;
    part.dimension = dimension;
    part.vertices = vertices;
    parts_.push_back(std::move(part));
  }

  void add_line(std::unique_ptr<OGRGeometry> g, int32_t feature, int32_t owner) {
    std::vector<Vec2> v = vertices_of(*g->toLineString());
    out_.report.vertices_removed += detail::remove_duplicate_vertices(v, false);
    if (v.empty()) return;
    pending_.back().parts.push_back(PendingPart{v.size() == 1 ? 0 : 1, v, {}});
    if (v.size() == 1) {
      // A line of one repeated position is a point (the seed model does the same).
      keep_part(std::make_unique<OGRPoint>(v[0].x, v[0].y), feature, owner, 0, 1);
      return;
    }
    auto line = std::make_unique<OGRLineString>();
    gdal::set_points(*line, v);
    keep_part(std::move(line), feature, owner, 1, static_cast<int64_t>(v.size()));
  }

  void add_polygon(std::unique_ptr<OGRGeometry> g, int32_t feature, int32_t owner, const std::string& source) {
    const OGRPolygon* in = g->toPolygon();
    std::vector<std::vector<Vec2>> rings;
    std::vector<std::string> repairs;
    for (int r = 0; r < in->getNumInteriorRings() + 1; ++r) {
      const OGRLinearRing* ring = r == 0 ? in->getExteriorRing() : in->getInteriorRing(r - 1);
      std::vector<Vec2> v = vertices_of(*ring);
      if (v.size() >= 2 && !(v.front() == v.back())) repairs.push_back("unclosed ring closed");
      out_.report.vertices_removed += detail::remove_duplicate_vertices(v, true);
      if (v.size() < 3) {
        if (r == 0)
          throw Error(ErrorKind::invalid_input,
                      source + ": polygon whose outer ring has fewer than 3 distinct vertices (no area)");
        repairs.push_back("degenerate hole dropped");
        continue;
      }
      rings.push_back(std::move(v));
    }
    auto clean = std::make_unique<OGRPolygon>();
    for (const auto& v : rings) clean->addRingDirectly(detail::make_ring(v).release());

    std::vector<std::unique_ptr<OGRPolygon>> result;
    {
      gdal::ErrorCapture quiet;  // GEOS explains invalidity through warnings; we report our own
      if (clean->IsValid()) {
        result.push_back(std::move(clean));
      } else {
        std::unique_ptr<OGRGeometry> fixed(clean->MakeValid());
        if (fixed) collect_polygons(*fixed, result);
        if (result.empty())
          throw Error(ErrorKind::invalid_input,
                      source + ": invalid polygon that cannot be repaired into an area" + quiet.suffix());
        repairs.push_back("invalid polygon (self-intersection or misplaced ring) repaired into " +
                          std::to_string(result.size()) + " polygon(s)");
      }
    }
    if (!repairs.empty()) {
      ++out_.report.polygons_repaired;
      std::string what;
      for (const std::string& r : repairs) what += (what.empty() ? "" : "; ") + r;
      out_.report.warnings.push_back(source + ": " + what);
    }
    for (auto& p : result) {
      std::vector<Ring> seed_rings;
      int64_t count = 0;
      for (const OGRLinearRing* ring : *p) {
        std::vector<Vec2> v = vertices_of(*ring);
        detail::remove_duplicate_vertices(v, true);  // repair output: not counted as input noise
        count += static_cast<int64_t>(v.size());
        seed_rings.push_back(std::move(v));
      }
      pending_.back().parts.push_back(PendingPart{2, {}, std::move(seed_rings)});
      keep_part(std::move(p), feature, owner, 2, count);
    }
  }

  // The polygons of MakeValid's output; lower-dimensional leftovers (collapsed spikes) dropped.
  static void collect_polygons(const OGRGeometry& g, std::vector<std::unique_ptr<OGRPolygon>>& out) {
    const OGRwkbGeometryType type = wkbFlatten(g.getGeometryType());
    if (type == wkbPolygon) {
      if (!g.IsEmpty() && g.toPolygon()->get_Area() > 0.0) out.emplace_back(g.toPolygon()->clone());
      return;
    }
    if (OGR_GT_IsSubClassOf(type, wkbGeometryCollection)) {
      const OGRGeometryCollection* c = g.toGeometryCollection();
      for (int i = 0; i < c->getNumGeometries(); ++i) collect_polygons(*c->getGeometryRef(i), out);
    }
  }

  const SeedReadOptions& options_;
  LoadedSeeds& out_;
  const gdal::ConfinedScope* confinement_;  // null: not confined
  std::vector<std::string> drivers_;        // passed to GDALOpenEx; empty = any
  int64_t features_seen_ = 0;               // counted only with a max_features limit
  int64_t points_seen_ = 0;                 // of SeedReadReport::vertices_read, those of points
  int64_t features_seen_for_memory_ = 0;    // non-empty features counted by count_vertices
  detail::InputTally tally_;                // what the inputs declared before they were opened
  std::vector<gdal::DatasetPtr> datasets_;
  std::vector<LayerRef> layers_;
  gdal::SrsPtr target_;
  gdal::SrsPtr grid_;            // geographic_seeds on a projected target: the target (grid) CRS
  std::vector<SeedPart> parts_;  // for the conflict check; feature = index into pending_
  std::vector<PendingFeature> pending_;
  int64_t position_ = 0;
  int weight_index_ = -1, reach_index_ = -1, effect_index_ = -1;  // the adjustments' fields in the layer being read
  std::set<std::string> gdal_warnings_seen_;
};

}  // namespace

SeedInventory describe_seed_files(const SeedReadOptions& options, bool with_features) {
  gdal_init();
  gdal::ErrorCapture quiet;
  SeedReadOptions plain = options;  // the target CRS itself, not its geographic base
  plain.geographic_seeds = false;
  LoadedSeeds unused;
  SeedInventory inventory;
  if (!plain.confined) {
    Reader(plain, unused, nullptr).describe(inventory, with_features);
    return inventory;
  }
  gdal::ConfinedScope scope;
  Reader(plain, unused, &scope).describe(inventory, with_features);
  return inventory;
}

LoadedSeeds load_seeds(const SeedReadOptions& options) {
  gdal_init();
  // Whatever GDAL says outside the reader's own captures (choosing layers, closing datasets) is
  // kept off stderr: in the daemon that is the structured log, and the text is the data's.
  gdal::ErrorCapture quiet;
  LoadedSeeds out;
  if (!options.confined) {
    Reader reader(options, out, nullptr);
    reader.run();
    return out;
  }
  // The scope covers everything the reader does with GDAL: opening, reading features and
  // creating the coordinate transformation all happen inside it, on this thread.
  gdal::ConfinedScope scope;
  Reader reader(options, out, &scope);
  reader.run();
  return out;
}

}  // namespace rv
