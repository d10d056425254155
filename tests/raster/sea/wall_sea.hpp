// A wall and the distance by sea round it, as the lines' tests use them: the barrier line from a
// to b, the exact engine's field of the seeds over the grid, the metric by sea and its index.
#pragma once

#include <initializer_list>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rv/engine/owner_index.hpp"
#include "rv/sea/sea_field.hpp"
#include "rv/sea/sea_metric.hpp"

namespace rv::test {

// Point seeds, one per (owner, position), in order: each a feature of that owner.
inline SeedSet named_points(std::initializer_list<std::pair<std::string, Vec2>> list) {
  SeedSet s;
  for (const auto& [owner, p] : list) s.add_point(s.add_feature(s.owner_code(owner)), p);
  return s;
}

struct WallSea {
  Barriers wall;
  SeaField field;
  std::unique_ptr<SiteMetric> metric;
  std::unique_ptr<OwnerIndex> index;  // adjusted (the engine's rule; plain distances without weights)
  // `seeds` must outlive it (the metric keeps a reference). `options`: the engine's and the
  // metric's (e.g. the geodesic metric, the wall then a geodesic in longitude/latitude).
  WallSea(const SeedSet& seeds, Vec2 a, Vec2 b, const GridSpec& g, const SeaOptions& options = {}) {
    wall.add_line(std::vector<Vec2>{a, b}, "wall");
    field = compute_sea(seeds, wall, g, g.full_window(), options);
    metric = make_sea_site_metric(seeds, wall, g, options);
    index = std::make_unique<OwnerIndex>(*metric);
  }
};

}  // namespace rv::test
