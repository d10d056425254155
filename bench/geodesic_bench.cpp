// Planar vs geodesic: ns per cell of the exact method (and the hv scan) on the same seeds and
// the same grid of >= 1e6 cells. The planar run treats longitude/latitude degrees as plane
// coordinates: it is the speed reference only (its owners are not the right ones).
//
//   geodesic_bench [--size N] [--threads T] [--points P] [--coast-vertices V] [--repeats R]
//                  [--only points|coastlines] [--no-scan]
//                  [--seeds FILE --res DEG --extent XMIN YMIN XMAX YMAX]
// --seeds: a third scenario (or the only one with --only file) on real data, any vector file
// GDAL reads with longitude/latitude coordinates (e.g. the Oresund fixture), on the grid given.
// (--no-scan skips the hv-scan rows)
// Each exact run is repeated R times (default 1), alternating planar and geodesic, into result
// buffers warmed up by an untimed first run of each; the medians are printed, of wall time and
// of the process's CPU time (all threads: the work done, which other load on a shared machine
// disturbs less than the wall time).
//
// Scenarios: P random point seeds, and two coastlines of V vertices each (many short geodesic
// edges, as real coastline data has) facing each other across a strait, near 55.5N.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include <sys/resource.h>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

#include "rv/engine/engine.hpp"
#include "rv/engine/validate.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/geodesic/geodesic.hpp"

namespace {

struct Args {
  int64_t size = 1000;
  int threads = 1;
  int points = 100;
  int coast_vertices = 500;
  bool scans = true;  // --no-scan: the exact method only
  int repeats = 1;
  std::string only;   // one scenario (empty: all)
  std::string seeds;  // --seeds: a file scenario
  double res = 0.0, xmin = 0.0, ymin = 0.0, xmax = 0.0, ymax = 0.0;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--no-scan") {
      a.scans = false;
      continue;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "option %s needs a value\n", k.c_str());
      std::exit(2);
    }
    if (k == "--only") {
      a.only = argv[++i];
      if (a.only != "points" && a.only != "coastlines" && a.only != "file") {
        std::fprintf(stderr, "--only takes points, coastlines or file\n");
        std::exit(2);
      }
      continue;
    }
    if (k == "--seeds") {
      a.seeds = argv[++i];
      continue;
    }
    if (k == "--res") {
      a.res = std::atof(argv[++i]);
      continue;
    }
    if (k == "--extent") {
      if (i + 4 >= argc) {
        std::fprintf(stderr, "--extent takes XMIN YMIN XMAX YMAX\n");
        std::exit(2);
      }
      a.xmin = std::atof(argv[++i]);
      a.ymin = std::atof(argv[++i]);
      a.xmax = std::atof(argv[++i]);
      a.ymax = std::atof(argv[++i]);
      continue;
    }
    const long v = std::strtol(argv[++i], nullptr, 10);
    if (k == "--size")
      a.size = v;
    else if (k == "--threads")
      a.threads = static_cast<int>(v);
    else if (k == "--points")
      a.points = static_cast<int>(v);
    else if (k == "--coast-vertices")
      a.coast_vertices = static_cast<int>(v);
    else if (k == "--repeats")
      a.repeats = std::max(1, static_cast<int>(v));
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      std::exit(2);
    }
  }
  return a;
}

// The process's CPU time (user + system, all threads), seconds.
double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Timing {
  double wall_ns = 0.0, cpu_ns = 0.0;  // per cell
};

// One run into `into` (compute_into: its buffers are reused once they have the grid's size, so
// a warmed-up field measures the computation, not the kernel's zeroing of fresh pages).
Timing run(const rv::SeedSet& s, const rv::GridSpec& g, rv::Method m, rv::MetricSpec metric, int threads,
           rv::NearestField& into) {
  rv::ComputeOptions o;
  o.method = m;
  o.threads = threads;
  o.metric = metric;
  const double cpu0 = cpu_seconds();
  rv::compute_into(s, g, o, into);
  const double cells = static_cast<double>(g.cell_count());
  return Timing{into.seconds * 1e9 / cells, (cpu_seconds() - cpu0) * 1e9 / cells};
}

// FNV-1a over the field's site ids and distance bits, row by row: two builds that print the same
// digest for a scenario computed the same field, bit for bit (A/B runs of a change that must not
// alter results).
uint64_t digest(const rv::NearestField& f) {
  uint64_t h = 1469598103934665603ULL;
  auto mix = [&](const void* p, size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ULL;
  };
  for (int64_t r = 0; r < f.site.height(); ++r) {
    mix(f.site.row(r), static_cast<size_t>(f.site.width()) * sizeof(int32_t));
    mix(f.distance.row(r), static_cast<size_t>(f.distance.width()) * sizeof(float));
  }
  return h;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void scenario(const char* name, const rv::SeedSet& s, const rv::GridSpec& g, int threads, bool scans, int repeats) {
  rv::MetricSpec geodesic;
  geodesic.kind = rv::MetricSpec::geodesic;
  std::vector<double> planar_wall, planar_cpu, geo_wall, geo_cpu, ratio_wall, ratio_cpu;
  rv::NearestField planar, exact;
  rv::GeodesicSegmentCounters counters;
  // Untimed first runs fault the result buffers in: the timed ones reuse them (both metrics
  // alike), so page faults of fresh buffers, which vary a lot on a shared VM, stay out.
  run(s, g, rv::Method::exact, {}, threads, planar);
  run(s, g, rv::Method::exact, geodesic, threads, exact);
  for (int i = 0; i < repeats; ++i) {
    const Timing p = run(s, g, rv::Method::exact, {}, threads, planar);
    rv::geodesic_segment_counters() = {};
    const Timing q = run(s, g, rv::Method::exact, geodesic, threads, exact);
    counters = rv::geodesic_segment_counters();
    planar_wall.push_back(p.wall_ns);
    planar_cpu.push_back(p.cpu_ns);
    geo_wall.push_back(q.wall_ns);
    geo_cpu.push_back(q.cpu_ns);
    ratio_wall.push_back(q.wall_ns / p.wall_ns);  // each pair ran back to back
    ratio_cpu.push_back(q.cpu_ns / p.cpu_ns);
  }
  rv::NearestField hv;
  const double planar_hv_ns = scans ? run(s, g, rv::Method::hv_scan, {}, threads, hv).wall_ns : 0.0;
  const double geo_hv_ns = scans ? run(s, g, rv::Method::hv_scan, geodesic, threads, hv).wall_ns : 0.0;
  const rv::ValidationStats st = scans ? rv::compare_fields(s, hv, exact) : rv::ValidationStats{};
  std::printf("%-12s %lldx%lld cells, %lld geometric sites, %d thread(s)\n", name, static_cast<long long>(g.width),
              static_cast<long long>(g.height), static_cast<long long>(s.geometric_site_count()), threads);
  std::printf(
      "  exact    planar %8.2f ns/cell   geodesic %8.2f ns/cell   ratio %6.2f   (wall, median of "
      "%d)\n",
      median(planar_wall), median(geo_wall), median(ratio_wall), repeats);
  std::printf(
      "  exact    planar %8.2f ns/cell   geodesic %8.2f ns/cell   ratio %6.2f   (CPU time, all "
      "threads)\n",
      median(planar_cpu), median(geo_cpu), median(ratio_cpu));
  if (scans)
    std::printf("  hv-scan  planar %8.2f ns/cell   geodesic %8.2f ns/cell   ratio %6.2f\n", planar_hv_ns, geo_hv_ns,
                geo_hv_ns / planar_hv_ns);
  if (counters.calls > 0)
    std::printf("  segment searches %lld, inverse problems per search %.2f (calling thread only)\n",
                static_cast<long long>(counters.calls),
                static_cast<double>(counters.evaluations) / static_cast<double>(counters.calls));
  std::printf("  field digests: planar %016llx, geodesic %016llx\n", static_cast<unsigned long long>(digest(planar)),
              static_cast<unsigned long long>(digest(exact)));
  if (scans)
    std::printf("  geodesic hv-scan vs exact: %lld wrong cells, max error %.3f m (%.3f cells)\n",
                static_cast<long long>(st.wrong_cells), st.max_error, st.max_error_cells);
}

}  // namespace

int main(int argc, char** argv) {
  const Args a = parse(argc, argv);
  // 0.002 degrees (~220 m x 125 m at 55.5N): the Oresund test's resolution.
  const double res = 2.0 / static_cast<double>(a.size);
  rv::GridSpec g;
  g.xmin = 11.7;
  g.ymax = 56.5;
  g.res = res;
  g.width = a.size;
  g.height = a.size;

  if (a.only.empty() || a.only == "points") {
    rv::SeedSet s;
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> lon(g.xmin, g.xmax()), lat(g.ymin(), g.ymax);
    for (int i = 0; i < a.points; ++i)
      s.add_point(s.add_feature(s.owner_code(std::to_string(i % 7))), {lon(rng), lat(rng)});
    scenario("points", s, g, a.threads, a.scans, a.repeats);
  }
  if (a.only.empty() || a.only == "coastlines") {
    rv::SeedSet s;
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> wig(-0.002, 0.002);
    for (int side = 0; side < 2; ++side) {
      std::vector<rv::Vec2> line;
      const double lon0 = g.xmin + (side == 0 ? 0.6 : 1.4);
      for (int i = 0; i < a.coast_vertices; ++i) {
        const double t = static_cast<double>(i) / (a.coast_vertices - 1);
        line.push_back({lon0 + 0.08 * std::sin(t * 40.0) + wig(rng), g.ymin() - 0.1 + t * 2.2});
      }
      s.add_polyline(s.add_feature(s.owner_code(side == 0 ? "DK" : "SE")), line);
    }
    scenario("coastlines", s, g, a.threads, a.scans, a.repeats);
  }
  if (!a.seeds.empty() && (a.only.empty() || a.only == "file")) {
    if (!(a.res > 0.0) || !(a.xmax > a.xmin) || !(a.ymax > a.ymin)) {
      std::fprintf(stderr, "--seeds needs --res and --extent\n");
      return 2;
    }
    rv::SeedReadOptions read;
    read.paths = {a.seeds};
    const rv::LoadedSeeds loaded = rv::load_seeds(read);
    if (!loaded.crs.geographic) {
      std::fprintf(stderr, "%s: the seeds' CRS is not longitude/latitude\n", a.seeds.c_str());
      return 2;
    }
    rv::GridSpec f;
    f.xmin = a.xmin;
    f.ymax = a.ymax;
    f.res = a.res;
    f.width = static_cast<int64_t>(std::ceil((a.xmax - a.xmin) / a.res - 1e-9));
    f.height = static_cast<int64_t>(std::ceil((a.ymax - a.ymin) / a.res - 1e-9));
    scenario(a.seeds.c_str(), loaded.seeds, f, a.threads, a.scans, a.repeats);
  }
  return 0;
}
