// complete_tripoints (boundary_stages.hpp): lines carried to the tripoints the cells do not show,
// and every tripoint given its three lines.
//
// Why: by sea, land hides cells. Where a tripoint's dual square has land centres, or one of its
// lines runs along a coast with land cells on one side and cells of one owner on the other, no two
// cells show that part of the boundary. A line's walk along its locus (follow_open_ends) then
// stops where a third owner comes nearer, in the open; and a tripoint found from its square may
// lack the line its hidden cells would have shown. Regions are bounded by these lines: one missing
// hands one owner's sea to another. Both are found from the locus itself, which every owner pair
// has whether or not a cell shows it.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <set>
#include <utility>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/line_tools.hpp"
#include "lines/locus_follow.hpp"

namespace rv::boundary_stages {

using namespace line_tools;

namespace {

// (Steps of an eighth of a cell, fewer in a sliver: as follow_open_ends' walks.)
constexpr int kPerCell = 8;
constexpr int64_t kMaxSteps = 8192;

// Where a walk may stop: an open end of a line of its two owners, or a tripoint of both lacking
// their line.
struct Target {
  Vec2 p;
  int64_t line = -1;  // an open end: the line, and whether its back end
  bool back = false;
  int64_t tripoint = -1;  // or a tripoint
};

class Completer {
 public:
  Completer(const BoundaryGrid& b, double max_distance, double per, std::vector<Tripoint>& tripoints,
            std::vector<BoundaryLine>& lines, BoundaryStats& stats)
      : b_(b), max_distance_(max_distance), per_(per), tripoints_(tripoints), lines_(lines), stats_(stats) {}

  // A line whose last chord to a tripoint leaves its owners' locus (along_locus) is taken off the
  // tripoint, its end left open for walk_open_ends: a square where two tripoints of the same owners
  // lie within a cell or two shows one of them, and every crossing near it was linked to that one.
  // (Not where the line would be left a single point.)
  void detach_off_locus() {
    for (BoundaryLine& line : lines_) {
      if (line.closed) continue;
      for (const bool back : {false, true}) {
        std::vector<BoundaryVertex>& v = line.vertices;
        if (v.size() < 3) break;
        const BoundaryVertex& end = back ? v.back() : v.front();
        const BoundaryVertex& next = back ? v[v.size() - 2] : v[1];
        if (!at_tripoint(tripoints_, end.p) || along_locus(b_, line.owner_a, line.owner_b, next.p, end.p)) continue;
        if (back)
          v.pop_back();
        else
          v.erase(v.begin());
        line.bows.clear();
        ++stats_.legs_detached;
      }
    }
  }

  // Each open end walked on along its locus: to a tripoint, one made where a third owner comes
  // nearer, or (as follow_open_ends) a coast or another open end.
  void walk_open_ends() {
    // (Passes until none walks an end not walked before: a line joined to another takes on its
    // far end.)
    std::set<std::pair<double, double>> walked;
    for (bool again = true; again;) {
      again = false;
      for (size_t n = 0; n < lines_.size(); ++n)
        for (const bool back : {false, true}) {
          BoundaryLine& line = lines_[n];
          if (line.closed || line.vertices.size() < 2 || line.vertices.front().p == line.vertices.back().p) break;
          const Vec2 end = back ? line.vertices.back().p : line.vertices.front().p;
          if (!open_end(back ? line.vertices.back() : line.vertices.front()) || !walked.insert({end.x, end.y}).second)
            continue;
          again = true;
          BoundaryLine grown = line;
          if (!back) std::reverse(grown.vertices.begin(), grown.vertices.end());
          const Vec2 before = grown.vertices[grown.vertices.size() - 2].p;
          const std::vector<Target> to = targets(line.owner_a, line.owner_b, static_cast<int64_t>(n), back);
          const locus_follow::Followed f =
              walk(line.owner_a, line.owner_b, end, Vec2{end.x - before.x, end.y - before.y}, to);
          // (A walk may leave the band at its first step: the end is then its last point in it. One
          // that runs along a line already drawn, the end's own line too -- turned back round a
          // boom's tip -- draws nothing new.)
          if (f.points.empty() || walk_runs_along(b_, lines_, f.points, line.owner_a, line.owner_b, -1) ||
              !extend(grown, f, to, static_cast<int64_t>(n)))
            continue;
          lines_[n] = std::move(grown);
          ++stats_.ends_followed;
        }
    }
  }

  // Each tripoint lacking the line of two of its owners given it: walked from the tripoint along
  // their locus, away from the third owner, to a coast, the frame, an open end of their line
  // (joined), another tripoint lacking it, or a tripoint made where a fourth owner comes nearer
  // (whose own missing lines are walked in turn).
  void walk_missing_legs() {
    // (Tripoints added while walking are appended: the index runs on to them.)
    for (size_t t = 0; t < tripoints_.size(); ++t)
      for (const auto& [i, k] : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}}) {
        const Tripoint tp = tripoints_[t];
        const int32_t lo = tp.owners[i], hi = tp.owners[k];
        if (!lacks(t, lo, hi) || on_centre_frame(b_.g, tp.p) || outside_frame(b_.g, tp.p)) continue;
        Vec2 from;
        if (!leg_start(tp, lo, hi, from)) continue;
        const std::vector<Target> to = targets(lo, hi, -1, false, static_cast<int64_t>(t));
        locus_follow::Followed f = walk(lo, hi, from, Vec2{from.x - tp.p.x, from.y - tp.p.y}, to);
        f.points.insert(f.points.begin(), tp.p);
        BoundaryLine line{lo, hi, false, {tripoint_vertex(tp, lo, hi)}, {}};
        if (walk_runs_along(b_, lines_, f.points, lo, hi, -1) || !extend(line, f, to, -1)) continue;
        lines_.push_back(std::move(line));
        ++stats_.legs_walked;
      }
  }

  // Lines joined into others were left empty.
  void drop_joined() {
    std::erase_if(lines_, [](const BoundaryLine& l) { return l.vertices.empty(); });
  }

 private:
  bool open_end(const BoundaryVertex& v) const { return open_line_end(b_, tripoints_, v); }

  bool has_pair(const Tripoint& t, int32_t lo, int32_t hi) const {
    return std::count(t.owners, t.owners + 3, lo) > 0 && std::count(t.owners, t.owners + 3, hi) > 0;
  }

  // Whether no line of owners lo and hi ends at tripoint t (closed lines aside).
  bool lacks(size_t t, int32_t lo, int32_t hi) const {
    const Vec2 p = tripoints_[t].p;
    return std::none_of(lines_.begin(), lines_.end(), [&](const BoundaryLine& l) {
      return !l.closed && !l.vertices.empty() && l.owner_a == lo && l.owner_b == hi &&
             (l.vertices.front().p == p || l.vertices.back().p == p);
    });
  }

  // The open ends of lo and hi's lines (line `own`'s end `own_back` aside: the walk's start; its
  // other end is the walk's own front, reaching which closes a ring) and the tripoints of both
  // lacking their line (`own_tripoint` aside).
  std::vector<Target> targets(int32_t lo, int32_t hi, int64_t own, bool own_back, int64_t own_tripoint = -1) const {
    std::vector<Target> out;
    for (size_t n = 0; n < lines_.size(); ++n) {
      const BoundaryLine& l = lines_[n];
      if (l.closed || l.vertices.size() < 2 || l.owner_a != lo || l.owner_b != hi) continue;
      for (const bool back : {false, true}) {
        if (back == own_back && static_cast<int64_t>(n) == own) continue;
        const BoundaryVertex& e = back ? l.vertices.back() : l.vertices.front();
        if (open_end(e)) out.push_back(Target{e.p, static_cast<int64_t>(n), back, -1});
      }
    }
    for (size_t t = 0; t < tripoints_.size(); ++t)
      if (static_cast<int64_t>(t) != own_tripoint && has_pair(tripoints_[t], lo, hi) && lacks(t, lo, hi))
        out.push_back(Target{tripoints_[t].p, -1, false, static_cast<int64_t>(t)});
    return out;
  }

  locus_follow::Followed walk(int32_t lo, int32_t hi, Vec2 from, Vec2 heading, const std::vector<Target>& to) const {
    std::vector<Vec2> stops;
    stops.reserve(to.size());
    for (const Target& t : to) stops.push_back(t.p);
    return locus_follow::follow_on(narrow_level(b_, lo, hi, per_), from, heading, b_.g.res / kPerCell, kMaxSteps,
                                   stops);
  }

  // Where the locus of lo and hi leaves tripoint tp on their side: the point a hundredth of a cell
  // from it where their costs are equal, no third owner nearer, in sight of it (false unless there
  // is exactly one such: a tripoint on a coast or in a tie has no single way out).
  bool leg_start(const Tripoint& tp, int32_t lo, int32_t hi, Vec2& out) const {
    const double r = 1e-2 * b_.g.res;
    auto at = [&](double a) { return Vec2{tp.p.x + r * std::cos(a), tp.p.y + r * std::sin(a)}; };
    auto f = [&](double a) {
      const Vec2 q = at(a);
      return b_.index.metric().in_domain(q) ? cost_gap(b_, lo, hi, q) : std::numeric_limits<double>::quiet_NaN();
    };
    constexpr int kSamples = 64;
    int found = 0;
    double a0 = 0.0, f0 = f(a0);
    for (int k = 1; k <= kSamples; ++k) {
      const double a1 = 2.0 * std::numbers::pi * k / kSamples, f1 = f(a1);
      if (std::isfinite(f0) && std::isfinite(f1) && (f0 <= 0.0) != (f1 <= 0.0)) {
        const Vec2 q = at(root_in(f, a0, a1 - a0, f0, f1, b_.ftol));
        OwnerIndex::Hit ha, hb;
        if (b_.index.metric().open_between(tp.p, q) && no_third_between(b_, lo, hi, q, ha, hb)) {
          out = q;
          ++found;
        }
      }
      a0 = a1;
      f0 = f1;
    }
    return found == 1;
  }

  // The tripoint where a walk of lo and hi's locus left their band between `last` and `beyond`
  // (the owner nearest there the third), solved and in sight of `last`: one already known of the
  // same owners within a thousandth of a cell, or a new one appended. -1 where none is found.
  int64_t tripoint_between(int32_t lo, int32_t hi, Vec2 last, Vec2 beyond) {
    const OwnerIndex::Hit h = b_.index.nearest(beyond);
    if (h.site == kNoSite) return -1;
    const int32_t x = b_.index.metric().seeds().site_owner(h.site);
    if (x == lo || x == hi) return -1;
    Tripoint t;
    if (!solve_tripoint(b_, {lo, hi, x}, lerp(last, beyond, 0.5), max_distance_, t) ||
        !b_.index.metric().open_between(last, t.p))
      return -1;
    for (size_t n = 0; n < tripoints_.size(); ++n) {
      const Tripoint& o = tripoints_[n];
      if (std::equal(o.owners, o.owners + 3, t.owners) && std::hypot(o.p.x - t.p.x, o.p.y - t.p.y) <= 1e-3 * b_.g.res)
        return static_cast<int64_t>(n);
    }
    tripoints_.push_back(t);
    stats_.max_residual = std::max(stats_.max_residual, t.residual);
    ++stats_.missing_tripoints_found;
    return static_cast<int64_t>(tripoints_.size()) - 1;
  }

  // `line` (its back end the walk's first point) carried on by walk f: to the coast or the frame,
  // a target of `to` (an open end's line appended and left empty; line `own` itself closed into
  // a ring), or the tripoint where it left the band. False where f ends none of these ways.
  bool extend(BoundaryLine& line, const locus_follow::Followed& f, const std::vector<Target>& to, int64_t own) {
    using locus_follow::Stop;
    const int32_t lo = line.owner_a, hi = line.owner_b;
    if ((f.stop == Stop::coast || f.stop == Stop::frame) && f.points.size() >= 2) {
      append_walked(b_, line, f.points);
      line.vertices.back().on_barrier = f.stop == Stop::coast;
      if (f.stop == Stop::coast) ++stats_.ends_on_barriers;
    } else if (f.stop == Stop::target && f.other >= 0) {
      const Target& t = to[static_cast<size_t>(f.other)];
      // Up to the point reached, which is its own vertex.
      append_walked(b_, line, std::vector<Vec2>(f.points.begin(), f.points.end() - 1));
      if (t.tripoint >= 0) {
        line.vertices.push_back(tripoint_vertex(tripoints_[static_cast<size_t>(t.tripoint)], lo, hi));
      } else if (t.line == own) {
        line.vertices.push_back(line.vertices.front());
        line.closed = true;
        ++stats_.ends_joined;
      } else {
        std::vector<BoundaryVertex>& o = lines_[static_cast<size_t>(t.line)].vertices;
        if (t.back)
          line.vertices.insert(line.vertices.end(), o.rbegin(), o.rend());
        else
          line.vertices.insert(line.vertices.end(), o.begin(), o.end());
        o.clear();
        ++stats_.ends_joined;
      }
    } else if (f.left_band && !f.points.empty()) {
      const int64_t t = tripoint_between(lo, hi, f.points.back(), f.beyond);
      if (t < 0) return false;
      append_walked(b_, line, f.points);
      line.vertices.push_back(tripoint_vertex(tripoints_[static_cast<size_t>(t)], lo, hi));
    } else {
      return false;
    }
    line.bows.clear();
    return true;
  }

  const BoundaryGrid& b_;
  double max_distance_, per_;
  std::vector<Tripoint>& tripoints_;
  std::vector<BoundaryLine>& lines_;
  BoundaryStats& stats_;
};

int64_t vertex_count(const std::vector<BoundaryLine>& lines) {
  int64_t n = 0;
  for (const BoundaryLine& l : lines) n += static_cast<int64_t>(l.vertices.size());
  return n;
}

}  // namespace

void complete_tripoints(const BoundaryGrid& b, double max_distance, double per, std::vector<Tripoint>& tripoints,
                        std::vector<BoundaryLine>& lines, BoundaryStats& stats) {
  // (As follow_open_ends: where a maximum distance or a reach ends the owned area, lines end on
  // its edge, which the walk does not know.)
  if (b.index.metric().straight() || std::isfinite(max_distance) || !std::isfinite(b.index.cost_slope())) return;
  const int64_t before = vertex_count(lines);
  Completer c(b, max_distance, per, tripoints, lines, stats);
  c.detach_off_locus();
  c.walk_open_ends();
  c.drop_joined();
  c.walk_missing_legs();
  c.drop_joined();
  stats.vertices += vertex_count(lines) - before;
}

}  // namespace rv::boundary_stages
