#include "store/pg_client.hpp"

#include <libpq-fe.h>
#include <poll.h>

#include <cstdlib>

#include "rv/field/error.hpp"
#include "rv/field/text.hpp"

namespace rv::pg {
namespace {

// libpq's messages end in a newline, some in two lines; one line for a log and a problem.
std::string one_line(const char* message) {
  std::string s = message ? message : "";
  for (char& ch : s)
    if (ch == '\n' || ch == '\r' || ch == '\t') ch = ' ';
  std::string out;
  for (char ch : s)
    if (ch != ' ' || (!out.empty() && out.back() != ' ')) out += ch;  // runs of blanks as one
  s = out;
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return valid_utf8(s);
}

// Connection-level failures: the server is gone, shutting down, starting, or refuses connections
// for now. The caller should retry later; everything else is the statement's own fault.
bool is_unavailable(const char* sqlstate) {
  if (!sqlstate) return false;
  const std::string_view s(sqlstate);
  return s.substr(0, 2) == "08" || s == "57P01" || s == "57P02" || s == "57P03";
}

constexpr const char* kUnavailable = "the job store is unavailable: ";

}  // namespace

Result::~Result() { PQclear(r_); }

Result& Result::operator=(Result&& o) noexcept {
  if (this != &o) {
    PQclear(r_);
    r_ = o.r_;
    o.r_ = nullptr;
  }
  return *this;
}

int Result::rows() const { return r_ ? PQntuples(r_) : 0; }
bool Result::is_null(int row, int col) const { return PQgetisnull(r_, row, col) != 0; }

std::string Result::text(int row, int col) const {
  if (is_null(row, col)) return {};
  return std::string(PQgetvalue(r_, row, col), static_cast<size_t>(PQgetlength(r_, row, col)));
}

int64_t Result::integer(int row, int col) const {
  if (is_null(row, col)) return 0;
  const char* v = PQgetvalue(r_, row, col);
  char* end = nullptr;
  const long long n = std::strtoll(v, &end, 10);
  if (end == v || *end != '\0')
    throw Error(ErrorKind::io, "job store: column " + std::to_string(col) + " is no integer");
  return n;
}

bool Result::boolean(int row, int col) const { return !is_null(row, col) && PQgetvalue(r_, row, col)[0] == 't'; }

int64_t Result::affected() const {
  const char* n = r_ ? PQcmdTuples(r_) : "";
  return *n ? std::strtoll(n, nullptr, 10) : 0;
}

Connection::Connection(const ConnectInfo& info) {
  // Keywords beside the URI (expand_dbname): the password never enters a string that is logged.
  const std::string timeout = std::to_string(info.connect_timeout_s);
  const char* keys[] = {"dbname", "password", "application_name", "connect_timeout", nullptr};
  const char* values[] = {info.uri.c_str(), info.password.empty() ? nullptr : info.password.c_str(),
                          info.application_name.c_str(), timeout.c_str(), nullptr};
  c_ = PQconnectdbParams(keys, values, 1);
  if (!c_) throw Error(ErrorKind::busy, std::string(kUnavailable) + "out of memory");
  if (PQstatus(c_) != CONNECTION_OK) {
    const std::string why = one_line(PQerrorMessage(c_));
    PQfinish(c_);
    c_ = nullptr;
    throw Error(ErrorKind::busy, kUnavailable + why);
  }
  // Quiet: NOTICEs (e.g. "relation already exists, skipping") are not the daemon's log lines.
  PQsetNoticeProcessor(
      c_, [](void*, const char*) {}, nullptr);
}

Connection::~Connection() { PQfinish(c_); }

bool Connection::ok() const { return c_ && PQstatus(c_) == CONNECTION_OK; }

bool Connection::alive() {
  if (!ok()) return false;
  pollfd p{PQsocket(c_), POLLIN, 0};
  if (p.fd < 0) return false;
  if (::poll(&p, 1, 0) > 0 && !PQconsumeInput(c_)) return false;
  return ok();
}

void Connection::fail(const std::string& what, pg_result* r) {
  const char* state = r ? PQresultErrorField(r, PG_DIAG_SQLSTATE) : nullptr;
  const std::string why = one_line(r ? PQresultErrorMessage(r) : PQerrorMessage(c_));
  const bool unavailable = is_unavailable(state) || PQstatus(c_) != CONNECTION_OK;
  const bool duplicate = state && std::string_view(state) == "23505";
  PQclear(r);
  if (unavailable) throw Error(ErrorKind::busy, kUnavailable + why);
  throw Error(duplicate ? ErrorKind::internal : ErrorKind::io, "job store: " + what + why);
}

Result Connection::exec(std::string_view sql, const Params& params) {
  if (!ok()) throw Error(ErrorKind::busy, std::string(kUnavailable) + "the connection was lost");
  std::vector<const char*> values;
  values.reserve(params.size());
  for (const auto& p : params) values.push_back(p ? p->c_str() : nullptr);
  const std::string text(sql);
  pg_result* r =
      PQexecParams(c_, text.c_str(), static_cast<int>(values.size()), nullptr, values.data(), nullptr, nullptr, 0);
  if (!r) fail("", nullptr);
  const ExecStatusType st = PQresultStatus(r);
  if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK) fail("", r);
  return Result(r);
}

void Connection::exec_script(const std::string& sql) {
  if (!ok()) throw Error(ErrorKind::busy, std::string(kUnavailable) + "the connection was lost");
  pg_result* r = PQexec(c_, sql.c_str());
  if (!r) fail("", nullptr);
  const ExecStatusType st = PQresultStatus(r);
  if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK) fail("", r);
  PQclear(r);
}

std::vector<Notification> Connection::wait_notifications(std::chrono::milliseconds timeout) {
  std::vector<Notification> out;
  auto drain = [&] {
    if (!PQconsumeInput(c_)) throw Error(ErrorKind::busy, kUnavailable + one_line(PQerrorMessage(c_)));
    while (PGnotify* n = PQnotifies(c_)) {
      out.push_back({n->relname ? n->relname : "", n->extra ? n->extra : ""});
      PQfreemem(n);
    }
  };
  if (!ok()) throw Error(ErrorKind::busy, std::string(kUnavailable) + "the connection was lost");
  drain();
  if (!out.empty()) return out;
  pollfd p{PQsocket(c_), POLLIN, 0};
  if (p.fd < 0) throw Error(ErrorKind::busy, std::string(kUnavailable) + "the connection was lost");
  if (::poll(&p, 1, static_cast<int>(timeout.count())) > 0) drain();
  return out;
}

Transaction::Transaction(Connection& c) : c_(c) { c_.exec("BEGIN"); }

Transaction::~Transaction() {
  if (done_ || !c_.ok()) return;
  try {
    c_.exec("ROLLBACK");
  } catch (...) {
    // The connection broke meanwhile: the server rolls the transaction back itself.
  }
}

void Transaction::commit() {
  c_.exec("COMMIT");
  done_ = true;
}

Pool::Pool(ConnectInfo info, int size) : info_(std::move(info)), size_(std::max(1, size)) {}

Pool::~Pool() = default;

Pool::Lease::~Lease() {
  if (pool_ && c_) pool_->give_back(std::move(c_));
}

Pool::Lease Pool::acquire(std::chrono::milliseconds wait) {
  std::unique_lock lock(mutex_);
  if (!cv_.wait_for(lock, wait, [this] { return !idle_.empty() || out_ < size_; }))
    throw Error(ErrorKind::busy, "every connection to the job store is in use; retry later");
  ++out_;
  while (!idle_.empty()) {
    std::unique_ptr<Connection> c = std::move(idle_.back());
    idle_.pop_back();
    if (c->alive()) return Lease(*this, std::move(c));
  }
  lock.unlock();
  try {
    return Lease(*this, std::make_unique<Connection>(info_));
  } catch (...) {
    lock.lock();
    --out_;
    cv_.notify_one();
    throw;
  }
}

void Pool::give_back(std::unique_ptr<Connection> c) {
  std::lock_guard lock(mutex_);
  --out_;
  if (c->ok()) idle_.push_back(std::move(c));  // a broken one is dropped: the next acquire reconnects
  cv_.notify_one();
}

}  // namespace rv::pg
