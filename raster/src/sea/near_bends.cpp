// The bend nodes each node sees nearby: see near_bends.hpp.
#include "sea/near_bends.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "sea/root_tree.hpp"

namespace rv::sea {

NearBends near_bends(const Prepared& p, const std::vector<Node>& nodes, int k, int threads,
                     const std::atomic<bool>* cancel) {
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
  });
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
