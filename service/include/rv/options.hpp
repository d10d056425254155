// Every option of a job, declared once (PDAL's way: one declaration gives parsing and help).
//
// An option has a process input id (the daemon's execute request, OGC API - Processes), a CLI
// flag, or both; a type that says how its value is written and checked; a unit, a default, the
// allowed values, a title and a help text; and the one function that puts a checked value into
// a JobSpec. From this table come:
//   - the CLI's parser and its --help (service/src/cli/cli.cpp),
//   - the daemon's checking of execute inputs (service/src/daemon/server_execute.cpp),
//   - the inputs of the process description (GET /processes/voronoi),
// and tests/service/daemon/test_openapi.py fails when openapi.yaml's voronoiInputs disagree with it.
// Front ends that come later (the Python module's keyword arguments, the web page's form) read
// the same table.
//
// Errors: a value that does not fit its option is rv::Error(invalid_argument) whose message
// starts with the option as the caller knows it ("--resolution: " or "input 'resolution': ").
// Thread safety: the table is immutable; the functions are reentrant.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/job.hpp"

namespace rv {

// How a value is written (CLI text, JSON) and what it must be.
enum class OptionType {
  positive_number,     // finite and > 0; JSON number, CLI decimal
  nonnegative_number,  // finite and >= 0
  number,              // finite
  count,               // integer within [min_count, max_count]
  text,                // non-empty string
  choice,              // one of `choices` (the first spelling of each is the canonical one)
  flag,                // CLI: present or not (no value); JSON: boolean
  extent,              // xmin ymin xmax ymax: CLI four numbers; JSON an array of four, or an
                       // OGC bbox object {"bbox": [...], "crs": ...}
  distance_list,       // limit distances: CLI "12nmi,24nmi"; JSON an array of "12nmi", 12 or
                       // {"value": 12, "unit": "nmi"}
  file,                // a path the CLI writes or reads (CLI only)
  length,              // one length >= 0: CLI "1mm", "0.5 m" or a plain number in the distance units;
                       // JSON the same, or {"value": 1, "unit": "mm"} (parse_length)
  layers,              // vector layers: the CLI a path; a process input uploads (a GeoJSON
                       // FeatureCollection, or a base64 qualified value of GeoPackage, zipped
                       // Shapefile or FlatGeobuf; the daemon stages them, server_execute.hpp); the
                       // Python module a path. `repeatable`: several (an array) allowed.
};

// A checked value, as the option's type makes it.
struct OptionValue {
  double number = 0.0;
  int64_t count = 0;
  bool flag = false;
  std::string text;  // text, choice (canonical spelling), file
  std::array<double, 4> box{};
  std::string box_crs;             // extent given as an OGC bbox with a crs ("" = none)
  std::vector<std::string> items;  // distance_list, each checked by parse_limit_distance
};

struct OptionSpec {
  std::string_view input;  // process input id ("" = not a process input)
  std::string_view flag;   // CLI flag without "--" ("" = not on the CLI)
  OptionType type;
  std::string_view metavar;               // the value in --help ("R", "XMIN YMIN XMAX YMAX"); "" for flags
  std::string_view section;               // --help section: seeds, grid, computation, outputs, deliverables
  std::string_view title;                 // short name (process description)
  std::string_view help;                  // what it does, its unit and default, in a sentence or three
  std::string_view default_text;          // as written in --help and the description; "" = none
  std::vector<std::string_view> choices;  // choice: the allowed spellings; aliases after "|"
                                          // ("hv-scan|hv_scan")
  int64_t min_count = 0, max_count = 0;   // count: the range
  bool repeatable = false;                // CLI: may be given more than once (each value applied in order)
  bool required = false;                  // process input with minOccurs 1
  // Puts the checked value into the job (the CLI's defaults are the JobSpec's own).
  void (*apply)(JobSpec& spec, const OptionValue& value) = nullptr;
  // What a client needs beyond the JSON schema, carried in the process description as schema
  // extensions OGC clients ignore (process_input_description), so that QGIS, the map page's
  // form and any other client are made from this table:
  std::string_view field_of = "";  // x-rvoronoi-field-of: an attribute of this layers input's features
  // x-rvoronoi-unit: "m" (metres), "crs" (the grid CRS's units: degrees or metres), "distance"
  // (the job's distanceUnits), "cells"; lengths and distance lists carry their own units.
  std::string_view unit = "";
  std::string_view geometry = "";  // layers: x-rvoronoi-upload's geometry, "any", "polygon" or "line"
  bool crs = false;                // x-rvoronoi-crs: a CRS definition (an authority code, URI or WKT)
};

// The options of `rvoronoi compute` / the process "voronoi", in --help order.
const std::vector<OptionSpec>& job_options();

// The option with this CLI flag (without "--") or process input id; nullptr when there is none.
const OptionSpec* find_flag(std::string_view flag);
const OptionSpec* find_input(std::string_view input);

// The value of a CLI option from the words after its flag (one, four for an extent, none for a
// flag). `words` holds at least as many as option_arity(). Throws rv::Error(invalid_argument)
// "--flag: ...".
OptionValue parse_cli_value(const OptionSpec& option, const std::vector<std::string>& words);
int option_arity(const OptionSpec& option);

// The value of a process input (a qualified value {"value": ...} is unwrapped; a reference
// {"href": ...} is refused). Throws rv::Error(invalid_argument) "input 'id': ...".
OptionValue parse_input_value(const OptionSpec& option, const nlohmann::json& value);

// The same from a JSON value under the caller's name for the option: messages start "name: "
// (the Python module passes its keyword, "owner_field: must be a string, got number").
OptionValue parse_json_value(const OptionSpec& option, const nlohmann::json& value, std::string_view name);

// The keyword of an option with a CLI flag in front ends whose names cannot hold '-' (the Python
// module): the flag with '_' for '-' ("owner_field").
std::string option_keyword(const OptionSpec& option);

// The --help text of a section, each option on one line and its help wrapped below it.
std::string options_help(std::string_view section, int width = 100);

// The process description's entry for a process input: title, description, minOccurs,
// maxOccurs and a JSON schema made from the type, choices and default, with the x-rvoronoi-*
// extensions (OptionSpec).
nlohmann::json process_input_description(const OptionSpec& option);

// The process "voronoi" as OGC API - Processes describes it (process_description.cpp): its summary
// (id, title, version, job control, links under `base`, e.g. "http://host:8080"; "" gives
// relative links), and the whole description: the summary, every process input of the table
// and the outputs with their media types. The daemon's /processes/voronoi, the Python module's
// rvoronoi.process_description() and the clients made from them share it.
nlohmann::json process_summary(const std::string& base);

// The file path of process output `id` in a job's OutputRequest (ownership, distance,
// nearestFeature, report, boundaries, tripoints, limits, regions, margin, preview, turningPoints,
// changes); nullptr for any other id. The daemon and the Python module set outputs through it.
std::string* output_path(OutputRequest& outputs, std::string_view id);
nlohmann::json process_description(const std::string& base);

}  // namespace rv
