#include "sea/orient.hpp"

#include <array>
#include <cmath>

namespace rv::sea {
namespace {

// a + b as s + e exactly (Knuth's branch-free two-sum).
inline void two_sum(double a, double b, double& s, double& e) {
  s = a + b;
  const double bb = s - a;
  e = (a - (s - bb)) + (b - bb);
}

// a * b as p + e exactly: std::fma rounds once, so a*b - p is representable.
inline void two_product(double a, double b, double& p, double& e) {
  p = a * b;
  e = std::fma(a, b, -p);
}

// The sign of the exact sum of `n` doubles: the terms are grown into a non-overlapping expansion
// (components of increasing magnitude), whose sign is that of its largest non-zero component.
template <size_t N>
int exact_sign(const std::array<double, N>& terms) {
  std::array<double, N> expansion{};
  size_t length = 0;
  for (double t : terms) {
    double q = t;
    for (size_t i = 0; i < length; ++i) {
      double s, e;
      two_sum(q, expansion[i], s, e);
      expansion[i] = e;
      q = s;
    }
    expansion[length++] = q;
  }
  for (size_t i = length; i-- > 0;)
    if (expansion[i] != 0.0) return expansion[i] > 0.0 ? 1 : -1;
  return 0;
}

}  // namespace

int orient_exact(const Vec2& a, const Vec2& b, const Vec2& c) {
  // Exact: each difference as hi + lo, each product of two such pairs as four exact products.
  double bxh, bxl, cyh, cyl, byh, byl, cxh, cxl;
  two_sum(b.x, -a.x, bxh, bxl);
  two_sum(c.y, -a.y, cyh, cyl);
  two_sum(b.y, -a.y, byh, byl);
  two_sum(c.x, -a.x, cxh, cxl);
  std::array<double, 16> t{};
  const double left[2] = {bxh, bxl}, left2[2] = {cyh, cyl};
  const double right[2] = {byh, byl}, right2[2] = {cxh, cxl};
  size_t k = 0;
  for (double u : left)
    for (double v : left2) {
      two_product(u, v, t[k], t[k + 1]);
      k += 2;
    }
  for (double u : right)
    for (double v : right2) {
      two_product(-u, v, t[k], t[k + 1]);
      k += 2;
    }
  return exact_sign(t);
}

int along(const Vec2& a, const Vec2& b, const Vec2& c) {
  const bool by_x = std::abs(b.x - a.x) >= std::abs(b.y - a.y);
  const double from = by_x ? a.x : a.y, to = by_x ? b.x : b.y, at = by_x ? c.x : c.y;
  if (at == from) return 0;
  return (at > from) == (to > from) ? 1 : -1;
}

}  // namespace rv::sea
