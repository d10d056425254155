// The one table that translates rv::ErrorKind at the entry points: the CLI's exit code, the
// daemon's RFC 7807 problem+json status and type, and the Python module's exception class.
// Pure, thread-safe.
#pragma once

#include <string_view>

#include "rv/field/error.hpp"

namespace rv {

struct ErrorInfo {
  int exit_code;            // rvoronoi's process exit status
  int http_status;          // HTTP status of the problem response
  std::string_view type;    // problem "type" URI
  std::string_view title;   // problem "title"
  std::string_view python;  // the Python module's exception class (rvoronoi.<name>)
};

const ErrorInfo& error_info(ErrorKind kind);

}  // namespace rv
