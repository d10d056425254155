#include <pthread.h>
#include <signal.h>

#include <iostream>

#include "runtime/server_util.hpp"
#include "rv/error_map.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/job.hpp"
#include "rv/server.hpp"

namespace rv {

int serve_main(const ServeOptions& options) {
  return serve_main(options, [](const JobSpec& spec, const JobLimits& limits, const JobHooks& hooks) {
    return run_job(spec, limits, hooks);
  });
}

int serve_main(const ServeOptions& options, JobRunner runner) {
  try {
    ServerConfig config = options.config_file.empty() ? ServerConfig{} : load_server_config(options.config_file);
    if (!options.listen.empty()) parse_listen(options.listen, config);
    if (!options.data_dir.empty()) config.data_dir = options.data_dir;
    // Before any thread: what the allocator keeps of freed memory (ServerConfig::retained_free_bytes;
    // the "listening" line reports it).
    apply_allocator_settings(config);
    gdal_init();

    // SIGTERM/SIGINT are blocked in every thread (the server's threads inherit the mask) and
    // taken synchronously here: no async-signal-safety concerns, and the shutdown runs on an
    // ordinary thread.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);
    // A client vanishing mid-response must cost an error code, not the process.
    signal(SIGPIPE, SIG_IGN);
    // A result file over the process's file size limit (RLIMIT_FSIZE, e.g. ulimit -f in a
    // container) must fail that job with EFBIG, not kill the daemon with SIGXFSZ.
    signal(SIGXFSZ, SIG_IGN);

    Server server(config, std::move(runner));
    server.start();
    int received = 0;
    sigwait(&signals, &received);
    daemon::log_line("{\"time\":\"" + daemon::now_rfc3339() + "\",\"event\":\"signal\",\"signal\":\"" +
                     (received == SIGTERM ? "SIGTERM" : "SIGINT") +
                     "\",\"action\":\"graceful shutdown: no new connections, " +
                     (config.store.shared() ? "queued jobs stay in the shared queue, running jobs get "
                                            : "queued jobs failed, running jobs get ") +
                     nlohmann::json(config.jobs.shutdown_grace_s).dump() + " s, then are cancelled" +
                     (config.store.shared() ? " and queued again" : "") + "\"}");
    server.stop();
    return 0;
  } catch (const Error& e) {
    std::cerr << "rvoronoi serve: " << e.what() << std::endl;
    return error_info(e.kind()).exit_code;
  } catch (const std::exception& e) {
    std::cerr << "rvoronoi serve: " << e.what() << std::endl;
    return error_info(ErrorKind::internal).exit_code;
  }
}

}  // namespace rv
