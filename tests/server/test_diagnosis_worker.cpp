// The diagnosis worker: a real (small, fast) diagnosis end to end through the API and the store,
// whose stored result equals studies::to_json(studies::diagnose(...)) on the same data; and, with
// an injected diagnosis whose timing the test controls, restart (queued and interrupted
// diagnoses rerun), cancel while running, failure, and shutdown leaving the diagnosis queued.
#include "stickslip/server/diagnosis_worker.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <condition_variable>
#include <cstdio>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "stickslip/server/api.h"
#include "stickslip/measured/synth.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using store::StudyState;
using testing::body_json;
using testing::get;
using testing::post_json;
using testing::TempDir;

std::string to_csv(const measured::MeasuredRun& r) {
  std::string s = "t,Fd\n";
  char line[64];
  for (std::size_t i = 0; i < r.t.size(); ++i) {
    std::snprintf(line, sizeof line, "%.17g,%.17g\n", r.t[i], r.Fd[i]);
    s += line;
  }
  return s;
}

/// A short synthetic LuGre dataset (2 runs of 3 s, vibration from 1.5 s; 500 Hz) as a request
/// with tiny options, so that a real diagnosis takes seconds.
json small_request() {
  measured::SynthOptions o;
  o.model = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  measured::MeasuredConditions c;
  c.t_on = 1.5;
  c.duration = 3.0;
  o.runs = {c, c};
  o.runs[1].va = 4e-3;
  o.rate = 500.0;
  o.noise_sigma = 0.03;
  o.seed = 7;
  o.rtol = 1e-7;
  const measured::MeasuredDataset ds = measured::synthesize(o);
  json manifest = {{"name", "small"}, {"runs", json::array()}};
  json files = json::object();
  for (std::size_t i = 0; i < ds.runs.size(); ++i) {
    const auto& r = ds.runs[i];
    const std::string file = "run" + std::to_string(i) + ".csv";
    manifest["runs"].push_back({{"name", "run" + std::to_string(i)},
                                {"file", file},
                                {"conditions",
                                 {{"va", r.conditions.va},
                                  {"t_on", r.conditions.t_on},
                                  {"duration", r.conditions.duration}}}});
    files[file] = to_csv(r);
  }
  return {{"manifest", manifest},
          {"files", files},
          {"options",
           {{"models", {"lugre"}},
            {"candidates", {"viscous"}},
            {"max_evals_base", 12},
            {"max_evals_candidate", 10},
            {"short_window", 1.0},
            {"later_stage_fit_span", 1.0}}}};
}

/// Polls GET /v1/diagnoses/{id} until the state is one of want (or the time is up).
json wait_state(const Api& api, const std::string& id, const std::set<std::string>& want,
                std::chrono::seconds limit = 60s) {
  const auto end = std::chrono::steady_clock::now() + limit;
  json d;
  while (std::chrono::steady_clock::now() < end) {
    d = body_json(api.handle(get("/v1/diagnoses/" + id)));
    if (want.count(d.value("state", ""))) return d;
    std::this_thread::sleep_for(20ms);
  }
  ADD_FAILURE() << "diagnosis " << id << " still " << d.value("state", "?");
  return d;
}

TEST(DiagnosisWorker, RealDiagnosisStoresExactlyTheLibrarysResult) {
  TempDir dir;
  ApiOptions ao;
  ao.db = dir / "d.db";
  DiagnosisWorkerOptions wo;
  wo.poll = 50ms;
  wo.nice = 0;
  DiagnosisWorker worker(ao.db, wo, &run_diagnosis);
  Api api(ao, nullptr, &worker);
  worker.start();
  const json req = small_request();
  const Response r = api.handle(post_json("/v1/diagnoses", req.dump()));
  ASSERT_EQ(r.status, 202) << r.body.substr(0, 500);
  const std::string id = body_json(r)["id"];
  const json done = wait_state(api, id, {"succeeded", "failed"}, 600s);
  ASSERT_EQ(done["state"], "succeeded") << done.dump().substr(0, 500);
  EXPECT_FALSE(done["started_at"].is_null());
  EXPECT_FALSE(done["finished_at"].is_null());
  // The worker counts a diagnosis just after storing its state: wait for the count (up to 5 s;
  // it lagged the stored state once in a loaded ctest -j2 run).
  for (int i = 0; i < 100 && worker.finished() == 0; ++i) std::this_thread::sleep_for(50ms);
  EXPECT_EQ(worker.finished(), 1u);

  // The library on the same data, options spelled out here (not taken from the server's parser).
  std::map<std::string, std::string> files;
  for (const auto& [k, v] : req["files"].items()) files[k] = v;
  const measured::MeasuredDataset data = measured::load_measured(req["manifest"], files);
  diagnosis::DiagnoseOptions o;
  o.models = {engine::model_kind<engine::LuGre>};
  o.candidates = {engine::ExtensionKind::kViscous};
  o.max_evals_base = 12;
  o.max_evals_candidate = 10;
  o.short_window = 1.0;
  o.later_stage_fit_span = 1.0;
  o.keep_traces = true;
  const diagnosis::Diagnosis lib = diagnosis::diagnose(data, o);
  json expected = diagnosis::to_json(lib);
  json got = done["result"];
  ASSERT_TRUE(got.is_object());
  for (json* j : {&expected, &got}) j->erase("seconds");  // wall time
  EXPECT_EQ(got, expected);
  EXPECT_EQ(got["dataset"], "small");

  // The series the library plots (runK.png) are stored with it: GET .../traces serves them.
  const json list = body_json(api.handle(get("/v1/diagnoses/" + id + "/traces")));
  ASSERT_EQ(list["runs"].size(), lib.series.size());
  for (std::size_t k = 0; k < lib.series.size(); ++k) {
    const auto& s = lib.series[k];
    EXPECT_EQ(list["runs"][k]["run"], s.name);
    const json t = body_json(api.handle(
        get("/v1/diagnoses/" + id + "/traces/" + std::to_string(k) + "?max_points=200000")));
    EXPECT_EQ(t["decimated"], false);
    EXPECT_EQ(t["t"].get<std::vector<double>>(), s.t);
    EXPECT_EQ(t["measured"].get<std::vector<double>>(), s.measured);
    EXPECT_EQ(t["base"].get<std::vector<double>>(), s.base);
    if (s.extended.empty())
      EXPECT_TRUE(t["extended"].is_null());
    else
      EXPECT_EQ(t["extended"].get<std::vector<double>>(), s.extended);
  }
}

/// A diagnosis that blocks until released, recording what it was asked to run.
class FakeDiagnosis {
 public:
  DiagnoseFn fn() {
    return [this](const measured::MeasuredDataset& data, const diagnosis::DiagnoseOptions&) -> json {
      std::unique_lock lock(mu_);
      started_.push_back(data.name);
      cv_.notify_all();
      cv_.wait(lock, [&] { return released_ > 0; });
      --released_;
      ++returned_;
      cv_.notify_all();
      if (fail_) throw std::invalid_argument("runs: nothing to fit");
      return {{"dataset", data.name}, {"cause", "none"}};
    };
  }
  void release(int n = 1) {
    std::lock_guard lock(mu_);
    released_ += n;
    cv_.notify_all();
  }
  /// Waits until n calls have returned (so that no thread uses this object any more).
  void wait_returned(int n) {
    std::unique_lock lock(mu_);
    EXPECT_TRUE(cv_.wait_for(lock, 20s, [&] { return returned_ >= n; }));
  }
  void fail_next() {
    std::lock_guard lock(mu_);
    fail_ = true;
  }
  void wait_started(std::size_t n) {
    std::unique_lock lock(mu_);
    EXPECT_TRUE(cv_.wait_for(lock, 20s, [&] { return started_.size() >= n; }))
        << started_.size() << " of " << n << " started";
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::string> started_;
  int released_ = 0;
  int returned_ = 0;
  bool fail_ = false;
};

/// A long diagnosis that honours DiagnoseOptions::stop_requested as studies::diagnose does:
/// it polls the callback until it says stop (then throws DiagnosisCancelled), or returns a
/// result after 30 s if it never does, so a lost stop fails the test rather than hanging it.
/// Datasets named "quick" return at once. plain_error: stop with a std::runtime_error instead,
/// as a diagnosis whose evaluations failed under the stop might.
class StoppableDiagnosis {
 public:
  explicit StoppableDiagnosis(bool plain_error = false) : plain_error_(plain_error) {}
  DiagnoseFn fn() {
    return [this](const measured::MeasuredDataset& data, const diagnosis::DiagnoseOptions& o) -> json {
      if (data.name == "quick") return {{"dataset", data.name}};
      {
        std::lock_guard lock(mu_);
        had_callback_ = static_cast<bool>(o.stop_requested);
        started_ = true;
        cv_.notify_all();
      }
      const auto end = std::chrono::steady_clock::now() + 30s;
      while (std::chrono::steady_clock::now() < end) {
        if (o.stop_requested && o.stop_requested()) {
          std::lock_guard lock(mu_);
          stopped_ = true;
          if (plain_error_) throw std::runtime_error("no base model could be calibrated");
          throw diagnosis::DiagnosisCancelled();
        }
        std::this_thread::sleep_for(1ms);
      }
      return {{"dataset", data.name}};
    };
  }
  void wait_started() {
    std::unique_lock lock(mu_);
    EXPECT_TRUE(cv_.wait_for(lock, 20s, [&] { return started_; }));
  }
  bool had_callback() {
    std::lock_guard lock(mu_);
    return had_callback_;
  }
  bool stopped() {
    std::lock_guard lock(mu_);
    return stopped_;
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool started_ = false, had_callback_ = false, stopped_ = false;
  const bool plain_error_;
};

class DiagnosisWorkerFake : public ::testing::Test {
 protected:
  DiagnosisWorkerFake() { ao_.db = dir_ / "d.db"; }
  DiagnosisWorkerOptions wo() {
    DiagnosisWorkerOptions o;
    o.poll = 50ms;
    o.nice = 0;
    return o;
  }
  /// Queues a (tiny, valid) diagnosis through an API with no worker; returns its id.
  std::string queue(const std::string& name) {
    Api api(ao_);
    std::string text = "t,Fd\n";
    for (int i = 0; i < 30; ++i) text += std::to_string(0.01 * i) + ",8\n";
    const json req = {{"manifest", {{"name", name}, {"runs", {{{"name", "r"}, {"file", "a.csv"}}}}}},
                      {"files", {{"a.csv", text}}}};
    const Response r = api.handle(post_json("/v1/diagnoses", req.dump()));
    EXPECT_EQ(r.status, 202) << r.body;
    return body_json(r)["id"];
  }
  StudyState state(const std::string& id) {
    auto store = store::Store::open(ao_.db);
    return store.get_diagnosis(id)->state;
  }
  TempDir dir_;
  ApiOptions ao_;
  FakeDiagnosis fake_;
};

TEST_F(DiagnosisWorkerFake, QueuedAndInterruptedDiagnosesRunAfterARestart) {
  // Queued while no worker ran (a server that stopped), one of them left running by a crash.
  const std::string a = queue("first");
  const std::string b = queue("second");
  {
    auto store = store::Store::open(ao_.db);
    store.set_diagnosis_state(a, StudyState::kRunning);
  }
  DiagnosisWorker worker(ao_.db, wo(), fake_.fn());
  Api api(ao_, nullptr, &worker);
  worker.start();
  fake_.wait_started(1);
  EXPECT_EQ(worker.running(), std::min(a, b));  // id order (= creation order to the ms)
  fake_.release(2);
  const json da = wait_state(api, a, {"succeeded"});
  EXPECT_EQ(da["result"], json({{"dataset", "first"}, {"cause", "none"}}));
  const json db = wait_state(api, b, {"succeeded"});
  EXPECT_EQ(db["result"]["dataset"], "second");
}

TEST_F(DiagnosisWorkerFake, CancelWhileRunningDiscardsTheResult) {
  DiagnosisWorker worker(ao_.db, wo(), fake_.fn());
  Api api(ao_, nullptr, &worker);
  worker.start();
  const std::string id = queue("c");
  worker.notify();
  fake_.wait_started(1);
  EXPECT_EQ(state(id), StudyState::kRunning);
  const Response c = api.handle(post_json("/v1/diagnoses/" + id + ":cancel", ""));
  ASSERT_EQ(c.status, 200) << c.body;
  EXPECT_EQ(body_json(c)["state"], "cancelled");
  fake_.release();
  while (worker.finished() < 1) std::this_thread::sleep_for(10ms);
  const json d = body_json(api.handle(get("/v1/diagnoses/" + id)));
  EXPECT_EQ(d["state"], "cancelled");
  EXPECT_TRUE(d["result"].is_null());
}

TEST_F(DiagnosisWorkerFake, AFailingDiagnosisIsFailedWithItsError) {
  DiagnosisWorker worker(ao_.db, wo(), fake_.fn());
  Api api(ao_, nullptr, &worker);
  worker.start();
  fake_.fail_next();
  const std::string id = queue("f");
  worker.notify();
  fake_.release();
  const json d = wait_state(api, id, {"failed"});
  EXPECT_EQ(d["error"], "runs: nothing to fit");
  EXPECT_TRUE(d["result"].is_null());
}

TEST_F(DiagnosisWorkerFake, ShutdownLeavesTheRunningDiagnosisQueuedForTheNextStart) {
  const std::string id = queue("s");
  {
    DiagnosisWorker worker(ao_.db, wo(), fake_.fn());
    worker.start();
    fake_.wait_started(1);
    EXPECT_EQ(state(id), StudyState::kRunning);
    // The computation cannot be interrupted: after the grace the thread is left to itself.
    EXPECT_FALSE(worker.shutdown(100ms));
    EXPECT_EQ(state(id), StudyState::kQueued);
  }
  // A new worker (the next start) runs it again; the abandoned computation, released too, may
  // store its result first: either way it ends succeeded, once.
  FakeDiagnosis second;
  DiagnosisWorker next(ao_.db, wo(), second.fn());
  Api api(ao_, nullptr, &next);
  next.start();
  second.wait_started(1);
  second.release();
  fake_.release();
  fake_.wait_returned(1);
  const json d = wait_state(api, id, {"succeeded"});
  EXPECT_EQ(d["result"]["dataset"], "s");
  EXPECT_TRUE(next.shutdown());
}

TEST_F(DiagnosisWorkerFake, CancelWhileRunningStopsTheComputation) {
  StoppableDiagnosis slow;
  DiagnosisWorker worker(ao_.db, wo(), slow.fn());
  Api api(ao_, nullptr, &worker);
  worker.start();
  const std::string id = queue("long");
  worker.notify();
  slow.wait_started();
  EXPECT_TRUE(slow.had_callback());
  const Response c = api.handle(post_json("/v1/diagnoses/" + id + ":cancel", ""));
  ASSERT_EQ(c.status, 200) << c.body;
  // The computation ends because it was told to (a lost stop would take 30 s and return).
  for (int i = 0; i < 3000 && worker.finished() < 1; ++i) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(worker.finished(), 1u);
  EXPECT_TRUE(slow.stopped());
  const json d = body_json(api.handle(get("/v1/diagnoses/" + id)));
  EXPECT_EQ(d["state"], "cancelled");
  EXPECT_TRUE(d["result"].is_null());
  // The worker is free for the next one.
  const std::string next = queue("quick");
  worker.notify();
  EXPECT_EQ(wait_state(api, next, {"succeeded"})["result"]["dataset"], "quick");
}

TEST_F(DiagnosisWorkerFake, ShutdownStopsTheRunningComputationAndRequeuesIt) {
  // Whether the stopped computation throws DiagnosisCancelled or another error, the re-queued
  // diagnosis stays queued (an error caused by the stop is not stored as its failure).
  for (const bool plain_error : {false, true}) {
    StoppableDiagnosis slow(plain_error);
    const std::string id = queue(plain_error ? "long-plain" : "long");
    DiagnosisWorker worker(ao_.db, wo(), slow.fn());
    worker.start();
    slow.wait_started();
    // The thread ends (joined, not detached) because the computation was told to stop.
    EXPECT_TRUE(worker.shutdown(20s));
    EXPECT_TRUE(slow.stopped());
    EXPECT_EQ(state(id), StudyState::kQueued) << "plain error: " << plain_error;
    auto store = store::Store::open(ao_.db);
    store.set_diagnosis_state(id, StudyState::kCancelled);  // out of the next round's way
  }
}

}  // namespace
}  // namespace stickslip::server
