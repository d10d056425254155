#include "rv/engine/outputs.hpp"

#include "rv/field/parallel.hpp"

namespace rv {
namespace {

// Applies fn(first cell, cell count) to each row of a width x rows block on `threads` threads.
template <class F>
void for_rows(int64_t rows, int64_t width, int threads, F&& fn) {
  detail::parallel_for(resolve_threads(threads), rows, [&](int64_t r, int) { fn(r * width, width); });
}

Raster<int32_t> coded_raster(const SiteCodes& codes, const NearestField& field, int threads) {
  Raster<int32_t> out(field.site.grid(), field.site.window(), Uninitialized{});
  const int32_t* s = field.site.data();
  int32_t* o = out.data();
  for_rows(out.height(), out.width(), threads, [&](int64_t i, int64_t n) { codes.apply(s + i, o + i, n); });
  return out;
}

}  // namespace

SiteCodes SiteCodes::owners(const SeedSet& seeds) {
  SiteCodes t;
  t.code_.resize(seeds.sites().size());
  for (size_t i = 0; i < t.code_.size(); ++i) t.code_[i] = seeds.site_owner(static_cast<int32_t>(i));
  return t;
}

SiteCodes SiteCodes::features(const SeedSet& seeds, std::span<const int64_t> numbering) {
  SiteCodes t;
  t.code_.resize(seeds.sites().size());
  for (size_t i = 0; i < t.code_.size(); ++i) {
    const int32_t f = seeds.sites()[i].feature;
    t.code_[i] = numbering.empty() ? f + 1 : static_cast<int32_t>(numbering[static_cast<size_t>(f)]);
  }
  return t;
}

void SiteCodes::apply(const int32_t* site, int32_t* out, int64_t n) const {
  const int32_t* code = code_.data();
  for (int64_t i = 0; i < n; ++i) out[i] = site[i] == kNoSite ? 0 : code[site[i]];
}

void scale_distances(const float* in, float* out, int64_t n, double factor) {
  for (int64_t i = 0; i < n; ++i) out[i] = in[i] == kNoDistance ? kNoDistance : static_cast<float>(in[i] * factor);
}

Raster<int32_t> owner_raster(const SeedSet& seeds, const NearestField& field, int threads) {
  return coded_raster(SiteCodes::owners(seeds), field, threads);
}

Raster<int32_t> owner_raster(const SeedSet& seeds, Raster<int32_t>&& sites, int threads) {
  Raster<int32_t> out = std::move(sites);
  const SiteCodes codes = SiteCodes::owners(seeds);
  int32_t* o = out.data();
  for_rows(out.height(), out.width(), threads, [&](int64_t i, int64_t n) { codes.apply(o + i, o + i, n); });
  return out;
}

Raster<int32_t> feature_raster(const SeedSet& seeds, const NearestField& field, int threads,
                               std::span<const int64_t> numbering) {
  return coded_raster(SiteCodes::features(seeds, numbering), field, threads);
}

Raster<float> scaled_distance(const NearestField& field, double factor, int threads) {
  Raster<float> out(field.distance.grid(), field.distance.window(), Uninitialized{});
  const float* d = field.distance.data();
  float* o = out.data();
  for_rows(out.height(), out.width(), threads, [&](int64_t i, int64_t n) { scale_distances(d + i, o + i, n, factor); });
  return out;
}

}  // namespace rv
