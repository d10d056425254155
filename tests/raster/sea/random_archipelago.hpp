// Random archipelagos for the distance by sea's tests: seven quadrilateral islands on a 40-unit
// square (the larger ones with a triangular lagoon) that may overlap, touch and share edges, a
// boom, up to five ports at sea, a port on a coast and a coast edge as a line seed. Whole-number
// corners: collinear and coincident cases come often, which is what these layouts are for.
#pragma once

#include <functional>
#include <random>
#include <vector>

#include "rv/sea/barriers.hpp"
#include "rv/sea/visibility.hpp"

namespace rv::test {

struct Archipelago {
  Barriers barriers;
  SeedSet seeds;
};

// The next layout from `rng`; `round` picks the island whose coast the seeds take. `to` maps the
// 40-unit square's coordinates to the layout's (longitude and latitude, say).
inline Archipelago random_archipelago(
    std::mt19937_64& rng, int round, const std::function<Vec2(Vec2)>& to = [](Vec2 v) { return v; }) {
  std::uniform_int_distribution<int> coord(0, 36);
  Archipelago out;
  Barriers& b = out.barriers;
  std::vector<Ring> outlines;
  for (int k = 0; k < 7; ++k) {
    const double x = coord(rng), y = coord(rng), w = 2 + coord(rng) % 7, h = 2 + coord(rng) % 7;
    std::vector<Ring> rings{{to({x, y}), to({x + w, y}), to({x + w * 0.6, y + h}), to({x, y + h * 0.8})}};
    if (w > 5 && h > 5) rings.push_back({to({x + 1.5, y + 1.5}), to({x + 3, y + 1.5}), to({x + 2.5, y + 3})});
    outlines.push_back(rings[0]);
    b.add_polygon(rings, "island");
  }
  const Vec2 b0{double(coord(rng)), double(coord(rng))}, b1{double(coord(rng)), double(coord(rng))};
  b.add_line(std::vector<Vec2>{to(b0), to(b1)}, "boom");
  const Visibility vis(b);
  SeedSet& s = out.seeds;
  int ports = 0;
  for (int k = 0; k < 12 && ports < 5; ++k) {
    const Vec2 p = to({coord(rng) + 0.25, coord(rng) + 0.75});
    if (vis.on_land(p)) continue;
    s.add_point(s.add_feature(s.owner_code(ports % 2 ? "A" : "B")), p);
    ++ports;
  }
  // A port on a coast, and a coast as a line seed (it may run through another island's land).
  const Ring& o = outlines[static_cast<size_t>(round) % outlines.size()];
  s.add_point(s.add_feature(s.owner_code("C")), {(o[0].x + o[1].x) / 2, (o[0].y + o[1].y) / 2});
  s.add_polyline(s.add_feature(s.owner_code("D")), std::vector<Vec2>{o[1], o[2]});
  return out;
}

}  // namespace rv::test
