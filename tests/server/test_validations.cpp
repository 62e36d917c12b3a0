// Validations as server jobs (POST /v1/validations, the ValidationWorker) and the live progress of
// a running diagnosis in GET /v1/diagnoses/{id}:
//  * a validation of a synthetic dataset with the very model that made it succeeds, its stored
//    result follows validation.schema.json, each run's CSV has the columns t, Fd_measured,
//    Fd_base, Fd_extended at every measured sample, and the base predicts the record to about
//    its noise;
//  * a request without calibrated models is a 422 naming /diagnosis; an unknown diagnosis_id
//    fails the job with why; a stored diagnosis' id is resolved to its models;
//  * a diagnosis that reports progress shows its phase while it runs, and none once it ended.
#include "stickslip/server/validation_worker.h"

#include <gtest/gtest.h>

#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "stickslip/common/json_schema.h"
#include "stickslip/diagnosis/validate.h"
#include "stickslip/measured/synth.h"
#include "stickslip/server/api.h"
#include "stickslip/server/diagnosis_worker.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using testing::body_json;
using testing::get;
using testing::post_json;
using testing::TempDir;

constexpr double kNoise = 0.02;

/// A short synthetic LuGre dataset (Table 1; 2 runs of 3 s, vibration from 1.5 s; 500 Hz) as the
/// manifest and files of a request.
json dataset_request() {
  measured::SynthOptions o;
  o.model = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  measured::MeasuredConditions c;
  c.t_on = 1.5;
  c.duration = 3.0;
  o.runs = {c, c};
  o.runs[1].va = 4e-3;
  o.rate = 500.0;
  o.noise_sigma = kNoise;
  o.seed = 9;
  o.rtol = 1e-8;
  const measured::MeasuredDataset ds = measured::synthesize(o);
  json manifest = {{"name", "small"}, {"runs", json::array()}};
  json files = json::object();
  for (std::size_t i = 0; i < ds.runs.size(); ++i) {
    const auto& r = ds.runs[i];
    const std::string file = "run" + std::to_string(i) + ".csv";
    manifest["runs"].push_back({{"name", "run" + std::to_string(i)},
                                {"file", file},
                                {"conditions",
                                 {{"va", r.conditions.va}, {"t_on", r.conditions.t_on}, {"duration", r.conditions.duration}}}});
    std::string s = "t,Fd\n";
    char line[64];
    for (std::size_t k = 0; k < r.t.size(); ++k) {
      std::snprintf(line, sizeof line, "%.17g,%.17g\n", r.t[k], r.Fd[k]);
      s += line;
    }
    files[file] = s;
  }
  return {{"manifest", manifest}, {"files", files}};
}

/// A diagnosis document whose calibrated models are Table 1's LuGre (the model of the data).
json table1_diagnosis() {
  diagnosis::CalibratedModel m;
  m.model = engine::model_kind<engine::LuGre>;
  const engine::SimConfig c = engine::SimConfig::seed(m.model, 0.0);
  for (const engine::ParamDef& p : engine::model_traits(m.model).params)
    m.params.emplace_back(p.name, engine::get_parameter(c, p.name));
  return {{"dataset", "calibration"},
          {"cause", "none"},
          {"verdict", "adequate"},
          {"models", {{"base", diagnosis::calibrated_json(m)}, {"extended", diagnosis::calibrated_json(m)}}}};
}

json wait_state(const Api& api, const std::string& target, const std::set<std::string>& want,
                std::chrono::seconds limit = 300s) {
  const auto end = std::chrono::steady_clock::now() + limit;
  json d;
  while (std::chrono::steady_clock::now() < end) {
    d = body_json(api.handle(get(target)));
    if (want.count(d.value("state", ""))) return d;
    std::this_thread::sleep_for(20ms);
  }
  ADD_FAILURE() << target << " still " << d.value("state", "?");
  return d;
}

TEST(Validations, PredictTheDatasetStoreTheSchemasFormAndTheColumnsOfEveryRun) {
  TempDir dir;
  ApiOptions ao;
  ao.db = dir / "v.db";
  ValidationWorkerOptions wo;
  wo.poll = 50ms;
  wo.nice = 0;
  ValidationWorker worker(ao.db, wo);
  Api api(ao, nullptr, nullptr, nullptr, &worker);
  worker.start();
  json req = dataset_request();
  req["diagnosis"] = table1_diagnosis();
  const Response r = api.handle(post_json("/v1/validations", req.dump()));
  ASSERT_EQ(r.status, 202) << r.body.substr(0, 500);
  const std::string id = body_json(r)["id"];
  const json done = wait_state(api, "/v1/validations/" + id, {"succeeded", "failed"});
  ASSERT_EQ(done["state"], "succeeded") << done.dump().substr(0, 800);
  EXPECT_TRUE(done["progress"].is_null());  // not running any more
  const common::SchemaValidator schema(json::parse(diagnosis::validation_schema_text()));
  const auto errors = schema.validate(done["result"]);
  EXPECT_TRUE(errors.empty()) << common::to_string(errors);
  ASSERT_EQ(done["result"]["runs"].size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const json& run = done["result"]["runs"][k];
    EXPECT_EQ(run["status"], "ok");
    // The model of the data, from rest: the base follows the record to about its noise.
    EXPECT_LT(run["rmse_base"].get<double>(), 2 * kNoise) << run.dump().substr(0, 400);
    const Response csv = api.handle(get("/v1/validations/" + id + "/traces/" + std::to_string(k) + "?format=csv"));
    ASSERT_EQ(csv.status, 200);
    std::istringstream lines(csv.body);
    std::string header;
    std::getline(lines, header);
    EXPECT_EQ(header, "t,Fd_measured,Fd_base,Fd_extended");
    const std::size_t rows = static_cast<std::size_t>(std::count(csv.body.begin(), csv.body.end(), '\n')) - 1;
    const std::string file = "run" + std::to_string(k) + ".csv";
    const std::string data = req["files"][file];
    EXPECT_EQ(rows, static_cast<std::size_t>(std::count(data.begin(), data.end(), '\n')) - 1);
  }
  // The extended model is the base when no cause was named: the same column.
  const json tr = body_json(api.handle(get("/v1/validations/" + id + "/traces/0")));
  EXPECT_EQ(tr["Fd_base"], tr["Fd_extended"]);
  worker.shutdown();
}

TEST(Validations, BadRequestsAreNamedAndAnUnknownDiagnosisFailsTheJob) {
  TempDir dir;
  ApiOptions ao;
  ao.db = dir / "v.db";
  ValidationWorkerOptions wo;
  wo.poll = 50ms;
  wo.nice = 0;
  ValidationWorker worker(ao.db, wo);
  Api api(ao, nullptr, nullptr, nullptr, &worker);
  worker.start();
  json req = dataset_request();
  req["diagnosis"] = {{"cause", "none"}};  // no models
  Response r = api.handle(post_json("/v1/validations", req.dump()));
  ASSERT_EQ(r.status, 422) << r.body.substr(0, 500);
  EXPECT_NE(r.body.find("/diagnosis"), std::string::npos) << r.body.substr(0, 500);
  req["diagnosis"] = table1_diagnosis();
  req["diagnosis"]["models"]["base"]["params"]["F_S"] = -1.0;
  r = api.handle(post_json("/v1/validations", req.dump()));
  ASSERT_EQ(r.status, 422) << r.body.substr(0, 500);
  EXPECT_NE(r.body.find("/diagnosis/models/base"), std::string::npos) << r.body.substr(0, 500);
  EXPECT_NE(r.body.find("F_S"), std::string::npos) << r.body.substr(0, 500);
  req.erase("diagnosis");
  req["diagnosis_id"] = "dg-000000000000nothere";
  r = api.handle(post_json("/v1/validations", req.dump()));
  ASSERT_EQ(r.status, 202) << r.body.substr(0, 500);
  const json failed = wait_state(api, "/v1/validations/" + body_json(r)["id"].get<std::string>(),
                                 {"succeeded", "failed"});
  EXPECT_EQ(failed["state"], "failed");
  EXPECT_NE(failed["error"].get<std::string>().find("no such diagnosis"), std::string::npos) << failed.dump();
  worker.shutdown();
}

/// A diagnosis that reports progress, then waits until the test releases it.
class ProgressingDiagnosis {
 public:
  DiagnoseFn fn() {
    return [this](const measured::MeasuredDataset& data, const diagnosis::DiagnoseOptions& o) -> json {
      diagnosis::Progress p;
      p.phase = "calibration";
      p.item = "lugre";
      p.evaluations = 7;
      p.estimated_total = 70;
      p.seconds = 1.5;
      p.seconds_left = 13.5;
      o.progress(p);
      std::unique_lock lock(mu_);
      reported_ = true;
      cv_.notify_all();
      cv_.wait(lock, [&] { return released_; });
      return {{"dataset", data.name}, {"cause", "none"}};
    };
  }
  void wait_reported() {
    std::unique_lock lock(mu_);
    EXPECT_TRUE(cv_.wait_for(lock, 20s, [&] { return reported_; }));
  }
  void release() {
    std::lock_guard lock(mu_);
    released_ = true;
    cv_.notify_all();
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool reported_ = false, released_ = false;
};

TEST(DiagnosisProgress, ARunningDiagnosisShowsItsPhaseAndEvaluationsAndNoneOnceItEnded) {
  TempDir dir;
  ApiOptions ao;
  ao.db = dir / "d.db";
  DiagnosisWorkerOptions wo;
  wo.poll = 50ms;
  wo.nice = 0;
  ProgressingDiagnosis fake;
  DiagnosisWorker worker(ao.db, wo, fake.fn());
  Api api(ao, nullptr, &worker);
  worker.start();
  json req = dataset_request();
  req["options"] = {{"models", {"lugre"}}};
  const Response r = api.handle(post_json("/v1/diagnoses", req.dump()));
  ASSERT_EQ(r.status, 202) << r.body.substr(0, 500);
  const std::string id = body_json(r)["id"];
  fake.wait_reported();
  const json running = body_json(api.handle(get("/v1/diagnoses/" + id)));
  EXPECT_EQ(running["state"], "running");
  ASSERT_TRUE(running["progress"].is_object()) << running.dump();
  EXPECT_EQ(running["progress"]["phase"], "calibration");
  EXPECT_EQ(running["progress"]["item"], "lugre");
  EXPECT_EQ(running["progress"]["evaluations"], 7);
  EXPECT_EQ(running["progress"]["estimated_total"], 70);
  EXPECT_DOUBLE_EQ(running["progress"]["seconds_left"].get<double>(), 13.5);
  fake.release();
  const json done = wait_state(api, "/v1/diagnoses/" + id, {"succeeded", "failed"});
  EXPECT_EQ(done["state"], "succeeded");
  EXPECT_TRUE(done["progress"].is_null());
  worker.shutdown();
}

}  // namespace
}  // namespace stickslip::server
