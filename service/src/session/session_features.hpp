// Internal to rv::Session: the session's seed features (each with an id that stays for the
// session's life), the five edit operations on them, and the seed set they make.
//
// Features sit in slots in input order: the features read at creation in the order of their
// input positions, then those added. A removed feature leaves its slot empty, so that undo can put it back where
// it was. The seed set is built as the reader builds one (rv/gdal/seed_reader.hpp): grouped by
// owner code, in input order within an owner; owner codes are the labels' order, frozen at
// creation, a new label taking the next code.
// Coordinates: the seeds' CRS. Reaches: metric units inside, the job's distance units in JSON.
// Not part of the public API. Thread safety: one session's, used by one thread at a time.
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/edit/feature_parts.hpp"
#include "rv/field/seeds.hpp"

namespace rv::detail {

struct SessionFeature {
  std::string id;
  std::string owner;   // label
  std::string source;  // Feature::source, for messages
  double weight = 1.0;
  double reach = std::numeric_limits<double>::infinity();  // metric units
  double effect = 1.0;
  std::vector<FeaturePart> parts;
};
using FeaturePtr = std::shared_ptr<const SessionFeature>;

// One step's change of slots: per slot touched, what it held before and after (null: empty).
struct SlotChange {
  size_t slot = 0;
  FeaturePtr before, after;
};

// How edit coordinates are bounded: longitude/latitude degrees, or any CRS's units.
struct CoordinateBounds {
  bool geographic = false;
  double limit = 1e12;  // |x|, |y| for other CRSs
};

class SessionFeatures {
 public:
  // From the seed set read at creation (reaches in metric units); ids are the features' 1-based
  // input positions (`input_position`, the nearest-feature raster's numbers), or their index + 1.
  SessionFeatures(const SeedSet& seeds, const std::vector<int64_t>& input_position, double to_output,
                  CoordinateBounds bounds);

  // The slots `edits` (an "edits" array, rv/session.hpp) change, in order, as one step; nothing
  // changes here (apply() does). Throws rv::Error(invalid_argument) naming the edit (1-based) and
  // what is wrong: an unknown operation, feature id or path, a malformed geometry, a
  // non-finite or out-of-bounds coordinate, a property of the wrong type or out of its domain.
  std::vector<SlotChange> plan(const nlohmann::json& edits) const;
  // Puts each change's `after` (or, undoing, its `before`) into its slot.
  void apply(const std::vector<SlotChange>& changes, bool undo = false);

  // The seed set of the slots (see above). `slot_of` receives, per feature, its slot; `position`
  // per feature its 1-based input position (counting only the slots in use). Throws
  // rv::Error(invalid_input) when no feature is left.
  SeedSet build(std::vector<size_t>& slot_of, std::vector<int64_t>& position) const;
  // What build() gives after `changes` were applied (undo: their `before`s put back), made from
  // `current`, the set build() gave before them (its features' slots `slot_of`), with the
  // changed features replaced (rv::SeedSet::replaced): the same set for a fraction of the work.
  // Empty when the step adds or removes a feature or gives one another owner (the order of the
  // features changes): then build() makes it. The features' slots and positions stay those of
  // `current`.
  std::optional<SeedSet> rebuild(const SeedSet& current, const std::vector<size_t>& slot_of,
                                 const std::vector<SlotChange>& changes, bool undo) const;
  // The owner labels, in code order (frozen at creation, new ones after).
  const std::vector<std::string>& labels() const { return labels_; }
  // A GeoJSON FeatureCollection of the features in input order: each with its string "id", and
  // properties owner, weight, reach (job units, null: none), kind, and with allow_effects() the
  // effect.
  nlohmann::json geojson() const;
  // One feature as geojson() writes it.
  nlohmann::json feature_json(const SessionFeature& f) const;
  // Whether "set" takes "effect" (a session with partial effect: its steps compute the whole job
  // again) and features carry it (geojson()).
  void allow_effects() { effects_ = true; }
  const FeaturePtr& at(size_t slot) const { return slots_[slot]; }
  size_t slots() const { return slots_.size(); }
  int64_t memory_bytes() const;

 private:
  static void add_feature(SeedSet& seeds, int32_t code, const SessionFeature& f);
  FeaturePtr parse_added(const nlohmann::json& edit, const std::string& where) const;
  std::vector<FeaturePart> parse_geometry(const nlohmann::json& g, const std::string& where) const;
  Vec2 parse_position(const nlohmann::json& p, const std::string& where) const;
  void set_properties(SessionFeature& f, const nlohmann::json& props, const std::string& where) const;

  std::vector<FeaturePtr> slots_;
  std::map<std::string, size_t> slot_of_id_;
  mutable std::vector<std::string> labels_;
  double to_output_ = 1.0;
  CoordinateBounds bounds_;
  mutable int64_t next_added_ = 1;  // ids "n1", "n2", ... of added features, never reused
  bool effects_ = false;            // allow_effects()
};

}  // namespace rv::detail
