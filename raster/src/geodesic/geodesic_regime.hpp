// Which part of a geodesic segment is nearest from a cell: one of its ends, its interior, or not
// certain. The exact geodesic method (geodesic_exact.cpp) interpolates a segment's distance where
// the form is certain (a vertex's point form, the interior's additive form) and measures it
// exactly where it is not; this file is the one definition of "certain", per cell (at) and over a
// block (over_block), and of the margin test the row kernels repeat with vectors (RV_GEO_BEYOND).
//
// A segment is nearest at one of its ends V when the geodesic from V to the cell leaves at an
// angle w against the edge with cos(w) <= 0 (first end; >= 0 at the second): by convexity the
// distance then grows all along the edge. Per cell this is tested with the normal section's
// direction instead of the geodesic's (the projection u of the chord t = P - V onto V's tangent
// plane, with te = t . e along the edge's tangent e: cos w_ns = te / |u|), beyond a margin
// (RV_GEO_BEYOND) that makes two things certain:
//  - the geodesic's cos w has the sign of the normal section's. The two directions differ by at
//    most eps(d) = (e^2 / 12) (d / a)^2 (measured: 1.01-1.02x that over 200 000 random pairs at
//    each of 1 km .. 2000 km; 1.4e-5 rad at 1000 km), and |cos w_geo - cos w_ns| <= eps;
//  - brute force's search (GeoSites::piece_distance) returns V's canonical distance: its
//    stopping test, |step cos w| = (m12 / M12) cos^2 w < 2 kGeoConvergence, cannot fire at a
//    point of the edge before V is evaluated. Along the edge away from the cell s and |cos w|
//    only grow (convexity), and m12 / M12 >= 0.98 s within kVertexMaxChord, so it is enough
//    that s cos^2 w_geo >= k0 = 2 kGeoConvergence / 0.98 at V.
// With a safety factor of 16 on k0 (4 on cos w), k = 16 k0: cos^2 w_ns >= 2 k / s + 2 eps^2
// gives |cos w_ns| >= sqrt(k / s) + eps, so |cos w_geo| >= sqrt(k / s) >= 4 sqrt(k0 / s). As
// s >= |chord| >= |u|, it holds when te^2 >= 4 k |u| and te^2 >= 4 eps^2 u^2, i.e.
// te^4 >= kVertexStop4 u^2 with kVertexStop4 = 16 k^2, and te^2 >= K2 chord^4 u^2 with
// K2 = 4 (1.1 (e^2 / 12) / a^2)^2 (1.1 covers the measured 1.02 and d vs chord): no root, no
// division, the same operations in the per-cell test and the row kernel. The band it leaves
// around a switch is narrow: |cos w_ns| ~ 1.1e-4 at 1 m, 1.1e-6 at 10 km, 3e-5 at 1000 km
// (a constant 2e-4 before, 7x the bound at 1000 km: on the Oresund fixture at 0.00038 deg it
// sent 9 350 cells per run to the per-cell method, 74 now).
//
// Thread safety: a SegmentRegimes is immutable after construction; any number of threads may
// query it. Units: ECEF metres.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "field/geodesic_sites.hpp"

namespace rv::detail {

constexpr double kVertexStop4 = 16.0 * (16.0 * 2.0 * kGeoConvergence / 0.98) * (16.0 * 2.0 * kGeoConvergence / 0.98);
constexpr double kVertexMaxChord = 1e6;  // metres
constexpr double kVertexMinChord = 1.0;  // metres

// K2 of the margin above for an ellipsoid (semi-major axis a, flattening f), 1 / m^4.
inline double vertex_k2(double a, double f) {
  const double e2 = std::abs(f * (2.0 - f));
  const double eps = 1.1 * (e2 / 12.0) / (a * a);
  return 4.0 * eps * eps;
}

// The margin test at one end (see kVertexStop4): te, u2 = |u|^2 and c2 = |t|^2 of the cell as
// segment_regime computes them, k2 = K2; doubles or a row kernel's vectors (the same operations
// either way; a macro, as a 32-byte vector returned by a function has another ABI with and
// without AVX).
#define RV_GEO_BEYOND(te, u2, c2, k2) \
  ((((te) * (te)) * ((te) * (te)) > kVertexStop4 * (u2)) & (((te) * (te)) > ((k2) * ((c2) * (c2))) * (u2)))

// A segment's end as the per-cell vertex test sees it: position, ellipsoid normal, and the unit
// tangent of the edge there (pointing from the first end to the second at both ends).
struct SegmentEnd {
  double lat, lon;
  double x, y, z, nx, ny, nz, ex, ey, ez;
  int32_t vertex;  // the distinct vertex (same lat/lon bits: the same index for every edge at it)
};

// The part of a segment that is nearest from a cell. The value is also the index of the
// interpolant of that part (uncertain: none for a segment, the point form for a point site).
enum class Regime : int { uncertain = 0, first_end = 1, second_end = 2, interior = 3 };
constexpr int index_of(Regime r) { return static_cast<int>(r); }
// The end a vertex regime is at: 0 for first_end, 1 for second_end.
constexpr int end_of(Regime r) { return static_cast<int>(r) - 1; }
constexpr bool at_vertex(Regime r) { return r == Regime::first_end || r == Regime::second_end; }

// What segment_regime can give for segment `id` at the cells of a block whose centres lie
// within `radius` of the ECEF point (cx, cy, cz): `certain` is the regime every cell
// certainly has (0: not certain), `possible` a bit per regime 1..3 that some cell may have
// (bit r - 1; a regime whose bit is clear occurs at no cell).
//
// Why the bounds hold: with t = P - V, te = t.e moves by at most |P - C| <= radius from its
// value at the centre (e is a unit vector), and so does |u| = |t - (t.n) n| (a projection:
// 1-Lipschitz); |t| likewise. |u| >= |te| (e lies in the tangent plane). The per-cell test
// (RV_GEO_BEYOND) is |te| > M(|u|, |t|) = max(kVertexStop4^(1/4) sqrt(|u|), sqrt(K2) |t|^2 |u|),
// which grows with |u| and |t|: it holds at every cell wherever |te| - radius exceeds M at
// |u| + radius and |t| + radius. The levels are widened by kRegimeSlack (and M by 1e-9) and the
// chord limits moved inwards so that the per-cell test's rounding cannot disagree: a certain
// regime is the one every cell's own test gives, bit for bit the per-cell method's values.
struct BlockRegime {
  Regime certain = Regime::uncertain;
  unsigned possible = 7;
  // Every cell certainly ahead of the first end beyond the margin (its test there settled:
  // te > 0, beyond it, the chord limits held), or behind the second end likewise: the other
  // end's test alone then decides a cell's regime.
  bool ahead_a = false, before_b = false;
};

// The regimes of the segments of one GeoSites: each segment's two ends (SegmentEnd) and the
// margin's K2 for the ellipsoid.
class SegmentRegimes {
 public:
  explicit SegmentRegimes(const GeoSites& geo);

  // For segment `id` seen from cell p: first_end or second_end when it is certainly nearest at
  // that end (brute force's search then returns that end's canonical distance, see
  // RV_GEO_BEYOND); interior when certainly nearest at an interior point (the cell ahead of the
  // first end and behind the second, so the convex distance along the edge has its minimum
  // inside); uncertain when none is certain (within RV_GEO_BEYOND's margin of a switch, or too
  // near or too far).
  //
  // Edges longer than a piece (kGeoPieceLength) too: brute force takes the minimum over the
  // pieces, and the piece holding the vertex returns its canonical distance (the other pieces'
  // minima are larger, the distance being convex along the edge), so the same argument holds.
  Regime at(const GeoCell& p, int32_t id) const {
    // With t = P - V, n the normal and e the edge's unit tangent at V, the tangent-plane
    // projection u = t - (t.n) n has u.e = t.e (e is in the plane) and |u|^2 = |t|^2 - (t.n)^2,
    // so cos w = t.e / |u| is compared with the margin without a root: cos w > m <=> t.e > 0
    // and (t.e)^2 > m^2 |u|^2.
    double te[2], u2[2], c2[2];
    for (int e = 0; e < 2; ++e) {
      const SegmentEnd& v = ends_[2 * static_cast<size_t>(id) + static_cast<size_t>(e)];
      const double tx = p.x - v.x, ty = p.y - v.y, tz = p.z - v.z;
      c2[e] = tx * tx + ty * ty + tz * tz;
      if (!(c2[e] <= kVertexMaxChord * kVertexMaxChord)) return Regime::uncertain;
      const double tn = tx * v.nx + ty * v.ny + tz * v.nz;
      u2[e] = c2[e] - tn * tn;
      if (!(u2[e] >= kVertexMinChord * kVertexMinChord)) return Regime::uncertain;
      te[e] = tx * v.ex + ty * v.ey + tz * v.ez;
    }
    const bool beyond0 = RV_GEO_BEYOND(te[0], u2[0], c2[0], k2_), beyond1 = RV_GEO_BEYOND(te[1], u2[1], c2[1], k2_);
    // First end: the cell lies behind it (against the edge); second end: beyond it.
    if (te[0] < 0.0 && beyond0) return Regime::first_end;
    if (te[1] > 0.0 && beyond1) return Regime::second_end;
    if (te[0] > 0.0 && beyond0 && te[1] < 0.0 && beyond1) return Regime::interior;
    return Regime::uncertain;
  }

  BlockRegime over_block(double cx, double cy, double cz, double radius, int32_t id) const;

  // End e (0 first, 1 second) of segment `id`.
  const SegmentEnd& end(int32_t id, int e) const { return ends_[2 * static_cast<size_t>(id) + static_cast<size_t>(e)]; }
  double k2() const { return k2_; }  // RV_GEO_BEYOND's K2 for the ellipsoid

 private:
  std::vector<SegmentEnd> ends_;  // per site: its two ends (segments only)
  double k2_ = 0.0;
};

// Inline: the callers use parts of the result, and the rest is optimised away.
inline BlockRegime SegmentRegimes::over_block(double cx, double cy, double cz, double radius, int32_t id) const {
  constexpr double kRegimeSlack = 1e-3;  // metres
  const double stop = std::sqrt(std::sqrt(kVertexStop4)), angle = std::sqrt(k2_);
  const double grow = radius + kRegimeSlack;
  double te[2], mu[2];
  bool settled_end[2] = {true, true};  // each end's chord and |u| limits hold at every cell
  for (int e = 0; e < 2; ++e) {
    const SegmentEnd& v = ends_[2 * static_cast<size_t>(id) + static_cast<size_t>(e)];
    const double tx = cx - v.x, ty = cy - v.y, tz = cz - v.z;
    const double chord = std::sqrt(tx * tx + ty * ty + tz * tz);
    const double tn = tx * v.nx + ty * v.ny + tz * v.nz;
    const double u = std::sqrt(std::max(chord * chord - tn * tn, 0.0)) + radius;
    const double t = chord + radius;
    mu[e] = std::max(stop * std::sqrt(u), angle * t * t * u) * (1.0 + 1e-9);
    te[e] = tx * v.ex + ty * v.ey + tz * v.ez;
    if (!(chord + radius + kRegimeSlack <= kVertexMaxChord * (1.0 - 1e-9))) settled_end[e] = false;
    if (!(std::abs(te[e]) - radius - kRegimeSlack >= kVertexMinChord)) settled_end[e] = false;
  }
  const bool settled = settled_end[0] && settled_end[1];
  BlockRegime out;
  // Bounds over the block: te in [te - radius, te + radius], and every cell's M below mu.
  const bool behind0 = -te[0] - mu[0] > grow, beyond1 = te[1] - mu[1] > grow;
  const bool ahead0 = te[0] - mu[0] > grow, before1 = -te[1] - mu[1] > grow;
  out.ahead_a = settled_end[0] && ahead0;
  out.before_b = settled_end[1] && before1;
  if (settled) {
    if (behind0)
      out.certain = Regime::first_end;
    else if (beyond1 && te[0] - radius > kRegimeSlack)  // and certainly not behind end 0
      out.certain = Regime::second_end;
    else if (ahead0 && before1)
      out.certain = Regime::interior;
  }
  // Regime 1 needs te0 < 0, 2 needs te1 > 0, 3 needs te0 > 0 and te1 < 0 somewhere.
  out.possible = 0;
  if (te[0] - radius < 0.0) out.possible |= 1u;
  if (te[1] + radius > 0.0) out.possible |= 2u;
  if (te[0] + radius > 0.0 && te[1] - radius < 0.0) out.possible |= 4u;
  return out;
}

}  // namespace rv::detail
