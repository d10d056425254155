// region_follow::follow (region_follow.hpp): the region edges' own stretches made to follow their
// loci, and the bows that let the areas follow them too.
//
// Why the bows. A region's area is the area of its ring of chords plus, along every chord, the
// sliver between the chord and the locus it stands for. Within a tolerance t a chord of length c
// leaves up to about 2/3 c t there: 1e-7 of a 12 nmi disc at 1 mm. The sliver is measured, not
// bounded: the locus point across the chord's middle (one Newton step from the middle along the
// locus function's gradient, in metric units) gives the bow b, and 2/3 b c is the sliver of the
// parabola through the three points -- a circle's to b^2 / R of it -- so closed forms come out
// to 1e-9.
#include "lines/regions/region_follow.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/limit_stages.hpp"
#include "lines/line_tools.hpp"
#include "rv/field/parallel.hpp"

namespace rv::region_follow {

using namespace line_tools;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// A boundary segment's bow is taken from the curve (the locus, or a reach's arc) nearest its
// middle, and only within this many tolerances of it: farther, the segment stands for none of
// them (it was left unresolved, or joins where the cells show less than the geometry).
constexpr double kFarBow = 16.0;

// Every segment's bow, over blocks of segments of all edges (a coast's few long edges would leave
// threads idle as single tasks).
void measure_bows(RegionEdges& e, const OwnerIndex& index, const limit_stages::Target& target, const CrsScale& scale,
                  double tol, bool partial, const SegmentBows& known) {
  const SiteMetric& metric = index.metric();
  constexpr size_t kBlock = 512;
  std::vector<std::array<size_t, 3>> blocks;  // edge, first segment, end
  for (size_t k = 0; k < e.edges.size(); ++k) {
    const EdgeLocus locus = e.loci[k];
    if (locus.kind == EdgeLocus::none || (locus.kind == EdgeLocus::pair && partial)) continue;
    for (size_t i = 0; i + 1 < e.edges[k].size(); i += kBlock)
      blocks.push_back({k, i, std::min(i + kBlock, e.edges[k].size() - 1)});
  }
  detail::parallel_for(0, static_cast<int64_t>(blocks.size()), [&](int64_t n, int) {
    const auto [k, i0, i1] = blocks[static_cast<size_t>(n)];
    const std::vector<Vec2>& pts = e.edges[k];
    const EdgeLocus locus = e.loci[k];
    // A boundary's sites at the previous segment's middle: the next one's hints.
    int32_t hint_a = kNoSite, hint_b = kNoSite;
    for (size_t i = i0; i < i1; ++i) {
      const Vec2 mid = lerp(pts[i], pts[i + 1], 0.5);
      Vec2 grad{std::numeric_limits<double>::quiet_NaN(), 0.0};
      double f = std::numeric_limits<double>::quiet_NaN();
      if (locus.kind == EdgeLocus::level) {
        const OwnerIndex::Hit h = target.at(mid);
        if (h.site != kNoSite) {
          f = h.distance - target.D;
          metric.distance_and_gradient(mid, h.site, grad);
        }
      } else if (const std::optional<Bow> b = known.of(pts[i], pts[i + 1])) {
        e.bows[k][i] = *b;  // measured as the line was refined
        continue;
      } else {
        // A boundary follows the two owners' locus, or where a reach ends it, that site's arc
        // (BoundaryVertex::arc): the curve nearest the chord's middle is the one it stands for.
        const OwnerIndex::Hit ha = index.nearest_of(mid, locus.a, hint_a), hb = index.nearest_of(mid, locus.b, hint_b);
        hint_a = ha.site;
        hint_b = hb.site;
        Bow best;
        double nearest = kFarBow * tol;
        auto consider = [&](double value, Vec2 gradient) {
          const Bow b = scale.bow(pts[i], pts[i + 1], value, gradient);
          if (std::abs(b.left) <= nearest) {
            nearest = std::abs(b.left);
            best = b;
          }
        };
        Vec2 ga{std::numeric_limits<double>::quiet_NaN(), 0.0}, gb = ga;
        const double ca = ha.site != kNoSite ? boundary_stages::site_cost(index, mid, ha.site, ga) : kInf;
        const double cb = hb.site != kNoSite ? boundary_stages::site_cost(index, mid, hb.site, gb) : kInf;
        if (std::isfinite(ca) && std::isfinite(cb)) consider(ca - cb, Vec2{ga.x - gb.x, ga.y - gb.y});
        for (const int32_t site : {ha.site, hb.site})
          if (site != kNoSite && std::isfinite(index.reach_of(site))) {
            Vec2 g;
            const double d = metric.distance_and_gradient(mid, site, g);
            consider(d - index.reach_of(site), g);
          }
        e.bows[k][i] = best;
        continue;
      }
      Bow b = scale.bow(pts[i], pts[i + 1], f, grad);
      if (!(std::abs(b.left) <= kFarBow * tol)) b.left = std::numeric_limits<double>::quiet_NaN();
      e.bows[k][i] = b;
    }
  });
}

}  // namespace

void follow(RegionEdges& e, const OwnerIndex& index, const GridSpec& g, double D, bool margins, double tol,
            bool partial, const BoundaryResult& lines) {
  const SiteMetric& metric = index.metric();
  const CrsScale scale(metric, centre(g, g.width / 2, g.height / 2), g.res);
  const double per_crs = std::max(scale.at0.x, scale.at0.y);
  const double cell = cell_metric(g, metric);
  const double ftol = 1e-9 * cell;
  const limit_stages::LimitGrid lg{{},      index,
                                   metric,  g,
                                   g.width, g.height,
                                   1,       cell,
                                   ftol,    owner_of_sites(metric.seeds()),
                                   true,    margins ? &index : nullptr};
  const limit_stages::Target target{lg, margins ? kOwnedEdge : 0, margins ? 0.0 : D};
  const limit_stages::LimitRefiner levels(target, tol, scale);
  const boundary_stages::LineRefiner pairs(index, tol, ftol, scale, per_crs);
  e.loci.resize(e.edges.size());
  e.bows.assign(e.edges.size(), {});
  std::vector<LineResidual> residual(e.edges.size());
  detail::parallel_for(0, static_cast<int64_t>(e.edges.size()), [&](int64_t k, int) {
    std::vector<Vec2>& pts = e.edges[static_cast<size_t>(k)];
    const EdgeLocus locus = e.loci[static_cast<size_t>(k)];
    LineResidual& r = residual[static_cast<size_t>(k)];
    if (pts.size() < 2) return;
    if (locus.kind == EdgeLocus::level) {
      std::vector<LimitVertex> v;
      v.reserve(pts.size());
      for (const Vec2 p : pts) {
        const OwnerIndex::Hit h = target.at(p);
        v.push_back(LimitVertex{p, h.site, std::abs(h.distance - target.D)});
      }
      int64_t corners = 0;
      v = levels.refine(v, r, corners);
      pts.clear();
      for (const LimitVertex& x : v) pts.push_back(x.p);
    } else if (locus.kind == EdgeLocus::pair && !partial) {
      // The carried-on ends: the first and last segments.
      auto vertex = [&](Vec2 p) {
        return boundary_stages::vertex_between(p, index.nearest_of(p, locus.a), index.nearest_of(p, locus.b));
      };
      const size_t n = pts.size();
      std::vector<BoundaryVertex> v;
      for (const size_t i : {size_t{0}, size_t{1}, n - 2, n - 1}) v.push_back(vertex(pts[std::min(i, n - 1)]));
      boundary_stages::LineRefiner::Added added;
      std::vector<BoundaryVertex> head{v[0]}, tail{v[2]};
      pairs.refine_segments(locus.a, locus.b, v, 0, 1, head, added);
      if (n > 2) pairs.refine_segments(locus.a, locus.b, v, 2, 3, tail, added);
      std::vector<Vec2> out;
      for (const BoundaryVertex& x : head) out.push_back(x.p);
      if (n > 3) out.insert(out.end(), pts.begin() + 2, pts.end() - 2);
      // (tail starts at pts[n - 2], which head ends at when n is 3)
      if (n > 2)
        for (size_t i = n == 3 ? 1 : 0; i < tail.size(); ++i) out.push_back(tail[i].p);
      pts = std::move(out);
      r.merge(added.locus);
      r.merge(added.arcs);
    }
    e.bows[static_cast<size_t>(k)].resize(pts.size() - 1);
  });
  for (const LineResidual& r : residual) e.residual.merge(r);
  SegmentBows known;
  if (!partial)
    for (const BoundaryLine& line : lines.lines) {
      std::vector<Vec2> pts;
      pts.reserve(line.vertices.size());
      for (const BoundaryVertex& v : line.vertices) pts.push_back(v.p);
      known.add(pts, line.bows);
    }
  measure_bows(e, index, target, scale, tol, partial, known);
}

}  // namespace rv::region_follow
