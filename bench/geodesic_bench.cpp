// Planar vs geodesic: ns per cell of the exact method (and the hv scan) on the same seeds and
// the same grid of >= 1e6 cells. The planar run treats longitude/latitude degrees as plane
// coordinates: it is the speed reference only (its owners are not the right ones).
//
//   geodesic_bench [--size N] [--threads T] [--points P] [--coast-vertices V] [--no-scan]
// (--no-scan goes last, or anywhere as a flag of its own: it skips the hv-scan rows)
//
// Scenarios: P random point seeds, and two coastlines of V vertices each (many short geodesic
// edges, as real coastline data has) facing each other across a strait, near 55.5N.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

#include "rv/engine.hpp"
#include "rv/geodesic.hpp"
#include "rv/validate.hpp"

namespace {

struct Args {
  int64_t size = 1000;
  int threads = 1;
  int points = 100;
  int coast_vertices = 500;
  bool scans = true;  // --no-scan: the exact method only
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--no-scan") a.scans = false;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--no-scan") --i, ++i;
    const std::string k = argv[i];
    const long v = std::strtol(argv[i + 1], nullptr, 10);
    if (k == "--size") a.size = v;
    else if (k == "--threads") a.threads = static_cast<int>(v);
    else if (k == "--points") a.points = static_cast<int>(v);
    else if (k == "--coast-vertices") a.coast_vertices = static_cast<int>(v);
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      std::exit(2);
    }
  }
  return a;
}

double run(const rv::SeedSet& s, const rv::GridSpec& g, rv::Method m, rv::MetricSpec metric, int threads,
           rv::NearestField* keep = nullptr) {
  rv::ComputeOptions o;
  o.method = m;
  o.threads = threads;
  o.metric = metric;
  rv::NearestField f = rv::compute(s, g, o);
  const double ns = f.seconds * 1e9 / static_cast<double>(g.cell_count());
  if (keep) *keep = std::move(f);
  return ns;
}

void scenario(const char* name, const rv::SeedSet& s, const rv::GridSpec& g, int threads, bool scans) {
  rv::MetricSpec geodesic;
  geodesic.kind = rv::MetricSpec::geodesic;
  const double planar_ns = run(s, g, rv::Method::exact, {}, threads);
  rv::geodesic_segment_counters() = {};
  rv::NearestField exact;
  const double geo_ns = run(s, g, rv::Method::exact, geodesic, threads, &exact);
  const rv::GeodesicSegmentCounters counters = rv::geodesic_segment_counters();
  rv::NearestField hv;
  const double planar_hv_ns = scans ? run(s, g, rv::Method::hv_scan, {}, threads) : 0.0;
  const double geo_hv_ns = scans ? run(s, g, rv::Method::hv_scan, geodesic, threads, &hv) : 0.0;
  const rv::ValidationStats st = scans ? rv::compare_fields(s, hv, exact) : rv::ValidationStats{};
  std::printf("%-12s %lldx%lld cells, %lld geometric sites, %d thread(s)\n", name,
              static_cast<long long>(g.width), static_cast<long long>(g.height),
              static_cast<long long>(s.geometric_site_count()), threads);
  std::printf("  exact    planar %8.1f ns/cell   geodesic %8.1f ns/cell   ratio %6.1f\n", planar_ns, geo_ns,
              geo_ns / planar_ns);
  if (scans)
    std::printf("  hv-scan  planar %8.1f ns/cell   geodesic %8.1f ns/cell   ratio %6.1f\n", planar_hv_ns,
                geo_hv_ns, geo_hv_ns / planar_hv_ns);
  if (counters.calls > 0)
    std::printf("  segment searches %lld, inverse problems per search %.2f (calling thread only)\n",
                static_cast<long long>(counters.calls),
                static_cast<double>(counters.evaluations) / static_cast<double>(counters.calls));
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

  {
    rv::SeedSet s;
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> lon(g.xmin, g.xmax()), lat(g.ymin(), g.ymax);
    for (int i = 0; i < a.points; ++i) s.add_point(s.add_feature(s.owner_code(std::to_string(i % 7))), {lon(rng), lat(rng)});
    scenario("points", s, g, a.threads, a.scans);
  }
  {
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
    scenario("coastlines", s, g, a.threads, a.scans);
  }
  return 0;
}
