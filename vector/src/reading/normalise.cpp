#include "reading/normalise.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include <ogr_api.h>
#include <ogr_spatialref.h>

#include "common/gdal_util.hpp"
#include "rv/field/error.hpp"

namespace rv::detail {

std::unique_ptr<OGRLinearRing> make_ring(const std::vector<Vec2>& v) {
  auto ring = std::make_unique<OGRLinearRing>();
  gdal::set_points(*ring, v);
  ring->addPoint(v.front().x, v.front().y);
  return ring;
}

int64_t remove_duplicate_vertices(std::vector<Vec2>& v, bool ring) {
  if (v.empty()) return 0;
  // The closing vertex of a ring is notation, not a vertex: drop it before counting.
  if (ring && v.size() > 1 && v.front() == v.back()) v.pop_back();
  const size_t before = v.size();
  auto end = std::unique(v.begin(), v.end());
  v.erase(end, v.end());
  int64_t removed = static_cast<int64_t>(before - v.size());
  // A ring whose last vertex repeats its first after the closing one was removed: a zero-length
  // closing segment.
  while (ring && v.size() > 1 && v.front() == v.back()) {
    v.pop_back();
    ++removed;
  }
  return removed;
}

namespace {

// Parts with more vertices than this get a GEOS prepared geometry the first time they are
// tested: a coastline polygon with thousands of vertices is then indexed once instead of being
// converted and scanned for every neighbour it is tested against.
constexpr int64_t kPrepareThreshold = 64;
constexpr int kMaxConflictLines = 20;

struct PreparedDeleter {
  void operator()(OGRPreparedGeometryH p) const { OGRDestroyPreparedGeometry(p); }
};
using PreparedPtr = std::unique_ptr<std::remove_pointer_t<OGRPreparedGeometryH>, PreparedDeleter>;

class ConflictFinder {
 public:
  ConflictFinder(std::vector<SeedPart>& parts) : parts_(parts), prepared_(parts.size()) {}

  bool interiors_intersect(size_t i, size_t j) {
    const SeedPart& a = parts_[i];
    const SeedPart& b = parts_[j];
    if (a.dimension == 0 && b.dimension == 0) {
      const auto* pa = a.geometry->toPoint();
      const auto* pb = b.geometry->toPoint();
      return pa->getX() == pb->getX() && pa->getY() == pb->getY();
    }
    const size_t big = a.vertices >= b.vertices ? i : j;
    const size_t small = big == i ? j : i;
    bool meets = false;
    if (parts_[big].vertices >= kPrepareThreshold && prepared(big) != nullptr) {
      meets = OGRPreparedGeometryIntersects(prepared(big), OGRGeometry::ToHandle(parts_[small].geometry.get())) != 0;
    } else {
      meets = a.geometry->Intersects(b.geometry.get()) != 0;
    }
    if (!meets) return false;
    // They meet; Touches() is true exactly when only their boundaries meet.
    return a.geometry->Touches(b.geometry.get()) == 0;
  }

 private:
  OGRPreparedGeometryH prepared(size_t k) {
    if (!prepared_[k]) prepared_[k].reset(OGRCreatePreparedGeometry(OGRGeometry::ToHandle(parts_[k].geometry.get())));
    return prepared_[k].get();
  }

  std::vector<SeedPart>& parts_;
  std::vector<PreparedPtr> prepared_;
};

std::string format_xy(double x, double y) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.10g, %.10g)", x, y);
  return buf;
}

// A first vertex of a geometry, descending into collections.
bool first_vertex(const OGRGeometry* g, double& x, double& y) {
  if (g == nullptr || g->IsEmpty()) return false;
  switch (wkbFlatten(g->getGeometryType())) {
    case wkbPoint:
      x = g->toPoint()->getX();
      y = g->toPoint()->getY();
      return true;
    case wkbLineString:
    case wkbLinearRing: {
      const OGRLineString* l = g->toLineString();
      // The middle of the first segment: inside the line, not at a boundary point.
      if (l->getNumPoints() >= 2) {
        x = 0.5 * (l->getX(0) + l->getX(1));
        y = 0.5 * (l->getY(0) + l->getY(1));
      } else {
        x = l->getX(0);
        y = l->getY(0);
      }
      return true;
    }
    case wkbPolygon:
      return first_vertex(g->toPolygon()->getExteriorRing(), x, y);
    default:
      if (OGR_GT_IsSubClassOf(g->getGeometryType(), wkbGeometryCollection)) {
        const OGRGeometryCollection* c = g->toGeometryCollection();
        // Prefer the highest-dimensional member: for a line crossing a polygon the overlap
        // line says more than a boundary point.
        int best = -1;
        for (int k = 0; k < c->getNumGeometries(); ++k)
          if (!c->getGeometryRef(k)->IsEmpty() &&
              (best < 0 || c->getGeometryRef(k)->getDimension() > c->getGeometryRef(best)->getDimension()))
            best = k;
        return best >= 0 && first_vertex(c->getGeometryRef(best), x, y);
      }
      return false;
  }
}

// A coordinate inside the intersection of two parts and, for polygons, the overlap's area.
std::string describe_intersection(const SeedPart& a, const SeedPart& b) {
  std::unique_ptr<OGRGeometry> x(a.geometry->Intersection(b.geometry.get()));
  double px = 0.0, py = 0.0;
  std::string area;
  bool found = false;
  if (x && !x->IsEmpty()) {
    if (x->getDimension() == 2) {
      OGRGeometryH p = OGR_G_PointOnSurface(OGRGeometry::ToHandle(x.get()));
      if (p != nullptr) {
        px = OGR_G_GetX(p, 0);
        py = OGR_G_GetY(p, 0);
        found = true;
        OGR_G_DestroyGeometry(p);
      }
      char buf[64];
      std::snprintf(buf, sizeof buf, ", overlap area %.6g", OGR_G_Area(OGRGeometry::ToHandle(x.get())));
      area = buf;
    }
    if (!found) found = first_vertex(x.get(), px, py);
  }
  if (!found) {
    // GEOS could not build the intersection: the middle of the envelopes' overlap.
    px = 0.5 * (std::max(a.envelope.MinX, b.envelope.MinX) + std::min(a.envelope.MaxX, b.envelope.MaxX));
    py = 0.5 * (std::max(a.envelope.MinY, b.envelope.MinY) + std::min(a.envelope.MaxY, b.envelope.MaxY));
  }
  return "at " + format_xy(px, py) + area;
}

std::string describe_feature(const SeedSet& seeds, int32_t feature) {
  const Feature& f = seeds.features()[feature];
  const std::string& label = seeds.owner_labels()[f.owner - 1];
  return seeds.feature_name(feature) + " (owner '" + label + "')";
}

const char* verb(int da, int db) {
  if (da == 2 && db == 2) return "overlap";
  if (da == 0 && db == 0) return "coincide";
  if (da == 0 || db == 0) return "share a point";
  return "cross";
}

// The polygons among a geometry's parts (an overlap may mix them with lines and points where
// the shapes only touch).
void gather_polygons(const OGRGeometry* g, OGRMultiPolygon& out) {
  if (g == nullptr || g->IsEmpty()) return;
  const OGRwkbGeometryType t = wkbFlatten(g->getGeometryType());
  if (t == wkbPolygon) {
    out.addGeometry(g);
  } else if (OGR_GT_IsSubClassOf(g->getGeometryType(), wkbGeometryCollection)) {
    for (const OGRGeometry* part : *g->toGeometryCollection()) gather_polygons(part, out);
  }
}

}  // namespace

bool sliver_narrow(const OGRGeometry& overlap, const OGRSpatialReference* srs, double tolerance, double& area,
                   double& mean_width) {
  OGRMultiPolygon polygons;
  gather_polygons(&overlap, polygons);
  area = mean_width = 0.0;
  if (polygons.IsEmpty()) return false;
  // In metres: a geographic CRS's overlap in an azimuthal equidistant projection centred on it
  // (its scale is exact along the radii and off by ~1e-12 across them over a few metres); a
  // projected CRS's units scaled to metres.
  std::unique_ptr<OGRGeometry> metric(polygons.clone());
  double unit = 1.0;  // metres per CRS unit
  if (srs != nullptr && srs->IsGeographic()) {
    OGREnvelope e;
    polygons.getEnvelope(&e);
    OGRSpatialReference from(*srs), local;
    from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    if (local.CopyGeogCSFrom(srs) != OGRERR_NONE ||
        local.SetAE(0.5 * (e.MinY + e.MaxY), 0.5 * (e.MinX + e.MaxX), 0.0, 0.0) != OGRERR_NONE)
      return false;
    local.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&from, &local));
    if (!ct || metric->transform(ct.get()) != OGRERR_NONE) return false;
  } else if (srs != nullptr && srs->IsProjected()) {
    unit = srs->GetLinearUnits();
  }
  double perimeter = 0.0;
  for (const OGRPolygon* p : *metric->toMultiPolygon())
    for (const OGRLinearRing* ring : *p) perimeter += ring->get_Length();
  area = metric->toMultiPolygon()->get_Area() * unit * unit;
  mean_width = perimeter > 0.0 ? 2.0 * area / (perimeter * unit) : 0.0;
  // No disc of diameter `tolerance` fits inside exactly when shrinking by half of it leaves nothing.
  const std::unique_ptr<OGRGeometry> shrunk(metric->Buffer(-0.5 * tolerance / unit, 8));
  return shrunk != nullptr && shrunk->IsEmpty();
}

void check_conflicts(std::vector<SeedPart>& parts, const SeedSet& seeds, ConflictPolicy policy, double border_tolerance,
                     const OGRSpatialReference* srs, SeedReadReport& report) {
  if (seeds.owner_count() < 2 || parts.size() < 2) return;
  gdal::ErrorCapture quiet;  // GEOS topology warnings are not for the user's terminal
  std::vector<size_t> order(parts.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return parts[a].envelope.MinX < parts[b].envelope.MinX; });
  ConflictFinder finder(parts);
  // Two polygons overlapping by a sliver narrower than the tolerance: listed, not a conflict.
  auto land_border = [&](const SeedPart& a, const SeedPart& b) {
    const std::unique_ptr<OGRGeometry> x(a.geometry->Intersection(b.geometry.get()));
    double area = 0.0, width = 0.0;
    if (!x || !sliver_narrow(*x, srs, border_tolerance, area, width)) return false;
    ++report.sliver_count;
    if (report.slivers.size() < SeedReadReport::kMaxSlivers) {
      BorderSliver s{a.feature, b.feature, 0.0, 0.0, area, width};
      const std::unique_ptr<OGRGeometry> at(
          OGRGeometry::FromHandle(OGR_G_PointOnSurface(OGRGeometry::ToHandle(x.get()))));
      if (at && !at->IsEmpty() && wkbFlatten(at->getGeometryType()) == wkbPoint) {
        s.x = at->toPoint()->getX();
        s.y = at->toPoint()->getY();
      } else {
        first_vertex(x.get(), s.x, s.y);
      }
      report.slivers.push_back(s);
    }
    return true;
  };
  std::vector<size_t> active;
  int64_t unchecked = 0;
  for (size_t i : order) {
    const OGREnvelope& e = parts[i].envelope;
    // Drop parts that end west of this one: no later part (sorted by MinX) can meet them.
    active.erase(
        std::remove_if(active.begin(), active.end(), [&](size_t k) { return parts[k].envelope.MaxX < e.MinX; }),
        active.end());
    for (size_t j : active) {
      const SeedPart& other = parts[j];
      if (other.owner == parts[i].owner) continue;
      if (other.envelope.MaxY < e.MinY || other.envelope.MinY > e.MaxY) continue;
      quiet.clear_error();
      const bool meet = finder.interiors_intersect(j, i);
      if (!quiet.last_error().empty()) {
        // GEOS refused the pair (e.g. a TopologyException): say so rather than pass it silently.
        ++unchecked;
        if (unchecked <= kMaxConflictLines)
          report.warnings.push_back("could not check " + describe_feature(seeds, parts[j].feature) + " against " +
                                    describe_feature(seeds, parts[i].feature) + " for overlap: " + quiet.last_error());
      }
      if (!meet) continue;
      // Report the lower feature first whatever order the sweep met them in.
      const SeedPart& a = parts[j].feature <= parts[i].feature ? parts[j] : parts[i];
      const SeedPart& b = &a == &parts[j] ? parts[i] : parts[j];
      if (a.dimension == 2 && b.dimension == 2 && border_tolerance > 0.0 && land_border(a, b)) continue;
      if (policy == ConflictPolicy::error) {
        char wider[96] = "";
        if (a.dimension == 2 && b.dimension == 2 && border_tolerance > 0.0)
          std::snprintf(wider, sizeof wider, " (wider than the land-border tolerance, %g %s)", border_tolerance,
                        srs != nullptr ? "m" : "CRS units");
        throw Error(ErrorKind::conflict, "seeds of two owners " + std::string(verb(a.dimension, b.dimension)) + ": " +
                                             describe_feature(seeds, a.feature) + " and " +
                                             describe_feature(seeds, b.feature) + " " + describe_intersection(a, b) +
                                             std::string(wider));
      }
      ++report.conflicts;
      if (report.conflicts <= kMaxConflictLines) {
        // The engine breaks ties (and resolves overlapping interiors) towards the lower site
        // index; features are stored grouped by owner code, so that is the lower code.
        const int32_t lower = std::min(a.owner, b.owner);
        report.warnings.push_back("seeds of two owners " + std::string(verb(a.dimension, b.dimension)) + ": " +
                                  describe_feature(seeds, a.feature) + " and " + describe_feature(seeds, b.feature) +
                                  " " + describe_intersection(a, b) + "; accepted (lower_code): the lower code '" +
                                  seeds.owner_labels()[lower - 1] + "' takes the overlap");
      }
    }
    active.push_back(i);
  }
  if (unchecked > kMaxConflictLines)
    report.warnings.push_back(std::to_string(unchecked - kMaxConflictLines) + " further pairs could not be checked");
  if (report.conflicts > kMaxConflictLines)
    report.warnings.push_back(std::to_string(report.conflicts - kMaxConflictLines) +
                              " further conflicts between owners not listed");
}

}  // namespace rv::detail
