// A minimal blocking HTTP/1.1 client for the daemon's tests, one connection per request.
// Compiled once (http_client.cpp, Boost.Beast) into rv_test_http, so that the test files that use
// it do not each compile Beast's templates. Not thread-safe per call site; independent calls may
// run on different threads. Throws boost::system::system_error when the connection fails.
#pragma once

#include <map>
#include <string>

#include <nlohmann/json.hpp>

namespace rv::test {

struct Reply {
  unsigned status = 0;
  std::map<std::string, std::string> headers;  // names lower-cased
  std::string body;

  nlohmann::json json() const { return nlohmann::json::parse(body); }
  std::string header(const std::string& name) const {
    const auto it = headers.find(name);
    return it == headers.end() ? std::string() : it->second;
  }
};

// `method` to http://127.0.0.1:`port``target` with `headers`; a body (or any POST) is sent as
// application/json. The reply's body is read whole, without a size limit; HEAD reads none.
Reply http_request(unsigned short port, const std::string& method, const std::string& target,
                   const std::string& body = "", const std::map<std::string, std::string>& headers = {});

}  // namespace rv::test
