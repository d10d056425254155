// The shortest-path map drawn root by root, as an experiment (sea_bench --paint 1).
//
// The cells that see their straight nearest site take its distance (sea_map/site_sight.hpp);
// every other sea cell starts at +infinity. Then every root (the point sites at 0, the settled
// bend nodes at their distance D) in increasing order of D draws the region it sees
// (sea/visible_region.hpp) over a square round it, and each cell of that region where the
// path is taut at the root takes D + length when that is less than what the cell holds. A
// root's region is star-shaped from it (a point on the way from a root to a cell it serves is
// served by it), so the square needs to grow only while the root still wins somewhere on its
// sides: along every part of the ring that runs on a side, every half cell, a sample y is
// refuted only by a witness, a cell round y that sees y (one exact sees()) and holds a path
// that, carried on to y, is shorter than the root's; an unrefuted sample grows the square. Cells
// within a ring's bands where the root could win are left to the exact predicates (counted as
// unsure), and so are the cells of a root whose region is blurred.
//
// In increasing order of D every cell whose distance is below the root's D already holds it, so
// a root draws only where its paths are at least D long.
//
// --paint 1 tries every taut cell of the ring in each square; --paint 2 (planar grids only) goes
// out from the root's row a row at a time and tries a cell only where the ray from the root
// passes between two live cells of the row before (cells where the root is not beaten by more
// than two diagonals), or next to one of the ring's crossings there. Lengths are GeographicLib's
// for every cell tried, so the time of the painting itself is not an engine's: the counts are
// what this measures, and the regions' and rings' times.

#include "paint_measure.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <tuple>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/sea/geodesic_frame.hpp"
#include "sea/bend_settle.hpp"
#include "sea/edge_index.hpp"
#include "sea/sea_prepare.hpp"
#include "sea/visible_region.hpp"
#include "sea_map/ground_rows.hpp"
#include "sea_map/row_pieces.hpp"
#include "sea_map/site_sight.hpp"

using namespace rv;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDegree = std::numbers::pi / 180.0;
constexpr int32_t kLand = -2, kNone = -1;

struct Counts {
  int64_t roots = 0, sweeps = 0, grown = 0, edges_read = 0, evaluated = 0, painted = 0, blurred = 0, undrawn = 0;
  int64_t rim_samples = 0;
  int64_t max_half_side_cells = 0;
  double sweep_s = 0.0, ring_s = 0.0, sides_s = 0.0;  // visible regions; rings put on rows; sides checked
};

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

class Painter {
 public:
  Painter(const sea::Prepared& p, const sea::Searches& b, const GridSpec& grid, const MetricSpec& metric,
          const std::vector<sea::EdgeIndex::Segment>& edges, const sea::EdgeIndex& index)
      : p_(p), b_(b), grid_(grid), metric_(metric), window_(grid.full_window()), edges_(edges), index_(index) {
    frame_ = p.vis.frame();
    const auto cells = static_cast<size_t>(window_.width * window_.height);
    spots_.resize(cells);
    std::vector<sea::Spot> row;
    for (int64_t r = 0; r < window_.height; ++r) {
      p.row_cells(grid, window_, r, row);
      std::copy(row.begin(), row.end(), spots_.begin() + r * window_.width);
    }
    val_.assign(cells, kInf);
    second_.assign(cells, kInf);
    lab_.assign(cells, kNone);
    unsure_.assign(cells, 0);
    open_.assign(cells, 0);
    // Plane units per cell at least (as site_sight.cpp), and a cell's diagonal in metres at most.
    const double lat = std::max(std::abs(grid.centre_y(0)), std::abs(grid.centre_y(window_.height - 1)));
    const double minor = metric.semi_major * (1.0 - metric.flattening);
    plane_per_cell_ =
        frame_ ? minor * grid.res * kDegree * std::cos(std::min(89.0, lat + grid.res) * kDegree) : grid.res;
    const double cell_m = frame_ ? metric.semi_major * grid.res * kDegree * 1.01 : grid.res;
    diagonal_ = cell_m * std::sqrt(2.0);
    // The window in the plane.
    wlo_ = {kInf, kInf};
    whi_ = {-kInf, -kInf};
    for (int k = 0; k <= 64; ++k) {
      const double f = k / 64.0;
      const double x = grid.xmin + f * (grid.xmax() - grid.xmin), y = grid.ymin() + f * (grid.ymax - grid.ymin());
      for (Vec2 q : {Vec2{x, grid.ymin()}, Vec2{x, grid.ymax}, Vec2{grid.xmin, y}, Vec2{grid.xmax(), y}}) {
        const Vec2 at = plane(q);
        wlo_ = {std::min(wlo_.x, at.x), std::min(wlo_.y, at.y)};
        whi_ = {std::max(whi_.x, at.x), std::max(whi_.y, at.y)};
      }
    }
  }

  // The cells that see their straight nearest site, and land.
  void start(const std::vector<Visibility::Ground>& ground, const std::vector<sea::SiteSight::Sight>& sight,
             const NearestField& straight) {
    for (size_t i = 0; i < val_.size(); ++i) {
      open_[i] = ground[i] == Visibility::Ground::open_sea;
      if (ground[i] == Visibility::Ground::land) {
        lab_[i] = kLand;
      } else if (sight[i] == sea::SiteSight::seen) {
        const int64_t c = static_cast<int64_t>(i) % window_.width, r = static_cast<int64_t>(i) / window_.width;
        val_[i] = straight.distance.at(c, r);
        lab_[i] = straight.site.at(c, r);
      }
    }
  }

  // Root: a point site (node -1, D 0) or settled node `node`.
  void paint(const Visibility::Place& from, double d, int32_t label, int32_t node, int32_t site) {
    ++counts.roots;
    double half = 32.0 * plane_per_cell_;
    Vec2 old_lo{kInf, kInf}, old_hi{-kInf, -kInf};  // the square already drawn
    for (;;) {
      const Vec2 lo{from.at.x - half, from.at.y - half}, hi{from.at.x + half, from.at.y + half};
      counts.max_half_side_cells = std::max(counts.max_half_side_cells, static_cast<int64_t>(half / plane_per_cell_));
      index_.edges_in_box(lo, hi, stamps_, near_);
      ++counts.sweeps;
      counts.edges_read += static_cast<int64_t>(near_.size());
      auto t0 = std::chrono::steady_clock::now();
      const sea::VisibleRegion region = sea::visible_region(p_.vis, from, lo, hi, edges_, &near_);
      counts.sweep_s += since(t0);
      if (region.blurred) {
        ++counts.blurred;
        (node >= 0 ? blurred_vertices : blurred_sites).push_back(node >= 0 ? from.vertex : site);
        return;
      }
      if (region.ring.empty()) return;
      const double band = 2.0 * (region.margin + (frame_ ? frame_->deviation() : 0.0)) / plane_per_cell_;
      t0 = std::chrono::steady_clock::now();
      sea::RowPieces ring(grid_, window_, metric_, frame_ != nullptr);
      for (size_t k = 0; k < region.ring.size(); ++k)
        ring.add_edge(lonlat(region.ring[k]), lonlat(region.ring[(k + 1) % region.ring.size()]), true, band);
      ring.index();
      counts.ring_s += since(t0);
      int64_t c0, c1, r0, r1;
      cell_range(lo, hi, c0, c1, r0, r1);
      auto value = [&](size_t i) {
        const sea::Spot& s = spots_[i];
        return d + (node >= 0 ? p_.vertex_length(b_.nodes[static_cast<size_t>(node)].vertex, s)
                              : std::sqrt(p_.site_key(s, site)));
      };
      auto taut_at = [&](Vec2 x) { return node < 0 || sea::taut(p_.vis, b_.tauts[static_cast<size_t>(node)], x); };
      auto drawn_before = [&](Vec2 x) { return x.x > old_lo.x && x.x < old_hi.x && x.y > old_lo.y && x.y < old_hi.y; };
      // One cell: painted where the root is shorter; whether the root may still win beyond it
      // along the ray from the root (live): not beaten there by more than two diagonals, or on a
      // barrier's edge, or in a band.
      auto cell = [&](int64_t r, int64_t c, bool in_band) {
        const auto i = static_cast<size_t>(r * window_.width + c);
        if (lab_[i] == kLand) return true;
        if (in_band) {
          ++counts.evaluated;
          if (value(i) - diagonal_ <= val_[i]) unsure_[i] = 1;
          return true;
        }
        if (!taut_at(spots_[i].at)) return false;
        if (!stop_rays && drawn_before(spots_[i].at)) return true;
        ++counts.evaluated;
        const double v = value(i);
        if (v < val_[i]) {
          second_[i] = val_[i];
          val_[i] = v;
          lab_[i] = label;
          ++counts.painted;
        } else if (v < second_[i] && lab_[i] != label) {
          second_[i] = v;
        }
        return !open_[i] || !(val_[i] + 2.0 * diagonal_ < v);
      };
      const int64_t root_row = std::clamp<int64_t>(std::lround(cell_of(from.at).second), r0, r1);
      // Rows outward from the root's, south then north. With stop_rays, a row's cells are tried
      // only where the ray from the root passes between two cells of the row before that are
      // live, or next to a crossing of the ring (a gap narrower than a cell): beyond a point
      // where the root loses, it loses all along the ray (its region is star-shaped).
      for (const int step : {1, -1}) {
        std::vector<std::pair<double, double>> live;  // angles from the root, the row before's
        bool all = true;
        for (int64_t r = step > 0 ? root_row : root_row - 1; r >= r0 && r <= r1; r += step) {
          ring.row(r, c0, c1 + 1, crossings_, bands_);
          std::vector<uint8_t>& alive = alive_;
          alive.assign(static_cast<size_t>(c1 - c0 + 1), 0);
          std::vector<std::pair<int64_t, int64_t>> tried;  // column ranges
          // A row whose image bends round the root's height (a parallel's image bows in the
          // frame) is tried whole: its angles from the root would not rise or fall along it.
          auto beyond_root = [&]() {
            for (int64_t c = c0;; c = std::min(c1, c + 16)) {
              const double y = spots_[static_cast<size_t>(r * window_.width + c)].at.y;
              if (step > 0 ? !(y < from.at.y) : !(y > from.at.y)) return false;
              if (c == c1) return true;
            }
          };
          if (!stop_rays || all || std::abs(r - root_row) <= 2 || !beyond_root()) {
            tried.emplace_back(c0, c1);
          } else {
            auto angle = [&](int64_t c) {
              const Vec2 x = spots_[static_cast<size_t>(r * window_.width + c)].at;
              return std::atan2(x.y - from.at.y, x.x - from.at.x);
            };
            // South of the root the angle rises along the row, north it falls.
            const bool rising = angle(c0) < angle(c1);
            for (const auto& [a0, a1] : live) {
              auto first_at_least = [&](double t) {  // first column whose angle is past t
                int64_t lo_c = c0, hi_c = c1 + 1;
                while (lo_c < hi_c) {
                  const int64_t m = (lo_c + hi_c) / 2;
                  if (rising ? angle(m) < t : angle(m) > t)
                    lo_c = m + 1;
                  else
                    hi_c = m;
                }
                return lo_c;
              };
              const int64_t f = first_at_least(rising ? a0 : a1), e = first_at_least(rising ? a1 : a0);
              const int64_t lo_c = std::max(c0, f - 1), hi_c = std::min(c1, e);
              if (lo_c <= hi_c) tried.emplace_back(lo_c, hi_c);
            }
          }
          for (const auto& [t0c, t1c] : tried) {
            sea::for_each_span(crossings_, t0c, t1c + 1, [&](int64_t first, int64_t stop, int winding) {
              if (winding < 1) return;
              for (int64_t c = first; c < stop; ++c) alive[static_cast<size_t>(c - c0)] |= cell(r, c, false) ? 1 : 0;
            });
            for (const auto& cr : crossings_) {
              const auto c = static_cast<int64_t>(std::floor(cr.u));
              for (int64_t k = c; k <= c + 1; ++k)
                if (k >= t0c && k <= t1c) alive[static_cast<size_t>(k - c0)] = 1;
            }
          }
          for (const auto& [first, last] : bands_)
            for (int64_t c = first; c <= last; ++c) alive[static_cast<size_t>(c - c0)] |= cell(r, c, true) ? 1 : 0;
          // The live runs, a cell wider each side, as angles for the next row.
          live.clear();
          auto angle_of = [&](int64_t c) {
            const Vec2 x =
                spots_[static_cast<size_t>(r * window_.width + std::clamp(c, int64_t{0}, window_.width - 1))].at;
            return std::atan2(x.y - from.at.y, x.x - from.at.x);
          };
          for (int64_t c = c0; c <= c1;) {
            if (!alive[static_cast<size_t>(c - c0)]) {
              ++c;
              continue;
            }
            int64_t e = c;
            while (e + 1 <= c1 && alive[static_cast<size_t>(e + 1 - c0)]) ++e;
            const double t0 = angle_of(c - 1), t1 = angle_of(e + 1);
            live.emplace_back(std::min(t0, t1), std::max(t0, t1));
            c = e + 1;
          }
          all = false;
          if (live.empty() && std::abs(r - root_row) > 2) break;
        }
      }
      // Does the root still win somewhere on the square's sides?
      const bool covers = lo.x <= wlo_.x && lo.y <= wlo_.y && hi.x >= whi_.x && hi.y >= whi_.y;
      auto value_at = [&](const sea::Spot& x) {
        return d + (node >= 0 ? p_.vertex_length(b_.nodes[static_cast<size_t>(node)].vertex, x)
                              : std::sqrt(p_.site_key(x, site)));
      };
      t0 = std::chrono::steady_clock::now();
      const bool grow = !covers && wins_on_sides(region, lo, hi, value_at);
      counts.sides_s += since(t0);
      if (!grow) return;
      old_lo = lo;
      old_hi = hi;
      half *= 2.0;
      ++counts.grown;
    }
  }

  Counts counts;
  bool stop_rays = true;                                 // else every taut cell of the ring in the square is tried
  std::vector<int32_t> blurred_sites, blurred_vertices;  // roots whose regions were not drawn
  const std::vector<double>& values() const { return val_; }
  const std::vector<double>& seconds() const { return second_; }
  const std::vector<int32_t>& labels() const { return lab_; }
  const std::vector<uint8_t>& unsure() const { return unsure_; }

 private:
  Vec2 plane(Vec2 q) const { return frame_ ? frame_->forward(q) : Vec2{q.x - grid_.xmin, q.y - grid_.ymax}; }
  Vec2 lonlat(Vec2 x) const { return frame_ ? frame_->reverse(x) : x; }
  // Fractional column and row of a plane point's cell centre.
  std::pair<double, double> cell_of(Vec2 x) const {
    if (!frame_) return {x.x / grid_.res - 0.5, -x.y / grid_.res - 0.5};
    const Vec2 ll = frame_->reverse(x);
    return {(ll.x - grid_.xmin) / grid_.res - 0.5, (grid_.ymax - ll.y) / grid_.res - 0.5};
  }
  void cell_range(Vec2 lo, Vec2 hi, int64_t& c0, int64_t& c1, int64_t& r0, int64_t& r1) const {
    double fc0 = kInf, fc1 = -kInf, fr0 = kInf, fr1 = -kInf;
    for (int k = 0; k <= 16; ++k) {
      const double f = k / 16.0, x = lo.x + f * (hi.x - lo.x), y = lo.y + f * (hi.y - lo.y);
      for (Vec2 q : {Vec2{x, lo.y}, Vec2{x, hi.y}, Vec2{lo.x, y}, Vec2{hi.x, y}}) {
        const auto [fc, fr] = cell_of(q);
        fc0 = std::min(fc0, fc);
        fc1 = std::max(fc1, fc);
        fr0 = std::min(fr0, fr);
        fr1 = std::max(fr1, fr);
      }
    }
    const double widen = 2.0 + 0.02 * std::max(fc1 - fc0, fr1 - fr0);
    c0 = std::clamp<int64_t>(static_cast<int64_t>(std::floor(fc0 - widen)), 0, window_.width - 1);
    c1 = std::clamp<int64_t>(static_cast<int64_t>(std::ceil(fc1 + widen)), 0, window_.width - 1);
    r0 = std::clamp<int64_t>(static_cast<int64_t>(std::floor(fr0 - widen)), 0, window_.height - 1);
    r1 = std::clamp<int64_t>(static_cast<int64_t>(std::ceil(fr1 + widen)), 0, window_.height - 1);
  }
  // Whether the root may still win somewhere on the square's sides: along the ring's parts on
  // them, every half cell, a sample is refuted only by a witness among the cells round it (the
  // nearest centre and its eight neighbours) that sees it and holds a shorter path to it.
  template <class ValueAt>
  bool wins_on_sides(const sea::VisibleRegion& region, Vec2 lo, Vec2 hi, ValueAt&& value_at) {
    const double eps = 1e-9 * std::max(hi.x - lo.x, hi.y - lo.y);
    // The side both ends of a ring edge lie on (a corner lies on two), or -1.
    auto on = [&](Vec2 x, int s) {
      return s == 0   ? std::abs(x.x - lo.x) < eps
             : s == 1 ? std::abs(x.x - hi.x) < eps
             : s == 2 ? std::abs(x.y - lo.y) < eps
                      : std::abs(x.y - hi.y) < eps;
    };
    const size_t n = region.ring.size();
    for (size_t k = 0; k < n; ++k) {
      const Vec2 a = region.ring[k], b = region.ring[(k + 1) % n];
      bool along = false;
      for (int s = 0; s < 4; ++s) along = along || (on(a, s) && on(b, s));
      if (!along) continue;
      const double len = std::hypot(b.x - a.x, b.y - a.y);
      const auto steps = static_cast<int64_t>(std::ceil(len / (0.5 * plane_per_cell_))) + 1;
      for (int64_t j = 0; j <= steps; ++j) {
        const double f = static_cast<double>(j) / static_cast<double>(steps);
        const Vec2 y{a.x + f * (b.x - a.x), a.y + f * (b.y - a.y)};
        ++counts.rim_samples;
        // The root loses at y when some cell seeing y holds a path that, carried on to y, is
        // shorter; else the square grows.
        const sea::Spot ys{y, lonlat(y)};
        const double at_y = value_at(ys);
        const auto [fc, fr] = cell_of(y);
        const auto cc = static_cast<int64_t>(std::lround(fc)), rr = static_cast<int64_t>(std::lround(fr));
        bool lost = false;
        for (int64_t r = rr - 1; r <= rr + 1 && !lost; ++r)
          for (int64_t c = cc - 1; c <= cc + 1 && !lost; ++c) {
            if (c < 0 || r < 0 || c >= window_.width || r >= window_.height) continue;
            const auto i = static_cast<size_t>(r * window_.width + c);
            if (lab_[i] == kLand || !std::isfinite(val_[i])) continue;
            const sea::Spot& x = spots_[i];
            const double way = frame_ ? p_.geodesic->point_distance(x.ll, ys.ll) : sea::length(x.at, y);
            if (val_[i] + way < at_y * (1.0 - 1e-12) && p_.vis.sees(Visibility::Place{x.at}, Visibility::Place{y}))
              lost = true;
          }
        if (!lost) return true;
      }
    }
    return false;
  }

  const sea::Prepared& p_;
  const sea::Searches& b_;
  const GridSpec& grid_;
  const MetricSpec& metric_;
  Window window_;
  const GeodesicFrame* frame_ = nullptr;
  const std::vector<sea::EdgeIndex::Segment>& edges_;
  const sea::EdgeIndex& index_;
  std::vector<sea::Spot> spots_;
  std::vector<double> val_, second_;
  std::vector<int32_t> lab_;
  std::vector<uint8_t> unsure_, open_, alive_;
  double plane_per_cell_ = 1.0, diagonal_ = 1.0;
  Vec2 wlo_, whi_;
  std::vector<int32_t> near_;
  sea::EdgeIndex::Stamps stamps_;
  std::vector<sea::RowPieces::Crossing> crossings_;
  std::vector<std::pair<int64_t, int64_t>> bands_;
};

}  // namespace

bool measure_paint(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid, const MetricSpec& metric,
                   const SeaField& field, bool stop_rays) {
  SeaOptions options;
  options.metric = metric;
  options.threads = 1;
  const auto prepared = prepare_sea(seeds, barriers, grid, options);
  const sea::Prepared& p = prepared->prepared;
  const sea::Searches& b = prepared->search;
  const Window window = grid.full_window();
  const auto cells = static_cast<size_t>(window.width * window.height);
  ComputeOptions o;
  o.metric = metric;
  o.threads = 1;
  const NearestField straight = compute(seeds, grid, o);
  const auto& cut = prepared->cut_edges();
  auto t0 = std::chrono::steady_clock::now();
  std::vector<Visibility::Ground> ground(cells);
  std::vector<sea::SiteSight::Sight> sight(cells);
  {
    const sea::GroundRows rows(p, metric, grid, window);
    const sea::SiteSight sites(p, metric, grid, window, straight.site, cut.edges, cut.index);
    for (int64_t r = 0; r < window.height; ++r) {
      rows.row(r, ground.data() + r * window.width);
      sites.row(r, sight.data() + r * window.width);
    }
  }
  Painter painter(p, b, grid, metric, cut.edges, cut.index);
  painter.start(ground, sight, straight);
  painter.stop_rays = stop_rays;
  if (stop_rays && p.geodesic) {
    // (A parallel's image bows in the frame: a ray from a root may meet a row twice, and the
    // rows' angles bracket it wrongly; tried at 0.001 deg, 2,976 cells were lost.)
    std::printf("paint: rays stopped on planar grids only\n");
    return false;
  }
  auto t1 = std::chrono::steady_clock::now();
  // The roots in increasing order of their distance: the point sites, then the settled nodes.
  std::vector<std::tuple<double, int32_t, int32_t>> roots;  // (D, site, node)
  for (int32_t s = 0; s < static_cast<int32_t>(p.local.size()); ++s)
    if (!p.segment(s)) roots.emplace_back(0.0, s, -1);
  for (size_t k = 0; k < b.nodes.size(); ++k)
    if (std::isfinite(b.dist[k].d) && b.dist[k].d > 0.0)
      roots.emplace_back(b.dist[k].d, b.dist[k].site, static_cast<int32_t>(k));
  std::sort(roots.begin(), roots.end());
  const auto sites = static_cast<int32_t>(p.local.size());
  for (const auto& [d, site, node] : roots) {
    if (node >= 0) {
      const sea::Node& n = b.nodes[static_cast<size_t>(node)];
      painter.paint(p.vis.at_vertex(n.vertex, n.wedge), d, sites + node, node, site);
      continue;
    }
    const Vec2 at{p.local[static_cast<size_t>(site)].ax, p.local[static_cast<size_t>(site)].ay};
    Visibility::Place from{at};
    from.vertex = p.vis.vertex_at(at);
    const Visibility::Star star = from.vertex >= 0 ? p.vis.vertex_star(from.vertex) : p.vis.star_at(at);
    if (star.wedges() > 1) {
      if (std::count(star.sea.begin(), star.sea.end(), uint8_t{1}) != 1) {
        ++painter.counts.undrawn;
        continue;
      }
      from.wedge = static_cast<int>(std::find(star.sea.begin(), star.sea.end(), uint8_t{1}) - star.sea.begin());
    }
    painter.paint(from, 0.0, site, -1, site);
  }
  auto t2 = std::chrono::steady_clock::now();
  // Against the exact engine's field.
  int64_t sea_cells = 0, bent = 0, of_blurred = 0, agree = 0, tie_labels = 0, unsure = 0, near_ties = 0, missed = 0,
          worse = 0, better = 0;
  const auto& val = painter.values();
  const auto& lab = painter.labels();
  for (int64_t r = 0; r < window.height; ++r)
    for (int64_t c = 0; c < window.width; ++c) {
      const auto i = static_cast<size_t>(r * window.width + c);
      const int32_t s = field.field.site.at(c, r);
      if (s == kNoSite || lab[i] == kLand) continue;
      ++sea_cells;
      const int32_t via = field.via.at(c, r);
      bent += via != kNoVia;
      if (std::count(painter.blurred_sites.begin(), painter.blurred_sites.end(), s) && via == kNoVia) {
        ++of_blurred;
        continue;
      }
      if (via != kNoVia && std::count(painter.blurred_vertices.begin(), painter.blurred_vertices.end(), via)) {
        ++of_blurred;
        continue;
      }
      if (painter.unsure()[i]) {
        ++unsure;
        continue;
      }
      if (painter.seconds()[i] - val[i] < 2e-5) ++near_ties;
      if (lab[i] == kNone) {
        ++missed;
        continue;
      }
      const double d = field.field.distance.at(c, r);
      const double tol = 1e-6 * std::max(1.0, d);
      if (val[i] > d + tol) {
        if (worse < 8)  // (the first few, to look at)
          std::printf("longer: cell %lld %lld painted %.3f label %d, field %.3f site %d via %d\n", (long long)c,
                      (long long)r, val[i], lab[i], d, s, via);
        ++worse;
        continue;
      }
      if (val[i] < d - tol) {
        ++better;
        continue;
      }
      const int32_t got_via = lab[i] >= sites ? b.nodes[static_cast<size_t>(lab[i] - sites)].vertex : kNoVia;
      ++agree;
      tie_labels += got_via != via;
    }
  const Counts& n = painter.counts;
  std::printf(
      "paint (%s), one thread: ground and sites' sight drawn %.3f s; roots painted %.3f s: %lld roots, %lld sweeps "
      "(%lld squares grown, the largest half side %lld cells), %lld edges read, %lld rim samples, %lld blurred, %lld "
      "sites undrawn; %lld cells evaluated, %lld painted; regions %.3f s, rings on rows %.3f s, sides %.3f s\n",
      stop_rays ? "rays stopped where the root loses" : "every taut cell of each square",
      std::chrono::duration<double>(t1 - t0).count(), std::chrono::duration<double>(t2 - t1).count(),
      static_cast<long long>(n.roots), static_cast<long long>(n.sweeps), static_cast<long long>(n.grown),
      static_cast<long long>(n.max_half_side_cells), static_cast<long long>(n.edges_read),
      static_cast<long long>(n.rim_samples), static_cast<long long>(n.blurred), static_cast<long long>(n.undrawn),
      static_cast<long long>(n.evaluated), static_cast<long long>(n.painted), n.sweep_s, n.ring_s, n.sides_s);
  std::printf(
      "paint against the field: %lld sea cells (%lld bent); %lld agree (%lld of them another label at the same "
      "length), %lld unsure (in a ring's band), %lld served by a blurred root, %lld within 2e-5 m of a second root; "
      "%lld unpainted, %lld longer, "
      "%lld shorter\n",
      static_cast<long long>(sea_cells), static_cast<long long>(bent), static_cast<long long>(agree),
      static_cast<long long>(tie_labels), static_cast<long long>(unsure), static_cast<long long>(of_blurred),
      static_cast<long long>(near_ties), static_cast<long long>(missed), static_cast<long long>(worse),
      static_cast<long long>(better));
  return missed == 0 && worse == 0 && better == 0;
}
