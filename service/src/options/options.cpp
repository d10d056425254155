// The parsing, help and description made from the option table (rv/options.hpp, declared in
// option_table.cpp).
#include "rv/options.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "rv/field/error.hpp"
#include "rv/field/text.hpp"

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
  // The name of item i of a list: "input 'limitDistances[1]'", "limit_distances[1]".
  Source item(size_t i) const {
    const std::string index = "[" + std::to_string(i) + "]";
    if (!name.empty() && name.back() == '\'') return Source{name.substr(0, name.size() - 1) + index + "'"};
    return Source{name + index};
  }
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
      src.item(i).bad(e.what());
    }
  }
  return items;
}

// A length's text, checked (parse_length).
std::string checked_length(const std::string& text, const Source& src) {
  try {
    parse_length(text);
  } catch (const Error& e) {
    src.bad(e.what());
  }
  return text;
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

const OptionSpec* find_flag(std::string_view flag) {
  for (const OptionSpec& o : job_options())
    if (!o.flag.empty() && o.flag == flag) return &o;
  return nullptr;
}

const OptionSpec* find_input(std::string_view input) {
  for (const OptionSpec& o : job_options())
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
    case OptionType::layers:
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
    case OptionType::length:
      v.text = checked_length(words.at(0), src);
      return v;
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
  return parse_json_value(o, raw, "input '" + std::string(o.input) + "'");
}

std::string option_keyword(const OptionSpec& o) {
  std::string k(o.flag);
  std::replace(k.begin(), k.end(), '-', '_');
  return k;
}

OptionValue parse_json_value(const OptionSpec& o, const json& raw, std::string_view name) {
  const Source src{std::string(name)};
  // OGC inputs may be bare or qualified {"value": ..., "mediaType": ...}; references are
  // refused: the server never fetches.
  const json* value = &raw;
  if (raw.is_object()) {
    if (raw.contains("href")) src.bad("references (href) are not accepted; send the value itself");
    // (A length's own object form has a value and a unit.)
    if (raw.contains("value") && o.type != OptionType::extent &&
        !(o.type == OptionType::length && raw.contains("unit")))
      value = &raw.at("value");
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
    case OptionType::layers:
      // Paths (the Python module); the daemon stages uploads itself and never comes here with one.
      if (j.is_array() && o.repeatable) {
        if (j.empty()) src.bad("the array of layers is empty");
        for (const json& item : j) {
          if (!item.is_string() || item.get_ref<const std::string&>().empty())
            src.bad("must be a path or an array of paths");
          v.items.push_back(item.get<std::string>());
        }
        return v;
      }
      if (!j.is_string()) src.bad(std::string("must be a path, got ") + j.type_name());
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
    case OptionType::length:
      if (j.is_array()) src.bad("must be one length such as \"1mm\", a number, or {\"value\": 1, \"unit\": \"mm\"}");
      v.text = checked_length(distance_text(j, src), src);
      return v;
    case OptionType::distance_list: {
      const json items = j.is_array() ? j : json::array({j});
      for (size_t i = 0; i < items.size(); ++i) v.items.push_back(distance_text(items[i], src.item(i)));
      v.items = checked_distances(std::move(v.items), src, true);
      return v;
    }
  }
  src.bad("unknown option type");
}

std::string options_help(std::string_view section, int width) {
  constexpr size_t kColumn = 26;  // where the help text starts
  std::string out;
  for (const OptionSpec& o : job_options()) {
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

namespace {

// An upload: one layer as a GeoJSON FeatureCollection or a base64 qualified value of a binary
// format; several (repeatable) as an array of them.
json upload_schema(const OptionSpec& o) {
  const json collection = {
      {"type", "object"},
      {"required", {"type", "features"}},
      {"properties",
       {{"type", {{"type", "string"}, {"enum", {"FeatureCollection"}}}}, {"features", {{"type", "array"}}}}}};
  const json qualified = {{"type", "object"},
                          {"required", {"value"}},
                          {"properties",
                           {{"value", {{"oneOf", {{{"type", "string"}}, {{"type", "object"}}}}}},
                            {"mediaType",
                             {{"type", "string"},
                              {"enum",
                               {"application/geo+json", "application/json", "application/geopackage+sqlite3",
                                "application/zip", "application/flatgeobuf"}}}},
                            {"encoding", {{"type", "string"}, {"enum", {"base64"}}}}}}};
  json one_of = json::array({collection, qualified});
  if (o.repeatable) one_of.push_back({{"type", "array"}, {"minItems", 1}, {"items", {{"type", "object"}}}});
  return {{"oneOf", one_of}};
}

}  // namespace

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
    case OptionType::layers:
      schema = upload_schema(o);
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
    case OptionType::length: {
      const json number = {{"type", "number"}, {"minimum", 0}};
      json unit = {{"type", "string"}, {"enum", json::array({"mm", "cm", "m", "km", "nmi"})}};
      json object = {{"type", "object"}, {"required", json::array({"value"})}};
      object["properties"] = {{"value", number}, {"unit", unit}};
      schema["oneOf"] = json::array({json{{"type", "string"}}, number, object});
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
    else if (o.type == OptionType::choice || o.type == OptionType::length)
      schema["default"] = std::string(o.default_text);
    else if (o.type == OptionType::nonnegative_number || o.type == OptionType::positive_number)
      schema["default"] = std::strtod(std::string(o.default_text).c_str(), nullptr);
  }
  // What a client needs beyond the schema (rv/options.hpp: OptionSpec): OGC clients ignore
  // members named x-*.
  if (!o.field_of.empty()) schema["x-rvoronoi-field-of"] = std::string(o.field_of);
  if (!o.unit.empty()) schema["x-rvoronoi-unit"] = std::string(o.unit);
  if (o.crs) schema["x-rvoronoi-crs"] = true;
  if (o.type == OptionType::layers)
    schema["x-rvoronoi-upload"] = {{"geometry", std::string(o.geometry.empty() ? "any" : o.geometry)},
                                   {"multiple", o.repeatable}};
  return {{"title", std::string(o.title)},
          {"description", std::string(o.help)},
          {"minOccurs", o.required ? 1 : 0},
          {"maxOccurs", 1},
          {"schema", schema}};
}

}  // namespace rv
