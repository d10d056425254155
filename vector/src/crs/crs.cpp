#include <cmath>

#include "common/gdal_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace rv {
namespace gdal {

CrsInfo crs_info(const OGRSpatialReference& srs) {
  CrsInfo info;
  info.wkt = to_wkt2(srs);
  info.geographic = srs.IsGeographic() != 0;
  OGRErr err = OGRERR_NONE;
  const double a = srs.GetSemiMajor(&err);
  if (err == OGRERR_NONE && a > 0.0) info.semi_major = a;
  const double inv_f = srs.GetInvFlattening(&err);
  // OSR reports a sphere as inverse flattening 0.
  if (err == OGRERR_NONE) info.flattening = inv_f > 0.0 ? 1.0 / inv_f : 0.0;
  if (srs.IsProjected() || srs.IsLocal()) {
    const double unit = srs.GetLinearUnits();
    if (std::isfinite(unit) && unit > 0.0) info.linear_unit = unit;
  }
  const char* name = srs.GetName();
  info.name = escape_utf8(name != nullptr ? name : "");  // a .prj or WKT names it: outside text
  return info;
}

}  // namespace gdal

CrsInfo describe_crs(const std::string& definition) {
  gdal_init();
  if (definition.empty()) throw Error(ErrorKind::invalid_argument, "empty CRS definition");
  gdal::SrsPtr srs = gdal::parse_srs(definition);
  if (!srs)
    throw Error(ErrorKind::invalid_argument, "cannot parse the CRS definition '" + quote_input(definition) + "'");
  return gdal::crs_info(*srs);
}

}  // namespace rv
