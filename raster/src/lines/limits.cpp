// Distance-limit lines (extract_limits, rv/lines/limits.hpp) as a pipeline of stages: which cells
// lie inside the limit, the crossings on the edges between inside and outside, links per square,
// chains of links into lines.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <numeric>
#include <set>
#include <unordered_map>
#include <vector>

#include "lines/limit_stages.hpp"
#include "lines/line_pieces.hpp"
#include "lines/line_tools.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/simplify.hpp"

namespace rv {
namespace limit_stages {

using namespace line_tools;  // the deliverables' own toolkit (line_tools.hpp)

// ---------------------------------------------------------------------------------------------
// Distance-limit lines.

namespace {

// ---- Stage 1: inside -------------------------------------------------------------------------
// Inside (d <= D) per cell. The Float32 field decides clear cases; cells within float rounding
// of D, and (per owner) cells of other owners within reach, are measured exactly (with weights,
// every cell the field cannot put inside: its distance is then not the nearest's). Per owner
// (with weights, for all seeds too),
// blocks of kBlock x kBlock cells are first settled as a whole where the distance at the
// block's centre is farther from D than the block's radius (distance is 1-Lipschitz), so exact
// queries are only spent near the line.
constexpr int64_t kBlock = 8;

// -1: decide per cell; 0: the whole block is outside; 1: inside.
int settle_block(const Target& t, int64_t c0, int64_t r0, int64_t c1, int64_t r1) {
  if (t.owner == 0 && t.grid.field_is_nearest) return -1;
  // (By sea a distance changes by more than the way between two points a barrier parts: a
  // block's middle bounds nothing beyond it.)
  if (!t.grid.metric.straight()) return -1;
  const LimitGrid& lg = t.grid;
  const Vec2 a = centre(lg.g, c0, r0), b = centre(lg.g, c1 - 1, r1 - 1);
  const Vec2 mid{0.5 * (a.x + b.x), 0.5 * (a.y + b.y)};
  double radius = 0.0;
  for (const Vec2 q : {a, b, Vec2{a.x, b.y}, Vec2{b.x, a.y}})
    radius = std::max(radius, lg.metric.point_distance(mid, q));
  // Corners bound a small block's extent exactly in the plane; 1 % covers the curvature of a
  // longitude/latitude block.
  radius = radius * 1.01 + 1e-6 * lg.cell;
  const double v = t.at(mid).distance;
  if (v - radius > t.D) return 0;
  if (v + radius < t.D) return 1;
  return -1;
}

// `d`: the field's (Float32) distance of cell (c, r), whose site is s.
bool cell_inside(const Target& t, int64_t c, int64_t r, int32_t s, double d) {
  const LimitGrid& lg = t.grid;
  const bool own = t.owner == 0 || lg.owner_of_site[static_cast<size_t>(s)] == t.owner;
  const double slack = 1e-6 * (t.D + lg.cell);
  if (own && d < t.D - slack) return true;  // the owner's nearest is no farther than this site
  if (lg.field_is_nearest) {
    if (own && d > t.D + slack) return false;
    if (!own && d > t.D + slack) return false;  // d_owner >= d > D
  }
  return t.reached(centre(lg.g, c, r));
}

}  // namespace

void InsideRows::drop_before(int64_t r) {
  r = std::clamp(r, row0, row1());
  flags.erase(flags.begin(), flags.begin() + static_cast<std::ptrdiff_t>((r - row0) * width));
  row0 = r;
}

namespace {

// Whether the 9 flags a[0..8] are all equal, and equal to b[0..7] (each may be null: not
// compared): 8 cells at a time where nothing changes, which is nearly everywhere.
inline bool flat8(const uint8_t* a, const uint8_t* b) {
  uint64_t x, z;
  std::memcpy(&x, a, 8);
  std::memcpy(&z, a + 1, 8);
  if (x != z) return false;
  if (b == nullptr) return true;
  uint64_t y;
  std::memcpy(&y, b, 8);
  return x == y;
}

}  // namespace

void inside_flags(const Target& t, int64_t row0, int64_t row1, InsideRows& inside) {
  const LimitGrid& lg = t.grid;
  if (inside.flags.empty()) {
    inside.width = lg.W;
    inside.row0 = row0;
  }
  if (inside.row1() != row0 || row1 < row0)
    throw Error(ErrorKind::invalid_argument, "inside flags are appended in row order");
  const size_t base = inside.flags.size();
  inside.flags.resize(base + static_cast<size_t>((row1 - row0) * lg.W));
  uint8_t* out = inside.flags.data() + base;
  if (t.owner == kOwnedEdge) {
    // The owned area is the field's: the engine decided each cell on the same reaches.
    detail::parallel_for(lg.threads, row1 - row0, [&](int64_t k, int) {
      const int32_t* site = lg.rows.site_row(row0 + k);
      uint8_t* o = out + k * lg.W;
      for (int64_t c = 0; c < lg.W; ++c) o[c] = site[c] != kNoSite ? 1 : 0;
    });
    return;
  }
  if (t.owner == 0 && lg.field_is_nearest) {
    // Every cell's distance is the target's: the Float32 field decides all but the cells within
    // its rounding of D, in a pass with no branch per cell, and those few are measured after.
    const double eps = 1e-6 * (t.D + lg.cell);
    detail::parallel_for(lg.threads, row1 - row0, [&](int64_t k, int) {
      const int64_t r = row0 + k, width = lg.W;
      const int32_t* site = lg.rows.site_row(r);
      const float* dist = lg.rows.distance_row(r);
      uint8_t* o = out + k * width;
      // Locals: the flags' bytes may alias anything, which would reload every operand per cell.
      const double level = t.D, lo = t.D - eps, hi = t.D + eps;
      int near = 0;
      for (int64_t c = 0; c < width; ++c) {
        const double d = dist[c];
        const int has = site[c] != kNoSite;
        o[c] = static_cast<uint8_t>(has & (d <= level));
        near |= has & (d >= lo) & (d <= hi);
      }
      if (near == 0) return;
      for (int64_t c = 0; c < lg.W; ++c)
        if (site[c] != kNoSite && std::abs(static_cast<double>(dist[c]) - t.D) <= eps)
          o[c] = cell_inside(t, c, r, site[c], dist[c]) ? 1 : 0;
    });
    return;
  }
  const int64_t bw = (lg.W + kBlock - 1) / kBlock, b0 = row0 / kBlock, b1 = (row1 + kBlock - 1) / kBlock;
  detail::parallel_for(lg.threads, b1 - b0, [&](int64_t k, int) {
    const int64_t br = b0 + k;
    for (int64_t bc = 0; bc < bw; ++bc) {
      // Blocks stay aligned to the grid; a strip clips them to its rows.
      const int64_t c0 = bc * kBlock, r0 = std::max(br * kBlock, row0);
      const int64_t c1 = std::min(lg.W, c0 + kBlock), r1 = std::min({lg.H, br * kBlock + kBlock, row1});
      const int settled = settle_block(t, c0, r0, c1, r1);
      for (int64_t r = r0; r < r1; ++r) {
        const int32_t* site = lg.rows.site_row(r);
        const float* dist = lg.rows.distance_row(r);
        uint8_t* o = out + (r - row0) * lg.W;
        for (int64_t c = c0; c < c1; ++c) {
          const int32_t s = site[c];
          // No site: beyond the field's max distance, outside every limit.
          const bool in = s != kNoSite && (settled >= 0 ? settled == 1 : cell_inside(t, c, r, s, dist[c]));
          o[c] = in ? 1 : 0;
        }
      }
    }
  });
}

// ---- Stage 2: crossings ----------------------------------------------------------------------
// Every edge between an inside and an outside cell, its vertex placed at distance D.

LimitCrossings limit_crossings(const Target& t, const InsideRows& inside, int64_t row0, int64_t row1,
                               const LimitVertexFromBase* from_base) {
  const LimitGrid& lg = t.grid;
  const int64_t W = lg.W, H = lg.H;
  LimitCrossings x;
  x.edges = scan_rows<int64_t>(lg.threads, row0, row1, [&](int64_t r, std::vector<int64_t>& edges) {
    const uint8_t* a = inside.row(r);
    const uint8_t* b = r + 1 < H ? inside.row(r + 1) : nullptr;
    for (int64_t c = 0; c < W; ++c) {
      if (c + 9 <= W && flat8(a + c, b == nullptr ? nullptr : b + c)) {
        c += 7;  // cells c .. c + 7: no edge changes
        continue;
      }
      if (c + 1 < W && a[c] != a[c + 1]) edges.push_back(edge_right(W, c, r));
      if (b != nullptr && a[c] != b[c]) edges.push_back(edge_down(W, c, r));
    }
  });
  x.verts.resize(x.edges.size());
  const int64_t chunk = 256;
  detail::parallel_for(lg.threads, (static_cast<int64_t>(x.edges.size()) + chunk - 1) / chunk, [&](int64_t k, int) {
    const size_t end = std::min(x.edges.size(), static_cast<size_t>((k + 1) * chunk));
    std::vector<int32_t> cands;
    for (size_t i = static_cast<size_t>(k * chunk); i < end; ++i) {
      if (from_base != nullptr && (*from_base)(x.edges[i], x.verts[i])) continue;
      const int64_t id = x.edges[i] / 2;
      const int64_t c = id % W, r = id / W;
      const Vec2 p0 = centre(lg.g, c, r);
      const Vec2 p1 = (x.edges[i] % 2 == 0) ? centre(lg.g, c + 1, r) : centre(lg.g, c, r + 1);
      // (By sea: a cell beside land is inside while land is not; no level crosses between them.)
      if (!lg.metric.open_between(p0, p1)) {
        x.verts[i].residual = std::numeric_limits<double>::quiet_NaN();
        continue;
      }
      if (t.owner == kOwnedEdge) {
        // The edge of the owned area is rare (a few cells per reach's arc): each query searches
        // the whole index, and the root of d - reach is bracketed (Illinois) from the two ends.
        auto f = [&](double u) { return t.at(lerp(p0, p1, u)).distance; };
        const Vec2 p = lerp(p0, p1, find_root(f, f(0.0), f(1.0), lg.ftol, 1e-15));
        const OwnerIndex::Hit h = t.at(p);
        x.verts[i] = LimitVertex{p, h.site, std::abs(h.distance)};
        continue;
      }
      // Every query is on the edge: the sites that can be nearest anywhere on it are gathered
      // once (OwnerIndex::candidates_of, candidates_not_of; a ball around its middle holding the
      // edge: edge_reach), bounded by the inside cell's site, and each query measures only
      // those: the same hits as Target::at.
      const int64_t ci = (x.edges[i] % 2 == 0) ? c + 1 : c, ri = (x.edges[i] % 2 == 0) ? r : r + 1;
      const int32_t hint = inside.at(c, r) ? lg.rows.site(c, r) : lg.rows.site(ci, ri);
      const Vec2 mid = lerp(p0, p1, 0.5);
      const double reach = edge_reach(lg.metric, mid, p0, p1);
      // The nearest distance at the middle is bounded without measuring by the inside cell's
      // field distance (Float32, relative rounding below 1e-7) plus the way from there, when that
      // cell's site is the target's.
      const float inside_distance = inside.at(c, r) ? lg.rows.distance(c, r) : lg.rows.distance(ci, ri);
      const bool own = hint != kNoSite && (t.owner == 0 || lg.owner_of_site[static_cast<size_t>(hint)] == t.owner);
      const double at_most = own ? nearest_at_most(inside_distance, reach) : std::numeric_limits<double>::infinity();
      if (t.owner != 0)
        lg.index.candidates_of(mid, reach, t.owner, hint, cands, at_most);
      else
        lg.index.candidates_not_of(mid, reach, 0, OwnerIndex::Hit{}, cands, at_most);
      // The root is usually the last position measured: its hit is kept, not measured again.
      Vec2 last{std::numeric_limits<double>::quiet_NaN(), 0.0};
      OwnerIndex::Hit last_hit;
      Vec2 gradient;
      auto hit = [&](Vec2 p) {
        if (!(p.x == last.x && p.y == last.y)) {
          last = p;
          last_hit = lg.index.nearest_among(p, cands, &gradient);
        }
        return last_hit;
      };
      auto f = [&](double u) { return hit(lerp(p0, p1, u)).distance - t.D; };
      auto with_slope = [&](double u) {
        const double v = f(u);
        return std::pair{v, gradient.x * (p1.x - p0.x) + gradient.y * (p1.y - p0.y)};
      };
      // Newton's steps with the nearest site's gradient, from where the field's distances put the
      // level (when both cells' distances are the target's: all seeds, or cells of its owner);
      // where they fail, the Illinois method on what is left of the bracket.
      const bool in0 = inside.at(c, r) != 0;
      double start = 0.5;
      const int32_t s0 = lg.rows.site(c, r), s1 = lg.rows.site(ci, ri);
      if (s0 != kNoSite && s1 != kNoSite &&
          (t.owner == 0 || (lg.owner_of_site[static_cast<size_t>(s0)] == t.owner &&
                            lg.owner_of_site[static_cast<size_t>(s1)] == t.owner))) {
        const double d0 = lg.rows.distance(c, r), d1 = lg.rows.distance(ci, ri);
        if (d1 != d0) start = std::clamp((t.D - d0) / (d1 - d0), 0.02, 0.98);
      }
      const double u = newton_then_bracket(f, with_slope, start, 0.0, 1.0, in0, lg.ftol);
      const Vec2 p = lerp(p0, p1, u);
      const auto h = hit(p);
      x.verts[i] = LimitVertex{p, h.site, std::abs(h.distance - t.D)};
    }
  });
  // The edges marked closed above left out.
  size_t kept = 0;
  for (size_t i = 0; i < x.edges.size(); ++i) {
    if (std::isnan(x.verts[i].residual)) continue;
    x.edges[kept] = x.edges[i];
    x.verts[kept] = x.verts[i];
    ++kept;
  }
  x.edges.resize(kept);
  x.verts.resize(kept);
  x.at.reserve(x.edges.size() * 2);
  for (size_t i = 0; i < x.edges.size(); ++i) x.at.emplace(x.edges[i], static_cast<int32_t>(i));
  return x;
}

void append(LimitCrossings& x, LimitCrossings&& part) {
  const auto base = static_cast<int32_t>(x.edges.size());
  for (size_t i = 0; i < part.edges.size(); ++i) x.at.emplace(part.edges[i], base + static_cast<int32_t>(i));
  x.edges.insert(x.edges.end(), part.edges.begin(), part.edges.end());
  x.verts.insert(x.verts.end(), part.verts.begin(), part.verts.end());
}

// ---- Stage 3: links --------------------------------------------------------------------------
// Per dual square, its two crossings joined; a saddle's four by the side of its centre.

std::vector<std::array<int32_t, 2>> limit_links(const Target& t, const InsideRows& inside, const LimitCrossings& x,
                                                int64_t row0, int64_t row1) {
  const LimitGrid& lg = t.grid;
  const int64_t W = lg.W, H = lg.H;
  using Link = std::array<int32_t, 2>;
  return scan_rows<Link>(lg.threads, row0, std::min(row1, H - 1), [&](int64_t r, std::vector<Link>& links) {
    const uint8_t* a = inside.row(r);
    const uint8_t* b = inside.row(r + 1);
    for (int64_t c = 0; c + 1 < W; ++c) {
      // Squares c .. c + 7 read cells c .. c + 8 of both rows.
      if (c + 9 <= W && flat8(a + c, b + c) && flat8(b + c, nullptr)) {
        c += 7;
        continue;
      }
      const std::array<bool, 4> in{a[c] != 0, a[c + 1] != 0, b[c + 1] != 0, b[c] != 0};
      if (in[0] == in[1] && in[1] == in[2] && in[2] == in[3]) continue;
      const auto sq = square_edges(W, c, r);
      std::array<int32_t, 4> n;
      std::vector<int> present;
      for (int k = 0; k < 4; ++k) {
        const auto it = x.at.find(sq[static_cast<size_t>(k)]);
        n[static_cast<size_t>(k)] = it == x.at.end() ? -1 : it->second;
        if (it != x.at.end()) present.push_back(k);
      }
      // (By sea an edge a barrier crosses has no crossing: the line ends in the square, to be
      // carried onto the barrier; a pair is linked only where both its crossings are there.)
      auto link = [&](int k1, int k2) {
        if (n[static_cast<size_t>(k1)] >= 0 && n[static_cast<size_t>(k2)] >= 0)
          links.push_back({n[static_cast<size_t>(k1)], n[static_cast<size_t>(k2)]});
      };
      const bool saddle = in[0] == in[2] && in[1] == in[3];
      if (!saddle) {
        if (present.size() == 2) link(present[0], present[1]);
      } else if (!present.empty()) {
        // Saddle: the centre's side decides which diagonal pair of corners is connected.
        const bool centre_in = t.at(square_mid(lg.g, c, r)).distance <= t.D;
        if (centre_in == in[0]) {  // corners 0 and 2 connected: cut off 1 and 3
          link(0, 1);
          link(2, 3);
        } else {
          link(3, 0);
          link(1, 2);
        }
      }
    }
  });
}

// ---- Stage 4: chains -------------------------------------------------------------------------

namespace {

// The level's junction with a barrier edge near the back end of `v` (by sea), appended; for a
// line of one crossing whose front end went onto a barrier already, on the far side from that.
bool level_onto_barrier(const Target& t, std::vector<LimitVertex>& v) {
  const LimitGrid& lg = t.grid;
  auto f = [&](Vec2 p) { return t.at(p).distance - t.D; };
  auto accept = [&](Vec2 p) { return std::abs(f(p)) <= 1e3 * lg.ftol; };
  Vec2 j;
  const bool lone = v.size() == 2 && v.front().on_barrier && !v.back().on_barrier;
  // (A plain index's nearest distance, and the depth within reach, are 1-Lipschitz along an open
  // way; an adjusted one's true distance of the cheapest site is not.)
  const double slope = t.owner == kOwnedEdge || !lg.index.adjusted() ? 1.0 : std::numeric_limits<double>::infinity();
  if (!onto_domain_edge(lg.metric, v.back().p, 4.0 * lg.g.res, lg.ftol, f, accept, j, lone ? &v.front().p : nullptr,
                        slope))
    return false;
  const OwnerIndex::Hit h = t.at(j);
  v.push_back(LimitVertex{j, h.site, std::abs(h.distance - t.D), true});
  return true;
}

}  // namespace

void chain_limit_lines(const Target& t, const LimitCrossings& x, const std::vector<std::array<int32_t, 2>>& links,
                       double tol, LimitResult& result, const LimitRefiner* refiner,
                       const SegmentReuse<LimitVertex, LimitRefiner::Measured>* reuse, LimitMemo* record) {
  Chains chains = chain_links(static_cast<int32_t>(x.verts.size()), links, std::vector<bool>(x.verts.size(), false));
  // By sea a crossing can be linked to none: the level crosses a channel narrower than the
  // squares around it (a barrier parts every other pair of its corners). It is a line of its own,
  // from one barrier to another.
  if (!t.grid.metric.straight()) {
    std::vector<bool> linked(x.verts.size(), false);
    for (const auto& l : links) linked[static_cast<size_t>(l[0])] = linked[static_cast<size_t>(l[1])] = true;
    for (size_t n = 0; n < linked.size(); ++n)
      if (!linked[n]) {
        chains.node_lists.push_back({static_cast<int32_t>(n)});
        chains.closed.push_back(false);
        chains.first_link.push_back(-1);
      }
  }
  std::vector<std::vector<LimitVertex>> verts(chains.node_lists.size());
  for (size_t k = 0; k < verts.size(); ++k)
    for (int32_t n : chains.node_lists[k]) verts[k].push_back(x.verts[static_cast<size_t>(n)]);
  // By sea: an open line's end short of a barrier carried onto it, before the lines are refined.
  for (size_t k = 0; k < verts.size(); ++k) {
    if (chains.closed[k] || verts[k].empty()) continue;
    for (int end = 0; end < 2; ++end) {
      std::vector<LimitVertex>& v = verts[k];
      if (end == 1) std::reverse(v.begin(), v.end());
      if (!on_centre_frame(t.grid.g, v.back().p) && level_onto_barrier(t, v)) ++result.ends_on_barriers;
      if (end == 1) std::reverse(v.begin(), v.end());
    }
  }
  // Refined over blocks of segments of every chain at once (one limit line may be most of the
  // work); each segment on its own, so the result does not depend on the threads.
  if (refiner != nullptr) {
    constexpr size_t kBlock = 256;
    struct Block {
      size_t chain, i0, i1;
      std::vector<LimitVertex> out;
      LimitRefiner::Measured measured;
      std::vector<LimitMemo::Entry> kept;  // with `record`: its segments
      int64_t taken = 0;                   // of which taken from `reuse`
    };
    std::vector<Block> blocks;
    for (size_t k = 0; k < verts.size(); ++k)
      for (size_t i = 0; i + 1 < verts[k].size(); i += kBlock)
        blocks.push_back(Block{k, i, std::min(i + kBlock, verts[k].size() - 1), {}, {}, {}, 0});
    detail::parallel_for(t.grid.threads, static_cast<int64_t>(blocks.size()), [&](int64_t k, int) {
      Block& b = blocks[static_cast<size_t>(k)];
      const std::vector<LimitVertex>& v = verts[b.chain];
      if (reuse == nullptr && record == nullptr) {
        refiner->refine_segments(v, b.i0, b.i1, b.out, b.measured.residual, b.measured.corners);
        return;
      }
      // Segment by segment: a valid earlier one taken, runs of the others refined together.
      std::vector<LimitRefiner::Segment> each;
      std::vector<Bow> no_bows;  // (limit lines have none)
      b.taken =
          refine_with_memo(reuse, record != nullptr ? &b.kept : nullptr, 0, 0, v, b.i0, b.i1, b.out, no_bows,
                           b.measured, [&](size_t i, size_t j, std::vector<RefinedRun<LimitRefiner::Measured>>& runs) {
                             each.clear();
                             refiner->refine_segments(v, i, j, b.out, b.measured.residual, b.measured.corners, &each);
                             for (const LimitRefiner::Segment& sg : each) runs.push_back({sg.out_end, 0, sg.measured});
                           });
    });
    if (record != nullptr)
      for (Block& b : blocks) {
        record->append(std::move(b.kept), b.i0 == 0 ? &verts[b.chain].front() : nullptr, b.out, {});
        record->taken += b.taken;
      }
    std::vector<std::vector<LimitVertex>> joined(verts.size());
    for (size_t k = 0; k < verts.size(); ++k)
      if (!verts[k].empty()) joined[k].push_back(verts[k].front());
    for (Block& b : blocks) {
      joined[b.chain].insert(joined[b.chain].end(), b.out.begin(), b.out.end());
      result.residual.merge(b.measured.residual);
      result.corners += b.measured.corners;
    }
    for (size_t k = 0; k < verts.size(); ++k)
      if (!verts[k].empty()) verts[k] = std::move(joined[k]);
  }
  // Each chain simplified on its own; the counts summed in chain order.
  struct Done {
    LimitLine line;
    int64_t before = 0;
    double simplified = 0.0;
  };
  std::vector<Done> done(verts.size());
  detail::parallel_for(t.grid.threads, static_cast<int64_t>(done.size()), [&](int64_t k, int) {
    Done& d = done[static_cast<size_t>(k)];
    std::vector<LimitVertex>& v = verts[static_cast<size_t>(k)];
    d.line.distance = t.D;
    d.line.owner = t.owner;
    d.line.closed = chains.closed[static_cast<size_t>(k)];
    drop_repeated(v);  // (a level through a cell centre: that vertex once)
    d.before = static_cast<int64_t>(v.size());
    if (!(tol > 0.0) || v.size() <= 2) {  // nothing to simplify: the chain is the line
      d.line.vertices = std::move(v);
      d.line.vertices.shrink_to_fit();
      return;
    }
    std::vector<Vec2> pts;
    pts.reserve(v.size());
    for (const LimitVertex& p : v) pts.push_back(p.p);
    const std::vector<size_t> keep = simplify_indices(pts, tol);
    d.line.vertices.reserve(keep.size());
    for (size_t i : keep) d.line.vertices.push_back(v[i]);
    if (refiner != nullptr && d.line.vertices.size() != v.size()) d.simplified = refiner->measure(d.line.vertices);
  });
  for (Done& d : done) {
    for (const LimitVertex& v : d.line.vertices) {
      result.max_residual = std::max(result.max_residual, v.residual);
      result.residual.max_vertex = std::max(result.residual.max_vertex, v.residual);
    }
    result.vertices_before_simplify += d.before;
    result.simplified_midpoint = std::max(result.simplified_midpoint, d.simplified);
    result.vertices += static_cast<int64_t>(d.line.vertices.size());
    result.lines.push_back(std::move(d.line));
  }
}

}  // namespace limit_stages

}  // namespace rv
