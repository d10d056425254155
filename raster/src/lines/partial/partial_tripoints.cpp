// Partial effect at the full-effect tripoints. See partial_tripoints.hpp.
#include "lines/partial/partial_tripoints.hpp"

#include <algorithm>
#include <cmath>

#include "lines/line_tools.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/regions.hpp"

namespace rv::partial_tripoints {

using namespace line_tools;
using namespace polyline_along;

std::string owner_label(const SeedSet& seeds, int32_t owner) {
  return "'" + seeds.owner_labels()[static_cast<size_t>(owner - 1)] + "'";
}

namespace {

// Whether both bands are given back all along S: at every vertex after T and the middle of every
// segment, both neighbours' balances below 0, and the point inside B's zone at full effect (S's
// last vertex apart: a nil-effect tripoint, the frame or a coast).
bool given_back_along(const PartialEffectRule& rule, const OwnerIndex& index, const TripointPlan& tp, int32_t B,
                      double cell) {
  // (At T the three owners tie: a point within a thousandth of a cell of it is not asked whose it is.)
  auto given_back = [&](Vec2 p, bool inside) {
    const bool at_t = std::hypot(p.x - tp.T.x, p.y - tp.T.y) <= 1e-3 * cell;
    return rule.balance(p, tp.owners[0]) < 0.0 && rule.balance(p, tp.owners[1]) < 0.0 &&
           (!inside || at_t || owner_at(index, p) == B);
  };
  for (size_t k = 1; k < tp.S.size(); ++k)
    if (!given_back(lerp(tp.S[k - 1], tp.S[k], 0.5), true) || !given_back(tp.S[k], k + 1 < tp.S.size())) return false;
  return true;
}

}  // namespace

std::vector<TripointPlan> plan_tripoints(const PartialEffectRule& rule, const SeedSet& seeds,
                                         const BoundaryResult& full, const OwnerIndex& index, double cell,
                                         double ftol) {
  const PartialEffect& pe = rule.effect();
  const int32_t B = pe.owner;
  std::vector<TripointPlan> plans;
  for (size_t n = 0; n < full.tripoints.size(); ++n) {
    const Tripoint& t = full.tripoints[n];
    int kb = -1;
    for (int k = 0; k < 3; ++k)
      if (t.owners[k] == B && t.sites[k] != kNoSite && pe.partial[static_cast<size_t>(seeds.site_feature(t.sites[k]))])
        kb = k;
    if (kb < 0) continue;
    TripointPlan tp;
    tp.index = n;
    tp.T = t.p;
    for (int k = 0, q = 0; k < 3; ++k)
      if (k != kb) tp.owners[static_cast<size_t>(q++)] = t.owners[k];
    const int32_t X = tp.owners[0], Y = tp.owners[1];
    auto refuse = [&](const std::string& why) {
      throw Error(ErrorKind::unsupported, "partial effect: where the zone of the partial features of " +
                                              owner_label(seeds, B) + " meets " + owner_label(seeds, X) + " and " +
                                              owner_label(seeds, Y) + ", " + why +
                                              "; the lines of this case are not drawn (the rasters are exact)");
    };
    auto of_pair = [&](const BoundaryLine& l) {
      return (l.owner_a == X && l.owner_b == Y) || (l.owner_a == Y && l.owner_b == X);
    };
    // The nil-effect X-Y line through T, and the way from T into the zone: away from the
    // full-effect X-Y line, which ends at T.
    std::vector<Vec2> pts;
    const BoundaryLine* nil_line = nullptr;
    Along uT;
    for (const BoundaryLine& l : rule.nil_lines().lines) {
      if (!of_pair(l) || l.closed || l.vertices.size() < 2) continue;
      std::vector<Vec2> q;
      for (const BoundaryVertex& v : l.vertices) q.push_back(v.p);
      const Along u = project(q, tp.T);
      if (u.distance <= cell && u.distance < uT.distance) {
        uT = u;
        pts = std::move(q);
        nil_line = &l;
      }
    }
    if (pts.empty()) refuse("their nil-effect line does not pass through the full-effect tripoint");
    const Vec2* outside = nullptr;
    for (const BoundaryLine& l : full.lines) {
      if (!of_pair(l) || l.closed || l.vertices.size() < 2) continue;
      // (Its first vertex away from T: a line may hold a vertex within a hair of its end.)
      auto away = [&](Vec2 p) { return std::hypot(p.x - tp.T.x, p.y - tp.T.y) > 1e-6 * cell; };
      const size_t n_v = l.vertices.size();
      if (l.vertices.front().p == tp.T)
        for (size_t k = 1; k < n_v && outside == nullptr; ++k)
          if (away(l.vertices[k].p)) outside = &l.vertices[k].p;
      if (l.vertices.back().p == tp.T)
        for (size_t k = n_v - 1; k-- > 0 && outside == nullptr;)
          if (away(l.vertices[k].p)) outside = &l.vertices[k].p;
    }
    if (outside == nullptr) refuse("their full-effect line does not end at the tripoint");
    const Along uo = project(pts, *outside);
    const Along end = uo.at() <= uT.at() ? Along{pts.size() - 2, 1.0, 0.0} : Along{0, 0.0, 0.0};
    tp.S = stretch(pts, false, uT, end);
    tp.S.front() = tp.T;
    tp.end_on_barrier = (end.t == 0.0 ? nil_line->vertices.front() : nil_line->vertices.back()).on_barrier;
    std::array<bool, 2> reached{false, false};
    for (size_t side = 0; side < 2; ++side) {
      const int32_t owner = tp.owners[side];
      bool found = false;
      double f0 = rule.balance(tp.S[0], owner);
      for (size_t k = 0; k + 1 < tp.S.size() && !found; ++k) {
        const double f1 = rule.balance(tp.S[k + 1], owner);
        if (f0 < 0.0 && f1 >= 0.0) {
          const Vec2 a = tp.S[k], b = tp.S[k + 1];
          const double u = find_root([&](double x) { return rule.balance(lerp(a, b, x), owner); }, f0, f1, ftol, 1e-15);
          tp.at[side] = Along{k, u, 0.0};
          tp.m[side] = lerp(a, b, u);
          found = true;
        }
        f0 = f1;
      }
      reached[side] = found;
    }
    if (!reached[0] && !reached[1] && given_back_along(rule, index, tp, B, cell)) {
      tp.whole = true;
      for (size_t side = 0; side < 2; ++side) {
        tp.at[side] = Along{tp.S.size() - 2, 1.0, 0.0};
        tp.m[side] = tp.S.back();
      }
      plans.push_back(std::move(tp));
      continue;
    }
    for (size_t side = 0; side < 2; ++side)
      if (!reached[side])
        refuse("no partial-effect line of " + owner_label(seeds, tp.owners[side]) +
               " reaches their nil-effect line (the islands lie far from the nil-effect line of " +
               owner_label(seeds, B) + " and " + owner_label(seeds, tp.owners[side]) +
               ", so the rule gives that band back whole, but not the other one)");
    tp.first = tp.at[0].at() <= tp.at[1].at() ? 0 : 1;
    plans.push_back(std::move(tp));
  }
  return plans;
}

int64_t extend_at_tripoints(const PartialEffectRule& rule, const std::vector<TripointPlan>& plans,
                            const OwnerIndex& index, BoundaryResult& out) {
  int64_t added = 0;
  for (const TripointPlan& tp : plans) {
    const Vec2 M = tp.tripoint();
    std::vector<Vec2> ext = stretch(tp.S, false, Along{0, 0.0, 0.0}, tp.at[static_cast<size_t>(tp.first)]);
    ext.back() = M;
    for (BoundaryLine& l : out.lines) {
      const bool pair = (l.owner_a == tp.owners[0] && l.owner_b == tp.owners[1]) ||
                        (l.owner_a == tp.owners[1] && l.owner_b == tp.owners[0]);
      if (!pair || l.closed || l.vertices.empty()) continue;
      const bool at_back = l.vertices.back().p == tp.T, at_front = l.vertices.front().p == tp.T;
      if (!at_back && !at_front) continue;
      if (at_front) std::reverse(l.vertices.begin(), l.vertices.end());
      for (size_t k = 1; k < ext.size(); ++k) {
        const OwnerIndex::Hit ha = index.nearest_of(ext[k], l.owner_a), hb = index.nearest_of(ext[k], l.owner_b);
        l.vertices.push_back(BoundaryVertex{ext[k], ha.site, hb.site, 0.5 * (ha.distance + hb.distance),
                                            std::abs(ha.cost - hb.cost), ha.distance, hb.distance});
        ++added;
      }
      if (tp.whole) l.vertices.back().on_barrier = tp.end_on_barrier;
      if (at_front) std::reverse(l.vertices.begin(), l.vertices.end());
      break;
    }
    if (tp.whole) continue;  // (no tripoint there: given_back_zone)
    Tripoint& t = out.tripoints[tp.index];
    t.p = M;
    double distance = 0.0, cost = 0.0;
    std::array<double, 3> costs{};
    for (int k = 0; k < 3; ++k) {
      const OwnerIndex::Hit h = index.nearest_of(M, t.owners[k]);
      t.sites[k] = h.site;
      t.distances[k] = h.distance;
      costs[static_cast<size_t>(k)] = h.cost;
      distance += h.distance / 3.0;
      cost += h.cost / 3.0;
    }
    t.distance = distance;
    t.cost = cost;
    // On the neighbours' line (their costs equal) and on the first owner's partial locus.
    double neighbours = 0.0;
    for (int k = 0; k < 3; ++k)
      for (int q = k + 1; q < 3; ++q)
        if (t.owners[k] != rule.effect().owner && t.owners[q] != rule.effect().owner)
          neighbours = std::abs(costs[static_cast<size_t>(k)] - costs[static_cast<size_t>(q)]);
    t.residual = std::max(neighbours, std::abs(rule.balance(M, tp.owners[static_cast<size_t>(tp.first)])));
  }
  return added;
}

int64_t given_back_zone(const PartialEffectRule& rule, const SeedSet& seeds, const std::vector<TripointPlan>& plans,
                        const OwnerIndex& index, double cell, BoundaryResult& out) {
  if (std::none_of(plans.begin(), plans.end(), [](const TripointPlan& tp) { return tp.whole; })) return 0;
  const int32_t B = rule.effect().owner;
  const BoundaryResult& nil = rule.nil_lines();
  const double near = 1e-6 * cell;
  auto same = [&](Vec2 a, Vec2 b) { return std::hypot(a.x - b.x, a.y - b.y) <= near; };
  auto pair_of = [](const BoundaryLine& l, int32_t a, int32_t b) {
    return (l.owner_a == a && l.owner_b == b) || (l.owner_a == b && l.owner_b == a);
  };
  // The nil-effect tripoints the whole plans' S reach (three neighbours, none of them B).
  std::vector<size_t> reached;
  for (const TripointPlan& tp : plans) {
    if (!tp.whole) continue;
    for (size_t n = 0; n < nil.tripoints.size(); ++n) {
      const Tripoint& t = nil.tripoints[n];
      if (!same(t.p, tp.S.back()) || std::count(t.owners, t.owners + 3, B) != 0) continue;
      if (std::find(reached.begin(), reached.end(), n) == reached.end()) reached.push_back(n);
    }
  }
  // The nil-effect lines of two neighbours inside the zone, both sides given back all along.
  auto inside = [&](const BoundaryLine& l) {
    auto given_back = [&](Vec2 p) {
      return owner_at(index, p) == B && rule.balance(p, l.owner_a) < 0.0 && rule.balance(p, l.owner_b) < 0.0;
    };
    for (size_t k = 0; k < l.vertices.size(); ++k) {
      const bool end = k == 0 || k + 1 == l.vertices.size();
      if (!end && !given_back(l.vertices[k].p)) return false;
      if (k > 0 && !given_back(lerp(l.vertices[k - 1].p, l.vertices[k].p, 0.5))) return false;
    }
    return l.vertices.size() >= 2;
  };
  int64_t added = 0;
  std::vector<const BoundaryLine*> drawn;
  for (const BoundaryLine& l : nil.lines) {
    if (l.owner_a == B || l.owner_b == B || !inside(l)) continue;
    BoundaryLine copy{l.owner_a, l.owner_b, l.closed, {}, {}};
    for (const BoundaryVertex& v : l.vertices) {
      const OwnerIndex::Hit ha = index.nearest_of(v.p, l.owner_a), hb = index.nearest_of(v.p, l.owner_b);
      BoundaryVertex w{v.p,         ha.site,    hb.site, 0.5 * (ha.distance + hb.distance), std::abs(ha.cost - hb.cost),
                       ha.distance, hb.distance};
      w.on_barrier = v.on_barrier;
      copy.vertices.push_back(w);
    }
    added += static_cast<int64_t>(copy.vertices.size());
    out.lines.push_back(std::move(copy));
    drawn.push_back(&l);
  }
  // Each reached tripoint: every nil-effect line ending there is drawn (a whole plan's S, or a
  // line added above), and it is a tripoint of the result.
  for (const size_t n : reached) {
    const Tripoint& t = nil.tripoints[n];
    for (const BoundaryLine& l : nil.lines) {
      if (l.closed || l.vertices.empty() || !(same(l.vertices.front().p, t.p) || same(l.vertices.back().p, t.p)))
        continue;
      const bool by_plan = std::any_of(plans.begin(), plans.end(), [&](const TripointPlan& tp) {
        return tp.whole && same(tp.S.back(), t.p) && pair_of(l, tp.owners[0], tp.owners[1]);
      });
      if (!by_plan && std::find(drawn.begin(), drawn.end(), &l) == drawn.end())
        throw Error(ErrorKind::unsupported,
                    "partial effect: the nil-effect lines of " + owner_label(seeds, t.owners[0]) + ", " +
                        owner_label(seeds, t.owners[1]) + " and " + owner_label(seeds, t.owners[2]) +
                        " meet in the zone of the partial features of " + owner_label(seeds, B) +
                        ", where the rule gives back some of it but not all; the lines of this case are not drawn "
                        "(the rasters are exact)");
    }
    out.tripoints.push_back(t);
  }
  // The whole plans' full-effect tripoints are none of the result.
  std::vector<size_t> gone;
  for (const TripointPlan& tp : plans)
    if (tp.whole) gone.push_back(tp.index);
  std::sort(gone.begin(), gone.end());
  gone.erase(std::unique(gone.begin(), gone.end()), gone.end());
  for (auto it = gone.rbegin(); it != gone.rend(); ++it)
    out.tripoints.erase(out.tripoints.begin() + static_cast<std::ptrdiff_t>(*it));
  return added;
}

}  // namespace rv::partial_tripoints
