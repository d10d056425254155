// A thin C++ wrapper over libpq, PostgreSQL's C client (Debian's libpqxx is the old 6.x series):
// one connection, its results, parameters as text, transactions, notifications, and a small pool.
//
// Errors: a connection that cannot be made or is lost (SQLSTATE class 08, a server shutting down
// or starting, a broken socket) throws rv::Error(busy), "the job store is unavailable: ..." (503
// with Retry-After for an HTTP client); a unique-key violation throws rv::Error(internal); any
// other failed statement rv::Error(io). Messages are libpq's and the server's, which never carry
// the password.
// Thread safety: a Connection, Result or Transaction belongs to one thread at a time; Pool's
// members may be called from any thread.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

struct pg_conn;
struct pg_result;

namespace rv::pg {

// Where and how to connect. `uri` is a postgresql:// URI without a password (the daemon refuses
// one with a password: URIs get logged); `password` is given to libpq apart from it, never logged.
struct ConnectInfo {
  std::string uri;
  std::string password;
  std::string application_name = "rvoronoi";
  int connect_timeout_s = 5;  // libpq's connect_timeout: per address tried
};

// One statement's outcome. Columns are read as text (the wrapper passes no binary formats).
class Result {
 public:
  Result() = default;
  explicit Result(pg_result* r) : r_(r) {}
  ~Result();
  Result(Result&& o) noexcept : r_(o.r_) { o.r_ = nullptr; }
  Result& operator=(Result&& o) noexcept;
  Result(const Result&) = delete;
  Result& operator=(const Result&) = delete;

  int rows() const;
  bool is_null(int row, int col) const;
  std::string text(int row, int col) const;  // "" for NULL
  int64_t integer(int row, int col) const;   // 0 for NULL; throws rv::Error(io) if not a number
  bool boolean(int row, int col) const;      // PostgreSQL's "t"
  // Rows an INSERT, UPDATE or DELETE touched: the fencing checks read it.
  int64_t affected() const;

 private:
  pg_result* r_ = nullptr;
};

using Params = std::vector<std::optional<std::string>>;  // nullopt = SQL NULL

// A notification received on a channel the connection LISTENs to.
struct Notification {
  std::string channel;
  std::string payload;
};

class Connection {
 public:
  // Connects. Throws rv::Error(busy) when the server cannot be reached or refuses the login.
  explicit Connection(const ConnectInfo& info);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  // One statement with $1.. parameters (text; nullopt is NULL), in its own implicit transaction
  // unless a Transaction is open. Throws as above.
  Result exec(std::string_view sql, const Params& params = {});
  // Several statements separated by semicolons, without parameters (a schema migration).
  void exec_script(const std::string& sql);
  // Whether the connection is still usable (false once libpq saw it break).
  bool ok() const;
  // ok(), after reading whatever the server sent meanwhile without waiting: a server that shut
  // down or restarted closed the socket, and an idle connection learns it here, not on its next
  // statement.
  bool alive();
  // Waits up to `timeout` for notifications (after exec("LISTEN ...")); returns those that came,
  // possibly none. Throws rv::Error(busy) if the connection broke meanwhile.
  std::vector<Notification> wait_notifications(std::chrono::milliseconds timeout);

 private:
  [[noreturn]] void fail(const std::string& what, pg_result* r);
  pg_conn* c_ = nullptr;
};

// BEGIN on construction; ROLLBACK on destruction unless commit() ran. Short by design: nothing of
// a job's computation ever runs inside one.
class Transaction {
 public:
  explicit Transaction(Connection& c);
  ~Transaction();
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  Result exec(std::string_view sql, const Params& params = {}) { return c_.exec(sql, params); }
  void exec_script(const std::string& sql) { c_.exec_script(sql); }
  void commit();

 private:
  Connection& c_;
  bool done_ = false;
};

// At most `size` connections, made when first needed. A connection that broke is dropped when it
// comes back, and the next acquire() connects afresh: the pool outlives a server restart.
class Pool {
 public:
  Pool(ConnectInfo info, int size);
  ~Pool();
  Pool(const Pool&) = delete;
  Pool& operator=(const Pool&) = delete;

  class Lease {
   public:
    Lease(Pool& pool, std::unique_ptr<Connection> c) : pool_(&pool), c_(std::move(c)) {}
    ~Lease();
    Lease(Lease&& o) noexcept = default;
    Lease& operator=(Lease&&) = delete;
    Lease(const Lease&) = delete;
    Connection& operator*() { return *c_; }
    Connection* operator->() { return c_.get(); }

   private:
    Pool* pool_;
    std::unique_ptr<Connection> c_;
  };

  // A connection for this thread until the Lease ends; waits up to `wait` for one to come back
  // when all are out, then throws rv::Error(busy). Throws rv::Error(busy) if connecting fails.
  Lease acquire(std::chrono::milliseconds wait = std::chrono::milliseconds(10000));
  const ConnectInfo& info() const { return info_; }

 private:
  void give_back(std::unique_ptr<Connection> c);
  ConnectInfo info_;
  int size_;
  int out_ = 0;
  std::vector<std::unique_ptr<Connection>> idle_;
  std::mutex mutex_;
  std::condition_variable cv_;
};

// The text of a value as a statement parameter.
inline std::optional<std::string> param(std::string s) { return std::optional<std::string>(std::move(s)); }
inline std::optional<std::string> param(int64_t v) { return std::to_string(v); }

}  // namespace rv::pg
