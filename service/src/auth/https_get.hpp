// One HTTPS GET, for an identity provider's key set: TLS with the peer's certificate and host
// name verified (the system's CAs, plus `ca_file` when given), the whole exchange within
// `timeout_s`, the body at most `max_bytes`. No redirects, no proxies, no plain HTTP.
// Thread safety: reentrant (each call has its own I/O context); it blocks its caller.
#pragma once

#include <cstddef>
#include <string>

namespace rv::auth {

struct HttpsReply {
  unsigned status = 0;
  std::string body;
};

// Throws rv::Error(invalid_argument) for a URL that is not https://host[:port][/path], and
// rv::Error(io) naming the step that failed (resolve, connect, TLS handshake or certificate,
// request, reply, too large, time out).
HttpsReply https_get(const std::string& url, const std::string& ca_file, double timeout_s, std::size_t max_bytes);

}  // namespace rv::auth
