#include "rv/field/grid.hpp"

#include <cmath>
#include <limits>

#include "rv/field/error.hpp"

namespace rv {
namespace {

void check_extent(double xmin, double ymin, double xmax, double ymax, double res) {
  if (!std::isfinite(xmin) || !std::isfinite(ymin) || !std::isfinite(xmax) || !std::isfinite(ymax))
    throw Error(ErrorKind::invalid_argument, "extent has a non-finite coordinate");
  if (!std::isfinite(res) || res <= 0.0)
    throw Error(ErrorKind::invalid_argument, "resolution must be a positive number");
  if (!(xmin < xmax)) throw Error(ErrorKind::invalid_argument, "extent: xmin must be less than xmax");
  if (!(ymin < ymax)) throw Error(ErrorKind::invalid_argument, "extent: ymin must be less than ymax");
}

// Whole cells needed to cover `span`; a fractional remainder under 1e-9 cell is rounding noise.
int64_t cells_for(double span, double res) {
  const double n = span / res;
  if (n > static_cast<double>(std::numeric_limits<int32_t>::max()))
    throw Error(ErrorKind::too_large, "grid has more than 2^31 cells along one axis");
  const double whole = std::floor(n);
  const int64_t count = static_cast<int64_t>(n - whole < 1e-9 ? whole : whole + 1.0);
  return count < 1 ? 1 : count;
}

}  // namespace

GridSpec make_grid(double xmin, double ymin, double xmax, double ymax, double res, std::string crs) {
  check_extent(xmin, ymin, xmax, ymax, res);
  GridSpec g;
  g.xmin = xmin;
  g.ymax = ymax;
  g.res = res;
  g.width = cells_for(xmax - xmin, res);
  g.height = cells_for(ymax - ymin, res);
  g.crs = std::move(crs);
  return g;
}

GridSpec make_aligned_grid(double xmin, double ymin, double xmax, double ymax, double res, std::string crs) {
  check_extent(xmin, ymin, xmax, ymax, res);
  const double x0 = std::floor(xmin / res) * res;
  const double y1 = std::ceil(ymax / res) * res;
  const double x1 = std::ceil(xmax / res) * res;
  const double y0 = std::floor(ymin / res) * res;
  return make_grid(x0, y0, x1 > x0 ? x1 : x0 + res, y1 > y0 ? y1 : y0 + res, res, std::move(crs));
}

}  // namespace rv
