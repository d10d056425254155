// The edit core (rv/edit/edit.hpp) on the case: 50,000 random point seeds on a square grid,
// one removed, one added, one moved. Prints, per edit, the cells that changed against the cells
// recomputed, and the plan's and the masked computation's wall time against a fresh exact run
// of the edited seeds (the results compared cell for cell).
//
// usage: edit_bench [SIZE=4000] [ROUNDS=3] [THREADS=0]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "../bench_case.hpp"
#include "rv/edit/edit.hpp"
#include "rv/engine/engine.hpp"

using namespace rv;

namespace {

double seconds_of(const std::chrono::steady_clock::time_point& t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// The edited set: `kind` 0 removes point k, 1 adds one near it, 2 moves it by 5 cells.
SeedSet edited_set(const SeedSet& base, int kind, int k) {
  SeedSet s;
  const auto& sites = base.sites();
  for (int i = 0; i < static_cast<int>(sites.size()); ++i) {
    if (kind == 0 && i == k) continue;
    Vec2 p = sites[static_cast<size_t>(i)].a;
    if (kind == 2 && i == k) p = Vec2{p.x + 5.0, p.y - 3.0};
    s.add_point(s.add_feature(s.owner_code(std::to_string(i + 1))), p);
    if (kind == 1 && i == k) s.add_point(s.add_feature(s.owner_code("new")), Vec2{p.x + 7.5, p.y + 2.5});
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  const int64_t size = argc > 1 ? std::atoll(argv[1]) : 4000;
  const int rounds = argc > 2 ? std::atoi(argv[2]) : 3;
  ComputeOptions o;
  o.threads = argc > 3 ? std::atoi(argv[3]) : 0;
  const GridSpec g = bench::square_grid(size);
  const SeedSet base_seeds = bench::random_points(50000, static_cast<double>(size), static_cast<double>(size), 7);
  const NearestField base = compute(base_seeds, g, o);
  std::printf("grid %lld x %lld, 50000 points\n", static_cast<long long>(size), static_cast<long long>(size));
  std::printf("%-7s %10s %10s %10s %10s %10s %s\n", "edit", "changed", "recomputed", "plan_s", "masked_s", "fresh_s",
              "equal");
  const char* names[] = {"remove", "add", "move"};
  for (int kind = 0; kind < 3; ++kind)
    for (int round = 0; round < rounds; ++round) {
      const SeedSet edited = edited_set(base_seeds, kind, 1000 + 7919 * round);
      auto t = std::chrono::steady_clock::now();
      const EditPlan plan = plan_edit(base, base_seeds, edited, g, o);
      const double plan_s = seconds_of(t);
      t = std::chrono::steady_clock::now();
      const NearestField result = apply_edit(base, base_seeds, edited, g, o, plan);
      const double masked_s = seconds_of(t);
      t = std::chrono::steady_clock::now();
      const NearestField fresh = compute(edited, g, o);
      const double fresh_s = seconds_of(t);
      int64_t changed = 0, differ = 0;
      const std::vector<int32_t> remap = edited_sites(base_seeds, edited, plan.match);
      for (size_t i = 0; i < fresh.site.cells().size(); ++i) {
        const int32_t s = base.site.cells()[i];
        const int32_t was = s == kNoSite ? kNoSite : remap[static_cast<size_t>(s)];
        changed += was != fresh.site.cells()[i] || base.distance.cells()[i] != fresh.distance.cells()[i];
        differ += result.site.cells()[i] != fresh.site.cells()[i] ||
                  std::memcmp(&result.distance.cells()[i], &fresh.distance.cells()[i], sizeof(float)) != 0;
      }
      std::printf("%-7s %10lld %10lld %10.4f %10.4f %10.4f %s\n", names[kind], static_cast<long long>(changed),
                  static_cast<long long>(plan.cells), plan_s, masked_s, fresh_s, differ == 0 ? "yes" : "NO");
    }
  return 0;
}
