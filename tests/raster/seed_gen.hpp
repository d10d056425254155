// Test helpers: seed sets generated from code (random, with a fixed seed for reproducibility).
#pragma once

#include <random>

#include "rv/seeds.hpp"

namespace rv::test {

// n point seeds, uniform over [x0, x1] x [y0, y1], each its own owner.
inline SeedSet random_points(int n, double x0, double y0, double x1, double y1, uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(x0, x1), uy(y0, y1);
  SeedSet s;
  for (int i = 0; i < n; ++i) {
    const int32_t f = s.add_feature(s.owner_code(std::to_string(i + 1)));
    s.add_point(f, {ux(rng), uy(rng)});
  }
  return s;
}

}  // namespace rv::test
