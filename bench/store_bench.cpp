// The floor under the engine: what merely writing its results costs on this machine. The exact
// method writes 8 bytes per cell (an Int32 site id and a Float32 distance) into two rasters;
// this writes the same bytes into two buffers of the same size, laid out as the engine's
// (2 MiB aligned, huge pages advised: rv::detail::allocate_cells) and already faulted in (as the
// engine's reused buffers are), in the ways a kernel could write them:
//
//   nt16 interleaved   16-byte non-temporal stores, distance and id alternating every 4 cells
//                      (put_row before the fourteenth session)
//   nt16 by row part   16-byte non-temporal stores, 32 distances then their 32 ids (put_row:
//                      a leaf's row of 32 cells)
//   nt32 interleaved   32-byte non-temporal stores, alternating every 8 cells
//   ordinary           16-byte ordinary stores, interleaved (each line is read before written)
//
// The two buffers start at the same offset from a 4 KiB boundary, as the engine's rasters do;
// --offset B moves the ids B bytes further, to see what that alignment costs.
//
//   store_bench [--cells N] [--threads N] [--repeats N] [--offset B]
//
// Prints one markdown row per store kind: median and range of the repeats in ms, ns per cell
// and GB/s. Threads split the cells into contiguous halves, as the engine's tiles fill the
// rasters. Quote it beside engine_bench --warm of the same grid, in the same sitting.
#include <immintrin.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <sys/mman.h>

namespace {

using Clock = std::chrono::steady_clock;

struct Buffers {
  float* distance = nullptr;
  int32_t* site = nullptr;
  int64_t cells = 0;
};

constexpr size_t kHuge = size_t{2} << 20;

// 2 MiB aligned, huge pages advised (as allocate_cells gives large rasters), `offset` bytes in,
// faulted in. Never freed (the process ends).
void* faulted(size_t bytes, size_t offset) {
  const size_t rounded = (bytes + offset + kHuge - 1) / kHuge * kHuge;
  char* p = static_cast<char*>(std::aligned_alloc(kHuge, rounded));
  if (p == nullptr) {
    std::fprintf(stderr, "store_bench: out of memory\n");
    std::exit(1);
  }
  madvise(p, rounded, MADV_HUGEPAGE);
  std::memset(p, 0, rounded);
  return p + offset;
}

void fill_nt16_parts(const Buffers& b, int64_t c0, int64_t c1, float d, int32_t s) {
  const __m128 dv = _mm_set1_ps(d);
  const __m128i sv = _mm_set1_epi32(s);
  for (int64_t c = c0; c < c1; c += 32) {
    const int64_t e = std::min(c + 32, c1);
    for (int64_t k = c; k < e; k += 4) _mm_stream_ps(b.distance + k, dv);
    for (int64_t k = c; k < e; k += 4) _mm_stream_si128(reinterpret_cast<__m128i*>(b.site + k), sv);
  }
  _mm_sfence();
}

// 16-byte stores, distance and id alternating every 4 cells: streaming or ordinary ones.
template <bool kStream>
void fill_interleaved16(const Buffers& b, int64_t c0, int64_t c1, float d, int32_t s) {
  const __m128 dv = _mm_set1_ps(d);
  const __m128i sv = _mm_set1_epi32(s);
  for (int64_t c = c0; c < c1; c += 4) {
    auto* site = reinterpret_cast<__m128i*>(b.site + c);
    if constexpr (kStream) {
      _mm_stream_ps(b.distance + c, dv);
      _mm_stream_si128(site, sv);
    } else {
      _mm_storeu_ps(b.distance + c, dv);
      _mm_storeu_si128(site, sv);
    }
  }
  if constexpr (kStream) _mm_sfence();
}

__attribute__((target("avx"))) void fill_nt32(const Buffers& b, int64_t c0, int64_t c1, float d, int32_t s) {
  const __m256 dv = _mm256_set1_ps(d);
  const __m256i sv = _mm256_set1_epi32(s);
  for (int64_t c = c0; c < c1; c += 8) {
    _mm256_stream_ps(b.distance + c, dv);
    _mm256_stream_si256(reinterpret_cast<__m256i*>(b.site + c), sv);
  }
  _mm_sfence();
}

using Fill = void (*)(const Buffers&, int64_t, int64_t, float, int32_t);

// Wall time in ms of each repeat: every thread fills its contiguous share (a multiple of 8 cells).
std::vector<double> run(const Buffers& b, Fill fill, int threads, int repeats) {
  std::vector<double> ms;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = Clock::now();
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) {
      const int64_t c0 = b.cells * t / threads / 8 * 8, c1 = b.cells * (t + 1) / threads / 8 * 8;
      pool.emplace_back(fill, std::cref(b), c0, c1, 1.0f + static_cast<float>(r), r);
    }
    for (std::thread& t : pool) t.join();
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  return ms;
}

}  // namespace

int main(int argc, char** argv) {
  int64_t cells = 100'000'000;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  int repeats = 7;
  int64_t offset = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--cells" && i + 1 < argc)
      cells = std::atoll(argv[++i]);
    else if (a == "--threads" && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (a == "--repeats" && i + 1 < argc)
      repeats = std::atoi(argv[++i]);
    else if (a == "--offset" && i + 1 < argc)
      offset = std::atoll(argv[++i]);
    else {
      std::fprintf(stderr, "usage: store_bench [--cells N] [--threads N] [--repeats N] [--offset B]\n");
      return 2;
    }
  }
  if (cells < 8 || threads < 1 || repeats < 1 || offset < 0 || offset % 32 != 0) {
    std::fprintf(stderr,
                 "store_bench: --cells >= 8, --threads >= 1, --repeats >= 1, --offset a multiple "
                 "of 32\n");
    return 2;
  }
  cells = cells / 8 * 8;
  Buffers b;
  b.cells = cells;
  b.distance = static_cast<float*>(faulted(static_cast<size_t>(cells) * sizeof(float), 0));
  b.site = static_cast<int32_t*>(faulted(static_cast<size_t>(cells) * sizeof(int32_t), static_cast<size_t>(offset)));
  const bool avx = __builtin_cpu_supports("avx");

  std::printf(
      "%lld cells (%.0f MB written per repeat), %d thread(s), %d repeats, ids %lld bytes "
      "off the distances' alignment\n\n",
      static_cast<long long>(cells), static_cast<double>(cells) * 8 / 1e6, threads, repeats,
      static_cast<long long>(offset));
  std::printf("| stores | ms (median) | ms (min - max) | ns/cell | GB/s |\n|---|---|---|---|---|\n");
  const struct {
    const char* name;
    Fill fill;
    bool needs_avx;
  } kinds[] = {{"nt16 interleaved", fill_interleaved16<true>, false},
               {"nt16 by row part (put_row)", fill_nt16_parts, false},
               {"nt32 interleaved", fill_nt32, true},
               {"ordinary (16-byte, interleaved)", fill_interleaved16<false>, false}};
  for (const auto& k : kinds) {
    if (k.needs_avx && !avx) {
      std::printf("| %s | — | — | — | — (no AVX) |\n", k.name);
      continue;
    }
    const std::vector<double> ms = run(b, k.fill, threads, repeats);
    const double med = ms[ms.size() / 2];
    std::printf("| %s | %.1f | %.1f - %.1f | %.3f | %.1f |\n", k.name, med, ms.front(), ms.back(),
                med * 1e6 / static_cast<double>(cells), static_cast<double>(cells) * 8 / (med * 1e-3) / 1e9);
  }
  return 0;
}
