// Exact nearest-site queries per owner over a SiteMetric (a bounding-volume hierarchy per owner,
// searched with the metric's lower bounds): what places every vertex of the deliverables, and
// what the adjusted method culls with.
//
// Thread safety: an OwnerIndex is immutable after construction; its const functions may be called
// from any number of threads.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "rv/engine/site_metric.hpp"
#include "rv/field/seeds.hpp"

namespace rv {

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
  // How fast a cost can change with the distance: the largest 1 / weight over the sites (1 in a
  // plain index or without weights); +infinity where some site has a finite reach (or the index a
  // cap), its cost jumping to infinity there. An owner's nearest cost then changes by at most
  // cost_slope() times the way between two points that see each other (distances being
  // 1-Lipschitz along an open way).
  double cost_slope() const { return cost_slope_; }
  // Nearest site of owner `owner` (1..K); {kNoSite, inf} if the owner has no sites. `hint`: a
  // site likely to be the nearest (e.g. the one found at a point nearby), measured first so that
  // the search prunes with its distance; the result is the same with any hint or none (a hint
  // not of `owner` is ignored). Without a hint the metric's SiteMetric::search_start serves.
  Hit nearest_of(Vec2 p, int32_t owner, int32_t hint = kNoSite) const;
  // Nearest site of any owner other than `owner` (owner 0: of any owner at all). `known`: a hit
  // already measured at p (metric().distance(p, known.site) == known.distance, a site not of
  // `owner`), used as the starting bound; the result is the same with or without it.
  Hit nearest_not_of(Vec2 p, int32_t owner, Hit known) const;
  Hit nearest_not_of(Vec2 p, int32_t owner) const { return nearest_not_of(p, owner, Hit{}); }
  // Nearest site of the owners other than a and b, if one is within `within` of p (ties with it
  // included); {kNoSite, inf} otherwise. Whether a third owner comes between two.
  Hit nearest_third(Vec2 p, int32_t a, int32_t b, double within) const;
  // The nearest site of `owner` (0: of any owner), if its cost is within `within` of p (ties
  // included); {kNoSite, inf} otherwise. Only sites whose lower bound is within are measured:
  // whether a level is reached, without measuring what lies beyond it.
  Hit nearest_within(Vec2 p, int32_t owner, double within) const;
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
  // The metric's likely nearest site of `owner` at p (SiteMetric::search_start), measured: a
  // start for a search that has no bound yet. Hit{} where the metric offers none, or its cost is
  // infinite.
  Hit start_of(Vec2 p, int32_t owner) const;
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
  double cost_slope_ = 1.0;
  std::vector<std::unique_ptr<Tree>> trees_;  // per owner code - 1
};

}  // namespace rv
