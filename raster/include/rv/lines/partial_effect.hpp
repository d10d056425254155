// Partial effect: one owner's features (islands) counted with an effect e in [0, 1) in that
// owner's boundaries with its neighbours.
//
// For owner B (the one with features of effect e < 1) and each neighbour X: L0 is the B-X
// boundary with those features absent (nil effect), L1 the B-X boundary with them at full effect.
// Between the two lines (the band: cells that are X's at nil effect and B's at full effect) the
// partial-effect line is the locus where the distances to the two lines are in the ratio
// e : (1 - e):
//     (1 - e) d(p, L0) = e d(p, L1),
// and a band position goes to B where (1 - e) d(p, L0) < e d(p, L1) (the side of L0), to X
// elsewhere (ties to X). Outside the bands L0 and L1 agree and nothing changes. e = 0.5 is the
// median line between L0 and L1; e = 0 gives L0, e -> 1 gives L1. Distances to the lines are the
// field's metric's (planar, or geodesic on the ellipsoid), to the lines' straight (geodesic)
// edges. Cells of no owner at nil effect (beyond a max distance from every other seed) that the
// partial features reach stay B's: the adjustment is between owners, not of an island's own
// entitlement.
// By sea (PartialEngines from the distance by sea) L0 and L1 are lines by sea, the partial features
// at nil effect no seeds but land where the barriers have them; the rule still measures straight
// distances to the lines as drawn, and partial_boundaries follows the locus through each band.
//
// The stages, all pure functions of value types:
//   partial_effect_of     which owner, which features, which e; the input's rules enforced
//   SeedSet::without      the nil-effect seeds (rv/field/seeds.hpp)
//   PartialEffectRule     the lines L0 and L1 per neighbour, and the rule above at a position
//   partial_field         the field of the rule from the full- and nil-effect fields
//   partial_boundaries    the full-effect lines with each band's stretch of L1 replaced by the
//                         partial-effect locus (exact to the refinement tolerance)
//
// Thread safety: everything here is const after construction and may be used from many threads.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/seeds.hpp"
#include "rv/lines/boundaries.hpp"

namespace rv {

// Which features count partly. owner 0: none (every effect is 1, or the partial features all
// have effect 1).
struct PartialEffect {
  int32_t owner = 0;          // B: the owner of the partial features
  double effect = 1.0;        // e, shared by all of them, in [0, 1)
  std::vector<bool> partial;  // per feature: effect < 1
  bool any() const { return owner != 0; }
};

// The partial effect of `seeds` (Feature::effect). Throws rv::Error(invalid_input) naming the
// features or owners when features of two owners have effects below 1, when one owner's differ,
// or when every feature of that owner has one (its nil-effect line would not exist).
PartialEffect partial_effect_of(const SeedSet& seeds);

// L0 and L1 per neighbour of B, and the rule at a position.
class PartialEffectRule {
 public:
  // `seeds`: the full seed set (partial features included); `nil`: the boundaries extracted at
  // nil effect, their sites numbered in the nil-effect seeds (`site_of`, from SeedSet::without,
  // maps them); `full`: those at full effect; `grid` and `options`: the fields' (make_site_metric;
  // a projected geodesic grid is refused with rv::Error(unsupported)). Keeps no reference to the
  // arguments.
  PartialEffectRule(const SeedSet& seeds, const PartialEffect& effect, BoundaryResult nil,
                    const std::vector<int32_t>& site_of, BoundaryResult full, const GridSpec& grid,
                    const ComputeOptions& options);
  ~PartialEffectRule();

  const PartialEffect& effect() const { return effect_; }
  // The owner of p given its owner at full effect and at nil effect (0: none): B or X by the
  // rule in a band, the full-effect owner elsewhere.
  int32_t owner(Vec2 p, int32_t full_owner, int32_t nil_owner) const;
  // e d(p, L1) - (1 - e) d(p, L0) for neighbour X (metric units): above 0 on B's side of the
  // partial-effect line. +-infinity or NaN where a line is missing (B and X do not meet at one
  // effect).
  double balance(Vec2 p, int32_t neighbour) const;
  // The distances from p to L0 and L1 of neighbour X (metric units; infinity without the line).
  double distance_to_nil(Vec2 p, int32_t neighbour) const;
  double distance_to_full(Vec2 p, int32_t neighbour) const;
  // The distance between two positions in the rule's metric (metric units).
  double separation(Vec2 a, Vec2 b) const;
  // The boundaries this rule was built from (sites in the full numbering).
  const BoundaryResult& nil_lines() const { return nil_; }
  const BoundaryResult& full_lines() const { return full_; }

 private:
  PartialEffect effect_;
  BoundaryResult nil_, full_;
  SeedSet lines_;  // L0 of neighbour X: owner 2X - 1; L1: owner 2X
  std::unique_ptr<SiteMetric> metric_;
  std::unique_ptr<OwnerIndex> index_;
};

// The field of the rule: per cell, the full-effect field's site and distance, or in a band cell
// that goes to the neighbour, the nil-effect field's (its site mapped by `site_of`, from
// SeedSet::without). Both fields whole, of one grid and metric. `threads` as ComputeOptions'.
NearestField partial_field(const NearestField& full, const NearestField& nil, const std::vector<int32_t>& site_of,
                           const SeedSet& seeds, const PartialEffectRule& rule, int threads);

// What partial_boundaries did.
struct PartialLineStats {
  int64_t stretches = 0;      // band stretches of L1 replaced
  int64_t points = 0;         // locus points on them (their ends, on L0 and L1 alike, included)
  int64_t coast_ends = 0;     // by sea: stretches ended on a coast (BoundaryVertex::on_barrier)
  double max_residual = 0.0;  // largest |balance| at a locus point, metric units
  // The traced stretches' segments: the largest distance from a chord's middle to the locus
  // point across it (rv/lines/residual.hpp; metric units), and the points added.
  LineResidual residual;
};

// The full-effect boundaries with each band's stretch of L1 (the vertices whose B site belongs
// to a partial feature) replaced by the partial-effect locus: its points placed exactly
// (|balance| <= ftol, metric units) on segments from L0 to L1, added until every chord is within
// `line_tolerance` (metric units) of the locus, then the line simplified at `simplify_cells` cells as the
// extraction does (BoundaryOptions). A band runs from the turning point where L1 leaves L0 to
// the one where it rejoins it, or to the grid's edge, or to a full-effect tripoint of B and two
// neighbours X and Y: there the two bands share the nil-effect X-Y line, each band's locus ends
// where it meets that line, the nearer of the two ends to the tripoint is the partial tripoint,
// the other owner's line follows the X-Y line to it, and so does the X-Y line (pair by pair).
// Vertices carry the nearest sites of both owners and the true distances to them. `index`: the
// full-effect field's (B's sites); `grid`: the field's. By sea (`index`'s metric not straight,
// `nil_index` the nil-effect field's): each band's locus is followed from its turning points;
// where land cuts it, to the coast (the point where the coast has the balance 0; the vertex
// BoundaryVertex::on_barrier, counted in PartialLineStats::coast_ends), and the line is cut there
// into two lines. A full-effect line wholly in its band (every vertex B's partial site: a port of
// X that the island shuts in, or an enclave of the island's at full effect), not ending at a
// planned tripoint, has no turning point to follow from: given `full_field` and `rule_field` (the
// full-effect field and partial_field's, whole, of `grid`) and `nil_index`, in either metric, the
// line is dropped (the rule gives its side back to X) and the band's loci that no drawn line
// follows are found where the rule's cells change owner and followed both ways to coasts, the
// frame or round (lines of their own; a locus between no two cell centres is not drawn).
// Where both bands at a full-effect tripoint are given back all along the neighbours' nil-effect
// line from it (an island far from its owner's nil-effect lines), that tripoint is no tripoint of
// the result: the neighbours' line follows their nil-effect line to its end (a nil-effect
// tripoint of three neighbours inside the zone, then one of the result, or a coast or the frame),
// nil-effect lines lying wholly where both sides are given back are lines of the result, and the
// island's lines ending there are left to the cells as above.
// Throws rv::Error(unsupported) where a line is all band and those fields are not given, where a
// locus so found cannot be followed (it meets a tripoint), where only one band at a tripoint is
// given back whole, the lines around a tripoint do not meet as above, a band followed by sea into
// another piece of its full-effect line does not join that piece's line end to end, or a line runs
// out and back over itself to where it began: the rasters are exact there, the lines are not drawn.
BoundaryResult partial_boundaries(const PartialEffectRule& rule, const SeedSet& seeds, const OwnerIndex& index,
                                  const GridSpec& grid, double ftol, double line_tolerance, double simplify_cells,
                                  PartialLineStats& stats, const OwnerIndex* nil_index = nullptr,
                                  const NearestField* full_field = nullptr, const NearestField* rule_field = nullptr);

// How compute_partial_effect makes each effect's field and measure. Empty members: the straight
// engine (compute) and make_site_metric, with the call's grid and options. The distance by sea
// passes its own (the service's job does): the two lines are then lines by sea, and the rule
// between them still measures straight distances to them (it interpolates two lines; it measures
// no way to a coast).
struct PartialEngines {
  // The whole field of `seeds` (the full-effect seeds, then, with `nil`, the nil-effect ones).
  std::function<NearestField(const SeedSet& seeds, bool nil)> field;
  // The measure of `seeds` whose field is `field` (the distance by sea settles as far as the
  // field's distances ask). May keep a reference to `seeds` (it outlives the measure), not to
  // `field`.
  std::function<std::unique_ptr<SiteMetric>(const SeedSet& seeds, const NearestField& field, bool nil)> metric;
};

// The whole of it for a field computed whole: the full- and nil-effect fields (compute, or
// engines.field), their boundaries (extract_boundaries with `lines`), the rule, the partial field
// and the partial lines (`draw_lines` false: no partial lines, and none of their refusals; the
// rule still needs L0 and L1). Without partial features, `rule` is null, `field` the full field
// and `boundaries` its lines. Errors: compute's (the engines'), extract_boundaries', and the above.
struct PartialEffectResult {
  NearestField full;   // at full effect (distance limits measure it: an island's own breadth)
  NearestField field;  // by the rule
  std::unique_ptr<PartialEffectRule> rule;
  BoundaryResult boundaries;  // partial_boundaries
  PartialLineStats stats;
  std::unique_ptr<SiteMetric> metric, nil_metric;  // the full- and nil-effect seeds' measures
  std::unique_ptr<OwnerIndex> index, nil_index;    // over them (owner_at by the rule: partial_owner_at)
  // The nil-effect seeds (held by pointer: nil_metric refers to them, and the result moves).
  std::shared_ptr<const SeedSet> nil_seeds;
  double seconds = 0.0;  // wall time, both fields and the lines
};
PartialEffectResult compute_partial_effect(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options,
                                           const BoundaryOptions& lines, bool draw_lines = true,
                                           const PartialEngines& engines = {});

// The owner of position p under the rule (regions' faces): owner_at at full and nil effect
// (`max_distance`: as owner_at's), then PartialEffectRule::owner.
int32_t partial_owner_at(const PartialEffectResult& r, Vec2 p,
                         double max_distance = std::numeric_limits<double>::infinity());

// The locus of owners a < b at p under the rule (region_edges' LocusFunction): in a band of B
// and X, -balance on B's side when a is B (+balance when b is); elsewhere the cost difference
// on the full-effect index. Its sign is continuous across the band's edges.
double partial_locus(const PartialEffectResult& r, int32_t a, int32_t b, Vec2 p);

}  // namespace rv
