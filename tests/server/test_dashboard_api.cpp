// The web dashboard's side of the server, without sockets: its files at / and /ui/... (embedded,
// exact vendored bytes, ETag and 304), the security headers on every response (the
// Content-Security-Policy; the reports' own), and no inline script or HTML-building call in
// the dashboard's own code.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>

#include "stickslip/server/api.h"
#include "stickslip/server/dashboard.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

using nlohmann::json;
using testing::body_json;
using testing::get;
using testing::post_json;
using testing::TempDir;
using testing::tiny_study;

std::string source_file(const std::string& rel) {
  std::ifstream in(std::string(STICKSLIP_SOURCE_DIR) + "/" + rel, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class DashboardApi : public ::testing::Test {
 protected:
  ApiOptions options() {
    ApiOptions o;
    o.db = dir_ / "d.db";
    o.reports_dir = dir_ / "reports";
    return o;
  }
  TempDir dir_;
};

TEST_F(DashboardApi, IndexAndFilesAreServedFromTheBinaryWithETags) {
  Api api(options());
  const Response index = api.handle(get("/"));
  ASSERT_EQ(index.status, 200) << index.body;
  EXPECT_EQ(index.header("Content-Type"), "text/html; charset=utf-8");
  EXPECT_EQ(index.body, source_file("server/web/index.html"));
  EXPECT_EQ(index.header("Cache-Control"), "no-cache");
  const auto etag = index.header("ETag");
  ASSERT_TRUE(etag);
  const Response again = api.handle(get("/", {{"If-None-Match", *etag}}));
  EXPECT_EQ(again.status, 304);
  EXPECT_TRUE(again.body.empty());

  const Response js = api.handle(get("/ui/js/pages/study.js"));
  ASSERT_EQ(js.status, 200);
  EXPECT_EQ(js.header("Content-Type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(js.body, source_file("server/web/js/pages/study.js"));
  // The vendored chart library: the exact upstream file, cacheable for good (versioned path).
  const Response lib = api.handle(get("/ui/vendor/uplot-1.6.32/uPlot.iife.min.js"));
  ASSERT_EQ(lib.status, 200);
  EXPECT_EQ(lib.body, source_file("server/web/vendor/uplot-1.6.32/uPlot.iife.min.js"));
  EXPECT_EQ(lib.header("Cache-Control"), "public, max-age=31536000, immutable");
  EXPECT_EQ(api.handle(get("/ui/vendor/uplot-1.6.32/LICENSE")).status, 200);

  for (const std::string bad : {"/ui/nope.js", "/ui/js/../index.html", "/ui/embed.cmake", "/ui/a/b/c/d"})
    EXPECT_EQ(api.handle(get(bad)).status, 404) << bad;
  EXPECT_EQ(api.handle(Request{"POST", "/", {}, ""}).status, 405);
}

TEST_F(DashboardApi, EveryResponseCarriesTheContentSecurityPolicy) {
  Api api(options());
  const std::string id = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  for (const std::string& target : std::vector<std::string>{"/", "/ui/app.css", "/v1/studies", "/v1/studies/" + id,
                                   "/v1/nothing", "/healthz", "/metrics"}) {
    const Response r = api.handle(get(target));
    EXPECT_EQ(r.header("Content-Security-Policy"), std::string(kContentSecurityPolicy)) << target;
    EXPECT_EQ(r.header("X-Content-Type-Options"), "nosniff") << target;
  }
  // A study poll answered from the cache on the I/O thread too.
  api.handle(get("/v1/studies/" + id));
  const auto cached = api.handle_cached(get("/v1/studies/" + id));
  ASSERT_TRUE(cached);
  EXPECT_EQ(cached->header("Content-Security-Policy"), std::string(kContentSecurityPolicy));
  // The policy: scripts from this origin only, none inline, nothing from elsewhere.
  const std::string csp(kContentSecurityPolicy);
  EXPECT_NE(csp.find("script-src 'self'"), std::string::npos);
  EXPECT_NE(csp.find("default-src 'none'"), std::string::npos);
  EXPECT_EQ(csp.find("unsafe-inline"), std::string::npos);
  EXPECT_EQ(csp.find("unsafe-eval"), std::string::npos);
  EXPECT_EQ(csp.find("http"), std::string::npos);

  // A nightly report's page: its own policy (inline style, no script at all, sandboxed).
  std::filesystem::create_directories(dir_ / "reports" / "2026-11-24");
  std::ofstream(dir_ / "reports" / "2026-11-24" / "index.html") << "<html><style>p{}</style></html>";
  const Response rep = api.handle(get("/v1/reports/2026-11-24/index.html"));
  ASSERT_EQ(rep.status, 200);
  EXPECT_EQ(rep.header("Content-Security-Policy"), std::string(kReportContentSecurityPolicy));
  EXPECT_EQ(std::string(kReportContentSecurityPolicy).find("script-src"), std::string::npos);
  EXPECT_NE(std::string(kReportContentSecurityPolicy).find("default-src 'none'"), std::string::npos);
}

TEST_F(DashboardApi, NoInlineScriptAndNoHtmlFromStringsInTheDashboardsOwnFiles) {
  // The CSP forbids inline script; this keeps the files from needing it, and keeps data out of
  // any HTML parser: the dashboard builds its DOM with textContent only.
  const std::regex inline_handler(R"(<[^>]*\son[a-z]+\s*=)", std::regex::icase);
  const std::regex script_tag(R"(<script\b([^>]*)>)", std::regex::icase);
  const std::regex html_sinks(R"(innerHTML|outerHTML|insertAdjacentHTML|document\.write|\beval\(|new Function\(|setAttribute\(\s*["']on)");
  int own = 0;
  for (const WebAsset& a : web_assets()) {
    const std::string path(a.path), body(a.body);
    if (path.starts_with("vendor/")) continue;
    if (path.ends_with(".html")) {
      EXPECT_FALSE(std::regex_search(body, inline_handler)) << path;
      for (auto it = std::sregex_iterator(body.begin(), body.end(), script_tag);
           it != std::sregex_iterator(); ++it)
        EXPECT_NE((*it)[1].str().find("src="), std::string::npos) << path << ": inline <script>";
      EXPECT_EQ(body.find("style=\""), std::string::npos) << path << ": inline style";
    }
    if (path.ends_with(".js")) {
      ++own;
      EXPECT_FALSE(std::regex_search(body, html_sinks)) << path;
    }
  }
  EXPECT_GE(own, 8);  // app, api, dom, charts and the pages
}

}  // namespace
}  // namespace stickslip::server
