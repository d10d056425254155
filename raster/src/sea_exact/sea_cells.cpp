// The exact engine's answers for cells: one alone, or a block at once (sea_exact/sea_cells.hpp says
// what each proves and why the answers are the same).
#include "sea_exact/sea_cells.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "sea_exact/length_patch.hpp"

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
    const double chord = Prepared::chord(xyz0, xyz[i]);
    reach =
        std::max(reach, chord <= 5e4 ? chord * (1.0 + 1e-5) + 1e-6 : p.geodesic->point_distance(x0.ll, spots[i].ll));
  }
  return reach * (1.0 + 1e-12);
}

}  // namespace

void answer_cell(const CellRun& run, CellWorker& w, int64_t c, int64_t r, const Spot& spot, Visibility::Ground ground,
                 bool hidden) {
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
  if (!hidden && (++w.tests, p.vis.sees(at, p.site_place(nearest, spot)))) {
    write_straight(run, c, r);
    return;
  }
  answer_bent(run, w, c, r, at, spot);
}

void answer_drawn(const CellRun& run, CellWorker& w, int64_t r, const Visibility::Ground* grounds,
                  const SiteSight::Sight* sight, uint8_t* answered) {
  const auto& spans = run.interiors.rows[static_cast<size_t>(r)];
  auto span = spans.begin();
  for (int64_t c = 0; c < run.window.width; ++c) {
    if (answered[c]) continue;
    if (grounds[c] == Visibility::Ground::land) {
      ++w.land;
      ++w.drawn;
      answered[c] = 1;
      continue;
    }
    if (!sight || sight[c] != SiteSight::seen || grounds[c] != Visibility::Ground::open_sea) continue;
    while (span != spans.end() && span->col1 <= c) ++span;
    if (span != spans.end() && c >= span->col0) continue;
    if (run.straight.site.at(c, r) == kNoSite) continue;
    write_straight(run, c, r);
    ++w.drawn;
    answered[c] = 1;
  }
}

namespace {

// A root of a block's bent cells: an item of the search's tree, its bound over the block, and
// whether it sees the whole block.
struct Candidate {
  int32_t item;
  double bound;
  bool sees_all;
};

// A root's value for one cell: its path's length `d` (within `err` of the exact one: 0, or
// kPatchError from a patch), site and via, and which candidate it is.
struct Valued {
  double d = 0.0, err = 0.0;
  int32_t site = kNoSite, via = kNoVia;
  size_t cand = 0;
};

// The lengths of one bent block's candidates (answer_bent_block): exact, or from a patch once a
// candidate has been measured for a few cells. A cell's answer is decided on patched lengths
// only where it cannot differ from the exact weighing's:
// - every other root valued is farther by more than both errors (or both are exact and lose by
//   Best's order), and every root not valued had a lower bound beyond some valued root's upper
//   end, which is beyond the winner's: the winner is the exact weighing's;
// - its length's float is the same at both ends of its error, and so is its side of the maximum
//   distance; where it could raise the largest detour, its exact length is taken.
// Else the cell is weighed again exactly.
class BlockLengths {
 public:
  // Over the candidates of the block whose first cell is (c0, r0).
  BlockLengths(const CellRun& run, CellWorker& w, size_t candidates, int64_t c0, int64_t r0)
      : run_(run), w_(w), patches_(candidates, nullptr) {
    const int64_t side = run.patch_tile;
    if (side == 0) return;
    tx_ = c0 / side;
    ty_ = r0 / side;
    const int64_t tc0 = tx_ * side, tr0 = ty_ * side;
    const int64_t tc1 = std::min(tc0 + side, run.window.width) - 1, tr1 = std::min(tr0 + side, run.window.height) - 1;
    if (tc1 - tc0 < 3 || tr1 - tr0 < 3) return;  // (a tile clipped by the window's edge)
    auto ll = [&](int64_t c, int64_t r) {
      return Vec2{run.grid.centre_x(run.window.col0 + c), run.grid.centre_y(run.window.row0 + r)};
    };
    tile_ = PatchBlock{tc0, tr0, tc1, tr1, ll(tc0, tr0), ll(tc1, tr1)};
    enabled_ = true;
  }

  // Candidate `cand` (index j) as the last leg of a path to cell (c, r) (`at`, `spot`, `xyz`)
  // whose length could be below `upper`: its value, and true; false where it cannot be a root
  // of the cell (not taut, not seen, no distance) or is certainly beyond `upper`.
  template <class Seen>
  bool value(const Candidate& cand, size_t j, int64_t c, int64_t r, const Place& at, const Spot& spot,
             const Prepared::Xyz& xyz, double upper, Seen& seen, Valued& v) {
    const Prepared& p = run_.p();
    const Searches& s = run_.search();
    auto sees = [&](const Place& to) { return cand.sees_all || seen(cand.item, to); };
    if (cand.item >= s.site_items()) {  // a bend node: as Searches::through weighs it
      const auto k = static_cast<size_t>(cand.item - s.site_items());
      const Node& n = s.nodes[k];
      const double weight = s.dist[k].d;
      const auto vx = static_cast<size_t>(n.vertex);
      if (!std::isfinite(weight) || weight + Prepared::chord_below(p.vertex_xyz[vx], xyz) > upper) return false;
      if (!taut(p.vis, s.tauts[k], spot.at) || !sees(p.vis.at_vertex(n.vertex, n.wedge))) return false;
      v = Valued{0.0, 0.0, s.dist[k].site, n.vertex, j};
      v.d = weight + length(j, cand.item, c, r, xyz, p.vertex_ll[vx], p.vertex_xyz[vx], spot, v.err);
      return true;
    }
    if (cand.item < s.touch_first && !p.segment(s.site_of[static_cast<size_t>(cand.item)])) {  // a point site
      const int32_t id = s.site_of[static_cast<size_t>(cand.item)];
      const auto si = static_cast<size_t>(id);
      if (Prepared::chord_below(p.site_xyz[si], xyz) > upper) return false;
      if (spot.ll != p.site_ll[si] && !sees(p.site_place(id, spot))) return false;
      v = Valued{0.0, 0.0, id, kNoVia, j};
      v.d = length(j, cand.item, c, r, xyz, p.site_ll[si], p.site_xyz[si], spot, v.err);
      return true;
    }
    // A segment site or a touch: its exact value alone.
    Best b;
    if (cand.sees_all)
      s.consider(cand.item, at, spot, xyz, -1, b, [](int32_t, const Place&) { return true; });
    else
      s.consider(cand.item, at, spot, xyz, -1, b, seen);
    if (b.site == kNoSite) return false;
    v = Valued{b.d, 0.0, b.site, b.via, j};
    return true;
  }

  // Writes cell (c, r)'s answer from the roots valued for it (see the class's comment), sets
  // `winner` to its candidate and returns true; false (nothing written) where it must be weighed
  // again exactly.
  bool write(int64_t c, int64_t r, const std::vector<Valued>& valued, const std::vector<Candidate>& cands,
             const Spot& spot, size_t& winner) {
    if (valued.empty()) return false;
    size_t win = 0;
    for (size_t k = 1; k < valued.size(); ++k)
      if (valued[k].d < valued[win].d) win = k;
    const Valued& W = valued[win];
    const Best wb{W.d, W.site, W.via};
    for (size_t k = 0; k < valued.size(); ++k) {
      if (k == win) continue;
      const Valued& o = valued[k];
      if (o.err == 0.0 && W.err == 0.0 ? !(wb < Best{o.d, o.site, o.via}) : !(o.d - o.err > W.d + W.err)) {
        ++w_.patch_retries;
        return false;
      }
    }
    winner = W.cand;
    const float d0 = run_.straight.distance.at(c, r);
    if (W.err == 0.0) {
      write_path(run_, w_, c, r, wb, d0);
      return true;
    }
    const double lo = W.d - W.err, hi = W.d + W.err;
    if ((lo <= run_.max_distance && hi > run_.max_distance) || static_cast<float>(lo) != static_cast<float>(hi) ||
        (d0 > 0.0f && hi / static_cast<double>(d0) >= w_.detour)) {
      write_path(run_, w_, c, r, Best{exact_length(cands[W.cand], spot), W.site, W.via}, d0);
      return true;
    }
    ++w_.interpolated;
    if (lo > run_.max_distance) return true;  // (beyond the maximum distance: no owner)
    run_.out.field.site.at(c, r) = W.site;
    run_.out.field.distance.at(c, r) = static_cast<float>(W.d);
    run_.out.via.at(c, r) = W.via;
    return true;
  }

 private:
  // Uses of a candidate's exact length before its patch is built (a patch costs 17 inverse
  // problems; most candidates measured for a few cells are never measured again).
  static constexpr int kExactUses = 3;

  // The length from candidate j's point (`item`'s: `ll`, `pxyz`) to the cell: from its patch
  // (err kPatchError) or exact (err 0, as exact_of measures it).
  double length(size_t j, int32_t item, int64_t c, int64_t r, const Prepared::Xyz& xyz, Vec2 ll,
                const Prepared::Xyz& pxyz, const Spot& spot, double& err) {
    const LengthPatch*& patch = patches_[j];
    if (enabled_ && !patch) {
      PatchTiles::Entry& e = w_.tiles.at(item, tx_, ty_);
      if (!e.patch && ++e.uses > kExactUses) {
        e.patch = std::make_unique<LengthPatch>(run_.p(), ll, pxyz, tile_);
        ++w_.patches;
      }
      patch = e.patch.get();
    }
    if (patch && patch->usable()) {
      err = kPatchError;
      return patch->length(c, r, xyz);
    }
    err = 0.0;
    return exact_of(item, spot, false);
  }
  // The exact length from a root's point (a bend node's vertex, or a point site) as
  // Searches::consider measures it; with the node's distance by sea for a node `with_weight`.
  double exact_length(const Candidate& cand, const Spot& spot) const { return exact_of(cand.item, spot, true); }
  double exact_of(int32_t item, const Spot& spot, bool with_weight) const {
    const Prepared& p = run_.p();
    const Searches& s = run_.search();
    if (item >= s.site_items()) {
      const auto k = static_cast<size_t>(item - s.site_items());
      return (with_weight ? s.dist[k].d : 0.0) + p.vertex_length(s.nodes[k].vertex, spot);
    }
    return std::sqrt(p.site_key(spot, s.site_of[static_cast<size_t>(item)]));
  }

  const CellRun& run_;
  CellWorker& w_;
  std::vector<const LengthPatch*> patches_;  // per candidate: its tile's patch, once built
  bool enabled_ = false;                     // patches over the block's tile
  int64_t tx_ = 0, ty_ = 0;
  PatchBlock tile_{};
};

// The roots that could give a cell of the block [lo, hi] its answer: those whose bound over the
// block is within `upper` (an upper bound of every cell's distance), less those proved hidden
// from all of it and the bends no cell could leave taut; each marked when proved to see all of
// it. By bound (a cell's search by patches stops at the first beyond its best). `mid`: a cell of
// the block (a segment site's nearest point is taken from it).
std::vector<Candidate> block_roots(const CellRun& run, CellWorker& w, Vec2 lo, Vec2 hi, double upper, const Spot& mid) {
  const Prepared& p = run.p();
  const Searches& s = run.search();
  std::vector<Candidate> cands;
  s.all.within(
      RootTree::Box{lo, hi}, [&] { return upper + 1e-12 * upper; },
      [&](int32_t item, double bound) {
        cands.push_back(Candidate{item, bound, false});
      });
  // Each proved to see the whole block, or hidden from all of it (left out), or tested per cell.
  size_t kept = 0;
  for (Candidate& cand : cands) {
    Visibility::Sight sight = Visibility::Sight::unknown;
    if (cand.item < s.site_items()) {
      const int32_t id = s.site_of[static_cast<size_t>(cand.item)];
      if (!p.segment(id)) sight = p.vis.sight_box(p.site_place(id, mid), lo, hi);
    } else {
      // (A bend that no cell of the block could leave taut is no root of any: left out before
      // its proof, the dearer test.)
      const auto k = static_cast<size_t>(cand.item - s.site_items());
      const Node& n = s.nodes[k];
      if (never_taut(p.vis, s.tauts[k], lo, hi)) continue;
      sight = p.vis.sight_box(p.vis.at_vertex(n.vertex, n.wedge), lo, hi);
    }
    ++w.tests;
    if (sight == Visibility::Sight::hidden) continue;
    cand.sees_all = sight == Visibility::Sight::seen;
    cands[kept++] = cand;
  }
  cands.resize(kept);
  std::sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) {
    return a.bound < b.bound || (a.bound == b.bound && a.item < b.item);
  });
  return cands;
}

// The block's cells whose path bends (`bent`: (row - r0) * stride + (column - c0) each), more
// than a few: one answered alone gives an upper bound of them all, and the roots within it are
// weighed for each (see the header).
void answer_bent_block(const CellRun& run, CellWorker& w, int64_t c0, int64_t r0, Vec2 lo, Vec2 hi,
                       const std::vector<Spot>* spots, const std::vector<int64_t>& bent, int64_t stride) {
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
  // Every cell sees the middle one (the block is clear sea), so its distance is at most the
  // middle's plus the way between them. The middle's is at most the length of any path to it:
  // the one from the root that won the last block, where that root sees the middle (the middle
  // is then weighed with the others); else the middle alone, its best path over every root.
  const size_t mid = bent.size() / 2;
  Place at0{cells[mid].at};
  at0.open = true;
  double upper0 = std::numeric_limits<double>::infinity();
  if (w.block_root >= 0) {
    Best b;
    s.consider(w.block_root, at0, cells[mid], xyz[mid], -1, b, [&](int32_t, const Place& to) {
      ++w.tests;
      return p.vis.sees(at0, to);
    });
    upper0 = b.d;
  }
  const bool mid_alone = !std::isfinite(upper0);
  if (mid_alone) {
    const int64_t cm = c0 + bent[mid] % stride, rm = r0 + bent[mid] / stride;
    const Best best0 = s.best_path(at0, cells[mid], Best{}, w.tests, -1, &w.blockers, w.last, &w.last);
    write_path(run, w, cm, rm, best0, run.straight.distance.at(cm, rm));
    if (best0.site == kNoSite) {  // no path reaches the middle: none reaches any of them
      w.unreachable += static_cast<int64_t>(bent.size()) - 1;
      return;
    }
    upper0 = best0.d;
    w.block_root = w.last;
  }
  const double upper = upper0 + reach_from(p, cells[mid], xyz[mid], cells, xyz);
  const std::vector<Candidate> cands = block_roots(run, w, lo, hi, upper, cells[mid]);
  std::vector<double> lower(cands.size());
  BlockLengths lengths(run, w, cands.size(), c0, r0);
  std::vector<Valued> valued;
  size_t last_winner = 0;  // the candidate that won the last cell answered by patches
  for (size_t i = 0; i < bent.size(); ++i) {
    if (i == mid && mid_alone) continue;
    const Spot& spot = cells[i];
    Place at{spot.at};
    at.open = true;
    // Each candidate's lower bound from this cell.
    auto lower_of = [&](size_t j) {
      const int32_t item = cands[j].item;
      if (item >= s.site_items()) {
        const auto k = static_cast<size_t>(item - s.site_items());
        const int32_t v = s.nodes[k].vertex;
        return s.dist[k].d + (p.geodesic ? Prepared::chord_below(p.vertex_xyz[static_cast<size_t>(v)], xyz[i])
                                         : length(p.vis.vertex(v), spot.at));
      }
      if (p.geodesic && !p.segment(s.site_of[static_cast<size_t>(item)]))
        return Prepared::chord_below(p.site_xyz[static_cast<size_t>(s.site_of[static_cast<size_t>(item)])], xyz[i]);
      return cands[j].bound;
    };
    auto seen = [&](int32_t item, const Place& to) {
      int32_t& b = w.blockers[static_cast<size_t>(item)];
      if (b >= 0 && p.vis.crosses(b, at, to)) return false;
      ++w.tests;
      return p.vis.sees(at, to, &b);
    };
    const int64_t c = c0 + bent[i] % stride, r = r0 + bent[i] / stride;
    // Lengths from patches where the block has them: the last cell's winner first (neighbours
    // mostly share their last bend), then the others in order of their bound over the block until
    // one is beyond the best so far. The answer when one root wins by more than the patches' error
    // (BlockLengths says why that is the exact answer), else weighed again exactly.
    if (run.patch_tile > 0 && !cands.empty()) {
      valued.clear();
      double upper = std::numeric_limits<double>::infinity();
      auto value = [&](size_t j) {
        Valued v;
        if (lengths.value(cands[j], j, c, r, at, spot, xyz[i], upper, seen, v)) {
          valued.push_back(v);
          upper = std::min(upper, v.d + v.err);
        }
      };
      value(last_winner);
      for (size_t j = 0; j < cands.size() && !beyond(cands[j].bound, upper); ++j)
        if (j != last_winner && !beyond(lower_of(j), upper)) value(j);
      if (lengths.write(c, r, valued, cands, spot, last_winner)) {
        w.block_root = cands[last_winner].item;
        continue;
      }
    }
    // The least lower bound first (mostly the answer), then every other not beyond the best so
    // far.
    size_t first = 0;
    for (size_t j = 0; j < cands.size(); ++j) {
      lower[j] = lower_of(j);
      if (lower[j] < lower[first]) first = j;
    }
    Best best;
    int32_t won = -1;
    auto weigh = [&](size_t j) {
      const bool taken = cands[j].sees_all ? s.consider(cands[j].item, at, spot, xyz[i], -1, best,
                                                        [](int32_t, const Place&) { return true; })
                                           : s.consider(cands[j].item, at, spot, xyz[i], -1, best, seen);
      if (taken) won = cands[j].item;
    };
    if (!cands.empty()) weigh(first);
    for (size_t j = 0; j < cands.size(); ++j)
      if (j != first && !beyond(lower[j], best.d)) weigh(j);
    write_path(run, w, c, r, best, run.straight.distance.at(c, r));
    if (won >= 0) w.block_root = won;
  }
}

}  // namespace

bool answer_block(const CellRun& run, CellWorker& w, int64_t c0, int64_t c1, int64_t r0, int64_t r1,
                  const std::vector<Spot>* spots, Visibility::Ground* grounds, int64_t stride, const uint8_t* answered,
                  const SiteSight::Sight* sight_drawn) {
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
    for (int64_t c = c0; c < c1; ++c) grounds[(r - r0) * stride + c] = ground;
  if (ground == Visibility::Ground::land) {
    for (int64_t r = r0; r < r1; ++r)
      for (int64_t c = c0; c < c1; ++c) w.land += answered[(r - r0) * stride + c] ? 0 : 1;
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
      const int64_t k = (r - r0) * stride + (c - c0);
      if (answered[k + c0]) continue;
      const int32_t nearest = run.straight.site.at(c, r);
      if (nearest == kNoSite) continue;
      if (sight_drawn && sight_drawn[k + c0] == SiteSight::hidden) {
        bent.push_back(k);
        continue;
      }
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
      bent.push_back(k);
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
