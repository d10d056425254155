#include "rv/field/raster.hpp"

#include <cstdlib>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace rv::detail {

namespace {
constexpr size_t kHuge = size_t{2} << 20;  // 2 MiB: an x86-64 huge page
constexpr size_t kLine = 64;               // a cache line
}  // namespace

void* allocate_cells(size_t bytes) {
  if (bytes < 4 * kHuge) {
    // Cache-line aligned: the kernels' scratch rows use this allocator too (kernel_memory.hpp),
    // and their 32-byte vector accesses must not straddle lines.
    return ::operator new (bytes == 0 ? 1 : bytes, std::align_val_t{kLine});
  }
  const size_t rounded = (bytes + kHuge - 1) / kHuge * kHuge;
  void* p = std::aligned_alloc(kHuge, rounded);
  if (p == nullptr) throw std::bad_alloc();
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  // Advice only: where transparent huge pages are off this changes nothing.
  ::madvise(p, rounded, MADV_HUGEPAGE);
#endif
  return p;
}

void free_cells(void* p, size_t bytes) noexcept {
  if (p == nullptr) return;
  if (bytes < 4 * kHuge)
    ::operator delete (p, std::align_val_t{kLine});
  else
    std::free(p);
}

}  // namespace rv::detail
