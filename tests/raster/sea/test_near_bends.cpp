// The near bends (raster/src/sea/near_bends.hpp) and the settling that hands a settled node's
// path to them (bend_settle.hpp's Settling with NearBends): every node settled as the settling
// without them settles it, to the bit, over every owner's sites, paused and resumed, on random
// archipelagos in the plane and on the ellipsoid; the near bends against a brute-force reading of
// their definition.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <tuple>
#include <vector>

#include "geodesic_oracle.hpp"
#include "random_archipelago.hpp"
#include "rv/field/error.hpp"
#include "rv/sea/sea_field.hpp"
#include "sea/bend_settle.hpp"
#include "sea/near_bends.hpp"
#include "sea/sea_prepare.hpp"
#include "seed_gen.hpp"
#include "wall_sea.hpp"

namespace rv {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

SeaOptions options_for(bool ellipsoid) {
  SeaOptions o;
  if (ellipsoid) o.metric = test::geodesic_metric();
  return o;
}

// A layout and its preparation (null where the layout puts a port on land, which prepare refuses).
struct Layout {
  Barriers barriers;
  SeedSet seeds;
  std::shared_ptr<const PreparedSea> prepared;
};

Layout archipelago(std::mt19937_64& rng, int round, bool ellipsoid) {
  auto to = [&](Vec2 v) { return ellipsoid ? Vec2{12.0 + 0.02 * v.x, 55.3 + 0.0125 * v.y} : v; };
  test::Archipelago a = test::random_archipelago(rng, round, to);
  Layout out{std::move(a.barriers), std::move(a.seeds), nullptr};
  const GridSpec g = ellipsoid ? test::grid_of(40, 25, 0.02, 12.0, 55.8) : test::grid_of(40, 40, 1.0);
  try {
    out.prepared = prepare_sea(out.seeds, out.barriers, g, options_for(ellipsoid));
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();  // a port on an island or the boom
  }
  return out;
}

// A bay closed on three sides (a square ring of land open in the north) with 36 islets in it,
// and two ports outside it to the south and east: every node in the bay lies a few units from a
// port in a straight line and tens of units by sea, round the headlands, deep in a shadow.
Layout bay() {
  Layout out;
  out.barriers.add_polygon({{{0, 0},
                             {40, 0},
                             {40, 40},
                             {24, 40},
                             {24, 36},
                             {36, 36},
                             {36, 4},
                             {4, 4},
                             {4, 36},
                             {16, 36},
                             {16, 40},
                             {0, 40}}},
                           "bay");
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      const double x = 6.0 + 5.0 * i + (j % 2) * 0.6, y = 6.0 + 4.5 * j + (i % 3) * 0.4;
      out.barriers.add_polygon({{{x, y}, {x + 1.5, y + 0.3}, {x + 1.2, y + 1.5}, {x, y + 1.2}}}, "islet");
    }
  out.seeds = test::named_points({{"A", {20.5, -2.5}}, {"B", {43.5, 20.5}}});
  out.prepared = prepare_sea(out.seeds, out.barriers, test::grid_of(50, 50, 1.0, -5.0, 45.0), SeaOptions{});
  return out;
}

// Each owner's geometric sites, then all of them.
std::vector<std::vector<int32_t>> owners_sites(const SeedSet& seeds, const sea::Prepared& p) {
  std::vector<std::vector<int32_t>> out(static_cast<size_t>(seeds.owner_count()));
  for (int32_t id : p.geometric) out[static_cast<size_t>(seeds.site_owner(id) - 1)].push_back(id);
  std::erase_if(out, [](const std::vector<int32_t>& s) { return s.empty(); });
  out.push_back(p.geometric);
  return out;
}

// Every node's distance, site, last bend, previous node and arrival the same, to the bit, and
// whether it is a root (sea::DeadArrivals).
void expect_same_nodes(const sea::Searches& want, const sea::Searches& got, const char* what) {
  ASSERT_EQ(want.nodes.size(), got.nodes.size());
  for (size_t k = 0; k < want.nodes.size(); ++k) {
    const sea::Best& a = want.dist[k];
    const sea::Best& b = got.dist[k];
    ASSERT_EQ(std::bit_cast<uint64_t>(a.d), std::bit_cast<uint64_t>(b.d))
        << what << ": node " << k << ": " << a.d << " against " << b.d;
    ASSERT_EQ(a.site, b.site) << what << ": node " << k;
    ASSERT_EQ(a.via, b.via) << what << ": node " << k;
    if (!std::isfinite(a.d)) continue;
    ASSERT_EQ(want.prev[k], got.prev[k]) << what << ": node " << k;
    ASSERT_EQ(std::bit_cast<uint64_t>(want.from[k].x), std::bit_cast<uint64_t>(got.from[k].x)) << what << ": " << k;
    ASSERT_EQ(std::bit_cast<uint64_t>(want.from[k].y), std::bit_cast<uint64_t>(got.from[k].y)) << what << ": " << k;
    ASSERT_EQ(want.root(k), got.root(k)) << what << ": node " << k;
  }
}

struct Counts {
  int64_t layouts = 0, settlings = 0, nodes = 0, settled = 0, paused = 0;
  int64_t evaluations_without = 0, evaluations_with = 0;
  int64_t tests_far = 0, tests_near_only = 0;  // visibility tests with k = 1, with and without far sight
};

// Over every owner's sites of the layout: the settling without near bends, and with them for
// several k (one run; and paused at quantiles of the distances, then resumed).
void compare_settlings(const Layout& layout, Counts& counts) {
  const sea::Prepared& p = layout.prepared->prepared;
  ++counts.layouts;
  const std::vector<sea::Node> nodes = sea::bend_nodes(p.vis);
  for (const std::vector<int32_t>& sites : owners_sites(layout.seeds, p)) {
    sea::Searches want(p, sites);
    int64_t tests = 0;
    sea::settle_bends(want, tests, nullptr);
    counts.evaluations_without += want.evaluations;
    std::vector<double> ds;
    for (const sea::Best& b : want.dist)
      if (std::isfinite(b.d)) ds.push_back(b.d);
    std::sort(ds.begin(), ds.end());
    counts.nodes += static_cast<int64_t>(want.nodes.size());
    counts.settled += static_cast<int64_t>(ds.size());
    // (k = 1 twice: with far sight and without, the one that passes roots over unweighed.)
    for (const auto& [k, far] :
         {std::pair{1, sea::kFarFactor}, {1, 0.0}, {3, sea::kFarFactor}, {16, sea::kFarFactor}}) {
      const PreparedSea::CutEdges& cut = layout.prepared->cut_edges();
      const sea::NearBends near = sea::near_bends(p, nodes, k, k == 3 ? 2 : 1, nullptr, cut.edges, cut.index, far);
      sea::Searches got(p, sites);
      int64_t run_tests = 0;
      sea::Settling(got, &near).run(run_tests, nullptr);
      ++counts.settlings;
      if (k == 16) counts.evaluations_with += got.evaluations;
      if (k == 1) (far > 0.0 ? counts.tests_far : counts.tests_near_only) += run_tests;
      expect_same_nodes(want, got, far > 0.0 ? "one run" : "one run without far sight");
      if (ds.empty()) continue;
      // Paused at a fifth, a half and all but the last of the distances, then resumed: the nodes
      // settled at each pause are exactly those within it.
      sea::Searches paused(p, sites);
      sea::Settling settling(paused, &near);
      for (const double within : {ds[ds.size() / 5], ds[ds.size() / 2], ds[ds.size() - 1] * (1 - 1e-9)}) {
        settling.run(tests, nullptr, within);
        for (size_t n = 0; n < want.nodes.size(); ++n) {
          const bool in = want.dist[n].d <= within;
          ASSERT_EQ(std::isfinite(paused.dist[n].d), in) << "paused at " << within << ": node " << n;
          if (in) {
            ASSERT_EQ(std::bit_cast<uint64_t>(paused.dist[n].d), std::bit_cast<uint64_t>(want.dist[n].d));
          }
        }
        ++counts.paused;
      }
      settling.run(tests, nullptr);
      expect_same_nodes(want, paused, "paused and resumed");
    }
  }
}

TEST(NearBends, ASettlingWithNearBendsSettlesEveryNodeAsTheOneWithout) {
  std::mt19937_64 rng(2026);
  Counts planar, ellipsoid;
  for (int round = 0; round < 36; ++round) {
    const bool on_ellipsoid = round % 3 == 2;
    const Layout layout = archipelago(rng, round, on_ellipsoid);
    if (!layout.prepared) continue;
    compare_settlings(layout, on_ellipsoid ? ellipsoid : planar);
    if (HasFatalFailure()) return;
  }
  Counts shadows;
  compare_settlings(bay(), shadows);
  for (const auto& [name, c] : {std::pair{"planar", planar}, {"ellipsoid", ellipsoid}, {"bay", shadows}})
    std::printf(
        "%-9s layouts %lld, settlings %lld, nodes %lld (settled %lld), pauses %lld; evaluations without "
        "near bends %lld, with (k = 16) %lld; visibility tests (k = 1) %lld with far sight, %lld without\n",
        name, static_cast<long long>(c.layouts), static_cast<long long>(c.settlings), static_cast<long long>(c.nodes),
        static_cast<long long>(c.settled), static_cast<long long>(c.paused),
        static_cast<long long>(c.evaluations_without), static_cast<long long>(c.evaluations_with),
        static_cast<long long>(c.tests_far), static_cast<long long>(c.tests_near_only));
  EXPECT_GE(planar.layouts, 15);
  EXPECT_GE(ellipsoid.layouts, 6);
  EXPECT_GT(planar.settled, 1000);
  EXPECT_GT(ellipsoid.settled, 300);
  // What they are for: nodes in shadows searched far fewer times; roots far sight proves hidden
  // not tested at all.
  EXPECT_LT(shadows.evaluations_with * 2, shadows.evaluations_without);
  EXPECT_LT(planar.tests_far, planar.tests_near_only);
  EXPECT_LT(ellipsoid.tests_far, ellipsoid.tests_near_only);
  EXPECT_LT(shadows.tests_far, shadows.tests_near_only);
}

// Far sight against sees(): every root, site, point and box a node's far sight passes over is
// hidden from it, over random archipelagos in the plane and on the ellipsoid and the bay, with
// squares of one radius and of kFarFactor; the cones sorted, apart and within [0, 4]; the same on
// one thread and two. And pseudo_angle rises with the angle.
TEST(NearBends, FarSightPassesOverOnlyWhatANodeCannotSee) {
  std::mt19937_64 rng(76);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  {
    std::vector<std::pair<double, double>> by;
    for (int i = 0; i < 20000; ++i) {
      const double t = 2.0 * std::numbers::pi * unit(rng), r = 0.001 + 1000.0 * unit(rng);
      const double dx = r * std::cos(t), dy = r * std::sin(t);
      by.emplace_back(std::atan2(dy, dx) < 0.0 ? std::atan2(dy, dx) + 2.0 * std::numbers::pi : std::atan2(dy, dx),
                      sea::pseudo_angle(dx, dy));
    }
    for (const auto& [dx, dy, want] : {std::tuple{1.0, 0.0, 0.0}, {0.0, 1.0, 1.0}, {-1.0, 0.0, 2.0}, {0.0, -1.0, 3.0}})
      EXPECT_EQ(sea::pseudo_angle(dx, dy), want);
    std::sort(by.begin(), by.end());
    for (size_t i = 1; i < by.size(); ++i) {
      ASSERT_LE(by[i - 1].second, by[i].second) << "at angle " << by[i].first;
      ASSERT_GE(by[i].second, 0.0);
      ASSERT_LT(by[i].second, 4.0);
    }
  }
  int64_t nodes_with = 0, passed_over = 0, kept_hidden = 0, kept_seen = 0, boxes_passed = 0;
  auto check = [&](const Layout& layout) {
    const sea::Prepared& p = layout.prepared->prepared;
    const Visibility& vis = p.vis;
    const std::vector<sea::Node> nodes = sea::bend_nodes(vis);
    Vec2 lo{kInf, kInf}, hi{-kInf, -kInf};
    for (const sea::Node& n : nodes) {
      const Vec2 v = vis.vertex(n.vertex);
      lo = {std::min(lo.x, v.x), std::min(lo.y, v.y)};
      hi = {std::max(hi.x, v.x), std::max(hi.y, v.y)};
    }
    const Vec2 span{hi.x - lo.x, hi.y - lo.y};
    lo = {lo.x - 0.1 * span.x, lo.y - 0.1 * span.y};
    auto random_point = [&] { return Vec2{lo.x + 1.2 * span.x * unit(rng), lo.y + 1.2 * span.y * unit(rng)}; };
    for (const double factor : {1.0, sea::kFarFactor}) {
      const PreparedSea::CutEdges& cut = layout.prepared->cut_edges();
      const sea::NearBends near = sea::near_bends(p, nodes, 3, 1, nullptr, cut.edges, cut.index, factor);
      const sea::NearBends twice = sea::near_bends(p, nodes, 3, 2, nullptr, cut.edges, cut.index, factor);
      ASSERT_EQ(near.far_half, twice.far_half);
      ASSERT_EQ(near.cone_first, twice.cone_first);
      ASSERT_EQ(near.cones, twice.cones);
      for (size_t v = 0; v < nodes.size(); ++v) {
        if (!(near.far_half[v] > 0.0)) continue;
        ++nodes_with;
        for (int32_t i = near.cone_first[v]; i < near.cone_first[v + 1]; ++i) {
          const auto& [c0, c1] = near.cones[static_cast<size_t>(i)];
          ASSERT_LE(0.0, c0);
          ASSERT_LE(c0, c1);
          ASSERT_LE(c1, 4.0);
          if (i > near.cone_first[v]) {
            ASSERT_LT(near.cones[static_cast<size_t>(i) - 1].second, c0);
          }
        }
        const Visibility::Place at = vis.at_vertex(nodes[v].vertex, nodes[v].wedge);
        auto hidden = [&](const Visibility::Place& to, const char* what) {
          if (near.may_see(v, at.at, to.at, to.at)) {
            (vis.sees(at, to) ? kept_seen : kept_hidden) += 1;
            return;
          }
          ++passed_over;
          ASSERT_FALSE(vis.sees(at, to)) << what << " (" << to.at.x << ", " << to.at.y << ") from node " << v
                                         << ", square " << near.far_half[v];
        };
        for (const sea::Node& r : nodes) {
          if (r.vertex == nodes[v].vertex) continue;
          hidden(vis.at_vertex(r.vertex, r.wedge), "node");
          if (HasFatalFailure()) return;
        }
        for (const LocalSite& s : p.local) hidden(Visibility::Place{Vec2{s.ax, s.ay}}, "site");
        for (int i = 0; i < 40; ++i) {
          const Vec2 x = random_point();
          if (!vis.on_land(x)) hidden(Visibility::Place{x}, "point");
          // A box: when passed over, hidden at its low corner and at eight random points inside.
          const Vec2 y = random_point();
          const Vec2 b0{std::min(x.x, y.x), std::min(x.y, y.y)}, b1{std::max(x.x, y.x), std::max(x.y, y.y)};
          const Vec2 box_hi{b0.x + 0.2 * (b1.x - b0.x), b0.y + 0.2 * (b1.y - b0.y)};
          if (near.may_see(v, at.at, b0, box_hi)) continue;
          ++boxes_passed;
          for (int j = 0; j < 9; ++j) {
            const Vec2 q{b0.x + (j == 0 ? 0.0 : unit(rng)) * (box_hi.x - b0.x),
                         b0.y + (j == 0 ? 0.0 : unit(rng)) * (box_hi.y - b0.y)};
            if (!vis.on_land(q)) {
              ASSERT_FALSE(vis.sees(at, Visibility::Place{q})) << "in a box, from node " << v;
            }
          }
        }
        if (HasFatalFailure()) return;
      }
    }
  };
  for (int round = 0; round < 18; ++round) {
    const Layout layout = archipelago(rng, round, round % 3 == 2);
    if (!layout.prepared) continue;
    check(layout);
    if (HasFatalFailure()) return;
  }
  check(bay());
  std::printf(
      "nodes with far sight %lld: passed over %lld (all hidden), kept %lld seen and %lld hidden; boxes passed "
      "over %lld\n",
      static_cast<long long>(nodes_with), static_cast<long long>(passed_over), static_cast<long long>(kept_seen),
      static_cast<long long>(kept_hidden), static_cast<long long>(boxes_passed));
  EXPECT_GT(nodes_with, 1000);
  EXPECT_GT(passed_over, 20000);
  EXPECT_GT(kept_seen, 5000);
  EXPECT_GT(boxes_passed, 1000);
}

// Each node's near roots against the definition, read by brute force: the nodes at its nearest k
// other vertices (and every node as near as the k-th) that see it, and no other; every node
// beyond is at least its reach away (on the ellipsoid, by GeographicLib's distance between the
// vertices). The same on one thread and two.
TEST(NearBends, EachNodesNearRootsAreTheNearbyNodesThatSeeIt) {
  std::mt19937_64 rng(55);
  int64_t checked = 0, near_pairs = 0, hidden = 0, beyond = 0;
  for (int round = 0; round < 12; ++round) {
    const bool ellipsoid = round % 2 == 1;
    const Layout layout = archipelago(rng, round, ellipsoid);
    if (!layout.prepared) continue;
    const sea::Prepared& p = layout.prepared->prepared;
    const std::vector<sea::Node> nodes = sea::bend_nodes(p.vis);
    for (const int k : {1, 4, 16}) {
      const PreparedSea::CutEdges& cut = layout.prepared->cut_edges();
      const sea::NearBends near = sea::near_bends(p, nodes, k, 1, nullptr, cut.edges, cut.index);
      const sea::NearBends twice = sea::near_bends(p, nodes, k, 2, nullptr, cut.edges, cut.index);
      ASSERT_EQ(near.first, twice.first);
      ASSERT_EQ(near.to, twice.to);
      ASSERT_EQ(near.reach.size(), nodes.size());
      for (size_t r = 0; r < nodes.size(); ++r)
        ASSERT_TRUE(std::is_sorted(near.to.begin() + near.first[r], near.to.begin() + near.first[r + 1]));
      auto listed = [&](size_t r, size_t v) {
        return std::binary_search(near.to.begin() + near.first[r], near.to.begin() + near.first[r + 1],
                                  static_cast<int32_t>(v));
      };
      for (size_t v = 0; v < nodes.size(); ++v) {
        const Vec2 at = p.vis.vertex(nodes[v].vertex);
        // The distance to the k-th nearest other vertex.
        std::vector<std::pair<double, int32_t>> others;
        for (const sea::Node& n : nodes)
          if (n.vertex != nodes[v].vertex) others.emplace_back(sea::length(at, p.vis.vertex(n.vertex)), n.vertex);
        std::sort(others.begin(), others.end());
        others.erase(std::unique(others.begin(), others.end(),
                                 [](const auto& a, const auto& b) { return a.second == b.second; }),
                     others.end());
        std::sort(others.begin(), others.end());
        const double radius = others.size() >= static_cast<size_t>(k) ? others[static_cast<size_t>(k) - 1].first : kInf;
        for (size_t r = 0; r < nodes.size(); ++r) {
          if (nodes[r].vertex == nodes[v].vertex) {
            ASSERT_FALSE(listed(r, v));
            continue;
          }
          ++checked;
          const double d = sea::length(at, p.vis.vertex(nodes[r].vertex));
          if (d <= radius) {
            const bool sees = p.vis.sees(p.vis.at_vertex(nodes[v].vertex, nodes[v].wedge),
                                         p.vis.at_vertex(nodes[r].vertex, nodes[r].wedge));
            ASSERT_EQ(listed(r, v), sees) << "node " << v << ", root " << r << " at " << d << " of " << radius;
            (sees ? near_pairs : hidden) += 1;
            continue;
          }
          ASSERT_FALSE(listed(r, v)) << "node " << v << ", root " << r << " beyond " << radius;
          ++beyond;
          const double length = p.vertex_length(nodes[r].vertex, p.vertex_spot(nodes[v].vertex));
          ASSERT_LE(near.reach[v], length) << "node " << v << ", root " << r;
        }
      }
    }
  }
  std::printf("pairs checked %lld: near and seen %lld, near and hidden %lld, beyond the reach %lld\n",
              static_cast<long long>(checked), static_cast<long long>(near_pairs), static_cast<long long>(hidden),
              static_cast<long long>(beyond));
  EXPECT_GT(near_pairs, 1000);
  EXPECT_GT(hidden, 100);
  EXPECT_GT(beyond, 10000);
}

}  // namespace
}  // namespace rv
