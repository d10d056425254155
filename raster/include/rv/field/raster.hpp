// Raster<T>: a window of a grid with one value of type T per cell, row-major, row 0 north.
// A value type: copying copies the cells. Not synchronised: concurrent writers must write
// disjoint cells.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#include "rv/field/grid.hpp"

namespace rv {

namespace detail {
// Large buffers: 2 MiB aligned and advised to use transparent huge pages (fewer page faults and
// TLB misses when an engine writes blocks of rows far apart). Small ones: new, aligned to a
// 64-byte cache line (kernel scratch rows take 32-byte vectors at 32-byte offsets).
void* allocate_cells(size_t bytes);
void free_cells(void* p, size_t bytes) noexcept;
}  // namespace detail

// An allocator that leaves trivially constructible values uninitialised on resize, so that a
// large result buffer is first touched (and page-faulted) by the worker threads that fill it,
// in parallel, instead of by one memset.
template <class T>
struct DefaultInitAllocator {
  using value_type = T;
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  T* allocate(size_t n) {
    if (n > static_cast<size_t>(-1) / sizeof(T)) throw std::bad_alloc();
    return static_cast<T*>(detail::allocate_cells(n * sizeof(T)));
  }
  void deallocate(T* p, size_t n) noexcept { detail::free_cells(p, n * sizeof(T)); }
  template <class U>
  bool operator==(const DefaultInitAllocator<U>&) const noexcept {
    return true;
  }
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

struct Uninitialized {};

template <class T>
class Raster {
 public:
  Raster() = default;
  Raster(GridSpec grid, Window window, T fill = T{})
      : grid_(std::move(grid)), window_(window), cells_(static_cast<size_t>(window.cell_count()), fill) {}
  Raster(GridSpec grid, T fill = T{}) : Raster(grid, grid.full_window(), fill) {}
  // Cells left uninitialised: the caller must write every cell before reading it.
  Raster(GridSpec grid, Window window, Uninitialized) : grid_(std::move(grid)), window_(window) {
    cells_.resize(static_cast<size_t>(window.cell_count()));
  }

  // Makes this raster hold `window` of `grid`, keeping the buffer (and its already-faulted pages)
  // when it is large enough: cell values are then unspecified, the caller must write every cell
  // before reading it. For computing strip after strip into one buffer.
  void retarget(GridSpec grid, Window window) {
    grid_ = std::move(grid);
    window_ = window;
    cells_.resize(static_cast<size_t>(window.cell_count()));
  }

  const GridSpec& grid() const { return grid_; }
  // Which cells of grid() this raster holds; (col, row) accessors below are window-relative.
  const Window& window() const { return window_; }
  int64_t width() const { return window_.width; }
  int64_t height() const { return window_.height; }
  size_t size() const { return cells_.size(); }

  T& at(int64_t col, int64_t row) { return cells_[index(col, row)]; }
  const T& at(int64_t col, int64_t row) const { return cells_[index(col, row)]; }
  T* row(int64_t r) { return cells_.data() + static_cast<size_t>(r) * window_.width; }
  const T* row(int64_t r) const { return cells_.data() + static_cast<size_t>(r) * window_.width; }
  T* data() { return cells_.data(); }
  const T* data() const { return cells_.data(); }
  using Storage = std::vector<T, DefaultInitAllocator<T>>;
  Storage& cells() { return cells_; }
  const Storage& cells() const { return cells_; }

  bool operator==(const Raster&) const = default;

 private:
  size_t index(int64_t col, int64_t row) const {
    return static_cast<size_t>(row) * static_cast<size_t>(window_.width) + static_cast<size_t>(col);
  }
  GridSpec grid_;
  Window window_;
  std::vector<T, DefaultInitAllocator<T>> cells_;
};

}  // namespace rv
