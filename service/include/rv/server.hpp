// The REST daemon: OGC API - Processes 1.0 (Core, OGC process description, JSON, OAS 3.0,
// job list, dismiss) over HTTP/1.1, one process "voronoi" backed by run_job().
//
// Lifecycle: construct with a configuration and a job runner, start() (binds, opens the job
// store under data_dir, marks jobs left running by a previous process as failed, starts the
// network and worker threads), stop() (graceful: stops accepting connections, fails queued
// jobs, lets running jobs finish for jobs.shutdown_grace_s then cancels them, flushes the
// responses in flight, joins every thread).
//
// One server per data directory (a lock file refuses a second). A Server is started at most
// once; to restart, construct a new one on the same data directory.
// Thread safety: start()/stop()/port() from one controlling thread. The server's own threads
// never call back into the caller except through the JobRunner.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "rv/job.hpp"
#include "rv/server_config.hpp"

namespace rv {

// What the server calls to compute a job (rv::run_job in production; tests may substitute a
// runner that writes known files). Called from worker threads, concurrently.
using JobRunner = std::function<JobResult(const JobSpec&, const JobLimits&, const JobHooks&)>;

class Server {
 public:
  Server(ServerConfig config, JobRunner runner);
  ~Server();  // stop()s if running
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Throws rv::Error(io) when the address cannot be bound or the store cannot be opened.
  void start();
  // The bound port (the ephemeral one when config.port is 0). Valid after start().
  unsigned short port() const;
  // Idempotent. Blocks until every thread has finished (at most shutdown_grace_s + a second
  // after the last running job reacts to cancellation).
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// `rvoronoi serve`: command-line values override the config file's (empty = not given).
struct ServeOptions {
  std::string listen;  // "host:port"
  std::string data_dir;
  std::string config_file;  // JSON, see server_config.hpp
};

// Runs the daemon with rv::run_job until SIGTERM or SIGINT, then stops it gracefully.
// Returns the process exit status (error_info(kind).exit_code on a startup failure, with the
// message on stderr).
int serve_main(const ServeOptions& options);
// The same with another job runner. Only the crash-safety tests use it (their test-only daemon,
// tests/service/daemon/crash_daemon.cpp, pauses jobs at chosen stages); `rvoronoi serve` never does.
int serve_main(const ServeOptions& options, JobRunner runner);

}  // namespace rv
