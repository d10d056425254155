// close_missing_tripoints (boundary_stages.hpp): tripoints a crowded dual square's search missed,
// found again from the ends of their three lines.
//
// Why: a square whose corners and interior hold four or five owners can hide two tripoints of
// which the search resolves one; its lines then stop in the open and the regions cannot be
// closed. The three lines of the missing tripoint are all there up to a cell from it, so the
// point is solved from them rather than from the square.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/line_tools.hpp"

namespace rv::boundary_stages {

using namespace line_tools;

namespace {

// One end of an owner pair's line near a missing tripoint: a line's end in the open, or a
// tripoint lacking that pair's line.
struct LooseEnd {
  int32_t lo, hi;  // the pair, lo < hi
  Vec2 p;
  size_t line = 0;  // an open end: the line, and which end
  bool front = false;
  size_t tripoint = 0;  // a gap: the tripoint and its owners' indices
  int i = 0, k = 0;
  bool gap = false;
  bool used = false;
  bool has(int32_t o) const { return lo == o || hi == o; }
  int32_t other(int32_t o) const { return lo == o ? hi : lo; }
};

std::vector<LooseEnd> loose_ends(const BoundaryGrid& b, const std::vector<Tripoint>& tripoints,
                                 const std::vector<BoundaryLine>& lines) {
  std::vector<LooseEnd> out;
  for (const TripointGap& g : tripoint_gaps(tripoints, lines)) {
    const Tripoint& t = tripoints[g.tripoint];
    LooseEnd e{t.owners[g.i], t.owners[g.k], t.p};
    e.tripoint = g.tripoint;
    e.i = g.i;
    e.k = g.k;
    e.gap = true;
    out.push_back(e);
  }
  for (size_t l = 0; l < lines.size(); ++l) {
    const BoundaryLine& line = lines[l];
    if (line.closed || line.vertices.empty()) continue;
    for (const bool front : {true, false}) {
      const Vec2 p = front ? line.vertices.front().p : line.vertices.back().p;
      if (on_centre_frame(b.g, p) || outside_frame(b.g, p)) continue;
      if (at_tripoint(tripoints, p)) continue;
      LooseEnd e{line.owner_a, line.owner_b, p};
      e.line = l;
      e.front = front;
      out.push_back(e);
    }
  }
  return out;
}

}  // namespace

bool solve_tripoint(const BoundaryGrid& b, std::array<int32_t, 3> owners, Vec2 start, double max_distance,
                    Tripoint& out) {
  std::sort(owners.begin(), owners.end());
  std::array<int32_t, 3> sites{};
  Vec2 p = start;
  for (int round = 0; round < 4; ++round) {
    for (int n = 0; n < 3; ++n)
      sites[static_cast<size_t>(n)] = b.index.nearest_of(p, owners[static_cast<size_t>(n)]).site;
    if (std::find(sites.begin(), sites.end(), kNoSite) != sites.end()) return false;
    Vec2 q;
    if (!equal_costs_point(b.index, sites[0], sites[1], sites[2], start, 2.0 * b.g.res, b.ftol, q)) return false;
    std::array<OwnerIndex::Hit, 3> h;
    for (int n = 0; n < 3; ++n) h[static_cast<size_t>(n)] = b.index.nearest_of(q, owners[static_cast<size_t>(n)]);
    p = q;
    if (h[0].site != sites[0] || h[1].site != sites[1] || h[2].site != sites[2]) continue;  // again with these
    const double hi = std::max({h[0].cost, h[1].cost, h[2].cost});
    const double lo = std::min({h[0].cost, h[1].cost, h[2].cost});
    // No fourth owner nearer than the three, and the owned area's (beyond the max distance the
    // three lines end on its edge instead).
    const OwnerIndex::Hit nearest = b.index.nearest(q);
    if (nearest.cost < lo - b.ftol) return false;
    if (std::max({h[0].distance, h[1].distance, h[2].distance}) > max_distance) return false;
    out = Tripoint{};
    out.p = q;
    for (int n = 0; n < 3; ++n) {
      out.owners[n] = owners[static_cast<size_t>(n)];
      out.sites[n] = h[static_cast<size_t>(n)].site;
      out.distances[n] = h[static_cast<size_t>(n)].distance;
    }
    out.distance = (h[0].distance + h[1].distance + h[2].distance) / 3.0;
    out.cost = (h[0].cost + h[1].cost + h[2].cost) / 3.0;
    out.residual = hi - lo;
    return true;
  }
  return false;
}

BoundaryVertex tripoint_vertex(const Tripoint& t, int32_t a, int32_t b) {
  const int i = static_cast<int>(std::find(t.owners, t.owners + 3, a) - t.owners);
  const int k = static_cast<int>(std::find(t.owners, t.owners + 3, b) - t.owners);
  return BoundaryVertex{t.p, t.sites[i], t.sites[k], t.distance, t.residual, t.distances[i], t.distances[k]};
}

void close_missing_tripoints(const BoundaryGrid& b, double max_distance, std::vector<Tripoint>& tripoints,
                             std::vector<BoundaryLine>& lines, BoundaryStats& stats) {
  std::vector<LooseEnd> ends = loose_ends(b, tripoints, lines);
  const double near = 2.0 * b.g.res;
  auto close = [&](const LooseEnd& u, const LooseEnd& v) { return std::hypot(u.p.x - v.p.x, u.p.y - v.p.y) <= near; };
  std::vector<BoundaryLine> added;
  // By sea, the three ends' ways to the tripoint must be open (a barrier between parts the
  // owners' costs: a tripoint solved across it is no end of theirs), a tripoint lacking a line
  // joined to it only along their locus (the line it lacks may leave it the other way, to a coast
  // the cells do not show), and a tripoint already known is not made again: the lines it lacks
  // are walked from it (complete_tripoints), and open ends are walked to it.
  const SiteMetric& metric = b.index.metric();
  auto reachable = [&](const Tripoint& t, std::array<size_t, 3> which) {
    if (metric.straight()) return true;
    for (const size_t n : which)
      if (!metric.open_between(ends[n].p, t.p) ||
          (ends[n].gap && !along_locus(b, ends[n].lo, ends[n].hi, ends[n].p, t.p)))
        return false;
    return std::none_of(tripoints.begin(), tripoints.end(), [&](const Tripoint& o) {
      return std::equal(o.owners, o.owners + 3, t.owners) && std::hypot(o.p.x - t.p.x, o.p.y - t.p.y) <= 1e-3 * b.g.res;
    });
  };
  for (size_t e = 0; e < ends.size(); ++e) {
    if (ends[e].gap || ends[e].used) continue;
    const int32_t a = ends[e].lo, c = ends[e].hi;
    // A third owner x with ends of (a, x) and (c, x) near this one.
    bool done = false;
    for (size_t f = 0; f < ends.size() && !done; ++f) {
      if (f == e || ends[f].used || !close(ends[e], ends[f]) || !(ends[f].has(a) || ends[f].has(c))) continue;
      if (ends[f].has(a) && ends[f].has(c)) continue;
      const int32_t x = ends[f].has(a) ? ends[f].other(a) : ends[f].other(c);
      const int32_t y = ends[f].has(a) ? c : a;  // the owner the third end pairs with x
      for (size_t g = 0; g < ends.size() && !done; ++g) {
        if (g == e || g == f || ends[g].used || !close(ends[e], ends[g]) || !ends[g].has(x) || !ends[g].has(y))
          continue;
        Tripoint t;
        if (!solve_tripoint(b, {a, c, x}, ends[e].p, max_distance, t) || !reachable(t, {e, f, g})) continue;
        for (const size_t n : {e, f, g}) {
          LooseEnd& le = ends[n];
          le.used = true;
          if (le.gap) {
            added.push_back(
                BoundaryLine{le.lo,
                             le.hi,
                             false,
                             {tripoint_vertex(tripoints[le.tripoint], le.lo, le.hi), tripoint_vertex(t, le.lo, le.hi)},
                             {}});
          } else {
            std::vector<BoundaryVertex>& v = lines[le.line].vertices;
            const BoundaryVertex tv = tripoint_vertex(t, le.lo, le.hi);
            if (le.front)
              v.insert(v.begin(), tv);
            else
              v.push_back(tv);
          }
        }
        tripoints.push_back(t);
        stats.max_residual = std::max(stats.max_residual, t.residual);
        ++stats.missing_tripoints_found;
        done = true;
      }
    }
  }
  for (BoundaryLine& l : added) {
    stats.vertices += static_cast<int64_t>(l.vertices.size());
    lines.push_back(std::move(l));
  }
}

}  // namespace rv::boundary_stages
