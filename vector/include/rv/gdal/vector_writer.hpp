// Writing the maritime deliverables (rv/lines/*.hpp) as vector files through GDAL/OGR, and
// polygonising the ownership raster into regions. GDAL types stay behind this header.
//
// Formats by extension: .geojson / .json -> GeoJSON (one layer), .gpkg -> GeoPackage. Anything
// else is rv::Error(invalid_argument). Every file is written atomically: a hidden temporary
// name in the target's directory, then rename(); on failure nothing is left behind.
// Coordinates are the grid CRS's (the layer carries that CRS when known); distances in
// attributes are multiplied by `distance_factor` (metric units -> reported units).
//
// Thread safety: functions may run concurrently on different files; call gdal_init() first.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "rv/engine/site_metric.hpp"
#include "rv/field/raster.hpp"
#include "rv/field/seeds.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/region_check.hpp"

namespace rv {

struct VectorOutputOptions {
  std::string crs;               // WKT (or any OSR definition); "" = no CRS
  double distance_factor = 1.0;  // metric units -> distance_units
  std::string distance_units;    // name written next to distances ("m", "nmi", "crs-units")
  int threads = 0;               // for what is measured while writing (basepoints, regions' land and
                                 // sea); 0 = all cores
};

// Layer "boundaries" (LineString): owner_a, owner_b (codes, owner_a < owner_b), label_a,
// label_b, closed (0/1), vertex_count, max_residual (distance units), features_a / features_b
// (integer lists; GeoPackage stores them as JSON text: per vertex, the 1-based index of the seed feature of that owner
// that controls it, the "basepoint" feature). GeoPackage files also get layer "boundary_vertices" (Point): per vertex
// line (1-based feature id of the line), owner_a, owner_b, feature_a, feature_b, basepoint_a_x/y, basepoint_b_x/y (the
// controlling position of each side's seed), distance, residual.
void write_boundaries(const std::string& path, const BoundaryResult& boundaries, const SiteMetric& metric,
                      const VectorOutputOptions& options);

// Layer "tripoints" (Point): owner_1..3, label_1..3, feature_1..3 (1-based), distance, residual.
void write_tripoints(const std::string& path, const BoundaryResult& boundaries, const SiteMetric& metric,
                     const VectorOutputOptions& options);

// Layer "limits" (LineString): distance (in distance units), units, owner (0 = all owners),
// label ("all" or the owner's label), closed (0/1), max_residual.
void write_limits(const std::string& path, const LimitResult& limits, const SeedSet& seeds,
                  const VectorOutputOptions& options);

struct RegionStats {
  int64_t owners = 0;    // features written (owners with a region)
  int64_t polygons = 0;  // polygon parts in all
  // Per owner written, in owner code order: its region's area, the land (its seed polygons'
  // interiors within it) and the sea, in LineRegions::area_units.
  struct OwnerArea {
    int32_t owner = 0;
    double area = 0.0, land = 0.0, sea = 0.0;
    // Within LineRegions::relevant, when given.
    double relevant_area = 0.0, relevant_land = 0.0, relevant_sea = 0.0;
  };
  std::vector<OwnerArea> areas;
  double relevant_total = 0.0;  // the relevant area's own, within the grid
};

// Regions bounded by the refined lines: the grid's outline and `edges` (region_edges) noded and
// polygonized (GEOS, through OGR), each face given the owner_of the cell centres inside it near
// a point inside it (by majority; of that point itself when the face holds no centre there: the
// lines are chords, and an interior point may fall in a sliver between a chord and the exact
// locus), an owner's faces collected into its region; so a region's edge is the boundary line
// itself, vertex for vertex, and the grid's edge (where GEOS nodes two lines that cross, at a
// point on both). Each owner's land is the interiors of its seed polygons (`polygons`, in
// the grid's CRS, one per seed polygon in SeedSet order) within its region; the rest is its sea.
// Layer "regions" (MultiPolygon): one feature per owner with owner, label, area, land_area,
// sea_area (area(ring) units: area_units), area_units; GeoPackage files also get layers
// "regions_land" and "regions_sea" (MultiPolygon; owner, label, area). Throws rv::Error(io) when
// the geometry engine fails (rv::Error(unsupported) when GDAL was built without GEOS).
struct LineRegions {
  std::vector<std::vector<Vec2>> edges;
  // More linework that bounds faces, clipped to the grid (by sea: the barriers' rings and lines,
  // where the lines that meet a barrier end; the faces on land hold no owned cell and are left
  // out).
  std::vector<std::vector<Vec2>> outline;
  GridSpec grid;
  std::function<int32_t(Vec2)> owner_of;              // 0: no owner (the face is left out)
  std::function<double(std::span<const Vec2>)> area;  // of one ring, >= 0; thread-safe
  std::string area_units;
  // The disproportionality test's relevant area (polygons in the grid's CRS, made valid and
  // merged), or null: each owner's area, land and sea within it too (RegionStats::OwnerArea).
  const std::vector<Polygon>* relevant = nullptr;
  // Called once with every face and the owner it was given (0: nobody's, left out), after the
  // faces are owned and before anything is written; what it throws refuses the regions (the
  // job's check of the faces against its cells, rv/lines/region_check.hpp). May be empty.
  std::function<void(std::span<const OwnedFace>)> verify;
};
// An empty `path` measures the regions without writing a file.
RegionStats write_line_regions(const std::string& path, const LineRegions& regions, const SeedSet& seeds,
                               const std::vector<Polygon>& polygons, const VectorOutputOptions& options);

}  // namespace rv
