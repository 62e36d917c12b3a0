#include "stickslip/server/http_server.h"
#include "stickslip/common/text.h"
#include "stickslip/server/priority.h"

#include <algorithm>

#include <atomic>
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/version.hpp>
#include <limits>
#include <optional>
#include <pthread.h>
#include <thread>
#include <vector>

#include <spdlog/spdlog.h>

namespace stickslip::server {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = asio::ip::tcp;

bool ServerOptions::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors != nullptr) errors->push_back(m);
  };
  boost::system::error_code ec;
  asio::ip::make_address(bind, ec);
  if (ec) fail("bind: not an IP address: \"" + bind + "\"");
  if (io_threads < 1) fail("io_threads: must be >= 1, got " + std::to_string(io_threads));
  if (handler_threads < 0)
    fail("handler_threads: must be >= 0, got " + std::to_string(handler_threads));
  if (io_nice < 0 || io_nice > 19)
    fail("io_nice: must be in [0, 19], got " + std::to_string(io_nice));
  if (io_slice_us < 0 || io_slice_us > 100000)
    fail("io_slice_us: must be in [0, 100000], got " + std::to_string(io_slice_us));
  if (max_connections < 1)
    fail("max_connections: must be >= 1, got " + std::to_string(max_connections));
  if (max_header_bytes < 1024)
    fail("max_header_bytes: must be >= 1024, got " + std::to_string(max_header_bytes));
  for (const auto& [name, timeout] : {std::pair<const char*, std::chrono::milliseconds>{
                                          "idle_timeout", idle_timeout},
                                      {"read_timeout", read_timeout},
                                      {"write_timeout", write_timeout}})
    if (timeout.count() <= 0)
      fail(std::string(name) + ": must be > 0 ms, got " + std::to_string(timeout.count()));
  if (min_poll_interval.count() < 0 || min_poll_interval.count() > 10000)
    fail("min_poll_interval: must be in [0, 10000] ms, got " +
         std::to_string(min_poll_interval.count()));
  return ok;
}

struct HttpServer::Impl {
  // Declared first, destroyed last: sessions still queued in ioc or the handler pool when they
  // are destroyed decrement it.
  std::atomic<std::size_t> connections{0};
  ServerOptions options;
  HttpHandler handler;
  InlineHandler inline_handler;
  asio::io_context ioc;
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work;
  tcp::acceptor acceptor;
  // The handler pool: an io_context of its own run by handler_threads threads (not an
  // asio::thread_pool, whose threads cannot be given a priority when they start).
  asio::io_context handlers;
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> handlers_work;
  std::vector<std::thread> io_threads;
  bool started = false, stopped = false;

  Impl(ServerOptions o, HttpHandler h, InlineHandler fast)
      : options(std::move(o)),
        handler(std::move(h)),
        inline_handler(std::move(fast)),
        ioc(options.io_threads),
        acceptor(ioc),
        handlers(std::max(options.handler_threads, 1)) {}

  /// Runs ctx on a new thread at the I/O priority, named name (in ps/top and /proc/PID/task, so
  /// bench/server_load.sh can add up the CPU of the HTTP threads).
  void spawn(asio::io_context& ctx, const char* name) {
    io_threads.emplace_back([this, &ctx, name] {
      ::pthread_setname_np(::pthread_self(), name);
      std::string why;
      if (!lower_thread_priority(options.io_nice, &why))
        spdlog::warn("HTTP thread: cannot lower its priority: {}", why);
      if (!set_thread_slice(options.io_slice_us, &why))
        spdlog::debug("HTTP thread: no custom scheduler slice: {}", why);
      ctx.run();
    });
  }

  void accept();
};

namespace {

Request to_request(const http::request<http::string_body>& req) {
  Request r;
  r.method = std::string(req.method_string());
  r.target = std::string(req.target());
  for (const auto& field : req) r.headers.push_back({std::string(field.name_string()),
                                                     std::string(field.value())});
  r.body = req.body();
  return r;
}

http::response<http::string_body> to_beast(const Response& resp, unsigned version,
                                           bool keep_alive) {
  http::response<http::string_body> res{static_cast<http::status>(resp.status), version};
  res.set(http::field::server, "stickslipd");
  for (const auto& h : resp.headers) res.set(h.name, h.value);
  res.body() = resp.body;
  res.keep_alive(keep_alive);
  // A 304 has no body and must not claim Content-Length: 0 (RFC 9110 8.6: it would have to be
  // the length of the 200's body), so only other responses get their payload headers.
  if (resp.status != 304) res.prepare_payload();
  return res;
}

class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket socket, HttpServer::Impl& server)
      : stream_(std::move(socket)), server_(server) {
    server_.connections.fetch_add(1);
  }
  ~Session() { server_.connections.fetch_sub(1); }

  void start() {
    asio::dispatch(stream_.get_executor(),
                   beast::bind_front_handler(&Session::wait_request, shared_from_this()));
  }

  /// Over the connection limit: answer 503 and close.
  void reject() {
    asio::dispatch(stream_.get_executor(), [self = shared_from_this()] {
      self->send(problem(503, "too-many-connections", "Too many connections",
                         "the server has reached its connection limit; retry shortly"),
                 11, false);
    });
  }

 private:
  // Idle phase: wait for the first byte of the next request under idle_timeout.
  void wait_request() {
    if (buffer_.size() > 0) return read_request();
    stream_.expires_after(server_.options.idle_timeout);
    stream_.async_read_some(
        buffer_.prepare(4096),
        [self = shared_from_this()](beast::error_code ec, std::size_t n) {
          if (ec) return self->close();
          self->buffer_.commit(n);
          self->read_request();
        });
  }

  // Read phase: the whole request under read_timeout.
  void read_request() {
    parser_.emplace();
    // Beast would check a Content-Length against the parser's limit when the header completes,
    // before the path is known: the header is read without a body limit, and on_header applies
    // the limit of the request's path (so a 413 always quotes the limit of its own path).
    parser_->body_limit(std::numeric_limits<std::uint64_t>::max());  // (boost::none: 413 in 1.74)
    body_limit_ = server_.options.max_body_bytes;
    parser_->header_limit(static_cast<std::uint32_t>(server_.options.max_header_bytes));
    // The read deadline is a timer of the session, not the stream's: when it expires, the read
    // is cancelled and the client gets a 408 before the connection closes.
    stream_.expires_never();
    timed_out_ = false;
    read_deadline_.expires_after(server_.options.read_timeout);
    read_deadline_.async_wait([self = shared_from_this()](beast::error_code ec) {
      if (ec) return;  // cancelled: the request arrived in time
      self->timed_out_ = true;
      beast::error_code ignored;
      self->stream_.socket().cancel(ignored);
    });
    // The header first, then the body with the limit of the request's path (same deadline).
    http::async_read_header(stream_, buffer_, *parser_,
                            beast::bind_front_handler(&Session::on_header, shared_from_this()));
  }

  void on_header(beast::error_code ec, std::size_t n) {
    if (ec) return on_read(ec, n);
    const std::string target(parser_->get().target());
    const auto path = percent_decode(std::string_view(target).substr(0, target.find('?')));
    const auto it = server_.options.path_body_limits.find(path);
    body_limit_ =
        it != server_.options.path_body_limits.end() ? it->second : server_.options.max_body_bytes;
    if (const auto length = parser_->content_length(); length && *length > body_limit_)
      return on_read(http::error::body_limit, n);
    parser_->body_limit(body_limit_);  // chunked bodies are checked chunk by chunk
    // "Expect: 100-continue" (curl sends it for bodies over 1 MB and otherwise waits 1 s before
    // sending the body): the body is acceptable, so ask for it now.
    const auto expect = parser_->get().find(http::field::expect);
    if (expect != parser_->get().end() && iequals(std::string(expect->value()), "100-continue") &&
        !parser_->is_done()) {
      static const std::string kContinue = "HTTP/1.1 100 Continue\r\n\r\n";
      asio::async_write(stream_, asio::buffer(kContinue),
                        [self = shared_from_this()](beast::error_code wec, std::size_t) {
                          if (wec) return self->close();
                          self->read_body();
                        });
      return;
    }
    read_body();
  }

  void read_body() {
    http::async_read(stream_, buffer_, *parser_,
                     beast::bind_front_handler(&Session::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, std::size_t) {
    read_deadline_.cancel();
    if (timed_out_) {
      return send(problem(408, "request-timeout", "Request timeout",
                          "the request was not received within " +
                              std::to_string(server_.options.read_timeout.count()) +
                              " ms (stickslipd --read-timeout)"),
                  11, false);
    }
    if (ec == http::error::end_of_stream || ec == asio::error::eof) return close();
    if (ec == http::error::body_limit) {
      return send(problem(413, "body-too-large", "Request body too large",
                          "the body exceeds the limit of " + std::to_string(body_limit_) +
                              " bytes"),
                  11, false);
    }
    if (ec == http::error::header_limit) {
      return send(problem(431, "header-too-large", "Request header fields too large",
                          "the header exceeds the limit of " +
                              std::to_string(server_.options.max_header_bytes) + " bytes"),
                  11, false);
    }
    if (ec) {
      if (ec.category() == make_error_code(http::error::bad_target).category() || ec == http::error::partial_message) {
        return send(problem(400, "bad-request", "Bad request",
                            "the request is not valid HTTP/1.1: " + ec.message()),
                    11, false);
      }
      return close();
    }
    auto req = parser_->release();
    const unsigned version = req.version();
    const bool keep_alive = req.keep_alive();
    stream_.expires_never();  // the handler pool may take a moment; the write sets its own
    Request request = to_request(req);
    // Pacing (header comment): a repeated GET of the same target waits out min_poll_interval.
    const auto now = std::chrono::steady_clock::now();
    const bool repeat = request.method == "GET" && last_get_target_ == request.target;
    if (request.method == "GET") last_get_target_ = request.target;
    else last_get_target_.clear();
    if (repeat && server_.options.min_poll_interval.count() > 0 &&
        now < last_answer_ + server_.options.min_poll_interval) {
      pace_timer_.expires_at(last_answer_ + server_.options.min_poll_interval);
      pace_timer_.async_wait([self = shared_from_this(), request = std::move(request), version,
                              keep_alive](beast::error_code ec) mutable {
        if (ec) return self->close();
        self->dispatch(std::move(request), version, keep_alive);
      });
      return;
    }
    dispatch(std::move(request), version, keep_alive);
  }

  void dispatch(Request request, unsigned version, bool keep_alive) {
    // Inline on this I/O thread (no hand-off) only without a body: checking a body (a study's
    // design, a diagnosis's CSV files) can take long and must never hold the I/O thread.
    if (server_.options.handler_threads == 0 && request.body.empty())
      return send(server_.handler(request), version, keep_alive);
    if (server_.inline_handler) {
      if (auto resp = server_.inline_handler(request)) return send(*resp, version, keep_alive);
    }
    asio::post(server_.handlers, [self = shared_from_this(), request = std::move(request), version,
                                  keep_alive]() mutable {
      Response resp = self->server_.handler(request);
      asio::post(self->stream_.get_executor(),
                 [self, resp = std::move(resp), version, keep_alive]() mutable {
                   self->send(resp, version, keep_alive);
                 });
    });
  }

  void send(const Response& resp, unsigned version, bool keep_alive) {
    last_answer_ = std::chrono::steady_clock::now();
    response_ = to_beast(resp, version, keep_alive);
    stream_.expires_after(server_.options.write_timeout);
    http::async_write(stream_, response_,
                      [self = shared_from_this(), keep_alive](beast::error_code ec, std::size_t) {
                        if (ec || !keep_alive) return self->close();
                        self->wait_request();
                      });
  }

  void close() {
    read_deadline_.cancel();
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
    stream_.socket().close(ec);
  }

  beast::tcp_stream stream_;
  HttpServer::Impl& server_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::size_t body_limit_ = 0;  // of the request being read
  http::response<http::string_body> response_;
  // Pacing of repeated GETs (header comment).
  asio::steady_timer pace_timer_{stream_.get_executor()};
  // The deadline of reading one request (read_request), and whether it expired.
  asio::steady_timer read_deadline_{stream_.get_executor()};
  bool timed_out_ = false;
  std::string last_get_target_;
  std::chrono::steady_clock::time_point last_answer_{};
};

}  // namespace

void HttpServer::Impl::accept() {
  acceptor.async_accept(asio::make_strand(ioc), [this](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted || !acceptor.is_open()) return;
    if (!ec) {
      const bool over = connections.load() >= options.max_connections;
      auto session = std::make_shared<Session>(std::move(socket), *this);
      if (over) {
        session->reject();
      } else {
        session->start();
      }
    } else {
      spdlog::warn("accept failed: {}", ec.message());
    }
    accept();
  });
}

HttpServer::HttpServer(ServerOptions options, HttpHandler handler, InlineHandler inline_handler)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(handler),
                                   std::move(inline_handler))) {
  if (std::vector<std::string> errors; !impl_->options.IsValid(&errors))
    throw std::invalid_argument("ServerOptions: " + common::join(errors, "; "));
  const tcp::endpoint ep(asio::ip::make_address(impl_->options.bind), impl_->options.port);
  beast::error_code ec;
  auto& a = impl_->acceptor;
  a.open(ep.protocol(), ec);
  if (!ec) a.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) a.bind(ep, ec);
  if (!ec) a.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error("cannot listen on " + impl_->options.bind + ":" +
                             std::to_string(impl_->options.port) + ": " + ec.message());
  }
}

HttpServer::~HttpServer() { stop(); }

unsigned short HttpServer::port() const noexcept {
  beast::error_code ec;
  const auto ep = impl_->acceptor.local_endpoint(ec);
  return ec ? 0 : ep.port();
}

void HttpServer::start() {
  if (impl_->started) return;
  impl_->started = true;
  impl_->work.emplace(impl_->ioc.get_executor());
  impl_->handlers_work.emplace(impl_->handlers.get_executor());
  impl_->accept();
  for (int i = 0; i < impl_->options.io_threads; ++i) impl_->spawn(impl_->ioc, "http-io");
  // At least one handler thread: requests with a body never run on an I/O thread.
  for (int i = 0; i < std::max(impl_->options.handler_threads, 1); ++i)
    impl_->spawn(impl_->handlers, "http-handler");
}

void HttpServer::stop_accepting() {
  asio::post(impl_->ioc, [this] {
    beast::error_code ec;
    impl_->acceptor.close(ec);
  });
  if (!impl_->started) {
    beast::error_code ec;
    impl_->acceptor.close(ec);
  }
}

void HttpServer::stop() {
  if (impl_->stopped) return;
  impl_->stopped = true;
  impl_->work.reset();
  impl_->handlers_work.reset();
  impl_->ioc.stop();
  impl_->handlers.stop();
  for (auto& t : impl_->io_threads) t.join();
  impl_->io_threads.clear();
}

std::size_t HttpServer::connections() const noexcept { return impl_->connections.load(); }

}  // namespace stickslip::server
