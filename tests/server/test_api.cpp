// Handler tests without sockets: every bad request of issue 4 gives a 4xx problem+json naming
// the offending field, and the good paths return what the store holds.
#include "stickslip/server/api.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <thread>

#include "stickslip/studies/map.h"
#include "stickslip/store/store.h"
#include "test_support.h"
#include "support/is_valid.h"

namespace stickslip::server {
namespace {

using nlohmann::json;
using testing::body_json;
using testing::get;
using testing::post_json;
using testing::TempDir;
using testing::tiny_study;

class ApiTest : public ::testing::Test {
 protected:
  ApiOptions options() {
    ApiOptions o;
    o.db = dir_ / "api.db";
    o.limits.max_runs = 10;
    o.max_body_bytes = 4096;
    return o;
  }
  /// Expects a problem+json response with this status; returns its body.
  static json expect_problem(const Response& r, int status) {
    EXPECT_EQ(r.status, status) << r.body;
    EXPECT_EQ(r.header("Content-Type"), "application/problem+json");
    json p = body_json(r);
    EXPECT_EQ(p["status"], status);
    EXPECT_TRUE(p["type"].get<std::string>().starts_with("urn:stickslip:problem:"));
    EXPECT_FALSE(p["detail"].get<std::string>().empty());
    return p;
  }
  /// The set of JSON pointers named in a problem's errors.
  static std::set<std::string> pointers(const json& p) {
    std::set<std::string> out;
    for (const auto& e : p.value("errors", json::array()))
      if (e.contains("pointer")) out.insert(e["pointer"].get<std::string>());
    return out;
  }
  std::size_t stored_studies() {
    auto store = store::Store::open(dir_ / "api.db");
    return store.list_studies(1000).size();
  }

  TempDir dir_;
};

TEST_F(ApiTest, CreateReturns202WithLocationAndTheQueuedStudy) {
  Api api(options());
  const Response r = api.handle(post_json("/v1/studies", tiny_study()));
  ASSERT_EQ(r.status, 202) << r.body;
  const json s = body_json(r);
  const std::string id = s["id"];
  EXPECT_EQ(r.header("Location"), "/v1/studies/" + id);
  EXPECT_EQ(s["state"], "queued");
  EXPECT_EQ(s["name"], "tiny");
  EXPECT_EQ(s["progress"], json({{"total", 4}, {"done", 0}, {"ok", 0}, {"failed", 0}}));
  EXPECT_TRUE(s["started_at"].is_null());

  auto store = store::Store::open(dir_ / "api.db");
  const auto rec = store.get_study(id);
  ASSERT_TRUE(rec);
  EXPECT_EQ(rec->total_runs, 4);
  EXPECT_EQ(rec->state, store::StudyState::kQueued);

  const Response g = api.handle(get("/v1/studies/" + id));
  ASSERT_EQ(g.status, 200);
  EXPECT_EQ(body_json(g)["id"], id);
  EXPECT_EQ(body_json(g)["spec"]["name"], "tiny");
}

TEST_F(ApiTest, MalformedJsonIs400) {
  Api api(options());
  const json p = expect_problem(api.handle(post_json("/v1/studies", R"({"name": "x",)")), 400);
  EXPECT_EQ(pointers(p), std::set<std::string>{""});
  EXPECT_NE(p["detail"].get<std::string>().find("line"), std::string::npos);
  EXPECT_EQ(stored_studies(), 0u);
}

TEST_F(ApiTest, DeeplyNestedJsonIsA400NotAStackOverflow) {
  ApiOptions o = options();
  o.max_body_bytes = 1 << 20;
  Api api(o);
  // Half a million levels: parsing or validating this recursively would crash the server.
  const std::string deep = std::string(500000, '[') + std::string(500000, ']');
  json p = expect_problem(api.handle(post_json("/v1/studies", deep)), 400);
  EXPECT_NE(p["detail"].get<std::string>().find("64 levels"), std::string::npos);
  const std::string nested = R"({"name": ")" + std::string(100, '[') + R"(", "base": )" +
                             std::string(100, '[') + std::string(100, ']') + "}";
  expect_problem(api.handle(post_json("/v1/studies", nested)), 400);  // brackets in a string skipped
  EXPECT_EQ(stored_studies(), 0u);
}

TEST_F(ApiTest, OddBodiesAreAll4xx) {
  Api api(options());
  for (const std::string& body :
       {std::string(""), std::string("[]"), std::string("null"), std::string("\"x\""),
        std::string("1e999999"), std::string("{\"name\": \"\xff\xfe\"}"),
        std::string(R"({"name": "x", "name": "y"})"),
        std::string(R"({"name": "x", "design": {"type": "grid", "axes": [{"name": "k_d",
                     "linspace": [1, 2, 1e300]}]}})"),
        std::string(R"({"name": "x", "stages": [{"duration": -1}], "integrator": {"dt": 1}})")}) {
    const Response r = api.handle(post_json("/v1/studies", body));
    EXPECT_GE(r.status, 400) << body;
    EXPECT_LT(r.status, 500) << body << " -> " << r.body;
    EXPECT_EQ(r.header("Content-Type"), "application/problem+json") << body;
  }
  EXPECT_EQ(stored_studies(), 0u);
}

TEST_F(ApiTest, WrongOrMissingContentTypeIs415) {
  Api api(options());
  Request r{"POST", "/v1/studies", {{"Content-Type", "text/plain"}}, tiny_study()};
  json p = expect_problem(api.handle(r), 415);
  EXPECT_EQ(p["errors"][0]["header"], "Content-Type");
  r.headers.clear();
  expect_problem(api.handle(r), 415);
  r.headers = {{"content-type", "application/json; charset=utf-8"}};
  EXPECT_EQ(api.handle(r).status, 202);
}

TEST_F(ApiTest, UnknownFieldsAreNamed) {
  Api api(options());
  const json p = expect_problem(
      api.handle(post_json("/v1/studies", R"({"name": "x", "colour": 1, "base": {"mass": 1}})")),
      422);
  EXPECT_TRUE(pointers(p).count("/colour")) << p.dump();
  EXPECT_TRUE(pointers(p).count("/base/mass")) << p.dump();
  EXPECT_EQ(stored_studies(), 0u);
}

TEST_F(ApiTest, WrongTypesNegativeMassAndUnknownModelAreAllReported) {
  Api api(options());
  const json p = expect_problem(
      api.handle(post_json("/v1/studies",
                           R"({"name": 5, "base": {"m": -1, "model": "coulombish"}})")),
      422);
  const auto ptrs = pointers(p);
  EXPECT_TRUE(ptrs.count("/name")) << p.dump();
  EXPECT_TRUE(ptrs.count("/base/m")) << p.dump();
  EXPECT_TRUE(ptrs.count("/base/model")) << p.dump();
  EXPECT_NE(p.dump().find("-1"), std::string::npos);  // the offending value is quoted
  EXPECT_NE(p.dump().find("coulombish"), std::string::npos);
}

TEST_F(ApiTest, StudyOverTheRunLimitIs422AtDesign) {
  Api api(options());  // max_runs = 10
  const json p = expect_problem(
      api.handle(post_json("/v1/studies", R"({"name": "big", "design": {"type": "grid", "axes": [
        {"name": "va_over_vd", "linspace": [0, 5, 11]}]}})")),
      422);
  EXPECT_TRUE(pointers(p).count("/design")) << p.dump();
  EXPECT_NE(p.dump().find("limit of 10"), std::string::npos) << p.dump();
}

TEST_F(ApiTest, BodyOverTheSizeLimitIs413) {
  Api api(options());  // 4096 bytes
  std::string big = R"({"name": ")" + std::string(5000, 'x') + R"("})";
  expect_problem(api.handle(post_json("/v1/studies", big)), 413);
  EXPECT_EQ(stored_studies(), 0u);
}

TEST_F(ApiTest, UnknownRouteIs404AndWrongMethodIs405) {
  Api api(options());
  expect_problem(api.handle(get("/v2/studies")), 404);
  expect_problem(api.handle(get("/v1/studies/x/y/z")), 404);
  const Response del = api.handle(Request{"DELETE", "/v1/studies", {}, ""});
  expect_problem(del, 405);
  EXPECT_EQ(del.header("Allow"), "POST, GET");
  const Response get_cancel = api.handle(get("/v1/studies/st-1:cancel"));
  expect_problem(get_cancel, 405);
  EXPECT_EQ(get_cancel.header("Allow"), "POST");
}

TEST_F(ApiTest, UnknownStudyIdIs404Everywhere) {
  Api api(options());
  for (const std::string suffix : {"", "/runs", "/map"}) {
    expect_problem(api.handle(get("/v1/studies/st-00000000000000000000" + suffix)), 404);
  }
  expect_problem(api.handle(post_json("/v1/studies/st-0000:cancel", "")), 404);
  expect_problem(api.handle(get("/v1/studies/bad%20id")), 404);
}

TEST_F(ApiTest, TokenProtectsStateChangesOnly) {
  ApiOptions o = options();
  o.token = "s3cret";
  Api api(o);
  const Response none = api.handle(post_json("/v1/studies", tiny_study()));
  json p = expect_problem(none, 401);
  EXPECT_TRUE(none.header("WWW-Authenticate").has_value());
  EXPECT_EQ(p["errors"][0]["header"], "Authorization");
  expect_problem(api.handle(post_json("/v1/studies", tiny_study(),
                                      {{"Authorization", "Bearer wrong"}})), 403);
  expect_problem(api.handle(post_json("/v1/studies", tiny_study(),
                                      {{"Authorization", "Basic czNjcmV0"}})), 401);
  EXPECT_EQ(stored_studies(), 0u);
  const Response ok =
      api.handle(post_json("/v1/studies", tiny_study(), {{"Authorization", "Bearer s3cret"}}));
  ASSERT_EQ(ok.status, 202);
  const std::string id = body_json(ok)["id"];
  // Reads need no token; cancel does.
  EXPECT_EQ(api.handle(get("/v1/studies/" + id)).status, 200);
  EXPECT_EQ(api.handle(get("/v1/studies")).status, 200);
  expect_problem(api.handle(post_json("/v1/studies/" + id + ":cancel", "")), 401);
  expect_problem(api.handle(post_json("/v1/studies/" + id + ":cancel", "",
                                      {{"Authorization", "Bearer s3cre"}})), 403);
  EXPECT_EQ(api.handle(post_json("/v1/studies/" + id + ":cancel", "",
                                 {{"Authorization", "Bearer s3cret"}}))
                .status,
            200);
}

TEST_F(ApiTest, IdempotencyKeyReplaysTheFirstResponseAndRejectsAnotherBody) {
  Api api(options());
  const std::vector<Header> key = {{"Idempotency-Key", "nightly-2024-05-01"}};
  const Response first = api.handle(post_json("/v1/studies", tiny_study(), key));
  ASSERT_EQ(first.status, 202);
  // Same body (even re-formatted): same study, same status and Location.
  json reformatted = json::parse(tiny_study());
  const Response again = api.handle(post_json("/v1/studies", reformatted.dump(2), key));
  EXPECT_EQ(again.status, 202);
  EXPECT_EQ(again.header("Location"), first.header("Location"));
  EXPECT_EQ(body_json(again)["id"], body_json(first)["id"]);
  EXPECT_EQ(again.header("Idempotent-Replayed"), "true");
  // Another body with the same key: 422, nothing stored.
  const json p =
      expect_problem(api.handle(post_json("/v1/studies", tiny_study("other"), key)), 422);
  EXPECT_EQ(p["errors"][0]["header"], "Idempotency-Key");
  EXPECT_EQ(stored_studies(), 1u);
  // A malformed key is a 400.
  expect_problem(api.handle(post_json("/v1/studies", tiny_study(), {{"Idempotency-Key", ""}})),
                 400);
}

TEST_F(ApiTest, ListPaginatesInCreationOrder) {
  Api api(options());
  std::vector<std::string> ids;
  for (int i = 0; i < 5; ++i)
    ids.push_back(body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"]);
  std::vector<std::string> seen;
  std::string target = "/v1/studies?page_size=2";
  int pages = 0;
  while (true) {
    const Response r = api.handle(get(target));
    ASSERT_EQ(r.status, 200) << r.body;
    const json page = body_json(r);
    EXPECT_LE(page["studies"].size(), 2u);
    for (const auto& s : page["studies"]) seen.push_back(s["id"]);
    ++pages;
    if (page["next_page_token"].is_null()) break;
    target = "/v1/studies?page_size=2&page_token=" + page["next_page_token"].get<std::string>();
  }
  EXPECT_EQ(pages, 3);
  // Every study exactly once, in id order (ids start with the creation time in ms, so this is
  // creation order to the millisecond).
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(seen, ids);
  for (const std::string bad : {"0", "1001", "x", "-1", "2.5"}) {
    const json p = expect_problem(api.handle(get("/v1/studies?page_size=" + bad)), 400);
    EXPECT_EQ(p["errors"][0]["parameter"], "page_size");
  }
  expect_problem(api.handle(get("/v1/studies?page_token=%00%01")), 400);
}

TEST_F(ApiTest, APageTokenThatNoPageReturnedIs400) {
  // Any [A-Za-z0-9-] token used to list the studies after it, 200 (issue 18, defect 6).
  Api api(options());
  const std::string id = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  for (const std::string bad : {"abc", "st-0", "st-ffffffffffffffffffff", "dg-018f3a2b4c5d9e8f7a6b"}) {
    const json p = expect_problem(api.handle(get("/v1/studies?page_token=" + bad)), 400);
    EXPECT_EQ(p["errors"][0]["parameter"], "page_token") << bad;
    expect_problem(api.handle(get("/v1/diagnoses?page_token=" + bad)), 400);
  }
  // A diagnosis' id is no token of the studies, nor a study's of the diagnoses.
  expect_problem(api.handle(get("/v1/diagnoses?page_token=" + id)), 400);
  const Response ok = api.handle(get("/v1/studies?page_token=" + id));
  ASSERT_EQ(ok.status, 200) << ok.body;
  EXPECT_TRUE(body_json(ok)["studies"].empty());
}

TEST_F(ApiTest, HealthzIsDegradedWhileAWorkerIsPausedByTheStore) {
  auto health = std::make_shared<Health>();
  Api api(options(), nullptr, nullptr, health);
  EXPECT_EQ(api.handle(get("/healthz")).status, 200);
  health->degrade("study", "disk I/O error (SQLite code 778)", std::chrono::seconds(4));
  const json p = expect_problem(api.handle(get("/healthz")), 503);
  EXPECT_EQ(p["health"], "degraded");
  EXPECT_NE(p["detail"].get<std::string>().find("disk I/O error"), std::string::npos);
  health->recover("study");
  EXPECT_EQ(api.handle(get("/healthz")).status, 200);
}

/// A run record as the runner would store it.
store::RunRecord make_run(const std::string& study, std::int64_t index, const std::string& model,
                            double ratio, const std::string& status = "ok") {
  store::RunRecord r;
  r.study_id = study;
  r.design_index = index;
  r.params_json = json({{"model", model}, {"va_over_vd", ratio}}).dump();
  r.param_hash = store::param_hash(r.params_json);
  r.model = model;
  r.va_over_vd = ratio;
  r.status = status;
  r.wall_time_s = 0.25;
  r.t_end = 1.0;
  r.steps = 100;
  if (status == "ok") {
    for (int s = 1; s <= 2; ++s) {
      store::StageMetricsRecord m;
      m.stage = s;
      m.t_start = 0.5 * (s - 1);
      m.t_end = 0.5 * s;
      m.amplitude = s == 1 ? 2.0 : (s == 2 && ratio > 0 ? 0.5 : std::nan(""));
      m.mean_force = 10.0 + s;
      r.stages.push_back(m);
    }
  } else {
    r.error = "diverged at t = 0.3 s, x = inf";
  }
  return r;
}

// Runs 0 (dahl, ok), 1 (dahl, diverged) and 3 (lugre, ok) of a tiny_study(); run 2 missing.
void store_three_runs(const std::filesystem::path& db, const std::string& id) {
  auto writer = store::RunWriter::open(db);
  writer.add(make_run(id, 0, "dahl", 0));
  writer.add(make_run(id, 1, "dahl", 2, "diverged"));
  writer.add(make_run(id, 3, "lugre", 2));
  writer.flush();
}

TEST_F(ApiTest, RunsArePagedAsJsonAndServedAsCsv) {
  Api api(options());
  const std::string id = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  store_three_runs(dir_ / "api.db", id);
  const Response p1 = api.handle(get("/v1/studies/" + id + "/runs?page_size=2"));
  ASSERT_EQ(p1.status, 200) << p1.body;
  const json j1 = body_json(p1);
  ASSERT_EQ(j1["runs"].size(), 2u);
  EXPECT_EQ(j1["runs"][0]["design_index"], 0);
  EXPECT_EQ(j1["runs"][0]["stages"][1]["amplitude"], nullptr);  // NaN is null, never dropped
  EXPECT_EQ(j1["runs"][1]["status"], "diverged");
  EXPECT_EQ(j1["runs"][1]["error"], "diverged at t = 0.3 s, x = inf");
  const Response p2 = api.handle(get("/v1/studies/" + id + "/runs?page_size=2&page_token=" +
                                     j1["next_page_token"].get<std::string>()));
  const json j2 = body_json(p2);
  ASSERT_EQ(j2["runs"].size(), 1u);
  EXPECT_EQ(j2["runs"][0]["design_index"], 3);
  EXPECT_TRUE(j2["next_page_token"].is_null());
  EXPECT_EQ(body_json(api.handle(get("/v1/studies/" + id)))["progress"],
            json({{"total", 4}, {"done", 3}, {"ok", 2}, {"failed", 1}}));

  const Response csv = api.handle(get("/v1/studies/" + id + "/runs", {{"Accept", "text/csv"}}));
  ASSERT_EQ(csv.status, 200);
  EXPECT_EQ(csv.header("Content-Type"), "text/csv; charset=utf-8");
  // studies/export.h format: header + one row per run (stages as columns), failures included
  EXPECT_EQ(std::count(csv.body.begin(), csv.body.end(), '\n'), 4) << csv.body;
  EXPECT_EQ(csv.body.substr(0, 36), "design_index,model,va_over_vd,status") << csv.body;
  EXPECT_NE(csv.body.find("\n1,dahl,2,diverged,"), std::string::npos) << csv.body;
  EXPECT_NE(csv.body.find("diverged at t = 0.3 s"), std::string::npos) << csv.body;
  EXPECT_EQ(api.handle(get("/v1/studies/" + id + "/runs?format=csv")).body, csv.body);
  expect_problem(api.handle(get("/v1/studies/" + id + "/runs", {{"Accept", "image/png"}})), 406);
  expect_problem(api.handle(get("/v1/studies/" + id + "/runs?page_token=abc")), 400);
}

TEST_F(ApiTest, MapIsTheStudiesMapAndMarksMissingAndFailedCells) {
  Api api(options());
  const std::string id = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  store_three_runs(dir_ / "api.db", id);
  const Response r = api.handle(get("/v1/studies/" + id + "/map"));
  ASSERT_EQ(r.status, 200) << r.body;
  const json m = body_json(r);
  // Exactly what `stickslip map --format json` prints for the same store.
  auto store = store::Store::open(dir_ / "api.db");
  EXPECT_EQ(m, studies::map_to_json(studies::build_map(store, id)));
  EXPECT_EQ(m["models"], json({"dahl", "lugre"}));
  EXPECT_EQ(m["missing"], 1);
  EXPECT_EQ(m["failed"], 1);
  ASSERT_EQ(m["rows"].size(), 2u);  // va_over_vd = 0 and 2
  EXPECT_EQ(m["rows"][0]["key"]["va_over_vd"], 0.0);
  EXPECT_EQ(m["rows"][0]["cells"]["dahl"]["state"], "ok");
  EXPECT_EQ(m["rows"][0]["cells"]["dahl"]["amplitude"], json({2.0, nullptr}));
  EXPECT_EQ(m["rows"][0]["cells"]["lugre"]["state"], "missing");
  EXPECT_EQ(m["rows"][1]["cells"]["dahl"]["state"], "failed");
  EXPECT_EQ(m["rows"][1]["cells"]["lugre"]["ratio"], 0.25);

  const Response csv = api.handle(get("/v1/studies/" + id + "/map", {{"Accept", "text/csv"}}));
  ASSERT_EQ(csv.status, 200);
  EXPECT_EQ(csv.body, studies::map_to_csv(studies::build_map(store, id)));
  EXPECT_NE(csv.body.find(",lugre,missing,2,"), std::string::npos) << csv.body;
}

TEST_F(ApiTest, CancelKeepsFinishedRunsAndIsIdempotent) {
  Api api(options());
  const std::string id = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  {
    auto writer = store::RunWriter::open(dir_ / "api.db");
    writer.add(make_run(id, 0, "dahl", 0));
    writer.flush();
  }
  const Response c = api.handle(post_json("/v1/studies/" + id + ":cancel", ""));
  ASSERT_EQ(c.status, 200) << c.body;
  EXPECT_EQ(body_json(c)["state"], "cancelled");
  EXPECT_EQ(body_json(c)["progress"]["done"], 1);
  EXPECT_EQ(api.handle(post_json("/v1/studies/" + id + ":cancel", "")).status, 200);

  const std::string id2 = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  store::Store::open(dir_ / "api.db").set_study_state(id2, store::StudyState::kSucceeded);
  expect_problem(api.handle(post_json("/v1/studies/" + id2 + ":cancel", "")), 409);
}

TEST_F(ApiTest, StudyCacheIsShortLivedAndForgetsACancelledStudy) {
  ApiOptions o = options();
  o.study_cache_ttl = std::chrono::milliseconds(300);
  Api api(o);
  const std::string id = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  EXPECT_EQ(body_json(api.handle(get("/v1/studies/" + id)))["progress"]["done"], 0);
  {
    auto writer = store::RunWriter::open(dir_ / "api.db");
    writer.add(make_run(id, 0, "dahl", 0));
    writer.flush();
  }
  // Within the TTL the cached answer is served; after it, the store's.
  EXPECT_EQ(body_json(api.handle(get("/v1/studies/" + id)))["progress"]["done"], 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(350));
  EXPECT_EQ(body_json(api.handle(get("/v1/studies/" + id)))["progress"]["done"], 1);
  // A cancel is visible at once.
  EXPECT_EQ(api.handle(post_json("/v1/studies/" + id + ":cancel", "")).status, 200);
  EXPECT_EQ(body_json(api.handle(get("/v1/studies/" + id)))["state"], "cancelled");
}

TEST_F(ApiTest, StudyETagRevalidatesWith304AndChangesWithTheStudy) {
  ApiOptions o = options();
  o.study_cache_ttl = std::chrono::milliseconds(0);  // every GET reads the store
  Api api(o);
  const std::string id = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  const std::string target = "/v1/studies/" + id;
  const Response first = api.handle(get(target));
  ASSERT_EQ(first.status, 200);
  const auto etag = first.header("ETag");
  ASSERT_TRUE(etag.has_value());
  EXPECT_EQ(etag->front(), '"');  // a strong tag
  EXPECT_EQ(first.header("Cache-Control"), "no-cache");
  // The same study gives the same bytes and the same tag.
  const Response again = api.handle(get(target));
  EXPECT_EQ(again.body, first.body);
  EXPECT_EQ(again.header("ETag"), etag);
  // If-None-Match with the current tag (alone, weak, or in a list; or *): 304, no body.
  for (const std::string& inm : {*etag, "W/" + *etag, "\"other\", " + *etag, std::string("*")}) {
    const Response nm = api.handle(get(target, {{"If-None-Match", inm}}));
    EXPECT_EQ(nm.status, 304) << inm;
    EXPECT_TRUE(nm.body.empty()) << inm;
    EXPECT_EQ(nm.header("ETag"), etag) << inm;
  }
  EXPECT_EQ(api.handle(get(target, {{"If-None-Match", "\"other\""}})).status, 200);
  EXPECT_EQ(api.responses(3), 4u);
  // A changed study: the old tag no longer matches; a new body under a new tag.
  {
    auto writer = store::RunWriter::open(dir_ / "api.db");
    writer.add(make_run(id, 0, "dahl", 0));
    writer.flush();
  }
  const Response changed = api.handle(get(target, {{"If-None-Match", *etag}}));
  ASSERT_EQ(changed.status, 200);
  EXPECT_EQ(body_json(changed)["progress"]["done"], 1);
  EXPECT_NE(changed.body, first.body);
  ASSERT_TRUE(changed.header("ETag").has_value());
  EXPECT_NE(changed.header("ETag"), etag);
  EXPECT_EQ(api.handle(get(target, {{"If-None-Match", *changed.header("ETag")}})).status, 304);
}

TEST_F(ApiTest, HandleCachedAnswersOnlyFreshStudyGetsAndMatchesHandle) {
  ApiOptions o = options();
  o.study_cache_ttl = std::chrono::milliseconds(300);
  Api api(o);
  const std::string id = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  const std::string target = "/v1/studies/" + id;
  EXPECT_FALSE(api.handle_cached(get(target)).has_value());  // nothing cached yet
  const Response full = api.handle(get(target));
  ASSERT_EQ(full.status, 200);
  const std::uint64_t ok_before = api.responses(2);
  const auto hit = api.handle_cached(get(target));
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->status, 200);
  EXPECT_EQ(hit->body, full.body);
  EXPECT_EQ(hit->header("ETag"), full.header("ETag"));
  EXPECT_EQ(hit->header("Content-Type"), "application/json");
  EXPECT_EQ(api.responses(2), ok_before + 1);  // counted like handle()
  const auto nm = api.handle_cached(get(target, {{"If-None-Match", *full.header("ETag")}}));
  ASSERT_TRUE(nm.has_value());
  EXPECT_EQ(nm->status, 304);
  // Other routes, methods and ids are never answered from the cache.
  for (const std::string& other : {target + "/runs", target + "/map", target + ":cancel",
                                  std::string("/v1/studies/"), std::string("/v1/studies"),
                                  target + "/", std::string("/v1/studies/nope")})
    EXPECT_FALSE(api.handle_cached(get(other)).has_value()) << other;
  EXPECT_FALSE(api.handle_cached(post_json(target, "{}")).has_value());
  // A run committed now is visible once the TTL has passed: the cached answer is never older.
  {
    auto writer = store::RunWriter::open(dir_ / "api.db");
    writer.add(make_run(id, 0, "dahl", 0));
    writer.flush();
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(350));
  EXPECT_FALSE(api.handle_cached(get(target)).has_value());
  EXPECT_EQ(body_json(api.handle(get(target)))["progress"]["done"], 1);
  // A cancel forgets the entry at once.
  ASSERT_TRUE(api.handle_cached(get(target)).has_value());
  EXPECT_EQ(api.handle(post_json(target + ":cancel", "")).status, 200);
  EXPECT_FALSE(api.handle_cached(get(target)).has_value());
  EXPECT_EQ(body_json(api.handle(get(target)))["state"], "cancelled");
  // With the cache off nothing is answered inline.
  ApiOptions off = options();
  off.study_cache_ttl = std::chrono::milliseconds(0);
  Api uncached(off);
  EXPECT_EQ(uncached.handle(get(target)).status, 200);
  EXPECT_FALSE(uncached.handle_cached(get(target)).has_value());
}

TEST_F(ApiTest, HealthAndMetricsReflectTheStore) {
  Api api(options());
  EXPECT_EQ(api.handle(get("/healthz")).status, 200);
  const std::string id = body_json(api.handle(post_json("/v1/studies", tiny_study())))["id"];
  body_json(api.handle(post_json("/v1/studies", tiny_study())));
  {
    auto writer = store::RunWriter::open(dir_ / "api.db");
    writer.add(make_run(id, 0, "dahl", 0));
    writer.add(make_run(id, 1, "dahl", 2, "diverged"));
    writer.flush();
  }
  store::Store::open(dir_ / "api.db").set_study_state(id, store::StudyState::kRunning);
  const Response m = api.handle(get("/metrics"));
  ASSERT_EQ(m.status, 200);
  EXPECT_TRUE(m.header("Content-Type")->starts_with("text/plain; version=0.0.4"));
  for (const std::string line :
       {"stickslip_runs_total{status=\"ok\"} 1", "stickslip_runs_total{status=\"diverged\"} 1",
        "stickslip_studies{state=\"running\"} 1", "stickslip_studies{state=\"queued\"} 1",
        "stickslip_queue_depth 1", "stickslip_run_duration_seconds_bucket{le=\"0.1\"} 0",
        "stickslip_run_duration_seconds_bucket{le=\"0.25\"} 2",
        "stickslip_run_duration_seconds_bucket{le=\"+Inf\"} 2",
        "stickslip_run_duration_seconds_count 2", "stickslip_run_duration_seconds_sum 0.5"}) {
    EXPECT_NE(m.body.find(line + "\n"), std::string::npos) << line << "\n" << m.body;
  }
}

TEST(ApiOptions, InvalidOptionsAreRejectedWithTheField) {
  ApiOptions o;
  std::string why;
  o.max_body_bytes = 1;
  EXPECT_FALSE(stickslip::testing::is_valid(o, why));
  EXPECT_NE(why.find("max_body_bytes"), std::string::npos);
  o = ApiOptions{};
  o.token = "has space";
  EXPECT_FALSE(stickslip::testing::is_valid(o, why));
  EXPECT_NE(why.find("token"), std::string::npos);
  EXPECT_EQ(why.find("has space"), std::string::npos) << why;  // the secret is not repeated
  EXPECT_NE(why.find("character 4"), std::string::npos) << why;
}

TEST(ApiStore, UnopenableDatabaseFailsAtConstruction) {
  ApiOptions o;
  o.db = "/nonexistent-dir/x/y.db";
  EXPECT_THROW(Api api(o), store::StoreError);
}

}  // namespace
}  // namespace stickslip::server
