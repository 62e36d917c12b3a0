#pragma once
// The HTTP/1.1 transport of stickslipd: Boost.Beast over Boost.Asio.
//
// Threads: io_threads run the Asio event loop and only do I/O (accept, read, write). Each
// parsed request is handed to a separate pool of handler_threads, which calls the pure handler
// (store reads, validation) and posts the response back to the connection's strand, so a slow
// handler never stalls other connections' I/O. Studies run in the Worker, on threads of its own.
// An optional inline handler answers what it can without blocking (a cache hit) on the I/O
// thread itself, which saves the two thread hand-offs of the pool for the most frequent request.
//
// Priority: the I/O and handler threads run at io_nice (added to the process's nice value;
// default 0, the study's priority). What protects a running study from a flood of requests
// (e.g. 50 clients polling back to back) is min_poll_interval below, which bounds how often a
// connection is answered, rather than a low priority, which made latency follow every other
// load on the machine (docs/server.md, Load: both policies measured). io_nice > 0 is still
// available for deployments that prefer the study's throughput over API latency.
//
// Limits, per connection:
//  - idle_timeout: how long a connection may sit without sending the first byte of a request;
//  - read_timeout: how long reading one whole request (header and body) may take, so a client
//    that sends slowly cannot hold a connection (and its memory) for long; it then gets a 408
//    and the connection closes;
//  - write_timeout: the same for writing the response;
//  - max_body_bytes / max_header_bytes: larger requests get 413 / 431 and the connection closes;
//    path_body_limits raises (or lowers) the body limit for exact request paths (the header is
//    read first, then the body with the limit of its path), e.g. "/v1/diagnoses" -> 64 MiB;
//    a request with "Expect: 100-continue" gets "100 Continue" once its header is accepted;
//  - max_connections: connections beyond it get 503 immediately and are closed;
//  - min_poll_interval: a GET for the same target on the same connection within this time of
//    the previous answer to it waits out the rest of the interval before it is handled (no error,
//    just later). Studies change at most once per study-cache period (100 ms), so a client that
//    polls faster learns nothing new; pacing bounds what a back-to-back poller can take from a
//    running study (50 connections x 1 / 20 ms = 2,500 answers/s at most) while any other
//    request, and the first poll, is answered at once. 0 = no pacing.

#include <chrono>
#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "stickslip/server/http.h"

namespace stickslip::server {

struct ServerOptions {
  std::string bind = "127.0.0.1";
  unsigned short port = 8080;  ///< 0: an ephemeral port (see HttpServer::port())
  int io_threads = 1;
  int handler_threads = 2;  ///< 0: handlers of requests without a body run on the I/O thread
  /// Nice increment (Linux, per thread, 0..19) of the I/O and handler threads over the
  /// process's nice value; 0 (default) = same priority as the rest of the process, e.g. a
  /// study (WorkerOptions::nice 0): see the header comment.
  int io_nice = 0;
  /// Scheduler slice of the I/O and handler threads [us] (Linux >= 6.12; see
  /// set_thread_slice): short slices let a low-priority thread run more often in smaller pieces,
  /// which cuts its latency without raising its share. 0 = the kernel's default; 0..100000.
  int io_slice_us = 100;
  std::size_t max_body_bytes = 1 << 20;
  std::map<std::string, std::size_t> path_body_limits;  ///< exact path (no query) -> bytes
  std::size_t max_header_bytes = 16 << 10;
  std::size_t max_connections = 256;
  std::chrono::milliseconds idle_timeout{30000};
  std::chrono::milliseconds read_timeout{10000};
  std::chrono::milliseconds write_timeout{30000};
  std::chrono::milliseconds min_poll_interval{20};  ///< 0..10000; see the header comment

  /// True if every field holds. Otherwise appends one message per broken constraint, naming the
  /// field and the value, to *errors when errors is non-null.
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

using HttpHandler = std::function<Response(const Request&)>;
/// Called on the I/O thread before a request goes to the handler pool: a response, or nullopt
/// to hand the request to the pool. It must not block (no store, no file I/O) and never throw.
using InlineHandler = std::function<std::optional<Response>(const Request&)>;


class HttpServer {
 public:
  /// Binds and listens (throws std::runtime_error naming the address when it cannot), but
  /// serves nothing until start().
  HttpServer(ServerOptions options, HttpHandler handler, InlineHandler inline_handler = {});
  ~HttpServer();  ///< stop()
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  /// The bound port (the chosen one when options.port was 0).
  unsigned short port() const noexcept;
  /// Starts the I/O and handler threads.
  void start();
  /// Closes the listening socket: new connections are refused; open ones are still served.
  void stop_accepting();
  /// Stops everything and joins the threads. Idempotent.
  void stop();
  /// Connections open now.
  std::size_t connections() const noexcept;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace stickslip::server
