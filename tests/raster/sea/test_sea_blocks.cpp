// The exact engine's blocks by sea (raster/src/sea_exact/sea_cells.cpp): the parts that let a block of
// cells be answered without an inverse problem or a visibility proof per cell, each against
// what it stands in for.
// - A length patch (sea_exact/length_patch.hpp) against GeographicLib's inverse problem, cell by cell.
// - never_taut (sea/sea_prepare.hpp), which leaves a bend out of a block before its visibility
//   proof, against taut() at points all over the box; taut() itself against the turn read from
//   angles; DeadArrivals, which leaves a node out of the roots, against the angles and against
//   taut() and sight from every departure.
// - Blocks with patches against every cell answered alone, to the bit, with and without a
//   maximum distance.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include "engines_agree.hpp"
#include "geodesic_oracle.hpp"
#include "random_archipelago.hpp"
#include "rv/field/error.hpp"
#include "rv/geodesic/geodesic.hpp"
#include "rv/sea/sea_field.hpp"
#include "sea/bend_settle.hpp"
#include "sea/sea_prepare.hpp"
#include "sea_exact/length_patch.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

SeaOptions on_the_ellipsoid() {
  SeaOptions o;
  o.metric = test::geodesic_metric();
  return o;
}

// Twelve random archipelagos with their ports, planar and on the ellipsoid in turn, each
// prepared by sea (its bend nodes settled) and handed to `use` (round, the preparation); a layout
// refused as input (a port on an island or the boom) is skipped.
template <class Use>
void for_each_settled_archipelago(std::mt19937_64& rng, Use&& use) {
  for (int round = 0; round < 12; ++round) {
    const bool ellipsoid = round % 2 == 1;
    auto to = [&](Vec2 v) { return ellipsoid ? Vec2{12.0 + 0.02 * v.x, 55.3 + 0.0125 * v.y} : v; };
    const test::Archipelago a = test::random_archipelago(rng, round, to);
    const GridSpec g = ellipsoid ? test::grid_of(40, 25, 0.02, 12.0, 55.8) : test::grid_of(40, 40, 1.0);
    std::shared_ptr<const PreparedSea> prepared;
    try {
      prepared = prepare_sea(a.seeds, a.barriers, g, ellipsoid ? on_the_ellipsoid() : SeaOptions{});
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
      continue;
    }
    use(round, *prepared);
  }
}

// Patches over blocks of 4 to 32 cells of grids from 0.0002 to 0.02 degrees across the western
// Baltic's latitudes, from points anywhere within 3 degrees (inside the block too, metres from a
// cell): every usable patch's length at every cell is within a hundredth of kPatchError of
// GeographicLib's, and every patch within kPatchSpan is usable; a block beyond that span, or a
// point on a node, gives none.
TEST(SeaBlocks, APatchsLengthsAreGeographicLibsWithinItsError) {
  const MetricSpec metric = test::geodesic_metric();
  sea::Prepared p(Visibility(Barriers{}));
  p.semi_major = metric.semi_major;
  p.e2 = metric.flattening * (2.0 - metric.flattening);
  p.geodesic = std::make_shared<const GeodesicMeasure>(metric);
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double resolutions[] = {0.0002, 0.001, 0.004, 0.01, 0.02};
  const int64_t sides[] = {4, 8, 16, 32};
  int within = 0, usable = 0, beyond = 0;
  int64_t cells = 0;
  double worst = 0.0;
  for (int k = 0; k < 400; ++k) {
    const double res = resolutions[k % 5];
    const int64_t w = sides[(k / 5) % 4], h = sides[(k / 20) % 4];
    const Vec2 ll0{9.0 + 6.0 * u(rng), 56.2 - 2.4 * u(rng)};  // the block's first cell (north-west)
    const Vec2 ll1{ll0.x + res * static_cast<double>(w - 1), ll0.y - res * static_cast<double>(h - 1)};
    // A third of the points within the block's own span, the rest up to 3 degrees away.
    const double spread = k % 3 == 0 ? 0.0 : 3.0 * u(rng);
    const Vec2 at{ll0.x + (ll1.x - ll0.x) * u(rng) + spread * (2.0 * u(rng) - 1.0),
                  ll0.y + (ll1.y - ll0.y) * u(rng) + spread * (2.0 * u(rng) - 1.0)};
    const sea::PatchBlock block{100, 200, 100 + w - 1, 200 + h - 1, ll0, ll1};
    const sea::LengthPatch patch(p, at, p.xyz(at), block);
    if (ll1.x - ll0.x > sea::kPatchSpan || ll0.y - ll1.y > sea::kPatchSpan) {
      ++beyond;
      EXPECT_FALSE(patch.usable()) << res << " x " << w << " x " << h;
      continue;
    }
    ++within;
    if (!patch.usable()) continue;
    ++usable;
    for (int64_t r = 0; r < h; ++r)
      for (int64_t c = 0; c < w; ++c) {
        const Vec2 cell{ll0.x + res * static_cast<double>(c), ll0.y - res * static_cast<double>(r)};
        const double want = p.geodesic->point_distance(at, cell);
        const double got = patch.length(100 + c, 200 + r, p.xyz(cell));
        worst = std::max(worst, std::abs(got - want));
        ++cells;
      }
  }
  std::printf("%d patches within the span, %d usable; %lld cells, worst error %.3g m; %d beyond the span\n", within,
              usable, static_cast<long long>(cells), worst, beyond);
  EXPECT_LT(worst, sea::kPatchError / 100.0);
  EXPECT_EQ(usable, within);
  EXPECT_GT(within, 300);
  EXPECT_GT(beyond, 20);
  // A point on the block's first cell (a node): no patch.
  const Vec2 ll0{12.0, 55.0}, ll1{12.0 + 0.001 * 15, 55.0 - 0.001 * 15};
  EXPECT_FALSE(sea::LengthPatch(p, ll0, p.xyz(ll0), sea::PatchBlock{0, 0, 15, 15, ll0, ll1}).usable());
}

// never_taut over random archipelagos, planar and on the ellipsoid: for every settled bend and
// boxes of every size near it (straddling its arrival line and its land's far ray too), a box it
// proves untaut holds no taut departure among 12 x 12 points over it, corners and edges
// included. It must prove many boxes, and many others must hold taut departures (the test has
// something to tell apart).
TEST(SeaBlocks, ABoxProvedUntautHoldsNoTautDeparture) {
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int64_t proved = 0, taut_boxes = 0, points = 0;
  for_each_settled_archipelago(rng, [&](int round, const PreparedSea& prepared) {
    const sea::Prepared& p = prepared.prepared;
    const sea::Searches& s = prepared.search;
    for (size_t k = 0; k < s.nodes.size(); ++k) {
      if (!std::isfinite(s.dist[k].d)) continue;
      const sea::Node& n = s.nodes[k];
      const Vec2 v = p.vis.vertex(n.vertex);
      const double scale = std::max(std::hypot(s.from[k].x - v.x, s.from[k].y - v.y), 1e-9);
      for (int b = 0; b < 40; ++b) {
        // A box of a random size (a thousandth of the arrival's length to four times it),
        // centred anywhere within three sizes of the vertex.
        const double size = scale * std::pow(10.0, -3.0 + 3.6 * u(rng));
        const double cx = v.x + 3.0 * size * (2.0 * u(rng) - 1.0), cy = v.y + 3.0 * size * (2.0 * u(rng) - 1.0);
        const Vec2 lo{cx - size * u(rng), cy - size * u(rng)}, hi{cx + size * u(rng), cy + size * u(rng)};
        const bool untaut = sea::never_taut(p.vis, s.tauts[k], lo, hi);
        bool any = false;
        for (int i = 0; i < 12; ++i)
          for (int j = 0; j < 12; ++j) {
            const Vec2 x{lo.x + (hi.x - lo.x) * i / 11.0, lo.y + (hi.y - lo.y) * j / 11.0};
            if (x.x == v.x && x.y == v.y) continue;
            ++points;
            if (sea::taut(p.vis, n, s.from[k], x)) {
              any = true;
              ASSERT_FALSE(untaut) << "round " << round << " node " << k << ": (" << x.x << ", " << x.y
                                   << ") is a taut departure in a box proved untaut";
            }
          }
        proved += untaut;
        taut_boxes += any;
      }
    }
  });
  std::printf("%lld boxes proved untaut, %lld boxes holding taut departures, %lld points\n",
              static_cast<long long>(proved), static_cast<long long>(taut_boxes), static_cast<long long>(points));
  EXPECT_GT(proved, 2000);
  EXPECT_GT(taut_boxes, 2000);
}

// A settled node's taut test (sea::TautTest, the arrival worked out once) against the turn read
// from angles: a path that reached the node from `from` and leaves towards x, both directions in
// the node's sea wedge, is taut exactly when the shorter way round from the one to the other
// passes over the land beside the wedge (both of its sides, rays k and k + 1, strictly inside
// that arc). Decided only where every angle is clear of the others by more than rounding and
// the frame's bend could move it; departures at random distances round every settled node.
TEST(SeaBlocks, ATautTestTurnsRoundTheLand) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  constexpr double kTurn = 2.0 * M_PI;
  auto ccw = [&](double from, double to) { return std::fmod(std::fmod(to - from, kTurn) + kTurn, kTurn); };
  int64_t taut = 0, untaut = 0;
  for_each_settled_archipelago(rng, [&](int round, const PreparedSea& prepared) {
    const sea::Prepared& p = prepared.prepared;
    const sea::Searches& s = prepared.search;
    const double bend = p.vis.frame() ? p.vis.frame()->deviation() : 0.0;
    for (size_t k = 0; k < s.nodes.size(); ++k) {
      if (!std::isfinite(s.dist[k].d)) continue;
      const sea::Node& n = s.nodes[k];
      const Visibility::Star& star = p.vis.vertex_star(n.vertex);
      const Vec2 v = star.at, from = s.from[k];
      const double arrival = std::hypot(from.x - v.x, from.y - v.y);
      if (arrival < 1e-6 * (1.0 + std::abs(v.x) + std::abs(v.y))) continue;  // a path that starts here
      const size_t m = star.rays.size();
      const auto w = static_cast<size_t>(n.wedge) % m;
      const Vec2 first = star.rays[w], last = star.rays[(w + 1) % m];  // the sea wedge's sides (ccw)
      auto angle = [&](Vec2 q) { return std::atan2(q.y - v.y, q.x - v.x); };
      const double side0 = angle(first), side1 = angle(last);
      const double wedge = m == 1 ? kTurn : ccw(side0, side1);
      // How far an angle seen over `length` may be off: rounding, and the frame's bend at both ends.
      auto blur = [&](double length) { return 1e-9 + 4.0 * bend / length; };
      const double near =
          std::min({arrival, std::hypot(first.x - v.x, first.y - v.y), std::hypot(last.x - v.x, last.y - v.y)});
      const double alpha = angle(from);
      if (ccw(side0, alpha) < blur(near) || ccw(alpha, side1) < blur(near) || ccw(side0, alpha) > wedge) continue;
      for (int i = 0; i < 200; ++i) {
        const double beta = side0 + wedge * u(rng);
        const double r = arrival * std::pow(10.0, -2.0 + 3.0 * u(rng));
        const Vec2 x{v.x + r * std::cos(beta), v.y + r * std::sin(beta)};
        const double clear = blur(std::min(near, r));
        // (Clear of the wedge's sides, of the arrival, and of straight on past the node.)
        if (ccw(side0, beta) < clear || ccw(beta, side1) < clear || std::abs(ccw(alpha, beta)) < clear ||
            std::abs(ccw(alpha, beta) - M_PI) < clear)
          continue;
        // The shorter way round from alpha to beta, and whether the land's sides lie inside it.
        const bool left = ccw(alpha, beta) < M_PI;
        const double a0 = left ? alpha : beta, span = left ? ccw(alpha, beta) : ccw(beta, alpha);
        const bool over_land = ccw(a0, side0) < span && ccw(a0, side1) < span;
        const bool got = sea::taut(p.vis, s.tauts[k], x);
        ASSERT_EQ(got, over_land) << "round " << round << " node " << k << " departure (" << x.x << ", " << x.y << ")";
        ASSERT_EQ(got, sea::taut(p.vis, n, from, x));
        (got ? taut : untaut) += 1;
      }
    }
  });
  std::printf("%lld departures taut, %lld not\n", static_cast<long long>(taut), static_cast<long long>(untaut));
  EXPECT_GT(taut, 5000);
  EXPECT_GT(untaut, 20000);
}

// DeadArrivals (sea/sea_prepare.hpp) over random archipelagos, planar and on the ellipsoid, round
// every bend node at a vertex of two rays:
// - against the angles: an arrival from q is dead exactly when q's direction from the node lies
//   inside the wedge opposite the land (decided only where it is clear of that wedge's sides by
//   more than rounding and the frame's bend could move it);
// - the claim the settlings rest on: from a dead arrival no departure is both taut and in sight
//   of the node's wedge, over departures in every direction, at every distance, along the rays.
// And the settling: a node is left out of the roots exactly when its own arrival is dead, and
// such a node is neither taut nor seen from any point tried.
TEST(SeaBlocks, AnArrivalThatRunsIntoTheLandGoesOnNowhere) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  constexpr double kTurn = 2.0 * M_PI;
  auto ccw = [&](double from, double to) { return std::fmod(std::fmod(to - from, kTurn) + kTurn, kTurn); };
  int64_t dead = 0, live = 0, departures = 0, left_out = 0, roots = 0;
  for_each_settled_archipelago(rng, [&](int round, const PreparedSea& prepared) {
    const sea::Prepared& p = prepared.prepared;
    const sea::Searches& s = prepared.search;
    const double bend = p.vis.frame() ? p.vis.frame()->deviation() : 0.0;
    for (size_t k = 0; k < s.nodes.size(); ++k) {
      const sea::Node& n = s.nodes[k];
      const Visibility::Star& star = p.vis.vertex_star(n.vertex);
      const sea::DeadArrivals arrivals(p.vis, n);
      const Visibility::Place node = p.vis.at_vertex(n.vertex, n.wedge);
      // A settled node is a root exactly when its own arrival may go on; one that is not is
      // taut and seen nowhere.
      if (std::isfinite(s.dist[k].d)) {
        ASSERT_EQ(s.root(k), !arrivals.from(s.from[k])) << "round " << round << " node " << k;
        (s.root(k) ? roots : left_out) += 1;
        const Vec2 v = star.at;
        const double r0 = std::hypot(s.from[k].x - v.x, s.from[k].y - v.y);
        for (int j = 0; j < (s.root(k) ? 0 : 200); ++j) {
          const double b = kTurn * u(rng), d = r0 * std::pow(10.0, -3.0 + 4.0 * u(rng));
          const Vec2 x{v.x + d * std::cos(b), v.y + d * std::sin(b)};
          ASSERT_FALSE(sea::taut(p.vis, s.tauts[k], x) && p.vis.sees(Visibility::Place{x}, node))
              << "round " << round << " node " << k << " left out, yet goes on to (" << x.x << ", " << x.y << ")";
        }
      }
      if (star.rays.size() != 2) continue;
      const Vec2 v = star.at;
      const auto w = static_cast<size_t>(n.wedge) % 2;
      const Vec2 far = star.rays[w], near = star.rays[1 - w];  // the land runs ccw from near to far
      auto angle = [&](Vec2 q) { return std::atan2(q.y - v.y, q.x - v.x); };
      const double n0 = angle(near) + M_PI, f0 = angle(far) + M_PI;  // the opposite wedge, ccw
      const double opposite = ccw(n0, f0);
      const double scale = std::min(std::hypot(near.x - v.x, near.y - v.y), std::hypot(far.x - v.x, far.y - v.y));
      auto blur = [&](double length) { return 1e-7 + 4.0 * bend / std::min(length, scale); };
      for (int i = 0; i < 60; ++i) {
        const double r = scale * std::pow(10.0, -2.0 + 3.0 * u(rng));
        const double a = kTurn * u(rng);
        const Vec2 q{v.x + r * std::cos(a), v.y + r * std::sin(a)};
        const bool got = arrivals.from(q);
        const double in = ccw(n0, a);
        if (std::min({in, kTurn - in, std::abs(in - opposite)}) > blur(r)) {
          ASSERT_EQ(got, in < opposite) << "round " << round << " node " << k << " arrival (" << q.x << ", " << q.y
                                        << ")";
        }
        if (!got) {
          ++live;
          continue;
        }
        ++dead;
        // Departures: anywhere round the node, along its rays, straight on past it.
        for (int j = 0; j < 40; ++j) {
          const double b = j < 30 ? kTurn * u(rng) : j < 34 ? angle(j % 2 ? near : far) : a + M_PI;
          const double d = scale * std::pow(10.0, -3.0 + 4.0 * u(rng));
          const Vec2 x{v.x + d * std::cos(b), v.y + d * std::sin(b)};
          ++departures;
          ASSERT_FALSE(sea::taut(p.vis, n, q, x) && p.vis.sees(Visibility::Place{x}, node))
              << "round " << round << " node " << k << ": from (" << q.x << ", " << q.y << ") on to (" << x.x << ", "
              << x.y << ")";
        }
      }
    }
  });
  std::printf(
      "%lld arrivals dead, %lld live; %lld departures tried from the dead; settled nodes: %lld roots, %lld "
      "left out\n",
      static_cast<long long>(dead), static_cast<long long>(live), static_cast<long long>(departures),
      static_cast<long long>(roots), static_cast<long long>(left_out));
  EXPECT_GT(dead, 2000);
  EXPECT_GT(live, 2 * dead);
  EXPECT_GT(left_out, 20);
  EXPECT_GT(roots, 3 * left_out);
}

// Blocks on a fine grid on the ellipsoid, where most cells whose path bends take their length
// from a patch: the same field as every cell alone, to the bit (owner, via, distance, the largest
// detour), with no maximum distance and with one that cuts through the bent cells.
TEST(SeaBlocks, PatchedBlocksAnswerAsEveryCellAlone) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int rounds = 0;
  int64_t interpolated = 0, patches = 0, via_cells = 0;
  for (int round = 0; round < 4; ++round) {
    Barriers b;
    for (int k = 0; k < 5; ++k) {  // islands with long coasts across the middle
      const double x = 12.05 + 0.12 * k + 0.03 * u(rng), y = 55.4 + 0.15 * u(rng);
      const double w = 0.05 + 0.04 * u(rng), h = 0.08 + 0.1 * u(rng);
      b.add_polygon(std::vector<Ring>{{{x, y}, {x + w, y + 0.01}, {x + w * 0.7, y + h}, {x - 0.01, y + h * 0.9}}},
                    "island");
    }
    SeedSet s;
    for (int k = 0; k < 4; ++k)
      s.add_point(s.add_feature(s.owner_code(k % 2 ? "A" : "B")), {12.0 + 0.7 * u(rng), 55.3 + 0.05 * u(rng)});
    const GridSpec g = test::grid_of(360, 240, 0.002, 12.0, 55.8);
    SeaOptions options = on_the_ellipsoid();
    if (round >= 2) options.max_distance = 18000.0 + 4000.0 * u(rng);
    SeaField f;
    try {
      f = test::blocks_agree(s, b, g, options);
    } catch (const Error& e) {
      ASSERT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
      continue;
    }
    if (HasFailure()) return;
    ++rounds;
    interpolated += f.interpolated_cells;
    patches += f.length_patches;
    for (int64_t r = 0; r < g.height; ++r)
      for (int64_t c = 0; c < g.width; ++c) via_cells += f.via.at(c, r) != kNoVia;
  }
  std::printf("%d rounds: %lld cells by way of a bend, %lld of them from %lld patches\n", rounds,
              static_cast<long long>(via_cells), static_cast<long long>(interpolated), static_cast<long long>(patches));
  EXPECT_GE(rounds, 3);
  EXPECT_GT(via_cells, 20000);
  EXPECT_GT(interpolated, via_cells / 2);
}

// A layout mirrored about the meridian 12.5 E on the ellipsoid (no barrier vertex on it), a cell
// column on it: behind the islands the cells near the axis are reached round mirrored corners by
// paths of the same length to within rounding, closer than any patch can tell apart. Such cells
// are weighed again exactly (length_retries), and the field is every cell's own, to the bit.
TEST(SeaBlocks, MirroredRootsAreToldApartExactly) {
  Barriers b;
  auto mirrored = [&](std::vector<Vec2> west) {
    std::vector<Vec2> east;
    for (auto it = west.rbegin(); it != west.rend(); ++it) east.push_back(Vec2{25.0 - it->x, it->y});
    b.add_polygon(std::vector<Ring>{west}, "west");
    b.add_polygon(std::vector<Ring>{east}, "east");
  };
  mirrored({{12.30, 55.40}, {12.46, 55.41}, {12.47, 55.50}, {12.31, 55.49}});
  mirrored({{12.20, 55.58}, {12.42, 55.60}, {12.40, 55.64}});
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A")), {12.28, 55.32});
  s.add_point(s.add_feature(s.owner_code("B")), {25.0 - 12.28, 55.32});
  const GridSpec g = test::grid_of(301, 200, 0.002, 12.5 - 150.5 * 0.002, 55.75);
  const SeaField f = test::blocks_agree(s, b, g, on_the_ellipsoid());
  if (HasFailure()) return;
  int64_t axis_bent = 0;
  for (int64_t r = 0; r < g.height; ++r) axis_bent += f.via.at(150, r) != kNoVia;
  std::printf("%lld cells on the axis by way of a bend; %lld cells from patches, %lld weighed again\n",
              static_cast<long long>(axis_bent), static_cast<long long>(f.interpolated_cells),
              static_cast<long long>(f.length_retries));
  EXPECT_GT(axis_bent, 50);
  EXPECT_GT(f.interpolated_cells, 5000);
  EXPECT_GT(f.length_retries, 50);
}

}  // namespace
}  // namespace rv
