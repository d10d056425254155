// Edits of a finished field (rv/edit.hpp): matching the features of two seed sets, the cells an
// edit can change, and the edited field from the base's.
#include "rv/edit.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "rv/deliverables.hpp"
#include "rv/error.hpp"
#include "rv/parallel.hpp"

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

bool same_feature(const FeatureKeys& x, int32_t fx, const FeatureKeys& y, int32_t fy) {
  const Feature& a = x.s.features()[static_cast<size_t>(fx)];
  const Feature& b = y.s.features()[static_cast<size_t>(fy)];
  if (x.label(fx) != y.label(fy) || a.kind != b.kind ||
      std::bit_cast<uint64_t>(a.weight) != std::bit_cast<uint64_t>(b.weight) ||
      std::bit_cast<uint64_t>(a.reach) != std::bit_cast<uint64_t>(b.reach) ||
      std::bit_cast<uint64_t>(a.effect) != std::bit_cast<uint64_t>(b.effect))
    return false;
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

// Whether the owners both sets have come in a different order of codes.
bool owners_reordered(const SeedSet& base, const SeedSet& edited) {
  auto present = [](const SeedSet& in, const SeedSet& other) {
    const std::unordered_set<std::string> there(other.owner_labels().begin(), other.owner_labels().end());
    std::vector<std::string> out;
    for (const std::string& l : in.owner_labels())
      if (there.count(l) != 0) out.push_back(l);
    return out;
  };
  return present(base, edited) != present(edited, base);
}

// The features of `edited` with `keep` set, as one owner's (their distances, weights and reaches;
// owners and order do not matter to where they can win): points and segments as themselves,
// polygons with their rings (which add their edges and interiors again: a repeated site changes
// no distance).
SeedSet added_features(const SeedSet& edited, const std::vector<bool>& keep) {
  SeedSet out;
  const int32_t owner = out.owner_code("added");
  const auto ranges = site_ranges(edited);
  const auto polys = polygons_of(edited);
  for (size_t f = 0; f < keep.size(); ++f) {
    if (!keep[f]) continue;
    const int32_t nf = out.add_feature(owner, edited.features()[f].source);
    for (const size_t p : polys[f]) out.add_polygon(nf, edited.polygons()[p].rings);
    for (int32_t i = ranges[f].first; i < ranges[f].second; ++i) {
      const Site& s = edited.sites()[static_cast<size_t>(i)];
      if (s.kind == SiteKind::point) out.add_point(nf, s.a);
      if (s.kind == SiteKind::segment) out.add_polyline(nf, std::vector<Vec2>{s.a, s.b});
    }
    const Feature& ft = edited.features()[f];
    if (ft.weight != 1.0 || std::isfinite(ft.reach)) out.set_adjustment(nf, ft.weight, ft.reach);
  }
  return out;
}

}  // namespace

int64_t FeatureMatch::kept() const {
  return std::count_if(edited_of_base.begin(), edited_of_base.end(), [](int32_t e) { return e >= 0; });
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

// The cells where added features can win: blocks of cells ruled out as a whole where the added
// features' nearest distance at the block's centre, less the block's radius, over their largest
// weight, exceeds every base cost in the block (or every reach); the rest cell by cell, by the
// added features' adjusted cost against the base's.
struct AddedFeatures {
  SeedSet seeds;
  std::unique_ptr<SiteMetric> metric;
  std::unique_ptr<OwnerIndex> plain, adjusted;
  double w_max = 0.0, r_max = 0.0;
};

// Relative slack on a base cost: the Float32 distance's rounding (2^-24), generously.
constexpr double kSlack = 1e-6;

}  // namespace

EditPlan plan_edit(const NearestField& base, const SeedSet& base_seeds, const SeedSet& edited, const GridSpec& grid,
                   const ComputeOptions& options) {
  EditPlan plan;
  plan.match = match_features(base_seeds, edited);
  const Window w = base.site.window();
  plan.mask = CellMask::none(w);
  const auto nsites = static_cast<int32_t>(base_seeds.sites().size());
  const std::vector<int32_t> remap = edited_sites(base_seeds, edited, plan.match);
  // Per cell: 1 where it must be computed again; the base cost elsewhere.
  std::vector<uint8_t> marked(static_cast<size_t>(w.cell_count()), 0);
  std::vector<double> cost(static_cast<size_t>(w.cell_count()), std::numeric_limits<double>::infinity());
  for (int64_t r = 0; r < w.height; ++r)
    for (int64_t c = 0; c < w.width; ++c) {
      const size_t i = static_cast<size_t>(r * w.width + c);
      const int32_t s = base.site.at(c, r);
      if (s == kNoSite) continue;
      if (s < 0 || s >= nsites) throw Error(ErrorKind::invalid_argument, "edit: the base field does not fit its seeds");
      const Site& site = base_seeds.sites()[static_cast<size_t>(s)];
      if (remap[static_cast<size_t>(s)] == kNoSite || (plan.match.owners_reordered && site.kind == SiteKind::area)) {
        marked[i] = 1;
        ++plan.removed_cells;
        continue;
      }
      cost[i] = static_cast<double>(base.distance.at(c, r)) * (1.0 + kSlack) /
                base_seeds.features()[static_cast<size_t>(site.feature)].weight;
    }
  // The added features alone.
  std::vector<bool> keep(edited.features().size(), false);
  bool any_added = false;
  for (size_t f = 0; f < keep.size(); ++f)
    if (plan.match.base_of_edited[f] < 0) keep[f] = any_added = true;
  if (any_added) {
    AddedFeatures added;
    added.seeds = added_features(edited, keep);
    ComputeOptions o = options;
    o.grid_polygons = nullptr;
    o.prepared = nullptr;
    o.mask = nullptr;
    if (options.geolocator && !added.seeds.polygons().empty()) {
      // Polygons on a projected geodesic grid need their grid-CRS copies, which the job holds
      // for the whole set: every cell is computed again.
      std::fill(marked.begin(), marked.end(), 1);
    } else {
      added.metric = make_site_metric(added.seeds, grid, o);
      added.plain = std::make_unique<OwnerIndex>(*added.metric, OwnerIndex::Measure::plain);
      added.adjusted = std::make_unique<OwnerIndex>(*added.metric, OwnerIndex::Measure::adjusted, options.max_distance);
      for (const Feature& f : added.seeds.features()) {
        added.w_max = std::max(added.w_max, f.weight);
        added.r_max = std::max(added.r_max, std::min(f.reach, options.max_distance));
      }
      const int64_t bw = (w.width + kBlock - 1) / kBlock, bh = (w.height + kBlock - 1) / kBlock;
      std::vector<int64_t> measured(static_cast<size_t>(bh), 0);
      detail::parallel_for(resolve_threads(options.threads), bh, [&](int64_t br, int) {
        for (int64_t bc = 0; bc < bw; ++bc) {
          const int64_t c0 = bc * kBlock, r0 = br * kBlock;
          const int64_t c1 = std::min(w.width, c0 + kBlock), r1 = std::min(w.height, r0 + kBlock);
          double block_cost = -1.0;
          for (int64_t r = r0; r < r1; ++r)
            for (int64_t c = c0; c < c1; ++c) {
              const size_t i = static_cast<size_t>(r * w.width + c);
              if (!marked[i]) block_cost = std::max(block_cost, cost[i]);
            }
          if (block_cost < 0.0) continue;  // every cell is computed again anyway
          const Vec2 a{grid.centre_x(w.col0 + c0), grid.centre_y(w.row0 + r0)};
          const Vec2 b{grid.centre_x(w.col0 + c1 - 1), grid.centre_y(w.row0 + r1 - 1)};
          const Vec2 mid{0.5 * (a.x + b.x), 0.5 * (a.y + b.y)};
          double radius = 0.0;
          for (const Vec2 q : {a, b, Vec2{a.x, b.y}, Vec2{b.x, a.y}})
            radius = std::max(radius, added.metric->point_distance(mid, q));
          // (Corners bound a small block in the plane; 1 % covers a longitude/latitude block's
          // curvature.)
          radius = radius * 1.01 + 1e-9;
          const double near = std::max(0.0, added.plain->nearest(mid).distance - radius);
          if (near > added.r_max || near / added.w_max > block_cost) continue;
          ++measured[static_cast<size_t>(br)];
          for (int64_t r = r0; r < r1; ++r)
            for (int64_t c = c0; c < c1; ++c) {
              const size_t i = static_cast<size_t>(r * w.width + c);
              if (marked[i]) continue;
              const OwnerIndex::Hit h =
                  added.adjusted->nearest(Vec2{grid.centre_x(w.col0 + c), grid.centre_y(w.row0 + r)});
              if (h.site != kNoSite && h.cost <= cost[i]) marked[i] = 1;
            }
        }
      });
      for (const int64_t m : measured) plan.blocks_measured += m;
    }
  }
  for (int64_t r = 0; r < w.height; ++r) {
    const uint8_t* row = marked.data() + r * w.width;
    for (int64_t c = 0; c < w.width;) {
      if (!row[c]) {
        ++c;
        continue;
      }
      int64_t e = c;
      while (e < w.width && row[e]) ++e;
      plan.mask.rows[static_cast<size_t>(r)].emplace_back(c, e);
      plan.cells += e - c;
      c = e;
    }
  }
  return plan;
}

NearestField apply_edit(const NearestField& base, const SeedSet& base_seeds, const SeedSet& edited,
                        const GridSpec& grid, const ComputeOptions& options, const EditPlan& plan) {
  if (options.method != Method::exact)
    throw Error(ErrorKind::invalid_argument, "edit: only the exact method recomputes a part of a field");
  const std::vector<int32_t> remap = edited_sites(base_seeds, edited, plan.match);
  NearestField out;
  out.site = base.site;
  out.distance = base.distance;
  out.metric = base.metric;
  out.geolocator = base.geolocator;
  for (int32_t& s : out.site.cells())
    if (s != kNoSite) s = remap[static_cast<size_t>(s)];
  ComputeOptions o = options;
  o.window = base.site.window();
  o.mask = std::make_shared<const CellMask>(plan.mask);
  compute_into(edited, grid, o, out);
  return out;
}

}  // namespace rv
