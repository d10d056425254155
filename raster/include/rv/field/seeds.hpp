// The seed model: features (each with an owner) made of sites.
//
// A feature is one input geometry (a point, a line, a polygon or a collection of them) and
// belongs to one owner (code 1..K). The engines work on *sites*, the atoms of a feature:
//   - point:   a single position;
//   - segment: the closed straight segment between two distinct positions (an edge of a line or of
//              a polygon ring; on geodesic grids, the geodesic between them);
//   - area:    the interior of a polygon feature; only ever assigned to cells whose centre lies
//              inside it (see interior.hpp), at distance 0.
// Coordinates are in the grid's CRS (x = easting or longitude, y = northing or latitude).
//
// Ordering invariant: sites are stored in feature order (and, inside a feature, in insertion
// order). All engines break distance ties towards the lower site index, hence towards the lower
// feature index, and (because owner codes are numbered by first appearance) the lower owner code.
//
// Not thread-safe for mutation; const access is safe from any number of threads.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <ostream>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

namespace rv {

struct Vec2 {
  double x = 0.0;
  double y = 0.0;
  bool operator==(const Vec2&) const = default;
};

enum class SiteKind : uint8_t { point, segment, area };

struct Site {
  Vec2 a;           // the point, or the segment's first end
  Vec2 b;           // the segment's second end (== a for points and areas)
  int32_t feature;  // 0-based feature index
  SiteKind kind;
};

// A polygon ring; closure is implied (the last vertex is not a repeat of the first).
using Ring = std::vector<Vec2>;

// One polygon part: rings[0] is the outer ring, the rest are holes. Inside is decided by the
// even-odd rule over all rings, so ring orientation does not matter.
struct Polygon {
  int32_t feature = 0;
  int32_t area_site = 0;  // index of this feature's area site
  std::vector<Ring> rings;
};

enum class GeometryKind : uint8_t { point, line, polygon, mixed };

// A feature's source name, immutable and shared by the copies of a seed set: copying a set of
// 50,000 features (each step of a session does) copies pointers, not 50,000 strings. Empty when
// the feature has no name. Thread safety: as std::shared_ptr<const std::string> (copies may be
// made and read from any number of threads).
class SourceText {
 public:
  SourceText() = default;
  SourceText(std::string text)  // NOLINT(google-explicit-constructor): a name is given as text
      : text_(text.empty() ? nullptr : std::make_shared<const std::string>(std::move(text))) {}
  SourceText(const char* text) : SourceText(std::string(text)) {}  // NOLINT(google-explicit-constructor)
  const std::string& str() const { return text_ ? *text_ : empty_text(); }
  operator const std::string&() const { return str(); }  // NOLINT(google-explicit-constructor)
  bool empty() const { return !text_; }
  // The bytes this name holds apart from the feature: the shared block and the text's own
  // buffer, counted in full by every copy (a set's memory counts the names it may outlive).
  int64_t heap_bytes() const;
  friend bool operator==(const SourceText& a, const SourceText& b) { return a.str() == b.str(); }
  friend std::ostream& operator<<(std::ostream& o, const SourceText& s) { return o << s.str(); }

 private:
  static const std::string& empty_text() {
    static const std::string none;
    return none;
  }
  std::shared_ptr<const std::string> text_;
};

struct Feature {
  int32_t owner = 0;  // owner code, 1..owner_count()
  GeometryKind kind = GeometryKind::point;
  SourceText source;  // where it came from, for messages ("file.gpkg:layer:fid 7")
  // The delimitation adjustments (SeedSet::set_adjustment): the feature's distance d counts as
  // d / weight (a multiplicatively weighted, "equiratio" comparison; weight > 0 and finite), and
  // only where d <= reach (metric units; an island with a reach of 12 nmi is enclaved in a 12 nmi
  // arc); beyond it the feature is as if absent. Defaults: the plain distance, everywhere.
  double weight = 1.0;
  double reach = std::numeric_limits<double>::infinity();
  // Partial effect (SeedSet::set_effect, rv/lines/partial_effect.hpp): in [0, 1]; below 1 the feature
  // counts partly in its owner's boundaries with the others (an island given half effect). The
  // engine's field ignores it; the partial-effect stage reads it.
  double effect = 1.0;
};

// What a distance d (metric units, >= 0) to a site of feature f counts for when the nearest
// feature is chosen: d / f.weight where d <= min(f.reach, cap), +infinity beyond (`cap`: the
// job's max distance, which bounds every feature's reach). With the defaults, d itself, to the
// bit. The one rule every engine and search compares by.
inline double adjusted_distance(const Feature& f, double d, double cap = std::numeric_limits<double>::infinity()) {
  return d > f.reach || d > cap ? std::numeric_limits<double>::infinity() : d / f.weight;
}

class SeedSet {
 public:
  // Registers an owner label and returns its code (1-based; the same label gets the same code).
  int32_t owner_code(const std::string& label);
  // Adds a feature owned by `owner` (a code from owner_code) and returns its 0-based index.
  int32_t add_feature(int32_t owner, SourceText source = {});

  // Geometry of the most recently added feature (feature must be the last index; sites stay in
  // feature order). Coordinates must be finite: otherwise rv::Error(invalid_input) naming the
  // feature. Consecutive duplicate vertices are dropped; a line that collapses to one position
  // becomes a point site. Returns the number of sites added.
  int add_point(int32_t feature, Vec2 p);
  int add_polyline(int32_t feature, std::span<const Vec2> vertices);
  // Rings: outer first, then holes. Rings with fewer than 3 distinct vertices are dropped.
  int add_polygon(int32_t feature, std::vector<Ring> rings);

  // Sets the adjustments of a feature (see Feature): weight > 0 and finite, reach > 0 (infinity:
  // none). Otherwise rv::Error(invalid_input) naming the feature.
  void set_adjustment(int32_t feature, double weight, double reach);
  // Sets a feature's partial effect: in [0, 1] (Feature::effect). Otherwise rv::Error(invalid_input)
  // naming the feature.
  void set_effect(int32_t feature, double effect);
  // Multiplies every finite reach by `factor` (> 0): from the job's distance units to the
  // metric's.
  void scale_reaches(double factor);
  // True when some feature has a weight other than 1 or a finite reach.
  bool adjusted() const { return adjusted_features_ > 0; }
  // A copy without the features whose `drop` entry (one per feature) is true: the same owners
  // and codes (an owner may be left without features), the kept features, sites and polygons in
  // their order. `site_of` receives, per site of the copy, its index here.
  SeedSet without(const std::vector<bool>& drop, std::vector<int32_t>& site_of) const;
  // A copy with feature `features[i]` (ascending, distinct) replaced by feature i of `by` (its
  // kind, source, adjustments, sites and polygons), everything else as here: what adding the
  // features again in order with the replacements gives, in O(sites + polygons) copying. `by`
  // numbers owners as this set does, and each replacement keeps its feature's owner (so the
  // order stays). Throws rv::Error(internal) where that does not hold.
  SeedSet replaced(const std::vector<int32_t>& features, const SeedSet& by) const;
  // A seed set from its parts as sites(), polygons(), features() and owner_labels() give them
  // (rv/edit/seed_archive.hpp reads them back). Throws rv::Error(invalid_input) where they do not fit
  // together: a site's or polygon's feature out of range or out of order, a polygon's area site
  // not an area site of its feature, an owner code out of range, a repeated owner label, or a
  // coordinate, weight, reach or effect out of its domain.
  static SeedSet from_parts(std::vector<Site> sites, std::vector<Polygon> polygons, std::vector<Feature> features,
                            std::vector<std::string> owner_labels);

  const std::vector<Site>& sites() const { return sites_; }
  const std::vector<Polygon>& polygons() const { return polygons_; }
  const std::vector<Feature>& features() const { return features_; }
  const std::vector<std::string>& owner_labels() const { return owner_labels_; }  // code-1 -> label
  // How messages and reports name a feature: its source, or "feature N" (1-based) without one.
  std::string feature_name(int32_t feature) const;
  int32_t owner_count() const { return static_cast<int32_t>(owner_labels_.size()); }

  int32_t site_feature(int32_t site) const { return sites_[site].feature; }
  int32_t site_owner(int32_t site) const { return features_[sites_[site].feature].owner; }

  // Bounding box of all vertices; {+inf, +inf, -inf, -inf} when empty.
  struct Box {
    double xmin, ymin, xmax, ymax;
  };
  Box bounds() const;

  // Number of sites that take part in distance computations (points and segments).
  int64_t geometric_site_count() const;

  // Bytes this seed set holds on the heap and inline (sites, polygons, features, labels and the
  // label index), for memory estimates. Allocator overhead is counted as one pointer per block.
  int64_t memory_bytes() const;

 private:
  void check_feature(int32_t feature) const;
  static int is_adjusted(const Feature& f) { return f.weight != 1.0 || std::isfinite(f.reach); }
  void count_adjusted();  // adjusted_features_ from features_
  void add_site(const Site& s);

  std::vector<Site> sites_;
  std::vector<Polygon> polygons_;
  std::vector<Feature> features_;
  std::vector<std::string> owner_labels_;
  std::unordered_map<std::string, int32_t> owner_index_;
  int64_t adjusted_features_ = 0;  // features whose weight or reach is not the default: O(1) adjusted()
};

}  // namespace rv
