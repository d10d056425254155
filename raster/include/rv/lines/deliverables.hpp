// Maritime deliverables computed from an exact nearest-site field: boundary (median) lines
// between owners, tripoints, distance-limit lines, and the margin raster.
//
// Geometry is measured with an abstract exact metric (SiteMetric) so that the same extraction
// runs on planar grids (PlanarSiteMetric, Euclidean distance in CRS units) and geodesic grids
// (GeodesicSiteMetric, metres on the ellipsoid, longitude/latitude grids). The metric must be
// the one the field was computed with (rv::Error(invalid_argument) otherwise). All positions are absolute grid-CRS
// coordinates (x = easting or longitude, y = northing or latitude); all distances are metric units (CRS units for
// planar).
//
// Method (why the vertices are exact): the raster only gives the topology. Every output vertex
// is placed by root-finding with the exact metric:
//   - a boundary vertex on the segment between two 4-neighbour cell centres owned by A and B is
//     the root of f(t) = d_A(p(t)) - d_B(p(t)), where d_X is the distance to the nearest site of
//     owner X, recomputed exactly at every evaluation (OwnerIndex: a bounding-volume hierarchy
//     per owner, searched with the metric's lower bounds, so the controlling seed may change
//     along the segment);
//   - a limit vertex is the root of d(p(t)) - D (d: nearest site of any owner, or of one owner);
//   - a tripoint solves d_A = d_B = d_C by Gauss-Newton from the dual square's centre.
// Connectivity comes from marching squares on the dual grid of cell centres: a saddle square
// (owners A B / B A) is resolved by the exact owner at the square's centre; squares with three
// or more owners are joined through their tripoints.
// Vertices are never moved: simplification (Douglas-Peucker) only drops vertices that lie within
// the tolerance of the simplified line, so every kept vertex is an exact locus point.
//
// Weights (Feature::weight, rv/field/seeds.hpp): the field's owners are the nearest by d / w, and so
// are the index's (OwnerIndex::Measure::adjusted): boundaries follow d_a / w_a = d_b / w_b (a
// circle round two weighted points: an enclave), tripoints equal three such costs, residuals are
// in them; distance limits measure true distances (OwnerIndex::Measure::plain: the breadth of a
// zone ignores weights). Reaches (Feature::reach) end a feature's influence without
// equidistance: where two owners' costs jump instead of crossing, the boundary is the arc where
// the site whose reach ends is that far (BoundaryVertex::arc), placed and refined as exactly as
// the locus; where such an arc meets a third owner the tripoint lies on it (an arc and the
// other two's locus, or two owners' arcs). The margin raster refuses adjusted seeds.
//
// Projected geodesic grids (a field computed with ComputeOptions::geolocator) are measured with
// LocatedGeodesicSiteMetric (grid positions located on the ellipsoid; output positions stay in
// the grid's CRS); margin_raster refuses such fields with rv::Error(unsupported) for now.
//
// Thread safety: SiteMetric and OwnerIndex are immutable after construction; their const
// functions may be called from any number of threads. The extraction functions are pure
// (`threads` only splits the work and never changes the result).
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/field/grid.hpp"
#include "rv/field/interior.hpp"
#include "rv/field/metric.hpp"
#include "rv/field/raster.hpp"
#include "rv/field/seeds.hpp"
#include "rv/geodesic/geodesic.hpp"

namespace rv {

// A point and an axis-aligned box in a metric's embedding space (see SiteMetric::embed).
struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
};
struct Box3 {
  double x0, y0, z0, x1, y1, z1;  // x0 <= x1, y0 <= y1, z0 <= z1
  void include(const Box3& b);
};

// The exact distance between a position and a site, plus what the searches need.
//
// Searches prune with an embedding: every position p maps to embed(p) in R^3 such that the
// Euclidean distance between embed(p) and embed(q) never exceeds the metric distance between p
// and q (planar: the plane itself, z = 0; geodesic: Earth-centred coordinates, where the chord
// is never longer than the geodesic). site_bounds() is a box in that space holding the embedding
// of every position of the site, so the Euclidean distance from embed(p) to the box is a valid
// lower bound of distance(p, site).
class SiteMetric {
 public:
  // Keeps a reference to `seeds`, which must outlive the metric. Builds the polygons' slab
  // indices for the inside tests of area sites.
  explicit SiteMetric(const SeedSet& seeds);
  virtual ~SiteMetric();
  SiteMetric(const SiteMetric&) = delete;
  SiteMetric& operator=(const SiteMetric&) = delete;

  // Exact distance (metric units, >= 0) from p to the site: point -> to the point; segment ->
  // to the nearest point of the closed segment; area -> 0 when p is inside the polygon (even-odd
  // rule over its rings), +infinity outside (the polygon's rings are segment sites of the same
  // feature, which carry the distance outside).
  virtual double distance(Vec2 p, int32_t site) const = 0;
  // Where a distance was attained at a vertex of a line: the vertex as given and the direction
  // to the position (metric-specific; valid false where the metric does not say).
  struct VertexHit {
    bool valid = false;
    Vec2 vertex;
    double direction = 0.0;
  };
  // distance(p, site), the same bits, with its gradient with respect to p: (dd/dx, dd/dy) in
  // metric units per CRS unit (a unit vector on planar grids, metres per degree on geodesic
  // ones), pointing away from the site's nearest point; NaN components where the metric gives
  // none (p on the site, area sites, and every site by default), which root finding takes as
  // "no slope known". In `hit`: whether it was attained at a vertex of the site's line (the
  // vertex's canonical distance, the same bits from every edge that shares it); by default never.
  virtual double distance_at_vertex(Vec2 p, int32_t site, Vec2& gradient, VertexHit& hit) const;
  // The same without the vertex.
  double distance_and_gradient(Vec2 p, int32_t site, Vec2& gradient) const {
    VertexHit hit;
    return distance_at_vertex(p, site, gradient, hit);
  }
  // True when distance(p, site) is certainly, to the bit, `d`: the canonical distance of the
  // vertex `hit` (from distance_at_vertex on a neighbouring edge at the same p), which this site
  // shares and attains its distance at. Searches take such ties without measuring. Default:
  // false (measure).
  virtual bool ties_at_vertex(Vec2 p, int32_t site, const VertexHit& hit, double d) const;
  // The position of the site nearest to p (the basepoint that controls p). Area sites: p.
  virtual Vec2 nearest_point(Vec2 p, int32_t site) const = 0;
  // Distance between two positions (metric units).
  virtual double point_distance(Vec2 a, Vec2 b) const = 0;
  // The embedding (see above).
  virtual Vec3 embed(Vec2 p) const = 0;
  // A box of the embedding space holding the whole site (area sites: their polygon).
  virtual Box3 site_bounds(int32_t site) const = 0;
  // A lower bound of distance(p, site), rounding included (never above it), as tight as the
  // metric can make it for much less than the distance costs: the searches measure a site only
  // where this does not exceed the best distance so far. Default: the embedding's bound from
  // site_bounds().
  virtual double distance_lower_bound(Vec2 p, int32_t site) const;
  // distance_lower_bound(p, sites[i]) into out[i] for every i (out.size() == sites.size()): one
  // position's work done once for many sites.
  virtual void distance_lower_bounds(Vec2 p, std::span<const int32_t> sites, std::span<double> out) const;

  // Lower bound of the metric distance from the embedded position q to anything in the box.
  static double lower_bound(const Vec3& q, const Box3& b);

  const SeedSet& seeds() const { return seeds_; }
  // Box of the site's vertices in grid-CRS coordinates (area sites: of the polygon's outer
  // ring), as {x0, y0, 0, x1, y1, 0}.
  Box3 vertex_box(int32_t site) const;
  // Even-odd test of p against the polygon of an area site (polygon edges straight in the grid
  // CRS, as the engine's interiors). False for other site kinds.
  bool inside_area(Vec2 p, int32_t area_site) const;

 protected:
  // The inside tests (and vertex boxes) on `polygons` instead of seeds.polygons(): the same
  // polygons one for one (same area sites) in the grid's coordinates, else
  // rv::Error(invalid_argument). Keeps a reference to `polygons`, which must outlive the metric.
  SiteMetric(const SeedSet& seeds, const std::vector<Polygon>& polygons);

 private:
  struct Slabs;
  const SeedSet& seeds_;
  const std::vector<Polygon>& polygons_;
  std::vector<int32_t> polygon_of_site_;       // site -> index into seeds.polygons(), or -1
  std::vector<std::unique_ptr<Slabs>> slabs_;  // per polygon
};

// Euclidean distance in CRS units. Computed relative to `origin` (use the grid's (xmin, ymax))
// so that large coordinates such as UTM northings keep full precision. Keeps a reference to
// `seeds`, which must outlive it.
class PlanarSiteMetric final : public SiteMetric {
 public:
  PlanarSiteMetric(const SeedSet& seeds, Vec2 origin);
  double distance(Vec2 p, int32_t site) const override;
  double distance_at_vertex(Vec2 p, int32_t site, Vec2& gradient, VertexHit& hit) const override;
  Vec2 nearest_point(Vec2 p, int32_t site) const override;
  double point_distance(Vec2 a, Vec2 b) const override;
  Vec3 embed(Vec2 p) const override;
  Box3 site_bounds(int32_t site) const override;

 private:
  Vec2 origin_;
};

// Geodesic distance (metres) on the ellipsoid of `metric`, with grid and seeds in longitude /
// latitude degrees: point and segment distances are the engines' own (every site prepared once
// at construction, as the engine prepares them), the embedding is Earth-centred coordinates (a
// chord never exceeds the geodesic). Keeps a reference to `seeds`, which must outlive it.
// Throws rv::Error(invalid_input) for a seed latitude outside [-90, 90].
class GeodesicSiteMetric final : public SiteMetric {
 public:
  GeodesicSiteMetric(const SeedSet& seeds, const MetricSpec& metric);
  ~GeodesicSiteMetric() override;
  double distance(Vec2 p, int32_t site) const override;
  double distance_at_vertex(Vec2 p, int32_t site, Vec2& gradient, VertexHit& hit) const override;
  bool ties_at_vertex(Vec2 p, int32_t site, const VertexHit& hit, double d) const override;
  Vec2 nearest_point(Vec2 p, int32_t site) const override;
  double point_distance(Vec2 a, Vec2 b) const override;
  Vec3 embed(Vec2 p) const override;
  Box3 site_bounds(int32_t site) const override;
  double distance_lower_bound(Vec2 p, int32_t site) const override;
  void distance_lower_bounds(Vec2 p, std::span<const int32_t> sites, std::span<double> out) const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Geodesic distance (metres) on a projected grid: positions are grid-CRS coordinates (as the
// field's), each located on the ellipsoid by `geolocator` and measured there with
// GeodesicSiteMetric's distances to the seeds (longitude/latitude degrees). Area sites are
// tested on `grid_polygons` (the seeds' polygons in the grid's CRS, one for one, as
// ComputeOptions::grid_polygons); nearest_point() returns grid-CRS coordinates
// (Geolocator::to_grid). The embedding is the located position's Earth-centred coordinates;
// area sites get the whole ellipsoid's box (their located interior has no cheap safe bound,
// and the inside test costs little). A position the geolocator cannot locate is
// rv::Error(invalid_input). Keeps a reference to `seeds`, which must outlive it; shares the
// geolocator and the polygons. Thread-safe as the others (the geolocator is, by contract).
class LocatedGeodesicSiteMetric final : public SiteMetric {
 public:
  LocatedGeodesicSiteMetric(const SeedSet& seeds, const MetricSpec& metric,
                            std::shared_ptr<const Geolocator> geolocator,
                            std::shared_ptr<const std::vector<Polygon>> grid_polygons);
  double distance(Vec2 p, int32_t site) const override;
  Vec2 nearest_point(Vec2 p, int32_t site) const override;
  double point_distance(Vec2 a, Vec2 b) const override;
  Vec3 embed(Vec2 p) const override;
  Box3 site_bounds(int32_t site) const override;
  double distance_lower_bound(Vec2 p, int32_t site) const override;
  void distance_lower_bounds(Vec2 p, std::span<const int32_t> sites, std::span<double> out) const override;

 private:
  Vec2 locate(Vec2 p) const;
  std::shared_ptr<const std::vector<Polygon>> grid_polygons_;
  std::shared_ptr<const Geolocator> geolocator_;
  GeodesicSiteMetric geodesic_;
  double earth_radius_;  // the larger semi-axis, metres
};

// The site metric of a field computed with these seeds, grid and options (the deliverables'
// measure and the adjusted method's): planar (origin the grid's (xmin, ymax)), geodesic, or,
// with options.geolocator, located geodesic over options.grid_polygons. Keeps a reference to
// `seeds`. Errors as the metrics' constructors.
std::unique_ptr<SiteMetric> make_site_metric(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options);

// Exact nearest-site queries, restricted to one owner or excluding one owner. Keeps references
// to the metric (and its seeds), which must outlive it.
//
// "Nearest" is by the adjusted distance (adjusted_distance in rv/field/seeds.hpp: each feature's
// weight and reach, and `cap` bounding every reach) unless the index is made Measure::plain.
// Without adjustments (every weight 1, no reach, no cap) the two are the same to the bit, and so
// is every result. With them, the distances and bounds below (`reach` of the ball queries,
// `nearest_at_most`, `within`) stay true distances; what is compared is the adjusted one.
class OwnerIndex {
 public:
  enum class Measure {
    adjusted,  // the features' weights and reaches (and the cap) apply: the engine's rule
    plain,     // true distances alone (distance limits: the breadth of a zone ignores weights)
  };
  explicit OwnerIndex(const SiteMetric& metric, Measure measure = Measure::adjusted,
                      double cap = std::numeric_limits<double>::infinity());
  ~OwnerIndex();
  OwnerIndex(OwnerIndex&&) noexcept;

  struct Hit {
    int32_t site = kNoSite;                                     // lowest site index among exact ties of `cost`
    double distance = std::numeric_limits<double>::infinity();  // true distance to it, metric units
    // What was compared (see above): distance / weight within reach; == distance without
    // adjustments. Hits handed in (`known`) need only site and distance.
    double cost = std::numeric_limits<double>::infinity();
  };
  // True when the index compares adjusted distances that differ from true ones somewhere.
  bool adjusted() const { return adjusted_; }
  // The weight `site` is compared with (its feature's; 1 in a plain index).
  double weight_of(int32_t site) const;
  // How far `site` counts (metric units): its feature's reach, at most the cap; infinity in a
  // plain index.
  double reach_of(int32_t site) const;
  // The cost of a true distance `d` to `site` (adjusted_distance of its feature, or d).
  double cost_of(int32_t site, double d) const;
  // Nearest site of owner `owner` (1..K); {kNoSite, inf} if the owner has no sites. `hint`: a
  // site likely to be the nearest (e.g. the one found at a point nearby), measured first so that
  // the search prunes with its distance; the result is the same with any hint or none (a hint
  // not of `owner` is ignored).
  Hit nearest_of(Vec2 p, int32_t owner, int32_t hint = kNoSite) const;
  // Nearest site of any owner other than `owner` (owner 0: of any owner at all). `known`: a hit
  // already measured at p (metric().distance(p, known.site) == known.distance, a site not of
  // `owner`), used as the starting bound; the result is the same with or without it.
  Hit nearest_not_of(Vec2 p, int32_t owner, Hit known) const;
  Hit nearest_not_of(Vec2 p, int32_t owner) const { return nearest_not_of(p, owner, Hit{}); }
  // Nearest site of the owners other than a and b, if one is within `within` of p (ties with it
  // included); {kNoSite, inf} otherwise. Whether a third owner comes between two.
  Hit nearest_third(Vec2 p, int32_t a, int32_t b, double within) const;
  // The sites of `owner` that can be nearest to, or tie with the nearest at, some position within
  // metric distance `reach` of `centre` (ascending indices, into `out`): every other site's lower
  // bound from the ball exceeds the distance of `hint` (or of the nearest, without a valid hint)
  // at the centre plus twice the reach. nearest_among(p, out) then equals nearest_of(p, owner) for
  // every such p, and measures only these (usually one or two): for many queries along a short
  // path (roots along a cell edge).
  // `nearest_at_most` (when finite): an upper bound of the owner's nearest distance at the centre
  // known without measuring (a neighbouring cell's field distance plus the way from there),
  // used for the bound in place of the hint's distance.
  void candidates_of(Vec2 centre, double reach, int32_t owner, int32_t hint, std::vector<int32_t>& out,
                     double nearest_at_most = std::numeric_limits<double>::infinity()) const;
  // The same for the sites of every owner but `owner` (0: of all owners), the bound from
  // `known` (a hit measured at the centre, as nearest_not_of takes it) or else from the nearest:
  // nearest_among(p, out) then equals nearest_not_of(p, owner) within `reach` of the centre.
  void candidates_not_of(Vec2 centre, double reach, int32_t owner, Hit known, std::vector<int32_t>& out,
                         double nearest_at_most = std::numeric_limits<double>::infinity()) const;
  // The nearest of `sites` (ascending indices) to p: the lowest index among exact ties. With
  // `gradient`: also the winner's (SiteMetric::distance_at_vertex; NaN when none).
  Hit nearest_among(Vec2 p, const std::vector<int32_t>& sites, Vec2* gradient = nullptr) const;
  // The site of owner `owner` (0: of any owner) whose reach p lies deepest within: the least
  // d - r over the sites, r the feature's reach at most the cap (reach_of; infinite in a plain
  // index). Hit{site, true distance d, cost = d - r}, the lowest index among ties; {kNoSite, inf,
  // inf} without sites. cost <= 0 exactly where the site counts at p, so with owner 0 the owned
  // area is where it is <= 0 and its edge (where reaches leave cells unowned) is its zero level.
  // 1-Lipschitz in p, as distances are.
  Hit deepest(Vec2 p, int32_t owner = 0) const;
  // Nearest site of any owner.
  Hit nearest(Vec2 p, Hit known) const { return nearest_not_of(p, 0, known); }
  Hit nearest(Vec2 p) const { return nearest_not_of(p, 0, Hit{}); }

  // The sites of `from` (ascending) that can be nearest to, or tie with the nearest at, some
  // position within `reach` of `centre` (ascending, into `out`; `out` may not be `from`), their
  // nearest among `from` measured at the centre: the cull of one block of cells whose centres lie
  // within `reach` of `centre` from its parent's list (the engine's adjusted method).
  void candidates_among(Vec2 centre, double reach, const std::vector<int32_t>& from, std::vector<int32_t>& out) const;

  const SiteMetric& metric() const { return metric_; }

 private:
  struct Tree;
  // The bound every site's adjusted lower bound is held to in a ball query: an upper bound of the
  // nearest's cost at any position within `reach` of the centre, from a hit measured there
  // (+infinity when that hit can leave its reach within the ball, or there is none).
  double ball_bound(const Hit& at_centre, double reach) const;
  // ball_bound of `nearest` (measured at the centre: of `owner`, or with `others` of every owner
  // but it, 0 meaning none), or where that hit can leave its reach in the ball, of the nearest
  // site that reaches over all of it.
  double ball_bound_at(Vec2 centre, double reach, int32_t owner, bool others, const Hit& nearest) const;
  // Drops the sites that cannot be nearest within `reach` of `centre` given `bound`
  // (ball_bound), by the metric's lower bounds at the centre.
  void keep_within(Vec2 centre, double reach, double bound, std::vector<int32_t>& sites) const;
  const SiteMetric& metric_;
  bool adjusted_ = false;
  double cap_ = std::numeric_limits<double>::infinity();
  std::vector<std::unique_ptr<Tree>> trees_;  // per owner code - 1
};

// One vertex of a boundary line: a point where the distances to the nearest sites of the two
// owners are equal.
// With weights (rv/field/seeds.hpp, Feature::weight) the locus is d_a / w_a = d_b / w_b: the two
// true distances differ by design, and `residual` is the difference of the adjusted ones.
struct BoundaryVertex {
  Vec2 p;
  int32_t site_a = kNoSite;  // controlling (nearest) site of owner_a at p
  int32_t site_b = kNoSite;  // controlling site of owner_b
  double distance = 0.0;     // distance to both (the mean of the two; they differ by residual)
  double residual = 0.0;     // |d_a - d_b| at p, metric units (adjusted distances)
  double distance_a = 0.0;   // the true distances to site_a and site_b, metric units
  double distance_b = 0.0;
  // Where a reach ends the comparison (Feature::reach) the line is not the locus but the arc
  // where one side's site reaches that far: 1, site_a's (distance_a is its reach); 2, site_b's;
  // 0, the locus. `residual` is then |d - reach| of that site.
  int8_t arc = 0;
};

struct BoundaryLine {
  int32_t owner_a = 0;  // owner_a < owner_b
  int32_t owner_b = 0;
  bool closed = false;  // a ring (first vertex repeated at the end)
  std::vector<BoundaryVertex> vertices;
};

struct Tripoint {
  Vec2 p;
  int32_t owners[3] = {0, 0, 0};                   // ascending
  int32_t sites[3] = {kNoSite, kNoSite, kNoSite};  // controlling site of each owner
  double distance = 0.0;                           // mean distance to the three
  double residual = 0.0;                           // max pairwise difference of the three (adjusted) distances
  double distances[3] = {0.0, 0.0, 0.0};           // true distance to each controlling site
  double cost = 0.0;                               // mean adjusted distance (== distance without weights)
};

struct BoundaryOptions {
  // Douglas-Peucker tolerance in cells (0: keep every vertex). Only vertices within this
  // distance of the simplified line are dropped; kept vertices are exact locus points.
  double simplify_cells = 0.0;
  // Root-finding tolerance along a cell-centre segment, in cells.
  double tolerance_cells = 1e-9;
  // The largest distance, in cells, left between a line's straight chords and the locus they
  // stand for. The vertices found on cell edges are exact, but the locus between two of them
  // turns where a controlling site changes and curves where it is not a straight bisector (a
  // point and a segment: a parabola; weighted points: a circle; any pair on the ellipsoid):
  // turning points are added exactly, and curved stretches get locus points until every chord
  // is within this of the locus. 0: only the vertices on cell edges.
  double refine_cells = 1e-3;
  int threads = 0;
  // The field's max distance (metric units). With an adjusted index (reaches, or weights with
  // this as the cap) lines that stop where the owned area ends end exactly on its edge
  // (end_at_owned_edge); with a plain one they stop at the last crossing.
  double max_distance = std::numeric_limits<double>::infinity();
};

struct BoundaryStats {
  int64_t crossings = 0;  // cell-centre segments with two different owners
  // Cell-centre segments where a third owner is nearer at the A-B equidistant point: its
  // region passes between the two centres without holding one (thinner than a cell there). Such
  // a segment carries the A-C and C-B crossings instead (and so on for more owners between).
  int64_t sliver_crossings = 0;
  int64_t unresolved_slivers = 0;    // segments with more owners between than followed (dropped)
  int64_t saddles = 0;               // dual squares A B / B A resolved by the centre's owner
  int64_t multi_owner_squares = 0;   // dual squares with three or more owners
  int64_t unresolved_tripoints = 0;  // such squares where no tripoint converged inside
  double max_residual = 0.0;         // largest |d_a - d_b| over all vertices and tripoints
  int64_t turning_points = 0;        // vertices added where a controlling site changes
  int64_t arc_points = 0;            // vertices added on curved stretches (refine_cells)
  int64_t vertices_before_simplify = 0;
  int64_t vertices = 0;
  int64_t ends_on_owned_edge = 0;  // line ends carried to where the owned area ends
  // Tripoints a crowded square's search missed, found from the ends of their lines (also in
  // unresolved_tripoints, which counts the squares).
  int64_t missing_tripoints_found = 0;
};

struct BoundaryResult {
  std::vector<BoundaryLine> lines;
  std::vector<Tripoint> tripoints;
  BoundaryStats stats;
  // Crossings linked to nothing, as one-vertex lines (not boundary lines: a point): where a max
  // distance ends the owned area in both squares beside a crossing, the two owners' boundary is
  // shorter than a cell. region_edges carries them to the max-distance line.
  std::vector<BoundaryLine> lone_crossings;
};

// Boundary lines and tripoints from an exact nearest-site field (method exact or brute force;
// a scan's approximate ownership only gives topology, and crossings it brackets wrongly are
// placed at the better end: use an exact field). `field` must cover the whole grid.
// Throws rv::Error(invalid_argument) for a field that does not cover a whole grid.
BoundaryResult extract_boundaries(const NearestField& field, const OwnerIndex& index,
                                  const BoundaryOptions& options = {});

struct LimitVertex {
  Vec2 p;
  int32_t site = kNoSite;  // controlling site at p
  double residual = 0.0;   // |d(p) - D|, metric units
};

// LimitLine::owner of the owned area's edge (LineRequest::owned_edge).
inline constexpr int32_t kOwnedEdge = -1;

struct LimitLine {
  double distance = 0.0;  // D, metric units (0 for the owned area's edge)
  // 0: distance to all owners' seeds; else to this owner's seeds only; kOwnedEdge: the edge of
  // the area some site reaches (OwnerIndex::deepest's zero level; vertex residuals |d - reach|).
  int32_t owner = 0;
  bool closed = false;
  std::vector<LimitVertex> vertices;
};

struct LimitOptions {
  bool per_owner = false;  // false: one set of lines per distance, from all seeds together
  double simplify_cells = 0.0;
  double tolerance_cells = 1e-9;
  int threads = 0;
};

struct LimitResult {
  std::vector<LimitLine> lines;
  double max_residual = 0.0;
  int64_t vertices = 0;
};

// Lines at the given distances (metric units, > 0) from the seeds. Cells without an owner in
// `field` (beyond its max distance) count as farther than any limit. Throws
// rv::Error(invalid_argument) for a non-positive or non-finite distance.
LimitResult extract_limits(const NearestField& field, const OwnerIndex& index, std::span<const double> distances,
                           const LimitOptions& options = {});

// Regions bounded by the refined lines. The boundary lines as region edges: each line's
// vertices, and, at an end on the frame of the outermost cell centres (where extraction stops;
// not a tripoint), one more vertex on the grid's edge where the line's two owners are
// equidistant: the root of d_a - d_b along the edge within a cell of the end's foot on it, or
// the foot itself where no root is bracketed there. Two such continuations that cross end at
// their tripoint (Newton; it lies between the frame and the edge), from which the third pair's
// line runs to the edge; so does the missing line of a tripoint found there.
// With a finite `max_distance` (the field's) and `max_distance_lines` (extract_limits at that
// distance, all owners), those lines are edges too, carried to the grid's edge on d =
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
struct RegionEdges {
  std::vector<std::vector<Vec2>> edges;
  int64_t dangling_ends = 0;
};
// A boundary's locus function for owners a < b at p: negative on a's side, 0 on the line
// (metric units). region_edges' default: the two owners' cost difference on `index`.
using LocusFunction = std::function<double(int32_t a, int32_t b, Vec2 p)>;
RegionEdges region_edges(const BoundaryResult& boundaries, const OwnerIndex& index, const GridSpec& grid,
                         double max_distance = std::numeric_limits<double>::infinity(),
                         const LimitResult* max_distance_lines = nullptr, const LocusFunction* locus = nullptr);
// The area enclosed by a ring of grid-CRS positions (closed or not; either orientation), its
// edges straight in the grid's CRS: planar, in CRS units squared (shoelace); geodesic, in square
// metres on the metric's ellipsoid. Longitude/latitude grids (`geolocator` null): the exact
// integral over the edges straight in degrees (to well under a square millimetre per degree of
// edge; `step` unused). Projected grids: the edges followed in steps of at most `step` CRS units,
// located by `geolocator` and measured as geodesics (GeographicLib::PolygonArea).
double ring_area(std::span<const Vec2> ring, const MetricSpec& metric, const Geolocator* geolocator, double step);
// The owner (code) of position p by the engine's rule: the nearest seed's owner; inside the
// polygons of several owners, the lowest code. 0 for a seed set without sites, or farther than
// `max_distance` (metric units) from every seed.
int32_t owner_at(const OwnerIndex& index, Vec2 p, double max_distance = std::numeric_limits<double>::infinity());

// What StripLines extracts: boundaries and tripoints (extract_boundaries), and limit lines at
// the given distances (extract_limits).
struct LineRequest {
  bool boundaries = false;
  BoundaryOptions boundary;
  std::vector<double> limit_distances;  // metric units, > 0; none: no limit lines
  LimitOptions limit;
  // Also the edge of the owned area where the index's reaches (each feature's, at most its cap)
  // leave cells unowned: one more set of limit lines, owner kOwnedEdge, after the others. Its
  // inside cells are the field's owned ones; its vertices lie where OwnerIndex::deepest is 0.
  bool owned_edge = false;
};

// The pieces a StripLines extraction's cell-level stages made (crossings, tripoints, links and
// their statistics; per limit line set its crossings and links), each with the grid row it
// belongs to: what a run keeps so that an edit of it (rv/edit/edit.hpp) extracts again only the rows
// near its changes and takes the others' pieces from here (StripLines::take_rows). As bytes
// (encode / decode): a flat little-endian layout behind a magic and a format version, doubles bit
// for bit. Cheap to copy (shared, immutable). Thread safety: const functions from any thread.
class LinePieces {
 public:
  LinePieces();
  bool empty() const;  // made by the default constructor
  // StripLines::key() of the extraction that made them.
  const std::string& key() const;
  std::string encode() const;
  // Throws rv::Error(invalid_input) for bytes that are not pieces of this format (magic, version,
  // truncated, trailing bytes, a row or a link out of range, rows out of order).
  static LinePieces decode(std::string_view bytes);
  // The rows (ascending, each once) holding a piece that names a site `site_map` (per site of the
  // seeds the pieces were made with, the site in an edited set) maps to kNoSite: rows an edit
  // must extract again.
  std::vector<int64_t> rows_naming_dropped(std::span<const int32_t> site_map) const;

  struct Data;

 private:
  explicit LinePieces(std::shared_ptr<const Data> d);
  std::shared_ptr<const Data> d_;
  friend class StripLines;
};

// Boundaries, tripoints and limit lines taken in strip by strip from an exact field that is
// computed in strips (a streamed job: the whole field never exists). The result equals
// extract_boundaries' and extract_limits' on the whole field, vertex for vertex, whatever the
// strips' heights: each stage runs over the rows whose neighbours have arrived, a few rows
// behind the last strip, and the pieces are chained into lines once the last row is in.
// Memory: a few rows of the field (copied from each strip before the next) and the lines'
// pieces, in proportion to the lines' length, not to the grid.
// Keeps references to `index` (and its metric and seeds); `grid` is copied.
// Thread safety: one StripLines per extraction, used from one thread at a time; it runs its
// stages on request.*.threads threads.
class StripLines {
 public:
  // Throws rv::Error(invalid_argument) for a non-positive or non-finite limit distance.
  StripLines(const GridSpec& grid, const OwnerIndex& index, const LineRequest& request);
  ~StripLines();
  StripLines(StripLines&&) noexcept;
  StripLines& operator=(StripLines&&) noexcept;

  // The next strip: whole rows of the grid, the first at row 0, each starting where the last
  // ended; its metric the index's. The strip is read during the call only. Throws
  // rv::Error(invalid_argument) otherwise (nothing taken in). After any other exception (the
  // stages' own) the extraction cannot go on.
  void add(const NearestField& strip);
  // Rows taken in so far.
  int64_t rows() const;

  // The pieces of a row depend on the field's cells and on the metric's measurements within
  // kDependRows rows of it (crossings read the next row, tripoint searches the crossings around
  // their square and the tripoints found from the rows before, links the tripoints filed up to a
  // square away, found from up to two squares farther).
  static constexpr int64_t kDependRows = 8;
  // What shapes the pieces: the grid, the request (but threads and simplification) and whether
  // the index is adjusted. Two extractions with one key make the same pieces from the same field.
  const std::string& key() const;
  // After the last row (before take_*): every piece so far (LinePieces).
  LinePieces pieces() const;
  // Rows [rows(), row1) taken from `base` (an earlier run's pieces(), key() equal) instead of
  // strips, as though their strips had been added: for an edit, rows whose pieces are the base's
  // (neither the field's cells nor any measurement by the metric changed within kDependRows rows
  // of them; the strips added around them must hold kDependRows such rows at each side).
  // `site_map`: per site of the base's seeds, the site of this extraction's seeds (empty: the
  // same). The next strip then starts at row1. Throws rv::Error(invalid_argument) for another key,
  // a row1 not after rows() or beyond the grid, or a piece naming a site the map drops;
  // rv::Error(invalid_input) for a piece naming a site or an owner these seeds do not have.
  void take_rows(const LinePieces& base, int64_t row1, std::span<const int32_t> site_map = {});
  // After the last row: the lines. Throws rv::Error(invalid_argument) when rows are missing.
  // Each may be called once.
  BoundaryResult take_boundaries();
  LimitResult take_limits();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The turning points of boundary lines: where the pair of controlling basepoints changes.
//
// A side's controlling basepoint at a point of a line is where its nearest seed is nearest: a
// basepoint seed, a vertex of a coastline (whichever of the vertex's two edges the index names),
// or the moving foot on an edge's interior (the line is then a parabola, not a bisector). Along a
// line the pair changes where a new seed takes over (the locus turns: a turning point of three
// basepoints, equidistant from all of them) and where the foot on an edge reaches its end (the
// line passes from a parabola to a bisector, without a corner). Both are found between the
// line's vertices by bisection on the locus, to 2^-26 of the distance between two vertices (the
// refinement has usually placed the first kind on a vertex already), every point a locus point.
// Where a reach ends the line follows an arc (BoundaryVertex::arc): only that side's basepoint
// controls it, the junctions with the locus or another arc (the refinement's vertices) are
// turning points, and so is a change of the arc's basepoint (bisection on the arc, then the
// corner where both basepoints are at the reach).
struct Basepoint {
  int32_t site = kNoSite;  // the controlling site
  Vec2 at;                 // the basepoint (as SiteMetric::nearest_point places it)
  double distance = 0.0;   // true distance from the turning point, metric units
};
struct TurningPoint {
  enum class Kind { end, turn, start };  // a line's end, a change of basepoint, a ring's first vertex
  Kind kind = Kind::turn;
  Vec2 p;
  // The line's vertices strictly between this point and the next turning point start here (the
  // true line between the two is this point, those vertices, and the next point).
  size_t next_vertex = 0;
  // Each side's basepoints here: one, or two where that side's changes (before, then after). A
  // side whose site does not control the line (the other side's reach ends there) has none.
  std::vector<Basepoint> a, b;
  // What the line follows from here to the next turning point: 0, the equidistance locus; 1 or
  // 2, the arc where side a's (1) or b's (2) reach ends (Feature::reach): round that side's last
  // basepoint here, at its distance (a circle round a basepoint, or a parallel to an edge).
  int8_t arc = 0;
};
struct TurningLine {
  int32_t owner_a = 0, owner_b = 0;
  bool closed = false;
  size_t line = 0;  // index into BoundaryResult::lines
  std::vector<TurningPoint> points;
};
// `geolocator`: the field's (projected geodesic grids), else null.
std::vector<TurningLine> turning_points(const BoundaryResult& boundaries, const OwnerIndex& index,
                                        const Geolocator* geolocator = nullptr, int threads = 0);

// The arcs of distance-limit lines: the stretches of a line drawn from one basepoint (a circular
// arc round a basepoint seed or a coastline vertex) or from one edge's interior (a line parallel
// to it), split where the controlling element changes, found as turning points are. `index`:
// the one the limits were measured with (plain: true distances).
struct LimitArc {
  Vec2 from, to;        // on the line, at distance D
  Basepoint basepoint;  // the controlling element at `from` (an edge's interior: its foot there)
  bool edge = false;    // true: drawn from an edge's interior (the foot moves along it)
  Vec2 edge_to;         // the foot at `to` when `edge`
};
struct LimitArcs {
  size_t line = 0;  // index into LimitResult::lines
  std::vector<LimitArc> arcs;
};
std::vector<LimitArcs> limit_arcs(const LimitResult& limits, const OwnerIndex& index,
                                  const Geolocator* geolocator = nullptr, int threads = 0);

// The relevant coast of a disproportionality test: the parts of the seeds' geometry that are
// nearest to at least one cell of the relevant area (cells whose centre `area` holds, by the
// interior rule of rv/field/interior.hpp; its window the whole grid). For each site nearest to such a
// cell, the stretch between the extreme nearest points (basepoints) of those cells along it: a
// point site's stretch is the point (length 0), an area site has none (land). The extremes are
// looked for on the cells at the edge of a site's cells within the area (a neighbour of another
// site, or outside the area or the grid), where they lie on planar grids (the basepoint's
// position along a segment is linear in the cell's position) and, to a fraction of a cell, on
// geodesic ones; so a stretch holds every basepoint of the area's cells and is no longer than
// the span between them (a site whose cells in the area fall in two separate pieces counts the
// span between the pieces too). Taken in strip by strip (whole rows in order, as StripLines):
// the whole field is never needed. Keeps references to `metric` and `area`.
// Thread safety: one accumulator per extraction, used from one thread at a time.
class RelevantCoasts {
 public:
  // `geolocator`: the field's (NearestField::geolocator; projected geodesic grids, whose metric
  // places basepoints in the grid's CRS), else null.
  RelevantCoasts(const GridSpec& grid, const SiteMetric& metric, const InteriorSpans& area,
                 const Geolocator* geolocator = nullptr, int threads = 0);
  ~RelevantCoasts();
  // The next strip: whole rows, the first at row 0, each starting where the last ended. Throws
  // rv::Error(invalid_argument) otherwise.
  void add(const NearestField& strip);
  struct Stretch {
    int32_t site = kNoSite;
    Vec2 from, to;        // the extreme basepoints (grid-CRS or seed coordinates, as nearest_point)
    double length = 0.0;  // metric units, between them along the site
  };
  // After the last row: the stretches in site order. Throws rv::Error(invalid_argument) when
  // rows are missing.
  std::vector<Stretch> take();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// For every cell owned by owner O: the distance to the nearest site of another owner, minus the
// distance to its own nearest site (>= 0, metric units, Float32). kNoDistance (-1) where the
// cell has no owner or the seed set has a single owner. A cell inside polygons of two owners
// has margin 0. Planar fields use the exact engine's tile culling with an owner filter
// (compute_other_owner, margins from double distances); other metrics run the exact engine once
// per owner, on the window of that owner's cells, over the other owners' seeds (margins from the
// Float32 distances: a few millimetres of rounding at 100 km).
Raster<float> margin_raster(const NearestField& field, const OwnerIndex& index, int threads = 0);

// The exact engine's culling, restricted per cell to sites whose owner differs from the owner
// of the cell's site in `own` (planar metric, whole-grid or windowed field as computed by
// compute()). Writes the nearest such site and its distance; kNoSite / kNoDistance where the
// cell has no owner or no other owner exists. Cells inside another owner's polygon are not
// special-cased here (see margin_raster). Result equals brute force over the filtered sites.
NearestField compute_other_owner(const SeedSet& seeds, const NearestField& own, int threads = 0);

// Douglas-Peucker on a polyline: indices of the vertices to keep (first and last always kept).
// A vertex is dropped only if it lies within `tolerance` (same units as the coordinates) of the
// segment that replaces it.
std::vector<size_t> simplify_indices(std::span<const Vec2> points, double tolerance);

}  // namespace rv
