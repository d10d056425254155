// The row kernels of the exact geodesic method (geodesic_kernels.hpp).
#include "geodesic/geodesic_kernels.hpp"

#include <cmath>
#include <limits>

#include "geodesic/geodesic_regime.hpp"
#include "rv/engine/engine.hpp"

namespace rv::detail {
namespace {

// Takes one value (squared: key) into the running results of four cells: a smaller key becomes
// the best (the old best competes for second); an equal key of the same vertex (tag >= 0) is
// the canonical tie of the per-cell method: the lower id, and no second.
#define RV_GEO_TAKE(key, tag, idv)                                      \
  do {                                                                  \
    const auto tie_ = ((key) == b) & ((tag) == btag) & ((tag) >= zero); \
    const auto lt_ = (key) < b;                                         \
    const GeoV4 hi_ = lt_ ? b : (key);                                  \
    s = tie_ ? s : (hi_ < s ? hi_ : s);                                 \
    id = tie_ ? ((idv) < id ? (idv) : id) : (lt_ ? (idv) : id);         \
    b = lt_ ? (key) : b;                                                \
    btag = lt_ ? (tag) : btag;                                          \
  } while (0)
// RV_GEO_TAKE for a value that ties with nothing (tag -1: a point site, an interior).
#define RV_GEO_TAKE_PLAIN(key, idv)    \
  do {                                 \
    const auto lt_ = (key) < b;        \
    const GeoV4 hi_ = lt_ ? b : (key); \
    s = hi_ < s ? hi_ : s;             \
    id = lt_ ? (idv) : id;             \
    b = lt_ ? (key) : b;               \
    btag = lt_ ? none : btag;          \
  } while (0)
#define RV_GEO_Q(p) (a0 * (p).qr[0] + a1 * (p).qr[1] + a2 * (p).qr[2] + a3 * (p).qr[3])
#define RV_GEO_QL(p) (l0 * (p).qr[0] + l1 * (p).qr[1] + l2 * (p).qr[2] + l3 * (p).qr[3])

// Cells c .. c + 3 of the row: their column weights into a0 .. a3 (w + b * stride: weight b of
// every column), their ECEF positions into x, y, z: on a geographic grid from the row's
// parallel (pos.rho, pos.z) and the columns' cos / sin (cell_at's arithmetic), else from the
// located positions.
#define RV_GEO_CELLS(c)                                  \
  do {                                                   \
    std::memcpy(&a0, w + (c), sizeof(a0));               \
    std::memcpy(&a1, w + stride + (c), sizeof(a1));      \
    std::memcpy(&a2, w + 2 * stride + (c), sizeof(a2));  \
    std::memcpy(&a3, w + 3 * stride + (c), sizeof(a3));  \
    if (pos.cos_lon) {                                   \
      decltype(x) cv_, sv_;                              \
      std::memcpy(&cv_, pos.cos_lon + (c), sizeof(cv_)); \
      std::memcpy(&sv_, pos.sin_lon + (c), sizeof(sv_)); \
      x = pos.rho * cv_;                                 \
      y = pos.rho * sv_;                                 \
      z = decltype(z){} + pos.z;                         \
    } else {                                             \
      std::memcpy(&x, pos.x + (c), sizeof(x));           \
      std::memcpy(&y, pos.y + (c), sizeof(y));           \
      std::memcpy(&z, pos.z_of + (c), sizeof(z));        \
    }                                                    \
  } while (0)

// interp_argmin_row for the commonest block: point-form candidates only, none of them a vertex
// (no ties by tag, nothing forced), the best's value being root(best2). Fewer running vectors
// than the general kernel: they all stay in registers. V: the version's vector type.
template <class V>
RV_LANES_INLINE void points_kernel_lanes(const RowCandidate* __restrict points, int kp, const double* __restrict w,
                                         int64_t stride, const RowPositions& pos, int64_t n, double* __restrict best2,
                                         double* __restrict second2, double* __restrict best_id) {
  const double inf = std::numeric_limits<double>::infinity();
  // One candidate into the running results; c2 = dx^2 + dy^2 + dz^2 in that order (apply()'s).
#define RV_GEO_POINT(dz2_expr)                                             \
  do {                                                                     \
    const V q = a0 * p.qr[0] + a1 * p.qr[1] + a2 * p.qr[2] + a3 * p.qr[3]; \
    const V dx = x - p.sx, dy = y - p.sy;                                  \
    const V c2 = dx * dx + dy * dy + (dz2_expr);                           \
    const V key = (q * q) * c2;                                            \
    const auto lt = key < b;                                               \
    const V hi = lt ? b : key;                                             \
    s = hi < s ? hi : s;                                                   \
    b = lt ? key : b;                                                      \
    const V idv = V{} + p.id;                                              \
    id = lt ? idv : id;                                                    \
  } while (0)
  for (int64_t c = 0; c < n; c += kLanesOf<V>) {
    V a0, a1, a2, a3, x, y, z;
    RV_GEO_CELLS(c);
    V b = V{} + inf, s = b, id = V{} + static_cast<double>(kNoSite);
    if (pos.cos_lon) {
      // A geographic grid's row is one parallel: every cell has the same z, and each
      // candidate's dz^2 comes with it (the same bits as computed here).
      for (int j = 0; j < kp; ++j) {
        const RowCandidate& p = points[j];
        RV_GEO_POINT(p.dz2);
      }
    } else {
      for (int j = 0; j < kp; ++j) {
        const RowCandidate& p = points[j];
        const V dz = z - p.sz;
        RV_GEO_POINT(dz * dz);
      }
    }
    std::memcpy(best2 + c, &b, sizeof(b));
    std::memcpy(second2 + c, &s, sizeof(s));
    std::memcpy(best_id + c, &id, sizeof(id));
  }
#undef RV_GEO_POINT
}
RV_LANE_KERNEL(void, points_kernel,
               (const RowCandidate* __restrict points, int kp, const double* __restrict w, int64_t stride,
                const RowPositions& pos, int64_t n, double* __restrict best2, double* __restrict second2,
                double* __restrict best_id),
               (points, kp, w, stride, pos, n, best2, second2, best_id))

// The segments whose form changes inside the block (RowSegment), for row_kernel_lanes' cells at
// x, y, z (column weights a0 .. a3 of the point form, l0 .. l3 of the additive form): each one's
// key by the form its ends' tests give each cell, taken into the running results b, s, id, btag,
// or `need` set where the cell must be measured exactly. A part of the kernel of its own (the
// kernel would be over the house's length), inlined into it: its vectors never cross a call.
template <class GeoV4>
RV_LANES_INLINE void take_segments(const RowSegment* __restrict segs, int ks, const GeoV4& x, const GeoV4& y,
                                   const GeoV4& z, const GeoV4& a0, const GeoV4& a1, const GeoV4& a2, const GeoV4& a3,
                                   const GeoV4& l0, const GeoV4& l1, const GeoV4& l2, const GeoV4& l3, const GeoV4& k2v,
                                   GeoV4& b, GeoV4& s, GeoV4& id, GeoV4& btag, GeoV4& need) {
  const double inf = std::numeric_limits<double>::infinity();
  constexpr double max2 = kVertexMaxChord * kVertexMaxChord, min2 = kVertexMinChord * kVertexMinChord;
  const GeoV4 zero = GeoV4{}, one = GeoV4{} + 1.0, none = GeoV4{} - 1.0;
  for (int j = 0; j < ks; ++j) {
    const RowSegment& g = segs[j];
    GeoV4 te[2], u2[2], c2[2];
    auto valid = (x == x);  // all lanes true
    for (int e = 0; e < 2; ++e) {
      const double* v = g.end[e];
      const GeoV4 tx = x - v[0], ty = y - v[1], tz = z - v[2];
      c2[e] = tx * tx + ty * ty + tz * tz;
      const GeoV4 tn = tx * v[3] + ty * v[4] + tz * v[5];
      u2[e] = c2[e] - tn * tn;
      te[e] = tx * v[6] + ty * v[7] + tz * v[8];
      valid = valid & (c2[e] <= GeoV4{} + max2) & (u2[e] >= GeoV4{} + min2);
    }
    const auto beyond0 = RV_GEO_BEYOND(te[0], u2[0], c2[0], k2v), beyond1 = RV_GEO_BEYOND(te[1], u2[1], c2[1], k2v);
    const auto r1 = (te[0] < zero) & beyond0;
    const auto r2 = ~r1 & (te[1] > zero) & beyond1;
    const auto r3 = ~r1 & ~r2 & (te[0] > zero) & beyond0 & (te[1] < zero) & beyond1;
    const RowCandidate& pa = g.part[0];
    const RowCandidate& pb = g.part[1];
    const RowCandidate& pi = g.part[2];
    const GeoV4 qa = RV_GEO_Q(pa), qb = RV_GEO_Q(pb), qi = RV_GEO_QL(pi);
    const GeoV4 ax = x - pa.sx, ay = y - pa.sy, az = z - pa.sz;
    const GeoV4 bx = x - pb.sx, by = y - pb.sy, bz = z - pb.sz;
    const GeoV4 ix = x - pi.sx, iy = y - pi.sy, iz = z - pi.sz;
    const GeoV4 ca = ax * ax + ay * ay + az * az, cb = bx * bx + by * by + bz * bz;
    const GeoV4 gi = ix * pi.nx + iy * pi.ny + iz * pi.nz;
    const GeoV4 h = (gi + (pi.k3 * (gi * gi)) * gi) + qi;  // normaliser() + q
    const GeoV4 vi = h < zero ? -h : h;
    const GeoV4 pq = r1 ? qa : qb, pc = r1 ? ca : cb;  // a vertex: the point form
    const GeoV4 pkey = (pq * pq) * pc;
    const auto vertex = r1 | r2;
    const auto missing = (r1 & (GeoV4{} + g.has[0] == zero)) | (r2 & (GeoV4{} + g.has[1] == zero)) |
                         (r3 & ((GeoV4{} + g.has[2] == zero) | (vi < GeoV4{} + kAdditiveMinValue)));
    const auto exact = ~valid | ~(r1 | r2 | r3) | missing;
    need = exact ? one : need;
    const GeoV4 key = exact ? GeoV4{} + inf : (vertex ? pkey : vi * vi);
    const GeoV4 tag = r1 ? GeoV4{} + pa.tag : (r2 ? GeoV4{} + pb.tag : none);
    const GeoV4 idv = GeoV4{} + pa.id;
    RV_GEO_TAKE(key, tag, idv);
  }
}

// One row of a block against all its interpolated candidates: per cell the smallest and second
// smallest squared value and the smallest's id. The smallest's value is the root of its square,
// with apply()'s bits: the point form's value is root(q^2 chord^2), the square's own root, with
// q = sum_b w_b qr_b; the additive form's is v = |h + q|, and root(v * v) = v exactly (in binary
// floating point the correctly rounded root of a correctly rounded square is the absolute
// value, without overflow or underflow; checked on 4e8 random doubles of 2^-10 .. 2^50 too).
// So no factors of the value are carried (they were two more running vectors and two more
// blends per candidate, spilled with AVX2's 16 registers). Candidates pass in
// any order: equal squared values of different interpolants leave a gap of 0, a close call the
// caller decides by the per-cell method, and those of one vertex tie as RV_GEO_TAKE says,
// order-free. Segments whose form changes in the block (segs) get segment_regime's test per cell,
// with its operations, and the value of the form it picks; force[c] = 1 where a cell's regime is 0
// (measured exactly by the per-cell method), its form has no interpolant, or an additive value
// is under kAdditiveMinValue (which value() measures exactly): the caller solves those cells
// by the per-cell method.
//
// Why this shape: the cells are taken a vector at a time (RowVec) and every candidate passes while
// the running results stay in registers (candidate-outer loops loaded and stored them once per
// candidate per cell); squared values need no root per candidate (the caller takes one per
// cell). The column weights come as eight arrays (w + b * stride: weight b of every column,
// b = 0 .. 3 in the point form's block, 4 .. 7 in the additive form's: a point site or a
// segment's end uses the first four, an edge's interior the last four), the cells' ECEF
// positions as RowPositions says; every array holds n rounded up to a multiple
// of kRowPad. Vectors stay inside this function (a 32-byte vector crossing a function boundary
// has another ABI with and without AVX).
template <class V>
RV_LANES_INLINE void row_kernel_lanes(const RowCandidate* __restrict points, int kp,
                                      const RowCandidate* __restrict additive, int ka,
                                      const RowSegment* __restrict segs, int ks, const RowMasked* __restrict masked,
                                      const int* km, const double* __restrict w, int64_t stride,
                                      const RowPositions& pos, int64_t n, double* __restrict best2,
                                      double* __restrict second2, double* __restrict best_id, double* __restrict force,
                                      double k2) {
  using GeoV4 = RowVec<V>;  // (the name the RV_GEO_* macros use)
  const double inf = std::numeric_limits<double>::infinity();
  const GeoV4 k2v = GeoV4{} + k2;
  constexpr double max2 = kVertexMaxChord * kVertexMaxChord, min2 = kVertexMinChord * kVertexMinChord;
  for (int64_t c = 0; c < n; c += kLanesOf<GeoV4>) {
    GeoV4 a0, a1, a2, a3, x, y, z, l0, l1, l2, l3;
    RV_GEO_CELLS(c);
    std::memcpy(&l0, w + 4 * stride + c, sizeof(l0));
    std::memcpy(&l1, w + 5 * stride + c, sizeof(l1));
    std::memcpy(&l2, w + 6 * stride + c, sizeof(l2));
    std::memcpy(&l3, w + 7 * stride + c, sizeof(l3));
    const GeoV4 zero = GeoV4{}, one = GeoV4{} + 1.0, none = GeoV4{} - 1.0;
    GeoV4 b = GeoV4{} + inf, s = b, id = GeoV4{} + static_cast<double>(kNoSite), btag = none;
    GeoV4 need = zero;
    for (int j = 0; j < kp; ++j) {
      const RowCandidate& p = points[j];
      const GeoV4 q = RV_GEO_Q(p);
      const GeoV4 dx = x - p.sx, dy = y - p.sy, dz = z - p.sz;
      const GeoV4 c2 = dx * dx + dy * dy + dz * dz;
      const GeoV4 key = (q * q) * c2;
      const GeoV4 idv = GeoV4{} + p.id;
      if (p.tag < 0.0)
        RV_GEO_TAKE_PLAIN(key, idv);
      else {
        const GeoV4 tag = GeoV4{} + p.tag;
        RV_GEO_TAKE(key, tag, idv);
      }
    }
    for (int j = 0; j < ka; ++j) {
      const RowCandidate& p = additive[j];
      const GeoV4 q = RV_GEO_QL(p);
      const GeoV4 dx = x - p.sx, dy = y - p.sy, dz = z - p.sz;
      const GeoV4 g = dx * p.nx + dy * p.ny + dz * p.nz;
      const GeoV4 h = (g + (p.k3 * (g * g)) * g) + q;  // normaliser() + q
      const GeoV4 v = h < zero ? -h : h;
      const GeoV4 key = v * v;
      const GeoV4 idv = GeoV4{} + p.id;
      RV_GEO_TAKE_PLAIN(key, idv);
    }
    // Interiors masked by one end's test (masked[0 .. km[0]): the first end's, then km[1] of
    // the second's, then km[2] of neither): segment_regime's operations at that end, the other
    // end's part of the test being settled over the block.
    for (int grp = 0, j = 0; grp < 3; ++grp)
      for (const int end_j = j + km[grp]; j < end_j; ++j) {
        const RowMasked& g = masked[j];
        const RowCandidate& pi = g.part;
        const GeoV4 qi = RV_GEO_QL(pi);
        const GeoV4 ix = x - pi.sx, iy = y - pi.sy, iz = z - pi.sz;
        const GeoV4 gi = ix * pi.nx + iy * pi.ny + iz * pi.nz;
        const GeoV4 h = (gi + (pi.k3 * (gi * gi)) * gi) + qi;  // normaliser() + q
        const GeoV4 vi = h < zero ? -h : h;
        auto inside = (x == x), at_vertex = ~inside, valid = inside;  // neither: inside everywhere
        if (grp < 2) {
          const double* v = g.end;
          const GeoV4 tx = x - v[0], ty = y - v[1], tz = z - v[2];
          const GeoV4 c2 = tx * tx + ty * ty + tz * tz;
          const GeoV4 tn = tx * v[3] + ty * v[4] + tz * v[5];
          const GeoV4 u2 = c2 - tn * tn;
          const GeoV4 te = tx * v[6] + ty * v[7] + tz * v[8];
          valid = (c2 <= GeoV4{} + max2) & (u2 >= GeoV4{} + min2);
          const auto beyond = RV_GEO_BEYOND(te, u2, c2, k2v);
          inside = (grp == 0 ? te > zero : te < zero) & beyond;
          at_vertex = (grp == 0 ? te < zero : te > zero) & beyond;
        }
        const auto missing = inside & ((GeoV4{} + g.has == zero) | (vi < GeoV4{} + kAdditiveMinValue));
        const auto exact = ~valid | ~(inside | at_vertex) | missing;
        need = exact ? one : need;
        const GeoV4 key = (inside & ~exact) ? vi * vi : GeoV4{} + inf;
        const GeoV4 idv = GeoV4{} + pi.id;
        RV_GEO_TAKE_PLAIN(key, idv);
      }
    take_segments(segs, ks, x, y, z, a0, a1, a2, a3, l0, l1, l2, l3, k2v, b, s, id, btag, need);
    std::memcpy(best2 + c, &b, sizeof(b));
    std::memcpy(second2 + c, &s, sizeof(s));
    std::memcpy(best_id + c, &id, sizeof(id));
    std::memcpy(force + c, &need, sizeof(need));
  }
}
RV_LANE_KERNEL(void, row_kernel,
               (const RowCandidate* __restrict points, int kp, const RowCandidate* __restrict additive, int ka,
                const RowSegment* __restrict segs, int ks, const RowMasked* __restrict masked, const int* km,
                const double* __restrict w, int64_t stride, const RowPositions& pos, int64_t n,
                double* __restrict best2, double* __restrict second2, double* __restrict best_id,
                double* __restrict force, double k2),
               (points, kp, additive, ka, segs, ks, masked, km, w, stride, pos, n, best2, second2, best_id, force, k2))
#undef RV_GEO_TAKE
#undef RV_GEO_TAKE_PLAIN
#undef RV_GEO_CELLS
#undef RV_GEO_Q
#undef RV_GEO_QL

}  // namespace

// The outputs of one row of the row kernels' cells (at least one candidate, so every cell has
// a best id): the best's value root(best2) (apply()'s bits, see interp_argmin_row); the site
// and distance as put() writes them (no site beyond max_distance); and second2[c] = 1 where
// the call may be too close for interpolated values (the two smallest within kInterpTie, or the
// best within kInterpTie of max_distance) or force[c] is set (force: null for
// interp_argmin_points, which forces nothing), else 0. Returns whether any cell is flagged.
// value: scratch of n.
//
// The close test runs on squares, without a second root: s - b <= t implies
// s^2 - b^2 = (s - b)(s + b) <= 2 t s, so (s^2 - b^2)^2 <= 4 t^2 s^2 holds for every close call.
// It also flags a few calls up to 2 t apart; the caller decides every flagged cell with the
// per-cell method, so those get exactly what that method gives them.
// Written as loops the vectoriser takes (one root per cell, no branches); the cells beyond a
// distance limit are fixed afterwards, since a select between converted floats is not taken.
// The commonest case (nothing forced, no limit) is one pass.
RV_KERNEL_CLONES bool interp_store_row(const double* __restrict best2, double* __restrict second2,
                                       const double* __restrict best_id, double* __restrict value,
                                       const double* __restrict force, int64_t n, double max_distance,
                                       int32_t* __restrict site_row, float* __restrict distance_row) {
  constexpr double kTie2x4 = 4.0 * kInterpTie * kInterpTie;
  constexpr double inf = std::numeric_limits<double>::infinity();
  int64_t any = 0;
  if (max_distance == inf) {  // no limit: one pass
    for (int64_t c = 0; c < n; ++c) {
      const double b2 = best2[c], s2 = second2[c], gap = s2 - b2;
      const int64_t tie = (s2 < inf) & (gap * gap <= kTie2x4 * s2);
      second2[c] = tie ? 1.0 : 0.0;
      any |= tie;
      site_row[c] = static_cast<int32_t>(best_id[c]);
      distance_row[c] = static_cast<float>(std::sqrt(b2));
    }
  } else {
    for (int64_t c = 0; c < n; ++c) {
      const double b2 = best2[c], s2 = second2[c], gap = s2 - b2, v = std::sqrt(b2);
      value[c] = v;
      const int64_t tie = ((s2 < inf) & (gap * gap <= kTie2x4 * s2)) | (std::abs(v - max_distance) <= kInterpTie);
      second2[c] = tie ? 1.0 : 0.0;
      any |= tie;
    }
    for (int64_t c = 0; c < n; ++c) site_row[c] = static_cast<int32_t>(best_id[c]);
    for (int64_t c = 0; c < n; ++c) distance_row[c] = static_cast<float>(value[c]);
    for (int64_t c = 0; c < n; ++c)
      if (value[c] > max_distance) {
        site_row[c] = kNoSite;
        distance_row[c] = kNoDistance;
      }
  }
  if (force) {
    int64_t forced = 0;
    for (int64_t c = 0; c < n; ++c) {
      const int64_t f = force[c] != 0.0;
      second2[c] = f ? 1.0 : second2[c];
      forced |= f;
    }
    any |= forced;
  }
  return any != 0;
}

void interp_argmin_points(const RowCandidate* points, int kp, const double* w, int64_t stride, const RowPositions& pos,
                          int64_t n, double* best2, double* second2, double* best_id) {
  points_kernel(points, kp, w, stride, pos, n, best2, second2, best_id);
}

void interp_argmin_row(const RowCandidate* points, int kp, const RowCandidate* additive, int ka, const RowSegment* segs,
                       int ks, const RowMasked* masked, const int* km, const double* w, int64_t stride,
                       const RowPositions& pos, int64_t n, double* best2, double* second2, double* best_id,
                       double* force, double k2) {
  row_kernel(points, kp, additive, ka, segs, ks, masked, km, w, stride, pos, n, best2, second2, best_id, force, k2);
}

}  // namespace rv::detail
