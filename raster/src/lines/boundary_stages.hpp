// The stages of boundary extraction (extract_boundaries, rv/lines/boundaries.hpp), each a function
// of its own over rows [row0, row1) of the field -- the shape streaming needs: a strip of the
// field in, pieces of line out -- and a last stage that joins the pieces into lines:
//
//   find_crossings   every 4-neighbour pair of differently owned cells of rows [row0, row1)
//                    (horizontal edges of those rows, vertical edges down from them), placed on
//                    the equidistance locus; owners passing between two centres (slivers) add
//                    their own crossings
//   find_tripoints   the points equidistant from three owners in the dual squares whose top row
//                    is in [row0, row1), each filed under the square it lies in
//   link_squares     per dual square of those rows, its crossings joined to each other or to its
//                    tripoints (nodes: crossings 0..n-1, then tripoints n + id)
//   chain_lines      the links chained into lines per owner pair (ending at tripoints, the grid's
//                    edge, or closed), simplified with Douglas-Peucker at `tol` CRS units, in a
//                    deterministic order
//   close_missing_tripoints  a tripoint a crowded square's search missed, found from its lines' ends
//   end_at_owned_edge  line ends where the owned area ends (a max distance, reaches) carried to
//                    the exact junction with its edge
//
// Internal to rv_raster (tests reach it by name). Thread safety: pure functions of their
// arguments; find_crossings runs on b.threads threads, with a result independent of them.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <unordered_map>
#include <utility>
#include <vector>

#include "lines/line_tools.hpp"
#include "lines/locus_follow.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/residual.hpp"

namespace rv::boundary_stages {

// Two ends (or junctions) i < j of a join stage's candidates, `d` apart (CRS units); the stages take
// them nearest first, ties by the indices, so that the joins never depend on the order found.
struct NearPair {
  double d;
  size_t i, j;
};
inline void sort_nearest_first(std::vector<NearPair>& pairs) {
  std::sort(pairs.begin(), pairs.end(), [](const NearPair& x, const NearPair& y) {
    return x.d < y.d || (x.d == y.d && (x.i < y.i || (x.i == y.i && x.j < y.j)));
  });
}

// A point of the equidistance locus between owners owner_lo < owner_hi on grid edge `edge`
// (line_tools.hpp's edge ids).
struct Crossing {
  int64_t edge;
  int32_t owner_lo, owner_hi;
  BoundaryVertex v;
};

// Per row of the grid, the stage statistics (BoundaryStats) its pieces counted: crossings by
// their edge's row, tripoint searches and links by their square's top row. What an edit needs
// to take rows of an earlier run's pieces with their counts (rv::LinePieces).
struct RowCounts {
  enum Counter { crossings, sliver_crossings, unresolved_slivers, multi_owner_squares, saddles, kCounters };
  std::vector<std::array<int64_t, kCounters>> rows;  // empty: not counted
  void add(int64_t row, Counter k, int64_t n) {
    if (!rows.empty()) rows[static_cast<size_t>(row)][k] += n;
  }
};

// What every stage of one extraction reads: the field's rows (line_tools::FieldRows: a whole
// field, or the rows of a streamed one the stages are at), the metric's index, the grid and the
// tolerance, and each cell's owner.
struct BoundaryGrid {
  line_tools::FieldRows rows;
  const OwnerIndex& index;
  const GridSpec& g;
  int64_t W, H;
  int threads;
  double ftol;
  std::vector<int32_t> owner_of_site;
  // Where the stages count their statistics per row as well (null: they do not).
  RowCounts* counts = nullptr;

  int32_t owner(int64_t c, int64_t r) const { return owner_code(rows.site(c, r)); }
  int32_t owner_code(int32_t site) const { return site == kNoSite ? 0 : owner_of_site[static_cast<size_t>(site)]; }
  // The owners of dual square (c, r)'s corners: (c,r), (c+1,r), (c+1,r+1), (c,r+1).
  std::array<int32_t, 4> corner_owners(int64_t c, int64_t r) const {
    return {owner(c, r), owner(c + 1, r), owner(c + 1, r + 1), owner(c, r + 1)};
  }
  static bool uniform(const std::array<int32_t, 4>& o) { return o[0] == o[1] && o[1] == o[2] && o[2] == o[3]; }
};

// Crossings of a range of rows, grouped by edge.
struct CrossingSet {
  std::vector<Crossing> crossings;
  // Edge -> its crossings: consecutive in `crossings` (first index, count), in order along it.
  std::unordered_map<int64_t, std::pair<int32_t, int32_t>> on_edge;
  std::unordered_map<int64_t, int32_t> sliver_at;  // edge -> the (first) owner passing between
};

// Tripoints of a range of squares: by owner triple and by the square they lie in.
struct TripointSet {
  std::vector<Tripoint> tripoints;
  std::map<std::array<int32_t, 3>, std::vector<int32_t>> by_owners;
  std::unordered_map<int64_t, std::vector<int32_t>> in_square;  // square id -> tripoint ids
  std::vector<int32_t> found_row;  // per tripoint: the top row of the square it was sought from
};

// Links between nodes, each once, with its owner pair's key. A node is a crossing (its index,
// >= 0) or a tripoint (tripoint_node(id) < 0: the number of crossings is known only once the
// last strip is in; chain_lines numbers the tripoints after them).
struct Links {
  std::vector<std::array<int32_t, 2>> links;
  std::vector<int64_t> pair;                     // pair_key of each link's owners
  std::vector<int32_t> row;                      // the top row of each link's square
  std::set<std::pair<int32_t, int32_t>> linked;  // a crossing is seen from both its squares
  void add(int32_t n1, int32_t n2, int64_t p, int32_t r) {
    if (!linked.emplace(std::min(n1, n2), std::max(n1, n2)).second) return;
    links.push_back({n1, n2});
    pair.push_back(p);
    row.push_back(r);
  }
};

inline int32_t tripoint_node(int32_t id) { return -1 - id; }

// A key for the unordered pair of owners {a, b}.
inline int64_t pair_key(int32_t a, int32_t b) {
  return (static_cast<int64_t>(std::min(a, b)) << 32) | static_cast<int64_t>(std::max(a, b));
}

// An edit's crossings taken from its base instead of placed again (rv::StripLines::take_measured):
// given an edge and the owners lo < hi of its two cells, true with the base's vertex there in `v`,
// or false where the edge is to be placed. Called from find_crossings' threads at once.
using CrossingFromBase = std::function<bool(int64_t edge, int32_t owner_lo, int32_t owner_hi, BoundaryVertex& v)>;

// Appends the crossings of rows [row0, row1) (rows up to row1 read) to `x`. With `from_base`, an
// edge it gives a vertex for holds that one crossing (no owner between) instead of one placed.
void find_crossings(const BoundaryGrid& b, int64_t row0, int64_t row1, CrossingSet& x, BoundaryStats& stats,
                    const CrossingFromBase* from_base = nullptr);
// Appends the tripoints of the squares of rows [row0, row1) to `t` (a tripoint already in `t`
// is not added again), and to `unplaced` the multi-owner squares where none converged. Reads
// the crossings of rows up to row1.
void find_tripoints(const BoundaryGrid& b, const CrossingSet& x, int64_t row0, int64_t row1, TripointSet& t,
                    std::vector<std::array<int64_t, 2>>& unplaced, BoundaryStats& stats);
// Files a tripoint found earlier (an edit taking it from its base's pieces) as the search filed
// it there, under `found_row`: by owners and by square, without looking for a duplicate.
void file_tripoint(const BoundaryGrid& b, TripointSet& t, const Tripoint& tp, int32_t found_row);
// Once every square is searched: the unplaced squares that a line must end in and that hold no
// tripoint (found from a neighbouring square) are counted as unresolved tripoints.
void count_unresolved(const BoundaryGrid& b, const CrossingSet& x, const TripointSet& t,
                      const std::vector<std::array<int64_t, 2>>& unplaced, BoundaryStats& stats);
// The links of the squares of rows [row0, row1): reads the crossings of rows up to row1 and the
// tripoints filed in squares of rows up to row1 (found from squares up to row1 + 1).
Links link_squares(const BoundaryGrid& b, const CrossingSet& x, const TripointSet& t, int64_t row0, int64_t row1,
                   BoundaryStats& stats);
// The cost of `site` at p as `index` compares it (adjusted_distance), and its gradient per CRS
// unit (line_refine.cpp).
double site_cost(const OwnerIndex& index, Vec2 p, int32_t site, Vec2& gradient);
// The point where sites s1, s2 and t cost the same (a locus's turning point), by Newton's method
// on their gradients from `start`, within `max_move` (CRS units) of it, to `ftol` (metric units);
// false when it does not converge there.
bool equal_costs_point(const OwnerIndex& index, int32_t s1, int32_t s2, int32_t t, Vec2 start, double max_move,
                       double ftol, Vec2& out);

// Stage 5 (line_refine.cpp): the line between two consecutive vertices made exact to a
// tolerance. Where the controlling site of a side changes between them, the locus turns: the
// turning point (the three sites' costs equal, by Newton's method on their gradients) is added.
// Where the stretch is curved (weighted pairs, a point and a segment, any pair on the
// ellipsoid), two measures decide: the chord's sagitta estimated from the locus normals at its
// ends (a circular arc's), and the distance from the chord's midpoint to the locus, measured
// (|f| / |grad f| with the two owners' nearest sites there, or the root across the chord where
// the metric gives no gradient). While either exceeds the tolerance the locus point across the
// chord's middle is added. Every added vertex is a locus point checked against the index (each
// owner's nearest, no third owner nearer) with its controlling sites; one that fails the check is
// not added. Recursion depth is bounded. Segments on land (both ends at distance 0 from an
// owner: shared land borders, overlapping land, where every point is on the locus) are left as
// they are and counted apart.
// Thread safety: refine_segments() and measure() are const and may run on many lines at once.
class LineRefiner {
 public:
  // `tol`: the line tolerance, metric units (0: measure only, add nothing); `ftol`: metric units;
  // `scale`: metric units per CRS unit near the grid's middle (line_tools::CrsScale); `per_crs`:
  // the larger of its two, for bounds.
  LineRefiner(const OwnerIndex& index, double tol, double ftol, const line_tools::CrsScale& scale, double per_crs)
      : index_(index), tol_(tol), ftol_(ftol), scale_(scale), per_crs_(per_crs) {}
  struct Added {
    int64_t turning_points = 0, arc_points = 0;
    LineResidual locus, arcs;  // the segments of the locus, and of reaches' arcs
    void merge(const Added& o) {
      turning_points += o.turning_points;
      arc_points += o.arc_points;
      locus.merge(o.locus);
      arcs.merge(o.arcs);
    }
  };
  // Refines segments [i0, i1) of a line's vertices (in order; a closed line's last vertex repeats
  // its first; segment i joins vertices i and i + 1) and measures every segment of the result:
  // the points added within them and each segment's end after it, appended to `out` (vertex i0
  // is not).
  // Segments are refined independently of each other: any split of a line gives the same line.
  // `bows`: each final segment's bow (rv/lines/residual.hpp) appended in order, when given.
  // `each`: per segment, in order, where its points end in `out` and its bows in `bows`, and what
  // it added alone (merged in order, the segments' Added make `n`'s increase), when given.
  struct Segment {
    size_t out_end = 0, bows_end = 0;
    Added added;
  };
  void refine_segments(int32_t owner_a, int32_t owner_b, const std::vector<BoundaryVertex>& vertices, size_t i0,
                       size_t i1, std::vector<BoundaryVertex>& out, Added& n, std::vector<Bow>* bows = nullptr,
                       std::vector<Segment>* each = nullptr) const;
  // Measures the segments of a line as they are (a simplified line): the largest distance from a
  // segment's midpoint to the locus, metric units (land segments left out).
  double measure(int32_t owner_a, int32_t owner_b, const std::vector<BoundaryVertex>& vertices) const;
  double tolerance() const { return tol_; }
  // A length in metric units as CRS units near p (over the smaller of the two scales there).
  double crs_length(double length, Vec2 p) const {
    const Vec2 s = scale_.at(p);
    return length / std::min(s.x, s.y);
  }

 private:
  struct End;
  void between(const End& u, const End& v, int depth, bool lifted, int32_t a, int32_t b, std::vector<End>& out,
               Added& n, std::vector<Bow>* bows = nullptr) const;
  // The distance from the chord's midpoint to the locus (metric units); NaN where not measured
  // (an owner has no site there).
  double midpoint_offset(const BoundaryVertex& u, const BoundaryVertex& v, int32_t a, int32_t b,
                         Bow* bow = nullptr) const;
  // The point that splits a chord: a turning point, an arc's or the locus' point across the
  // middle (two edges of one coast sharing a vertex: one smooth stretch; or, `loose`, where more
  // sites change within the chord: between() keeps what it gives only where the line so refined
  // is simple); false where none checks out.
  bool split(const End& u, const End& v, bool same, bool arcs, double stray, int32_t a, int32_t b, End& mid,
             bool& turning, bool& loose) const;
  // Whether the line u, out[from..], v is simple: no two of its segments cross, and it comes back
  // within a millionth of the chord to none of its vertices but the one before.
  static bool runs_simply(Vec2 u, Vec2 v, const std::vector<End>& out, size_t from);
  // The systems of three sites that can hold a change between u and v: a changing side's two
  // sites against the other side's at u (and, `both_ends`, at v where it differs).
  struct System {
    int32_t s1, s2, t;
  };
  static std::vector<System> systems(const End& u, const End& v, bool both_ends);
  bool turning_point(const End& u, const End& v, int32_t a, int32_t b, double max_off, End& out) const;
  bool across_middle(const End& u, const End& v, int32_t a, int32_t b, double max_off, End& out) const;
  // By sea, where an end of across_middle's perpendicular lies on land: the interval [lo, hi] of
  // the perpendicular's parameter holding the sign change of f nearest its middle, found at sea,
  // with f's values at its ends; false where there is none.
  template <class F>
  static bool sea_bracket(F&& f, double& f0, double& f1, double& lo, double& hi);
  // The ends' two sites' locus point from the chord's middle (Newton's method), within max_off.
  bool onto_locus(const End& u, const End& v, double max_off, End& out) const;
  // Whether p is a locus point of owners a and b (each owner's nearest costs the same there, and
  // no third owner's is lower), as `out` with its sites; checked() asks also within_chord().
  bool checked(Vec2 p, int32_t a, int32_t b, const End& u, const End& v, double max_off, End& out) const;
  bool verified(Vec2 p, int32_t a, int32_t b, const End& u, const End& v, End& out) const;
  // A tip (split(): a wedge of one owner narrower than a cell, cut across by the chord): the
  // turning point where the changing side's two sites and the other side's cost the same, by
  // Newton's method from where the ends' tangents meet and within half that point's distance
  // from the chord's middle (and a chord) of it; anywhere along the chord, beyond its ends too.
  bool tip_point(const End& u, const End& v, int32_t a, int32_t b, End& out) const;
  bool tie_apex(const End& u, const End& v, int32_t a, int32_t b, End& out) const;
  // By sea, the same two sites at both ends but one side's path bending last at another barrier
  // vertex at each (SiteMetric::last_bend): the corner where the two paths cost the same and the
  // other side's site as much, by Newton's method on the three costs, checked like a turning
  // point; false where the bends agree or no such point checks out within the chord.
  bool bend_corner(const End& u, const End& v, int32_t a, int32_t b, double max_off, End& out) const;
  bool tie_edge(const BoundaryVertex& u, const BoundaryVertex& v, int32_t a, int32_t b, End& out, double& off) const;
  // The chord's perpendicular through its middle, max_off either side; whether p lies between
  // the ends along the chord and within max_off of it.
  static std::array<Vec2, 2> perpendicular(const End& u, const End& v, double max_off);
  static bool within_chord(Vec2 p, const End& u, const End& v, double max_off);
  // Arcs (BoundaryVertex::arc: where a reach ends the line is the arc d_s = reach_s): the arc
  // point across a chord of one arc, where the curves of two ends meet (an arc and the locus, or
  // two arcs), and the check of such a point (on the arc, its owner winning inside, the other
  // owner beyond, no third owner between).
  static int32_t arc_site(const BoundaryVertex& v);
  double arc_value(Vec2 p, int32_t site, Vec2& gradient) const;  // d - reach
  double curve_value(const BoundaryVertex& e, Vec2 p, Vec2& gradient) const;
  bool across_arc(const End& u, const End& v, int32_t a, int32_t b, double max_off, End& out) const;
  bool arc_junction(const End& u, const End& v, int32_t a, int32_t b, double max_off, End& out) const;
  bool checked_arc(Vec2 p, int8_t arc, int32_t site, int32_t a, int32_t b, const End& u, const End& v, double max_off,
                   End& out) const;
  double cost(Vec2 p, int32_t site, Vec2& gradient) const;
  void set_normal(End& e) const;
  // The locus normal at `e` of the stretch towards `other` (the sites the two share).
  Vec2 normal_towards(const End& e, const End& other) const;
  const OwnerIndex& index_;
  double tol_, ftol_;
  line_tools::CrsScale scale_;
  double per_crs_;
};

// Whether a boundary vertex lies on an owner's land (distance 0 to one of its two owners), and
// whether a segment runs along such land from end to end (where every point is on the locus).
inline bool on_land(const BoundaryVertex& v) { return v.distance_a == 0.0 || v.distance_b == 0.0; }
inline bool land_segment(const BoundaryVertex& u, const BoundaryVertex& v) { return on_land(u) && on_land(v); }

// The last stage of the lines, once they have their final ends (finish_lines: after
// join_close_tripoints, close_missing_tripoints and end_at_owned_edge): each refined to the
// refiner's tolerance (when given) and measured, then simplified with Douglas-Peucker at `tol`
// CRS units; the statistics (vertices, residuals, points added) summed in line order. On
// `threads` threads, over blocks of segments of every line; the result independent of them.
// With a refiner, `reuse` (an earlier state's segments an edit leaves valid) gives the segments
// it holds instead of refining them again, and `record` gets every segment's refinement (for the
// next state), when given: the lines are the same.
using BoundaryMemo = SegmentMemo<BoundaryVertex, LineRefiner::Added>;
void finish_lines(std::vector<BoundaryLine>& lines, const LineRefiner* refiner, double tol, BoundaryStats& stats,
                  int threads, const SegmentReuse<BoundaryVertex, LineRefiner::Added>* reuse = nullptr,
                  BoundaryMemo* record = nullptr);

// The closed lines that run wholly along another line of the same two owners, to be dropped
// (repeated_loops.cpp): each vertex and each segment's middle within twice the refiner's
// tolerance of that line. Cells of a wedge narrower than a cell near its tip, cut off from the
// rest of it, trace such a loop; refined, it follows the wedge's sides out to the tip, as the
// main line does. Lines already found repeated are not compared against; the result is in order.
std::vector<bool> repeated_loops(const std::vector<BoundaryLine>& lines, const LineRefiner& refiner);

// The links chained into lines per owner pair, finished as finish_lines does (refined with
// `refiner` when given, simplified with Douglas-Peucker at `tol` CRS units), in a deterministic
// order.
std::vector<BoundaryLine> chain_lines(const CrossingSet& x, const TripointSet& t, const Links& links, double tol,
                                      BoundaryStats& stats, const LineRefiner* refiner = nullptr, int threads = 1);
// The crossings no link reaches, as one-vertex lines in crossing order (BoundaryResult::
// lone_crossings).
std::vector<BoundaryLine> lone_crossings(const CrossingSet& x, const Links& links);
// The owner pairs of each tripoint with no line of theirs ending at it (closed lines aside), in
// tripoint order: tripoint index and the indices i < k into its owners.
struct TripointGap {
  size_t tripoint;
  int i, k;
};
std::vector<TripointGap> tripoint_gaps(const std::vector<Tripoint>& tripoints, const std::vector<BoundaryLine>& lines);
// Two tripoints of one owner triple less than a cell apart share the line of one of its owner
// pairs, which crosses no segment between cell centres and so has no crossing to be chained
// from: each such pair of tripoints, both without a line of that owner pair, gets the line
// between them (two vertices) appended to `lines`. `cell`: the grid's cell size (CRS units).
void join_close_tripoints(const std::vector<Tripoint>& tripoints, double cell, std::vector<BoundaryLine>& lines);
// The tripoint of the three `owners` near `start` (Newton's method on their nearest sites' costs,
// the sites taken again where they change): no other owner nearer, within two cells of `start`,
// within `max_distance`. False where none is found.
bool solve_tripoint(const BoundaryGrid& b, std::array<int32_t, 3> owners, Vec2 start, double max_distance,
                    Tripoint& out);
// The vertex of the line of owners a and b (two of t's) that ends at tripoint t.
BoundaryVertex tripoint_vertex(const Tripoint& t, int32_t a, int32_t b);
// Where more owners meet in a dual square than its tripoint search resolved, a tripoint of
// owners a, b, x can be missing: its three lines then show as a line of a and b ending in the
// open and two of (a, x), (b, x) -- each a line ending in the open or a tripoint lacking that
// pair's line -- all within two cells of each other. The tripoint is solved (Newton's method on
// the three owners' nearest sites from the open end, accepted where no other owner is nearer
// and within two cells), appended to `tripoints`, the open ends carried to it and each lacking
// tripoint joined to it by a line of two vertices. Counts them in stats.missing_tripoints_found.
// A tripoint beyond the field's `max_distance` (or, with an adjusted index, beyond a reach: the
// index finds no site there) is not added: there the lines end on the owned area's edge.
void close_missing_tripoints(const BoundaryGrid& b, double max_distance, std::vector<Tripoint>& tripoints,
                             std::vector<BoundaryLine>& lines, BoundaryStats& stats);
// Lines that stop where the reaches of an adjusted index (OwnerIndex::deepest, its cap, the
// field's max distance, included) end the owned area; with a plain index nothing moves.
// Extraction leaves such an end at the last crossing of two owners' cells, up to a cell short of
// the edge (or, where unowned sea thinner than a cell pokes between the two cells, on a stretch
// that is not the boundary at all). Each open end off the frame of the outermost centres and not
// at a tripoint inside the owned area gets its vertices beyond either owner's reach dropped and
// the junction appended: the point near it where both owners are just at their reach (Newton;
// within two cells), as a vertex with that stretch's arc flag. Where no junction is found the
// line is left as it was. Counts the ends moved in stats.ends_on_owned_edge.
void end_at_owned_edge(const BoundaryGrid& b, double max_distance, const std::vector<Tripoint>& tripoints,
                       std::vector<BoundaryLine>& lines, BoundaryStats& stats);
// Lines that stop at a barrier (a metric with domain edges: the distance by sea). Extraction
// leaves such an end at the last crossing of two owners' cells, up to a cell short of the coast
// or boom (cells a barrier parts are not neighbours). Each open end off the frame of the
// outermost centres and not at a tripoint gets the junction appended: the point of a barrier
// edge within four cells of it where the two owners' distances by sea are equal (approached from
// the end's side, SiteMetric::domain_edge_point), no third owner nearer, and the way from the
// end to it open; of several, the nearest. Where none is found the line is left as it was.
// Where that junction lies behind the end (seen along the line's last chord), the line goes on
// where no cells show it (round an islet in a channel narrower than a cell, the junction then on
// another stretch of the locus): the end is followed along the locus instead
// (locus_follow::follow_on, an eighth of a cell a step, up to eight cells) to the coast it
// reaches, and keeps the junction only where the follower gets to none, meets no third owner
// (the end goes on to a tripoint: left open for complete_tripoints) and no open end of the same
// owners (left to be joined), and the way back to the junction does not run along the line itself.
// Counts the ends moved in stats.ends_on_barriers, those followed also in stats.ends_followed.
void end_at_barriers(const BoundaryGrid& b, const std::vector<Tripoint>& tripoints, std::vector<BoundaryLine>& lines,
                     BoundaryStats& stats);
// By sea, a line whose locus turns on land: where one side's site changes between two vertices
// and the stretches' tangents there (from their neighbouring vertices) meet on land within four
// cells, the locus meets the coast before it would turn (the cells, a cell apart across a coast
// that cuts their square's corner, linked the two stretches by one chord). The line is parted
// there, each part ending at its junction with the coast (found as end_at_barriers finds one,
// ahead of its end). So is a line whose chord between two vertices crosses a barrier, or lies far
// off the locus (a twentieth of the chord at its middle) by a coast, where the locus followed
// from each vertex towards the other reaches a coast first (a bisector through an islet narrower
// than a cell; one owner's sea touching an island's face between the two vertices): each part
// ends where its walk met the coast. Counts the partings in stats.turns_on_land, their ends in
// stats.ends_on_barriers.
void part_where_turning_on_land(const BoundaryGrid& b, std::vector<BoundaryLine>& lines, BoundaryStats& stats);
// By sea, two open ends of lines of the same two owners (off the frame, not at a tripoint, not on
// a barrier) within four cells of each other, with the way between them open and the locus
// passing between them (the two owners' costs change sign on the chord's perpendicular through its
// middle, within a sixteenth, an eighth, a quarter or half the chord's length as far as the way
// from the middle is open: an islet beside the chord leaves the nearer points to tell): the line
// broken where it passes a coast closer than a cell (the cells beside it are parted by land, though
// the locus stays at sea). Joined, nearest pairs first, where the locus walked on from one of the
// two reaches the other without running along a line of the same owners (walk_runs_along: it would
// come round that line's far end, and draw the line twice) (narrow_level's walk, `per` as
// follow_open_ends'; one line's two ends make it a ring); the points walked are the join's own
// vertices (a chord between the two ends may cut an islet's corner that the locus goes round),
// which finish_lines then refines. Counts the joins in stats.ends_joined.
void join_parted_ends(const BoundaryGrid& b, double per, const std::vector<Tripoint>& tripoints,
                      std::vector<BoundaryLine>& lines, BoundaryStats& stats);
// By sea, each open end left (off the frame and the grid's edge, not at a tripoint, not on a
// barrier: where the cells stop showing the locus, in a fjord narrower than two cells whose land
// parts them, or short of a coast) followed on along its locus (locus_follow::follow_on, an eighth
// of a cell a step, up to eight cells) to another open end of the same two owners (the two lines
// joined through the points walked; its own other end makes a ring) or a coast; left as it was
// where the walk is lost, runs along another line of the same owners (walk_runs_along: a stretch
// the cells showed), or reaches the frame of the cell centres (a line there goes on to the grid's
// edge). Counts the ends followed in stats.ends_followed, the joins also in
// stats.ends_joined, the coasts reached in stats.ends_on_barriers. The walk's steps are at most
// half the way to the nearer side (locus_follow::Level::clearance), so a locus going on up a
// sliver of sea metres wide between two owners' land is walked up it, to where the two coasts
// meet (a ten-thousandth of a cell apart, or their crossing reached straight along the two edges'
// bisector). Not run where a maximum distance (`max_distance` finite) or a reach ends the owned
// area: lines end on its edge there. `per`: metric units per CRS unit, the larger of the two
// axes' in the grid's middle (a step in CRS units from a length then errs short).
void follow_open_ends(const BoundaryGrid& b, double max_distance, double per, const std::vector<Tripoint>& tripoints,
                      std::vector<BoundaryLine>& lines, BoundaryStats& stats);
// By sea, after follow_open_ends: each line end still open walked on along its locus as there,
// and where the walk meets a third owner (its points leave the band of the two), carried to the
// tripoint of the three solved there (solve_tripoint; one already known within a thousandth of a
// cell, or a new one: stats.missing_tripoints_found) -- a tripoint whose square's centres are
// land; the walk also stops at a tripoint of both owners lacking their line. Then each tripoint
// off the frame lacking the line of two of its owners gets it: walked from the point a hundredth
// of a cell off it where their locus leaves it away from the third owner (the one such point) to
// a coast, the frame of the cell centres, an open end of their line (joined), another tripoint
// lacking it, or a tripoint made where a fourth owner comes nearer, whose own missing lines are
// walked in turn (stats.legs_walked). A walk that runs along a line of the same owners is not
// taken. Not run where follow_open_ends is not.
void complete_tripoints(const BoundaryGrid& b, double max_distance, double per, std::vector<Tripoint>& tripoints,
                        std::vector<BoundaryLine>& lines, BoundaryStats& stats);

// The level of the locus of owners oa and ob for the follower (locus_follow.hpp): their balance
// (cost_gap), and the band where no third owner is nearer.
locus_follow::Level pair_level(const BoundaryGrid& b, int32_t oa, int32_t ob);
// pair_level's, with steps of at most half the way to the nearer side (`per`: metric units per CRS
// unit) and an end where the two sides meet (a sliver of sea along a land border walked up).
locus_follow::Level narrow_level(const BoundaryGrid& b, int32_t oa, int32_t ob, double per);
// Whether the chord p-q runs along the locus of owners oa and ob: at sixteen points of it no third
// owner between them (ties within 4 ftol aside), and their costs within a tenth of the chord's
// length of each other (a point that far off the locus has them apart by as much or more).
bool along_locus(const BoundaryGrid& b, int32_t oa, int32_t ob, Vec2 p, Vec2 q);
// Whether points walked along the locus of owners oa and ob (a quarter of a cell from either end
// aside) run along a line of theirs other than lines[own] (-1: none), within a fiftieth of a cell:
// the cells showed that stretch.
bool walk_runs_along(const BoundaryGrid& b, const std::vector<BoundaryLine>& lines, const std::vector<Vec2>& points,
                     int32_t oa, int32_t ob, int64_t own);
// Appends the points walked along the locus of `line`'s owners (points[0], the line's back end,
// left out) as its vertices, with the turning point between two of them where one side's nearest
// site changes.
void append_walked(const BoundaryGrid& b, BoundaryLine& line, const std::vector<Vec2>& points);
// A change of owner along a coast (a junction of the owners' locus with a barrier's edge): where,
// and the two owners, lo < hi.
struct CoastChange {
  Vec2 p;
  int32_t lo = 0, hi = 0;
};
// By sea, a crossing linked to none (`lone`, lone_crossings) where the line crosses a channel
// narrower than the squares around it (a barrier parts every other pair of their corners): made a
// line of its own when it reaches a barrier on both sides (end_at_barriers' junction one way,
// then the nearest on the far side), and taken out of `lone`. Counts as end_at_barriers.
void cross_channels(const BoundaryGrid& b, std::vector<BoundaryLine>& lone, std::vector<BoundaryLine>& lines,
                    BoundaryStats& stats);
// By sea, the lines where no two cells show the change of owner (a sliver of sea along a land
// border that holds no cell centre, a channel whose cells meet only diagonally, sea between the
// last cells and the grid's edge): the barrier edges that may come within the grid are walked where
// the cells may not show their coast (within a cell of the grid's edge, or the four centres round a
// point of it all on land, or only two diagonal ones at sea), on their sea side(s), at their ends
// and along an edge longer than two cells about every cell, inside the grid. So is, whole, every
// stretch of a closed ring inside the grid between two line ends next to each other along it (ends
// on the barrier) where the owner just past the first is not the owner just before the second: a
// sound between two islands inside one dual square whose corners are all at sea hides a change
// there. Where the owner changes (both owned, within `max_distance`) the junction is solved as
// end_at_barriers solves it. A junction that no end of a line of its two owners explains (an end on
// the barrier at the same point, an open end within two cells, a tripoint of both within two cells)
// is a line missing: such junctions of the same two owners within four cells of each other, the way
// between them open and their costs nearly equal at its middle (within a quarter of the chord's
// length), are paired nearest first and each pair appended as a line of two vertices on the
// barriers (finish_lines refines the chord onto the locus). A junction left within a cell of the
// grid's edge gets the line from it to the edge (the point of the nearest side, within a cell and a
// half, where the costs are equal, the way open; region_edges leaves an end on the edge where it
// is). A junction left after that is followed along the locus from it into the sea (narrow_level's
// walk, `per` as follow_open_ends'), and the points walked make its line where the walk reaches a
// coast, another junction left, or an open end of a line of the same owners (joined to it), and
// does not run along a line of theirs (walk_runs_along): a pocket of sea whose cells meet the rest
// only corner to corner, the line from one coast across it to a coast the cells show. A line drawn
// to an island may leave that island's other change hidden in turn, so the stretches are found
// again from the lines drawn, and the new ones walked, up to 16 rounds (a chain of islands inside
// cells, one more a round). Where islands overlap (or states' land meets), each ring whose land
// meets that of a ring with such a stretch is walked whole too: the change may lie on its coast,
// between where the first ring's coast goes under its land and where it comes out. Counts the
// lines in stats.channels_crossed; appends the junctions no round explained to `left` (a later
// stage may still draw their lines: unexplained_changes counts them at the end).
void cross_hidden_channels(const BoundaryGrid& b, double max_distance, double per,
                           const std::vector<Tripoint>& tripoints, std::vector<BoundaryLine>& lines,
                           BoundaryStats& stats, std::vector<CoastChange>& left);
// How many of the changes of owner along coasts in `left` (cross_hidden_channels') no end of
// `lines` explains (an end on the barrier at it, an open end or a tripoint of both owners within
// two cells), each counted once: stats.coast_changes_unexplained.
int64_t unexplained_changes(const BoundaryGrid& b, const std::vector<Tripoint>& tripoints,
                            const std::vector<BoundaryLine>& lines, const std::vector<CoastChange>& left);

// Whether no owner but a and b comes between them at p: their nearest there into ha and hb, and no
// third owner's cost below the lesser of theirs by more than 4 ftol (ties with it included).
inline bool no_third_between(const BoundaryGrid& b, int32_t a, int32_t o, Vec2 p, OwnerIndex::Hit& ha,
                             OwnerIndex::Hit& hb) {
  ha = b.index.nearest_of(p, a);
  hb = b.index.nearest_of(p, o);
  const OwnerIndex::Hit third = b.index.nearest_third(p, a, o, std::max(ha.cost, hb.cost));
  return third.site == kNoSite || third.cost >= std::min(ha.cost, hb.cost) - 4.0 * b.ftol;
}

// Owner a's cost less owner o's at p (each its nearest site's; 0 on their locus).
inline double cost_gap(const BoundaryGrid& b, int32_t a, int32_t o, Vec2 p) {
  return b.index.nearest_of(p, a).cost - b.index.nearest_of(p, o).cost;
}

// Whether p is one of `tripoints` (exactly: a line's end placed at it).
inline bool at_tripoint(const std::vector<Tripoint>& tripoints, Vec2 p) {
  return std::any_of(tripoints.begin(), tripoints.end(), [&](const Tripoint& t) { return t.p == p; });
}

// Whether a line's end is open: not on a barrier, on or beyond the frame of the cell centres, nor
// at one of `tripoints` (where the cells stopped showing its locus).
inline bool open_line_end(const BoundaryGrid& b, const std::vector<Tripoint>& tripoints, const BoundaryVertex& v) {
  return !v.on_barrier && !line_tools::on_centre_frame(b.g, v.p) && !line_tools::outside_frame(b.g, v.p) &&
         !at_tripoint(tripoints, v.p);
}

// Whether a point found on the locus of a and o (a root of cost_gap) counts as one: no third owner
// between them, and their costs within 1e3 ftol (the root finder's tolerance, with room for a
// search along a coast's edge). Their nearest into ha and hb.
inline bool on_pair_locus(const BoundaryGrid& b, int32_t a, int32_t o, Vec2 p, OwnerIndex::Hit& ha,
                          OwnerIndex::Hit& hb) {
  return no_third_between(b, a, o, p, ha, hb) && std::abs(ha.cost - hb.cost) <= 1e3 * b.ftol;
}

// The boundary vertex at p between the hits of its two sides (each owner's nearest there).
inline BoundaryVertex vertex_between(Vec2 p, const OwnerIndex::Hit& a, const OwnerIndex::Hit& b) {
  return BoundaryVertex{p,          a.site,    b.site, 0.5 * (a.distance + b.distance), std::abs(a.cost - b.cost),
                        a.distance, b.distance};
}

// A crossing where a reach ends (Feature::reach) rather than where two owners' costs meet (one
// of find_crossings' cases, boundaries.cpp).
// Where the costs of owners x (nearest towards p0) and y (towards p1) jump between two positions
// of segment p0-p1 instead of crossing: a site's reach ends there (x's nearest inside it
// reaching its reach) or begins (y's). The arc point solves d_s = reach_s on the segment by
// Newton's method with the site's gradient; the vertex has that site on its side (arc 1: x's,
// 2: y's, in x-y order) and the other side's nearest beyond. `between`: the larger of the two
// winners' costs there, which a third owner must beat to come between. site kNoSite: no reach
// explains the jump (left as it was).
struct ArcPoint {
  int32_t site = kNoSite;
  double t = 0.0, between = 0.0;
  BoundaryVertex vertex;
};

template <class NearestOf>
ArcPoint reach_arc(const OwnerIndex& index, NearestOf&& nearest_of, Vec2 p0, Vec2 p1, int32_t x, int32_t y, double t0,
                   double t1, double t, double ftol) {
  ArcPoint out;
  const SiteMetric& m = index.metric();
  const double step = 1e-7;
  const Vec2 inside = line_tools::lerp(p0, p1, std::max(t0, t - step)),
             beyond = line_tools::lerp(p0, p1, std::min(t1, t + step));
  const OwnerIndex::Hit xin = nearest_of(inside, x, nullptr), yin = nearest_of(beyond, y, nullptr);
  if (xin.site == kNoSite || yin.site == kNoSite) return out;
  const Vec2 p = line_tools::lerp(p0, p1, t);
  const double gx = std::abs(m.distance(p, xin.site) - index.reach_of(xin.site));
  const double gy = std::abs(m.distance(p, yin.site) - index.reach_of(yin.site));
  if (!std::isfinite(std::min(gx, gy))) return out;
  const bool x_side = gx <= gy;
  const int32_t s = x_side ? xin.site : yin.site;
  const double r = index.reach_of(s);
  Vec2 grad;
  auto g = [&](double u) { return m.distance_and_gradient(line_tools::lerp(p0, p1, u), s, grad) - r; };
  auto g_slope = [&](double u) {
    const double value = g(u);
    return std::pair{value, grad.x * (p1.x - p0.x) + grad.y * (p1.y - p0.y)};
  };
  // x's site is inside its reach towards p0; y's towards p1.
  const double lo = std::max(t0, t - 1e-6), hi = std::min(t1, t + 1e-6);
  out.t = line_tools::newton_then_bracket(g, g_slope, t, lo, hi, x_side, ftol);
  const Vec2 q = line_tools::lerp(p0, p1, out.t);
  const double ds = m.distance(q, s);
  // The other side's nearest where it wins: beyond the arc for y, inside it for x.
  const OwnerIndex::Hit other = x_side ? nearest_of(beyond, y, nullptr) : nearest_of(inside, x, nullptr);
  const double d_other = m.distance(q, other.site);
  const double c_s = ds / index.weight_of(s), c_other = d_other / index.weight_of(other.site);
  out.site = s;
  out.between = std::max(c_s, c_other);
  out.vertex = BoundaryVertex{q,
                              x_side ? s : other.site,
                              x_side ? other.site : s,
                              0.5 * (ds + d_other),
                              std::abs(ds - r),
                              x_side ? ds : d_other,
                              x_side ? d_other : ds,
                              static_cast<int8_t>(x_side ? 1 : 2)};
  return out;
}

}  // namespace rv::boundary_stages
