// The process description of "voronoi" (OGC API - Processes): its summary, every input from the
// option table (rv/options.hpp) and its outputs. The daemon serves it at /processes/voronoi, the
// Python module returns it (rvoronoi.process_description()), and clients such as the QGIS provider
// are made from it.
#include <nlohmann/json.hpp>

#include "rv/options.hpp"

namespace rv {
namespace {

using nlohmann::json;

json link(const std::string& href, const std::string& rel, const std::string& title) {
  return {{"href", href}, {"rel", rel}, {"type", "application/json"}, {"title", title}};
}

}  // namespace

std::string* output_path(OutputRequest& out, std::string_view id) {
  const std::pair<std::string_view, std::string*> paths[] = {{"ownership", &out.ownership},
                                                             {"distance", &out.distance},
                                                             {"nearestFeature", &out.nearest_feature},
                                                             {"report", &out.report},
                                                             {"boundaries", &out.boundaries},
                                                             {"tripoints", &out.tripoints},
                                                             {"limits", &out.limits},
                                                             {"regions", &out.regions},
                                                             {"margin", &out.margin},
                                                             {"preview", &out.preview},
                                                             {"turningPoints", &out.turning_points},
                                                             {"changes", &out.changes},
                                                             {"via", &out.via}};
  for (const auto& [name, path] : paths)
    if (name == id) return path;
  return nullptr;
}

json process_summary(const std::string& base) {
  return {
      {"id", "voronoi"},
      {"title", "Raster Voronoi diagram"},
      {"description",
       "For every cell of a raster grid, the owner of the nearest seed (points, lines or polygons) and "
       "the distance to it; geodesic on longitude/latitude grids. Used for maritime boundary delimitation."},
      {"version", "1.0.0"},
      {"keywords", json::array({"voronoi", "raster", "nearest", "delimitation"})},
      {"jobControlOptions", json::array({"sync-execute", "async-execute", "dismiss"})},
      {"outputTransmission", json::array({"value", "reference"})},
      {"links", json::array({link(base + "/processes/voronoi", "self", "process description"),
                             link(base + "/processes/voronoi/execution",
                                  "http://www.opengis.net/def/rel/ogc/1.0/execute", "execute the process")})},
  };
}

json process_description(const std::string& base) {
  json d = process_summary(base);
  static const json outputs = json::parse(R"json({
    "ownership": {"title": "Ownership raster", "description": "Owner codes (0 = none) in the narrowest integer type that holds them (Byte up to 255 owners, UInt16 up to 65535, else Int32), a Cloud Optimized GeoTIFF with a raster attribute table (served also as ownership.aux.xml).",
      "schema": {"type": "string", "contentEncoding": "binary", "contentMediaType": "image/tiff; application=geotiff; profile=cloud-optimized"}},
    "distance": {"title": "Distance raster", "description": "Float32 distance to the nearest seed (-1 = none), a Cloud Optimized GeoTIFF.",
      "schema": {"type": "string", "contentEncoding": "binary", "contentMediaType": "image/tiff; application=geotiff; profile=cloud-optimized"}},
    "nearestFeature": {"title": "Nearest-feature raster", "description": "1-based position of the nearest seed feature in the input (0 = none), in the narrowest integer type that holds them (Byte, UInt16 or Int32), a Cloud Optimized GeoTIFF.",
      "schema": {"type": "string", "contentEncoding": "binary", "contentMediaType": "image/tiff; application=geotiff; profile=cloud-optimized"}},
    "report": {"title": "Job report", "description": "What was computed: grid, seeds, method, timings, validation, deliverables.",
      "schema": {"type": "object", "contentMediaType": "application/json"}},
    "boundaries": {"title": "Boundary (equidistance) lines", "description": "For every pair of owners that touch, the lines where the distances to both are equal, every vertex placed on the exact locus with the grid's metric. Line features with owner_a < owner_b (codes), label_a, label_b, closed, max_residual, units, and the controlling seed features per vertex (features_a, features_b); the GeoPackage adds a layer boundary_vertices with each vertex's basepoints. GeoJSON (default) or GeoPackage by format.mediaType.",
      "schema": {"oneOf": [
        {"type": "object", "contentMediaType": "application/geo+json"},
        {"type": "string", "contentEncoding": "binary", "contentMediaType": "application/geopackage+sqlite3"}]}},
    "tripoints": {"title": "Tripoints", "description": "Points equidistant from three owners' nearest seeds: owner_1..3, label_1..3, feature_1..3, distance, residual, units. GeoJSON (default) or GeoPackage.",
      "schema": {"oneOf": [
        {"type": "object", "contentMediaType": "application/geo+json"},
        {"type": "string", "contentEncoding": "binary", "contentMediaType": "application/geopackage+sqlite3"}]}},
    "limits": {"title": "Distance-limit lines", "description": "Lines at the distances of the input limitDistances from the seeds (all owners, or per owner with limitsPerOwner): distance, units, owner (0 = all), label, closed, max_residual. GeoJSON (default) or GeoPackage.",
      "schema": {"oneOf": [
        {"type": "object", "contentMediaType": "application/geo+json"},
        {"type": "string", "contentEncoding": "binary", "contentMediaType": "application/geopackage+sqlite3"}]}},
    "regions": {"title": "Ownership regions", "description": "One multipolygon per owner from the ownership raster (8-connected cells): owner, label, cells, area. GeoJSON (default) or GeoPackage.",
      "schema": {"oneOf": [
        {"type": "object", "contentMediaType": "application/geo+json"},
        {"type": "string", "contentEncoding": "binary", "contentMediaType": "application/geopackage+sqlite3"}]}},
    "margin": {"title": "Margin raster", "description": "Float32: distance to the nearest seed of another owner minus distance to the own nearest seed (>= 0; -1 = no owner or a single owner), in distanceUnits, a Cloud Optimized GeoTIFF.",
      "schema": {"type": "string", "contentEncoding": "binary", "contentMediaType": "image/tiff; application=geotiff; profile=cloud-optimized"}},
    "turningPoints": {"title": "Turning points", "description": "The boundary lines' turning points as a treaty table: where the pair of controlling basepoints changes, in decimal degrees and degrees-minutes-seconds with the datum, each side's basepoints (feature, owner, position, distance), and per segment to the next point its geodesic length and initial azimuth, the rhumb line's separation from the geodesic and the true line's largest distance from the geodesic segment. JSON (default) or CSV (text/csv, one row per point).",
      "schema": {"oneOf": [
        {"type": "object", "contentMediaType": "application/json"},
        {"type": "string", "contentMediaType": "text/csv"}]}},
    "via": {"title": "Via raster", "description": "With barriers (the distance by sea): the number of the last barrier vertex on each cell's path (0 = the seed seen directly, or none reached), in the narrowest integer type that holds them, a Cloud Optimized GeoTIFF; the report's sea.via_vertices gives each number's position in the grid's CRS.",
      "schema": {"type": "string", "contentEncoding": "binary", "contentMediaType": "image/tiff; application=geotiff; profile=cloud-optimized"}},
    "changes": {"title": "Changes raster", "description": "With baseJob: 1 where the edit changed a cell's owner, 2 where only its distance changed, 0 elsewhere (Byte).",
      "schema": {"type": "string", "contentEncoding": "binary", "contentMediaType": "image/tiff; application=geotiff; profile=cloud-optimized"}},
    "preview": {"title": "Quicklook", "description": "PNG map: each owner's sea in its colour, land (inside the seed polygons), boundaries and dashed limit lines, owner labels, a legend with the owners' sea areas (when regions are made) and a scale bar; one pixel per cell, or per n x n cells (the smallest integer n keeping the long side within 2000 px; the report's deliverables.preview gives it).",
      "schema": {"type": "string", "contentEncoding": "binary", "contentMediaType": "image/png"}}
  })json");
  // Every input comes from the option table, in its order (rv/options.hpp), uploads included.
  json all = json::object();
  for (const OptionSpec& o : job_options())
    if (!o.input.empty()) all[std::string(o.input)] = process_input_description(o);
  d["inputs"] = all;
  d["outputs"] = outputs;
  return d;
}

}  // namespace rv
