// Visibility among barriers: the exact orientation predicate, land and sea for points, and which
// straight paths are free (touching, running along, wedges at lines and at touching polygons).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>

#include "rv/sea/geodesic_frame.hpp"
#include "rv/sea/visibility.hpp"
#include "sea/orient.hpp"

namespace rv {
namespace {

using Place = Visibility::Place;

// The exact sign of the determinant for coordinates in [1, 4): multiples of 2^-52 there, so
// scaled by 2^52 they are integers below 2^54 whose products fit 128 bits.
__extension__ typedef __int128 Int128;
int integer_orient(Vec2 a, Vec2 b, Vec2 c) {
  auto i = [](double v) { return static_cast<Int128>(std::ldexp(v, 52)); };
  const Int128 det = (i(b.x) - i(a.x)) * (i(c.y) - i(a.y)) - (i(b.y) - i(a.y)) * (i(c.x) - i(a.x));
  return det > 0 ? 1 : (det < 0 ? -1 : 0);
}

TEST(Orient, ExactOnNearlyCollinearPoints) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(1.0, 2.0);
  int zeros = 0, naive_wrong = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec2 a{u(rng), u(rng)}, b{u(rng), u(rng)};
    const double t = u(rng) - 1.0;
    // A point on the line a-b rounded, then nudged by a few units in the last place.
    Vec2 c{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
    const int nudge = static_cast<int>(rng() % 7) - 3;
    for (int k = 0; k < std::abs(nudge); ++k) c.y = std::nextafter(c.y, nudge > 0 ? 4.0 : 0.0);
    const int want = integer_orient(a, b, c);
    ASSERT_EQ(sea::orient(a, b, c), want) << i;
    ASSERT_EQ(sea::orient(b, c, a), want) << i;  // cyclic
    ASSERT_EQ(sea::orient(b, a, c), -want) << i;
    zeros += want == 0;
    const double naive = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    naive_wrong += (naive > 0) - (naive < 0) != want;
  }
  // The cases are hard enough that plain floating point gets some wrong.
  EXPECT_GT(naive_wrong, 100);
  // Exactly collinear dyadic triples (a, a + d, a + 2d, all exact): zero both ways.
  for (int i = 0; i < 1000; ++i) {
    const auto k = [&] { return static_cast<double>(rng() % 512) / 1024.0; };
    const Vec2 a{1 + k(), 1 + k()}, d{k(), k()};
    const Vec2 b{a.x + d.x, a.y + d.y}, c{a.x + 2 * d.x, a.y + 2 * d.y};
    ASSERT_EQ(integer_orient(a, b, c), 0);
    ASSERT_EQ(sea::orient(a, b, c), 0);
    ASSERT_EQ(sea::orient(c, a, b), 0);
    ++zeros;
  }
  // Exactly collinear in binary: zero.
  EXPECT_EQ(sea::orient({0.5, 0.5}, {12, 12}, {24.25, 24.25}), 0);
  EXPECT_EQ(sea::orient({0, 0}, {1, 0}, {5, 1e-300}), 1);
  EXPECT_EQ(sea::orient({0, 0}, {1, 0}, {5, -1e-300}), -1);
}

Barriers square_island(double x0, double y0, double x1, double y1) {
  Barriers b;
  b.add_polygon({{{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}}, "island");
  return b;
}

bool sees(const Visibility& v, Vec2 a, Vec2 b) { return v.sees(Place{a}, Place{b}); }

TEST(Visibility, SquareIslandBlocksTouchesAndRunsAlong) {
  const Visibility v(square_island(2, 2, 4, 4));
  EXPECT_FALSE(sees(v, {0, 3}, {6, 3}));    // through
  EXPECT_TRUE(sees(v, {0, 4}, {6, 4}));     // along the top edge
  EXPECT_TRUE(sees(v, {0, 5}, {6, 5}));     // past
  EXPECT_TRUE(sees(v, {3, 5}, {5, 3}));     // grazing the corner (4, 4)
  EXPECT_FALSE(sees(v, {5, 5}, {3, 3}));    // into land through the corner
  EXPECT_TRUE(sees(v, {5, 5}, {3, 4}));     // ends on the top edge, from above
  EXPECT_TRUE(sees(v, {5, 5}, {4, 4}));     // ends at the corner
  EXPECT_TRUE(sees(v, {3, 6}, {3, 4}));     // ends on the edge
  EXPECT_FALSE(sees(v, {3, 6}, {3, 3.5}));  // ends inside
  EXPECT_TRUE(v.on_land({3, 3}));
  EXPECT_FALSE(v.on_land({3, 4}));  // the coast is sea
  EXPECT_FALSE(v.on_land({4, 4}));
  EXPECT_FALSE(v.on_land({5, 5}));
  // Its corners: one sea wedge each.
  ASSERT_EQ(v.vertex_count(), 4);
  for (int32_t i = 0; i < 4; ++i) {
    const auto& s = v.vertex_star(i);
    EXPECT_EQ(s.wedges(), 2);
    EXPECT_EQ(s.sea[0] + s.sea[1], 1);
  }
}

TEST(Visibility, HoleIsSeaAndClosed) {
  Barriers b;
  b.add_polygon({{{0, 0}, {10, 0}, {10, 10}, {0, 10}}, {{3, 3}, {7, 3}, {7, 7}, {3, 7}}}, "atoll");
  const Visibility v(b);
  EXPECT_FALSE(v.on_land({5, 5}));
  EXPECT_TRUE(v.on_land({1, 1}));
  EXPECT_TRUE(sees(v, {4, 4}, {6, 6}));
  EXPECT_TRUE(sees(v, {3, 5}, {7, 5}));  // across the lagoon from coast to coast
  EXPECT_FALSE(sees(v, {5, 5}, {12, 5}));
}

TEST(Visibility, PolygonsMeetingAtACornerCloseThePassage) {
  Barriers b;
  b.add_polygon({{{0, 0}, {2, 0}, {2, 2}, {0, 2}}}, "sw");
  b.add_polygon({{{2, 2}, {4, 2}, {4, 4}, {2, 4}}}, "ne");
  const Visibility v(b);
  EXPECT_FALSE(sees(v, {0, 4}, {4, 0}));  // through the corner where they meet
  EXPECT_TRUE(sees(v, {0, 4}, {2, 2}));   // to it
  EXPECT_TRUE(sees(v, {4, 0}, {2, 2}));
  const int32_t corner = v.vertex_at({2, 2});
  ASSERT_GE(corner, 0);
  const auto& s = v.vertex_star(corner);
  EXPECT_EQ(s.wedges(), 4);
  EXPECT_EQ(s.sea[0] + s.sea[1] + s.sea[2] + s.sea[3], 2);
  // A path may arrive in one wedge and not leave by the other.
  const int nw = s.wedge_towards({0, 4}, true), se = s.wedge_towards({4, 0}, true);
  EXPECT_NE(nw, se);
  EXPECT_TRUE(v.sees(Place{{0, 4}}, v.at_vertex(corner, nw)));
  EXPECT_FALSE(v.sees(Place{{0, 4}}, v.at_vertex(corner, se)));
}

TEST(Visibility, SharedBorderIsLand) {
  Barriers b;
  b.add_polygon({{{0, 0}, {2, 0}, {2, 2}, {0, 2}}}, "west");
  b.add_polygon({{{2, 0}, {4, 0}, {4, 2}, {2, 2}}}, "east");
  const Visibility v(b);
  EXPECT_TRUE(v.on_land({2, 1}));   // on the border, land both sides
  EXPECT_FALSE(v.on_land({2, 0}));  // the coast where the border meets the sea
  EXPECT_FALSE(v.on_land({1, 0}));
  EXPECT_FALSE(sees(v, {2, -1}, {2, 3}));  // along the border
  EXPECT_FALSE(sees(v, {1, -1}, {3, 1}));  // into the land at the border's end
  EXPECT_TRUE(sees(v, {-1, 0}, {5, 0}));   // along the common coast
  EXPECT_TRUE(sees(v, {2, -1}, {2, 0}));
}

TEST(Visibility, LinesAreCrossedNowhere) {
  Barriers b;
  b.add_line(std::vector<Vec2>{{0, 1}, {2, 0}, {4, 1}}, "boom");
  const Visibility v(b);
  EXPECT_FALSE(sees(v, {1, -1}, {1, 2}));  // through an edge
  EXPECT_FALSE(sees(v, {2, -1}, {2, 1}));  // through the inner vertex
  EXPECT_TRUE(sees(v, {1, -1}, {3, -1}));
  EXPECT_TRUE(sees(v, {-1, 1}, {5, 1}));   // touching both ends
  EXPECT_TRUE(sees(v, {-1, 2}, {1, -1}));  // past the end (0, 1)
  EXPECT_FALSE(v.on_land({2, 0}));
  // The inner vertex has a wedge per side, the ends one each.
  EXPECT_EQ(v.vertex_star(v.vertex_at({2, 0})).wedges(), 2);
  EXPECT_EQ(v.vertex_star(v.vertex_at({0, 1})).wedges(), 1);
  // A path bending at the inner vertex stays on its side.
  const auto& s = v.vertex_star(v.vertex_at({2, 0}));
  const int below = s.wedge_towards({2, -1}, true), above = s.wedge_towards({2, 1}, true);
  EXPECT_NE(below, above);
  EXPECT_TRUE(v.sees(Place{{2, -1}}, v.at_vertex(v.vertex_at({2, 0}), below)));
  EXPECT_FALSE(v.sees(Place{{2, -1}}, v.at_vertex(v.vertex_at({2, 0}), above)));
}

TEST(Visibility, RunningAlongALineKeepsOneSide) {
  Barriers crossing, touching;
  crossing.add_line(std::vector<Vec2>{{0, 2}, {1, 0}, {3, 0}, {4, -2}}, "crossing");
  touching.add_line(std::vector<Vec2>{{0, 2}, {1, 0}, {3, 0}, {4, 2}}, "touching");
  EXPECT_FALSE(sees(Visibility(crossing), {-1, 0}, {5, 0}));
  EXPECT_TRUE(sees(Visibility(touching), {-1, 0}, {5, 0}));
  EXPECT_TRUE(sees(Visibility(crossing), {1, 0}, {3, 0}));  // along its middle edge, end to end
}

TEST(Visibility, StraitNarrowerThanACellIsOpen) {
  Barriers b;
  b.add_polygon({{{0, 0}, {4.9, 0}, {4.9, 10}, {0, 10}}}, "west");
  b.add_polygon({{{5.1, 0}, {10, 0}, {10, 10}, {5.1, 10}}}, "east");
  const Visibility v(b);
  EXPECT_TRUE(sees(v, {5, -3}, {5, 13}));
  EXPECT_TRUE(sees(v, {4.95, -1}, {5.05, 11}));
  EXPECT_FALSE(sees(v, {4.5, -1}, {5.5, 11}));
}

TEST(Visibility, ComputedEndOnTheCoastIsTakenAsOnIt) {
  // A coast edge that is not axis-parallel: the foot of a perpendicular on it is rounded.
  Barriers b;
  b.add_polygon({{{0.1, 0.3}, {7.3, 2.9}, {3.3, 9.7}}}, "land");
  const Visibility v(b);
  const Vec2 a{0.1, 0.3}, e{7.3, 2.9};
  // The edge's ends, from their sea wedges (a path along the coast to a point on it: to where a
  // seed's edge crosses it, say).
  auto sea_side = [&](Vec2 corner) {
    const int32_t id = v.vertex_at(corner);
    const Visibility::Star& star = v.vertex_star(id);
    for (int k = 0; k < star.wedges(); ++k)
      if (star.sea[static_cast<size_t>(k)]) return v.at_vertex(id, k);
    return Place{corner};
  };
  const Place from_a = sea_side(a), from_e = sea_side(e);
  int rounded_inland = 0;
  for (int i = 1; i < 200; ++i) {
    const double t = i / 200.0;
    const Vec2 foot{a.x + t * (e.x - a.x), a.y + t * (e.y - a.y)};
    // The sea side of the edge a -> e is its right: below.
    const Vec2 from{foot.x + 0.8 * (e.y - a.y), foot.y - 0.8 * (e.x - a.x)};
    Place end{foot};
    end.exact = false;
    EXPECT_TRUE(v.sees(Place{from}, end)) << t;
    EXPECT_TRUE(v.sees(from_a, end)) << t;
    EXPECT_TRUE(v.sees(from_e, end)) << t;
    // (Taken as on the edge, not beyond it: the third corner's wedge is not the way.)
    EXPECT_FALSE(v.sees(sea_side({3.3, 9.7}), end)) << t;
    rounded_inland += sea::orient(a, e, foot) > 0;
  }
  EXPECT_GT(rounded_inland, 0);  // some feet did round inland: the allowance is exercised
}

// Random barriers: visibility is symmetric, and a free path's points are all sea.
TEST(Visibility, SymmetricAndSeaAlongFreePaths) {
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<int> coord(0, 20);
  for (int round = 0; round < 30; ++round) {
    Barriers b;
    for (int k = 0; k < 3; ++k) {
      const double x = coord(rng), y = coord(rng);
      b.add_polygon({{{x, y}, {x + 1 + coord(rng) % 4, y}, {x + coord(rng) % 3, y + 1 + coord(rng) % 4}}}, "tri");
    }
    b.add_line(std::vector<Vec2>{{double(coord(rng)), double(coord(rng))},
                                 {double(coord(rng)), double(coord(rng))},
                                 {double(coord(rng)), double(coord(rng))}},
               "line");
    const Visibility v(b);
    for (int i = 0; i < 200; ++i) {
      // Integer points hit vertices and run along edges often.
      const Vec2 p{double(coord(rng)), double(coord(rng))}, q{double(coord(rng)), double(coord(rng))};
      if (v.on_land(p) || v.on_land(q)) continue;
      const bool pq = sees(v, p, q);
      ASSERT_EQ(pq, sees(v, q, p)) << round << " " << i;
      if (!pq) continue;
      for (int k = 1; k < 16; ++k) {
        const Vec2 m{p.x + (q.x - p.x) * k / 16.0, p.y + (q.y - p.y) * k / 16.0};
        ASSERT_FALSE(v.on_land(m)) << round << " " << i << " " << k;
      }
    }
  }
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// The index answers as the full scan does: stars of every vertex, land, and free paths, on
// random islands, holes and lines, near the origin and at UTM-like coordinates.
TEST(Visibility, IndexAnswersAsTheFullScan) {
  std::mt19937_64 rng(23);
  for (const Vec2 offset : {Vec2{0, 0}, Vec2{512345.25, 6123456.5}}) {
    std::uniform_int_distribution<int> coord(0, 60);
    Barriers b;
    for (int k = 0; k < 25; ++k) {
      const double x = offset.x + coord(rng), y = offset.y + coord(rng);
      const double w = 1 + coord(rng) % 8, h = 1 + coord(rng) % 8;
      std::vector<Ring> rings{{{x, y}, {x + w, y}, {x + w, y + h}, {x, y + h}}};
      if (w > 3 && h > 3) rings.push_back({{x + 1, y + 1}, {x + 2, y + 1}, {x + 2, y + 2}, {x + 1, y + 2}});
      b.add_polygon(rings, "island");
    }
    for (int k = 0; k < 8; ++k)
      b.add_line(std::vector<Vec2>{{offset.x + coord(rng), offset.y + coord(rng)},
                                   {offset.x + coord(rng), offset.y + coord(rng)},
                                   {offset.x + coord(rng), offset.y + coord(rng)}},
                 "line");
    const Visibility indexed(b), full(b, false);
    ASSERT_EQ(indexed.vertex_count(), full.vertex_count());
    for (int32_t v = 0; v < full.vertex_count(); ++v) {
      ASSERT_EQ(indexed.vertex(v), full.vertex(v));
      ASSERT_EQ(indexed.vertex_star(v).rays, full.vertex_star(v).rays);
      ASSERT_EQ(indexed.vertex_star(v).sea, full.vertex_star(v).sea);
    }
    int64_t free_paths = 0, blocked = 0;
    for (int i = 0; i < 4000; ++i) {
      const Vec2 p{offset.x + coord(rng) + (i % 3) * 0.5, offset.y + coord(rng)};
      const Vec2 q{offset.x + coord(rng), offset.y + coord(rng) + (i % 5) * 0.25};
      ASSERT_EQ(indexed.on_land(p), full.on_land(p));
      ASSERT_EQ(indexed.classify(q) == Visibility::Ground::land, full.on_land(q));
      if (full.on_land(p) || full.on_land(q)) continue;
      Visibility::Place from{p};
      from.open = full.classify(p) == Visibility::Ground::open_sea;
      const bool want = full.sees(Place{p}, Place{q});
      ASSERT_EQ(indexed.sees(from, Place{q}), want) << i;
      ASSERT_EQ(indexed.sees(Place{p}, Place{q}), want) << i;
      (want ? free_paths : blocked) += 1;
    }
    EXPECT_GT(free_paths, 100);
    EXPECT_GT(blocked, 200);
  }
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// A row at a time answers as a point at a time, also where centres fall on edges, vertices,
// edges along the row, shared borders and lines.
TEST(Visibility, RowsClassifyAsPoints) {
  std::mt19937_64 rng(41);
  std::uniform_int_distribution<int> coord(0, 30);
  for (int round = 0; round < 8; ++round) {
    Barriers b;
    for (int k = 0; k < 12; ++k) {
      const double x = coord(rng), y = coord(rng), w = 1 + coord(rng) % 6, h = 1 + coord(rng) % 6;
      std::vector<Ring> rings{{{x, y}, {x + w, y}, {x + w, y + h}, {x + (k % 3), y + h + (k % 2)}}};
      if (w > 3 && h > 3) rings.push_back({{x + 1, y + 1}, {x + 2, y + 1}, {x + 2, y + 2}});
      b.add_polygon(rings, "island");
    }
    b.add_polygon({{{2, 2}, {4, 2}, {4, 4}, {2, 4}}}, "west");  // a shared border
    b.add_polygon({{{4, 2}, {6, 2}, {6, 4}, {4, 4}}}, "east");
    b.add_line(std::vector<Vec2>{{double(coord(rng)), double(coord(rng))}, {double(coord(rng)), 7.0}}, "line");
    const Visibility v(b);
    int64_t on = 0, land = 0;
    for (double y = -0.5; y <= 32; y += 0.5) {
      std::vector<double> xs;
      for (double x = -1; x <= 32; x += 0.5) xs.push_back(x);
      std::vector<Visibility::Ground> row(xs.size());
      v.classify_row(y, xs.data(), static_cast<int64_t>(xs.size()), row.data());
      for (size_t i = 0; i < xs.size(); ++i) {
        const Visibility::Ground want = v.classify({xs[i], y});
        ASSERT_EQ(static_cast<int>(row[i]), static_cast<int>(want)) << round << ": " << xs[i] << "," << y;
        on += want == Visibility::Ground::on_barrier;
        land += want == Visibility::Ground::land;
      }
    }
    EXPECT_GT(on, 100);
    EXPECT_GT(land, 100);
  }
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// Box proofs (sight_box, clear_box) against the exact predicates at points of the box: a box
// proved seen is seen from every point sampled in it, one proved hidden from none, one proved
// clear has one ground. On random islands with holes and lines, from vertices (every wedge),
// points at sea and points on coasts; planar, and geodesic in a frame over the Oresund.
struct BoxCounts {
  int64_t seen = 0, hidden = 0, hidden_at_sea = 0, clear = 0;
};
void check_box_proofs(const Barriers& b, std::shared_ptr<const GeodesicFrame> frame, Vec2 origin, double span,
                      uint64_t seed, BoxCounts& counts) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Visibility v(b, true, frame), full(b, false, frame);
  auto at = [&](double x, double y) { return Vec2{origin.x + x * span, origin.y + y * span}; };
  std::vector<Place> roots;
  for (int32_t k = 0; k < v.vertex_count(); ++k)
    for (int w = 0; w < v.vertex_star(k).wedges(); ++w)
      if (v.vertex_star(k).sea[static_cast<size_t>(w)]) roots.push_back(v.at_vertex(k, w));
  for (int k = 0; k < 40; ++k) {
    const Vec2 p = at(u(rng), u(rng));
    if (v.classify(p) == Visibility::Ground::open_sea) roots.push_back(Place{p});
  }
  for (const Ring& r : b.polygons()[0].rings)  // points on a coast (inside edges)
    roots.push_back(Place{Vec2{(r[0].x + r[1].x) / 2, (r[0].y + r[1].y) / 2}});
  for (int i = 0; i < 1500; ++i) {
    const Place& from = roots[static_cast<size_t>(rng() % roots.size())];
    const double size = span * (0.005 + 0.05 * u(rng));
    const Vec2 lo = at(u(rng), u(rng)), hi{lo.x + size, lo.y + size * (0.5 + u(rng))};
    const Visibility::Sight sight = v.sight_box(from, lo, hi);
    ASSERT_EQ(sight, full.sight_box(from, lo, hi)) << i;
    ASSERT_EQ(v.sees_box(from, lo, hi), sight == Visibility::Sight::seen) << i;
    const bool clear = v.clear_box(lo, hi);
    ASSERT_EQ(clear, full.clear_box(lo, hi)) << i;
    counts.clear += clear;
    if (sight == Visibility::Sight::unknown && !clear) continue;
    const Visibility::Ground ground = v.classify(lo);
    for (int k = 0; k < 60; ++k) {
      const Vec2 x = k < 49 ? Vec2{lo.x + (hi.x - lo.x) * (k % 7) / 6.0, lo.y + (hi.y - lo.y) * (k / 7) / 6.0}
                            : Vec2{lo.x + (hi.x - lo.x) * u(rng), lo.y + (hi.y - lo.y) * u(rng)};
      if (clear) {
        ASSERT_EQ(static_cast<int>(v.classify(x)), static_cast<int>(ground)) << i << " " << k;
      }
      if (sight == Visibility::Sight::unknown) continue;
      const bool want = sight == Visibility::Sight::seen;
      ASSERT_EQ(v.sees(from, Place{x}), want) << i << " " << k;
      ASSERT_EQ(v.sees(Place{x}, from), want) << i << " " << k;
    }
    counts.seen += sight == Visibility::Sight::seen;
    counts.hidden += sight == Visibility::Sight::hidden;
    counts.hidden_at_sea += sight == Visibility::Sight::hidden && from.vertex < 0 && from.open == false &&
                            v.classify(from.at) == Visibility::Ground::open_sea;
  }
}

Barriers box_islands(std::mt19937_64& rng, Vec2 origin, double span) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Barriers b;
  for (int k = 0; k < 14; ++k) {
    const double x = origin.x + u(rng) * span, y = origin.y + u(rng) * span, w = span * (0.02 + 0.08 * u(rng)),
                 h = span * (0.02 + 0.08 * u(rng));
    std::vector<Ring> rings{{{x, y}, {x + w, y}, {x + w * 0.7, y + h * 0.5}, {x + w, y + h}, {x, y + h}}};
    if (w > span * 0.06 && h > span * 0.06)
      rings.push_back({{x + w * 0.2, y + h * 0.2}, {x + w * 0.4, y + h * 0.2}, {x + w * 0.3, y + h * 0.4}});
    b.add_polygon(rings, "island");
  }
  for (int k = 0; k < 3; ++k)
    b.add_line(std::vector<Vec2>{{origin.x + u(rng) * span, origin.y + u(rng) * span},
                                 {origin.x + u(rng) * span, origin.y + u(rng) * span},
                                 {origin.x + u(rng) * span, origin.y + u(rng) * span}},
               "boom");
  return b;
}

TEST(Visibility, BoxProofsHoldAtEveryPointOfTheBox) {
  BoxCounts planar;
  for (int round = 0; round < 4; ++round) {
    std::mt19937_64 rng(70 + round);
    const Vec2 origin = round % 2 ? Vec2{512345.25, 6123456.5} : Vec2{0, 0};
    check_box_proofs(box_islands(rng, origin, 40.0), nullptr, origin, 40.0, 90 + round, planar);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(planar.seen, 400);
  EXPECT_GT(planar.hidden, 2000);
  EXPECT_GT(planar.hidden_at_sea, 500);  // by edges covering every direction, not by a wedge
  EXPECT_GT(planar.clear, 2500);
  BoxCounts geodesic;
  MetricSpec wgs84;
  wgs84.kind = MetricSpec::geodesic;
  const auto frame = std::make_shared<const GeodesicFrame>(wgs84, 12.0, 55.3, 13.0, 56.0);
  for (int round = 0; round < 2; ++round) {
    std::mt19937_64 rng(80 + round);
    const Barriers ll = box_islands(rng, Vec2{12.1, 55.35}, 0.6);
    const Barriers b = ll.mapped([&](Vec2 p) { return frame->forward(p); });
    const Vec2 lo = frame->forward({12.1, 55.35}), hi = frame->forward({12.7, 55.95});
    check_box_proofs(b, frame, lo, std::min(hi.x - lo.x, hi.y - lo.y), 95 + round, geodesic);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(geodesic.seen, 250);
  EXPECT_GT(geodesic.hidden, 1000);
  EXPECT_GT(geodesic.hidden_at_sea, 250);
}

}  // namespace
}  // namespace rv

namespace rv {
namespace {

// Where a seed's edge meets a barrier: along the same edge, or at an end it shares with one, is
// no meeting; a crossing (computed), a barrier vertex inside the edge (exact), an end of the edge
// inside a barrier edge (on it to rounding), and a stretch along another edge (its two ends) are.
std::string meetings_of(const Visibility& v, Vec2 a, Vec2 b) {
  std::vector<Place> m = v.meetings(a, b);
  std::sort(m.begin(), m.end(),
            [](const Place& p, const Place& q) { return p.at.x < q.at.x || (p.at.x == q.at.x && p.at.y < q.at.y); });
  std::string out;
  for (const Place& p : m) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s(%g %g)%s", out.empty() ? "" : " ", p.at.x, p.at.y, p.exact ? "" : "~");
    out += buf;
  }
  return out;
}

TEST(Visibility, MeetingsAreWhereASeedsEdgeMeetsABarrier) {
  Barriers b;
  b.add_polygon({{{0, 0}, {4, 0}, {4, 4}, {0, 4}}}, "square");
  b.add_line(std::vector<Vec2>{{10, 0}, {10, 4}}, "boom");
  const Visibility v(b);
  EXPECT_EQ(meetings_of(v, {0, 0}, {4, 0}), "");                // the square's own edge
  EXPECT_EQ(meetings_of(v, {4, 0}, {0, 0}), "");                // the other way round
  EXPECT_EQ(meetings_of(v, {4, 0}, {7, -2}), "");               // from a corner out to sea
  EXPECT_EQ(meetings_of(v, {5, 5}, {7, 7}), "");                // at sea
  EXPECT_EQ(meetings_of(v, {4, 0}, {8, 0}), "");                // on the bottom edge's line, back to back at the corner
  EXPECT_EQ(meetings_of(v, {10, 4}, {10, 6}), "");              // from the boom's end on its line, back to back
  EXPECT_EQ(meetings_of(v, {8, 2}, {12, 2}), "(10 2)~");        // across the boom
  EXPECT_EQ(meetings_of(v, {6, 4}, {10, 2}), "(10 2)~");        // ending inside the boom
  EXPECT_EQ(meetings_of(v, {2, 0}, {6, 0}), "(2 0)~ (4 0)");    // along the bottom edge from its middle
  EXPECT_EQ(meetings_of(v, {2, -2}, {6, 2}), "(4 0)");          // through the corner
  EXPECT_EQ(meetings_of(v, {-2, 2}, {6, 2}), "(0 2)~ (4 2)~");  // across the square
  EXPECT_EQ(meetings_of(v, {10, -2}, {10, 6}), "(10 0) (10 4)");  // along the whole boom and past it
}

// Land by the parity of crossings, decided independently: a coast of many islands beside a
// mainland whose box holds nearly every point, lakes in it, islands overlapping it and each other,
// and lines. Every point of the whole-number and half-number lattice (aligned with vertices in x,
// y or both, where a ray's half-open rule decides), planar; and on the ellipsoid the points
// farther than the images' bending from every edge, and the vertices. The oracle: a point is land
// when strictly inside some polygon; on the boundary of one polygon only (inside none) it is sea
// on a barrier; points on two polygons' boundaries (a shared border's rule) are left out.
struct Layout {
  std::vector<std::vector<Ring>> polygons;
  std::vector<std::vector<Vec2>> lines;
  Barriers barriers() const {
    Barriers b;
    for (const auto& rings : polygons) b.add_polygon(rings, "land");
    for (const auto& line : lines) b.add_line(line, "line");
    return b;
  }
};

Layout random_coast(std::mt19937_64& rng) {
  Layout l;
  std::uniform_int_distribution<int> coord(0, 56), size(1, 7), top(18, 34);
  std::vector<Vec2> mainland{{0, 0}, {60, 0}};
  for (int x = 60; x >= 0; x -= 4) mainland.push_back({static_cast<double>(x), static_cast<double>(top(rng))});
  std::vector<Ring> rings{mainland};
  for (int k = 0; k < 4; ++k) {  // lakes, apart: one per band of 14
    const double x = 2 + 14 * k + coord(rng) % 6, y = 2 + coord(rng) % 8;
    rings.push_back({{x, y}, {x, y + 3}, {x + 3, y + 3}, {x + 3, y}});  // (clockwise: a hole)
  }
  l.polygons.push_back(rings);
  for (int k = 0; k < 30; ++k) {
    const double x = coord(rng), y = coord(rng), w = size(rng), h = size(rng);
    if (k % 3 == 0)
      l.polygons.push_back({{{x, y}, {x + w, y}, {x, y + h}}});
    else
      l.polygons.push_back({{{x, y}, {x + w, y}, {x + w, y + h}, {x, y + h}}});
  }
  for (int k = 0; k < 5; ++k)
    l.lines.push_back({{static_cast<double>(coord(rng)), static_cast<double>(coord(rng))},
                       {static_cast<double>(coord(rng)), static_cast<double>(coord(rng))}});
  return l;
}

// Whether p lies on segment a-b (closed), and whether the ray from p east crosses it (half-open:
// an end on the ray's line counts as below), for coordinates whose products are exact.
bool on_segment(Vec2 a, Vec2 b, Vec2 p) {
  const double det = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
  return det == 0 && p.x >= std::min(a.x, b.x) && p.x <= std::max(a.x, b.x) && p.y >= std::min(a.y, b.y) &&
         p.y <= std::max(a.y, b.y);
}
bool crosses_east(Vec2 a, Vec2 b, Vec2 p) {
  if ((a.y > p.y) == (b.y > p.y)) return false;
  const double det = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
  return b.y > p.y ? det > 0 : det < 0;
}

// The oracle's ground for p, or -1 to leave it out. `near`: whether p counts as on an edge
// (exactly, or within the bending).
template <class Near>
int oracle_ground(const Layout& l, Vec2 p, Near&& near) {
  int inside = 0, on = 0;
  for (const auto& rings : l.polygons) {
    bool boundary = false, odd = false;
    for (const Ring& r : rings)
      for (size_t i = 0; i < r.size(); ++i) {
        const Vec2 a = r[i], b = r[(i + 1) % r.size()];
        boundary = boundary || near(a, b, p);
        odd = odd != crosses_east(a, b, p);
      }
    if (boundary)
      ++on;
    else if (odd)
      ++inside;
  }
  if (inside > 0) return static_cast<int>(Visibility::Ground::land);
  if (on > 1) return -1;
  bool on_line = false;
  for (const auto& line : l.lines)
    for (size_t i = 0; i + 1 < line.size(); ++i) on_line = on_line || near(line[i], line[i + 1], p);
  return static_cast<int>(on == 1 || on_line ? Visibility::Ground::on_barrier : Visibility::Ground::open_sea);
}

TEST(Visibility, LandIsEachPolygonsParity) {
  int counts[3] = {0, 0, 0}, left_out = 0;
  for (int round = 0; round < 6; ++round) {
    std::mt19937_64 rng(300 + round);
    const Layout l = random_coast(rng);
    const Barriers b = l.barriers();
    const Visibility indexed(b), full(b, false);
    for (int iy = -4; iy <= 124; ++iy)
      for (int ix = -4; ix <= 124; ++ix) {
        const Vec2 p{ix * 0.5, iy * 0.5};
        const int want = oracle_ground(l, p, on_segment);
        if (want < 0) {
          ++left_out;
          continue;
        }
        ++counts[want];
        ASSERT_EQ(static_cast<int>(indexed.classify(p)), want) << round << " " << p.x << " " << p.y;
        ASSERT_EQ(static_cast<int>(full.classify(p)), want) << round << " " << p.x << " " << p.y;
      }
  }
  std::printf("planar: land %d, open sea %d, on a barrier %d, left out %d\n", counts[0], counts[1], counts[2],
              left_out);
  EXPECT_GT(counts[static_cast<int>(Visibility::Ground::land)], 20000);
  EXPECT_GT(counts[static_cast<int>(Visibility::Ground::open_sea)], 20000);
  EXPECT_GT(counts[static_cast<int>(Visibility::Ground::on_barrier)], 2000);

  // On the ellipsoid: the layout in hundredths of a degree over the Oresund, its images in a
  // frame. The oracle reads chords in the frame's plane, so points within twice the bending (and
  // a micrometre) of an edge's chord are left out but for the vertices themselves.
  MetricSpec wgs84;
  wgs84.kind = MetricSpec::geodesic;
  const auto frame = std::make_shared<const GeodesicFrame>(wgs84, 11.9, 55.2, 12.8, 56.0);
  int geo[3] = {0, 0, 0};
  for (int round = 0; round < 2; ++round) {
    std::mt19937_64 rng(400 + round);
    Layout l = random_coast(rng);
    auto image = [&](Vec2 q) { return frame->forward({12.0 + q.x * 0.01, 55.3 + q.y * 0.01}); };
    for (auto& rings : l.polygons)
      for (Ring& r : rings)
        for (Vec2& v : r) v = image(v);
    for (auto& line : l.lines)
      for (Vec2& v : line) v = image(v);
    const Visibility v(l.barriers(), true, frame);
    const double margin = 2 * frame->deviation() + 1e-6;
    auto near = [&](Vec2 a, Vec2 c, Vec2 p) {
      if (p == a || p == c) return true;
      const Vec2 d{c.x - a.x, c.y - a.y};
      const double t = std::clamp(((p.x - a.x) * d.x + (p.y - a.y) * d.y) / (d.x * d.x + d.y * d.y), 0.0, 1.0);
      return std::hypot(p.x - a.x - t * d.x, p.y - a.y - t * d.y) <= margin;
    };
    for (int iy = -4; iy <= 124; ++iy)
      for (int ix = -4; ix <= 124; ++ix) {
        const Vec2 p = image({ix * 0.5, iy * 0.5});
        bool vertex = false;
        for (const auto& rings : l.polygons)
          for (const Ring& r : rings) vertex = vertex || std::find(r.begin(), r.end(), p) != r.end();
        int want = oracle_ground(l, p, near);
        if (want == static_cast<int>(Visibility::Ground::on_barrier) && !vertex) want = -1;  // within the bending
        if (want < 0) continue;
        ++geo[want];
        ASSERT_EQ(static_cast<int>(v.classify(p)), want) << round << " " << ix << " " << iy;
      }
  }
  std::printf("ellipsoid: land %d, open sea %d, on a barrier (vertices) %d\n", geo[0], geo[1], geo[2]);
  EXPECT_GT(geo[static_cast<int>(Visibility::Ground::land)], 5000);
  EXPECT_GT(geo[static_cast<int>(Visibility::Ground::open_sea)], 5000);
  EXPECT_GT(geo[static_cast<int>(Visibility::Ground::on_barrier)], 100);
}

}  // namespace
}  // namespace rv
