#include "sea/root_tree.hpp"

#include <algorithm>
#include <cmath>

namespace rv::sea {

RootTree::RootTree(const std::vector<Box>& items, double scale)
    : scale_(scale),
      leaf_(items.size(), -1),
      boxes_(items),
      weight_(items.size(), std::numeric_limits<double>::infinity()),
      stamp_(items.size(), 0) {
  if (items.empty()) return;
  order_.resize(items.size());
  for (size_t i = 0; i < items.size(); ++i) order_[i] = static_cast<int32_t>(i);
  nodes_.reserve(2 * items.size() / kLeaf + 2);
  build(0, static_cast<int32_t>(items.size()), -1, 0, items);
}

int32_t RootTree::build(int32_t first, int32_t count, int32_t parent, int depth, const std::vector<Box>& items) {
  const auto id = static_cast<int32_t>(nodes_.size());
  nodes_.push_back(Node{});
  Box box = items[static_cast<size_t>(order_[static_cast<size_t>(first)])];
  for (int32_t i = first; i < first + count; ++i) {
    const Box& b = items[static_cast<size_t>(order_[static_cast<size_t>(i)])];
    box.lo.x = std::min(box.lo.x, b.lo.x);
    box.lo.y = std::min(box.lo.y, b.lo.y);
    box.hi.x = std::max(box.hi.x, b.hi.x);
    box.hi.y = std::max(box.hi.y, b.hi.y);
  }
  nodes_[static_cast<size_t>(id)].box = box;
  nodes_[static_cast<size_t>(id)].parent = parent;
  if (count <= kLeaf) {
    nodes_[static_cast<size_t>(id)].first = first;
    nodes_[static_cast<size_t>(id)].count = count;
    for (int32_t i = first; i < first + count; ++i) leaf_[static_cast<size_t>(order_[static_cast<size_t>(i)])] = id;
    return id;
  }
  // Split at the median of the box centres along the longer side.
  const bool by_x = box.hi.x - box.lo.x >= box.hi.y - box.lo.y;
  auto centre = [&](int32_t item) {
    const Box& b = items[static_cast<size_t>(item)];
    return by_x ? b.lo.x + b.hi.x : b.lo.y + b.hi.y;
  };
  const int32_t half = count / 2;
  std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                   [&](int32_t a, int32_t b) { return centre(a) < centre(b) || (centre(a) == centre(b) && a < b); });
  const int32_t left = build(first, half, id, depth + 1, items);
  const int32_t right = build(first + half, count - half, id, depth + 1, items);
  nodes_[static_cast<size_t>(id)].left = left;
  nodes_[static_cast<size_t>(id)].right = right;
  return id;
}

void RootTree::set_weight(int32_t item, double weight) {
  weight_[static_cast<size_t>(item)] = weight;
  const uint64_t stamp = stamp_[static_cast<size_t>(item)] = ++clock_;
  for (int32_t n = leaf_[static_cast<size_t>(item)]; n >= 0; n = nodes_[static_cast<size_t>(n)].parent) {
    Node& node = nodes_[static_cast<size_t>(n)];
    node.max_stamp = stamp;  // the newest: every subtree above holds it
    double m = std::numeric_limits<double>::infinity(), top = -m;
    if (node.left < 0) {
      for (int32_t i = node.first; i < node.first + node.count; ++i) {
        const double w = weight_[static_cast<size_t>(order_[static_cast<size_t>(i)])];
        m = std::min(m, w);
        if (std::isfinite(w)) top = std::max(top, w);
      }
    } else {
      const Node& l = nodes_[static_cast<size_t>(node.left)];
      const Node& r = nodes_[static_cast<size_t>(node.right)];
      m = std::min(l.min_weight, r.min_weight);
      top = std::max(l.max_weight, r.max_weight);
    }
    node.min_weight = m;
    node.max_weight = top;
  }
}

}  // namespace rv::sea
