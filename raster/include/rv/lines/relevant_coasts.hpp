// The relevant coasts of a disproportionality test, taken in strip by strip.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/geolocate.hpp"
#include "rv/field/grid.hpp"
#include "rv/field/interior.hpp"
#include "rv/field/seeds.hpp"

namespace rv {

// The relevant coast of a disproportionality test: the parts of the seeds' geometry that are
// nearest to at least one cell of the relevant area (cells whose centre `area` holds, by the
// interior rule of rv/field/interior.hpp; its window the whole grid). For each site nearest to such a
// cell, the stretch between the extreme nearest points (basepoints) of those cells along it: a
// point site's stretch is the point (length 0), an area site has none (land). The extremes are
// looked for on the cells at the edge of a site's cells within the area (a neighbour of another
// site, or outside the area or the grid), where they lie on planar grids (the basepoint's
// position along a segment is linear in the cell's position) and, to a fraction of a cell, on
// geodesic ones; so a stretch holds every basepoint of the area's cells and is no longer than
// the span between them (a site whose cells in the area fall in two separate pieces counts the
// span between the pieces too). By sea (a metric that is not straight, rv/sea/sea_metric.hpp) a
// cell's basepoint is where its path leaves the site, which is not linear in the cell's position
// (every cell behind one bend has that bend's): every cell of the area is measured, one question of
// the path each. Taken in strip by strip (whole rows in order, as StripLines):
// the whole field is never needed. Keeps references to `metric` and `area`.
// Thread safety: one accumulator per extraction, used from one thread at a time.
class RelevantCoasts {
 public:
  // `geolocator`: the field's (NearestField::geolocator; projected geodesic grids, whose metric
  // places basepoints in the grid's CRS), else null.
  RelevantCoasts(const GridSpec& grid, const SiteMetric& metric, const InteriorSpans& area,
                 const Geolocator* geolocator = nullptr, int threads = 0);
  ~RelevantCoasts();
  // The next strip: whole rows, the first at row 0, each starting where the last ended. Throws
  // rv::Error(invalid_argument) otherwise.
  void add(const NearestField& strip);
  struct Stretch {
    int32_t site = kNoSite;
    Vec2 from, to;        // the extreme basepoints (grid-CRS or seed coordinates, as nearest_point)
    double length = 0.0;  // metric units, between them along the site
  };
  // After the last row: the stretches in site order. Throws rv::Error(invalid_argument) when
  // rows are missing.
  std::vector<Stretch> take();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rv
