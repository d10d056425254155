// take_inventory(): see seed_inventory.hpp and describe_seed_files() in rv/gdal/seed_reader.hpp.
#include "reading/seed_inventory.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <set>
#include <unordered_set>

#include <cpl_conv.h>
#include <ogr_api.h>

#include "common/gdal_util.hpp"
#include "rv/field/text.hpp"

namespace rv::detail {
namespace {

using gdal::CtPtr;

const char* type_name(OGRFieldType t, OGRFieldSubType sub) {
  switch (t) {
    case OFTInteger:
      return sub == OFSTBoolean ? "boolean" : "integer";
    case OFTInteger64:
      return "integer64";
    case OFTReal:
      return "real";
    case OFTString:
      return "string";
    case OFTDate:
      return "date";
    case OFTTime:
      return "time";
    case OFTDateTime:
      return "datetime";
    case OFTBinary:
      return "binary";
    default:
      return "list";
  }
}

// Per field: the distinct values seen so far (bounded), for the summary.
struct FieldTally {
  std::unordered_set<std::string> seen;
  bool capped = false;
};

// The summary of one field value; the set stops growing at kMaxDistinct so that a unique id
// column of a million features costs what a thousand do.
void tally(SeedFieldSummary& field, FieldTally& t, const std::string& value) {
  ++field.non_null;
  if (t.capped) return;
  if (t.seen.count(value)) return;
  if (static_cast<int64_t>(t.seen.size()) >= SeedFieldSummary::kMaxDistinct) {
    t.capped = true;
    field.distinct_exact = false;
    t.seen.clear();
    return;
  }
  t.seen.insert(value);
  field.distinct = static_cast<int64_t>(t.seen.size());
  if (field.values.size() < SeedFieldSummary::kMaxValues) field.values.push_back(value);
}

void grow(std::optional<SeedSet::Box>& box, const OGREnvelope& e) {
  if (!box) {
    box = SeedSet::Box{e.MinX, e.MinY, e.MaxX, e.MaxY};
    return;
  }
  box->xmin = std::min(box->xmin, e.MinX);
  box->ymin = std::min(box->ymin, e.MinY);
  box->xmax = std::max(box->xmax, e.MaxX);
  box->ymax = std::max(box->ymax, e.MaxY);
}

// GeoJSON of a geometry already in the target CRS: enough significant digits for a millimetre
// at planetary coordinates (1e7 m) and for 1e-9 degrees.
std::string geojson(const OGRGeometry& g) {
  char* text =
      OGR_G_ExportToJsonEx(OGRGeometry::ToHandle(const_cast<OGRGeometry*>(&g)),
                           const_cast<char**>(std::array<const char*, 2>{"SIGNIFICANT_FIGURES=12", nullptr}.data()));
  std::string out = text != nullptr ? text : "null";
  CPLFree(text);
  return out;
}

}  // namespace

bool truly_empty(const OGRGeometry& g) {
  const OGRwkbGeometryType type = wkbFlatten(g.getGeometryType());
  if (type == wkbPoint) {
    const OGRPoint* p = g.toPoint();
    if (!p->IsEmpty()) return false;
    return std::isnan(p->getX()) == std::isnan(p->getY());
  }
  if (OGR_GT_IsSubClassOf(type, wkbGeometryCollection)) {
    const OGRGeometryCollection* c = g.toGeometryCollection();
    for (int i = 0; i < c->getNumGeometries(); ++i)
      if (!truly_empty(*c->getGeometryRef(i))) return false;
    return true;
  }
  return g.IsEmpty() != 0;
}

void take_inventory(const std::vector<InventoryLayer>& layers, const OGRSpatialReference* target, bool with_features,
                    const InventoryHooks& hooks, SeedInventory& out) {
  int64_t position = 0;
  for (size_t li = 0; li < layers.size(); ++li) {
    const InventoryLayer& l = layers[li];
    gdal::ErrorCapture capture;
    SeedLayerSummary summary;
    summary.source = l.label;
    summary.name = l.name;
    OGRFeatureDefn* defn = l.layer->GetLayerDefn();
    const int field_count = defn->GetFieldCount();
    std::vector<FieldTally> tallies(static_cast<size_t>(field_count));
    for (int i = 0; i < field_count; ++i) {
      const OGRFieldDefn* f = defn->GetFieldDefn(i);
      SeedFieldSummary field;
      field.name = escape_utf8(f->GetNameRef());
      field.type = type_name(f->GetType(), f->GetSubType());
      summary.fields.push_back(std::move(field));
    }
    CtPtr ct;
    if (target != nullptr && l.srs != nullptr && !l.srs->IsSame(target)) {
      ct.reset(OGRCreateCoordinateTransformation(l.srs, target));
      if (!ct)
        throw Error(ErrorKind::invalid_input,
                    "layer " + l.label + ": no transformation from its CRS to the target CRS" + capture.suffix());
    }
    hooks.check_declared_features(*l.layer, l.label);
    std::set<std::string> types;
    l.layer->ResetReading();
    while (true) {
      std::unique_ptr<OGRFeature> feature(l.layer->GetNextFeature());
      hooks.check_network(l.label);
      if (!feature) break;
      ++position;
      hooks.count_feature(l.label);
      ++summary.features;
      const std::string source = l.label + ":fid " + std::to_string(feature->GetFID());
      SeedPreviewFeature preview;
      preview.layer = li;
      preview.position = position;
      preview.geometry = "null";
      for (int i = 0; i < field_count; ++i) {
        std::optional<std::string> value;
        if (feature->IsFieldSetAndNotNull(i)) {
          value = escape_utf8(feature->GetFieldAsString(i));
          tally(summary.fields[static_cast<size_t>(i)], tallies[static_cast<size_t>(i)], *value);
        }
        if (with_features) preview.values.push_back(std::move(value));
      }
      const OGRGeometry* geometry = feature->GetGeometryRef();
      if (geometry == nullptr || truly_empty(*geometry)) {
        ++summary.empty;
      } else {
        hooks.count_vertices(*geometry, source);
        types.insert(OGRGeometryTypeToName(wkbFlatten(geometry->getGeometryType())));
        std::unique_ptr<OGRGeometry> g(geometry->hasCurveGeometry(TRUE) ? geometry->getLinearGeometry(kArcStepDegrees)
                                                                        : geometry->clone());
        if (!g) throw Error(ErrorKind::invalid_input, source + ": the curve geometry cannot be linearised");
        g->flattenTo2D();
        if (ct && g->transform(ct.get()) != OGRERR_NONE)
          throw Error(ErrorKind::invalid_input,
                      source + ": cannot be reprojected into the target CRS" + capture.suffix());
        OGREnvelope e;
        g->getEnvelope(&e);
        if (std::isfinite(e.MinX) && std::isfinite(e.MinY) && std::isfinite(e.MaxX) && std::isfinite(e.MaxY))
          grow(out.bounds, e);
        if (with_features) preview.geometry = geojson(*g);
      }
      if (with_features) out.features.push_back(std::move(preview));
    }
    if (!capture.last_error().empty())
      throw Error(hooks.read_error_kind, "reading layer " + l.label + " failed: " + capture.last_error());
    summary.geometry_types.assign(types.begin(), types.end());
    out.layers.push_back(std::move(summary));
  }
}

}  // namespace rv::detail
