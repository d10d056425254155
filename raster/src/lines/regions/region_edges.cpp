// The edges of regions bounded by the refined lines (region_edges, rv/lines/regions.hpp): the
// boundary lines carried from where extraction stops -- the frame of the outermost cell
// centres, the edge of the owned area with a max distance -- to the grid's edge or the
// max-distance line, and joined where the cells show too little (lines shorter than a cell,
// holes and wedges of unowned sea thinner than one). The polygons are made by the vector
// adaptor (write_line_regions), which has a geometry engine.
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <set>
#include <tuple>
#include <unordered_map>
#include <utility>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/line_tools.hpp"
#include "lines/regions/region_follow.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/regions.hpp"

namespace rv {

using namespace line_tools;

namespace {

// By sea: the point a thousandth of a cell on from a line's end on a barrier, in the direction
// it arrives from `prev` (see carry_on).
Vec2 across_barrier(Vec2 prev, Vec2 end, double res) {
  const double len = std::hypot(end.x - prev.x, end.y - prev.y);
  if (!(len > 0.0)) return end;
  const double k = 1e-3 * res / len;
  return Vec2{end.x + k * (end.x - prev.x), end.y + k * (end.y - prev.y)};
}

// The vertex on the grid's edge that continues a line ending at `end`, a point on or outside the
// frame of the outermost cell centres: on the edge beyond it, where f (the line's locus: d_a - d_b, or
// d - D for a distance limit) changes sign.
template <class F>
Vec2 edge_vertex(const GridSpec& g, Vec2 end, F&& f, double ftol) {
  const double x0 = g.xmin, x1 = g.xmax(), y0 = g.ymin(), y1 = g.ymax;
  Vec2 foot = end, along{0.0, 0.0};
  if (end.x <= g.centre_x(0)) {
    foot.x = x0;
    along = {0.0, g.res};
  } else if (end.x >= g.centre_x(g.width - 1)) {
    foot.x = x1;
    along = {0.0, g.res};
  } else if (end.y >= g.centre_y(0)) {
    foot.y = y1;
    along = {g.res, 0.0};
  } else {
    foot.y = y0;
    along = {g.res, 0.0};
  }
  // The locus meets the edge within a cell of the foot (it crosses the half cell between the
  // centre frame and the edge): search that stretch, clamped to the edge.
  auto clamp = [&](Vec2 p) { return Vec2{std::clamp(p.x, x0, x1), std::clamp(p.y, y0, y1)}; };
  const Vec2 p0 = clamp(Vec2{foot.x - along.x, foot.y - along.y});
  const Vec2 p1 = clamp(Vec2{foot.x + along.x, foot.y + along.y});
  auto ft = [&](double t) { return f(lerp(p0, p1, t)); };
  const double f0 = ft(0.0), f1 = ft(1.0);
  if ((f0 < 0.0) == (f1 < 0.0) && f0 != 0.0 && f1 != 0.0) return foot;  // not bracketed: the foot
  return lerp(p0, p1, find_root(ft, f0, f1, ftol, 1e-15));
}

// The point near `start` where owners a and b are both at distance D (a boundary line meets the
// max-distance line).
bool junction(const OwnerIndex& index, int32_t a, int32_t b, double D, Vec2 start, double res, double ftol, Vec2& out) {
  auto f = [&](Vec2 p) {
    return std::array<double, 2>{index.nearest_of(p, a).distance - D, index.nearest_of(p, b).distance - D};
  };
  return solve2(f, start, res, ftol, out);
}

// The point near `start` where owners a, b and c are equidistant (a tripoint).
bool meeting(const OwnerIndex& index, int32_t a, int32_t b, int32_t c, Vec2 start, double res, double ftol, Vec2& out) {
  auto f = [&](Vec2 p) {
    const double ca = index.nearest_of(p, a).cost;
    return std::array<double, 2>{ca - index.nearest_of(p, b).cost, ca - index.nearest_of(p, c).cost};
  };
  return solve2(f, start, res, ftol, out);
}

// Where segments p0-p1 and q0-q1 cross (not at a shared end): false when they do not.
bool crossing(Vec2 p0, Vec2 p1, Vec2 q0, Vec2 q1, Vec2& out) {
  const double rx = p1.x - p0.x, ry = p1.y - p0.y, sx = q1.x - q0.x, sy = q1.y - q0.y;
  const double den = rx * sy - ry * sx;
  if (den == 0.0) return false;
  const double t = ((q0.x - p0.x) * sy - (q0.y - p0.y) * sx) / den;
  const double u = ((q0.x - p0.x) * ry - (q0.y - p0.y) * rx) / den;
  if (!(t > 0.0 && t < 1.0 && u > 0.0 && u < 1.0)) return false;
  out = Vec2{p0.x + t * rx, p0.y + t * ry};
  return true;
}

}  // namespace

namespace {

// An axis-aligned box of grid-CRS positions (a dual square: four cell centres at its corners).
struct Box {
  double x0, y0, x1, y1;
  bool holds(Vec2 p, double eps) const {
    return p.x >= x0 - eps && p.x <= x1 + eps && p.y >= y0 - eps && p.y <= y1 + eps;
  }
};

// The two dual squares beside `end`, a crossing on the segment between two cell centres (the
// one on the segment's upper or left side first). None when `end` is not on such a segment (a
// simplified line).
std::optional<std::pair<Box, Box>> squares_beside(const GridSpec& g, Vec2 end) {
  const double cx = (end.x - g.xmin) / g.res - 0.5, cy = (g.ymax - end.y) / g.res - 0.5;  // in centres
  const bool on_row = cy == std::floor(cy), on_col = cx == std::floor(cx);
  if (on_row == on_col) return std::nullopt;
  if (on_row) {
    const auto c = static_cast<int64_t>(std::floor(cx)), r = static_cast<int64_t>(cy);
    return std::pair{Box{g.centre_x(c), g.centre_y(r), g.centre_x(c + 1), g.centre_y(r - 1)},
                     Box{g.centre_x(c), g.centre_y(r + 1), g.centre_x(c + 1), g.centre_y(r)}};
  }
  const auto c = static_cast<int64_t>(cx), r = static_cast<int64_t>(std::floor(cy));
  return std::pair{Box{g.centre_x(c - 1), g.centre_y(r + 1), g.centre_x(c), g.centre_y(r)},
                   Box{g.centre_x(c), g.centre_y(r + 1), g.centre_x(c + 1), g.centre_y(r)}};
}

// The dual square a boundary line ending at `end` runs on into: the one beside it that does not
// hold `prev`, the line's vertex before it. A line of a single crossing runs on into both: its
// back end (`second` false) into the second, its front end into the first.
std::optional<Box> next_square(const GridSpec& g, const std::vector<Vec2>& v, bool second) {
  const auto beside = squares_beside(g, v.back());
  if (!beside) return std::nullopt;
  if (v.size() < 2) return second ? beside->first : beside->second;
  return beside->first.holds(v[v.size() - 2], 1e-9 * g.res) ? beside->second : beside->first;
}

// The max-distance lines as region edges, and the points where boundary lines end on them. Both
// are made of crossings on the segments between cell centres, so within a dual square each
// separates its corners by owner: a boundary line that stops where the owned area ends (its next
// crossing would be with an unowned cell) is joined to the max-distance line's chord across the
// square it runs on into, at the chord's point nearest the exact junction (where both owners are
// at the max distance). The joining segment then stays in that square and parts its corners as
// the raster does; the point becomes a vertex of both lines, and the max-distance line keeps its
// shape.
class ReachLines {
 public:
  // `owners`: per vertex of each line, the owner of its controlling site.
  ReachLines(const GridSpec& g, std::vector<std::vector<Vec2>> lines, std::vector<std::vector<int32_t>> owners)
      : g_(g), lines_(std::move(lines)), owners_(std::move(owners)) {
    for (size_t k = 0; k < lines_.size(); ++k)
      for (size_t i = 0; i + 1 < lines_[k].size(); ++i) {
        const Vec2 m = lerp(lines_[k][i], lines_[k][i + 1], 0.5);
        buckets_[key(m)].push_back({k, i});
      }
  }

  // The point of the lines nearest `target` within `radius` (CRS units; at most three cells), on
  // a segment with both ends in `square` when one is given: filed to be inserted as a vertex,
  // and returned in `out`. False when there is none. `exact`: the target is the exact junction,
  // where the point moves once the lines follow their level (moves()). `away` (or null): only
  // points on the far side of `target` from it.
  bool attach(Vec2 target, const std::optional<Box>& square, double radius, Vec2& out, bool exact = false,
              const Vec2* away = nullptr) {
    const auto [c0, r0] = cell(target);
    const double eps = 1e-9 * g_.res;
    double best = radius;
    Insert found{};
    bool any = false;
    for (int64_t r = r0 - 3; r <= r0 + 3; ++r)
      for (int64_t c = c0 - 3; c <= c0 + 3; ++c) {
        const auto it = buckets_.find(pack(c, r));
        if (it == buckets_.end()) continue;
        for (const auto& [k, i] : it->second) {
          const Vec2 a = lines_[k][i], b = lines_[k][i + 1];
          if (square && !(square->holds(a, eps) && square->holds(b, eps))) continue;
          const double t = nearest_t(a, b, target);
          const Vec2 q = lerp(a, b, t);
          const double d = std::hypot(q.x - target.x, q.y - target.y);
          if (away && (q.x - target.x) * (away->x - target.x) + (q.y - target.y) * (away->y - target.y) >= 0.0)
            continue;
          if (d <= best) {
            best = d;
            found = Insert{k, i, t, q};
            any = true;
          }
        }
      }
    if (!any) return false;
    cover(found.line, found.seg);
    // A point at a vertex touches the segment on its other side too (across a ring's start).
    if (found.t == 0.0) cover(found.line, found.seg == 0 ? segments(found.line) : found.seg - 1);
    if (found.t == 1.0) cover(found.line, found.seg + 1);
    // At a segment's end the point is its vertex: nothing to insert.
    if (found.t == 0.0) {
      out = lines_[found.line][found.seg];
    } else if (found.t == 1.0) {
      out = lines_[found.line][found.seg + 1];
    } else {
      out = found.q;
      inserts_.push_back(found);
      if (exact) moves_.emplace_back(found.q, target);
    }
    return true;
  }

  // Points inserted on a chord for an exact junction, and the junction: where the point belongs
  // once the chord gives way to its locus (a vertex of two edges, moved in both).
  const std::vector<std::pair<Vec2, Vec2>>& moves() const { return moves_; }

  // A point lacking the line of owner pair (a, b), to be joined to another.
  struct Loose {
    int32_t a, b;  // a < b
    Vec2 q;
    bool required = false;  // an owner change of a max-distance line (a tripoint's pair may have
                            // no line at all: three owners meeting at the tip of one's region)
    bool used = false;
  };

  // Where the owner along a line changes (between two vertices of different owners) and no
  // boundary line was attached there: two owners' discs overlapping by less than a cell, so that
  // no two neighbouring cells of theirs show a boundary. Each such change gets the point of its
  // segment nearest `junction_near(a, b, point)` (filed to be inserted). These and `loose` (the
  // tripoints lacking a line, in a square of the owned area's edge) are paired by owner pair,
  // nearest first, within three cells, at least one of each pair a change: the missing boundary
  // edges, returned. A tripoint left over is joined to the max-distance line within a cell of
  // its junction, if it passes there; a change left over counts in `unpaired`.
  template <class J>
  std::vector<std::vector<Vec2>> close_overlaps(J&& junction_near, std::vector<Loose> loose, int64_t& unpaired) {
    std::vector<Loose> changes = std::move(loose);
    for (size_t k = 0; k < lines_.size(); ++k)
      for (size_t i = 0; i + 1 < lines_[k].size(); ++i) {
        const int32_t a = owners_[k][i], b = owners_[k][i + 1];
        if (a == b || a == 0 || b == 0) continue;
        if (covered_.count({k, i})) continue;
        const Vec2 p0 = lines_[k][i], p1 = lines_[k][i + 1];
        const Vec2 j = junction_near(a, b, lerp(p0, p1, 0.5));
        // (Strictly inside the segment: a new vertex, not one of its ends.)
        const double t = std::clamp(nearest_t(p0, p1, j), 1e-9, 1.0 - 1e-9);
        const Insert in{k, i, t, lerp(p0, p1, t)};
        inserts_.push_back(in);
        changes.push_back(Loose{std::min(a, b), std::max(a, b), in.q, true});
      }
    std::vector<std::vector<Vec2>> edges;
    for (size_t x = 0; x < changes.size(); ++x) {
      if (changes[x].used) continue;
      size_t best = changes.size();
      double best_d = 3.0 * g_.res;
      for (size_t y = x + 1; y < changes.size(); ++y) {
        if (changes[y].used || changes[y].a != changes[x].a || changes[y].b != changes[x].b ||
            !(changes[x].required || changes[y].required))
          continue;
        const double d = std::hypot(changes[y].q.x - changes[x].q.x, changes[y].q.y - changes[x].q.y);
        if (d < best_d) {
          best_d = d;
          best = y;
        }
      }
      changes[x].used = true;
      if (best == changes.size()) {
        if (changes[x].required) {
          ++unpaired;
          continue;
        }
        // A tripoint whose line of this pair reaches the max-distance line within a cell: where
        // the third owner holds less than a cell of that line, no owner change shows it.
        Vec2 on_line;
        if (attach(junction_near(changes[x].a, changes[x].b, changes[x].q), std::nullopt, g_.res, on_line))
          edges.push_back({changes[x].q, on_line});
        continue;
      }
      changes[best].used = true;
      edges.push_back({changes[x].q, changes[best].q});
    }
    return edges;
  }

  // The lines with every point filed inserted, in order along their segments.
  std::vector<std::vector<Vec2>> take() {
    std::sort(inserts_.begin(), inserts_.end(), [](const Insert& x, const Insert& y) {
      return x.line != y.line ? x.line < y.line : x.seg != y.seg ? x.seg > y.seg : x.t > y.t;
    });
    for (const Insert& in : inserts_) {
      std::vector<Vec2>& v = lines_[in.line];
      v.insert(v.begin() + static_cast<std::ptrdiff_t>(in.seg) + 1, in.q);
    }
    inserts_.clear();
    return std::move(lines_);
  }

 private:
  struct Insert {
    size_t line = 0, seg = 0;
    double t = 0.0;
    Vec2 q;
  };
  size_t segments(size_t line) const { return lines_[line].size() - 1; }
  // Marks segment `seg` of `line` (an index one past either end wraps around a ring; dropped on
  // an open line) and its neighbours as reached by a boundary line: an owner change there is
  // the boundary's own.
  void cover(size_t line, size_t seg) {
    const size_t n = segments(line);
    const bool ring = lines_[line].front() == lines_[line].back();
    if (seg >= n) {
      if (!ring) return;
      seg = seg % n;
    }
    covered_.insert({line, seg});
    if (seg > 0 || ring) covered_.insert({line, (seg + n - 1) % n});
    if (seg + 1 < n || ring) covered_.insert({line, (seg + 1) % n});
  }
  std::pair<int64_t, int64_t> cell(Vec2 p) const {
    return {static_cast<int64_t>(std::floor((p.x - g_.xmin) / g_.res)),
            static_cast<int64_t>(std::floor((g_.ymax - p.y) / g_.res))};
  }
  static int64_t pack(int64_t c, int64_t r) { return (r + 4) * (int64_t{1} << 31) + (c + 4); }
  int64_t key(Vec2 p) const {
    const auto [c, r] = cell(p);
    return pack(c, r);
  }

  const GridSpec& g_;
  std::vector<std::vector<Vec2>> lines_;
  std::vector<std::vector<int32_t>> owners_;
  std::unordered_map<int64_t, std::vector<std::pair<size_t, size_t>>> buckets_;
  std::set<std::pair<size_t, size_t>> covered_;  // segments a boundary line was attached to
  std::vector<Insert> inserts_;
  std::vector<std::pair<Vec2, Vec2>> moves_;
};

// The stages of region_edges, in order; each appends to `out` (see the contract in
// rv/lines/regions.hpp).
class EdgeBuilder {
 public:
  EdgeBuilder(const BoundaryResult& boundaries, const OwnerIndex& index, const GridSpec& g, double max_distance)
      : b_(boundaries), index_(index), g_(g), D_(max_distance), ftol_(1e-9 * cell_metric(g, index.metric())) {}
  const LocusFunction* locus_ = nullptr;  // the lines' locus, when not the cost difference

  RegionEdges run(const LimitResult* max_distance_lines) {
    ReachLines reach_lines = limit_edges(max_distance_lines);
    reach_lines_ = &reach_lines;
    tripoint_gaps();
    boundary_edges();
    frame_tripoints();
    join_open_ends();
    std::vector<ReachLines::Loose> loose = gaps_left();
    if (reach_) {
      auto junction_near = [&](int32_t a, int32_t b, Vec2 start) {
        Vec2 j;
        return junction_at(a, b, start, j) ? j : start;
      };
      for (std::vector<Vec2>& e : reach_lines.close_overlaps(junction_near, std::move(loose), out_.dangling_ends))
        push(std::move(e), EdgeLocus{});
    }
    const std::vector<std::pair<Vec2, Vec2>> moves = reach_lines.moves();
    for (std::vector<Vec2>& e : reach_lines.take()) push(std::move(e), EdgeLocus{EdgeLocus::level, 0, 0});
    if (tol_ > 0.0) {
      // The junctions exact in both edges that share them, then every edge made to follow.
      std::unordered_map<double, std::vector<std::pair<Vec2, Vec2>>> by_x;
      for (const auto& m : moves) by_x[m.first.x].push_back(m);
      for (std::vector<Vec2>& e : out_.edges)
        for (Vec2& p : e) {
          const auto it = by_x.find(p.x);
          if (it == by_x.end()) continue;
          for (const auto& [from, to] : it->second)
            if (from.y == p.y) p = to;
        }
      region_follow::follow(out_, index_, g_, D_, margins_, tol_, locus_ != nullptr && *locus_, b_);
    }
    return std::move(out_);
  }
  double tol_ = 0.0;  // the line tolerance (metric units; 0: none)

 private:
  struct OpenEnd {
    size_t edge;
    bool front;
    Box square;
  };
  struct FrameEnd {
    size_t edge;
    bool front;
    int32_t a, b;
  };
  // An owner pair of a tripoint without a line ending there.
  struct TripointGap {
    int32_t a, b;
    Vec2 p;
    bool used = false;
  };

  void push(std::vector<Vec2> edge, EdgeLocus locus) {
    out_.edges.push_back(std::move(edge));
    out_.loci.push_back(locus);
  }
  double locus(int32_t a, int32_t b, Vec2 p) const {
    if (locus_ != nullptr && *locus_) return (*locus_)(a, b, p);
    return index_.nearest_of(p, a).cost - index_.nearest_of(p, b).cost;
  }
  // How far beyond the owned area p lies (<= 0 inside it): d - D with a max distance alone; with
  // reaches (the owned-edge lines), how far beyond its reach the deepest site is.
  double beyond(Vec2 p) const { return margins_ ? index_.deepest(p).cost : index_.nearest(p).distance - D_; }
  // The point near `start` where owners a and b both reach just so far: both at D, or (with
  // reaches) each at the reach of its deepest site -- where their line meets the owned area's
  // edge. False as solve2.
  bool junction_at(int32_t a, int32_t b, Vec2 start, Vec2& out) const {
    if (!margins_) return junction(index_, a, b, D_, start, g_.res, ftol_, out);
    auto f = [&](Vec2 p) { return std::array<double, 2>{index_.deepest(p, a).cost, index_.deepest(p, b).cost}; };
    return solve2(f, start, g_.res, ftol_, out);
  }
  bool at_tripoint(Vec2 p) const {
    return std::any_of(b_.tripoints.begin(), b_.tripoints.end(), [&](const Tripoint& t) { return t.p == p; });
  }

  // The max-distance lines, carried to the grid's edge on d = D where they reach the frame of
  // the outermost centres, with the owner of each vertex's controlling site.
  ReachLines limit_edges(const LimitResult* max_distance_lines) {
    std::vector<std::vector<Vec2>> edges;
    std::vector<std::vector<int32_t>> owners_of;
    const SeedSet& seeds = index_.metric().seeds();
    if (max_distance_lines != nullptr) {
      margins_ = std::any_of(max_distance_lines->lines.begin(), max_distance_lines->lines.end(),
                             [](const LimitLine& l) { return l.owner == kOwnedEdge; });
      auto on_d = [&](Vec2 p) { return beyond(p); };
      for (const LimitLine& line : max_distance_lines->lines) {
        const bool edge =
            margins_ ? line.owner == kOwnedEdge : std::isfinite(D_) && line.owner == 0 && line.distance == D_;
        if (!edge || line.vertices.empty()) continue;
        std::vector<Vec2> pts;
        std::vector<int32_t> owners;
        pts.reserve(line.vertices.size() + 2);
        for (const LimitVertex& v : line.vertices) {
          pts.push_back(v.p);
          owners.push_back(v.site == kNoSite ? 0 : seeds.site_owner(v.site));
        }
        if (!line.closed) {
          for (const bool at_end : {true, false}) {
            const Vec2 end = at_end ? pts.back() : pts.front();
            // By sea: an end on a barrier goes a thousandth of a cell on into it, as a boundary's
            // does (carry_on), so that the faces close against the coast.
            const LimitVertex& last = at_end ? line.vertices.back() : line.vertices.front();
            const bool on_barrier = last.on_barrier && pts.size() >= 2;
            if (!on_barrier && !on_centre_frame(g_, end)) {
              ++out_.dangling_ends;
              continue;
            }
            const Vec2 q = on_barrier ? across_barrier(at_end ? pts[pts.size() - 2] : pts[1], end, g_.res)
                                      : edge_vertex(g_, end, on_d, ftol_);
            if (at_end) {
              pts.push_back(q);
              owners.push_back(owners.back());
            } else {
              pts.insert(pts.begin(), q);
              owners.insert(owners.begin(), owners.front());
            }
          }
        }
        edges.push_back(std::move(pts));
        owners_of.push_back(std::move(owners));
      }
    }
    reach_ = !edges.empty();
    return ReachLines(g_, std::move(edges), std::move(owners_of));
  }

  void tripoint_gaps() {
    for (const boundary_stages::TripointGap& gap : boundary_stages::tripoint_gaps(b_.tripoints, b_.lines)) {
      const Tripoint& t = b_.tripoints[gap.tripoint];
      gaps_.push_back({t.owners[gap.i], t.owners[gap.k], t.p});
    }
  }

  // Every boundary line (and, with a max distance, every lone crossing), both ends carried on.
  void boundary_edges() {
    std::vector<const BoundaryLine*> lines;
    for (const BoundaryLine& line : b_.lines) lines.push_back(&line);
    if (reach_)
      for (const BoundaryLine& line : b_.lone_crossings) lines.push_back(&line);
    out_.edges.reserve(lines.size());
    for (const BoundaryLine* line : lines) {
      std::vector<Vec2> pts;
      pts.reserve(line->vertices.size() + 2);
      for (const BoundaryVertex& v : line->vertices) pts.push_back(v.p);
      if (pts.empty()) continue;
      if (!line->closed) {
        carry_on(*line, pts, false);
        std::reverse(pts.begin(), pts.end());
        carry_on(*line, pts, true);
        std::reverse(pts.begin(), pts.end());
      }
      push(std::move(pts), EdgeLocus{EdgeLocus::pair, line->owner_a, line->owner_b});
    }
  }

  // The line's last vertex carried on: to the grid's edge; to a tripoint lacking the line in the
  // square it runs on into (its link was not made); or, where the owned area ends (a max
  // distance), to the max-distance line's chord across that square, at its point nearest the
  // exact junction (or nearest the end where no junction is found within two cells: a wedge of
  // unowned sea thinner than a cell, which neither the cells nor the max-distance line show).
  // Else it is left open, for join_open_ends. `front`: the line's front end (reversed in `v`).
  void carry_on(const BoundaryLine& line, std::vector<Vec2>& v, bool front) {
    if (at_tripoint(v.back())) {
      // A tripoint beyond the max distance (the three owners' discs do not all meet there): the
      // line's stretch towards it lies in unowned sea but for its last crossing.
      if (!reach_ || v.size() < 2 || beyond(v.back()) <= 0.0) return;
      v.pop_back();
    }
    const Vec2 end = v.back();
    // By sea: an end on a barrier (end_at_barriers) goes a thousandth of a cell on into it, so
    // that it crosses the barrier's edge in the regions' linework (straight there, where the
    // edge is a geodesic: the end lies on the geodesic) and is noded with it; the stub is a
    // dangle the faces drop.
    const BoundaryVertex& last = front ? line.vertices.front() : line.vertices.back();
    if (last.on_barrier && last.p.x == end.x && last.p.y == end.y && v.size() >= 2) {
      v.push_back(across_barrier(v[v.size() - 2], end, g_.res));
      return;
    }
    // By sea, a line found from the coasts beyond the frame (cross_hidden_channels) may end on the
    // grid's edge itself.
    if (end.x == g_.xmin || end.x == g_.xmax() || end.y == g_.ymax || end.y == g_.ymin()) return;
    Vec2 j, on_line;
    // (A lone crossing on the frame: one end goes to the grid's edge, the other inwards.)
    const bool came_from_edge = v.size() >= 2 && outside_frame(g_, v[v.size() - 2]);
    if (on_centre_frame(g_, end) && !came_from_edge) {
      const Vec2 e = edge_vertex(
          g_, end, [&](Vec2 p) { return locus(line.owner_a, line.owner_b, p); }, ftol_);
      // Leaving the owned area before the grid's edge: it ends where it meets the max-distance
      // line (carried to the edge there too), at the junction made a vertex of both.
      if (reach_ && beyond(e) > 0.0 && junction_at(line.owner_a, line.owner_b, end, j) &&
          reach_lines_->attach(j, std::nullopt, g_.res, on_line, true)) {
        v.push_back(on_line);
        return;
      }
      frame_ends_.push_back(FrameEnd{out_.edges.size(), front, line.owner_a, line.owner_b});
      v.push_back(e);
      return;
    }
    const std::optional<Box> square = next_square(g_, v, front);
    for (TripointGap& gap : gaps_)
      if (!gap.used && gap.a == line.owner_a && gap.b == line.owner_b &&
          (square ? square->holds(gap.p, 1e-9 * g_.res) : std::hypot(gap.p.x - end.x, gap.p.y - end.y) <= g_.res)) {
        gap.used = true;
        v.push_back(gap.p);
        return;
      }
    if (reach_) {
      const bool exact = junction_at(line.owner_a, line.owner_b, end, j);
      // By sea, a lone crossing whose first end went to the edge: its second end goes the other
      // way (the nearest point of the edge is the one the first end took, across a sliver of
      // unowned sea round a pocket the owners' discs leave between them).
      const bool lone = !index_.metric().straight() && line.vertices.size() == 1 && v.size() == 2;
      const Vec2* away = lone ? &v.front() : nullptr;
      // With reaches the edge has its corners as vertices (where two sites' arcs meet, which no
      // cell edge crosses): a corner in the square before splits the chord across this one, and
      // the line ends on the corner itself.
      if (reach_lines_->attach(exact ? j : end, square, 3.0 * g_.res, on_line, exact, away) ||
          (exact && margins_ && reach_lines_->attach(j, std::nullopt, g_.res, on_line, true, away))) {
        // (A line ended at the junction already, end_at_owned_edge, may meet the edge there.)
        if (!(on_line.x == end.x && on_line.y == end.y)) v.push_back(on_line);
        return;
      }
    }
    if (square) {
      open_ends_.push_back(OpenEnd{out_.edges.size(), front, *square});
    } else {
      ++out_.dangling_ends;
    }
  }

  // Two lines carried from the frame of the outermost centres to the grid's edge that cross on
  // the way: their tripoint lies between the frame and the edge, where no dual square holds the
  // three owners' cells (it was not found). Both end at it, and the third pair's line runs from
  // it to the edge.
  void frame_tripoints() {
    for (size_t i = 0; i < frame_ends_.size(); ++i)
      for (size_t k = i + 1; k < frame_ends_.size(); ++k) {
        const FrameEnd& x = frame_ends_[i];
        const FrameEnd& y = frame_ends_[k];
        std::vector<Vec2>& vx = out_.edges[x.edge];
        std::vector<Vec2>& vy = out_.edges[y.edge];
        if (vx.size() < 2 || vy.size() < 2) continue;
        auto ext = [](const std::vector<Vec2>& v, bool front) {
          return front ? std::pair{v[1], v[0]} : std::pair{v[v.size() - 2], v.back()};
        };
        const auto [x0, x1] = ext(vx, x.front);
        const auto [y0, y1] = ext(vy, y.front);
        Vec2 c, t;
        if (std::hypot(x0.x - y0.x, x0.y - y0.y) > 2.0 * g_.res || !crossing(x0, x1, y0, y1, c)) continue;
        std::vector<int32_t> owners = {x.a, x.b, y.a, y.b};
        std::sort(owners.begin(), owners.end());
        owners.erase(std::unique(owners.begin(), owners.end()), owners.end());
        if (owners.size() != 3 || !meeting(index_, owners[0], owners[1], owners[2], c, g_.res, ftol_, t)) continue;
        (x.front ? vx.front() : vx.back()) = t;
        (y.front ? vy.front() : vy.back()) = t;
        // The pair neither line belongs to.
        int32_t p = 0, q = 0;
        for (const auto& [i1, k1] : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}})
          if (!((owners[i1] == x.a && owners[k1] == x.b) || (owners[i1] == y.a && owners[k1] == y.b))) {
            p = owners[i1];
            q = owners[k1];
          }
        push({t, edge_vertex(
                     g_, t, [&](Vec2 at) { return locus(p, q, at); }, ftol_)},
             EdgeLocus{EdgeLocus::pair, std::min(p, q), std::max(p, q)});
      }
  }

  // Ends left in the open in one square: where the owners' discs leave a hole in the owned area
  // smaller than the square (no cell shows it; nor does the max-distance line), the lines are
  // joined at the mean of their ends, inside the square. A lone end there is a defect.
  void join_open_ends() {
    std::sort(open_ends_.begin(), open_ends_.end(), [](const OpenEnd& a, const OpenEnd& b) {
      return std::tie(a.square.x0, a.square.y0) < std::tie(b.square.x0, b.square.y0);
    });
    auto end_of = [&](const OpenEnd& e) -> Vec2& {
      std::vector<Vec2>& v = out_.edges[e.edge];
      return e.front ? v.front() : v.back();
    };
    for (size_t i = 0; i < open_ends_.size();) {
      size_t k = i;
      Vec2 sum{0.0, 0.0};
      while (k < open_ends_.size() && open_ends_[k].square.x0 == open_ends_[i].square.x0 &&
             open_ends_[k].square.y0 == open_ends_[i].square.y0) {
        sum = Vec2{sum.x + end_of(open_ends_[k]).x, sum.y + end_of(open_ends_[k]).y};
        ++k;
      }
      if (k - i < 2) {
        ++out_.dangling_ends;
      } else {
        const Vec2 meet{sum.x / static_cast<double>(k - i), sum.y / static_cast<double>(k - i)};
        for (size_t e = i; e < k; ++e) {
          std::vector<Vec2>& v = out_.edges[open_ends_[e].edge];
          if (open_ends_[e].front)
            v.insert(v.begin(), meet);
          else
            v.push_back(meet);
        }
      }
      i = k;
    }
  }

  // Tripoints still lacking a line of one of their pairs: between the frame of the outermost
  // centres and the grid's edge, the line towards the edge has no crossing to be extracted from
  // (it gets the edge from the tripoint to the grid's edge on the pair's locus); in the owned
  // area's edge, neither has the line to the max-distance line (returned, to be paired with the
  // max-distance line's owner changes).
  std::vector<ReachLines::Loose> gaps_left() {
    std::vector<ReachLines::Loose> loose;
    for (const TripointGap& gap : gaps_) {
      if (gap.used) continue;
      if (outside_frame(g_, gap.p) || on_centre_frame(g_, gap.p)) {
        push({gap.p, edge_vertex(
                         g_, gap.p, [&](Vec2 p) { return locus(gap.a, gap.b, p); }, ftol_)},
             EdgeLocus{EdgeLocus::pair, gap.a, gap.b});
      } else if (reach_ && beyond(gap.p) <= 0.0) {
        // (Beyond the max distance, the three owners' lines are cut short of it anyway.)
        loose.push_back({gap.a, gap.b, gap.p});
      }
    }
    return loose;
  }

  const BoundaryResult& b_;
  const OwnerIndex& index_;
  const GridSpec& g_;
  const double D_;
  const double ftol_;
  bool reach_ = false;
  bool margins_ = false;  // the owned area's edge is given by reaches (kOwnedEdge lines)
  ReachLines* reach_lines_ = nullptr;
  std::vector<TripointGap> gaps_;
  std::vector<OpenEnd> open_ends_;
  std::vector<FrameEnd> frame_ends_;
  RegionEdges out_;
};

}  // namespace

RegionEdges region_edges(const BoundaryResult& boundaries, const OwnerIndex& index, const GridSpec& g,
                         double max_distance, const LimitResult* max_distance_lines, const LocusFunction* locus,
                         double line_tolerance) {
  EdgeBuilder builder(boundaries, index, g, max_distance);
  builder.locus_ = locus;
  builder.tol_ = std::max(line_tolerance, 0.0);
  return builder.run(max_distance_lines);
}

}  // namespace rv
