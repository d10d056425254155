// rv/report/treaty.hpp: degrees-minutes-seconds, and segments between turning points on the ellipsoid.
#include "rv/report/treaty.hpp"

#include <GeographicLib/Geodesic.hpp>
#include <GeographicLib/GeodesicLine.hpp>
#include <GeographicLib/Rhumb.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <string>

#include "rv/field/error.hpp"

namespace rv {

std::string to_dms(double degrees, bool latitude, int decimals) {
  if (!std::isfinite(degrees)) return "";
  decimals = std::clamp(decimals, 0, 9);
  const char hemisphere = latitude ? (degrees < 0.0 ? 'S' : 'N') : (degrees < 0.0 ? 'W' : 'E');
  // Whole units of the last decimal shown, rounded once: the carries into seconds, minutes and
  // degrees follow from integer arithmetic.
  const double scale = std::pow(10.0, decimals);
  const auto units = static_cast<long long>(std::llround(std::abs(degrees) * 3600.0 * scale));
  const long long per_second = static_cast<long long>(scale);
  const long long whole_seconds = units / per_second, fraction = units % per_second;
  const long long d = whole_seconds / 3600, m = (whole_seconds / 60) % 60, sec = whole_seconds % 60;
  char text[64];
  if (decimals > 0)
    std::snprintf(text, sizeof text,
                  latitude ? "%02lld\u00b0%02lld'%02lld.%0*lld\"%c" : "%03lld\u00b0%02lld'%02lld.%0*lld\"%c", d, m, sec,
                  decimals, fraction, hemisphere);
  else
    std::snprintf(text, sizeof text, latitude ? "%02lld\u00b0%02lld'%02lld\"%c" : "%03lld\u00b0%02lld'%02lld\"%c", d, m,
                  sec, hemisphere);
  return text;
}

double from_dms(std::string_view text) {
  auto bad = [&]() -> double {
    throw Error(ErrorKind::invalid_argument, "not an angle in degrees, minutes and seconds: '" + std::string(text) +
                                                 "' (e.g. 55\u00b030'12.345\"N)");
  };
  // Three numbers separated by the degree sign, the apostrophe and the quote, then N, S, E or W.
  std::string s(text);
  double parts[3] = {0.0, 0.0, 0.0};
  size_t at = 0;
  for (int k = 0; k < 3; ++k) {
    while (at < s.size() && s[at] == ' ') ++at;
    size_t used = 0;
    try {
      parts[k] = std::stod(s.substr(at), &used);
    } catch (const std::exception&) {
      return bad();
    }
    at += used;
    const std::string_view marks[3] = {"\u00b0", "'", "\""};
    if (s.compare(at, marks[k].size(), marks[k]) != 0) return bad();
    at += marks[k].size();
  }
  while (at < s.size() && s[at] == ' ') ++at;
  if (at + 1 != s.size()) return bad();
  const char h = static_cast<char>(std::toupper(static_cast<unsigned char>(s[at])));
  if (h != 'N' && h != 'S' && h != 'E' && h != 'W') return bad();
  if (parts[1] >= 60.0 || parts[2] >= 60.0 || parts[0] < 0.0 || parts[1] < 0.0 || parts[2] < 0.0) return bad();
  const double v = parts[0] + parts[1] / 60.0 + parts[2] / 3600.0;
  return h == 'S' || h == 'W' ? -v : v;
}

namespace {

// The distance from p to the geodesic segment `line` of length `length`: the foot where the
// geodesic from it to p leaves the line at a right angle, by Newton's method on the position
// along the line (the step is the along-line component of the way to p, s cos(angle)), which
// converges in a few steps on a segment short against the Earth; a golden-section search where
// it does not. Clamped to the segment.
double to_segment(const GeographicLib::Geodesic& g, const GeographicLib::GeodesicLine& line, double length, Vec2 p) {
  auto at = [&](double s) {
    double lat = 0.0, lon = 0.0, d = 0.0;
    line.Position(s, lat, lon);
    g.Inverse(p.y, p.x, lat, lon, d);
    return d;
  };
  double s = 0.5 * length;
  for (int iter = 0; iter < 12; ++iter) {
    double lat = 0.0, lon = 0.0, azi_line = 0.0, d = 0.0, azi_to_p = 0.0, azi2 = 0.0;
    line.Position(s, lat, lon, azi_line);
    g.Inverse(lat, lon, p.y, p.x, d, azi_to_p, azi2);
    const double step = d * std::cos((azi_to_p - azi_line) * M_PI / 180.0);
    const double next = std::clamp(s + step, 0.0, length);
    if (std::abs(next - s) <= std::max(length * 1e-12, 1e-10)) return at(next);
    s = next;
  }
  // No convergence (a point far from a long segment): the golden-section search.
  constexpr double kGolden = 0.6180339887498949;
  double lo = 0.0, hi = length;
  double x1 = hi - kGolden * (hi - lo), x2 = lo + kGolden * (hi - lo);
  double f1 = at(x1), f2 = at(x2);
  const double stop = std::max(length * 1e-10, 1e-9);
  while (hi - lo > stop) {
    if (f1 <= f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - kGolden * (hi - lo);
      f1 = at(x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + kGolden * (hi - lo);
      f2 = at(x2);
    }
  }
  return std::min({f1, f2, at(0.0), at(length)});
}

}  // namespace

SegmentOnEllipsoid segment_on_ellipsoid(Vec2 from, Vec2 to, std::span<const Vec2> true_line, const MetricSpec& metric) {
  const GeographicLib::Geodesic g(metric.semi_major, metric.flattening);
  SegmentOnEllipsoid out;
  double azi2 = 0.0;
  g.Inverse(from.y, from.x, to.y, to.x, out.length, out.azimuth, azi2);
  if (!(out.length > 0.0)) return out;
  const GeographicLib::GeodesicLine line = g.InverseLine(from.y, from.x, to.y, to.x);
  const GeographicLib::Rhumb rhumb(metric.semi_major, metric.flattening);
  double rhumb_azimuth = 0.0;
  rhumb.Inverse(from.y, from.x, to.y, to.x, out.rhumb_length, rhumb_azimuth);
  constexpr int kRhumbSteps = 64;
  for (int k = 1; k < kRhumbSteps; ++k) {
    double lat = 0.0, lon = 0.0;
    rhumb.Direct(from.y, from.x, rhumb_azimuth, out.rhumb_length * k / kRhumbSteps, lat, lon);
    out.rhumb_separation = std::max(out.rhumb_separation, to_segment(g, line, out.length, Vec2{lon, lat}));
  }
  for (const Vec2& p : true_line) out.deviation = std::max(out.deviation, to_segment(g, line, out.length, p));
  return out;
}

}  // namespace rv
