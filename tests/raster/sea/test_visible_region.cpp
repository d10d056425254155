// The region a point sees within a box (sea/visible_region.hpp) against the exact rule
// (Visibility::sees), point by point: random archipelagos whose whole-number corners make
// collinear and coincident cases often (islands that overlap and touch, a boom across them), seen
// from every barrier vertex in each of its wedges, from points at sea and from a port on a coast,
// planar and on the ellipsoid.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "random_archipelago.hpp"
#include "rv/field/error.hpp"
#include "rv/sea/geodesic_frame.hpp"
#include "rv/sea/visibility.hpp"
#include "sea/visible_region.hpp"

namespace rv {
namespace {

using sea::VisibleRegion;

// random_archipelago's port on a coast: the point site before its last (the coast as a line).
Vec2 coast_port(const SeedSet& seeds) { return seeds.sites()[seeds.sites().size() - 2].a; }

std::string ring_text(const VisibleRegion& region) {
  std::ostringstream out;
  out.precision(17);
  for (const Vec2 p : region.ring) out << "(" << p.x << ", " << p.y << ") ";
  return out.str();
}

struct Counts {
  int64_t seen = 0, hidden = 0, undecided = 0, regions = 0, land_wedges = 0, blurred = 0;
  void print(const char* reading) const {
    std::printf("%s: %lld regions, %lld land wedges, %lld blurred, %lld seen, %lld hidden, %lld undecided\n", reading,
                static_cast<long long>(regions), static_cast<long long>(land_wedges), static_cast<long long>(blurred),
                static_cast<long long>(seen), static_cast<long long>(hidden), static_cast<long long>(undecided));
  }
};

// Every sample of the box farther than the margin from the ring's boundary: inside exactly when
// the exact rule sees it. Samples: random points, and the box's whole-number lattice (in the
// archipelago's own units, mapped by `to`), where alignments with vertices are common.
void check_region(const Visibility& vis, const Visibility::Place& from, Vec2 lo, Vec2 hi,
                  const std::vector<sea::EdgeIndex::Segment>& edges, std::mt19937_64& rng,
                  const std::vector<Vec2>& lattice, Counts& counts) {
  const VisibleRegion region = sea::visible_region(vis, from, lo, hi, edges);
  if (region.blurred) {
    ++counts.blurred;
    return;
  }
  if (region.ring.empty()) {
    ++counts.land_wedges;
    return;
  }
  ++counts.regions;
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y);
  std::vector<Vec2> samples = lattice;
  for (int k = 0; k < 300; ++k) samples.push_back({ux(rng), uy(rng)});
  // And just beyond the margin on both sides of each of the ring's edges, at its middle: where
  // the margin's claim is tightest (on the ellipsoid, where paths and edges bend).
  for (size_t i = 0, n = region.ring.size(); i < n; ++i) {
    const Vec2 a = region.ring[i], b = region.ring[(i + 1) % n];
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    if (len < 4.0 * region.margin) continue;
    const double off = 1.5 * region.margin / len;
    for (const double side : {-1.0, 1.0})
      samples.push_back({(a.x + b.x) / 2 - side * off * (b.y - a.y), (a.y + b.y) / 2 + side * off * (b.x - a.x)});
  }
  for (const Vec2 x : samples) {
    if (!(lo.x <= x.x && x.x <= hi.x && lo.y <= x.y && x.y <= hi.y)) continue;
    if (region.boundary_distance(x) <= region.margin) {
      ++counts.undecided;
      continue;
    }
    const bool seen = vis.sees(from, Visibility::Place{x});
    ASSERT_EQ(region.contains(x), seen) << "from (" << from.at.x << ", " << from.at.y << ") vertex " << from.vertex
                                        << " wedge " << from.wedge << " to (" << x.x << ", " << x.y << ") at "
                                        << region.boundary_distance(x) << " from the boundary (margin " << region.margin
                                        << "), box (" << lo.x << ", " << lo.y << ") - (" << hi.x << ", " << hi.y
                                        << "), ring " << ring_text(region);
    ++(seen ? counts.seen : counts.hidden);
  }
}

// Every vertex in each of its wedges, points at sea, and `port` (a point on a coast), over the
// whole layout's box and over a box of a random size round each point.
void check_layout(const Visibility& vis, Vec2 port, Vec2 lo, Vec2 hi, const std::vector<Vec2>& lattice,
                  std::mt19937_64& rng, Counts& counts) {
  const auto edges = sea::barrier_edges(vis);
  std::uniform_real_distribution<double> share(0.05, 0.5);
  auto around = [&](const Visibility::Place& from) {
    check_region(vis, from, lo, hi, edges, rng, lattice, counts);
    const double r = share(rng) * (hi.x - lo.x);
    check_region(vis, from, {from.at.x - r, from.at.y - r}, {from.at.x + r, from.at.y + r}, edges, rng, lattice,
                 counts);
  };
  for (int32_t v = 0; v < vis.vertex_count(); ++v) {
    const Vec2 at = vis.vertex(v);
    if (!(lo.x < at.x && at.x < hi.x && lo.y < at.y && at.y < hi.y)) continue;
    for (int w = 0; w < vis.vertex_star(v).wedges(); ++w) {
      around(vis.at_vertex(v, w));
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
  std::uniform_real_distribution<double> ux(lo.x, hi.x), uy(lo.y, hi.y);
  for (int k = 0; k < 6; ++k) {
    const Vec2 p{ux(rng), uy(rng)};
    if (vis.classify(p) != Visibility::Ground::open_sea) continue;
    Visibility::Place at{p};
    at.open = true;
    around(at);
    if (::testing::Test::HasFatalFailure()) return;
  }
  // The port on a coast (a point inside an edge: two wedges, the land one giving no ring).
  const Visibility::Star star = vis.star_at(port);
  for (int w = 0; w < star.wedges(); ++w) {
    Visibility::Place at{port};
    at.wedge = w;
    if (lo.x < port.x && port.x < hi.x && lo.y < port.y && port.y < hi.y) around(at);
  }
}

TEST(VisibleRegion, AgreesWithTheExactRuleAwayFromItsBoundaryPlanar) {
  Counts counts;
  std::vector<Vec2> lattice;
  for (int x = -2; x <= 42; ++x)
    for (int y = -2; y <= 42; ++y) lattice.push_back({double(x), double(y)});
  for (int round = 0; round < 30; ++round) {
    std::mt19937_64 rng(7000 + round);
    const auto layout = rv::test::random_archipelago(rng, round);
    const Visibility vis(layout.barriers);
    check_layout(vis, coast_port(layout.seeds), {-2.5, -2.5}, {42.5, 42.5}, lattice, rng, counts);
    if (HasFatalFailure()) return;
  }
  // Not vacuous: many regions, both answers often, few samples left to the exact predicates.
  EXPECT_GT(counts.regions, 2000);
  EXPECT_GT(counts.land_wedges, 500);
  EXPECT_GT(counts.seen, 200000);
  EXPECT_GT(counts.hidden, 200000);
  EXPECT_LT(counts.undecided, (counts.seen + counts.hidden) / 50);
  EXPECT_EQ(counts.blurred, 0);  // whole-number corners: no vertex a rounding off another's edge
  counts.print("planar");
}

TEST(VisibleRegion, AgreesWithTheExactRuleAwayFromItsBoundaryOnTheEllipsoid) {
  MetricSpec wgs84;
  wgs84.kind = MetricSpec::geodesic;
  // The 40-unit layouts over 0.8 degrees of longitude and 0.5 of latitude at 55 N.
  const auto frame = std::make_shared<const GeodesicFrame>(wgs84, 11.9, 54.9, 12.9, 55.6);
  auto to_ll = [](Vec2 v) { return Vec2{12.0 + v.x * 0.02, 55.0 + v.y * 0.0125}; };
  std::vector<Vec2> lattice;
  for (int x = 0; x <= 40; ++x)
    for (int y = 0; y <= 40; ++y) lattice.push_back(frame->forward(to_ll({double(x), double(y)})));
  Counts counts;
  for (int round = 0; round < 6; ++round) {
    std::mt19937_64 rng(7100 + round);
    const auto ll = rv::test::random_archipelago(rng, round, to_ll);
    const Visibility vis(ll.barriers.mapped([&](Vec2 p) { return frame->forward(p); }), true, frame);
    // The layout's box in the frame's plane (its images of meridians and parallels lean).
    Vec2 lo{1e300, 1e300}, hi{-1e300, -1e300};
    for (const Vec2 c : {Vec2{11.95, 54.95}, Vec2{12.85, 54.95}, Vec2{11.95, 55.55}, Vec2{12.85, 55.55}}) {
      const Vec2 p = frame->forward(c);
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y)};
    }
    check_layout(vis, frame->forward(coast_port(ll.seeds)), lo, hi, lattice, rng, counts);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(counts.regions, 400);
  EXPECT_GT(counts.seen, 30000);
  EXPECT_GT(counts.hidden, 30000);
  EXPECT_LT(counts.undecided, (counts.seen + counts.hidden) / 50);
  // Corners computed as x + 0.6 w may land a rounding off another island's corner or edge: the
  // points there are left to the exact predicates, and they are few.
  EXPECT_LT(counts.blurred, counts.regions / 20);
  counts.print("ellipsoid");
}

TEST(VisibleRegion, AWallsShadowIsTheClosedForm) {
  // A wall from (0, 1) to (2, 1) seen from the origin in a box of side 10: hidden exactly in the
  // wedge through the wall's ends beyond it; the ring has the box's corners and the wall's ends.
  Barriers b;
  b.add_line(std::vector<Vec2>{{0.0, 1.0}, {2.0, 1.0}}, "wall");
  const Visibility vis(b);
  Visibility::Place o{{0.0, 0.0}};
  o.open = true;
  const auto region = sea::visible_region(vis, o, {-5.0, -5.0}, {5.0, 5.0}, sea::barrier_edges(vis));
  for (const Vec2 x : std::vector<Vec2>{{1.0, 3.0}, {0.2, 4.0}, {2.4, 4.9}}) EXPECT_FALSE(region.contains(x));
  for (const Vec2 x : std::vector<Vec2>{{1.0, 0.5}, {-0.2, 4.0}, {4.0, 1.9}, {-4.0, -4.0}, {4.9, 2.0}})
    EXPECT_TRUE(region.contains(x));
  auto has = [&](Vec2 p) {
    return std::any_of(region.ring.begin(), region.ring.end(),
                       [&](Vec2 q) { return std::hypot(q.x - p.x, q.y - p.y) < 1e-12; });
  };
  EXPECT_TRUE(has({0.0, 1.0}));
  EXPECT_TRUE(has({2.0, 1.0}));
  EXPECT_TRUE(has({0.0, 5.0}));
  EXPECT_TRUE(has({5.0, 2.5}));
  EXPECT_TRUE(has({-5.0, -5.0}));
  // Three of the box's corners (the fourth is in the shadow), the wall's ends, and where the
  // shadow's sides meet the box.
  EXPECT_EQ(region.ring.size(), 7u);
}

// A coast that goes on all but straight past the end of a vertex's wedge side: the next edge's
// far end a rounding off the side's line, so that its angle from the side may come out a
// rounding below a whole turn while the orientation puts it a rounding above none. That piece
// was once taken as spanning the whole turn, and the ring collapsed onto the side's end (found by
// near_bends' far sight on an archipelago on the ellipsoid). Random directions and offsets of a
// few units in the last place, every wedge of the vertex, the contract checked.
TEST(VisibleRegion, AnEdgeAllButAlongAWedgesSideSpansNoWholeTurn) {
  std::mt19937_64 rng(2076);
  std::uniform_real_distribution<double> angle(0.0, 2.0 * std::numbers::pi), ulps(-4.0, 4.0);
  Counts counts;
  for (int trial = 0; trial < 400; ++trial) {
    const double t = angle(rng), c = std::cos(t), s = std::sin(t);
    const Vec2 o{1000.0 * c + 20000.0, 1000.0 * s - 20000.0};
    const Vec2 p{o.x + 5000.0 * c, o.y + 5000.0 * s};
    // Beyond p on the line from o, moved across it by a few units in the last place.
    const double off = ulps(rng) * 4e-12;
    const Vec2 x{p.x + 2000.0 * c - off * s, p.y + 2000.0 * s + off * c};
    // Land on one side of o-p-x (either, by the trial's parity).
    const double side = trial % 2 == 0 ? 1.0 : -1.0;
    const Vec2 x2{x.x - side * 3000.0 * s, x.y + side * 3000.0 * c},
        o2{o.x - side * 3000.0 * s, o.y + side * 3000.0 * c};
    Barriers b;
    b.add_polygon({{o, p, x, x2, o2}}, "coast");
    const Visibility vis(b);
    const int32_t v = vis.vertex_at(o);
    ASSERT_GE(v, 0);
    const auto edges = sea::barrier_edges(vis);
    for (int w = 0; w < vis.vertex_star(v).wedges(); ++w) {
      check_region(vis, vis.at_vertex(v, w), {o.x - 6000.0, o.y - 6000.0}, {o.x + 6000.0, o.y + 6000.0}, edges, rng, {},
                   counts);
      if (HasFatalFailure()) return;
    }
  }
  counts.print("edges all but along a side");
  EXPECT_GE(counts.regions, 400);
  EXPECT_GT(counts.seen, 50000);
}

TEST(VisibleRegion, RefusesABoxWithoutThePointAndAnUnchosenWedge) {
  Barriers b;
  b.add_line(std::vector<Vec2>{{0.0, 1.0}, {2.0, 1.0}, {2.0, 3.0}}, "wall");
  const Visibility vis(b);
  const auto edges = sea::barrier_edges(vis);
  Visibility::Place o{{0.0, 0.0}};
  o.open = true;
  EXPECT_THROW(sea::visible_region(vis, o, {1.0, 1.0}, {5.0, 5.0}, edges), Error);
  const int32_t bend = vis.vertex_at({2.0, 1.0});
  ASSERT_GE(bend, 0);
  EXPECT_THROW(sea::visible_region(vis, vis.at_vertex(bend, -1), {-5.0, -5.0}, {5.0, 5.0}, edges), Error);
  EXPECT_FALSE(sea::visible_region(vis, vis.at_vertex(bend, 0), {-5.0, -5.0}, {5.0, 5.0}, edges).ring.empty());
}

}  // namespace
}  // namespace rv
