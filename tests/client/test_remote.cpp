// The client side of the server commands without a server: URL parsing and readable problem
// messages with field paths.
#include "stickslip/client/remote.h"

#include <gtest/gtest.h>

namespace stickslip::client {
namespace {

using nlohmann::json;

TEST(ServerUrl, ParsesHostPortAndPrefix) {
  auto u = ServerUrl::parse("http://127.0.0.1:8080");
  EXPECT_EQ(u.host, "127.0.0.1");
  EXPECT_EQ(u.port, "8080");
  EXPECT_EQ(u.prefix, "");
  u = ServerUrl::parse("http://example.org/stickslip/");
  EXPECT_EQ(u.host, "example.org");
  EXPECT_EQ(u.port, "80");
  EXPECT_EQ(u.prefix, "/stickslip");
  u = ServerUrl::parse("http://[::1]:9000");
  EXPECT_EQ(u.host, "::1");
  EXPECT_EQ(u.port, "9000");
  EXPECT_EQ(u.to_string(), "http://[::1]:9000");
}

TEST(ServerUrl, RejectsWhatItCannotUseNamingTheUrl) {
  for (const std::string bad : {"127.0.0.1:8080", "https://x", "http://", "http://x:0",
                                "http://x:99999", "http://x:8o80", "ftp://x"}) {
    try {
      ServerUrl::parse(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("--server"), std::string::npos) << e.what();
    }
  }
}

TEST(DescribeError, ListsEveryFieldOfAProblem) {
  HttpReply r;
  r.status = 422;
  r.headers = {{"Content-Type", "application/problem+json"}};
  r.body = json({{"type", "urn:stickslip:problem:invalid-study"},
                 {"title", "Invalid study"},
                 {"status", 422},
                 {"detail", "2 problem(s)"},
                 {"errors",
                  {{{"pointer", "/base/m"}, {"detail", "must be > 0, got -1"}},
                   {{"header", "Idempotency-Key"}, {"detail", "already used"}},
                   {{"pointer", ""}, {"detail", "syntax error at line 1"}}}}})
               .dump();
  const std::string text = describe_error(r);
  EXPECT_NE(text.find("422 Invalid study (3 problems):"), std::string::npos) << text;
  EXPECT_NE(text.find("\n  /base/m: must be > 0, got -1"), std::string::npos) << text;
  EXPECT_NE(text.find("\n  header Idempotency-Key: already used"), std::string::npos) << text;
  EXPECT_NE(text.find("\n  (document): syntax error"), std::string::npos) << text;

  HttpReply plain;
  plain.status = 502;
  plain.body = "bad gateway";
  EXPECT_EQ(describe_error(plain), "server: HTTP 502: bad gateway");
}

}  // namespace
}  // namespace stickslip::client
