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

// The kept base's name of a product's raster (EditBaseWriter::record's roles), or null.
const char* role_of(Product p) {
  switch (p) {
    case Product::site:
      return "site";
    case Product::metric_distance:
      return "distance";
    case Product::ownership:
      return "ownership";
    case Product::nearest_feature:
      return "nearest_feature";
    case Product::distance:
      return "output_distance";
    default:
      return nullptr;
  }
}

// Decoding a tile costs about a quarter of encoding it (ZSTD and DEFLATE alike decode several
// times faster than they encode): recoding a code file takes its writer its encoding time afresh
// plus a quarter, and reading the base field whole a quarter of its two rasters' encoding time
// (bench/RESULTS-edits.md, sessions 39 and 40).
constexpr double kDecodeShare = 0.25;

struct CodeChoice {
  bool afresh = false;        // the code files whose codes move are encoded afresh
  bool engine_whole = false;  // where every cell is needed, the engine computes it
  nlohmann::json why;
};

// Weighs, by the base's costs, recoding every tile of the code files whose codes move against
// producing every cell (the engine, or the base field read whole) and encoding them afresh. The
// cells are produced on the computing thread while the files' writers encode beside it, and the
// slowest writer is what the job waits for: so the engine's wall time (not its threads' sum) is
// set against the writers' extra time to decode. Unknown costs keep the recoding (and the base
// field read where every cell is needed).
CodeChoice choose_codes(const StreamJob& stream, const EditBase& base, const EditCodes& codes) {
  const EditBase::Costs& c = base.costs();
  auto decode = [&](const char* role) {
    const double e = c.encode(role);
    return e < 0.0 ? -1.0 : kDecodeShare * e;
  };
  const double read_whole =
      decode("site") < 0.0 || decode("distance") < 0.0 ? -1.0 : decode("site") + decode("distance");
  double recode = 0.0;
  bool known = true, moves = false;
  for (const StreamTarget& t : stream.targets) {
    const CodeMap* m = t.product == Product::ownership         ? &codes.owners
                       : t.product == Product::nearest_feature ? &codes.features
                                                               : nullptr;
    const char* role = role_of(t.product);
    if (m == nullptr || !m->valid || m->identity || !base.earlier(role)) continue;
    moves = true;
    known = known && decode(role) >= 0.0;
    recode += std::max(0.0, decode(role));
  }
  CodeChoice out;
  out.engine_whole = c.engine_s >= 0.0 && read_whole >= 0.0 && c.engine_s < read_whole;
  const double every_cell = out.engine_whole ? c.engine_s : read_whole;
  out.afresh = moves && known && every_cell >= 0.0 && every_cell < recode;
  if (moves)
    out.why = {{"made", out.afresh ? "afresh" : "recoded"},
               {"every_cell_by", out.engine_whole ? "engine" : "reading the base"},
               {"estimate_s",
                {{"recoding", known ? nlohmann::json(recode) : nlohmann::json()},
                 {"engine", c.engine_s >= 0.0 ? nlohmann::json(c.engine_s) : nlohmann::json()},
                 {"reading_base", read_whole >= 0.0 ? nlohmann::json(read_whole) : nlohmann::json()}}}};
  return out;
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
    add_target(stream, Product::codes, spec.outputs.changes, o, "changes");
  }
  // Each file copies from the base's file of the same product the tiles where the edit changes no
  // cell: their bytes where the codes of what the base's cells hold are the same in both runs
  // (distances always are), else decoded and coded again.
  // A code file whose codes move is recoded from the base's, or encoded afresh (choose_codes).
  st.codes = code_maps(base, *st.edit, job.loaded);
  const CodeChoice choice = choose_codes(stream, base, st.codes);
  st.tally.choice = choice.why;
  auto coded_from = [&](StreamTarget& t, const char* role, const CodeMap& m) {
    if (!(choice.afresh && !m.identity)) copy_from(t, base, role, &m);
  };
  for (StreamTarget& t : stream.targets) {
    if (t.product == Product::ownership) coded_from(t, "ownership", st.codes.owners);
    if (t.product == Product::distance) copy_from(t, base, "output_distance");
    if (t.product == Product::nearest_feature) coded_from(t, "nearest_feature", st.codes.features);
  }
  const bool codes = !spec.outputs.changes.empty();
  const int64_t across = base.tiles().cols;
  // The base strip is read into the strip's own buffers and edited in place; the base's values of
  // the cells the plan recomputes are kept aside for the tally. Where every cell is needed and the
  // engine is the cheaper way to them, the base is read only where the plan reads it, and the
  // engine computes the strip whole (equal to the edit's cells: both are the edited seeds' field).
  // (The plan's tiles: to_read before attach_edit_lines adds the lines' rows.)
  stream.source = [&st, &base, codes, across, engine_whole = choice.engine_whole, plan_tiles = st.to_read,
                   compute = stream.compute, seeds = &job.loaded.seeds,
                   grid = job.grid](const Window& w, NearestField& field, std::vector<int32_t>& changes,
                                    std::vector<uint8_t>& fresh, bool all_cells) {
    EditTally& tally = st.tally;
    const bool engine = all_cells && engine_whole;
    const std::vector<uint8_t>* only = engine ? &plan_tiles : all_cells ? nullptr : &st.to_read;
    auto compute_whole = [&] {
      timed_add(tally.engine_seconds, [&] {
        ComputeOptions o = compute;
        o.window = w;
        compute_into(*seeds, grid, o, field);
      });
      ++tally.strips_by_engine;
    };
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
      if (engine) compute_whole();
      return;
    }
    EditPlan plan;
    timed_add(tally.plan_seconds, [&] { plan = st.edit->plan(field, &base.tiles()); });
    ChangeTally::MaskedCells before;
    timed_add(tally.apply_seconds, [&] {
      before = ChangeTally::masked_cells(plan.mask, field);
      if (!engine) st.edit->apply(field, plan, field, only);
    });
    if (engine) compute_whole();
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
  for (StreamTarget& t : stream.targets)
    if (const char* role = role_of(t.product)) t.checksums = keep.record(role, t.path);
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

nlohmann::json run_costs(const StreamJob& stream, const StreamStats& stats, const EditBase* base,
                         const StreamEdit* edit) {
  const EditBase::Costs none;
  const EditBase::Costs& was = base ? base->costs() : none;
  // The engine over the whole grid: a fresh run's, or an edit's that computed every strip; else
  // the base's figure carried (an edit that recomputed some cells says nothing of the whole).
  double engine = was.engine_s;
  if (base == nullptr || (edit && edit->tally.strips > 0 && edit->tally.strips_by_engine == edit->tally.strips))
    engine = base ? edit->tally.engine_seconds : stats.compute;
  nlohmann::json encode = nlohmann::json::object();
  for (const StreamTarget& t : stream.targets) {
    const char* role = role_of(t.product);
    if (role == nullptr) continue;
    const auto copied = [&](const std::map<std::string, int64_t>& m) {
      const auto i = m.find(t.name);
      return i != m.end() && i->second >= 0;
    };
    const bool afresh = t.earlier.empty() || !(copied(stats.tiles_copied) || copied(stats.tiles_recoded));
    const auto w = stats.write.find(t.name);
    const double s = afresh && w != stats.write.end() ? w->second : was.encode(role);
    if (s >= 0.0) encode[role] = s;
  }
  // The job's distance raster when it is the kept one (EditBaseWriter::shares_distance).
  if (!encode.contains("distance") && encode.contains("output_distance"))
    encode["distance"] = encode["output_distance"];
  nlohmann::json out = {{"encode_s", encode}};
  if (engine >= 0.0) out["engine_s"] = engine;
  return out;
}

}  // namespace rv::detail
