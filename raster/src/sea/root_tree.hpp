// A static kd-tree over boxes with additive weights: the roots a path may leave from (seed sites,
// bend nodes with their distance by sea), searched in increasing order of weight plus distance.
//
// Items are fixed at construction; each has a weight, +infinity (absent) until set. Subtree
// minima are kept up to date by set_weight (O(log n)). nearest() visits items in increasing
// order of a lower bound of weight + |x - box| and lets the caller stop.
// Thread safety: const access (nearest) from any number of threads; set_weight is not.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <queue>
#include <vector>

#include "rv/field/seeds.hpp"

namespace rv::sea {

class RootTree {
 public:
  struct Box {
    Vec2 lo, hi;
  };
  // `scale`: bounds take the distance to a box times it (a geodesic frame's plane distances made
  // lower bounds of metres: 1 / its largest scale).
  explicit RootTree(const std::vector<Box>& items, double scale = 1.0);
  RootTree() = default;

  // Sets an item's weight and stamps it with the tree's next stamp (1, 2, ...).
  void set_weight(int32_t item, double weight);
  uint64_t stamp() const { return clock_; }  // the last stamp given
  double weight(int32_t item) const { return weight_[static_cast<size_t>(item)]; }

  // Calls visit(item, bound) for present items in increasing order of bound (a lower bound of
  // weight + the distance from x to the item's box, never above it) until visit returns false.
  template <class F>
  void nearest(Vec2 x, F&& visit) const;
  // Depth first, nearer subtree first: calls visit(item, bound) for every present item whose
  // bound is not above limit() (read again before each subtree and item, so the caller may
  // lower it as it finds better). Without a priority queue: the cheaper search when the caller
  // starts from a good limit.
  // `since`, `seen`: an item stamped no later than `since` is skipped when its bound is at most
  // `seen` (searched before up to that bound); seen +infinity (the default): every such item.
  // Either way whole subtrees at once where every item is such, so a search resumed from a
  // larger bound walks little more than the ring between the two bounds and what is new.
  template <class L, class F>
  void within(Vec2 x, L&& limit, F&& visit, uint64_t since = 0,
              double seen = std::numeric_limits<double>::infinity()) const {
    within(x, limit, visit, since, seen, [](const Box&) { return true; });
  }
  // The same over the items and subtrees whose box `keep(box)` holds: the caller's proof that
  // none of the others can serve (for a subtree's box, none of the items inside it).
  template <class L, class F, class K>
  void within(Vec2 x, L&& limit, F&& visit, uint64_t since, double seen, K&& keep) const {
    within_by([&](const Box& b) { return box_distance(b, x); }, [&](const Box& b) { return far_distance(b, x); }, limit,
              visit, since, seen, keep);
  }
  // The same for every point of box q at once: bounds of weight + the distance between the
  // item's box and q (a lower bound for each point of q).
  template <class L, class F>
  void within(const Box& q, L&& limit, F&& visit) const {
    within_by([&](const Box& b) { return boxes_distance(b, q); }, [](const Box&) { return 0.0; }, limit, visit, 0,
              std::numeric_limits<double>::infinity(), [](const Box&) { return true; });
  }

 private:
  static constexpr int kLeaf = 8;
  struct Node {
    Box box;
    double min_weight = std::numeric_limits<double>::infinity();
    double max_weight = -std::numeric_limits<double>::infinity();  // of the present items
    uint64_t max_stamp = 0;
    int32_t first = 0, count = 0;  // a leaf's items in order_
    int32_t left = -1, right = -1, parent = -1;
  };
  int32_t build(int32_t first, int32_t count, int32_t parent, int depth, const std::vector<Box>& items);
  // (Maxima of two: an initializer list's stack array is not inlined away in the sanitizer build,
  // where these bounds are most of a search's time.)
  double box_distance(const Box& b, Vec2 x) const {
    const double dx = std::max(std::max(b.lo.x - x.x, 0.0), x.x - b.hi.x);
    const double dy = std::max(std::max(b.lo.y - x.y, 0.0), x.y - b.hi.y);
    return std::sqrt(dx * dx + dy * dy) * scale_;
  }
  // At least box_distance(c, x) for every box c inside b, as computed (the same operations on
  // operands at least as large).
  double far_distance(const Box& b, Vec2 x) const {
    const double dx = std::max(x.x - b.lo.x, b.hi.x - x.x);
    const double dy = std::max(x.y - b.lo.y, b.hi.y - x.y);
    return std::sqrt(dx * dx + dy * dy) * scale_;
  }

  double boxes_distance(const Box& b, const Box& q) const {
    const double dx = std::max(std::max(b.lo.x - q.hi.x, 0.0), q.lo.x - b.hi.x);
    const double dy = std::max(std::max(b.lo.y - q.hi.y, 0.0), q.lo.y - b.hi.y);
    return std::sqrt(dx * dx + dy * dy) * scale_;
  }
  // `far(b)`: at least distance(c) for every box c inside b (read only while `seen` is finite).
  template <class D, class Far, class L, class F, class K>
  void within_by(D&& distance, Far&& far, L&& limit, F&& visit, uint64_t since, double seen, K&& keep) const;

  double scale_ = 1.0;
  std::vector<Node> nodes_;
  std::vector<int32_t> order_;   // items by leaf
  std::vector<int32_t> leaf_;    // item -> its leaf node
  std::vector<Box> boxes_;       // per item
  std::vector<double> weight_;   // per item
  std::vector<uint64_t> stamp_;  // per item: when its weight was last set
  uint64_t clock_ = 0;
};

template <class F>
void RootTree::nearest(Vec2 x, F&& visit) const {
  if (nodes_.empty()) return;
  // Entries: (bound, node) for subtrees, (bound, -1 - item) for items.
  using Entry = std::pair<double, int32_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  if (std::isfinite(nodes_[0].min_weight)) queue.emplace(nodes_[0].min_weight + box_distance(nodes_[0].box, x), 0);
  while (!queue.empty()) {
    const auto [bound, id] = queue.top();
    queue.pop();
    if (id < 0) {
      if (!visit(-1 - id, bound)) return;
      continue;
    }
    const Node& n = nodes_[static_cast<size_t>(id)];
    if (n.left < 0) {
      for (int32_t i = n.first; i < n.first + n.count; ++i) {
        const int32_t item = order_[static_cast<size_t>(i)];
        const double w = weight_[static_cast<size_t>(item)];
        if (std::isfinite(w)) queue.emplace(w + box_distance(boxes_[static_cast<size_t>(item)], x), -1 - item);
      }
      continue;
    }
    for (int32_t child : {n.left, n.right}) {
      const Node& c = nodes_[static_cast<size_t>(child)];
      if (std::isfinite(c.min_weight)) queue.emplace(c.min_weight + box_distance(c.box, x), child);
    }
  }
}

template <class D, class Far, class L, class F, class K>
void RootTree::within_by(D&& distance, Far&& far, L&& limit, F&& visit, uint64_t since, double seen, K&& keep) const {
  if (nodes_.empty()) return;
  const bool all_seen = std::isinf(seen) && seen > 0.0;
  int32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[static_cast<size_t>(stack[--top])];
    if (!std::isfinite(n.min_weight) || n.min_weight + distance(n.box) > limit()) continue;
    // (Every item searched before: stamped by then, and its bound at most `seen`, which the
    // heaviest item at the box's farthest corner bounds.)
    if (n.max_stamp <= since && (all_seen || n.max_weight + far(n.box) <= seen)) continue;
    if (!keep(n.box)) continue;
    if (n.left < 0) {
      for (int32_t i = n.first; i < n.first + n.count; ++i) {
        const int32_t item = order_[static_cast<size_t>(i)];
        const double w = weight_[static_cast<size_t>(item)];
        if (!std::isfinite(w) || (all_seen && stamp_[static_cast<size_t>(item)] <= since)) continue;
        const double bound = w + distance(boxes_[static_cast<size_t>(item)]);
        if (stamp_[static_cast<size_t>(item)] <= since && bound <= seen) continue;
        if (bound <= limit() && keep(boxes_[static_cast<size_t>(item)])) visit(item, bound);
      }
      continue;
    }
    const Node& l = nodes_[static_cast<size_t>(n.left)];
    const Node& r = nodes_[static_cast<size_t>(n.right)];
    const double bl = l.min_weight + distance(l.box), br = r.min_weight + distance(r.box);
    // The nearer child is searched first: pushed last.
    if (bl <= br) {
      stack[top++] = n.right;
      stack[top++] = n.left;
    } else {
      stack[top++] = n.left;
      stack[top++] = n.right;
    }
  }
}

}  // namespace rv::sea
