#include "rv/error_map.hpp"

namespace rv {

const ErrorInfo& error_info(ErrorKind kind) {
  // Exit codes: 2 is the conventional "usage" status; the rest are distinct so that scripts can
  // tell a bad input from a full disk. Problem types reuse OGC API - Processes URIs where the
  // standard names one.
  static const ErrorInfo table[] = {
      /* invalid_argument */ {2, 400, "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/invalid-parameter",
                              "Invalid parameter", "InvalidArgument"},
      /* invalid_input */
      {3, 400, "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/invalid-input", "Invalid input",
       "InvalidInput"},
      /* not_found */
      {4, 404, "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/not-found", "Not found", "NotFound"},
      /* conflict */ {5, 400, "https://rvoronoi.dev/problems/seed-conflict", "Seeds of two owners overlap", "Conflict"},
      /* too_large */ {6, 422, "https://rvoronoi.dev/problems/too-large", "Request exceeds a limit", "TooLarge"},
      /* unsupported */ {7, 400, "https://rvoronoi.dev/problems/unsupported", "Not supported", "Unsupported"},
      /* cancelled */ {8, 409, "https://rvoronoi.dev/problems/dismissed", "Job dismissed", "Cancelled"},
      /* io */ {9, 500, "https://rvoronoi.dev/problems/io", "Input/output failure", "IOFailure"},
      /* busy */ {10, 503, "https://rvoronoi.dev/problems/busy", "Server busy", "Busy"},
      /* over_quota */
      {11, 429, "https://rvoronoi.dev/problems/over-quota", "Over your allowance", "OverQuota"},
      /* internal */ {70, 500, "https://rvoronoi.dev/problems/internal", "Internal error", "InternalError"},
  };
  static_assert(sizeof(table) / sizeof(table[0]) == static_cast<int>(ErrorKind::internal) + 1);
  return table[static_cast<int>(kind)];
}

}  // namespace rv
