// The row kernels of the exact geodesic method: one row of a leaf block against all its
// interpolated candidates at once, vectorised (one version per instruction set, picked at load
// time: kernel_memory.hpp), computing per cell the best and second-best squared value and the
// best id with exactly the operations the per-cell method uses, so that a cell gets the same
// bits whichever path decides it. The structures below are the rows' candidates as the leaf
// (geodesic_exact.cpp, solve_interp) prepares them.
//
// Thread safety: pure functions over the caller's arrays.
#pragma once

#include <algorithm>
#include <cstdint>
#include <type_traits>

#include "engine/kernel_memory.hpp"
#include "geodesic/geodesic_interpolant.hpp"

namespace rv::detail {

// One candidate of solve_interp on the current row: its interpolated quantity already reduced
// over the row weights (qr), its interpolant's point and plane normal (additive form), its id
// and its tag (the distinct vertex it measures, -1 for anything else; doubles, exact below
// 2^53, so one compare mask blends them with the values).
struct RowCandidate {
  double qr[4];
  double sx, sy, sz, nx, ny, nz, id, tag, k3;
  double dz2;  // interp_argmin_points on a geographic grid: (z - sz)^2 of the row's z
};

// A segment whose form changes inside the block: its two ends as segment_regime sees them and
// its three interpolants (first end, second end, interior), each with has = 1 or 0 (none).
struct RowSegment {
  RowCandidate part[3];
  double has[3];
  double end[2][9];  // x, y, z, nx, ny, nz, ex, ey, ez
};

// A segment whose form changes in the block at one end only, the other end's test being settled
// over the block (BlockRegime::ahead_a, before_b), or only by coming within kAdditiveMinValue of
// the edge: its interior, as an additive candidate masked to the cells that end's test puts
// inside the edge. Cells the test puts at the vertex take the vertex's own point candidate,
// gathered beside it (a vertex's distance is never below the edge's, so that candidate is sound
// everywhere). Cheaper than a RowSegment: one end's test and one form per cell.
struct RowMasked {
  RowCandidate part;  // the interior
  double has;         // 1 or 0: the interior has an interpolant
  double end[9];      // the end whose test decides, as RowSegment::end (unused: neither)
};

// Where the row kernels find a row's cell positions: cos_lon / sin_lon (the row's columns, padded
// to whole vectors) with the parallel's radius rho and height z, or, when cos_lon is null, the
// located positions x, y, z_of (padded likewise).
struct RowPositions {
  const double* cos_lon = nullptr;
  const double* sin_lon = nullptr;
  double rho = 0.0, z = 0.0;
  const double* x = nullptr;
  const double* y = nullptr;
  const double* z_of = nullptr;
};

// Cells per step of the row kernels, at most: one vector of their version (RV_LANE_KERNEL: 8
// lanes in a single AVX-512 register, 4 with AVX2, 2 by default), and at most 4 for
// interp_argmin_row (RowVec). Rows are padded to whole steps of both.
constexpr int64_t kRowLanes = 4;
constexpr int64_t kPointLanes = 8;
constexpr int64_t kRowPad = std::max(kRowLanes, kPointLanes);
static_assert(kRowPad % kRowLanes == 0 && kRowPad % kPointLanes == 0, "rows padded to whole steps");
// interp_argmin_row's vector in the version for V: V, but no wider than 4 lanes. 8 lanes were
// slower with AVX-512 (bench/RESULTS-kernels.md): its running values outnumber the registers.
template <class V>
using RowVec = std::conditional_t<(kLanesOf<V> > kRowLanes), VecD4, V>;

// One row of points-only candidates (every candidate a point form): per cell the smallest and
// second smallest squared value (best2, second2) and the best's id (best_id, as a double), over
// the n cells of `pos`, the candidates' quantities reduced by the row weights already (qr) and the
// column weights w (stride: the columns' weight rows).
void interp_argmin_points(const RowCandidate* points, int kp, const double* w, int64_t stride, const RowPositions& pos,
                          int64_t n, double* best2, double* second2, double* best_id);

// The same with additive candidates (edges' interiors), segments whose form changes in the block
// (segs: each cell takes the form SegmentRegimes::at would give it) and masked interiors
// (masked, km[0..2] of them by deciding end); force[c] = 1 where a cell needs the per-cell method
// (a regime not certain, an additive value under kAdditiveMinValue). k2: RV_GEO_BEYOND's K2.
void interp_argmin_row(const RowCandidate* points, int kp, const RowCandidate* additive, int ka, const RowSegment* segs,
                       int ks, const RowMasked* masked, const int* km, const double* w, int64_t stride,
                       const RowPositions& pos, int64_t n, double* best2, double* second2, double* best_id,
                       double* force, double k2);

// The outputs of one row from the kernels' results (see its definition for the close-call test).
bool interp_store_row(const double* best2, double* second2, const double* best_id, double* value, const double* force,
                      int64_t n, double max_distance, int32_t* site_row, float* distance_row);

}  // namespace rv::detail
