// Internal: the normalisation of seed geometry (the constraint-set normalisation of Li, Zeng,
// Cai, Liu 2013, Algorithm 1, reduced to what a raster nearest-site engine needs) and the
// detection of conflicts between owners. Not part of the public API.
//
// What the engine needs and what it does not:
//   - duplicate vertices / zero-length segments are removed (a zero-length segment is a point
//     already present as the neighbouring segments' end); a point repeated inside a feature is
//     removed. Both are counted.
//   - segments of the same owner that cross or overlap need no splitting: the distance to a
//     union of segments does not depend on how it is cut, and ties between them go to the same
//     owner.
//   - geometry of two owners whose interiors meet (overlapping polygons, crossing lines, a line
//     or point inside another owner's polygon, coincident points, collinear overlapping lines)
//     has no well-defined owner there: a conflict. Touching (a shared polygon edge, a line
//     ending on another owner's line or polygon boundary) is not a conflict.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <ogr_geometry.h>

#include "rv/field/seeds.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace rv::detail {

// One simple part (point, line string or polygon) of a seed feature, in the target CRS.
struct SeedPart {
  std::unique_ptr<OGRGeometry> geometry;
  OGREnvelope envelope;
  int32_t feature = 0;
  int32_t owner = 0;
  int dimension = 0;     // 0 point, 1 line, 2 polygon
  int64_t vertices = 0;  // a cost estimate for GEOS (decides whether to prepare the geometry)
};

// Removes consecutive duplicate vertices (and, for a ring, the closing repeat of the first
// vertex, which the seed model implies). Returns the number of vertices removed, not counting
// the closing repeat of a ring.
int64_t remove_duplicate_vertices(std::vector<Vec2>& vertices, bool ring);

// A closed OGR ring of `v` (closure implied: the first vertex is repeated at the end).
std::unique_ptr<OGRLinearRing> make_ring(const std::vector<Vec2>& v);

// Finds pairs of parts of different owners whose interiors intersect. Candidate pairs come from
// a sweep over the parts' envelopes sorted by xmin, then GEOS (prepared geometries for large
// parts) decides. Two polygons whose overlap holds no disc of diameter `border_tolerance` metres
// (sliver_narrow) meet along a land border: the sliver goes into report.slivers, not a conflict.
// Policy error: throws rv::Error(conflict) for the first other pair found, naming both features
// (Feature::source), their owners and a coordinate inside the intersection. Policy lower_code:
// counts the pairs in report.conflicts and adds warning lines for the first few. `srs`: the
// parts' CRS (null: none; the tolerance is then in CRS units).
void check_conflicts(std::vector<SeedPart>& parts, const SeedSet& seeds, ConflictPolicy policy, double border_tolerance,
                     const OGRSpatialReference* srs, SeedReadReport& report);

// Whether the polygonal part of `overlap` (in the CRS `srs`) holds no disc of diameter
// `tolerance` metres: it vanishes when shrunk by half that (a negative buffer, in metres: a
// geographic CRS's overlap is first taken to an azimuthal equidistant projection centred on it).
// Also its area (m^2) and mean width (twice the area over the perimeter, m). False for an overlap
// with no area.
bool sliver_narrow(const OGRGeometry& overlap, const OGRSpatialReference* srs, double tolerance, double& area,
                   double& mean_width);

}  // namespace rv::detail
