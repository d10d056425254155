// Seeds on the coast: vertices on land within the tolerance move onto the coast and end at sea;
// deeper ones are refused by name; the rest is untouched.
#include <gtest/gtest.h>

#include <cmath>

#include "rv/field/error.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/snap.hpp"
#include "rv/sea/visibility.hpp"
#include "seed_gen.hpp"

namespace rv {
namespace {

// Land below a diagonal coast from (0.1, 0.3) to (40.7, 21.9) (not axis-parallel: the nearest
// points on it are rounded).
Barriers diagonal_land() {
  Barriers b;
  b.add_polygon({{{0.1, 0.3}, {40.7, 21.9}, {40.7, -10}, {0.1, -10}}}, "land.gpkg:land:fid 1");
  return b;
}

// A point `depth` inland, square to the coast, at fraction t along it.
Vec2 inland(double t, double depth) {
  const Vec2 a{0.1, 0.3}, e{40.7, 21.9};
  const double len = std::hypot(e.x - a.x, e.y - a.y);
  return {a.x + t * (e.x - a.x) + depth * (e.y - a.y) / len, a.y + t * (e.y - a.y) - depth * (e.x - a.x) / len};
}

TEST(Snap, PortsJustInlandMoveOntoTheCoast) {
  const Barriers land = diagonal_land();
  const Visibility vis(land);
  SeedSet s;
  const Vec2 port = inland(0.37, 0.3), sea_port{12.5, 30.25};
  ASSERT_TRUE(vis.on_land(port));
  s.add_point(s.add_feature(s.owner_code("A"), "ports.gpkg:ports:fid 4"), port);
  s.add_point(s.add_feature(s.owner_code("B"), "ports.gpkg:ports:fid 5"), sea_port);
  const SnappedSeeds snapped = snap_to_sea(s, land, 1.0);
  EXPECT_EQ(snapped.moved, 1);
  EXPECT_NEAR(snapped.largest_move, 0.3, 1e-9);
  const Vec2 now = snapped.seeds.sites()[0].a;
  EXPECT_FALSE(vis.on_land(now));
  EXPECT_EQ(snapped.seeds.sites()[1].a, sea_port);  // at sea: untouched
  // The moved port serves the sea in front of it.
  const GridSpec g = test::grid_of(40, 40, 1.0, 0.0, 40.0);
  const SeaField f = compute_sea(snapped.seeds, land, g, g.full_window());
  int64_t owned = 0;
  for (int64_t r = 0; r < g.height; ++r)
    for (int64_t c = 0; c < g.width; ++c) owned += f.field.site.at(c, r) == 0;
  EXPECT_GT(owned, 50);
  // Unsnapped, the port is refused.
  EXPECT_THROW(compute_sea(s, land, g, g.full_window()), Error);
}

TEST(Snap, DeeperThanTheToleranceIsRefusedByName) {
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A"), "ports.gpkg:ports:fid 4"), inland(0.5, 2.0));
  try {
    snap_to_sea(s, diagonal_land(), 1.0);
    FAIL() << "a port 2 inland was moved with a tolerance of 1";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::invalid_input);
    EXPECT_NE(std::string(e.what()).find("ports.gpkg:ports:fid 4"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("inside a barrier"), std::string::npos) << e.what();
  }
  EXPECT_THROW(snap_to_sea(s, diagonal_land(), -1.0), Error);
}

// Two states' land as seeds and barriers both, overlapping along their border (as the western
// Baltic's do): A's polygon runs 0.5 into B's. A's vertices under B's land lie on A's own
// boundary but inside B: a land border no path reaches. They stay where they are (moved, they
// would end nowhere near a coast: the nearest coast is B's, 1 away), the seed is
// reached where it is at sea, and the report counts them. A seed all of whose vertices are such
// lies inside the barriers: refused by name.
TEST(Snap, AVertexOnALandBorderUnderAnotherBarrierStays) {
  const Ring a{{0, 0}, {10.5, 1}, {10.5, 9}, {0, 10}}, b{{10, 0}, {20, 0}, {20, 10}, {10, 10}};
  Barriers land;
  land.add_polygon({a}, "states:fid 1");
  land.add_polygon({b}, "states:fid 2");
  SeedSet s;
  s.add_polygon(s.add_feature(s.owner_code("A"), "states:fid 1"), {a});
  s.add_polygon(s.add_feature(s.owner_code("B"), "states:fid 2"), {b});
  const SnappedSeeds snapped = snap_to_sea(s, land, 0.1);
  EXPECT_EQ(snapped.moved, 0);
  EXPECT_EQ(snapped.on_land_borders, 2);  // (10.5, 1) and (10.5, 9): on A's boundary, under B
  ASSERT_EQ(snapped.seeds.polygons().size(), 2u);
  EXPECT_EQ(snapped.seeds.polygons()[0].rings[0], a);
  // Engines take such a seed: the sea round the two states is the straight field's.
  const GridSpec g = test::grid_of(30, 20, 1.0, -5.0, 15.0);
  EXPECT_NO_THROW(compute_sea(snapped.seeds, land, g, g.full_window()));
  // An island of A's wholly under B's land (its every vertex on A's own boundary, inside B).
  Barriers covered = land;
  const Ring islet{{12, 2}, {14, 2}, {14, 4}, {12, 4}};
  covered.add_polygon({islet}, "islets:fid 7");
  SeedSet t = s;
  t.add_polygon(t.add_feature(t.owner_code("A"), "islets:fid 7"), {islet});
  try {
    snap_to_sea(t, covered, 0.1);
    FAIL() << "a seed wholly under another barrier was taken";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::invalid_input);
    EXPECT_NE(std::string(e.what()).find("islets:fid 7"), std::string::npos) << e.what();
  }
  // A point seed on that border is no land border's vertex: refused as any seed that deep.
  SeedSet u = s;
  u.add_point(u.add_feature(u.owner_code("A"), "ports:fid 3"), {10.5, 5.0});
  EXPECT_THROW(snap_to_sea(u, land, 0.1), Error);
}

TEST(Snap, ALineMovesAsOneAndStaysConnected) {
  // A coast line digitised a little inland: every vertex moves, shared ends alike.
  const Barriers land = diagonal_land();
  const Visibility vis(land);
  SeedSet s;
  const int32_t f = s.add_feature(s.owner_code("coast"), "coast.gpkg:coast:fid 2");
  // It starts at the coast's own first vertex (exactly on it, whatever the rounding).
  s.add_polyline(f, std::vector<Vec2>{inland(0.0, 0.0), inland(0.2, 0.05), inland(0.3, 0.2), inland(0.45, 0.1)});
  ASSERT_EQ(s.sites()[0].a, (Vec2{0.1, 0.3}));
  const SnappedSeeds snapped = snap_to_sea(s, land, 0.5);
  EXPECT_EQ(snapped.moved, 3);
  const auto& sites = snapped.seeds.sites();
  ASSERT_EQ(sites.size(), 3u);
  for (size_t i = 0; i < sites.size(); ++i) {
    EXPECT_FALSE(vis.on_land(sites[i].a));
    EXPECT_FALSE(vis.on_land(sites[i].b));
    if (i > 0) {
      EXPECT_EQ(sites[i].a, sites[i - 1].b);
    }
  }
  EXPECT_LE(snapped.largest_move, 0.2 + 1e-9);
}

TEST(Snap, NothingOnLandNothingMoves) {
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A")), {5.5, 30.5});
  s.add_polygon(s.add_feature(s.owner_code("B")), {{{20, 30}, {25, 30}, {25, 35}}});
  const SnappedSeeds snapped = snap_to_sea(s, diagonal_land(), 1.0);
  EXPECT_EQ(snapped.moved, 0);
  EXPECT_EQ(snapped.largest_move, 0.0);
  ASSERT_EQ(snapped.seeds.sites().size(), s.sites().size());
  for (size_t i = 0; i < s.sites().size(); ++i) {
    EXPECT_EQ(snapped.seeds.sites()[i].a, s.sites()[i].a);
    EXPECT_EQ(snapped.seeds.sites()[i].b, s.sites()[i].b);
  }
}

// On the ellipsoid: a port 0.4 m inside a longitude/latitude island (its west edge along 11.0 E,
// a geodesic) is moved onto the coast, seen from the geodesic frame as sea, and stays sea in a
// frame of another centre; at a tolerance of 0.1 m it is refused.
TEST(Snap, OnTheEllipsoidInMetres) {
  MetricSpec metric;
  metric.kind = MetricSpec::geodesic;
  Barriers land;
  land.add_polygon({Ring{{11.0, 55.0}, {11.3, 55.0}, {11.3, 55.2}, {11.0, 55.2}}}, "island");
  // 0.4 m east of the edge at 55.1 N (the edge is a meridian: due east is perpendicular).
  const double east = 0.4 / (111320.0 * std::cos(55.1 * M_PI / 180.0));
  SeedSet s;
  s.add_point(s.add_feature(s.owner_code("A")), {11.0 + east, 55.1});
  const auto frame = std::make_shared<const GeodesicFrame>(metric, 10.9, 54.9, 11.4, 55.3);
  const SnappedSeeds snapped = snap_to_sea(s, land, 1.0, frame);
  EXPECT_EQ(snapped.moved, 1);
  EXPECT_NEAR(snapped.largest_move, 0.4, 0.01);
  const Vec2 moved = snapped.seeds.sites()[0].a;
  EXPECT_LT(moved.x, 11.0 + east);
  const auto other = std::make_shared<const GeodesicFrame>(metric, 10.0, 54.0, 12.0, 56.0);
  for (const auto& f : {frame, other}) {
    const Visibility vis(land.mapped([&](Vec2 v) { return f->forward(v); }), true, f);
    EXPECT_FALSE(vis.on_land(f->forward(moved)));
  }
  EXPECT_THROW(snap_to_sea(s, land, 0.1, frame), Error);
}

}  // namespace
}  // namespace rv
