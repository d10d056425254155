// The loci of a band found from the rule's cells. See partial_loci.hpp.
#include "lines/partial/partial_loci.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <unordered_map>
#include <vector>

#include "lines/line_tools.hpp"

namespace rv::partial_loci {

namespace {

// The segments of lines, filed by the cells they pass through: whether a cell lies within one
// cell of a line (a cell pair found beside a drawn line is that line's locus), and whether the way
// between two cell centres crosses (or touches) a line.
class Drawn {
 public:
  explicit Drawn(const GridSpec& g) : g_(g) {}

  void add(const std::vector<Vec2>& line) {
    if (line.size() == 1) add_segment(line.front(), line.front());
    for (size_t k = 1; k < line.size(); ++k) add_segment(line[k - 1], line[k]);
  }

  bool near(int64_t col, int64_t row) const {
    return any_near(col, row, [](int32_t) { return true; });
  }

  // Whether a line passes within `d` of p (CRS units, at most seven eighths of a cell: a sample of
  // the line within an eighth of a cell of that point then lies in p's cell or a neighbour).
  bool within(Vec2 p, double d) const {
    return any_near(static_cast<int64_t>(std::floor((p.x - g_.xmin) / g_.res)),
                    static_cast<int64_t>(std::floor((g_.ymax - p.y) / g_.res)), [&](int32_t id) {
                      const std::array<Vec2, 2>& sg = segments_[static_cast<size_t>(id)];
                      const Vec2 q = line_tools::lerp(sg[0], sg[1], line_tools::nearest_t(sg[0], sg[1], p));
                      return std::hypot(p.x - q.x, p.y - q.y) <= d;
                    });
  }

  bool crosses(Vec2 a, Vec2 b) const {
    bool met = false;
    for_samples(a, b, [&](int64_t col, int64_t row) {
      met = met || any_near(col, row, [&](int32_t id) {
              return meet(a, b, segments_[static_cast<size_t>(id)][0], segments_[static_cast<size_t>(id)][1]);
            });
    });
    return met;
  }

 private:
  // Cells from -1 to width (height) along each axis: a line's point just outside the grid still
  // counts for the cells beside it; farther out, none (-1).
  int64_t key(int64_t col, int64_t row) const {
    if (col < -1 || row < -1 || col > g_.width || row > g_.height) return -1;
    return (row + 1) * (g_.width + 2) + col + 1;
  }
  void add_segment(Vec2 a, Vec2 b) {
    const auto id = static_cast<int32_t>(segments_.size());
    segments_.push_back({a, b});
    // Sampled at a quarter of a cell: any point of the segment lies within an eighth of a cell of
    // a sample, so a way that meets it passes through that sample's cell or a neighbour.
    for_samples(a, b, [&](int64_t col, int64_t row) {
      const int64_t k = key(col, row);
      if (k < 0) return;
      std::vector<int32_t>& ids = cells_[k];
      if (ids.empty() || ids.back() != id) ids.push_back(id);
    });
  }
  template <class F>
  void for_samples(Vec2 a, Vec2 b, F&& f) const {
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    const auto n = static_cast<int64_t>(std::ceil(len / (0.25 * g_.res))) + 1;
    for (int64_t i = 0; i <= n; ++i) {
      const Vec2 p = line_tools::lerp(a, b, static_cast<double>(i) / static_cast<double>(n));
      f(static_cast<int64_t>(std::floor((p.x - g_.xmin) / g_.res)),
        static_cast<int64_t>(std::floor((g_.ymax - p.y) / g_.res)));
    }
  }
  // Whether `hit` holds for a segment filed in cell (col, row) or a neighbour.
  template <class F>
  bool any_near(int64_t col, int64_t row, F&& hit) const {
    for (int64_t r = row - 1; r <= row + 1; ++r)
      for (int64_t c = col - 1; c <= col + 1; ++c) {
        const auto it = cells_.find(key(c, r));
        if (it == cells_.end()) continue;
        for (const int32_t id : it->second)
          if (hit(id)) return true;
      }
    return false;
  }
  // Whether segments a-b and p-q share a point (touching counts).
  static bool meet(Vec2 a, Vec2 b, Vec2 p, Vec2 q) {
    auto orient = [](Vec2 o, Vec2 u, Vec2 v) {
      const double x = (u.x - o.x) * (v.y - o.y) - (u.y - o.y) * (v.x - o.x);
      return (x > 0.0) - (x < 0.0);
    };
    auto within = [](Vec2 o, Vec2 u, Vec2 v) {  // v on the line o-u: within the box of o and u
      return std::min(o.x, u.x) <= v.x && v.x <= std::max(o.x, u.x) && std::min(o.y, u.y) <= v.y &&
             v.y <= std::max(o.y, u.y);
    };
    const int o1 = orient(a, b, p), o2 = orient(a, b, q), o3 = orient(p, q, a), o4 = orient(p, q, b);
    if (o1 != o2 && o3 != o4) return true;
    return (o1 == 0 && within(a, b, p)) || (o2 == 0 && within(a, b, q)) || (o3 == 0 && within(p, q, a)) ||
           (o4 == 0 && within(p, q, b));
  }

  const GridSpec& g_;
  std::vector<std::array<Vec2, 2>> segments_;
  std::unordered_map<int64_t, std::vector<int32_t>> cells_;
};

}  // namespace

std::vector<locus_follow::Through> loci_from_cells(const locus_follow::Level& level, const NearestField& full,
                                                   const NearestField& field, const SeedSet& seeds, int32_t B,
                                                   int32_t X, const std::vector<std::vector<Vec2>>& drawn,
                                                   LineResidual& residual) {
  const GridSpec& g = level.grid;
  std::vector<locus_follow::Through> out;
  if (full.site.width() != g.width || full.site.height() != g.height || field.site.width() != g.width ||
      field.site.height() != g.height)
    return out;
  auto owner = [&](const NearestField& f, int64_t c, int64_t r) {
    const int32_t s = f.site.at(c, r);
    return s == kNoSite ? 0 : seeds.site_owner(s);
  };
  // Given back: B's at full effect, X's by the rule. Kept: B's at both.
  auto given_back = [&](int64_t c, int64_t r) { return owner(full, c, r) == B && owner(field, c, r) == X; };
  auto kept = [&](int64_t c, int64_t r) { return owner(full, c, r) == B && owner(field, c, r) == B; };
  Drawn lines(g);
  for (const std::vector<Vec2>& l : drawn) lines.add(l);
  // The balance's root between two cell centres (given back: below 0; kept: at or above; a tie or
  // a missing line has no root) in the band, or false.
  auto root_between = [&](Vec2 a, Vec2 b, Vec2& on) {
    const double fa = level.balance(a), fb = level.balance(b);
    if (!(fa < 0.0) || !(fb >= 0.0) || !level.metric->open_between(a, b)) return false;
    on = line_tools::lerp(a, b,
                          line_tools::find_root([&](double t) { return level.balance(line_tools::lerp(a, b, t)); }, fa,
                                                fb, level.ftol, 1e-15));
    return level.in_band(on);  // (a root beside another band, across the neighbours' line)
  };
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      if (!given_back(c, r)) continue;
      constexpr int kSteps[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
      for (const auto& s : kSteps) {
        const int64_t c2 = c + s[0], r2 = r + s[1];
        if (c2 < 0 || r2 < 0 || c2 >= g.width || r2 >= g.height || !kept(c2, r2)) continue;
        if (lines.near(c, r) || lines.near(c2, r2)) continue;
        const Vec2 a{g.centre_x(c), g.centre_y(r)}, b{g.centre_x(c2), g.centre_y(r2)};
        Vec2 on;
        if (!root_between(a, b, on)) continue;
        locus_follow::Through t = locus_follow::follow_through(level, on, residual);
        if (t.points.empty()) continue;
        lines.add(t.points);
        out.push_back(std::move(t));
      }
    }
  // Where the rule's cells change owner along a channel narrower than a cell, the given-back and
  // the kept cells may meet only across corners, or a cell or two apart across the water: a pair
  // up to two cells apart in sight of each other whose way crosses no line drawn nor a locus
  // found above has the locus between them. Followed in steps of an eighth of a cell (at half a
  // cell the walk jumps the channel); a pair whose locus cannot be followed to coasts, the frame
  // or round is left without a line, as the cells alone would leave it.
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      if (!given_back(c, r)) continue;
      for (int64_t dr = -2; dr <= 2; ++dr)
        for (int64_t dc = -2; dc <= 2; ++dc) {
          const int64_t c2 = c + dc, r2 = r + dr;
          if (std::abs(dc) + std::abs(dr) <= 1 || c2 < 0 || r2 < 0 || c2 >= g.width || r2 >= g.height || !kept(c2, r2))
            continue;
          const Vec2 a{g.centre_x(c), g.centre_y(r)}, b{g.centre_x(c2), g.centre_y(r2)};
          Vec2 on;
          // (A root within the tolerance of a line drawn is that line's locus, the centre beside
          // it on the other side of the drawn chord.)
          if (lines.crosses(a, b) || !root_between(a, b, on) || lines.within(on, 4.0 * level.tol)) continue;
          LineResidual walked;
          locus_follow::Through t = locus_follow::follow_through(level, on, walked, 0.125 * g.res);
          if (t.points.size() < 2 || t.first == locus_follow::Stop::lost || t.last == locus_follow::Stop::lost)
            continue;
          residual.merge(walked);
          lines.add(t.points);
          out.push_back(std::move(t));
        }
    }
  return out;
}

}  // namespace rv::partial_loci
