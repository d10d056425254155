// A seed feature's geometry as the parts it was made of: the form an editor moves vertices of.
//
// A SeedSet keeps sites, not parts. Its features' parts are recovered from the sites in order:
// a point site is a point part; each polygon (SeedSet::polygons()) is a polygon part, its ring
// edges and area site consumed; every other run of segment sites, each starting where the last
// ended, is a line part. add_parts() of those parts to an empty feature makes the same sites,
// in the same order, bit for bit (two lines of one feature that meet end to start come back as
// one line, which makes the same sites).
//
// Units: the seeds' coordinates. Pure functions over value types; thread-safe.
#pragma once

#include <cstdint>
#include <vector>

#include "rv/field/seeds.hpp"

namespace rv {

struct FeaturePart {
  enum class Kind : uint8_t { point, line, polygon };
  Kind kind = Kind::point;
  std::vector<Vec2> vertices;  // point: one; line: two or more
  std::vector<Ring> rings;     // polygon: outer first, then holes (closure implied)
  bool operator==(const FeaturePart&) const = default;
};

// Per feature of `seeds`, its parts in site order.
std::vector<std::vector<FeaturePart>> feature_parts(const SeedSet& seeds);

// Adds `parts` to `feature`, the last feature of `seeds` (SeedSet::add_point, add_polyline,
// add_polygon, which drop repeated vertices and degenerate rings). Returns the sites added.
// Throws as they do (a non-finite coordinate: rv::Error(invalid_input) naming the feature).
int add_parts(SeedSet& seeds, int32_t feature, const std::vector<FeaturePart>& parts);

}  // namespace rv
