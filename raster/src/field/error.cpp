#include "rv/field/error.hpp"

namespace rv {

std::string_view to_string(ErrorKind kind) {
  switch (kind) {
    case ErrorKind::invalid_argument:
      return "invalid-argument";
    case ErrorKind::invalid_input:
      return "invalid-input";
    case ErrorKind::not_found:
      return "not-found";
    case ErrorKind::conflict:
      return "conflict";
    case ErrorKind::too_large:
      return "too-large";
    case ErrorKind::unsupported:
      return "unsupported";
    case ErrorKind::cancelled:
      return "cancelled";
    case ErrorKind::io:
      return "io";
    case ErrorKind::busy:
      return "busy";
    case ErrorKind::over_quota:
      return "over_quota";
    case ErrorKind::internal:
      return "internal";
  }
  return "internal";
}

}  // namespace rv
