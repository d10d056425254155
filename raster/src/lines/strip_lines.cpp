// StripLines (rv/lines/strip_lines.hpp): the boundary and limit stages (boundary_stages.hpp,
// limit_stages.hpp) driven strip by strip, and extract_boundaries / extract_limits as the same
// driver fed one whole field, so that the streamed and the whole results cannot differ.
//
// Why the lags: a stage over row r reads the rows after it, so with rows [0, have) in hand
//   - crossings of row r need cells of rows r and r + 1:            rows < have - 1;
//   - tripoints of square row r need the crossings of rows r, r + 1: rows < crossings - 1;
//   - links of square row r need the tripoints filed in squares r - 1 .. r + 1, and a tripoint
//     is filed up to one square from the square it was found from:  rows < tripoints - 2.
// Each stage appends in row order, so the pieces are in the whole field's order and numbered as
// there; the chains are made once the last row is in. Only the rows from the earliest stage's
// position on are kept between strips (FieldRows::keep_from), a handful.
#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/limit_stages.hpp"
#include "lines/line_pieces.hpp"
#include "lines/line_tools.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/strip_lines.hpp"

namespace rv {

using namespace line_tools;

namespace {

using Pieces = LinePieces::Data;

// The first of `n` pieces whose row (row_of(i), non-decreasing in i) is at least r.
template <class RowOf>
size_t first_at(size_t n, int64_t r, RowOf&& row_of) {
  size_t lo = 0, hi = n;
  while (lo < hi) {
    const size_t mid = (lo + hi) / 2;
    if (row_of(mid) < r)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

// A base's site in this extraction's seeds (`sites` of them).
int32_t mapped_site(std::span<const int32_t> site_map, int32_t s, size_t sites) {
  if (s == kNoSite) return s;
  const int32_t m = site_map.empty()                                     ? s
                    : s >= 0 && static_cast<size_t>(s) < site_map.size() ? site_map[static_cast<size_t>(s)]
                                                                         : kNoSite;
  if (m == kNoSite)
    throw Error(ErrorKind::invalid_argument, "line pieces taken from a base name a site the edit removed");
  if (m < 0 || static_cast<size_t>(m) >= sites)
    throw Error(ErrorKind::invalid_input, "line pieces taken from a base do not fit its seeds");
  return m;
}

// An owner code of the pieces, checked against the seeds' `owners`.
int32_t checked_owner(int32_t o, size_t owners) {
  if (o < 0 || static_cast<size_t>(o) > owners)
    throw Error(ErrorKind::invalid_input, "line pieces taken from a base do not fit its seeds");
  return o;
}

// A base's pieces are checked against the seeds they are taken into, not only their sites' and
// owners' ranges: a base's checksum is no key, and a piece whose coordinates or distances were
// changed would bend a line without a word. A vertex taken must lie on its edge (between the two
// cell centres it joins) and be what the metric measures there, to a hair: the same
// computation gives the same distances, and a moved vertex is off the locus.
void refuse_piece(const char* what) {
  throw Error(ErrorKind::invalid_input,
              std::string("line pieces taken from a base do not fit its seeds: a ") + what + " is not where it says");
}
void check_on_edge(const GridSpec& g, int64_t edge, Vec2 p) {
  const int64_t cell = edge / 2, c = cell % g.width, r = cell / g.width;
  const Vec2 a = line_tools::centre(g, c, r);
  const Vec2 b = edge % 2 == 0 ? line_tools::centre(g, c + 1, r) : line_tools::centre(g, c, r + 1);
  const double slack = 1e-6 * g.res;
  if (!(p.x >= std::min(a.x, b.x) - slack && p.x <= std::max(a.x, b.x) + slack && p.y >= std::min(a.y, b.y) - slack &&
        p.y <= std::max(a.y, b.y) + slack))
    refuse_piece("crossing");
}
// Whether a stored distance is the one measured now (`scale`: a cell in metric units).
bool measured(double stored, double now, double scale) {
  return std::abs(stored - now) <= 1e-9 * std::max({std::abs(now), scale, 1e-300});
}
void check_crossing(const GridSpec& g, const SiteMetric& metric, double cell, int64_t edge, const BoundaryVertex& v) {
  check_on_edge(g, edge, v.p);
  if (v.arc != 0) return;  // a reach's arc (never taken: rows with reaches are extracted again)
  const double da = metric.distance(v.p, v.site_a), db = metric.distance(v.p, v.site_b);
  if (!measured(v.distance_a, da, cell) || !measured(v.distance_b, db, cell) ||
      !measured(v.residual, std::abs(da - db), cell))
    refuse_piece("boundary vertex");
}
void check_tripoint(const SiteMetric& metric, double cell, const Tripoint& tp) {
  double d[3];
  for (int k = 0; k < 3; ++k) {
    d[k] = metric.distance(tp.p, tp.sites[k]);
    if (!measured(tp.distances[k], d[k], cell)) refuse_piece("tripoint");
  }
  if (!measured(tp.residual, std::max({std::abs(d[0] - d[1]), std::abs(d[0] - d[2]), std::abs(d[1] - d[2])}), cell))
    refuse_piece("tripoint");
}

// Whether edge `edge` (of a grid `W` x `H`) lies where neither the field's cells nor a measurement
// by the metric changed: its two cells, widened as a kept segment's are (SegmentReuse::kMargin),
// in tiles `changed` flags 0. A vertex on it is placed by measurements along it alone.
bool edge_unchanged(const ChangedTiles& changed, int64_t W, int64_t H, int64_t edge) {
  constexpr int64_t M = SegmentReuse<BoundaryVertex, boundary_stages::LineRefiner::Added>::kMargin;
  const int64_t cell = edge / 2, c = cell % W, r = cell / W;
  return tiles_unchanged(changed, W, H, c - M, r - M, c + 1 + M, r + 1 + M);
}

// Room for `n` more elements in a vector or an unordered map, growing at least twofold (a base's
// rows are taken in a few large calls, or, in a streamed edit, in many small ones).
template <class C>
void room_for(C& c, size_t n) {
  if constexpr (requires { c.capacity(); }) {
    if (c.size() + n > c.capacity()) c.reserve(std::max(c.size() + n, 2 * c.capacity()));
  } else {
    if (static_cast<double>(c.size() + n) > static_cast<double>(c.bucket_count()) * c.max_load_factor())
      c.reserve(std::max(c.size() + n, 2 * c.size()));
  }
}

// One boundary extraction in progress.
struct BoundaryRun {
  boundary_stages::BoundaryGrid b;
  double tol;             // simplification, CRS units
  double line_tolerance;  // BoundaryOptions::line_tolerance, metric units (0: measure only)
  double cell;            // one cell in metric units
  double max_distance;    // BoundaryOptions::max_distance
  boundary_stages::CrossingSet x;
  boundary_stages::TripointSet t;
  boundary_stages::Links links;
  std::vector<std::array<int64_t, 2>> unplaced;
  BoundaryStats stats;
  boundary_stages::RowCounts counts;                         // per row: what stats counted there (b.counts points here)
  int64_t crossings_to = 0, tripoints_to = 0, links_to = 0;  // rows done: [0, *_to)
  const boundary_stages::CrossingFromBase* from_base = nullptr;  // StripLines::take_measured

  // Every stage as far as rows [0, have) allow (to the end when they are all in).
  void advance(int64_t have) {
    using namespace boundary_stages;
    const bool all = have == b.H;
    const int64_t xc = all ? b.H : std::max(crossings_to, have - 1);
    find_crossings(b, crossings_to, xc, x, stats, from_base);
    crossings_to = xc;
    const int64_t tp = all ? b.H : std::max(tripoints_to, crossings_to - 1);
    find_tripoints(b, x, tripoints_to, tp, t, unplaced, stats);
    tripoints_to = tp;
    const int64_t ln = all ? b.H : std::max(links_to, tripoints_to - 2);
    const Links part = link_squares(b, x, t, links_to, ln, stats);
    for (size_t i = 0; i < part.links.size(); ++i)
      links.add(part.links[i][0], part.links[i][1], part.pair[i], part.row[i]);
    links_to = ln;
  }

  // Rows [*_to, row1) of every stage taken from the base's pieces `p`.
  void take(const Pieces::Boundary& p, int64_t W, int64_t row1, std::span<const int32_t> site_map, bool verify) {
    using namespace boundary_stages;
    auto edge_row = [W](int64_t e) { return e / 2 / W; };
    const size_t x0 =
        first_at(p.crossings.size(), crossings_to, [&](size_t i) { return edge_row(p.crossings[i].edge); });
    const size_t x1 = first_at(p.crossings.size(), row1, [&](size_t i) { return edge_row(p.crossings[i].edge); });
    const size_t t0 = first_at(p.tripoints.size(), tripoints_to, [&](size_t i) { return p.tripoint_row[i]; });
    const size_t t1 = first_at(p.tripoints.size(), row1, [&](size_t i) { return p.tripoint_row[i]; });
    // A base node's number here: the pieces before the first taken one are this run's own, equal
    // to the base's near the rows taken, so every base number moves by one offset.
    const int64_t dx = static_cast<int64_t>(x.crossings.size()) - static_cast<int64_t>(x0);
    const int64_t dt = static_cast<int64_t>(t.tripoints.size()) - static_cast<int64_t>(t0);
    const size_t sites = b.owner_of_site.size();
    const size_t owners = static_cast<size_t>(b.index.metric().seeds().owner_count());
    // Room for the rows' crossings at once (a session's step takes most of the grid's rows in two
    // calls, and rehashing the index as it grew cost more than filling it).
    room_for(x.on_edge, x1 - x0);
    room_for(x.crossings, x1 - x0);
    for (size_t i = x0; i < x1; ++i) {
      Crossing cr = p.crossings[i];
      cr.v.site_a = mapped_site(site_map, cr.v.site_a, sites);
      cr.v.site_b = mapped_site(site_map, cr.v.site_b, sites);
      checked_owner(cr.owner_lo, owners);
      checked_owner(cr.owner_hi, owners);
      if (cr.edge < 0 || cr.edge >= 2 * W * b.H) refuse_piece("crossing");
      if (verify) check_crossing(b.g, b.index.metric(), cell, cr.edge, cr.v);
      auto [it, fresh] = x.on_edge.try_emplace(cr.edge, static_cast<int32_t>(x.crossings.size()), 0);
      ++it->second.second;
      x.crossings.push_back(cr);
    }
    for (size_t i = first_at(p.slivers.size(), crossings_to, [&](size_t k) { return edge_row(p.slivers[k].first); });
         i < p.slivers.size() && edge_row(p.slivers[i].first) < row1; ++i)
      x.sliver_at.emplace(p.slivers[i].first, checked_owner(p.slivers[i].second, owners));
    for (size_t i = t0; i < t1; ++i) {
      Tripoint tp = p.tripoints[i];
      for (int32_t& s : tp.sites) s = mapped_site(site_map, s, sites);
      for (const int32_t o : tp.owners) checked_owner(o, owners);
      if (verify) check_tripoint(b.index.metric(), cell, tp);
      file_tripoint(b, t, tp, p.tripoint_row[i]);
    }
    for (const auto& u : p.unplaced)
      if (u[1] >= tripoints_to && u[1] < row1) unplaced.push_back(u);
    const size_t l0 = first_at(p.links.size(), links_to, [&](size_t i) { return p.link_row[i]; });
    const size_t l1 = first_at(p.links.size(), row1, [&](size_t i) { return p.link_row[i]; });
    auto node = [&](int32_t n) {
      return static_cast<int32_t>(n >= 0 ? n + dx : tripoint_node(static_cast<int32_t>(-1 - n + dt)));
    };
    for (size_t i = l0; i < l1; ++i) links.add(node(p.links[i][0]), node(p.links[i][1]), p.link_pair[i], p.link_row[i]);
    // The per-row statistics of the rows taken, each counter from its own stage's position
    // (finish() sums them).
    auto take_counts = [&](int64_t from, std::initializer_list<RowCounts::Counter> which) {
      for (int64_t r = from; r < row1; ++r)
        for (const RowCounts::Counter k : which) counts.add(r, k, p.counts[static_cast<size_t>(r)][k]);
    };
    take_counts(crossings_to, {RowCounts::crossings, RowCounts::sliver_crossings, RowCounts::unresolved_slivers});
    take_counts(tripoints_to, {RowCounts::multi_owner_squares});
    take_counts(links_to, {RowCounts::saddles});
    crossings_to = tripoints_to = links_to = row1;
    b.rows.restart();
  }

  Pieces::Boundary pieces() const {
    Pieces::Boundary p;
    p.crossings = x.crossings;
    p.slivers = sorted_slivers();
    p.tripoints = t.tripoints;
    p.tripoint_row = t.found_row;
    p.links = links.links;
    p.link_pair = links.pair;
    p.link_row = links.row;
    p.unplaced = unplaced;
    p.counts = counts.rows;
    return p;
  }
  // The sliver crossings' owners by edge, in edge order (the map's order is not the pieces').
  std::vector<std::pair<int64_t, int32_t>> sorted_slivers() const {
    std::vector<std::pair<int64_t, int32_t>> out(x.sliver_at.begin(), x.sliver_at.end());
    std::sort(out.begin(), out.end());
    return out;
  }
  // After finish() (which reads them last), the pieces but the tripoints moved into `p`: finish()
  // takes the tripoints (and may add to them), so keep_pieces copies them before.
  void move_pieces(Pieces::Boundary& p) {
    p.crossings = std::move(x.crossings);
    p.slivers = sorted_slivers();
    p.links = std::move(links.links);
    p.link_pair = std::move(links.pair);
    p.link_row = std::move(links.row);
    p.unplaced = std::move(unplaced);
    p.counts = std::move(counts.rows);
  }

  BoundaryResult finish(const SegmentReuse<BoundaryVertex, boundary_stages::LineRefiner::Added>* reuse = nullptr,
                        boundary_stages::BoundaryMemo* record = nullptr) {
    using namespace boundary_stages;
    // The stages' counters are the sums of their rows' (rows taken from a base bring theirs).
    int64_t* counter[RowCounts::kCounters] = {&stats.crossings, &stats.sliver_crossings, &stats.unresolved_slivers,
                                              &stats.multi_owner_squares, &stats.saddles};
    for (int k = 0; k < RowCounts::kCounters; ++k) {
      *counter[k] = 0;
      for (const auto& row : counts.rows) *counter[k] += row[static_cast<size_t>(k)];
    }
    count_unresolved(b, x, t, unplaced, stats);
    BoundaryResult result;
    result.stats = stats;
    // The lines get their final ends first, then are refined, measured and simplified as they
    // will be written (finish_lines): every segment of the output, the ends' too, follows the
    // locus to the tolerance.
    result.lines = chain_lines(x, t, links, 0.0, result.stats);
    join_close_tripoints(t.tripoints, b.g.res, result.lines);
    close_missing_tripoints(b, max_distance, t.tripoints, result.lines, result.stats);
    end_at_owned_edge(b, max_distance, t.tripoints, result.lines, result.stats);
    end_at_barriers(b, t.tripoints, result.lines, result.stats);
    part_where_turning_on_land(b, result.lines, result.stats);
    // Metric units per CRS unit in the grid's middle, the larger of the two axes'.
    const CrsScale scale(b.index.metric(), line_tools::centre(b.g, b.W / 2, b.H / 2), b.g.res);
    const double per = std::max(scale.at0.x, scale.at0.y);
    join_parted_ends(b, per, t.tripoints, result.lines, result.stats);
    result.lone_crossings = lone_crossings(x, links);
    cross_channels(b, result.lone_crossings, result.lines, result.stats);
    std::vector<CoastChange> changes_left;
    cross_hidden_channels(b, max_distance, per, t.tripoints, result.lines, result.stats, changes_left);
    follow_open_ends(b, max_distance, per, t.tripoints, result.lines, result.stats);
    // A line of no length (its vertices all within a millionth of a cell of its first: two
    // crossings placed at one cell centre on the locus, each to the root's tolerance, linked)
    // draws nothing and is no line (two tripoints a thousandth of a cell apart keep theirs). Taken
    // out before complete_tripoints, which would take one at a tripoint for its line there.
    std::erase_if(result.lines, [&](const BoundaryLine& l) {
      if (l.closed || l.vertices.empty()) return false;
      const Vec2 p = l.vertices.front().p;
      return std::all_of(l.vertices.begin(), l.vertices.end(), [&](const BoundaryVertex& v) {
        return std::hypot(v.p.x - p.x, v.p.y - p.y) <= 1e-6 * b.g.res;
      });
    });
    complete_tripoints(b, max_distance, per, t.tripoints, result.lines, result.stats);
    result.stats.coast_changes_unexplained += unexplained_changes(b, t.tripoints, result.lines, changes_left);
    const LineRefiner refiner(b.index, line_tolerance, b.ftol, scale, per);
    finish_lines(result.lines, &refiner, tol, result.stats, b.threads, reuse, record);
    for (const Tripoint& tp : t.tripoints) {
      const bool land = tp.distances[0] == 0.0 || tp.distances[1] == 0.0 || tp.distances[2] == 0.0;
      double& worst = land ? result.stats.max_residual_on_land : result.stats.max_residual;
      worst = std::max(worst, tp.residual);
    }
    result.tripoints = std::move(t.tripoints);
    return result;
  }
};

// One limit line set (a distance, all owners or one) in progress.
struct LimitRun {
  limit_stages::Target t;
  limit_stages::InsideRows inside;
  limit_stages::LimitCrossings x;
  std::vector<std::array<int32_t, 2>> links;
  int64_t crossings_to = 0, links_to = 0;
  const limit_stages::LimitVertexFromBase* from_base = nullptr;  // StripLines::take_measured

  void advance(int64_t have) {
    using namespace limit_stages;
    const int64_t H = t.grid.H;
    const bool all = have == H;
    inside_flags(t, inside.row1(), have, inside);
    const int64_t xc = all ? H : std::max(crossings_to, have - 1);
    append(x, limit_crossings(t, inside, crossings_to, xc, from_base));
    crossings_to = xc;
    const int64_t ln = all ? H : std::max(links_to, crossings_to - 1);
    const auto part = limit_links(t, inside, x, links_to, ln);
    links.insert(links.end(), part.begin(), part.end());
    links_to = ln;
    inside.drop_before(links_to);
  }

  // Rows [*_to, row1) of both stages taken from the base's pieces `p`.
  void take(const Pieces::Limit& p, int64_t row1, std::span<const int32_t> site_map, bool verify) {
    const int64_t W = t.grid.W;
    auto edge_row = [&](size_t i) { return p.edges[i] / 2 / W; };
    const size_t x0 = first_at(p.edges.size(), crossings_to, edge_row);
    const size_t x1 = first_at(p.edges.size(), row1, edge_row);
    const int64_t dx = static_cast<int64_t>(x.edges.size()) - static_cast<int64_t>(x0);
    room_for(x.at, x1 - x0);  // (as the boundaries')
    room_for(x.edges, x1 - x0);
    room_for(x.verts, x1 - x0);
    for (size_t i = x0; i < x1; ++i) {
      x.at.emplace(p.edges[i], static_cast<int32_t>(x.edges.size()));
      x.edges.push_back(p.edges[i]);
      LimitVertex v = p.verts[i];
      v.site = mapped_site(site_map, v.site, t.grid.owner_of_site.size());
      if (p.edges[i] < 0 || p.edges[i] >= 2 * W * t.grid.H) refuse_piece("limit vertex");
      if (verify) check_on_edge(t.grid.g, p.edges[i], v.p);
      // The owned area's edge (regions) ends where a reach does: its distance is not D.
      if (verify && t.owner != kOwnedEdge &&
          !measured(v.residual, std::abs(t.grid.metric.distance(v.p, v.site) - t.D), t.grid.cell))
        refuse_piece("limit vertex");
      x.verts.push_back(v);
    }
    const size_t l0 = first_at(p.links.size(), links_to, [&](size_t i) { return p.link_row[i]; });
    const size_t l1 = first_at(p.links.size(), row1, [&](size_t i) { return p.link_row[i]; });
    for (size_t i = l0; i < l1; ++i)
      links.push_back({static_cast<int32_t>(p.links[i][0] + dx), static_cast<int32_t>(p.links[i][1] + dx)});
    crossings_to = links_to = row1;
    inside = limit_stages::InsideRows{};
    inside.row0 = row1;
  }

  Pieces::Limit pieces() const {
    Pieces::Limit p;
    p.link_row = link_rows();
    p.edges = x.edges;
    p.verts = x.verts;
    p.links = links;
    return p;
  }
  // The same, moved out (after the chains, which read them last).
  Pieces::Limit move_pieces() {
    Pieces::Limit p;
    p.link_row = link_rows();
    p.edges = std::move(x.edges);
    p.verts = std::move(x.verts);
    p.links = std::move(links);
    return p;
  }
  // A link joins crossings on two edges of its square, one of them on the square's top row.
  std::vector<int32_t> link_rows() const {
    const int64_t W = t.grid.W;
    std::vector<int32_t> rows;
    rows.reserve(links.size());
    for (const auto& l : links)
      rows.push_back(static_cast<int32_t>(
          std::min(x.edges[static_cast<size_t>(l[0])], x.edges[static_cast<size_t>(l[1])]) / 2 / W));
    return rows;
  }
};

}  // namespace

struct StripLines::Impl {
  GridSpec g;
  const OwnerIndex& index;
  // Limits measure true distances (the breadth of a zone ignores weights): with adjusted seeds,
  // an index of their own.
  std::unique_ptr<const OwnerIndex> plain;
  std::vector<BoundaryRun> boundary;  // none or one
  std::unique_ptr<limit_stages::LimitGrid> limit_grid;
  std::vector<LimitRun> limits;
  double limit_tol = 0.0;             // simplification, CRS units
  double limit_line_tolerance = 0.0;  // LimitOptions::line_tolerance, metric units
  int64_t have = 0;
  bool boundaries_taken = false, limits_taken = false;
  std::string key;
  std::string refine_key;  // key and the line tolerances: what shapes a refinement
  // With keep_refined: the earlier state's segments, the rows changed since, its site map, and
  // what this extraction refines.
  struct Keeping {
    RefinedSegments before;
    ChangedTiles changed;
    std::vector<int32_t> site_map;
    std::shared_ptr<RefinedSegments::Data> now;
  };
  std::optional<Keeping> keeping;
  // With take_measured: the base, its unchanged tiles and site map, and the runs' look-ups.
  struct Measured {
    LinePieces base;
    ChangedTiles changed;
    std::vector<int32_t> site_map;
    boundary_stages::CrossingFromBase crossing;
    std::vector<limit_stages::LimitVertexFromBase> limit;  // per limit run
    std::atomic<int64_t> taken{0};                         // vertices taken (the look-ups run on threads)
  };
  std::unique_ptr<Measured> measured;
  // With keep_pieces: the pieces, filled as the lines are taken (kept_runs: the runs whose pieces
  // are in; a take that failed part way leaves it short, and kept_pieces() refuses).
  std::shared_ptr<Pieces> kept;
  size_t kept_runs = 0;

  Impl(const GridSpec& grid, const OwnerIndex& i) : g(grid), index(i) {}

  void require_all(const char* what) const {
    if (have != g.height)
      throw Error(ErrorKind::invalid_argument, std::string(what) + " asked for before the last row of the field (" +
                                                   std::to_string(have) + " of " + std::to_string(g.height) + " rows)");
  }
};

StripLines::StripLines(const GridSpec& grid, const OwnerIndex& index, const LineRequest& request)
    : impl_(std::make_unique<Impl>(grid, index)) {
  for (double d : request.limit_distances)
    if (!std::isfinite(d) || d <= 0.0)
      throw Error(ErrorKind::invalid_argument, "limit distances must be positive finite numbers");
  Impl& m = *impl_;
  const SiteMetric& metric = index.metric();
  const double cell = cell_metric(m.g, metric);
  const std::vector<int32_t> owners_of_site = owner_of_sites(metric.seeds());
  if (request.boundaries) {
    const BoundaryOptions& o = request.boundary;
    m.boundary.push_back(BoundaryRun{{{},
                                      index,
                                      m.g,
                                      m.g.width,
                                      m.g.height,
                                      resolve_threads(o.threads),
                                      std::max(o.tolerance_cells, 1e-15) * cell,
                                      owners_of_site},
                                     o.simplify_cells * m.g.res,
                                     std::max(o.line_tolerance, 0.0),
                                     cell,
                                     o.max_distance,
                                     {},
                                     {},
                                     {},
                                     {},
                                     {},
                                     {}});
    BoundaryRun& run = m.boundary.back();
    run.counts.rows.assign(static_cast<size_t>(m.g.height), {});
    run.b.counts = &run.counts;
  }
  if (!request.limit_distances.empty() || request.owned_edge) {
    const LimitOptions& o = request.limit;
    if (index.adjusted()) m.plain = std::make_unique<const OwnerIndex>(metric, OwnerIndex::Measure::plain);
    m.limit_grid =
        std::make_unique<limit_stages::LimitGrid>(limit_stages::LimitGrid{{},
                                                                          m.plain ? *m.plain : index,
                                                                          metric,
                                                                          m.g,
                                                                          m.g.width,
                                                                          m.g.height,
                                                                          resolve_threads(o.threads),
                                                                          cell,
                                                                          std::max(o.tolerance_cells, 1e-15) * cell,
                                                                          owners_of_site,
                                                                          !metric.seeds().adjusted(),
                                                                          &index});
    m.limit_tol = o.simplify_cells * m.g.res;
    m.limit_line_tolerance = std::max(o.line_tolerance, 0.0);
    std::vector<int32_t> owners = {0};
    if (o.per_owner) {
      owners.clear();
      for (int32_t k = 1; k <= metric.seeds().owner_count(); ++k) owners.push_back(k);
    }
    // In the whole field's order: by distance, then by owner.
    for (double D : request.limit_distances)
      for (int32_t owner : owners) m.limits.push_back(LimitRun{{*m.limit_grid, owner, D}, {}, {}, {}, 0, 0});
    if (request.owned_edge) m.limits.push_back(LimitRun{{*m.limit_grid, kOwnedEdge, 0.0}, {}, {}, {}, 0, 0});
  }
  // Doubles by their bits: a key equal only where the pieces are.
  std::string& key = m.key;
  auto put = [&key](const char* name, auto v) {
    key += name;
    if constexpr (std::is_floating_point_v<decltype(v)>)
      key += std::to_string(std::bit_cast<uint64_t>(static_cast<double>(v)));
    else
      key += std::to_string(v);
  };
  put("grid ", m.g.width);
  put(" x ", m.g.height);
  put(" at ", m.g.xmin);
  put(" ", m.g.ymax);
  put(" res ", m.g.res);
  put("; adjusted ", static_cast<int>(index.adjusted()));
  key += metric.kind() == SiteMetric::Kind::located_geodesic ? "; located geodesic"
         : metric.kind() == SiteMetric::Kind::geodesic       ? "; geodesic"
                                                             : "; planar";
  if (!metric.straight()) key += "; by sea";
  if (request.boundaries) {
    put("; boundaries tol ", request.boundary.tolerance_cells);
    put(" max ", request.boundary.max_distance);
  }
  if (m.limit_grid) {
    put("; limits tol ", request.limit.tolerance_cells);
    put(" per_owner ", static_cast<int>(request.limit.per_owner));
    put(" owners ", metric.seeds().owner_count());
    put(" owned_edge ", static_cast<int>(request.owned_edge));
    for (double d : request.limit_distances) put(" at ", d);
  }
  auto bits = [](double d) { return std::to_string(std::bit_cast<uint64_t>(d)); };
  m.refine_key = key + "; refined to " + bits(m.boundary.empty() ? 0.0 : m.boundary.front().line_tolerance) + " and " +
                 bits(m.limit_line_tolerance);
}

StripLines::~StripLines() = default;
StripLines::StripLines(StripLines&&) noexcept = default;
StripLines& StripLines::operator=(StripLines&&) noexcept = default;

int64_t StripLines::rows() const { return impl_->have; }

void StripLines::add(const NearestField& strip) {
  const Window w = strip.site.window();
  add(strip, w.row0, w.row0 + w.height);
}

void StripLines::add(const NearestField& strip, int64_t row0, int64_t row1) {
  Impl& m = *impl_;
  check_metric(strip, m.index.metric());
  const Window w = strip.site.window();
  if (!(strip.site.grid() == m.g) || row0 != m.have || row0 < w.row0 || row1 > w.row0 + w.height || row0 >= row1 ||
      w.col0 != 0 || w.width != m.g.width || !(strip.distance.window() == w))
    throw Error(ErrorKind::invalid_argument, "strips of a field must be whole rows of the grid, in order");
  m.have = row1;
  int64_t keep = m.have;  // the first row a stage still reads
  for (BoundaryRun& run : m.boundary) {
    run.b.rows.set_strip(strip, row0, row1);
    run.advance(m.have);
    keep = std::min(keep, run.links_to);
  }
  if (m.limit_grid) {
    m.limit_grid->rows.set_strip(strip, row0, row1);
    for (LimitRun& run : m.limits) {
      run.advance(m.have);
      keep = std::min(keep, run.crossings_to);
    }
  }
  // The strip is not read after this call: what the next strip's stages read is copied.
  for (BoundaryRun& run : m.boundary) run.b.rows.keep_from(keep);
  if (m.limit_grid) m.limit_grid->rows.keep_from(keep);
}

const std::string& StripLines::key() const { return impl_->key; }

LinePieces StripLines::pieces() const {
  const Impl& m = *impl_;
  m.require_all("line pieces");
  if (m.boundaries_taken || m.limits_taken)
    throw Error(ErrorKind::invalid_argument, "line pieces asked for after the lines were taken");
  auto d = std::make_shared<Pieces>();
  d->key = m.key;
  d->measured_here = true;
  d->width = m.g.width;
  d->height = m.g.height;
  for (const BoundaryRun& run : m.boundary) d->boundary.push_back(run.pieces());
  for (const LimitRun& run : m.limits) d->limits.push_back(run.pieces());
  return LinePieces(std::move(d));
}

void StripLines::keep_pieces() {
  Impl& m = *impl_;
  m.require_all("line pieces");
  if (m.boundaries_taken || m.limits_taken)
    throw Error(ErrorKind::invalid_argument, "line pieces kept from after the lines were taken");
  m.kept = std::make_shared<Pieces>();
  m.kept->key = m.key;
  m.kept->measured_here = true;
  m.kept->width = m.g.width;
  m.kept->height = m.g.height;
  m.kept->boundary.resize(m.boundary.size());
  m.kept->limits.resize(m.limits.size());
}

LinePieces StripLines::kept_pieces() const {
  const Impl& m = *impl_;
  if (!m.kept || !taken() || m.kept_runs != m.boundary.size() + m.limits.size())
    throw Error(ErrorKind::invalid_argument,
                "kept line pieces asked for before the lines were taken (or after a take failed), or not kept");
  return LinePieces(m.kept);
}

void StripLines::take_rows(const LinePieces& base, int64_t row1, std::span<const int32_t> site_map) {
  Impl& m = *impl_;
  if (base.empty() || base.key() != m.key)
    throw Error(ErrorKind::invalid_argument, "line pieces of another extraction (grid, request or seeds' adjustments)");
  if (row1 <= m.have || row1 > m.g.height)
    throw Error(ErrorKind::invalid_argument, "line pieces taken for rows " + std::to_string(m.have) + " to " +
                                                 std::to_string(row1) + " of " + std::to_string(m.g.height));
  const Pieces& p = *base.d_;
  for (size_t i = 0; i < m.boundary.size(); ++i)
    m.boundary[i].take(p.boundary.at(i), m.g.width, row1, site_map, !p.measured_here);
  if (m.limit_grid) m.limit_grid->rows.restart();
  for (size_t i = 0; i < m.limits.size(); ++i) m.limits[i].take(p.limits.at(i), row1, site_map, !p.measured_here);
  m.have = row1;
}

void StripLines::take_measured(const LinePieces& base, ChangedTiles changed, std::vector<int32_t> site_map) {
  Impl& m = *impl_;
  if (base.empty() || base.key() != m.key)
    throw Error(ErrorKind::invalid_argument, "line pieces of another extraction (grid, request or seeds' adjustments)");
  const int64_t W = m.g.width, H = m.g.height, T = changed.size;
  if (T <= 0 || changed.flags.size() != static_cast<size_t>(((W + T - 1) / T) * ((H + T - 1) / T)))
    throw Error(ErrorKind::invalid_argument, "the changed tiles do not cover the grid");
  if (m.have != 0) throw Error(ErrorKind::invalid_argument, "vertices taken from a base after the first row");
  // Decoded pieces (bytes from outside) are measured, not taken: only this process's own
  // measurements are known to be the metric's.
  if (!base.d_->measured_here) return;
  m.measured = std::make_unique<Impl::Measured>();
  Impl::Measured& u = *m.measured;
  u.base = base;
  u.changed = std::move(changed);
  u.site_map = std::move(site_map);
  const Pieces& p = *u.base.d_;
  if (!p.boundary.empty() && !m.boundary.empty()) {
    const Pieces::Boundary& pb = p.boundary.front();
    // The base's crossings and slivers are in edge order (rows in order, each row's edges too).
    u.crossing = [&pb, &u, W, H](int64_t edge, int32_t lo, int32_t hi, BoundaryVertex& v) {
      if (!edge_unchanged(u.changed, W, H, edge)) return false;
      const auto it = std::partition_point(pb.crossings.begin(), pb.crossings.end(),
                                           [edge](const boundary_stages::Crossing& c) { return c.edge < edge; });
      if (it == pb.crossings.end() || it->edge != edge || it->owner_lo != lo || it->owner_hi != hi) return false;
      if (std::next(it) != pb.crossings.end() && std::next(it)->edge == edge) return false;
      if (std::binary_search(pb.slivers.begin(), pb.slivers.end(), std::pair<int64_t, int32_t>{edge, INT32_MIN},
                             [](const auto& a, const auto& b) { return a.first < b.first; }))
        return false;
      v = it->v;
      if (!renumber(v, u.site_map)) return false;
      u.taken.fetch_add(1, std::memory_order_relaxed);
      return true;
    };
    m.boundary.front().from_base = &u.crossing;
  }
  if (p.limits.size() == m.limits.size()) {
    u.limit.resize(m.limits.size());
    for (size_t i = 0; i < m.limits.size(); ++i) {
      const Pieces::Limit& pl = p.limits[i];
      u.limit[i] = [&pl, &u, W, H](int64_t edge, LimitVertex& v) {
        if (!edge_unchanged(u.changed, W, H, edge)) return false;
        const auto it = std::lower_bound(pl.edges.begin(), pl.edges.end(), edge);
        if (it == pl.edges.end() || *it != edge) return false;
        v = pl.verts[static_cast<size_t>(it - pl.edges.begin())];
        if (!renumber(v, u.site_map)) return false;
        u.taken.fetch_add(1, std::memory_order_relaxed);
        return true;
      };
      m.limits[i].from_base = &u.limit[i];
    }
  }
}

int64_t StripLines::vertices_taken() const {
  return impl_->measured ? impl_->measured->taken.load(std::memory_order_relaxed) : 0;
}

void StripLines::keep_refined(RefinedSegments before, ChangedTiles changed, std::vector<int32_t> site_map) {
  Impl& m = *impl_;
  if (m.boundaries_taken || m.limits_taken)
    throw Error(ErrorKind::invalid_argument, "refinements kept from after the lines were taken");
  if (!before.empty() && (before.d_->key != m.refine_key || before.d_->limits.size() != m.limits.size()))
    throw Error(ErrorKind::invalid_argument, "refined segments of another extraction (grid, request or tolerances)");
  if (!before.empty()) {
    const int64_t T = changed.size;
    if (T <= 0 || changed.flags.size() != static_cast<size_t>(((m.g.width + T - 1) / T) * ((m.g.height + T - 1) / T)))
      throw Error(ErrorKind::invalid_argument, "the changed tiles do not cover the grid");
  }
  m.keeping.emplace();
  m.keeping->before = std::move(before);
  m.keeping->changed = std::move(changed);
  m.keeping->site_map = std::move(site_map);
  m.keeping->now = std::make_shared<RefinedSegments::Data>();
  m.keeping->now->key = m.refine_key;
}

bool StripLines::taken() const {
  const Impl& m = *impl_;
  return (m.boundary.empty() || m.boundaries_taken) && (m.limits.empty() || m.limits_taken);
}

RefinedSegments StripLines::refined() const {
  const Impl& m = *impl_;
  if (!m.keeping || !taken())
    throw Error(ErrorKind::invalid_argument, "refined segments asked for before the lines were taken, or not kept");
  return RefinedSegments(m.keeping->now);
}

RefinedSegments::RefinedSegments() = default;
RefinedSegments::RefinedSegments(std::shared_ptr<const Data> d) : d_(std::move(d)) {}
bool RefinedSegments::empty() const { return !d_; }
int64_t RefinedSegments::segments() const {
  if (!d_) return 0;
  auto n = static_cast<int64_t>(d_->boundary.entries.size());
  for (const auto& l : d_->limits) n += static_cast<int64_t>(l.entries.size());
  return n;
}
int64_t RefinedSegments::segments_taken() const {
  if (!d_) return 0;
  int64_t n = d_->boundary.taken;
  for (const auto& l : d_->limits) n += l.taken;
  return n;
}
int64_t RefinedSegments::memory_bytes() const {
  if (!d_) return 0;
  int64_t n = d_->boundary.memory_bytes();
  for (const auto& l : d_->limits) n += l.memory_bytes();
  return n;
}

BoundaryResult StripLines::take_boundaries() {
  Impl& m = *impl_;
  m.require_all("boundaries");
  if (m.boundary.empty() || m.boundaries_taken)
    throw Error(ErrorKind::invalid_argument, "boundaries not requested, or already taken");
  m.boundaries_taken = true;
  BoundaryRun& run = m.boundary.front();
  if (m.kept) {
    m.kept->boundary.front().tripoints = run.t.tripoints;
    m.kept->boundary.front().tripoint_row = run.t.found_row;
  }
  BoundaryResult result;
  if (!m.keeping) {
    result = run.finish();
  } else {
    Impl::Keeping& k = *m.keeping;
    std::optional<SegmentReuse<BoundaryVertex, boundary_stages::LineRefiner::Added>> reuse;
    if (!k.before.empty()) reuse.emplace(k.before.d_->boundary, m.g, k.changed, k.site_map);
    result = run.finish(reuse ? &*reuse : nullptr, &k.now->boundary);
    k.now->boundary.shrink_to_fit();
  }
  if (m.kept) {
    run.move_pieces(m.kept->boundary.front());
    ++m.kept_runs;
  }
  return result;
}

LimitResult StripLines::take_limits() {
  Impl& m = *impl_;
  m.require_all("limits");
  if (m.limits_taken) throw Error(ErrorKind::invalid_argument, "limits already taken");
  m.limits_taken = true;
  LimitResult result;
  const CrsScale scale(m.limit_grid ? m.limit_grid->metric : m.index.metric(),
                       line_tools::centre(m.g, m.g.width / 2, m.g.height / 2), m.g.res);
  if (m.keeping) m.keeping->now->limits.resize(m.limits.size());
  for (size_t i = 0; i < m.limits.size(); ++i) {
    LimitRun& run = m.limits[i];
    const limit_stages::LimitRefiner refiner(run.t, m.limit_line_tolerance, scale);
    std::optional<SegmentReuse<LimitVertex, limit_stages::LimitRefiner::Measured>> reuse;
    if (m.keeping && !m.keeping->before.empty())
      reuse.emplace(m.keeping->before.d_->limits.at(i), m.g, m.keeping->changed, m.keeping->site_map);
    limit_stages::chain_limit_lines(run.t, run.x, run.links, m.limit_tol, result, &refiner, reuse ? &*reuse : nullptr,
                                    m.keeping ? &m.keeping->now->limits[i] : nullptr);
    if (m.keeping) m.keeping->now->limits[i].shrink_to_fit();
    if (m.kept) {
      m.kept->limits[i] = run.move_pieces();
      ++m.kept_runs;
    }
  }
  return result;
}

BoundaryResult extract_boundaries(const NearestField& field, const OwnerIndex& index, const BoundaryOptions& options) {
  check_whole_grid(field);
  LineRequest request;
  request.boundaries = true;
  request.boundary = options;
  StripLines lines(field.site.grid(), index, request);
  lines.add(field);
  return lines.take_boundaries();
}

LimitResult extract_limits(const NearestField& field, const OwnerIndex& index, std::span<const double> distances,
                           const LimitOptions& options) {
  check_whole_grid(field);
  LineRequest request;
  request.limit_distances.assign(distances.begin(), distances.end());
  request.limit = options;
  StripLines lines(field.site.grid(), index, request);
  lines.add(field);
  return lines.take_limits();
}

}  // namespace rv
