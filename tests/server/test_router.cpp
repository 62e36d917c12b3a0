// Router and HTTP value helpers: pattern matching, 404, 405 + Allow, query parsing.
#include "stickslip/server/router.h"

#include <gtest/gtest.h>

#include "test_support.h"

namespace stickslip::server {
namespace {

using testing::body_json;
using testing::get;

TEST(Router, MatchesLiteralsParametersAndCustomVerbs) {
  PathParams p;
  EXPECT_TRUE(Router::match("/v1/studies", "/v1/studies", &p));
  EXPECT_FALSE(Router::match("/v1/studies", "/v1/studies/x", &p));
  EXPECT_TRUE(Router::match("/v1/studies/{id}", "/v1/studies/st-1", &p));
  EXPECT_EQ(p.at("id"), "st-1");
  EXPECT_TRUE(Router::match("/v1/studies/{id}:cancel", "/v1/studies/st-2:cancel", &p));
  EXPECT_EQ(p.at("id"), "st-2");
  // A plain parameter never swallows a custom verb, and the verb needs a non-empty id.
  EXPECT_FALSE(Router::match("/v1/studies/{id}", "/v1/studies/st-2:cancel", &p));
  EXPECT_FALSE(Router::match("/v1/studies/{id}:cancel", "/v1/studies/:cancel", &p));
  EXPECT_FALSE(Router::match("/v1/studies/{id}:cancel", "/v1/studies/st-2:pause", &p));
  EXPECT_FALSE(Router::match("/v1/studies/{id}", "/v1/studies/", &p));
}

TEST(Router, UnknownPathIs404AndWrongMethodIs405WithAllow) {
  Router router;
  router.add("GET", "/a/{id}", [](const Request&, const PathParams& p) {
    return json_response(200, {{"id", p.at("id")}});
  });
  router.add("DELETE", "/a/{id}", [](const Request&, const PathParams&) {
    return json_response(204, nullptr);
  });
  EXPECT_EQ(body_json(router.route(get("/a/x%2Dy")))["id"], "x-y");  // percent-decoded

  const Response nf = router.route(get("/b"));
  EXPECT_EQ(nf.status, 404);
  EXPECT_EQ(nf.header("Content-Type"), "application/problem+json");
  EXPECT_EQ(body_json(nf)["status"], 404);

  const Response na = router.route(Request{"PUT", "/a/1", {}, ""});
  EXPECT_EQ(na.status, 405);
  EXPECT_EQ(na.header("Allow"), "GET, DELETE");
  EXPECT_EQ(na.header("Content-Type"), "application/problem+json");
}

TEST(Router, HandlerExceptionBecomes500ProblemAndDuplicateRoutesAreRejected) {
  Router router;
  router.add("GET", "/x", [](const Request&, const PathParams&) -> Response {
    throw std::runtime_error("boom");
  });
  const Response r = router.route(get("/x"));
  EXPECT_EQ(r.status, 500);
  EXPECT_NE(body_json(r)["detail"].get<std::string>().find("boom"), std::string::npos);
  EXPECT_THROW(router.add("GET", "/x", {}), std::invalid_argument);
  EXPECT_THROW(router.add("GET", "x", {}), std::invalid_argument);
}

TEST(Http, QueryAndHeadersAreDecodedCaseInsensitively) {
  Request r = get("/v1/studies?page_size=2&page_token=st%2D1&a=x+y&page_size=9",
                  {{"ACCEPT", "text/csv"}});
  const auto q = r.query();
  EXPECT_EQ(q.at("page_size"), "2");  // the first of a repeated parameter
  EXPECT_EQ(q.at("page_token"), "st-1");
  EXPECT_EQ(q.at("a"), "x y");
  EXPECT_EQ(r.path(), "/v1/studies");
  EXPECT_EQ(r.header("accept"), "text/csv");
  EXPECT_EQ(percent_decode("%zz%4"), "%zz%4");  // invalid escapes are kept
}

}  // namespace
}  // namespace stickslip::server
