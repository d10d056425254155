// Regions: the refined lines as the edges of each owner's area, the areas of rings on the
// metric's surface, and the owner of a position by the engine's rule.
//
// Pure; thread-safe.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "rv/engine/owner_index.hpp"
#include "rv/field/geolocate.hpp"
#include "rv/field/grid.hpp"
#include "rv/field/metric.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/residual.hpp"

namespace rv {

// Regions bounded by the refined lines. The boundary lines as region edges: each line's
// vertices, and, at an end on the frame of the outermost cell centres (where extraction stops;
// not a tripoint), one more vertex on the grid's edge where the line's two owners are
// equidistant: the root of d_a - d_b along the edge within a cell of the end's foot on it, or
// the foot itself where no root is bracketed there. Two such continuations that cross end at
// their tripoint (Newton; it lies between the frame and the edge), from which the third pair's
// line runs to the edge; so does the missing line of a tripoint found there.
// With a finite `max_distance` (the field's) and `max_distance_lines` (extract_limits at that
// distance, all owners, with LimitOptions::line_tolerance 0: on cell edges), those lines are edges
// too, carried to the grid's edge on d =
// max_distance, and a boundary line that stops where the owned area ends (as do the lone
// crossings, BoundaryResult::lone_crossings) ends on the max-distance line's chord across the
// dual square it runs on into, at the chord's point nearest the exact junction (d_a = d_b =
// max_distance, Newton within two cells), made a vertex of both. Within a square both lines
// part the four cell centres by owner as the field does. Where the cells show less than the
// owners' geometry -- two discs overlapping by less than a cell (no two neighbouring cells of
// the two owners: an owner change along the max-distance line with no boundary reaching it), a
// hole or a wedge of unowned sea thinner than a cell, a tripoint beyond the max distance or one
// whose line to the max-distance line has no crossing -- the missing stretch is made of the
// points at hand: two owner changes of one pair joined, a line carried to the tripoint lacking
// it in the square it runs into, lines ending in one square joined at the mean of their ends.
// With the grid's outline the edges divide the grid into faces of one owner each, or none beyond
// the max distance -- unless a line stops in the open, a defect that would merge two owners'
// faces: `dangling_ends` counts such ends. Faces are owned as the field's cell centres inside
// them are (write_line_regions).
// Where reaches end the owned area (an adjusted `index`: features' reaches, or weights with a
// max distance), `max_distance_lines` holds the owned area's edge instead (StripLines with
// LineRequest::owned_edge: lines of owner kOwnedEdge, which are then the only ones read): all of
// the above holds with "at the max distance" read as "at the reach of the owner's deepest site"
// (OwnerIndex::deepest), the junctions where both owners' deepest sites are at their reach.
// By sea, a line that ends on a barrier (BoundaryVertex::on_barrier) is carried a thousandth of a
// cell on across it, for the barriers' own edges to close the faces (LineRegions::outline).
// What an edge follows: a boundary's locus (owners a < b), the max-distance line or the owned
// area's edge (its level), or nothing exact (a stretch joined where the cells show less than the
// owners' geometry).
struct EdgeLocus {
  enum Kind : uint8_t { none, pair, level } kind = none;
  int32_t a = 0, b = 0;
};
struct RegionEdges {
  std::vector<std::vector<Vec2>> edges;
  std::vector<EdgeLocus> loci;         // per edge
  std::vector<std::vector<Bow>> bows;  // per edge, per segment (empty without a line tolerance)
  int64_t dangling_ends = 0;
  // With a line tolerance: the stretches region_edges adds (the ends carried on, the
  // max-distance line or the owned edge) followed and measured as the lines are.
  LineResidual residual;
};
// A boundary's locus function for owners a < b at p: negative on a's side, 0 on the line
// (metric units). region_edges' default: the two owners' cost difference on `index`.
using LocusFunction = std::function<double(int32_t a, int32_t b, Vec2 p)>;
// `line_tolerance` (metric units; 0: none): the edges region_edges adds or carries on -- the
// max-distance line or the owned edge (given on cell edges), the stretches from the lines' ends
// to the grid's edge, to a tripoint or to the max-distance line -- are made to follow their locus
// to it as the lines are (rv/lines/boundaries.hpp, limits.hpp), a boundary meeting the
// max-distance line does so at the exact junction, and every segment's bow is measured (Bow).
RegionEdges region_edges(const BoundaryResult& boundaries, const OwnerIndex& index, const GridSpec& grid,
                         double max_distance = std::numeric_limits<double>::infinity(),
                         const LimitResult* max_distance_lines = nullptr, const LocusFunction* locus = nullptr,
                         double line_tolerance = 0.0);
// The area enclosed by a ring of grid-CRS positions (closed or not; either orientation), its
// edges straight in the grid's CRS: planar, in CRS units squared (shoelace); geodesic, in square
// metres on the metric's ellipsoid. Longitude/latitude grids (`geolocator` null): the exact
// integral over the edges straight in degrees (to well under a square millimetre per degree of
// edge; `step` unused). Projected grids: the edges followed in steps of at most `step` CRS units,
// located by `geolocator` and measured as geodesics (GeographicLib::PolygonArea).
double ring_area(std::span<const Vec2> ring, const MetricSpec& metric, const Geolocator* geolocator, double step);
// The bows of the region edges' segments by their ends (either direction), for ring_area.
// Thread safety: const lookups from any thread.
class SegmentBows {
 public:
  SegmentBows() = default;
  explicit SegmentBows(const RegionEdges& edges);
  // The bows of a line's segments (bows[i]: points[i] -> points[i + 1]; NaN ones left out).
  void add(std::span<const Vec2> points, std::span<const Bow> bows);
  // The bow of segment p -> q (left of that direction), or null.
  std::optional<Bow> of(Vec2 p, Vec2 q) const;
  bool empty() const { return bows_.empty(); }

 private:
  struct Key {
    double px, py, qx, qy;
    bool operator==(const Key&) const = default;
  };
  struct Hash {
    size_t operator()(const Key& k) const;
  };
  std::unordered_map<Key, Bow, Hash> bows_;
};
// The area a ring encloses when its segments stand for the loci they follow: ring_area plus, for
// every segment with a bow, the area between it and its locus (2/3 of bow times length, on the
// side it bows to). Closed forms (a disc, a lens) come out to within 1e-9 of their area.
double ring_area(std::span<const Vec2> ring, const MetricSpec& metric, const Geolocator* geolocator, double step,
                 const SegmentBows& bows);
// The owner (code) of position p by the engine's rule: the nearest seed's owner; inside the
// polygons of several owners, the lowest code. 0 for a seed set without sites, or farther than
// `max_distance` (metric units) from every seed.
int32_t owner_at(const OwnerIndex& index, Vec2 p, double max_distance = std::numeric_limits<double>::infinity());

}  // namespace rv
