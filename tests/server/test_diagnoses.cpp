// POST/GET /v1/diagnoses without sockets: a valid request is queued (202); every bad input is a
// 4xx problem+json naming its JSON pointer; cancel, idempotency, pagination and /metrics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <set>

#include "stickslip/server/api.h"
#include "stickslip/diagnosis/diagnosis_request.h"
#include "stickslip/store/store.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

using nlohmann::json;
using testing::body_json;
using testing::get;
using testing::post_json;
using testing::TempDir;

/// A CSV of n samples at 100 Hz (a plausible force level, nothing to diagnose).
std::string csv(std::size_t n = 50) {
  std::string s = "t,Fd\n";
  char line[64];
  for (std::size_t i = 0; i < n; ++i) {
    std::snprintf(line, sizeof line, "%.2f,%.3f\n", 0.01 * static_cast<double>(i),
                  8.0 + 0.01 * static_cast<double>(i % 7));
    s += line;
  }
  return s;
}

json request(std::string data = csv()) {
  return {{"manifest",
           {{"name", "stand"},
            {"runs", {{{"name", "r1"}, {"file", "a.csv"}, {"conditions", {{"duration", 0.5}, {"t_on", 0.2}}}}}}}},
          {"files", {{"a.csv", std::move(data)}}},
          {"options", {{"models", {"lugre"}}, {"candidates", {"viscous"}}}}};
}

class DiagnosesApi : public ::testing::Test {
 protected:
  ApiOptions options() {
    ApiOptions o;
    o.db = dir_ / "api.db";
    o.max_body_bytes = 256;  // the study limit: diagnoses have their own
    o.max_diagnosis_body_bytes = 100000;
    return o;
  }
  static json expect_problem(const Response& r, int status) {
    EXPECT_EQ(r.status, status) << r.body;
    EXPECT_EQ(r.header("Content-Type"), "application/problem+json");
    json p = body_json(r);
    EXPECT_EQ(p["status"], status);
    EXPECT_FALSE(p["detail"].get<std::string>().empty());
    return p;
  }
  /// pointer -> detail of every error of a problem.
  static std::map<std::string, std::string> errors(const json& p) {
    std::map<std::string, std::string> out;
    for (const auto& e : p.value("errors", json::array()))
      if (e.contains("pointer")) out[e["pointer"]] += e["detail"].get<std::string>() + ";";
    return out;
  }
  /// POSTs doc, expects 422 and returns its errors by pointer.
  std::map<std::string, std::string> rejected(const json& doc) {
    const Response r = api_->handle(post_json("/v1/diagnoses", doc.dump()));
    return errors(expect_problem(r, 422));
  }
  std::size_t stored() {
    auto store = store::Store::open(dir_ / "api.db");
    return store.list_diagnoses(100).size();
  }
  void SetUp() override { api_ = std::make_unique<Api>(options()); }

  TempDir dir_;
  std::unique_ptr<Api> api_;
};

TEST_F(DiagnosesApi, ValidRequestIsQueuedWithLocationAndReadBack) {
  const json req = request();
  const Response r = api_->handle(post_json("/v1/diagnoses", req.dump()));
  ASSERT_EQ(r.status, 202) << r.body;
  const json d = body_json(r);
  const std::string id = d["id"];
  EXPECT_TRUE(id.starts_with("dg-"));
  EXPECT_EQ(r.header("Location"), "/v1/diagnoses/" + id);
  EXPECT_EQ(d["state"], "queued");
  EXPECT_EQ(d["name"], "stand");
  EXPECT_TRUE(d["result"].is_null());
  EXPECT_TRUE(d["started_at"].is_null());

  // The canonical request is stored as sent (the CSV text included).
  auto store = store::Store::open(dir_ / "api.db");
  EXPECT_EQ(json::parse(*store.get_diagnosis_request(id)), req);

  const Response g = api_->handle(get("/v1/diagnoses/" + id));
  ASSERT_EQ(g.status, 200);
  EXPECT_EQ(body_json(g)["state"], "queued");
  EXPECT_EQ(api_->handle(get("/v1/diagnoses/dg-unknown")).status, 404);
  expect_problem(api_->handle(get("/v1/diagnoses/bad%20id")), 404);

  const std::string metrics = api_->handle(get("/metrics")).body;
  EXPECT_NE(metrics.find("stickslip_diagnoses{state=\"queued\"} 1"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("stickslip_diagnoses{state=\"succeeded\"} 0"), std::string::npos);
}

TEST_F(DiagnosesApi, CsvProblemsNameTheFilePointerAndTheLine) {
  std::string bad = csv();
  bad.replace(bad.find("\n0.03,") + 1, 4, "0.0x");  // line 5: header is line 1
  auto e = rejected(request(bad));
  ASSERT_EQ(e.size(), 1u);
  EXPECT_NE(e["/files/a.csv"].find("a.csv:5: column 't': '0.0x"), std::string::npos)
      << e["/files/a.csv"];

  e = rejected(request(csv() + "0.2,8\n"));  // t goes back at line 52
  EXPECT_NE(e["/files/a.csv"].find("a.csv:52: t = 0.2"), std::string::npos) << e["/files/a.csv"];
  EXPECT_NE(e["/files/a.csv"].find("does not increase"), std::string::npos);

  e = rejected(request("t,F\n0,1\n"));
  EXPECT_NE(e["/files/a.csv"].find("missing column 'Fd'"), std::string::npos);
  e = rejected(request(csv(5)));
  EXPECT_NE(e["/files/a.csv"].find("5 samples, need at least"), std::string::npos);
  e = rejected(request(csv() + "0.6,nan\n"));
  EXPECT_NE(e["/files/a.csv"].find("nan is not finite"), std::string::npos);
  EXPECT_EQ(stored(), 0u);
}

TEST_F(DiagnosesApi, MissingOrPathLikeFilesArePointed) {
  json req = request();
  req["files"] = {{"other.csv", csv()}};
  auto e = rejected(req);
  EXPECT_NE(e["/manifest/runs/0/file"].find("no content for file 'a.csv'"), std::string::npos);
  EXPECT_NE(e["/files/other.csv"].find("not named by any run"), std::string::npos);

  req = request();
  req["manifest"]["runs"][0]["file"] = "/etc/passwd";
  req["files"] = {{"/etc/passwd", csv()}};
  e = rejected(req);
  EXPECT_NE(e["/files/~1etc~1passwd"].find("not a plain file name"), std::string::npos);
  EXPECT_NE(e["/manifest/runs/0/file"].find("not a plain file name"), std::string::npos);
  EXPECT_EQ(stored(), 0u);
}

// The whole-run options reach the diagnosis' options; the others keep their defaults.
TEST_F(DiagnosesApi, WholeRunOptionsAreParsed) {
  json req = request();
  req["options"]["whole_run_holdout"] = false;
  req["options"]["max_evals_fold"] = 12;
  const auto parsed = diagnosis::parse_diagnosis_request(req);
  ASSERT_TRUE(parsed.ok()) << common::to_string(parsed.errors);
  EXPECT_FALSE(parsed.request->options.whole_run_holdout);
  EXPECT_EQ(parsed.request->options.max_evals_fold, 12);
  const auto plain = diagnosis::parse_diagnosis_request(request());
  ASSERT_TRUE(plain.ok());
  EXPECT_TRUE(plain.request->options.whole_run_holdout);
  EXPECT_EQ(plain.request->options.max_evals_fold, diagnosis::DiagnoseOptions{}.max_evals_fold);
}

TEST_F(DiagnosesApi, SchemaAndOptionErrorsArePointed) {
  json req = request();
  req["options"]["max_iters"] = 3;  // unknown option
  auto e = rejected(req);
  EXPECT_TRUE(e.count("/options/max_iters")) << json(e).dump();

  req = request();
  req["options"]["fit_rate"] = -1;
  req["options"]["models"] = {"coulomb"};
  e = rejected(req);
  EXPECT_TRUE(e.count("/options/fit_rate")) << json(e).dump();
  EXPECT_TRUE(e.count("/options/models/0")) << json(e).dump();

  req = request();
  req["options"]["max_evals_base"] = 5;  // schema-valid, rejected by DiagnoseOptions::IsValid
  e = rejected(req);
  EXPECT_TRUE(e.count("/options/max_evals_base")) << json(e).dump();

  req = request();
  req["options"]["max_evals_fold"] = 3;
  req["options"]["whole_run_holdout"] = "yes";
  e = rejected(req);
  EXPECT_NE(e["/options/max_evals_fold"].find("3"), std::string::npos) << json(e).dump();
  EXPECT_TRUE(e.count("/options/whole_run_holdout")) << json(e).dump();

  req = request();
  req["manifest"].erase("runs");
  req["manifest"]["runs_"] = json::array();
  e = rejected(req);
  EXPECT_TRUE(e.count("/manifest/runs_")) << json(e).dump();

  req = request();
  req["manifest"]["runs"][0]["conditions"]["m"] = -0.5;
  e = rejected(req);
  EXPECT_TRUE(e.count("/manifest/runs/0/conditions/m")) << json(e).dump();

  req = request();
  req["files"] = "a.csv";
  e = rejected(req);
  EXPECT_TRUE(e.count("/files")) << json(e).dump();

  e = rejected(json{{"files", {{"a.csv", csv()}}}});
  EXPECT_EQ(e.size(), 1u) << json(e).dump();  // "manifest" is required (pointer "")
  EXPECT_EQ(stored(), 0u);
}

TEST_F(DiagnosesApi, TransportLevelProblems) {
  // Over the diagnosis limit (the study limit of 256 bytes does not apply).
  const Response big = api_->handle(post_json("/v1/diagnoses", request(csv(10000)).dump()));
  const json p = expect_problem(big, 413);
  EXPECT_NE(p["detail"].get<std::string>().find("100000"), std::string::npos);
  EXPECT_EQ(api_->handle(post_json("/v1/diagnoses", request().dump())).status, 202);

  expect_problem(api_->handle(post_json("/v1/diagnoses", "{\"manifest\": ")), 400);
  expect_problem(api_->handle(post_json("/v1/diagnoses", std::string(1000, '['))), 400);
  Request text{"POST", "/v1/diagnoses", {{"Content-Type", "text/csv"}}, "t,Fd\n"};
  expect_problem(api_->handle(text), 415);
  expect_problem(api_->handle(Request{"DELETE", "/v1/diagnoses", {}, ""}), 405);
  expect_problem(api_->handle(post_json("/v1/diagnoses", request().dump(),
                                        {{"Idempotency-Key", std::string(300, 'k')}})),
                 400);
}

TEST_F(DiagnosesApi, BearerTokenProtectsCreateAndCancel) {
  ApiOptions o = options();
  o.token = "s3cret";
  Api api(o);
  const std::string body = request().dump();
  expect_problem(api.handle(post_json("/v1/diagnoses", body)), 401);
  expect_problem(api.handle(post_json("/v1/diagnoses", body, {{"Authorization", "Bearer nope"}})),
                 403);
  const Response ok =
      api.handle(post_json("/v1/diagnoses", body, {{"Authorization", "Bearer s3cret"}}));
  ASSERT_EQ(ok.status, 202) << ok.body;
  const std::string id = body_json(ok)["id"];
  expect_problem(api.handle(post_json("/v1/diagnoses/" + id + ":cancel", "")), 401);
  EXPECT_EQ(api.handle(get("/v1/diagnoses/" + id)).status, 200);  // reading needs no token
  EXPECT_EQ(api.handle(post_json("/v1/diagnoses/" + id + ":cancel", "",
                                 {{"Authorization", "Bearer s3cret"}}))
                .status,
            200);
}

TEST_F(DiagnosesApi, IdempotencyKeyReplaysOrConflicts) {
  const json req = request();
  const Response a =
      api_->handle(post_json("/v1/diagnoses", req.dump(), {{"Idempotency-Key", "day-1"}}));
  ASSERT_EQ(a.status, 202);
  // Same body (other whitespace and key order): the first diagnosis.
  const Response b =
      api_->handle(post_json("/v1/diagnoses", req.dump(2), {{"Idempotency-Key", "day-1"}}));
  ASSERT_EQ(b.status, 202);
  EXPECT_EQ(body_json(b)["id"], body_json(a)["id"]);
  EXPECT_EQ(b.header("Idempotent-Replayed"), "true");
  json other = req;
  other["options"]["min_gain"] = 0.2;
  const auto p = expect_problem(
      api_->handle(post_json("/v1/diagnoses", other.dump(), {{"Idempotency-Key", "day-1"}})), 422);
  EXPECT_EQ(p["errors"][0]["header"], "Idempotency-Key");
  EXPECT_EQ(stored(), 1u);
}

TEST_F(DiagnosesApi, CancelAndPagination) {
  std::vector<std::string> ids;
  for (int i = 0; i < 3; ++i) {
    const Response r = api_->handle(post_json("/v1/diagnoses", request().dump()));
    ASSERT_EQ(r.status, 202);
    ids.push_back(body_json(r)["id"]);
  }
  const Response c = api_->handle(post_json("/v1/diagnoses/" + ids[0] + ":cancel", ""));
  ASSERT_EQ(c.status, 200) << c.body;
  EXPECT_EQ(body_json(c)["state"], "cancelled");
  EXPECT_FALSE(body_json(c)["finished_at"].is_null());
  EXPECT_EQ(api_->handle(post_json("/v1/diagnoses/" + ids[0] + ":cancel", "")).status, 200);
  expect_problem(api_->handle(post_json("/v1/diagnoses/dg-nope:cancel", "")), 404);
  {
    auto store = store::Store::open(dir_ / "api.db");
    store.finish_diagnosis(ids[1], store::StudyState::kSucceeded, R"({"cause": "none"})");
  }
  expect_problem(api_->handle(post_json("/v1/diagnoses/" + ids[1] + ":cancel", "")), 409);
  EXPECT_EQ(body_json(api_->handle(get("/v1/diagnoses/" + ids[1])))["result"],
            json({{"cause", "none"}}));

  // Listed in id order: creation order to the millisecond (ids made within one ms may swap).
  std::sort(ids.begin(), ids.end());
  const json p1 = body_json(api_->handle(get("/v1/diagnoses?page_size=2")));
  ASSERT_EQ(p1["diagnoses"].size(), 2u);
  EXPECT_EQ(p1["diagnoses"][0]["id"], ids[0]);
  EXPECT_FALSE(p1["diagnoses"][0].contains("result"));  // lists leave results out
  const std::string token = p1["next_page_token"];
  const json p2 = body_json(api_->handle(get("/v1/diagnoses?page_size=2&page_token=" + token)));
  ASSERT_EQ(p2["diagnoses"].size(), 1u);
  EXPECT_EQ(p2["diagnoses"][0]["id"], ids[2]);
  EXPECT_TRUE(p2["next_page_token"].is_null());
  expect_problem(api_->handle(get("/v1/diagnoses?page_size=0")), 400);
  expect_problem(api_->handle(get("/v1/diagnoses?page_token=a%2Fb")), 400);
}

}  // namespace
}  // namespace stickslip::server
