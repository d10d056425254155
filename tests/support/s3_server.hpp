// An S3-compatible server of the test's own: s3rver (npm, tests/service/shared/package.json,
// installed by tools/setup.sh) on a free port of 127.0.0.1, its objects in a temporary folder, one
// bucket made at start. Point GDAL at it with configure_gdal() (path-style addressing, plain
// HTTP, s3rver's fixed keys). Stopped and its folder removed on destruction.
// Thread safety: one thread drives it.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cpl_conv.h>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

#include <thread>
#include "free_port.hpp"

namespace rv::test {

class S3Server {
 public:
  explicit S3Server(const std::string& bucket = "rv") : bucket_(bucket) {
    const char* src = std::getenv("RV_SOURCE_DIR");
    if (!src) throw std::runtime_error("RV_SOURCE_DIR is not set (run through ctest)");
    const std::string bin = std::string(src) + "/tests/service/shared/node_modules/.bin/s3rver";
    if (!std::filesystem::exists(bin)) throw std::runtime_error(bin + " is missing: run tools/setup.sh");
    char tmpl[] = "/tmp/rv-s3-XXXXXX";
    if (!mkdtemp(tmpl)) throw std::runtime_error("mkdtemp failed");
    dir_ = tmpl;
    port_ = free_port();
    pid_ = fork();
    if (pid_ == 0) {
      const std::string port = std::to_string(port_), data = dir_.string();
      execl(bin.c_str(), "s3rver", "-d", data.c_str(), "-p", port.c_str(), "-a", "127.0.0.1", "--configure-bucket",
            bucket_.c_str(), "--silent", static_cast<char*>(nullptr));
      _exit(127);
    }
    for (int i = 0; i < 300 && !answers(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (!answers()) throw std::runtime_error("s3rver did not start");
  }
  ~S3Server() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      waitpid(pid_, nullptr, 0);
    }
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  S3Server(const S3Server&) = delete;
  S3Server& operator=(const S3Server&) = delete;

  int port() const { return port_; }
  const std::string& bucket() const { return bucket_; }
  // GDAL's /vsis3/ settings for this server, process-wide.
  void configure_gdal() const {
    CPLSetConfigOption("AWS_S3_ENDPOINT", ("127.0.0.1:" + std::to_string(port_)).c_str());
    CPLSetConfigOption("AWS_HTTPS", "NO");
    CPLSetConfigOption("AWS_VIRTUAL_HOSTING", "FALSE");
    CPLSetConfigOption("AWS_ACCESS_KEY_ID", "S3RVER");
    CPLSetConfigOption("AWS_SECRET_ACCESS_KEY", "S3RVER");
    CPLSetConfigOption("AWS_REGION", "us-east-1");
  }

 private:
  bool answers() const {
    const int s = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(port_));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    ::close(s);
    return ok;
  }

  std::string bucket_;
  std::filesystem::path dir_;
  int port_ = 0;
  pid_t pid_ = -1;
};

}  // namespace rv::test
