#include "rv/field/seeds.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "rv/field/error.hpp"

namespace rv {
namespace {

bool finite(Vec2 p) { return std::isfinite(p.x) && std::isfinite(p.y); }

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.10g", v);
  return text;
}

}  // namespace

int32_t SeedSet::owner_code(const std::string& label) {
  auto [it, inserted] = owner_index_.try_emplace(label, static_cast<int32_t>(owner_labels_.size() + 1));
  if (inserted) owner_labels_.push_back(label);
  return it->second;
}

int32_t SeedSet::add_feature(int32_t owner, SourceText source) {
  if (owner < 1 || owner > owner_count())
    throw Error(ErrorKind::internal, "add_feature: owner code " + std::to_string(owner) + " was never registered");
  if (features_.size() >= static_cast<size_t>(std::numeric_limits<int32_t>::max()))
    throw Error(ErrorKind::too_large, "too many seed features");
  features_.push_back(Feature{owner, GeometryKind::point, std::move(source)});
  return static_cast<int32_t>(features_.size() - 1);
}

void SeedSet::check_feature(int32_t feature) const {
  // Sites must stay in feature order: only the newest feature may receive geometry.
  if (feature < 0 || feature + 1 != static_cast<int32_t>(features_.size()))
    throw Error(ErrorKind::internal, "seed geometry added out of feature order");
}

void SeedSet::add_site(const Site& s) {
  if (sites_.size() >= static_cast<size_t>(std::numeric_limits<int32_t>::max() - 1))
    throw Error(ErrorKind::too_large, "too many seed sites (more than 2^31 points and segments)");
  sites_.push_back(s);
}

namespace {
GeometryKind merge_kind(bool had_sites, GeometryKind old_kind, GeometryKind add) {
  if (!had_sites || old_kind == add) return add;
  return GeometryKind::mixed;
}
}  // namespace

std::string SeedSet::feature_name(int32_t feature) const {
  const Feature& f = features_[static_cast<size_t>(feature)];
  return f.source.empty() ? "feature " + std::to_string(feature + 1) : f.source.str();
}

void SeedSet::set_adjustment(int32_t feature, double weight, double reach) {
  if (feature < 0 || feature >= static_cast<int32_t>(features_.size()))
    throw Error(ErrorKind::internal, "set_adjustment: no feature " + std::to_string(feature));
  if (!std::isfinite(weight) || !(weight > 0.0))
    throw Error(ErrorKind::invalid_input,
                feature_name(feature) + ": the weight must be a finite number above 0 (got " + number(weight) + ")");
  if (std::isnan(reach) || !(reach > 0.0))
    throw Error(ErrorKind::invalid_input,
                feature_name(feature) + ": the reach must be a distance above 0 (got " + number(reach) + ")");
  Feature& f = features_[static_cast<size_t>(feature)];
  adjusted_features_ -= is_adjusted(f);
  f.weight = weight;
  f.reach = reach;
  adjusted_features_ += is_adjusted(f);
}

void SeedSet::set_effect(int32_t feature, double effect) {
  if (feature < 0 || feature >= static_cast<int32_t>(features_.size()))
    throw Error(ErrorKind::internal, "set_effect: no feature " + std::to_string(feature));
  if (!(effect >= 0.0 && effect <= 1.0))
    throw Error(ErrorKind::invalid_input,
                feature_name(feature) + ": the effect must be a number from 0 to 1 (got " + number(effect) + ")");
  features_[static_cast<size_t>(feature)].effect = effect;
}

void SeedSet::scale_reaches(double factor) {
  if (!std::isfinite(factor) || !(factor > 0.0)) throw Error(ErrorKind::internal, "scale_reaches: bad factor");
  for (Feature& f : features_)
    if (std::isfinite(f.reach)) f.reach *= factor;
  count_adjusted();  // a reach may overflow to infinity
}

void SeedSet::count_adjusted() {
  adjusted_features_ = 0;
  for (const Feature& f : features_) adjusted_features_ += is_adjusted(f);
}

SeedSet SeedSet::without(const std::vector<bool>& drop, std::vector<int32_t>& site_of) const {
  if (drop.size() != features_.size()) throw Error(ErrorKind::internal, "SeedSet::without: one entry per feature");
  SeedSet out;
  out.owner_labels_ = owner_labels_;
  out.owner_index_ = owner_index_;
  std::vector<int32_t> feature_of(features_.size(), -1);
  for (size_t f = 0; f < features_.size(); ++f) {
    if (drop[f]) continue;
    feature_of[f] = static_cast<int32_t>(out.features_.size());
    out.features_.push_back(features_[f]);
  }
  std::vector<int32_t> new_site(sites_.size(), -1);
  site_of.clear();
  for (size_t i = 0; i < sites_.size(); ++i) {
    const int32_t f = feature_of[static_cast<size_t>(sites_[i].feature)];
    if (f < 0) continue;
    new_site[i] = static_cast<int32_t>(out.sites_.size());
    site_of.push_back(static_cast<int32_t>(i));
    Site s = sites_[i];
    s.feature = f;
    out.sites_.push_back(s);
  }
  for (const Polygon& p : polygons_) {
    const int32_t f = feature_of[static_cast<size_t>(p.feature)];
    if (f < 0) continue;
    out.polygons_.push_back(Polygon{f, new_site[static_cast<size_t>(p.area_site)], p.rings});
  }
  out.count_adjusted();
  return out;
}

SeedSet SeedSet::replaced(const std::vector<int32_t>& features, const SeedSet& by) const {
  auto wrong = [](const std::string& what) { throw Error(ErrorKind::internal, "SeedSet::replaced: " + what); };
  if (features.size() != by.features_.size()) wrong("one replacement per feature");
  if (by.owner_labels_.size() < owner_labels_.size() ||
      !std::equal(owner_labels_.begin(), owner_labels_.end(), by.owner_labels_.begin()))
    wrong("the replacements number owners otherwise");
  for (size_t i = 0; i < features.size(); ++i) {
    const int32_t f = features[i];
    if (f < 0 || static_cast<size_t>(f) >= features_.size() || (i > 0 && f <= features[i - 1]))
      wrong("features out of range or order");
    if (by.features_[i].owner != features_[static_cast<size_t>(f)].owner) wrong("a replacement changes its owner");
  }
  SeedSet out;
  out.owner_labels_ = owner_labels_;
  out.owner_index_ = owner_index_;
  out.features_ = features_;
  out.adjusted_features_ = adjusted_features_;
  for (size_t i = 0; i < features.size(); ++i) {
    Feature& f = out.features_[static_cast<size_t>(features[i])];
    out.adjusted_features_ += is_adjusted(by.features_[i]) - is_adjusted(f);
    f = by.features_[i];
  }
  // Sites: this set's, each replaced feature's run swapped for its replacement's. Polygons follow
  // their area sites, whose indices shift by the runs' differences.
  std::vector<int32_t> moved_site(sites_.size(), -1), by_site(by.sites_.size(), -1);
  out.sites_.reserve(sites_.size() + by.sites_.size());
  size_t s = 0, t = 0;
  for (size_t i = 0; i < features.size(); ++i) {
    const int32_t f = features[i];
    for (; s < sites_.size() && sites_[s].feature < f; ++s) {
      moved_site[s] = static_cast<int32_t>(out.sites_.size());
      out.sites_.push_back(sites_[s]);
    }
    while (s < sites_.size() && sites_[s].feature == f) ++s;
    for (; t < by.sites_.size() && by.sites_[t].feature == static_cast<int32_t>(i); ++t) {
      by_site[t] = static_cast<int32_t>(out.sites_.size());
      Site x = by.sites_[t];
      x.feature = f;
      out.add_site(x);
    }
  }
  for (; s < sites_.size(); ++s) {
    moved_site[s] = static_cast<int32_t>(out.sites_.size());
    out.sites_.push_back(sites_[s]);
  }
  if (t != by.sites_.size()) wrong("the replacements' sites out of feature order");
  size_t p = 0, q = 0;
  auto keep = [&](const Polygon& x) {
    out.polygons_.push_back(Polygon{x.feature, moved_site[static_cast<size_t>(x.area_site)], x.rings});
  };
  for (size_t i = 0; i < features.size(); ++i) {
    const int32_t f = features[i];
    for (; p < polygons_.size() && polygons_[p].feature < f; ++p) keep(polygons_[p]);
    while (p < polygons_.size() && polygons_[p].feature == f) ++p;
    for (; q < by.polygons_.size() && by.polygons_[q].feature == static_cast<int32_t>(i); ++q)
      out.polygons_.push_back(
          Polygon{f, by_site[static_cast<size_t>(by.polygons_[q].area_site)], by.polygons_[q].rings});
  }
  for (; p < polygons_.size(); ++p) keep(polygons_[p]);
  if (q != by.polygons_.size()) wrong("the replacements' polygons out of feature order");
  for (const Polygon& x : out.polygons_)
    if (x.area_site < 0) wrong("a polygon out of feature order");
  return out;
}

SeedSet SeedSet::from_parts(std::vector<Site> sites, std::vector<Polygon> polygons, std::vector<Feature> features,
                            std::vector<std::string> owner_labels) {
  auto bad = [](const std::string& what) { throw Error(ErrorKind::invalid_input, "seed set: " + what); };
  SeedSet out;
  for (const std::string& label : owner_labels)
    if (!out.owner_index_.emplace(label, static_cast<int32_t>(out.owner_index_.size() + 1)).second)
      bad("owner label repeated");
  const auto nf = static_cast<int64_t>(features.size());
  const auto no = static_cast<int64_t>(owner_labels.size());
  for (const Feature& f : features)
    if (f.owner < 1 || f.owner > no || !(f.weight > 0.0) || !std::isfinite(f.weight) || !(f.reach > 0.0) ||
        !(f.effect >= 0.0 && f.effect <= 1.0))
      bad("a feature's owner, weight, reach or effect out of range");
  int32_t last = 0;
  for (const Site& s : sites) {
    if (s.feature < last || s.feature >= nf) bad("a site's feature out of range or order");
    if (!finite(s.a) || !finite(s.b) || static_cast<uint8_t>(s.kind) > static_cast<uint8_t>(SiteKind::area))
      bad("a site out of its domain");
    last = s.feature;
  }
  if (sites.size() >= static_cast<size_t>(std::numeric_limits<int32_t>::max() - 1)) bad("too many sites");
  for (const Polygon& p : polygons) {
    if (p.feature < 0 || p.feature >= nf || p.area_site < 0 || static_cast<size_t>(p.area_site) >= sites.size())
      bad("a polygon's feature or area site out of range");
    const Site& a = sites[static_cast<size_t>(p.area_site)];
    if (a.kind != SiteKind::area || a.feature != p.feature) bad("a polygon's area site is not its own");
    for (const Ring& r : p.rings)
      for (const Vec2 v : r)
        if (!finite(v)) bad("a polygon's vertex out of its domain");
  }
  out.sites_ = std::move(sites);
  out.polygons_ = std::move(polygons);
  out.features_ = std::move(features);
  out.owner_labels_ = std::move(owner_labels);
  out.count_adjusted();
  return out;
}

int SeedSet::add_point(int32_t feature, Vec2 p) {
  check_feature(feature);
  if (!finite(p)) throw Error(ErrorKind::invalid_input, feature_name(feature) + ": non-finite coordinate");
  const bool had = !sites_.empty() && sites_.back().feature == feature;
  features_[feature].kind = merge_kind(had, features_[feature].kind, GeometryKind::point);
  add_site(Site{p, p, feature, SiteKind::point});
  return 1;
}

int SeedSet::add_polyline(int32_t feature, std::span<const Vec2> vertices) {
  check_feature(feature);
  for (const Vec2& v : vertices)
    if (!finite(v)) throw Error(ErrorKind::invalid_input, feature_name(feature) + ": non-finite coordinate");
  std::vector<Vec2> clean;
  clean.reserve(vertices.size());
  for (const Vec2& v : vertices)
    if (clean.empty() || !(clean.back() == v)) clean.push_back(v);
  if (clean.empty()) return 0;
  if (clean.size() == 1) return add_point(feature, clean.front());
  const bool had = !sites_.empty() && sites_.back().feature == feature;
  features_[feature].kind = merge_kind(had, features_[feature].kind, GeometryKind::line);
  for (size_t i = 0; i + 1 < clean.size(); ++i) add_site(Site{clean[i], clean[i + 1], feature, SiteKind::segment});
  return static_cast<int>(clean.size() - 1);
}

int SeedSet::add_polygon(int32_t feature, std::vector<Ring> rings) {
  check_feature(feature);
  std::vector<Ring> kept;
  for (Ring& ring : rings) {
    Ring clean;
    clean.reserve(ring.size());
    for (const Vec2& v : ring) {
      if (!finite(v)) throw Error(ErrorKind::invalid_input, feature_name(feature) + ": non-finite coordinate");
      if (clean.empty() || !(clean.back() == v)) clean.push_back(v);
    }
    while (clean.size() > 1 && clean.back() == clean.front()) clean.pop_back();
    if (clean.size() >= 3) kept.push_back(std::move(clean));
  }
  if (kept.empty()) return 0;
  const bool had = !sites_.empty() && sites_.back().feature == feature;
  features_[feature].kind = merge_kind(had, features_[feature].kind, GeometryKind::polygon);
  int added = 0;
  for (const Ring& ring : kept) {
    for (size_t i = 0; i < ring.size(); ++i) {
      add_site(Site{ring[i], ring[(i + 1) % ring.size()], feature, SiteKind::segment});
      ++added;
    }
  }
  const auto area = static_cast<int32_t>(sites_.size());
  add_site(Site{kept[0][0], kept[0][0], feature, SiteKind::area});
  polygons_.push_back(Polygon{feature, area, std::move(kept)});
  return added + 1;
}

SeedSet::Box SeedSet::bounds() const {
  const double inf = std::numeric_limits<double>::infinity();
  Box b{inf, inf, -inf, -inf};
  for (const Site& s : sites_) {
    for (const Vec2& p : {s.a, s.b}) {
      b.xmin = std::min(b.xmin, p.x);
      b.ymin = std::min(b.ymin, p.y);
      b.xmax = std::max(b.xmax, p.x);
      b.ymax = std::max(b.ymax, p.y);
    }
  }
  return b;
}

int64_t SeedSet::geometric_site_count() const {
  int64_t n = 0;
  for (const Site& s : sites_) n += s.kind != SiteKind::area;
  return n;
}

int64_t SourceText::heap_bytes() const {
  if (!text_) return 0;
  // make_shared's one block: the control block's table pointer and two counts, and the string;
  // the text's own buffer past the short-string capacity, with the allocator's word.
  constexpr auto word = static_cast<int64_t>(sizeof(void*));
  const int64_t own = text_->capacity() > 15 ? static_cast<int64_t>(text_->capacity()) + 1 + word : 0;
  return 2 * static_cast<int64_t>(sizeof(int32_t)) + static_cast<int64_t>(sizeof(std::string)) + word + own;
}

int64_t SeedSet::memory_bytes() const {
  constexpr auto block = static_cast<int64_t>(sizeof(void*));
  auto text = [&](const std::string& s) {
    return static_cast<int64_t>(sizeof(std::string)) +
           (s.capacity() > 15 ? static_cast<int64_t>(s.capacity()) + block : 0);
  };
  int64_t bytes = static_cast<int64_t>(sizeof(SeedSet)) + static_cast<int64_t>(sites_.capacity() * sizeof(Site));
  bytes += static_cast<int64_t>(polygons_.capacity() * sizeof(Polygon));
  for (const Polygon& p : polygons_) {
    bytes += static_cast<int64_t>(p.rings.capacity() * sizeof(Ring)) + block;
    for (const Ring& r : p.rings) bytes += static_cast<int64_t>(r.capacity() * sizeof(Vec2)) + block;
  }
  bytes += static_cast<int64_t>(features_.capacity() * sizeof(Feature));
  for (const Feature& f : features_) bytes += f.source.heap_bytes();
  for (const std::string& label : owner_labels_) {
    // The label, its copy as the index's key, the index node and its bucket.
    bytes += 2 * text(label) + static_cast<int64_t>(sizeof(int32_t)) + 3 * block;
  }
  return bytes;
}

}  // namespace rv
