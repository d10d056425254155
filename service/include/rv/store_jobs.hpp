// The persistent job store: jobs, their parameters, status and results, in one SQLite database
// (WAL mode) under the data directory. Survives restarts and SIGKILL: every state change is a
// committed transaction before it is visible over HTTP.
//
// Thread safety: all member functions may be called from any thread (one connection, guarded
// by a mutex; the calls are short).
#pragma once

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

struct sqlite3;

namespace rv {

enum class JobStatus { accepted, running, successful, failed, dismissed };

std::string_view to_string(JobStatus status);
// Throws rv::Error(invalid_argument) for an unknown name.
JobStatus parse_job_status(std::string_view name);

struct JobRecord {
  std::string id;          // 32 lower-case hex digits (128 random bits)
  std::string process_id;  // "voronoi"
  JobStatus status = JobStatus::accepted;
  std::string message;     // human-readable; the error message when failed
  std::string error_kind;  // rv::ErrorKind name when failed (to answer /results with it)
  int progress = 0;        // 0..100
  // RFC 3339 UTC timestamps ("2026-01-02T03:04:05.678Z"); empty = not yet.
  std::string created, started, finished, updated;
  nlohmann::json inputs = nlohmann::json::object();  // the inputs as received (uploads summarised)
  std::vector<std::string> outputs;                  // output ids requested (ownership, ...)
  std::vector<std::string> transmission;             // per output: "value" or "reference"
  // Per output: the media type its file was written as; may be shorter than `outputs` (jobs
  // stored before formats were recorded), a missing entry meaning the output's default.
  std::vector<std::string> formats;
  nlohmann::json report;  // the job report, once successful
};

class JobStore {
 public:
  // Opens (creating if needed) the database file. Throws rv::Error(io).
  explicit JobStore(const std::filesystem::path& db_path);
  ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  // Inserts a new job. Throws rv::Error(io), rv::Error(internal) on a duplicate id.
  void insert(const JobRecord& job);
  // Writes every mutable field of an existing job.
  void update(const JobRecord& job);
  std::optional<JobRecord> get(const std::string& id) const;
  // Newest first; `status` empty = any.
  std::vector<JobRecord> list(int limit, int offset, const std::vector<JobStatus>& status = {}) const;

  // At startup: every job still accepted or running belonged to a process that is gone (its
  // inputs lived in memory). Marks them failed with `message`; returns their ids.
  std::vector<std::string> fail_interrupted(const std::string& message, const std::string& now);

 private:
  void exec(const char* sql) const;
  sqlite3* db_ = nullptr;
  mutable std::mutex mutex_;
};

}  // namespace rv
