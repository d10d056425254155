// Barriers read as seeds: the seed reader does the reading (formats, confinement, limits,
// reprojection, repair); here its features become barriers, without owners or conflicts.
#include <set>
#include <utility>
#include <vector>

#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace rv {

LoadedBarriers load_barriers(const SeedReadOptions& options) {
  SeedReadOptions o = options;
  o.owner_field.reset();  // every feature its own barrier
  o.weight_field.reset();
  o.reach_field.reset();
  o.effect_field.reset();
  // Barriers overlap and cross freely: what would be two owners' conflict is nothing here.
  o.on_conflict = ConflictPolicy::lower_code;
  o.border_tolerance = 0.0;
  LoadedSeeds seeds = load_seeds(o);
  LoadedBarriers out;
  out.crs = seeds.crs;
  out.report = std::move(seeds.report);
  out.report.conflicts = 0;
  out.report.sliver_count = 0;
  out.report.slivers.clear();
  const SeedSet& s = seeds.seeds;
  // Polygons by feature, in order; the line runs of each feature from its segment sites (a run
  // ends where the next segment does not start at this one's end).
  size_t next_polygon = 0;
  size_t site = 0;
  for (int32_t f = 0; f < static_cast<int32_t>(s.features().size()); ++f) {
    const SourceText& source = s.features()[static_cast<size_t>(f)].source;
    // This feature's polygons become land; their edges (segment sites too) are not lines.
    std::set<std::pair<std::pair<double, double>, std::pair<double, double>>> ring_edges;
    for (; next_polygon < s.polygons().size() && s.polygons()[next_polygon].feature == f; ++next_polygon) {
      const Polygon& p = s.polygons()[next_polygon];
      for (const Ring& r : p.rings)
        for (size_t i = 0; i < r.size(); ++i) {
          const Vec2 a = r[i], b = r[(i + 1) % r.size()];
          ring_edges.insert({{a.x, a.y}, {b.x, b.y}});
          ring_edges.insert({{b.x, b.y}, {a.x, a.y}});
        }
      out.barriers.add_polygon(p.rings, source);
    }
    std::vector<Vec2> run;
    for (; site < s.sites().size() && s.sites()[site].feature == f; ++site) {
      const Site& st = s.sites()[site];
      if (st.kind == SiteKind::point)
        throw Error(ErrorKind::invalid_input,
                    "the barrier " + s.feature_name(f) + " is a point: barriers are polygons and lines");
      if (st.kind != SiteKind::segment || ring_edges.count({{st.a.x, st.a.y}, {st.b.x, st.b.y}})) continue;
      if (!run.empty() && !(run.back() == st.a)) {
        out.barriers.add_line(run, source);
        run.clear();
      }
      if (run.empty()) run.push_back(st.a);
      run.push_back(st.b);
    }
    if (!run.empty()) out.barriers.add_line(run, source);
  }
  return out;
}

}  // namespace rv
