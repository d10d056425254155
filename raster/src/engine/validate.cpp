#include "rv/engine/validate.hpp"

#include <algorithm>
#include <cmath>

#include <optional>

#include "engine/engine_internal.hpp"
#include "field/geodesic_sites.hpp"
#include "rv/field/error.hpp"
#include "rv/field/planar.hpp"

namespace rv {

ValidationStats compare_fields(const SeedSet& seeds, const NearestField& test, const NearestField& reference,
                               double tolerance_cells, int max_examples) {
  if (!(test.site.grid() == reference.site.grid()) || !(test.site.window() == reference.site.window()))
    throw Error(ErrorKind::invalid_argument, "compare_fields: the two fields cover different cells");
  if (!(test.metric == reference.metric))
    throw Error(ErrorKind::invalid_argument, "compare_fields: the two fields were measured with different metrics");
  if (!test.geolocator != !reference.geolocator)
    throw Error(ErrorKind::invalid_argument,
                "compare_fields: one field was located on the ellipsoid from a projected grid, the other not");
  const GridSpec& g = test.site.grid();
  const Window& w = test.site.window();
  const bool geodesic = test.metric.kind == MetricSpec::geodesic;
  const Geolocator* geolocator = test.geolocator.get();  // projected geodesic grids
  const std::vector<LocalSite> local = geodesic ? std::vector<LocalSite>{} : to_local(seeds, g);
  std::optional<detail::GeoSites> geo;
  if (geodesic) geo.emplace(test.metric, seeds);
  // The cell (absolute grid coordinates) on the ellipsoid: located on projected grids.
  auto geo_cell = [&](double x, double y) {
    if (geolocator == nullptr) return geo->cell(x, y);
    double lon, lat;
    detail::locate_centres(*geolocator, &x, &y, &lon, &lat, 1);
    return geo->cell(lon, lat);
  };
  // One cell in metric units: res for planar; for geodesic on a geographic grid the
  // north-south size of a cell (res degrees of latitude) on a sphere of radius a, to within
  // 0.7 % everywhere; on a projected grid the geodesic distance between the located centres of
  // two neighbouring cells in the middle of the window (the grid's unit may be feet, and its
  // scale varies a little over the grid).
  double cell_size = geodesic ? g.res * 3.14159265358979323846 / 180.0 * test.metric.semi_major : g.res;
  if (geolocator != nullptr) {
    const int64_t c = w.col0 + w.width / 2, r = w.row0 + w.height / 2;
    const detail::GeoCell a = geo_cell(g.centre_x(c), g.centre_y(r));
    const detail::GeoCell b = geo_cell(g.centre_x(c) + g.res, g.centre_y(r));
    geo->geodesic().Inverse(a.lat, a.lon, b.lat, b.lon, cell_size);
  }
  const double tol = tolerance_cells * cell_size;
  auto dist = [&](int32_t id, double px, double py) {
    if (seeds.sites()[id].kind == SiteKind::area) return 0.0;
    if (geodesic) return geo->distance(geo_cell(px + g.xmin, py + g.ymax), id);
    return std::sqrt(planar_key(px, py, local[id]));
  };
  ValidationStats st;
  for (int64_t r = 0; r < w.height; ++r) {
    const double py = g.local_y(w.row0 + r);
    for (int64_t c = 0; c < w.width; ++c) {
      ++st.cells;
      const int32_t a = test.site.at(c, r), b = reference.site.at(c, r);
      if (a == b) continue;
      if (a == kNoSite || b == kNoSite) {
        ++st.nodata_mismatch;
        continue;
      }
      const double px = g.local_x(w.col0 + c);
      const double err = dist(a, px, py) - dist(b, px, py);
      if (err <= tol) {
        ++st.tie_cells;
        continue;
      }
      ++st.wrong_cells;
      if (seeds.site_owner(a) != seeds.site_owner(b)) ++st.wrong_owner_cells;
      st.max_error = std::max(st.max_error, err);
      if (static_cast<int>(st.examples.size()) < max_examples) st.examples.push_back(WrongCell{c, r, a, b, err});
    }
  }
  st.max_error_cells = st.max_error / cell_size;
  return st;
}

}  // namespace rv
