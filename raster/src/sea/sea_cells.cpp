// The exact engine's answers for cells: one alone, or a block at once (sea/sea_cells.hpp says
// what each proves and why the answers are the same).
#include "sea/sea_cells.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rv::sea {
namespace {

// A cell's answer over the classes of adjusted seeds (PreparedSea::classes): per class its
// shortest path (its straight nearest site where seen, else the search), the cheapest by
// adjusted_distance, ties to the lower site. A class whose straight distance already costs more
// than the best so far cannot win (no path by sea is shorter than the straight line), and its
// search stops at the length that would tie. `d0`: the winning class's straight distance, 0 where
// its path is that class's straight nearest site seen (no detour). `unreachable`: some class is
// within its reach of the cell in a straight line, and none of those has any path to it at all
// (as opposed to none within the reach).
Best adjusted_path(const PreparedSea& prepared, const SeedSet& seeds, const Place& at, const Spot& spot,
                   double max_distance, std::vector<ClassHints>& hints, int64_t& tests, double& d0, bool& unreachable) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const Prepared& p = prepared.prepared;
  Best won;
  double won_cost = kInf;
  unreachable = false;
  std::vector<size_t> unanswered;  // classes searched within their reach that found no path
  bool found = false;              // some class searched found a path (within its reach or not)
  for (size_t k = 0; k < prepared.classes.size(); ++k) {
    const PreparedSea::Class& cls = prepared.classes[k];
    const Searches& s = *cls.search;
    const auto [k0, nearest] = s.straight(spot);
    if (nearest == kNoSite) continue;
    const double straight = std::sqrt(k0);
    const double cap = std::min(max_distance, cls.reach);
    const double limit = won.site == kNoSite ? cap : std::min(cap, won_cost * cls.weight * (1.0 + 1e-12));
    if (straight > limit) continue;
    ClassHints& h = hints[k];
    if (h.blockers.empty()) h.blockers.assign(static_cast<size_t>(s.site_items()) + s.nodes.size(), -1);
    Best b;
    ++tests;
    const bool seen = p.vis.sees(at, p.site_place(nearest, spot));
    if (seen)
      b = Best{straight, nearest, kNoVia};
    else
      b = s.best_path(at, spot, Best{}, tests, -1, &h.blockers, h.last, &h.last, 0, kInf, limit);
    if (b.site == kNoSite) {
      unanswered.push_back(k);
      continue;
    }
    found = true;
    const double cost =
        adjusted_distance(seeds.features()[static_cast<size_t>(seeds.site_feature(b.site))], b.d, max_distance);
    if (cost < won_cost || (cost == won_cost && cost < kInf && b.site < won.site)) {
      won = b;
      won_cost = cost;
      d0 = seen ? 0.0 : straight;
    }
  }
  if (won.site != kNoSite) return won;
  // (Only cells no class reaches within its reach ask whether any path reaches them at all.)
  unreachable = !found && !unanswered.empty();
  for (size_t k : unanswered)
    if (prepared.classes[k].search->best_path(at, spot, Best{}, tests).site != kNoSite) unreachable = false;
  return won;
}

// Writes a cell's path (none: nothing; beyond the maximum distance: no owner).
void write_path(const CellRun& run, CellWorker& w, int64_t c, int64_t r, const Best& best, float d0) {
  if (best.site == kNoSite) {
    ++w.unreachable;
    return;
  }
  if (best.d > run.max_distance) return;
  run.out.field.site.at(c, r) = best.site;
  run.out.field.distance.at(c, r) = static_cast<float>(best.d);
  run.out.via.at(c, r) = best.via;
  if (d0 > 0.0f) w.detour = std::max(w.detour, best.d / static_cast<double>(d0));
}

// Writes the straight field's answer (its nearest site, seen).
void write_straight(const CellRun& run, int64_t c, int64_t r) {
  run.out.field.site.at(c, r) = run.straight.site.at(c, r);
  run.out.field.distance.at(c, r) = run.straight.distance.at(c, r);
}

// A cell whose nearest site it does not see: the best path over every root.
void answer_bent(const CellRun& run, CellWorker& w, int64_t c, int64_t r, const Place& at, const Spot& spot) {
  const Best best = run.search().best_path(at, spot, Best{}, w.tests, -1, &w.blockers, w.last, &w.last);
  write_path(run, w, c, r, best, run.straight.distance.at(c, r));
}

// The largest length from x0 to any of the cells, or above it (geodesic: the chord, which a
// geodesic exceeds by a factor below 1 + 1e-5 up to 50 km; beyond, the inverse problem).
double reach_from(const Prepared& p, const Spot& x0, const Prepared::Xyz& xyz0, const std::vector<Spot>& spots,
                  const std::vector<Prepared::Xyz>& xyz) {
  double reach = 0.0;
  for (size_t i = 0; i < spots.size(); ++i) {
    if (!p.geodesic) {
      reach = std::max(reach, length(x0.at, spots[i].at));
      continue;
    }
    const double dx = xyz0.x - xyz[i].x, dy = xyz0.y - xyz[i].y, dz = xyz0.z - xyz[i].z;
    const double chord = std::sqrt(dx * dx + dy * dy + dz * dz);
    reach =
        std::max(reach, chord <= 5e4 ? chord * (1.0 + 1e-5) + 1e-6 : p.geodesic->point_distance(x0.ll, spots[i].ll));
  }
  return reach * (1.0 + 1e-12);
}

}  // namespace

void answer_cell(const CellRun& run, CellWorker& w, int64_t c, int64_t r, const Spot& spot, Visibility::Ground ground) {
  const Prepared& p = run.p();
  Place at{spot.at};
  at.open = ground == Visibility::Ground::open_sea;
  if (run.adjusted()) {
    double d0 = 0.0;
    bool unreachable = false;
    const Best best =
        adjusted_path(run.prepared, run.seeds, at, spot, run.max_distance, w.classes, w.tests, d0, unreachable);
    w.unreachable += unreachable ? 1 : 0;
    if (best.site == kNoSite) return;
    run.out.field.site.at(c, r) = best.site;
    run.out.field.distance.at(c, r) = static_cast<float>(best.d);
    run.out.via.at(c, r) = best.via;
    // (Over the straight distance as a float, as the reference.)
    if (d0 > 0.0) w.detour = std::max(w.detour, best.d / static_cast<double>(static_cast<float>(d0)));
    return;
  }
  // The straight field's answer where its nearest site is seen; else the best path. (None
  // within the maximum distance: no path by sea is shorter than the straight line.)
  const int32_t nearest = run.straight.site.at(c, r);
  if (nearest == kNoSite) return;
  ++w.tests;
  if (p.vis.sees(at, p.site_place(nearest, spot))) {
    write_straight(run, c, r);
    return;
  }
  answer_bent(run, w, c, r, at, spot);
}

namespace {

// A root of a block's bent cells: an item of the search's tree, its bound over the block, and
// whether it sees the whole block.
struct Candidate {
  int32_t item;
  double bound;
  bool sees_all;
};

// The block's cells whose path bends (`bent`: (row - r0) * stride + (column - c0) each), more
// than a few: one answered alone gives an upper bound of them all, and the roots within it are
// weighed for each (see the header).
void answer_bent_block(const CellRun& run, CellWorker& w, int64_t c0, int64_t r0, Vec2 lo, Vec2 hi,
                       const std::vector<std::vector<Spot>>& spots, const std::vector<int64_t>& bent, int64_t stride) {
  const Prepared& p = run.p();
  const Searches& s = run.search();
  auto spot_of = [&](int64_t k) -> const Spot& {
    return spots[static_cast<size_t>(k / stride)][static_cast<size_t>(c0 + k % stride)];
  };
  std::vector<Spot> cells;
  std::vector<Prepared::Xyz> xyz;
  for (int64_t k : bent) {
    cells.push_back(spot_of(k));
    xyz.push_back(p.spot_xyz(cells.back()));
  }
  // The middle cell alone. Every other sees it (the block is clear sea), so its distance is at
  // most the middle's plus the way between them.
  const size_t mid = bent.size() / 2;
  Place at0{cells[mid].at};
  at0.open = true;
  const int64_t cm = c0 + bent[mid] % stride, rm = r0 + bent[mid] / stride;
  const Best best0 = s.best_path(at0, cells[mid], Best{}, w.tests, -1, &w.blockers, w.last, &w.last);
  write_path(run, w, cm, rm, best0, run.straight.distance.at(cm, rm));
  if (best0.site == kNoSite) {  // no path reaches the middle: none reaches any of them
    w.unreachable += static_cast<int64_t>(bent.size()) - 1;
    return;
  }
  const double upper = best0.d + reach_from(p, cells[mid], xyz[mid], cells, xyz);
  std::vector<Candidate> cands;
  s.all.within(
      RootTree::Box{lo, hi}, [&] { return upper + 1e-12 * upper; },
      [&](int32_t item, double bound) {
        cands.push_back(Candidate{item, bound, false});
      });
  // Each proved to see the whole block, or hidden from all of it (left out), or tested per cell.
  size_t kept = 0;
  for (Candidate& cand : cands) {
    ++w.tests;
    Visibility::Sight sight = Visibility::Sight::unknown;
    if (cand.item < s.site_items()) {
      const int32_t id = s.site_of[static_cast<size_t>(cand.item)];
      if (!p.segment(id)) sight = p.vis.sight_box(p.site_place(id, cells[mid]), lo, hi);
    } else {
      const Node& n = s.nodes[static_cast<size_t>(cand.item - s.site_items())];
      sight = p.vis.sight_box(p.vis.at_vertex(n.vertex, n.wedge), lo, hi);
    }
    if (sight == Visibility::Sight::hidden) continue;
    cand.sees_all = sight == Visibility::Sight::seen;
    cands[kept++] = cand;
  }
  cands.resize(kept);
  std::vector<double> lower(cands.size());
  for (size_t i = 0; i < bent.size(); ++i) {
    if (i == mid) continue;
    const Spot& spot = cells[i];
    Place at{spot.at};
    at.open = true;
    // Each candidate's lower bound from this cell; the least first (mostly the answer), then
    // every other not beyond the best so far.
    size_t first = 0;
    for (size_t j = 0; j < cands.size(); ++j) {
      const int32_t item = cands[j].item;
      double l = cands[j].bound;
      if (item >= s.site_items()) {
        const auto k = static_cast<size_t>(item - s.site_items());
        const int32_t v = s.nodes[k].vertex;
        l = s.dist[k].d + (p.geodesic ? Prepared::chord_below(p.vertex_xyz[static_cast<size_t>(v)], xyz[i])
                                      : length(p.vis.vertex(v), spot.at));
      } else if (p.geodesic && !p.segment(s.site_of[static_cast<size_t>(item)])) {
        l = Prepared::chord_below(p.site_xyz[static_cast<size_t>(s.site_of[static_cast<size_t>(item)])], xyz[i]);
      }
      lower[j] = l;
      if (l < lower[first]) first = j;
    }
    Best best;
    auto seen = [&](int32_t item, const Place& to) {
      int32_t& b = w.blockers[static_cast<size_t>(item)];
      if (b >= 0 && p.vis.crosses(b, at, to)) return false;
      ++w.tests;
      return p.vis.sees(at, to, &b);
    };
    auto weigh = [&](size_t j) {
      if (cands[j].sees_all)
        s.consider(cands[j].item, at, spot, xyz[i], -1, best, [](int32_t, const Place&) { return true; });
      else
        s.consider(cands[j].item, at, spot, xyz[i], -1, best, seen);
    };
    if (!cands.empty()) weigh(first);
    for (size_t j = 0; j < cands.size(); ++j)
      if (j != first && !beyond(lower[j], best.d)) weigh(j);
    const int64_t c = c0 + bent[i] % stride, r = r0 + bent[i] / stride;
    write_path(run, w, c, r, best, run.straight.distance.at(c, r));
  }
}

}  // namespace

bool answer_block(const CellRun& run, CellWorker& w, int64_t c0, int64_t c1, int64_t r0, int64_t r1,
                  const std::vector<std::vector<Spot>>& spots, std::vector<Visibility::Ground>& grounds,
                  int64_t stride) {
  const Prepared& p = run.p();
  Vec2 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()}, hi{-lo.x, -lo.y};
  for (int64_t r = r0; r < r1; ++r)
    for (int64_t c = c0; c < c1; ++c) {
      const Vec2 x = spots[static_cast<size_t>(r - r0)][static_cast<size_t>(c)].at;
      lo = Vec2{std::min(lo.x, x.x), std::min(lo.y, x.y)};
      hi = Vec2{std::max(hi.x, x.x), std::max(hi.y, x.y)};
    }
  if (!p.vis.clear_box(lo, hi)) return false;
  const Visibility::Ground ground = p.vis.classify(spots[0][static_cast<size_t>(c0)].at);
  if (ground == Visibility::Ground::on_barrier) return false;  // (not where no barrier is near)
  w.block_cells += (r1 - r0) * (c1 - c0);
  for (int64_t r = r0; r < r1; ++r)
    for (int64_t c = c0; c < c1; ++c) grounds[static_cast<size_t>((r - r0) * stride + c)] = ground;
  if (ground == Visibility::Ground::land) {
    w.land += (r1 - r0) * (c1 - c0);
    return true;
  }
  // The straight nearest sites: each proved to see the whole block once, or per cell.
  std::vector<std::pair<int32_t, Visibility::Sight>> proved;
  auto sight_of = [&](int32_t site, const Spot& spot) {
    for (const auto& [s, sight] : proved)
      if (s == site) return sight;
    ++w.tests;
    const Visibility::Sight sight =
        p.segment(site) ? Visibility::Sight::unknown : p.vis.sight_box(p.site_place(site, spot), lo, hi);
    proved.emplace_back(site, sight);
    return sight;
  };
  std::vector<int64_t>& bent = w.pending;
  bent.clear();
  for (int64_t r = r0; r < r1; ++r)
    for (int64_t c = c0; c < c1; ++c) {
      const int32_t nearest = run.straight.site.at(c, r);
      if (nearest == kNoSite) continue;
      const Spot& spot = spots[static_cast<size_t>(r - r0)][static_cast<size_t>(c)];
      const Visibility::Sight sight = sight_of(nearest, spot);
      if (sight == Visibility::Sight::seen) {
        write_straight(run, c, r);
        continue;
      }
      Place at{spot.at};
      at.open = true;
      if (sight == Visibility::Sight::unknown && (++w.tests, p.vis.sees(at, p.site_place(nearest, spot)))) {
        write_straight(run, c, r);
        continue;
      }
      bent.push_back((r - r0) * stride + (c - c0));
    }
  // Fewer bent cells than a few: each alone.
  constexpr size_t kFew = 3;
  if (bent.size() < kFew) {
    for (int64_t k : bent) {
      const int64_t c = c0 + k % stride, r = r0 + k / stride;
      const Spot& spot = spots[static_cast<size_t>(k / stride)][static_cast<size_t>(c)];
      Place at{spot.at};
      at.open = true;
      answer_bent(run, w, c, r, at, spot);
    }
    return true;
  }
  answer_bent_block(run, w, c0, r0, lo, hi, spots, bent, stride);
  return true;
}

}  // namespace rv::sea
