// cross_hidden_channels (boundary_stages.hpp): by sea, the lines where no two cells show the change
// of owner.
//
// Why: the lines are found between cells in sight of each other. Where the owner changes inside
// sea narrower than a cell -- a sliver of sea along a land border, a river mouth, a sound between
// two islands at a coarse grid -- or between the last cells and the grid's edge, no two such
// cells lie either side of the change, so no line is drawn there, and the regions make one face
// of two owners' seas. The coasts show it instead: walked edge by edge, every change of owner
// along a coast is where a line of those two owners meets it. A change that no line ends at is a
// line missing; across a channel its other end is the same two owners' change on the opposite
// coast, and near the grid's edge the edge itself.
#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <limits>
#include <numbers>
#include <unordered_map>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/line_tools.hpp"

namespace rv::boundary_stages {

using namespace line_tools;

namespace {

// Where two owners' distances by sea meet on a barrier's edge, approached from one side.
struct Junction {
  Vec2 p;
  int32_t lo = 0, hi = 0;  // the owners, lo < hi
  BoundaryVertex v;
  Vec2 into;  // off the edge's chord towards the side approached from (the sea there)
};

// Whether p lies strictly inside the grid's extent.
bool inside_grid(const GridSpec& g, Vec2 p) { return p.x > g.xmin && p.x < g.xmax() && p.y > g.ymin() && p.y < g.ymax; }

// A point off the chord e0-e1 on its left (s = 1) or right (s = -1), an edge's length from its
// middle: the side a point of the edge is approached from (SiteMetric::domain_edge_point).
Vec2 off_chord(Vec2 e0, Vec2 e1, double s) {
  const Vec2 mid = lerp(e0, e1, 0.5), n{-(e1.y - e0.y), e1.x - e0.x};
  return Vec2{mid.x + s * n.x, mid.y + s * n.y};
}

// The owner at p (0: none, or beyond max_distance), with `last` the site nearest to the position
// asked before: measured here, it is the search's first bound (along a coast it mostly stays the
// nearest; the answer is the same with or without it), and it becomes this one's.
int32_t owner_at(const BoundaryGrid& b, double max_distance, Vec2 p, int32_t& last) {
  OwnerIndex::Hit known;
  if (last != kNoSite) {
    known.site = last;
    known.distance = b.index.metric().distance(p, last);
  }
  const OwnerIndex::Hit h = b.index.nearest(p, known);
  if (h.site != kNoSite) last = h.site;
  return h.site != kNoSite && h.distance <= max_distance ? b.owner_code(h.site) : 0;
}

// The junction of owners oa and ob on `edge` between parameters t0 and t1, approached from
// `side`, where oa is the owner towards t0 and ob towards t1 (see the contract); false where the
// costs do not part there from that side, or a third owner is nearer.
bool junction_on(const BoundaryGrid& b, int32_t edge, Vec2 side, double t0, double t1, int32_t oa, int32_t ob,
                 Junction& out) {
  const SiteMetric& m = b.index.metric();
  auto f = [&](double t) {
    Vec2 p;
    if (!m.domain_edge_point(edge, t, side, p)) return std::numeric_limits<double>::quiet_NaN();
    return cost_gap(b, oa, ob, p);
  };
  const double f0 = f(t0), f1 = f(t1);
  if (!std::isfinite(f0) || !std::isfinite(f1) || (f0 <= 0.0) == (f1 <= 0.0)) return false;
  Vec2 p;
  if (!m.domain_edge_point(edge, root_in(f, t0, t1 - t0, f0, f1, b.ftol), side, p)) return false;
  OwnerIndex::Hit ha, hb;
  // (Not where either owner's own seed is: coasts that are seeds meet at land borders, where the
  // lines of the cells end.)
  if (!on_pair_locus(b, oa, ob, p, ha, hb) || !(ha.distance > 0.0) || !(hb.distance > 0.0)) return false;
  out.p = p;
  out.lo = std::min(oa, ob);
  out.hi = std::max(oa, ob);
  out.v = oa < ob ? vertex_between(p, ha, hb) : vertex_between(p, hb, ha);
  out.v.on_barrier = true;
  Vec2 e0, e1;
  if (!m.domain_edge_ends(edge, e0, e1)) return false;
  out.into = Vec2{-(e1.y - e0.y), e1.x - e0.x};
  if (out.into.x * (side.x - e0.x) + out.into.y * (side.y - e0.y) < 0.0) out.into = Vec2{-out.into.x, -out.into.y};
  return true;
}

// Two solutions of one junction agree to far less than this many cells: each is solved to the root
// finder's tolerance on the same edge.
constexpr double kSame = 1e-4;

// Whether change c is explained by an end of a line of its two owners: on the barrier at it (the
// same point, found by another search of the same edge), or left in the open within two cells (a
// line the later stages could not carry; not drawn twice), or by a tripoint of both owners beside
// it.
bool explained(const BoundaryGrid& b, const std::vector<Tripoint>& tripoints, const std::vector<BoundaryLine>& lines,
               const CoastChange& c) {
  const double same = kSame * b.g.res, near = 2.0 * b.g.res;
  for (const BoundaryLine& l : lines) {
    if (l.owner_a != c.lo || l.owner_b != c.hi || l.vertices.empty()) continue;
    for (const BoundaryVertex* e : {&l.vertices.front(), &l.vertices.back()}) {
      const double d = std::hypot(e->p.x - c.p.x, e->p.y - c.p.y);
      if (d <= (e->on_barrier ? same : near)) return true;
    }
  }
  for (const Tripoint& t : tripoints) {
    const bool both = std::count(t.owners, t.owners + 3, c.lo) > 0 && std::count(t.owners, t.owners + 3, c.hi) > 0;
    if (both && std::hypot(t.p.x - c.p.x, t.p.y - c.p.y) <= near) return true;
  }
  return false;
}

// What one edge's walk hands the next along a coast: its second end and the owner there (on its
// one sea side), and the site nearest to the last position asked (owner_at's hint).
struct Carry {
  Vec2 end{std::numeric_limits<double>::quiet_NaN(), 0.0};
  int32_t owner = -1;  // -1: not known (the edge had two sea sides, or none)
  int32_t last = kNoSite;
};

// Whether the cells may not show the coast at p: p lies within a cell of the grid's edge (beyond
// the outermost centres, or in a dual square along them), or the corners of the dual square it
// lies in are all on land, or only two diagonal ones are at sea (a channel whose cells meet only
// diagonally), so no pair of cells beside p need place a line through it. (Elsewhere one corner
// at sea is the common case along a coast, its lines placed with the cells beyond it; two
// 4-neighbours at sea that land parts are not looked for: their lines are joined across
// (join_parted_ends), and a visibility test per sample would cost more than the rest of the
// walk.) Per task, the ground of each cell centre asked is kept: neighbouring samples along a
// coast share their corners.
class Hidden {
 public:
  explicit Hidden(const BoundaryGrid& b) : b_(b) {}
  bool operator()(Vec2 p) {
    const auto c = static_cast<int64_t>(std::floor((p.x - b_.g.xmin) / b_.g.res - 0.5));
    const auto r = static_cast<int64_t>(std::floor((b_.g.ymax - p.y) / b_.g.res - 0.5));
    // (Beyond the outermost centres or in the squares along them: a line from the coast there
    // may run out to the grid's edge past the cells without passing between two.)
    if (c <= 0 || r <= 0 || c + 1 >= b_.W - 1 || r + 1 >= b_.H - 1) return true;
    // The corners (c, r), (c + 1, r), (c + 1, r + 1), (c, r + 1).
    std::array<bool, 4> sea;
    for (int k = 0; k < 4; ++k) sea[static_cast<size_t>(k)] = at_sea(c + (k == 1 || k == 2), r + (k >= 2));
    const int n = static_cast<int>(std::count(sea.begin(), sea.end(), true));
    return n == 0 || (n == 2 && sea[0] == sea[2]);
  }

 private:
  bool at_sea(int64_t c, int64_t r) {
    const auto [it, added] = sea_.try_emplace(r * b_.W + c, false);
    if (added) it->second = b_.index.metric().in_domain(centre(b_.g, c, r));
    return it->second;
  }
  const BoundaryGrid& b_;
  std::unordered_map<int64_t, bool> sea_;
};

// Samples along an edge: its ends, and along an edge longer than two cells one every cell or so
// (a locus may meet it twice), at parameter t of its length.
int edge_pieces(const BoundaryGrid& b, Vec2 e0, Vec2 e1) {
  const double len = std::hypot(e1.x - e0.x, e1.y - e0.y);
  return len > 2.0 * b.g.res ? static_cast<int>(std::ceil(len / b.g.res)) : 1;
}

// The owners' changes along domain edge `edge` where the cells do not show its coast (see the
// contract), or along all of it where `whole`, appended to `out`, on each of its sides that is
// sea.
void junctions_on(const BoundaryGrid& b, double max_distance, int32_t edge, Vec2 e0, Vec2 e1, Hidden& hidden,
                  bool whole, Carry& carry, std::vector<Junction>& out) {
  const SiteMetric& m = b.index.metric();
  // A point off either side of the edge's chord (a polygon's edge has sea on one, a line's on
  // both).
  const Vec2 mid = lerp(e0, e1, 0.5), n{-(e1.y - e0.y), e1.x - e0.x};
  // (Not at the edge's ends themselves, as line_tools::onto_domain_edge: a point within a
  // micrometre of a vertex has no reliable direction towards it, and a search from a barrier's
  // vertex itself weighs every path along its edges.)
  constexpr double kEnd = 1e-6;
  const int pieces = edge_pieces(b, e0, e1);
  std::array<Vec2, 2> sea_sides;
  int n_sides = 0;
  for (const double s : {1.0, -1.0}) {
    const Vec2 side = off_chord(e0, e1, s);
    // (A short edge's land side is told at once by a point a thousandth of its length off its
    // middle, before the search along its normal that would fail there: along an edge of two
    // cells or less the chord and the geodesic part by far less.)
    if (pieces == 1 && !m.in_domain(Vec2{mid.x + 1e-3 * s * n.x, mid.y + 1e-3 * s * n.y})) continue;
    Vec2 p;
    if (m.domain_edge_point(edge, 0.5, side, p)) sea_sides[static_cast<size_t>(n_sides++)] = side;
  }
  // (A vertex's owner is the same either side of it but where a line meets the coast at the
  // vertex itself, within a micrometre: asked once where one coast's edges follow each other.)
  const bool carried = n_sides == 1 && carry.owner >= 0 && e0 == carry.end;
  int32_t end_owner = -1;
  struct Sample {
    double t;
    Vec2 p;  // on the edge, moved off it to the side walked
    bool in, hidden;
    int32_t owner;
  };
  std::vector<Sample> samples(static_cast<size_t>(pieces) + 1);
  for (int si = 0; si < n_sides; ++si) {
    const Vec2 side = sea_sides[static_cast<size_t>(si)];
    for (int k = 0; k <= pieces; ++k) {
      Sample& x = samples[static_cast<size_t>(k)];
      x.t = k == 0 ? kEnd : k == pieces ? 1.0 - kEnd : static_cast<double>(k) / pieces;
      x.in = m.domain_edge_point(edge, x.t, side, x.p) && inside_grid(b.g, x.p);
      x.hidden = x.in && (whole || hidden(x.p));
      x.owner = 0;
    }
    // Owners asked where the coast is hidden and at the samples beside such stretches (a change
    // of owner between a shown sample and a hidden one is found too).
    for (int k = 0; k <= pieces; ++k) {
      Sample& x = samples[static_cast<size_t>(k)];
      const bool near_hidden = x.hidden || (k > 0 && samples[static_cast<size_t>(k) - 1].hidden) ||
                               (k < pieces && samples[static_cast<size_t>(k) + 1].hidden);
      if (!x.in || !near_hidden) continue;
      // (Walked whole, it is asked again past the vertex too: where the owner changes within a
      // micrometre of the vertex the carried one is not this edge's, and would hide its change.)
      x.owner = k == 0 && carried && !whole ? carry.owner : owner_at(b, max_distance, x.p, carry.last);
      const Sample& w = samples[static_cast<size_t>(k > 0 ? k - 1 : 0)];
      Junction j;
      if (k > 0 && x.owner != 0 && w.owner != 0 && x.owner != w.owner &&
          junction_on(b, edge, side, w.t, x.t, w.owner, x.owner, j))
        out.push_back(j);
    }
    end_owner = samples.back().in && samples.back().owner != 0 ? samples.back().owner : -1;
  }
  carry.end = e1;
  carry.owner = n_sides == 1 ? end_owner : -1;
}

// A closed ring of domain edges: consecutive ids from `first` (an index into the edges near the
// grid), each edge starting where the one before ends, the last ending where the first starts;
// its edges' ends, the length along its chords up to each edge's first end (and the whole length
// last), and its bounds.
struct Ring {
  size_t first = 0;
  std::vector<Vec2> e0, e1;
  std::vector<double> from;
  line_tools::Bounds box;
};

// The closed rings among `edges` (every domain edge near the grid, in id order: a ring's edges
// are consecutive ids); a barrier line's chain, or a ring cut by the selection, is none.
std::vector<Ring> closed_rings(const SiteMetric& m, const std::vector<int32_t>& edges) {
  std::vector<Ring> rings;
  for (size_t first = 0; first < edges.size();) {
    Ring r;
    r.first = first;
    size_t last = first;
    for (; last < edges.size(); ++last) {
      Vec2 a, c;
      if (!m.domain_edge_ends(edges[last], a, c)) return rings;
      if (last > first && !(edges[last] == edges[last - 1] + 1 && a == r.e1.back())) break;
      r.e0.push_back(a);
      r.e1.push_back(c);
    }
    first = last;
    const size_t n = r.e0.size();
    if (n < 3 || !(r.e1.back() == r.e0.front())) continue;
    r.from.assign(n + 1, 0.0);
    for (size_t k = 0; k < n; ++k) {
      r.from[k + 1] = r.from[k] + std::hypot(r.e1[k].x - r.e0[k].x, r.e1[k].y - r.e0[k].y);
      r.box.add(r.e0[k]);
    }
    rings.push_back(std::move(r));
  }
  return rings;
}

// Whether two rings' edges cross or touch (their land overlaps or meets).
bool rings_meet(const Ring& r, const Ring& s) {
  for (size_t i = 0; i < r.e0.size(); ++i) {
    line_tools::Bounds ei;
    ei.add(r.e0[i]);
    ei.add(r.e1[i]);
    if (!ei.meets(s.box, 0.0)) continue;
    const Vec2 d{r.e1[i].x - r.e0[i].x, r.e1[i].y - r.e0[i].y};
    for (size_t k = 0; k < s.e0.size(); ++k) {
      const Vec2 e{s.e1[k].x - s.e0[k].x, s.e1[k].y - s.e0[k].y};
      double t, u;
      if (line_tools::lines_meet(r.e0[i], d, s.e0[k], e, t, u) && t >= 0.0 && t <= 1.0 && u >= 0.0 && u <= 1.0)
        return true;
    }
  }
  return false;
}

// Adds to `out` every edge of each ring inside the grid whose land meets that of a ring marked in
// `whole` (a stretch of it walked), and of the rings that meet those in turn. Why: where islands
// overlap (or states' land meets at a border) a ring's coast dips under the other's land, and the
// change of owner a stretch of it holds may lie on the other ring's coast, between where the first
// goes under and where it comes out; no line ends on that ring, so no stretch of it is walked.
void with_overlapping_rings(const GridSpec& g, const std::vector<Ring>& rings, const std::vector<int32_t>& edges,
                            std::vector<bool> whole, std::vector<int32_t>& out) {
  std::vector<size_t> queue;
  for (size_t ri = 0; ri < rings.size(); ++ri)
    if (whole[ri]) queue.push_back(ri);
  while (!queue.empty()) {
    const Ring& r = rings[queue.back()];
    queue.pop_back();
    for (size_t si = 0; si < rings.size(); ++si) {
      const Ring& s = rings[si];
      // (Every vertex strictly inside the grid: its bounds are.)
      const bool inside = s.box.x0 > g.xmin && s.box.x1 < g.xmax() && s.box.y0 > g.ymin() && s.box.y1 < g.ymax;
      if (whole[si] || !inside || !r.box.meets(s.box, 0.0) || !rings_meet(r, s)) continue;
      whole[si] = true;
      queue.push_back(si);
      for (size_t k = 0; k < s.e0.size(); ++k) out.push_back(edges[s.first + k]);
    }
  }
}

// The coasts between line ends whose owners disagree (see the contract): the ids of the edges
// of every stretch of a closed ring (`rings`, of `edges`), between two of its line ends next to
// each other along it, where the owner just past the first end is not the owner just before the
// second, sorted. Such a stretch holds a change of owner that no line ends at, wherever the cells
// lie: the locus may cross a channel narrower than a cell inside one dual square whose four
// corners are at sea.
std::vector<int32_t> disagreeing_stretches(const BoundaryGrid& b, double max_distance, const std::vector<Ring>& rings,
                                           const std::vector<int32_t>& edges, const std::vector<BoundaryLine>& lines) {
  const SiteMetric& m = b.index.metric();
  std::vector<bool> whole_ring(rings.size(), false);  // a stretch of it is walked
  std::vector<Vec2> ends;
  for (const BoundaryLine& l : lines)
    if (!l.closed && !l.vertices.empty())
      for (const BoundaryVertex* e : {&l.vertices.front(), &l.vertices.back()})
        if (e->on_barrier) ends.push_back(e->p);
  std::vector<int32_t> out;
  if (ends.empty()) return out;
  const GridSpec& g = b.g;
  // (An end lies on its edge's geodesic, which an edge of a few cells leaves by far less than a
  // hundredth of a cell; the nearest edge within that is the one it ends on.)
  const double on_edge = 1e-2 * g.res;
  struct At {
    double s;  // along the ring from its first vertex, in grid-CRS units along the chords
    size_t k;  // the edge's index in the ring
  };
  for (size_t ri = 0; ri < rings.size(); ++ri) {
    const Ring& r = rings[ri];
    const size_t n = r.e0.size();
    const double length = r.from[n];
    std::vector<At> at;
    for (const Vec2& p : ends) {
      line_tools::Bounds at_p;
      at_p.add(p);
      if (!r.box.meets(at_p, on_edge)) continue;
      double best = on_edge;
      At found{-1.0, 0};
      for (size_t k = 0; k < n; ++k) {
        const double d = line_tools::segment_distance(p, r.e0[k], r.e1[k]);
        if (d <= best) {
          best = d;
          found = At{r.from[k] + line_tools::nearest_t(r.e0[k], r.e1[k], p) * (r.from[k + 1] - r.from[k]), k};
        }
      }
      if (found.s >= 0.0) at.push_back(found);
    }
    if (at.empty()) continue;
    std::sort(at.begin(), at.end(), [](const At& x, const At& y) { return x.s < y.s; });
    // The point of ring edge k at t on its sea side (the first side found); false where neither is.
    auto sea_point = [&](size_t k, double t, Vec2& p) {
      for (const double side : {1.0, -1.0})
        if (m.domain_edge_point(edges[r.first + k], t, off_chord(r.e0[k], r.e1[k], side), p)) return true;
      return false;
    };
    // The owner at s along the ring, on its sea side; 0 where that is not known (outside the grid,
    // no sea side, or no owner).
    int32_t last_site = kNoSite;
    auto owner_along = [&](double s) {
      s = std::fmod(s + length, length);
      const size_t k = std::min<size_t>(
          n - 1, static_cast<size_t>(std::upper_bound(r.from.begin(), r.from.end(), s) - r.from.begin()) - 1);
      const double t = std::clamp((s - r.from[k]) / std::max(r.from[k + 1] - r.from[k], 1e-300), 0.0, 1.0);
      Vec2 p;
      return sea_point(k, t, p) && inside_grid(g, p) ? owner_at(b, max_distance, p, last_site) : 0;
    };
    for (size_t i = 0; i < at.size(); ++i) {
      const At& x = at[i];
      const At& y = at[(i + 1) % at.size()];
      const double gap = at.size() == 1 ? length : std::fmod(y.s - x.s + length, length);
      // (Two ends at one point: a line through a vertex, or two tripoints' lines.)
      if (!(gap > 1e-6 * g.res)) continue;
      const double d = std::min(1e-3 * g.res, 0.25 * gap);
      const int32_t after = owner_along(x.s + d), before = owner_along(x.s + gap - d);
      if (after == 0 || before == 0 || after == before) continue;
      // (From the first end's edge to the second's; round the whole ring where the second lies
      // on the same edge behind the first.)
      const size_t count = y.k == x.k && (at.size() == 1 || y.s < x.s) ? n : (y.k + n - x.k) % n + 1;
      // (Not a stretch that leaves the grid: its change may be a line's end on the frame, and a
      // mainland's coast clipped to the grid runs for hundreds of cells.)
      bool within = true;
      for (size_t c = 1; c < count && within; ++c) within = inside_grid(g, r.e0[(x.k + c) % n]);
      if (!within) continue;
      for (size_t c = 0; c < count; ++c) out.push_back(edges[r.first + (x.k + c) % n]);
      whole_ring[ri] = true;
    }
  }
  with_overlapping_rings(g, rings, edges, whole_ring, out);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

// Where the locus of junction j's two owners meets the grid's edge beside it, for a junction
// within a cell of the edge that no other pairs: on the nearest side of the grid's outline,
// within a cell and a half of j's foot on it, the point where the owners' costs
// are equal, no third owner nearer and the way from j open; of several, the nearest. False
// where there is none.
bool to_grid_edge(const BoundaryGrid& b, const Junction& j, BoundaryVertex& out) {
  const GridSpec& g = b.g;
  const double gaps[4] = {j.p.x - g.xmin, g.xmax() - j.p.x, g.ymax - j.p.y, j.p.y - g.ymin()};
  const int side = static_cast<int>(std::min_element(gaps, gaps + 4) - gaps);
  if (!(gaps[side] <= g.res)) return false;
  const bool vertical = side < 2;
  const Vec2 foot = side == 0   ? Vec2{g.xmin, j.p.y}
                    : side == 1 ? Vec2{g.xmax(), j.p.y}
                    : side == 2 ? Vec2{j.p.x, g.ymax}
                                : Vec2{j.p.x, g.ymin()};
  const Vec2 along = vertical ? Vec2{0.0, 1.5 * g.res} : Vec2{1.5 * g.res, 0.0};
  auto clamp = [&](Vec2 p) { return Vec2{std::clamp(p.x, g.xmin, g.xmax()), std::clamp(p.y, g.ymin(), g.ymax)}; };
  const Vec2 p0 = clamp(Vec2{foot.x - along.x, foot.y - along.y}), p1 = clamp(Vec2{foot.x + along.x, foot.y + along.y});
  auto f = [&](Vec2 p) { return cost_gap(b, j.lo, j.hi, p); };
  auto accept = [&](Vec2 e) {
    OwnerIndex::Hit ha, hb;
    return no_third_between(b, j.lo, j.hi, e, ha, hb) && b.index.metric().open_between(j.p, e);
  };
  auto at = [&](double t, Vec2& p) {
    p = lerp(p0, p1, t);
    return true;
  };
  double best = std::numeric_limits<double>::infinity();
  Vec2 e;
  constexpr int kSamples = 12;
  if (!nearest_root_along(at, 0.0, 1.0, kSamples, f, b.ftol, j.p, accept, best, e)) return false;
  out = vertex_between(e, b.index.nearest_of(e, j.lo), b.index.nearest_of(e, j.hi));
  return true;
}

// Where the locus of junction j's owners leaves it into the sea: the point a hundredth of a cell
// from it where their costs are equal, over the half-turn towards j.into (bisected), in sight of
// it; false where there is none. (The locus may leave at any angle to the coast; a walk from the
// coast itself would take the costs' gradient across land.)
bool leaving(const BoundaryGrid& b, const Junction& j, Vec2& out) {
  const double r = 1e-2 * b.g.res, base = std::atan2(j.into.y, j.into.x);
  auto at = [&](double a) { return Vec2{j.p.x + r * std::cos(base + a), j.p.y + r * std::sin(base + a)}; };
  auto f = [&](double a) {
    const Vec2 q = at(a);
    return b.index.metric().in_domain(q) ? cost_gap(b, j.lo, j.hi, q) : std::numeric_limits<double>::quiet_NaN();
  };
  constexpr int kSamples = 32;
  const double half = 0.5 * std::numbers::pi;
  double a0 = -half, f0 = f(a0);
  for (int k = 1; k <= kSamples; ++k) {
    double a1 = -half + std::numbers::pi * k / kSamples;
    const double f1 = f(a1);
    if (std::isfinite(f0) && std::isfinite(f1) && (f0 <= 0.0) != (f1 <= 0.0)) {
      out = at(root_in(f, a0, a1 - a0, f0, f1, b.ftol));
      OwnerIndex::Hit ha, hb;
      if (b.index.metric().open_between(j.p, out) && no_third_between(b, j.lo, j.hi, out, ha, hb)) return true;
    }
    a0 = a1;
    f0 = f1;
  }
  return false;
}

// A walk's steps along the locus from a junction: an eighth of a cell, fewer in a sliver (as
// follow_open_ends' walks).
constexpr int kPerCell = 8;

// The locus walked from junction u to junction w of the same owners (narrow_level's walk, `per` as
// follow_open_ends'), into `points`: u's point, the points walked, w's point left out; false where
// the walk does not reach w within three times their distance.
bool walk_between(const BoundaryGrid& b, double per, const Junction& u, const Junction& w, std::vector<Vec2>& points) {
  Vec2 from;
  if (!leaving(b, u, from)) return false;
  const double step = b.g.res / kPerCell;
  const auto steps = static_cast<int64_t>(std::ceil(3.0 * std::hypot(w.p.x - u.p.x, w.p.y - u.p.y) / step)) + kPerCell;
  locus_follow::Followed f = locus_follow::follow_on(narrow_level(b, u.lo, u.hi, per), from,
                                                     Vec2{from.x - u.p.x, from.y - u.p.y}, step, steps, {w.p}, &u.p);
  if (f.stop != locus_follow::Stop::target || f.other != 0) return false;
  points.assign(1, u.p);
  points.insert(points.end(), f.points.begin(), f.points.end() - 1);
  return true;
}

// The junctions no pair or grid edge took (not `used`), each followed along the locus from it into
// the sea (see the contract); the lines drawn (or lengthened) with `add`, the junctions a walk
// reaches marked used.
template <class Add>
void follow_from_junctions(const BoundaryGrid& b, double per, const std::vector<Tripoint>& tripoints,
                           const std::vector<Junction>& open, std::vector<bool>& used, std::vector<BoundaryLine>& lines,
                           Add&& add) {
  constexpr int64_t kMaxSteps = 8192;
  auto open_end = [&](const BoundaryVertex& v) { return open_line_end(b, tripoints, v); };
  for (size_t i = 0; i < open.size(); ++i) {
    if (used[i]) continue;
    const Junction& j = open[i];
    Vec2 from;
    if (!leaving(b, j, from)) continue;
    // Where the walk may stop: the other junctions left of the same owners (their index), and the
    // open ends of those owners' lines (line n's front as -2 - 2n, its back as -3 - 2n).
    std::vector<Vec2> others;
    std::vector<int64_t> what;
    for (size_t k = 0; k < open.size(); ++k)
      if (k != i && !used[k] && open[k].lo == j.lo && open[k].hi == j.hi) {
        others.push_back(open[k].p);
        what.push_back(static_cast<int64_t>(k));
      }
    for (size_t n = 0; n < lines.size(); ++n) {
      const BoundaryLine& l = lines[n];
      if (l.closed || l.vertices.size() < 2 || l.owner_a != j.lo || l.owner_b != j.hi) continue;
      for (const int back : {0, 1})
        if (open_end(back ? l.vertices.back() : l.vertices.front())) {
          others.push_back(back ? l.vertices.back().p : l.vertices.front().p);
          what.push_back(-2 - 2 * static_cast<int64_t>(n) - back);
        }
    }
    locus_follow::Followed f =
        locus_follow::follow_on(narrow_level(b, j.lo, j.hi, per), from, Vec2{from.x - j.p.x, from.y - j.p.y},
                                b.g.res / kPerCell, kMaxSteps, others, &j.p);
    f.points.insert(f.points.begin(), j.p);
    const bool coast = f.stop == locus_follow::Stop::coast || f.stop == locus_follow::Stop::frame,
               target = f.stop == locus_follow::Stop::target;
    // (Not a walk along a line the cells showed: the junction is that line's other change,
    // misplaced, and its stretch is drawn.)
    if (f.points.size() < 2 || !(coast || target) || (target && f.other < 0) ||
        std::hypot(f.points.back().x - j.p.x, f.points.back().y - j.p.y) <= 1e-4 * b.g.res ||
        walk_runs_along(b, lines, f.points, j.lo, j.hi, -1))
      continue;
    used[i] = true;
    BoundaryLine line{j.lo, j.hi, false, {j.v}, {}};
    if (coast) {
      append_walked(b, line, f.points);
      line.vertices.back().on_barrier = f.stop == locus_follow::Stop::coast;
      add(std::move(line), -1);
      continue;
    }
    // Up to the point reached, which is its own vertex.
    append_walked(b, line, std::vector<Vec2>(f.points.begin(), f.points.end() - 1));
    const int64_t t = what[static_cast<size_t>(f.other)];
    if (t >= 0) {
      used[static_cast<size_t>(t)] = true;
      line.vertices.push_back(open[static_cast<size_t>(t)].v);
      add(std::move(line), -1);
      continue;
    }
    const auto n = static_cast<size_t>((-2 - t) / 2);
    const std::vector<BoundaryVertex>& o = lines[n].vertices;
    if ((-2 - t) % 2 == 0)
      line.vertices.insert(line.vertices.end(), o.begin(), o.end());
    else
      line.vertices.insert(line.vertices.end(), o.rbegin(), o.rend());
    add(std::move(line), static_cast<int64_t>(n));
  }
}

// One round of cross_hidden_channels (see the contract) over `edges`, every domain edge near the
// grid: the edges in `whole` (sorted) walked whole, and where `hidden_too` the coast the cells do
// not show on every other edge; the junctions found that no line explains joined, carried to the
// grid's edge or followed.
void channels_round(const BoundaryGrid& b, double max_distance, double per, const std::vector<Tripoint>& tripoints,
                    const std::vector<int32_t>& edges, const std::vector<int32_t>& whole, bool hidden_too,
                    std::vector<BoundaryLine>& lines, BoundaryStats& stats, std::vector<CoastChange>& left) {
  const SiteMetric& m = b.index.metric();
  // Only coast the cells do not show is walked (hidden, above): an edge with a sample there, by
  // its chord (an edge's samples on its geodesic are found only for the edges walked). Elsewhere
  // a line that meets the coast passes between sea cells, which place it (end_at_barriers), but
  // for the stretches between two line ends whose owners disagree, walked whole.
  auto walked_edge = [&](Vec2 e0, Vec2 e1, bool in_whole, Hidden& hidden) {
    // (Not an edge along the grid's outline: land clipped to the grid's extent has no sea there.)
    if ((e0.x == e1.x && (e0.x <= b.g.xmin || e0.x >= b.g.xmax())) ||
        (e0.y == e1.y && (e0.y <= b.g.ymin() || e0.y >= b.g.ymax)))
      return false;
    if (in_whole) return true;
    if (!hidden_too) return false;
    const int pieces = edge_pieces(b, e0, e1);
    for (int k = 0; k <= pieces; ++k)
      if (hidden(lerp(e0, e1, static_cast<double>(k) / pieces))) return true;
    return false;
  };
  // The edges in runs of consecutive ids (a ring's edges follow each other: the hint carries along
  // the coast), walked in parallel; the junctions in the edges' order, whatever the threads.
  constexpr size_t kRun = 32;
  const size_t runs = (edges.size() + kRun - 1) / kRun;
  std::vector<std::vector<Junction>> found(runs);
  detail::parallel_for(b.threads, static_cast<int64_t>(runs), [&](int64_t r, int) {
    Carry carry;
    Hidden hidden(b);
    for (size_t k = static_cast<size_t>(r) * kRun; k < std::min(edges.size(), (static_cast<size_t>(r) + 1) * kRun);
         ++k) {
      Vec2 e0, e1;
      const bool in_whole = std::binary_search(whole.begin(), whole.end(), edges[k]);
      if (!m.domain_edge_ends(edges[k], e0, e1) || e0 == e1 || !walked_edge(e0, e1, in_whole, hidden)) {
        carry.owner = -1;
        continue;
      }
      junctions_on(b, max_distance, edges[k], e0, e1, hidden, in_whole, carry, found[static_cast<size_t>(r)]);
    }
  });
  std::vector<Junction> all;
  for (std::vector<Junction>& f : found) all.insert(all.end(), f.begin(), f.end());
  if (all.empty()) return;
  const double same = kSame * b.g.res;
  std::vector<Junction> open;
  for (const Junction& j : all)
    if (!explained(b, tripoints, lines, CoastChange{j.p, j.lo, j.hi})) open.push_back(j);
  // Pairs across a channel: the same two owners, within four cells, the way between them open and
  // the locus along it (the owners' costs at its middle nearly equal, against the chord's length).
  std::vector<NearPair> pairs;
  for (size_t i = 0; i < open.size(); ++i)
    for (size_t k = i + 1; k < open.size(); ++k) {
      const Junction &u = open[i], &w = open[k];
      if (u.lo != w.lo || u.hi != w.hi) continue;
      const double d = std::hypot(w.p.x - u.p.x, w.p.y - u.p.y);
      if (!(d > same && d <= 4.0 * b.g.res) || !m.open_between(u.p, w.p)) continue;
      if (std::abs(cost_gap(b, u.lo, u.hi, lerp(u.p, w.p, 0.5))) <= 0.25 * m.point_distance(u.p, w.p))
        pairs.push_back(NearPair{d, i, k});
    }
  sort_nearest_first(pairs);
  std::vector<bool> used(open.size(), false);
  // A line drawn: new, or in place of line `in_place` (>= 0), which it lengthens.
  auto add = [&](BoundaryLine&& line, int64_t in_place) {
    for (const BoundaryVertex& v : line.vertices) stats.max_residual = std::max(stats.max_residual, v.residual);
    stats.vertices += static_cast<int64_t>(line.vertices.size()) -
                      (in_place >= 0 ? static_cast<int64_t>(lines[static_cast<size_t>(in_place)].vertices.size()) : 0);
    if (in_place >= 0)
      lines[static_cast<size_t>(in_place)] = std::move(line);
    else
      lines.push_back(std::move(line));
    ++stats.channels_crossed;
  };
  // (A line of two vertices from junction i to `to`.)
  auto add_line = [&](size_t i, const BoundaryVertex& to) {
    used[i] = true;
    add(BoundaryLine{open[i].lo, open[i].hi, false, {open[i].v, to}, {}}, -1);
  };
  for (const NearPair& pr : pairs) {
    if (used[pr.i] || used[pr.j]) continue;
    if (pr.d <= b.g.res) {
      used[pr.j] = true;
      add_line(pr.i, open[pr.j].v);
      continue;
    }
    // (A chord longer than a cell may cut past an islet the locus goes round, off it by more than
    // the refinement can mend: the pair's line is walked along the locus, and left to the walks
    // below where it does not reach the other junction.)
    std::vector<Vec2> walked;
    if (!walk_between(b, per, open[pr.i], open[pr.j], walked)) continue;
    used[pr.i] = used[pr.j] = true;
    BoundaryLine line{open[pr.i].lo, open[pr.i].hi, false, {open[pr.i].v}, {}};
    append_walked(b, line, walked);
    line.vertices.push_back(open[pr.j].v);
    add(std::move(line), -1);
  }
  // A junction left within a cell of the grid's edge: its line runs out to the edge (past the
  // outermost cells without passing between two; region_edges carries the lines that end on the
  // frame of centres to the edge the same way).
  for (size_t i = 0; i < open.size(); ++i) {
    BoundaryVertex e;
    if (!used[i] && to_grid_edge(b, open[i], e)) add_line(i, e);
  }
  follow_from_junctions(b, per, tripoints, open, used, lines, add);
  for (size_t i = 0; i < open.size(); ++i)
    if (!used[i]) left.push_back(CoastChange{open[i].p, open[i].lo, open[i].hi});
}

}  // namespace

void cross_hidden_channels(const BoundaryGrid& b, double max_distance, double per,
                           const std::vector<Tripoint>& tripoints, std::vector<BoundaryLine>& lines,
                           BoundaryStats& stats, std::vector<CoastChange>& left) {
  const SiteMetric& m = b.index.metric();
  if (m.straight()) return;
  // Every domain edge that may come within the grid.
  std::vector<int32_t> edges;
  const Vec2 middle{b.g.xmin + 0.5 * static_cast<double>(b.W) * b.g.res,
                    b.g.ymax - 0.5 * static_cast<double>(b.H) * b.g.res};
  m.domain_edges_near(middle, std::hypot(static_cast<double>(b.W), static_cast<double>(b.H)) * b.g.res, edges);
  if (edges.empty()) return;
  // A line a round draws from a coast to an island ends there, and that island's other change of
  // owner may be hidden in turn: a chain of islands inside cells, one more each round. An edge is
  // walked whole once; a stretch that still disagrees after that is left as it is.
  constexpr int kRounds = 16;
  const std::vector<Ring> rings = closed_rings(m, edges);
  std::vector<int32_t> walked, fresh, both;
  for (int round = 0; round < kRounds; ++round) {
    const std::vector<int32_t> whole = disagreeing_stretches(b, max_distance, rings, edges, lines);
    fresh.clear();
    std::set_difference(whole.begin(), whole.end(), walked.begin(), walked.end(), std::back_inserter(fresh));
    if (round > 0 && fresh.empty()) break;
    channels_round(b, max_distance, per, tripoints, edges, fresh, round == 0, lines, stats, left);
    both.clear();
    std::set_union(walked.begin(), walked.end(), fresh.begin(), fresh.end(), std::back_inserter(both));
    walked.swap(both);
  }
}

int64_t unexplained_changes(const BoundaryGrid& b, const std::vector<Tripoint>& tripoints,
                            const std::vector<BoundaryLine>& lines, const std::vector<CoastChange>& left) {
  const double same = kSame * b.g.res;
  int64_t n = 0;
  for (size_t i = 0; i < left.size(); ++i) {
    const CoastChange& c = left[i];
    // (Found again by a later round, on an edge it walked whole: counted once.)
    const bool again =
        std::any_of(left.begin(), left.begin() + static_cast<std::ptrdiff_t>(i), [&](const CoastChange& o) {
          return o.lo == c.lo && o.hi == c.hi && std::hypot(o.p.x - c.p.x, o.p.y - c.p.y) <= same;
        });
    if (!again && !explained(b, tripoints, lines, c)) ++n;
  }
  return n;
}

}  // namespace rv::boundary_stages
