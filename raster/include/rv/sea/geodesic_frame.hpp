// The plane the distance by sea decides visibility in when distances are geodesic: the
// ellipsoidal gnomonic projection (GeographicLib::Gnomonic; Karney, "Algorithms for geodesics",
// J. Geodesy 87, 2013, section 8) centred in the data. On a sphere it maps every geodesic to a
// straight line; on the ellipsoid a geodesic's image bends away from the straight line through
// its ends by millimetres over hundreds of kilometres (measured on WGS84: 4.6 mm for the 428 km
// geodesic between (9.0 E, 53.8 N) and (15.5 E, 53.8 N) in a frame centred at (12.25 E, 55 N);
// micrometres for edges under 100 km).
//
// So the frame's orientation predicate is the geodesic one, decided in two steps: the plane's
// determinant where it is farther from zero than the images' bending can move it (`deviation()`,
// a bound measured over the frame's box at construction, with a safety factor), else the exact
// ellipsoidal test: c lies left of the geodesic from a through b when the geodesic from a to c
// leaves a at a smaller azimuth (counter-clockwise), from GeographicLib's inverse problems on
// the points' longitudes and latitudes. Geodesics from one point never meet again this side of
// their conjugate point (thousands of kilometres on the Earth), so that order is the order of
// the geodesics themselves. The result: visibility, wedges and land read every barrier edge and
// every path as the geodesic between its ends, exactly up to GeographicLib's own error (about
// 15 nm for WGS84), whatever the frame's bending.
//
// Units: longitudes and latitudes in degrees; plane coordinates in metres. The box may reach at
// most 40 degrees of arc from its centre (the projection's scale grows as 1 / cos^2 of it, and
// the bending is measured over the box enlarged to twice its size).
// Thread safety: immutable once built; const access from any number of threads.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>

#include "rv/field/metric.hpp"
#include "rv/field/seeds.hpp"
#include "rv/sea/barriers.hpp"

namespace rv {

class GeodesicFrame {
 public:
  // A frame for everything in the box (lon_min..lon_max, lat_min..lat_max, degrees; longitudes
  // may exceed 180 for a box across the antimeridian), centred at its middle. Throws
  // rv::Error(invalid_argument) for a metric that is not geodesic, an empty or non-finite box,
  // or one reaching more than 40 degrees of arc from its centre.
  // Points the frame holds lie in the box; reference points (east_of) within half its size of it.
  GeodesicFrame(const MetricSpec& metric, double lon_min, double lat_min, double lon_max, double lat_max);
  ~GeodesicFrame();
  GeodesicFrame(const GeodesicFrame&) = delete;
  GeodesicFrame& operator=(const GeodesicFrame&) = delete;

  // Plane (metres) from (lon, lat) degrees, and back.
  Vec2 forward(Vec2 lonlat) const;
  Vec2 reverse(Vec2 plane) const;
  // forward() of n points along a parallel, (lon0 + i * dlon, lat), i in [0, n): a row of cells.
  // Exact at points about 4 km (at most 64 cells) apart and near both ends; between, quintic
  // interpolation of the exact ones (the projection is smooth: within 1e-8 m of forward(), tested
  // on the western Baltic's rows and on a frame 50 by 30 degrees, below GeographicLib's own
  // error). Fine rows cost a small fraction of forward() per point.
  void forward_row(double lat, double lon0, double dlon, int64_t n, Vec2* out) const;
  // Point i of forward_row(lat, lon0, dlon, n, ...), the same to the bit, alone (eight forward
  // problems): for a cell of a row whose other cells are not wanted.
  Vec2 forward_row_point(double lat, double lon0, double dlon, int64_t n, int64_t i) const;
  // The largest distance (metres) between a geodesic's image and the straight line through any
  // two of its points, over the box, as the predicate allows for it.
  double deviation() const { return deviation_; }
  // The largest scale of the projection over the box (enlarged as for the deviation), with a
  // margin: a plane distance d means at least d / max_scale() metres on the ellipsoid.
  double max_scale() const { return max_scale_; }
  // The geodesic reading of the orientation of plane points a, b, c: +1 when c lies left of the
  // geodesic from a through b, -1 right, 0 when c is a or b (or a is b) or lies on that geodesic
  // to GeographicLib's precision. (What the exact test locates and measures is remembered per
  // thread, about 96 KB each, for points that come back: the answers are the same.)
  int orient(const Vec2& a, const Vec2& b, const Vec2& c) const;
  // A point east of `at` in the plane, for a reference direction: at + (half the box's width, 0).
  Vec2 east_of(Vec2 at) const { return Vec2{at.x + reach_, at.y}; }
  // How many orient() calls the exact test decided (for tests and benchmarks).
  int64_t exact_tests() const { return exact_tests_.load(std::memory_order_relaxed); }

 private:
  int64_t row_step(double lat, double lon0, double dlon, int64_t n) const;
  int orient_exact(const Vec2& a, const Vec2& b, const Vec2& c) const;

  struct Impl;
  std::unique_ptr<Impl> impl_;
  double deviation_ = 0.0;
  double max_scale_ = 1.0;
  double reach_ = 1.0;  // half the box's width in the plane (metres, at least 1)
  uint64_t id_ = 0;     // this frame's number in the exact test's memos
  mutable std::atomic<int64_t> exact_tests_{0};
};

// A frame centred in everything given, in longitude/latitude: the barriers, the seeds (sites and
// polygons) and, when `box` is not empty (xmin > xmax: empty), that box too (a grid's). Throws
// as the constructor.
struct LonLatBox {
  double xmin = 1.0, ymin = 1.0, xmax = -1.0, ymax = -1.0;
};
std::shared_ptr<const GeodesicFrame> frame_for(const MetricSpec& metric, const Barriers& barriers, const SeedSet& seeds,
                                               LonLatBox box = {});

}  // namespace rv
