// Internal: a uniform bucket grid over the point and segment sites, in the grid's local frame.
// Built once per prepared seed set (rv::PreparedSeeds), or by a solver whose context brings none,
// and then only read, from any number of threads at once.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "rv/field/planar.hpp"

namespace rv::detail {

// Buckets along one axis: span / size + 1, at most 2^14. Clamped while still a double: a span
// huge against the bucket size (seeds 1e30 apart along a thin line) or inf / inf (seeds at both
// ends of the double range) must not reach the integer conversion, which would be undefined.
inline int64_t bucket_count(double span, double size) {
  constexpr double kMax = 1 << 14;
  const double n = span / size;
  if (!(n >= 0.0)) return 1;  // NaN
  return static_cast<int64_t>(std::min(std::floor(n) + 1.0, kMax));
}

// Uniform bucket grid over the geometric sites (segments registered in every bucket they cross).
//
// A bucket's entries carry a point's coordinates, not only its id: a query over random points
// then walks memory in order. With ids alone every visit was a load from the site array in input
// order, a cache miss per site on large point sets (perf put half of the exact engine's tile
// gathering on those loads, 50 000 points). A segment's entries (about four: one per bucket it
// crosses) hold its id only; the engine reads the segment from the site array, where a
// coastline's segments lie in order along the coast. Whole copies of the sites were measured no
// faster on coastlines, for 48 bytes per entry instead of these 24 (ids alone: 4).
class BucketIndex {
 public:
  struct Entry {
    double ax, ay;  // a point's coordinates (LocalSite::ax, ay); 0 for a segment
    int32_t id;
    bool point;   // the site is a point (LocalSite::inv_len2 == 0)
    bool shared;  // registered in more than one bucket: a query over several buckets may meet it
                  // twice
  };

  BucketIndex(const std::vector<LocalSite>& local, const std::vector<int32_t>& ids) {
    double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
    for (int32_t id : ids) {
      const LocalSite& s = local[id];
      x0 = std::min({x0, s.ax, s.bx()});
      x1 = std::max({x1, s.ax, s.bx()});
      y0 = std::min({y0, s.ay, s.by()});
      y1 = std::max({y1, s.ay, s.by()});
    }
    const double w = x1 - x0, h = y1 - y0;
    const double n = std::max<double>(1.0, static_cast<double>(ids.size()) / 2.0);
    double size;
    if (w > 0.0 && h > 0.0)
      size = std::sqrt(w * h / n);
    else
      size = std::max(w, h) / n;
    if (!(size > 0.0)) size = 1.0;
    nx_ = bucket_count(w, size);
    ny_ = bucket_count(h, size);
    x0_ = x0;
    y0_ = y0;
    sx_ = std::max(w / static_cast<double>(nx_), size * 1e-9);
    sy_ = std::max(h / static_cast<double>(ny_), size * 1e-9);
    if (w == 0.0) sx_ = size;
    if (h == 0.0) sy_ = size;

    std::vector<int64_t> counts(static_cast<size_t>(nx_ * ny_) + 1, 0);
    std::vector<int32_t> buckets_of(ids.size(), 0);
    auto visit = [&](const LocalSite& s, auto&& fn) {
      const double ya = std::min(s.ay, s.by()), yb = std::max(s.ay, s.by());
      const int64_t by0 = clamp_y(ya), by1 = clamp_y(yb);
      for (int64_t by = by0; by <= by1; ++by) {
        // x-range of the segment within this bucket row's band (inclusive of its edges).
        const double band0 = y0_ + static_cast<double>(by) * sy_;
        const double band1 = band0 + sy_;
        double xa, xb;
        if (s.dy == 0.0) {
          xa = std::min(s.ax, s.bx());
          xb = std::max(s.ax, s.bx());
        } else {
          double ta = (band0 - s.ay) / s.dy, tb = (band1 - s.ay) / s.dy;
          if (ta > tb) std::swap(ta, tb);
          ta = std::clamp(ta, 0.0, 1.0);
          tb = std::clamp(tb, 0.0, 1.0);
          xa = s.ax + ta * s.dx;
          xb = s.ax + tb * s.dx;
          if (xa > xb) std::swap(xa, xb);
        }
        // One bucket of slack on each side absorbs rounding in the band clipping. A point (and a
        // horizontal segment) is not clipped: it goes in exactly the buckets its x-range maps
        // to, the ones a query's clamp_x() of the same coordinates finds. (With the slack every
        // point sat in three buckets: three times the visits per query.)
        const int64_t slack = s.dy == 0.0 ? 0 : 1;
        const int64_t bx0 = std::max<int64_t>(clamp_x(xa) - slack, 0);
        const int64_t bx1 = std::min<int64_t>(clamp_x(xb) + slack, nx_ - 1);
        for (int64_t bx = bx0; bx <= bx1; ++bx) fn(by * nx_ + bx);
      }
    };
    for (size_t i = 0; i < ids.size(); ++i)
      visit(local[ids[i]], [&](int64_t b) {
        ++counts[b + 1];
        ++buckets_of[i];
      });
    for (size_t i = 1; i < counts.size(); ++i) counts[i] += counts[i - 1];
    offsets_ = counts;
    entries_.resize(static_cast<size_t>(offsets_.back()));
    std::vector<int64_t> fill(offsets_.begin(), offsets_.end() - 1);
    for (size_t i = 0; i < ids.size(); ++i) {
      const LocalSite& s = local[ids[i]];
      const bool point = s.inv_len2 == 0.0;
      const Entry e{point ? s.ax : 0.0, point ? s.ay : 0.0, ids[i], point, buckets_of[i] > 1};
      visit(s, [&](int64_t b) { entries_[fill[b]++] = e; });
    }
  }

  int64_t clamp_x(double x) const { return clamp_bucket(std::floor((x - x0_) / sx_), nx_); }
  int64_t clamp_y(double y) const { return clamp_bucket(std::floor((y - y0_) / sy_), ny_); }

  // A bucket position clamped to [0, count - 1] before the integer conversion. NaN (inf / inf:
  // only when the sites' extent overflowed, which leaves a single bucket) is bucket 0.
  static int64_t clamp_bucket(double b, int64_t count) {
    if (!(b > 0.0)) return 0;
    return static_cast<int64_t>(std::min(b, static_cast<double>(count - 1)));
  }

  // Calls fn(entry) for every site registered in buckets [bx0, bx1] x [by0, by1] (clamped); an
  // entry with `shared` set may come more than once.
  template <class F>
  void for_range(int64_t bx0, int64_t by0, int64_t bx1, int64_t by1, F&& fn) const {
    bx0 = std::max<int64_t>(bx0, 0);
    by0 = std::max<int64_t>(by0, 0);
    bx1 = std::min(bx1, nx_ - 1);
    by1 = std::min(by1, ny_ - 1);
    for (int64_t by = by0; by <= by1; ++by)
      for (int64_t bx = bx0; bx <= bx1; ++bx) {
        const int64_t b = by * nx_ + bx;
        for (int64_t i = offsets_[b]; i < offsets_[b + 1]; ++i) fn(entries_[i]);
      }
  }

  // Calls fn(entry) for the sites of the first non-empty square ring of buckets around (x, y),
  // and of the ring after it. Any site gives a valid upper bound; near ones give a tight one.
  template <class F>
  void near(double x, double y, F&& fn) const {
    near_filtered(
        x, y, [](const Entry&) { return true; }, fn);
  }

  // Like near(), but only sites passing `keep` count as found (the others are still passed to
  // fn, which filters them itself). Visits every ring when no site passes.
  template <class Keep, class F>
  void near_filtered(double x, double y, Keep&& keep, F&& fn) const {
    const int64_t cx = clamp_x(x), cy = clamp_y(y);
    const int64_t max_ring = std::max(nx_, ny_);
    int64_t found_at = -1;
    for (int64_t ring = 0; ring <= max_ring; ++ring) {
      bool any = false;
      auto take = [&](int64_t bx, int64_t by) {
        if (bx < 0 || by < 0 || bx >= nx_ || by >= ny_) return;
        const int64_t b = by * nx_ + bx;
        for (int64_t i = offsets_[b]; i < offsets_[b + 1]; ++i) {
          fn(entries_[i]);
          any = any || keep(entries_[i]);
        }
      };
      if (ring == 0) {
        take(cx, cy);
      } else {
        for (int64_t bx = cx - ring; bx <= cx + ring; ++bx) {
          take(bx, cy - ring);
          take(bx, cy + ring);
        }
        for (int64_t by = cy - ring + 1; by <= cy + ring - 1; ++by) {
          take(cx - ring, by);
          take(cx + ring, by);
        }
      }
      if (any && found_at < 0) found_at = ring;
      if (found_at >= 0 && ring >= found_at + 1) return;
    }
  }

  double x0() const { return x0_; }
  double y0() const { return y0_; }
  double sx() const { return sx_; }
  double sy() const { return sy_; }

 private:
  double x0_, y0_, sx_, sy_;
  int64_t nx_, ny_;
  std::vector<int64_t> offsets_;
  std::vector<Entry> entries_;
};

}  // namespace rv::detail
