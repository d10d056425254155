// Times the maritime deliverables against the engine on random seeds: points and coastline-like
// polylines of several owners on an N x N grid. Prints one markdown row per grid size.
//
//   deliver_bench [--sizes 1000,2000] [--owners K] [--threads N]
#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/margin.hpp"

using namespace rv;

namespace {

double since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Each owner: 20 points and 5 wiggly polylines of 40 vertices, scattered over the grid.
SeedSet scene(int owners, double size, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, size), step(-size / 200, size / 200);
  SeedSet s;
  for (int o = 0; o < owners; ++o) {
    const int32_t code = s.owner_code("owner" + std::to_string(o + 1));
    for (int i = 0; i < 20; ++i) s.add_point(s.add_feature(code), {u(rng), u(rng)});
    for (int i = 0; i < 5; ++i) {
      std::vector<Vec2> line{{u(rng), u(rng)}};
      for (int k = 0; k < 39; ++k) line.push_back({line.back().x + step(rng), line.back().y + step(rng)});
      s.add_polyline(s.add_feature(code), line);
    }
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int64_t> sizes{1000, 2000};
  int owners = 8, threads = 0;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--sizes") && i + 1 < argc) {
      sizes.clear();
      for (char* tok = std::strtok(argv[++i], ","); tok; tok = std::strtok(nullptr, ","))
        sizes.push_back(std::atoll(tok));
    } else if (!std::strcmp(argv[i], "--owners") && i + 1 < argc) {
      owners = std::atoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--threads") && i + 1 < argc) {
      threads = std::atoi(argv[++i]);
    }
  }
  std::printf(
      "| grid | sites | owners | exact s | boundaries s | lines | vertices | tripoints | max residual (cells) | "
      "limits (2 distances) s | limit vertices | per owner s | per-owner vertices | margin s |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (int64_t n : sizes) {
    const SeedSet s = scene(owners, static_cast<double>(n), 42);
    GridSpec g;
    g.xmin = 0;
    g.ymax = static_cast<double>(n);
    g.res = 1.0;
    g.width = n;
    g.height = n;
    ComputeOptions co;
    co.threads = threads;
    const NearestField f = compute(s, g, co);
    const PlanarSiteMetric metric(s, Vec2{g.xmin, g.ymax});
    const OwnerIndex index(metric);
    auto t = std::chrono::steady_clock::now();
    BoundaryOptions bo;
    bo.threads = threads;
    const BoundaryResult b = extract_boundaries(f, index, bo);
    const double tb = since(t);
    t = std::chrono::steady_clock::now();
    LimitOptions lo;
    lo.threads = threads;
    const std::vector<double> ds{static_cast<double>(n) / 50, static_cast<double>(n) / 20};
    const LimitResult l = extract_limits(f, index, ds, lo);
    const double tl = since(t);
    t = std::chrono::steady_clock::now();
    lo.per_owner = true;
    const LimitResult lp = extract_limits(f, index, ds, lo);
    const double tlp = since(t);
    t = std::chrono::steady_clock::now();
    const Raster<float> m = margin_raster(f, index, threads);
    const double tm = since(t);
    std::printf("| %lld² | %zu | %d | %.3f | %.3f | %zu | %lld | %zu | %.2e | %.3f | %lld | %.3f | %lld | %.3f |\n",
                static_cast<long long>(n), s.sites().size(), owners, f.seconds, tb, b.lines.size(),
                static_cast<long long>(b.stats.vertices), b.tripoints.size(), b.stats.max_residual / g.res, tl,
                static_cast<long long>(l.vertices), tlp, static_cast<long long>(lp.vertices), tm);
    std::fflush(stdout);
  }
  return 0;
}
