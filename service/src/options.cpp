// The option table (rv/options.hpp) and the parsing, help and description made from it.
#include "rv/options.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "rv/error.hpp"
#include "rv/text.hpp"

namespace rv {
namespace {

using nlohmann::json;

// The first spelling of a choice ("hv-scan|hv_scan" -> "hv-scan") and whether `s` is one of its.
std::string_view canonical(std::string_view choice) { return choice.substr(0, choice.find('|')); }
bool spells(std::string_view choice, std::string_view s) {
  size_t start = 0;
  while (start <= choice.size()) {
    const size_t end = std::min(choice.find('|', start), choice.size());
    if (choice.substr(start, end - start) == s) return true;
    start = end + 1;
  }
  return false;
}

std::string all_spellings(const OptionSpec& o, const char* sep) {
  std::string out;
  for (std::string_view c : o.choices) {
    size_t start = 0;
    while (start <= c.size()) {
      const size_t end = std::min(c.find('|', start), c.size());
      out += (out.empty() ? "" : sep) + std::string(c.substr(start, end - start));
      start = end + 1;
    }
  }
  return out;
}

// Where a value came from, for messages: "--resolution" or "input 'resolution'".
struct Source {
  std::string name;
  [[noreturn]] void bad(const std::string& why) const { throw Error(ErrorKind::invalid_argument, name + ": " + why); }
};

void check_number(const OptionSpec& o, double v, const Source& src) {
  if (!std::isfinite(v)) src.bad("must be a finite number");
  if (o.type == OptionType::positive_number && !(v > 0.0)) src.bad("must be a finite number > 0");
  if (o.type == OptionType::nonnegative_number && !(v >= 0.0)) src.bad("must be a finite number >= 0");
}

OptionValue choice_value(const OptionSpec& o, std::string_view s, const Source& src) {
  for (std::string_view c : o.choices) {
    if (spells(c, s)) {
      OptionValue v;
      v.text = std::string(canonical(c));
      return v;
    }
  }
  src.bad("must be one of " + all_spellings(o, ", ") + ", got '" + quote_input(s) + "'");
}

double text_number(std::string_view text, const Source& src) {
  const std::string s(text);
  char* end = nullptr;
  const double d = std::strtod(s.c_str(), &end);
  // The whole text must be the number (an embedded NUL stops strtod early).
  if (s.empty() || end != s.c_str() + s.size()) src.bad("'" + quote_input(text) + "' is not a number");
  return d;
}

// Each distance checked by the façade's own parser; `indexed`: the message names the item
// ("input 'limitDistances[1]'"), as a JSON array's reader finds it.
std::vector<std::string> checked_distances(std::vector<std::string> items, const Source& src, bool indexed) {
  if (items.empty()) src.bad("needs at least one distance");
  if (items.size() > 64) src.bad("at most 64 distances");
  for (size_t i = 0; i < items.size(); ++i) {
    try {
      parse_limit_distance(items[i]);
    } catch (const Error& e) {
      if (!indexed) src.bad(e.what());
      const std::string& n = src.name;
      Source{n.substr(0, n.size() - 1) + "[" + std::to_string(i) + "]'"}.bad(e.what());
    }
  }
  return items;
}

// The JSON form of one limit distance: "12nmi", 12 or {"value": 12, "unit": "nmi"}.
std::string distance_text(const json& d, const Source& src) {
  if (d.is_string()) return d.get<std::string>();
  if (d.is_number()) return d.dump();
  if (d.is_object() && d.contains("value") && d.at("value").is_number()) {
    std::string text = d.at("value").dump();
    if (d.contains("unit")) {
      if (!d.at("unit").is_string()) src.bad("\"unit\" must be a string (m, km or nmi)");
      text += d.at("unit").get<std::string>();
    }
    return text;
  }
  src.bad("must be a string such as \"12nmi\", a number, or {\"value\": 12, \"unit\": \"nmi\"}");
}

std::array<double, 4> box_from_json(const json& array, const Source& src) {
  if (!array.is_array() || array.size() != 4)
    src.bad("must be [xmin, ymin, xmax, ymax] (4 numbers; 3-D boxes are not supported)");
  std::array<double, 4> b{};
  for (size_t i = 0; i < 4; ++i) {
    if (!array[i].is_number()) src.bad("coordinate " + std::to_string(i) + " is not a number");
    b[i] = array[i].get<double>();
    if (!std::isfinite(b[i])) src.bad("coordinate " + std::to_string(i) + " is not finite");
  }
  if (!(b[0] < b[2]) || !(b[1] < b[3])) src.bad("needs xmin < xmax and ymin < ymax");
  return b;
}

// --- what each option does to the job ---------------------------------------------------------

Method method_of(std::string_view s) { return parse_method(s); }

const std::vector<OptionSpec> kOptions = {
    // seeds
    {"",
     "layer",
     OptionType::text,
     "NAME",
     "seeds",
     "Layer",
     "read only this layer (repeatable; default: every layer)",
     "",
     {},
     0,
     0,
     true,
     false,
     [](JobSpec& s, const OptionValue& v) { s.seeds.layers.push_back(v.text); }},
    {"ownerField",
     "owner-field",
     OptionType::text,
     "FIELD",
     "seeds",
     "Owner field",
     "Attribute naming each feature's owner; features with the same value share an owner. Without it every "
     "feature is its own owner.",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.seeds.owner_field = v.text; }},
    {"weightField",
     "weight-field",
     OptionType::text,
     "FIELD",
     "seeds",
     "Weight field",
     "Numeric attribute giving each feature a weight w (> 0; a null value is an error): its distance d counts "
     "as d / w when cells are assigned (multiplicatively weighted, equiratio lines: the boundary of A and B is "
     "where d_A / w_A = d_B / w_B, and may close round an enclave). The distance raster keeps the true "
     "distance to the winning feature; distance limits measure true distances. Needs the exact or brute-force "
     "method. Default: every weight 1.",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.seeds.weight_field = v.text; }},
    {"reachField",
     "reach-field",
     OptionType::text,
     "FIELD",
     "seeds",
     "Reach field",
     "Numeric attribute giving a feature a reach in the job's distance units (> 0; null: no reach): the feature "
     "counts only where its true distance is within it, beyond as if absent (an island with a reach of 12 nmi "
     "is enclaved in a 12 nmi arc, and its boundary follows the arc exactly; where reaches leave cells unowned, "
     "regions end on the edge of what they cover, and the turning-point report names the arcs). Needs the exact "
     "or brute-force method.",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.seeds.reach_field = v.text; }},
    {"effectField",
     "effect-field",
     OptionType::text,
     "FIELD",
     "seeds",
     "Effect field",
     "Numeric attribute giving a feature a partial effect e from 0 to 1 (null: 1), for one owner's islands: "
     "between that owner's line with them absent (L0, nil effect) and with them at full effect (L1), the line "
     "is where (1 - e) d(L0) = e d(L1), so 0.5 is half effect, the median line between L0 and L1; elsewhere "
     "nothing changes. One owner's features with e < 1 share one value, and only one owner has them. Rasters "
     "and lines follow, pair by pair where the islands' zone meets each neighbour (a tripoint of the "
     "owner and two neighbours moves to where the two partial lines meet their nil-effect line). Needs the "
     "exact or brute-force "
     "method, a field computed whole, and not reaches, the margin raster or the turning-point report.",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.seeds.effect_field = v.text; }},
    {"",
     "on-conflict",
     OptionType::choice,
     "POLICY",
     "seeds",
     "Conflict policy",
     "when the geometry of two owners overlaps: error, or lower-code (the lower owner code takes the overlap, "
     "reported as a warning)",
     "error",
     {"error", "lower-code"},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) {
       s.seeds.on_conflict = v.text == "error" ? ConflictPolicy::error : ConflictPolicy::lower_code;
     }},
    {"borderTolerance",
     "border-tolerance",
     OptionType::nonnegative_number,
     "METRES",
     "seeds",
     "Land-border tolerance",
     "Two owners' polygons that overlap only by slivers holding no disc of this diameter (metres; CRS units "
     "for data without a CRS) share a land border: not a conflict. Reprojecting countries that share a border "
     "leaves such slivers. They are listed in the report (seeds.land_border_slivers), and the lower owner code "
     "takes them. 0 makes every overlap a conflict.",
     "0.01",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.seeds.border_tolerance = v.number; }},
    {"transformAccuracy",
     "transform-accuracy",
     OptionType::nonnegative_number,
     "METRES",
     "seeds",
     "Accepted datum transformation accuracy",
     "A layer in another datum than the grid's is refused when the coordinate operation PROJ can use for "
     "its area is less accurate than this (metres) or states no accuracy; the error names the operation and "
     "the grid files a better one needs. Every layer's operation and accuracy are in the report "
     "(seeds.transformations).",
     "1",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.seeds.transform_accuracy = v.number; }},
    {"allowBallpark",
     "allow-ballpark",
     OptionType::flag,
     "",
     "seeds",
     "Allow ballpark transformations",
     "Accept a layer whose only usable operation is a ballpark one (the datum shift ignored or guessed: "
     "errors of the order of 100 m) or less accurate than the accepted accuracy; it is then a warning in the "
     "report.",
     "false",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.seeds.allow_ballpark = v.flag; }},
    // grid
    {"resolution",
     "resolution",
     OptionType::positive_number,
     "R",
     "grid",
     "Cell size",
     "Cell size in grid-CRS units (degrees on geographic grids).",
     "",
     {},
     0,
     0,
     false,
     true,
     [](JobSpec& s, const OptionValue& v) { s.grid.resolution = v.number; }},
    {"extent",
     "extent",
     OptionType::extent,
     "XMIN YMIN XMAX YMAX",
     "grid",
     "Grid extent",
     "xmin, ymin, xmax, ymax in the grid CRS; default: the seeds' box grown by the margin (5 % of its larger "
     "side), snapped to whole cells. As an OGC bbox, its crs (if any) sets the grid CRS and must agree with the "
     "crs input.",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.grid.extent = v.box; }},
    {"",
     "margin",
     OptionType::nonnegative_number,
     "M",
     "grid",
     "Margin",
     "growth of the seeds' box on every side, CRS units (default: 5 % of its larger side)",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.grid.margin = v.number; }},
    {"crs",
     "crs",
     OptionType::text,
     "CRS",
     "grid",
     "Grid CRS",
     "EPSG:<code>, an OGC CRS URI or WKT (the CLI takes any definition GDAL reads); default: the first layer's "
     "CRS.",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.seeds.target_crs = v.text; }},
    {"",
     "like",
     OptionType::file,
     "RASTER.tif",
     "grid",
     "Template raster",
     "take extent, cell size and CRS from this raster",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.grid.like = v.text; }},
    // computation
    {"method",
     "method",
     OptionType::choice,
     "M",
     "computation",
     "Method",
     "exact (tile culling with provably safe bounds: every cell exact), hv-scan (the horizontal-vertical 3x3 "
     "scan of Liu et al. 2019), h-scan (its horizontal cycle alone), brute-force (every cell against every "
     "seed).",
     "exact",
     {"exact", "hv-scan|hv_scan", "h-scan|h_scan", "brute-force|brute_force"},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.method = method_of(v.text); }},
    {"metric",
     "metric",
     OptionType::choice,
     "M",
     "computation",
     "Distance metric",
     "auto, planar or geodesic. auto: geodesic on a longitude/latitude grid CRS, planar on a projected one. "
     "geodesic on a projected grid CRS locates each cell centre on the CRS's ellipsoid and measures metres "
     "there (every method; the margin raster is refused for it).",
     "auto",
     {"auto", "planar", "geodesic"},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.metric = parse_metric_request(v.text); }},
    {"",
     "threads",
     OptionType::count,
     "N",
     "computation",
     "Threads",
     "worker threads (0 = all cores)",
     "0",
     {},
     0,
     1024,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.threads = static_cast<int>(v.count); }},
    {"maxDistance",
     "max-distance",
     OptionType::positive_number,
     "D",
     "computation",
     "Maximum distance",
     "Cells farther than this from every seed get no owner, in the distance units.",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.max_distance = v.number; }},
    {"distanceUnits",
     "distance-units",
     OptionType::choice,
     "U",
     "computation",
     "Distance units",
     "m, km or nmi: the unit of the distances written, of the maximum distance and of plain limit distances "
     "(default: the CRS's units on planar grids, metres on geodesic ones).",
     "",
     {"m", "km", "nmi"},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.distance_units = parse_distance_unit(v.text); }},
    {"validate",
     "validate",
     OptionType::flag,
     "",
     "computation",
     "Validate",
     "Also compute by brute force and report every cell that differs (limited grid size).",
     "false",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.validate = v.flag; }},
    {"",
     "strip-rows",
     OptionType::count,
     "N",
     "computation",
     "Rows per strip",
     "rows per strip when the job is streamed (0 = automatic; -1 = compute the whole field first); never "
     "changes the outputs",
     "0",
     {},
     -1,
     int64_t{1} << 31,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.strip_rows = v.count; }},
    // outputs
    {"",
     "ownership",
     OptionType::file,
     "OWN.tif",
     "outputs",
     "Ownership raster",
     "owner code per cell (0 = none; Byte up to 255 owners, UInt16 up to 65535, else Int32)",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.ownership = v.text; }},
    {"",
     "distance",
     OptionType::file,
     "DIST.tif",
     "outputs",
     "Distance raster",
     "distance to the nearest seed (Float32, -1 = none)",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.distance = v.text; }},
    {"",
     "nearest-feature",
     OptionType::file,
     "F.tif",
     "outputs",
     "Nearest-feature raster",
     "1-based position of the nearest seed feature (0 = none; type as ownership)",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.nearest_feature = v.text; }},
    {"",
     "report",
     OptionType::file,
     "FILE.json",
     "outputs",
     "Report",
     "grid, method, seeds, timings per phase, memory",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.report = v.text; }},
    {"",
     "cog",
     OptionType::flag,
     "",
     "outputs",
     "Cloud-Optimized GeoTIFF",
     "write Cloud-Optimized GeoTIFFs",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.cloud_optimized = v.flag; }},
    {"compression",
     "compression",
     OptionType::choice,
     "PROFILE",
     "outputs",
     "GeoTIFF compression",
     "How the raster outputs are compressed, all lossless: fast (the code rasters ZSTD level 1 with predictor 2, "
     "Float32 rasters uncompressed: no lossless codec saves more than a tenth of a distance raster cheaply), "
     "small (ZSTD level 6 with predictors: the smallest files, slower), deflate (DEFLATE level 1 with "
     "predictors, for readers without ZSTD), none (uncompressed).",
     "fast",
     {"fast", "small", "deflate", "none"},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.compression = parse_compression(v.text); }},
    // deliverables
    {"",
     "boundaries",
     OptionType::file,
     "FILE",
     "deliverables",
     "Boundary lines",
     "boundary lines between owners, with each vertex's controlling seed features (.geojson, .json or .gpkg)",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.boundaries = v.text; }},
    {"",
     "tripoints",
     OptionType::file,
     "FILE",
     "deliverables",
     "Tripoints",
     "points where three owners meet",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.tripoints = v.text; }},
    {"",
     "limits",
     OptionType::file,
     "FILE",
     "deliverables",
     "Limit lines",
     "lines at the limit distances from the seeds",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.limits = v.text; }},
    {"limitDistances",
     "limit-distances",
     OptionType::distance_list,
     "LIST",
     "deliverables",
     "Limit distances",
     "Distances of the limit lines (required with them, refused without them): \"12nmi\", \"24 nmi\", "
     "\"500m\", \"3.5km\", a plain number in the distance units, or {\"value\": 12, \"unit\": \"nmi\"}; on "
     "the CLI a comma-separated list (12nmi,24nmi). Each > 0 and within the maximum distance.",
     "",
     {},
     0,
     0,
     true,
     false,
     [](JobSpec& s, const OptionValue& v) {
       s.outputs.limit_distances.insert(s.outputs.limit_distances.end(), v.items.begin(), v.items.end());
     }},
    {"limitsPerOwner",
     "limits-per-owner",
     OptionType::flag,
     "",
     "deliverables",
     "Limits per owner",
     "One set of limit lines per owner (distance to that owner's seeds) instead of one for all seeds.",
     "false",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.limits_per_owner = v.flag; }},
    {"",
     "regions",
     OptionType::file,
     "FILE",
     "deliverables",
     "Regions",
     "one (multi)polygon per owner bounded by the boundary lines, with its land and sea areas",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.regions = v.text; }},
    {"",
     "turning-points",
     OptionType::file,
     "FILE",
     "deliverables",
     "Turning points",
     "the boundary lines' turning points as a treaty table (.json or .csv): where the pair of controlling "
     "basepoints changes, in decimal degrees and degrees-minutes-seconds with the datum, each side's basepoints "
     "and distances, and per segment to the next point its geodesic length and azimuth, the rhumb line's "
     "separation from the geodesic and the true line's largest distance from it",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.turning_points = v.text; }},
    {"",
     "relevant-area",
     OptionType::file,
     "FILE",
     "deliverables",
     "Relevant area",
     "polygons of the disproportionality test's relevant area: each owner's sea and land area within it, its "
     "relevant coast (the parts of its seeds nearest to the area's cells) and the ratio of its shares go into "
     "the report (deliverables.regions.relevant_area); the regions are made for it even without --regions",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.relevant_area = v.text; }},
    {"",
     "relevant-coasts",
     OptionType::file,
     "FILE",
     "deliverables",
     "Relevant coasts",
     "lines giving each owner's relevant coast instead (owned through --owner-field, as the seeds)",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.relevant_coasts = v.text; }},
    {"",
     "margin-raster",
     OptionType::file,
     "F.tif",
     "deliverables",
     "Margin raster",
     "distance to the nearest other owner minus the own distance (Float32)",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.margin = v.text; }},
    {"",
     "preview",
     OptionType::file,
     "FILE.png",
     "deliverables",
     "Quicklook",
     "quicklook: ownership in colours with the boundary lines",
     "",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.preview = v.text; }},
    {"simplify",
     "simplify",
     OptionType::nonnegative_number,
     "CELLS",
     "deliverables",
     "Simplification tolerance",
     "Douglas-Peucker tolerance of the boundary and limit lines, in cells; kept vertices stay exact locus "
     "points. 0 keeps every vertex.",
     "0",
     {},
     0,
     0,
     false,
     false,
     [](JobSpec& s, const OptionValue& v) { s.outputs.simplify_cells = v.number; }},
};

// Wraps `text` to `width` columns, every line indented by `indent`.
std::string wrap(std::string_view text, size_t indent, size_t width) {
  std::string out, line;
  std::istringstream words{std::string(text)};
  for (std::string w; words >> w;) {
    if (!line.empty() && indent + line.size() + 1 + w.size() > width) {
      out += std::string(indent, ' ') + line + "\n";
      line.clear();
    }
    line += (line.empty() ? "" : " ") + w;
  }
  if (!line.empty()) out += std::string(indent, ' ') + line + "\n";
  return out;
}

}  // namespace

const std::vector<OptionSpec>& job_options() { return kOptions; }

const OptionSpec* find_flag(std::string_view flag) {
  for (const OptionSpec& o : kOptions)
    if (!o.flag.empty() && o.flag == flag) return &o;
  return nullptr;
}

const OptionSpec* find_input(std::string_view input) {
  for (const OptionSpec& o : kOptions)
    if (!o.input.empty() && o.input == input) return &o;
  return nullptr;
}

int option_arity(const OptionSpec& o) {
  if (o.type == OptionType::flag) return 0;
  if (o.type == OptionType::extent) return 4;
  return 1;
}

OptionValue parse_cli_value(const OptionSpec& o, const std::vector<std::string>& words) {
  const Source src{"--" + std::string(o.flag)};
  OptionValue v;
  switch (o.type) {
    case OptionType::positive_number:
    case OptionType::nonnegative_number:
    case OptionType::number:
      v.number = text_number(words.at(0), src);
      check_number(o, v.number, src);
      return v;
    case OptionType::count: {
      const std::string& w = words.at(0);
      char* end = nullptr;
      const long long n = std::strtoll(w.c_str(), &end, 10);
      if (w.empty() || end != w.c_str() + w.size()) src.bad("'" + quote_input(w) + "' is not an integer");
      if (n < o.min_count || n > o.max_count)
        src.bad("expected " + std::to_string(o.min_count) + ".." + std::to_string(o.max_count));
      v.count = n;
      return v;
    }
    case OptionType::text:
    case OptionType::file:
      if (words.at(0).empty()) src.bad("must not be empty");
      v.text = words.at(0);
      return v;
    case OptionType::choice:
      return choice_value(o, words.at(0), src);
    case OptionType::flag:
      v.flag = true;
      return v;
    case OptionType::extent:
      for (size_t i = 0; i < 4; ++i) {
        v.box[i] = text_number(words.at(i), src);
        if (!std::isfinite(v.box[i])) src.bad("'" + quote_input(words.at(i)) + "' is not a finite number");
      }
      return v;  // the order of the edges is the grid's to check (make_grid), as for --like
    case OptionType::distance_list: {
      std::stringstream ss(words.at(0));
      for (std::string item; std::getline(ss, item, ',');)
        if (!item.empty()) v.items.push_back(item);
      v.items = checked_distances(std::move(v.items), src, false);
      return v;
    }
  }
  src.bad("unknown option type");
}

OptionValue parse_input_value(const OptionSpec& o, const json& raw) {
  const Source src{"input '" + std::string(o.input) + "'"};
  // OGC inputs may be bare or qualified {"value": ..., "mediaType": ...}; references are
  // refused: the server never fetches.
  const json* value = &raw;
  if (raw.is_object()) {
    if (raw.contains("href")) src.bad("references (href) are not accepted; send the value itself");
    if (raw.contains("value") && o.type != OptionType::extent) value = &raw.at("value");
  }
  const json& j = *value;
  OptionValue v;
  switch (o.type) {
    case OptionType::positive_number:
    case OptionType::nonnegative_number:
    case OptionType::number:
      if (!j.is_number()) src.bad(std::string("must be a number, got ") + j.type_name());
      v.number = j.get<double>();
      check_number(o, v.number, src);
      return v;
    case OptionType::count:
      if (!j.is_number_integer()) src.bad(std::string("must be an integer, got ") + j.type_name());
      v.count = j.get<int64_t>();
      if (v.count < o.min_count || v.count > o.max_count)
        src.bad("expected " + std::to_string(o.min_count) + ".." + std::to_string(o.max_count));
      return v;
    case OptionType::text:
    case OptionType::file:
      if (!j.is_string()) src.bad(std::string("must be a string, got ") + j.type_name());
      v.text = j.get<std::string>();
      if (v.text.empty()) src.bad("must not be empty");
      return v;
    case OptionType::choice:
      if (!j.is_string()) src.bad(std::string("must be a string, got ") + j.type_name());
      return choice_value(o, j.get_ref<const std::string&>(), src);
    case OptionType::flag:
      if (!j.is_boolean()) src.bad("must be a boolean");
      v.flag = j.get<bool>();
      return v;
    case OptionType::extent: {
      const json& e = j.is_object() && j.contains("value") ? j.at("value") : j;
      if (e.is_object()) {
        if (!e.contains("bbox")) src.bad("an object extent needs \"bbox\"");
        v.box = box_from_json(e.at("bbox"), src);
        if (e.contains("crs")) {
          if (!e.at("crs").is_string()) src.bad("\"crs\" must be a string");
          v.box_crs = e.at("crs").get<std::string>();
        }
      } else {
        v.box = box_from_json(e, src);
      }
      return v;
    }
    case OptionType::distance_list: {
      const json items = j.is_array() ? j : json::array({j});
      const std::string& n = src.name;
      for (size_t i = 0; i < items.size(); ++i)
        v.items.push_back(distance_text(items[i], Source{n.substr(0, n.size() - 1) + "[" + std::to_string(i) + "]'"}));
      v.items = checked_distances(std::move(v.items), src, true);
      return v;
    }
  }
  src.bad("unknown option type");
}

std::string options_help(std::string_view section, int width) {
  constexpr size_t kColumn = 26;  // where the help text starts
  std::string out;
  for (const OptionSpec& o : kOptions) {
    if (o.section != section || o.flag.empty()) continue;
    std::string head = "  --" + std::string(o.flag) + (o.metavar.empty() ? "" : " " + std::string(o.metavar));
    std::string help(o.help);
    if (!o.default_text.empty() && o.type != OptionType::flag)
      help += " (default: " + std::string(o.default_text) + ")";
    const std::string body = wrap(help, kColumn, static_cast<size_t>(width));
    if (head.size() + 1 < kColumn) {
      out += head + std::string(kColumn - head.size(), ' ') + body.substr(kColumn);
    } else {
      out += head + "\n" + body;
    }
  }
  return out;
}

json process_input_description(const OptionSpec& o) {
  json schema;
  switch (o.type) {
    case OptionType::positive_number:
      schema = {{"type", "number"}, {"minimum", 0}, {"exclusiveMinimum", true}};
      break;
    case OptionType::nonnegative_number:
      schema = {{"type", "number"}, {"minimum", 0}};
      break;
    case OptionType::number:
      schema = {{"type", "number"}};
      break;
    case OptionType::count:
      schema = {{"type", "integer"}, {"minimum", o.min_count}, {"maximum", o.max_count}};
      break;
    case OptionType::text:
    case OptionType::file:
      schema = {{"type", "string"}, {"minLength", 1}};
      break;
    case OptionType::choice: {
      json values = json::array();
      for (std::string_view c : o.choices) {
        size_t start = 0;
        while (start <= c.size()) {
          const size_t end = std::min(c.find('|', start), c.size());
          values.push_back(std::string(c.substr(start, end - start)));
          start = end + 1;
        }
      }
      schema = {{"type", "string"}, {"enum", values}};
      break;
    }
    case OptionType::flag:
      schema = {{"type", "boolean"}};
      break;
    case OptionType::extent: {
      const json box = {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 4}, {"maxItems", 4}};
      schema = {{"oneOf",
                 {box,
                  {{"type", "object"},
                   {"required", {"bbox"}},
                   {"properties", {{"bbox", box}, {"crs", {{"type", "string"}}}}}}}}};
      break;
    }
    case OptionType::distance_list: {
      const json positive = {{"type", "number"}, {"minimum", 0}, {"exclusiveMinimum", true}};
      json unit = {{"type", "string"}, {"enum", json::array({"m", "km", "nmi"})}};
      json object = {{"type", "object"}, {"required", json::array({"value"})}};
      object["properties"] = {{"value", positive}, {"unit", unit}};
      json item;
      item["oneOf"] = json::array({json{{"type", "string"}}, positive, object});
      schema = {{"type", "array"}, {"minItems", 1}, {"maxItems", 64}};
      schema["items"] = item;
      break;
    }
  }
  if (!o.default_text.empty()) {
    if (o.type == OptionType::flag)
      schema["default"] = o.default_text == "true";
    else if (o.type == OptionType::choice)
      schema["default"] = std::string(o.default_text);
    else if (o.type == OptionType::nonnegative_number || o.type == OptionType::positive_number)
      schema["default"] = std::strtod(std::string(o.default_text).c_str(), nullptr);
  }
  return {{"title", std::string(o.title)},
          {"description", std::string(o.help)},
          {"minOccurs", o.required ? 1 : 0},
          {"maxOccurs", 1},
          {"schema", schema}};
}

}  // namespace rv
