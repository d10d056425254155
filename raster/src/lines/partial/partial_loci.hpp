// The partial-effect loci of one band that no drawn line follows, found from the rule's cells
// (rv/lines/partial_effect.hpp).
//
// Why from the cells: a band is followed from its turning points, where L1 leaves L0. A band whose
// full-effect line lies wholly in it (a port of X that B's island shuts in at full effect: L1 is
// an arc round the port, L0 far off) has none, and its locus may touch neither line. The rule's
// field is exact per cell, so wherever the locus separates two cell centres, one of them is given
// back to X and its 4-neighbour is kept by B; the balance changes sign between their centres and
// its root there is a point of the locus to follow both ways (locus_follow::follow_through). A
// piece of locus that passes between no two centres changes no cell's owner: the lines of such a
// piece are below the grid's resolution and are not drawn (as extraction draws no boundary that
// separates no two cells).
// By sea a channel narrower than a cell may hold centres of both owners that are no
// 4-neighbours (they meet across corners, or a cell or two apart along the water): a given-back
// and a kept cell up to two cells apart, in sight of each other, whose way crosses no line yet
// drawn, also hold a root of the locus; it is followed in steps of an eighth of a cell (half a
// cell jumps the channel), and left undrawn where that walk is lost.
//
// Internal to rv_raster. Thread safety: pure over its arguments (the level's functions are called
// from the calling thread only).
#pragma once

#include <cstdint>
#include <vector>

#include "lines/locus_follow.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/seeds.hpp"

namespace rv::partial_loci {

// The loci of band (B, X) of `level` that pass between two cell centres and that no line in
// `drawn` already follows (4-neighbours: within a cell of it; pairs farther apart: no line
// crosses their way), each followed both ways, in row-major order of the cell pair each was
// found from, the 4-neighbours' first (deterministic). `full`: the full-effect field; `field`: the
// rule's (partial_field); both whole fields of level.grid with sites numbered in `seeds`. A
// locus whose following is lost comes back with that Stop at an end (the caller refuses it).
std::vector<locus_follow::Through> loci_from_cells(const locus_follow::Level& level, const NearestField& full,
                                                   const NearestField& field, const SeedSet& seeds, int32_t B,
                                                   int32_t X, const std::vector<std::vector<Vec2>>& drawn,
                                                   LineResidual& residual);

}  // namespace rv::partial_loci
