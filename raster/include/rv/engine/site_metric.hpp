// The exact measure of the deliverables and of the adjusted method: the distance between a
// position and one site, with what the searches need (an embedding for lower bounds, gradients,
// vertex ties).
//
// One abstract metric (SiteMetric) so that the same extraction runs on planar grids
// (PlanarSiteMetric, Euclidean distance in CRS units) and geodesic grids (GeodesicSiteMetric,
// metres on the ellipsoid, longitude/latitude grids). The metric must be the one the field was
// computed with (rv::Error(invalid_argument) otherwise). All positions are absolute grid-CRS
// coordinates (x = easting or longitude, y = northing or latitude); all distances are metric
// units (CRS units for planar).
//
// Projected geodesic grids (a field computed with ComputeOptions::geolocator) are measured with
// LocatedGeodesicSiteMetric (grid positions located on the ellipsoid; output positions stay in
// the grid's CRS).
//
// Thread safety: a SiteMetric is immutable after construction; its const functions may be called
// from any number of threads.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/field/geolocate.hpp"
#include "rv/field/grid.hpp"
#include "rv/field/metric.hpp"
#include "rv/field/seeds.hpp"

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

  // What the metric is: planar, geodesic on longitude/latitude grids, or geodesic with grid
  // positions located on the ellipsoid (a projected grid's); and whether its distance is the
  // straight one (false: by sea, rv/sea/sea_metric.hpp), which some shortcuts need.
  enum class Kind { planar, geodesic, located_geodesic };
  virtual Kind kind() const = 0;
  virtual bool straight() const { return true; }
  // The metric it measures with: planar, or geodesic on that ellipsoid (for the geodesic kinds).
  virtual MetricSpec spec() const = 0;

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
  // distance_at_vertex(p, site, gradient, hit), the same bits, where that distance is at most
  // `bound`; elsewhere any value above `bound` (infinity allowed; gradient and hit then
  // unspecified). For searches that take a site only at or under their best so far: a metric
  // whose distance is a search of its own (by sea: over the paths that bend round land) stops
  // it at the bound. Default: distance_at_vertex.
  virtual double distance_within(Vec2 p, int32_t site, double bound, Vec2& gradient, VertexHit& hit) const;
  // A site of owner `owner` (1..K) whose distance from p is likely the owner's least, found for
  // much less than measuring the owner's sites one by one costs, or kNoSite. A start for the
  // searches of an owner's sites (OwnerIndex), whose results never depend on it. Default: kNoSite
  // (a straight metric's lower bounds order its searches well enough; by sea the nearest sites
  // in a straight line are often hidden, and the owner's search over its bend nodes finds the
  // way round at once).
  virtual int32_t search_start(Vec2 p, int32_t owner) const;
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
  // Whether distances change continuously along the straight way from a to b (grid-CRS
  // positions): true but where the metric's domain has an edge on it (the distance by sea,
  // rv/sea/sea_metric.hpp: a or b on land, or a barrier across the way). The deliverables place
  // no equidistance point on a way between two cell centres that is not open. Default: true.
  virtual bool open_between(Vec2 a, Vec2 b) const;
  // The barrier vertex the site's path to p bends at last (by sea: an index of the barriers'
  // distinct vertices, rv/sea/sea_field.hpp's via), or -1 where the path is straight. Two owners
  // whose paths bend last at one vertex with equal costs tie over the whole area behind it
  // (BoundaryVertex::tie). Default: -1 (a straight metric's paths never bend).
  virtual int32_t last_bend(Vec2 p, int32_t site) const;
  // Where bend vertex `vertex` (from last_bend) is, in the grid's CRS. Default (no bends):
  // rv::Error(internal).
  virtual Vec2 bend_position(int32_t vertex) const;
  // Where the domain has edges (the distance by sea: the barriers' boundaries; a straight metric
  // has none): the ids of the edges that may come within `radius` CRS units of p, into `out`
  // (cleared first), so that a line which stops short of an edge can be carried onto it.
  virtual void domain_edges_near(Vec2 p, double radius, std::vector<int32_t>& out) const;
  // The point of domain edge `edge` at fraction t in [0, 1] of its length from its first end, as
  // approached from the side where `side` lies: moved off the edge by the least amount (a few
  // units in the last place of the edge's length, at most a micrometre's order; on the ellipsoid
  // at least 0.1 um, where every orientation test reads it on that side alike) that puts it on
  // that side and in the domain. Grid-CRS coordinates into `out`; false where there is none
  // (`side` on the edge's line, or the edge's side towards it is not the domain's).
  virtual bool domain_edge_point(int32_t edge, double t, Vec2 side, Vec2& out) const;
  // Whether p lies in the metric's domain (by sea: not strictly inside a barrier polygon; a
  // straight metric's domain is everywhere). Default: true.
  virtual bool in_domain(Vec2 p) const;
  // The two ends of domain edge `edge` (an id from domain_edges_near), in grid-CRS coordinates,
  // first end first; false where the metric has no domain edges.
  virtual bool domain_edge_ends(int32_t edge, Vec2& first, Vec2& second) const;
  // A bound, in grid-CRS units, of how far any point domain_edge_point gives for `edge` lies from
  // the straight segment between its two ends (domain_edge_ends): a geodesic edge's bow in the
  // grid's coordinates, and the move off the edge. A search for the nearest point of the edges
  // may pass over an edge whose segment lies farther than the best found by more than this.
  // Default: 0 (no domain edges). Thread safety: as every const member (a metric may fill a cache
  // of these on first use).
  virtual double domain_edge_bow(int32_t edge) const;

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
  Kind kind() const override { return Kind::planar; }
  MetricSpec spec() const override { return MetricSpec{}; }
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
  // Measures with the sites `prepared` holds (prepare() of these very seeds with this metric),
  // shared rather than prepared again; the same distances, bit for bit. Throws
  // rv::Error(invalid_argument) where `prepared` is not of them.
  GeodesicSiteMetric(const SeedSet& seeds, const MetricSpec& metric, std::shared_ptr<const PreparedSeeds> prepared);
  ~GeodesicSiteMetric() override;
  Kind kind() const override { return Kind::geodesic; }
  MetricSpec spec() const override;
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
  Kind kind() const override { return Kind::located_geodesic; }
  MetricSpec spec() const override { return geodesic_.spec(); }
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
// `seeds`. Errors as the metrics' constructors. A geodesic metric shares options.prepared's sites
// where it was made from these seeds with this metric.
std::unique_ptr<SiteMetric> make_site_metric(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options);

}  // namespace rv
