#include "rv/seed_description.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

namespace rv {

using nlohmann::json;

namespace {

json field_json(const SeedFieldSummary& f) {
  return {{"name", f.name},
          {"type", f.type},
          {"nonNull", f.non_null},
          {"distinct", f.distinct},
          {"distinctExact", f.distinct_exact},
          {"values", f.values}};
}

// A field value as GeoJSON wants it: numbers of numeric fields as numbers, the rest as text.
json property(const std::optional<std::string>& v, const std::string& type) {
  if (!v) return nullptr;
  if (type == "integer" || type == "integer64" || type == "real" || type == "boolean") {
    try {
      size_t used = 0;
      const double d = std::stod(*v, &used);
      if (used == v->size() && std::isfinite(d)) {
        if (type != "real") return json(std::stoll(*v));
        return json(d);
      }
    } catch (const std::exception&) {
    }
  }
  return *v;
}

json features_json(const SeedInventory& inv) {
  json features = json::array();
  for (const SeedPreviewFeature& f : inv.features) {
    const SeedLayerSummary& layer = inv.layers[f.layer];
    json props = json::object();
    for (size_t i = 0; i < f.values.size() && i < layer.fields.size(); ++i)
      props[layer.fields[i].name] = property(f.values[i], layer.fields[i].type);
    // The feature's place in the input (nearestFeature codes count the same way) and its layer.
    features.push_back({{"type", "Feature"},
                        {"id", f.position},
                        {"geometry", json::parse(f.geometry)},
                        {"properties", props},
                        {"layer", f.layer}});
  }
  return {{"type", "FeatureCollection"}, {"features", features}};
}

}  // namespace

json seed_description(const SeedInventory& inv, bool with_features) {
  json layers = json::array();
  std::vector<std::string> common;
  for (size_t i = 0; i < inv.layers.size(); ++i) {
    const SeedLayerSummary& l = inv.layers[i];
    json fields = json::array();
    std::vector<std::string> names;
    for (const SeedFieldSummary& f : l.fields) {
      fields.push_back(field_json(f));
      names.push_back(f.name);
    }
    if (i == 0) {
      common = names;
    } else {
      common.erase(
          std::remove_if(common.begin(), common.end(),
                         [&](const std::string& n) { return std::find(names.begin(), names.end(), n) == names.end(); }),
          common.end());
    }
    layers.push_back({{"source", l.source},
                      {"name", l.name},
                      {"features", l.features},
                      {"empty", l.empty},
                      {"geometryTypes", l.geometry_types},
                      {"fields", fields}});
  }
  json crs = {{"name", inv.crs.name},
              {"wkt", inv.crs.wkt},
              {"geographic", inv.crs.geographic},
              {"metresPerUnit", inv.crs.geographic ? 0.0 : inv.crs.linear_unit}};
  crs["code"] = inv.crs_code.empty() ? json(nullptr) : json(inv.crs_code);
  json d = {{"crs", crs}, {"layers", layers}, {"commonFields", common}, {"warnings", inv.warnings}};
  d["bbox"] = inv.bounds ? json::array({inv.bounds->xmin, inv.bounds->ymin, inv.bounds->xmax, inv.bounds->ymax})
                         : json(nullptr);
  if (with_features) d["features"] = features_json(inv);
  return d;
}

}  // namespace rv
