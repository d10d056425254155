// The engine benchmarks' point case: a square grid of unit cells and uniformly random point
// seeds over it, one owner per point. engine_bench (the paper's Table 1 rows) and
// span_floor_bench (its largest row) build it here, so that their numbers are of the same points.
#pragma once

#include <cstdint>
#include <random>
#include <string>

#include "rv/field/grid.hpp"
#include "rv/field/seeds.hpp"

namespace rv::bench {

// size x size cells of 1 unit, covering [0, size] x [0, size].
inline GridSpec square_grid(int64_t size) {
  GridSpec g;
  g.xmin = 0;
  g.ymax = static_cast<double>(size);
  g.res = 1;
  g.width = g.height = size;
  return g;
}

// n points uniform over [0, w) x [0, h), owners "1".."n"; the same seed gives the same points.
inline SeedSet random_points(int n, double w, double h, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(0, w), uy(0, h);
  SeedSet s;
  for (int i = 0; i < n; ++i) s.add_point(s.add_feature(s.owner_code(std::to_string(i + 1))), {ux(rng), uy(rng)});
  return s;
}

}  // namespace rv::bench
