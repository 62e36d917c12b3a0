// The Beast transport in-process (real sockets, no study runner): request/response conversion,
// keep-alive, 413 for a body over the limit, a slow client cut off by the read timeout, an idle
// connection closed, the connection limit, and the server still serving after every bad request.
#include "stickslip/server/http_server.h"

#include <gtest/gtest.h>

#include <boost/asio.hpp>
#include <chrono>
#include <cstdio>
#include <thread>

#include "stickslip/server/api.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using namespace std::chrono_literals;

/// A blocking raw TCP client: send bytes, read until the server closes or a full response.
class RawClient {
 public:
  explicit RawClient(unsigned short port) : socket_(ioc_) {
    socket_.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  }
  void send(const std::string& bytes) { asio::write(socket_, asio::buffer(bytes)); }
  /// Reads until EOF (the server closed the connection) and returns everything received.
  std::string read_to_eof() {
    std::string out;
    boost::system::error_code ec;
    char buf[4096];
    while (true) {
      const std::size_t n = socket_.read_some(asio::buffer(buf), ec);
      out.append(buf, n);
      if (ec) break;
    }
    return out;
  }
  /// Reads one response with a Content-Length body.
  std::string read_response() {
    std::string out;
    char buf[4096];
    while (true) {
      const auto end = out.find("\r\n\r\n");
      if (end != std::string::npos) {
        const auto cl = out.find("Content-Length: ");
        const std::size_t len = cl == std::string::npos ? 0 : std::stoul(out.substr(cl + 16));
        if (out.size() >= end + 4 + len) return out;
      }
      const std::size_t n = socket_.read_some(asio::buffer(buf));
      out.append(buf, n);
    }
  }

 private:
  asio::io_context ioc_;
  tcp::socket socket_;
};

class TransportTest : public ::testing::Test {
 protected:
  void start(ServerOptions net = {}) {
    ApiOptions o;
    o.db = dir_ / "t.db";
    o.max_body_bytes = 2048;
    api_ = std::make_unique<Api>(o);
    net.port = 0;
    net.max_body_bytes = o.max_body_bytes;
    server_ = std::make_unique<HttpServer>(net, [this](const Request& r) { return api_->handle(r); });
    server_->start();
  }
  std::string get_healthz() {
    RawClient c(server_->port());
    c.send("GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    return c.read_to_eof();
  }
  testing::TempDir dir_;
  std::unique_ptr<Api> api_;
  std::unique_ptr<HttpServer> server_;
};

TEST_F(TransportTest, EphemeralPortServesAndKeepsConnectionsAlive) {
  start();
  ASSERT_NE(server_->port(), 0);
  RawClient c(server_->port());
  for (int i = 0; i < 3; ++i) {  // three requests on one connection
    c.send("GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n");
    const std::string r = c.read_response();
    EXPECT_EQ(r.substr(0, 15), "HTTP/1.1 200 OK") << r;
    EXPECT_NE(r.find("{\"status\":\"ok\"}"), std::string::npos);
  }
  c.send("POST /v1/studies HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
         "Content-Length: 5\r\nConnection: close\r\n\r\n{\"a\":");
  const std::string bad = c.read_to_eof();
  EXPECT_EQ(bad.substr(0, 12), "HTTP/1.1 400") << bad;
  EXPECT_NE(bad.find("application/problem+json"), std::string::npos);
}

TEST_F(TransportTest, BodyOverTheLimitIs413BeforeItIsRead) {
  start();
  RawClient c(server_->port());
  // Announce 1 MB but send nothing: the limit is checked on Content-Length.
  c.send("POST /v1/studies HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
         "Content-Length: 1000000\r\n\r\n");
  const std::string r = c.read_to_eof();
  EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 413") << r;
  EXPECT_NE(r.find("application/problem+json"), std::string::npos);
  EXPECT_EQ(get_healthz().substr(0, 12), "HTTP/1.1 200");
}

TEST_F(TransportTest, DiagnosesHaveTheirOwnBodyLimit) {
  ServerOptions net;
  net.path_body_limits["/v1/diagnoses"] = 16384;
  start(net);
  // 8 KB: over the default limit of 2 KB for studies (413 on Content-Length, before the body) ...
  {
    RawClient c(server_->port());
    c.send("POST /v1/studies HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
           "Content-Length: 8192\r\n\r\n");
    const std::string r = c.read_to_eof();
    EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 413") << r;
    EXPECT_NE(r.find("limit of 2048 bytes"), std::string::npos) << r;
  }
  // ... but read whole for diagnoses and handed to the handler (422: not a valid request) ...
  {
    RawClient c(server_->port());
    const std::string body = "{\"manifest\": {}, \"pad\": \"" + std::string(8000, 'x') + "\"}";
    c.send("POST /v1/diagnoses HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
           "Content-Length: " + std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body);
    const std::string r = c.read_to_eof();
    EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 422") << r.substr(0, 300);
    EXPECT_NE(r.find("/pad"), std::string::npos);
  }
  // ... up to its own limit, also for a chunked body that never says its length.
  {
    RawClient c(server_->port());
    c.send("POST /v1/diagnoses HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
           "Content-Length: 20000\r\n\r\n");
    const std::string r = c.read_to_eof();
    EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 413") << r;
    EXPECT_NE(r.find("limit of 16384 bytes"), std::string::npos) << r;
  }
  {
    RawClient c(server_->port());
    const std::string chunk(10000, ' ');
    char size[16];
    std::snprintf(size, sizeof size, "%zx", chunk.size());
    c.send("POST /v1/diagnoses HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
           "Transfer-Encoding: chunked\r\n\r\n" + std::string(size) + "\r\n" + chunk + "\r\n" +
           std::string(size) + "\r\n" + chunk + "\r\n0\r\n\r\n");
    const std::string r = c.read_to_eof();
    EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 413") << r;
  }
  EXPECT_EQ(get_healthz().substr(0, 12), "HTTP/1.1 200");
}

TEST_F(TransportTest, ExpectContinueIsAnsweredBeforeTheBodyIsSent) {
  start();
  RawClient c(server_->port());
  const std::string body = "{\"a\": 1}";
  c.send("POST /v1/diagnoses HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
         "Expect: 100-continue\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n");
  const std::string interim = c.read_response();  // before any byte of the body
  EXPECT_EQ(interim, "HTTP/1.1 100 Continue\r\n\r\n");
  c.send(body);
  const std::string r = c.read_response();
  EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 422") << r;
  // Over the limit: no 100, the 413 straight away.
  RawClient big(server_->port());
  big.send("POST /v1/studies HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
           "Expect: 100-continue\r\nContent-Length: 100000\r\n\r\n");
  EXPECT_EQ(big.read_to_eof().substr(0, 12), "HTTP/1.1 413");
}

TEST_F(TransportTest, SlowClientIsCutOffByTheReadTimeout) {
  ServerOptions net;
  net.read_timeout = 300ms;
  start(net);
  RawClient c(server_->port());
  const auto t0 = std::chrono::steady_clock::now();
  c.send("GET /healthz HTTP/1.1\r\nHo");  // ... and never the rest
  const std::string r = c.read_to_eof();
  const auto waited = std::chrono::steady_clock::now() - t0;
  EXPECT_EQ(r, "");  // tcp_stream closes the socket when the read times out
  EXPECT_GE(waited, 250ms);
  EXPECT_LT(waited, 5s);
  EXPECT_EQ(get_healthz().substr(0, 12), "HTTP/1.1 200");
}

TEST_F(TransportTest, IdleConnectionIsClosed) {
  ServerOptions net;
  net.idle_timeout = 200ms;
  start(net);
  RawClient c(server_->port());
  EXPECT_EQ(c.read_to_eof(), "");  // closed without a byte
}

TEST_F(TransportTest, ConnectionsOverTheLimitGet503) {
  ServerOptions net;
  net.max_connections = 2;
  start(net);
  RawClient a(server_->port()), b(server_->port());
  // Let the server accept both before the third arrives.
  for (int i = 0; i < 100 && server_->connections() < 2; ++i) std::this_thread::sleep_for(10ms);
  ASSERT_EQ(server_->connections(), 2u);
  RawClient c(server_->port());
  const std::string r = c.read_to_eof();
  EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 503") << r;
}

TEST_F(TransportTest, GarbageIsA400AndTheServerKeepsServing) {
  start();
  RawClient c(server_->port());
  c.send("THIS IS NOT HTTP\r\n\r\n");
  const std::string r = c.read_to_eof();
  EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 400") << r;
  EXPECT_EQ(get_healthz().substr(0, 12), "HTTP/1.1 200");
}

TEST(ServerOptions, InvalidOptionsNameTheField) {
  ServerOptions o;
  o.bind = "localhost:80";
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("bind"), std::string::npos);
}

}  // namespace
}  // namespace stickslip::server
