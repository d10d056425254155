// Geodesic distances on an ellipsoid of revolution, as the engines measure them.
//
// Coordinates are (x = longitude, y = latitude) in degrees; latitudes must lie in [-90, 90],
// longitudes may have any value (they are reduced modulo 360 when measuring, so grids may run
// past 180 across the antimeridian). Distances are metres on the ellipsoid of the MetricSpec.
//
//   point:   GeographicLib::Geodesic::Inverse (the shortest geodesic; error ~15 nm for WGS84).
//   segment: the edge between two vertices is the shortest geodesic between them; the distance
//            is to the nearest point of that geodesic segment (ends included). Computed by
//            Karney's interception iteration: from a point X(t) on the segment, solve the inverse
//            problem X -> P, getting the azimuth w between the segment and the geodesic to P, the
//            reduced length m12 and the geodesic scale M12; move along the segment by
//            dt = m12 cos(w) / M12 (exact for a plane, quadratically convergent on the
//            ellipsoid), inside a bracket that falls back to bisection, clamped to the ends.
//            Edges are handled in pieces of at most 100 km, each inside a bounding ball, so the
//            iteration always runs where the distance along the piece is convex (the cell within
//            ~80 degrees of the piece) or takes the robust path (ends plus bracketed search).
//            The returned value is the distance to an actual point of the segment, so it never
//            underestimates; it overestimates the true minimum by < 1e-9 m (convergence test)
//            plus GeographicLib's own error. Measured: within 2e-9 m of a dense sampling along
//            GeographicLib::GeodesicLine, 1.0 (500 m coastline edges) to 1.4 (edges up to
//            300 km) inverse problems per piece. When the nearest point is a vertex, the value
//            is the inverse problem from the vertex as given, so edges sharing the vertex agree
//            bit for bit.
//            Limits: an edge between antipodal vertices is whichever shortest geodesic
//            GeographicLib picks; beyond ~80 degrees from a piece the search checks the ends and
//            a bracketed interior critical point (no convexity there), still never below the
//            true distance.
//
// Thread safety: pure functions; GeodesicMeasure is immutable after construction and may be
// shared by any number of threads.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "rv/field/geolocate.hpp"
#include "rv/field/metric.hpp"
#include "rv/field/seeds.hpp"

namespace rv {

class GeodesicMeasure {
 public:
  // Throws rv::Error(invalid_argument) for a spec that is not geodesic or has a bad ellipsoid.
  explicit GeodesicMeasure(const MetricSpec& metric);
  ~GeodesicMeasure();
  GeodesicMeasure(GeodesicMeasure&&) noexcept;
  GeodesicMeasure& operator=(GeodesicMeasure&&) noexcept;

  // Distance in metres between two (lon, lat) positions.
  double point_distance(Vec2 p, Vec2 q) const;
  // The same distance, to the bit, with its gradient with respect to p: metres per degree of
  // longitude and latitude (NaN where p == q).
  double point_distance(Vec2 p, Vec2 q, Vec2& gradient) const;
  // The gradient at p (metres per degree of longitude and latitude) of a distance that grows at
  // one metre per metre in the direction `azimuth` (degrees clockwise from north) and not across it.
  Vec2 gradient(Vec2 p, double azimuth) const;
  // Points on the geodesic from a to b (longitude/latitude), a and b included as given,
  // longitudes continuous from a's, as few as keep every straight chord between two consecutive
  // ones within `tolerance` metres (> 0) of the geodesic between them: chords straight in
  // longitude/latitude, or with `grid`, straight in the grid's CRS (the points still returned in
  // longitude/latitude). A piece is halved until its geodesic midpoint lies within half the
  // tolerance of its chord (where a chord departs most on so flat an arc; the half a margin for
  // the rest), so a meridian or the equator keeps its two ends. Throws
  // rv::Error(invalid_argument) for a latitude beyond +-90 or a tolerance not above 0.
  std::vector<Vec2> chords(Vec2 a, Vec2 b, double tolerance, const Geolocator* grid = nullptr) const;
  // Distance in metres from p to the geodesic segment a-b (a == b: the point distance).
  // Prepares the edge on every call (one more inverse problem); for many cells against the same
  // edges use compute(). Throws rv::Error(invalid_argument) for a latitude beyond +-90.
  double segment_distance(Vec2 p, Vec2 a, Vec2 b) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Counters of the segment iteration in the calling thread (for benchmarks): calls = piece
// searches, evaluations = inverse problems solved by them.
struct GeodesicSegmentCounters {
  int64_t calls = 0;
  int64_t evaluations = 0;
};
GeodesicSegmentCounters& geodesic_segment_counters();

}  // namespace rv
