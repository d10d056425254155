// Barriers for the distance by sea: what a path may not cross.
//
// Two kinds of barrier, with coordinates in one frame (the grid's CRS, or the engines' local
// frame after translated()):
//   - polygons (land): rings, outer first then holes, inside by the even-odd rule as seed
//     polygons are; a path may not enter their interior. Overlapping polygons make their union:
//     two land polygons sharing a border are land across it.
//   - lines (a breakwater, a boom, a closed boundary): a path may not cross them.
// A path may touch a barrier's boundary and run along it on either side. Which straight paths
// are free, and which points are land, is rv/sea/visibility.hpp's.
//
// A value type. Thread safety: const access from any number of threads; not for mutation.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "rv/field/seeds.hpp"

namespace rv {

class Barriers {
 public:
  // Adds a polygon (rings outer first, then holes; closure implied; consecutive duplicates
  // dropped; rings of fewer than 3 distinct vertices dropped) and returns its barrier index, or
  // -1 when no ring is left. Ring orientation is normalised: land lies to the left of every
  // edge (outer rings counter-clockwise, holes clockwise). Non-finite coordinates:
  // rv::Error(invalid_input) naming `source`. Self-intersecting rings are the reader's to mend.
  int32_t add_polygon(std::vector<Ring> rings, SourceText source = {});
  // Adds a line and returns its barrier index, or -1 when fewer than 2 distinct vertices are left.
  int32_t add_line(std::span<const Vec2> vertices, SourceText source = {});

  struct Polygon {
    std::vector<Ring> rings;  // normalised as above
    int32_t barrier = 0;
  };
  struct Line {
    std::vector<Vec2> vertices;
    int32_t barrier = 0;
  };
  const std::vector<Polygon>& polygons() const { return polygons_; }
  const std::vector<Line>& lines() const { return lines_; }
  int32_t size() const { return static_cast<int32_t>(sources_.size()); }
  bool empty() const { return sources_.empty(); }
  // How messages name barrier i: its source, or "barrier N" (1-based).
  std::string name(int32_t barrier) const;
  // A copy with every coordinate minus `origin` (the engines' local frame, GridSpec::local_x).
  Barriers translated(Vec2 origin) const;
  // A copy with every vertex v replaced by f(v) (into a geodesic frame's plane); f must keep
  // orientation (land on the left) and distinct vertices distinct.
  Barriers mapped(const std::function<Vec2(Vec2)>& f) const;
  // The number of vertices over every ring and line.
  int64_t vertex_count() const;

 private:
  std::vector<Polygon> polygons_;
  std::vector<Line> lines_;
  std::vector<SourceText> sources_;
};

}  // namespace rv
