// A test-only daemon for the crash-safety tests (test_crash.py): exactly `rvoronoi serve`
// (rv::serve_main, the real Server, job store and rv::run_job) except that a job can be held at
// a chosen stage, so that the test can SIGKILL it there deterministically instead of racing a
// timer. This binary is built under tests/ only and never installed; the hook does not exist in
// `rvoronoi`, so no configuration or environment can enable it in production.
//
// usage: rv_crash_daemon --listen HOST:PORT --data-dir DIR [--config FILE]
// Environment:
//   RV_TEST_PAUSE_STAGE  "compute" or "write": the first progress report of that stage with a
//                        fraction > 0 holds the job. For "write" that is after the ownership
//                        raster is renamed into place and before the distance raster is begun.
//   RV_TEST_PAUSE_DIR    directory: on holding, the daemon creates <dir>/paused (containing the
//                        stage) and waits until <dir>/resume exists, at most 120 s.
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <thread>

#include "rv/job.hpp"
#include "rv/server.hpp"

namespace {

namespace fs = std::filesystem;

void hold(const fs::path& dir, const std::string& stage) {
  {
    std::ofstream marker(dir / "paused.tmp");
    marker << stage << "\n";
  }
  fs::rename(dir / "paused.tmp", dir / "paused");  // the test never reads a half-written marker
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(dir / "resume") && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

}  // namespace

int main(int argc, char** argv) {
  rv::ServeOptions options;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string opt = argv[i];
    if (opt == "--listen")
      options.listen = argv[i + 1];
    else if (opt == "--data-dir")
      options.data_dir = argv[i + 1];
    else if (opt == "--config")
      options.config_file = argv[i + 1];
    else {
      std::cerr << "rv_crash_daemon: unknown option " << opt << "\n";
      return 2;
    }
  }
  const char* stage_env = std::getenv("RV_TEST_PAUSE_STAGE");
  const char* dir_env = std::getenv("RV_TEST_PAUSE_DIR");
  const std::string pause_stage = stage_env ? stage_env : "";
  const fs::path pause_dir = dir_env ? dir_env : "";
  auto held = std::make_shared<std::atomic<bool>>(false);

  return rv::serve_main(options, [=](const rv::JobSpec& spec, const rv::JobLimits& limits, const rv::JobHooks& hooks) {
    rv::JobHooks wrapped = hooks;
    wrapped.progress = [=, inner = hooks.progress](const std::string& stage, double fraction) {
      // Engine threads report concurrently: only the first report of the stage holds.
      if (!pause_stage.empty() && stage == pause_stage && fraction > 0.0 && !held->exchange(true)) {
        hold(pause_dir, stage);
      }
      if (inner) inner(stage, fraction);
    };
    return rv::run_job(spec, limits, wrapped);
  });
}
