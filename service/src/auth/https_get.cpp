#include "auth/https_get.hpp"

#include <openssl/ssl.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <chrono>

#include "rv/field/error.hpp"

namespace rv::auth {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
namespace ssl = net::ssl;
using tcp = net::ip::tcp;

struct Target {
  std::string host, port = "443", path = "/";
};

Target parse_url(const std::string& url) {
  const std::string scheme = "https://";
  if (url.rfind(scheme, 0) != 0) throw Error(ErrorKind::invalid_argument, "not an https:// URL");
  const std::string rest = url.substr(scheme.size());
  const size_t slash = rest.find('/');
  std::string authority = rest.substr(0, slash);
  Target t;
  if (slash != std::string::npos) t.path = rest.substr(slash);
  if (authority.find('@') != std::string::npos) throw Error(ErrorKind::invalid_argument, "user information in a URL");
  const size_t close = authority.rfind(']');
  const size_t colon = authority.rfind(':');
  if (colon != std::string::npos && (close == std::string::npos || colon > close)) {
    t.port = authority.substr(colon + 1);
    authority = authority.substr(0, colon);
  }
  if (authority.size() > 2 && authority.front() == '[' && authority.back() == ']')
    authority = authority.substr(1, authority.size() - 2);
  t.host = authority;
  if (t.host.empty() || t.port.empty() || t.port.find_first_not_of("0123456789") != std::string::npos)
    throw Error(ErrorKind::invalid_argument, "no host or a bad port in the URL");
  return t;
}

// Runs the asynchronous operation started by `start` to its end on `ioc`; the stream's deadline
// cancels it when time is up.
template <class Start>
void run(net::io_context& ioc, const char* step, Start&& start) {
  beast::error_code result = net::error::would_block;
  start([&result](beast::error_code ec, auto&&...) { result = ec; });
  ioc.restart();
  ioc.run();
  if (result == beast::error::timeout) throw Error(ErrorKind::io, std::string(step) + ": timed out");
  if (result) throw Error(ErrorKind::io, std::string(step) + ": " + result.message());
}

}  // namespace

HttpsReply https_get(const std::string& url, const std::string& ca_file, double timeout_s, std::size_t max_bytes) {
  const Target t = parse_url(url);
  ssl::context ctx(ssl::context::tls_client);
  ctx.set_options(ssl::context::default_workarounds | ssl::context::no_sslv2 | ssl::context::no_sslv3 |
                  ssl::context::no_tlsv1 | ssl::context::no_tlsv1_1);
  ctx.set_default_verify_paths();
  beast::error_code ec;
  if (!ca_file.empty()) {
    ctx.load_verify_file(ca_file, ec);
    if (ec) throw Error(ErrorKind::io, "the CA file '" + ca_file + "': " + ec.message());
  }
  ctx.set_verify_mode(ssl::verify_peer);
  net::io_context ioc;
  beast::ssl_stream<beast::tcp_stream> stream(ioc, ctx);
  stream.set_verify_callback(ssl::host_name_verification(t.host));
  // SNI: the server picks the certificate for this host name.
  if (!SSL_set_tlsext_host_name(stream.native_handle(), t.host.c_str()))
    throw Error(ErrorKind::io, "cannot set the TLS server name");
  const auto deadline =
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(timeout_s));
  beast::get_lowest_layer(stream).expires_after(deadline);

  tcp::resolver resolver(ioc);
  tcp::resolver::results_type endpoints;
  run(ioc, "resolving the host", [&](auto done) {
    resolver.async_resolve(t.host, t.port, [&, done](beast::error_code e, tcp::resolver::results_type r) {
      endpoints = std::move(r);
      done(e);
    });
  });
  run(ioc, "connecting", [&](auto done) { beast::get_lowest_layer(stream).async_connect(endpoints, done); });
  run(ioc, "the TLS handshake", [&](auto done) { stream.async_handshake(ssl::stream_base::client, done); });
  http::request<http::empty_body> req(http::verb::get, t.path, 11);
  req.set(http::field::host, t.host);
  req.set(http::field::user_agent, "rvoronoi");
  req.set(http::field::accept, "application/jwk-set+json, application/json");
  run(ioc, "sending the request", [&](auto done) { http::async_write(stream, req, done); });
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(max_bytes);
  run(ioc, "reading the reply", [&](auto done) { http::async_read(stream, buffer, parser, done); });
  HttpsReply reply;
  reply.status = parser.get().result_int();
  reply.body = parser.release().body();
  // The close_notify exchange is a courtesy; its failure changes nothing about the reply.
  beast::get_lowest_layer(stream).expires_after(std::chrono::seconds(1));
  stream.async_shutdown([](beast::error_code) {});
  ioc.restart();
  ioc.run();
  return reply;
}

}  // namespace rv::auth
