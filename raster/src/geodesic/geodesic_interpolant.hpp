// The interpolated distances of the exact geodesic method (geodesic_exact.cpp, whose top comment
// says why they are accurate): the interpolant of one site on one grid-aligned block (a bicubic
// over 4 x 4 nodes of a quantity that varies smoothly with the cell), the two forms (point form:
// distance over the ECEF chord to a point; additive form: signed distance to an edge's geodesic
// minus a cubic in the distance to its plane), how a value is taken from them, the block sizes
// and accuracy limits, and the store the workers of one run share them in.
//
// Thread safety: Interpolant values are immutable once built; SharedInterpolants is safe for
// any number of threads. Units: metres, ECEF metres, degrees where named.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <unordered_map>

namespace rv::detail {

// Interpolation of point-site distances (see the top of this file).
// Two block sizes: the point form (point sites, segments' ends) is so smooth that blocks of
// up to 0.35 degrees (512 cells, 4 tiles) keep it within 4.4e-6 m (1.7e-11 relative; measured,
// see the top of this file), which makes its 17 inverse problems rare; the additive form
// (edges' interiors) keeps blocks of up to 0.21 degrees (512 cells): its extended edge must
// stay one piece (build_line_interpolant), and its error is absolute.
constexpr double kPointSpan = 0.35;          // degrees: largest point-form block edge
constexpr double kPointSpanMetres = 38e3;    // the same on projected grids (~0.35 deg of latitude)
constexpr int64_t kPointMaxBlock = 512;      // cells (2 x kTile: shared between tiles)
constexpr double kLineSpan = 0.21;           // degrees: largest additive-form block edge
constexpr double kLineSpanMetres = 23e3;     // the same on projected grids (~0.21 deg of latitude)
constexpr int64_t kLineMaxBlock = 512;       // cells (2 x kTile, shared between tiles; cells
                                             // over 0.00041 deg get smaller blocks: kLineSpan)
constexpr int64_t kInterpSolveBlock = 64;    // culling goes on down to blocks this small before
                                             // the per-cell pass: fewer candidates per cell, while
                                             // the interpolants stay those of the larger block
constexpr int64_t kInterpMinBlock = 8;       // cells
constexpr double kAdditiveMinValue = 2.0;    // metres: see value()
constexpr int64_t kInterpMinEdge = 4;        // a block clipped by the grid below this: per cell
constexpr size_t kInterpMaxCandidates = 24;  // more candidates: subdivide (or per cell)
// Leaves with segments take the row kernels only where line blocks are this large: the
// kernels need every candidate's interpolants (17 inverse problems each), which the per-cell
// method builds only for candidates its bounds cannot exclude; on smaller blocks (coarse grids)
// those extra builds cost more than the kernels save (bench/RESULTS-kernels.md).
constexpr int64_t kLeafKernelMinBlock = 128;
constexpr double kInterpCheck = 5e-6;          // metres: accepted error at the block's centre
constexpr double kInterpCheckAdditive = 6e-8;  // ... for the additive form, whose values are used
                                               // down to kAdditiveMinValue (worst centre error
                                               // measured 1.8e-8 m; a cell's worst, 3.1e-8 m, was
                                               // under twice its block's centre error)
constexpr double kInterpTie = 1e-4;            // metres: closer calls are decided exactly
constexpr double kInterpMaxDistance = 1.2e7;   // metres: beyond, the antipode's kink is too near
constexpr double kInterpMinChord = 1e-3;       // metres: a node on the seed (or on an edge)
                                               // cannot form d / chord (or a side)

// Lagrange weights of the cubic through t = 0, 1/3, 2/3, 1.
inline void cubic_weights(double t, double w[4]) {
  const double a = t, b = t - 1.0 / 3.0, c = t - 2.0 / 3.0, d = t - 1.0;
  w[0] = -4.5 * b * c * d;
  w[1] = 13.5 * a * c * d;
  w[2] = -13.5 * a * b * d;
  w[3] = 4.5 * a * b * c;
}

struct Interpolant {
  int32_t id;         // the site (a point site, or a segment measured at an end or inside)
  double lat, lon;    // the point measured from: the point site, or the segment's (first) end
  double sx, sy, sz;  // its ECEF position
  // Point form: q = d / chord to (sx, sy, sz), value q * chord. Additive form (an edge's
  // interior, build_line_interpolant): q = signed d - h, h = g + k3 g^3 with g = n . (P - s) the
  // signed distance to the plane through the edge's chord and the mean normal of its ends,
  // value |h + q|.
  bool additive = false;
  double nx = 0.0, ny = 0.0, nz = 0.0;
  double k3 = 0.0;  // additive form: 1 / (6 R^2), R the radius of curvature across the edge
  double q[4][4];   // the interpolated quantity at the nodes [row][col]
};

// The normaliser of an interpolant at ECEF (x, y, z): the chord to its point, or for a segment's
// interior h = g + k3 g^3 from the signed distance g to its plane. (On a sphere of radius R the
// distance to the great circle is R asin(g / R) = g + g^3 / (6 R^2) + ...: the cubic term leaves
// q ten times smaller and smoother, so the bicubic fits it ten times closer; the row kernels
// compute it with the same operations.)
inline double normaliser(const Interpolant& it, double x, double y, double z) {
  const double dx = x - it.sx, dy = y - it.sy, dz = z - it.sz;
  if (it.additive) {
    const double g = dx * it.nx + dy * it.ny + dz * it.nz;
    return g + (it.k3 * (g * g)) * g;
  }
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// A cell's weights inside its interpolation blocks (rows, columns): the point form's block
// (wt, wc) and the additive form's (lt, lc).
struct CellWeights {
  double wt[4], wc[4], lt[4], lc[4];
};

// Marks an interpolant slot not looked up yet (GeodesicExactSolver::value).
inline const Interpolant kNotLooked{};

// The distance an interpolant gives at ECEF (x, y, z) from its interpolated quantity q. The
// point form is root(q^2 chord^2) (q > 0), not q * root(chord^2): the row kernels compare the
// squares and take this root of the best alone, and every path must give a cell the same bits.
inline double apply(const Interpolant& it, double q, double x, double y, double z) {
  if (it.additive) return std::abs(normaliser(it, x, y, z) + q);
  const double dx = x - it.sx, dy = y - it.sy, dz = z - it.sz;
  return std::sqrt((q * q) * (dx * dx + dy * dy + dz * dz));
}

// The value of an interpolant's quantity at a cell with row weights wt and column weights wc:
// rows first, then columns, the same operations in the same order as the row kernels, so that
// every path gives a cell the same bits.
inline double eval(const Interpolant& it, const double wt[4], const double wc[4]) {
  double qr[4];
  for (int b = 0; b < 4; ++b) qr[b] = wt[0] * it.q[0][b] + wt[1] * it.q[1][b] + wt[2] * it.q[2][b] + wt[3] * it.q[3][b];
  return wc[0] * qr[0] + wc[1] * qr[1] + wc[2] * qr[2] + wc[3] * qr[3];
}

// The interpolants of one run, shared by its workers: an interpolation block may hold many
// tiles (kPointMaxBlock > kTile), taken by any thread, and all of them use the one built
// first. Each is built once: a thread asking for one that another is building waits for it
// (std::call_once) rather than repeating its 17 inverse problems; it never changes after, and
// its bits do not depend on which thread built it. Rows of blocks above the tiles being started
// are dropped (drop_rows_before); a worker still using an entry holds it (shared_ptr).
// Thread safety: every member may be called from any worker at any time.
class SharedInterpolants {
 public:
  struct Entry {
    std::once_flag built;
    std::unique_ptr<Interpolant> it;  // after `built`: null where the interpolant is rejected
  };
  // The entry of the block whose first cell is grid column bx, row by (a point-form or a line
  // block: `kind` tells them apart), for `who` (a site, or a distinct vertex) and `kind`
  // (interpolant()'s end, 1 for both ends), made empty on first use.
  std::shared_ptr<Entry> entry(int64_t bx, int64_t by, int32_t who, int kind) {
    const Key k{bx, who, kind};
    std::lock_guard lock(mutex_);
    std::shared_ptr<Entry>& e = rows_[by][k];
    if (!e) e = std::make_shared<Entry>();
    return e;
  }
  // Forgets the blocks whose first row is above grid row `by`.
  void drop_rows_before(int64_t by) {
    std::lock_guard lock(mutex_);
    rows_.erase(rows_.begin(), rows_.lower_bound(by));
  }

 private:
  struct Key {
    int64_t bx;
    int32_t who;
    int kind;
    bool operator==(const Key& o) const { return bx == o.bx && who == o.who && kind == o.kind; }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      const uint64_t h = (static_cast<uint64_t>(k.bx) * 0x9e3779b97f4a7c15ULL) ^
                         (static_cast<uint64_t>(static_cast<uint32_t>(k.who)) << 2) ^ static_cast<uint64_t>(k.kind);
      return std::hash<uint64_t>()(h);
    }
  };
  std::mutex mutex_;
  std::map<int64_t, std::unordered_map<Key, std::shared_ptr<Entry>, KeyHash>> rows_;
};

}  // namespace rv::detail
