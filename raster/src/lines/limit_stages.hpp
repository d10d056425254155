// The stages of distance-limit lines (extract_limits, rv/lines/limits.hpp), each a function of
// its own over rows [row0, row1) of the field -- the shape streaming needs -- and a last stage
// that joins the pieces into lines:
//
//   inside_flags       per cell of the rows, whether it lies within distance D of the target
//                      (all seeds, or one owner's), decided exactly near the line
//   limit_crossings    every edge between an inside and an outside cell of the rows (horizontal
//                      edges of those rows, vertical edges down from them: row1's flags must be
//                      there too), its vertex placed at distance D
//   limit_links        per dual square whose top row is in the rows, its crossings joined (a
//                      saddle's four by the side of its centre)
//   chain_limit_lines  the links chained into lines (closed rings, or ending at the grid's
//                      edge), each made to follow the level between its vertices (LimitRefiner:
//                      corners where the controlling site changes, points on curved stretches
//                      to the line tolerance), simplified with Douglas-Peucker at `tol` CRS units
//
// Internal to rv_raster (tests reach it by name). Thread safety: pure functions of their
// arguments but for the outputs named; inside_flags and limit_crossings run on the grid's
// threads, with results independent of them.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "lines/line_tools.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/lines/limits.hpp"

namespace rv::limit_stages {

// What every stage of one extraction reads (rows: line_tools::FieldRows, a whole field or the
// rows of a streamed one the stages are at).
struct LimitGrid {
  line_tools::FieldRows rows;
  const OwnerIndex& index;
  const SiteMetric& metric;
  const GridSpec& g;
  int64_t W, H;
  int threads;
  double cell;  // one cell in metric units
  double ftol;
  std::vector<int32_t> owner_of_site;
  // Whether a cell's field distance is the nearest distance of its owner's seeds (not with
  // weights: the field's site is the nearest by adjusted distance, the limits measure true ones,
  // `index` is plain). Otherwise it only bounds that distance from above.
  bool field_is_nearest = true;
  // The index whose reaches end the owned area (Target owner kOwnedEdge); null without.
  const OwnerIndex* reaches = nullptr;
};

// The distance whose level D is drawn: to any seed (owner 0), or to one owner's; or (owner
// kOwnedEdge, D 0) how deep within its reach the deepest site is, d - reach, as the hit's
// `distance`.
struct Target {
  const LimitGrid& grid;
  int32_t owner;
  double D;
  OwnerIndex::Hit at(Vec2 p) const {
    if (owner == kOwnedEdge) {
      const OwnerIndex::Hit h = grid.reaches->deepest(p);
      return OwnerIndex::Hit{h.site, h.cost, h.cost};
    }
    return owner == 0 ? grid.index.nearest(p) : grid.index.nearest_of(p, owner);
  }
  // Whether at(p).distance <= D (the owned edge aside), measuring only what may be within D.
  bool reached(Vec2 p) const {
    if (owner == kOwnedEdge) return at(p).distance <= D;
    return grid.index.nearest_within(p, owner, D).site != kNoSite;
  }
};

// The crossings of a range of rows: their edges, vertices, and each edge's index.
struct LimitCrossings {
  std::vector<int64_t> edges;
  std::vector<LimitVertex> verts;           // per edge
  std::unordered_map<int64_t, int32_t> at;  // edge -> index
};

// The inside flags of rows [row0, row1()), row-major over the grid's width: 1 inside.
struct InsideRows {
  int64_t width = 0;
  int64_t row0 = 0;
  std::vector<uint8_t> flags;
  int64_t row1() const { return width == 0 ? row0 : row0 + static_cast<int64_t>(flags.size()) / width; }
  bool at(int64_t c, int64_t r) const { return flags[static_cast<size_t>((r - row0) * width + c)] != 0; }
  const uint8_t* row(int64_t r) const { return flags.data() + (r - row0) * width; }
  // Forgets the rows before r.
  void drop_before(int64_t r);
};

// Appends the flags of rows [row0, row1) to `inside`, which must end at row0 (or be empty: it
// then starts there).
void inside_flags(const Target& t, int64_t row0, int64_t row1, InsideRows& inside);
// An edit's limit vertices taken from its base instead of placed again
// (rv::StripLines::take_measured): true with the base's vertex on `edge` in `v`, or false where
// the edge is to be placed. Called from limit_crossings' threads at once.
using LimitVertexFromBase = std::function<bool(int64_t edge, LimitVertex& v)>;
// The crossings of rows [row0, row1); reads the flags of rows up to row1. With `from_base`, an
// edge it gives a vertex for holds that one.
LimitCrossings limit_crossings(const Target& t, const InsideRows& inside, int64_t row0, int64_t row1,
                               const LimitVertexFromBase* from_base = nullptr);
// Appends the crossings of `part` (the rows after those of `x`) to `x`.
void append(LimitCrossings& x, LimitCrossings&& part);
// The links of the squares of rows [row0, row1); reads flags and crossings of rows up to row1.
std::vector<std::array<int32_t, 2>> limit_links(const Target& t, const InsideRows& inside, const LimitCrossings& x,
                                                int64_t row0, int64_t row1);
// Stage 4a (limit_refine.cpp): a chain's vertices made to follow the level d = D between them,
// and every final segment measured. Where the controlling site changes between two vertices the
// level has a corner (two sites' circles meet; with reaches, two arcs): the point where both
// sites are at their level (Newton's method on the two, from the chord's middle) is added when no
// third site is nearer there. Where the site is the same, the chord's midpoint is measured
// against the level with that site (|d - D|: a distance's gradient has unit length, so this is
// the midpoint's distance from the level); above kSplitAt of the tolerance the chord is cut into
// the pieces a circle of that sagitta needs (the sagitta falls with the square of the chord),
// each new point placed on the level by Newton's method along the site's gradient, and the
// pieces measured again. A straight offset of a segment measures 0 and gets nothing.
// Thread safety: const; any number of chains at once.
class LimitRefiner {
 public:
  // `tol`: metric units (0: measure only); `scale`: metric units per CRS unit near the grid's
  // middle.
  LimitRefiner(const Target& t, double tol, const line_tools::CrsScale& scale);
  // The chain with corners and arc points added (a closed chain's last vertex repeats its first);
  // adds its segments' measures to `r` and the corners to `corners`.
  std::vector<LimitVertex> refine(const std::vector<LimitVertex>& v, LineResidual& r, int64_t& corners) const;
  // The same for segments [i0, i1) of a chain: the points added within them and each segment's
  // end after it, appended to `out` (vertex i0 is not). Segments are refined independently.
  // `each`: per segment, in order, where its points end in `out` and what it measured and added
  // alone (merged in order, they make `r`'s and `corners`' increase), when given.
  struct Measured {
    LineResidual residual;
    int64_t corners = 0;
    void merge(const Measured& o) {
      residual.merge(o.residual);
      corners += o.corners;
    }
  };
  struct Segment {
    size_t out_end = 0;
    Measured measured;
  };
  void refine_segments(const std::vector<LimitVertex>& v, size_t i0, size_t i1, std::vector<LimitVertex>& out,
                       LineResidual& r, int64_t& corners, std::vector<Segment>* each = nullptr) const;
  // The largest distance from a segment's midpoint to the level (a simplified chain).
  double measure(const std::vector<LimitVertex>& v) const;

 private:
  struct End {
    LimitVertex v;
    int32_t alt = kNoSite;  // a corner's second site
  };
  double radius(int32_t site) const;  // the level's distance from `site`: D, or its reach
  // f = d_site - radius at p, and its gradient per CRS unit.
  double level(Vec2 p, int32_t site, Vec2& gradient) const;
  // The level of s1 at p, or (`any`) of the nearest site there (searched); the site it is, and
  // its gradient.
  double level_near(Vec2 p, int32_t s1, bool any, int32_t& site, Vec2& gradient) const;
  bool corner(const End& u, const End& v, End& out) const;
  // p moved onto the level of `site` by Newton's method along its gradient; false where it does
  // not converge within `max_move` CRS units.
  bool onto_level(Vec2 start, int32_t site, double max_move, LimitVertex& out) const;
  // The level across chord u-v at `at` (on it), with the nearest site at each position.
  bool across(Vec2 u, Vec2 v, Vec2 at, LimitVertex& out) const;
  void between(const End& u, const End& v, int depth, std::vector<End>& out, LineResidual& r, int64_t& corners) const;
  const Target& t_;
  double tol_;
  line_tools::CrsScale scale_;
};

// Appends the lines to result.lines (and its vertex count, largest residual and the residual
// along them). `refiner`: the level followed between the vertices (null: the vertices on cell
// edges alone, unmeasured); on the grid's threads, over blocks of segments of every chain.
// With a refiner, `reuse` (an earlier state's segments of this target an edit leaves valid) gives
// the segments it holds instead of refining them again, and `record` gets every segment's
// refinement (for the next state), when given: the lines are the same.
using LimitMemo = SegmentMemo<LimitVertex, LimitRefiner::Measured>;
void chain_limit_lines(const Target& t, const LimitCrossings& x, const std::vector<std::array<int32_t, 2>>& links,
                       double tol, LimitResult& result, const LimitRefiner* refiner = nullptr,
                       const SegmentReuse<LimitVertex, LimitRefiner::Measured>* reuse = nullptr,
                       LimitMemo* record = nullptr);

}  // namespace rv::limit_stages
