// The command line: `rvoronoi compute | validate | serve`. Parses arguments into the façade's
// typed JobSpec, runs it, and translates rv::Error into an exit code through error_info().
#include "rv/cli.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <mutex>
#include <random>
#include <sstream>
#include <string_view>

#include "rv/engine/validate.hpp"
#include "rv/error_map.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/job.hpp"
#include "rv/json_text.hpp"
#include "rv/options.hpp"
#include "rv/server.hpp"
#include "rv/version.hpp"

namespace rv {
namespace {

constexpr const char* kUsageHead =
    R"(rvoronoi — raster Voronoi diagrams (ownership and distance) for GIS

usage:
  rvoronoi compute SEEDS... --resolution R [--ownership OWN.tif] [outputs] [options]   (one output at least)
  rvoronoi validate SEEDS... --resolution R [--methods M,M...] [grid options]
  rvoronoi validate --random-seeds N --size W H [--trials T] [--methods M,M...] [--seed S]
                    [--buckets A,B]
  rvoronoi serve [--listen HOST:PORT] [--data-dir DIR] [--config FILE]
  rvoronoi --version | --help
)";

// The sections of --help: the option table's (rv/options.hpp), then the CLI's own.
struct HelpSection {
  const char* section;
  const char* heading;
};
constexpr HelpSection kHelpSections[] = {
    {"seeds", "seeds (any vector format GDAL reads; .zip shapefiles too):"},
    {"grid", "grid:"},
    {"computation", "computation:"},
    {"outputs", "outputs:"},
    {"deliverables", "maritime deliverables (exact: vertices placed on the equidistance locus, see README):"},
};

// The CLI's own options (not job options), in --help's layout: a heading, then each option.
struct CliOption {
  const char* heading;  // printed when it differs from the previous option's
  const char* head;     // the flag and its value
  const char* help;
};
constexpr CliOption kCliOptions[] = {
    {"other:", "--quiet", "no progress bar"},
    {"validate:", "--methods M,M...", "methods compared with brute force (default: exact,hv-scan,h-scan)"},
    {"validate:", "--random-seeds N", "the paper's Table 2: N random point seeds on a --size W H grid"},
    {"validate:", "--size W H", "grid of W x H unit cells for --random-seeds"},
    {"validate:", "--trials T", "random trials (default 100)"},
    {"validate:", "--seed S", "random seed of the first trial (default 1)"},
    {"validate:", "--buckets A,B", "Table 2's error buckets in cells (default 1,3)"},
};

std::string usage() {
  std::string out = kUsageHead;
  for (const HelpSection& h : kHelpSections) out += std::string("\n") + h.heading + "\n" + options_help(h.section);
  out += "\n";
  const char* heading = "";
  for (const CliOption& o : kCliOptions) {
    if (std::string_view(o.heading) != heading) out += std::string(heading = o.heading) + "\n";
    const std::string head = std::string("  ") + o.head;
    out += head + std::string(head.size() < 26 ? 26 - head.size() : 1, ' ') + o.help + "\n";
  }
  return out;
}

// `rvoronoi serve`'s options (cmd_serve parses them; the configuration file has the rest). Only the
// man page describes them; --help shows them in its usage lines.
constexpr CliOption kServeOptions[] = {
    {"serve:", "--listen HOST:PORT", "address and port to listen on; overrides the configuration's listen"},
    {"serve:", "--data-dir DIR", "job store (SQLite) and result files; overrides the configuration's data_dir"},
    {"serve:", "--config FILE",
     "the daemon's JSON configuration, read once at startup; every key is optional and an unknown key is an "
     "error (the Debian package's is /etc/rvoronoi/serve.json)"},
};

// Text as roff reads it: backslashes and minus signs escaped, no line taken for a request.
std::string roff(std::string_view text) {
  std::string out;
  for (char c : text) {
    if (c == '\\')
      out += "\\e";
    else if (c == '-')
      out += "\\-";
    else
      out += c;
  }
  if (!out.empty() && (out[0] == '.' || out[0] == '\'')) out.insert(0, "\\&");
  return out;
}

// An option's entry: the flag in bold, its value in italics, the help below.
std::string roff_option(std::string_view head, std::string_view help) {
  const size_t space = head.find(' ');
  std::string out = ".TP\n\\fB" + roff(head.substr(0, space)) + "\\fR";
  if (space != std::string_view::npos) out += " \\fI" + roff(head.substr(space + 1)) + "\\fR";
  return out + "\n" + roff(help) + "\n";
}

// The man page rvoronoi(1) (the hidden `rvoronoi --help-man`; the build writes rvoronoi.1 from it):
// the same usage lines, option table and CLI options as --help, and the exit codes of the error
// table.
std::string man_page() {
  const std::string_view head = kUsageHead;
  const std::string_view name = head.substr(0, head.find('\n'));
  const size_t dash = name.find(" \u2014 ");
  std::string out = ".TH RVORONOI 1 \"\" \"rvoronoi " + std::string(kVersion) + "\" \"User Commands\"\n";
  out += ".SH NAME\nrvoronoi \\- " + roff(name.substr(dash + std::string_view(" \u2014 ").size())) + "\n";
  out += ".SH SYNOPSIS\n.nf\n";
  std::string_view lines = head.substr(head.find("usage:\n") + 7);
  while (!lines.empty()) {
    const size_t end = lines.find('\n');
    out += roff(lines.substr(2, end - 2)) + "\n";
    lines.remove_prefix(end + 1);
  }
  out +=
      ".fi\n.SH DESCRIPTION\n"
      "For every cell of a grid, the owner of the nearest seed and the distance to it; seeds are points, "
      "lines and polygons, each belonging to an owner.\n"
      ".B compute\nwrites the rasters and the maritime deliverables,\n"
      ".B validate\ncompares methods with brute force, and\n"
      ".B serve\nruns the OGC API \\- Processes daemon.\n"
      ".SH OPTIONS\n";
  for (const HelpSection& h : kHelpSections) {
    out += ".SS \"" + roff(h.heading) + "\"\n";
    for (const OptionSpec& o : job_options()) {
      if (o.section != h.section || o.flag.empty()) continue;
      std::string help(o.help);
      if (!o.default_text.empty() && o.type != OptionType::flag)
        help += " (default: " + std::string(o.default_text) + ")";
      out += roff_option("--" + std::string(o.flag) + (o.metavar.empty() ? "" : " " + std::string(o.metavar)), help);
    }
  }
  const char* heading = "";
  auto cli_options = [&](const auto& table) {
    for (const CliOption& o : table) {
      if (std::string_view(o.heading) != heading) out += ".SS \"" + roff(heading = o.heading) + "\"\n";
      out += roff_option(o.head, o.help);
    }
  };
  cli_options(kCliOptions);
  cli_options(kServeOptions);
  out += ".SH EXIT STATUS\n0 on success; otherwise the kind of error:\n";
  for (int k = 0; k <= static_cast<int>(ErrorKind::internal); ++k) {
    const ErrorInfo& e = error_info(static_cast<ErrorKind>(k));
    out += ".TP\n.B " + std::to_string(e.exit_code) + "\n" + roff(e.title) + "\n";
  }
  out +=
      ".SH FILES\n"
      ".TP\n.I /etc/rvoronoi/serve.json\n"
      "the packaged daemon's configuration (rvoronoi.service runs \\fBrvoronoi serve \\-\\-config\\fR with it)\n"
      ".TP\n.I /var/lib/rvoronoi\n"
      "the packaged daemon's job store and results\n"
      ".TP\n.I /usr/share/doc/rvoronoi/examples/serve\\-config.example.json\n"
      "every configuration key with its default\n"
      ".SH SEE ALSO\n"
      ".BR gdalinfo (1),\n"
      ".BR systemctl (1)\n";
  return out;
}

class Args {
 public:
  Args(int argc, char** argv, int first) {
    for (int i = first; i < argc; ++i) items_.emplace_back(argv[i]);
  }
  bool done() const { return pos_ >= items_.size(); }
  const std::string& peek() const { return items_[pos_]; }
  std::string next() { return items_[pos_++]; }
  std::string value(const std::string& opt) {
    if (done()) throw Error(ErrorKind::invalid_argument, opt + " needs a value");
    return next();
  }
  int64_t integer(const std::string& opt) {
    const std::string v = value(opt);
    char* end = nullptr;
    const long long n = std::strtoll(v.c_str(), &end, 10);
    if (end == v.c_str() || *end != '\0')
      throw Error(ErrorKind::invalid_argument, opt + ": '" + v + "' is not an integer");
    return n;
  }

 private:
  std::vector<std::string> items_;
  size_t pos_ = 0;
};

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, sep);)
    if (!item.empty()) out.push_back(item);
  return out;
}

// A one-line progress bar on stderr, redrawn when the percentage changes.
class ProgressBar {
 public:
  explicit ProgressBar(bool enabled) : enabled_(enabled && ::isatty(STDERR_FILENO)) {}
  ~ProgressBar() { finish(); }
  void update(const std::string& stage, double fraction) {
    if (!enabled_) return;
    std::lock_guard lock(mutex_);
    const int percent = static_cast<int>(fraction * 100.0 + 0.5);
    if (stage == stage_ && percent == percent_) return;
    stage_ = stage;
    percent_ = percent;
    const int filled = percent * 30 / 100;
    std::fprintf(stderr, "\r%-8s [%s%s] %3d%%", stage.c_str(), std::string(filled, '#').c_str(),
                 std::string(30 - filled, ' ').c_str(), percent);
    std::fflush(stderr);
    drawn_ = true;
  }
  void finish() {
    if (drawn_) std::fprintf(stderr, "\r%60s\r", "");
    drawn_ = false;
  }

 private:
  bool enabled_;
  bool drawn_ = false;
  std::string stage_;
  int percent_ = -1;
  std::mutex mutex_;
};

struct CommonOptions {
  JobSpec spec;
  std::vector<Method> methods;  // validate
  bool quiet = false;
  int64_t random_seeds = 0, size_w = 0, size_h = 0, trials = 100;
  uint64_t rng_seed = 1;
  std::array<double, 2> buckets{1.0, 3.0};  // Table 2 bucket limits, cells
};

CommonOptions parse(Args& args, bool validate_mode) {
  CommonOptions o;
  while (!args.done()) {
    const std::string a = args.next();
    if (a.rfind("--", 0) != 0) {
      o.spec.seeds.paths.push_back(a);
      continue;
    }
    // The job's options come from the one table; what follows is the CLI's own.
    if (const OptionSpec* option = find_flag(std::string_view(a).substr(2))) {
      std::vector<std::string> words;
      for (int i = 0; i < option_arity(*option); ++i) words.push_back(args.value(a));
      option->apply(o.spec, parse_cli_value(*option, words));
    } else if (a == "--quiet") {
      o.quiet = true;
    } else if (validate_mode && a == "--methods") {
      for (const auto& m : split(args.value(a), ',')) o.methods.push_back(parse_method(m));
    } else if (validate_mode && a == "--random-seeds") {
      o.random_seeds = args.integer(a);
    } else if (validate_mode && a == "--size") {
      o.size_w = args.integer(a);
      o.size_h = args.integer(a);
    } else if (validate_mode && a == "--trials") {
      o.trials = args.integer(a);
    } else if (validate_mode && a == "--seed") {
      o.rng_seed = static_cast<uint64_t>(args.integer(a));
    } else if (validate_mode && a == "--buckets") {
      const auto v = split(args.value(a), ',');
      char* e1 = nullptr;
      char* e2 = nullptr;
      if (v.size() == 2) o.buckets = {std::strtod(v[0].c_str(), &e1), std::strtod(v[1].c_str(), &e2)};
      if (v.size() != 2 || *e1 || *e2 || !(o.buckets[0] > 0 && o.buckets[1] > o.buckets[0]))
        throw Error(ErrorKind::invalid_argument, "--buckets: expected two increasing limits in cells, e.g. 1,3");
    } else {
      throw Error(ErrorKind::invalid_argument, "unknown option " + quote_input(a) + " (see rvoronoi --help)");
    }
  }
  return o;
}

int cmd_compute(Args& args) {
  CommonOptions o = parse(args, false);
  if (o.spec.seeds.paths.empty()) throw Error(ErrorKind::invalid_argument, "compute: no seed file given");
  const OutputRequest& out = o.spec.outputs;
  if (out.ownership.empty() && out.distance.empty() && out.nearest_feature.empty() && out.via.empty() &&
      !out.any_deliverable())
    throw Error(ErrorKind::invalid_argument,
                "compute: nothing to write: give --ownership FILE.tif, --distance FILE.tif, --nearest-feature "
                "FILE.tif, --via FILE.tif or a deliverable (--boundaries, --tripoints, --limits, --regions, "
                "--margin-raster, --preview)");
  ProgressBar bar(!o.quiet);
  JobHooks hooks;
  hooks.progress = [&](const std::string& stage, double f) { bar.update(stage, f); };
  const JobResult r = run_job(o.spec, {}, hooks);
  bar.finish();
  const auto& g = r.report["grid"];
  std::cout << "rvoronoi: " << g["width"] << "x" << g["height"] << " cells, method "
            << r.report["method"].get<std::string>() << ", compute " << r.report["timings_s"]["compute"].get<double>()
            << " s\n";
  if (r.report.contains("validation")) std::cout << "validation: " << json_text(r.report["validation"]) << "\n";
  for (const auto& w : r.report["seeds"]["warnings"])
    std::cerr << "warning: " << valid_utf8(w.get<std::string>()) << "\n";
  for (const std::string& f : r.files) std::cout << "wrote " << f << "\n";
  return 0;
}

// `rvoronoi serve`: the daemon (service/src/daemon, rv/server.hpp).
int cmd_serve(Args& args) {
  ServeOptions o;
  while (!args.done()) {
    const std::string opt = args.next();
    if (opt == "--listen")
      o.listen = args.value(opt);
    else if (opt == "--data-dir")
      o.data_dir = args.value(opt);
    else if (opt == "--config")
      o.config_file = args.value(opt);
    else
      throw Error(ErrorKind::invalid_argument, "serve: unknown option '" + opt + "'");
  }
  return serve_main(o);
}

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Distances (max_error, each example's error) in output units: `to_output` per metric unit.
nlohmann::json stats_json(const ValidationStats& v, double to_output) {
  nlohmann::json examples = nlohmann::json::array();
  for (const WrongCell& w : v.examples)
    examples.push_back({{"col", w.col},
                        {"row", w.row},
                        {"site", w.site},
                        {"nearest_site", w.reference},
                        {"error", w.error * to_output}});
  return {{"cells", v.cells},
          {"wrong_cells", v.wrong_cells},
          {"wrong_owner_cells", v.wrong_owner_cells},
          {"tie_cells", v.tie_cells},
          {"nodata_mismatch", v.nodata_mismatch},
          {"max_error", v.max_error * to_output},
          {"max_error_cells", v.max_error_cells},
          {"wrong_examples", examples}};
}

// The paper's Table 2: random point seeds on a W x H grid of unit cells, T trials; the largest
// Δd of each trial counted in buckets [0, A], (A, B], > B cells (the paper uses A = 1 and
// B = 3, 5, 10 for its 100², 300², 1000² grids).
int random_trials(const CommonOptions& o) {
  if (o.size_w <= 0 || o.size_h <= 0) throw Error(ErrorKind::invalid_argument, "--size W H must be positive");
  if (o.random_seeds <= 0) throw Error(ErrorKind::invalid_argument, "--random-seeds must be positive");
  if (o.trials <= 0) throw Error(ErrorKind::invalid_argument, "--trials must be positive");
  std::vector<Method> methods = o.methods.empty() ? std::vector<Method>{Method::h_scan, Method::hv_scan} : o.methods;
  GridSpec g;
  g.xmin = 0;
  g.ymax = static_cast<double>(o.size_h);
  g.res = 1;
  g.width = o.size_w;
  g.height = o.size_h;
  struct Tally {
    int64_t le1 = 0, le3 = 0, gt3 = 0, wrong_cells = 0;
    double worst = 0, seconds = 0;
  };
  std::vector<Tally> tally(methods.size());
  double brute_seconds = 0;
  std::mt19937_64 rng(o.rng_seed);
  std::uniform_real_distribution<double> ux(0.0, static_cast<double>(o.size_w)), uy(0.0, static_cast<double>(o.size_h));
  for (int64_t t = 0; t < o.trials; ++t) {
    SeedSet seeds;
    for (int64_t i = 0; i < o.random_seeds; ++i) {
      const int32_t f = seeds.add_feature(seeds.owner_code(std::to_string(i + 1)));
      seeds.add_point(f, {ux(rng), uy(rng)});
    }
    ComputeOptions co;
    co.threads = o.spec.threads;
    co.method = Method::brute_force;
    const NearestField ref = compute(seeds, g, co);
    brute_seconds += ref.seconds;
    for (size_t m = 0; m < methods.size(); ++m) {
      co.method = methods[m];
      const NearestField f = compute(seeds, g, co);
      const ValidationStats v = compare_fields(seeds, f, ref);
      Tally& k = tally[m];
      k.seconds += f.seconds;
      k.wrong_cells += v.wrong_cells;
      k.worst = std::max(k.worst, v.max_error_cells);
      if (v.max_error_cells <= o.buckets[0])
        ++k.le1;
      else if (v.max_error_cells <= o.buckets[1])
        ++k.le3;
      else
        ++k.gt3;
    }
  }
  nlohmann::json out;
  out["grid"] = {{"width", o.size_w}, {"height", o.size_h}};
  out["seeds"] = o.random_seeds;
  out["trials"] = o.trials;
  out["rng_seed"] = o.rng_seed;
  out["buckets_cells"] = {"0-" + fmt(o.buckets[0]), fmt(o.buckets[0]) + "-" + fmt(o.buckets[1]),
                          ">" + fmt(o.buckets[1])};
  out["brute_force_mean_seconds"] = brute_seconds / static_cast<double>(o.trials);
  for (size_t m = 0; m < methods.size(); ++m) {
    const Tally& k = tally[m];
    out["methods"][std::string(to_string(methods[m]))] = {{"trials_in_bucket", {k.le1, k.le3, k.gt3}},
                                                          {"worst_error_cells", k.worst},
                                                          {"wrong_cells_total", k.wrong_cells},
                                                          {"mean_seconds", k.seconds / static_cast<double>(o.trials)}};
  }
  std::cout << json_text(out, 2) << "\n";
  return 0;
}

int cmd_validate(Args& args) {
  CommonOptions o = parse(args, true);
  if (o.random_seeds > 0 || o.size_w > 0) return random_trials(o);
  if (o.spec.seeds.paths.empty()) throw Error(ErrorKind::invalid_argument, "validate: no seed file given");
  std::vector<Method> methods =
      o.methods.empty() ? std::vector<Method>{Method::exact, Method::hv_scan, Method::h_scan} : o.methods;
  // The set-up is the job's own first stage (read the seeds, plan the grid and the metric).
  const PreparedJob job = prepare_job(o.spec);
  const LoadedSeeds& loaded = job.loaded;
  const GridSpec& grid = job.grid;
  ComputeOptions co = job.compute;
  co.method = Method::brute_force;
  const NearestField ref = compute(loaded.seeds, grid, co);
  nlohmann::json out;
  out["grid"] = {{"width", grid.width}, {"height", grid.height}, {"resolution", grid.res}};
  out["metric"] = std::string(to_string(job.metric.kind));
  out["distance_units"] = job.unit;
  out["reference"] = {{"method", "brute-force"}, {"seconds", ref.seconds}};
  for (Method m : methods) {
    co.method = m;
    // A method this grid does not support yet (exact on a projected geodesic grid) is reported
    // as such instead of hiding the other methods' results.
    NearestField f;
    try {
      f = compute(loaded.seeds, grid, co);
    } catch (const Error& e) {
      if (e.kind() != ErrorKind::unsupported) throw;
      out["methods"][std::string(to_string(m))] = {{"unsupported", e.what()}};
      continue;
    }
    nlohmann::json j = stats_json(compare_fields(loaded.seeds, f, ref), job.to_output);
    j["seconds"] = f.seconds;
    out["methods"][std::string(to_string(m))] = j;
  }
  std::cout << json_text(out, 2) << "\n";
  return 0;
}

}  // namespace

int cli_main(int argc, char** argv) {
  try {
    bound_block_cache();
    if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h" ||
        std::string(argv[1]) == "help") {
      std::cout << usage();
      return argc < 2 ? 2 : 0;
    }
    if (std::string(argv[1]) == "--help-man") {  // hidden: the build's man page
      std::cout << man_page();
      return 0;
    }
    const std::string cmd = argv[1];
    if (cmd == "--version") {
      std::cout << "rvoronoi " << kVersion << "\n";
      return 0;
    }
    Args args(argc, argv, 2);
    if (cmd == "compute") return cmd_compute(args);
    if (cmd == "validate") return cmd_validate(args);
    if (cmd == "serve") return cmd_serve(args);
    throw Error(ErrorKind::invalid_argument, "unknown command '" + cmd + "' (see rvoronoi --help)");
  } catch (const Error& e) {
    // One line, valid UTF-8 whatever a file name or a GDAL message held (rv/field/text.hpp).
    std::cerr << "rvoronoi: error: " << valid_utf8(e.what()) << "\n";
    return error_info(e.kind()).exit_code;
  } catch (const std::bad_alloc&) {
    std::cerr << "rvoronoi: error: out of memory\n";
    return error_info(ErrorKind::too_large).exit_code;
  } catch (const std::exception& e) {
    std::cerr << "rvoronoi: internal error: " << valid_utf8(e.what()) << "\n";
    return error_info(ErrorKind::internal).exit_code;
  } catch (...) {
    std::cerr << "rvoronoi: internal error: unknown exception\n";
    return error_info(ErrorKind::internal).exit_code;
  }
}

}  // namespace rv
