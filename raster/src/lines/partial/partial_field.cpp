// The field of the partial-effect rule (rv/lines/partial_effect.hpp: partial_field): the
// full-effect field, with the band cells the rule gives to the neighbour taken from the nil-effect
// field. Split from partial_effect.cpp: the field is one stage, the lines another.
#include <algorithm>
#include <utility>
#include <vector>

#include "lines/line_tools.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/lines/partial_effect.hpp"

namespace rv {

using line_tools::check_whole_grid;

NearestField partial_field(const NearestField& full, const NearestField& nil, const std::vector<int32_t>& site_of,
                           const SeedSet& seeds, const PartialEffectRule& rule, int threads) {
  check_whole_grid(full);
  check_whole_grid(nil);
  if (!(full.site.grid() == nil.site.grid()))
    throw Error(ErrorKind::internal, "partial_field: the two fields are of different grids");
  NearestField out = full;
  const GridSpec& g = full.site.grid();
  const int32_t B = rule.effect().owner;
  // The band's neighbour per cell (0: not in a band).
  auto neighbour = [&](int64_t c, int64_t r) -> int32_t {
    const int32_t s1 = full.site.at(c, r);
    if (s1 == kNoSite || seeds.site_owner(s1) != B) return 0;
    const int32_t n0 = nil.site.at(c, r);
    if (n0 == kNoSite) return 0;
    const int32_t o0 = seeds.site_owner(site_of[static_cast<size_t>(n0)]);
    return o0 == B ? 0 : o0;
  };
  auto give_back = [&](int64_t c, int64_t r) {
    out.site.at(c, r) = site_of[static_cast<size_t>(nil.site.at(c, r))];
    out.distance.at(c, r) = nil.distance.at(c, r);
  };
  // The balance is 1-Lipschitz (both distances are, and e + (1 - e) = 1): where its magnitude at
  // a block's middle exceeds the block's reach from there, every cell of the block is on that
  // side, and only the cells near the partial line are decided one by one. The band can be much
  // of the grid; its line is a curve through it.
  constexpr int64_t kBlock = 32;
  auto decide = [&](auto&& self, int64_t c0, int64_t r0, int64_t n, int32_t x) -> void {
    const int64_t c1 = std::min(c0 + n, g.width) - 1, r1 = std::min(r0 + n, g.height) - 1;
    if (n <= 2) {
      for (int64_t r = r0; r <= r1; ++r)
        for (int64_t c = c0; c <= c1; ++c)
          if (neighbour(c, r) == x && rule.owner(Vec2{g.centre_x(c), g.centre_y(r)}, B, x) != B) give_back(c, r);
      return;
    }
    const Vec2 mid{0.5 * (g.centre_x(c0) + g.centre_x(c1)), 0.5 * (g.centre_y(r0) + g.centre_y(r1))};
    double reach = 0.0;
    for (const Vec2 corner : {Vec2{g.centre_x(c0), g.centre_y(r0)}, Vec2{g.centre_x(c1), g.centre_y(r0)},
                              Vec2{g.centre_x(c0), g.centre_y(r1)}, Vec2{g.centre_x(c1), g.centre_y(r1)}})
      reach = std::max(reach, rule.separation(mid, corner));
    reach = reach * (1.0 + 1e-6) + 1e-9 * g.res;
    const double balance = rule.balance(mid, x);
    if (balance > reach) return;  // all B's
    if (balance < -reach) {
      for (int64_t r = r0; r <= r1; ++r)
        for (int64_t c = c0; c <= c1; ++c)
          if (neighbour(c, r) == x) give_back(c, r);
      return;
    }
    const int64_t h = n / 2;
    for (const auto& [dc, dr] : {std::pair{0, 0}, {1, 0}, {0, 1}, {1, 1}})
      if (c0 + dc * h < g.width && r0 + dr * h < g.height) self(self, c0 + dc * h, r0 + dr * h, h, x);
  };
  const int64_t bw = (g.width + kBlock - 1) / kBlock, bh = (g.height + kBlock - 1) / kBlock;
  detail::parallel_for(threads, bw * bh, [&](int64_t k, int) {
    const int64_t c0 = (k % bw) * kBlock, r0 = (k / bw) * kBlock;
    std::vector<int32_t> present;
    for (int64_t r = r0; r < std::min(r0 + kBlock, g.height); ++r)
      for (int64_t c = c0; c < std::min(c0 + kBlock, g.width); ++c) {
        const int32_t x = neighbour(c, r);
        if (x != 0 && std::find(present.begin(), present.end(), x) == present.end()) present.push_back(x);
      }
    for (const int32_t x : present) decide(decide, c0, r0, kBlock, x);
  });
  return out;
}

}  // namespace rv
