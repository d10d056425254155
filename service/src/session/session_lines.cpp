// Line ids across a session's steps (session_lines.hpp).
#include "session/session_lines.hpp"

#include <algorithm>
#include <functional>
#include <limits>
#include <map>

#include "rv/field/checksum.hpp"

namespace rv::detail {
namespace {

using json = nlohmann::json;

std::array<double, 4> empty_box() {
  const double inf = std::numeric_limits<double>::infinity();
  return {inf, inf, -inf, -inf};
}

void take(std::array<double, 4>& b, Vec2 p) {
  b[0] = std::min(b[0], p.x);
  b[1] = std::min(b[1], p.y);
  b[2] = std::max(b[2], p.x);
  b[3] = std::max(b[3], p.y);
}

// The area two boxes share; a point or a thin box counts by its extent, so that lines along one
// row or points still compare.
double overlap(const std::array<double, 4>& a, const std::array<double, 4>& b) {
  const double w = std::min(a[2], b[2]) - std::max(a[0], b[0]);
  const double h = std::min(a[3], b[3]) - std::max(a[1], b[1]);
  if (w < 0.0 || h < 0.0) return -1.0;
  return (w + 1e-12) * (h + 1e-12);
}

std::string label(const std::vector<std::string>& labels, int32_t code) {
  return code >= 1 && static_cast<size_t>(code) <= labels.size() ? labels[static_cast<size_t>(code - 1)] : "";
}

}  // namespace

json SessionLines::update(const BoundaryResult& boundaries, const LimitResult& limits,
                          const std::vector<std::string>& labels, double to_output) {
  auto line_record = [](const auto& vertices, std::string group) {
    Record r;
    r.box = empty_box();
    // Every vertex of every line is hashed at each step: the checksum's word-at-a-time mix.
    uint64_t h = 0;
    for (const auto& v : vertices) {
      take(r.box, v.p);
      const double xy[2] = {v.p.x, v.p.y};
      h = checksum64(xy, sizeof xy, h);
    }
    r.hash = h;
    r.group = std::move(group);
    return r;
  };
  auto line_geometry = [](const auto& vertices) {
    json coords = json::array();
    for (const auto& v : vertices) coords.push_back({v.p.x, v.p.y});
    return json{{"type", "LineString"}, {"coordinates", coords}};
  };
  auto pair = [&](const BoundaryLine& line) {
    return json::array({label(labels, line.owner_a), label(labels, line.owner_b)});
  };
  auto limit_owner = [&](const LimitLine& line) { return line.owner == 0 ? json() : json(label(labels, line.owner)); };
  auto triple = [&](const Tripoint& p) {
    return json::array({label(labels, p.owners[0]), label(labels, p.owners[1]), label(labels, p.owners[2])});
  };
  std::vector<Record> b, l, t;
  for (const BoundaryLine& line : boundaries.lines) b.push_back(line_record(line.vertices, pair(line).dump()));
  for (const LimitLine& line : limits.lines)
    l.push_back(line_record(line.vertices, json::array({limit_owner(line), line.distance}).dump()));
  for (const Tripoint& p : boundaries.tripoints) {
    const struct { Vec2 p; } v[1] = {{p.p}};
    t.push_back(line_record(v, triple(p).dump()));
  }
  // What a line added or changed is answered with (made for those alone).
  const json bj = diff(boundaries_, std::move(b), "b", [&](size_t n) {
    const BoundaryLine& line = boundaries.lines[n];
    return json{{"owners", pair(line)}, {"geometry", line_geometry(line.vertices)}};
  });
  const json lj = diff(limits_, std::move(l), "l", [&](size_t n) {
    const LimitLine& line = limits.lines[n];
    return json{{"owner", limit_owner(line)},
                {"distance", line.distance * to_output},
                {"geometry", line_geometry(line.vertices)}};
  });
  const json tj = diff(tripoints_, std::move(t), "t", [&](size_t n) {
    const Tripoint& p = boundaries.tripoints[n];
    return json{{"owners", triple(p)}, {"geometry", {{"type", "Point"}, {"coordinates", {p.p.x, p.p.y}}}}};
  });
  return {{"boundaries", bj}, {"limits", lj}, {"tripoints", tj}};
}

json SessionLines::diff(Kind& kind, std::vector<Record> now, const char* prefix,
                        const std::function<json(size_t)>& entry_of) {
  // Unchanged lines first (same group and hash), in order; then each other new line takes the
  // best-overlapping unmatched old line of its group.
  std::multimap<std::pair<std::string, uint64_t>, size_t> old_exact;
  for (size_t i = 0; i < kind.records.size(); ++i)
    old_exact.emplace(std::make_pair(kind.records[i].group, kind.records[i].hash), i);
  std::vector<bool> old_used(kind.records.size(), false);
  std::vector<int64_t> match(now.size(), -1);
  for (size_t n = 0; n < now.size(); ++n) {
    auto [a, b] = old_exact.equal_range({now[n].group, now[n].hash});
    for (auto it = a; it != b; ++it)
      if (!old_used[it->second]) {
        old_used[it->second] = true;
        match[n] = static_cast<int64_t>(it->second);
        break;
      }
  }
  json added = json::array(), changed = json::array(), removed = json::array();
  std::vector<std::string> ids(now.size());
  for (size_t n = 0; n < now.size(); ++n) {
    if (match[n] >= 0) {
      now[n].id = kind.records[static_cast<size_t>(match[n])].id;
      continue;
    }
    int64_t best = -1;
    double best_overlap = -1.0;
    for (size_t o = 0; o < kind.records.size(); ++o) {
      if (old_used[o] || kind.records[o].group != now[n].group) continue;
      const double v = overlap(kind.records[o].box, now[n].box);
      if (v > best_overlap) {
        best_overlap = v;
        best = static_cast<int64_t>(o);
      }
    }
    json entry = entry_of(n);
    if (best >= 0 && best_overlap >= 0.0) {
      old_used[static_cast<size_t>(best)] = true;
      now[n].id = kind.records[static_cast<size_t>(best)].id;
      entry["id"] = now[n].id;
      changed.push_back(std::move(entry));
    } else {
      now[n].id = prefix + std::to_string(next_++);
      entry["id"] = now[n].id;
      added.push_back(std::move(entry));
    }
  }
  for (size_t o = 0; o < kind.records.size(); ++o)
    if (!old_used[o]) removed.push_back(kind.records[o].id);
  for (size_t n = 0; n < now.size(); ++n) ids[n] = now[n].id;
  kind.records = std::move(now);
  kind.ids = std::move(ids);
  return {{"added", added}, {"changed", changed}, {"removed", removed}};
}

const std::vector<std::string>& SessionLines::ids(const std::string& kind) const {
  return kind == "boundaries" ? boundaries_.ids : kind == "limits" ? limits_.ids : tripoints_.ids;
}

int64_t SessionLines::memory_bytes() const {
  int64_t bytes = 0;
  for (const Kind* k : {&boundaries_, &limits_, &tripoints_})
    for (const Record& r : k->records)
      bytes += static_cast<int64_t>(sizeof(Record) + r.group.size() + 2 * r.id.size() + 64);
  return bytes;
}

}  // namespace rv::detail
