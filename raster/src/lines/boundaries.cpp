// Boundaries and tripoints (extract_boundaries, rv/lines/boundaries.hpp) as a pipeline of stages:
// crossings on the edges between differently owned cells, tripoints in the dual squares, links
// between them per square, chains of links into lines.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <numeric>
#include <set>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/line_tools.hpp"
#include "lines/locus/tie_edge.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/regions.hpp"

namespace rv {
namespace boundary_stages {

using namespace line_tools;  // the deliverables' own toolkit (line_tools.hpp)

// ---------------------------------------------------------------------------------------------
// Boundaries and tripoints.

namespace {

// How deep the owners passing between two cell centres are followed (A | C D E ... | B): each
// level finds one more owner between; beyond it the segment is dropped as unresolved.
constexpr int kMaxSliverDepth = 8;

struct TripointSolver {
  const OwnerIndex& index;
  double ftol;  // metric units
  double step;  // finite-difference step, CRS units

  // Solves d_X = d_Y = d_Z from `start` (Gauss-Newton, numeric Jacobian, step halving).
  bool solve(const std::array<int32_t, 3>& o, Vec2 start, double max_move, Tripoint& out) const {
    auto eval = [&](Vec2 p, std::array<double, 2>& f, std::array<OwnerIndex::Hit, 3>* hits) {
      const auto a = index.nearest_of(p, o[0]), b = index.nearest_of(p, o[1]), c = index.nearest_of(p, o[2]);
      f = {a.cost - b.cost, a.cost - c.cost};
      if (hits) *hits = {a, b, c};
      return std::isfinite(f[0]) && std::isfinite(f[1]);
    };
    Vec2 p = start;
    std::array<double, 2> f;
    if (!eval(p, f, nullptr)) return false;
    for (int iter = 0; iter < 60; ++iter) {
      const double norm = std::max(std::abs(f[0]), std::abs(f[1]));
      if (norm <= ftol) {
        std::array<OwnerIndex::Hit, 3> h;
        eval(p, f, &h);
        out.p = p;
        for (int k = 0; k < 3; ++k) {
          out.owners[k] = o[static_cast<size_t>(k)];
          out.sites[k] = h[static_cast<size_t>(k)].site;
        }
        out.distance = (h[0].distance + h[1].distance + h[2].distance) / 3.0;
        out.cost = (h[0].cost + h[1].cost + h[2].cost) / 3.0;
        out.residual = std::max(
            {std::abs(h[0].cost - h[1].cost), std::abs(h[0].cost - h[2].cost), std::abs(h[1].cost - h[2].cost)});
        for (int k = 0; k < 3; ++k) out.distances[k] = h[static_cast<size_t>(k)].distance;
        return true;
      }
      std::array<double, 2> fx, fy;
      if (!eval(Vec2{p.x + step, p.y}, fx, nullptr) || !eval(Vec2{p.x, p.y + step}, fy, nullptr)) return false;
      const double j00 = (fx[0] - f[0]) / step, j01 = (fy[0] - f[0]) / step;
      const double j10 = (fx[1] - f[1]) / step, j11 = (fy[1] - f[1]) / step;
      const double det = j00 * j11 - j01 * j10;
      if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return false;
      double dx = (-f[0] * j11 + f[1] * j01) / det;
      double dy = (-j00 * f[1] + j10 * f[0]) / det;
      const double len = std::hypot(dx, dy);
      if (len > max_move) {
        dx *= max_move / len;
        dy *= max_move / len;
      }
      // Step halving: accept the first step that reduces the residual.
      bool moved = false;
      for (int h = 0; h < 30; ++h) {
        const Vec2 q{p.x + dx, p.y + dy};
        std::array<double, 2> fq;
        if (eval(q, fq, nullptr) && std::max(std::abs(fq[0]), std::abs(fq[1])) < norm) {
          p = q;
          f = fq;
          moved = true;
          break;
        }
        dx *= 0.5;
        dy *= 0.5;
      }
      if (!moved) return false;
      if (std::hypot(p.x - start.x, p.y - start.y) > 4.0 * max_move) return false;
    }
    return false;
  }
};

// ---- Stage 1: crossings ------------------------------------------------------------------------
// Every 4-neighbour pair of differently owned cells, placed on the locus.

struct Segment {
  int64_t edge;
  int32_t from, to;  // owner of the first and the second cell centre
};

// Whether the 9 sites a[0..8] are all one, and b[0..7] (when not null) that one too: 8 cells at a
// time where nothing changes, which is nearly everywhere (compared without a branch per cell).
inline bool same8(const int32_t* a, const int32_t* b) {
  // a[0..8] all one is a[0..7] == a[1..8]; then b[0..7] == a[0..7] (fixed-size compares, which
  // the compiler does a vector at a time).
  return std::memcmp(a, a + 1, 8 * sizeof(int32_t)) == 0 &&
         (b == nullptr || std::memcmp(a, b, 8 * sizeof(int32_t)) == 0);
}

// The edges of rows [row0, row1) whose two cells have different owners.
std::vector<Segment> owner_changes(const BoundaryGrid& b, int64_t row0, int64_t row1) {
  return scan_rows<Segment>(b.threads, row0, row1, [&](int64_t r, std::vector<Segment>& segments) {
    const int32_t* here = b.rows.site_row(r);
    const int32_t* below = r + 1 < b.H ? b.rows.site_row(r + 1) : nullptr;
    for (int64_t c = 0; c < b.W; ++c) {
      if (c + 9 <= b.W && same8(here + c, below == nullptr ? nullptr : below + c)) {
        c += 7;  // cells c .. c + 7: no edge changes site
        continue;
      }
      // Sites equal means owners equal: the owner lookups only where sites differ.
      const int32_t s = here[c];
      if ((c + 1 >= b.W || here[c + 1] == s) && (below == nullptr || below[c] == s)) continue;
      const int32_t o = b.owner_code(s);
      if (o == 0) continue;
      if (c + 1 < b.W) {
        const int32_t q = b.owner_code(here[c + 1]);
        if (q != 0 && q != o) segments.push_back(Segment{edge_right(b.W, c, r), o, q});
      }
      if (below != nullptr) {
        const int32_t q = b.owner_code(below[c]);
        if (q != 0 && q != o) segments.push_back(Segment{edge_down(b.W, c, r), o, q});
      }
    }
  });
}

// The dual squares whose top row is in [row0, row1) and whose four corners do not all have one
// owner, as (c, r), in row-major order.
std::vector<std::array<int64_t, 2>> mixed_squares(const BoundaryGrid& b, int64_t row0, int64_t row1) {
  return scan_rows<std::array<int64_t, 2>>(
      b.threads, row0, std::min(row1, b.H - 1), [&](int64_t r, std::vector<std::array<int64_t, 2>>& out) {
        const int32_t* here = b.rows.site_row(r);
        const int32_t* below = b.rows.site_row(r + 1);
        // Sites equal means owners equal: the owner lookups only where sites differ.
        for (int64_t c = 0; c + 1 < b.W; ++c) {
          // Squares c .. c + 7 read cells c .. c + 8 of both rows.
          if (c + 9 <= b.W && same8(here + c, below + c) && below[c + 8] == here[c]) {
            c += 7;
            continue;
          }
          if (here[c] == here[c + 1] && here[c] == below[c] && here[c] == below[c + 1]) continue;
          const int32_t o = b.owner_code(here[c]);
          if (o != b.owner_code(here[c + 1]) || o != b.owner_code(below[c]) || o != b.owner_code(below[c + 1]))
            out.push_back({c, r});
        }
      });
}

// Every query of a crossing is on the cell-centre segment p0-p1: per owner, the few sites that
// can be nearest anywhere on it are gathered once (OwnerIndex::candidates_of, from a ball around
// its middle holding the segment: edge_reach), and each query measures only those: the same hits
// as nearest_of. The cells' own sites bound the gathering.
struct SegmentSites {
  SegmentSites(const BoundaryGrid& b, const Segment& sg, Vec2 p0, Vec2 p1)
      : index(b.index), mid(lerp(p0, p1, 0.5)), reach(edge_reach(b.index.metric(), mid, p0, p1)) {
    const int64_t cell_id = sg.edge / 2;
    const int64_t c = cell_id % b.W, r = cell_id / b.W;
    const bool across = sg.edge % 2 == 0;
    hint[sg.from] = b.rows.site(c, r);
    hint[sg.to] = across ? b.rows.site(c + 1, r) : b.rows.site(c, r + 1);
    // The two owners' nearest distances at the middle, bounded without measuring: the field's
    // (Float32, relative rounding below 1e-7) at their centres, plus the way from there.
    at_most[sg.from] = nearest_at_most(b.rows.distance(c, r), reach);
    at_most[sg.to] = nearest_at_most(across ? b.rows.distance(c + 1, r) : b.rows.distance(c, r + 1), reach);
  }
  OwnerIndex::Hit nearest_of(Vec2 p, int32_t owner, Vec2* gradient) {
    auto [it, fresh] = candidates.try_emplace(owner);
    if (fresh) {
      const auto h = hint.find(owner);
      const auto m = at_most.find(owner);
      index.candidates_of(mid, reach, owner, h == hint.end() ? kNoSite : h->second, it->second,
                          m == at_most.end() ? std::numeric_limits<double>::infinity() : m->second);
    }
    return index.nearest_among(p, it->second, gradient);
  }
  const OwnerIndex& index;
  const Vec2 mid;
  const double reach;
  std::unordered_map<int32_t, int32_t> hint;  // per owner, a site of it near the segment
  std::unordered_map<int32_t, double> at_most;
  std::unordered_map<int32_t, std::vector<int32_t>> candidates;
};

// A vertex with its two sides swapped (owner a's becoming b's).
void flip_sides(BoundaryVertex& v) {
  std::swap(v.site_a, v.site_b);
  std::swap(v.distance_a, v.distance_b);
  if (v.arc != 0) v.arc = static_cast<int8_t>(3 - v.arc);
}

// The crossings of one segment, in order along it. A third owner nearer than both at the A-B
// root means its region passes between the two cell centres without holding one: A and B do not
// touch there. The segment then carries the A-C and C-B crossings instead (and so on, for more
// owners between): without them the sides of a region thinner than a cell would have no vertex
// until the region holds a centre, and the lines along it could not reach the tripoint at its
// tip (they dangled).
void place_crossings(const BoundaryGrid& b, const Segment& sg, std::vector<Crossing>& out,
                     std::vector<std::pair<int64_t, int32_t>>& slivers, int64_t& unresolved) {
  const int64_t cell_id = sg.edge / 2;
  const int64_t c = cell_id % b.W, r = cell_id / b.W;
  const Vec2 p0 = centre(b.g, c, r);
  const Vec2 p1 = (sg.edge % 2 == 0) ? centre(b.g, c + 1, r) : centre(b.g, c, r + 1);
  const OwnerIndex& index = b.index;
  // (By sea: two cells on either side of a barrier are not neighbours; their line, if they have
  // one, runs elsewhere.)
  if (!index.metric().open_between(p0, p1)) return;
  const double ftol = b.ftol;
  SegmentSites sites(b, sg, p0, p1);
  std::unordered_map<int32_t, int32_t>& hint = sites.hint;
  auto nearest_of = [&](Vec2 p, int32_t owner, Vec2* gradient) { return sites.nearest_of(p, owner, gradient); };
  // Owner x is nearest at t0, owner y at t1: place the x-y root, or split at the owner found
  // nearer there. Appends in order of t.
  auto place = [&](auto&& self, int32_t x, int32_t y, double t0, double t1, int depth) -> void {
    // The last position measured and its hits: the root is usually the last position the search
    // measured, whose hits are then not measured again.
    Vec2 last{std::numeric_limits<double>::quiet_NaN(), 0.0};
    OwnerIndex::Hit last_x, last_y;
    Vec2 grad_x, grad_y;
    auto hits = [&](Vec2 p) {
      if (!(p.x == last.x && p.y == last.y)) {
        last = p;
        last_x = nearest_of(p, x, &grad_x);
        last_y = nearest_of(p, y, &grad_y);
      }
    };
    auto f = [&](double t) {
      hits(lerp(p0, p1, t));
      return last_x.cost - last_y.cost;
    };
    // Newton's steps with the sites' gradients (two or three positions where a bracketing
    // method measures five: the segment's ends and three inside), and where they fail (a slope
    // unknown, or a step out of the bracket where the controlling site changes) the Illinois
    // method on what is left of the bracket.
    auto with_slope = [&](double t) {
      const double v = f(t);
      return std::pair{v, (grad_x.x - grad_y.x) * (p1.x - p0.x) + (grad_x.y - grad_y.y) * (p1.y - p0.y)};
    };
    double t = newton_then_bracket(f, with_slope, 0.5 * (t0 + t1), t0, t1, true, ftol);
    Vec2 p = lerp(p0, p1, t);
    hits(p);
    OwnerIndex::Hit hx = last_x, hy = last_y;
    BoundaryVertex v = vertex_between(p, hx, hy);
    // The cost a third owner must beat to come between: the two sides' common cost on the locus.
    double between = 0.5 * (hx.cost + hy.cost);
    // By sea, a tie region (tie_edge.hpp): one cell centre in it, the other not, and the root
    // found anywhere in it; the line runs along its edge instead.
    if (!index.metric().straight() && hx.cost == hy.cost && std::isfinite(hx.cost)) {
      const double edge = tie_edge_on(
          [&](double u) {
            f(u);
            return ties(index.metric(), lerp(p0, p1, u), last_x, last_y);
          },
          t0, t1);
      if (!std::isnan(edge)) {
        t = edge;
        p = lerp(p0, p1, t);
        hits(p);
        hx = last_x;
        hy = last_y;
        v = vertex_between(p, hx, hy);
        v.tie = true;
        between = hx.cost;
      }
    }
    if (!(v.residual <= 4.0 * ftol) && index.adjusted()) {
      // The costs jump there: a reach ends (or begins) between the two sides, and the line is
      // that site's arc (reach_arc).
      const ArcPoint arc = reach_arc(index, nearest_of, p0, p1, x, y, t0, t1, t, ftol);
      if (arc.site != kNoSite) {
        t = arc.t;
        p = lerp(p0, p1, t);
        v = arc.vertex;
        between = arc.between;
      }
    }
    // Only a third owner can come between (nothing of x or y is nearer than their hits).
    // (Where both sides are beyond their reaches at the root, their costs are infinite and the
    // residual undefined: any third owner that reaches there comes between.)
    const double slack = 4.0 * ftol + (std::isfinite(v.residual) ? v.residual : 0.0);
    const auto nearest = index.nearest_third(p, x, y, std::max(between, hy.cost));
    if (nearest.site != kNoSite && nearest.cost < between - slack) {
      const int32_t z = b.owner_of_site[static_cast<size_t>(nearest.site)];
      hint.try_emplace(z, nearest.site);
      if (depth == 0) slivers.emplace_back(sg.edge, z);
      if (depth >= kMaxSliverDepth) {
        ++unresolved;
        return;
      }
      self(self, x, z, t0, t, depth + 1);
      self(self, z, y, t, t1, depth + 1);
      return;
    }
    if (x > y) flip_sides(v);
    out.push_back(Crossing{sg.edge, std::min(x, y), std::max(x, y), v});
  };
  place(place, sg.from, sg.to, 0.0, 1.0, 0);
}

}  // namespace

void find_crossings(const BoundaryGrid& b, int64_t row0, int64_t row1, CrossingSet& x, BoundaryStats& stats,
                    const CrossingFromBase* from_base) {
  const std::vector<Segment> segments = owner_changes(b, row0, row1);
  stats.crossings += static_cast<int64_t>(segments.size());
  auto row_of = [&](int64_t edge) { return edge / 2 / b.W; };
  if (b.counts)
    for (const Segment& sg : segments) b.counts->add(row_of(sg.edge), RowCounts::crossings, 1);
  // In chunks on the threads, gathered in chunk order: the result does not depend on them.
  const int64_t chunk = 256;
  const int64_t chunks = (static_cast<int64_t>(segments.size()) + chunk - 1) / chunk;
  std::vector<std::vector<Crossing>> chunk_crossings(static_cast<size_t>(chunks));
  std::vector<std::vector<std::pair<int64_t, int32_t>>> chunk_slivers(static_cast<size_t>(chunks));
  std::vector<int64_t> unresolved(segments.size(), 0);  // per segment
  detail::parallel_for(b.threads, chunks, [&](int64_t k, int) {
    const size_t end = std::min(segments.size(), static_cast<size_t>((k + 1) * chunk));
    for (size_t i = static_cast<size_t>(k * chunk); i < end; ++i) {
      const Segment& sg = segments[i];
      const int32_t lo = std::min(sg.from, sg.to), hi = std::max(sg.from, sg.to);
      BoundaryVertex v;
      if (from_base != nullptr && (*from_base)(sg.edge, lo, hi, v))
        chunk_crossings[static_cast<size_t>(k)].push_back(Crossing{sg.edge, lo, hi, v});
      else
        place_crossings(b, sg, chunk_crossings[static_cast<size_t>(k)], chunk_slivers[static_cast<size_t>(k)],
                        unresolved[i]);
    }
  });
  const size_t slivers_before = x.sliver_at.size();
  for (size_t k = 0; k < chunk_crossings.size(); ++k) {
    for (const Crossing& cr : chunk_crossings[k]) {
      auto [it, fresh] = x.on_edge.try_emplace(cr.edge, static_cast<int32_t>(x.crossings.size()), 0);
      ++it->second.second;
      x.crossings.push_back(cr);
    }
    for (const auto& [edge, third] : chunk_slivers[k])
      if (x.sliver_at.emplace(edge, third).second && b.counts)
        b.counts->add(row_of(edge), RowCounts::sliver_crossings, 1);
  }
  for (size_t i = 0; i < segments.size(); ++i) {
    stats.unresolved_slivers += unresolved[i];
    if (unresolved[i] != 0 && b.counts)
      b.counts->add(row_of(segments[i].edge), RowCounts::unresolved_slivers, unresolved[i]);
  }
  stats.sliver_crossings += static_cast<int64_t>(x.sliver_at.size() - slivers_before);
}

namespace {

// ---- Stage 2: tripoints ------------------------------------------------------------------------
// Candidate squares: three or more corner owners, or a sliver edge (an owner passing between
// two centres adds itself to the square's owners). Each tripoint found is filed under the square
// it actually lies in, which need not be the square it was sought from.

// The square a tripoint is filed under. A tripoint between the outermost cell centres and the
// grid's edge is filed under the border square next to it: the lines of the border squares end
// there, not half a cell short of it (dropping such tripoints left those lines dangling).
// Outside the grid: none (-1).
int64_t square_of(const BoundaryGrid& b, Vec2 p) {
  const GridSpec& g = b.g;
  const double gc = (p.x - g.xmin) / g.res, gr = (g.ymax - p.y) / g.res;
  if (!(gc >= 0.0 && gr >= 0.0 && gc <= static_cast<double>(b.W) && gr <= static_cast<double>(b.H))) return -1;
  if (b.W < 2 || b.H < 2) return -1;
  const double fc = std::clamp(std::floor(gc - 0.5), 0.0, static_cast<double>(b.W - 2));
  const double fr = std::clamp(std::floor(gr - 0.5), 0.0, static_cast<double>(b.H - 2));
  return static_cast<int64_t>(fr) * b.W + static_cast<int64_t>(fc);
}

// Files t unless it is one already filed (or outside the dual grid); whether it was new.
bool add_tripoint(const BoundaryGrid& b, TripointSet& set, const Tripoint& t) {
  auto& list = set.by_owners[{t.owners[0], t.owners[1], t.owners[2]}];
  for (int32_t id : list) {
    const Vec2 q = set.tripoints[static_cast<size_t>(id)].p;
    if (std::hypot(q.x - t.p.x, q.y - t.p.y) <= 1e-6 * b.g.res) return false;
  }
  const int64_t sq = square_of(b, t.p);
  if (sq < 0) return false;  // outside the dual grid: no cell-centre square holds it
  const auto id = static_cast<int32_t>(set.tripoints.size());
  set.tripoints.push_back(t);
  list.push_back(id);
  set.in_square[sq].push_back(id);
  return true;
}

// Where to start the search for the tripoint of `owners` in square (c, r): its centre, then the
// crossings on its edges between two of the three owners (the ends of the lines that meet
// there). Two tripoints of one triple a fraction of a cell apart (a short boundary between them)
// draw the search from the centre to the one already filed; from the crossing the other line
// ends at, it finds the second.
std::vector<Vec2> tripoint_starts(const BoundaryGrid& b, const CrossingSet& x, int64_t c, int64_t r,
                                  const std::array<int32_t, 3>& owners) {
  std::vector<Vec2> starts{square_mid(b.g, c, r)};
  auto in_triple = [&](int32_t o) { return o == owners[0] || o == owners[1] || o == owners[2]; };
  for (int64_t e : square_edges(b.W, c, r)) {
    const auto it = x.on_edge.find(e);
    if (it == x.on_edge.end()) continue;
    for (int32_t i = 0; i < it->second.second; ++i) {
      const Crossing& cr = x.crossings[static_cast<size_t>(it->second.first + i)];
      if (in_triple(cr.owner_lo) && in_triple(cr.owner_hi)) starts.push_back(cr.v.p);
    }
  }
  return starts;
}

// The distinct owners of square (c, r): its corners', and those passing between its centres.
std::vector<int32_t> square_owners(const BoundaryGrid& b, const CrossingSet& x, int64_t c, int64_t r,
                                   const std::array<int32_t, 4>& corners) {
  std::vector<int32_t> distinct;
  for (int32_t v : corners)
    if (v != 0 && std::find(distinct.begin(), distinct.end(), v) == distinct.end()) distinct.push_back(v);
  if (!x.sliver_at.empty())
    for (int64_t e : square_edges(b.W, c, r)) {
      const auto it = x.sliver_at.find(e);
      if (it != x.sliver_at.end() && std::find(distinct.begin(), distinct.end(), it->second) == distinct.end())
        distinct.push_back(it->second);
    }
  std::sort(distinct.begin(), distinct.end());
  return distinct;
}

// Whether some owner pair has an odd number of crossings on the square's edges: a line of that
// pair enters the square and does not leave it, so it ends at a tripoint inside.
bool line_ends_inside(const BoundaryGrid& b, const CrossingSet& x, int64_t c, int64_t r) {
  std::vector<std::pair<int64_t, int>> counts;
  for (int64_t e : square_edges(b.W, c, r)) {
    const auto it = x.on_edge.find(e);
    if (it == x.on_edge.end()) continue;
    for (int32_t i = 0; i < it->second.second; ++i) {
      const Crossing& cr = x.crossings[static_cast<size_t>(it->second.first + i)];
      const int64_t key = pair_key(cr.owner_lo, cr.owner_hi);
      auto p = std::find_if(counts.begin(), counts.end(), [&](const auto& q) { return q.first == key; });
      if (p == counts.end())
        counts.emplace_back(key, 1);
      else
        ++p->second;
    }
  }
  return std::any_of(counts.begin(), counts.end(), [](const auto& q) { return q.second % 2 != 0; });
}

// The tripoint of `o` in square (c, r) where one of them is bounded by an arc (a reach ends): the
// arcs are those of the crossings on the square's edges. Each system -- an arc and the locus of
// the other two, or two owners' arcs -- is solved by Newton's method (numeric Jacobian) from the
// square's middle; a solution counts where the three owners, and only they, hold the positions
// round it.
bool arc_tripoint(const BoundaryGrid& b, const CrossingSet& x, int64_t c, int64_t r, const std::array<int32_t, 3>& o,
                  Tripoint& out) {
  const OwnerIndex& index = b.index;
  const SiteMetric& m = index.metric();
  struct Arc {
    int32_t owner, site;
  };
  std::vector<Arc> arcs;
  for (int64_t e : square_edges(b.W, c, r)) {
    const auto it = x.on_edge.find(e);
    if (it == x.on_edge.end()) continue;
    for (int32_t i = 0; i < it->second.second; ++i) {
      const Crossing& cr = x.crossings[static_cast<size_t>(it->second.first + i)];
      if (cr.v.arc == 0) continue;
      const Arc a = cr.v.arc == 1 ? Arc{cr.owner_lo, cr.v.site_a} : Arc{cr.owner_hi, cr.v.site_b};
      if (std::find(o.begin(), o.end(), a.owner) == o.end()) continue;
      if (std::none_of(arcs.begin(), arcs.end(), [&](const Arc& q) { return q.site == a.site; })) arcs.push_back(a);
    }
  }
  if (arcs.empty()) return false;
  auto on_arc = [&](const Arc& a, Vec2 p) { return m.distance(p, a.site) - index.reach_of(a.site); };
  auto locus = [&](int32_t i, int32_t j, Vec2 p) { return index.nearest_of(p, i).cost - index.nearest_of(p, j).cost; };
  std::vector<std::function<std::array<double, 2>(Vec2)>> systems;
  for (const Arc& a : arcs) {
    std::array<int32_t, 2> rest{};
    for (int k = 0, q = 0; k < 3; ++k)
      if (o[static_cast<size_t>(k)] != a.owner) rest[static_cast<size_t>(q++)] = o[static_cast<size_t>(k)];
    systems.push_back([&, a, rest](Vec2 p) { return std::array<double, 2>{on_arc(a, p), locus(rest[0], rest[1], p)}; });
  }
  for (size_t i = 0; i < arcs.size(); ++i)
    for (size_t j = i + 1; j < arcs.size(); ++j)
      if (arcs[i].owner != arcs[j].owner)
        systems.push_back([&, i, j](Vec2 p) { return std::array<double, 2>{on_arc(arcs[i], p), on_arc(arcs[j], p)}; });
  const Vec2 mid = square_mid(b.g, c, r);
  const double res = b.g.res, h = 1e-6 * res;
  for (const auto& f : systems) {
    Vec2 p = mid;
    bool converged = false;
    for (int iter = 0; iter < 40 && !converged; ++iter) {
      const std::array<double, 2> v = f(p);
      if (!std::isfinite(v[0]) || !std::isfinite(v[1])) break;
      if (std::max(std::abs(v[0]), std::abs(v[1])) <= b.ftol) {
        converged = true;
        break;
      }
      const auto fx = f(Vec2{p.x + h, p.y}), fy = f(Vec2{p.x, p.y + h});
      const double j00 = (fx[0] - v[0]) / h, j01 = (fy[0] - v[0]) / h, j10 = (fx[1] - v[1]) / h,
                   j11 = (fy[1] - v[1]) / h;
      const double det = j00 * j11 - j01 * j10;
      if (!(std::abs(det) > 0.0) || !std::isfinite(det)) break;
      Vec2 d{-(j11 * v[0] - j01 * v[1]) / det, -(-j10 * v[0] + j00 * v[1]) / det};
      const double len = std::hypot(d.x, d.y);
      if (len > res) d = Vec2{d.x * res / len, d.y * res / len};
      p = Vec2{p.x + d.x, p.y + d.y};
      if (std::hypot(p.x - mid.x, p.y - mid.y) > 2.0 * res) break;
    }
    if (!converged) continue;
    // The owners round it: the three, and no other (nor unowned sea).
    std::array<bool, 3> seen{false, false, false};
    bool other = false;
    for (int k = 0; k < 16; ++k) {
      const double a = k * std::numbers::pi / 8.0, eps = 1e-4 * res;
      const int32_t w = owner_at(index, Vec2{p.x + eps * std::cos(a), p.y + eps * std::sin(a)});
      const auto at = std::find(o.begin(), o.end(), w);
      if (at == o.end())
        other = true;
      else
        seen[static_cast<size_t>(at - o.begin())] = true;
    }
    if (other || !(seen[0] && seen[1] && seen[2])) continue;
    // Each owner's site there: its arc's, or its nearest within reach. An owner none of whose
    // sites reaches the point (its arc ends just short of it) makes no tripoint here.
    std::array<int32_t, 3> site{};
    for (int k = 0; k < 3; ++k) {
      const auto arc = std::find_if(arcs.begin(), arcs.end(), [&](const Arc& q) { return q.owner == o[k]; });
      site[static_cast<size_t>(k)] = arc != arcs.end() && std::abs(on_arc(*arc, p)) <= 4.0 * b.ftol
                                         ? arc->site
                                         : index.nearest_of(p, o[static_cast<size_t>(k)]).site;
    }
    if (std::find(site.begin(), site.end(), kNoSite) != site.end()) continue;
    double worst = 0.0;
    for (double v : f(p)) worst = std::max(worst, std::abs(v));
    out = Tripoint{};
    out.p = p;
    out.residual = worst;
    for (int k = 0; k < 3; ++k) {
      out.owners[k] = o[static_cast<size_t>(k)];
      out.sites[k] = site[static_cast<size_t>(k)];
      out.distances[k] = m.distance(p, out.sites[k]);
      out.distance += out.distances[k] / 3.0;
      out.cost += out.distances[k] / index.weight_of(out.sites[k]) / 3.0;
    }
    return true;
  }
  return false;
}

}  // namespace

void find_tripoints(const BoundaryGrid& b, const CrossingSet& x, int64_t row0, int64_t row1, TripointSet& set,
                    std::vector<std::array<int64_t, 2>>& unplaced, BoundaryStats& stats) {
  const TripointSolver solver{b.index, b.ftol, 1e-6 * b.g.res};
  const double res = b.g.res;
  for (const auto& [c, r] : mixed_squares(b, row0, row1)) {
    const auto corners = b.corner_owners(c, r);
    const std::vector<int32_t> distinct = square_owners(b, x, c, r, corners);
    if (distinct.size() < 3) continue;
    ++stats.multi_owner_squares;
    if (b.counts) b.counts->add(r, RowCounts::multi_owner_squares, 1);
    const Vec2 mid = square_mid(b.g, c, r);
    const size_t before = set.tripoints.size();
    for (size_t i = 0; i < distinct.size(); ++i)
      for (size_t j = i + 1; j < distinct.size(); ++j)
        for (size_t k = j + 1; k < distinct.size(); ++k) {
          const std::array<int32_t, 3> triple{distinct[i], distinct[j], distinct[k]};
          // From the centre first; from the crossings only when that found none new.
          bool found = false;
          for (const Vec2 start : tripoint_starts(b, x, c, r, triple)) {
            Tripoint t;
            if (!solver.solve(triple, start, res, t)) continue;
            if (std::abs(t.p.x - mid.x) > res || std::abs(t.p.y - mid.y) > res) continue;
            const auto any = b.index.nearest(t.p);
            if (any.cost < t.cost - 4.0 * b.ftol - t.residual) continue;  // another owner is nearer
            if (add_tripoint(b, set, t)) {
              found = true;
              break;
            }
          }
          // Where a reach ends, the three regions meet on an arc: an arc and the other two's
          // locus, or two arcs.
          if (!found && b.index.adjusted()) {
            Tripoint t;
            if (arc_tripoint(b, x, c, r, triple, t) && std::abs(t.p.x - mid.x) <= res && std::abs(t.p.y - mid.y) <= res)
              add_tripoint(b, set, t);
          }
        }
    if (set.tripoints.size() == before) unplaced.push_back({c, r});
    set.found_row.resize(set.tripoints.size(), static_cast<int32_t>(r));
  }
}

void file_tripoint(const BoundaryGrid& b, TripointSet& set, const Tripoint& t, int32_t found_row) {
  const auto id = static_cast<int32_t>(set.tripoints.size());
  set.tripoints.push_back(t);
  set.by_owners[{t.owners[0], t.owners[1], t.owners[2]}].push_back(id);
  set.in_square[square_of(b, t.p)].push_back(id);
  set.found_row.push_back(found_row);
}

void count_unresolved(const BoundaryGrid& b, const CrossingSet& x, const TripointSet& set,
                      const std::vector<std::array<int64_t, 2>>& unplaced, BoundaryStats& stats) {
  // A square whose search placed nothing is a defect only if a line must end inside it and no
  // tripoint is filed under it (found from a neighbouring square, checked once all are done): a
  // square crossed by two lines that meet outside it has three owners at its corners and every
  // owner pair's crossings in pairs.
  for (const auto& [c, r] : unplaced)
    if (set.in_square.find(r * b.W + c) == set.in_square.end() && line_ends_inside(b, x, c, r))
      ++stats.unresolved_tripoints;
}

namespace {

// ---- Stage 3: links ----------------------------------------------------------------------------
// Per dual square, the crossings on its edges are joined to each other or to the square's
// tripoints; the nodes are crossings (ids 0..n-1), then tripoints (n + tripoint id).

bool has(const Tripoint& t, int32_t a) { return t.owners[0] == a || t.owners[1] == a || t.owners[2] == a; }

// The nearest tripoint of `ids` that has both owners of the crossing, or -1.
int32_t nearest_tripoint(const TripointSet& set, const Crossing& cr, const std::vector<int32_t>& ids) {
  int32_t best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (int32_t id : ids) {
    const Tripoint& t = set.tripoints[static_cast<size_t>(id)];
    if (!has(t, cr.owner_lo) || !has(t, cr.owner_hi)) continue;
    const double d = std::hypot(t.p.x - cr.v.p.x, t.p.y - cr.v.p.y);
    if (d < best_d) {
      best_d = d;
      best = id;
    }
  }
  return best;
}

// One square being linked: its crossings (edge k of the square, crossing id), in edge order.
struct SquareLinks {
  const BoundaryGrid& b;
  const CrossingSet& x;
  const TripointSet& t;
  Links& out;
  int64_t c, r;
  std::vector<std::pair<int, int32_t>> items;
  bool open = false;  // a corner without owner (beyond a max distance)

  const Crossing& cross(size_t item) const { return x.crossings[static_cast<size_t>(items[item].second)]; }
  int32_t node(size_t item) const { return items[item].second; }
  int64_t pair_of(size_t item) const { return pair_key(cross(item).owner_lo, cross(item).owner_hi); }
  // By sea, a line joins a crossing to a tripoint only where the way between them is open: a
  // barrier across the square parts the two sides' costs (a boom's faces, an islet between the
  // centres), and the tripoint solved on one side is no end of a line on the other. Such a
  // crossing is left an open end (end_at_barriers takes it to the barrier; complete_tripoints
  // walks the tripoint's own line if it lacks one).
  bool clear(Vec2 u, Vec2 w) const { return b.index.metric().straight() || b.index.metric().open_between(u, w); }
  Vec2 tripoint_at(int32_t id) const { return t.tripoints[static_cast<size_t>(id)].p; }

  // Crossings end at the nearest tripoint of their pair filed in this square. A tripoint filed
  // here from the half cell beyond the outermost centres (see square_of) lies outside the square:
  // the line may cross the square on its way there, so only the crossing nearest to it ends
  // there, and the others are returned to be paired.
  std::vector<size_t> at_tripoints(const std::vector<int32_t>& here) {
    const GridSpec& g = b.g;
    const double x0 = g.centre_x(c), x1 = g.centre_x(c + 1), y0 = g.centre_y(r + 1), y1 = g.centre_y(r);
    std::vector<int32_t> target(items.size(), -1);
    std::map<std::pair<int32_t, int64_t>, size_t> nearest_to_outside;  // (tripoint, pair) -> item
    for (size_t i = 0; i < items.size(); ++i) {
      const int32_t tp = nearest_tripoint(t, cross(i), here);
      if (tp < 0) continue;
      target[i] = tp;
      const Vec2 q = t.tripoints[static_cast<size_t>(tp)].p;
      if (q.x >= x0 && q.x <= x1 && q.y >= y0 && q.y <= y1) continue;
      auto [it, fresh] = nearest_to_outside.try_emplace({tp, pair_of(i)}, i);
      auto dist = [&](size_t j) { return std::hypot(q.x - cross(j).v.p.x, q.y - cross(j).v.p.y); };
      if (!fresh && dist(i) < dist(it->second)) it->second = i;
    }
    // The line to an outside tripoint that leaves the square through the edge facing it (the
    // outermost centre line) entered it through another edge: with exactly one other crossing
    // of the pair here, that one is joined to the crossing on the facing edge.
    std::vector<bool> joined(items.size(), false);
    for (const auto& [key, n] : nearest_to_outside) {
      const Vec2 q = t.tripoints[static_cast<size_t>(key.first)].p;
      const int k = items[n].first;
      const bool facing = (k == 0 && q.y > y1) || (k == 1 && q.x > x1) || (k == 2 && q.y < y0) || (k == 3 && q.x < x0);
      std::vector<size_t> same;
      for (size_t i = 0; i < items.size(); ++i)
        if (i != n && pair_of(i) == key.second) same.push_back(i);
      if (facing && same.size() == 1) {
        out.add(node(same[0]), node(n), key.second, static_cast<int32_t>(r));
        joined[same[0]] = true;
      }
    }
    std::vector<size_t> unlinked;
    for (size_t i = 0; i < items.size(); ++i) {
      if (joined[i]) continue;
      bool ends_here = target[i] >= 0;
      if (ends_here) {
        const auto it = nearest_to_outside.find({target[i], pair_of(i)});
        ends_here = it == nearest_to_outside.end() || it->second == i;
      }
      if (ends_here && !clear(cross(i).v.p, tripoint_at(target[i]))) continue;
      if (ends_here)
        out.add(node(i), tripoint_node(target[i]), pair_of(i), static_cast<int32_t>(r));
      else
        unlinked.push_back(i);
    }
    // Two tripoints sharing two owners are joined by those owners' boundary.
    for (size_t i = 0; i < here.size(); ++i)
      for (size_t j = i + 1; j < here.size(); ++j) {
        const Tripoint& ti = t.tripoints[static_cast<size_t>(here[i])];
        const Tripoint& tj = t.tripoints[static_cast<size_t>(here[j])];
        std::vector<int32_t> shared;
        for (int32_t a : ti.owners)
          if (has(tj, a)) shared.push_back(a);
        if (shared.size() == 2 && clear(ti.p, tj.p))
          out.add(tripoint_node(here[i]), tripoint_node(here[j]), pair_key(shared[0], shared[1]),
                  static_cast<int32_t>(r));
      }
    return unlinked;
  }

  // Saddle A B / B A: the owner of the square's centre connects its two corners.
  void saddle(const std::array<int32_t, 4>& o) {
    const Vec2 mid = square_mid(b.g, c, r);
    const auto h0 = b.index.nearest_of(mid, o[0]), h1 = b.index.nearest_of(mid, o[1]);
    const bool centre_is_o0 = h0.cost < h1.cost || (h0.cost == h1.cost && h0.site < h1.site);
    const int64_t pair = pair_key(o[0], o[1]);
    if (centre_is_o0) {  // corners 1 and 3 are cut off
      out.add(node(0), node(1), pair, static_cast<int32_t>(r));
      out.add(node(2), node(3), pair, static_cast<int32_t>(r));
    } else {  // corners 0 and 2 are cut off
      out.add(node(3), node(0), pair, static_cast<int32_t>(r));
      out.add(node(1), node(2), pair, static_cast<int32_t>(r));
    }
  }

  // The tripoints filed in the 8 squares around this one.
  std::vector<int32_t> tripoints_around() const {
    std::vector<int32_t> around;
    for (int64_t dr = -1; dr <= 1; ++dr)
      for (int64_t dc = -1; dc <= 1; ++dc) {
        if ((dr == 0 && dc == 0) || r + dr < 0 || c + dc < 0 || r + dr + 1 >= b.H || c + dc + 1 >= b.W) continue;
        const auto it = t.in_square.find((r + dr) * b.W + (c + dc));
        if (it != t.in_square.end()) around.insert(around.end(), it->second.begin(), it->second.end());
      }
    return around;
  }

  // Crossings of one pair, two in the square: joined. A lone crossing whose pair has a tripoint
  // in a neighbouring square (its third owner passed between two centres): joined to that
  // tripoint -- unless a corner here has no owner: the line ends where the owned area does.
  void pair_up(const std::vector<size_t>& unlinked) {
    for (size_t k : unlinked) {
      int same = 0;
      size_t other = 0;
      for (size_t m : unlinked)
        if (m != k && cross(m).owner_lo == cross(k).owner_lo && cross(m).owner_hi == cross(k).owner_hi) {
          ++same;
          other = m;
        }
      const int64_t pair = pair_of(k);
      if (same == 1) {
        if (k < other) out.add(node(k), node(other), pair, static_cast<int32_t>(r));
        continue;
      }
      if (same > 1 || open) continue;
      std::vector<int32_t> around = tripoints_around();
      // The line leaves the crossing into this square, so the tripoint lies on this square's
      // side of the crossing's edge (edges: 0 top, 1 right, 2 bottom, 3 left).
      const Vec2 e = cross(k).v.p;
      const int side = items[k].first;
      std::erase_if(around, [&](int32_t id) {
        const Vec2 q = t.tripoints[static_cast<size_t>(id)].p;
        switch (side) {
          case 0:
            return !(q.y < e.y);
          case 1:
            return !(q.x < e.x);
          case 2:
            return !(q.y > e.y);
          default:
            return !(q.x > e.x);
        }
      });
      const int32_t tp = nearest_tripoint(t, cross(k), around);
      if (tp >= 0 && clear(e, tripoint_at(tp))) out.add(node(k), tripoint_node(tp), pair, static_cast<int32_t>(r));
    }
  }
};

}  // namespace

Links link_squares(const BoundaryGrid& b, const CrossingSet& x, const TripointSet& t, int64_t row0, int64_t row1,
                   BoundaryStats& stats) {
  Links out;
  for (const auto& [c, r] : mixed_squares(b, row0, row1)) {
    const auto o = b.corner_owners(c, r);
    SquareLinks sq{b, x, t, out, c, r, {}, o[0] == 0 || o[1] == 0 || o[2] == 0 || o[3] == 0};
    const auto edges = square_edges(b.W, c, r);
    // The crossings on the square's edges; an edge crossed by owners passing between its two
    // centres carries several.
    std::array<int, 4> per_edge{0, 0, 0, 0};
    for (int k = 0; k < 4; ++k) {
      const auto it = x.on_edge.find(edges[static_cast<size_t>(k)]);
      if (it == x.on_edge.end()) continue;
      for (int32_t i = 0; i < it->second.second; ++i) sq.items.emplace_back(k, it->second.first + i);
      per_edge[static_cast<size_t>(k)] = it->second.second;
    }
    if (sq.items.empty()) continue;
    const auto here = t.in_square.find(r * b.W + c);
    std::vector<size_t> unlinked;
    if (here != t.in_square.end()) {
      unlinked = sq.at_tripoints(here->second);
    } else if (per_edge == std::array<int, 4>{1, 1, 1, 1} && o[0] == o[2] && o[1] == o[3] && o[0] != o[1]) {
      ++stats.saddles;
      if (b.counts) b.counts->add(r, RowCounts::saddles, 1);
      sq.saddle(o);
      continue;
    } else {
      unlinked.resize(sq.items.size());
      std::iota(unlinked.begin(), unlinked.end(), size_t{0});
    }
    sq.pair_up(unlinked);
  }
  return out;
}

// ---- Stage 4: chains ---------------------------------------------------------------------------
// The links chained into lines per owner pair, simplified, in a deterministic order.

std::vector<BoundaryLine> chain_lines(const CrossingSet& x, const TripointSet& t, const Links& links, double tol,
                                      BoundaryStats& stats, const LineRefiner* refiner, int threads) {
  const auto ncross = static_cast<int32_t>(x.crossings.size());
  const auto ntri = static_cast<int32_t>(t.tripoints.size());
  std::vector<bool> terminal(static_cast<size_t>(ncross + ntri), false);
  for (int32_t i = 0; i < ntri; ++i) terminal[static_cast<size_t>(ncross + i)] = true;
  // Tripoints are numbered after the crossings.
  std::vector<std::array<int32_t, 2>> numbered(links.links);
  for (auto& l : numbered)
    for (int32_t& n : l)
      if (n < 0) n = ncross + (-1 - n);
  const Chains chains = chain_links(ncross + ntri, numbered, terminal);
  std::vector<BoundaryLine> lines;
  for (size_t k = 0; k < chains.node_lists.size(); ++k) {
    const int64_t pair = links.pair[static_cast<size_t>(chains.first_link[k])];
    BoundaryLine line;
    line.owner_a = static_cast<int32_t>(pair >> 32);
    line.owner_b = static_cast<int32_t>(pair & 0xffffffff);
    line.closed = chains.closed[k];
    std::vector<BoundaryVertex>& all = line.vertices;
    for (int32_t node : chains.node_lists[k]) {
      if (node < ncross) {
        all.push_back(x.crossings[static_cast<size_t>(node)].v);
        continue;
      }
      const Tripoint& tp = t.tripoints[static_cast<size_t>(node - ncross)];
      BoundaryVertex v{tp.p, kNoSite, kNoSite, tp.distance, tp.residual};
      for (int i = 0; i < 3; ++i) {
        if (tp.owners[i] == line.owner_a) {
          v.site_a = tp.sites[i];
          v.distance_a = tp.distances[i];
        }
        if (tp.owners[i] == line.owner_b) {
          v.site_b = tp.sites[i];
          v.distance_b = tp.distances[i];
        }
      }
      all.push_back(v);
    }
    lines.push_back(std::move(line));
  }
  finish_lines(lines, refiner, tol, stats, threads);
  // Deterministic order: by owner pair, then by first vertex.
  std::stable_sort(lines.begin(), lines.end(), [](const BoundaryLine& a, const BoundaryLine& b) {
    if (a.owner_a != b.owner_a) return a.owner_a < b.owner_a;
    if (a.owner_b != b.owner_b) return a.owner_b < b.owner_b;
    const Vec2 pa = a.vertices.front().p, pb = b.vertices.front().p;
    return pa.y != pb.y ? pa.y > pb.y : pa.x < pb.x;
  });
  return lines;
}

}  // namespace boundary_stages

}  // namespace rv

namespace rv::boundary_stages {

std::vector<BoundaryLine> lone_crossings(const CrossingSet& x, const Links& links) {
  std::vector<bool> linked(x.crossings.size(), false);
  for (const auto& l : links.links)
    for (const int32_t n : l)
      if (n >= 0) linked[static_cast<size_t>(n)] = true;
  std::vector<BoundaryLine> out;
  for (size_t i = 0; i < linked.size(); ++i)
    if (!linked[i]) {
      const Crossing& c = x.crossings[i];
      out.push_back(BoundaryLine{c.owner_lo, c.owner_hi, false, {c.v}, {}});
    }
  return out;
}

std::vector<TripointGap> tripoint_gaps(const std::vector<Tripoint>& tripoints, const std::vector<BoundaryLine>& lines) {
  std::set<std::tuple<double, double, int32_t, int32_t>> ends;
  for (const BoundaryLine& l : lines)
    if (!l.closed && !l.vertices.empty())
      for (const Vec2 p : {l.vertices.front().p, l.vertices.back().p}) ends.insert({p.x, p.y, l.owner_a, l.owner_b});
  std::vector<TripointGap> gaps;
  for (size_t n = 0; n < tripoints.size(); ++n) {
    const Tripoint& t = tripoints[n];
    for (const auto& [i, k] : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}})
      if (ends.count({t.p.x, t.p.y, t.owners[i], t.owners[k]}) == 0) gaps.push_back({n, i, k});
  }
  return gaps;
}

void join_close_tripoints(const std::vector<Tripoint>& tripoints, double cell, std::vector<BoundaryLine>& lines) {
  struct Missing {
    size_t tripoint;
    int i, k;  // owners[i] < owners[k]
    bool used = false;
  };
  std::vector<Missing> missing;
  for (const TripointGap& g : tripoint_gaps(tripoints, lines)) missing.push_back({g.tripoint, g.i, g.k});
  for (size_t m = 0; m < missing.size(); ++m) {
    if (missing[m].used) continue;
    const Tripoint& t = tripoints[missing[m].tripoint];
    const int32_t a = t.owners[missing[m].i], b = t.owners[missing[m].k];
    size_t best = missing.size();
    double best_d = cell;
    for (size_t q = m + 1; q < missing.size(); ++q) {
      const Tripoint& u = tripoints[missing[q].tripoint];
      if (missing[q].used || u.owners[missing[q].i] != a || u.owners[missing[q].k] != b) continue;
      const double d = std::hypot(u.p.x - t.p.x, u.p.y - t.p.y);
      if (d < best_d) {
        best_d = d;
        best = q;
      }
    }
    if (best == missing.size()) continue;
    missing[m].used = missing[best].used = true;
    const Tripoint& u = tripoints[missing[best].tripoint];
    auto vertex = [&](const Tripoint& x, int i, int k) {
      return BoundaryVertex{x.p, x.sites[i], x.sites[k], x.distance, x.residual, x.distances[i], x.distances[k]};
    };
    lines.push_back(BoundaryLine{
        a, b, false, {vertex(t, missing[m].i, missing[m].k), vertex(u, missing[best].i, missing[best].k)}, {}});
  }
}

}  // namespace rv::boundary_stages
