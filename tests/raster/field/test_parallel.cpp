// The parallel engines under concurrency: several compute() calls at once on one shared SeedSet
// (compute() is documented reentrant), and cancellation arriving mid-computation while several
// workers run (the scans' wavefront must not wait forever for a line nobody will finish).
// Meant to be run under ThreadSanitizer too (RV_TSAN, tools/test-tsan.sh).
#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

GridSpec grid(int64_t w, int64_t h) { return test::grid_of(w, h); }

constexpr Method kMethods[] = {Method::exact, Method::hv_scan, Method::h_scan, Method::brute_force};

TEST(Parallel, ConcurrentComputationsOnOneSeedSetAgree) {
  const SeedSet s = test::random_points(120, -5, -5, 165, 125, 21);
  const GridSpec g = grid(160, 120);
  for (Method m : kMethods) {
    ComputeOptions one;
    one.method = m;
    one.threads = 1;
    const NearestField reference = compute(s, g, one);
    std::vector<NearestField> results(3);
    std::vector<std::thread> callers;
    for (size_t i = 0; i < results.size(); ++i)
      callers.emplace_back([&, i] {
        ComputeOptions o;
        o.method = m;
        o.threads = 3;
        results[i] = compute(s, g, o);
      });
    for (auto& t : callers) t.join();
    for (const NearestField& r : results) {
      EXPECT_EQ(r.site.cells(), reference.site.cells()) << to_string(m);
      EXPECT_EQ(r.distance.cells(), reference.distance.cells()) << to_string(m);
    }
  }
}

TEST(Parallel, CancellationMidwayStopsEveryWorker) {
  const SeedSet s = test::random_points(60, 0, 0, 400, 300, 22);
  const GridSpec g = grid(400, 300);
  for (Method m : kMethods) {
    for (int threads : {2, 5}) {
      std::atomic<bool> cancel{false};
      std::atomic<int> calls{0};
      ComputeOptions o;
      o.method = m;
      o.threads = threads;
      o.cancel = &cancel;
      o.progress = [&](double f) {
        ++calls;
        if (f >= 0.2) cancel = true;
      };
      try {
        compute(s, g, o);
        ADD_FAILURE() << to_string(m) << " threads " << threads << ": not cancelled";
      } catch (const Error& e) {
        EXPECT_EQ(e.kind(), ErrorKind::cancelled) << to_string(m);
      }
      EXPECT_GT(calls.load(), 0);
    }
  }
}

TEST(Parallel, ProgressIsMonotoneWithManyThreads) {
  const SeedSet s = test::random_points(40, 0, 0, 300, 200, 23);
  for (Method m : kMethods) {
    std::vector<double> seen;  // progress is never called concurrently (the contract)
    ComputeOptions o;
    o.method = m;
    o.threads = 4;
    o.progress = [&](double f) { seen.push_back(f); };
    compute(s, grid(300, 200), o);
    ASSERT_FALSE(seen.empty()) << to_string(m);
    for (size_t i = 1; i < seen.size(); ++i) EXPECT_GT(seen[i], seen[i - 1]) << to_string(m);
    EXPECT_GE(seen.front(), 0.0) << to_string(m);
    EXPECT_LE(seen.back(), 1.0) << to_string(m);
  }
}

}  // namespace
}  // namespace rv
