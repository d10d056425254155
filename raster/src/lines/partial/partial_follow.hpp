// By sea (rv/lines/partial_effect.hpp): the partial-effect locus followed through its band from a
// turning point, where land may cut the band.
//
// Why not the two chains paired by their fraction of length, as partial_effect.cpp traces the
// straight case: by sea land cuts the lines. The nil-effect line of an island's owner stops at
// the island's coast where it would cross it, a full-effect line may end on the neighbour's coast,
// and a band is then bounded by stretches of L0, of L1 and of coast, in any number of pieces; no
// pairing of two chains describes it. The locus is the zero level of the balance (1-Lipschitz,
// continuous), which inside a band touches L0 or L1 only where they meet (at turning points) and
// otherwise leaves the band only at a coast, the grid's frame or a tripoint. So it is followed:
// predicted along the level's tangent, each point placed on it across that step (a root of the
// balance), until it reaches the other turning point, a coast (its end then on the barrier's edge,
// where the coast has the balance 0) or the frame.
//
// Internal to rv_raster. Thread safety: pure over its arguments (the functions must be callable
// from the calling thread).
#pragma once

#include <functional>
#include <vector>

#include "rv/engine/site_metric.hpp"
#include "rv/field/grid.hpp"
#include "rv/lines/residual.hpp"

namespace rv::partial_follow {

// What the locus is, and where its band is.
struct Level {
  std::function<double(Vec2)> balance;  // metric units; >= 0 on L0's side, 0 on the locus
  std::function<bool(Vec2)> in_band;    // the full-effect owner B and the nil-effect one X at p
  const SiteMetric* metric = nullptr;   // the full effect's (open_between, the coasts' edges)
  GridSpec grid;                        // the field's: its frame of cell centres, its cell size
  double ftol = 0.0;                    // |balance| accepted as on the locus, metric units
  double tol = 0.0;                     // the line tolerance, CRS units (chords to the locus)
  double per_crs = 1.0;                 // metric units per CRS unit (residuals as lengths)
};

enum class Stop {
  target,  // reached the other turning point (the last point is it)
  coast,   // ended on a barrier's edge (the last point, BoundaryVertex::on_barrier)
  frame,   // ended on the frame of the outermost cell centres
  lost,    // the level could not be followed on (no root across a step)
};

struct Followed {
  std::vector<Vec2> points;  // from the start on, the start included
  Stop stop = Stop::lost;    // how its last point was reached
};

// The locus followed from `start` (a turning point, where L1 leaves L0) into the band, until
// `target` (the turning point where the band closes; null where it runs to a line's end) or a
// coast or the frame; its chords then made to lie within level.tol of the locus (midpoints
// added), each chord kept measured into `residual`.
Followed follow(const Level& level, Vec2 start, const Vec2* target, LineResidual& residual);

}  // namespace rv::partial_follow
