// Live what-if sessions (rv/session.hpp): the field kept in memory and edited in place
// (rv::Edit), the lines extracted again only near the change (rv::Edit::line_rows), the
// deliverables made by the job's own stage (StripDeliverables) into memory files, so that they
// are a fresh job's by construction.
#include "rv/session.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <exception>
#include <map>
#include <optional>
#include <unordered_map>
#include <unordered_set>

#include "job/job_run.hpp"
#include "rv/edit/edit.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "rv/gdal/memory_files.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/lines/partial_effect.hpp"
#include "rv/lines/regions.hpp"
#include "session/session_features.hpp"
#include "session/session_lines.hpp"

namespace rv {
namespace {

using json = nlohmann::json;
using detail::Clock;
using detail::seconds_since;

std::atomic<int64_t> g_sessions{0};  // names each session's memory directory

// One step of the session: the slots it changed.
struct Step {
  std::vector<detail::SlotChange> changes;
  int64_t memory_bytes() const {
    int64_t b = static_cast<int64_t>(sizeof(Step) + changes.capacity() * sizeof(detail::SlotChange));
    // The replaced features are held by the step alone (the session holds the current ones).
    for (const detail::SlotChange& c : changes)
      if (c.before)
        for (const FeaturePart& p : c.before->parts) {
          b += static_cast<int64_t>(sizeof(FeaturePart) + p.vertices.capacity() * sizeof(Vec2));
          for (const Ring& r : p.rings) b += static_cast<int64_t>(r.capacity() * sizeof(Vec2));
        }
    return b;
  }
};

// Each cell's area as the edit's tally measures it (its square, rv/lines/regions.hpp's ring_area),
// summed per owner code over the whole field.
std::vector<double> owner_cell_areas(const NearestField& field, const SeedSet& seeds, const GridSpec& g) {
  std::vector<double> area(static_cast<size_t>(seeds.owner_count()) + 1, 0.0);
  const bool per_row = field.metric.kind == MetricSpec::geodesic;
  for (int64_t r = 0; r < g.height; ++r) {
    const double y1 = g.ymax - static_cast<double>(r) * g.res;
    double row_area = 0.0;
    if (per_row) {
      const std::array<Vec2, 4> ring{Vec2{g.xmin, y1}, Vec2{g.xmin + g.res, y1}, Vec2{g.xmin + g.res, y1 - g.res},
                                     Vec2{g.xmin, y1 - g.res}};
      row_area = ring_area(ring, field.metric, nullptr, g.res);
    }
    const int32_t* s = field.site.row(r);
    for (int64_t c = 0; c < g.width; ++c) {
      if (s[c] == kNoSite) continue;
      double a = row_area;
      if (!per_row) {
        const double x0 = g.xmin + static_cast<double>(c) * g.res;
        const std::array<Vec2, 4> ring{Vec2{x0, y1}, Vec2{x0 + g.res, y1}, Vec2{x0 + g.res, y1 - g.res},
                                       Vec2{x0, y1 - g.res}};
        a = ring_area(ring, field.metric, nullptr, g.res);
      }
      area[static_cast<size_t>(seeds.site_owner(s[c]))] += a;
    }
  }
  return area;
}

// What shapes a session's lines and regions (frozen with it): copied onto other outputs.
void copy_line_options(const OutputRequest& from, OutputRequest& to) {
  to.limit_distances = from.limit_distances;
  to.limits_per_owner = from.limits_per_owner;
  to.simplify_cells = from.simplify_cells;
  to.line_tolerance = from.line_tolerance;
  to.relevant_area = from.relevant_area;
  to.relevant_coasts = from.relevant_coasts;
}

}  // namespace

// A step's deliverables between its lines and its files: the lines taken (what the answer
// says), the files and the regions made when first read (Session::State::files).
struct PendingFiles {
  JobHooks hooks;  // none: JobRun keeps a reference
  std::unique_ptr<detail::JobRun> run;
  std::unique_ptr<detail::StripDeliverables> d;

  // `partial`: a partial effect's fields and lines (kept alive by the session while these are).
  static std::unique_ptr<PendingFiles> make(const JobSpec& spec, const JobLimits& limits, const PreparedJob& job,
                                            const PartialEffectResult* partial) {
    auto p = std::make_unique<PendingFiles>();
    p->run = std::make_unique<detail::JobRun>(spec, limits, p->hooks);
    p->d = std::make_unique<detail::StripDeliverables>(*p->run, job, false, partial);
    return p;
  }
};

struct Session::State {
  JobSpec spec;  // outputs: the kept deliverables' memory files
  JobLimits job_limits;
  SessionLimits limits;
  PreparedJob job;
  std::string dir;  // /vsimem/ directory of the deliverables while they are written
  std::optional<detail::SessionFeatures> features;
  std::vector<size_t> slot_of;  // per feature of job.loaded.seeds, its slot
  NearestField field;
  // With partial effect (job.partial): the fields at full and nil effect and the rule's lines,
  // made whole again by every step (update_whole); `field` is the rule's.
  std::unique_ptr<PartialEffectResult> partial;
  bool whole_steps = false;  // made with partial effect: every step computes the whole job again
  TileSummaries tiles;
  std::map<std::string, LinePieces> pieces;
  mutable int64_t piece_bytes = -1;  // their bytes in memory, counted when memory is asked (-1: not yet)
  // The lines' refinement, segment by segment, of the current state (the regions' edges only
  // once its files are made).
  mutable std::map<std::string, RefinedSegments> refined;
  // The current state's files: made by the step (`pending`, lines taken) and written when first
  // read, or `stale` (a step failed after its state's files were dropped: made again whole).
  mutable std::unique_ptr<PendingFiles> pending;
  mutable bool stale = false;
  mutable std::map<std::string, std::string> texts;  // deliverable name -> its file's text, once made
  mutable int64_t text_bytes = 0;                    // the texts' size when last made
  mutable double files_seconds = 0.0;                // the last making of the files
  std::map<std::string, std::string> paths;          // deliverable name -> memory file
  detail::SessionLines lines;
  mutable json report = json::object();     // the deliverables' report entries, as the job's, once made
  std::map<std::string, double> cell_area;  // per owner label: its cells' area
  std::deque<Step> undo, redo;
  int64_t steps = 0;

  // The lines of the current field and seeds; `edit` (with the summaries before it): only the
  // rows near its changes extracted again. The files wait in `pending`. Returns what the answer
  // says of the lines.
  json deliver(const Edit* edit, const EditPlan* plan, const TileSummaries* before, json& recompute);
  // The current state's files and report, made now if they are not.
  void files() const;
  // Whether the answer of a step carries what only the files give (turning points, the relevant
  // area's ratios): then they are made with the step.
  bool files_answer() const { return paths.count("turning_points") != 0 || !spec.outputs.relevant_area.empty(); }
  // Moves the field and seeds to `edited` (its features' slots `slot_of`, input positions
  // `position`; the slots the step changed `touched`) and answers what changed; on failure the
  // session is as it was.
  json update(SeedSet edited, std::vector<size_t> slot_of, std::vector<int64_t> position,
              const std::unordered_set<size_t>& touched);
  // The same for a session with partial effect: the field and the lines made whole again.
  json update_whole(SeedSet edited, std::vector<size_t> slot_of, std::vector<int64_t> position);
  json apply_seeds(SeedSet edited, std::vector<size_t> slot_of, std::vector<int64_t> position,
                   const std::unordered_set<size_t>& touched) {
    return whole_steps ? update_whole(std::move(edited), std::move(slot_of), std::move(position))
                       : update(std::move(edited), std::move(slot_of), std::move(position), touched);
  }
  // The end of a step whose lines are made: the files when its answer needs them, the features'
  // slots, the cells' areas updated by the change, and the answer with its lines and timings.
  json finish_step(const EditChanges& changes, const json& lines_changed, json recompute, json timings,
                   Clock::time_point started, std::vector<size_t> new_slot_of);
  // After a failed step whose lines went ahead of the state restored: that state's files are
  // made again whole when read, and the next step extracts every row.
  void drop_files() {
    pending.reset();
    texts.clear();
    report = json::object();
    stale = true;
    pieces.clear();
    refined.clear();
  }
  // The field (and with partial effect its fields and lines) of the current seeds, computed whole.
  void compute_whole(const JobHooks* hooks);
  // The current field into `d` (with partial effect, the full-effect field for the limits).
  void add_field(detail::StripDeliverables& d) const { d.add(field, partial ? &partial->full : nullptr); }
  json areas_json() const;
  json step(const std::vector<detail::SlotChange>& changes, bool undoing);
  int64_t memory_bytes() const;
};

json Session::State::deliver(const Edit* edit, const EditPlan* plan, const TileSummaries* before, json& recompute) {
  if (paths.empty()) {  // the field alone
    recompute["rows_extracted"] = 0;
    recompute["rows_taken"] = 0;
    return lines.update(BoundaryResult{}, LimitResult{}, job.loaded.seeds.owner_labels(), job.to_output);
  }
  const auto started = Clock::now();
  std::unique_ptr<PendingFiles> p = PendingFiles::make(spec, job_limits, job, partial.get());
  detail::StripDeliverables& d = *p->d;
  json& stages = recompute["lines_stages_s"];
  auto lap = [&stages, t = started](const char* name) mutable {
    stages[name] = seconds_since(t);
    t = Clock::now();
  };
  lap("setup");
  int64_t extracted = job.grid.height;
  std::string why;
  ChangedTiles changed;  // where the edit may have changed the lines' measurements
  if (edit != nullptr && !pieces.empty()) {
    std::map<std::string, LinePieces> base;
    std::vector<LinePieces> list;
    for (const auto& [name, key] : d.line_keys()) {
      const auto it = pieces.find(name);
      if (it == pieces.end() || it->second.key() != key) {
        why = "no pieces of " + name;
        break;
      }
      base[name] = it->second;
      list.push_back(it->second);
    }
    if (why.empty() && d.needs_every_cell()) why = "a deliverable reads every cell";
    if (why.empty()) {
      double floor = 0.0;
      if (spec.outputs.limits_per_owner && !spec.outputs.limits.empty())
        for (const double v : job.limit_distances) floor = std::max(floor, v);
      std::vector<uint8_t> near = edit->line_tiles(*before, floor, plan);
      std::vector<std::pair<int64_t, int64_t>> fed = edit->line_rows(near, list);
      extracted = 0;
      for (const auto& [a, b] : fed) extracted += b - a;
      changed = ChangedTiles{TileSummaries::kTile, std::move(near)};
      d.take_lines_from(std::move(base), std::move(fed), edit->site_map(), changed);
    }
  }
  lap("rows");
  d.keep_refined(refined, std::move(changed));
  add_field(d);
  lap("extract");
  d.keep_line_pieces();
  d.finish_lines();
  std::map<std::string, LinePieces> now_pieces = d.kept_line_pieces();
  lap("chain");
  // Kept once the lines are made (a step that fails keeps the state before).
  pieces = std::move(now_pieces);
  piece_bytes = -1;
  refined = d.refined_segments();
  pending = std::move(p);
  stale = false;
  texts.clear();
  report = json::object();
  recompute["lines_s"] = seconds_since(started);
  recompute["rows_extracted"] = extracted;
  recompute["rows_taken"] = job.grid.height - extracted;
  recompute["vertices_taken"] = d.vertices_taken();
  int64_t segments = 0, taken = 0;
  for (const auto& [name, r] : refined) {
    segments += r.segments();
    taken += r.segments_taken();
  }
  recompute["segments_refined"] = segments - taken;
  recompute["segments_taken"] = taken;
  if (!why.empty()) recompute["why_every_row"] = why;
  json out = lines.update(d.boundaries(), d.limits(), job.loaded.seeds.owner_labels(), job.to_output);
  lap("ids");
  return out;
}

void Session::State::files() const {
  if (paths.empty() || (!pending && !stale)) return;
  const auto started = Clock::now();
  if (!pending) {  // the files of a state whose step's files were dropped: made whole again
    std::unique_ptr<PendingFiles> p = PendingFiles::make(spec, job_limits, job, partial.get());
    p->d->keep_refined({}, {});
    add_field(*p->d);
    pending = std::move(p);
  }
  try {
    pending->d->finish();
    std::map<std::string, std::string> now;
    for (const auto& [name, path] : paths) now[name] = read_memory_file(path);
    remove_memory_files(dir);
    texts = std::move(now);
  } catch (...) {
    // A stage failed part way: the files are made again whole when next read.
    remove_memory_files(dir);
    pending.reset();
    stale = true;
    throw;
  }
  report = pending->run->report["deliverables"];
  // The regions' edges refined for this state: the next step takes from them too.
  for (auto& [name, r] : pending->d->refined_segments())
    if (!refined.contains(name)) refined[name] = std::move(r);
  pending.reset();
  stale = false;
  text_bytes = 0;
  for (const auto& [name, t] : texts) text_bytes += static_cast<int64_t>(t.size());
  files_seconds = seconds_since(started);
}

json Session::State::areas_json() const {
  json out = json::array();
  const std::vector<std::string>& labels = job.loaded.seeds.owner_labels();
  const double to_area = job.to_output * job.to_output;  // metric units squared -> area_units
  std::map<std::string, json> regions;
  if (report.contains("regions"))
    for (const json& a : report["regions"]["areas"]) regions[a["label"].get<std::string>()] = a;
  for (const std::string& l : labels) {
    json a = {{"label", l}, {"cells_area", (cell_area.count(l) ? cell_area.at(l) : 0.0) * to_area}};
    if (const auto it = regions.find(l); it != regions.end()) {
      a["area"] = it->second["area"];
      a["sea_area"] = it->second["sea_area"];
      a["land_area"] = it->second["land_area"];
    }
    out.push_back(std::move(a));
  }
  return out;
}

namespace {

// The features of two states of a session paired by slot: a slot the step did not touch holds the
// same feature in both (features keep their slots' order), a touched one is removed and added.
FeatureMatch match_by_slot(const std::vector<size_t>& before, const std::vector<size_t>& after,
                           const std::unordered_set<size_t>& touched) {
  FeatureMatch m;
  m.edited_of_base.assign(before.size(), -1);
  m.base_of_edited.assign(after.size(), -1);
  size_t slots = 0;
  for (const size_t s : before) slots = std::max(slots, s + 1);
  std::vector<int32_t> was(slots, -1);  // per slot, its feature before
  for (size_t f = 0; f < before.size(); ++f)
    if (!touched.contains(before[f])) was[before[f]] = static_cast<int32_t>(f);
  for (size_t f = 0; f < after.size(); ++f) {
    const int32_t b = after[f] < slots ? was[after[f]] : -1;
    if (b < 0) continue;
    m.base_of_edited[f] = b;
    m.edited_of_base[static_cast<size_t>(b)] = static_cast<int32_t>(f);
  }
  return m;
}

}  // namespace

void Session::State::compute_whole(const JobHooks* hooks) {
  ComputeOptions co = job.compute;
  if (hooks != nullptr) {
    co.progress = [hooks](double f) {
      if (hooks->progress) hooks->progress("compute", f);
    };
    co.cancel = hooks->cancel;
  }
  if (whole_steps) {
    // An edit may leave no partial feature (then the plain field), or one the rule refuses
    // (invalid_input: the step is refused).
    job.partial = partial_effect_of(job.loaded.seeds);
    if (job.partial.any()) {
      BoundaryOptions lines;
      lines.simplify_cells = spec.outputs.simplify_cells;
      lines.line_tolerance = job.line_tolerance;
      lines.threads = spec.threads;
      const OutputRequest& out = spec.outputs;
      const bool draw =
          !out.boundaries.empty() || !out.tripoints.empty() || out.regions_wanted() || !out.preview.empty();
      // The nil-effect seeds are computed with these options too: no preparation of these seeds.
      job.compute.prepared = nullptr;
      co.prepared = nullptr;
      // Made in place (a prvalue, never moved): its metrics refer to its own nil-effect seeds.
      std::unique_ptr<PartialEffectResult> r(
          new PartialEffectResult(compute_partial_effect(job.loaded.seeds, job.grid, co, lines, draw)));
      field = std::move(r->field);
      partial = std::move(r);
      return;
    }
    partial.reset();
  }
  job.compute.prepared = prepare(job.loaded.seeds, job.grid, job.compute);
  co.prepared = job.compute.prepared;
  field = compute(job.loaded.seeds, job.grid, co);
}

json Session::State::finish_step(const EditChanges& changes, const json& lines_changed, json recompute, json timings,
                                 Clock::time_point started, std::vector<size_t> new_slot_of) {
  if (files_answer()) {
    const auto t = Clock::now();
    files();
    timings["files"] = seconds_since(t);
  }
  slot_of = std::move(new_slot_of);
  for (const auto& [pair, area] : changes.moved) {
    if (!pair.first.empty()) cell_area[pair.first] -= area;
    if (!pair.second.empty()) cell_area[pair.second] += area;
  }
  json moved = json::array();
  for (const auto& [pair, area] : changes.moved)
    moved.push_back({{"from", pair.first.empty() ? json() : json(pair.first)},
                     {"to", pair.second.empty() ? json() : json(pair.second)},
                     {"area", area * job.to_output * job.to_output}});
  json answer = {
      {"cells",
       {{"owner_changed", changes.owner_cells},
        {"distance_only", changes.distance_only_cells},
        {"box", changes.any() ? json::array({changes.col0, changes.row0, changes.col1, changes.row1}) : json()}}},
      {"moved", moved},
      {"areas", areas_json()},
      {"area_units", report.contains("regions") ? report["regions"]["area_units"] : json(job.unit + "^2")},
      {"lines", {{"boundaries", lines_changed["boundaries"]}, {"limits", lines_changed["limits"]}}},
      {"tripoints", lines_changed["tripoints"]},
      {"recompute", std::move(recompute)}};
  if (texts.count("turning_points")) answer["turning_points"] = json::parse(texts["turning_points"]);
  if (report.contains("regions") && report["regions"].contains("relevant_area"))
    answer["relevant_area"] = report["regions"]["relevant_area"];
  timings["total"] = seconds_since(started);
  answer["timings"] = std::move(timings);
  return answer;
}

json Session::State::update_whole(SeedSet edited, std::vector<size_t> new_slot_of, std::vector<int64_t> position) {
  const auto started = Clock::now();
  json timings = json::object();
  SeedSet old_seeds = std::move(job.loaded.seeds);
  std::vector<int64_t> old_position = std::move(job.loaded.input_position);
  const PartialEffect old_effect = job.partial;
  std::shared_ptr<const PreparedSeeds> old_prepared = job.compute.prepared;
  std::unique_ptr<PartialEffectResult> old_partial = std::move(partial);
  NearestField before = std::move(field);
  const TileSummaries old_tiles = tiles;
  const detail::SessionLines old_lines = lines;
  job.loaded.seeds = std::move(edited);
  job.loaded.input_position = std::move(position);
  bool delivered = false;
  try {
    compute_whole(nullptr);
    timings["field"] = seconds_since(started);
    auto t = Clock::now();
    const EditChanges changes =
        ChangeTally(old_seeds, job.loaded.seeds, job.grid, nullptr).measure(before, field, nullptr);
    tiles = TileSummaries::for_grid(job.grid);
    tiles.add(field.site.data(), field.distance.data(), 0, job.grid.height, job.grid.width, job.loaded.seeds);
    timings["tally"] = seconds_since(t);
    t = Clock::now();
    json recompute = {{"cells", job.grid.cell_count()},
                      {"whole",
                       "partial effect: its field follows every feature's effect, so each step computes "
                       "the whole job again"}};
    const json lines_changed = deliver(nullptr, nullptr, nullptr, recompute);
    delivered = true;
    timings["lines"] = seconds_since(t);
    return finish_step(changes, lines_changed, std::move(recompute), std::move(timings), started,
                       std::move(new_slot_of));
  } catch (...) {
    job.loaded.seeds = std::move(old_seeds);
    job.loaded.input_position = std::move(old_position);
    job.partial = old_effect;
    job.compute.prepared = old_prepared;
    partial = std::move(old_partial);
    field = std::move(before);
    tiles = old_tiles;
    lines = old_lines;
    if (delivered) drop_files();
    throw;
  }
}

json Session::State::update(SeedSet edited, std::vector<size_t> new_slot_of, std::vector<int64_t> position,
                            const std::unordered_set<size_t>& touched) {
  const auto started = Clock::now();
  json timings = json::object();
  // The seeds move into the job before the edit is prepared and made: rv::Edit keeps both sets
  // by reference, and a preparation names the set it was made for.
  SeedSet old_seeds = std::move(job.loaded.seeds);
  std::vector<int64_t> old_position = std::move(job.loaded.input_position);
  std::shared_ptr<const PreparedSeeds> old_prepared = job.compute.prepared;
  job.loaded.seeds = std::move(edited);
  job.loaded.input_position = std::move(position);
  job.compute.prepared = nullptr;
  const TileSummaries old_tiles = tiles;
  const detail::SessionLines old_lines = lines;
  bool applied = false, delivered = false;
  // Back to the seeds before: the field by the inverse edit (exact by the same construction).
  auto restore = [&] {
    // The seeds before go back first: their preparation names the job's set, which the inverse
    // edit computes into. Its plan reads every cell: the summaries may be the edited field's or
    // not yet, depending on where the step failed.
    SeedSet edited_now = std::move(job.loaded.seeds);
    job.loaded.seeds = std::move(old_seeds);
    job.loaded.input_position = std::move(old_position);
    job.compute.prepared = old_prepared;
    if (applied) {
      const Edit undo_edit(edited_now, job.loaded.seeds, job.grid, job.compute);
      const EditPlan p = undo_edit.plan(field, nullptr);
      undo_edit.apply(field, p, field);
    }
    tiles = old_tiles;
    lines = old_lines;
    if (delivered) drop_files();
  };
  try {
    job.compute.prepared = prepare(job.loaded.seeds, job.grid, job.compute);
    timings["prepare"] = seconds_since(started);
    auto t = Clock::now();
    const Edit edit(old_seeds, job.loaded.seeds, job.grid, job.compute, match_by_slot(slot_of, new_slot_of, touched));
    const EditPlan plan = edit.plan(field, &tiles);
    const ChangeTally tallier(old_seeds, job.loaded.seeds, job.grid, nullptr);
    const ChangeTally::MaskedCells before = ChangeTally::masked_cells(plan.mask, field);
    timings["plan"] = seconds_since(t);
    t = Clock::now();
    applied = true;
    edit.apply(field, plan, field);
    timings["field"] = seconds_since(t);
    t = Clock::now();
    const EditChanges changes = tallier.measure_masked(plan.mask, before, field, nullptr);
    // The summaries of the tiles the edit recomputed.
    std::vector<uint8_t> fresh(tiles.max_cost.size(), 0);
    for (int64_t r = 0; r < job.grid.height; ++r)
      for (const auto& [c0, c1] : plan.mask.rows[static_cast<size_t>(r)])
        for (int64_t c = c0; c < c1; c += TileSummaries::kTile - c % TileSummaries::kTile)
          fresh[tiles.tile_of(c, r)] = 1;
    tiles.add(field.site.data(), field.distance.data(), 0, job.grid.height, job.grid.width, job.loaded.seeds,
              fresh.data());
    timings["tally"] = seconds_since(t);
    t = Clock::now();
    json recompute = {{"cells", plan.cells}, {"cells_of_removed", plan.removed_cells}};
    json lines_changed = deliver(&edit, &plan, &old_tiles, recompute);
    delivered = true;
    timings["lines"] = seconds_since(t);
    return finish_step(changes, lines_changed, std::move(recompute), std::move(timings), started,
                       std::move(new_slot_of));
  } catch (...) {
    restore();
    throw;
  }
}

json Session::State::step(const std::vector<detail::SlotChange>& changes, bool undoing) {
  const auto started = Clock::now();
  features->apply(changes, undoing);
  try {
    std::vector<size_t> new_slot_of;
    std::vector<int64_t> position;
    std::optional<SeedSet> quick = features->rebuild(job.loaded.seeds, slot_of, changes, undoing);
    SeedSet edited;
    if (quick) {  // the same features in the same order: their slots and positions stay
      edited = std::move(*quick);
      new_slot_of = slot_of;
      position = job.loaded.input_position;
    } else {
      edited = features->build(new_slot_of, position);
    }
    const double built = seconds_since(started);
    // Undo and redo come back to states that passed; their slivers are found again all the same.
    std::unordered_set<size_t> touched;
    for (const detail::SlotChange& c : changes) touched.insert(c.slot);
    std::vector<int32_t> edited_features;
    for (size_t f = 0; f < new_slot_of.size(); ++f)
      if (touched.contains(new_slot_of[f])) edited_features.push_back(static_cast<int32_t>(f));
    const std::vector<BorderSliver> slivers = check_edited_features(
        edited, edited_features,
        [&](int32_t f) -> const std::vector<FeaturePart>& {
          return features->at(new_slot_of[static_cast<size_t>(f)])->parts;
        },
        job.loaded.seed_crs.wkt, spec.seeds.on_conflict, spec.seeds.border_tolerance);
    const double checked = seconds_since(started) - built;
    const std::vector<size_t> old_slot_of = slot_of;
    const std::vector<BorderSliver> old_slivers = job.loaded.report.slivers;
    const detail::SessionLines old_lines = lines;
    json answer = apply_seeds(std::move(edited), std::move(new_slot_of), std::move(position), touched);
    // The seeds' report (what a saved job states) names the land-border slivers by feature:
    // those of untouched features renumbered, the edited features' as the check found them.
    std::vector<int32_t> index_of_slot;
    if (!old_slivers.empty()) {
      index_of_slot.assign(features->slots(), -1);
      for (size_t f = 0; f < slot_of.size(); ++f) index_of_slot[slot_of[f]] = static_cast<int32_t>(f);
    }
    std::vector<BorderSliver> now;
    for (BorderSliver b : old_slivers) {
      const size_t sa = old_slot_of[static_cast<size_t>(b.feature_a)],
                   sb = old_slot_of[static_cast<size_t>(b.feature_b)];
      if (touched.contains(sa) || touched.contains(sb) || index_of_slot[sa] < 0 || index_of_slot[sb] < 0) continue;
      b.feature_a = index_of_slot[sa];
      b.feature_b = index_of_slot[sb];
      if (b.feature_a > b.feature_b) std::swap(b.feature_a, b.feature_b);
      now.push_back(b);
    }
    now.insert(now.end(), slivers.begin(), slivers.end());
    job.loaded.report.slivers = std::move(now);
    job.loaded.report.sliver_count = static_cast<int64_t>(job.loaded.report.slivers.size());
    answer["timings"]["seeds"] = built;
    answer["timings"]["checks"] = checked;
    if (limits.max_memory_bytes > 0 && memory_bytes() > limits.max_memory_bytes) {
      // Over the limit: back to the state before, by the same path.
      features->apply(changes, !undoing);
      std::vector<size_t> s;
      std::vector<int64_t> p;
      SeedSet back = features->build(s, p);
      apply_seeds(std::move(back), std::move(s), std::move(p), touched);
      lines = old_lines;
      job.loaded.report.slivers = old_slivers;
      job.loaded.report.sliver_count = static_cast<int64_t>(old_slivers.size());
      throw Error(ErrorKind::too_large, "the edit would take the session past its memory limit (" +
                                            std::to_string(limits.max_memory_bytes) + " bytes)");
    }
    // The features the step changed, as GET .../features gives them (a client redraws those).
    json added = json::array(), changed_features = json::array(), removed = json::array();
    for (const detail::SlotChange& c : changes) {
      const detail::FeaturePtr& was = undoing ? c.after : c.before;
      const detail::FeaturePtr& now = features->at(c.slot);
      if (!now && !was) continue;  // added and removed in the one step
      if (!now)
        removed.push_back(was->id);
      else
        (was ? changed_features : added).push_back(features->feature_json(*now));
    }
    answer["features"] = {{"added", added}, {"changed", changed_features}, {"removed", removed}};
    answer["timings"]["total"] = seconds_since(started);
    return answer;
  } catch (const Error& e) {
    if (e.kind() != ErrorKind::too_large) features->apply(changes, !undoing);
    throw;
  } catch (...) {
    features->apply(changes, !undoing);
    throw;
  }
}

int64_t Session::State::memory_bytes() const {
  int64_t b =
      static_cast<int64_t>(field.site.cells().size() * sizeof(int32_t) + field.distance.cells().size() * sizeof(float));
  if (partial) {
    const NearestField& full = partial->full;
    b +=
        static_cast<int64_t>(full.site.cells().size() * sizeof(int32_t) + full.distance.cells().size() * sizeof(float));
    b += (partial->nil_seeds ? partial->nil_seeds->memory_bytes() : 0);
  }
  b += static_cast<int64_t>(tiles.max_distance.size() * (2 * sizeof(float) + 1) +
                            tiles.band_max_distance.size() * (sizeof(float) + 1));
  b += job.loaded.seeds.memory_bytes() + static_cast<int64_t>(job.loaded.input_position.capacity() * sizeof(int64_t));
  b += features->memory_bytes() + lines.memory_bytes();
  b += static_cast<int64_t>(slot_of.capacity() * sizeof(size_t));
  if (piece_bytes < 0) {
    piece_bytes = 0;
    for (const auto& [name, p] : pieces) piece_bytes += p.memory_bytes();
  }
  b += piece_bytes;
  for (const auto& [name, r] : refined) b += r.memory_bytes();
  // The files once made; while they wait, their size when last made (about what they will take)
  // and the lines taken for them.
  for (const auto& [name, t] : texts) b += static_cast<int64_t>(t.size());
  if (pending) {
    b += text_bytes;
    const detail::StripDeliverables& d = *pending->d;
    for (const BoundaryLine& l : d.boundaries().lines)
      b += static_cast<int64_t>(sizeof(BoundaryLine) + l.vertices.capacity() * sizeof(l.vertices[0]));
    for (const LimitLine& l : d.limits().lines)
      b += static_cast<int64_t>(sizeof(LimitLine) + l.vertices.capacity() * sizeof(l.vertices[0]));
  }
  for (const Step& s : undo) b += s.memory_bytes();
  for (const Step& s : redo) b += s.memory_bytes();
  return b;
}

Session::Session() : st_(std::make_unique<State>()) {}
Session::~Session() {
  if (st_ && !st_->dir.empty()) remove_memory_files(st_->dir);
}

std::unique_ptr<Session> Session::create(const JobSpec& spec, const SessionLimits& limits, const JobLimits& job_limits,
                                         const JobHooks& hooks) {
  if (spec.method != Method::exact)
    throw Error(ErrorKind::invalid_argument, "a session takes the exact method only (the scans are not edited)");
  if (spec.validate) throw Error(ErrorKind::invalid_argument, "a session does not validate; run a job for that");
  if (!spec.base_report.empty() || spec.window)
    throw Error(ErrorKind::invalid_argument, "a session starts from seeds, not from a base or a window");
  if (!spec.barriers.empty())
    throw Error(ErrorKind::unsupported,
                "barriers: a session does not compute by sea yet (its edits recompute straight distances); run a "
                "job for that");
  if (limits.undo_depth < 0) throw Error(ErrorKind::invalid_argument, "the undo depth must be >= 0");
  const OutputRequest& o = spec.outputs;
  std::unique_ptr<Session> s(new Session());
  State& st = *s->st_;
  st.dir = "/vsimem/rvoronoi-session/" + std::to_string(++g_sessions);
  st.limits = limits;
  st.job_limits = job_limits;
  st.spec = spec;
  OutputRequest& out = st.spec.outputs;
  out = OutputRequest{};
  copy_line_options(o, out);
  out.keep_for_edits = false;
  auto keep = [&](const std::string& given, std::string& into, const char* name, const char* ext) {
    if (given.empty()) return;
    into = st.dir + "/" + name + ext;
    st.paths[name] = into;
  };
  keep(o.boundaries, out.boundaries, "boundaries", ".geojson");
  keep(o.tripoints, out.tripoints, "tripoints", ".geojson");
  keep(o.limits, out.limits, "limits", ".geojson");
  keep(o.regions, out.regions, "regions", ".geojson");
  keep(o.turning_points, out.turning_points, "turning_points", ".json");
  st.job = prepare_job(st.spec, job_limits, hooks);
  PreparedJob& job = st.job;
  st.whole_steps = job.partial.any();
  if (job.located())
    throw Error(ErrorKind::invalid_argument,
                "sessions do not take the geodesic metric on a projected grid yet; use a longitude/latitude grid or "
                "the planar metric");
  // With partial effect, the fields at full effect and by the rule.
  const int64_t field_bytes = job.grid.cell_count() * (st.whole_steps ? 16 : 8);
  if (limits.max_memory_bytes > 0 && field_bytes > limits.max_memory_bytes)
    throw Error(ErrorKind::too_large, "the session's field alone takes " + std::to_string(field_bytes) +
                                          " bytes, over its memory limit of " +
                                          std::to_string(limits.max_memory_bytes));
  if (hooks.reserve_memory) hooks.reserve_memory(field_bytes);
  detail::CoordinateBounds bounds;
  bounds.geographic = job.loaded.seed_crs.geographic;
  bounds.limit = kMaxSeedCoordinate;
  st.features.emplace(job.loaded.seeds, job.loaded.input_position, job.to_output, bounds);
  if (st.whole_steps) st.features->allow_effects();
  std::vector<int64_t> position;
  // The seeds as the session builds them: the same set, checked (a feature's parts come back to
  // the same sites).
  SeedSet built = st.features->build(st.slot_of, position);
  const std::vector<Site>& a = built.sites();
  const std::vector<Site>& b = job.loaded.seeds.sites();
  const bool same = a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](const Site& x, const Site& y) {
                      return x.a == y.a && x.b == y.b && x.feature == y.feature && x.kind == y.kind;
                    });
  if (!same) throw Error(ErrorKind::internal, "session: the seeds' parts do not make the seeds again");
  st.compute_whole(&hooks);
  st.tiles = TileSummaries::for_grid(job.grid);
  st.tiles.add(st.field.site.data(), st.field.distance.data(), 0, job.grid.height, job.grid.width, job.loaded.seeds);
  const std::vector<double> area = owner_cell_areas(st.field, job.loaded.seeds, job.grid);
  for (size_t c = 1; c < area.size(); ++c) st.cell_area[job.loaded.seeds.owner_labels()[c - 1]] = area[c];
  // The hooks are the creation's: nothing of them is kept.
  job.compute.cancel = nullptr;
  job.compute.progress = nullptr;
  if (hooks.progress) hooks.progress("deliver", 0.0);
  json recompute;
  st.deliver(nullptr, nullptr, nullptr, recompute);
  st.files();
  if (limits.max_memory_bytes > 0 && st.memory_bytes() > limits.max_memory_bytes)
    throw Error(ErrorKind::too_large, "the session takes " + std::to_string(st.memory_bytes()) +
                                          " bytes, over its memory limit of " +
                                          std::to_string(limits.max_memory_bytes));
  return s;
}

json Session::edit(const json& edits) {
  State& st = *st_;
  Step step{st.features->plan(edits)};
  json answer = st.step(step.changes, false);
  answer["edits"] = edits.size();
  answer["step"] = ++st.steps;
  st.undo.push_back(std::move(step));
  while (st.undo.size() > static_cast<size_t>(st.limits.undo_depth)) st.undo.pop_front();
  st.redo.clear();
  return answer;
}

json Session::undo() {
  State& st = *st_;
  if (st.undo.empty()) throw Error(ErrorKind::invalid_argument, "nothing to undo");
  json answer = st.step(st.undo.back().changes, true);
  st.redo.push_back(std::move(st.undo.back()));
  st.undo.pop_back();
  answer["step"] = --st.steps;
  answer["undone"] = true;
  return answer;
}

json Session::redo() {
  State& st = *st_;
  if (st.redo.empty()) throw Error(ErrorKind::invalid_argument, "nothing to redo");
  json answer = st.step(st.redo.back().changes, false);
  st.undo.push_back(std::move(st.redo.back()));
  st.redo.pop_back();
  answer["step"] = ++st.steps;
  answer["redone"] = true;
  return answer;
}

json Session::info() const {
  const State& st = *st_;
  st.files();  // the regions' areas
  const int64_t bytes = memory_bytes();
  const GridSpec& g = st.job.grid;
  json owners = json::array();
  for (size_t c = 0; c < st.job.loaded.seeds.owner_labels().size(); ++c)
    owners.push_back({{"code", c + 1}, {"label", st.job.loaded.seeds.owner_labels()[c]}});
  json out = {
      {"grid",
       {{"xmin", g.xmin},
        {"ymax", g.ymax},
        {"res", g.res},
        {"width", g.width},
        {"height", g.height},
        {"crs", st.job.loaded.crs.name}}},
      {"metric", st.job.metric.kind == MetricSpec::geodesic ? "geodesic" : "planar"},
      {"distance_units", st.job.unit},
      {"owners", owners},
      {"features", st.job.loaded.seeds.features().size()},
      {"areas", st.areas_json()},
      {"area_units", st.report.contains("regions") ? st.report["regions"]["area_units"] : json(st.job.unit + "^2")},
      {"deliverables", deliverables()},
      {"memory_bytes", bytes},
      {"bytes_per_cell", static_cast<double>(bytes) / static_cast<double>(std::max<int64_t>(1, g.cell_count()))},
      {"steps", st.steps},
      {"undo", st.undo.size()},
      {"redo", st.redo.size()}};
  // The regions checked against the session's cells, as a job's (every row: the field is whole).
  if (st.report.contains("regions") && st.report["regions"].contains("against_cells"))
    out["regions_check"] = st.report["regions"]["against_cells"];
  return out;
}

json Session::features() const {
  json fc = st_->features->geojson();
  // GeoJSON means longitude/latitude; other CRSs are named the way GDAL and older readers take.
  const CrsInfo& crs = st_->job.loaded.seed_crs;
  if (!crs.geographic && !crs.wkt.empty()) fc["crs"] = {{"type", "name"}, {"properties", {{"name", crs.wkt}}}};
  return fc;
}

json Session::line_ids() const {
  json out = json::object();
  for (const char* kind : {"boundaries", "limits", "tripoints"}) out[kind] = st_->lines.ids(kind);
  return out;
}

std::vector<std::string> Session::deliverables() const {
  std::vector<std::string> out;
  for (const char* name : kSessionDeliverables)
    if (st_->paths.count(name)) out.emplace_back(name);
  return out;
}

const std::string& Session::deliverable(const std::string& name) const {
  if (!st_->paths.count(name)) throw Error(ErrorKind::not_found, "the session keeps no deliverable \"" + name + "\"");
  st_->files();
  const auto it = st_->texts.find(name);
  if (it == st_->texts.end()) throw Error(ErrorKind::not_found, "the session keeps no deliverable \"" + name + "\"");
  return it->second;
}

JobResult Session::save(const OutputRequest& outputs, const JobHooks& hooks) const {
  return snapshot()->save(outputs, hooks);
}

std::shared_ptr<const SessionSnapshot> Session::snapshot() const {
  auto s = std::make_shared<SessionSnapshot>();
  s->spec_ = st_->spec;
  s->job_ = st_->job;
  s->job_.compute.prepared = nullptr;  // made for the session's own copy of the seeds
  s->limits_ = st_->job_limits;
  return s;
}

JobResult SessionSnapshot::save(const OutputRequest& outputs, const JobHooks& hooks) const {
  // The files asked for, with the session's options for its lines (what it was prepared with).
  JobSpec spec = spec_;
  spec.outputs = outputs;
  copy_line_options(spec_.outputs, spec.outputs);
  if (!spec.outputs.limits.empty() && spec.outputs.limit_distances.empty())
    throw Error(ErrorKind::invalid_argument, "the session has no limit distances: it cannot save limits");
  PreparedJob job = job_;
  job.compute.cancel = hooks.cancel;
  return run_prepared(spec, job, limits_, hooks);
}

void Session::set_memory_limit(int64_t bytes) { st_->limits.max_memory_bytes = std::max<int64_t>(bytes, 0); }

const SeedSet& Session::seeds() const { return st_->job.loaded.seeds; }
const GridSpec& Session::grid() const { return st_->job.grid; }
const PreparedJob& Session::job() const { return st_->job; }
const NearestField& Session::field() const { return st_->field; }
int64_t Session::steps() const { return st_->steps; }
int64_t Session::memory_bytes() const { return st_->memory_bytes(); }

}  // namespace rv
