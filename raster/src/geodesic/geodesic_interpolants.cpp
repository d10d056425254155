// Building the interpolants of a block (GeodesicExactSolver, geodesic_solver.hpp): the point
// form of a point site or a segment's end, the additive form of a segment's interior.
#include "geodesic/geodesic_solver.hpp"

namespace rv::detail {

namespace {

// The distance from a point to a geodesic line (the extended edge of an additive interpolant,
// between its ends a and b), for the interpolants' nodes: one inverse problem per point instead
// of GeoSites::distance's search (~1.75 of them, each with a position on the line).
//
// The foot of the point on the line is taken from a cubic model of the line in ECEF (through
// its positions at 0, 1/3, 2/3 and 1 of its length, at most ~2e-4 m off the line over 100 km:
// the cubic interpolation error of an arc of radius R, L^4 / (24 R^3) x 0.012), where the
// point's chord to the model is least (Newton's method on the model). The geodesic foot lies
// within c f (c / R)^2 of that (~1e-4 m at c = 10 km: the chord's minimiser moves only with the
// ellipsoid's departure from a sphere), so the distance from the line point there, minus the
// second-order excess of the convex distance, m12 cos^2 w / (2 M12) (the value the search's
// Newton step heads for), is the minimum to far below the nodes' needs: within 3.5e-9 m of
// the search on every node of the Oresund fixture at 0.0002 .. 0.002 deg and of the synthetic
// coastlines, GeographicLib's own ~1e-8 m. `side` gets sin w there, as GeoEnd::sin_w.
// Thread safety: const after construction.
class LineFoot {
 public:
  LineFoot(const GeoSites& geo, const Site& line)
      : geod_(geo.geodesic()),
        line_(geod_.InverseLine(line.a.y, line.a.x, line.b.y, line.b.x,
                                GeographicLib::Geodesic::LATITUDE | GeographicLib::Geodesic::LONGITUDE |
                                    GeographicLib::Geodesic::AZIMUTH | GeographicLib::Geodesic::DISTANCE_IN)),
        length_(line_.Distance()) {
    for (int k = 0; k < 4; ++k) {
      double lat, lon, azi;
      line_.Position(length_ * k / 3.0, lat, lon, azi);
      geo.ecef(lat, lon, x_[k][0], x_[k][1], x_[k][2]);
    }
  }

  // The distance d from p to the line and sin w at its foot; false where the foot is not
  // inside the line (nearest at an end) or the line's geometry there is unusable.
  bool distance(const GeoCell& p, double& d, double& sin_w) const {
    const double ux = x_[3][0] - x_[0][0], uy = x_[3][1] - x_[0][1], uz = x_[3][2] - x_[0][2];
    const double len2 = ux * ux + uy * uy + uz * uz;
    if (!(len2 > 0.0)) return false;
    double u = ((p.x - x_[0][0]) * ux + (p.y - x_[0][1]) * uy + (p.z - x_[0][2]) * uz) / len2;
    for (int iter = 0; iter < 8; ++iter) {
      // The model X(u) = sum w_k(u) x_k (Lagrange weights at 0, 1/3, 2/3, 1), X' and X''.
      const double a = u, b = u - 1.0 / 3.0, c = u - 2.0 / 3.0, e = u - 1.0;
      const double w0[4] = {-4.5 * b * c * e, 13.5 * a * c * e, -13.5 * a * b * e, 4.5 * a * b * c};
      const double w1[4] = {-4.5 * (c * e + b * e + b * c), 13.5 * (c * e + a * e + a * c),
                            -13.5 * (b * e + a * e + a * b), 4.5 * (b * c + a * c + a * b)};
      const double w2[4] = {-9.0 * (b + c + e), 27.0 * (a + c + e), -27.0 * (a + b + e), 9.0 * (a + b + c)};
      double x[3] = {0.0, 0.0, 0.0}, d1[3] = {0.0, 0.0, 0.0}, d2[3] = {0.0, 0.0, 0.0};
      for (int k = 0; k < 4; ++k)
        for (int q = 0; q < 3; ++q) {
          x[q] += w0[k] * x_[k][q];
          d1[q] += w1[k] * x_[k][q];
          d2[q] += w2[k] * x_[k][q];
        }
      const double dx = x[0] - p.x, dy = x[1] - p.y, dz = x[2] - p.z;
      const double g = dx * d1[0] + dy * d1[1] + dz * d1[2];
      const double slope = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2] + dx * d2[0] + dy * d2[1] + dz * d2[2];
      if (!(slope > 0.0)) return false;
      const double step = g / slope;
      u -= step;
      if (std::abs(step) * length_ < 1e-7) break;
    }
    if (!(u > 1e-6 && u < 1.0 - 1e-6)) return false;
    double lat, lon, azi;
    line_.Position(u * length_, lat, lon, azi);
    double s12, azi1, azi2, m12, big_m12, big_m21;
    geod_.Inverse(lat, lon, p.lat, p.lon, s12, azi1, azi2, m12, big_m12, big_m21);
    if (!(m12 > 0.0 && big_m12 > 0.0)) return false;
    double cos_w;
    GeographicLib::Math::sincosd(GeographicLib::Math::AngDiff(azi, azi1), sin_w, cos_w);
    d = s12 - m12 * cos_w * cos_w / (2.0 * big_m12);
    return true;
  }

 private:
  const GeographicLib::Geodesic& geod_;
  GeographicLib::GeodesicLine line_;
  double length_;
  double x_[4][3];  // ECEF of the line at 0, 1/3, 2/3, 1 of its length
};

}  // namespace

const Interpolant* GeodesicExactSolver::interpolant(GeoWorker& wk, int64_t c, int64_t r, int32_t id, int end) const {
  const int64_t S = end == 3 ? line_block_ : point_block_;
  const int64_t gc = ctx_.window.col0 + c, gr = ctx_.window.row0 + r;
  const int64_t bx0 = (gc / S) * S, by0 = (gr / S) * S;
  // Edges meeting at a vertex measure it with one interpolant (same nodes, same bits): the
  // key names the distinct vertex for ends (kind 1), the site for points (0) and interiors (3).
  const bool vertex = end == 1 || end == 2;
  const int32_t who = vertex ? regimes_.end(id, end - 1).vertex : id;
  const uint64_t key = (static_cast<uint64_t>((by0 % kTile) / S * (kTile / S) + (bx0 % kTile) / S) << 34) |
                       (static_cast<uint64_t>(static_cast<uint32_t>(who)) << 2) |
                       static_cast<uint64_t>(vertex ? 1 : end);
  auto it = wk.cache.find(key);
  if (it != wk.cache.end()) return it->second;
  std::shared_ptr<SharedInterpolants::Entry> e = shared_.entry(bx0, by0, who, vertex ? 1 : end);
  std::call_once(e->built, [&] {
    auto made = std::make_unique<Interpolant>();
    if (build_interpolant(*made, bx0, by0, std::min(bx0 + S, ctx_.grid.width), std::min(by0 + S, ctx_.grid.height), id,
                          end))
      e->it = std::move(made);
  });
  const Interpolant* got = e->it.get();
  wk.held.push_back(std::move(e));
  return wk.cache.emplace(key, got).first->second;
}

GeoCell GeodesicExactSolver::cell_at_fraction(double gcol, double grow) const {
  const GridSpec& g = ctx_.grid;
  const double x = g.xmin + (gcol + 0.5) * g.res, y = g.ymax - (grow + 0.5) * g.res;
  if (!located_) return geo_.cell(x, y);
  double lon, lat;
  locate_centres(*ctx_.geolocator, &x, &y, &lon, &lat, 1);
  return geo_.cell(lon, lat);
}

bool GeodesicExactSolver::build_interpolant(Interpolant& it, int64_t bx0, int64_t by0, int64_t bx1, int64_t by1,
                                            int32_t id, int end) const {
  if (bx1 - bx0 < kInterpMinEdge || by1 - by0 < kInterpMinEdge) return false;
  const GeoSite& s = geo_.site(id);
  it.id = id;
  if (end == 3) return build_line_interpolant(it, bx0, by0, bx1, by1, id);
  if (end == 0) {
    it.lat = s.lat;
    it.lon = s.lon;
  } else {
    const SegmentEnd& v = regimes_.end(id, end - 1);
    it.lat = v.lat;
    it.lon = v.lon;
  }
  geo_.ecef(it.lat, it.lon, it.sx, it.sy, it.sz);
  const GeographicLib::Geodesic& geod = geo_.geodesic();
  // The exact distance at p: the point site's own (GeoSites::distance), or the inverse problem
  // from the segment's end, which is the segment's distance wherever it is nearest at that end.
  auto exact = [&](const GeoCell& p) {
    if (end == 0) return geo_.distance(p, id);
    double d;
    geod.Inverse(it.lat, it.lon, p.lat, p.lon, d);
    return d;
  };
  auto value = [&](const GeoCell& p, double& q) {
    const double d = exact(p);
    const double dx = p.x - it.sx, dy = p.y - it.sy, dz = p.z - it.sz;
    const double chord = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (!(d <= kInterpMaxDistance) || !(chord >= kInterpMinChord)) return false;
    q = d / chord;
    return true;
  };
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b)
      if (!value(cell_at_fraction(node_at(bx0, bx1 - 1, b / 3.0), node_at(by0, by1 - 1, a / 3.0)), it.q[a][b]))
        return false;
  // The check: the exact distance at the block's centre (not a node) against the interpolant.
  const GeoCell centre = cell_at_fraction(node_at(bx0, bx1 - 1, 0.5), node_at(by0, by1 - 1, 0.5));
  double wt[4], wc[4];
  cubic_weights(0.5, wt);
  cubic_weights(0.5, wc);
  const double dx = centre.x - it.sx, dy = centre.y - it.sy, dz = centre.z - it.sz;
  const double approx = eval(it, wt, wc) * std::sqrt(dx * dx + dy * dy + dz * dz);
  return std::abs(approx - exact(centre)) <= kInterpCheck;
}

bool GeodesicExactSolver::build_line_interpolant(Interpolant& it, int64_t bx0, int64_t by0, int64_t bx1, int64_t by1,
                                                 int32_t id) const {
  const GeoSite& s = geo_.site(id);
  const SegmentEnd& va = regimes_.end(id, 0);
  const SegmentEnd& vb = regimes_.end(id, 1);
  const double ux = vb.x - va.x, uy = vb.y - va.y, uz = vb.z - va.z;
  const double len = std::sqrt(ux * ux + uy * uy + uz * uz);
  if (!(len >= 1.0)) return false;
  it.additive = true;
  it.lat = s.lat;
  it.lon = s.lon;
  it.sx = va.x;
  it.sy = va.y;
  it.sz = va.z;
  {
    const double mx = va.nx + vb.nx, my = va.ny + vb.ny, mz = va.nz + vb.nz;
    const double px = uy * mz - uz * my, py = uz * mx - ux * mz, pz = ux * my - uy * mx;
    const double pn = std::sqrt(px * px + py * py + pz * pz);
    it.nx = px / pn;
    it.ny = py / pn;
    it.nz = pz / pn;
  }
  {
    // R: the normal section's radius across the edge (azimuth + 90 degrees) at its middle
    // latitude, 1 / R = cos^2(a) / M + sin^2(a) / N.
    using GeographicLib::Math;
    const double a = geo_.geodesic().EquatorialRadius(), f = geo_.geodesic().Flattening();
    const double e2 = f * (2.0 - f);
    double sp, cp, sa, ca;
    Math::sincosd(0.5 * (s.lat + s.lat_b), sp, cp);
    Math::sincosd(s.azi_a + 90.0, sa, ca);
    const double w2 = 1.0 - e2 * sp * sp;
    const double n_radius = a / std::sqrt(w2), m_radius = a * (1.0 - e2) / (w2 * std::sqrt(w2));
    const double inv = ca * ca / m_radius + sa * sa / n_radius;
    it.k3 = inv * inv / 6.0;
  }
  // The extension: a cell of the block whose nearest point is inside the edge has every other
  // cell of the block within the block's diagonal d (its corners' chord, 1.25 d covering
  // chord vs arc) of it, so their nearest points of the extended line lie within that of the
  // edge; 1 km more for good measure. A node nearest at an end of the extension rejects the
  // interpolant anyway.
  const GeoCell c00 = cell_at_fraction(static_cast<double>(bx0), static_cast<double>(by0));
  const GeoCell c11 = cell_at_fraction(static_cast<double>(bx1 - 1), static_cast<double>(by1 - 1));
  const GeoCell c01 = cell_at_fraction(static_cast<double>(bx1 - 1), static_cast<double>(by0));
  const GeoCell c10 = cell_at_fraction(static_cast<double>(bx0), static_cast<double>(by1 - 1));
  auto chord = [](const GeoCell& a, const GeoCell& b) {
    return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
  };
  const double diag = std::max(chord(c00, c11), chord(c01, c10));
  const double ext = 1.25 * diag + 1000.0;
  if (!(ext < 0.45 * kGeoPieceLength)) return false;
  const GeographicLib::Geodesic& geod = geo_.geodesic();
  Site extended;
  extended.kind = SiteKind::segment;
  extended.feature = 0;
  double lat, lon;
  geod.Direct(s.lat, s.lon, s.azi_a + 180.0, ext, lat, lon);
  extended.a = Vec2{lon, lat};
  geod.Direct(s.lat_b, s.lon_b, s.azi_b, ext, lat, lon);
  extended.b = Vec2{lon, lat};
  MetricSpec m;
  m.kind = MetricSpec::geodesic;
  m.semi_major = geod.EquatorialRadius();
  m.flattening = geod.Flattening();
  const GeoSites line(m, std::vector<Site>{extended});
  bool ok = true;
  double side = 0.0;  // the last node's: > 0 right of the edge, < 0 left (GeoEnd::sin_w)
  // The check at the block's centre measures with brute force's search on the extended line.
  auto exact = [&](const GeoCell& p) {
    GeoEnd end;
    const double d = line.distance(p, 0, &end);
    if (end.valid) ok = false;  // nearest at an end of the extension: not the line's distance
    side = end.sin_w;
    return d;
  };
  // The nodes with one inverse problem each instead of the search's ~1.75 (LineFoot).
  const LineFoot foot(geo_, extended);
  auto node = [&](const GeoCell& p) {
    double d;
    if (!foot.distance(p, d, side)) ok = false;
    return d;
  };
  for (int a = 0; a < 4 && ok; ++a)
    for (int b = 0; b < 4 && ok; ++b) {
      const GeoCell p = cell_at_fraction(node_at(bx0, bx1 - 1, b / 3.0), node_at(by0, by1 - 1, a / 3.0));
      const double d = node(p);
      if (!ok) return false;
      const double h = normaliser(it, p.x, p.y, p.z);
      // The side comes from the geodesic itself: the direction to the node at its nearest
      // point is square to the edge, sin w = +-1. A node on the line (d below a millimetre)
      // or not square to it (an unconverged search) rejects the block.
      if (!(d <= kInterpMaxDistance) || !(d >= kInterpMinChord) || !(std::abs(side) >= 0.5)) return false;
      it.q[a][b] = (side > 0.0 ? d : -d) - h;
    }
  if (!ok) return false;
  const GeoCell centre = cell_at_fraction(node_at(bx0, bx1 - 1, 0.5), node_at(by0, by1 - 1, 0.5));
  double wt[4], wc[4];
  cubic_weights(0.5, wt);
  cubic_weights(0.5, wc);
  const double approx = apply(it, eval(it, wt, wc), centre.x, centre.y, centre.z);
  const double want = exact(centre);
  return ok && std::abs(approx - want) <= kInterpCheckAdditive;
}

}  // namespace rv::detail
