// Handler tests of GET /v1/studies/{id}/indices and the nightly report routes, without sockets.
#include <gtest/gtest.h>

#include <fstream>

#include "stickslip/server/api.h"
#include "stickslip/studies/runner.h"
#include "stickslip/store/store.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

using nlohmann::json;
using testing::body_json;
using testing::get;
using testing::TempDir;

// Runs a study into db and returns its id.
std::string run_into(const std::filesystem::path& db, const std::string& text) {
  studies::ParseResult parsed = studies::parse_study(text);
  EXPECT_TRUE(parsed.ok()) << (parsed.ok() ? "" : parsed.errors[0].message);
  store::Store store = store::Store::open(db);
  const std::string id = studies::create_or_find_study(store, *parsed.spec).id;
  EXPECT_EQ(studies::run_study(db, id, *parsed.spec).outcome, studies::RunOutcome::kCompleted);
  return id;
}

TEST(SensitivityApi, IndicesOfAnIshigamiSobolStudy) {
  TempDir dir;
  const auto db = dir / "s.db";
  const std::string id = run_into(db, R"({"name": "ish", "base": {"model": "ishigami"},
      "design": {"type": "sobol", "n": 2048, "seed": 3}})");
  ApiOptions o;
  o.db = db;
  Api api(o);
  const Response r = api.handle(get("/v1/studies/" + id + "/indices?output=y"));
  ASSERT_EQ(r.status, 200) << r.body;
  const json j = body_json(r);
  const std::string text = j.dump();
  // The served JSON is the library's: S1 of x2 is the analytic 0.4424 within sampling error.
  ASSERT_TRUE(text.find("S1") != std::string::npos) << text.substr(0, 400);
  bool found = false;
  for (const auto& out : j["outputs"])
    for (const auto& p : out["indices"])
      if (p["parameter"] == "x2") {
        EXPECT_NEAR(p["S1"].get<double>(), 0.4424, 0.06) << p.dump();
        found = true;
      }
  EXPECT_TRUE(found) << text.substr(0, 600);

  EXPECT_EQ(api.handle(get("/v1/studies/st-nope/indices")).status, 404);
  EXPECT_EQ(api.handle(get("/v1/studies/" + id + "/indices?output=stage9.colour")).status, 422);
  EXPECT_EQ(api.handle(get("/v1/studies/" + id + "/indices?confidence=high")).status, 400);
  EXPECT_EQ(api.handle(get("/v1/studies/" + id + "/indices?confidence=1.5")).status, 400);
}

TEST(SensitivityApi, IndicesOfAGridStudyAreUnprocessable) {
  TempDir dir;
  const auto db = dir / "g.db";
  const std::string id = run_into(db, R"({"name": "g", "stages": [{"duration": 0.2}, {"duration": 0.2}],
      "design": {"type": "grid", "axes": [{"name": "va_over_vd", "values": [0, 1]}]}})");
  ApiOptions o;
  o.db = db;
  Api api(o);
  const Response r = api.handle(get("/v1/studies/" + id + "/indices"));
  EXPECT_EQ(r.status, 422) << r.body;
  EXPECT_EQ(r.header("Content-Type"), "application/problem+json");
}

TEST(SensitivityApi, ReportsAreListedAndServedWithoutEscapingTheirDirectory) {
  TempDir dir;
  const auto reports = dir / "reports";
  for (const char* d : {"2026-11-19", "2026-11-20"}) {
    std::filesystem::create_directories(reports / d / "plots");
    std::ofstream(reports / d / "summary.json") << R"({"date": ")" << d << R"("})";
    std::ofstream(reports / d / "index.html") << "<html><body>" << d << "</body></html>";
    std::ofstream(reports / d / "plots" / "map.svg") << "<svg/>";
  }
  std::ofstream(dir / "secret.txt") << "not for the web";
  ApiOptions o;
  o.db = dir / "r.db";
  o.reports_dir = reports;
  Api api(o);
  const Response list = api.handle(get("/v1/reports"));
  ASSERT_EQ(list.status, 200) << list.body;
  const json j = body_json(list);
  ASSERT_EQ(j["reports"].size(), 2u);
  EXPECT_EQ(j["reports"][0]["date"], "2026-11-20");  // newest first
  const Response html = api.handle(get("/v1/reports/2026-11-19/index.html"));
  EXPECT_EQ(html.status, 200);
  EXPECT_NE(html.body.find("2026-11-19"), std::string::npos);
  EXPECT_EQ(html.header("Content-Type"), "text/html; charset=utf-8");
  const Response svg = api.handle(get("/v1/reports/2026-11-20/plots/map.svg"));
  EXPECT_EQ(svg.status, 200);
  EXPECT_EQ(svg.header("Content-Type"), "image/svg+xml");
  EXPECT_EQ(api.handle(get("/v1/reports/2026-11-21/index.html")).status, 404);
  EXPECT_EQ(api.handle(get("/v1/reports/2026-11-20/..%2F..%2Fsecret.txt")).status, 404);
  EXPECT_EQ(api.handle(get("/v1/reports/..%2F/secret.txt")).status, 404);
  EXPECT_EQ(api.handle(get("/v1/reports/2026-11-20/.hidden")).status, 404);

  ApiOptions none;
  none.db = dir / "r2.db";
  Api bare(none);
  const Response empty = bare.handle(get("/v1/reports"));
  EXPECT_EQ(empty.status, 200);
  EXPECT_EQ(body_json(empty)["configured"], false);
  EXPECT_EQ(bare.handle(get("/v1/reports/2026-11-20/index.html")).status, 404);
}

}  // namespace
}  // namespace stickslip::server
