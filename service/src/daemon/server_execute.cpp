#include "daemon/server_execute.hpp"

#include <cpl_vsi.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <regex>
#include <set>
#include <thread>

#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/grid.hpp"
#include "rv/field/parallel.hpp"
#include "rv/field/text.hpp"
#include "rv/options.hpp"

namespace rv::daemon {
namespace {

using nlohmann::json;

[[noreturn]] void bad(const std::string& input, const std::string& why) {
  throw Error(ErrorKind::invalid_argument, "input '" + input + "': " + why);
}

std::string type_name(const json& v) { return v.type_name(); }

std::string string_value(const json& raw, const std::string& input) {
  const json& v = literal(raw, input);
  if (!v.is_string()) bad(input, "must be a string, got " + type_name(v));
  return v.get<std::string>();
}

bool all_digits(std::string_view s) {
  return !s.empty() && s.size() <= 9 && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// A string member of an object, or "" when it is absent or not a string: json::value() would
// throw nlohmann's type_error for a member of another type ({"type": 5}), which is not an
// rv::Error (found by tests/fuzz/fuzz_execute).
std::string text_member(const json& object, const char* key) {
  if (!object.is_object()) return {};
  const auto it = object.find(key);
  return it != object.end() && it->is_string() ? it->get<std::string>() : std::string();
}

bool has_prefix(std::string_view bytes, std::string_view magic) {
  return bytes.size() >= magic.size() && bytes.substr(0, magic.size()) == magic;
}

struct SeedFormat {
  const char* media_type;
  const char* extension;
  std::string_view magic;
  const char* description;
};

constexpr std::string_view kSqliteMagic{"SQLite format 3\0", 16};
const SeedFormat kUploadFormats[] = {
    {"application/geopackage+sqlite3", "gpkg", kSqliteMagic, "a GeoPackage"},
    {"application/zip", "zip", "PK\x03\x04", "a zip archive (zipped Shapefile)"},
    {"application/flatgeobuf", "fgb", "fgb\x03", "a FlatGeobuf file"},
};

// Writes one element of `seeds` to /vsimem/ and returns the name GDAL opens it by, plus the
// summary stored with the job.
std::pair<std::string, json> stage_seed_layer(const json& item, const std::string& input, const std::string& base,
                                              VsiMemFiles& files) {
  if (item.is_object() && item.contains("href")) {
    bad(input, "references (href) are not accepted; upload the data by value");
  }
  if (item.is_object() && text_member(item, "type") == "FeatureCollection") {
    if (!item.contains("features") || !item.at("features").is_array()) {
      bad(input, "FeatureCollection without a \"features\" array");
    }
    const std::string path = files.write(base + ".geojson", item.dump());
    return {path, json{{"type", "FeatureCollection"}, {"features", item.at("features").size()}}};
  }
  if (!item.is_object() || !item.contains("value")) {
    bad(input,
        "expected a GeoJSON FeatureCollection or a qualified value "
        "{\"value\", \"mediaType\", \"encoding\": \"base64\"}, got " +
            (item.is_object() ? std::string("an object of type '") + text_member(item, "type") + "'"
                              : type_name(item)));
  }
  const std::string media = text_member(item, "mediaType");
  const json& value = item.at("value");
  if (media.empty() || media == "application/geo+json" || media == "application/json") {
    if (value.is_object()) return stage_seed_layer(value, input, base, files);
    if (value.is_string()) {
      const std::string path = files.write(base + ".geojson", value.get<std::string>());
      return {path, json{{"mediaType", "application/geo+json"}, {"bytes", value.get<std::string>().size()}}};
    }
    bad(input, "GeoJSON value must be a FeatureCollection object or its text");
  }
  for (const SeedFormat& f : kUploadFormats) {
    if (media != f.media_type) continue;
    if (text_member(item, "encoding") != "base64") bad(input, "binary uploads need \"encoding\": \"base64\"");
    if (!value.is_string()) bad(input, "\"value\" must be the base64 text of " + std::string(f.description));
    const std::string bytes = base64_decode(value.get_ref<const std::string&>(), "input '" + input + "'");
    if (!has_prefix(bytes, f.magic)) {
      throw Error(ErrorKind::invalid_input,
                  "input '" + input + "': the uploaded data is not " + f.description + " (mediaType " + media + ")");
    }
    std::string path = files.write(base + "." + f.extension, bytes);
    // A zipped Shapefile is read through GDAL's zip file system, entirely in memory.
    if (std::string_view(f.extension) == "zip") path = "/vsizip/" + path;
    return {path, json{{"mediaType", media}, {"bytes", bytes.size()}}};
  }
  bad(input, "unsupported mediaType '" + media +
                 "' (accepted: application/geo+json, application/geopackage+sqlite3, application/zip, "
                 "application/flatgeobuf)");
}

const std::vector<OutputInfo>& output_table() {
  static const std::vector<OutputInfo> table = {
      {"ownership", "ownership", {{kMediaGeoTiff, "tif"}}},
      {"distance", "distance", {{kMediaGeoTiff, "tif"}}},
      {"nearestFeature", "nearest_feature", {{kMediaGeoTiff, "tif"}}},
      {"report", "report", {{kMediaJson, "json"}}, true},
      {"boundaries", "boundaries", {{kMediaGeoJson, "geojson"}, {kMediaGeoPackage, "gpkg"}}},
      {"tripoints", "tripoints", {{kMediaGeoJson, "geojson"}, {kMediaGeoPackage, "gpkg"}}},
      {"limits", "limits", {{kMediaGeoJson, "geojson"}, {kMediaGeoPackage, "gpkg"}}},
      {"regions", "regions", {{kMediaGeoJson, "geojson"}, {kMediaGeoPackage, "gpkg"}}},
      {"margin", "margin", {{kMediaGeoTiff, "tif"}}},
      {"preview", "preview", {{kMediaPng, "png"}}},
      {"turningPoints", "turning_points", {{kMediaJson, "json"}, {kMediaCsv, "csv"}}},
      {"changes", "changes", {{kMediaGeoTiff, "tif"}}},
      {"via", "via", {{kMediaGeoTiff, "tif"}}},
  };
  return table;
}

// Media types compare without case and blanks ("image/tiff;application=geotiff" is ours).
std::string media_key(std::string_view m) {
  std::string k;
  for (char c : m)
    if (!std::isspace(static_cast<unsigned char>(c)))
      k += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return k;
}

std::string id_list() {
  std::string s;
  for (const OutputInfo& o : output_table()) s += (s.empty() ? "" : ", ") + std::string(o.id);
  return s;
}

// The media type an output request asks for: OGC's "format": {"mediaType": ...}, or "".
std::string requested_media_type(const json& options, const std::string& id) {
  if (!options.contains("format")) return {};
  const json& f = options.at("format");
  if (!f.is_object()) bad("outputs", "output '" + id + "': \"format\" must be an object {\"mediaType\": ...}");
  if (!f.contains("mediaType")) return {};
  if (!f.at("mediaType").is_string()) bad("outputs", "output '" + id + "': \"format.mediaType\" must be a string");
  return f.at("mediaType").get<std::string>();
}

}  // namespace

void parse_outputs(const json& body, Execution& ex) {
  struct Chosen {
    std::string id, mode, media;
  };
  std::vector<Chosen> chosen;
  if (body.contains("outputs") && !body.at("outputs").empty()) {
    const json& outputs = body.at("outputs");
    if (!outputs.is_object()) bad("outputs", "must be an object keyed by output id");
    for (const auto& item : outputs.items()) {
      const std::string& id = item.key();
      const json& options = item.value();
      const OutputInfo* info = find_output(id);
      if (info == nullptr) {
        throw Error(ErrorKind::invalid_argument,
                    "output '" + id.substr(0, 64) + "': no such output (outputs: " + id_list() + ")");
      }
      std::string mode = info->by_value ? "value" : "reference";
      if (!options.is_object()) bad("outputs", "output '" + id + "' must map to an object");
      if (options.contains("transmissionMode")) {
        const json& m = options.at("transmissionMode");
        if (!m.is_string() || (m != "value" && m != "reference")) {
          throw Error(ErrorKind::invalid_argument,
                      "output '" + id + "': transmissionMode must be \"value\" or \"reference\"");
        }
        mode = m.get<std::string>();
      }
      if (!info->by_value && mode == "value") {
        throw Error(
            ErrorKind::invalid_argument,
            "output '" + id + "': file outputs (GeoTIFF, GeoJSON, GeoPackage, PNG) are returned by reference only");
      }
      chosen.push_back({id, mode, output_media_type(id, requested_media_type(options, id))});
    }
  } else {
    chosen = {{"ownership", "reference", kMediaGeoTiff},
              {"distance", "reference", kMediaGeoTiff},
              {"report", "value", kMediaJson}};
  }
  for (const OutputInfo& o : output_table()) {
    for (const Chosen& c : chosen) {
      if (c.id == o.id) {
        ex.outputs.push_back(c.id);
        ex.transmission.push_back(c.mode);
        ex.formats.push_back(c.media);
      }
    }
  }
  if (body.contains("response")) {
    const json& r = body.at("response");
    if (r != "raw" && r != "document") bad("response", "must be \"raw\" or \"document\"");
    ex.raw = r == "raw";
  }
  if (ex.raw && ex.outputs.size() != 1) {
    throw Error(ErrorKind::unsupported,
                "\"response\": \"raw\" needs exactly one requested output (multipart responses are "
                "not supported); request one output or use \"document\"");
  }
}

const OutputInfo* find_output(std::string_view id) {
  for (const OutputInfo& o : output_table())
    if (id == o.id) return &o;
  return nullptr;
}

std::string output_media_type(std::string_view id, std::string_view requested) {
  const OutputInfo* info = find_output(id);
  if (info == nullptr) throw Error(ErrorKind::invalid_argument, "output '" + std::string(id) + "': no such output");
  if (requested.empty()) return info->formats.front().media_type;
  const std::string key = media_key(requested);
  std::string accepted;
  for (const OutputFormat& f : info->formats) {
    if (media_key(f.media_type) == key) return f.media_type;
    // GeoTIFF may be asked for less precisely: every GeoTIFF this server writes is a COG.
    if (std::string_view(f.media_type) == kMediaGeoTiff &&
        (key == "image/tiff" || key == "image/tiff;application=geotiff")) {
      return f.media_type;
    }
    accepted += (accepted.empty() ? "" : ", ") + std::string(f.media_type);
  }
  throw Error(ErrorKind::invalid_argument, "output '" + std::string(id) + "': format '" +
                                               std::string(requested.substr(0, 80)) +
                                               "' is not available (accepted: " + accepted + ")");
}

std::string output_file_name(std::string_view id, std::string_view media_type) {
  const OutputInfo* info = find_output(id);
  if (info == nullptr) throw Error(ErrorKind::internal, "unknown output id " + std::string(id));
  for (const OutputFormat& f : info->formats)
    if (media_type.empty() || media_type == f.media_type) return std::string(info->stem) + "." + f.extension;
  throw Error(ErrorKind::internal, "output " + std::string(id) + " has no format " + std::string(media_type));
}

VsiMemFiles::~VsiMemFiles() {
  for (const std::string& f : files_) VSIUnlink(f.c_str());
}

std::string VsiMemFiles::write(const std::string& name, std::string_view bytes) {
  const std::string path = directory_ + "/" + name;
  VSILFILE* fp = VSIFOpenL(path.c_str(), "wb");
  if (fp == nullptr) throw Error(ErrorKind::io, "cannot create in-memory file " + path);
  files_.push_back(path);
  const size_t written = VSIFWriteL(bytes.data(), 1, bytes.size(), fp);
  VSIFCloseL(fp);
  if (written != bytes.size()) throw Error(ErrorKind::io, "cannot write in-memory file " + path);
  return path;
}

std::string checked_crs(const json& raw, const std::string& input) {
  const std::string s = string_value(raw, input);
  // OGC CRS URIs name an authority and a code; they are translated here, never resolved.
  for (const char* prefix : {"http://www.opengis.net/def/crs/EPSG/0/", "https://www.opengis.net/def/crs/EPSG/0/"}) {
    if (starts_with_ci(s, prefix)) {
      const std::string code = s.substr(std::string_view(prefix).size());
      if (!all_digits(code)) bad(input, "EPSG URI without a numeric code: '" + quote_input(s) + "'");
      return "EPSG:" + code;
    }
  }
  for (const char* crs84 :
       {"http://www.opengis.net/def/crs/OGC/1.3/CRS84", "https://www.opengis.net/def/crs/OGC/1.3/CRS84", "OGC:CRS84",
        "urn:ogc:def:crs:OGC:1.3:CRS84"}) {
    if (s == crs84) return "OGC:CRS84";
  }
  if (starts_with_ci(s, "EPSG:") && all_digits(s.substr(5))) return "EPSG:" + s.substr(5);
  if (starts_with_ci(s, "urn:ogc:def:crs:EPSG::") && all_digits(s.substr(22))) return "EPSG:" + s.substr(22);
  // WKT (1 or 2): a keyword then '['. Parsed by OSR from the text itself, no file access.
  size_t k = 0;
  while (k < s.size() && std::isupper(static_cast<unsigned char>(s[k]))) ++k;
  if (k >= 4 && k < s.size() && s[k] == '[') return s;
  bad(input, "CRS must be EPSG:<code>, an OGC CRS URI (http://www.opengis.net/def/crs/...) or WKT; got '" +
                 s.substr(0, 80) + "'");
}

// OGC inputs may be given bare or as a qualified value {"value": ..., "mediaType": ...}; for
// the literal inputs both mean the same. References are refused: the server never fetches.
const json& literal(const json& v, const std::string& input) {
  if (v.is_object()) {
    if (v.contains("href")) bad(input, "references (href) are not accepted; send the value itself");
    if (v.contains("value")) return v.at("value");
  }
  return v;
}

void check_body_members(const json& body) {
  if (!body.is_object()) bad("(body)", "the execute request must be a JSON object");
  for (const auto& [key, value] : body.items()) {
    if (key == "subscriber") {
      throw Error(ErrorKind::unsupported, "callbacks (\"subscriber\") are not supported; poll /jobs/{jobId}");
    }
    if (key != "inputs" && key != "outputs" && key != "response") {
      throw Error(ErrorKind::invalid_argument, "execute request: unknown member '" + quote_input(key) + "'");
    }
  }
  if (!body.contains("inputs") || !body.at("inputs").is_object()) {
    bad("inputs", "the execute request needs an \"inputs\" object");
  }
}

// Upload paths in messages are ours (/vsimem/rvoronoi/<id>/seeds_<n>.<ext>, <input>.<ext>,
// <input>_<n>.<ext> for the other uploads of the option table); the client knows its layers as
// seeds[n], barriers[n] and the inputs by name.
std::string client_names(std::string message, const std::string& id) {
  // A claimed attempt stages under "<id>-a<attempt>" (parse_execution's `staging`).
  const std::string dir = "(/vsizip/)?/vsimem/rvoronoi/" + id + "(?:-a[0-9]+)?/";
  std::string inputs;
  for (const OptionSpec& o : job_options())
    if (o.type == OptionType::layers) inputs += (inputs.empty() ? "" : "|") + std::string(o.input);
  const std::regex listed(dir + "(" + inputs + ")_([0-9]+)\\.[a-z]+");
  const std::regex named(dir + "(" + inputs + ")\\.[a-z]+");
  return std::regex_replace(std::regex_replace(message, listed, "$2[$3]"), named, "$2");
}

json stage_seed_input(const json& in, SeedReadOptions& read, VsiMemFiles& files) {
  if (!in.contains("seeds")) bad("seeds", "is required");
  const json& seeds = in.at("seeds");
  json summary = json::array();
  if (seeds.is_array()) {
    if (seeds.empty()) bad("seeds", "the array of layers is empty");
    for (size_t i = 0; i < seeds.size(); ++i) {
      auto [path, s] =
          stage_seed_layer(seeds[i], "seeds[" + std::to_string(i) + "]", "seeds_" + std::to_string(i), files);
      read.paths.push_back(path);
      summary.push_back(s);
    }
  } else {
    auto [path, s] = stage_seed_layer(seeds, "seeds", "seeds_0", files);
    read.paths.push_back(path);
    summary.push_back(s);
  }
  read.allowed_drivers = {"GeoJSON", "GPKG", "ESRI Shapefile", "FlatGeobuf"};
  // Uploads are untrusted: in-memory paths only, no network, no other files (rv/gdal/seed_reader.hpp).
  read.confined = true;
  return summary;
}

namespace {

// seeds: one layer or an array of layers, staged in /vsimem/.
void stage_seeds(const json& in, Execution& ex) {
  ex.inputs_summary["seeds"] = stage_seed_input(in, ex.spec.seeds, *ex.uploads);
  // The other uploads of the option table (the disproportionality test's layers), uploaded as
  // the seeds are (and read as confined), each put into the job by its option.
  for (const OptionSpec& o : job_options()) {
    const std::string input(o.input);
    if (o.type != OptionType::layers || input == "seeds" || !in.contains(input)) continue;
    const json& value = in.at(input);
    // A repeatable upload (the barriers) may be an array of layers, staged as <input>_<n>.
    if (o.repeatable && value.is_array()) {
      if (value.empty()) bad(input, "the array of layers is empty");
      json summary = json::array();
      for (size_t i = 0; i < value.size(); ++i) {
        auto [path, s] = stage_seed_layer(value[i], input + "[" + std::to_string(i) + "]",
                                          input + "_" + std::to_string(i), *ex.uploads);
        OptionValue v;
        v.text = path;
        o.apply(ex.spec, v);
        summary.push_back(s);
      }
      ex.inputs_summary[input] = summary;
      continue;
    }
    auto [path, s] = stage_seed_layer(value, input, input, *ex.uploads);
    OptionValue v;
    v.text = path;
    o.apply(ex.spec, v);
    ex.inputs_summary[input] = s;
  }
}

// Every other input, through the option table (rv/options.hpp). CRS definitions from a client
// are restricted further (checked_crs: no definition that names a file or URL to open).
void apply_inputs(const json& in, Execution& ex) {
  std::string bbox_crs;
  for (const auto& [key, value] : in.items()) {
    const OptionSpec* option = find_input(key);
    if (option == nullptr) {
      throw Error(ErrorKind::invalid_argument,
                  "unknown input '" + quote_input(key) + "' (see GET /processes/voronoi for the inputs)");
    }
    if (option->type == OptionType::layers) continue;  // uploads: staged above
    OptionValue v = parse_input_value(*option, value);
    if (key == "crs") v.text = checked_crs(value, "crs");
    if (!v.box_crs.empty()) bbox_crs = checked_crs(v.box_crs, "extent.crs");
    option->apply(ex.spec, v);
    ex.inputs_summary[key] = value;
  }
  if (in.contains("resolution") == false) bad("resolution", "is required (cell size in grid-CRS units)");
  // The box defines the grid's CRS when no `crs` input is given; both must agree otherwise.
  std::string& crs = ex.spec.seeds.target_crs;
  if (!bbox_crs.empty()) {
    if (crs.empty()) {
      crs = bbox_crs;
    } else if (crs != bbox_crs) {
      bad("extent", "the bbox CRS (" + bbox_crs + ") differs from the 'crs' input (" + crs +
                        "); give the extent in the grid's CRS");
    }
  }
}

// With an explicit extent the grid size is known now: refuse an oversized job before it is
// queued (run_job checks again, with the memory estimate, once the seeds are read).
// Returns the cell count (0 when it is not known yet).
int64_t check_grid_limits(const JobSpec& spec, const ServerConfig& config) {
  if (!spec.grid.extent) return 0;
  const auto& b = *spec.grid.extent;
  const GridSpec g = make_grid(b[0], b[1], b[2], b[3], *spec.grid.resolution, "");
  if (g.cell_count() > config.limits.max_cells) {
    throw Error(ErrorKind::too_large, "input 'resolution': the grid would have " + std::to_string(g.width) + " x " +
                                          std::to_string(g.height) + " cells, over this server's limit of " +
                                          std::to_string(config.limits.max_cells));
  }
  if (spec.validate && g.cell_count() > config.limits.validate_max_cells) {
    throw Error(ErrorKind::too_large, "input 'validate': brute-force validation is limited to " +
                                          std::to_string(config.limits.validate_max_cells) +
                                          " cells on this server; the grid has " + std::to_string(g.cell_count()));
  }
  return g.cell_count();
}

// The limit inputs and the limits output go together: either alone is a mistake to report
// now, not a job that fails (or silently ignores an input) later.
void check_limits_pairing(const json& in, const Execution& ex) {
  const bool limits = std::find(ex.outputs.begin(), ex.outputs.end(), "limits") != ex.outputs.end();
  if (limits && ex.spec.outputs.limit_distances.empty()) {
    bad("limitDistances", "is required with the output 'limits' (e.g. [\"12nmi\", \"24nmi\"])");
  }
  if (!limits && (in.contains("limitDistances") || in.contains("limitsPerOwner"))) {
    bad(in.contains("limitDistances") ? "limitDistances" : "limitsPerOwner",
        "applies to the output 'limits', which is not requested");
  }
}

// The changes raster is an edit's: without a base job it is a mistake to report now.
void check_changes_pairing(const Execution& ex) {
  const bool changes = std::find(ex.outputs.begin(), ex.outputs.end(), "changes") != ex.outputs.end();
  if (changes && ex.spec.base_name.empty())
    throw Error(ErrorKind::invalid_argument, "output 'changes': needs the input baseJob (the job this one edits)");
}

// The via raster is the distance by sea's: without barriers it is a mistake to report now.
void check_via_pairing(const Execution& ex) {
  const bool via = std::find(ex.outputs.begin(), ex.outputs.end(), "via") != ex.outputs.end();
  if (via && ex.spec.barriers.empty())
    throw Error(ErrorKind::invalid_argument, "output 'via': needs the input barriers (it is the distance by sea's)");
}

}  // namespace

Execution parse_execution(const json& body, const std::string& job_id, const ServerConfig& config,
                          const std::string& staging) {
  check_body_members(body);
  const json& in = body.at("inputs");
  Execution ex;
  ex.inputs_summary = json::object();
  ex.uploads = std::make_shared<VsiMemFiles>("/vsimem/rvoronoi/" + (staging.empty() ? job_id : staging));
  stage_seeds(in, ex);
  apply_inputs(in, ex);
  const int workers = std::max(1, config.jobs.workers);
  ex.spec.threads =
      config.jobs.threads_per_job > 0 ? config.jobs.threads_per_job : std::max(1, resolve_threads(0) / workers);
  ex.cells = check_grid_limits(ex.spec, config);
  parse_outputs(body, ex);
  check_limits_pairing(in, ex);
  check_changes_pairing(ex);
  check_via_pairing(ex);
  return ex;
}

}  // namespace rv::daemon
