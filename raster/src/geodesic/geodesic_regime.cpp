#include "geodesic/geodesic_regime.hpp"

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

}  // namespace rv::detail
