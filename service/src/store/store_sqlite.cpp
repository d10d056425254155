#include "rv/store_jobs.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <array>
#include <set>

#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/json_text.hpp"
#include "store/job_columns.hpp"

namespace rv {
namespace {

constexpr std::array<std::string_view, 5> kStatusNames = {"accepted", "running", "successful", "failed", "dismissed"};

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
  // A text column as stored: bytes (SQLite does not check UTF-8).
  std::string text(int col) const {
    const auto* p = sqlite3_column_text(stmt_, col);
    return p ? std::string(reinterpret_cast<const char*>(p), static_cast<size_t>(sqlite3_column_bytes(stmt_, col)))
             : std::string();
  }
  // A text column for display. Records of older builds may hold bytes that are not UTF-8 (a GDAL
  // message quoting a damaged upload): they are escaped on the way out, as they would have been
  // on the way in (rv/field/text.hpp); text written by this build is valid and comes back unchanged.
  std::string display_text(int col) const { return valid_utf8(text(col)); }
  int64_t integer(int col) const { return sqlite3_column_int64(stmt_, col); }

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

JobRecord read_row(const Statement& s) {
  return store::record_from_texts([&s](int col) { return s.text(col); });
}

void bind_record(Statement& s, const JobRecord& r) {
  const auto texts = store::record_texts(r);
  for (int i = 0; i < store::kRecordColumnCount; ++i) {
    if (i == store::kProgressColumn)
      s.bind(i + 1, int64_t{r.progress});
    else if (i == store::kCellsColumn)
      s.bind(i + 1, r.cells);
    else
      s.bind(i + 1, texts[static_cast<size_t>(i)]);
  }
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
  if (sqlite3_open_v2(db_path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
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
        " transmission TEXT NOT NULL, report TEXT NOT NULL, formats TEXT NOT NULL DEFAULT '[]',"
        " principal TEXT NOT NULL DEFAULT 'anonymous', cells INTEGER NOT NULL DEFAULT 0)");
    exec("CREATE INDEX IF NOT EXISTS jobs_created ON jobs(created)");
    // Databases of earlier builds lack the later columns; their jobs read back with what they
    // had: no formats (each output's default, all they could have had), the principal
    // "anonymous" (no job had an owner), no cells charged. One transaction: a crash halfway
    // leaves the database as it was.
    std::set<std::string> columns;
    {
      Statement info(db_, "PRAGMA table_info(jobs)");
      while (info.step()) columns.insert(info.text(1));
    }
    exec("BEGIN IMMEDIATE");
    try {
      if (!columns.count("formats")) exec("ALTER TABLE jobs ADD COLUMN formats TEXT NOT NULL DEFAULT '[]'");
      if (!columns.count("principal")) exec("ALTER TABLE jobs ADD COLUMN principal TEXT NOT NULL DEFAULT 'anonymous'");
      if (!columns.count("cells")) exec("ALTER TABLE jobs ADD COLUMN cells INTEGER NOT NULL DEFAULT 0");
      exec("CREATE INDEX IF NOT EXISTS jobs_principal_created ON jobs(principal, created)");
      exec("COMMIT");
    } catch (...) {
      sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
      throw;
    }
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
  Statement s(db_, (std::string("INSERT INTO jobs (") + store::kRecordColumns +
                    ") VALUES (?1,?2,?3,?4,?5,?6,?7,?8,?9,?10,?11,?12,?13,?14,?15,?16,?17)")
                       .c_str());
  bind_record(s, job);
  s.step();
}

void JobStore::update(const JobRecord& job) {
  std::lock_guard lock(mutex_);
  Statement s(db_,
              "UPDATE jobs SET process_id=?2, status=?3, message=?4, error_kind=?5, progress=?6,"
              " created=?7, started=?8, finished=?9, updated=?10, inputs=?11, outputs=?12,"
              " transmission=?13, report=?14, formats=?15, principal=?16, cells=?17 WHERE id=?1");
  bind_record(s, job);
  s.step();
}

std::optional<JobRecord> JobStore::get(const std::string& id) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, (std::string("SELECT ") + store::kRecordColumns + " FROM jobs WHERE id=?1").c_str());
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return read_row(s);
}

std::vector<JobRecord> JobStore::list(int limit, int offset, const std::vector<JobStatus>& status,
                                      const std::string& principal) const {
  std::string sql = std::string("SELECT ") + store::kRecordColumns + " FROM jobs WHERE 1";
  if (!status.empty()) {
    sql += " AND status IN (";
    for (size_t i = 0; i < status.size(); ++i) sql += i ? ",?" : "?";
    sql += ")";
  }
  if (!principal.empty()) sql += " AND principal = ?";
  sql += " ORDER BY created DESC, id LIMIT ? OFFSET ?";
  std::lock_guard lock(mutex_);
  Statement s(db_, sql.c_str());
  int i = 1;
  for (JobStatus st : status) s.bind(i++, std::string(to_string(st)));
  if (!principal.empty()) s.bind(i++, principal);
  s.bind(i++, int64_t{limit});
  s.bind(i++, int64_t{offset});
  std::vector<JobRecord> out;
  while (s.step()) out.push_back(read_row(s));
  return out;
}

std::vector<CellCharge> JobStore::charges_since(const std::string& since) const {
  std::lock_guard lock(mutex_);
  // RFC 3339 UTC timestamps of one fixed format order as text.
  // A job refused over the allowance once planned keeps its size, but charged nothing.
  Statement s(db_,
              "SELECT principal, created, cells FROM jobs WHERE created >= ?1 AND cells > 0"
              " AND NOT (status = 'failed' AND error_kind = 'over_quota')");
  s.bind(1, since);
  std::vector<CellCharge> out;
  while (s.step()) out.push_back(CellCharge{s.display_text(0), s.display_text(1), s.integer(2)});
  return out;
}

std::vector<std::pair<std::string, int64_t>> JobStore::count_by_principal() const {
  std::lock_guard lock(mutex_);
  Statement s(db_, "SELECT principal, COUNT(*) FROM jobs GROUP BY principal ORDER BY principal");
  std::vector<std::pair<std::string, int64_t>> out;
  while (s.step()) out.emplace_back(s.display_text(0), s.integer(1));
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
