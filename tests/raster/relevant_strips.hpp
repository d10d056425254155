// The relevant coasts of a field as a streamed job takes them: the field cut into strips of
// `strip_rows` whole rows, fed in order to one RelevantCoasts over `area` with `metric`.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/interior.hpp"
#include "rv/lines/relevant_coasts.hpp"

namespace rv::test {

inline std::vector<RelevantCoasts::Stretch> relevant_stretches(const NearestField& field, const SiteMetric& metric,
                                                               const InteriorSpans& area, int64_t strip_rows) {
  const GridSpec& g = field.site.grid();
  RelevantCoasts rc(g, metric, area);
  for (int64_t r0 = 0; r0 < g.height; r0 += strip_rows) {
    const int64_t h = std::min(strip_rows, g.height - r0);
    NearestField strip;
    strip.site = Raster<int32_t>(g, Window{0, r0, g.width, h}, kNoSite);
    strip.distance = Raster<float>(g, Window{0, r0, g.width, h}, kNoDistance);
    for (int64_t r = 0; r < h; ++r)
      for (int64_t c = 0; c < g.width; ++c) {
        strip.site.at(c, r) = field.site.at(c, r0 + r);
        strip.distance.at(c, r) = field.distance.at(c, r0 + r);
      }
    rc.add(strip);
  }
  return rc.take();
}

}  // namespace rv::test
