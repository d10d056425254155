// Partial-effect lines as a whole (partial_joins.hpp). The turned-back check exists because a
// trace from a partial tripoint was seen to come back over itself (straight, Zealand at half
// effect: bench/RESULTS-sea.md, sessions 59-60); drawing that line would hand a strait's cells to
// the wrong owner in the regions, so it is refused until the trace is right.
#include "lines/partial/partial_joins.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "lines/partial/partial_tripoints.hpp"
#include "rv/field/error.hpp"

namespace rv::partial_joins {

using partial_tripoints::owner_label;

namespace {

[[noreturn]] void refuse(const SeedSet& seeds, int32_t a, int32_t b, const std::string& why) {
  throw Error(ErrorKind::unsupported, "partial effect: the partial-effect line of owners " + owner_label(seeds, a) +
                                          " and " + owner_label(seeds, b) + " " + why +
                                          "; its lines are not drawn (the rasters are exact)");
}

}  // namespace

void join_at(std::vector<BoundaryLine>& lines, const SeedSet& seeds, int32_t B, int32_t X,
             const std::vector<Vec2>& at) {
  auto pair = [&](const BoundaryLine& l) {
    return !l.closed && ((l.owner_a == B && l.owner_b == X) || (l.owner_a == X && l.owner_b == B));
  };
  for (const Vec2 c : at) {
    auto ending = std::find_if(lines.begin(), lines.end(),
                               [&](const BoundaryLine& l) { return pair(l) && l.vertices.back().p == c; });
    auto starting = std::find_if(lines.begin(), lines.end(),
                                 [&](const BoundaryLine& l) { return pair(l) && l.vertices.front().p == c; });
    if (ending == lines.end() || starting == lines.end() || ending == starting || ending->owner_a != starting->owner_a)
      refuse(seeds, B, X, "followed past a coast does not join its other piece");
    ending->vertices.insert(ending->vertices.end(), starting->vertices.begin() + 1, starting->vertices.end());
    ending->bows.clear();
    lines.erase(starting);
  }
}

void refuse_turned_back(const std::vector<BoundaryLine>& lines, const SeedSet& seeds, double res) {
  auto same = [&](Vec2 a, Vec2 b) { return std::hypot(a.x - b.x, a.y - b.y) <= 1e-6 * res; };
  for (const BoundaryLine& line : lines) {
    const std::vector<BoundaryVertex>& v = line.vertices;
    if (!line.closed && v.size() > 3 && same(v.front().p, v.back().p) && same(v[1].p, v[v.size() - 2].p))
      refuse(seeds, line.owner_a, line.owner_b, "turns back to where it began");
  }
}

}  // namespace rv::partial_joins
