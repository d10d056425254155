// A uniform grid of buckets over the barriers' edges and vertices: which of them a straight
// segment may meet, in time proportional to the buckets it crosses rather than to the barriers.
//
// The answer is a superset (every edge that meets the closed segment, every vertex on it, and
// some that do not): the exact predicates decide. Buckets are walked with a margin of a
// billionth of their size, so rounding in the walk never drops a bucket the segment touches.
// Immutable once built; const access from any number of threads.
#pragma once

#include <algorithm>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "rv/field/seeds.hpp"

namespace rv::sea {

class EdgeIndex {
 public:
  struct Segment {
    Vec2 a, b;
  };
  // About two buckets per edge over the bounding box of the vertices and the edges' ends, at most
  // 4096 a side. `slack`: how
  // far a segment's true course may stray from its chord (a geodesic's image: the frame's
  // deviation); the walk widens by it.
  EdgeIndex(const std::vector<Segment>& edges, const std::vector<Vec2>& vertices, double slack = 0.0);
  EdgeIndex() = default;

  // Appends the edges and vertices of every bucket the closed segment p-q may meet (each once
  // per bucket; the caller removes repeats when it needs to).
  void along(Vec2 p, Vec2 q, std::vector<int32_t>& edges, std::vector<int32_t>& vertices) const;
  // The buckets a closed segment may meet, as indices, from p's end towards q's (rows, then
  // columns within a row); f returns false to stop the walk.
  template <class F>
  void buckets(Vec2 p, Vec2 q, F&& f) const;
  // Calls f(edges, edge count, vertices, vertex count) bucket by bucket along p-q, from p's end,
  // until it returns false.
  template <class F>
  void visit(Vec2 p, Vec2 q, F&& f) const {
    buckets(p, q, [&](int64_t b) {
      const auto i = static_cast<size_t>(b);
      return f(edge_ids_.data() + edge_start_[i], edge_start_[i + 1] - edge_start_[i],
               vertex_ids_.data() + vertex_start_[i], vertex_start_[i + 1] - vertex_start_[i]);
    });
  }

  // Calls f(edges, edge count, vertices, vertex count) for every bucket a convex polygon
  // (`poly`, n >= 1 vertices in order) widened by `margin` may meet, row by row, until f returns
  // false: every edge that comes within `margin` of the polygon and every vertex within it are met.
  template <class F>
  void cover(const Vec2* poly, int n, double margin, F&& f) const;

  int64_t bucket_count() const { return cols_ * rows_; }

  // The edges of every bucket the box [lo, hi] meets, each once, in `out` (cleared first): a
  // superset of those that meet the box. `stamps`: the caller's scratch, kept from call to call
  // (one entry per edge once used), so that repeated boxes cost their buckets, not the edges.
  struct Stamps {
    std::vector<uint32_t> of;
    uint32_t now = 0;
  };
  void edges_in_box(Vec2 lo, Vec2 hi, Stamps& stamps, std::vector<int32_t>& out) const;

 private:
  int64_t column(double x) const;
  int64_t row(double y) const;

  size_t edge_count_ = 0;
  double x0_ = 0, y0_ = 0, size_ = 1, pad_ = 0;
  int64_t cols_ = 0, rows_ = 0;
  std::vector<uint32_t> edge_start_, vertex_start_;  // per bucket, then one past the last
  std::vector<int32_t> edge_ids_, vertex_ids_;
};

template <class F>
void EdgeIndex::buckets(Vec2 p, Vec2 q, F&& f) const {
  if (cols_ == 0) return;
  const double ymin = std::min(p.y, q.y) - pad_, ymax = std::max(p.y, q.y) + pad_;
  const double top = y0_ + static_cast<double>(rows_) * size_, right = x0_ + static_cast<double>(cols_) * size_;
  if (ymax < y0_ || ymin > top || std::max(p.x, q.x) + pad_ < x0_ || std::min(p.x, q.x) - pad_ > right) return;
  const int64_t r_first = row(p.y <= q.y ? ymin : ymax), r_last = row(p.y <= q.y ? ymax : ymin);
  const int64_t r_step = r_first <= r_last ? 1 : -1;
  for (int64_t r = r_first;; r += r_step) {
    // The segment's x-range within this row of buckets (widened by the margin).
    const double lo = std::max(ymin, y0_ + static_cast<double>(r) * size_ - pad_);
    const double hi = std::min(ymax, y0_ + static_cast<double>(r + 1) * size_ + pad_);
    double xa, xb;
    if (p.y == q.y) {
      xa = std::min(p.x, q.x);
      xb = std::max(p.x, q.x);
    } else {
      const double slope = (q.x - p.x) / (q.y - p.y);
      const double ya = std::clamp(lo, std::min(p.y, q.y), std::max(p.y, q.y));
      const double yb = std::clamp(hi, std::min(p.y, q.y), std::max(p.y, q.y));
      xa = p.x + (ya - p.y) * slope;
      xb = p.x + (yb - p.y) * slope;
      if (xa > xb) std::swap(xa, xb);
    }
    xa -= pad_;
    xb += pad_;
    if (!(xb < x0_ || xa > right)) {
      const int64_t c0 = column(xa), c1 = column(xb);
      if (p.x <= q.x) {
        for (int64_t c = c0; c <= c1; ++c)
          if (!f(r * cols_ + c)) return;
      } else {
        for (int64_t c = c1; c >= c0; --c)
          if (!f(r * cols_ + c)) return;
      }
    }
    if (r == r_last) break;
  }
}

template <class F>
void EdgeIndex::cover(const Vec2* poly, int n, double margin, F&& f) const {
  if (cols_ == 0 || n <= 0) return;
  const double pad = pad_ + margin;
  double xmin = poly[0].x, xmax = xmin, ymin = poly[0].y, ymax = ymin;
  for (int i = 1; i < n; ++i) {
    xmin = std::min(xmin, poly[i].x);
    xmax = std::max(xmax, poly[i].x);
    ymin = std::min(ymin, poly[i].y);
    ymax = std::max(ymax, poly[i].y);
  }
  const double top = y0_ + static_cast<double>(rows_) * size_, right = x0_ + static_cast<double>(cols_) * size_;
  if (ymax + pad < y0_ || ymin - pad > top || xmax + pad < x0_ || xmin - pad > right) return;
  for (int64_t r = row(ymin - pad), r_last = row(ymax + pad); r <= r_last; ++r) {
    // The polygon's x-extent within this row of buckets widened by the pad: a convex polygon's
    // is that of its boundary clipped to the row.
    const double lo = y0_ + static_cast<double>(r) * size_ - pad, hi = y0_ + static_cast<double>(r + 1) * size_ + pad;
    double xa = std::numeric_limits<double>::infinity(), xb = -xa;
    for (int i = 0; i < n; ++i) {
      const Vec2 a = poly[i], b = poly[(i + 1) % n];
      if (std::max(a.y, b.y) < lo || std::min(a.y, b.y) > hi) continue;
      if (a.y == b.y) {
        xa = std::min({xa, a.x, b.x});
        xb = std::max({xb, a.x, b.x});
        continue;
      }
      for (const double y : {lo, hi}) {
        const double t = std::clamp((y - a.y) / (b.y - a.y), 0.0, 1.0);
        const double x = a.x + t * (b.x - a.x);
        xa = std::min(xa, x);
        xb = std::max(xb, x);
      }
    }
    if (!(xa <= xb)) continue;
    xa -= pad;
    xb += pad;
    if (xb < x0_ || xa > right) continue;
    for (int64_t c = column(xa), c_last = column(xb); c <= c_last; ++c) {
      const auto i = static_cast<size_t>(r * cols_ + c);
      if (!f(edge_ids_.data() + edge_start_[i], edge_start_[i + 1] - edge_start_[i],
             vertex_ids_.data() + vertex_start_[i], vertex_start_[i + 1] - vertex_start_[i]))
        return;
    }
  }
}

}  // namespace rv::sea
