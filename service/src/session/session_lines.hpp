// Internal to rv::Session: the ids of a session's lines and tripoints across its steps, and
// what a step added, changed and removed (the rule is rv/session.hpp's "Line ids").
// Not part of the public API. Thread safety: one session's, used by one thread at a time.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"

namespace rv::detail {

class SessionLines {
 public:
  // Takes the lines of a new state and returns, per kind ("boundaries", "limits", "tripoints"),
  // {"added": [...], "changed": [...], "removed": [ids]}, each added or changed entry with its
  // "id", "owners" (labels), "distance" (limits, in the job's units) and GeoJSON "geometry".
  // The first call names every line and returns them all as added. `labels`: the owner labels
  // by code - 1; `to_output`: metric units to the job's.
  nlohmann::json update(const BoundaryResult& boundaries, const LimitResult& limits,
                        const std::vector<std::string>& labels, double to_output);
  // The current lines' ids, in the deliverables' order, per kind.
  const std::vector<std::string>& ids(const std::string& kind) const;
  int64_t memory_bytes() const;

  struct Record {
    std::string id;
    std::string group;            // kind, owners and distance: lines match within a group only
    std::array<double, 4> box{};  // xmin, ymin, xmax, ymax
    uint64_t hash = 0;            // of every vertex's coordinates, bit for bit
  };

 private:
  struct Kind {
    std::vector<Record> records;
    std::vector<std::string> ids;
  };
  // `entry_of(n)`: the answer's entry of new line n (its id is added).
  nlohmann::json diff(Kind& kind, std::vector<Record> now, const char* prefix,
                      const std::function<nlohmann::json(size_t)>& entry_of);
  Kind boundaries_, limits_, tripoints_;
  int64_t next_ = 1;
};

}  // namespace rv::detail
