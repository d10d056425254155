// Partial effect (rv/lines/partial_effect.hpp): the rule between the nil- and full-effect lines, the
// field it gives, and the lines with each band's stretch replaced by the partial-effect locus.
//
// Why the locus is traced between the two lines rather than extracted from cells: the rule is not
// a nearest-site comparison (it compares distances to two lines, and only inside the band), so
// the extraction's per-owner costs do not describe it. Inside one band the locus runs from the
// turning point P where L1 leaves L0 to the one Q where it rejoins it; a segment from a point of
// L0 to a point of L1 has the balance >= 0 at its L0 end and <= 0 at its L1 end, so it holds a
// locus point. Pairing the two chains by their fraction of length gives an ordered run of such
// segments from P to Q, and midpoints are added where a chord strays from the locus.
#include "rv/lines/partial_effect.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/line_tools.hpp"
#include "lines/locus_follow.hpp"
#include "lines/partial/partial_joins.hpp"
#include "lines/partial/partial_loci.hpp"
#include "lines/partial/partial_tripoints.hpp"
#include "lines/partial/polyline_along.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/regions.hpp"
#include "rv/lines/simplify.hpp"

namespace rv {

using namespace line_tools;
using namespace polyline_along;
using partial_tripoints::owner_label;
using partial_tripoints::TripointPlan;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxDepth = 12;

std::string effect_text(double e) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", e);
  return buf;
}

}  // namespace

PartialEffect partial_effect_of(const SeedSet& seeds) {
  PartialEffect pe;
  const auto& features = seeds.features();
  pe.partial.assign(features.size(), false);
  int32_t first = -1;
  for (size_t i = 0; i < features.size(); ++i) {
    const Feature& f = features[i];
    if (!(f.effect < 1.0)) continue;
    const auto fi = static_cast<int32_t>(i);
    if (first < 0) {
      first = fi;
      pe.owner = f.owner;
      pe.effect = f.effect;
    } else if (f.owner != pe.owner) {
      throw Error(ErrorKind::invalid_input,
                  seeds.feature_name(first) + " and " + seeds.feature_name(fi) +
                      " both have an effect below 1 but belong to different owners: partial effect is given to one "
                      "owner's features per run");
    } else if (f.effect != pe.effect) {
      throw Error(ErrorKind::invalid_input, seeds.feature_name(first) + " has effect " + effect_text(pe.effect) +
                                                " and " + seeds.feature_name(fi) + " effect " + effect_text(f.effect) +
                                                ": one owner's partial features share one effect");
    }
    pe.partial[i] = true;
  }
  if (pe.owner == 0) return pe;
  for (size_t i = 0; i < features.size(); ++i)
    if (features[i].owner == pe.owner && !pe.partial[i]) return pe;
  throw Error(ErrorKind::invalid_input,
              "every feature of owner " + owner_label(seeds, pe.owner) +
                  " has an effect below 1: the nil-effect line is drawn without them, so the owner needs features "
                  "at full effect (e.g. its mainland)");
}

PartialEffectRule::PartialEffectRule(const SeedSet& seeds, const PartialEffect& effect, BoundaryResult nil,
                                     const std::vector<int32_t>& site_of, BoundaryResult full, const GridSpec& grid,
                                     const ComputeOptions& options)
    : effect_(effect), nil_(std::move(nil)), full_(std::move(full)) {
  auto renumber = [&](int32_t& site) {
    if (site != kNoSite) site = site_of.at(static_cast<size_t>(site));
  };
  for (BoundaryLine& l : nil_.lines)
    for (BoundaryVertex& v : l.vertices) {
      renumber(v.site_a);
      renumber(v.site_b);
    }
  for (Tripoint& t : nil_.tripoints)
    for (int32_t& site : t.sites) renumber(site);
  if (options.geolocator)
    throw Error(ErrorKind::unsupported,
                "partial effect is not available on a projected grid measured on the ellipsoid: use a "
                "longitude/latitude grid, or the planar metric");
  const int32_t B = effect_.owner;
  for (int32_t x = 1; x <= seeds.owner_count(); ++x) {
    lines_.owner_code("nil:" + std::to_string(x));
    lines_.owner_code("full:" + std::to_string(x));
  }
  // A line that ends on the frame of the outermost cell centres goes on beyond the grid, where
  // its points are still the nearest to cells near the edge: it is continued straight along its
  // last chord for the grid's diagonal (exact for a straight bisector; the grid holds no more of
  // a curved one).
  const double eps = 1e-9 * grid.res, far = std::hypot(grid.xmax() - grid.xmin, grid.ymax - grid.ymin());
  auto on_frame = [&](Vec2 p) {
    return p.x <= grid.centre_x(0) + eps || p.x >= grid.centre_x(grid.width - 1) - eps ||
           p.y >= grid.centre_y(0) - eps || p.y <= grid.centre_y(grid.height - 1) + eps;
  };
  auto beyond = [&](Vec2 end, Vec2 before) {
    const double len = std::hypot(end.x - before.x, end.y - before.y);
    return len > 0.0 ? Vec2{end.x + (end.x - before.x) * far / len, end.y + (end.y - before.y) * far / len} : end;
  };
  auto add = [&](const BoundaryResult& r, int32_t offset) {
    for (const BoundaryLine& l : r.lines) {
      if ((l.owner_a != B && l.owner_b != B) || l.vertices.size() < 2) continue;
      const int32_t x = l.owner_a == B ? l.owner_b : l.owner_a;
      std::vector<Vec2> pts;
      pts.reserve(l.vertices.size() + 2);
      const auto& v = l.vertices;
      if (!l.closed && on_frame(v.front().p)) pts.push_back(beyond(v.front().p, v[1].p));
      for (const BoundaryVertex& u : v) pts.push_back(u.p);
      if (!l.closed && on_frame(v.back().p)) pts.push_back(beyond(v.back().p, v[v.size() - 2].p));
      lines_.add_polyline(lines_.add_feature(2 * x - offset), pts);
    }
  };
  add(nil_, 1);
  add(full_, 0);
  ComputeOptions o = options;
  o.grid_polygons = nullptr;
  metric_ = make_site_metric(lines_, grid, o);
  index_ = std::make_unique<OwnerIndex>(*metric_, OwnerIndex::Measure::plain);
}

PartialEffectRule::~PartialEffectRule() = default;

double PartialEffectRule::distance_to_nil(Vec2 p, int32_t neighbour) const {
  return index_->nearest_of(p, 2 * neighbour - 1).distance;
}

double PartialEffectRule::distance_to_full(Vec2 p, int32_t neighbour) const {
  return index_->nearest_of(p, 2 * neighbour).distance;
}

double PartialEffectRule::separation(Vec2 a, Vec2 b) const { return metric_->point_distance(a, b); }

double PartialEffectRule::balance(Vec2 p, int32_t neighbour) const {
  const double e = effect_.effect;
  return e * distance_to_full(p, neighbour) - (1.0 - e) * distance_to_nil(p, neighbour);
}

int32_t PartialEffectRule::owner(Vec2 p, int32_t full_owner, int32_t nil_owner) const {
  const int32_t B = effect_.owner;
  if (full_owner != B || nil_owner == B || nil_owner == 0) return full_owner;
  const double e = effect_.effect;
  // Written as a comparison, not as balance() > 0: a missing line is an infinite distance, and
  // e = 0 times it must not decide (NaN compares false: the neighbour keeps it).
  return (1.0 - e) * distance_to_nil(p, nil_owner) < e * distance_to_full(p, nil_owner) ? B : nil_owner;
}

namespace {

// One line of owners B and X being rewritten.
struct LineRewrite {
  const PartialEffectRule& rule;
  const SeedSet& seeds;
  const OwnerIndex& index;
  double ftol, tol;
  int32_t B, X;
  bool b_is_a;
  PartialLineStats& stats;
  const std::vector<TripointPlan>& plans;
  double per_crs;  // metric units per CRS unit (the larger axis): offsets measured as lengths
  // The nil-effect index (the band: locus_follow by sea, which way round the frame a band runs);
  // may be null.
  const OwnerIndex* nil_index = nullptr;
  const GridSpec* grid = nullptr;
  // A metric that is not straight and the nil-effect index given: each band's locus is followed
  // (locus_follow), not traced between L0 and L1.
  bool by_sea = false;
  // The rule's cells can be had (partial_boundaries' `cells`): a line wholly in its band is left to
  // them (Rewritten::wholly_in_band) instead of refused.
  bool by_cells = false;
  // By sea: the turning points of the bands that run to or from an end of a B-X line (a piece of
  // a full-effect line that a coast cut where L1 touched it: its band goes on in another piece),
  // and those a followed locus reached from another piece (that piece's band is drawn; the two
  // lines are joined there afterwards: join_at).
  const std::vector<Vec2>* open_turnings = nullptr;
  std::vector<Vec2>* claimed = nullptr;

  // The turning points of the bands at the ends of `line` (not at a planned tripoint).
  std::vector<Vec2> end_turnings(const BoundaryLine& line) const {
    const std::vector<BoundaryVertex>& v = line.vertices;
    std::vector<Vec2> out;
    if (line.closed || v.size() < 2) return out;
    if (partial(v.front()) && plan_at(v.front().p) == nullptr) {
      const size_t j = run_end(v, 0, 1);
      if (j + 1 < v.size()) out.push_back(turning(v[j + 1], v[j]));
    }
    if (partial(v.back()) && plan_at(v.back().p) == nullptr) {
      const size_t i = run_end(v, v.size() - 1, -1);
      if (i > 0) out.push_back(turning(v[i - 1], v[i]));
    }
    return out;
  }

  // The last vertex of the run of partial vertices from v[i] (partial) on, by `step` (+-1): a
  // band's other end along the line.
  size_t run_end(const std::vector<BoundaryVertex>& v, size_t i, int step) const {
    for (size_t next = i + static_cast<size_t>(step); next < v.size() && partial(v[next]);
         next += static_cast<size_t>(step))
      i = next;  // (i = 0, step -1: next wraps past size())
    return i;
  }

  const TripointPlan* plan_at(Vec2 p) const {
    for (const TripointPlan& t : plans)
      if (t.T == p && (t.owners[0] == X || t.owners[1] == X)) return &t;
    return nullptr;
  }

  int32_t b_site(const BoundaryVertex& v) const { return b_is_a ? v.site_a : v.site_b; }
  int32_t x_site(const BoundaryVertex& v) const { return b_is_a ? v.site_b : v.site_a; }
  bool partial(const BoundaryVertex& v) const {
    const int32_t s = b_site(v);
    return s != kNoSite && rule.effect().partial[static_cast<size_t>(seeds.site_feature(s))];
  }

  BoundaryVertex vertex(Vec2 p) const {
    const OwnerIndex::Hit hb = index.nearest_of(p, B), hx = index.nearest_of(p, X);
    BoundaryVertex v{p,           hb.site,    hx.site, 0.5 * (hb.distance + hx.distance), std::abs(rule.balance(p, X)),
                     hb.distance, hx.distance};
    if (!b_is_a) {
      std::swap(v.site_a, v.site_b);
      std::swap(v.distance_a, v.distance_b);
    }
    stats.max_residual = std::max(stats.max_residual, v.residual);
    return v;
  }

  // Where L1 leaves L0 between common vertex c and partial vertex q: the costs of B's two sites
  // and X's equal (the refinement has usually placed a vertex there already).
  Vec2 turning(const BoundaryVertex& c, const BoundaryVertex& q) const {
    const Vec2 mid = lerp(c.p, q.p, 0.5);
    const double chord = std::hypot(q.p.x - c.p.x, q.p.y - c.p.y);
    Vec2 p;
    for (const int32_t t : {x_site(q), x_site(c)})
      if (t != kNoSite && boundary_stages::equal_costs_point(index, b_site(c), b_site(q), t, mid, chord, ftol, p))
        return p;
    return c.p;  // no turning point inside the chord: the common vertex is the nearest to it
  }

  // The common vertex that shows which way L0 runs from turning point t beside v[k] (a common
  // vertex): the first of the common run from v[k] on (by `step`, +-1) that is apart from t. t is
  // v[k] itself where no turning point lies inside the chord, and a point shows no direction
  // from itself (the chain then ran the wrong way: Zealand straight, bench/RESULTS-sea.md).
  Vec2 away_from(const std::vector<BoundaryVertex>& v, size_t k, int step, Vec2 t) const {
    const double apart = 1e-6 * grid->res;
    for (size_t q = k;; q += static_cast<size_t>(step)) {
      const size_t next = q + static_cast<size_t>(step);  // (q = 0, step -1: wraps past size())
      if (std::hypot(v[q].p.x - t.x, v[q].p.y - t.y) > apart || next >= v.size() || partial(v[next])) return v[q].p;
    }
  }

  // Where L0 and L1 both end on the frame of cell centres (a band running out of the grid): the
  // locus point on the frame between their ends a and b, along the way round the frame that the
  // band holds (the shorter where the nil-effect index is not given). The chord from a to b cuts
  // the corner the band makes with the frame, so a locus point on it stops short of the frame by
  // as much as the lines part there (cells beyond it would have no line between B and X).
  bool on_frame(Vec2 a, Vec2 b, Vec2& out) const {
    const GridSpec& g = *grid;
    const std::vector<std::vector<Vec2>> ways = round_rectangle(a, b, g.centre_x(0), g.centre_y(g.height - 1),
                                                                g.centre_x(g.width - 1), g.centre_y(0), 1e-9 * g.res);
    if (ways.empty()) return false;
    const std::vector<Vec2>* way = length(ways[0]) <= length(ways[1]) ? &ways[0] : &ways[1];
    if (nil_index != nullptr)
      for (const std::vector<Vec2>& w : ways) {
        const Vec2 m = at_fraction(w, cumulative(w), 0.5);
        if (owner_at(index, m) == B && owner_at(*nil_index, m) == X) way = &w;
      }
    const std::vector<double> k = cumulative(*way);
    auto f = [&](double t) { return rule.balance(at_fraction(*way, k, t), X); };
    const double fa = f(0.0), fb = f(1.0);
    if (!(fa >= -ftol && fb <= ftol)) return false;
    out = at_fraction(*way, k, find_root(f, fa, fb, ftol, 1e-15));
    return true;
  }

  // The locus point on the segment a-b (balance >= 0 at a, on L0; <= 0 at b, on L1).
  bool locus(Vec2 a, Vec2 b, Vec2& out) const {
    auto f = [&](double t) { return rule.balance(lerp(a, b, t), X); };
    const double fa = f(0.0), fb = f(1.0);
    if (!(fa >= -ftol && fb <= ftol)) return false;
    out = lerp(a, b, find_root(f, fa, fb, ftol, 1e-15));
    return true;
  }

  // The locus between chains c0 (on L0) and c1 (on L1), run in the same direction: from P to Q,
  // or from or to the line's end where the band reaches the edge of the owned area (`fixed`:
  // whether the chains' first and last points are P and Q, shared by both).
  std::vector<Vec2> trace(const std::vector<Vec2>& c0, const std::vector<Vec2>& c1, std::array<bool, 2> fixed) const {
    const std::vector<double> k0 = cumulative(c0), k1 = cumulative(c1);
    std::vector<double> fractions;
    for (double v : k0) fractions.push_back(k0.back() > 0.0 ? v / k0.back() : 0.0);
    for (double v : k1) fractions.push_back(k1.back() > 0.0 ? v / k1.back() : 0.0);
    std::sort(fractions.begin(), fractions.end());
    fractions.erase(std::unique(fractions.begin(), fractions.end()), fractions.end());
    struct Sample {
      double s;
      Vec2 p;
    };
    auto sample = [&](double s, Sample& out) {
      if ((s <= 0.0 && fixed[0]) || (s >= 1.0 && fixed[1])) {
        out = Sample{s, s <= 0.0 ? c1.front() : c1.back()};
        return true;
      }
      if ((s <= 0.0 || s >= 1.0) &&
          on_frame(s <= 0.0 ? c0.front() : c0.back(), s <= 0.0 ? c1.front() : c1.back(), out.p)) {
        out.s = s;
        return true;
      }
      out.s = s;
      return locus(at_fraction(c0, k0, s), at_fraction(c1, k1, s), out.p);
    };
    std::vector<Sample> samples;
    for (double s : fractions) {
      Sample x;
      if (sample(s, x)) samples.push_back(x);
    }
    if (samples.empty()) return {};
    std::vector<Vec2> out{samples.front().p};
    auto refine = [&](auto&& self, const Sample& u, const Sample& v, int depth) -> void {
      if (depth >= kMaxDepth) return;
      Sample m;
      if (!sample(0.5 * (u.s + v.s), m)) return;
      const double dx = v.p.x - u.p.x, dy = v.p.y - u.p.y, chord = std::hypot(dx, dy);
      const double off = chord > 0.0 ? std::abs((m.p.x - u.p.x) * dy - (m.p.y - u.p.y) * dx) / chord
                                     : std::hypot(m.p.x - u.p.x, m.p.y - u.p.y);
      if (!(off > tol) || depth + 1 >= kMaxDepth) {
        // The chord stays: its midpoint's distance from the locus point across it is measured.
        const Vec2 mid = lerp(u.p, v.p, 0.5);
        stats.residual.add(off * per_crs, mid.x, mid.y, tol * per_crs);
        return;
      }
      ++stats.residual.added;
      self(self, u, m, depth + 1);
      out.push_back(m.p);
      self(self, m, v, depth + 1);
    };
    for (size_t i = 1; i < samples.size(); ++i) {
      refine(refine, samples[i - 1], samples[i], 0);
      out.push_back(samples[i].p);
    }
    return out;
  }

  // L0's stretch for a band: from P to Q (both on the nil-effect B-X line, within a cell), or,
  // where the band reaches the line's end, from P to the end of L0 away from `anchor` (a common
  // vertex on the other side of P), or from that end to Q.
  std::vector<Vec2> nil_chain(const Vec2* P, const Vec2* Q, Vec2 anchor, double cell) const {
    const Vec2 known = P != nullptr ? *P : *Q;
    const BoundaryLine* best = nullptr;
    Along bu, bv;
    double best_off = kInf;
    std::vector<Vec2> best_pts;
    for (const BoundaryLine& l : rule.nil_lines().lines) {
      if (!((l.owner_a == B && l.owner_b == X) || (l.owner_a == X && l.owner_b == B)) || l.vertices.size() < 2)
        continue;
      std::vector<Vec2> pts;
      for (const BoundaryVertex& v : l.vertices) pts.push_back(v.p);
      const Along u = project(pts, known), v = P != nullptr && Q != nullptr ? project(pts, *Q) : project(pts, anchor);
      const double off = std::max(u.distance, v.distance);
      if (off > cell || off >= best_off) continue;
      best = &l;
      best_off = off;
      bu = u;
      bv = v;
      best_pts = std::move(pts);
    }
    if (best == nullptr || ((P == nullptr || Q == nullptr) && best->closed))
      throw Error(ErrorKind::unsupported,
                  "partial effect: a stretch of the full-effect line of owners " + label(B) + " and " + label(X) +
                      " has no nil-effect line beside it; its lines are not drawn (the rasters are exact)");
    if (P != nullptr && Q != nullptr) {
      std::vector<Vec2> chain = stretch(best_pts, best->closed, bu, bv);
      chain.front() = *P;
      chain.back() = *Q;
      return chain;
    }
    // bv is the anchor's position: the chain runs from the known end away from it.
    const size_t last = best_pts.size() - 2;
    const Along end = bv.at() <= bu.at() ? Along{last, 1.0, 0.0} : Along{0, 0.0, 0.0};
    std::vector<Vec2> chain = P != nullptr ? stretch(best_pts, false, bu, end) : stretch(best_pts, false, end, bu);
    (P != nullptr ? chain.front() : chain.back()) = known;
    return chain;
  }

  std::string label(int32_t owner) const { return owner_label(seeds, owner); }

  // The level the locus is, for locus_follow; `nil`: the nil-effect field's index.
  locus_follow::Level level(const OwnerIndex& nil) const {
    locus_follow::Level l;
    l.balance = [this](Vec2 p) { return rule.balance(p, X); };
    l.in_band = [this, &nil](Vec2 p) { return owner_at(index, p) == B && owner_at(nil, p) == X; };
    l.metric = &index.metric();
    l.grid = *grid;
    l.ftol = ftol;
    l.tol = tol;
    l.per_crs = per_crs;
    return l;
  }

  // By sea: the band v[i..j]'s locus followed from its turning points (locus_follow.hpp): from P
  // to Q where it gets there; else from P to where land or the frame stops it, the line cut there
  // (what `out` holds so far goes to `pieces`), and from that stop back to Q. An open end of the
  // band (the line's end) is followed to from the turning point on its other side.
  void band_by_sea(const std::vector<BoundaryVertex>& v, size_t i, size_t j, std::vector<BoundaryVertex>& out,
                   std::vector<std::vector<BoundaryVertex>>& pieces) const {
    const bool open_start = i == 0, open_end = j + 1 == v.size();
    std::optional<Vec2> P, Q;
    if (!open_start) P = turning(v[i - 1], v[i]);
    if (!open_end) Q = turning(v[j + 1], v[j]);
    const locus_follow::Level l = level(*nil_index);
    // A band running to or from the line's end may go on in another piece of the line: its
    // turning points stop the walk too; one drawn from there already is not drawn again.
    std::vector<Vec2> others;
    if (open_turnings != nullptr && open_start != open_end)
      for (const Vec2 t : *open_turnings)
        if (!(P && t == *P) && !(Q && t == *Q)) others.push_back(t);
    auto is_claimed = [&](Vec2 t) {
      return claimed != nullptr && std::find(claimed->begin(), claimed->end(), t) != claimed->end();
    };
    auto followed = [&](Vec2 from, const Vec2* to) {
      locus_follow::Followed f = locus_follow::follow(l, from, to, stats.residual, to ? std::vector<Vec2>{} : others);
      if (f.other >= 0 && claimed != nullptr) claimed->push_back(others[static_cast<size_t>(f.other)]);
      if (f.stop == locus_follow::Stop::lost)
        throw Error(ErrorKind::unsupported, "partial effect: the partial-effect line of owners " + label(B) + " and " +
                                                label(X) + " could not be followed by sea from (" +
                                                std::to_string(from.x) + ", " + std::to_string(from.y) +
                                                "); its lines are not drawn (the rasters are exact)");
      ++stats.stretches;
      stats.points += static_cast<int64_t>(f.points.size());
      if (f.stop == locus_follow::Stop::coast) ++stats.coast_ends;
      return f;
    };
    auto add = [&](const std::vector<Vec2>& pts, bool coast_first, bool coast_last) {
      const size_t first = out.size();
      for (const Vec2 p : pts)
        if (out.empty() || !(out.back().p == p)) out.push_back(vertex(p));
      if (coast_first && out.size() > first) out[first].on_barrier = true;
      if (coast_last && out.size() > first) out.back().on_barrier = true;
    };
    if ((P && !Q && is_claimed(*P)) || (Q && !P && is_claimed(*Q))) {
      add({P ? *P : *Q}, false, false);
      return;
    }
    if (P) {
      const locus_follow::Followed a = followed(*P, Q ? &*Q : nullptr);
      add(a.points, false, a.stop == locus_follow::Stop::coast);
      if (a.stop == locus_follow::Stop::target || !Q) return;
      if (out.size() >= 2) pieces.push_back(std::move(out));
      out.clear();
    }
    locus_follow::Followed b = followed(*Q, nullptr);
    std::reverse(b.points.begin(), b.points.end());
    add(b.points, b.stop == locus_follow::Stop::coast, false);
  }

  // Rewrites `line`; by sea, where land cuts a band's locus, the line's pieces after the first go
  // to `more`. `unchanged` where the line has no partial vertex; `wholly_in_band` (the line left
  // as it was) where every vertex is partial and no end is a planned tripoint, when `by_cells`
  // (the caller then draws the band's loci from the rule's cells).
  enum class Rewritten { unchanged, rewritten, wholly_in_band };
  Rewritten rewrite(BoundaryLine& line, double cell, std::vector<BoundaryLine>& more) const {
    std::vector<BoundaryVertex>& v = line.vertices;
    if (std::none_of(v.begin(), v.end(), [&](const BoundaryVertex& x) { return partial(x); }))
      return Rewritten::unchanged;
    const bool all = std::all_of(v.begin(), v.end(), [&](const BoundaryVertex& x) { return partial(x); });
    // (An end at a planned tripoint whose bands are given back whole has nothing to follow either.)
    auto free_end = [&](Vec2 p) {
      const TripointPlan* tp = plan_at(p);
      return tp == nullptr || tp->whole;
    };
    if (all && by_cells && (line.closed || (free_end(v.front().p) && free_end(v.back().p))))
      return Rewritten::wholly_in_band;
    if (line.closed) {
      // Start at a common vertex: the bands are then runs inside the line.
      v.pop_back();
      const auto common = std::find_if(v.begin(), v.end(), [&](const BoundaryVertex& x) { return !partial(x); });
      if (common == v.end())
        throw Error(ErrorKind::unsupported, "partial effect: the partial features of " + label(B) +
                                                " make an enclave in the zone of " + label(X) +
                                                " with no nil-effect line beside it; give them a reach or nil "
                                                "effect instead (its lines are not drawn; the rasters are exact)");
      std::rotate(v.begin(), common, v.end());
      v.push_back(v.front());
    } else if (all) {
      // Each end at a tripoint where the zone meets two neighbours, or on the grid's edge or a
      // coast: the band's locus runs from end to end (a neighbour's line that the island's zone
      // holds between two of its tripoints: Rügen between Bornholm and Poland).
      const TripointPlan *first = plan_at(v.front().p), *last = plan_at(v.back().p);
      if ((first != nullptr && !first->whole) || (last != nullptr && !last->whole)) {
        if ((first != nullptr && first->whole) || (last != nullptr && last->whole))
          throw Error(ErrorKind::unsupported,
                      "partial effect: the line of owners " + label(B) + " and " + label(X) +
                          " runs from a tripoint where the rule gives the zone of the partial features back whole "
                          "to one where it does not; its lines are not drawn (the rasters are exact)");
        v = end_to_end(v, first, last, cell);
        line.bows.clear();
        return Rewritten::rewritten;
      }
      throw Error(ErrorKind::unsupported, "partial effect: a line of owners " + label(B) + " and " + label(X) +
                                              " lies wholly in the band of the partial features, with no "
                                              "nil-effect stretch to anchor it; its lines are not drawn (the "
                                              "rasters are exact)");
    }
    // A band ending at a planned tripoint is handled at the line's end: turn the line round if
    // that end is its first.
    const bool turned = !line.closed && partial(v.front()) && plan_at(v.front().p) != nullptr;
    if (turned) std::reverse(v.begin(), v.end());
    std::vector<BoundaryVertex> out;
    std::vector<std::vector<BoundaryVertex>> pieces;  // by sea: what land cut off before `out`
    for (size_t i = 0; i < v.size();) {
      if (!partial(v[i])) {
        out.push_back(v[i++]);
        continue;
      }
      const size_t j = run_end(v, i, 1);
      // A band between two common vertices runs from turning point P to turning point Q; one at
      // an end of the line (the edge of the grid or of the owned area) runs to or from there.
      const bool open_start = i == 0, open_end = j + 1 == v.size();
      const TripointPlan* tp = open_end && !open_start ? plan_at(v.back().p) : nullptr;
      if (tp != nullptr && tp->whole)
        throw Error(ErrorKind::unsupported,
                    "partial effect: the line of owners " + label(B) + " and " + label(X) +
                        " leaves their nil-effect line for a tripoint where the rule gives the zone of the partial "
                        "features back whole; its lines are not drawn (the rasters are exact)");
      if (tp != nullptr) {
        to_tripoint(v, i, *tp, cell, out);
        break;
      }
      if (by_sea) {
        band_by_sea(v, i, j, out, pieces);
        i = j + 1;
        if (i < v.size() && !out.empty() && out.back().p == v[i].p) ++i;
        continue;
      }
      Vec2 P{}, Q{};
      if (!open_start) P = turning(v[i - 1], v[i]);
      if (!open_end) Q = turning(v[j + 1], v[j]);
      std::vector<Vec2> c1;
      if (!open_start) c1.push_back(P);
      for (size_t k = i; k <= j; ++k) c1.push_back(v[k].p);
      if (!open_end) c1.push_back(Q);
      const Vec2 anchor = open_end ? away_from(v, i - 1, -1, P) : away_from(v, j + 1, 1, Q);
      const std::vector<Vec2> c0 = nil_chain(open_start ? nullptr : &P, open_end ? nullptr : &Q, anchor, cell);
      const std::vector<Vec2> traced = trace(c0, c1, {!open_start, !open_end});
      for (const Vec2 p : traced) {
        if (!out.empty() && out.back().p == p) continue;
        out.push_back(vertex(p));
      }
      ++stats.stretches;
      stats.points += static_cast<int64_t>(traced.size());
      i = j + 1;
      if (i < v.size() && !out.empty() && out.back().p == v[i].p) ++i;
    }
    if (turned) std::reverse(out.begin(), out.end());
    line.bows.clear();  // (of the full-effect line's segments)
    if (pieces.empty()) {
      v = std::move(out);
      return Rewritten::rewritten;
    }
    // Cut by land: a ring becomes one open line (its last piece joined to its first), and each
    // piece is a line of its own.
    if (line.closed) {
      std::vector<BoundaryVertex>& head = pieces.front();
      if (!out.empty() && out.back().p == head.front().p) out.pop_back();
      out.insert(out.end(), head.begin(), head.end());
      pieces.erase(pieces.begin());
      line.closed = false;
    }
    if (out.size() >= 2) pieces.push_back(std::move(out));
    if (pieces.empty()) throw Error(ErrorKind::internal, "partial effect: a line cut by land left no piece");
    for (size_t k = 1; k < pieces.size(); ++k) {
      BoundaryLine piece{line.owner_a, line.owner_b, false, std::move(pieces[k]), {}};
      more.push_back(std::move(piece));
    }
    v = std::move(pieces.front());
    return Rewritten::rewritten;
  }

  // A point within a billionth of a cell of the last is the same point (where both chains run
  // along S on either side of M, every pairing's locus point is M): the later one is kept, so that
  // the line ends exactly where it is sent, but never in place of the line's first point.
  void append(std::vector<BoundaryVertex>& out, const std::vector<Vec2>& pts) const {
    const double same = 1e-9 * grid->res;
    for (const Vec2 p : pts) {
      if (out.empty() || !(std::hypot(out.back().p.x - p.x, out.back().p.y - p.y) <= same))
        out.push_back(vertex(p));
      else if (out.size() > 1 && !(out.back().p == p))
        out.back() = vertex(p);
    }
  }

  // The nil-effect B-X line from `a` (within a cell of it) to `b`, or, without b, to its end
  // farther along from a.
  std::vector<Vec2> nil_from(Vec2 a, const Vec2* b, double cell) const {
    for (const BoundaryLine& l : rule.nil_lines().lines) {
      if (!((l.owner_a == B && l.owner_b == X) || (l.owner_a == X && l.owner_b == B)) || l.vertices.size() < 2)
        continue;
      std::vector<Vec2> pts;
      for (const BoundaryVertex& u : l.vertices) pts.push_back(u.p);
      const Along u = project(pts, a);
      if (!(u.distance <= cell)) continue;
      Along w;
      if (b != nullptr) {
        w = project(pts, *b);
        if (!(w.distance <= cell)) continue;
      } else {
        if (l.closed) continue;
        const double half = 0.5 * static_cast<double>(pts.size() - 1);
        w = u.at() <= half ? Along{pts.size() - 2, 1.0, 0.0} : Along{0, 0.0, 0.0};
      }
      std::vector<Vec2> chain = stretch(pts, l.closed, u, w);
      chain.front() = a;
      if (b != nullptr) chain.back() = *b;
      return chain;
    }
    throw Error(ErrorKind::unsupported, "partial effect: the full-effect line of owners " + label(B) + " and " +
                                            label(X) +
                                            " lies wholly in the band, and no nil-effect line of theirs runs "
                                            "between its ends; its lines are not drawn (the rasters are exact)");
  }

  // A line wholly in its band whose ends are each a planned tripoint (not given back whole) or
  // open (the grid's edge, a coast), at least one a tripoint: the locus from the partial
  // tripoint of one end to that of the other (or to the open end) between L0 (the nil-effect
  // line, reached along S from each tripoint) and L1 (the full-effect line, from T along S).
  std::vector<BoundaryVertex> end_to_end(const std::vector<BoundaryVertex>& v, const TripointPlan* first,
                                         const TripointPlan* last, double cell) const {
    auto along_s = [&](const TripointPlan& tp, bool to_t) {  // M_X to T (or S's end), as the line runs
      const Along at = tp.at[static_cast<size_t>(tp.side(X))];
      return stretch(tp.S, false, at, to_t ? Along{0, 0.0, 0.0} : Along{tp.S.size() - 2, 1.0, 0.0});
    };
    auto join = [](std::vector<Vec2>& c, const std::vector<Vec2>& more) {
      for (const Vec2 p : more)
        if (c.empty() || !(c.back() == p)) c.push_back(p);
    };
    auto m_of = [&](const TripointPlan& tp) { return tp.m[static_cast<size_t>(tp.side(X))]; };
    std::vector<Vec2> traced;
    bool coast_end = false;
    if (by_sea && (first == nullptr || last == nullptr)) {
      // By sea an open end may be a coast, where L0's and L1's ends need not pair: the locus is
      // followed from the partial tripoint to wherever it ends.
      const Vec2 from = m_of(first != nullptr ? *first : *last);
      const locus_follow::Followed f = locus_follow::follow(level(*nil_index), from, nullptr, stats.residual);
      if (f.stop == locus_follow::Stop::lost || f.points.size() < 2)
        throw Error(ErrorKind::unsupported, "partial effect: the partial-effect line of owners " + label(B) + " and " +
                                                label(X) + " could not be followed by sea from (" +
                                                std::to_string(from.x) + ", " + std::to_string(from.y) +
                                                "); its lines are not drawn (the rasters are exact)");
      traced = f.points;
      if (first == nullptr) std::reverse(traced.begin(), traced.end());
      coast_end = f.stop == locus_follow::Stop::coast;
      stats.coast_ends += coast_end;
    } else {
      std::vector<Vec2> c1, c0;
      if (first != nullptr) {
        join(c1, along_s(*first, true));
        join(c0, along_s(*first, false));
      }
      for (const BoundaryVertex& u : v) join(c1, {u.p});
      std::vector<Vec2> tail0;
      if (last != nullptr) {
        std::vector<Vec2> tail1 = along_s(*last, true);
        tail0 = along_s(*last, false);
        std::reverse(tail1.begin(), tail1.end());
        std::reverse(tail0.begin(), tail0.end());
        join(c1, tail1);
      }
      if (first != nullptr) {
        join(c0, nil_from(c0.back(), last != nullptr ? &tail0.front() : nullptr, cell));
      } else {
        c0 = nil_from(tail0.front(), nullptr, cell);
        std::reverse(c0.begin(), c0.end());
      }
      join(c0, tail0);
      if (first != nullptr) c0.front() = c1.front() = m_of(*first);
      if (last != nullptr) c0.back() = c1.back() = m_of(*last);
      traced = trace(c0, c1, {first != nullptr, last != nullptr});
    }
    std::vector<BoundaryVertex> out;
    // The owner whose M is farther from T goes on along S to the partial tripoint.
    if (first != nullptr && first->side(X) != first->first) {
      const size_t k = static_cast<size_t>(first->side(X)), f = static_cast<size_t>(first->first);
      std::vector<Vec2> on = stretch(first->S, false, first->at[f], first->at[k]);
      on.front() = first->tripoint();
      append(out, on);
    }
    append(out, traced);
    if (last != nullptr && last->side(X) != last->first) {
      const size_t k = static_cast<size_t>(last->side(X)), f = static_cast<size_t>(last->first);
      std::vector<Vec2> on = stretch(last->S, false, last->at[k], last->at[f]);
      on.back() = last->tripoint();
      append(out, on);
    }
    if (coast_end) (first == nullptr ? out.front() : out.back()).on_barrier = true;
    ++stats.stretches;
    stats.points += static_cast<int64_t>(traced.size());
    return out;
  }

  // The band from turning point P (between v[i - 1] and v[i]) to the line's end at tripoint
  // plan T: the locus from P to M_X between L0 (on to the nil tripoint, then back along S) and L1
  // (to T, then along S), and for the owner whose M is farther from T, S on to the partial
  // tripoint.
  void to_tripoint(const std::vector<BoundaryVertex>& v, size_t i, const TripointPlan& tp, double cell,
                   std::vector<BoundaryVertex>& out) const {
    const int k = tp.side(X);
    const Vec2 P = turning(v[i - 1], v[i]);
    const Along start{0, 0.0, 0.0}, end{tp.S.size() - 2, 1.0, 0.0};
    const Along at = tp.at[static_cast<size_t>(k)];
    std::vector<Vec2> c1{P};
    for (size_t q = i; q < v.size(); ++q) c1.push_back(v[q].p);
    const std::vector<Vec2> along_s = stretch(tp.S, false, start, at);
    c1.insert(c1.end(), along_s.begin() + 1, along_s.end());
    // L0 from P to the nil-effect tripoint at S's end (known: no direction to guess, even where P
    // is the common vertex itself).
    const Vec2 t0 = tp.S.back();
    std::vector<Vec2> c0 = nil_chain(&P, &t0, v[i - 1].p, cell);
    const std::vector<Vec2> back = stretch(tp.S, false, end, at);
    c0.insert(c0.end(), back.begin() + 1, back.end());
    c0.back() = c1.back() = tp.m[static_cast<size_t>(k)];
    const std::vector<Vec2> traced = trace(c0, c1, {true, true});
    append(out, traced);
    ++stats.stretches;
    stats.points += static_cast<int64_t>(traced.size());
    if (k != tp.first) {
      std::vector<Vec2> on = stretch(tp.S, false, at, tp.at[static_cast<size_t>(tp.first)]);
      on.back() = tp.tripoint();
      append(out, on);
    }
  }
};

}  // namespace

namespace {

// The loci of band (B, w.X) that no line in `out` or `more` follows, from the rule's cells
// (partial_loci.hpp): the band of a full-effect line wholly in it. Each locus a line of its own,
// ending on coasts or the frame, or closed.
std::vector<BoundaryLine> loci_by_cells(const LineRewrite& w, const OwnerIndex& nil, const NearestField& full,
                                        const NearestField& field, const BoundaryResult& out,
                                        const std::vector<BoundaryLine>& more) {
  std::vector<std::vector<Vec2>> drawn;
  auto add_drawn = [&](const BoundaryLine& l) {
    if (!((l.owner_a == w.B && l.owner_b == w.X) || (l.owner_a == w.X && l.owner_b == w.B))) return;
    std::vector<Vec2>& pts = drawn.emplace_back();
    for (const BoundaryVertex& v : l.vertices) pts.push_back(v.p);
  };
  for (const BoundaryLine& l : out.lines) add_drawn(l);
  for (const BoundaryLine& l : more) add_drawn(l);
  const locus_follow::Level level = w.level(nil);
  std::vector<BoundaryLine> lines;
  for (const locus_follow::Through& t :
       partial_loci::loci_from_cells(level, full, field, w.seeds, w.B, w.X, drawn, w.stats.residual)) {
    if (t.first == locus_follow::Stop::lost || t.last == locus_follow::Stop::lost || t.points.size() < 2)
      throw Error(ErrorKind::unsupported, "partial effect: the partial-effect line of owners " + w.label(w.B) +
                                              " and " + w.label(w.X) + " could not be followed from (" +
                                              std::to_string(t.points.front().x) + ", " +
                                              std::to_string(t.points.front().y) +
                                              ") where it leaves the band; its lines are not drawn (the rasters "
                                              "are exact)");
    BoundaryLine l{w.b_is_a ? w.B : w.X, w.b_is_a ? w.X : w.B, t.first == locus_follow::Stop::closed, {}, {}};
    for (const Vec2 p : t.points) l.vertices.push_back(w.vertex(p));
    const bool coast_first = t.first == locus_follow::Stop::coast, coast_last = t.last == locus_follow::Stop::coast;
    l.vertices.front().on_barrier = coast_first;
    l.vertices.back().on_barrier = coast_last;
    ++w.stats.stretches;
    w.stats.points += static_cast<int64_t>(t.points.size());
    w.stats.coast_ends += coast_first + coast_last;
    lines.push_back(std::move(l));
  }
  return lines;
}

}  // namespace

BoundaryResult partial_boundaries(const PartialEffectRule& rule, const SeedSet& seeds, const OwnerIndex& index,
                                  const GridSpec& grid, double ftol, double line_tolerance, double simplify_cells,
                                  PartialLineStats& stats, const OwnerIndex* nil_index, const NearestField* full_field,
                                  const NearestField* rule_field) {
  BoundaryResult out = rule.full_lines();
  const PartialEffect& pe = rule.effect();
  if (!pe.any()) return out;
  const int32_t B = pe.owner;
  const std::vector<TripointPlan> plans = partial_tripoints::plan_tripoints(rule, seeds, out, index, grid.res, ftol);
  // The tolerance in CRS units, over the larger scale of the two axes (a bound in either).
  const line_tools::CrsScale scale(index.metric(), Vec2{grid.centre_x(grid.width / 2), grid.centre_y(grid.height / 2)},
                                   grid.res);
  const double per_crs = std::max(scale.at0.x, scale.at0.y);
  const double tol = std::max(line_tolerance / per_crs, 1e-9 * grid.res), simplify = simplify_cells * grid.res;
  const bool by_cells = nil_index != nullptr && full_field != nullptr && rule_field != nullptr;
  int64_t vertices = 0;
  auto simplified = [&](BoundaryLine& line) {
    std::vector<Vec2> pts;
    for (const BoundaryVertex& v : line.vertices) pts.push_back(v.p);
    std::vector<BoundaryVertex> kept;
    for (size_t j : simplify_indices(pts, simplify)) kept.push_back(line.vertices[j]);
    line.vertices = std::move(kept);
  };
  std::map<int32_t, std::vector<Vec2>> turnings, claimed;  // by neighbour (LineRewrite::open_turnings)
  auto rewriter = [&](int32_t X, bool b_is_a) {
    LineRewrite w{rule, seeds, index, ftol, tol, B, X, b_is_a, stats, plans, per_crs, nil_index, &grid};
    w.by_cells = by_cells;
    w.by_sea = !index.metric().straight() && nil_index != nullptr;
    if (w.by_sea) {
      w.open_turnings = &turnings[X];
      w.claimed = &claimed[X];
    }
    return w;
  };
  for (const BoundaryLine& line : out.lines)
    if (line.owner_a == B || line.owner_b == B) {
      const int32_t X = line.owner_a == B ? line.owner_b : line.owner_a;
      const LineRewrite w = rewriter(X, line.owner_a == B);
      if (w.open_turnings != nullptr)
        for (const Vec2 t : w.end_turnings(line)) turnings[X].push_back(t);
    }
  std::vector<BoundaryLine> more;                // by sea: the pieces of lines that land cut
  std::vector<std::pair<int32_t, bool>> wholly;  // neighbours (and B's side) with a line wholly in the band
  std::vector<bool> dropped(out.lines.size(), false);
  for (size_t k = 0; k < out.lines.size(); ++k) {
    BoundaryLine& line = out.lines[k];
    if (line.owner_a == B || line.owner_b == B) {
      const int32_t X = line.owner_a == B ? line.owner_b : line.owner_a;
      const LineRewrite w = rewriter(X, line.owner_a == B);
      const size_t before = more.size();
      const LineRewrite::Rewritten done = w.rewrite(line, grid.res, more);
      if (done == LineRewrite::Rewritten::wholly_in_band) {
        dropped[k] = true;
        if (std::none_of(wholly.begin(), wholly.end(), [&](const auto& h) { return h.first == X; }))
          wholly.emplace_back(X, line.owner_a == B);
        continue;
      }
      if (done == LineRewrite::Rewritten::rewritten) simplified(line);
      for (size_t j = before; j < more.size(); ++j) simplified(more[j]);
    }
    vertices += static_cast<int64_t>(line.vertices.size());
  }
  if (!wholly.empty()) {
    std::vector<BoundaryLine> kept;
    for (size_t k = 0; k < out.lines.size(); ++k)
      if (!dropped[k]) kept.push_back(std::move(out.lines[k]));
    out.lines = std::move(kept);
  }
  for (const auto& [X, b_is_a] : wholly) {
    const LineRewrite w = rewriter(X, b_is_a);
    for (BoundaryLine& l : loci_by_cells(w, *nil_index, *full_field, *rule_field, out, more)) {
      simplified(l);
      more.push_back(std::move(l));
    }
  }
  for (BoundaryLine& line : more) {
    vertices += static_cast<int64_t>(line.vertices.size());
    out.lines.push_back(std::move(line));
  }
  for (const auto& [X, at] : claimed) partial_joins::join_at(out.lines, seeds, B, X, at);
  vertices += partial_tripoints::extend_at_tripoints(rule, plans, index, out);
  vertices += partial_tripoints::given_back_zone(rule, seeds, plans, index, grid.res, out);
  partial_joins::refuse_turned_back(out.lines, seeds, grid.res);
  out.stats.vertices = vertices;
  out.stats.max_residual = std::max(out.stats.max_residual, stats.max_residual);
  return out;
}

PartialEffectResult compute_partial_effect(const SeedSet& seeds, const GridSpec& grid, const ComputeOptions& options,
                                           const BoundaryOptions& lines, bool draw_lines,
                                           const PartialEngines& engines) {
  const auto start = std::chrono::steady_clock::now();
  auto field_of = [&](const SeedSet& s, bool nil) {
    return engines.field ? engines.field(s, nil) : compute(s, grid, options);
  };
  auto metric_of = [&](const SeedSet& s, const NearestField& f, bool nil) {
    return engines.metric ? engines.metric(s, f, nil) : make_site_metric(s, grid, options);
  };
  PartialEffectResult r;
  const PartialEffect pe = partial_effect_of(seeds);
  r.full = field_of(seeds, false);
  r.metric = metric_of(seeds, r.full, false);
  r.index = std::make_unique<OwnerIndex>(*r.metric);
  BoundaryResult full_lines = extract_boundaries(r.full, *r.index, lines);
  if (!pe.any()) {
    r.field = r.full;
    r.boundaries = std::move(full_lines);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return r;
  }
  std::vector<int32_t> site_of;
  r.nil_seeds = std::make_shared<const SeedSet>(seeds.without(pe.partial, site_of));
  const NearestField nil = field_of(*r.nil_seeds, true);
  r.nil_metric = metric_of(*r.nil_seeds, nil, true);
  r.nil_index = std::make_unique<OwnerIndex>(*r.nil_metric);
  BoundaryResult nil_lines = extract_boundaries(nil, *r.nil_index, lines);
  r.rule = std::make_unique<PartialEffectRule>(seeds, pe, std::move(nil_lines), site_of, std::move(full_lines), grid,
                                               options);
  r.field = partial_field(r.full, nil, site_of, seeds, *r.rule, options.threads);
  const double ftol = std::max(lines.tolerance_cells, 1e-15) * cell_metric(grid, *r.metric);
  if (draw_lines)
    r.boundaries = partial_boundaries(*r.rule, seeds, *r.index, grid, ftol, lines.line_tolerance, lines.simplify_cells,
                                      r.stats, r.nil_index.get(), &r.full, &r.field);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

int32_t partial_owner_at(const PartialEffectResult& r, Vec2 p, double max_distance) {
  const int32_t full = owner_at(*r.index, p, max_distance);
  if (!r.rule) return full;
  return r.rule->owner(p, full, owner_at(*r.nil_index, p, max_distance));
}

double partial_locus(const PartialEffectResult& r, int32_t a, int32_t b, Vec2 p) {
  if (r.rule) {
    const int32_t B = r.rule->effect().owner;
    if (a == B || b == B) {
      const int32_t x = a == B ? b : a;
      if (owner_at(*r.index, p) == B && owner_at(*r.nil_index, p) == x) {
        const double balance = r.rule->balance(p, x);
        return a == B ? -balance : balance;
      }
    }
  }
  return r.index->nearest_of(p, a).cost - r.index->nearest_of(p, b).cost;
}

}  // namespace rv
