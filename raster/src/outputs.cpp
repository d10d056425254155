#include "rv/outputs.hpp"

#include "parallel.hpp"

namespace rv {
namespace {

// Applies fn(i) to every cell index in row-sized chunks on `threads` threads.
template <class F>
void for_cells(int64_t rows, int64_t width, int threads, F&& fn) {
  detail::parallel_for(resolve_threads(threads), rows, [&](int64_t r, int) {
    const int64_t base = r * width;
    for (int64_t c = 0; c < width; ++c) fn(base + c);
  });
}

}  // namespace

Raster<int32_t> owner_raster(const SeedSet& seeds, const NearestField& field, int threads) {
  Raster<int32_t> out(field.site.grid(), field.site.window(), Uninitialized{});
  std::vector<int32_t> owner_of_site(seeds.sites().size());
  for (size_t i = 0; i < owner_of_site.size(); ++i) owner_of_site[i] = seeds.site_owner(static_cast<int32_t>(i));
  const int32_t* s = field.site.data();
  int32_t* o = out.data();
  for_cells(out.height(), out.width(), threads, [&](int64_t i) { o[i] = s[i] == kNoSite ? 0 : owner_of_site[s[i]]; });
  return out;
}

Raster<int32_t> feature_raster(const SeedSet& seeds, const NearestField& field, int threads,
                               std::span<const int64_t> numbering) {
  Raster<int32_t> out(field.site.grid(), field.site.window(), Uninitialized{});
  std::vector<int32_t> number_of_site(seeds.sites().size());
  for (size_t i = 0; i < number_of_site.size(); ++i) {
    const int32_t f = seeds.sites()[i].feature;
    number_of_site[i] = numbering.empty() ? f + 1 : static_cast<int32_t>(numbering[static_cast<size_t>(f)]);
  }
  const int32_t* s = field.site.data();
  int32_t* o = out.data();
  for_cells(out.height(), out.width(), threads, [&](int64_t i) { o[i] = s[i] == kNoSite ? 0 : number_of_site[s[i]]; });
  return out;
}

Raster<float> scaled_distance(const NearestField& field, double factor, int threads) {
  Raster<float> out(field.distance.grid(), field.distance.window(), Uninitialized{});
  const float* d = field.distance.data();
  float* o = out.data();
  for_cells(out.height(), out.width(), threads, [&](int64_t i) {
    o[i] = d[i] == kNoDistance ? kNoDistance : static_cast<float>(d[i] * factor);
  });
  return out;
}

}  // namespace rv
