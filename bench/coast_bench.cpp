// A coastline-sized case for the exact method and the hv-scan: two owners' coasts as closed
// polygons with tens of thousands of segments (a fractal-like random walk around an island and
// a mainland), on a grid of 1e7 cells or more. Prints ns per cell and the hv-scan's error
// against exact (equal to brute force, as the test suite asserts).
//
//   coast_bench [--segments N] [--width W] [--height H] [--threads N]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/validate.hpp"

using namespace rv;

namespace {

// A closed, non-self-intersecting ring: a star-shaped polygon around (cx, cy) whose radius is a
// sum of random harmonics (so the coast is wiggly at every scale), sampled at n vertices.
Ring wiggly_ring(double cx, double cy, double radius, int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> phase(0.0, 2.0 * M_PI);
  struct Harmonic {
    double k, amp, ph;
  };
  std::vector<Harmonic> hs;
  for (int k = 2; k <= 64; k *= 2) hs.push_back({static_cast<double>(k), 0.25 / std::sqrt(k), phase(rng)});
  Ring ring;
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * M_PI * i / n;
    double r = 1.0;
    for (const Harmonic& h : hs) r += h.amp * std::sin(h.k * t + h.ph) / 2.0;
    ring.push_back({cx + radius * r * std::cos(t), cy + radius * r * std::sin(t)});
  }
  return ring;
}

}  // namespace

int main(int argc, char** argv) {
  int segments = 40000, threads = 0;
  int64_t width = 4000, height = 2500;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--segments") && i + 1 < argc)
      segments = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--width") && i + 1 < argc)
      width = std::atoll(argv[++i]);
    else if (!std::strcmp(argv[i], "--height") && i + 1 < argc)
      height = std::atoll(argv[++i]);
    else if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: coast_bench [--segments N] [--width W] [--height H] [--threads N]\n");
      return 2;
    }
  }
  GridSpec g;
  g.xmin = 0;
  g.ymax = static_cast<double>(height);
  g.res = 1;
  g.width = width;
  g.height = height;
  std::mt19937_64 rng(7);
  SeedSet seeds;
  const double w = static_cast<double>(width), h = static_cast<double>(height);
  // Owner A: an island left of centre; owner B: two islands on the right. Segments split 50/25/25.
  seeds.add_polygon(seeds.add_feature(seeds.owner_code("A")),
                    {wiggly_ring(0.3 * w, 0.5 * h, 0.2 * h, segments / 2, rng)});
  const int32_t b = seeds.owner_code("B");
  seeds.add_polygon(seeds.add_feature(b), {wiggly_ring(0.75 * w, 0.3 * h, 0.12 * h, segments / 4, rng)});
  seeds.add_polygon(seeds.add_feature(b), {wiggly_ring(0.75 * w, 0.75 * h, 0.12 * h, segments / 4, rng)});

  std::printf("coastline case: %lld x %lld cells (%.1e), %lld segments, 2 owners\n\n", (long long)width,
              (long long)height, static_cast<double>(width * height), (long long)seeds.geometric_site_count());
  std::printf(
      "| method | seconds | ns/cell | × exact | wrong cells | wrong owner cells | max Δd (cells) "
      "|\n|---|---|---|---|---|---|---|\n");
  ComputeOptions o;
  o.threads = threads;
  o.method = Method::exact;
  const NearestField exact = compute(seeds, g, o);
  const double cells = static_cast<double>(width * height);
  std::printf("| exact | %.3f | %.2f | 1.0 | 0 | 0 | 0 |\n", exact.seconds, exact.seconds * 1e9 / cells);
  std::fflush(stdout);
  for (Method m : {Method::hv_scan, Method::h_scan}) {
    o.method = m;
    const NearestField f = compute(seeds, g, o);
    const ValidationStats v = compare_fields(seeds, f, exact);
    std::printf("| %s | %.3f | %.2f | %.1f | %lld | %lld | %.3f |\n", std::string(to_string(m)).c_str(), f.seconds,
                f.seconds * 1e9 / cells, f.seconds / exact.seconds, (long long)v.wrong_cells,
                (long long)v.wrong_owner_cells, v.max_error_cells);
    std::fflush(stdout);
  }
  return 0;
}
