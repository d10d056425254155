// The 3x3 scans: the horizontal cycle of Shih & Wu (2004) and the horizontal-vertical cycle of
// Liu, Zhao, Wang, Sun (2019), Acta Geodaetica et Cartographica Sinica 48(3):393-399.
//
// Every cell holds a candidate site and its exact squared distance. A pass walks the cells in a
// fixed order; each cell compares its candidate with the candidates of four neighbours that the
// pass has already finalised and keeps the nearest (ties: lower site index). The four passes all
// have one shape: the grid is a sequence of *lines* (rows, or columns) walked one after the other,
// and a cell at position i of line l looks at positions i-1, i, i+1 of line l-1 and at position
// i-1 of its own line:
//
//   pass                  lines                      walk in a line     neighbours (paper, Fig. 1)
//   horizontal forward    rows, top -> bottom        left -> right      Q1 Q2 Q3 Q4
//   horizontal backward   rows, bottom -> top        right -> left      Q8 Q7 Q6 Q5
//   vertical forward      columns, left -> right     top -> bottom      Q1 Q4 Q6 Q2
//   vertical backward     columns, right -> left     bottom -> top      Q8 Q5 Q3 Q7
//
// (The paper lists Q2 for the vertical backward pass; walking bottom -> top, the in-column
// predecessor is Q7, which is what is used here.)
//
// Parallel schedule: a pipelined wavefront. Threads take lines in order; a thread may process
// positions [i0, i1) of line l only once line l-1 is final up to position i1 (inclusive), which
// is exactly the data the sequential walk would have seen. So the output is identical, cell for
// cell, to the one-thread walk, for any thread count.
//
// Seeding: each cell starts with the nearest of the sites that touch it (a point in the cell; a
// segment crossing it, every cell of it, found by clipping the segment to each row band). Sites
// that touch no cell of the window (outside it) enter through the border: each border cell also
// starts with its exact nearest among those outside sites.
//
// Metric: the passes are templated on the metric's operations (engine_internal.hpp), so the
// geodesic scan compares exact geodesic distances of the neighbours' candidates exactly as the
// planar scan compares squared Euclidean distances. Seeding uses the sites' positions in the grid
// frame (for geodesic grids: degrees, longitudes unwrapped around the grid; for projected
// geodesic grids: the sites placed in the grid's CRS by the geolocator), which only decides
// where a site's identity enters the scan. On projected geodesic grids a cell's position is
// located once per pass (not once per candidate).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <vector>

#include "engine/engine_internal.hpp"
#include "rv/field/parallel.hpp"

namespace rv::detail {
namespace {

constexpr int64_t kChunk = 128;  // positions processed between two wavefront synchronisations

template <class Ops>
struct ScanState {
  const EngineContext& ctx;
  Ops ops;
  int64_t width, height;
  Raster<int32_t>& site;
  std::vector<double> key;

  size_t at(int64_t c, int64_t r) const { return static_cast<size_t>(r * width + c); }

  // Offers site `id` to cell (c, r): kept if strictly nearer, or equally near with a lower id.
  void offer(int64_t c, int64_t r, int32_t id) {
    const size_t i = at(c, r);
    int32_t* s = site.data();
    if (id == s[i] || id == kNoSite) return;
    offer_at(i, ops.cell(ctx.window.col0 + c, ctx.window.row0 + r), id);
  }

  // The same for a cell whose position p is already known (the passes compute it once for the
  // four candidates: on a projected geodesic grid each position costs a transformation).
  void offer_at(size_t i, const typename Ops::Cell& p, int32_t id) {
    int32_t* s = site.data();
    if (id == s[i] || id == kNoSite) return;
    const double k = ops.key(p, id);
    if (k < key[i] || (k == key[i] && (s[i] == kNoSite || id < s[i]))) {
      key[i] = k;
      s[i] = id;
    }
  }
};

// Marks every cell that the site touches; returns false if it touches none.
template <class F>
bool touched_cells(const GridSpec& g, const Window& w, const LocalSite& s, F&& fn) {
  // Window-relative continuous cell coordinates: u = x / res - col0, v = -y / res - row0.
  const double ua = s.ax / g.res - static_cast<double>(w.col0);
  const double va = -s.ay / g.res - static_cast<double>(w.row0);
  const double ub = s.bx() / g.res - static_cast<double>(w.col0);
  const double vb = -s.by() / g.res - static_cast<double>(w.row0);
  const auto W = static_cast<double>(w.width), H = static_cast<double>(w.height);
  if (std::max(ua, ub) < 0.0 || std::min(ua, ub) > W || std::max(va, vb) < 0.0 || std::min(va, vb) > H) return false;
  bool any = false;
  const auto r0 = static_cast<int64_t>(std::clamp(std::floor(std::min(va, vb)), 0.0, H - 1.0));
  const auto r1 = static_cast<int64_t>(std::clamp(std::floor(std::max(va, vb)), 0.0, H - 1.0));
  for (int64_t r = r0; r <= r1; ++r) {
    double u0, u1;
    if (va == vb) {
      u0 = std::min(ua, ub);
      u1 = std::max(ua, ub);
    } else {
      double t0 = (static_cast<double>(r) - va) / (vb - va);
      double t1 = (static_cast<double>(r + 1) - va) / (vb - va);
      if (t0 > t1) std::swap(t0, t1);
      t0 = std::clamp(t0, 0.0, 1.0);
      t1 = std::clamp(t1, 0.0, 1.0);
      u0 = ua + t0 * (ub - ua);
      u1 = ua + t1 * (ub - ua);
      if (u0 > u1) std::swap(u0, u1);
    }
    if (u1 < 0.0 || u0 > W) continue;
    const auto c0 = static_cast<int64_t>(std::clamp(std::floor(u0), 0.0, W - 1.0));
    const auto c1 = static_cast<int64_t>(std::clamp(std::floor(u1), 0.0, W - 1.0));
    for (int64_t c = c0; c <= c1; ++c) fn(c, r);
    any = true;
  }
  return any;
}

template <class Ops>
void seed(ScanState<Ops>& st) {
  const EngineContext& ctx = st.ctx;
  std::vector<int32_t> outside;
  for (int32_t id : ctx.geometric) {
    const bool inside =
        touched_cells(ctx.grid, ctx.window, ctx.local[id], [&](int64_t c, int64_t r) { st.offer(c, r, id); });
    if (!inside) outside.push_back(id);
  }
  if (outside.empty()) return;
  // Border cells get their exact nearest outside site, computed by the exact method on the
  // four one-cell-wide border strips with the outside sites only.
  const Window& w = ctx.window;
  const Window strips[4] = {{w.col0, w.row0, w.width, 1},
                            {w.col0, w.row0 + w.height - 1, w.width, 1},
                            {w.col0, w.row0, 1, w.height},
                            {w.col0 + w.width - 1, w.row0, 1, w.height}};
  Progress quiet(nullptr, nullptr, 1);
  for (const Window& strip : strips) {
    EngineContext sub{ctx.seeds, ctx.grid, strip,  ctx.local, outside, std::numeric_limits<double>::infinity(),
                      1,         &quiet,   ctx.geo};
    sub.geolocator = ctx.geolocator;
    Raster<int32_t> s(ctx.grid, strip, Uninitialized{});
    Raster<float> d(ctx.grid, strip, Uninitialized{});
    if (ctx.geo)
      run_exact_geodesic(sub, s, d);
    else
      run_exact(sub, s, d);
    for (int64_t r = 0; r < strip.height; ++r)
      for (int64_t c = 0; c < strip.width; ++c) st.offer(strip.col0 - w.col0 + c, strip.row0 - w.row0 + r, s.at(c, r));
  }
}

struct PassShape {
  bool columns;   // lines are columns (vertical cycle) rather than rows
  bool reversed;  // lines and positions walked from the far end
};

template <class Ops>
void run_pass(ScanState<Ops>& st, PassShape shape, int threads) {
  const int64_t lines = shape.columns ? st.width : st.height;
  const int64_t len = shape.columns ? st.height : st.width;
  // Map (line, position) in walk order to the cell's (col, row).
  auto cell = [&](int64_t l, int64_t i, int64_t& c, int64_t& r) {
    if (shape.reversed) {
      l = lines - 1 - l;
      i = len - 1 - i;
    }
    if (shape.columns) {
      c = l;
      r = i;
    } else {
      c = i;
      r = l;
    }
  };
  std::vector<std::atomic<int64_t>> done(static_cast<size_t>(lines));
  for (auto& d : done) d.store(0, std::memory_order_relaxed);
  Progress& progress = *st.ctx.progress;
  const int32_t* sites = st.site.data();

  parallel_for(threads, lines, [&](int64_t l, int) {
    for (int64_t i0 = 0; i0 < len; i0 += kChunk) {
      const int64_t i1 = std::min(i0 + kChunk, len);
      if (l > 0) {
        // Line l-1 must be final up to position i1 (the i+1 neighbour of position i1-1).
        const int64_t need = std::min(i1 + 1, len);
        std::atomic<int64_t>& prev = done[static_cast<size_t>(l - 1)];
        for (int64_t seen = prev.load(std::memory_order_acquire); seen < need;
             seen = prev.load(std::memory_order_acquire))
          prev.wait(seen, std::memory_order_acquire);
      }
      for (int64_t i = i0; i < i1; ++i) {
        int64_t c, r;
        cell(l, i, c, r);
        int32_t cand[4];
        int n = 0;
        auto take = [&](int64_t ll, int64_t ii) {
          if (ll < 0 || ii < 0 || ii >= len) return;
          int64_t cc, rr;
          cell(ll, ii, cc, rr);
          cand[n++] = sites[st.at(cc, rr)];
        };
        take(l - 1, i - 1);
        take(l - 1, i);
        take(l - 1, i + 1);
        take(l, i - 1);
        const size_t at = st.at(c, r);
        typename Ops::Cell p{};
        bool located = false;
        for (int k = 0; k < n; ++k) {
          if (cand[k] == sites[at] || cand[k] == kNoSite) continue;
          if (!located) {
            p = st.ops.cell(st.ctx.window.col0 + c, st.ctx.window.row0 + r);
            located = true;
          }
          st.offer_at(at, p, cand[k]);
        }
      }
      std::atomic<int64_t>& mine = done[static_cast<size_t>(l)];
      mine.store(i1, std::memory_order_release);
      mine.notify_all();
    }
    progress.advance(len);
  });
}

template <class Ops>
void scan(const EngineContext& ctx, const Ops ops, bool vertical_cycle, Raster<int32_t>& site,
          Raster<float>& distance) {
  const Window& w = ctx.window;
  ScanState<Ops> st{ctx, ops, w.width, w.height, site, {}};
  std::fill(site.cells().begin(), site.cells().end(), kNoSite);
  st.key.assign(static_cast<size_t>(w.cell_count()), std::numeric_limits<double>::infinity());
  seed(st);
  ctx.progress->set_total(w.cell_count() * (vertical_cycle ? 4 : 2));
  run_pass(st, {false, false}, ctx.threads);  // horizontal forward
  run_pass(st, {false, true}, ctx.threads);   // horizontal backward
  if (vertical_cycle) {
    run_pass(st, {true, false}, ctx.threads);  // vertical forward
    run_pass(st, {true, true}, ctx.threads);   // vertical backward
  }
  float* d = distance.data();
  int32_t* s = site.data();
  for (size_t i = 0; i < st.key.size(); ++i) {
    if (s[i] == kNoSite || st.key[i] > ctx.max_key) {
      s[i] = kNoSite;
      d[i] = kNoDistance;
    } else {
      d[i] = static_cast<float>(Ops::distance(st.key[i]));
    }
  }
}

}  // namespace

void run_scan(const EngineContext& ctx, bool vertical_cycle, Raster<int32_t>& site, Raster<float>& distance) {
  if (ctx.geo)
    scan(ctx, GeodesicOps{ctx}, vertical_cycle, site, distance);
  else
    scan(ctx, PlanarOps{ctx}, vertical_cycle, site, distance);
}

}  // namespace rv::detail
