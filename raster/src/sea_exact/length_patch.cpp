// Interpolated lengths from a root to a block's cells (sea_exact/length_patch.hpp says what they
// promise and why).
#include "sea_exact/length_patch.hpp"

#include <cmath>

#include "geodesic/geodesic_interpolant.hpp"

namespace rv::sea {
namespace {

// (A node within a millimetre of the point cannot form length / chord.)
constexpr double kMinChord = 1e-3;

}  // namespace

LengthPatch::LengthPatch(const Prepared& p, Vec2 ll, const Prepared::Xyz& xyz, const PatchBlock& block)
    : xyz_(xyz), block_(block) {
  if (std::abs(block.ll1.x - block.ll0.x) > kPatchSpan || std::abs(block.ll1.y - block.ll0.y) > kPatchSpan) return;
  auto node = [&](double tc, double tr) {
    return Vec2{block.ll0.x + tc * (block.ll1.x - block.ll0.x), block.ll0.y + tr * (block.ll1.y - block.ll0.y)};
  };
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      const Vec2 at = node(j / 3.0, i / 3.0);
      const double ch = Prepared::chord(p.xyz(at), xyz);
      if (ch < kMinChord) return;
      q_[i][j] = p.geodesic->point_distance(ll, at) / ch;
    }
  // The check at the centre, where the cubics through thirds stray most.
  const Vec2 mid = node(0.5, 0.5);
  const Prepared::Xyz mid_xyz = p.xyz(mid);
  double w[4];
  detail::cubic_weights(0.5, w);
  double q = 0.0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) q += w[i] * w[j] * q_[i][j];
  usable_ = std::abs(q * Prepared::chord(mid_xyz, xyz) - p.geodesic->point_distance(ll, mid)) <= kPatchCheck;
}

double LengthPatch::length(int64_t c, int64_t r, const Prepared::Xyz& at) const {
  double wr[4], wc[4];
  detail::cubic_weights(static_cast<double>(r - block_.r0) / static_cast<double>(block_.r1 - block_.r0), wr);
  detail::cubic_weights(static_cast<double>(c - block_.c0) / static_cast<double>(block_.c1 - block_.c0), wc);
  double q = 0.0;
  for (int i = 0; i < 4; ++i) q += wr[i] * (wc[0] * q_[i][0] + wc[1] * q_[i][1] + wc[2] * q_[i][2] + wc[3] * q_[i][3]);
  return q * Prepared::chord(at, xyz_);
}

}  // namespace rv::sea
