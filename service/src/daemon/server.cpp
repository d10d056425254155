// The HTTP transport of the daemon: Boost.Beast, asynchronous accept and per-connection
// sessions on strands, so that a slow or idle client costs a socket and a timer, never a thread.
#include "rv/server.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <cerrno>
#include <chrono>
#include <filesystem>
#include <memory>
#include <thread>

#include "daemon/server_api.hpp"
#include "daemon/server_auth.hpp"
#include "daemon/server_jobs.hpp"
#include "runtime/server_connections.hpp"
#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"
#include "rv/json_text.hpp"
#include "rv/store_jobs.hpp"

namespace rv {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using daemon::ApiRequest;
using daemon::ApiResponse;
using daemon::FileSlice;

// A Beast body that streams a slice of an open result file (ObjectReader::read_at), 64 KiB at a time: large
// results (and GDAL's range reads of them) never sit in memory whole.
struct FileSliceBody {
  using value_type = FileSlice;
  static std::uint64_t size(const value_type& body) { return body.length; }

  class writer {
   public:
    using const_buffers_type = net::const_buffer;
    template <bool isRequest, class Fields>
    writer(const http::header<isRequest, Fields>&, const value_type& body) : body_(body) {}
    void init(beast::error_code& ec) { ec = {}; }
    boost::optional<std::pair<const_buffers_type, bool>> get(beast::error_code& ec) {
      const uint64_t left = body_.length - done_;
      if (left == 0) {
        ec = {};
        return boost::none;
      }
      const size_t want = static_cast<size_t>(std::min<uint64_t>(left, sizeof buffer_));
      const int64_t n = body_.file->read_at(buffer_, want, body_.offset + done_);
      if (n <= 0) {
        // The file shrank or the storage failed: end the connection rather than send garbage.
        ec = beast::error_code(EIO, beast::system_category());
        return boost::none;
      }
      done_ += static_cast<uint64_t>(n);
      ec = {};
      return std::make_pair(net::const_buffer(buffer_, static_cast<size_t>(n)), done_ < body_.length);
    }

   private:
    const value_type& body_;
    uint64_t done_ = 0;
    char buffer_[64 * 1024];
  };
};

struct Shared {
  Shared(const ServerConfig& c, daemon::Api& a)
      : config(c),
        api(a),
        auth(c.auth, [](const std::string& line) { daemon::log_event(line); }),
        connections(daemon::connection_cap(c.http.max_connections)) {}
  const ServerConfig& config;
  daemon::Api& api;
  daemon::Authenticator auth;
  std::atomic<int> in_flight{0};  // requests handed to the Api whose response is not yet written
  daemon::ConnectionTable connections;
};

std::string json_escape(const std::string& s) { return json_text(nlohmann::json(s)); }

class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket&& socket, Shared& shared) : stream_(std::move(socket)), shared_(shared) {}
  ~Session() { shared_.connections.remove(id_); }

  void run() {
    // Evicting a session closes its socket on its strand; its pending read then ends it.
    id_ = shared_.connections.add([weak = weak_from_this(), executor = stream_.get_executor()] {
      net::post(executor, [weak] {
        if (auto self = weak.lock()) self->close();
      });
    });
    net::dispatch(stream_.get_executor(), beast::bind_front_handler(&Session::read_request, shared_from_this()));
  }

 private:
  std::chrono::steady_clock::duration request_timeout() const {
    return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(shared_.config.http.request_timeout_s));
  }

  void read_request() {
    shared_.connections.set_waiting(id_, true);
    parser_.emplace();
    parser_->header_limit(static_cast<std::uint32_t>(shared_.config.http.max_header_bytes));
    parser_->body_limit(static_cast<std::uint64_t>(shared_.config.http.max_body_bytes));
    // One deadline for the whole request: a client dribbling bytes cannot keep it open longer.
    stream_.expires_after(request_timeout());
    http::async_read_header(stream_, buffer_, *parser_,
                            beast::bind_front_handler(&Session::on_header, shared_from_this()));
  }

  // The header alone first: limits (a Content-Length over body_limit fails here already) are
  // answered before the body is sent, and a client waiting on "Expect: 100-continue" (curl
  // with an upload) is told to go on instead of waiting a second for nothing.
  void on_header(beast::error_code ec, std::size_t bytes) { authenticate(ec, bytes, false); }

  // Before the body: a client without a valid token cannot make us read (and hold) an upload,
  // nor learn the body limit. A Content-Length over it fails the header read with body_limit
  // once every field is parsed (Beast checks it when the header ends), so the fields are there.
  void authenticate(beast::error_code ec, std::size_t bytes, bool keys_refreshed) {
    if ((!ec && parser_->is_header_done()) || ec == http::error::body_limit) {
      const auto& head = parser_->get();
      const auto target = head.target();
      const auto authorization = head[http::field::authorization];
      const auto accept = head[http::field::accept];
      const auto method = head.method_string();
      daemon::Authenticator::Outcome who = shared_.auth.check(
          std::string_view(target.data(), target.size()), std::string_view(authorization.data(), authorization.size()),
          std::string_view(method.data(), method.size()), std::string_view(accept.data(), accept.size()),
          keys_refreshed);
      if (who.needs_keys) {
        // The identity provider may have rotated its keys: fetch them (on the key source's
        // thread) and check again; this connection waits, no thread does.
        shared_.auth.refresh_keys_then([self = shared_from_this(), ec, bytes] {
          net::post(self->stream_.get_executor(), [self, ec, bytes] { self->authenticate(ec, bytes, true); });
        });
        return;
      }
      principal_ = std::move(who.principal);
      auth_error_ = std::move(who.reason);
      if (who.refusal) return reject(std::move(*who.refusal));
    }
    if (ec) return on_read(ec, bytes);
    const auto& req = parser_->get();
    if (!parser_->is_done() && beast::iequals(req[http::field::expect], "100-continue")) {
      auto res = std::make_shared<http::response<http::empty_body>>(http::status::continue_, req.version());
      auto self = shared_from_this();
      http::async_write(stream_, *res, [self, res](beast::error_code wec, std::size_t) {
        if (wec) return self->close();
        self->read_body();
      });
      return;
    }
    read_body();
  }

  void read_body() {
    http::async_read(stream_, buffer_, *parser_, beast::bind_front_handler(&Session::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, std::size_t) {
    started_ = std::chrono::steady_clock::now();
    if (ec == http::error::end_of_stream) return close();
    if (ec == http::error::header_limit) {
      return protocol_error(
          431, "request-header-fields-too-large", "Request header fields too large",
          "the request headers exceed " + std::to_string(shared_.config.http.max_header_bytes) + " bytes");
    }
    if (ec == http::error::body_limit) {
      return protocol_error(413, "payload-too-large", "Payload too large",
                            "the request body exceeds this server's limit of " +
                                std::to_string(shared_.config.http.max_body_bytes) + " bytes");
    }
    if (ec == beast::error::timeout) {
      // tcp_stream has closed the socket already: nothing can be answered. A partial request
      // is logged as 408 so that slow or stalled clients show up in the request log.
      if (parser_->got_some()) {
        status_ = 408;
        method_ = parser_->is_header_done() ? std::string(parser_->get().method_string()) : "-";
        log();
      }
      return close();
    }
    if (ec) {
      if (ec.category() == beast::error_code(http::error::bad_target).category() || parser_->got_some()) {
        return protocol_error(400, "bad-request", "Bad request", "malformed HTTP request: " + ec.message());
      }
      return close();
    }

    shared_.connections.set_waiting(id_, false);
    const auto& req = parser_->get();
    method_ = std::string(req.method_string());
    target_ = std::string(req.target());
    keep_alive_ = req.keep_alive();
    version_ = req.version();
    ApiRequest api_req;
    api_req.method = method_;
    api_req.target = target_;
    api_req.host = std::string(req[http::field::host]);
    // Every Prefer and If-None-Match header, each as one list (RFC 9110 5.3: the fields of a
    // list may be split over several lines).
    auto joined = [&](http::field f) {
      std::string out;
      for (auto [it, end] = req.equal_range(f); it != end; ++it)
        out += (out.empty() ? "" : ",") + std::string(it->value());
      return out;
    };
    api_req.prefer = joined(http::field::prefer);
    api_req.range = std::string(req[http::field::range]);
    api_req.accept = std::string(req[http::field::accept]);
    api_req.accept_encoding = std::string(req[http::field::accept_encoding]);
    api_req.if_none_match = joined(http::field::if_none_match);
    api_req.body = parser_->release().body();
    api_req.principal = principal_;

    // A synchronous execution answers when its job ends: no deadline while it runs (the job
    // has its own time limit), a fresh one for writing the answer.
    stream_.expires_never();
    ++shared_.in_flight;
    auto self = shared_from_this();
    shared_.api.handle(api_req, [self](ApiResponse response) {
      net::post(self->stream_.get_executor(), [self, r = std::move(response)]() mutable { self->send(std::move(r)); });
    });
  }

  void protocol_error(unsigned status, const char* slug, const char* title, const std::string& detail) {
    reject(daemon::problem_response(status, std::string("https://rvoronoi.dev/problems/") + slug, title, detail, ""));
  }

  // Answers without handing the request to the Api, then closes the connection (the client may
  // still be sending a body we will not read).
  void reject(daemon::ApiResponse response) {
    started_ = std::chrono::steady_clock::now();
    method_ = parser_ && parser_->is_header_done() ? std::string(parser_->get().method_string()) : "-";
    target_ = parser_ && parser_->is_header_done() ? std::string(parser_->get().target()) : "-";
    keep_alive_ = false;
    version_ = 11;
    ++shared_.in_flight;
    send(std::move(response));
  }

  template <class Body>
  void prepare(http::response<Body>& res, const ApiResponse& r) {
    res.result(r.status);
    res.version(version_);
    res.set(http::field::server, "rvoronoi");
    for (const auto& [name, value] : r.headers) res.set(name, value);
    res.keep_alive(keep_alive_);
  }

  void send(ApiResponse r) {
    status_ = r.status;
    const bool head = method_ == "HEAD";
    if (head) {
      auto res = std::make_shared<http::response<http::empty_body>>();
      prepare(*res, r);
      res->content_length(r.file ? r.file->length : r.body.size());
      return write(res);
    }
    if (r.file) {
      auto res = std::make_shared<http::response<FileSliceBody>>();
      prepare(*res, r);
      res->body() = std::move(*r.file);
      res->prepare_payload();
      return write(res);
    }
    auto res = std::make_shared<http::response<http::string_body>>();
    prepare(*res, r);
    res->body() = std::move(r.body);
    res->prepare_payload();
    write(res);
  }

  // A response goes out piece by piece (a file body 64 KiB at a time), each piece within
  // request_timeout_s of the last: a client that stops reading is dropped then, while one on a slow
  // link may take as long as its download needs, down to http.min_send_bytes_per_s on average
  // (past that deadline a client reading a trickle to hold the connection is dropped too).
  template <class Message>
  void write(std::shared_ptr<Message> res) {
    using Serializer = http::serializer<false, typename Message::body_type, typename Message::fields_type>;
    auto sr = std::make_shared<Serializer>(*res);
    const auto now = std::chrono::steady_clock::now();
    const double rate = static_cast<double>(shared_.config.http.min_send_bytes_per_s);
    const uint64_t length = res->payload_size().value_or(0);
    deadline_ = rate > 0.0 ? now + request_timeout() +
                                 std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                     std::chrono::duration<double>(static_cast<double>(length) / rate))
                           : std::chrono::steady_clock::time_point::max();
    write_some(std::move(res), std::move(sr));
  }

  template <class Message, class Serializer>
  void write_some(std::shared_ptr<Message> res, std::shared_ptr<Serializer> sr) {
    const auto now = std::chrono::steady_clock::now();
    stream_.expires_after(
        std::min(request_timeout(), std::max(deadline_ - now, std::chrono::steady_clock::duration{})));
    auto self = shared_from_this();
    http::async_write_some(stream_, *sr, [self, res, sr](beast::error_code ec, std::size_t) {
      if (!ec && !sr->is_done()) return self->write_some(res, sr);
      self->log();
      --self->shared_.in_flight;
      if (ec) return self->close();
      if (!res->keep_alive()) return self->drain_and_close();
      self->read_request();
    });
  }

  void log() {
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started_).count();
    char dur[32];
    std::snprintf(dur, sizeof dur, "%.1f", ms);
    daemon::log_line("{\"time\":\"" + daemon::now_rfc3339() + "\",\"method\":" + json_escape(method_) + ",\"path\":" +
                     json_escape(daemon::loggable_target(target_)) + ",\"status\":" + std::to_string(status_) +
                     ",\"ms\":" + dur + ",\"principal\":" + json_escape(principal_.name) +
                     (auth_error_.empty() ? std::string() : ",\"auth_error\":" + json_escape(auth_error_)) + "}");
  }

  // After an early answer (413, 431) the client may still be sending: stop writing, read and
  // discard for a moment, so that it receives our answer instead of a connection reset.
  void drain_and_close() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
    stream_.expires_after(std::chrono::seconds(2));
    drain();
  }
  void drain() {
    auto self = shared_from_this();
    stream_.async_read_some(net::buffer(scratch_), [self](beast::error_code ec, std::size_t) {
      if (ec) return self->close();
      self->drain();
    });
  }

  void close() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
    stream_.socket().close(ec);
  }

  beast::tcp_stream stream_;
  Shared& shared_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::string method_ = "-";
  std::string target_ = "-";
  auth::Principal principal_;  // who the current request comes from (auth/principal.hpp)
  std::string auth_error_;     // why its token was refused, for the log
  unsigned status_ = 0;
  std::chrono::steady_clock::time_point deadline_{};  // the response being written: its last moment
  unsigned version_ = 11;
  bool keep_alive_ = false;
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  char scratch_[4096];
  daemon::ConnectionTable::Id id_ = 0;
};

class Listener : public std::enable_shared_from_this<Listener> {
 public:
  Listener(net::io_context& ioc, tcp::acceptor&& acceptor, Shared& shared)
      : ioc_(ioc), acceptor_(std::move(acceptor)), shared_(shared), backoff_(ioc) {}

  void run() { accept(); }
  void close() {
    net::post(acceptor_.get_executor(), [self = shared_from_this()] {
      beast::error_code ec;
      self->acceptor_.close(ec);
    });
  }

 private:
  void accept() {
    acceptor_.async_accept(net::make_strand(ioc_), beast::bind_front_handler(&Listener::on_accept, shared_from_this()));
  }
  void on_accept(beast::error_code ec, tcp::socket socket) {
    if (ec == net::error::operation_aborted || !acceptor_.is_open()) return;
    // accept() fails only with system errors: the errno is compared directly (comparing with
    // error conditions goes through Boost's category objects, which UBSan's vptr check rejects).
    const int errno_value = ec ? ec.value() : 0;
    if (errno_value == EMFILE || errno_value == ENFILE || errno_value == ENOBUFS || errno_value == ENOMEM) {
      // Out of descriptors (or kernel memory): accepting again at once would fail again, in a
      // tight loop. Free a descriptor by closing the connection that has waited longest, wait a
      // moment, then accept again; the pending connections wait in the kernel's backlog.
      shared_.connections.evict_oldest_waiting();
      log_backoff(ec);
      backoff_.expires_after(kAcceptBackoff);
      backoff_.async_wait([self = shared_from_this()](beast::error_code wec) {
        if (!wec) self->accept();
      });
      return;
    }
    if (!ec) {
      if (shared_.connections.make_room()) {
        std::make_shared<Session>(std::move(socket), shared_)->run();
      } else {
        refuse_busy(socket);
      }
    }
    accept();
  }

  // Every connection is busy with a request: answer this one 503 at once and close it. A fresh
  // socket's send buffer is empty, so the short answer is written without blocking.
  static void refuse_busy(tcp::socket& socket) {
    static const std::string answer =
        "HTTP/1.1 503 Service Unavailable\r\nServer: rvoronoi\r\nContent-Type: application/problem+json\r\n"
        "Retry-After: " +
        std::to_string(daemon::kRetryAfterSeconds) +
        "\r\nConnection: close\r\nContent-Length: " + std::to_string(kBusyBody.size()) + "\r\n\r\n" +
        std::string(kBusyBody);
    beast::error_code ec;
    socket.non_blocking(true, ec);
    net::write(socket, net::buffer(answer), ec);
    socket.shutdown(tcp::socket::shutdown_both, ec);
    socket.close(ec);
  }

  void log_backoff(const beast::error_code& ec) {
    const auto now = std::chrono::steady_clock::now();
    ++backoffs_;
    if (now - last_log_ < std::chrono::seconds(1)) return;  // one line a second at most
    last_log_ = now;
    daemon::log_line("{\"time\":\"" + daemon::now_rfc3339() + "\",\"event\":\"accept_backoff\",\"error\":" +
                     json_escape(ec.message()) + ",\"backoffs\":" + std::to_string(backoffs_) +
                     ",\"connections\":" + std::to_string(shared_.connections.size()) + "}");
  }

  static constexpr auto kAcceptBackoff = std::chrono::milliseconds(50);
  static constexpr std::string_view kBusyBody =
      R"({"type":"https://rvoronoi.dev/problems/busy","title":"Server busy","status":503,)"
      R"("detail":"every connection this server accepts is busy with a request; retry later"})";

  net::io_context& ioc_;
  tcp::acceptor acceptor_;
  Shared& shared_;
  net::steady_timer backoff_;
  std::chrono::steady_clock::time_point last_log_{};
  int64_t backoffs_ = 0;
};

// With authentication on, jobs of the anonymous principal (stored before principals, or while
// the server was open) are the admins' alone to see: say so at start, and say when no admin is
// configured to see them.
void log_anonymous_jobs(const JobRecords& store, const AuthConfig& auth) {
  int64_t anonymous = 0;
  for (const auto& [principal, count] : store.count_by_principal())
    if (principal == auth::kAnonymous) anonymous = count;
  if (anonymous == 0) return;
  bool admin = !auth.jwt.role_claim.empty();
  for (const PrincipalConfig& p : auth.principals) admin = admin || p.role == Role::admin;
  daemon::log_event("{\"event\":\"anonymous_jobs\",\"jobs\":" + std::to_string(anonymous) + ",\"detail\":" +
                    json_escape(std::to_string(anonymous) +
                                " stored jobs belong to the principal 'anonymous' (made before principals, or "
                                "without authentication): only admins see them" +
                                (admin ? "" : "; no admin is configured")) +
                    "}");
}

}  // namespace

struct Server::Impl {
  ServerConfig config;
  JobRunner runner;
  std::unique_ptr<JobStore> store;                        // the SQLite store, or
  std::unique_ptr<store::PostgresJobStore> shared_store;  // the shared one (config `store`)
  std::unique_ptr<daemon::MemoryAccount> memory;
  std::unique_ptr<daemon::RequestPool> describe_pool;
  std::unique_ptr<daemon::JobManager> jobs;
  std::unique_ptr<daemon::SessionManager> sessions;
  std::unique_ptr<daemon::Api> api;
  std::unique_ptr<Shared> shared;
  net::io_context ioc;
  std::shared_ptr<Listener> listener;
  std::vector<std::thread> threads;
  unsigned short port = 0;
  bool running = false;
  int lock_fd = -1;  // flock()ed <data_dir>/lock: one server per data directory
};

Server::Server(ServerConfig config, JobRunner runner) : impl_(std::make_unique<Impl>()) {
  impl_->config = std::move(config);
  impl_->runner = std::move(runner);
}

Server::~Server() { stop(); }

unsigned short Server::port() const { return impl_->port; }

void Server::start() {
  Impl& s = *impl_;
  if (s.running) return;
  std::error_code fec;
  std::filesystem::create_directories(s.config.data_dir, fec);
  if (fec) throw Error(ErrorKind::io, "data directory '" + s.config.data_dir + "': " + fec.message());
  // Two servers on one data directory would each take the other's running jobs for
  // interrupted ones. The kernel drops the lock when the process dies, SIGKILL included.
  const std::string lock_path = (std::filesystem::path(s.config.data_dir) / "lock").string();
  s.lock_fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (s.lock_fd < 0 || ::flock(s.lock_fd, LOCK_EX | LOCK_NB) != 0) {
    if (s.lock_fd >= 0) ::close(s.lock_fd);
    s.lock_fd = -1;
    throw Error(ErrorKind::io, "data directory '" + s.config.data_dir + "' is in use by another rvoronoi serve");
  }
  struct LockGuard {  // released again if start() fails below
    int& fd;
    bool armed = true;
    ~LockGuard() {
      if (armed && fd >= 0) {
        ::close(fd);
        fd = -1;
      }
    }
  } lock_guard{s.lock_fd};
  std::vector<std::string> interrupted;
  if (s.config.store.shared()) {
    // Unreachable at start: one line, and the daemon exits (Error(busy) to serve_main).
    s.shared_store = std::make_unique<store::PostgresJobStore>(
        pg::ConnectInfo{s.config.store.uri, s.config.store.password, "rvoronoi", 5}, s.config.store.connections);
  } else {
    s.store = std::make_unique<JobStore>(std::filesystem::path(s.config.data_dir) / "jobs.sqlite");
    // Decision (documented in openapi.yaml): a job that was queued or running when the previous
    // process died cannot be resumed (its uploaded inputs lived in memory); it is failed with a
    // message saying so, and whatever it had written is deleted. (A shared store's reaper
    // queues such jobs again.)
    interrupted = s.store->fail_interrupted(
        "the server stopped (crash or restart) before this job finished; resubmit it", daemon::now_rfc3339());
    for (const std::string& id : interrupted) {
      if (daemon::is_job_id(id)) {
        std::error_code ec;
        std::filesystem::remove_all(std::filesystem::path(s.config.data_dir) / "jobs" / id, ec);
      }
    }
  }
  const JobRecords& records = s.shared_store ? static_cast<const JobRecords&>(*s.shared_store) : *s.store;
  if (s.config.auth.enabled()) log_anonymous_jobs(records, s.config.auth);

  beast::error_code ec;
  const auto address = net::ip::make_address(s.config.host, ec);
  if (ec) throw Error(ErrorKind::invalid_argument, "listen address '" + s.config.host + "': " + ec.message());
  tcp::acceptor acceptor(s.ioc);
  const tcp::endpoint endpoint(address, static_cast<unsigned short>(s.config.port));
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec) {
    throw Error(ErrorKind::io,
                "cannot listen on " + s.config.host + ":" + std::to_string(s.config.port) + ": " + ec.message());
  }
  s.port = acceptor.local_endpoint().port();
  s.config.port = s.port;  // links made without a Host header name the port really bound

  s.memory = std::make_unique<daemon::MemoryAccount>(s.config.memory_budget());
  s.describe_pool = std::make_unique<daemon::RequestPool>(s.config.jobs.describe_workers);
  const std::string daemon_name =
      s.config.daemon_name.empty() ? daemon::default_daemon_name(s.port) : s.config.daemon_name;
  if (s.shared_store) {
    // The leases' holder: fresh at every start, so that a restarted daemon never mistakes the
    // leases of its previous life for its own.
    const std::string url =
        s.config.public_url.empty() ? "http://" + s.config.host + ":" + std::to_string(s.port) : s.config.public_url;
    s.jobs =
        std::make_unique<daemon::JobManager>(*s.shared_store, s.config, s.runner, *s.memory,
                                             daemon_name + "/" + daemon::new_job_id().substr(0, 16), daemon_name, url);
  } else {
    s.jobs = std::make_unique<daemon::JobManager>(*s.store, s.config, s.runner, *s.memory);
  }
  s.sessions = std::make_unique<daemon::SessionManager>(s.config, *s.jobs, *s.memory, daemon_name);
  s.api = std::make_unique<daemon::Api>(s.config, records, *s.jobs, *s.memory, *s.describe_pool, *s.sessions);
  s.shared = std::make_unique<Shared>(s.config, *s.api);
  s.shared->auth.start();  // the identity provider's keys, before the first request
  s.listener = std::make_shared<Listener>(s.ioc, std::move(acceptor), *s.shared);
  s.listener->run();
  for (int i = 0; i < std::max(1, s.config.http.io_threads); ++i) {
    s.threads.emplace_back([&ioc = s.ioc] {
      // A handler that throws would end run() and, on this thread, the process (terminate).
      // The Api turns every error into an answer; this is the net below it: log, keep serving.
      for (;;) {
        try {
          ioc.run();
          return;
        } catch (const std::exception& e) {
          daemon::log_line("{\"time\":\"" + daemon::now_rfc3339() +
                           "\",\"event\":\"handler_exception\",\"error\":" + json_escape(e.what()) + "}");
        } catch (...) {
          daemon::log_line("{\"time\":\"" + daemon::now_rfc3339() + "\",\"event\":\"handler_exception\"}");
        }
      }
    });
  }
  s.running = true;
  lock_guard.armed = false;
  daemon::log_line("{\"time\":\"" + daemon::now_rfc3339() + "\",\"event\":\"listening\",\"address\":" +
                   json_escape(s.config.host + ":" + std::to_string(s.port)) + ",\"data_dir\":" +
                   json_escape(s.config.data_dir) + ",\"auth\":\"" + (s.config.auth.enabled() ? "bearer" : "off") +
                   "\",\"principals\":" + std::to_string(s.config.auth.principals.size()) +
                   ",\"jwt\":" + (s.config.auth.jwt.enabled() ? "true" : "false") +
                   ",\"daemon\":" + json_escape(s.sessions->daemon_name()) +
                   ",\"interrupted_jobs_failed\":" + std::to_string(interrupted.size()) + ",\"store\":\"" +
                   (s.shared_store ? "postgresql" : "sqlite") + "\"" +
                   ",\"retained_free_bytes\":" + std::to_string(applied_allocator_settings().trim_threshold) + "}");
}

void Server::stop() {
  Impl& s = *impl_;
  if (!s.running) return;
  s.running = false;
  s.listener->close();
  // Running jobs get the grace period, then are cancelled; queued ones are failed at once.
  s.jobs->shutdown(std::chrono::duration<double>(s.config.jobs.shutdown_grace_s));
  s.sessions->stop();       // after the jobs: creations under way ended there; requests waiting fail
  s.describe_pool->stop();  // the descriptions under way answer first
  // Let the answers already on their way (synchronous executions that just ended) be written.
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (s.shared->in_flight.load() > 0 && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  s.ioc.stop();
  for (std::thread& t : s.threads) t.join();
  s.threads.clear();
  // Connections waiting for the identity provider's keys are let go (their continuations are
  // posted to the stopped context and destroyed with it).
  s.shared->auth.stop();
  s.listener.reset();
  s.api.reset();
  s.sessions.reset();
  s.jobs.reset();  // its workers are joined; the store closes after it
  s.describe_pool.reset();
  s.memory.reset();
  s.store.reset();
  s.shared_store.reset();
  if (s.lock_fd >= 0) {
    ::close(s.lock_fd);
    s.lock_fd = -1;
  }
  daemon::log_line("{\"time\":\"" + daemon::now_rfc3339() + "\",\"event\":\"stopped\"}");
}

}  // namespace rv
