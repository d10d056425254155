// The project's one error type. Every layer throws rv::Error with a kind from this table; each
// entry point (the CLI's exit code, the daemon's problem+json) translates the kind exactly once,
// in service/src/error_map.cpp.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

namespace rv {

enum class ErrorKind {
  invalid_argument,  // a parameter is malformed or out of range (bad extent, resolution, option)
  invalid_input,     // the seed data is unusable (empty, NaN coordinates, bad geometry)
  not_found,         // a named file, layer, field, job or output does not exist
  conflict,          // seeds of two owners overlap or cross
  too_large,         // the request exceeds a configured limit (cells, memory, body, features)
  unsupported,       // valid, but not something this build can do
  cancelled,         // the caller asked the computation to stop
  io,                // reading or writing a file failed
  busy,              // no capacity right now (queue full); retry later
  over_quota,        // the caller's own allowance is used up (a principal's jobs or cells); retry later
  internal,          // a bug: an invariant did not hold
};

std::string_view to_string(ErrorKind kind);

class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const { return kind_; }

 private:
  ErrorKind kind_;
};

}  // namespace rv
