#include "rv/store_jobs.hpp"

#include <sqlite3.h>

#include <array>

#include "rv/error.hpp"

namespace rv {
namespace {

constexpr std::array<std::string_view, 5> kStatusNames = {"accepted", "running", "successful",
                                                          "failed", "dismissed"};

// RAII for one prepared statement; column/bind helpers keep the SQL call sites readable.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) {
      throw Error(ErrorKind::io, std::string("job store: ") + sqlite3_errmsg(db));
    }
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  void bind(int i, const std::string& text) {
    sqlite3_bind_text(stmt_, i, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
  }
  void bind(int i, int64_t value) { sqlite3_bind_int64(stmt_, i, value); }
  // SQLITE_ROW -> true, SQLITE_DONE -> false, anything else throws.
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw Error(rc == SQLITE_CONSTRAINT ? ErrorKind::internal : ErrorKind::io,
                std::string("job store: ") + sqlite3_errmsg(db_));
  }
  std::string text(int col) const {
    const auto* p = sqlite3_column_text(stmt_, col);
    return p ? std::string(reinterpret_cast<const char*>(p),
                           static_cast<size_t>(sqlite3_column_bytes(stmt_, col)))
             : std::string();
  }
  int64_t integer(int col) const { return sqlite3_column_int64(stmt_, col); }

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

constexpr const char* kColumns =
    "id, process_id, status, message, error_kind, progress, created, started, finished, updated, "
    "inputs, outputs, transmission, report, formats";

JobRecord read_row(const Statement& s) {
  JobRecord r;
  r.id = s.text(0);
  r.process_id = s.text(1);
  r.status = parse_job_status(s.text(2));
  r.message = s.text(3);
  r.error_kind = s.text(4);
  r.progress = static_cast<int>(s.integer(5));
  r.created = s.text(6);
  r.started = s.text(7);
  r.finished = s.text(8);
  r.updated = s.text(9);
  r.inputs = nlohmann::json::parse(s.text(10), nullptr, false);
  const auto outputs = nlohmann::json::parse(s.text(11), nullptr, false);
  if (outputs.is_array()) r.outputs = outputs.get<std::vector<std::string>>();
  const auto transmission = nlohmann::json::parse(s.text(12), nullptr, false);
  if (transmission.is_array()) r.transmission = transmission.get<std::vector<std::string>>();
  const std::string report = s.text(13);
  if (!report.empty()) r.report = nlohmann::json::parse(report, nullptr, false);
  const auto formats = nlohmann::json::parse(s.text(14), nullptr, false);
  if (formats.is_array()) r.formats = formats.get<std::vector<std::string>>();
  return r;
}

void bind_record(Statement& s, const JobRecord& r) {
  s.bind(1, r.id);
  s.bind(2, r.process_id);
  s.bind(3, std::string(to_string(r.status)));
  s.bind(4, r.message);
  s.bind(5, r.error_kind);
  s.bind(6, int64_t{r.progress});
  s.bind(7, r.created);
  s.bind(8, r.started);
  s.bind(9, r.finished);
  s.bind(10, r.updated);
  s.bind(11, r.inputs.dump());
  s.bind(12, nlohmann::json(r.outputs).dump());
  s.bind(13, nlohmann::json(r.transmission).dump());
  s.bind(14, r.report.is_null() ? std::string() : r.report.dump());
  s.bind(15, nlohmann::json(r.formats).dump());
}

}  // namespace

std::string_view to_string(JobStatus status) { return kStatusNames[static_cast<size_t>(status)]; }

JobStatus parse_job_status(std::string_view name) {
  for (size_t i = 0; i < kStatusNames.size(); ++i) {
    if (kStatusNames[i] == name) return static_cast<JobStatus>(i);
  }
  throw Error(ErrorKind::invalid_argument, "unknown job status '" + std::string(name) + "'");
}

JobStore::JobStore(const std::filesystem::path& db_path) {
  if (sqlite3_open_v2(db_path.c_str(), &db_,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                      nullptr) != SQLITE_OK) {
    const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw Error(ErrorKind::io, "job store '" + db_path.string() + "': " + why);
  }
  sqlite3_busy_timeout(db_, 5000);
  try {
    // WAL: readers never block the writer; synchronous=NORMAL in WAL mode keeps the database
    // consistent after a crash (a power cut may lose the last transactions, a SIGKILL loses
    // nothing).
    exec("PRAGMA journal_mode=WAL");
    exec("PRAGMA synchronous=NORMAL");
    exec(
        "CREATE TABLE IF NOT EXISTS jobs ("
        " id TEXT PRIMARY KEY, process_id TEXT NOT NULL, status TEXT NOT NULL,"
        " message TEXT NOT NULL, error_kind TEXT NOT NULL, progress INTEGER NOT NULL,"
        " created TEXT NOT NULL, started TEXT NOT NULL, finished TEXT NOT NULL,"
        " updated TEXT NOT NULL, inputs TEXT NOT NULL, outputs TEXT NOT NULL,"
        " transmission TEXT NOT NULL, report TEXT NOT NULL, formats TEXT NOT NULL DEFAULT '[]')");
    exec("CREATE INDEX IF NOT EXISTS jobs_created ON jobs(created)");
    // Databases written before the output formats were recorded lack the column; their jobs
    // read back with no formats (each output's default, which is all they could have had).
    bool has_formats = false;
    {
      Statement info(db_, "PRAGMA table_info(jobs)");
      while (info.step()) has_formats = has_formats || info.text(1) == "formats";
    }
    if (!has_formats) exec("ALTER TABLE jobs ADD COLUMN formats TEXT NOT NULL DEFAULT '[]'");
  } catch (...) {
    sqlite3_close(db_);
    throw;
  }
}

JobStore::~JobStore() { sqlite3_close(db_); }

void JobStore::exec(const char* sql) const {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string why = err ? err : "unknown error";
    sqlite3_free(err);
    throw Error(ErrorKind::io, "job store: " + why);
  }
}

void JobStore::insert(const JobRecord& job) {
  std::lock_guard lock(mutex_);
  Statement s(db_, (std::string("INSERT INTO jobs (") + kColumns +
                    ") VALUES (?1,?2,?3,?4,?5,?6,?7,?8,?9,?10,?11,?12,?13,?14,?15)").c_str());
  bind_record(s, job);
  s.step();
}

void JobStore::update(const JobRecord& job) {
  std::lock_guard lock(mutex_);
  Statement s(db_,
              "UPDATE jobs SET process_id=?2, status=?3, message=?4, error_kind=?5, progress=?6,"
              " created=?7, started=?8, finished=?9, updated=?10, inputs=?11, outputs=?12,"
              " transmission=?13, report=?14, formats=?15 WHERE id=?1");
  bind_record(s, job);
  s.step();
}

std::optional<JobRecord> JobStore::get(const std::string& id) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, (std::string("SELECT ") + kColumns + " FROM jobs WHERE id=?1").c_str());
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return read_row(s);
}

std::vector<JobRecord> JobStore::list(int limit, int offset, const std::vector<JobStatus>& status) const {
  std::string sql = std::string("SELECT ") + kColumns + " FROM jobs";
  if (!status.empty()) {
    sql += " WHERE status IN (";
    for (size_t i = 0; i < status.size(); ++i) sql += i ? ",?" : "?";
    sql += ")";
  }
  sql += " ORDER BY created DESC, id LIMIT ? OFFSET ?";
  std::lock_guard lock(mutex_);
  Statement s(db_, sql.c_str());
  int i = 1;
  for (JobStatus st : status) s.bind(i++, std::string(to_string(st)));
  s.bind(i++, int64_t{limit});
  s.bind(i++, int64_t{offset});
  std::vector<JobRecord> out;
  while (s.step()) out.push_back(read_row(s));
  return out;
}

std::vector<std::string> JobStore::fail_interrupted(const std::string& message, const std::string& now) {
  std::lock_guard lock(mutex_);
  std::vector<std::string> ids;
  {
    Statement s(db_, "SELECT id FROM jobs WHERE status IN ('accepted','running')");
    while (s.step()) ids.push_back(s.text(0));
  }
  Statement u(db_,
              "UPDATE jobs SET status='failed', message=?1, error_kind='internal', finished=?2,"
              " updated=?2 WHERE status IN ('accepted','running')");
  u.bind(1, message);
  u.bind(2, now);
  u.step();
  return ids;
}

}  // namespace rv
