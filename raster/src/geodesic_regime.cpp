#include "geodesic_regime.hpp"

#include <GeographicLib/Math.hpp>

#include <algorithm>
#include <cstring>
#include <unordered_map>
#include <utility>

namespace rv::detail {

SegmentRegimes::SegmentRegimes(const GeoSites& geo)
    : k2_(vertex_k2(geo.geodesic().EquatorialRadius(), geo.geodesic().Flattening())) {
  using GeographicLib::Math;
  ends_.resize(2 * geo.size());
  struct PairHash {
    size_t operator()(const std::pair<uint64_t, uint64_t>& k) const {
      return std::hash<uint64_t>()(k.first * 0x9e3779b97f4a7c15ULL ^ k.second);
    }
  };
  std::unordered_map<std::pair<uint64_t, uint64_t>, int32_t, PairHash> vertices;
  for (size_t i = 0; i < geo.size(); ++i) {
    const GeoSite& k = geo.site(static_cast<int32_t>(i));
    if (!k.segment) continue;
    for (int e = 0; e < 2; ++e) {
      SegmentEnd& v = ends_[2 * i + static_cast<size_t>(e)];
      v.lat = e == 0 ? k.lat : k.lat_b;
      v.lon = e == 0 ? k.lon : k.lon_b;
      uint64_t lat_bits, lon_bits;
      std::memcpy(&lat_bits, &v.lat, sizeof(lat_bits));
      std::memcpy(&lon_bits, &v.lon, sizeof(lon_bits));
      v.vertex =
          vertices.emplace(std::make_pair(lat_bits, lon_bits), static_cast<int32_t>(vertices.size())).first->second;
      geo.ecef(v.lat, v.lon, v.x, v.y, v.z);
      double sp, cp, sl, cl, sa, ca;
      Math::sincosd(v.lat, sp, cp);
      Math::sincosd(v.lon, sl, cl);
      Math::sincosd(e == 0 ? k.azi_a : k.azi_b, sa, ca);
      v.nx = cp * cl;  // geodetic normal
      v.ny = cp * sl;
      v.nz = sp;
      // east (-sl, cl, 0), north (-sp cl, -sp sl, cp)
      v.ex = sa * -sl + ca * -sp * cl;
      v.ey = sa * cl + ca * -sp * sl;
      v.ez = ca * cp;
    }
  }
}

BlockRegime SegmentRegimes::over_block(double cx, double cy, double cz, double radius, int32_t id) const {
  constexpr double kRegimeSlack = 1e-3;  // metres
  const double stop = std::sqrt(std::sqrt(kVertexStop4)), angle = std::sqrt(k2_);
  const double grow = radius + kRegimeSlack;
  double te[2], mu[2];
  bool settled_end[2] = {true, true};  // each end's chord and |u| limits hold at every cell
  for (int e = 0; e < 2; ++e) {
    const SegmentEnd& v = ends_[2 * static_cast<size_t>(id) + static_cast<size_t>(e)];
    const double tx = cx - v.x, ty = cy - v.y, tz = cz - v.z;
    const double chord = std::sqrt(tx * tx + ty * ty + tz * tz);
    const double tn = tx * v.nx + ty * v.ny + tz * v.nz;
    const double u = std::sqrt(std::max(chord * chord - tn * tn, 0.0)) + radius;
    const double t = chord + radius;
    mu[e] = std::max(stop * std::sqrt(u), angle * t * t * u) * (1.0 + 1e-9);
    te[e] = tx * v.ex + ty * v.ey + tz * v.ez;
    if (!(chord + radius + kRegimeSlack <= kVertexMaxChord * (1.0 - 1e-9))) settled_end[e] = false;
    if (!(std::abs(te[e]) - radius - kRegimeSlack >= kVertexMinChord)) settled_end[e] = false;
  }
  const bool settled = settled_end[0] && settled_end[1];
  BlockRegime out;
  // Bounds over the block: te in [te - radius, te + radius], and every cell's M below mu.
  const bool behind0 = -te[0] - mu[0] > grow, beyond1 = te[1] - mu[1] > grow;
  const bool ahead0 = te[0] - mu[0] > grow, before1 = -te[1] - mu[1] > grow;
  out.ahead_a = settled_end[0] && ahead0;
  out.before_b = settled_end[1] && before1;
  if (settled) {
    if (behind0)
      out.certain = Regime::first_end;
    else if (beyond1 && te[0] - radius > kRegimeSlack)  // and certainly not behind end 0
      out.certain = Regime::second_end;
    else if (ahead0 && before1)
      out.certain = Regime::interior;
  }
  // Regime 1 needs te0 < 0, 2 needs te1 > 0, 3 needs te0 > 0 and te1 < 0 somewhere.
  out.possible = 0;
  if (te[0] - radius < 0.0) out.possible |= 1u;
  if (te[1] + radius > 0.0) out.possible |= 2u;
  if (te[0] + radius > 0.0 && te[1] - radius < 0.0) out.possible |= 4u;
  return out;
}

}  // namespace rv::detail
