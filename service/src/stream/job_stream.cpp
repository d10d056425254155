// The streaming path of run_job. See job_stream.hpp and rv/job.hpp (JobPlan) for the contract.
//
// Why this shape: at 1e8 cells the whole-field path spent more time having the kernel zero fresh
// pages (the field, then an owner raster copy) and encoding than computing, one after the other.
// Here the engine computes every strip into the same two buffers (compute_into reuses them, so
// pages are faulted once per buffer, not once per cell), and the writer threads (one per file)
// encode strip k while the engine computes strip k+1. Two buffers suffice: the engine never waits
// unless the encoder is slower, and then a third buffer would only delay the wait.
//
// Determinism: strips are computed and written in row order, each strip's cells equal the
// whole grid's (exact and brute force compute any window identically), and the conversion is
// per cell, so the files do not depend on strip height or thread count.
#include "stream/job_stream.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <exception>
#include <optional>
#include <thread>
#include <variant>
#include <vector>

#include <sys/resource.h>
#include <unistd.h>

#include "rv/engine/outputs.hpp"
#include "rv/field/error.hpp"
#include "stream/strip_handoff.hpp"

namespace rv::detail {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int64_t kTileSide = 256;  // the GeoTIFF writers' tiles

// The writer threads' nice value. The engine's threads and the encoders compete for the same
// cores; with equal priority the engine ran about 1.7x slower than alone (1e8 cells, 2 cores),
// and strips waited for nothing faster to happen. At a lower priority the encoders use the time
// the engine leaves (it waits for a free strip buffer anyway when they are the slower side): on
// that case the engine's time fell from 0.60-0.71 s to 0.34-0.41 s, the command's from
// 2.10-2.40 s to 1.81-2.50 s (noise of this VM).
constexpr int kWriterNice = 10;

// Lowers the calling thread's scheduling priority. Linux nice values are per thread, and the
// threads it creates later (GDAL's compression workers) inherit them. Best effort: a failure
// leaves the priority as it was.
void lower_priority() {
#if defined(__linux__)
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()));
  if (errno == 0) (void)setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), std::min(now + kWriterNice, 19));
#endif
}

// One strip buffer: the engine's field for its rows (the distance is scaled in place). The code
// rasters (owner, feature) are made from its sites by the writer of each file, on its own thread:
// on the engine's thread that pass was serial time between two strips (0.14 s of a 0.2 s
// computation at 1e8 cells).
struct Strip {
  NearestField field;
  std::vector<float> metric_distance;  // the distances before conversion (a metric_distance target, factor != 1)
  std::vector<int32_t> codes;          // a codes target's codes (from the strip source)
  std::vector<uint8_t> fresh;          // per tile of the strip, from the source (StreamJob::source)
  int64_t row0 = 0;
  int64_t rows = 0;
};

using AnyWriter = std::variant<GeoTiffStripWriter<int32_t>, GeoTiffStripWriter<float>>;

AnyWriter open_writer(const StreamTarget& t, const GridSpec& grid) {
  switch (t.product) {
    case StreamTarget::Product::distance:
    case StreamTarget::Product::metric_distance:
      return GeoTiffStripWriter<float>(t.path, grid, grid.full_window(), static_cast<double>(kNoDistance), t.options);
    case StreamTarget::Product::ownership:
    case StreamTarget::Product::nearest_feature:
    case StreamTarget::Product::site:
    case StreamTarget::Product::codes:
      break;
  }
  return GeoTiffStripWriter<int32_t>(t.path, grid, grid.full_window(), 0.0, t.options);
}

}  // namespace

namespace {

// What the engine's thread and the writer threads of one streamed job share.
struct StreamState {
  const StreamJob& job;
  int64_t width = 0, height = 0;
  SiteCodes owner_codes, feature_codes;  // made only when a file needs them
  std::vector<AnyWriter> writers;        // one per target
  std::array<Strip, 2> strips;
  bool keep_metric_distance = false;  // a metric_distance target with a unit conversion
  StripHandoff handoff;
  std::vector<double> write_seconds, write_waited;  // per writer
  std::vector<char> copies;                         // per writer: its earlier file's tiles are copied
  std::vector<int64_t> copied;                      // per writer: tiles copied
  bool all_cells = true;                            // the source must fill every cell
  int64_t across = 0;                               // tiles across the grid

  StreamState(const StreamJob& j, int files) : job(j), handoff(files) {}
};

// The writer thread of file `i`: encodes every strip in order into its file, then finishes it.
// The files are independent GDAL datasets, so they are encoded side by side (one thread handing
// both files' tiles to GDAL was the command's serial part: 1e8 cells, see
// bench/RESULTS-encoding.md).
void write_file(StreamState& st, size_t i) {
  lower_priority();
  const StreamTarget& target = st.job.targets[i];
  const bool copies = st.copies[i] != 0;
  const bool every_cell = !copies;
  std::vector<int32_t> codes;  // this file's codes of the strip in hand (code rasters only)
  // Site ids -> this file's codes over the strip's cells: every cell, or, for a file that copies
  // the tiles flagged 0 (a COG decodes them from its earlier file for its overviews), the cells
  // of the tiles flagged 1 alone (the others may hold anything).
  auto coded = [&](const Strip& s, auto&& code) {
    const int64_t n = s.rows * st.width;
    codes.resize(static_cast<size_t>(n));
    const int32_t* sites = s.field.site.data();
    if (every_cell || s.fresh.empty()) {
      code(sites, codes.data(), n);
      return codes.data();
    }
    for (int64_t r = 0; r < s.rows; ++r)
      for (int64_t bx = 0; bx < st.across; ++bx) {
        if (!s.fresh[static_cast<size_t>((r / kTileSide) * st.across + bx)]) continue;
        const int64_t c0 = bx * kTileSide, w = std::min(kTileSide, st.width - c0);
        code(sites + r * st.width + c0, codes.data() + r * st.width + c0, w);
      }
    return codes.data();
  };
  auto table = [](const SiteCodes& t) {
    return [&t](const int32_t* in, int32_t* out, int64_t n) { t.apply(in, out, n); };
  };
  try {
    for (size_t seq = 0;; ++seq) {
      const std::optional<int> k = st.handoff.take_filled(seq, st.write_waited[i]);
      if (!k) break;
      const Strip& s = st.strips[static_cast<size_t>(*k)];
      const auto t = Clock::now();
      // Band by band where the strip marks tiles to copy, else its rows at once.
      auto write = [&](auto& writer, const auto* cells) {
        if (!copies || s.fresh.empty()) {
          writer.write_rows(cells, s.rows);
          return;
        }
        std::vector<bool> copy(static_cast<size_t>(st.across));
        for (int64_t b = 0; b * kTileSide < s.rows; ++b) {
          for (int64_t bx = 0; bx < st.across; ++bx)
            copy[static_cast<size_t>(bx)] = s.fresh[static_cast<size_t>(b * st.across + bx)] == 0;
          st.copied[i] += std::count(copy.begin(), copy.end(), true);
          writer.write_band(cells + b * kTileSide * st.width, copy);
        }
      };
      auto write_codes = [&](const int32_t* cells) {
        write(std::get<GeoTiffStripWriter<int32_t>>(st.writers[i]), cells);
      };
      auto write_floats = [&](const float* cells) { write(std::get<GeoTiffStripWriter<float>>(st.writers[i]), cells); };
      // (Also where every cell is valid: the tiles flagged 0 are their earlier files', whose
      // summaries the observer may take instead of reading the cells again.)
      const uint8_t* fresh = s.fresh.empty() ? nullptr : s.fresh.data();
      switch (target.product) {
        case StreamTarget::Product::ownership:
          write_codes(coded(s, table(st.owner_codes)));
          break;
        case StreamTarget::Product::nearest_feature:
          write_codes(coded(s, table(st.feature_codes)));
          break;
        case StreamTarget::Product::site:
          if (target.site_codes.empty())
            write_codes(coded(s, [](const int32_t* in, int32_t* out, int64_t n) {
              for (int64_t c = 0; c < n; ++c) out[c] = in[c] + 1;  // kNoSite -> 0
            }));
          else
            write_codes(coded(s, [&](const int32_t* in, int32_t* out, int64_t n) {
              for (int64_t c = 0; c < n; ++c)
                out[c] = in[c] == kNoSite ? 0 : target.site_codes[static_cast<size_t>(in[c])];
            }));
          break;
        case StreamTarget::Product::codes:
          write_codes(s.codes.data());
          break;
        case StreamTarget::Product::distance:
          // (Observed only in metric units: StreamJob::distance_factor 1.)
          if (target.observe) target.observe(s.field.site.data(), s.field.distance.data(), s.row0, s.rows, fresh);
          write_floats(s.field.distance.data());
          break;
        case StreamTarget::Product::metric_distance: {
          const float* metric = st.keep_metric_distance ? s.metric_distance.data() : s.field.distance.data();
          if (target.observe) target.observe(s.field.site.data(), metric, s.row0, s.rows, fresh);
          write_floats(metric);
          break;
        }
      }
      st.write_seconds[i] += seconds_since(t);
      st.handoff.put_done(*k, s.rows);
    }
    // Closed and drained (a stop leaves rows missing; the writer then aborts when destroyed).
    // Into place once every file is written (else, for an edit writing over its base's files, a
    // file replaced and then removed by the job's failure would leave the base without it).
    if (std::visit([&](const auto& x) { return x.rows_written() != st.height; }, st.writers[i])) return;
    if (!st.handoff.all_written()) return;
    const auto t = Clock::now();
    std::visit([](auto& x) { x.finish(); }, st.writers[i]);
    if (target.checksums)
      *target.checksums = std::visit([](const auto& x) { return x.tile_checksums(); }, st.writers[i]);
    st.write_seconds[i] += seconds_since(t);
    st.handoff.finished(static_cast<int>(i));
  } catch (...) {
    st.handoff.fail(std::current_exception());
  }
}

// The engine's side: every strip computed into a free buffer, its distances converted, handed
// to the writers. `report` forwards progress over the whole grid.
template <class Report>
void compute_strips(StreamState& st, int64_t strip_rows, StreamStats& stats, Report&& report) {
  const StreamJob& job = st.job;
  ComputeOptions options = job.compute;
  // Every strip shares one preparation of the seeds (sites in the grid's frame, the index).
  if (options.prepared == nullptr) options.prepared = prepare(*job.seeds, job.grid, options);
  for (int64_t row0 = 0; row0 < st.height; row0 += strip_rows) {
    if (options.cancel && options.cancel->load()) throw Error(ErrorKind::cancelled, "job dismissed");
    const std::optional<int> k = st.handoff.take_free(stats.compute_waited);
    if (!k) std::rethrow_exception(st.handoff.error());
    Strip& s = st.strips[static_cast<size_t>(*k)];
    s.row0 = row0;
    s.rows = std::min(strip_rows, st.height - row0);
    options.window = Window{0, row0, st.width, s.rows};
    options.progress = [&, row0, rows = s.rows](double f) {
      report("compute", (static_cast<double>(row0) + f * static_cast<double>(rows)) / static_cast<double>(st.height));
    };
    if (job.source) {
      if (row0 % kTileSide != 0 || (s.rows % kTileSide != 0 && row0 + s.rows != st.height))
        throw Error(ErrorKind::internal, "a strip source's strips must hold whole bands of tiles");
      const auto t = Clock::now();
      s.fresh.clear();
      job.source(*options.window, s.field, s.codes, s.fresh, st.all_cells);
      if (!s.fresh.empty() && static_cast<int64_t>(s.fresh.size()) != (s.rows + kTileSide - 1) / kTileSide * st.across)
        throw Error(ErrorKind::internal, "a strip source's tile flags do not fit its strip");
      s.field.seconds = seconds_since(t);
      report("compute", static_cast<double>(row0 + s.rows) / static_cast<double>(st.height));
    } else {
      compute_into(*job.seeds, job.grid, options, s.field);
    }
    stats.compute += s.field.seconds;
    stats.contested_cells += s.field.contested_cells;
    stats.threads = s.field.threads;
    if (job.on_strip) {
      const auto t = Clock::now();
      job.on_strip(s.field);
      stats.deliverables += seconds_since(t);
    }
    const auto t = Clock::now();
    if (st.keep_metric_distance)
      s.metric_distance.assign(s.field.distance.cells().begin(), s.field.distance.cells().end());
    if (job.distance_factor != 1.0)
      scale_distances(s.field.distance.data(), s.field.distance.data(), s.rows * st.width, job.distance_factor);
    stats.convert += seconds_since(t);
    st.handoff.put_filled(*k);
  }
}

}  // namespace

StreamStats run_streamed(const StreamJob& job) {
  const auto start = Clock::now();
  StreamState st(job, static_cast<int>(job.targets.size()));
  st.width = job.grid.width;
  st.height = job.grid.height;
  const int64_t strip_rows = std::clamp<int64_t>(job.strip_rows, 1, st.height);
  StreamStats stats;
  stats.strips = (st.height + strip_rows - 1) / strip_rows;
  bool want_owners = false, want_features = false;
  for (const StreamTarget& t : job.targets) {
    want_owners = want_owners || t.product == StreamTarget::Product::ownership;
    want_features = want_features || t.product == StreamTarget::Product::nearest_feature;
  }
  for (const StreamTarget& t : job.targets)
    st.keep_metric_distance =
        st.keep_metric_distance || (t.product == StreamTarget::Product::metric_distance && job.distance_factor != 1.0);
  if (want_owners) st.owner_codes = SiteCodes::owners(*job.seeds);
  if (want_features) st.feature_codes = SiteCodes::features(*job.seeds, job.feature_numbering);
  // Every file is created before the first strip is computed: an unwritable target fails at
  // once, not after the computation. Each file's writer may use all of the job's threads (its
  // options.threads) to compress its tiles: a static share would leave the slow file (a Float32
  // distance with the floating-point predictor, `small`) one thread while the other core idles
  // once the owner codes are done. (An uncompressed file uses one.)
  st.writers.reserve(job.targets.size());
  for (const StreamTarget& t : job.targets) {
    job.will_write(t.path);
    st.writers.push_back(open_writer(t, job.grid));
  }
  // An edit's earlier files: copied from where their layout allows (a COG decodes the copied
  // tiles for its overviews). Every cell is needed where a file encodes all its tiles, and by
  // on_strip.
  st.across = (st.width + kTileSide - 1) / kTileSide;
  st.copies.assign(job.targets.size(), 0);
  st.copied.assign(job.targets.size(), 0);
  st.all_cells = !job.source || (job.on_strip && job.on_strip_every_cell);
  for (size_t i = 0; i < job.targets.size(); ++i) {
    const StreamTarget& t = job.targets[i];
    if (!t.earlier.empty()) {
      try {
        std::visit(
            [&](auto& w) { w.take_tiles_from(t.earlier, t.earlier_checksums, t.earlier_display, t.earlier_remap); },
            st.writers[i]);
        st.copies[i] = 1;
      } catch (const Error& e) {
        stats.not_copied[t.name] = e.what();
      }
    }
    if (t.product != StreamTarget::Product::codes && !st.copies[i]) st.all_cells = true;
  }
  stats.all_cells = st.all_cells;
  st.write_seconds.assign(job.targets.size(), 0.0);
  st.write_waited.assign(job.targets.size(), 0.0);
  for (int k = 0; k < static_cast<int>(st.strips.size()); ++k) st.handoff.add_free(k);

  // Joins the writers on every way out; on an exception they are stopped first.
  struct Joiner {
    StripHandoff& handoff;
    std::vector<std::thread> threads;
    ~Joiner() { join(); }
    void join() {
      handoff.stop();
      for (std::thread& t : threads)
        if (t.joinable()) t.join();
    }
  } joiner{st.handoff, {}};
  for (size_t i = 0; i < st.writers.size(); ++i) joiner.threads.emplace_back([&st, i] { write_file(st, i); });

  // Engine progress is per strip; the job's is over the grid, forwarded in whole percents.
  int last_percent = -1;
  auto report = [&](const char* stage, double fraction) {
    const int percent = static_cast<int>(fraction * 100.0);
    if (!job.progress || percent <= last_percent) return;
    last_percent = percent;
    job.progress(stage, percent / 100.0);
  };
  compute_strips(st, strip_rows, stats, report);
  st.handoff.close();
  // Stage "write": the files in place, in the targets' order (the rows were reported with the
  // strips). A file's report follows those before it, so a job held at its first "write" report
  // has the first file complete and in place.
  st.handoff.wait_finished([](int64_t) {},
                           [&](int files) {
                             if (job.progress)
                               job.progress("write",
                                            static_cast<double>(files) / static_cast<double>(st.writers.size()));
                           });
  joiner.join();
  // The writers wait side by side: the longest wait is the time the files waited for the engine.
  if (!st.write_waited.empty()) stats.write_waited = *std::max_element(st.write_waited.begin(), st.write_waited.end());
  for (size_t i = 0; i < job.targets.size(); ++i) {
    stats.write[job.targets[i].name] = st.write_seconds[i];
    const StreamTarget& t = job.targets[i];
    if (!t.earlier.empty())
      (t.earlier_remap.empty() ? stats.tiles_copied : stats.tiles_recoded)[t.name] = st.copies[i] ? st.copied[i] : -1;
  }
  stats.wall = seconds_since(start);
  return stats;
}

}  // namespace rv::detail
