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
#include "lines/region_follow.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/limit_stages.hpp"
#include "lines/line_tools.hpp"
#include "rv/field/parallel.hpp"

namespace rv::region_follow {

using namespace line_tools;

namespace {

// The bow of segment p-q given the locus function's value `f` and gradient `g` (per CRS unit) at
// its middle.
Bow bow_of(const CrsScale& scale, Vec2 p, Vec2 q, double f, Vec2 g) {
  const Vec2 mid = lerp(p, q, 0.5);
  const Vec2 s = scale.at(mid);
  const Vec2 gm{g.x / s.x, g.y / s.y};  // per metric unit
  const double gg = gm.x * gm.x + gm.y * gm.y;
  const Vec2 d{(q.x - p.x) * s.x, (q.y - p.y) * s.y};
  const double length = std::hypot(d.x, d.y);
  Bow b;
  b.length = length;
  if (!std::isfinite(f) || !(gg > 0.0) || !std::isfinite(gg) || !(length > 0.0)) return b;
  const Vec2 step{-f * gm.x / gg, -f * gm.y / gg};  // from the middle to the locus, metric units
  b.left = (step.x * -d.y + step.y * d.x) / length;
  return b;
}

}  // namespace

void follow(RegionEdges& e, const OwnerIndex& index, const GridSpec& g, double D, bool margins, double tol,
            bool partial) {
  const SiteMetric& metric = index.metric();
  const CrsScale scale(metric, centre(g, g.width / 2, g.height / 2), g.res);
  const double per_crs = std::max(scale.at0.x, scale.at0.y);
  const double cell = cell_metric(g, metric);
  const double ftol = 1e-9 * cell;
  const limit_stages::LimitGrid lg{{},    index, metric, g, g.width, g.height, 1, cell, ftol, owner_of_sites(metric.seeds()),
                                   true,  margins ? &index : nullptr};
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
        const OwnerIndex::Hit ha = index.nearest_of(p, locus.a), hb = index.nearest_of(p, locus.b);
        return BoundaryVertex{p,           ha.site,    hb.site, 0.5 * (ha.distance + hb.distance), std::abs(ha.cost - hb.cost),
                              ha.distance, hb.distance};
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
    // Every segment's bow.
    std::vector<Bow>& bows = e.bows[static_cast<size_t>(k)];
    bows.resize(pts.size() - 1);
    if (locus.kind == EdgeLocus::none || (locus.kind == EdgeLocus::pair && partial)) return;
    for (size_t i = 0; i + 1 < pts.size(); ++i) {
      const Vec2 mid = lerp(pts[i], pts[i + 1], 0.5);
      Vec2 grad{std::numeric_limits<double>::quiet_NaN(), 0.0};
      double f = std::numeric_limits<double>::quiet_NaN();
      if (locus.kind == EdgeLocus::level) {
        const OwnerIndex::Hit h = target.at(mid);
        if (h.site != kNoSite) {
          f = h.distance - target.D;
          metric.distance_and_gradient(mid, h.site, grad);
        }
      } else {
        const OwnerIndex::Hit ha = index.nearest_of(mid, locus.a), hb = index.nearest_of(mid, locus.b);
        if (ha.site != kNoSite && hb.site != kNoSite) {
          Vec2 ga, gb;
          f = boundary_stages::site_cost(index, mid, ha.site, ga) - boundary_stages::site_cost(index, mid, hb.site, gb);
          grad = Vec2{ga.x - gb.x, ga.y - gb.y};
        }
      }
      bows[i] = bow_of(scale, pts[i], pts[i + 1], f, grad);
    }
  });
  for (const LineResidual& r : residual) e.residual.merge(r);
}

}  // namespace rv::region_follow
