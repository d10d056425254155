// Reproduces the rows of Table 1 of Liu, Zhao, Wang, Sun (2019) — grid size and seed count —
// for h-scan, hv-scan, exact and (on the small rows) brute force, in one run on one machine.
// Prints a markdown table with wall time (median of the repeats), ns per cell and ratios.
//
//   engine_bench [--quick] [--threads N] [--repeats N] [--min-cells N] [--max-cells N]
//                [--methods exact,hv-scan,...] [--warm] [--strip-rows N]
//
// --repeats N: runs per row (default 3; rows of 9e6 cells or more run once unless it is given).
// --warm adds the time of compute_into() into the previous run's buffers: the computation
// without the first-touch page faults of fresh result rasters (which, on a VM, can cost as much
// as the computation itself).
// --strip-rows N (exact and brute force) also computes the grid strip by strip, N rows at a
// time, into one reused result (what `rvoronoi compute` does when it streams), prints the summed
// time on a line under the table and checks the strips against the whole grid cell for cell.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "bench_case.hpp"
#include "rv/engine/engine.hpp"
#include "rv/engine/validate.hpp"

using namespace rv;

namespace {

struct Row {
  int64_t size;
  int seeds;
  double paper_brute_ms, paper_h_ms, paper_hv_ms;  // Table 1, i5-3337U, one thread (-1: not given)
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false, warm = false, repeats_given = false;
  int threads = 0, repeats = 3;
  int64_t min_cells = 0, max_cells = int64_t{1} << 62, strip_rows = 0;
  std::string strip_lines;
  bool strips_differ = false;
  std::vector<Method> methods = {Method::exact, Method::h_scan, Method::hv_scan, Method::brute_force};
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--quick"))
      quick = true;
    else if (!std::strcmp(argv[i], "--threads") && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--repeats") && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
      repeats_given = true;
    } else if (!std::strcmp(argv[i], "--max-cells") && i + 1 < argc)
      max_cells = std::atoll(argv[++i]);
    else if (!std::strcmp(argv[i], "--min-cells") && i + 1 < argc)
      min_cells = std::atoll(argv[++i]);
    else if (!std::strcmp(argv[i], "--warm"))
      warm = true;
    else if (!std::strcmp(argv[i], "--strip-rows") && i + 1 < argc)
      strip_rows = std::atoll(argv[++i]);
    else if (!std::strcmp(argv[i], "--methods") && i + 1 < argc) {
      // Exact first: it is the reference the others are compared with.
      methods = {Method::exact};
      std::string list = argv[++i];
      for (size_t start = 0; start <= list.size();) {
        const size_t comma = std::min(list.find(',', start), list.size());
        const Method m = parse_method(list.substr(start, comma - start));
        if (m != Method::exact) methods.push_back(m);
        start = comma + 1;
      }
    } else {
      std::fprintf(stderr,
                   "usage: engine_bench [--quick] [--threads N] [--repeats N] [--min-cells N] [--max-cells N] "
                   "[--methods exact,hv-scan,...] [--warm] [--strip-rows N]\n");
      return 2;
    }
  }
  std::vector<Row> rows = {{100, 20, 18, 19, 25},           {300, 50, 177, 109, 137},
                           {1000, 100, 3232, 1230, 1518},   {1000, 1000, 23895, 1239, 1536},
                           {3000, 10000, -1, 14375, 17066}, {10000, 50000, -1, 171055, 199673}};
  if (quick) rows.resize(3);
  std::printf(
      "| grid | seeds | method | ms (median) | ns/cell | warm ms (buffers reused) | warm ns/cell | × exact | "
      "paper ms (1 thread, i5-3337U) | wrong cells | max Δd (cells) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& row : rows) {
    const int64_t cells = row.size * row.size;
    if (cells > max_cells || cells < min_cells) continue;
    const GridSpec g = bench::square_grid(row.size);
    const SeedSet seeds =
        bench::random_points(row.seeds, static_cast<double>(row.size), static_cast<double>(row.size), 2019);
    double exact_ms = 0;
    NearestField exact_field;
    for (Method m : methods) {
      // Brute force only where the paper ran it (up to 1000 x 1000).
      if (m == Method::brute_force && row.paper_brute_ms < 0) continue;
      const int reps = cells >= 9'000'000 && !repeats_given ? 1 : repeats;
      std::vector<double> ms;
      NearestField f;
      for (int r = 0; r < reps; ++r) {
        ComputeOptions o;
        o.method = m;
        o.threads = threads;
        f = compute(seeds, g, o);
        ms.push_back(f.seconds * 1e3);
      }
      const double med = median(ms);
      double warm_ms = -1;
      if (warm) {
        std::vector<double> wms;
        for (int r = 0; r < reps; ++r) {
          ComputeOptions o;
          o.method = m;
          o.threads = threads;
          compute_into(seeds, g, o, f);
          wms.push_back(f.seconds * 1e3);
        }
        warm_ms = median(wms);
      }
      if (strip_rows > 0 && (m == Method::exact || m == Method::brute_force)) {
        std::vector<double> sms;
        bool same = true;
        // With --warm the strips' buffer is faulted by one untimed pass first, as a streamed
        // command's buffers are after its first strips.
        NearestField strip;
        for (int r = warm ? -1 : 0; r < reps; ++r) {
          // As a streamed job does: the seeds prepared once (timed), shared by the strips.
          ComputeOptions base;
          base.method = m;
          base.threads = threads;
          const auto t0 = std::chrono::steady_clock::now();
          base.prepared = prepare(seeds, g, base);
          double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          for (int64_t row0 = 0; row0 < g.height; row0 += strip_rows) {
            ComputeOptions o = base;
            o.window = Window{0, row0, g.width, std::min(strip_rows, g.height - row0)};
            compute_into(seeds, g, o, strip);
            total += strip.seconds;
            const size_t n = static_cast<size_t>(strip.site.size());
            same = same && std::equal(strip.site.data(), strip.site.data() + n, f.site.row(row0)) &&
                   std::memcmp(strip.distance.data(), f.distance.row(row0), n * sizeof(float)) == 0;
          }
          if (r >= 0) sms.push_back(total * 1e3);
        }
        const double sm = median(sms);
        char line[256];
        std::snprintf(line, sizeof(line),
                      "\n%lldx%lld %s in strips of %lld rows (one reused buffer): %.1f ms, %.2f ns/cell; "
                      "identical to the whole grid: %s",
                      (long long)row.size, (long long)row.size, std::string(to_string(m)).c_str(),
                      (long long)strip_rows, sm, sm * 1e6 / static_cast<double>(cells), same ? "yes" : "NO");
        strip_lines += line;
        if (!same) strips_differ = true;
      }
      ValidationStats v;
      if (m == Method::exact) {
        exact_ms = med;
        exact_field = std::move(f);
      } else {
        // exact == brute force cell for cell (asserted by the test suite), so it is the reference.
        v = compare_fields(seeds, f, exact_field);
      }
      const double paper = m == Method::h_scan        ? row.paper_h_ms
                           : m == Method::hv_scan     ? row.paper_hv_ms
                           : m == Method::brute_force ? row.paper_brute_ms
                                                      : -1;
      const std::string warm_txt =
          warm_ms < 0 ? "—" : std::to_string(warm_ms).substr(0, std::to_string(warm_ms).find('.') + 2);
      const std::string warm_ns =
          warm_ms < 0 ? "—" : std::to_string(warm_ms * 1e6 / static_cast<double>(cells)).substr(0, 5);
      std::printf("| %lldx%lld | %d | %s | %.1f | %.2f | %s | %s | %.1f | %s | %lld | %.3f |\n", (long long)row.size,
                  (long long)row.size, row.seeds, std::string(to_string(m)).c_str(), med,
                  med * 1e6 / static_cast<double>(cells), warm_txt.c_str(), warm_ns.c_str(), med / exact_ms,
                  paper < 0 ? "—" : std::to_string(static_cast<int>(paper)).c_str(), (long long)v.wrong_cells,
                  v.max_error_cells);
      std::fflush(stdout);
    }
  }
  if (!strip_lines.empty()) std::printf("%s\n", strip_lines.c_str());
  return strips_differ ? 1 : 0;
}
