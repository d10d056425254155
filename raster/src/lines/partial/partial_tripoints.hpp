// Partial effect at the full-effect tripoints of the partial features' owner B and two
// neighbours (rv/lines/partial_effect.hpp): where each band's partial line meets the neighbours'
// nil-effect line, the neighbours' line carried along it to the partial tripoint, and the zone of
// an island that the rule gives back whole there.
//
// Why a zone given back whole is drawn from the nil-effect lines: where the partial features lie
// far from their owner's nil-effect lines (Bornholm in the western Baltic), the balance
// e d(L1) - (1 - e) d(L0) stays below 0 over the bands near a tripoint, so no partial line reaches
// the neighbours' nil-effect line there: every cell beside that line is the nil-effect run's, and
// the result's boundary between the neighbours is their nil-effect line itself, as far as both its
// sides are given back -- on to a nil-effect tripoint of three neighbours inside the zone, which is
// then a tripoint of the result.
//
// Internal to rv_raster. Thread safety: pure functions of their arguments.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "lines/partial/polyline_along.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/partial_effect.hpp"

namespace rv::partial_tripoints {

using polyline_along::Along;

// An owner's label, quoted, for messages.
std::string owner_label(const SeedSet& seeds, int32_t owner);

// Where the partial features' zone meets two neighbours X and Y at a full-effect tripoint T: the
// two bands (X's and Y's cells that B takes at full effect) share the nil-effect X-Y line from T
// into the zone (S). Each band's partial line ends where it meets S (M_X, M_Y: where that
// neighbour's balance changes sign along S); the one nearer T is the partial tripoint, the other
// owner's line goes on along S to it, and the X-Y line follows S from T to it.
struct TripointPlan {
  size_t index = 0;  // into the tripoints
  Vec2 T;
  std::array<int32_t, 2> owners{0, 0};  // X, Y
  std::vector<Vec2> S;                  // from T
  std::array<Along, 2> at{};            // M_X, M_Y on S
  std::array<Vec2, 2> m{};
  int first = 0;  // whose M is nearer T
  // Both bands given back all along S (an island far from its owner's nil-effect lines): no
  // partial line meets S, M_X = M_Y = S's end, and the X-Y line follows the whole of S; T is no
  // tripoint of the result (given_back_zone).
  bool whole = false;
  bool end_on_barrier = false;  // S's end is its nil-effect line's end on a coast
  Vec2 tripoint() const { return m[static_cast<size_t>(first)]; }
  int side(int32_t owner) const { return owner == owners[0] ? 0 : 1; }
};

// The plans of the full-effect tripoints (in `full`, sites in `seeds`) where the partial features'
// zone meets two neighbours; `index`: the full-effect field's; `cell`: the grid's cell size (CRS
// units); `ftol`: the balance's root tolerance (metric units). Throws rv::Error(unsupported) where
// the lines there do not meet as TripointPlan says, or only one band is given back whole.
std::vector<TripointPlan> plan_tripoints(const PartialEffectRule& rule, const SeedSet& seeds,
                                         const BoundaryResult& full, const OwnerIndex& index, double cell, double ftol);

// The neighbours' line at each planned tripoint carried along S to the partial tripoint, and the
// tripoint moved there (a whole plan's line along all of S, its tripoint left to
// given_back_zone). Returns the vertices added.
int64_t extend_at_tripoints(const PartialEffectRule& rule, const std::vector<TripointPlan>& plans,
                            const OwnerIndex& index, BoundaryResult& out);

// Where plans are whole: the nil-effect lines of two neighbours lying wholly where both sides are
// given back (inside the zone, no full tripoint on them) added as lines of the result, the
// nil-effect tripoints of three neighbours that whole plans' S reach made tripoints of it, and
// the whole plans' full-effect tripoints removed. Throws rv::Error(unsupported) where a nil-effect
// line reaching such a tripoint is not given back whole. Returns the vertices added.
int64_t given_back_zone(const PartialEffectRule& rule, const SeedSet& seeds, const std::vector<TripointPlan>& plans,
                        const OwnerIndex& index, double cell, BoundaryResult& out);

}  // namespace rv::partial_tripoints
