// A locus followed where cells do not show it. See locus_follow.hpp.
#include "lines/locus_follow.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "lines/line_tools.hpp"

namespace rv::locus_follow {

using namespace line_tools;

namespace {

constexpr int kMaxDepth = 24;  // chord refinement, as the straight trace's
// |balance| at a root, in ftol, beyond which the bracket closed on a jump, not a root (a converged
// root is within ftol, or a bracket of 1e-15 of the segment across a slope of at most 2).
constexpr double kJump = 1e3;

double norm(Vec2 v) { return std::hypot(v.x, v.y); }

struct Follower {
  const Level& L;
  LineResidual& residual;
  // CRS units (half a cell through the partial effect's bands); a walk up a channel narrows it.
  mutable double step;
  // How far across the level a step's root is looked for (CRS units; with Level::clearance, just
  // under the way to the nearer side).
  mutable double across = std::numeric_limits<double>::infinity();
  // The coast point a walk leaves (follow_on's `left`), or null.
  const Vec2* left = nullptr;

  bool sees(Vec2 a, Vec2 b) const { return L.metric->open_between(a, b) && L.in_band(b); }

  // The root of the balance on segment a-b (its ends of opposite signs), or false. Also false
  // where the sign changes by a jump (the balance finite and far from 0 where the bracket closes):
  // across a boom, each face's costs are its own, and the owners change there without a locus.
  bool root(Vec2 a, Vec2 b, Vec2& out) const {
    // (find_root returns a point it evaluated: its value is kept, not asked for again.)
    double last_t = 0.0, last_f = 0.0;
    auto f = [&](double t) {
      last_t = t;
      last_f = L.balance(lerp(a, b, t));
      return last_f;
    };
    const double fa = f(0.0), fb = f(1.0);
    if (!std::isfinite(fa) || !std::isfinite(fb) || (fa < 0.0) == (fb < 0.0)) return false;
    const double t = find_root(f, fa, fb, L.ftol, 1e-15);
    out = lerp(a, b, t);
    const double at = t == last_t ? last_f : t == 0.0 ? fa : t == 1.0 ? fb : L.balance(out);
    // (A bracket across land closes on its coast, where the balance is undefined: the caller's
    // sight test ends the walk there.)
    return !(std::abs(at) > kJump * L.ftol);
  }

  // The first point of the locus from turning point `c`: on the circle of radius `step` round
  // it, where the balance changes sign between two points in the band (the band is a wedge at a
  // turning point, L0 on one side, L1 on the other: one change). The lines often part at a small
  // angle, so the circle is sampled finely (the balance is cheap: distances to two polylines) and
  // only the samples beside a change are asked whether they lie in the band.
  bool first(Vec2 c, Vec2& out) const {
    constexpr int kRound = 4096;
    const double w = 2.0 * std::numbers::pi / kRound;
    auto on_circle = [&](double a) { return Vec2{c.x + step * std::cos(a), c.y + step * std::sin(a)}; };
    std::vector<double> f(kRound);
    for (int k = 0; k < kRound; ++k) f[k] = L.balance(on_circle(w * k));
    for (int k = 0; k < kRound; ++k) {
      const int n = (k + 1) % kRound;
      if (!std::isfinite(f[k]) || !std::isfinite(f[n]) || (f[k] < 0.0) == (f[n] < 0.0)) continue;
      if (!sees(c, on_circle(w * k)) || !sees(c, on_circle(w * (k + 1)))) continue;
      const double a0 = w * k;
      auto g = [&](double t) { return L.balance(on_circle(a0 + w * t)); };
      out = on_circle(a0 + w * find_root(g, f[k], f[n], L.ftol, 1e-15));
      return true;
    }
    return false;
  }

  // The balance's gradient at p (central differences, per CRS unit).
  Vec2 gradient(Vec2 p) const {
    const double h = 1e-4 * L.grid.res;
    return Vec2{(L.balance(Vec2{p.x + h, p.y}) - L.balance(Vec2{p.x - h, p.y})) / (2.0 * h),
                (L.balance(Vec2{p.x, p.y + h}) - L.balance(Vec2{p.x, p.y - h})) / (2.0 * h)};
  }

  // The next point of the locus from c, going on in direction `dir` (unit): a step along the
  // level's tangent, then the root across it along the gradient; shorter steps where none is
  // found. False where no step finds one.
  bool next(Vec2 c, Vec2 dir, Vec2& out) const {
    const Vec2 g = gradient(c);
    const double gn = norm(g);
    if (!(gn > 0.0) || !std::isfinite(gn)) return false;
    const Vec2 n{g.x / gn, g.y / gn};
    Vec2 t{-n.y, n.x};
    if (t.x * dir.x + t.y * dir.y < 0.0) t = Vec2{-t.x, -t.y};
    for (double s = step; s >= step / 16.0; s *= 0.5) {
      const Vec2 q{c.x + s * t.x, c.y + s * t.y};
      const double a = std::min(s, across);  // (within a channel: across it, not onto its land)
      if (root(Vec2{q.x - a * n.x, q.y - a * n.y}, Vec2{q.x + a * n.x, q.y + a * n.y}, out) &&
          norm(Vec2{out.x - c.x, out.y - c.y}) > 0.0)
        return true;
    }
    return round_corner(c, dir, out);
  }

  // Where the level turns sharply at c (a corner: the nearest part of L0 or L1 changes there, as
  // on the inner offset of a ring's corner), the tangent's step finds no root across it: the
  // locus is then taken where it crosses the circle of half a step round c, at the crossing most
  // along `dir` (the other one leads back). False where the circle has no crossing in the band.
  bool round_corner(Vec2 c, Vec2 dir, Vec2& out) const {
    constexpr int kRound = 256;
    const double r = 0.5 * step, w = 2.0 * std::numbers::pi / kRound;
    auto on_circle = [&](double a) { return Vec2{c.x + r * std::cos(a), c.y + r * std::sin(a)}; };
    std::vector<double> f(kRound);
    for (int k = 0; k < kRound; ++k) f[k] = L.balance(on_circle(w * k));
    double best = -0.9;  // (a turn of up to about 150 degrees; the crossing behind lies near -1)
    for (int k = 0; k < kRound; ++k) {
      const int m = (k + 1) % kRound;
      if (!std::isfinite(f[k]) || !std::isfinite(f[m]) || (f[k] < 0.0) == (f[m] < 0.0)) continue;
      const double a0 = w * k;
      const Vec2 p = on_circle(root_in([&](double a) { return L.balance(on_circle(a)); }, a0, w, f[k], f[m], L.ftol));
      const double along = ((p.x - c.x) * dir.x + (p.y - c.y) * dir.y) / r;
      if (along <= best || std::abs(L.balance(p)) > kJump * L.ftol || !sees(c, p)) continue;
      best = along;
      out = p;
    }
    return best > -0.9;
  }

  bool outside_frame(Vec2 p) const {
    const GridSpec& g = L.grid;
    return p.x < g.centre_x(0) || p.x > g.centre_x(g.width - 1) || p.y > g.centre_y(0) ||
           p.y < g.centre_y(g.height - 1);
  }

  // Where the locus between c (inside the frame) and r (outside) meets the frame: the point
  // where the chord leaves it, moved along the frame onto the level (within a step).
  Vec2 onto_frame(Vec2 c, Vec2 r) const {
    const GridSpec& g = L.grid;
    const double x0 = g.centre_x(0), x1 = g.centre_x(g.width - 1), y0 = g.centre_y(g.height - 1), y1 = g.centre_y(0);
    double t = 1.0;
    bool vertical = false;
    auto cut = [&](double from, double to, double edge, bool v) {
      if ((to - edge) * (from - edge) < 0.0 || to == edge) {
        const double u = (edge - from) / (to - from);
        if (u < t) {
          t = u;
          vertical = v;
        }
      }
    };
    cut(c.x, r.x, x0, true);
    cut(c.x, r.x, x1, true);
    cut(c.y, r.y, y0, false);
    cut(c.y, r.y, y1, false);
    Vec2 x = lerp(c, r, t);
    // (Exactly on the frame, as extraction's line ends are.)
    if (vertical)
      x.x = std::abs(x.x - x0) < std::abs(x.x - x1) ? x0 : x1;
    else
      x.y = std::abs(x.y - y0) < std::abs(x.y - y1) ? y0 : y1;
    const Vec2 along = vertical ? Vec2{0.0, step} : Vec2{step, 0.0};
    Vec2 on;
    if (root(Vec2{x.x - along.x, x.y - along.y}, Vec2{x.x + along.x, x.y + along.y}, on)) return on;
    return x;
  }

  // Where the locus from c (at sea, within two steps of land) meets the coast: the nearest point
  // of a barrier edge within two steps, approached from c's side, where the balance is 0, that c
  // sees and that lies in the band (line_tools::onto_domain_edge, which searches a long coast edge
  // only near c); not the coast point the walk left (`left`, within a ten-thousandth of a cell).
  // (A walk from a coast across a sound narrower than two steps is nearer the point it left than
  // the coast ahead when its first step finds no root.)
  bool onto_coast(Vec2 c, Vec2& out) const {
    const double hair = 1e-4 * L.grid.res;
    return line_tools::onto_domain_edge(
        *L.metric, c, 2.0 * step, L.ftol, [this](Vec2 p) { return L.balance(p); },
        [this, hair](Vec2 p) {
          return L.in_band(p) && !(left && norm(Vec2{p.x - left->x, p.y - left->y}) <= hair);
        },
        out, nullptr, L.slope);
  }

  // Midpoints where a chord strays from the locus by more than the tolerance.
  void refine(Vec2 a, Vec2 b, int depth, std::vector<Vec2>& out) const {
    const Vec2 d{b.x - a.x, b.y - a.y};
    const double len = norm(d);
    const Vec2 mid = lerp(a, b, 0.5);
    if (!(len > 0.0)) return;
    const Vec2 n{-d.y / len, d.x / len};
    Vec2 m;
    const double reach = 0.5 * len;
    if (!root(Vec2{mid.x - reach * n.x, mid.y - reach * n.y}, Vec2{mid.x + reach * n.x, mid.y + reach * n.y}, m)) {
      // (No locus point across it within half its length: the chord is counted, not measured.)
      residual.add(std::numeric_limits<double>::quiet_NaN(), mid.x, mid.y, L.tol * L.per_crs);
      return;
    }
    const double off = norm(Vec2{m.x - mid.x, m.y - mid.y});
    if (!(off > L.tol) || depth + 1 >= kMaxDepth || !L.metric->open_between(a, m) || !L.metric->open_between(m, b)) {
      residual.add(off * L.per_crs, mid.x, mid.y, L.tol * L.per_crs);
      return;
    }
    ++residual.added;
    refine(a, m, depth + 1, out);
    out.push_back(m);
    refine(m, b, depth + 1, out);
  }

  // Walks the locus on from pts.back() (pts: the start, and the points found so far; with one
  // point, the first step goes along `dir0`): until `target`, the frame, a coast, out of the
  // band, or back at pts.front() where `closing` (a loop: once more than three steps away from
  // it, back within one and a half). Appends the points walked; returns how the walk ended.
  Stop walk(std::vector<Vec2>& pts, Vec2 dir0, const Vec2* target, bool closing, const std::vector<Vec2>& others = {},
            int* reached = nullptr, int64_t max_steps = -1, Vec2* beyond = nullptr) const {
    // The target, or else the first of `others`, within `reach` of p (-2: none; -1: the target).
    auto near_target = [&](Vec2 p, double reach) {
      if (target && norm(Vec2{p.x - target->x, p.y - target->y}) <= reach) return -1;
      for (size_t k = 0; k < others.size(); ++k)
        if (norm(Vec2{p.x - others[k].x, p.y - others[k].y}) <= reach) return static_cast<int>(k);
      return -2;
    };
    auto stop_at = [&](int k) {
      if (reached) *reached = k;
      return k < 0 ? *target : others[static_cast<size_t>(k)];
    };
    // A band is crossed in well under this many steps (its length over half a cell, with room).
    const auto limit = max_steps >= 0 ? max_steps : static_cast<int64_t>(8 * (L.grid.width + L.grid.height)) + 64;
    const Vec2 origin = pts.front();
    bool away = false;
    const double full_step = step;
    for (int64_t k = 0; k < limit; ++k) {
      const Vec2 c = pts.back();
      double room = std::numeric_limits<double>::infinity();
      if (L.clearance) {
        // Where the sides meet (see Level::clearance), the walk ends there.
        room = L.clearance(c);
        if (!std::isfinite(room)) return Stop::lost;
        if (!(room > L.meet)) return pts.size() < 2 ? Stop::lost : Stop::coast;
        Vec2 at;
        if (room < full_step && pts.size() >= 2 && L.meeting && L.meeting(c, at)) {
          const Vec2 d{c.x - pts[pts.size() - 2].x, c.y - pts[pts.size() - 2].y};
          if ((at.x - c.x) * d.x + (at.y - c.y) * d.y > 0.0 && L.metric->open_between(c, at)) {
            pts.push_back(at);
            return Stop::coast;
          }
        }
        step = std::min(full_step, 8.0 * room);
        across = 0.9 * room;
      }
      if (const int k = near_target(c, 1.5 * step); k > -2) {
        if (pts.size() > 2) pts.pop_back();
        pts.push_back(stop_at(k));
        return Stop::target;
      }
      const double from_origin = norm(Vec2{c.x - origin.x, c.y - origin.y});
      away = away || from_origin > 3.0 * step;
      if (closing && away && from_origin <= 1.5 * step) {
        pts.back() = origin;
        return Stop::closed;
      }
      Vec2 dir = dir0;
      if (pts.size() >= 2) {
        const Vec2 before = pts[pts.size() - 2];
        const double dl = norm(Vec2{c.x - before.x, c.y - before.y});
        dir = Vec2{(c.x - before.x) / dl, (c.y - before.y) / dl};
      }
      Vec2 r;
      bool found = next(c, dir, r);
      // In a channel (clearance given) a step that finds no locus or crosses land is tried again
      // shorter, down to half the way to the nearer side, before the coast is looked for.
      while (L.clearance && step > 0.5 * room && (!found || !L.metric->open_between(c, r))) {
        step = std::max(0.5 * room, 0.25 * step);
        found = next(c, dir, r);
      }
      if (!found) {
        // Heading into a coast, the steps shrink until none finds the level across it (the
        // points beyond lie on land): the coast's point where the balance is 0 ends it there.
        Vec2 at;
        if (!onto_coast(c, at)) return Stop::lost;
        pts.push_back(at);
        return Stop::coast;
      }
      if (outside_frame(r)) {
        pts.push_back(onto_frame(c, r));
        return Stop::frame;
      }
      if (!L.metric->open_between(c, r)) {
        // Land across the step: the coast's point where the balance is 0, seen from c.
        Vec2 at;
        if (!onto_coast(c, at)) return Stop::lost;
        pts.push_back(at);
        return Stop::coast;
      }
      if (!L.in_band(r)) {
        // Out of the band away from land: only where L0 meets L1, at the target.
        if (const int k = near_target(r, 3.0 * step); k > -2) {
          pts.push_back(stop_at(k));
          return Stop::target;
        }
        if (beyond) *beyond = r;
        return Stop::lost;
      }
      pts.push_back(r);
    }
    return Stop::lost;
  }

  // The walked points with their chords refined onto the locus.
  std::vector<Vec2> refined(const std::vector<Vec2>& pts) const {
    std::vector<Vec2> out{pts.front()};
    for (size_t i = 1; i < pts.size(); ++i) {
      refine(pts[i - 1], pts[i], 0, out);
      out.push_back(pts[i]);
    }
    return out;
  }

  Followed run(Vec2 start, const Vec2* target, const std::vector<Vec2>& others) const {
    std::vector<Vec2> pts{start};
    Vec2 p;
    if (!first(start, p)) return Followed{pts, Stop::lost};
    pts.push_back(p);
    int reached = -1;
    const Stop stop = walk(pts, Vec2{}, target, false, others, &reached);
    return Followed{refined(pts), stop, stop == Stop::target ? reached : -1};
  }

  Through through(Vec2 on) const {
    Through t;
    const Vec2 g = gradient(on);
    const double gn = norm(g);
    if (!(gn > 0.0) || !std::isfinite(gn)) return t;
    const Vec2 tangent{-g.y / gn, g.x / gn};
    std::vector<Vec2> ahead{on};
    t.last = walk(ahead, tangent, nullptr, true);
    if (t.last == Stop::closed) {
      t.first = Stop::closed;
      t.points = refined(ahead);
      return t;
    }
    std::vector<Vec2> behind{on};
    t.first = walk(behind, Vec2{-tangent.x, -tangent.y}, nullptr, false);
    std::reverse(behind.begin(), behind.end());
    behind.insert(behind.end(), ahead.begin() + 1, ahead.end());
    t.points = refined(behind);
    return t;
  }
};

}  // namespace

Followed follow_on(const Level& level, Vec2 from, Vec2 heading, double step, int64_t max_steps,
                   const std::vector<Vec2>& others, const Vec2* left) {
  LineResidual unused;  // (nothing is refined here)
  std::vector<Vec2> pts{from};
  int reached = -1;
  Vec2 beyond{std::numeric_limits<double>::quiet_NaN(), 0.0};
  Follower walker{level, unused, step};
  walker.left = left;
  const Stop stop = walker.walk(pts, heading, nullptr, false, others, &reached, max_steps, &beyond);
  Followed f{std::move(pts), stop, stop == Stop::target ? reached : -1};
  f.left_band = stop == Stop::lost && std::isfinite(beyond.x);
  f.beyond = beyond;
  return f;
}

Followed follow(const Level& level, Vec2 start, const Vec2* target, LineResidual& residual,
                const std::vector<Vec2>& others) {
  return Follower{level, residual, 0.5 * level.grid.res}.run(start, target, others);
}

Through follow_through(const Level& level, Vec2 on, LineResidual& residual, double step) {
  return Follower{level, residual, step > 0.0 ? step : 0.5 * level.grid.res}.through(on);
}

}  // namespace rv::locus_follow
