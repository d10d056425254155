// The loci of a band found from the rule's cells. See partial_loci.hpp.
#include "lines/partial/partial_loci.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "lines/line_tools.hpp"

namespace rv::partial_loci {

namespace {

// The cells within one cell of lines: a cell pair found beside a drawn line is that line's locus.
class Covered {
 public:
  explicit Covered(const GridSpec& g) : g_(g) {}

  // Marks the cells round every point of the polyline, sampled at a quarter of a cell: a cell
  // pair whose centres the line passes between lies within this margin.
  void add(const std::vector<Vec2>& line) {
    if (line.size() == 1) mark(line.front());
    for (size_t k = 1; k < line.size(); ++k) {
      const Vec2 a = line[k - 1], b = line[k];
      const double len = std::hypot(b.x - a.x, b.y - a.y);
      const auto n = static_cast<int64_t>(std::ceil(len / (0.25 * g_.res))) + 1;
      for (int64_t i = 0; i <= n; ++i) mark(line_tools::lerp(a, b, static_cast<double>(i) / static_cast<double>(n)));
    }
  }

  bool has(int64_t col, int64_t row) const { return cells_.count(row * g_.width + col) != 0; }

 private:
  void mark(Vec2 p) {
    const auto col = static_cast<int64_t>(std::floor((p.x - g_.xmin) / g_.res));
    const auto row = static_cast<int64_t>(std::floor((g_.ymax - p.y) / g_.res));
    for (int64_t r = row - 1; r <= row + 1; ++r)
      for (int64_t c = col - 1; c <= col + 1; ++c)
        if (c >= 0 && r >= 0 && c < g_.width && r < g_.height) cells_.insert(r * g_.width + c);
  }

  const GridSpec& g_;
  std::unordered_set<int64_t> cells_;
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
  Covered covered(g);
  for (const std::vector<Vec2>& l : drawn) covered.add(l);
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) {
      if (!given_back(c, r)) continue;
      constexpr int kSteps[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
      for (const auto& s : kSteps) {
        const int64_t c2 = c + s[0], r2 = r + s[1];
        if (c2 < 0 || r2 < 0 || c2 >= g.width || r2 >= g.height || !kept(c2, r2)) continue;
        if (covered.has(c, r) || covered.has(c2, r2)) continue;
        const Vec2 a{g.centre_x(c), g.centre_y(r)}, b{g.centre_x(c2), g.centre_y(r2)};
        const double fa = level.balance(a), fb = level.balance(b);
        // (Given back: the balance below 0; kept: at or above. A tie or a missing line has no root.)
        if (!(fa < 0.0) || !(fb >= 0.0) || !level.metric->open_between(a, b)) continue;
        const Vec2 on =
            line_tools::lerp(a, b,
                             line_tools::find_root([&](double t) { return level.balance(line_tools::lerp(a, b, t)); },
                                                   fa, fb, level.ftol, 1e-15));
        if (!level.in_band(on)) continue;  // (a root beside another band, across the neighbours' line)
        locus_follow::Through t = locus_follow::follow_through(level, on, residual);
        if (t.points.empty()) continue;
        covered.add(t.points);
        out.push_back(std::move(t));
      }
    }
  return out;
}

}  // namespace rv::partial_loci
