// Bands of a split job and their assembly (job_bands.hpp).
#include "job/job_bands.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>

#include "common/atomic_file.hpp"
#include "rv/engine/engine.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/json_text.hpp"

namespace rv::detail {
namespace {

constexpr int64_t kBandRows = 256;  // the tiles' side: a band holds whole tiles of every file
constexpr const char* kFormat = "rvoronoi-band";
constexpr int kVersion = 1;

[[noreturn]] void refuse(const std::string& why) { throw Error(ErrorKind::invalid_argument, why); }

GeoTiffOptions site_options(int64_t sites) {
  GeoTiffOptions o;
  o.max_code = sites;
  o.metadata["CONTENT"] = "nearest site index + 1 (0 = none), one band of a split job";
  return o;
}

GeoTiffOptions distance_options() {
  GeoTiffOptions o;
  o.metadata["CONTENT"] = "distance to the nearest site in metric units, one band of a split job";
  return o;
}

// A window (one chunk of a grid computed in pieces): inside the grid, with outputs in memory
// only, and a method that computes a window as the same cells of the whole grid.
void check_window(const JobSpec& spec, const GridSpec& grid) {
  if (!spec.window) return;
  const Window& w = *spec.window;
  const OutputRequest& out = spec.outputs;
  auto refuse = [](const std::string& why) { throw Error(ErrorKind::invalid_argument, "window: " + why); };
  if (w.width <= 0 || w.height <= 0 || w.col0 < 0 || w.row0 < 0 || w.col0 + w.width > grid.width ||
      w.row0 + w.height > grid.height)
    refuse("rows " + std::to_string(w.row0) + "+" + std::to_string(w.height) + ", columns " + std::to_string(w.col0) +
           "+" + std::to_string(w.width) + " are not inside the grid of " + std::to_string(grid.height) + " x " +
           std::to_string(grid.width) + " cells");
  if (spec.method != Method::exact && spec.method != Method::brute_force)
    refuse("the scan methods propagate across the whole grid, so a piece of it would differ; use method exact");
  if (!out.ownership.empty() || !out.distance.empty() || !out.nearest_feature.empty() || out.any_deliverable() ||
      !out.report.empty() || !out.changes.empty())
    refuse("a piece of a grid gives its rasters in memory only (no files, no deliverables)");
  if (spec.validate) refuse("validation compares whole fields");
  if (spec.seeds.effect_field) refuse("partial effect compares whole fields");
  if (!spec.base_report.empty()) refuse("an edit covers its base's whole grid");
}

}  // namespace

void check_pieces(const JobSpec& spec, const GridSpec& grid, const JobPlan& plan) {
  check_window(spec, grid);
  if (!spec.band && spec.bands.empty()) return;
  if (spec.band && !spec.bands.empty()) refuse("band: a band run assembles nothing");
  const char* what = spec.band ? "band" : "bands";
  if (!plan.streamed) refuse(std::string(what) + ": a split job is streamed (" + plan.why_whole + ")");
  if (!spec.base_report.empty()) refuse(std::string(what) + ": an edit is not split");
  if (spec.window) refuse(std::string(what) + ": a window is a piece of its own");
  if (!spec.band) return;
  const JobSpec::Band& b = *spec.band;
  if (b.dir.empty()) refuse("band: no folder to write it into");
  if (b.row0 < 0 || b.rows <= 0 || b.row0 + b.rows > grid.height)
    refuse("band: rows " + std::to_string(b.row0) + "+" + std::to_string(b.rows) + " are not inside the grid's " +
           std::to_string(grid.height) + " rows");
  if (b.row0 % kBandRows != 0 || (b.rows % kBandRows != 0 && b.row0 + b.rows != grid.height))
    refuse("band: rows " + std::to_string(b.row0) + "+" + std::to_string(b.rows) +
           " must start and end on whole bands of 256 rows (or at the grid's last row)");
  const OutputRequest& out = spec.outputs;
  if (!out.ownership.empty() || !out.distance.empty() || !out.nearest_feature.empty() || out.any_deliverable() ||
      !out.report.empty() || !out.changes.empty())
    refuse("band: a band writes its field only; the assembling run writes the job's files");
}

JobResult run_band(JobRun& run, const PreparedJob& job) {
  const JobSpec::Band& b = *run.spec.band;
  const GridSpec& grid = job.grid;
  const int64_t sites = static_cast<int64_t>(job.loaded.seeds.sites().size());
  std::error_code ec;
  std::filesystem::create_directories(b.dir, ec);
  if (ec) throw Error(ErrorKind::io, "cannot create the band's folder: " + ec.message());
  const std::string site_path = b.dir + "/site.tif", distance_path = b.dir + "/distance.tif";
  const std::string meta_path = b.dir + "/band.json";
  for (const std::string& p : {site_path, distance_path, meta_path}) run.will_write(p);
  const Window band{0, b.row0, grid.width, b.rows};
  GeoTiffStripWriter<int32_t> site(site_path, grid, band, 0.0, site_options(sites));
  GeoTiffStripWriter<float> distance(distance_path, grid, band, static_cast<double>(kNoDistance), distance_options());
  ComputeOptions options = job.compute;
  options.cancel = run.hooks.cancel;
  if (options.prepared == nullptr) options.prepared = prepare(job.loaded.seeds, grid, options);
  // Strips of the plan's height, on whole bands of tiles.
  const int64_t strip = std::max(kBandRows, run.plan.strip_rows / kBandRows * kBandRows);
  NearestField field;
  int64_t contested = 0;
  double seconds = 0.0;
  int threads = 1;
  for (int64_t r = b.row0; r < b.row0 + b.rows; r += strip) {
    run.check_cancel();
    const int64_t rows = std::min(strip, b.row0 + b.rows - r);
    options.window = Window{0, r, grid.width, rows};
    options.progress = [&run, done = r - b.row0, rows, all = b.rows](double f) {
      run.progress("compute", (static_cast<double>(done) + f * static_cast<double>(rows)) / static_cast<double>(all));
    };
    compute_into(job.loaded.seeds, grid, options, field);
    seconds += field.seconds;
    contested += field.contested_cells;
    threads = field.threads;
    int32_t* cells = field.site.data();
    for (int64_t c = 0, n = rows * grid.width; c < n; ++c) cells[c] += 1;  // kNoSite (-1) -> 0
    site.write_rows(cells, rows);
    distance.write_rows(field.distance.data(), rows);
  }
  run.progress("write", 0.0);
  site.finish();
  distance.finish();
  const nlohmann::json meta = {{"format", kFormat},
                               {"version", kVersion},
                               {"row0", b.row0},
                               {"rows", b.rows},
                               {"grid", {{"width", grid.width}, {"height", grid.height}}},
                               {"sites", sites},
                               {"contested_cells", contested},
                               {"threads", threads}};
  write_file_atomically(meta_path, json_text(meta, 2) + "\n");
  run.timings["compute"] = seconds;
  run.report["band"] = meta;
  run.report["threads"] = threads;
  run.report["timings"] = run.timings;
  run.progress("write", 1.0);
  JobResult result{run.report, run.guard.files(), {}, grid};
  run.guard.commit();
  return result;
}

struct BandFields::State {
  struct Band {
    std::string dir;
    int64_t row0 = 0, rows = 0, contested = 0;
    int threads = 1;
    std::optional<GeoTiffRowReader<int32_t>> site;
    std::optional<GeoTiffRowReader<float>> distance;
  };
  std::vector<Band> bands;  // by row0
  GridSpec grid;
  MetricSpec metric;
  std::shared_ptr<const Geolocator> geolocator;
  int64_t sites = 0;
};

BandFields::BandFields(const std::vector<std::string>& dirs, const PreparedJob& job) : st_(std::make_unique<State>()) {
  State& st = *st_;
  st.grid = job.grid;
  st.metric = job.compute.metric;
  st.geolocator = job.compute.geolocator;
  st.sites = static_cast<int64_t>(job.loaded.seeds.sites().size());
  for (const std::string& dir : dirs) {
    auto bad = [&](const std::string& why) { refuse("bands: " + dir + ": " + why); };
    nlohmann::json meta;
    try {
      meta = nlohmann::json::parse(read_regular_file(dir + "/band.json", "band.json"));
      if (meta.at("format") != kFormat || meta.at("version") != kVersion) bad("not a band of this version");
      State::Band b;
      b.dir = dir;
      b.row0 = meta.at("row0").get<int64_t>();
      b.rows = meta.at("rows").get<int64_t>();
      b.contested = meta.at("contested_cells").get<int64_t>();
      b.threads = meta.at("threads").get<int>();
      if (meta.at("grid").at("width").get<int64_t>() != st.grid.width ||
          meta.at("grid").at("height").get<int64_t>() != st.grid.height || meta.at("sites").get<int64_t>() != st.sites)
        bad("a band of another grid or other seeds");
      st.bands.push_back(std::move(b));
    } catch (const nlohmann::json::exception&) {
      bad("a damaged band.json");
    }
  }
  std::sort(st.bands.begin(), st.bands.end(),
            [](const State::Band& a, const State::Band& b) { return a.row0 < b.row0; });
  int64_t next = 0;
  for (const State::Band& b : st.bands) {
    if (b.row0 != next)
      refuse("bands: rows " + std::to_string(next) + ".." + std::to_string(b.row0) + " are " +
             (b.row0 > next ? "in no band" : "in two bands"));
    next = b.row0 + b.rows;
  }
  if (next != st.grid.height)
    refuse("bands: rows " + std::to_string(next) + ".." + std::to_string(st.grid.height) + " are in no band");
}

BandFields::~BandFields() = default;

int64_t BandFields::count() const { return static_cast<int64_t>(st_->bands.size()); }

void BandFields::read(const Window& w, NearestField& field) {
  State& st = *st_;
  field.site.retarget(st.grid, w);
  field.distance.retarget(st.grid, w);
  field.metric = st.metric;
  field.geolocator = st.geolocator;
  field.contested_cells = 0;
  field.threads = 1;  // the engine's threads where the bands were computed (the report's "threads")
  const int64_t width = st.grid.width;
  for (State::Band& b : st.bands) {
    const int64_t from = std::max(w.row0, b.row0), to = std::min(w.row0 + w.height, b.row0 + b.rows);
    if (from >= to) continue;
    // Each band's cells decided between contested polygons count once, in the strip of its first row.
    if (b.row0 >= w.row0 && b.row0 < w.row0 + w.height) field.contested_cells += b.contested;
    field.threads = std::max(field.threads, b.threads);
    if (!b.site) {  // opened when first needed: a band's files are read once, in row order
      b.site.emplace(b.dir + "/site.tif");
      b.distance.emplace(b.dir + "/distance.tif");
      if (b.site->grid().width != width || b.site->grid().height != b.rows || b.distance->grid().height != b.rows)
        refuse("bands: " + b.dir + ": its rasters do not hold its rows");
    }
    int32_t* site = field.site.data() + (from - w.row0) * width;
    b.site->read_rows(from - b.row0, to - from, site);
    b.distance->read_rows(from - b.row0, to - from, field.distance.data() + (from - w.row0) * width);
    for (int64_t c = 0, n = (to - from) * width; c < n; ++c) {
      if (site[c] < 0 || site[c] > st.sites) refuse("bands: " + b.dir + ": a site code outside the seeds");
      site[c] -= 1;  // 0 -> kNoSite
    }
  }
}

void attach_bands(StreamJob& stream, BandFields& bands) {
  stream.source = [&bands](const Window& w, NearestField& field, std::vector<int32_t>&, std::vector<uint8_t>&, bool) {
    const auto t = Clock::now();
    bands.read(w, field);
    field.seconds = seconds_since(t);
  };
}

}  // namespace rv::detail
