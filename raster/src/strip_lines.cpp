// StripLines (rv/deliverables.hpp): the boundary and limit stages (boundary_stages.hpp,
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
#include <cmath>
#include <optional>
#include <vector>

#include "boundary_stages.hpp"
#include "limit_stages.hpp"
#include "line_tools.hpp"
#include "rv/deliverables.hpp"
#include "rv/error.hpp"
#include "rv/parallel.hpp"

namespace rv {

using namespace line_tools;

namespace {

// One boundary extraction in progress.
struct BoundaryRun {
  boundary_stages::BoundaryGrid b;
  double tol;           // simplification, CRS units
  double refine;        // BoundaryOptions::refine_cells in metric units (0: none)
  double cell;          // one cell in metric units
  double max_distance;  // BoundaryOptions::max_distance
  boundary_stages::CrossingSet x;
  boundary_stages::TripointSet t;
  boundary_stages::Links links;
  std::vector<std::array<int64_t, 2>> unplaced;
  BoundaryStats stats;
  int64_t crossings_to = 0, tripoints_to = 0, links_to = 0;  // rows done: [0, *_to)

  // Every stage as far as rows [0, have) allow (to the end when they are all in).
  void advance(int64_t have) {
    using namespace boundary_stages;
    const bool all = have == b.H;
    const int64_t xc = all ? b.H : std::max(crossings_to, have - 1);
    find_crossings(b, crossings_to, xc, x, stats);
    crossings_to = xc;
    const int64_t tp = all ? b.H : std::max(tripoints_to, crossings_to - 1);
    find_tripoints(b, x, tripoints_to, tp, t, unplaced, stats);
    tripoints_to = tp;
    const int64_t ln = all ? b.H : std::max(links_to, tripoints_to - 2);
    const Links part = link_squares(b, x, t, links_to, ln, stats);
    for (size_t i = 0; i < part.links.size(); ++i) links.add(part.links[i][0], part.links[i][1], part.pair[i]);
    links_to = ln;
  }

  BoundaryResult finish() {
    using namespace boundary_stages;
    count_unresolved(b, x, t, unplaced, stats);
    BoundaryResult result;
    result.stats = stats;
    std::optional<LineRefiner> refiner;
    if (refine > 0.0) refiner.emplace(b.index, refine, b.ftol, cell / b.g.res);
    result.lines = chain_lines(x, t, links, tol, result.stats, refiner ? &*refiner : nullptr, b.threads);
    join_close_tripoints(t.tripoints, b.g.res, result.lines);
    close_missing_tripoints(b, max_distance, t.tripoints, result.lines, result.stats);
    end_at_owned_edge(b, max_distance, t.tripoints, result.lines, result.stats);
    result.lone_crossings = lone_crossings(x, links);
    for (const Tripoint& tp : t.tripoints) result.stats.max_residual = std::max(result.stats.max_residual, tp.residual);
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

  void advance(int64_t have) {
    using namespace limit_stages;
    const int64_t H = t.grid.H;
    const bool all = have == H;
    inside_flags(t, inside.row1(), have, inside);
    const int64_t xc = all ? H : std::max(crossings_to, have - 1);
    append(x, limit_crossings(t, inside, crossings_to, xc));
    crossings_to = xc;
    const int64_t ln = all ? H : std::max(links_to, crossings_to - 1);
    const auto part = limit_links(t, inside, x, links_to, ln);
    links.insert(links.end(), part.begin(), part.end());
    links_to = ln;
    inside.drop_before(links_to);
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
  double limit_tol = 0.0;
  int64_t have = 0;
  bool boundaries_taken = false, limits_taken = false;

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
                                     std::max(o.refine_cells, 0.0) * cell,
                                     cell,
                                     o.max_distance,
                                     {},
                                     {},
                                     {},
                                     {},
                                     {}});
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
}

StripLines::~StripLines() = default;
StripLines::StripLines(StripLines&&) noexcept = default;
StripLines& StripLines::operator=(StripLines&&) noexcept = default;

int64_t StripLines::rows() const { return impl_->have; }

void StripLines::add(const NearestField& strip) {
  Impl& m = *impl_;
  check_metric(strip, m.index.metric());
  const Window w = strip.site.window();
  if (!(strip.site.grid() == m.g) || w.row0 != m.have || w.height < 1 || w.col0 != 0 || w.width != m.g.width ||
      !(strip.distance.window() == w))
    throw Error(ErrorKind::invalid_argument, "strips of a field must be whole rows of the grid, in order");
  m.have = w.row0 + w.height;
  int64_t keep = m.have;  // the first row a stage still reads
  for (BoundaryRun& run : m.boundary) {
    run.b.rows.set_strip(strip);
    run.advance(m.have);
    keep = std::min(keep, run.links_to);
  }
  if (m.limit_grid) {
    m.limit_grid->rows.set_strip(strip);
    for (LimitRun& run : m.limits) {
      run.advance(m.have);
      keep = std::min(keep, run.crossings_to);
    }
  }
  // The strip is not read after this call: what the next strip's stages read is copied.
  for (BoundaryRun& run : m.boundary) run.b.rows.keep_from(keep);
  if (m.limit_grid) m.limit_grid->rows.keep_from(keep);
}

BoundaryResult StripLines::take_boundaries() {
  Impl& m = *impl_;
  m.require_all("boundaries");
  if (m.boundary.empty() || m.boundaries_taken)
    throw Error(ErrorKind::invalid_argument, "boundaries not requested, or already taken");
  m.boundaries_taken = true;
  return m.boundary.front().finish();
}

LimitResult StripLines::take_limits() {
  Impl& m = *impl_;
  m.require_all("limits");
  if (m.limits_taken) throw Error(ErrorKind::invalid_argument, "limits already taken");
  m.limits_taken = true;
  LimitResult result;
  for (LimitRun& run : m.limits) limit_stages::chain_limit_lines(run.t, run.x, run.links, m.limit_tol, result);
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
