// The cell loop of a span method, timed: what the exact method's per-cell work would cost if each
// row's cells were already split into spans of one Voronoi region (issue 7). The engine's exact
// method finds candidates per 64x64 tile and runs an argmin per leaf; a method that scan-converts
// the Voronoi diagram instead knows each cell's site from its span, and its cell loop is one pass
// of key, root, conversion and store (the engine's own put_row). This measures that pass alone, on
// the largest point case (10000 x 10000 cells, 50 000 random points, the engine_bench
// seeds), with the spans taken from the engine's own result; building the spans (a Delaunay
// triangulation, the boundaries of each row) is not timed, so the number is a floor for such a
// method, not its cost.
//
//   span_floor_bench [--threads N] [--repeats N]
//
// Prints the engine's warm time, the span count, and the span loop's median and minimum over the
// repeats (buffers faulted before, as engine_bench --warm), and checks that the loop reproduces
// the engine's sites and distances bit for bit (same key arithmetic: -ffp-contract=off; the
// distance is the double root rounded to float). Exit status 1 if it does not.
#include <immintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <vector>

#include "../raster/src/engine/kernel_memory.hpp"
#include "bench_case.hpp"
#include "rv/engine/engine.hpp"

using namespace rv;

namespace {

constexpr int64_t kSize = 10000;  // grid edge, cells
constexpr int kSeeds = 50000;
constexpr int64_t kBandRows = 64;  // rows a thread takes at a time, as the engine's tile rows

struct Span {
  int32_t c0, c1;  // columns [c0, c1)
  int32_t site;
};

using detail::VecD4;
using VecF4 = float __attribute__((vector_size(16)));
using VecI4 = int32_t __attribute__((vector_size(16)));

// One row's spans into row scratch (td, ti): 4 cells at a time, the last vector of a span moved
// back to end at the span's end (it rewrites cells of the same span with the same values), so
// only spans shorter than 4 cells take the scalar loop.
__attribute__((target("avx2"))) void span_row(const Span* sp, const Span* end, const double* ax, const double* ay,
                                              double y, const double* px, float* td, int32_t* ti) {
  for (; sp != end; ++sp) {
    const double a = ax[sp->site], ey = y - ay[sp->site], ey2 = ey * ey;
    if (sp->c1 - sp->c0 >= 4) {
      const VecI4 id = VecI4{} + sp->site;
      for (int32_t c = sp->c0;; c += 4) {
        if (c + 4 > sp->c1) c = sp->c1 - 4;
        VecD4 x;
        std::memcpy(&x, px + c, sizeof(x));
        const VecD4 e = x - a;
        const VecD4 key = e * e + ey2;
        const VecF4 d =
            __builtin_convertvector(reinterpret_cast<VecD4>(_mm256_sqrt_pd(reinterpret_cast<__m256d>(key))), VecF4);
        std::memcpy(td + c, &d, sizeof(d));
        std::memcpy(ti + c, &id, sizeof(id));
        if (c + 4 >= sp->c1) break;
      }
    } else {
      for (int32_t c = sp->c0; c < sp->c1; ++c) {
        const double e = px[c] - a;
        td[c] = static_cast<float>(std::sqrt(e * e + ey2));
        ti[c] = sp->site;
      }
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  int threads = 2, repeats = 7;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--repeats") && i + 1 < argc)
      repeats = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: span_floor_bench [--threads N] [--repeats N]\n");
      return 2;
    }
  }
  if (!__builtin_cpu_supports("avx2")) {
    std::fprintf(stderr, "span_floor_bench: needs AVX2\n");
    return 2;
  }
  threads = std::max(threads, 1);
  repeats = std::max(repeats, 1);
  const GridSpec g = bench::square_grid(kSize);
  const SeedSet seeds = bench::random_points(kSeeds, kSize, kSize, 2019);  // engine_bench's
  ComputeOptions o;
  o.method = Method::exact;
  o.threads = threads;
  NearestField f = compute(seeds, g, o);
  compute_into(seeds, g, o, f);  // warm, as engine_bench --warm
  std::printf("engine (exact, %d threads, warm, one run): %.1f ms\n", threads, f.seconds * 1e3);

  std::vector<std::vector<Span>> spans(kSize);
  size_t count = 0;
  for (int64_t r = 0; r < kSize; ++r) {
    const int32_t* s = f.site.row(r);
    int32_t c0 = 0;
    for (int32_t c = 1; c <= kSize; ++c)
      if (c == kSize || s[c] != s[c0]) {
        spans[r].push_back({c0, c, s[c0]});
        c0 = c;
      }
    count += spans[r].size();
  }
  std::printf("spans: %zu, %.1f per row, %.1f cells each\n", count, static_cast<double>(count) / kSize,
              static_cast<double>(kSize * kSize) / count);

  // Sites and cell centres in the engine's local frame (relative to the grid origin).
  std::vector<double> ax(seeds.sites().size()), ay(ax.size()), px(kSize);
  for (size_t i = 0; i < ax.size(); ++i) {
    ax[i] = seeds.sites()[i].a.x - g.xmin;
    ay[i] = seeds.sites()[i].a.y - g.ymax;
  }
  for (int64_t c = 0; c < kSize; ++c) px[c] = g.local_x(c);
  // Laid out as the engine's results (huge-page aligned), and faulted by the fill.
  Raster<float> dist(g, 0.0f);
  Raster<int32_t> site(g, 0);

  std::vector<double> ms;
  for (int rep = 0; rep < repeats; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t)
      pool.emplace_back([&, t] {
        std::vector<float> td(kSize);
        std::vector<int32_t> ti(kSize);
        for (int64_t band = t; band * kBandRows < kSize; band += threads)
          for (int64_t r = band * kBandRows; r < std::min(kSize, (band + 1) * kBandRows); ++r) {
            const std::vector<Span>& row = spans[static_cast<size_t>(r)];
            span_row(row.data(), row.data() + row.size(), ax.data(), ay.data(), g.local_y(r), px.data(), td.data(),
                     ti.data());
            detail::put_row(dist.row(r), site.row(r), td.data(), ti.data(), kSize, true);
          }
        detail::store_fence();
      });
    for (std::thread& th : pool) th.join();
    ms.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() * 1e3);
  }
  std::sort(ms.begin(), ms.end());
  const size_t bytes = static_cast<size_t>(kSize * kSize) * 4;
  const bool same =
      std::memcmp(site.data(), f.site.data(), bytes) == 0 && std::memcmp(dist.data(), f.distance.data(), bytes) == 0;
  std::printf(
      "span cell loop, %d threads: median %.1f ms, min %.1f ms (%d repeats); "
      "identical to the engine: %s\n",
      threads, ms[ms.size() / 2], ms.front(), repeats, same ? "yes" : "NO");
  return same ? 0 : 1;
}
