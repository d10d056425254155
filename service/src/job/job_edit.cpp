// An edit's and a kept base's parts of the streamed job (job_edit.hpp).
#include "job/job_edit.hpp"

#include <algorithm>
#include <map>
#include <string>
#include <utility>

#include "job/job_run.hpp"

namespace rv::detail {
namespace {

using Product = StreamTarget::Product;
constexpr int64_t kTile = TileSummaries::kTile;

StreamTarget& add_target(StreamJob& stream, Product product, const std::string& path, GeoTiffOptions options,
                         const char* name) {
  StreamTarget& t = stream.targets.emplace_back();
  t.product = product;
  t.path = path;
  t.options = std::move(options);
  t.name = name;
  return t;
}

// Copies tiles from the base's raster of `role`, if it wrote one; coded again through `codes`
// where the edit changed the codes.
void copy_from(StreamTarget& t, const EditBase& base, const char* role, const CodeMap* codes = nullptr) {
  if (codes && !codes->valid) return;
  if (const auto e = base.earlier(role)) {
    t.earlier = e->path;
    t.earlier_display = e->display;
    t.earlier_checksums = e->checksums;
    if (codes && !codes->identity) t.earlier_remap = codes->to;
  }
}

}  // namespace

void attach_edit(StreamJob& stream, StreamEdit& st, const JobSpec& spec, const PreparedJob& job, EditBase& base,
                 std::shared_ptr<const PreparedSeeds> prepared) {
  stream.compute.prepared = prepared ? std::move(prepared) : prepare(job.loaded.seeds, job.grid, stream.compute);
  st.edit.emplace(base.seeds(), job.loaded.seeds, job.grid, stream.compute);
  st.tallier.emplace(base.seeds(), job.loaded.seeds, job.grid, job.compute.geolocator.get());
  st.tally.tiles_read.assign(base.tiles().max_cost.size(), false);
  st.tally.tiles_planned.assign(base.tiles().max_cost.size(), false);
  st.to_read = st.edit->tiles_to_read(base.tiles());
  if (!spec.outputs.changes.empty()) {
    GeoTiffOptions o = raster_options(spec);
    o.max_code = 2;
    o.metadata["CONTENT"] = "1 = owner changed, 2 = only the distance changed, 0 = unchanged (edit of a finished run)";
    add_target(stream, Product::changes, spec.outputs.changes, o, "changes");
  }
  // Each file copies from the base's file of the same product the tiles where the edit changes no
  // cell: their bytes where the codes of what the base's cells hold are the same in both runs
  // (distances always are), else decoded and coded again.
  st.codes = code_maps(base, *st.edit, job.loaded);
  for (StreamTarget& t : stream.targets) {
    if (t.product == Product::ownership) copy_from(t, base, "ownership", &st.codes.owners);
    if (t.product == Product::distance) copy_from(t, base, "output_distance");
    if (t.product == Product::nearest_feature) copy_from(t, base, "nearest_feature", &st.codes.features);
  }
  const bool codes = !spec.outputs.changes.empty();
  const int64_t across = base.tiles().cols;
  // The base strip is read into the strip's own buffers and edited in place; the base's values of
  // the cells the plan recomputes are kept aside for the tally.
  stream.source = [&st, &base, codes, across](const Window& w, NearestField& field, std::vector<int32_t>& changes,
                                              std::vector<uint8_t>& fresh, bool all_cells) {
    EditTally& tally = st.tally;
    const std::vector<uint8_t>* only = all_cells ? nullptr : &st.to_read;
    timed_add(tally.read_seconds, [&] { base.read(w.row0, w.height, field, only); });
    const int64_t bands = (w.height + kTile - 1) / kTile;
    ++tally.strips;
    // The tiles whose cells were read: every tile of the strip, or those flagged.
    for (int64_t t = w.row0 / kTile * across; t < (w.row0 / kTile + bands) * across; ++t)
      if (only == nullptr || (*only)[static_cast<size_t>(t)]) tally.tiles_read[static_cast<size_t>(t)] = true;
    // A strip of tiles the edit cannot change, none of them read: nothing to plan, every tile copied.
    // (A tile read for the lines alone is planned too: its cells are renumbered to the edit's sites.)
    if (only != nullptr &&
        std::none_of(only->begin() + w.row0 / kTile * across, only->begin() + (w.row0 / kTile + bands) * across,
                     [](uint8_t t) { return t != 0; })) {
      fresh.assign(static_cast<size_t>(bands * across), 0);
      if (codes) changes.assign(static_cast<size_t>(w.cell_count()), 0);
      return;
    }
    EditPlan plan;
    timed_add(tally.plan_seconds, [&] { plan = st.edit->plan(field, &base.tiles()); });
    ChangeTally::MaskedCells before;
    timed_add(tally.apply_seconds, [&] {
      before = ChangeTally::masked_cells(plan.mask, field);
      st.edit->apply(field, plan, field, only);
    });
    // The tiles with cells of the plan are encoded again; the files copy the others.
    fresh.assign(static_cast<size_t>(bands * across), 0);
    for (int64_t r = 0; r < w.height; ++r)
      for (const auto& span : plan.mask.rows[static_cast<size_t>(r)])
        for (int64_t bx = span.first / kTile; bx * kTile < span.second; ++bx)
          fresh[static_cast<size_t>(r / kTile * across + bx)] = 1;
    tally.tiles_encoded += std::count(fresh.begin(), fresh.end(), uint8_t{1});
    tally.cells_recomputed += plan.cells;
    tally.cells_of_removed += plan.removed_cells;
    tally.blocks_measured += plan.blocks_measured;
    for (const int64_t t : plan.tiles_read) tally.tiles_planned[static_cast<size_t>(t)] = true;
    if (codes) changes.resize(static_cast<size_t>(w.cell_count()));
    timed_add(tally.tally_seconds, [&] {
      tally.changes.add(st.tallier->measure_masked(plan.mask, before, field, codes ? changes.data() : nullptr));
    });
  };
}

nlohmann::json attach_edit_lines(StreamJob& stream, StreamEdit& st, StripDeliverables& deliverables,
                                 const EditBase& base, const JobSpec& spec, const PreparedJob& job) {
  const int64_t H = job.grid.height;
  if (deliverables.needs_every_cell())
    return {
        {"rows_extracted", H}, {"rows_taken", 0}, {"why", "the quicklook, margin or relevant coasts read every cell"}};
  std::map<std::string, LinePieces> pieces;
  std::vector<LinePieces> list;
  for (const auto& [name, key] : deliverables.line_keys()) {
    LinePieces p = base.line_pieces(name, key);
    if (p.empty())
      return {{"rows_extracted", H},
              {"rows_taken", 0},
              {"why", "the base kept no " + name + " pieces of these options, seeds' weights and reaches"}};
    list.push_back(p);
    pieces[name] = std::move(p);
  }
  // Limits drawn per owner measure an owner's distance across other owners' cells, out to the
  // largest limit.
  double floor = 0.0;
  if (spec.outputs.limits_per_owner && !spec.outputs.limits.empty())
    for (const double d : job.limit_distances) floor = std::max(floor, d);
  std::vector<std::pair<int64_t, int64_t>> fed;
  if (!pieces.empty()) fed = st.edit->line_rows(base.tiles(), list, floor);
  int64_t extracted = 0;
  const int64_t across = base.tiles().cols;
  for (const auto& [a, b] : fed) {
    extracted += b - a;
    for (int64_t t = a / kTile * across; t < ((b + kTile - 1) / kTile) * across; ++t)
      st.to_read[static_cast<size_t>(t)] = 1;
  }
  deliverables.take_lines_from(std::move(pieces), std::move(fed), st.edit->site_map());
  stream.on_strip_every_cell = false;
  return {{"rows_extracted", extracted}, {"rows_taken", H - extracted}};
}

void attach_keep(StreamJob& stream, EditBaseWriter& keep, const EditBase* base, const StreamEdit* edit,
                 const PreparedJob& job) {
  // An edit's site raster keeps the base's codes: its unchanged tiles are the base's bytes.
  SiteCodeTable codes;
  if (base && edit) {
    codes = edit_site_codes(*base, *edit->edit, job.loaded.seeds.sites().size());
    keep.set_site_codes(codes.site_of_code);
  }
  StreamTarget& site = add_target(stream, Product::site, keep.site_path(), keep.site_options(), "edit_base_site");
  if (base && edit) {
    site.site_codes = std::move(codes.code_of_site);
    copy_from(site, *base, "site");
  }
  if (!keep.shares_distance()) {
    StreamTarget& d = add_target(stream, Product::metric_distance, keep.distance_path(), keep.distance_options(),
                                 "edit_base_distance");
    if (base) copy_from(d, *base, "distance");
  }
  for (StreamTarget& t : stream.targets) {
    const char* role = t.product == Product::site              ? "site"
                       : t.product == Product::metric_distance ? "distance"
                       : t.product == Product::ownership       ? "ownership"
                       : t.product == Product::nearest_feature ? "nearest_feature"
                       : t.product == Product::distance        ? "output_distance"
                                                               : nullptr;
    if (role != nullptr) t.checksums = keep.record(role, t.path);
  }
  StreamTarget& d = *std::find_if(stream.targets.begin(), stream.targets.end(), [&](const StreamTarget& t) {
    return t.product == (keep.shares_distance() ? Product::distance : Product::metric_distance);
  });
  // Per tile: summarised from the cells where they are valid, else the base's (the tile is the
  // base's, renumbered).
  EditBaseWriter* k = &keep;
  d.observe = [k, &job, base](const int32_t* site, const float* distance, int64_t row0, int64_t rows,
                              const uint8_t* fresh) {
    k->tiles.add(site, distance, row0, rows, job.grid.width, job.loaded.seeds, fresh);
    if (fresh == nullptr || base == nullptr) return;
    TileSummaries& t = k->tiles;
    const TileSummaries& b = base->tiles();
    for (int64_t by = row0 / kTile; by * kTile < row0 + rows; ++by)
      for (int64_t bx = 0; bx < t.cols; ++bx) {
        if (fresh[static_cast<size_t>((by - row0 / kTile) * t.cols + bx)]) continue;
        const auto i = static_cast<size_t>(by * t.cols + bx);
        t.max_distance[i] = b.max_distance[i];
        t.max_cost[i] = b.max_cost[i];
        t.unowned[i] = b.unowned[i];
      }
  };
}

}  // namespace rv::detail
