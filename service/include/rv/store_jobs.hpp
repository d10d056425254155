// The persistent job store: jobs, their parameters, status and results, in one SQLite database
// (WAL mode) under the data directory. Survives restarts and SIGKILL: every state change is a
// committed transaction before it is visible over HTTP. A database of an earlier build is
// migrated in place when opened (columns added with the defaults its jobs had: no recorded
// formats, the principal "anonymous", no cells).
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
  // Who submitted it (auth/principal.hpp): only it and the admins see it. Jobs of a server
  // without authentication, and jobs stored before principals existed, are "anonymous"'s.
  std::string principal = "anonymous";
  // The grid's cells, once known (at submission when the extent is given, else once planned);
  // what the job counts against its principal's hourly allowance. 0 = not known.
  int64_t cells = 0;
  // A shared store's jobs: where the successful attempt published its files, relative to the
  // results location ("<id>/<attempt>"); "" = the job's directory (the SQLite store).
  std::string results;
};

// What one job charged its principal: for the hourly allowance, restored at start.
struct CellCharge {
  std::string principal;
  std::string created;  // RFC 3339
  int64_t cells = 0;
};

// What the API reads of the jobs, whichever store keeps them (this SQLite store, or the shared
// PostgreSQL store of service/src/store/store_postgres.hpp).
class JobRecords {
 public:
  virtual ~JobRecords() = default;
  virtual std::optional<JobRecord> get(const std::string& id) const = 0;
  // Newest first; `status` empty = any; `principal` empty = anyone's.
  virtual std::vector<JobRecord> list(int limit, int offset, const std::vector<JobStatus>& status = {},
                                      const std::string& principal = "") const = 0;
  // The jobs created at or after `since` (RFC 3339) that charged cells (not those refused over
  // the allowance once planned).
  virtual std::vector<CellCharge> charges_since(const std::string& since) const = 0;
  // How many jobs each principal owns, for the startup's account of the store.
  virtual std::vector<std::pair<std::string, int64_t>> count_by_principal() const = 0;
};

class JobStore final : public JobRecords {
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
  std::optional<JobRecord> get(const std::string& id) const override;
  std::vector<JobRecord> list(int limit, int offset, const std::vector<JobStatus>& status = {},
                              const std::string& principal = "") const override;
  std::vector<CellCharge> charges_since(const std::string& since) const override;
  std::vector<std::pair<std::string, int64_t>> count_by_principal() const override;

  // At startup: every job still accepted or running belonged to a process that is gone (its
  // inputs lived in memory). Marks them failed with `message`; returns their ids.
  std::vector<std::string> fail_interrupted(const std::string& message, const std::string& now);

 private:
  void exec(const char* sql) const;
  sqlite3* db_ = nullptr;
  mutable std::mutex mutex_;
};

}  // namespace rv
