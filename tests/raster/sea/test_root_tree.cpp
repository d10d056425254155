// The roots' search tree (raster/src/sea/root_tree.hpp) against brute force: which items a search
// visits (resumed searches that skip what was searched before, whole subtrees at once, included),
// and in what order nearest() hands them over, while weights are set, raised and removed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "sea/root_tree.hpp"

namespace rv {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The bound the tree gives item i from x: its weight plus the distance to its box, scaled.
double bound_of(const sea::RootTree::Box& b, double w, Vec2 x, double scale) {
  const double dx = std::max({b.lo.x - x.x, 0.0, x.x - b.hi.x});
  const double dy = std::max({b.lo.y - x.y, 0.0, x.y - b.hi.y});
  return w + std::sqrt(dx * dx + dy * dy) * scale;
}

// Random boxes (points and small boxes, clustered and spread), weights set in rounds as a
// settling sets them; after each round, searches from random points with and without a resumed
// search's `since` and `seen`: the items visited are exactly brute force's, each once.
TEST(RootTree, ASearchVisitsExactlyTheItemsWithinItsLimitNotSearchedBefore) {
  std::mt19937_64 rng(72);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int64_t searches = 0, visited = 0, skipped_as_searched = 0;
  for (int layout = 0; layout < 20; ++layout) {
    const int n = 50 + static_cast<int>(u(rng) * 2000);
    const double scale = layout % 2 ? 1.0 : 0.83;
    std::vector<sea::RootTree::Box> boxes;
    for (int i = 0; i < n; ++i) {
      // Half of them in clusters (a detailed coast), half spread; a third are boxes.
      const double cx = i % 2 ? 100.0 * u(rng) : 20.0 * std::floor(5.0 * u(rng)) + u(rng);
      const double cy = i % 2 ? 100.0 * u(rng) : 20.0 * std::floor(5.0 * u(rng)) + u(rng);
      const double w = i % 3 == 0 ? 2.0 * u(rng) : 0.0, h = i % 3 == 0 ? 2.0 * u(rng) : 0.0;
      boxes.push_back({{cx, cy}, {cx + w, cy + h}});
    }
    sea::RootTree tree(boxes, scale);
    std::vector<double> weight(static_cast<size_t>(n), kInf);
    std::vector<uint64_t> stamp(static_cast<size_t>(n), 0);
    for (int round = 0; round < 8; ++round) {
      // Some items get a weight (settled), some lose it (+infinity), some are raised.
      for (int k = 0; k < n / 6; ++k) {
        const auto i = static_cast<int32_t>(u(rng) * n);
        const double w = u(rng) < 0.15 ? kInf : 10.0 * round + 30.0 * u(rng);
        tree.set_weight(i, w);
        weight[static_cast<size_t>(i)] = w;
        stamp[static_cast<size_t>(i)] = tree.stamp();
      }
      for (int q = 0; q < 30; ++q) {
        const Vec2 x{120.0 * u(rng) - 10.0, 120.0 * u(rng) - 10.0};
        const double limit = q % 5 == 0 ? kInf : 20.0 + 80.0 * u(rng);
        const bool resumed = q % 2 == 1;
        const uint64_t since = resumed ? static_cast<uint64_t>(u(rng) * static_cast<double>(tree.stamp() + 1)) : 0;
        const double seen = resumed ? (q % 4 == 1 ? kInf : limit * u(rng)) : kInf;
        std::vector<int> times(static_cast<size_t>(n), 0);
        tree.within(
            x, [&] { return limit; },
            [&](int32_t item, double bound) {
              ++times[static_cast<size_t>(item)];
              EXPECT_EQ(bound, bound_of(boxes[static_cast<size_t>(item)], weight[static_cast<size_t>(item)], x, scale));
            },
            since, seen);
        ++searches;
        for (int i = 0; i < n; ++i) {
          const auto k = static_cast<size_t>(i);
          const double b = bound_of(boxes[k], weight[k], x, scale);
          const bool before = stamp[k] <= since && (std::isinf(seen) || b <= seen);
          const bool want = std::isfinite(weight[k]) && b <= limit && !before;
          ASSERT_EQ(times[k], want ? 1 : 0)
              << "layout " << layout << ", round " << round << ", item " << i << ": bound " << b << ", limit " << limit
              << ", since " << since << " (stamp " << stamp[k] << "), seen " << seen;
          visited += times[k];
          skipped_as_searched += std::isfinite(weight[k]) && b <= limit && before;
        }
      }
    }
  }
  std::printf("searches %lld: items visited %lld, skipped as searched before %lld\n", static_cast<long long>(searches),
              static_cast<long long>(visited), static_cast<long long>(skipped_as_searched));
  EXPECT_GT(visited, 100000);
  EXPECT_GT(skipped_as_searched, 100000);
}

// nearest() hands over every present item once, in nondecreasing order of its bound, until told
// to stop.
TEST(RootTree, NearestHandsOverThePresentItemsInOrderOfTheirBound) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int layout = 0; layout < 20; ++layout) {
    const int n = 20 + static_cast<int>(u(rng) * 800);
    std::vector<sea::RootTree::Box> boxes;
    for (int i = 0; i < n; ++i) {
      const double cx = 50.0 * u(rng), cy = 50.0 * u(rng);
      boxes.push_back({{cx, cy}, {cx + (i % 4 == 0 ? u(rng) : 0.0), cy}});
    }
    sea::RootTree tree(boxes);
    std::vector<double> weight(static_cast<size_t>(n), kInf);
    for (int i = 0; i < n; ++i)
      if (u(rng) < 0.8) {
        weight[static_cast<size_t>(i)] = 5.0 * u(rng);
        tree.set_weight(i, weight[static_cast<size_t>(i)]);
      }
    const Vec2 x{60.0 * u(rng) - 5.0, 60.0 * u(rng) - 5.0};
    std::vector<double> want;
    for (int i = 0; i < n; ++i)
      if (std::isfinite(weight[static_cast<size_t>(i)]))
        want.push_back(bound_of(boxes[static_cast<size_t>(i)], weight[static_cast<size_t>(i)], x, 1.0));
    std::sort(want.begin(), want.end());
    std::vector<double> got;
    std::vector<int> times(static_cast<size_t>(n), 0);
    tree.nearest(x, [&](int32_t item, double bound) {
      ++times[static_cast<size_t>(item)];
      got.push_back(bound);
      return true;
    });
    ASSERT_EQ(got, want) << "layout " << layout;
    for (int i = 0; i < n; ++i) ASSERT_EQ(times[static_cast<size_t>(i)], std::isfinite(weight[static_cast<size_t>(i)]));
    // Stopped after the tenth: ten handed over.
    int count = 0;
    tree.nearest(x, [&](int32_t, double) { return ++count < 10; });
    EXPECT_EQ(count, std::min<int>(10, static_cast<int>(want.size())));
  }
}

}  // namespace
}  // namespace rv
