// A wall and the distance by sea round it, as the lines' tests use them: the barrier line from a
// to b, the exact engine's field of the seeds over the grid, the metric by sea and its index.
#pragma once

#include <memory>
#include <vector>

#include "rv/engine/owner_index.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/sea_metric.hpp"

namespace rv::test {

struct WallSea {
  Barriers wall;
  SeaField field;
  std::unique_ptr<SiteMetric> metric;
  std::unique_ptr<OwnerIndex> index;  // adjusted (the engine's rule; plain distances without weights)
  // `seeds` must outlive it (the metric keeps a reference).
  WallSea(const SeedSet& seeds, Vec2 a, Vec2 b, const GridSpec& g) {
    wall.add_line(std::vector<Vec2>{a, b}, "wall");
    field = compute_sea(seeds, wall, g, g.full_window());
    metric = make_sea_site_metric(seeds, wall, g);
    index = std::make_unique<OwnerIndex>(*metric);
  }
};

}  // namespace rv::test
