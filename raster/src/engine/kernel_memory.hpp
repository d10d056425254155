// Internal: memory helpers of the kernels. Storage aligned to a cache line for their scratch
// rows, the non-temporal copy of finished result rows, and the CPU-specific clones of the row
// kernels.
//
// Why aligned scratch: the kernels load and store 32-byte vectors at offsets that are multiples
// of 32 bytes from a row's start. From the default heap (16-byte alignment) every other such
// access straddles two cache lines; on the exact method's row scratch that cost a 1-thread run
// half its time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#define RV_STREAM_STORES 1
#endif

#include "rv/field/grid.hpp"
#include "rv/field/raster.hpp"

// The row kernels' clones, one picked at load time for the CPU (an ifunc): x86-64-v4 (AVX-512;
// faster than the AVX2 clone where the CPU has it: bench/RESULTS-kernels.md), AVX2, and the
// default. Every clone
// computes bit-identical keys and distances (-ffp-contract=off: no fused multiply-add in any),
// so the choice changes speed only.
//
// Builds with sanitizers test the other clones: ThreadSanitizer instruments the ifunc resolver,
// which the dynamic loader runs before the TSan runtime is initialised (a crash at startup), so
// TSan builds get the default clone only; AddressSanitizer builds leave out the x86-64-v4 clone,
// so that the CI's sanitizer stage runs the AVX2 clone where the main stage runs x86-64-v4.
#if defined(__SANITIZE_THREAD__)
#define RV_KERNEL_CLONES
#elif defined(__SANITIZE_ADDRESS__) || defined(__clang__)
// (Clang 14 defines no __SANITIZE_ADDRESS__, and its resolver picked the x86-64-v4 clone on a
// CPU without AVX-512: an illegal instruction in the sanitizer build. Clang builds, the
// sanitizer stage's and the fuzz targets', take the AVX2 clone at most.)
#define RV_KERNEL_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define RV_KERNEL_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#endif

// Kernels written for one vector width per instruction set: `name` defined once per version
// (GCC's function multiversioning, the same ifunc pick as RV_KERNEL_CLONES), each running the
// template name##_lanes<V> with V the widest double vector its registers hold: 8 lanes
// (x86-64-v4), 4 (AVX2), 2 (the default, SSE2). A template body is inlined into each version
// (RV_LANES_INLINE) and compiled for its instruction set.
//
// Why not one 8-wide body in target_clones: GCC 12 lowers a 64-byte vector's compares and
// selects in the AVX2 clone through the stack, element by element: on a CPU without AVX-512
// that clone made both exact methods several times slower (bench/RESULTS-kernels.md).
// The lanes of every width compute the same operations on the same operands, so every version
// gives the same bits.
#define RV_LANES_INLINE __attribute__((always_inline)) inline
#define RV_LANE_VERSION(target_, lanes_, ret, name, params, args) \
  __attribute__((target(target_))) ret name params { return name##_lanes<::rv::detail::VecD##lanes_> args; }
#if defined(__SANITIZE_THREAD__)
#define RV_LANE_KERNEL(ret, name, params, args) \
  ret name params { return name##_lanes<::rv::detail::VecD2> args; }
#elif defined(__SANITIZE_ADDRESS__) || defined(__clang__)
// (Clang, which builds the fuzz targets: its multiversioning takes no x86-64-v4.)
#define RV_LANE_KERNEL(ret, name, params, args)       \
  RV_LANE_VERSION("avx2", 4, ret, name, params, args) \
  RV_LANE_VERSION("default", 2, ret, name, params, args)
#else
#define RV_LANE_KERNEL(ret, name, params, args)                 \
  RV_LANE_VERSION("arch=x86-64-v4", 8, ret, name, params, args) \
  RV_LANE_VERSION("avx2", 4, ret, name, params, args)           \
  RV_LANE_VERSION("default", 2, ret, name, params, args)
#endif

namespace rv::detail {

// Double vectors of 2, 4 and 8 lanes (GCC vector extensions), for RV_LANE_KERNEL.
using VecD2 = double __attribute__((vector_size(16)));
using VecD4 = double __attribute__((vector_size(32)));
using VecD8 = double __attribute__((vector_size(64)));
// Lanes of a vector type.
template <class V>
inline constexpr int64_t kLanesOf = static_cast<int64_t>(sizeof(V) / sizeof(double));

// A vector whose first element starts a cache line (rv::DefaultInitAllocator: small buffers come
// cache-line aligned, large ones huge-page aligned). Its elements are default-initialised:
// resize() leaves new doubles unset, so scratch that must start at zero is filled with assign().
template <class T>
using AlignedVector = std::vector<T, DefaultInitAllocator<T>>;

// Results of a window larger than this (bytes of site ids and distances together) are written
// with non-temporal stores: such a window is far larger than the caches, nothing reads its cells
// again before they have left them, and a normal store first reads the cache line it writes.
// On the 1e8-cell benchmark (50 000 points) that read was about 40 % of the exact method's time.
inline constexpr int64_t kStreamBytes = int64_t{4} << 20;

inline bool streams_results(const Window& window) {
  return window.cell_count() * int64_t{sizeof(int32_t) + sizeof(float)} > kStreamBytes;
}

#if defined(RV_STREAM_STORES)
// n 4-byte values from src to dst with non-temporal stores: 4-byte ones up to dst's first 16-byte
// boundary and after its last, 16-byte ones between. An ordinary store into a line that is also
// written around the cache costs a read of that line and a flush of the partial one: on a grid
// whose rows are not 16-byte multiples (3474 cells of 4 bytes: every other row starts 8 bytes
// off) ordinary stores at the ends made the planar method twice as slow per cell as on one of
// 3300.
template <class T>
inline void stream_values(T* __restrict dst, const T* __restrict src, int64_t n) {
  static_assert(sizeof(T) == 4, "4-byte values");
  auto one = [&](int64_t c) {
    int bits;
    std::memcpy(&bits, src + c, sizeof(bits));
    _mm_stream_si32(reinterpret_cast<int*>(dst + c), bits);
  };
  int64_t c = 0;
  for (; c < n && (reinterpret_cast<uintptr_t>(dst + c) & 15) != 0; ++c) one(c);
  for (; c + 4 <= n; c += 4)
    _mm_stream_si128(reinterpret_cast<__m128i*>(dst + c), _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + c)));
  for (; c < n; ++c) one(c);
}
#endif

// Copies n results of a row from scratch (td, ti) to their place in the result rasters (od, os).
// With `stream`, they go with non-temporal stores (stream_values); the caller runs
// store_fence() before another thread may read those cells.
//
// With stream, the distances go first, then the ids, not the two interleaved 16 bytes at a time:
// the two rasters are huge-page aligned, so od + c and os + c are the same distance from a 4 KiB
// boundary, and interleaved streaming stores to two such addresses were several times slower on
// an AMD EPYC of family 25 (Zen 3; bench/store_bench, bench/RESULTS-stores.md; the exact method
// with the two orders: bench/RESULTS-kernels.md).
inline void put_row(float* __restrict od, int32_t* __restrict os, const float* __restrict td,
                    const int32_t* __restrict ti, int64_t n, bool stream) {
#if defined(RV_STREAM_STORES)
  if (stream) {
    stream_values(od, td, n);
    stream_values(os, ti, n);
    return;
  }
#endif
  (void)stream;
  std::memcpy(od, td, static_cast<size_t>(n) * sizeof(float));
  std::memcpy(os, ti, static_cast<size_t>(n) * sizeof(int32_t));
}

// Orders this thread's non-temporal stores before its later stores (the release that hands the
// cells to another thread): they are weakly ordered otherwise.
inline void store_fence() {
#if defined(RV_STREAM_STORES)
  _mm_sfence();
#endif
}

}  // namespace rv::detail
