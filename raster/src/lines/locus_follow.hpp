// A locus followed where cells do not show it: the zero level of a balance (the difference of two
// costs) walked in small steps, each point a root across the step, to a coast, the frame or a
// target. Two users: the partial effect by sea (rv/lines/partial_effect.hpp), through its bands
// from turning points, where land may cut a band; and a boundary line's end whose cells stop
// where it goes on round land they do not show (follow_on, boundary_stages::end_at_barriers).
//
// The partial effect's bands.
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
// A band with no turning point at all -- a full-effect line wholly in it, such as a port that the
// island shuts in at full effect -- has no start to follow from; its locus is found where the
// rule's cells change owner (partial_loci.hpp) and followed both ways from there to coasts or the
// frame, or round to where it began (follow_through). That holds for the straight metric as well
// (no land: every step open).
//
// A point of the locus is a root of the balance: where its sign changes by a jump instead (across
// a boom, each face's costs are its own; the balance far from 0 where the bracket closes), there is
// no locus, and the walk does not take one.
//
// Internal to rv_raster. Thread safety: pure over its arguments (the functions must be callable
// from the calling thread).
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "rv/engine/site_metric.hpp"
#include "rv/field/grid.hpp"
#include "rv/lines/residual.hpp"

namespace rv::locus_follow {

// What the locus is, and where its band is.
struct Level {
  std::function<double(Vec2)> balance;  // metric units; >= 0 on L0's side, 0 on the locus
  std::function<bool(Vec2)> in_band;    // the full-effect owner B and the nil-effect one X at p
  const SiteMetric* metric = nullptr;   // the full effect's (open_between, the coasts' edges)
  GridSpec grid;                        // the field's: its frame of cell centres, its cell size
  double ftol = 0.0;                    // |balance| accepted as on the locus, metric units
  double tol = 0.0;                     // the line tolerance, CRS units (chords to the locus)
  double per_crs = 1.0;                 // metric units per CRS unit (residuals as lengths)
  // How fast the balance can change along an open way, per metric unit (+infinity: unknown);
  // line_tools::onto_domain_edge's `slope`, for the search of a coast.
  double slope = std::numeric_limits<double>::infinity();
  // Optional (follow_on): the way to the nearer of the locus's two sides at p, CRS units (for two
  // owners' locus, the smaller of their distances, as CRS units at most). Where given, a step is
  // at most half of it, so the walk goes on up a channel far narrower than a cell (a sliver of sea
  // between two states' land along their border); and where it falls below `meet` the two sides
  // meet there (their coasts cross or touch): the walk ends as on a coast.
  std::function<double(Vec2)> clearance;
  double meet = 0.0;  // CRS units
  // With `clearance`: where the two sides meet ahead of p, into `at`, when the locus runs straight
  // from p to there (the bisector of two coast edges, from p to their crossing); false where it
  // does not. The walk then ends there, on the coast, if p sees it and it lies ahead.
  std::function<bool(Vec2 p, Vec2& at)> meeting;
};

enum class Stop {
  target,  // reached the other turning point (the last point is it)
  coast,   // ended on a barrier's edge (the last point, BoundaryVertex::on_barrier)
  frame,   // ended on the frame of the outermost cell centres
  lost,    // the level could not be followed on (no root across a step)
  closed,  // back at its start (follow_through: a loop; the last point is the first)
};

struct Followed {
  std::vector<Vec2> points;  // from the start on, the start included
  Stop stop = Stop::lost;    // how its last point was reached
  int other = -1;            // Stop::target at others[other] (-1: at `target`, or not at a target)
  // follow_on only: lost where the level's next point, `beyond`, lies out of the band (a third
  // owner nearer there: the tripoint lies between the last point and it).
  bool left_band = false;
  Vec2 beyond{};
};

// The locus followed from `start` (a turning point, where L1 leaves L0) into the band, until
// `target` (the turning point where the band closes; null where it runs to a line's end) or a
// coast or the frame; its chords then made to lie within level.tol of the locus (midpoints
// added), each chord kept measured into `residual`.
// `others`: further points at which the walk also stops as at a target (the turning points of
// the same band on other pieces of a full-effect line that a coast cut: the band goes on past
// the coast's point where L1 touched it).
Followed follow(const Level& level, Vec2 start, const Vec2* target, LineResidual& residual,
                const std::vector<Vec2>& others = {});

// A locus followed both ways from a point of it inside its band.
struct Through {
  std::vector<Vec2> points;                    // from one end to the other (closed: last == first)
  Stop first = Stop::lost, last = Stop::lost;  // how each end was reached (both `closed` for a loop)
};

// The locus through `on` (a point of it in the band where it crosses no line yet drawn: where
// the rule's cells change owner, partial_loci.hpp) followed both ways, each to a coast or the
// frame, or round to `on` again; its chords made to lie within level.tol of the locus as follow's.
// Empty where the level has no direction at `on`. `step`: CRS units a step (0: half a cell; a
// channel narrower than that needs a shorter one, or the walk jumps across it).
Through follow_through(const Level& level, Vec2 on, LineResidual& residual, double step = 0.0);

// The locus followed on from `from` (a point of it where a line stops; `heading` the way the line
// goes on there, any length) in steps of `step` CRS units, at most `max_steps` of them: to a coast
// (the last point on a barrier's edge), the frame, or until the level is lost or leaves the band
// (Stop::lost, also where the steps run out; Followed::left_band where it leaves the band). The
// points walked, `from` first, unrefined: the caller refines the chords as it does every other
// line's. Any two-owner locus will do (the balance the difference of their costs, the band where
// no third owner is nearer).
// `others`: points at which the walk stops as at a target (Stop::target, Followed::other its
// index, the last point that point): other lines' ends on the same locus, to join.
// `left` (or null): the coast point the walk leaves from (a junction of the locus with a barrier's
// edge, `from` just off it); the walk does not end back on it (within a ten-thousandth of a cell)
// but on the coast it reaches.
Followed follow_on(const Level& level, Vec2 from, Vec2 heading, double step, int64_t max_steps,
                   const std::vector<Vec2>& others = {}, const Vec2* left = nullptr);

}  // namespace rv::locus_follow
