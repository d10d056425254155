#include "sea/edge_index.hpp"

#include <algorithm>
#include <cmath>

namespace rv::sea {

int64_t EdgeIndex::column(double x) const {
  return std::clamp<int64_t>(static_cast<int64_t>(std::floor((x - x0_) / size_)), 0, cols_ - 1);
}
int64_t EdgeIndex::row(double y) const {
  return std::clamp<int64_t>(static_cast<int64_t>(std::floor((y - y0_) / size_)), 0, rows_ - 1);
}

EdgeIndex::EdgeIndex(const std::vector<Segment>& edges, const std::vector<Vec2>& vertices, double slack)
    : edge_count_(edges.size()) {
  if (vertices.empty() && edges.empty()) return;
  const Vec2 first = vertices.empty() ? edges[0].a : vertices[0];
  double xmin = first.x, xmax = xmin, ymin = first.y, ymax = ymin;
  auto span = [&](const Vec2& v) {
    xmin = std::min(xmin, v.x);
    xmax = std::max(xmax, v.x);
    ymin = std::min(ymin, v.y);
    ymax = std::max(ymax, v.y);
  };
  for (const Vec2& v : vertices) span(v);
  for (const Segment& e : edges) {
    span(e.a);
    span(e.b);
  }
  const double w = std::max(xmax - xmin, 0.0), h = std::max(ymax - ymin, 0.0);
  const double wanted = 2.0 * static_cast<double>(std::max<size_t>(edges.size(), 1));
  double size = std::sqrt(std::max(w * h, 1e-300) / wanted);
  size = std::max({size, std::max(w, h) / 4096.0, 1e-300});
  if (!(size > 0.0) || !std::isfinite(size)) size = 1.0;
  // The margin also covers the rounding of coordinates far from the origin.
  const double magnitude = std::max({std::abs(xmin), std::abs(xmax), std::abs(ymin), std::abs(ymax)});
  x0_ = xmin;
  y0_ = ymin;
  size_ = size;
  pad_ = 1e-9 * size + 1e-12 * magnitude + slack;
  cols_ = std::max<int64_t>(1, static_cast<int64_t>(std::floor(w / size)) + 1);
  rows_ = std::max<int64_t>(1, static_cast<int64_t>(std::floor(h / size)) + 1);
  const auto n = static_cast<size_t>(cols_ * rows_);
  // Counting pass, then filling (compressed rows).
  std::vector<uint32_t> count(n + 1, 0);
  for (const Segment& e : edges)
    buckets(e.a, e.b, [&](int64_t b) {
      ++count[static_cast<size_t>(b)];
      return true;
    });
  edge_start_.assign(n + 1, 0);
  for (size_t i = 0; i < n; ++i) edge_start_[i + 1] = edge_start_[i] + count[i];
  edge_ids_.resize(edge_start_[n]);
  std::vector<uint32_t> at(edge_start_.begin(), edge_start_.end() - 1);
  for (size_t i = 0; i < edges.size(); ++i)
    buckets(edges[i].a, edges[i].b, [&](int64_t b) {
      edge_ids_[at[static_cast<size_t>(b)]++] = static_cast<int32_t>(i);
      return true;
    });
  std::fill(count.begin(), count.end(), 0);
  auto bucket_of = [&](Vec2 v) { return static_cast<size_t>(row(v.y) * cols_ + column(v.x)); };
  for (const Vec2& v : vertices) ++count[bucket_of(v)];
  vertex_start_.assign(n + 1, 0);
  for (size_t i = 0; i < n; ++i) vertex_start_[i + 1] = vertex_start_[i] + count[i];
  vertex_ids_.resize(vertex_start_[n]);
  at.assign(vertex_start_.begin(), vertex_start_.end() - 1);
  for (size_t i = 0; i < vertices.size(); ++i) vertex_ids_[at[bucket_of(vertices[i])]++] = static_cast<int32_t>(i);
}

void EdgeIndex::along(Vec2 p, Vec2 q, std::vector<int32_t>& edges, std::vector<int32_t>& vertices) const {
  buckets(p, q, [&](int64_t b) {
    const auto i = static_cast<size_t>(b);
    edges.insert(edges.end(), edge_ids_.begin() + edge_start_[i], edge_ids_.begin() + edge_start_[i + 1]);
    vertices.insert(vertices.end(), vertex_ids_.begin() + vertex_start_[i], vertex_ids_.begin() + vertex_start_[i + 1]);
    return true;
  });
}

void EdgeIndex::edges_in_box(Vec2 lo, Vec2 hi, Stamps& stamps, std::vector<int32_t>& out) const {
  out.clear();
  if (stamps.of.size() < edge_count_) stamps.of.assign(edge_count_, 0);
  if (++stamps.now == 0) {  // (wrapped: every old stamp forgotten)
    std::fill(stamps.of.begin(), stamps.of.end(), 0u);
    stamps.now = 1;
  }
  const Vec2 square[4] = {lo, {hi.x, lo.y}, hi, {lo.x, hi.y}};
  cover(square, 4, 0.0, [&](const int32_t* ids, size_t n, const int32_t*, size_t) {
    for (size_t i = 0; i < n; ++i)
      if (stamps.of[static_cast<size_t>(ids[i])] != stamps.now) {
        stamps.of[static_cast<size_t>(ids[i])] = stamps.now;
        out.push_back(ids[i]);
      }
    return true;
  });
}

}  // namespace rv::sea
