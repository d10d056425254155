#include "rv/sea/barriers.hpp"

#include <algorithm>
#include <cmath>

#include "rv/field/error.hpp"

namespace rv {
namespace {

std::vector<Vec2> without_repeats(std::span<const Vec2> vertices, const SourceText& source, const char* what) {
  std::vector<Vec2> out;
  out.reserve(vertices.size());
  for (const Vec2& v : vertices) {
    if (!std::isfinite(v.x) || !std::isfinite(v.y))
      throw Error(ErrorKind::invalid_input, std::string("barrier ") + what +
                                                (source.empty() ? std::string() : " " + source.str()) +
                                                " has a non-finite coordinate");
    if (out.empty() || !(out.back() == v)) out.push_back(v);
  }
  return out;
}

// Twice the signed area (shoelace); positive for counter-clockwise rings.
double twice_area(const Ring& r) {
  double s = 0.0;
  for (size_t i = 0, n = r.size(); i < n; ++i) {
    const Vec2& a = r[i];
    const Vec2& b = r[(i + 1) % n];
    s += (a.x - r[0].x) * (b.y - r[0].y) - (b.x - r[0].x) * (a.y - r[0].y);
  }
  return s;
}

}  // namespace

int32_t Barriers::add_polygon(std::vector<Ring> rings, SourceText source) {
  Polygon p;
  for (size_t i = 0; i < rings.size(); ++i) {
    Ring r = without_repeats(rings[i], source, "polygon");
    while (r.size() > 1 && r.back() == r.front()) r.pop_back();
    if (r.size() < 3) continue;
    // Land to the left of every edge: the outer ring counter-clockwise, holes clockwise.
    const double a = twice_area(r);
    const bool outer = p.rings.empty() && i == 0;
    if ((outer && a < 0.0) || (!outer && a > 0.0)) std::reverse(r.begin(), r.end());
    if (i == 0 || !p.rings.empty()) p.rings.push_back(std::move(r));
  }
  if (p.rings.empty()) return -1;
  p.barrier = size();
  polygons_.push_back(std::move(p));
  sources_.push_back(std::move(source));
  return polygons_.back().barrier;
}

int32_t Barriers::add_line(std::span<const Vec2> vertices, SourceText source) {
  Line l;
  l.vertices = without_repeats(vertices, source, "line");
  if (l.vertices.size() < 2) return -1;
  l.barrier = size();
  lines_.push_back(std::move(l));
  sources_.push_back(std::move(source));
  return lines_.back().barrier;
}

std::string Barriers::name(int32_t barrier) const {
  const SourceText& s = sources_.at(static_cast<size_t>(barrier));
  return s.empty() ? "barrier " + std::to_string(barrier + 1) : s.str();
}

Barriers Barriers::translated(Vec2 origin) const {
  return mapped([&](Vec2 v) { return Vec2{v.x - origin.x, v.y - origin.y}; });
}

Barriers Barriers::mapped(const std::function<Vec2(Vec2)>& f) const {
  Barriers out = *this;
  for (Polygon& p : out.polygons_)
    for (Ring& r : p.rings)
      for (Vec2& v : r) v = f(v);
  for (Line& l : out.lines_)
    for (Vec2& v : l.vertices) v = f(v);
  return out;
}

int64_t Barriers::vertex_count() const {
  int64_t n = 0;
  for (const Polygon& p : polygons_)
    for (const Ring& r : p.rings) n += static_cast<int64_t>(r.size());
  for (const Line& l : lines_) n += static_cast<int64_t>(l.vertices.size());
  return n;
}

}  // namespace rv
