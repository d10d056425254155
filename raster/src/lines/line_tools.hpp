// The machinery the deliverables share (boundaries.cpp, limits.cpp, margin.cpp): positions of
// cell centres, root finding along a segment, the grid's edges and dual squares, chaining links
// into lines, and the checks every deliverable makes of its field. Internal to rv_raster; the
// files that use it bring the namespace in whole (using namespace rv::line_tools).
// Thread safety: pure functions.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "rv/engine/site_metric.hpp"
#include "rv/field/parallel.hpp"
#include "rv/lines/residual.hpp"

namespace rv {
// What a refinement keeps of each segment, and the segments an edit leaves valid (line_pieces.hpp):
// the stages take them by pointer.
template <class V, class Stat>
struct SegmentMemo;
template <class V, class Stat>
class SegmentReuse;
}  // namespace rv

namespace rv::line_tools {

inline Vec2 centre(const GridSpec& g, int64_t col, int64_t row) { return Vec2{g.centre_x(col), g.centre_y(row)}; }
inline Vec2 lerp(Vec2 a, Vec2 b, double t) { return Vec2{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)}; }
// The parameter in [0, 1] of the point of segment a-b nearest p (0 for a degenerate segment).
inline double nearest_t(Vec2 a, Vec2 b, Vec2 p) {
  const double dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
  return len2 > 0.0 ? std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / len2, 0.0, 1.0) : 0.0;
}
// The distance from p to the segment a-b (CRS units).
inline double segment_distance(Vec2 p, Vec2 a, Vec2 b) {
  const Vec2 foot = lerp(a, b, nearest_t(a, b, p));
  return std::hypot(p.x - foot.x, p.y - foot.y);
}
// The axis-aligned bounds of the points added (empty until one is), and whether two bounds come
// within `pad` of each other: a cheap test before distances to segments.
struct Bounds {
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  void add(Vec2 p) {
    x0 = std::min(x0, p.x);
    y0 = std::min(y0, p.y);
    x1 = std::max(x1, p.x);
    y1 = std::max(y1, p.y);
  }
  bool meets(const Bounds& o, double pad) const {
    return x0 <= o.x1 + pad && o.x0 <= x1 + pad && y0 <= o.y1 + pad && o.y0 <= y1 + pad;
  }
};
// Where the lines p + s d and q + t e meet: s and t, false where they are parallel.
inline bool lines_meet(Vec2 p, Vec2 d, Vec2 q, Vec2 e, double& s, double& t) {
  const double det = d.x * -e.y - d.y * -e.x;
  if (!(std::abs(det) > 0.0)) return false;
  const Vec2 r{q.x - p.x, q.y - p.y};
  s = (r.x * -e.y - r.y * -e.x) / det;
  t = (d.x * r.y - d.y * r.x) / det;
  return true;
}
// The indices of a line's vertices (anything with a position `p`) left once each vertex at the
// same point as the one before it goes: the first of each run. A cell centre on a locus or level
// is the crossing of both ways from it, and both are linked; a zero-length segment is no part of
// a line, and some GIS tools refuse it.
template <class V>
std::vector<size_t> unrepeated(const std::vector<V>& v) {
  std::vector<size_t> keep;
  keep.reserve(v.size());
  for (size_t i = 0; i < v.size(); ++i)
    if (keep.empty() || v[i].p.x != v[keep.back()].p.x || v[i].p.y != v[keep.back()].p.y) keep.push_back(i);
  return keep;
}
// v's unrepeated() vertices alone, where at least two are left.
template <class V>
void drop_repeated(std::vector<V>& v) {
  const std::vector<size_t> keep = unrepeated(v);
  if (keep.size() == v.size() || keep.size() < 2) return;
  std::vector<V> kept;
  kept.reserve(keep.size());
  for (const size_t i : keep) kept.push_back(v[i]);
  v = std::move(kept);
}
// The centre of dual square (c, r): the grid corner shared by cells (c, r) .. (c + 1, r + 1).
inline Vec2 square_mid(const GridSpec& g, int64_t c, int64_t r) {
  return Vec2{g.xmin + (static_cast<double>(c) + 1.0) * g.res, g.ymax - (static_cast<double>(r) + 1.0) * g.res};
}

// A root of f on [0, 1] given f(0) <= 0 <= f(1) (or the reverse): the Illinois variant of
// regula falsi, with a bisection step whenever the bracket failed to halve, so convergence is
// superlinear on smooth stretches and never worse than bisection where the controlling seed
// changes. Stops when |f| <= ftol or the bracket is below t_tol. If f does not change sign the
// end with the smaller |f| is returned.
template <class F>
double find_root(F&& f, double f0, double f1, double ftol, double t_tol) {
  if (std::abs(f0) <= ftol) return 0.0;
  if (std::abs(f1) <= ftol) return 1.0;
  if ((f0 < 0.0) == (f1 < 0.0)) return std::abs(f0) <= std::abs(f1) ? 0.0 : 1.0;
  double a = 0.0, b = 1.0, fa = f0, fb = f1;
  int side = 0;
  double width = 1.0;
  for (int iter = 0; iter < 200; ++iter) {
    double t;
    if (iter % 3 == 2 && (b - a) > 0.5 * width) {
      t = 0.5 * (a + b);  // the last steps did not halve the bracket
    } else {
      t = (a * fb - b * fa) / (fb - fa);
      if (!(t > a && t < b)) t = 0.5 * (a + b);
    }
    if (iter % 3 == 2) width = b - a;
    const double ft = f(t);
    if (std::abs(ft) <= ftol) return t;
    if ((ft < 0.0) == (fa < 0.0)) {
      a = t;
      fa = ft;
      if (side == -1) fb *= 0.5;
      side = -1;
    } else {
      b = t;
      fb = ft;
      if (side == 1) fa *= 0.5;
      side = 1;
    }
    if (b - a <= t_tol) break;
  }
  return std::abs(fa) <= std::abs(fb) ? a : b;
}

// A root of f in [t0, t0 + w] given f(t0) = f0 and f(t0 + w) = f1 of opposite signs: find_root
// on the bracket scaled to [0, 1].
template <class F>
double root_in(F&& f, double t0, double w, double f0, double f1, double ftol) {
  return t0 + w * find_root([&](double u) { return f(t0 + w * u); }, f0, f1, ftol, 1e-15);
}

// Along a path at(t) (false: no point there), t in [lo, hi] sampled in `samples` equal steps:
// each place where f changes sign between two samples (both finite), solved to `ftol`; of the
// roots nearer `near` than `best_gap` that `accept` takes, the nearest goes to `out` and its
// distance to `best_gap` (the first of equals). True where one did. Where the path has no point
// at one sample and has at the next, the first t with a point between them is bisected for (and
// f's sign compared there) unless `may_reach` (when given) says f, of value fa at ta, cannot
// reach 0 by tb.
bool nearest_root_along(const std::function<bool(double, Vec2&)>& at, double lo, double hi, int samples,
                        const std::function<double(Vec2)>& f, double ftol, Vec2 near,
                        const std::function<bool(Vec2)>& accept, double& best_gap, Vec2& out,
                        const std::function<bool(double ta, double fa, double tb)>& may_reach = {});

// Newton's method for a root of f in [lo, hi], where f(lo) <= 0 <= f(hi) when `rising` (the
// reverse otherwise) is known without f having been measured there: g(t) gives {f(t), f'(t)}.
// From `start`, each measured position narrows the bracket; a step is taken only when it stays
// strictly inside it. `t` is the first position with |f| <= ftol (the last one measured), or NaN
// when a step leaves the bracket, a slope or value is not finite, or `max_steps` pass: then
// [lo, hi] is the narrowed bracket, f_lo / f_hi its measured values (NaN where not measured),
// for a bracketing method (find_root) to go on from.
// Steps before newton_root hands over (quadratic convergence needs three from mid-cell).
constexpr int kNewtonSteps = 6;
struct NewtonRoot {
  double t, lo, hi, f_lo, f_hi;
};
template <class G>
NewtonRoot newton_root(G&& g, double start, double lo, double hi, bool rising, double ftol, int max_steps) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  NewtonRoot r{nan, lo, hi, nan, nan};
  double t = start;
  for (int k = 0; k < max_steps; ++k) {
    const auto [v, slope] = g(t);
    if (!std::isfinite(v)) break;
    if (std::abs(v) <= ftol) {
      r.t = t;
      break;
    }
    if ((v < 0.0) == rising) {
      r.lo = t;
      r.f_lo = v;
    } else {
      r.hi = t;
      r.f_hi = v;
    }
    const double next = t - v / slope;
    if (!(next > r.lo && next < r.hi)) break;  // NaN (no slope) included
    t = next;
  }
  return r;
}

// A root of f on [lo, hi] (f(lo) <= 0 <= f(hi) when `rising`, the reverse otherwise, known
// without measuring): newton_root's steps from `start` with g(t) = {f(t), f'(t)}, and where they
// hand over, find_root (Illinois) on what is left of the bracket, measuring its ends only where
// Newton did not.
template <class F, class G>
double newton_then_bracket(F&& f, G&& g, double start, double lo, double hi, bool rising, double ftol) {
  const NewtonRoot nr = newton_root(g, start, lo, hi, rising, ftol, kNewtonSteps);
  if (!std::isnan(nr.t)) return nr.t;
  const double a = nr.lo, w = nr.hi - nr.lo;
  const double fa = std::isnan(nr.f_lo) ? f(a) : nr.f_lo, fb = std::isnan(nr.f_hi) ? f(nr.hi) : nr.f_hi;
  return root_in(f, a, w, fa, fb, ftol);
}

// An upper bound of the nearest distance at the middle of a cell edge, without measuring: the
// field's Float32 distance at one of its centres (relative rounding below 1e-7, taken as 1e-6)
// plus the way from that centre (`reach`, edge_reach).
inline double nearest_at_most(float field_distance, double reach) {
  return static_cast<double>(field_distance) * (1.0 + 1e-6) + reach;
}

// f(r, out) for each row of [row0, row1) on `threads` threads, in chunks of rows, each chunk
// appending to its own list; the lists joined in row order, so the result does not depend on the
// threads. For the scans over every cell or square of a field, whose finds are few.
template <class T, class F>
std::vector<T> scan_rows(int threads, int64_t row0, int64_t row1, F&& f) {
  constexpr int64_t kRowsPerChunk = 32;
  const int64_t chunks = std::max<int64_t>(0, (row1 - row0 + kRowsPerChunk - 1) / kRowsPerChunk);
  std::vector<std::vector<T>> found(static_cast<size_t>(chunks));
  detail::parallel_for(threads, chunks, [&](int64_t k, int) {
    const int64_t r0 = row0 + k * kRowsPerChunk, r1 = std::min(row1, r0 + kRowsPerChunk);
    for (int64_t r = r0; r < r1; ++r) f(r, found[static_cast<size_t>(k)]);
  });
  std::vector<T> all;
  for (auto& part : found) all.insert(all.end(), part.begin(), part.end());
  return all;
}

// Metric units per CRS unit along x and along y near a position: what turns a gradient per CRS
// unit (SiteMetric::distance_and_gradient) into one per metric unit, and so |f| / |grad f| into a
// length. Planar grids: 1 and 1. Longitude/latitude grids (geodesic): metres per degree, measured
// once at `p0` (two distances) and carried to other latitudes by the cosine of the latitude
// (the parallel's radius; the meridian's scale varies by under 1 % over 10 degrees).
struct CrsScale {
  Vec2 at0{1.0, 1.0};
  double lat0 = 0.0;
  bool lonlat = false;
  CrsScale() = default;
  CrsScale(const SiteMetric& m, Vec2 p0, double res);
  Vec2 at(Vec2 p) const;
  // The length (metric units) of the step that moves f by `f` along its gradient `g` (per CRS
  // unit): |f| / |grad f| in metric units; NaN where g is not known or vanishes.
  double offset(Vec2 p, double f, Vec2 g) const;
  // The bow (rv/lines/residual.hpp) of segment p-q from the locus function's value `f` and
  // gradient `g` (per CRS unit) at its middle: one Newton step there, in metric units.
  Bow bow(Vec2 p, Vec2 q, double f, Vec2 g) const;
};

// The metric radius of a ball around `mid`, the middle of the short path p0-p1 between two
// neighbouring cell centres, that holds every position lerp(p0, p1, t) of it: the larger distance
// to an end, 1 % wider for the curvature of a longitude/latitude path (OwnerIndex::candidates_of).
inline double edge_reach(const SiteMetric& m, Vec2 mid, Vec2 p0, Vec2 p1) {
  return 1.01 * std::max(m.point_distance(mid, p0), m.point_distance(mid, p1)) + 1e-9;
}

// The rows of a field the stages read, by absolute grid row: one whole field, or (a streamed
// extraction) the strip in hand preceded by the rows kept from the strips before it. Holds a
// pointer to the strip, which must stay alive and unchanged until the next set_strip().
class FieldRows {
 public:
  FieldRows() = default;
  FieldRows(const NearestField& whole) { set_strip(whole); }  // NOLINT: a whole field converts
  // The next strip: full rows of the grid, starting at row1() (or any row when nothing is
  // held). Throws rv::Error(invalid_argument) for a strip of other columns or out of order.
  void set_strip(const NearestField& strip);
  // Rows [row0, row1) of `strip` (which holds them) as the next strip.
  void set_strip(const NearestField& strip, int64_t row0, int64_t row1);
  // Copies rows [from, row1()) (from >= row0()) so that they outlive the strip in hand.
  void keep_from(int64_t from);
  // Holds nothing: the next strip may start at any row.
  void restart() { *this = FieldRows(); }
  int64_t row0() const { return carry_row0_; }  // the first row held
  int64_t row1() const { return strip_row1_; }  // one past the last
  const int32_t* site_row(int64_t r) const {
    return r >= strip_row0_ ? strip_->site.row(r - strip_base_) : carry_site_.data() + (r - carry_row0_) * width_;
  }
  const float* distance_row(int64_t r) const {
    return r >= strip_row0_ ? strip_->distance.row(r - strip_base_)
                            : carry_distance_.data() + (r - carry_row0_) * width_;
  }
  int32_t site(int64_t c, int64_t r) const { return site_row(r)[c]; }
  float distance(int64_t c, int64_t r) const { return distance_row(r)[c]; }

 private:
  const NearestField* strip_ = nullptr;
  bool started_ = false;
  int64_t width_ = 0;
  int64_t strip_row0_ = 0, strip_row1_ = 0;  // the rows of the strip in hand read
  int64_t strip_base_ = 0;                   // the strip's first row
  int64_t carry_row0_ = 0;                   // carry rows are [carry_row0_, strip_row0_)
  std::vector<int32_t> carry_site_;
  std::vector<float> carry_distance_;
};

// Links between graph nodes; chains them into polylines. A chain starts and stops at terminal
// nodes (tripoints, or nodes of degree other than 2); what is left are closed rings.
struct Chains {
  std::vector<std::vector<int32_t>> node_lists;
  std::vector<bool> closed;
  std::vector<int32_t> first_link;  // the link each chain started with (its pair tag)
};

Chains chain_links(int32_t node_count, const std::vector<std::array<int32_t, 2>>& links,
                   const std::vector<bool>& always_terminal);

// Grid edges between 4-neighbour cell centres: id 2*(row*W + col) joins (col,row)-(col+1,row),
// id 2*(row*W + col) + 1 joins (col,row)-(col,row+1).
inline int64_t edge_right(int64_t w, int64_t c, int64_t r) { return 2 * (r * w + c); }
inline int64_t edge_down(int64_t w, int64_t c, int64_t r) { return 2 * (r * w + c) + 1; }

// The four edges of dual square (c, r), in order top, right, bottom, left; corner k lies between
// edge k-1 and edge k (corners: 0 = (c,r), 1 = (c+1,r), 2 = (c+1,r+1), 3 = (c,r+1)).
inline std::array<int64_t, 4> square_edges(int64_t w, int64_t c, int64_t r) {
  return {edge_right(w, c, r), edge_down(w, c + 1, r), edge_right(w, c, r + 1), edge_down(w, c, r)};
}

// The field's distances and ownership and the metric's must agree, or the roots are sought in
// a different geometry than the one that decided the owners. Throws rv::Error(invalid_argument).
void check_metric(const NearestField& field, const SiteMetric& metric);
// Deliverables need the whole grid. Throws rv::Error(invalid_argument).
void check_whole_grid(const NearestField& field);
// Metric length of one cell near the grid centre: the scale of every tolerance.
double cell_metric(const GridSpec& g, const SiteMetric& m);
// The owner code of every site of `seeds`.
std::vector<int32_t> owner_of_sites(const SeedSet& seeds);

// A root of F: R^2 -> R^2 near `start` (Newton's method, numeric Jacobian, steps of at most a
// cell halved while they do not reduce the residual's largest component). False when it does not
// converge to within ftol, within two cells of the start.
template <class F>
bool solve2(F&& f_of, Vec2 start, double res, double ftol, Vec2& out) {
  auto norm = [](const std::array<double, 2>& v) { return std::max(std::abs(v[0]), std::abs(v[1])); };
  Vec2 p = start;
  std::array<double, 2> f = f_of(p);
  const double h = 1e-7 * res;
  for (int iter = 0; iter < 60; ++iter) {
    if (norm(f) <= ftol) {
      out = p;
      return std::hypot(p.x - start.x, p.y - start.y) <= 2.0 * res;
    }
    const auto fx = f_of(Vec2{p.x + h, p.y}), fy = f_of(Vec2{p.x, p.y + h});
    const double j00 = (fx[0] - f[0]) / h, j01 = (fy[0] - f[0]) / h, j10 = (fx[1] - f[1]) / h, j11 = (fy[1] - f[1]) / h;
    const double det = j00 * j11 - j01 * j10;
    if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return false;
    Vec2 d{-(j11 * f[0] - j01 * f[1]) / det, -(-j10 * f[0] + j00 * f[1]) / det};
    const double len = std::hypot(d.x, d.y);
    if (len > res) d = Vec2{d.x * res / len, d.y * res / len};
    bool moved = false;
    for (int half = 0; half < 30 && !moved; ++half) {
      const Vec2 q{p.x + d.x, p.y + d.y};
      const auto fq = f_of(q);
      if (norm(fq) < norm(f)) {
        p = q;
        f = fq;
        moved = true;
      }
      d = Vec2{0.5 * d.x, 0.5 * d.y};
    }
    if (!moved) return false;
  }
  return false;
}

// On the frame of the outermost cell centres (where extraction stops).
inline bool on_centre_frame(const GridSpec& g, Vec2 p) {
  return p.x == g.centre_x(0) || p.x == g.centre_x(g.width - 1) || p.y == g.centre_y(0) ||
         p.y == g.centre_y(g.height - 1);
}

// Where a line that stops short of the metric's domain edge (SiteMetric::domain_edges_near: a
// barrier by sea) meets it: on the edges within `radius` CRS units of `end`, approached from
// `end`'s side (domain_edge_point), the points where `f` (the line's locus function, metric
// units) changes sign -- sampled a sixteenth of the radius apart, then solved to `ftol` (Illinois)
// -- and of those `accept`s and that `end` sees (open_between), the nearest to `end`; an end
// vertex of a searched edge counts too where f is 0 there within `ftol` (a locus through an
// island's corner or a boom's tip). False where there is none. An edge longer than one and a
// half radii is sampled only within that of `end`'s foot on it; one with both ends under other
// land is left out. The edges are searched nearest first (by their chord's distance less
// SiteMetric::domain_edge_bow), up to the first whose every point lies beyond the nearest found.
// `away` (or null): only points on the far side of `end` from it (a line of one vertex, whose
// other end went towards `away`, leaves the other way).
// `slope` (or +infinity): a bound of how fast f changes along a way at sea, per metric unit (two
// owners' costs: twice OwnerIndex::cost_slope). An edge whose searched stretch is open along
// itself and whose two ends' values have one sign and too large for f to reach 0 between them is
// then left unsampled: the same answer, for two evaluations of f instead of all the samples.
bool onto_domain_edge(const SiteMetric& m, Vec2 end, double radius, double ftol, const std::function<double(Vec2)>& f,
                      const std::function<bool(Vec2)>& accept, Vec2& out, const Vec2* away = nullptr,
                      double slope = std::numeric_limits<double>::infinity());

// Strictly between the frame of the outermost centres and the grid's edge (or on the edge).
inline bool outside_frame(const GridSpec& g, Vec2 p) {
  return p.x < g.centre_x(0) || p.x > g.centre_x(g.width - 1) || p.y > g.centre_y(0) || p.y < g.centre_y(g.height - 1);
}

// The point near `start` where site s1 is at distance r1 and s2 at r2 (two arcs or a corner of
// a limit meet): Newton's method on the two distances' gradients, at most `iterations` steps,
// staying within `max_move` of `start`, to `ftol` (metric units). False where it does not
// converge there.
inline bool arcs_meet(const SiteMetric& m, int32_t s1, double r1, int32_t s2, double r2, Vec2 start, double max_move,
                      double ftol, int iterations, Vec2& out) {
  Vec2 q = start;
  for (int iter = 0; iter < iterations; ++iter) {
    Vec2 g1, g2;
    const double f1 = m.distance_and_gradient(q, s1, g1) - r1;
    const double f2 = m.distance_and_gradient(q, s2, g2) - r2;
    if (std::max(std::abs(f1), std::abs(f2)) <= ftol) {
      out = q;
      return true;
    }
    const double det = g1.x * g2.y - g1.y * g2.x;
    if (!std::isfinite(det) || !(std::abs(det) > 0.0)) return false;
    q = Vec2{q.x - (f1 * g2.y - f2 * g1.y) / det, q.y - (g1.x * f2 - g2.x * f1) / det};
    if (!(std::hypot(q.x - start.x, q.y - start.y) <= max_move)) return false;
  }
  return false;
}

}  // namespace rv::line_tools
