// Test helpers of the raster tests: grids and seed sets made from code (random ones with a fixed
// seed for reproducibility), and a planar field of basepoints with what the deliverables read.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/seeds.hpp"

namespace rv::test {

// A grid of w x h square cells of `res` CRS units, its north-west corner at (xmin, ymax); by
// default ymax = h * res, so that the grid's south-west corner is (xmin, 0). No CRS.
inline GridSpec grid_of(int64_t w, int64_t h, double res = 1.0, double xmin = 0.0,
                        double ymax = std::numeric_limits<double>::quiet_NaN()) {
  GridSpec g;
  g.xmin = xmin;
  g.ymax = std::isnan(ymax) ? static_cast<double>(h) * res : ymax;
  g.res = res;
  g.width = w;
  g.height = h;
  return g;
}

// Basepoints, points[i] owned by owners[i] (labels; owners may be longer), computed exactly on `grid` (planar; no
// site beyond max_distance), with
// the metric and owner index the deliverables take.
struct PointsField {
  SeedSet seeds;
  GridSpec grid;
  NearestField field;
  PlanarSiteMetric metric;
  OwnerIndex index;

  PointsField(const std::vector<Vec2>& points, const std::vector<std::string>& owners, const GridSpec& g,
              double max_distance = std::numeric_limits<double>::infinity())
      : seeds(make(points, owners)),
        grid(g),
        field(compute(seeds, grid, options(max_distance))),
        metric(seeds, Vec2{g.xmin, g.ymax}),
        index(metric) {}

  // The distance from p to the nearest point of owner code `owner` (0: of any owner).
  double distance(Vec2 p, int32_t owner = 0) const {
    double best = std::numeric_limits<double>::infinity();
    for (const Site& s : seeds.sites())
      if (owner == 0 || seeds.features()[static_cast<size_t>(s.feature)].owner == owner)
        best = std::min(best, std::hypot(p.x - s.a.x, p.y - s.a.y));
    return best;
  }

 private:
  static ComputeOptions options(double max_distance) {
    ComputeOptions o;
    o.max_distance = max_distance;
    return o;
  }
  static SeedSet make(const std::vector<Vec2>& points, const std::vector<std::string>& owners) {
    SeedSet s;
    for (size_t i = 0; i < points.size(); ++i) s.add_point(s.add_feature(s.owner_code(owners[i])), points[i]);
    return s;
  }
};

// What mixed_seeds() makes: `features` features of `owners` owners (labels "o1", "o2", ..., in
// turn), each placed from a point uniform over [2, x1] x [2, y1]: feature i a coastline of three
// vertices when i % line_every == 1, an island (a quadrilateral) when listed in `islands`, else a
// point.
struct MixedSeeds {
  int features = 16, owners = 4;
  double x1 = 58.0, y1 = 43.0;
  int line_every = 4;
  std::vector<int> islands{6};
};
// Those seeds at origin + scale * (x, y).
inline SeedSet mixed_seeds(uint32_t seed, const MixedSeeds& m = {}, double scale = 1.0, Vec2 origin = {0.0, 0.0}) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(2, m.x1), uy(2, m.y1);
  auto at = [&](double x, double y) { return Vec2{origin.x + x * scale, origin.y + y * scale}; };
  SeedSet s;
  for (int i = 0; i < m.features; ++i) {
    const int32_t f = s.add_feature(s.owner_code("o" + std::to_string(1 + i % m.owners)));
    const double x = ux(rng), y = uy(rng);
    if (i % m.line_every == 1)
      s.add_polyline(f, std::vector<Vec2>{at(x, y), at(x + 3.1, y + 1.7), at(x + 4.2, y - 2.3)});
    else if (std::find(m.islands.begin(), m.islands.end(), i) != m.islands.end())
      s.add_polygon(f, {{at(x, y), at(x + 4.5, y), at(x + 4.0, y + 3.5), at(x, y + 3.0), at(x, y)}});
    else
      s.add_point(f, at(x, y));
  }
  return s;
}

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
