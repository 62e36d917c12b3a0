// The client side of the server commands without a server: URL parsing, readable problem
// messages with field paths, and the map JSON round trip that lets `map --server` print the
// same table as the local `map --db`.
#include "stickslip/client/remote.h"

#include <gtest/gtest.h>

#include <cmath>

#include "stickslip/studies/map.h"

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

TEST(MapFromJson, RoundTripsTheStudiesMapSoTablesAreIdentical) {
  studies::StudyMap m;
  m.study_id = "st-1";
  m.study_name = "n";
  m.state = "running";
  m.models = {"dahl", "lugre"};
  m.key_names = {"va_over_vd"};
  m.stages = 2;
  m.missing = 1;
  m.failed = 1;
  const double nan = std::nan("");
  for (int k = 0; k < 2; ++k) {
    studies::MapRow row;
    row.key = {{"va_over_vd", 0.5 * k}};
    studies::MapCell ok;
    ok.state = studies::CellState::kOk;
    ok.design_index = 2 * k;
    ok.status = "ok";
    ok.amplitude = {2.0, k == 0 ? nan : 0.5};
    ok.mean_force = {10.0, 11.0};
    ok.ratio = k == 0 ? std::nullopt : std::optional<double>(0.25);
    ok.stage_rmse = {std::nullopt, 0.1};
    studies::MapCell other;
    other.design_index = 2 * k + 1;
    if (k == 1) {
      other.state = studies::CellState::kFailed;
      other.status = "diverged";
      other.error = "x = inf";
      other.amplitude = {nan, nan};
      other.mean_force = {nan, nan};
      other.stage_rmse = {std::nullopt, std::nullopt};
    }
    row.cells = {ok, other};
    m.rows.push_back(row);
  }
  const json j = studies::map_to_json(m);
  const studies::StudyMap back = map_from_json(j);
  EXPECT_EQ(studies::map_to_json(back), j);
  for (const auto view : {studies::MapView::kAmplitude, studies::MapView::kMeanForce,
                          studies::MapView::kRmse})
    EXPECT_EQ(studies::map_to_table(back, view), studies::map_to_table(m, view));
  EXPECT_EQ(studies::map_to_csv(back), studies::map_to_csv(m));
}

}  // namespace
}  // namespace stickslip::client
