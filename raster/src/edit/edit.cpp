// Edits of a finished field (rv/edit/edit.hpp): matching the features of two seed sets, the cells an
// edit can change, and the edited field from the base's.
#include "rv/edit/edit.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "rv/engine/owner_index.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/lines/strip_lines.hpp"

namespace rv {

namespace {

// Each feature's sites [first, end) (sites are stored in feature order).
std::vector<std::pair<int32_t, int32_t>> site_ranges(const SeedSet& s) {
  std::vector<std::pair<int32_t, int32_t>> r(s.features().size(), {0, 0});
  const auto& sites = s.sites();
  for (int32_t i = 0; i < static_cast<int32_t>(sites.size()); ++i) {
    auto& range = r[static_cast<size_t>(sites[static_cast<size_t>(i)].feature)];
    if (range.first == range.second) range.first = i;
    range.second = i + 1;
  }
  return r;
}

// Each feature's polygons (indices into SeedSet::polygons()).
std::vector<std::vector<size_t>> polygons_of(const SeedSet& s) {
  std::vector<std::vector<size_t>> p(s.features().size());
  for (size_t i = 0; i < s.polygons().size(); ++i) p[static_cast<size_t>(s.polygons()[i].feature)].push_back(i);
  return p;
}

// What makes a feature the same feature: its owner's label, adjustments, sites and rings.
struct FeatureKeys {
  const SeedSet& s;
  std::vector<std::pair<int32_t, int32_t>> ranges = site_ranges(s);
  std::vector<std::vector<size_t>> polys = polygons_of(s);

  const std::string& label(int32_t f) const {
    return s.owner_labels()[static_cast<size_t>(s.features()[static_cast<size_t>(f)].owner - 1)];
  }
  uint64_t hash(int32_t f) const {
    uint64_t h = std::hash<std::string>{}(label(f));
    auto mix = [&h](uint64_t v) { h ^= v + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2); };
    auto bits = [](double x) { return std::bit_cast<uint64_t>(x); };
    const Feature& ft = s.features()[static_cast<size_t>(f)];
    mix(bits(ft.weight));
    mix(bits(ft.reach));
    mix(bits(ft.effect));
    const auto [b, e] = ranges[static_cast<size_t>(f)];
    for (int32_t i = b; i < e; ++i) {
      const Site& st = s.sites()[static_cast<size_t>(i)];
      mix(static_cast<uint64_t>(st.kind));
      mix(bits(st.a.x));
      mix(bits(st.a.y));
      mix(bits(st.b.x));
      mix(bits(st.b.y));
    }
    return h;
  }
};

// The same owner label, geometry kind and adjustments (bit for bit): all of a feature but its sites.
bool same_attributes(const SeedSet& x, int32_t fx, const SeedSet& y, int32_t fy) {
  const Feature& a = x.features()[static_cast<size_t>(fx)];
  const Feature& b = y.features()[static_cast<size_t>(fy)];
  return x.owner_labels()[static_cast<size_t>(a.owner - 1)] == y.owner_labels()[static_cast<size_t>(b.owner - 1)] &&
         a.kind == b.kind && std::bit_cast<uint64_t>(a.weight) == std::bit_cast<uint64_t>(b.weight) &&
         std::bit_cast<uint64_t>(a.reach) == std::bit_cast<uint64_t>(b.reach) &&
         std::bit_cast<uint64_t>(a.effect) == std::bit_cast<uint64_t>(b.effect);
}

bool same_feature(const FeatureKeys& x, int32_t fx, const FeatureKeys& y, int32_t fy) {
  if (!same_attributes(x.s, fx, y.s, fy)) return false;
  const auto [xb, xe] = x.ranges[static_cast<size_t>(fx)];
  const auto [yb, ye] = y.ranges[static_cast<size_t>(fy)];
  if (xe - xb != ye - yb) return false;
  for (int32_t k = 0; k < xe - xb; ++k) {
    const Site& p = x.s.sites()[static_cast<size_t>(xb + k)];
    const Site& q = y.s.sites()[static_cast<size_t>(yb + k)];
    if (p.kind != q.kind || !(p.a == q.a) || !(p.b == q.b)) return false;
  }
  const auto& px = x.polys[static_cast<size_t>(fx)];
  const auto& py = y.polys[static_cast<size_t>(fy)];
  if (px.size() != py.size()) return false;
  for (size_t k = 0; k < px.size(); ++k)
    if (x.s.polygons()[px[k]].rings != y.s.polygons()[py[k]].rings) return false;
  return true;
}

// Whether the owners both sets have come in a different order of codes: the owners they share,
// walked in the base's order, do not have rising codes in the edited set.
bool owners_reordered(const SeedSet& base, const SeedSet& edited) {
  const std::vector<int32_t> to = owner_codes_in(base, edited);
  int32_t last = 0;
  for (size_t c = 1; c < to.size(); ++c) {
    if (to[c] < 0) continue;
    if (to[c] < last) return true;
    last = to[c];
  }
  return false;
}

// The sites of `set` with `pick` set, as one owner's seed set (their distances, weights and
// reaches; owners and order do not matter to where they can win): points and segments as
// themselves, a picked area site as its polygon with its rings (which add their edges again: a
// repeated site changes no distance).
SeedSet sites_as_set(const SeedSet& set, const std::vector<bool>& pick) {
  SeedSet out;
  const int32_t owner = out.owner_code("picked");
  const auto polys = polygons_of(set);
  int32_t feature = -1, nf = -1;
  for (size_t i = 0; i < pick.size(); ++i) {
    if (!pick[i]) continue;
    const Site& s = set.sites()[i];
    if (s.feature != feature) {
      feature = s.feature;
      nf = out.add_feature(owner, set.features()[static_cast<size_t>(feature)].source);
      const Feature& ft = set.features()[static_cast<size_t>(feature)];
      if (ft.weight != 1.0 || std::isfinite(ft.reach)) out.set_adjustment(nf, ft.weight, ft.reach);
    }
    if (s.kind == SiteKind::point) out.add_point(nf, s.a);
    if (s.kind == SiteKind::segment) out.add_polyline(nf, std::vector<Vec2>{s.a, s.b});
    if (s.kind == SiteKind::area)
      for (const size_t p : polys[static_cast<size_t>(feature)])
        if (set.polygons()[p].area_site == static_cast<int32_t>(i)) out.add_polygon(nf, set.polygons()[p].rings);
  }
  return out;
}

}  // namespace

std::string source_key(const std::string& source) {
  const size_t slash = source.rfind('/');
  return slash == std::string::npos ? source : source.substr(slash + 1);
}

int64_t FeatureMatch::kept() const {
  return std::count_if(edited_of_base.begin(), edited_of_base.end(), [](int32_t e) { return e >= 0; });
}

std::vector<int32_t> owner_codes_in(const SeedSet& from, const SeedSet& to) {
  std::unordered_map<std::string_view, int32_t> code;
  code.reserve(to.owner_labels().size());
  for (size_t i = 0; i < to.owner_labels().size(); ++i) code.emplace(to.owner_labels()[i], static_cast<int32_t>(i + 1));
  std::vector<int32_t> out(from.owner_labels().size() + 1, 0);
  for (size_t i = 0; i < from.owner_labels().size(); ++i) {
    const auto it = code.find(from.owner_labels()[i]);
    out[i + 1] = it == code.end() ? -1 : it->second;
  }
  return out;
}

FeatureMatch match_features(const SeedSet& base, const SeedSet& edited) {
  const FeatureKeys kb{base}, ke{edited};
  FeatureMatch m;
  m.edited_of_base.assign(base.features().size(), -1);
  m.base_of_edited.assign(edited.features().size(), -1);
  std::unordered_multimap<uint64_t, int32_t> by_hash;
  for (int32_t f = 0; f < static_cast<int32_t>(base.features().size()); ++f) by_hash.emplace(kb.hash(f), f);
  // Equal features pair in order: each edited feature takes the first unused equal base one.
  for (int32_t f = 0; f < static_cast<int32_t>(edited.features().size()); ++f) {
    int32_t best = -1;
    const auto [lo, hi] = by_hash.equal_range(ke.hash(f));
    for (auto it = lo; it != hi; ++it)
      if (m.edited_of_base[static_cast<size_t>(it->second)] < 0 && (best < 0 || it->second < best) &&
          same_feature(kb, it->second, ke, f))
        best = it->second;
    if (best >= 0) {
      m.edited_of_base[static_cast<size_t>(best)] = f;
      m.base_of_edited[static_cast<size_t>(f)] = best;
    }
  }
  // Kept features keep their order: one that moved before a kept feature it followed counts as
  // changed (the lower index wins ties, so its cells may change hands).
  int32_t last = -1;
  for (int32_t f = 0; f < static_cast<int32_t>(edited.features().size()); ++f) {
    const int32_t b = m.base_of_edited[static_cast<size_t>(f)];
    if (b < 0) continue;
    if (b < last) {
      m.base_of_edited[static_cast<size_t>(f)] = -1;
      m.edited_of_base[static_cast<size_t>(b)] = -1;
    } else {
      last = b;
    }
  }
  m.owners_reordered = owners_reordered(base, edited);
  return m;
}

std::vector<int32_t> edited_sites(const SeedSet& base, const SeedSet& edited, const FeatureMatch& match) {
  const auto rb = site_ranges(base), re = site_ranges(edited);
  std::vector<int32_t> out(base.sites().size(), kNoSite);
  for (size_t f = 0; f < match.edited_of_base.size(); ++f) {
    const int32_t e = match.edited_of_base[f];
    if (e < 0) continue;
    for (int32_t k = 0; k < rb[f].second - rb[f].first; ++k)
      out[static_cast<size_t>(rb[f].first + k)] = re[static_cast<size_t>(e)].first + k;
  }
  return out;
}

namespace {

constexpr int64_t kBlock = 16;
constexpr int64_t kSubBlock = 4;   // plan_part's second bound, within a block that may be won
constexpr int64_t kSuperTile = 4;  // tiles bounded together first (tile_bounds)
// The rows of a tile line_tiles tells apart: a tile's flag holds one bit per band of kLineBand
// rows (an edit near a coast flags a few bands of a few tiles, and the rows extracted again are
// those bands', not the tiles' 256).
constexpr int64_t kLineBand = TileSummaries::kTile / TileSummaries::kBands;

// Relative slack on a base cost: the Float32 distance's rounding (2^-24), generously.
constexpr double kSlack = 1e-6;

// A lower bound on the distance from the sites of `index` to the centre of any cell of the grid's
// cells [c0, c1) x [r0, r1): the distance to the box's middle less the box's radius. (The corners
// bound a box in the plane; 1 % covers a longitude/latitude box's curvature.)
double box_bound(const SiteMetric& metric, const OwnerIndex& index, const GridSpec& grid, int64_t c0, int64_t r0,
                 int64_t c1, int64_t r1) {
  const Vec2 a{grid.centre_x(c0), grid.centre_y(r0)};
  const Vec2 b{grid.centre_x(c1 - 1), grid.centre_y(r1 - 1)};
  const Vec2 mid{0.5 * (a.x + b.x), 0.5 * (a.y + b.y)};
  double radius = 0.0;
  for (const Vec2 q : {a, b, Vec2{a.x, b.y}, Vec2{b.x, a.y}}) radius = std::max(radius, metric.point_distance(mid, q));
  radius = radius * 1.01 + 1e-9;
  return std::max(0.0, index.nearest(mid).distance - radius);
}

// The sites an edit keeps, finer than its features: a feature that changed only in geometry (the
// same source, owner and adjustments: a basepoint moved on a coast of thousands) keeps the sites
// it still has. Its polygon's interior stays the same interior except between the edges that
// changed: every cell whose decision the interior can change lies in the box of those edges
// (each part of the two interiors' difference is enclosed by changed edges alone).
struct SiteMatch {
  std::vector<int32_t> remap;       // base site -> edited site, kNoSite where not kept
  std::vector<bool> added;          // per edited site: not kept
  std::vector<bool> removed;        // per base site: not kept
  std::vector<SeedSet::Box> boxes;  // grid-CRS boxes of changed polygon edges
};

SiteMatch match_sites(const SeedSet& base, const SeedSet& edited, const FeatureMatch& m, bool boxes) {
  SiteMatch out;
  out.remap = edited_sites(base, edited, m);
  const auto rb = site_ranges(base), re = site_ranges(edited);
  const auto pb = polygons_of(base), pe = polygons_of(edited);
  // Changed features paired by source, owner label, kind and adjustments.
  std::unordered_map<std::string, int32_t> by_source;
  for (int32_t f = 0; f < static_cast<int32_t>(edited.features().size()); ++f)
    if (m.base_of_edited[static_cast<size_t>(f)] < 0 && !edited.features()[static_cast<size_t>(f)].source.empty())
      by_source.emplace(source_key(edited.features()[static_cast<size_t>(f)].source), f);
  std::vector<std::pair<int32_t, int32_t>> pairs;
  for (int32_t f = 0; f < static_cast<int32_t>(base.features().size()); ++f) {
    const Feature& a = base.features()[static_cast<size_t>(f)];
    if (m.edited_of_base[static_cast<size_t>(f)] >= 0 || a.source.empty()) continue;
    const auto it = by_source.find(source_key(a.source));
    if (it == by_source.end() || !same_attributes(base, f, edited, it->second)) continue;
    pairs.emplace_back(f, it->second);
    by_source.erase(it);
  }
  struct Key {
    uint8_t kind;
    Vec2 a, b;
    bool operator==(const Key&) const = default;
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      uint64_t h = k.kind;
      for (const double v : {k.a.x, k.a.y, k.b.x, k.b.y}) h = (h ^ std::bit_cast<uint64_t>(v)) * 0x9e3779b97f4a7c15ULL;
      return static_cast<size_t>(h ^ (h >> 31));
    }
  };
  for (const auto& [fb, fe] : pairs) {
    // Equal points and segments pair in order of appearance.
    std::unordered_map<Key, std::vector<int32_t>, KeyHash> sites;
    for (int32_t i = rb[static_cast<size_t>(fb)].second - 1; i >= rb[static_cast<size_t>(fb)].first; --i) {
      const Site& st = base.sites()[static_cast<size_t>(i)];
      if (st.kind != SiteKind::area) sites[Key{static_cast<uint8_t>(st.kind), st.a, st.b}].push_back(i);
    }
    for (int32_t j = re[static_cast<size_t>(fe)].first; j < re[static_cast<size_t>(fe)].second; ++j) {
      const Site& st = edited.sites()[static_cast<size_t>(j)];
      if (st.kind == SiteKind::area) continue;
      const auto it = sites.find(Key{static_cast<uint8_t>(st.kind), st.a, st.b});
      if (it == sites.end() || it->second.empty()) continue;
      out.remap[static_cast<size_t>(it->second.back())] = j;
      it->second.pop_back();
    }
    // Interiors pair polygon by polygon where the boxes can bound their change.
    const auto& polys_b = pb[static_cast<size_t>(fb)];
    const auto& polys_e = pe[static_cast<size_t>(fe)];
    if (boxes && polys_b.size() == polys_e.size())
      for (size_t k = 0; k < polys_b.size(); ++k)
        out.remap[static_cast<size_t>(base.polygons()[polys_b[k]].area_site)] = edited.polygons()[polys_e[k]].area_site;
  }
  // Kept sites keep their order (the lower index wins ties): one that moved before a kept site it
  // followed is not kept.
  int32_t last = -1;
  for (int32_t& e : out.remap) {
    if (e == kNoSite) continue;
    if (e < last)
      e = kNoSite;
    else
      last = e;
  }
  out.removed.assign(base.sites().size(), false);
  out.added.assign(edited.sites().size(), true);
  for (size_t i = 0; i < out.remap.size(); ++i) {
    if (out.remap[i] == kNoSite)
      out.removed[i] = true;
    else
      out.added[static_cast<size_t>(out.remap[i])] = false;
  }
  // The box of each kept interior's changed edges (both sets' edges not kept).
  for (const auto& [fb, fe] : pairs) {
    SeedSet::Box box{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    bool interior_kept = false;
    for (const size_t p : pb[static_cast<size_t>(fb)])
      interior_kept = interior_kept || out.remap[static_cast<size_t>(base.polygons()[p].area_site)] != kNoSite;
    if (!interior_kept) continue;
    auto grow = [&box](const Site& st) {
      for (const Vec2 v : {st.a, st.b}) {
        box.xmin = std::min(box.xmin, v.x);
        box.ymin = std::min(box.ymin, v.y);
        box.xmax = std::max(box.xmax, v.x);
        box.ymax = std::max(box.ymax, v.y);
      }
    };
    for (int32_t i = rb[static_cast<size_t>(fb)].first; i < rb[static_cast<size_t>(fb)].second; ++i)
      if (out.removed[static_cast<size_t>(i)] && base.sites()[static_cast<size_t>(i)].kind != SiteKind::area)
        grow(base.sites()[static_cast<size_t>(i)]);
    for (int32_t j = re[static_cast<size_t>(fe)].first; j < re[static_cast<size_t>(fe)].second; ++j)
      if (out.added[static_cast<size_t>(j)] && edited.sites()[static_cast<size_t>(j)].kind != SiteKind::area)
        grow(edited.sites()[static_cast<size_t>(j)]);
    if (box.xmin <= box.xmax) out.boxes.push_back(box);
  }
  return out;
}

// Some features of a seed set as one owner's, indexed for the distance to them (an edit's added
// or removed features). `all` when they cannot be indexed apart from the job (polygons on a
// projected geodesic grid need the job's grid-CRS copies): every cell is then a candidate.
struct FeatureGroup {
  bool any = false, all = false;
  SeedSet seeds;
  std::unique_ptr<SiteMetric> metric;
  std::unique_ptr<OwnerIndex> plain, adjusted;
  double w_max = 0.0, r_max = 0.0;

  // `pick`: per site of `from`, whether it belongs to the group.
  void build(const SeedSet& from, const std::vector<bool>& pick, const GridSpec& grid, const ComputeOptions& options) {
    any = std::find(pick.begin(), pick.end(), true) != pick.end();
    if (!any) return;
    seeds = sites_as_set(from, pick);
    if (options.geolocator && !seeds.polygons().empty()) {
      all = true;
      return;
    }
    ComputeOptions a = options;
    a.grid_polygons = nullptr;
    a.prepared = nullptr;
    metric = make_site_metric(seeds, grid, a);
    plain = std::make_unique<OwnerIndex>(*metric, OwnerIndex::Measure::plain);
    adjusted = std::make_unique<OwnerIndex>(*metric, OwnerIndex::Measure::adjusted, options.max_distance);
    for (const Feature& f : seeds.features()) {
      w_max = std::max(w_max, f.weight);
      r_max = std::max(r_max, std::min(f.reach, options.max_distance));
    }
  }
  // Whether a feature of the group can win a cell of the box, where the cells' costs are at most
  // `max_cost` (and some are unowned: `unowned`).
  bool may_win(const GridSpec& grid, int64_t c0, int64_t r0, int64_t c1, int64_t r1, double max_cost,
               bool unowned) const {
    const double least = min_cost(grid, c0, r0, c1, r1);
    return std::isfinite(least) && (unowned || least <= max_cost);
  }
  // The same for a box whose cells are at least `near` (box_bound) from the group.
  bool may_win_beyond(double near, double max_cost, bool unowned) const {
    if (all) return true;
    const double least = near > r_max ? std::numeric_limits<double>::infinity() : near / w_max;
    return std::isfinite(least) && (unowned || least <= max_cost);
  }
  // The distance beyond which may_win_beyond is false (at least).
  double win_limit(double max_cost, bool unowned) const {
    return unowned ? r_max : std::min(r_max, max_cost * w_max * (1.0 + 1e-9));
  }
  // A lower bound of the group's cost at every cell of the box: infinite where no feature of the
  // group reaches it, 0 for `all`.
  double min_cost(const GridSpec& grid, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
    if (all) return 0.0;
    const double near = box_bound(*metric, *plain, grid, c0, r0, c1, r1);
    return near > r_max ? std::numeric_limits<double>::infinity() : near / w_max;
  }
};

}  // namespace

// The edit prepared: matches, the site map, the added and the removed features indexed.
struct Edit::State {
  const SeedSet& base_seeds;
  const SeedSet& edited;
  GridSpec grid;
  ComputeOptions options;
  FeatureMatch match;
  std::vector<int32_t> remap;  // base site -> edited site
  bool keeps_indices = false;  // every kept site has the same index in both sets
  FeatureGroup added, removed;

  std::vector<SeedSet::Box> boxes;  // cells whose centre is in one are computed again

  State(const SeedSet& b, const SeedSet& e, const GridSpec& g, const ComputeOptions& o,
        std::optional<FeatureMatch> given = std::nullopt)
      : base_seeds(b), edited(e), grid(g), options(o) {
    if (options.method != Method::exact)
      throw Error(ErrorKind::invalid_argument, "edit: only the exact method recomputes a part of a field");
    options.window.reset();
    options.mask = nullptr;
    options.progress = nullptr;
    if (given) {
      match = std::move(*given);
      check_given_match();
      match.owners_reordered = owners_reordered(base_seeds, edited);
    } else {
      match = match_features(base_seeds, edited);
    }
    // Interiors kept across a change of their edges need the boxes in the grid's CRS: not on a
    // projected geodesic grid (the seeds are in longitude/latitude there).
    SiteMatch sites = match_sites(base_seeds, edited, match, options.geolocator == nullptr);
    remap = std::move(sites.remap);
    keeps_indices = true;
    for (size_t i = 0; i < remap.size(); ++i)
      keeps_indices = keeps_indices && (remap[i] == kNoSite || remap[i] == static_cast<int32_t>(i));
    boxes = std::move(sites.boxes);
    added.build(edited, sites.added, grid, options);
    removed.build(base_seeds, sites.removed, grid, options);
    // Owners in another order of codes: the cells inside polygons of two owners may change hands.
    if (match.owners_reordered) removed.any = removed.all = true;
    // Weights or reaches given or taken away switch a geodesic field between the exact method's
    // kernels and the adjusted method, whose distances agree with them to one float ulp, not
    // bit for bit (rv/geodesic/geodesic.hpp): every cell is computed again by the new one.
    every_cell = options.metric.kind == MetricSpec::geodesic && base_seeds.adjusted() != edited.adjusted();
  }
  bool every_cell = false;

  // A caller's match fits the sets: sizes, pairs both ways, in order, and each pair with as many
  // sites of each kind (site ranges as match_sites reads them).
  void check_given_match() const {
    const auto nb = static_cast<int32_t>(base_seeds.features().size()),
               ne = static_cast<int32_t>(edited.features().size());
    if (match.edited_of_base.size() != static_cast<size_t>(nb) ||
        match.base_of_edited.size() != static_cast<size_t>(ne))
      throw Error(ErrorKind::invalid_argument, "edit: the given feature match does not fit the seed sets");
    const auto rb = site_ranges(base_seeds), re = site_ranges(edited);
    int32_t last = -1;
    for (int32_t f = 0; f < ne; ++f) {
      const int32_t k = match.base_of_edited[static_cast<size_t>(f)];
      if (k < 0) continue;
      if (k >= nb || k <= last || match.edited_of_base[static_cast<size_t>(k)] != f ||
          rb[static_cast<size_t>(k)].second - rb[static_cast<size_t>(k)].first !=
              re[static_cast<size_t>(f)].second - re[static_cast<size_t>(f)].first)
        throw Error(ErrorKind::invalid_argument, "edit: the given feature match does not fit the seed sets");
      last = k;
    }
    for (int32_t k = 0; k < nb; ++k) {
      const int32_t f = match.edited_of_base[static_cast<size_t>(k)];
      if (f >= ne || (f >= 0 && match.base_of_edited[static_cast<size_t>(f)] != k))
        throw Error(ErrorKind::invalid_argument, "edit: the given feature match does not fit the seed sets");
    }
  }
  // Whether a cell centre (grid coordinates) lies in a box of changed edges.
  bool in_box(Vec2 p) const {
    for (const SeedSet::Box& b : boxes)
      if (p.x >= b.xmin && p.x <= b.xmax && p.y >= b.ymin && p.y <= b.ymax) return true;
    return false;
  }
  // Whether a box of changed edges meets the cell centres of [c0, c1) x [r0, r1) (grid).
  bool box_meets(int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
    const double x0 = grid.centre_x(c0), x1 = grid.centre_x(c1 - 1);
    const double y1 = grid.centre_y(r0), y0 = grid.centre_y(r1 - 1);
    for (const SeedSet::Box& b : boxes)
      if (b.xmin <= x1 && b.xmax >= x0 && b.ymin <= y1 && b.ymax >= y0) return true;
    return false;
  }

  // The part of the plan in the cells [c0, c1) x [r0, r1) of window `w` (window-relative):
  // per row of the part, its spans to compute again.
  struct Part {
    std::vector<std::vector<std::pair<int64_t, int64_t>>> spans;
    int64_t removed_cells = 0, blocks = 0;
  };
  // Why a tile of the grid must be read: a removed feature may have owned some of its cells, an
  // added one may win some, or a box of changed polygon edges meets it.
  struct TileNeed {
    bool by_removal = false, by_addition = false, boxed = false;
    bool any() const { return by_removal || by_addition || boxed; }
  };
  // Tiles [tr0, tr1) x [tc0, tc1) of the grid.
  struct TileRange {
    int64_t tr0, tc0, tr1, tc1;
    int64_t rows() const { return tr1 - tr0; }
    int64_t cols() const { return tc1 - tc0; }
  };
  // Per tile of `range` (row-major), why it must be read (`tiles`: the base field's summaries;
  // without them every tile may hold cells of a removed or an added feature).
  std::vector<TileNeed> tile_needs(const TileRange& range, const TileSummaries* tiles) const;
  // Per tile of `range` (row-major), a lower bound of the distance from `group`'s features to the
  // tile's cell centres (box_bound), or a value above the tile's `limit` where none of its cells
  // is within it. Tiles are bounded by blocks of kSuperTile x kSuperTile first: a block's bound
  // above every limit of its tiles stands for theirs (a far edit measures a few blocks, not every
  // tile). A negative limit asks for no bound. 0 for a group of `all`.
  std::vector<double> tile_bounds(const FeatureGroup& group, const TileRange& range,
                                  std::span<const double> limit) const;
  // A lower bound of the distance from `group`'s features to the centres of cells [c0, c1) x
  // [r0, r1) of the grid (box_bound; 0 for a group of `all`).
  double group_bound(const FeatureGroup& group, int64_t c0, int64_t r0, int64_t c1, int64_t r1) const {
    return group.all ? 0.0 : box_bound(*group.metric, *group.plain, grid, c0, r0, c1, r1);
  }
  void check_tiles(const TileSummaries* tiles) const;
  // `boxed`: cells in a box of changed polygon edges may be there.
  Part plan_part(const NearestField& base, const Window& w, int64_t c0, int64_t r0, int64_t c1, int64_t r1,
                 bool by_removal, bool by_addition, bool boxed) const;
};

Edit::State::Part Edit::State::plan_part(const NearestField& base, const Window& w, int64_t c0, int64_t r0, int64_t c1,
                                         int64_t r1, bool by_removal, bool by_addition, bool boxed) const {
  const int64_t pw = c1 - c0, ph = r1 - r0;
  const auto nsites = static_cast<int32_t>(base_seeds.sites().size());
  Part part;
  part.spans.resize(static_cast<size_t>(ph));
  if (every_cell) {
    for (auto& row : part.spans) row.emplace_back(c0, c1);
    return part;
  }
  // Per cell: 1 where it must be computed again; the base cost elsewhere.
  std::vector<uint8_t> marked(static_cast<size_t>(pw * ph), 0);
  std::vector<double> cost(static_cast<size_t>(pw * ph), std::numeric_limits<double>::infinity());
  for (int64_t r = 0; r < ph; ++r)
    for (int64_t c = 0; c < pw; ++c) {
      const size_t i = static_cast<size_t>(r * pw + c);
      if (boxed && in_box(Vec2{grid.centre_x(w.col0 + c0 + c), grid.centre_y(w.row0 + r0 + r)})) {
        marked[i] = 1;
        ++part.removed_cells;
        continue;
      }
      const int32_t s = base.site.at(c0 + c, r0 + r);
      if (s == kNoSite) continue;
      if (s < 0 || s >= nsites) throw Error(ErrorKind::invalid_argument, "edit: the base field does not fit its seeds");
      const Site& site = base_seeds.sites()[static_cast<size_t>(s)];
      if (by_removal &&
          (remap[static_cast<size_t>(s)] == kNoSite || (match.owners_reordered && site.kind == SiteKind::area))) {
        marked[i] = 1;
        ++part.removed_cells;
        continue;
      }
      cost[i] = static_cast<double>(base.distance.at(c0 + c, r0 + r)) * (1.0 + kSlack) /
                base_seeds.features()[static_cast<size_t>(site.feature)].weight;
    }
  if (by_addition) {
    if (added.all) std::fill(marked.begin(), marked.end(), 1);
    for (int64_t b0 = 0; b0 < ph && !added.all; b0 += kBlock)
      for (int64_t a0 = 0; a0 < pw; a0 += kBlock) {
        const int64_t a1 = std::min(pw, a0 + kBlock), b1 = std::min(ph, b0 + kBlock);
        double block_cost = -1.0;
        bool unowned = false;
        for (int64_t r = b0; r < b1; ++r)
          for (int64_t c = a0; c < a1; ++c) {
            const size_t i = static_cast<size_t>(r * pw + c);
            if (marked[i]) continue;
            block_cost = std::max(block_cost, cost[i]);
            unowned = unowned || std::isinf(cost[i]);
          }
        if (block_cost < 0.0) continue;  // every cell is computed again anyway
        const int64_t gc = w.col0 + c0, gr = w.row0 + r0;
        if (!added.may_win(grid, gc + a0, gr + b0, gc + a1, gr + b1, block_cost, unowned)) continue;
        ++part.blocks;
        // Bounded again by quarters of the block's side: the group's cost in a sub-block is at
        // least its bound, so a cell whose cost is below it keeps its owner and is not measured.
        // Where the added features win a few cells at the edge of their region (a moved vertex),
        // most cells of a block that may be won are not.
        for (int64_t sb = b0; sb < b1; sb += kSubBlock)
          for (int64_t sa = a0; sa < a1; sa += kSubBlock) {
            const int64_t sa1 = std::min(a1, sa + kSubBlock), sb1 = std::min(b1, sb + kSubBlock);
            bool open = false;
            for (int64_t r = sb; r < sb1 && !open; ++r)
              for (int64_t c = sa; c < sa1; ++c) open = open || !marked[static_cast<size_t>(r * pw + c)];
            if (!open) continue;
            const double least = added.min_cost(grid, gc + sa, gr + sb, gc + sa1, gr + sb1);
            if (std::isinf(least)) continue;
            for (int64_t r = sb; r < sb1; ++r)
              for (int64_t c = sa; c < sa1; ++c) {
                const size_t i = static_cast<size_t>(r * pw + c);
                if (marked[i] || cost[i] < least) continue;
                const OwnerIndex::Hit h = added.adjusted->nearest(Vec2{grid.centre_x(gc + c), grid.centre_y(gr + r)});
                if (h.site != kNoSite && h.cost <= cost[i]) marked[i] = 1;
              }
          }
      }
  }
  for (int64_t r = 0; r < ph; ++r) {
    const uint8_t* row = marked.data() + r * pw;
    for (int64_t c = 0; c < pw;) {
      if (!row[c]) {
        ++c;
        continue;
      }
      int64_t e = c;
      while (e < pw && row[e]) ++e;
      part.spans[static_cast<size_t>(r)].emplace_back(c0 + c, c0 + e);
      c = e;
    }
  }
  return part;
}

Edit::Edit(const SeedSet& base_seeds, const SeedSet& edited, const GridSpec& grid, const ComputeOptions& options)
    : st_(std::make_unique<State>(base_seeds, edited, grid, options)) {}
Edit::Edit(const SeedSet& base_seeds, const SeedSet& edited, const GridSpec& grid, const ComputeOptions& options,
           FeatureMatch match)
    : st_(std::make_unique<State>(base_seeds, edited, grid, options, std::move(match))) {}
Edit::~Edit() = default;
Edit::Edit(Edit&&) noexcept = default;

const FeatureMatch& Edit::match() const { return st_->match; }
const std::vector<int32_t>& Edit::site_map() const { return st_->remap; }

bool Edit::keeps_indices() const { return st_->keeps_indices; }

std::vector<double> Edit::State::tile_bounds(const FeatureGroup& group, const TileRange& range,
                                             std::span<const double> limit) const {
  constexpr int64_t T = TileSummaries::kTile, S = kSuperTile;
  const int64_t rows = range.rows(), cols = range.cols();
  std::vector<double> out(static_cast<size_t>(rows * cols), 0.0);
  if (group.all || !group.any) return out;
  // Tiles [a0, a1) x [b0, b1) of the range, as cells of the grid.
  auto bound = [&](int64_t a0, int64_t b0, int64_t a1, int64_t b1) {
    return box_bound(*group.metric, *group.plain, grid, (range.tc0 + a0) * T, (range.tr0 + b0) * T,
                     std::min(grid.width, (range.tc0 + a1) * T), std::min(grid.height, (range.tr0 + b1) * T));
  };
  const int64_t block_rows = (rows + S - 1) / S, block_cols = (cols + S - 1) / S;
  detail::parallel_for(resolve_threads(options.threads), block_rows * block_cols, [&](int64_t k, int) {
    const int64_t b0 = k / block_cols * S, a0 = k % block_cols * S;
    const int64_t b1 = std::min(rows, b0 + S), a1 = std::min(cols, a0 + S);
    auto at = [&](int64_t a, int64_t b) -> double& { return out[static_cast<size_t>(b * cols + a)]; };
    double most = -1.0;
    for (int64_t b = b0; b < b1; ++b)
      for (int64_t a = a0; a < a1; ++a) most = std::max(most, limit[static_cast<size_t>(b * cols + a)]);
    const double whole = most < 0.0 ? std::numeric_limits<double>::infinity() : bound(a0, b0, a1, b1);
    for (int64_t b = b0; b < b1; ++b)
      for (int64_t a = a0; a < a1; ++a) at(a, b) = whole > most ? whole : bound(a, b, a + 1, b + 1);
  });
  return out;
}

std::vector<Edit::State::TileNeed> Edit::State::tile_needs(const TileRange& range, const TileSummaries* tiles) const {
  constexpr int64_t T = TileSummaries::kTile;
  const auto n = static_cast<size_t>(range.rows() * range.cols());
  std::vector<TileNeed> out(n);
  if (every_cell) {
    std::fill(out.begin(), out.end(), TileNeed{true, true, true});
    return out;
  }
  std::vector<double> removal(n, -1.0), addition(n, -1.0);
  for (size_t i = 0; i < n; ++i) {
    const int64_t tr = range.tr0 + static_cast<int64_t>(i) / range.cols();
    const int64_t tc = range.tc0 + static_cast<int64_t>(i) % range.cols();
    const int64_t gc0 = tc * T, gr0 = tr * T;
    out[i] = TileNeed{removed.any, added.any,
                      box_meets(gc0, gr0, std::min(grid.width, gc0 + T), std::min(grid.height, gr0 + T))};
    if (!tiles) continue;
    const size_t k = static_cast<size_t>(tr * tiles->cols + tc);
    const double max_d = tiles->max_distance[k];
    if (removed.any && max_d >= 0.0) removal[i] = max_d * (1.0 + kSlack);
    if (added.any) addition[i] = added.win_limit(tiles->max_cost[k] * (1.0 + kSlack), tiles->unowned[k] != 0);
  }
  if (!tiles) return out;
  const std::vector<double> near_removed = tile_bounds(removed, range, removal);
  const std::vector<double> near_added = tile_bounds(added, range, addition);
  for (size_t i = 0; i < n; ++i) {
    const int64_t tr = range.tr0 + static_cast<int64_t>(i) / range.cols();
    const int64_t tc = range.tc0 + static_cast<int64_t>(i) % range.cols();
    const size_t k = static_cast<size_t>(tr * tiles->cols + tc);
    const double max_d = tiles->max_distance[k], max_c = tiles->max_cost[k];
    out[i].by_removal = out[i].by_removal && max_d >= 0.0 && near_removed[i] <= max_d * (1.0 + kSlack);
    out[i].by_addition =
        out[i].by_addition && added.may_win_beyond(near_added[i], max_c * (1.0 + kSlack), tiles->unowned[k] != 0);
  }
  return out;
}

std::vector<uint8_t> Edit::line_tiles(const TileSummaries& tiles, double reach_floor, const EditPlan* plan) const {
  const State& st = *st_;
  const GridSpec& g = st.grid;
  st.check_tiles(&tiles);
  constexpr int64_t T = TileSummaries::kTile, B = kLineBand;
  constexpr uint8_t kWhole = 0xFF;
  static_assert(T % B == 0 && T / B == 8, "a tile's bands are the bits of its flag");
  std::vector<uint8_t> near(static_cast<size_t>(tiles.cols * tiles.rows), kWhole);
  if (st.base_seeds.adjusted() || st.edited.adjusted() || st.match.owners_reordered || st.options.geolocator ||
      st.added.all || st.removed.all)
    return near;
  // One cell's diagonal in metric units, at most: the extraction measures within a few of them of
  // a row's cells (a degree of latitude is at most 111.7 km, one of longitude less).
  const double diag =
      std::sqrt(2.0) * g.res * (st.options.metric.kind == MetricSpec::geodesic ? 111700.0 : 1.0) * (1.0 + kSlack);
  // The bands where the field may change: those the plan's mask meets (a tile it read may keep
  // every cell), or every band of a tile the plan would read.
  std::vector<uint8_t> changed(near.size(), 0);
  if (plan != nullptr && plan->window.col0 == 0 && plan->window.row0 == 0 && plan->window.width == g.width &&
      plan->window.height == g.height) {
    for (int64_t r = 0; r < g.height; ++r)
      for (const auto& [c0, c1] : plan->mask.rows[static_cast<size_t>(r)])
        for (int64_t tc = c0 / T; tc <= (c1 - 1) / T; ++tc)
          changed[static_cast<size_t>(r / T * tiles.cols + tc)] |= static_cast<uint8_t>(1u << (r % T / B));
  } else {
    const std::vector<uint8_t> read = tiles_to_read(tiles);
    for (size_t k = 0; k < read.size(); ++k) changed[k] = read[k] ? kWhole : 0;
  }
  // Per tile and band, the distance within which a removed or an added site may be measured
  // there: from its largest distance, the floor, and the max distance where it has unowned cells;
  // none (every band) where it is not finite. A tile's reach is its bands' largest.
  auto reach_of = [&](float max_distance, uint8_t unowned) {
    double d = std::max(static_cast<double>(max_distance), reach_floor);
    if (unowned) d = std::max(d, st.options.max_distance);
    d = d * (1.0 + kSlack) + 4.0 * diag;
    return std::isfinite(d) ? d : -1.0;
  };
  std::vector<double> reach(near.size(), -1.0);
  for (size_t k = 0; k < near.size(); ++k) reach[k] = reach_of(tiles.max_distance[k], tiles.unowned[k]);
  const State::TileRange all{0, 0, tiles.rows, tiles.cols};
  const std::vector<double> removed = st.removed.any ? st.tile_bounds(st.removed, all, reach) : std::vector<double>{};
  const std::vector<double> added = st.added.any ? st.tile_bounds(st.added, all, reach) : std::vector<double>{};
  // A tile's flag: the bands (bit b: rows [b * B, b * B + B) of the tile) a box of changed edges
  // meets, the field may change in, or a removed or an added site may be measured in.
  for (int64_t tr = 0; tr < tiles.rows; ++tr)
    for (int64_t tc = 0; tc < tiles.cols; ++tc) {
      const auto k = static_cast<size_t>(tr * tiles.cols + tc);
      if (reach[k] < 0.0) continue;  // every band
      const int64_t c0 = tc * T, c1 = std::min(g.width, c0 + T);
      const bool removal = st.removed.any && removed[k] <= reach[k], addition = st.added.any && added[k] <= reach[k];
      const bool boxed = st.box_meets(std::max<int64_t>(0, c0 - 3), std::max<int64_t>(0, tr * T - 3),
                                      std::min(g.width, c1 + 3), std::min(g.height, tr * T + T + 3));
      uint8_t bands = changed[k];
      for (int64_t b = 0; b < T / B && (removal || addition || boxed); ++b) {
        const int64_t r0 = tr * T + b * B, r1 = std::min(g.height, r0 + B);
        if (r0 >= g.height) break;
        const size_t kb = k * TileSummaries::kBands + static_cast<size_t>(b);
        const double d = tiles.has_bands() ? reach_of(tiles.band_max_distance[kb], tiles.band_unowned[kb]) : reach[k];
        const bool in = d < 0.0 ||
                        (boxed && st.box_meets(std::max<int64_t>(0, c0 - 3), std::max<int64_t>(0, r0 - 3),
                                               std::min(g.width, c1 + 3), std::min(g.height, r1 + 3))) ||
                        (removal && st.group_bound(st.removed, c0, r0, c1, r1) <= d) ||
                        (addition && st.group_bound(st.added, c0, r0, c1, r1) <= d);
        if (in) bands |= static_cast<uint8_t>(1u << b);
      }
      near[k] = bands;
    }
  return near;
}

std::vector<std::pair<int64_t, int64_t>> Edit::line_rows(const TileSummaries& tiles,
                                                         std::span<const LinePieces> base_pieces,
                                                         double reach_floor) const {
  const std::vector<uint8_t> near = line_tiles(tiles, reach_floor);
  return line_rows(near, base_pieces);
}

std::vector<std::pair<int64_t, int64_t>> Edit::line_rows(std::span<const uint8_t> near,
                                                         std::span<const LinePieces> base_pieces) const {
  const State& st = *st_;
  const GridSpec& g = st.grid;
  constexpr int64_t T = TileSummaries::kTile;
  const int64_t pad = 2 * StripLines::kDependRows;
  const struct { int64_t cols, rows; } tiles{(g.width + T - 1) / T, (g.height + T - 1) / T};
  if (near.size() != static_cast<size_t>(tiles.cols * tiles.rows))
    throw Error(ErrorKind::invalid_argument, "edit: the line tiles do not fit the grid");
  std::vector<std::pair<int64_t, int64_t>> rows;
  constexpr int64_t B = kLineBand;
  for (int64_t tr = 0; tr < tiles.rows; ++tr)
    for (int64_t tc = 0; tc < tiles.cols; ++tc) {
      const uint8_t bands = near[static_cast<size_t>(tr * tiles.cols + tc)];
      for (int64_t b = 0; b < T / B; ++b)
        if (bands & (1u << b) && tr * T + b * B < g.height)
          rows.emplace_back(tr * T + b * B, std::min(g.height, tr * T + b * B + B));
    }
  for (const LinePieces& p : base_pieces)
    for (const int64_t r : p.rows_naming_dropped(st.remap)) rows.emplace_back(r, r + 1);
  for (auto& [a, b] : rows) {
    a = std::max<int64_t>(0, a - pad);
    b = std::min(g.height, b + pad);
  }
  std::sort(rows.begin(), rows.end());
  std::vector<std::pair<int64_t, int64_t>> merged;
  for (const auto& r : rows) {
    if (!merged.empty() && r.first <= merged.back().second)
      merged.back().second = std::max(merged.back().second, r.second);
    else
      merged.push_back(r);
  }
  return merged;
}

void Edit::State::check_tiles(const TileSummaries* tiles) const {
  constexpr int64_t T = TileSummaries::kTile;
  if (tiles && (tiles->cols != (grid.width + T - 1) / T || tiles->rows != (grid.height + T - 1) / T))
    throw Error(ErrorKind::invalid_argument, "edit: the tile summaries do not fit the grid");
}

std::vector<uint8_t> Edit::tiles_to_read(const TileSummaries& tiles) const {
  const State& st = *st_;
  st.check_tiles(&tiles);
  std::vector<uint8_t> out(static_cast<size_t>(tiles.cols * tiles.rows), 0);
  const std::vector<State::TileNeed> need = st.tile_needs(State::TileRange{0, 0, tiles.rows, tiles.cols}, &tiles);
  for (size_t k = 0; k < need.size(); ++k) out[k] = need[k].any() ? 1 : 0;
  return out;
}

EditPlan Edit::plan(const NearestField& base, const TileSummaries* tiles) const {
  const State& st = *st_;
  const GridSpec& g = st.grid;
  constexpr int64_t T = TileSummaries::kTile;
  EditPlan plan;
  plan.match = st.match;
  const Window w = base.site.window();
  plan.window = w;
  plan.mask = CellMask::none(w);
  st.check_tiles(tiles);
  // The tiles of the window (clipped to it), and which of them must be read.
  struct Part {
    int64_t c0, r0, c1, r1;  // window-relative
    State::TileNeed need;
  };
  std::vector<Part> parts;
  const State::TileRange range{w.row0 / T, w.col0 / T, (w.row0 + w.height + T - 1) / T, (w.col0 + w.width + T - 1) / T};
  const std::vector<State::TileNeed> needs = st.tile_needs(range, tiles);
  for (int64_t tr = range.tr0; tr < range.tr1; ++tr)
    for (int64_t tc = range.tc0; tc < range.tc1; ++tc) {
      const State::TileNeed& need = needs[static_cast<size_t>((tr - range.tr0) * range.cols() + (tc - range.tc0))];
      if (!need.any()) continue;
      const int64_t gc0 = tc * T, gr0 = tr * T;
      const int64_t gc1 = std::min(g.width, gc0 + T), gr1 = std::min(g.height, gr0 + T);
      plan.tiles_read.push_back(tr * ((g.width + T - 1) / T) + tc);
      parts.push_back({std::max(gc0, w.col0) - w.col0, std::max(gr0, w.row0) - w.row0,
                       std::min(gc1, w.col0 + w.width) - w.col0, std::min(gr1, w.row0 + w.height) - w.row0, need});
    }
  std::vector<State::Part> done(parts.size());
  detail::parallel_for(resolve_threads(st.options.threads), static_cast<int64_t>(parts.size()), [&](int64_t k, int) {
    const Part& p = parts[static_cast<size_t>(k)];
    done[static_cast<size_t>(k)] =
        st.plan_part(base, w, p.c0, p.r0, p.c1, p.r1, p.need.by_removal, p.need.by_addition, p.need.boxed);
  });
  // Tiles in row-major order: each row's spans come in column order.
  for (size_t k = 0; k < parts.size(); ++k) {
    const State::Part& d = done[k];
    plan.removed_cells += d.removed_cells;
    plan.blocks_measured += d.blocks;
    for (size_t r = 0; r < d.spans.size(); ++r)
      for (const auto& span : d.spans[r]) {
        plan.mask.rows[static_cast<size_t>(parts[k].r0) + r].push_back(span);
        plan.cells += span.second - span.first;
      }
  }
  return plan;
}

void Edit::apply(const NearestField& base, const EditPlan& plan, NearestField& out,
                 const std::vector<uint8_t>* valid) const {
  const State& st = *st_;
  const bool in_place = &out == &base;
  if (valid && !in_place) throw Error(ErrorKind::invalid_argument, "edit: valid tiles are for an edit in place");
  if (!in_place) {
    out.site = base.site;
    out.distance = base.distance;
    out.metric = base.metric;
    out.geolocator = base.geolocator;
  }
  auto renumber = [&](int32_t* cells, int64_t n) {
    for (int64_t c = 0; c < n; ++c)
      if (cells[c] != kNoSite) cells[c] = st.remap[static_cast<size_t>(cells[c])];
  };
  const Window w = out.site.window();
  if (in_place && st.keeps_indices) {
    // Every cell outside the mask has a kept site, which keeps its index: only the mask's cells
    // (those of removed sites among them) are renumbered.
    for (int64_t r = 0; r < w.height; ++r)
      for (const auto& [c0, c1] : plan.mask.rows[static_cast<size_t>(r)]) renumber(&out.site.at(c0, r), c1 - c0);
  } else if (valid) {
    constexpr int64_t T = TileSummaries::kTile;
    const int64_t cols = (st.grid.width + T - 1) / T;
    if (static_cast<int64_t>(valid->size()) != cols * ((st.grid.height + T - 1) / T))
      throw Error(ErrorKind::invalid_argument, "edit: the valid tiles do not fit the grid");
    for (int64_t r = 0; r < w.height; ++r) {
      const int64_t gr = w.row0 + r;
      for (int64_t gc0 = w.col0 / T * T; gc0 < w.col0 + w.width; gc0 += T) {
        if (!(*valid)[static_cast<size_t>((gr / T) * cols + gc0 / T)]) continue;
        const int64_t c0 = std::max(gc0, w.col0) - w.col0, c1 = std::min(gc0 + T, w.col0 + w.width) - w.col0;
        renumber(&out.site.at(c0, r), c1 - c0);
      }
    }
  } else {
    renumber(out.site.cells().data(), static_cast<int64_t>(out.site.cells().size()));
  }
  // Nothing to compute: the renumbered base is the edited field (an engine call would still
  // prepare the window).
  if (plan.cells == 0) {
    out.seconds = 0.0;
    out.contested_cells = 0;
    return;
  }
  ComputeOptions o = st.options;
  o.window = w;
  o.mask = std::make_shared<const CellMask>(plan.mask);
  compute_into(st.edited, st.grid, o, out);
}

EditPlan plan_edit(const NearestField& base, const SeedSet& base_seeds, const SeedSet& edited, const GridSpec& grid,
                   const ComputeOptions& options) {
  return Edit(base_seeds, edited, grid, options).plan(base);
}

NearestField apply_edit(const NearestField& base, const SeedSet& base_seeds, const SeedSet& edited,
                        const GridSpec& grid, const ComputeOptions& options, const EditPlan& plan) {
  NearestField out;
  Edit(base_seeds, edited, grid, options).apply(base, plan, out);
  return out;
}

}  // namespace rv
