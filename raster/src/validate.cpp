#include "rv/validate.hpp"

#include <algorithm>
#include <cmath>

#include "rv/error.hpp"
#include "rv/planar.hpp"

namespace rv {

ValidationStats compare_fields(const SeedSet& seeds, const NearestField& test,
                               const NearestField& reference, double tolerance_cells,
                               int max_examples) {
  if (!(test.site.grid() == reference.site.grid()) || !(test.site.window() == reference.site.window()))
    throw Error(ErrorKind::invalid_argument, "compare_fields: the two fields cover different cells");
  const GridSpec& g = test.site.grid();
  const Window& w = test.site.window();
  const std::vector<LocalSite> local = to_local(seeds, g);
  const double tol = tolerance_cells * g.res;
  auto dist = [&](int32_t id, double px, double py) {
    if (seeds.sites()[id].kind == SiteKind::area) return 0.0;
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
      if (static_cast<int>(st.examples.size()) < max_examples)
        st.examples.push_back(WrongCell{c, r, a, b, err});
    }
  }
  st.max_error_cells = st.max_error / g.res;
  return st;
}

}  // namespace rv
