#include "daemon/server_seeds.hpp"

#include <algorithm>

#include "daemon/server_execute.hpp"
#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/job.hpp"
#include "rv/options.hpp"
#include "rv/seed_description.hpp"

namespace rv::daemon {

using nlohmann::json;

json describe_seeds_summary(const std::string& base) {
  const std::string self = base + "/processes/" + kDescribeSeedsId;
  return {
      {"id", kDescribeSeedsId},
      {"title", "Describe seed files"},
      {"description",
       "What uploaded seed files hold, before a job is made of them: their layers, fields (type, "
       "distinct values), feature counts, geometry types, CRS and box, and optionally every feature in "
       "the grid CRS (GeoJSON), for choosing the owner field and the grid."},
      {"version", "1.0.0"},
      {"keywords", json::array({"seeds", "fields", "inspect"})},
      {"jobControlOptions", json::array({"sync-execute"})},
      {"outputTransmission", json::array({"value"})},
      {"links",
       json::array({link(self, "self", "application/json"),
                    link(self + "/execution", "http://www.opengis.net/def/rel/ogc/1.0/execute", "application/json")})}};
}

json describe_seeds_description(const std::string& base, const ServerConfig& config) {
  json d = describe_seeds_summary(base);
  d["inputs"] = {
      {"seeds",
       {{"title", "Seed layers"},
        {"description",
         "As the voronoi process's seeds: a GeoJSON FeatureCollection, an array of layers, or a base64 "
         "GeoPackage, zipped Shapefile or FlatGeobuf."},
        {"schema",
         {{"oneOf", json::array({{{"type", "object"}},
                                 {{"type", "array"}, {"minItems", 1}, {"items", {{"type", "object"}}}}})}}},
        {"minOccurs", 1},
        {"maxOccurs", 1}}},
      {"crs", process_input_description(*find_input("crs"))},
      {"features",
       {{"title", "Features"},
        {"description",
         "Also return every feature, in the CRS (crs, else the first layer's), as a GeoJSON FeatureCollection "
         "whose ids are the features' 1-based positions in the input. Refused (422, too-large) above " +
             std::to_string(config.preview_max_vertices) + " vertices (this server's limits.preview_max_vertices)."},
        {"schema", {{"type", "boolean"}, {"default", false}}},
        {"minOccurs", 0},
        {"maxOccurs", 1}}}};
  d["outputs"] = {
      {"description",
       {{"title", "Description of the seed files"},
        {"description",
         "crs {name, code, wkt, geographic, metresPerUnit}, bbox in it, layers [{source, name, features, empty, "
         "geometryTypes, fields [{name, type, nonNull, distinct, distinctExact, values}]}], commonFields (in "
         "every layer: the owner field must be one), warnings, and features when asked. The response is this "
         "object itself."},
        {"schema", {{"type", "object"}, {"contentMediaType", "application/json"}}}}}};
  return d;
}

json describe_seeds_execute(const json& body, const ServerConfig& config, const std::function<void(int64_t)>& reserve) {
  check_body_members(body);
  const json& in = body.at("inputs");
  bool with_features = false;
  SeedReadOptions read;
  for (const auto& [key, value] : in.items()) {
    if (key == "seeds") continue;
    if (key == "crs") {
      read.target_crs = checked_crs(value, "crs");
    } else if (key == "features") {
      const json& v = literal(value, "features");
      if (!v.is_boolean()) throw Error(ErrorKind::invalid_argument, "input 'features': must be true or false");
      with_features = v.get<bool>();
    } else {
      throw Error(ErrorKind::invalid_argument,
                  "unknown input '" + quote_input(key) + "' (inputs: seeds, crs, features)");
    }
  }
  const std::string id = new_job_id();
  VsiMemFiles files("/vsimem/rvoronoi/" + id);
  stage_seed_input(in, read, files);
  read.on_reading_bytes = reserve;
  JobLimits limits = effective_limits(config);
  if (with_features)
    limits.max_vertices = limits.max_vertices > 0 ? std::min(limits.max_vertices, config.preview_max_vertices)
                                                  : config.preview_max_vertices;
  try {
    SeedInventory inventory = describe_seeds(read, limits, with_features);
    // The client knows its uploads as seeds[n], not by our in-memory paths.
    for (SeedLayerSummary& l : inventory.layers) l.source = client_names(l.source, id);
    for (std::string& w : inventory.warnings) w = client_names(w, id);
    return seed_description(inventory, with_features);
  } catch (const Error& e) {
    throw Error(e.kind(), client_names(e.what(), id));
  }
}

}  // namespace rv::daemon
