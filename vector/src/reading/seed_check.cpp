// The reader's checks for features edited in memory (rv/gdal/seed_reader.hpp,
// check_edited_features): polygon validity and conflicts between owners, over the edited
// features and the parts whose boxes meet theirs (found from the set's sites and polygons, so
// that the other features' parts are read only where they come near).
#include <algorithm>
#include <memory>

#include "common/gdal_util.hpp"
#include "reading/normalise.hpp"
#include "rv/edit/feature_parts.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace rv {
namespace {

std::unique_ptr<OGRGeometry> part_geometry(const FeaturePart& part, int64_t& vertices) {
  switch (part.kind) {
    case FeaturePart::Kind::point:
      vertices = 1;
      return std::make_unique<OGRPoint>(part.vertices.front().x, part.vertices.front().y);
    case FeaturePart::Kind::line: {
      auto line = std::make_unique<OGRLineString>();
      gdal::set_points(*line, part.vertices);
      vertices = static_cast<int64_t>(part.vertices.size());
      return line;
    }
    case FeaturePart::Kind::polygon: {
      auto poly = std::make_unique<OGRPolygon>();
      vertices = 0;
      for (const Ring& r : part.rings) {
        poly->addRingDirectly(detail::make_ring(r).release());
        vertices += static_cast<int64_t>(r.size());
      }
      return poly;
    }
  }
  return nullptr;
}

int dimension(FeaturePart::Kind k) { return k == FeaturePart::Kind::point ? 0 : k == FeaturePart::Kind::line ? 1 : 2; }

bool meets(const OGREnvelope& a, const OGREnvelope& b) {
  return a.MinX <= b.MaxX && b.MinX <= a.MaxX && a.MinY <= b.MaxY && b.MinY <= a.MaxY;
}

// A part's box from its vertices, without making its geometry.
OGREnvelope envelope_of(const FeaturePart& p) {
  OGREnvelope e;
  auto take = [&](const Vec2& v) { e.Merge(v.x, v.y); };
  for (const Vec2& v : p.vertices) take(v);
  for (const Ring& r : p.rings)
    for (const Vec2& v : r) take(v);
  return e;
}

}  // namespace

std::vector<BorderSliver> check_edited_features(const SeedSet& seeds, const std::vector<int32_t>& features,
                                                const std::string& crs_wkt, ConflictPolicy policy,
                                                double border_tolerance) {
  const std::vector<std::vector<FeaturePart>> parts = feature_parts(seeds);
  return check_edited_features(
      seeds, features, [&](int32_t f) -> const std::vector<FeaturePart>& { return parts[static_cast<size_t>(f)]; },
      crs_wkt, policy, border_tolerance);
}

std::vector<BorderSliver> check_edited_features(const SeedSet& seeds, const std::vector<int32_t>& features,
                                                const FeaturePartsOf& parts_of, const std::string& crs_wkt,
                                                ConflictPolicy policy, double border_tolerance) {
  gdal_init();
  auto make = [&](int32_t f, const FeaturePart& p) {
    detail::SeedPart part;
    part.geometry = part_geometry(p, part.vertices);
    part.geometry->getEnvelope(&part.envelope);
    part.feature = f;
    part.owner = seeds.features()[static_cast<size_t>(f)].owner;
    part.dimension = dimension(p.kind);
    return part;
  };
  std::vector<detail::SeedPart> checked;
  for (const int32_t f : features) {
    for (const FeaturePart& p : parts_of(f)) {
      detail::SeedPart part = make(f, p);
      if (part.dimension == 2) {
        gdal::ErrorCapture quiet;  // GEOS explains invalidity through warnings; we state our own
        if (!part.geometry->IsValid())
          throw Error(ErrorKind::invalid_input,
                      seeds.feature_name(f) +
                          ": the edited polygon is not valid (a ring crosses itself or another, or a hole lies "
                          "outside its shell); move the vertex elsewhere");
      }
      checked.push_back(std::move(part));
    }
  }
  if (policy != ConflictPolicy::error || checked.empty()) return {};
  // The other owners' parts that may meet an edited one; pairs between two of them were checked
  // when they were read or edited.
  const size_t edited_parts = checked.size();
  const std::vector<Feature>& all = seeds.features();
  std::vector<char> near_edit(all.size(), 0);  // 1: edited; 2: a site or polygon near an edited part
  for (const int32_t f : features) near_edit[static_cast<size_t>(f)] = 1;
  auto meets_edited = [&](int32_t f, const OGREnvelope& box) {
    const int32_t owner = all[static_cast<size_t>(f)].owner;
    return std::any_of(checked.begin(), checked.begin() + static_cast<std::ptrdiff_t>(edited_parts),
                       [&](const detail::SeedPart& e) { return e.owner != owner && meets(e.envelope, box); });
  };
  // A first pass over the sites and polygons as the set stores them, one after the other: what
  // meets a part must meet one of its segments' or points' boxes, or its polygon's box.
  for (const Site& x : seeds.sites()) {
    if (x.kind == SiteKind::area || near_edit[static_cast<size_t>(x.feature)] != 0) continue;
    OGREnvelope box;
    box.Merge(x.a.x, x.a.y);
    box.Merge(x.b.x, x.b.y);
    if (meets_edited(x.feature, box)) near_edit[static_cast<size_t>(x.feature)] = 2;
  }
  for (const Polygon& poly : seeds.polygons()) {
    if (near_edit[static_cast<size_t>(poly.feature)] != 0 || poly.rings.empty()) continue;
    OGREnvelope box;
    for (const Vec2& v : poly.rings.front()) box.Merge(v.x, v.y);
    if (meets_edited(poly.feature, box)) near_edit[static_cast<size_t>(poly.feature)] = 2;
  }
  for (size_t f = 0; f < all.size(); ++f) {
    if (near_edit[f] != 2) continue;
    const int32_t owner = all[f].owner;
    for (const FeaturePart& p : parts_of(static_cast<int32_t>(f))) {
      const OGREnvelope box = envelope_of(p);
      const bool near =
          std::any_of(checked.begin(), checked.begin() + static_cast<std::ptrdiff_t>(edited_parts),
                      [&](const detail::SeedPart& e) { return e.owner != owner && meets(e.envelope, box); });
      if (near) checked.push_back(make(static_cast<int32_t>(f), p));
    }
  }
  if (checked.size() < 2) return {};  // one part alone meets nothing (the CRS is not even read)
  gdal::SrsPtr srs;
  if (!crs_wkt.empty()) srs = gdal::parse_srs(crs_wkt);
  SeedReadReport report;
  detail::check_conflicts(checked, seeds, policy, border_tolerance, srs.get(), report);
  return report.slivers;
}

}  // namespace rv
