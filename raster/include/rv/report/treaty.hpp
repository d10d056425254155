// What a treaty table states of a line: positions in degrees, minutes and seconds, and the
// segments joining its turning points on the ellipsoid (GeographicLib).
//
// Treaties give a boundary as turning points joined by lines of a named kind (geodesics, or
// rhumb lines, loxodromes). segment_on_ellipsoid says what such a segment is and what it costs:
// its geodesic length and initial azimuth, how far the rhumb line between the same two points
// strays from the geodesic, and how far the true equidistance line between them strays from the
// geodesic segment.
//
// Units: degrees (longitude east, latitude north), metres. Pure functions; thread-safe.
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "rv/field/metric.hpp"
#include "rv/field/seeds.hpp"

namespace rv {

// An angle as degrees, minutes and seconds with `decimals` decimals of a second and the
// hemisphere: 55°30'12.345"N, 012°05'00.000"E (three digits of longitude degrees). Rounded once,
// to the last decimal shown (59.9996" becomes the next minute). Non-finite: "".
std::string to_dms(double degrees, bool latitude, int decimals = 3);
// The inverse of to_dms for its output (and the same without leading zeros, or with spaces
// between the parts): signed degrees. Throws rv::Error(invalid_argument) for anything else.
double from_dms(std::string_view text);

struct SegmentOnEllipsoid {
  double length = 0.0;            // geodesic length, metres
  double azimuth = 0.0;           // initial azimuth of the geodesic, degrees clockwise from north
  double rhumb_length = 0.0;      // the rhumb line's length, metres
  double rhumb_separation = 0.0;  // largest distance from a point of the rhumb line to the geodesic, metres
  double deviation = 0.0;         // largest distance from `true_line` to the geodesic segment, metres
};
// The segment from `from` to `to` (longitude/latitude degrees) on the ellipsoid of `metric`
// (its semi-major axis and flattening; the kind is not read). `true_line`: the line the segment
// stands for between the two points (longitude/latitude), measured against the geodesic
// segment. A point's distance to the geodesic segment is to its foot on it (Newton's method on
// the position along it, a golden-section search where that fails); the rhumb line is followed
// in 64 steps.
SegmentOnEllipsoid segment_on_ellipsoid(Vec2 from, Vec2 to, std::span<const Vec2> true_line, const MetricSpec& metric);

}  // namespace rv
