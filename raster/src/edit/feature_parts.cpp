// Parts of seed features recovered from their sites (rv/edit/feature_parts.hpp).
#include "rv/edit/feature_parts.hpp"

#include <unordered_map>

namespace rv {

std::vector<std::vector<FeaturePart>> feature_parts(const SeedSet& seeds) {
  const std::vector<Site>& sites = seeds.sites();
  std::vector<std::vector<FeaturePart>> out(seeds.features().size());
  // Each polygon's first ring edge: its area site minus its edges (SeedSet::add_polygon adds the
  // rings' edges, then the area site).
  std::unordered_map<size_t, size_t> polygon_at;
  for (size_t p = 0; p < seeds.polygons().size(); ++p) {
    const Polygon& poly = seeds.polygons()[p];
    size_t edges = 0;
    for (const Ring& r : poly.rings) edges += r.size();
    polygon_at[static_cast<size_t>(poly.area_site) - edges] = p;
  }
  for (size_t i = 0; i < sites.size();) {
    const Site& s = sites[i];
    std::vector<FeaturePart>& parts = out[static_cast<size_t>(s.feature)];
    if (const auto p = polygon_at.find(i); p != polygon_at.end()) {
      const Polygon& poly = seeds.polygons()[p->second];
      parts.push_back(FeaturePart{FeaturePart::Kind::polygon, {}, poly.rings});
      i = static_cast<size_t>(poly.area_site) + 1;
      continue;
    }
    if (s.kind == SiteKind::point || s.kind == SiteKind::area) {
      // An area site outside a polygon cannot be made by SeedSet's adders; points are parts.
      if (s.kind == SiteKind::point) parts.push_back(FeaturePart{FeaturePart::Kind::point, {s.a}, {}});
      ++i;
      continue;
    }
    FeaturePart line{FeaturePart::Kind::line, {s.a, s.b}, {}};
    ++i;
    while (i < sites.size() && sites[i].kind == SiteKind::segment && sites[i].feature == s.feature &&
           !polygon_at.contains(i) && sites[i].a == line.vertices.back()) {
      line.vertices.push_back(sites[i].b);
      ++i;
    }
    parts.push_back(std::move(line));
  }
  return out;
}

int add_parts(SeedSet& seeds, int32_t feature, const std::vector<FeaturePart>& parts) {
  int added = 0;
  for (const FeaturePart& part : parts) {
    switch (part.kind) {
      case FeaturePart::Kind::point:
        for (const Vec2& v : part.vertices) added += seeds.add_point(feature, v);
        break;
      case FeaturePart::Kind::line:
        added += seeds.add_polyline(feature, part.vertices);
        break;
      case FeaturePart::Kind::polygon:
        added += seeds.add_polygon(feature, part.rings);
        break;
    }
  }
  return added;
}

}  // namespace rv
