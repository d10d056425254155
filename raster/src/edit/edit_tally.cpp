// What an edit changed (rv/edit/edit.hpp): the base field's tile summaries that bound where an
// edit can reach, and the tally of the cells, owners and areas an edit moved.
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <vector>

#include "rv/edit/edit.hpp"
#include "rv/engine/site_metric.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/regions.hpp"

namespace rv {

TileSummaries TileSummaries::for_grid(const GridSpec& grid) {
  TileSummaries t;
  t.cols = (grid.width + kTile - 1) / kTile;
  t.rows = (grid.height + kTile - 1) / kTile;
  const auto n = static_cast<size_t>(t.cols * t.rows);
  t.max_distance.assign(n, -1.0f);
  t.max_cost.assign(n, -1.0f);
  t.unowned.assign(n, 0);
  t.band_max_distance.assign(n * kBands, -1.0f);
  t.band_unowned.assign(n * kBands, 0);
  return t;
}

void TileSummaries::add(const int32_t* site, const float* distance, int64_t row0, int64_t rows, int64_t width,
                        const SeedSet& seeds, const uint8_t* only) {
  const auto& sites = seeds.sites();
  const auto& features = seeds.features();
  // Without weights a cost is its distance: no site's feature to look up per cell.
  const bool weighted = std::any_of(features.begin(), features.end(), [](const Feature& f) { return f.weight != 1.0; });
  const bool bands = has_bands();
  for (int64_t r = 0; r < rows; ++r) {
    const size_t tile_row = static_cast<size_t>((row0 + r) / kTile * cols);
    const auto band = static_cast<size_t>((row0 + r) % kTile / (kTile / kBands));
    for (int64_t c0 = 0; c0 < width; c0 += kTile) {
      if (only && !only[static_cast<size_t>(((row0 + r) / kTile - row0 / kTile) * cols + c0 / kTile)]) continue;
      const size_t k = tile_row + static_cast<size_t>(c0 / kTile);
      float max_d = -1.0f;
      double max_c = max_cost[k];
      bool none = false;
      for (int64_t c = c0; c < std::min(width, c0 + kTile); ++c) {
        const size_t i = static_cast<size_t>(r * width + c);
        const int32_t s = site[i];
        if (s == kNoSite) {
          none = true;
          continue;
        }
        max_d = std::max(max_d, distance[i]);
        if (weighted) {
          const double w = features[static_cast<size_t>(sites[static_cast<size_t>(s)].feature)].weight;
          max_c = std::max(max_c, static_cast<double>(distance[i]) / w);
        }
      }
      if (bands) {
        band_max_distance[k * kBands + band] = std::max(band_max_distance[k * kBands + band], max_d);
        band_unowned[k * kBands + band] |= none ? 1 : 0;
      }
      max_d = std::max(max_d, max_distance[k]);
      none = none || unowned[k] != 0;
      max_distance[k] = max_d;
      if (!weighted) max_c = std::max(max_c, static_cast<double>(max_d));
      // Rounded up: the summary bounds every cost of the tile.
      const auto fc = static_cast<float>(max_c);
      max_cost[k] = static_cast<double>(fc) < max_c ? std::nextafter(fc, std::numeric_limits<float>::infinity()) : fc;
      unowned[k] = none ? 1 : 0;
    }
  }
}

void EditChanges::add(const EditChanges& o) {
  owner_cells += o.owner_cells;
  distance_only_cells += o.distance_only_cells;
  for (const auto& [pair, area] : o.moved) moved[pair] += area;
  if (!o.any()) return;
  take_cell(o.col0, o.row0);
  take_cell(o.col1 - 1, o.row1 - 1);
}

void EditChanges::take_cell(int64_t col, int64_t row) {
  if (!any()) {
    col0 = col;
    row0 = row;
    col1 = col + 1;
    row1 = row + 1;
    return;
  }
  col0 = std::min(col0, col);
  row0 = std::min(row0, row);
  col1 = std::max(col1, col + 1);
  row1 = std::max(row1, row + 1);
}

ChangeTally::ChangeTally(const SeedSet& base_seeds, const SeedSet& edited_seeds, const GridSpec& grid,
                         const Geolocator* geolocator)
    : base_seeds_(base_seeds), edited_seeds_(edited_seeds), grid_(grid), geolocator_(geolocator) {
  // Owners by label: each base code's code in the edited set (-1 for an owner the edit dropped).
  code_in_edited_ = owner_codes_in(base_seeds, edited_seeds);
}

EditChanges tally_changes(const NearestField& base, const SeedSet& base_seeds, const NearestField& edited,
                          const SeedSet& edited_seeds, const GridSpec& grid, const Geolocator* geolocator,
                          int32_t* codes, const CellMask* only) {
  return ChangeTally(base_seeds, edited_seeds, grid, geolocator).measure(base, edited, codes, only);
}

int32_t ChangeTally::count(int32_t sb, float db, int32_t se, float de, int64_t col, int64_t row,
                           const MetricSpec& metric, EditChanges& out,
                           std::unordered_map<int64_t, double>& rows) const {
  auto owner_of = [](const SeedSet& s, int32_t site) { return site == kNoSite ? 0 : s.site_owner(site); };
  auto label = [](const SeedSet& s, int32_t code) {
    return code <= 0 ? std::string() : s.owner_labels()[static_cast<size_t>(code - 1)];
  };
  const int32_t ob = owner_of(base_seeds_, sb), oe = owner_of(edited_seeds_, se);
  const bool owner_changed = (ob == 0 ? 0 : code_in_edited_[static_cast<size_t>(ob)]) != oe;
  const bool distance_changed = std::bit_cast<uint32_t>(db) != std::bit_cast<uint32_t>(de);
  if (owner_changed || distance_changed) out.take_cell(col, row);
  if (!owner_changed) {
    out.distance_only_cells += distance_changed;
    return distance_changed ? 2 : 0;
  }
  ++out.owner_cells;
  // The area of a cell: its square, measured as the regions' rings are (per row on
  // longitude/latitude grids, where it depends on the row alone).
  auto cell_area = [&] {
    const GridSpec& g = grid_;
    const double x0 = g.xmin + static_cast<double>(col) * g.res;
    const double y1 = g.ymax - static_cast<double>(row) * g.res;
    const std::array<Vec2, 4> ring{Vec2{x0, y1}, Vec2{x0 + g.res, y1}, Vec2{x0 + g.res, y1 - g.res},
                                   Vec2{x0, y1 - g.res}};
    return ring_area(ring, metric, geolocator_, g.res);
  };
  double area = 0.0;
  if (metric.kind == MetricSpec::geodesic && geolocator_ == nullptr) {
    const auto it = rows.find(row);
    area = it != rows.end() ? it->second : (rows[row] = cell_area());
  } else {
    area = cell_area();
  }
  out.moved[{label(base_seeds_, ob), label(edited_seeds_, oe)}] += area;
  return 1;
}

EditChanges ChangeTally::measure(const NearestField& base, const NearestField& edited, int32_t* codes,
                                 const CellMask* only) const {
  const Window w = base.site.window();
  if (!(edited.site.window() == w)) throw Error(ErrorKind::invalid_argument, "tally_changes: the windows differ");
  if (only != nullptr) {
    if (!only->fits(w)) throw Error(ErrorKind::invalid_argument, "tally_changes: the mask does not fit the window");
    return measure_masked(*only, masked_cells(*only, base), edited, codes);
  }
  std::unordered_map<int64_t, double> rows;
  EditChanges out;
  for (int64_t r = 0; r < w.height; ++r)
    for (int64_t c = 0; c < w.width; ++c) {
      const int32_t code = count(base.site.at(c, r), base.distance.at(c, r), edited.site.at(c, r),
                                 edited.distance.at(c, r), w.col0 + c, w.row0 + r, edited.metric, out, rows);
      if (codes) codes[r * w.width + c] = code;
    }
  return out;
}

ChangeTally::MaskedCells ChangeTally::masked_cells(const CellMask& mask, const NearestField& base) {
  MaskedCells out;
  for (int64_t r = 0; r < base.site.height(); ++r)
    for (const auto& [c0, c1] : mask.rows[static_cast<size_t>(r)])
      for (int64_t c = c0; c < c1; ++c) {
        out.site.push_back(base.site.at(c, r));
        out.distance.push_back(base.distance.at(c, r));
      }
  return out;
}

EditChanges ChangeTally::measure_masked(const CellMask& mask, const MaskedCells& base, const NearestField& edited,
                                        int32_t* codes) const {
  const Window w = edited.site.window();
  if (!mask.fits(w)) throw Error(ErrorKind::invalid_argument, "tally_changes: the mask does not fit the window");
  if (codes) std::fill(codes, codes + w.cell_count(), 0);
  std::unordered_map<int64_t, double> rows;
  EditChanges out;
  size_t k = 0;
  for (int64_t r = 0; r < w.height; ++r)
    for (const auto& [c0, c1] : mask.rows[static_cast<size_t>(r)])
      for (int64_t c = c0; c < c1; ++c, ++k) {
        const int32_t code = count(base.site[k], base.distance[k], edited.site.at(c, r), edited.distance.at(c, r),
                                   w.col0 + c, w.row0 + r, edited.metric, out, rows);
        if (codes) codes[r * w.width + c] = code;
      }
  return out;
}

}  // namespace rv
