// The session's features and its edit operations (session_features.hpp).
#include "session/session_features.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "rv/field/error.hpp"

namespace rv::detail {
namespace {

using json = nlohmann::json;
using Kind = FeaturePart::Kind;

[[noreturn]] void refuse(const std::string& where, const std::string& what) {
  throw Error(ErrorKind::invalid_argument, where + ": " + what);
}

const char* kind_name(const std::vector<FeaturePart>& parts) {
  bool point = false, line = false, polygon = false;
  for (const FeaturePart& p : parts) {
    point |= p.kind == Kind::point;
    line |= p.kind == Kind::line;
    polygon |= p.kind == Kind::polygon;
  }
  return point + line + polygon > 1 ? "mixed" : polygon ? "polygon" : line ? "line" : "point";
}

json coordinates(const std::vector<Vec2>& v) {
  json a = json::array();
  for (const Vec2& p : v) a.push_back({p.x, p.y});
  return a;
}

json ring_coordinates(const Ring& r) {
  json a = coordinates(r);
  a.push_back({r.front().x, r.front().y});  // GeoJSON repeats the first position
  return a;
}

json part_geometry(const FeaturePart& p) {
  switch (p.kind) {
    case Kind::point:
      return {{"type", "Point"}, {"coordinates", {p.vertices.front().x, p.vertices.front().y}}};
    case Kind::line:
      return {{"type", "LineString"}, {"coordinates", coordinates(p.vertices)}};
    case Kind::polygon: {
      json rings = json::array();
      for (const Ring& r : p.rings) rings.push_back(ring_coordinates(r));
      return {{"type", "Polygon"}, {"coordinates", rings}};
    }
  }
  return nullptr;
}

// One geometry for the parts: the single part's, else a collection.
json geometry(const std::vector<FeaturePart>& parts) {
  if (parts.size() == 1) return part_geometry(parts.front());
  json g = json::array();
  for (const FeaturePart& p : parts) g.push_back(part_geometry(p));
  return {{"type", "GeometryCollection"}, {"geometries", g}};
}

size_t index_in(const json& path, size_t k, size_t size, const std::string& where, const char* what) {
  if (k >= path.size() || !path[k].is_number_integer() || path[k].get<int64_t>() < 0 || path[k].get<uint64_t>() >= size)
    refuse(where, std::string("path: no ") + what + (k < path.size() ? " " + path[k].dump() : std::string()) +
                      " (there are " + std::to_string(size) + ")");
  return path[k].get<size_t>();
}

}  // namespace

SessionFeatures::SessionFeatures(const SeedSet& seeds, const std::vector<int64_t>& input_position, double to_output,
                                 CoordinateBounds bounds)
    : labels_(seeds.owner_labels()), to_output_(to_output), bounds_(bounds) {
  std::vector<std::vector<FeaturePart>> parts = feature_parts(seeds);
  // Slots in input order (the seed set groups its features by owner): a session's features, and a
  // file of them, list the features as the input did, and number them as it did.
  std::vector<size_t> order(parts.size());
  for (size_t f = 0; f < order.size(); ++f) order[f] = f;
  if (input_position.size() == parts.size())
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return input_position[a] < input_position[b]; });
  for (const size_t f : order) {
    const Feature& in = seeds.features()[f];
    auto out = std::make_shared<SessionFeature>();
    out->id = std::to_string(f < input_position.size() ? input_position[f] : static_cast<int64_t>(f) + 1);
    out->owner = seeds.owner_labels()[static_cast<size_t>(in.owner - 1)];
    out->source = in.source;
    out->weight = in.weight;
    out->reach = in.reach;
    out->effect = in.effect;
    out->parts = std::move(parts[f]);
    slot_of_id_[out->id] = slots_.size();
    slots_.push_back(std::move(out));
  }
}

Vec2 SessionFeatures::parse_position(const json& p, const std::string& where) const {
  if (!p.is_array() || p.size() < 2 || !p[0].is_number() || !p[1].is_number())
    refuse(where, "a position is an array of two numbers [x, y]");
  const Vec2 v{p[0].get<double>(), p[1].get<double>()};
  if (!std::isfinite(v.x) || !std::isfinite(v.y)) refuse(where, "a coordinate is not a finite number");
  if (bounds_.geographic ? (std::abs(v.x) > 180.0 || std::abs(v.y) > 90.0)
                         : (std::abs(v.x) > bounds_.limit || std::abs(v.y) > bounds_.limit))
    refuse(where, "position [" + json(v.x).dump() + ", " + json(v.y).dump() + "] lies outside the seeds' CRS (" +
                      (bounds_.geographic ? std::string("longitude -180..180, latitude -90..90")
                                          : "|x|, |y| up to " + json(bounds_.limit).dump()) +
                      ")");
  return v;
}

std::vector<FeaturePart> SessionFeatures::parse_geometry(const json& g, const std::string& where) const {
  if (!g.is_object() || !g.contains("type") || !g["type"].is_string())
    refuse(where, "geometry: a GeoJSON geometry object with a \"type\"");
  const std::string type = g["type"].get<std::string>();
  std::vector<FeaturePart> out;
  if (type == "GeometryCollection") {
    if (!g.contains("geometries") || !g["geometries"].is_array()) refuse(where, "geometry: no \"geometries\" array");
    for (const json& member : g["geometries"]) {
      std::vector<FeaturePart> more = parse_geometry(member, where);
      out.insert(out.end(), more.begin(), more.end());
    }
    return out;
  }
  if (!g.contains("coordinates") || !g["coordinates"].is_array()) refuse(where, "geometry: no \"coordinates\" array");
  const json& c = g["coordinates"];
  auto line = [&](const json& a) {
    if (!a.is_array() || a.size() < 2) refuse(where, "a LineString has two positions or more");
    FeaturePart p{Kind::line, {}, {}};
    for (const json& q : a) p.vertices.push_back(parse_position(q, where));
    return p;
  };
  auto polygon = [&](const json& a) {
    if (!a.is_array() || a.empty()) refuse(where, "a Polygon has an outer ring");
    FeaturePart p{Kind::polygon, {}, {}};
    for (const json& r : a) {
      if (!r.is_array() || r.size() < 4) refuse(where, "a polygon ring has four positions or more, the last the first");
      Ring ring;
      for (const json& q : r) ring.push_back(parse_position(q, where));
      if (!(ring.front() == ring.back())) refuse(where, "a polygon ring ends where it starts");
      ring.pop_back();
      p.rings.push_back(std::move(ring));
    }
    return p;
  };
  if (type == "Point") {
    out.push_back(FeaturePart{Kind::point, {parse_position(c, where)}, {}});
  } else if (type == "MultiPoint") {
    for (const json& q : c) out.push_back(FeaturePart{Kind::point, {parse_position(q, where)}, {}});
  } else if (type == "LineString") {
    out.push_back(line(c));
  } else if (type == "MultiLineString") {
    for (const json& a : c) out.push_back(line(a));
  } else if (type == "Polygon") {
    out.push_back(polygon(c));
  } else if (type == "MultiPolygon") {
    for (const json& a : c) out.push_back(polygon(a));
  } else {
    refuse(where, "geometry type \"" + type + "\" is not a GeoJSON geometry type");
  }
  if (out.empty()) refuse(where, "the geometry is empty");
  return out;
}

void SessionFeatures::set_properties(SessionFeature& f, const json& props, const std::string& where) const {
  if (!props.is_object()) refuse(where, "\"properties\" is an object");
  for (const auto& [key, value] : props.items()) {
    if (key == "owner") {
      if (!value.is_string() || value.get<std::string>().empty()) refuse(where, "owner: a non-empty string");
      f.owner = value.get<std::string>();
    } else if (key == "weight") {
      if (!value.is_number() || !(value.get<double>() > 0.0) || !std::isfinite(value.get<double>()))
        refuse(where, "weight: a finite number > 0");
      f.weight = value.get<double>();
    } else if (key == "reach") {
      if (value.is_null()) {
        f.reach = std::numeric_limits<double>::infinity();
      } else {
        if (!value.is_number() || !(value.get<double>() > 0.0) || !std::isfinite(value.get<double>()))
          refuse(where, "reach: a finite number > 0 in the job's distance units, or null for none");
        f.reach = value.get<double>() * (1.0 / to_output_);  // as a job reads it (SeedSet::scale_reaches)
      }
    } else if (key == "effect" && effects_) {
      if (!value.is_number() || !(value.get<double>() >= 0.0 && value.get<double>() <= 1.0))
        refuse(where, "effect: a number in [0, 1]");
      f.effect = value.get<double>();
    } else {
      refuse(where, "property \"" + key + "\" cannot be set (owner, weight, reach" +
                        (effects_ ? ", effect)" : "; effect in a session made with partial effect)"));
    }
  }
}

FeaturePtr SessionFeatures::parse_added(const json& e, const std::string& where) const {
  auto f = std::make_shared<SessionFeature>();
  if (!e.contains("properties") || !e["properties"].is_object() || !e["properties"].contains("owner"))
    refuse(where, "add: \"properties\" with an \"owner\"");
  set_properties(*f, e["properties"], where);
  if (!e.contains("geometry")) refuse(where, "add: no \"geometry\"");
  f->parts = parse_geometry(e["geometry"], where);
  f->id = "n" + std::to_string(next_added_++);
  f->source = "added feature " + f->id;
  return f;
}

std::vector<SlotChange> SessionFeatures::plan(const json& edits) const {
  if (!edits.is_array() || edits.empty()) refuse("edits", "a non-empty array of edit operations");
  // The slots as the step leaves them so far: later edits of the step see earlier ones.
  std::map<size_t, FeaturePtr> now;
  auto current = [&](size_t slot) -> const FeaturePtr& {
    const auto it = now.find(slot);
    return it != now.end() ? it->second : slots_[slot];
  };
  size_t added = slots_.size();
  std::unordered_map<std::string, size_t> new_ids;
  for (size_t k = 0; k < edits.size(); ++k) {
    const json& e = edits[k];
    const std::string where = "edit " + std::to_string(k + 1);
    if (!e.is_object() || !e.contains("op") || !e["op"].is_string()) refuse(where, "an object with an \"op\"");
    const std::string op = e["op"].get<std::string>();
    if (op == "add") {
      FeaturePtr f = parse_added(e, where);
      new_ids[f->id] = added;
      now[added++] = std::move(f);
      continue;
    }
    if (!e.contains("feature") || !e["feature"].is_string()) refuse(where, op + ": \"feature\", a feature id (string)");
    const std::string id = e["feature"].get<std::string>();
    size_t slot = 0;
    if (const auto it = slot_of_id_.find(id); it != slot_of_id_.end()) {
      slot = it->second;
    } else if (const auto jt = new_ids.find(id); jt != new_ids.end()) {
      slot = jt->second;
    } else {
      refuse(where, "no feature \"" + id + "\" in this session");
    }
    if (!current(slot)) refuse(where, "feature \"" + id + "\" was removed");
    const SessionFeature& was = *current(slot);
    if (op == "remove") {
      now[slot] = nullptr;
      continue;
    }
    auto f = std::make_shared<SessionFeature>(was);
    if (op == "replace") {
      if (!e.contains("geometry")) refuse(where, "replace: no \"geometry\"");
      f->parts = parse_geometry(e["geometry"], where);
    } else if (op == "set") {
      if (!e.contains("properties")) refuse(where, "set: no \"properties\"");
      set_properties(*f, e["properties"], where);
    } else if (op == "move-vertex") {
      if (!e.contains("path") || !e["path"].is_array()) refuse(where, "move-vertex: \"path\", an array");
      if (!e.contains("to")) refuse(where, "move-vertex: no \"to\"");
      const json& path = e["path"];
      const Vec2 to = parse_position(e["to"], where);
      std::vector<FeaturePart>& parts = f->parts;
      if (path.empty()) {
        if (parts.size() != 1 || parts[0].kind != Kind::point)
          refuse(where, "path []: feature \"" + id + "\" is not a single point (give [part, ...])");
        parts[0].vertices[0] = to;
      } else {
        FeaturePart& part = parts[index_in(path, 0, parts.size(), where, "part")];
        if (part.kind == Kind::point) {
          if (path.size() != 1) refuse(where, "path: a point part takes [part]");
          part.vertices[0] = to;
        } else if (part.kind == Kind::line) {
          if (path.size() != 2) refuse(where, "path: a line takes [part, vertex]");
          part.vertices[index_in(path, 1, part.vertices.size(), where, "vertex")] = to;
        } else {
          if (path.size() != 3) refuse(where, "path: a polygon takes [part, ring, vertex]");
          Ring& ring = part.rings[index_in(path, 1, part.rings.size(), where, "ring")];
          // GeoJSON's closing position is the first one: moving either moves both.
          size_t v = index_in(path, 2, ring.size() + 1, where, "vertex");
          if (v == ring.size()) v = 0;
          ring[v] = to;
        }
      }
    } else {
      refuse(where, "unknown operation \"" + op + "\" (replace, move-vertex, add, remove, set)");
    }
    now[slot] = std::move(f);
  }
  std::vector<SlotChange> out;
  for (auto& [slot, after] : now)
    out.push_back(SlotChange{slot, slot < slots_.size() ? slots_[slot] : nullptr, std::move(after)});
  return out;
}

void SessionFeatures::apply(const std::vector<SlotChange>& changes, bool undo) {
  for (const SlotChange& c : changes) {
    if (c.slot >= slots_.size()) slots_.resize(c.slot + 1);
    slots_[c.slot] = undo ? c.before : c.after;
    const FeaturePtr& f = c.after ? c.after : c.before;
    if (f) slot_of_id_[f->id] = c.slot;
  }
}

SeedSet SessionFeatures::build(std::vector<size_t>& slot_of, std::vector<int64_t>& position) const {
  SeedSet seeds;
  for (const std::string& l : labels_) seeds.owner_code(l);
  // Input positions of the slots in use; then the features grouped by owner code.
  std::vector<int64_t> pos(slots_.size(), 0);
  std::vector<std::pair<int32_t, size_t>> order;
  int64_t n = 0;
  for (size_t s = 0; s < slots_.size(); ++s) {
    if (!slots_[s]) continue;
    pos[s] = ++n;
    const int32_t code = seeds.owner_code(slots_[s]->owner);
    if (static_cast<size_t>(code) > labels_.size()) labels_.push_back(slots_[s]->owner);
    order.emplace_back(code, s);
  }
  if (order.empty()) throw Error(ErrorKind::invalid_input, "the edit removes every seed feature");
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  slot_of.clear();
  position.clear();
  for (const auto& [code, s] : order) {
    add_feature(seeds, code, *slots_[s]);
    slot_of.push_back(s);
    position.push_back(pos[s]);
  }
  return seeds;
}

void SessionFeatures::add_feature(SeedSet& seeds, int32_t code, const SessionFeature& f) {
  const int32_t index = seeds.add_feature(code, f.source);
  add_parts(seeds, index, f.parts);
  seeds.set_adjustment(index, f.weight, f.reach);
  if (f.effect != 1.0) seeds.set_effect(index, f.effect);
}

std::optional<SeedSet> SessionFeatures::rebuild(const SeedSet& current, const std::vector<size_t>& slot_of,
                                                const std::vector<SlotChange>& changes, bool undo) const {
  for (const SlotChange& c : changes) {
    const FeaturePtr& was = undo ? c.after : c.before;
    const FeaturePtr& now = c.slot < slots_.size() ? slots_[c.slot] : nullptr;
    if (!was || !now || was->owner != now->owner) return std::nullopt;
  }
  if (current.features().size() != slot_of.size()) return std::nullopt;
  std::vector<int32_t> index_of_slot(slots_.size(), -1);
  for (size_t f = 0; f < slot_of.size(); ++f) index_of_slot[slot_of[f]] = static_cast<int32_t>(f);
  std::vector<std::pair<int32_t, size_t>> touched;
  for (const SlotChange& c : changes) {
    if (index_of_slot[c.slot] < 0) return std::nullopt;
    touched.emplace_back(index_of_slot[c.slot], c.slot);
  }
  std::sort(touched.begin(), touched.end());
  SeedSet by;
  for (const std::string& l : labels_) by.owner_code(l);
  std::vector<int32_t> features;
  for (const auto& [f, slot] : touched) {
    add_feature(by, by.owner_code(slots_[slot]->owner), *slots_[slot]);
    features.push_back(f);
  }
  return current.replaced(features, by);
}

json SessionFeatures::feature_json(const SessionFeature& f) const {
  json props = {{"owner", f.owner},
                {"weight", f.weight},
                {"reach", std::isfinite(f.reach) ? json(f.reach * to_output_) : json()},
                {"kind", kind_name(f.parts)}};
  if (effects_) props["effect"] = f.effect;
  return {{"type", "Feature"}, {"id", f.id}, {"properties", props}, {"geometry", geometry(f.parts)}};
}

json SessionFeatures::geojson() const {
  json features = json::array();
  for (const FeaturePtr& f : slots_)
    if (f) features.push_back(feature_json(*f));
  return {{"type", "FeatureCollection"}, {"features", features}};
}

int64_t SessionFeatures::memory_bytes() const {
  int64_t bytes = static_cast<int64_t>(slots_.capacity() * sizeof(FeaturePtr));
  for (const FeaturePtr& f : slots_) {
    if (!f) continue;
    bytes += static_cast<int64_t>(sizeof(SessionFeature) + f->id.size() + f->owner.size() + f->source.size());
    for (const FeaturePart& p : f->parts) {
      bytes += static_cast<int64_t>(sizeof(FeaturePart) + p.vertices.capacity() * sizeof(Vec2));
      for (const Ring& r : p.rings) bytes += static_cast<int64_t>(sizeof(Ring) + r.capacity() * sizeof(Vec2));
    }
  }
  return bytes + static_cast<int64_t>(slot_of_id_.size() * 64);
}

}  // namespace rv::detail
