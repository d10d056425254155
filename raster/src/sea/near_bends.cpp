// The bend nodes each node sees nearby: see near_bends.hpp.
#include "sea/near_bends.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/sea/geodesic_frame.hpp"
#include "sea/root_tree.hpp"
#include "sea/visible_region.hpp"

namespace rv::sea {

namespace {

// The directions from `at` to the parts of `region`'s ring within `tol` of the sides of its
// square [lo, hi] (a spike's tip on a side is such a part), widened by `w`, into `out`.
void far_cones(Vec2 at, const VisibleRegion& region, Vec2 lo, Vec2 hi, double tol, double w,
               std::vector<std::pair<double, double>>& out) {
  const Vec2 in_lo{lo.x + tol, lo.y + tol}, in_hi{hi.x - tol, hi.y - tol};
  auto add = [&](Vec2 a, Vec2 b) {
    double p = pseudo_angle(a.x - at.x, a.y - at.y), q = pseudo_angle(b.x - at.x, b.y - at.y);
    if (p > q) std::swap(p, q);
    // (A segment clear of `at` spans less than a half-turn: the other way round when wider.)
    if (q - p > 2.0) {
      out.emplace_back(q - w, 4.0);
      out.emplace_back(0.0, p + w);
      return;
    }
    const double c0 = p - w, c1 = q + w;
    out.emplace_back(std::max(0.0, c0), std::min(4.0, c1));
    if (c0 < 0.0) out.emplace_back(c0 + 4.0, 4.0);
    if (c1 > 4.0) out.emplace_back(0.0, c1 - 4.0);
  };
  // A point outside the inner square: within tol of a side.
  auto outside = [&](Vec2 x) { return x.x < in_lo.x || x.x > in_hi.x || x.y < in_lo.y || x.y > in_hi.y; };
  const size_t n = region.ring.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec2 a = region.ring[i], b = region.ring[(i + 1) % n];
    // The parts of a-b outside its part inside the inner square.
    Vec2 ia = a, ib = b;
    if (!clip_to_box(ia, ib, in_lo, in_hi)) {
      add(a, b);
      continue;
    }
    if (!(ia == a) || outside(a)) add(a, ia);
    if (!(ib == b) || outside(b)) add(ib, b);
  }
}

}  // namespace

NearBends near_bends(const Prepared& p, const std::vector<Node>& nodes, int k, int threads,
                     const std::atomic<bool>* cancel, const std::vector<EdgeIndex::Segment>& edges,
                     const EdgeIndex& index, double far_factor) {
  const Visibility& vis = p.vis;
  const size_t n = nodes.size();
  NearBends out;
  out.radius.assign(n, 0.0);
  out.reach.assign(n, 0.0);
  std::vector<RootTree::Box> boxes;
  boxes.reserve(n);
  for (const Node& node : nodes) boxes.push_back({vis.vertex(node.vertex), vis.vertex(node.vertex)});
  RootTree tree(boxes);
  for (size_t i = 0; i < n; ++i) tree.set_weight(static_cast<int32_t>(i), 0.0);
  std::vector<std::vector<int32_t>> near_of(n);  // per node, its near roots that see it
  std::vector<int64_t> tests(n, 0);
  out.far_half.assign(n, 0.0);
  std::vector<std::vector<std::pair<double, double>>> cones(n);
  const double deviation = vis.frame() ? vis.frame()->deviation() : 0.0;
  detail::parallel_for(resolve_threads(threads), static_cast<int64_t>(n), [&](int64_t task, int) {
    if (cancel && (task & 63) == 0 && cancel->load(std::memory_order_relaxed))
      throw Error(ErrorKind::cancelled, "computation cancelled");
    const auto v = static_cast<size_t>(task);
    const Node& node = nodes[v];
    const Visibility::Place at = vis.at_vertex(node.vertex, node.wedge);
    // Nodes in increasing plane distance: up to the k-th other vertex, and every node as near.
    std::vector<int32_t> vertices;  // the other vertices met so far
    double radius = std::numeric_limits<double>::infinity();
    std::vector<int32_t> near;
    // (Membership by length(), as Searches::best_path leaves the near nodes out; the tree's bound
    // for a point is the same number.)
    tree.nearest(at.at, [&](int32_t item, double bound) {
      if (bound > radius) return false;
      const Node& r = nodes[static_cast<size_t>(item)];
      const double gap = length(at.at, vis.vertex(r.vertex));
      if (r.vertex == node.vertex || gap > radius) return true;
      near.push_back(item);
      // (A vertex's wedges come one after another unless another vertex lies as near.)
      if (std::find(vertices.begin(), vertices.end(), r.vertex) == vertices.end()) {
        vertices.push_back(r.vertex);
        if (static_cast<int>(vertices.size()) == k) radius = gap;
      }
      return true;
    });
    // (Fewer than k other vertices: every node is near, and no root lies beyond.)
    out.radius[v] = radius;
    out.reach[v] = std::isfinite(radius) ? radius * p.lower_scale() * (1.0 - 1e-9) : radius;
    for (int32_t r : near) {
      const Node& root = nodes[static_cast<size_t>(r)];
      ++tests[v];
      if (vis.sees(at, vis.at_vertex(root.vertex, root.wedge))) near_of[v].push_back(r);
    }
    // Far sight.
    const double h = far_factor * radius;
    if (!(h > 0.0) || !std::isfinite(h)) return;
    thread_local std::vector<int32_t> meet;
    thread_local EdgeIndex::Stamps stamps;
    const Vec2 lo{at.at.x - h, at.at.y - h}, hi{at.at.x + h, at.at.y + h};
    index.edges_in_box(lo, hi, stamps, meet);
    const VisibleRegion region = visible_region(vis, at, lo, hi, edges, &meet);
    if (region.blurred || region.ring.empty()) return;
    const double tol = 4.0 * region.margin + 2.0 * deviation + 1e-9 * h;
    if (!(tol < 0.25 * h)) return;
    std::vector<std::pair<double, double>>& c = cones[v];
    far_cones(at.at, region, lo, hi, tol, 4.0 * tol / h, c);
    // Merged.
    std::sort(c.begin(), c.end());
    size_t m = 0;
    for (const auto& iv : c) {
      if (m > 0 && iv.first <= c[m - 1].second) {
        c[m - 1].second = std::max(c[m - 1].second, iv.second);
      } else {
        c[m++] = iv;
      }
    }
    c.resize(m);
    out.far_half[v] = h;
  });
  out.cone_first.assign(n + 1, 0);
  for (size_t v = 0; v < n; ++v) {
    out.cone_first[v + 1] = out.cone_first[v] + static_cast<int32_t>(cones[v].size());
    out.cones.insert(out.cones.end(), cones[v].begin(), cones[v].end());
  }
  out.first.assign(n + 1, 0);
  for (size_t v = 0; v < n; ++v) {
    out.tests += tests[v];
    for (int32_t r : near_of[v]) ++out.first[static_cast<size_t>(r) + 1];
  }
  for (size_t r = 0; r < n; ++r) out.first[r + 1] += out.first[r];
  out.to.resize(static_cast<size_t>(out.first[n]));
  std::vector<int32_t> fill(out.first.begin(), out.first.end() - 1);
  for (size_t v = 0; v < n; ++v)
    for (int32_t r : near_of[v]) out.to[static_cast<size_t>(fill[static_cast<size_t>(r)]++)] = static_cast<int32_t>(v);
  return out;
}

}  // namespace rv::sea
