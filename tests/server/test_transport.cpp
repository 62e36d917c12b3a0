// The Beast transport in-process (real sockets, no study runner): request/response conversion,
// keep-alive, 413 for a body over the limit, a slow client cut off by the read timeout, an idle
// connection closed, the connection limit, and the server still serving after every bad request.
#include "stickslip/server/http_server.h"

#include <gtest/gtest.h>

#include <boost/asio.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "stickslip/server/api.h"
#include "stickslip/server/priority.h"
#include "test_support.h"
#include "support/is_valid.h"

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

TEST_F(TransportTest, A413QuotesTheLimitOfItsOwnPath) {
  // Over the diagnoses' (larger) limit too: the header used to be read under the largest limit,
  // and the 413 of /v1/studies quoted the diagnoses' (issue 18, defect 6).
  ServerOptions net;
  net.path_body_limits["/v1/diagnoses"] = 16384;
  start(net);
  RawClient c(server_->port());
  c.send("POST /v1/studies HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
         "Content-Length: 20000\r\n\r\n");
  const std::string r = c.read_to_eof();
  EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 413") << r;
  EXPECT_NE(r.find("limit of 2048 bytes"), std::string::npos) << r;
  EXPECT_EQ(r.find("16384"), std::string::npos) << r;
}

TEST_F(TransportTest, TwoLargeDesignsOnBothHandlerThreadsAreAcceptedAndHealthzIsAnswered) {
  // Two 600 KB list designs on both handler threads are both accepted, and an unrelated GET sent
  // after them is answered (issue 18, defect 4: a quadratic validation held both threads, and
  // the GET waited 30 s). How long the validation takes per point, and that it stays linear, is
  // measured by bench/study_bench (section 4), not bounded here.
  ApiOptions o;
  o.db = dir_ / "big.db";
  o.max_body_bytes = 8 << 20;
  o.limits.max_runs = 300000;
  api_ = std::make_unique<Api>(o);
  ServerOptions net;
  net.port = 0;
  net.max_body_bytes = o.max_body_bytes;
  net.handler_threads = 2;
  server_ = std::make_unique<HttpServer>(net, [this](const Request& r) { return api_->handle(r); });
  server_->start();
  std::string points;
  for (int i = 0; i < 200000; ++i) points += i ? ",{}" : "{}";  // 600 KB
  const std::string body = R"({"name": "big", "stages": [{"duration": 0.1}], )"
                           R"("design": {"type": "list", "points": [)" + points + "]}}";
  const std::string post = "POST /v1/studies HTTP/1.1\r\nHost: x\r\nContent-Type: "
                           "application/json\r\nConnection: close\r\nContent-Length: " +
                           std::to_string(body.size()) + "\r\n\r\n" + body;
  RawClient a(server_->port()), b(server_->port());
  a.send(post);
  b.send(post);
  EXPECT_EQ(get_healthz().substr(0, 12), "HTTP/1.1 200");
  const std::string ra = a.read_to_eof(), rb = b.read_to_eof();
  EXPECT_EQ(ra.substr(0, 12), "HTTP/1.1 202") << ra.substr(0, 300);
  EXPECT_EQ(rb.substr(0, 12), "HTTP/1.1 202") << rb.substr(0, 300);
  EXPECT_NE(ra, rb);  // two studies, two ids
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
  // Told why before the connection closes (issue 18, defect 6: it was closed without a word).
  EXPECT_EQ(r.substr(0, 12), "HTTP/1.1 408") << r;
  EXPECT_NE(r.find("read-timeout"), std::string::npos) << r;
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
  EXPECT_FALSE(stickslip::testing::is_valid(o, why));
  EXPECT_NE(why.find("bind"), std::string::npos);
  for (const int bad : {-1, 20, 25}) {
    o = ServerOptions{};
    o.io_nice = bad;
    EXPECT_FALSE(stickslip::testing::is_valid(o, why)) << bad;
    EXPECT_NE(why.find("io_nice"), std::string::npos) << why;
    EXPECT_NE(why.find("got " + std::to_string(bad)), std::string::npos) << why;
  }
  o = ServerOptions{};
  o.io_nice = 19;
  EXPECT_TRUE(stickslip::testing::is_valid(o, why)) << why;
  for (const int bad : {-5, 100001}) {
    o = ServerOptions{};
    o.io_slice_us = bad;
    EXPECT_FALSE(stickslip::testing::is_valid(o, why)) << bad;
    EXPECT_NE(why.find("io_slice_us"), std::string::npos) << why;
    EXPECT_NE(why.find("got " + std::to_string(bad)), std::string::npos) << why;
  }
}

TEST(ServerOptions, EveryBrokenOptionIsNamedWithItsValue) {
  ServerOptions o;
  o.io_threads = 0;
  o.max_connections = 0;
  o.read_timeout = std::chrono::milliseconds(-7);
  std::vector<std::string> errors;
  EXPECT_FALSE(o.IsValid(&errors));
  ASSERT_EQ(errors.size(), 3u);
  EXPECT_NE(errors[0].find("io_threads"), std::string::npos) << errors[0];
  EXPECT_NE(errors[0].find("got 0"), std::string::npos) << errors[0];
  EXPECT_NE(errors[1].find("max_connections"), std::string::npos) << errors[1];
  EXPECT_NE(errors[1].find("got 0"), std::string::npos) << errors[1];
  EXPECT_NE(errors[2].find("read_timeout"), std::string::npos) << errors[2];
  EXPECT_NE(errors[2].find("got -7"), std::string::npos) << errors[2];
  EXPECT_FALSE(o.IsValid());  // errors may be null
  EXPECT_TRUE(ServerOptions{}.IsValid());
}

TEST(ServerOptions, MinPollIntervalIsBounded) {
  ServerOptions o;
  std::string why;
  for (const auto bad : {-1ll, 10001ll}) {
    o.min_poll_interval = std::chrono::milliseconds(bad);
    EXPECT_FALSE(stickslip::testing::is_valid(o, why)) << bad;
    EXPECT_NE(why.find("min_poll_interval"), std::string::npos) << why;
    EXPECT_NE(why.find("got " + std::to_string(bad)), std::string::npos) << why;
  }
  o.min_poll_interval = 0ms;
  EXPECT_TRUE(stickslip::testing::is_valid(o, why)) << why;
}

// Pacing is behaviour, checked with wide margins: a repeated GET of the same target on the same
// connection is answered no sooner than min_poll_interval after the previous answer (a lower
// bound, which load cannot break); another target, or the same one after the interval, is not
// held back (upper bounds far above any normal answer time).
TEST_F(TransportTest, RepeatedGetOnAConnectionIsPaced) {
  ServerOptions net;
  net.min_poll_interval = 1500ms;
  start(net);
  RawClient c(server_->port());
  const auto get = [&c](const std::string& target) {
    const auto t0 = std::chrono::steady_clock::now();
    c.send("GET " + target + " HTTP/1.1\r\nHost: x\r\n\r\n");
    const std::string r = c.read_response();
    EXPECT_EQ(r.substr(0, 15), "HTTP/1.1 200 OK") << r.substr(0, 200);
    return std::chrono::steady_clock::now() - t0;
  };
  get("/healthz");
  EXPECT_GE(get("/healthz"), 1400ms) << "a repeat within the interval must wait it out";
  EXPECT_LT(get("/v1/openapi.json"), 1200ms) << "another target is not paced";
  std::this_thread::sleep_for(1600ms);
  EXPECT_LT(get("/v1/openapi.json"), 1200ms) << "a repeat after the interval is not paced";
  RawClient other(server_->port());  // pacing is per connection
  const auto t0 = std::chrono::steady_clock::now();
  other.send("GET /v1/openapi.json HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(other.read_response().substr(0, 15), "HTTP/1.1 200 OK");
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1200ms);
}

/// Nice values of this process's threads (/proc/self/task/TID/stat, field 19).
std::vector<int> thread_nice_values() {
  std::vector<int> out;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task")) {
    std::ifstream in(task.path() / "stat");
    std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto close = stat.rfind(')');  // the comm field may hold spaces
    if (close == std::string::npos) continue;
    std::istringstream fields(stat.substr(close + 2));  // field 3 onwards
    std::string f;
    for (int i = 3; i <= 19 && (fields >> f); ++i)
      if (i == 19) out.push_back(std::stoi(f));
  }
  return out;
}

TEST(ThreadPriority, LowersTheCallingThreadOnlyAndNamesABadIncrement) {
  const int process_nice = thread_nice();
  int seen = -100;
  bool ok = false;
  std::thread([&] {
    std::string why;
    ok = lower_thread_priority(3, &why);
    seen = thread_nice();
  }).join();
  EXPECT_TRUE(ok);
  EXPECT_EQ(seen, std::min(19, process_nice + 3));
  EXPECT_EQ(thread_nice(), process_nice);  // this thread is unchanged
  std::string why;
  EXPECT_FALSE(lower_thread_priority(25, &why));
  EXPECT_NE(why.find("25"), std::string::npos) << why;
  EXPECT_TRUE(lower_thread_priority(0, &why));
  EXPECT_EQ(thread_nice(), process_nice);
}

/// se.slice [ns] of the calling thread from /proc/thread-self/sched; -1 when not shown.
long long own_slice_ns() {
  std::ifstream in("/proc/thread-self/sched");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("se.slice", 0) == 0) return std::stoll(line.substr(line.find(':') + 1));
  }
  return -1;
}

TEST(ThreadPriority, SliceIsSetForTheCallingThreadKeepingItsNice) {
  std::string why;
  EXPECT_FALSE(set_thread_slice(-1, &why));
  EXPECT_NE(why.find("-1"), std::string::npos) << why;
  EXPECT_TRUE(set_thread_slice(0, &why));  // nothing to do
  bool ok = false;
  long long slice = -1;
  int nice_before = 0, nice_after = 0;
  std::thread([&] {
    lower_thread_priority(2, &why);
    nice_before = thread_nice();
    ok = set_thread_slice(300, &why);
    nice_after = thread_nice();
    slice = own_slice_ns();
  }).join();
  if (!ok) GTEST_SKIP() << "the kernel has no custom slices: " << why;
  EXPECT_EQ(nice_after, nice_before);
  if (slice >= 0) {
    EXPECT_EQ(slice, 300000);
  }
}

TEST_F(TransportTest, HttpThreadsRunAtTheIoNiceIncrement) {
  const int base = thread_nice();
  const auto count_at = [](int nice) {
    const auto v = thread_nice_values();
    return std::count(v.begin(), v.end(), nice);
  };
  const auto before = count_at(std::min(19, base + 7));
  ServerOptions net;
  net.io_threads = 1;
  net.handler_threads = 2;
  net.io_nice = 7;
  start(net);
  EXPECT_EQ(get_healthz().substr(0, 12), "HTTP/1.1 200");  // threads are up and serving
  // A handler thread sets its nice when it starts, which may be after the I/O thread has
  // answered (seen once in a full ctest -j2 run): wait up to 5 s for all three.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (count_at(std::min(19, base + 7)) - before < 3 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(count_at(std::min(19, base + 7)) - before, 3);  // 1 I/O + 2 handler threads
}

TEST_F(TransportTest, InlineHandlerAnswersOnTheIoThreadAndPassesTheRestOn) {
  ApiOptions o;
  o.db = dir_ / "t.db";
  api_ = std::make_unique<Api>(o);
  ServerOptions net;
  net.port = 0;
  std::atomic<int> inline_calls{0};
  server_ = std::make_unique<HttpServer>(
      net, [this](const Request& r) { return api_->handle(r); },
      [&inline_calls](const Request& r) -> std::optional<Response> {
        ++inline_calls;
        if (r.target == "/not-modified") {
          Response nm;
          nm.status = 304;
          nm.set_header("ETag", "\"x\"");
          return nm;
        }
        if (r.target != "/inline") return std::nullopt;
        return text_response(200, "text/plain", "from the I/O thread");
      });
  server_->start();
  RawClient c(server_->port());
  c.send("GET /inline HTTP/1.1\r\nHost: x\r\n\r\n");
  const std::string a = c.read_response();
  EXPECT_EQ(a.substr(0, 15), "HTTP/1.1 200 OK") << a;
  EXPECT_NE(a.find("from the I/O thread"), std::string::npos) << a;
  c.send("GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n");
  const std::string b = c.read_response();
  EXPECT_NE(b.find("{\"status\":\"ok\"}"), std::string::npos) << b;  // the pool's answer
  // A 304 has no body and no Content-Length, and the connection stays usable after it.
  c.send("GET /not-modified HTTP/1.1\r\nHost: x\r\n\r\n");
  const std::string nm = c.read_response();
  EXPECT_EQ(nm.substr(0, 12), "HTTP/1.1 304") << nm;
  EXPECT_EQ(nm.find("Content-Length"), std::string::npos) << nm;
  EXPECT_EQ(nm.substr(nm.size() - 4), "\r\n\r\n") << nm;
  c.send("GET /inline HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(c.read_response().substr(0, 15), "HTTP/1.1 200 OK");
  EXPECT_EQ(inline_calls.load(), 4);
}

}  // namespace
}  // namespace stickslip::server
