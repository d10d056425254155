// The option table (rv/options.hpp): each option declared once, the CLI and the process inputs
// parsed by the same rules into the same JobSpec, --help and the process description made from it.
#include <gtest/gtest.h>

#include <functional>
#include <set>
#include <string>
#include <vector>

#include "rv/field/error.hpp"
#include "rv/options.hpp"

namespace rv {
namespace {

using nlohmann::json;

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::invalid_argument) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no error";
  return {};
}

JobSpec from_cli(const std::vector<std::vector<std::string>>& args) {
  JobSpec s;
  for (const auto& a : args) {
    const OptionSpec* o = find_flag(a.front());
    EXPECT_NE(o, nullptr) << a.front();
    o->apply(s, parse_cli_value(*o, std::vector<std::string>(a.begin() + 1, a.end())));
  }
  return s;
}

JobSpec from_inputs(const json& inputs) {
  JobSpec s;
  for (const auto& [key, value] : inputs.items()) {
    const OptionSpec* o = find_input(key);
    EXPECT_NE(o, nullptr) << key;
    o->apply(s, parse_input_value(*o, value));
  }
  return s;
}

TEST(Options, EachOptionIsDeclaredOnceAndComplete) {
  std::set<std::string_view> flags, inputs;
  for (const OptionSpec& o : job_options()) {
    EXPECT_FALSE(o.flag.empty() && o.input.empty()) << o.title;
    if (!o.flag.empty()) {
      EXPECT_TRUE(flags.insert(o.flag).second) << o.flag;
    }
    if (!o.input.empty()) {
      EXPECT_TRUE(inputs.insert(o.input).second) << o.input;
    }
    EXPECT_NE(o.apply, nullptr) << o.title;
    EXPECT_FALSE(o.help.empty()) << o.title;
    EXPECT_FALSE(o.title.empty());
    EXPECT_EQ(o.type == OptionType::choice, !o.choices.empty()) << o.title;
    EXPECT_EQ(o.type == OptionType::flag, o.metavar.empty()) << o.title;
    if (o.type == OptionType::file) {
      EXPECT_TRUE(o.input.empty()) << "files are the CLI's: " << o.flag;
    }
    // A field names an attribute of an upload's features; only uploads have a geometry.
    if (!o.field_of.empty()) {
      const OptionSpec* layers = find_input(o.field_of);
      ASSERT_NE(layers, nullptr) << o.title;
      EXPECT_EQ(layers->type, OptionType::layers) << o.title;
    }
    EXPECT_EQ(o.type == OptionType::layers, !o.geometry.empty()) << o.title;
  }
  // The process inputs of the voronoi process, uploads included: the API's ids stay as they are.
  EXPECT_EQ(inputs,
            (std::set<std::string_view>{"seeds",          "barriers",       "snapTolerance",   "relevantArea",
                                        "relevantCoasts", "onConflict",     "ownerField",      "weightField",
                                        "reachField",     "effectField",    "borderTolerance", "transformAccuracy",
                                        "allowBallpark",  "resolution",     "extent",          "crs",
                                        "metric",         "method",         "maxDistance",     "distanceUnits",
                                        "validate",       "limitDistances", "limitsPerOwner",  "simplify",
                                        "lineTolerance",  "compression",    "baseJob"}));
}

TEST(Options, TheCliAndTheProcessInputsMakeTheSameJob) {
  const JobSpec cli = from_cli({{"resolution", "250"},
                                {"extent", "0", "0", "1000", "2000"},
                                {"crs", "EPSG:32633"},
                                {"owner-field", "state"},
                                {"border-tolerance", "0.05"},
                                {"transform-accuracy", "12"},
                                {"allow-ballpark"},
                                {"metric", "planar"},
                                {"method", "hv_scan"},
                                {"max-distance", "5000"},
                                {"distance-units", "km"},
                                {"validate"},
                                {"limit-distances", "12nmi,24nmi"},
                                {"limits-per-owner"},
                                {"simplify", "0.5"},
                                {"line-tolerance", "0.5mm"},
                                {"compression", "deflate"}});
  const JobSpec api = from_inputs(json::parse(R"({
      "resolution": 250, "extent": {"bbox": [0, 0, 1000, 2000]}, "crs": "EPSG:32633", "ownerField": "state",
      "borderTolerance": 0.05, "transformAccuracy": 12, "allowBallpark": true, "metric": "planar", "method": {"value": "hv_scan"}, "maxDistance": 5000, "distanceUnits": "km",
      "validate": true, "limitDistances": ["12nmi", {"value": 24, "unit": "nmi"}], "limitsPerOwner": true,
      "simplify": 0.5, "lineTolerance": {"value": 0.5, "unit": "mm"}, "compression": "deflate"})"));
  for (const JobSpec* s : {&cli, &api}) {
    EXPECT_EQ(*s->grid.resolution, 250.0);
    EXPECT_EQ(*s->grid.extent, (std::array<double, 4>{0, 0, 1000, 2000}));
    EXPECT_EQ(s->seeds.target_crs, "EPSG:32633");
    EXPECT_EQ(*s->seeds.owner_field, "state");
    EXPECT_EQ(s->seeds.border_tolerance, 0.05);
    EXPECT_EQ(s->seeds.transform_accuracy, 12.0);
    EXPECT_TRUE(s->seeds.allow_ballpark);
    EXPECT_EQ(s->metric, MetricRequest::planar);
    EXPECT_EQ(s->method, Method::hv_scan);  // an alias, read as the method it names
    EXPECT_EQ(*s->max_distance, 5000.0);
    EXPECT_EQ(s->distance_units, DistanceUnit::km);
    EXPECT_TRUE(s->validate);
    EXPECT_EQ(s->outputs.limit_distances.size(), 2u);
    EXPECT_TRUE(s->outputs.limits_per_owner);
    EXPECT_EQ(s->outputs.simplify_cells, 0.5);
    const Length tolerance = parse_length(s->outputs.line_tolerance);
    EXPECT_EQ(tolerance.value * tolerance.metres_per_unit, 0.5 * 0.001);
    EXPECT_EQ(s->outputs.compression, Compression::deflate);
  }
}

TEST(Options, BadValuesNameTheOptionAsTheCallerKnowsIt) {
  const OptionSpec& res = *find_flag("resolution");
  EXPECT_EQ(message_of([&] { parse_cli_value(res, {"-1"}); }), "--resolution: must be a finite number > 0");
  EXPECT_EQ(message_of([&] { parse_cli_value(res, {"1e999"}); }), "--resolution: must be a finite number");
  EXPECT_EQ(message_of([&] { parse_cli_value(res, {"10m"}); }), "--resolution: '10m' is not a number");
  EXPECT_EQ(message_of([&] { parse_input_value(res, "ten"); }), "input 'resolution': must be a number, got string");
  EXPECT_EQ(message_of([&] {
              parse_input_value(res, json{{"href", "http://x"}});
            }),
            "input 'resolution': references (href) are not accepted; send the value itself");
  EXPECT_EQ(message_of([&] { parse_cli_value(*find_flag("metric"), {"spherical"}); }),
            "--metric: must be one of auto, planar, geodesic, got 'spherical'");
  EXPECT_EQ(message_of([&] { parse_cli_value(*find_flag("threads"), {"2000"}); }), "--threads: expected 0..1024");
  EXPECT_EQ(message_of([&] {
              parse_cli_value(*find_flag("extent"), {"0", "0", "inf", "1"});
            }),
            "--extent: 'inf' is not a finite number");
  EXPECT_EQ(message_of([&] {
              parse_input_value(*find_input("extent"), json::array({0, 0, 1}));
            }),
            "input 'extent': must be [xmin, ymin, xmax, ymax] (4 numbers; 3-D boxes are not supported)");
  EXPECT_EQ(message_of([&] { parse_input_value(*find_input("validate"), "yes"); }),
            "input 'validate': must be a boolean");
  // Each limit distance is checked by the façade's parser; a JSON array names the item.
  EXPECT_NE(message_of([&] {
              parse_input_value(*find_input("limitDistances"), json{"12nmi", -3});
            }).find("input 'limitDistances[1]': "),
            std::string::npos);
  EXPECT_NE(message_of([&] {
              parse_cli_value(*find_flag("limit-distances"), {"12nmi,12 parsecs"});
            }).find("--limit-distances: unknown distance unit 'parsecs'"),
            std::string::npos);
  EXPECT_EQ(message_of([&] { parse_input_value(*find_input("limitDistances"), json::array()); }),
            "input 'limitDistances': needs at least one distance");
  // A length: one value with a unit of its own table, never negative.
  EXPECT_EQ(message_of([&] { parse_cli_value(*find_flag("line-tolerance"), {"1 furlong"}); }),
            "--line-tolerance: length '1 furlong': unknown unit 'furlong' (mm, cm, m, km or nmi)");
  EXPECT_EQ(message_of([&] { parse_input_value(*find_input("lineTolerance"), -1); }),
            "input 'lineTolerance': length '-1' is not a non-negative number");
  EXPECT_NE(message_of([&] {
              parse_input_value(*find_input("lineTolerance"), json::array({"1mm"}));
            }).find("input 'lineTolerance': must be one length"),
            std::string::npos);
  EXPECT_EQ(parse_input_value(*find_input("lineTolerance"), "2 cm").text, "2 cm");
  EXPECT_EQ(parse_input_value(*find_input("lineTolerance"), 0).text, "0");
  EXPECT_EQ(parse_length("3km").metres_per_unit, 1000.0);
  EXPECT_EQ(parse_length("0.002").unit, "");
  // A 700 KB value is not echoed whole.
  EXPECT_LT(message_of([&] { parse_cli_value(*find_flag("metric"), {std::string(700000, 'x')}); }).size(), 200u);
}

TEST(Options, HelpAndDescriptionComeFromTheTable) {
  std::string help;
  for (const char* section : {"seeds", "grid", "computation", "outputs", "deliverables"}) help += options_help(section);
  for (const OptionSpec& o : job_options()) {
    if (o.flag.empty()) continue;
    const std::string flag = "  --" + std::string(o.flag) + (o.metavar.empty() ? "" : " ");
    size_t first = help.find(flag);
    EXPECT_NE(first, std::string::npos) << o.flag;
    EXPECT_EQ(help.find(flag, first + 1), std::string::npos) << "listed twice: " << o.flag;
  }
  for (const std::string_view line : {std::string_view(help)}) {
    size_t start = 0;
    while (start < line.size()) {
      const size_t end = line.find('\n', start);
      EXPECT_LE(end - start, 100u) << line.substr(start, end - start);
      start = end + 1;
    }
  }
  const json d = process_input_description(*find_input("resolution"));
  EXPECT_EQ(d["minOccurs"], 1);
  EXPECT_EQ(d["schema"]["exclusiveMinimum"], true);
  const json m = process_input_description(*find_input("method"));
  EXPECT_EQ(m["schema"]["default"], "exact");
  EXPECT_EQ(m["schema"]["enum"].size(), 7u);  // aliases accepted are listed too
  EXPECT_EQ(process_input_description(*find_input("validate"))["schema"]["default"], false);
  const json t = process_input_description(*find_input("lineTolerance"));
  EXPECT_EQ(t["schema"]["default"], "1mm");
  EXPECT_EQ(t["schema"]["oneOf"].size(), 3u);
}

// What a client needs beyond the schema (issue 53), in the description as x-rvoronoi-* members:
// which upload a field belongs to, the uploads' geometry, units, CRS inputs.
TEST(Options, TheDescriptionCarriesWhatAClientNeeds) {
  auto schema = [](std::string_view input) { return process_input_description(*find_input(input))["schema"]; };
  for (const char* field : {"ownerField", "weightField", "reachField", "effectField"})
    EXPECT_EQ(schema(field)["x-rvoronoi-field-of"], "seeds") << field;
  EXPECT_EQ(schema("seeds")["x-rvoronoi-upload"], (json{{"geometry", "any"}, {"multiple", true}}));
  EXPECT_EQ(schema("seeds")["oneOf"].size(), 3u);  // a collection, a qualified value, an array of them
  EXPECT_EQ(process_input_description(*find_input("seeds"))["minOccurs"], 1);
  EXPECT_EQ(schema("relevantArea")["x-rvoronoi-upload"], (json{{"geometry", "polygon"}, {"multiple", false}}));
  EXPECT_EQ(schema("relevantArea")["oneOf"].size(), 2u);
  EXPECT_EQ(schema("relevantCoasts")["x-rvoronoi-upload"]["geometry"], "line");
  EXPECT_EQ(schema("resolution")["x-rvoronoi-unit"], "crs");
  EXPECT_EQ(schema("maxDistance")["x-rvoronoi-unit"], "distance");
  EXPECT_EQ(schema("borderTolerance")["x-rvoronoi-unit"], "m");
  EXPECT_EQ(schema("simplify")["x-rvoronoi-unit"], "cells");
  EXPECT_EQ(schema("crs")["x-rvoronoi-crs"], true);
  EXPECT_FALSE(schema("metric").contains("x-rvoronoi-unit"));
  EXPECT_EQ(schema("onConflict")["enum"], (json{"error", "lower-code"}));
  // The Python module passes paths for uploads: one, or several for the seeds.
  const OptionValue one = parse_json_value(*find_input("relevantArea"), "area.gpkg", "relevant_area");
  EXPECT_EQ(one.text, "area.gpkg");
  const OptionValue two = parse_json_value(*find_input("seeds"), json{"a.gpkg", "b.geojson"}, "seeds");
  EXPECT_EQ(two.items, (std::vector<std::string>{"a.gpkg", "b.geojson"}));
  EXPECT_THROW(parse_json_value(*find_input("relevantArea"), json{"a", "b"}, "relevant_area"), Error);
}

}  // namespace
}  // namespace rv
