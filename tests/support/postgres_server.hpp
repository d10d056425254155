// A PostgreSQL 15 server of the test's own: initdb in a temporary folder, run as the postgres
// user (runuser) when the test runs as root, on a free port of 127.0.0.1, with a password for
// TCP logins (scram-sha-256) so that the daemon's password path is exercised. Stopped and its
// folder removed on destruction. Durability is off (fsync): the tests crash daemons, not the
// machine.
// Thread safety: one thread drives it; the server itself is shared like any other.
#pragma once

#include <netinet/in.h>
#include <pwd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "free_port.hpp"

namespace rv::test {

class PostgresServer {
 public:
  static constexpr const char* kBin = "/usr/lib/postgresql/15/bin";
  static constexpr const char* kUser = "rv";
  static constexpr const char* kPassword = "rv-test-secret-7Q";

  PostgresServer() {
    char tmpl[] = "/tmp/rv-pg-XXXXXX";
    if (!mkdtemp(tmpl)) throw std::runtime_error("mkdtemp failed");
    dir_ = tmpl;
    as_postgres_ = geteuid() == 0;
    if (as_postgres_) {
      const passwd* pw = getpwnam("postgres");
      if (!pw) throw std::runtime_error("no postgres user: install postgresql-15 (tools/setup.sh)");
      if (chown(dir_.c_str(), pw->pw_uid, pw->pw_gid) != 0) throw std::runtime_error("chown failed");
    }
    std::ofstream(dir_ / "pw") << kPassword << "\n";
    if (as_postgres_) run("chown postgres " + (dir_ / "pw").string());
    run(prefix() + kBin + "/initdb -D " + data() + " -U " + kUser + " -E UTF8 --no-sync" +
        " --auth-local=trust --auth-host=scram-sha-256 --pwfile=" + (dir_ / "pw").string() + " >" +
        (dir_ / "initdb.log").string() + " 2>&1");
    port_ = free_port();
    start();
  }
  ~PostgresServer() {
    std::system((prefix() + kBin + "/pg_ctl -D " + data() + " -m immediate stop >/dev/null 2>&1").c_str());
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  void start() {
    run(prefix() + kBin + "/pg_ctl -D " + data() + " -l " + (dir_ / "server.log").string() + " -w -t 60 -o \"-p " +
        std::to_string(port_) + " -k " + dir_.string() +
        " -c listen_addresses=127.0.0.1 -c fsync=off -c max_connections=200\" start >/dev/null");
  }
  // Fast shutdown: connections are terminated, as when an operator restarts the server.
  void stop() { run(prefix() + kBin + "/pg_ctl -D " + data() + " -m fast -w stop >/dev/null"); }

  int port() const { return port_; }
  // A URI for database `db`, without the password (the daemon takes it apart from the URI).
  std::string uri(const std::string& db = "postgres") const {
    return "postgresql://" + std::string(kUser) + "@127.0.0.1:" + std::to_string(port_) + "/" + db;
  }
  // Runs SQL through psql on the server's socket (trusted locally).
  void psql(const std::string& sql) const {
    run(prefix() + "/usr/bin/psql -X -q -v ON_ERROR_STOP=1 -h " + dir_.string() + " -p " + std::to_string(port_) +
        " -U " + kUser + " -d postgres -c \"" + sql + "\" >/dev/null");
  }
  // A fresh, empty database for one test.
  std::string create_database() {
    const std::string name = "t" + std::to_string(++databases_);
    psql("CREATE DATABASE " + name);
    return name;
  }

 private:
  std::string data() const { return (dir_ / "data").string(); }
  std::string prefix() const { return as_postgres_ ? "runuser -u postgres -- " : ""; }
  static void run(const std::string& cmd) {
    if (std::system(cmd.c_str()) != 0) throw std::runtime_error("failed: " + cmd);
  }

  std::filesystem::path dir_;
  bool as_postgres_ = false;
  int port_ = 0;
  int databases_ = 0;
};

}  // namespace rv::test
