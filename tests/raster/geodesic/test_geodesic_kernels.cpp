// The row kernels of the exact geodesic method (geodesic_kernels.hpp), on their own: over random
// candidates and cells, each cell's best value is the root of the kernel's best square with the
// very bits apply() gives the best candidate from eval()'s quantity (the per-cell method's
// arithmetic), the best id is the lowest of the equal best, the second square is the next
// value's; geographic rows (parallels) and located rows alike, every row length (padding). And
// interp_store_row flags every close call and writes what put() would.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "engine/kernel_memory.hpp"
#include "geodesic/geodesic_interpolant.hpp"
#include "geodesic/geodesic_kernels.hpp"
#include "rv/engine/engine.hpp"

namespace rv::detail {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A row of n cells near ECEF (6.4e6 scale) point (x0, y0, z0): geographic (one parallel: rho, z
// and per-column cos / sin) or located (x, y, z per cell); the column weights of 8 rows.
struct Row {
  int64_t n = 0, stride = 0;
  bool geographic = true;
  double rho = 0.0, z = 0.0;
  AlignedVector<double> cos_lon, sin_lon, x, y, zs, w;
  double wt[4], lt[4];  // the row's weights (point form, additive form)

  RowPositions positions() const {
    RowPositions p;
    if (geographic) {
      p.cos_lon = cos_lon.data();
      p.sin_lon = sin_lon.data();
      p.rho = rho;
      p.z = z;
    } else {
      p.x = x.data();
      p.y = y.data();
      p.z_of = zs.data();
    }
    return p;
  }
  double cx(int64_t c) const { return geographic ? rho * cos_lon[static_cast<size_t>(c)] : x[static_cast<size_t>(c)]; }
  double cy(int64_t c) const { return geographic ? rho * sin_lon[static_cast<size_t>(c)] : y[static_cast<size_t>(c)]; }
  double cz(int64_t c) const { return geographic ? z : zs[static_cast<size_t>(c)]; }
  void column(int64_t c, double wc[4], double lc[4]) const {
    for (int b = 0; b < 4; ++b) {
      wc[b] = w[static_cast<size_t>(b * stride + c)];
      lc[b] = w[static_cast<size_t>((4 + b) * stride + c)];
    }
  }
};

Row make_row(std::mt19937_64& rng, int64_t n, bool geographic) {
  Row row;
  row.n = n;
  row.stride = (n + kRowPad - 1) / kRowPad * kRowPad;
  row.geographic = geographic;
  const auto len = static_cast<size_t>(row.stride);
  for (auto* v : {&row.cos_lon, &row.sin_lon, &row.x, &row.y, &row.zs}) v->assign(len, 0.0);
  row.w.assign(8 * len, 0.0);
  const double lat = 0.96, lon0 = 0.21;  // radians, about 55N 12E
  row.rho = 6.39e6 * std::cos(lat);
  row.z = 6.36e6 * std::sin(lat);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double t = u(rng), tl = u(rng);
  cubic_weights(t, row.wt);
  cubic_weights(tl, row.lt);
  for (int64_t c = 0; c < n; ++c) {
    const double lon = lon0 + 2e-5 * static_cast<double>(c);
    row.cos_lon[static_cast<size_t>(c)] = std::cos(lon);
    row.sin_lon[static_cast<size_t>(c)] = std::sin(lon);
    row.x[static_cast<size_t>(c)] = row.rho * std::cos(lon) + 3.0 * u(rng);
    row.y[static_cast<size_t>(c)] = row.rho * std::sin(lon) + 3.0 * u(rng);
    row.zs[static_cast<size_t>(c)] = row.z + 3.0 * u(rng);
    double wc[4], lc[4];
    cubic_weights(static_cast<double>(c) / static_cast<double>(std::max<int64_t>(n - 1, 1)), wc);
    cubic_weights(u(rng), lc);
    for (int b = 0; b < 4; ++b) {
      row.w[static_cast<size_t>(b * row.stride + c)] = wc[b];
      row.w[static_cast<size_t>((4 + b) * row.stride + c)] = lc[b];
    }
  }
  return row;
}

// An interpolant near the row, point form (q about 1, as d / chord is) or additive (a plane
// through the point, q a few metres), with id `id`. `twin`: a copy of another's quantity and
// point, so that the two tie exactly.
Interpolant make_interpolant(std::mt19937_64& rng, const Row& row, int32_t id, bool additive) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Interpolant it{};
  it.id = id;
  it.sx = row.cx(0) + 4000.0 * u(rng);
  it.sy = row.cy(0) + 4000.0 * u(rng);
  it.sz = row.cz(0) + 4000.0 * u(rng);
  it.additive = additive;
  for (auto& qrow : it.q)
    for (double& q : qrow) q = additive ? 40.0 + 30.0 * u(rng) : 1.0 + 1e-3 * u(rng);
  if (additive) {
    const double nx = u(rng), ny = u(rng), nz = u(rng), len = std::sqrt(nx * nx + ny * ny + nz * nz);
    it.nx = nx / len;
    it.ny = ny / len;
    it.nz = nz / len;
    it.k3 = 1.0 / (6.0 * 6.37e6 * 6.37e6);
  }
  return it;
}

// The kernel's view of an interpolant on the row: qr reduced as the leaf reduces it.
RowCandidate row_candidate(const Interpolant& it, const Row& row) {
  RowCandidate rc{};
  const double* wt = it.additive ? row.lt : row.wt;
  for (int b = 0; b < 4; ++b)
    rc.qr[b] = wt[0] * it.q[0][b] + wt[1] * it.q[1][b] + wt[2] * it.q[2][b] + wt[3] * it.q[3][b];
  rc.sx = it.sx;
  rc.sy = it.sy;
  rc.sz = it.sz;
  rc.nx = it.nx;
  rc.ny = it.ny;
  rc.nz = it.nz;
  rc.k3 = it.k3;
  rc.id = static_cast<double>(it.id);
  rc.tag = -1.0;
  const double dz = row.z - it.sz;
  rc.dz2 = dz * dz;
  return rc;
}

struct Expected {
  double best, second;
  int32_t id;
};

// The per-cell method's arithmetic: eval() then apply() per candidate; the lowest id of the
// smallest value wins.
Expected reference(const std::vector<Interpolant>& its, const Row& row, int64_t c) {
  double wc[4], lc[4];
  row.column(c, wc, lc);
  Expected e{kInf, kInf, kNoSite};
  for (const Interpolant& it : its) {
    const double q = it.additive ? eval(it, row.lt, lc) : eval(it, row.wt, wc);
    const double v = apply(it, q, row.cx(c), row.cy(c), row.cz(c));
    if (v < e.best || (v == e.best && it.id < e.id)) {
      e.second = e.best;
      e.best = v;
      e.id = it.id;
    } else if (v < e.second) {
      e.second = v;
    }
  }
  return e;
}

TEST(GeodesicKernels, ThePointsKernelGivesThePerCellMethodsBits) {
  std::mt19937_64 rng(21);
  int64_t cells = 0;
  for (int trial = 0; trial < 80; ++trial) {
    const bool geographic = trial % 2 == 0;
    const int64_t n = 1 + trial % 37;
    const Row row = make_row(rng, n, geographic);
    std::vector<Interpolant> its;
    const int k = 1 + trial % 9;
    for (int j = 0; j < k; ++j) its.push_back(make_interpolant(rng, row, 3 * j + 1, false));
    if (k > 2) {  // an exact tie: the same quantity and point under a higher id
      its.push_back(its[1]);
      its.back().id = 3 * k + 5;
    }
    std::vector<RowCandidate> rcs;
    for (const Interpolant& it : its) rcs.push_back(row_candidate(it, row));
    const auto len = static_cast<size_t>(row.stride);
    AlignedVector<double> best2(len), second2(len), best_id(len);
    interp_argmin_points(rcs.data(), static_cast<int>(rcs.size()), row.w.data(), row.stride, row.positions(), n,
                         best2.data(), second2.data(), best_id.data());
    for (int64_t c = 0; c < n; ++c) {
      const Expected e = reference(its, row, c);
      ASSERT_EQ(std::sqrt(best2[static_cast<size_t>(c)]), e.best) << "trial " << trial << " cell " << c;
      ASSERT_EQ(static_cast<int32_t>(best_id[static_cast<size_t>(c)]), e.id) << "trial " << trial << " cell " << c;
      ASSERT_EQ(std::sqrt(second2[static_cast<size_t>(c)]), e.second) << "trial " << trial << " cell " << c;
      ++cells;
    }
  }
  EXPECT_GT(cells, 1000);
}

TEST(GeodesicKernels, TheRowKernelGivesThePerCellMethodsBitsWithAdditiveCandidates) {
  std::mt19937_64 rng(22);
  int additive_best = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const int64_t n = 1 + (trial * 7) % 41;
    const Row row = make_row(rng, n, trial % 3 != 0);
    std::vector<Interpolant> points, additive;
    for (int j = 0; j < 1 + trial % 5; ++j) points.push_back(make_interpolant(rng, row, 2 * j, false));
    for (int j = 0; j < 1 + trial % 4; ++j) additive.push_back(make_interpolant(rng, row, 2 * j + 1, true));
    std::vector<RowCandidate> rp, ra;
    for (const Interpolant& it : points) rp.push_back(row_candidate(it, row));
    for (const Interpolant& it : additive) ra.push_back(row_candidate(it, row));
    const auto len = static_cast<size_t>(row.stride);
    AlignedVector<double> best2(len), second2(len), best_id(len), force(len, 7.0);
    const int km[3] = {0, 0, 0};
    interp_argmin_row(rp.data(), static_cast<int>(rp.size()), ra.data(), static_cast<int>(ra.size()), nullptr, 0,
                      nullptr, km, row.w.data(), row.stride, row.positions(), n, best2.data(), second2.data(),
                      best_id.data(), force.data(), 0.0);
    std::vector<Interpolant> all = points;
    all.insert(all.end(), additive.begin(), additive.end());
    for (int64_t c = 0; c < n; ++c) {
      const Expected e = reference(all, row, c);
      const auto i = static_cast<size_t>(c);
      ASSERT_EQ(std::sqrt(best2[i]), e.best) << "trial " << trial << " cell " << c;
      ASSERT_EQ(static_cast<int32_t>(best_id[i]), e.id) << "trial " << trial << " cell " << c;
      ASSERT_EQ(std::sqrt(second2[i]), e.second) << "trial " << trial << " cell " << c;
      ASSERT_EQ(force[i], 0.0) << "nothing forces a cell without changing segments";
      additive_best += e.id % 2 == 1;
    }
  }
  EXPECT_GT(additive_best, 100);  // the additive path decided many cells
}

TEST(GeodesicKernels, TheStoreFlagsEveryCloseCallAndWritesWhatPutWould) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> d(0.0, 5e5), gap(0.0, 4.0 * kInterpTie);
  for (const double limit : {kInf, 2.5e5}) {
    const int64_t n = 333;
    AlignedVector<double> best2(n), second2(n), best_id(n), value(n), force(n, 0.0);
    AlignedVector<int32_t> site(n);
    AlignedVector<float> dist(n);
    std::vector<double> b(n), s(n);
    for (int64_t c = 0; c < n; ++c) {
      b[c] = d(rng);
      s[c] = c % 5 == 0 ? kInf : b[c] + (c % 2 ? gap(rng) : 100.0 * gap(rng));
      best2[c] = b[c] * b[c];
      second2[c] = s[c] * s[c];
      best_id[c] = static_cast<double>(c % 17);
      if (c % 11 == 0) force[c] = 1.0;
    }
    const bool any = interp_store_row(best2.data(), second2.data(), best_id.data(), value.data(), force.data(), n,
                                      limit, site.data(), dist.data());
    bool flagged_any = false;
    for (int64_t c = 0; c < n; ++c) {
      const double v = std::sqrt(best2[c]);
      const bool flagged = second2[c] != 0.0;
      flagged_any = flagged_any || flagged;
      // Every close call is flagged (the two within kInterpTie, or the best that near the limit),
      // every forced cell too; a call more than 2 kInterpTie apart is not.
      const double apart = s[c] - v;
      if (apart <= kInterpTie || std::abs(v - limit) <= kInterpTie || force[c] != 0.0) {
        EXPECT_TRUE(flagged) << c;
      } else if (apart > 2.0 * kInterpTie && std::abs(v - limit) > 2.0 * kInterpTie) {
        EXPECT_FALSE(flagged) << c;
      }
      // put(): no site beyond the limit, else the id and the float of the value.
      if (v > limit) {
        EXPECT_EQ(site[c], kNoSite);
        EXPECT_EQ(dist[c], kNoDistance);
      } else {
        EXPECT_EQ(site[c], static_cast<int32_t>(best_id[c]));
        EXPECT_EQ(dist[c], static_cast<float>(v));
      }
    }
    EXPECT_EQ(any, flagged_any);
    EXPECT_TRUE(any);
  }
}

}  // namespace
}  // namespace rv::detail
