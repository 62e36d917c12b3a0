// The study worker with an injected runner that behaves like studies::run_study towards the
// store (running -> succeeded / cancelled) but whose timing the test controls: queue order,
// resume of interrupted studies, user cancellation versus shutdown, invalid stored specs.
#include "stickslip/server/worker.h"

#include <gtest/gtest.h>

#include <condition_variable>
#include <mutex>
#include <thread>

#include "stickslip/server/api.h"
#include "test_support.h"
#include "support/is_valid.h"

namespace stickslip::server {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using store::StudyState;
using testing::body_json;
using testing::post_json;
using testing::TempDir;
using testing::tiny_study;

/// A runner that blocks until released (or cancelled), recording what it was asked to run.
class FakeRunner {
 public:
  RunStudyFn fn() {
    return [this](const std::filesystem::path& db, const std::string& id,
                  const studies::StudySpec& spec, const studies::RunnerOptions& o) {
      auto store = store::Store::open(db);
      store.set_study_state(id, StudyState::kRunning);
      {
        std::unique_lock lock(mu_);
        started_.push_back(id);
        total_runs_ = spec.run_count();
        cv_.notify_all();
        // The cancel flag is set without a notification (like run_study, which polls it).
        while (!released_ && !(o.cancel != nullptr && o.cancel->load()) &&
               !(o.stop != nullptr && o.stop->load()))
          cv_.wait_for(lock, 5ms);
      }
      studies::RunSummary s;
      s.total = static_cast<std::int64_t>(spec.run_count());
      if (o.cancel != nullptr && o.cancel->load()) {
        s.outcome = studies::RunOutcome::kCancelled;
        store.set_study_state(id, StudyState::kCancelled);
      } else if (o.stop != nullptr && o.stop->load()) {
        s.outcome = studies::RunOutcome::kStopped;  // run_study leaves it running
      } else {
        s.outcome = studies::RunOutcome::kCompleted;
        store.set_study_state(id, StudyState::kSucceeded);
      }
      return s;
    };
  }
  void release_all() {
    std::lock_guard lock(mu_);
    released_ = true;
    cv_.notify_all();
  }
  /// Waits until n studies have been started; returns their ids in order.
  std::vector<std::string> wait_started(std::size_t n) {
    std::unique_lock lock(mu_);
    EXPECT_TRUE(cv_.wait_for(lock, 10s, [&] { return started_.size() >= n; }))
        << "only " << started_.size() << " of " << n << " studies started";
    return started_;
  }
  std::vector<std::string> started() {
    std::lock_guard lock(mu_);
    return started_;
  }
  /// Needed for the wake-up: notify_all from another thread while the runner waits.
  void poke() { cv_.notify_all(); }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::string> started_;
  std::size_t total_runs_ = 0;
  bool released_ = false;
};

StudyState state_of(const std::filesystem::path& db, const std::string& id) {
  return store::Store::open(db).get_study(id)->state;
}

/// Polls until the study reaches state (the worker finishes asynchronously).
bool wait_state(const std::filesystem::path& db, const std::string& id, StudyState state) {
  for (int i = 0; i < 500; ++i) {
    if (state_of(db, id) == state) return true;
    std::this_thread::sleep_for(10ms);
  }
  return false;
}

class WorkerTest : public ::testing::Test {
 protected:
  std::filesystem::path db() const { return dir_ / "w.db"; }
  std::string create(Api& api, const std::string& name = "tiny") {
    const Response r = api.handle(post_json("/v1/studies", tiny_study(name)));
    EXPECT_EQ(r.status, 202) << r.body;
    return body_json(r)["id"];
  }
  ApiOptions api_options() const {
    ApiOptions o;
    o.db = db();
    return o;
  }
  WorkerOptions worker_options() const {
    WorkerOptions o;
    o.poll = 50ms;
    return o;
  }
  TempDir dir_;
  FakeRunner runner_;
};

TEST_F(WorkerTest, RunsQueuedStudiesOneAtATimeInCreationOrder) {
  Worker worker(db(), worker_options(), runner_.fn());
  Api api(api_options(), &worker);
  std::vector<std::string> ids = {create(api, "a"), create(api, "b"), create(api, "c")};
  std::sort(ids.begin(), ids.end());  // creation order = id order
  worker.start();
  EXPECT_EQ(runner_.wait_started(1), std::vector<std::string>{ids[0]});
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(runner_.started().size(), 1u) << "concurrency 1 ran two studies at once";
  EXPECT_EQ(state_of(db(), ids[1]), StudyState::kQueued);
  runner_.release_all();
  EXPECT_EQ(runner_.wait_started(3), ids);
  for (const auto& id : ids) EXPECT_TRUE(wait_state(db(), id, StudyState::kSucceeded)) << id;
}

TEST_F(WorkerTest, ConcurrencyTwoRunsTwoStudiesAtOnce) {
  WorkerOptions o = worker_options();
  o.concurrency = 2;
  Worker worker(db(), o, runner_.fn());
  Api api(api_options(), &worker);
  create(api, "a");
  create(api, "b");
  worker.start();
  EXPECT_EQ(runner_.wait_started(2).size(), 2u);
  runner_.release_all();
}

TEST_F(WorkerTest, StudiesLeftRunningByACrashResume) {
  std::string id;
  {
    Api api(api_options());
    id = create(api);
    store::Store::open(db()).set_study_state(id, StudyState::kRunning);  // as after SIGKILL
  }
  runner_.release_all();
  Worker worker(db(), worker_options(), runner_.fn());
  worker.start();
  EXPECT_EQ(runner_.wait_started(1), std::vector<std::string>{id});
  EXPECT_TRUE(wait_state(db(), id, StudyState::kSucceeded));
}

TEST_F(WorkerTest, UserCancelStopsTheRunningStudyAndCancelsQueuedOnes) {
  Worker worker(db(), worker_options(), runner_.fn());
  Api api(api_options(), &worker);
  const std::string first = create(api, "a");
  worker.start();
  runner_.wait_started(1);
  const std::string second = create(api, "b");  // waits behind the first

  const Response c2 = api.handle(post_json("/v1/studies/" + second + ":cancel", ""));
  EXPECT_EQ(c2.status, 200) << c2.body;
  EXPECT_EQ(body_json(c2)["state"], "cancelled");

  const Response c1 = api.handle(post_json("/v1/studies/" + first + ":cancel", ""));
  EXPECT_EQ(c1.status, 202) << c1.body;  // running: cancellation requested
  runner_.poke();
  EXPECT_TRUE(wait_state(db(), first, StudyState::kCancelled));
  std::this_thread::sleep_for(150ms);
  EXPECT_EQ(runner_.started(), std::vector<std::string>{first}) << "a cancelled study ran";
  EXPECT_EQ(state_of(db(), second), StudyState::kCancelled);
}

TEST_F(WorkerTest, ShutdownLeavesTheInterruptedStudyQueuedForTheNextStart) {
  std::string id;
  {
    Worker worker(db(), worker_options(), runner_.fn());
    Api api(api_options(), &worker);
    id = create(api);
    worker.start();
    runner_.wait_started(1);
    worker.shutdown();  // sets the stop flag; the fake returns kStopped like run_study
  }
  EXPECT_EQ(state_of(db(), id), StudyState::kQueued);
  runner_.release_all();
  Worker again(db(), worker_options(), runner_.fn());
  again.start();
  EXPECT_EQ(runner_.wait_started(2), (std::vector<std::string>{id, id}));
  EXPECT_TRUE(wait_state(db(), id, StudyState::kSucceeded));
}

TEST_F(WorkerTest, AStoredSpecThatNoLongerParsesFailsTheStudy) {
  std::string id;
  {
    Api api(api_options());
    id = create(api);  // 4 runs
  }
  WorkerOptions o = worker_options();
  o.limits.max_runs = 2;  // the server restarted with a lower limit
  Worker worker(db(), o, runner_.fn());
  worker.start();
  ASSERT_TRUE(wait_state(db(), id, StudyState::kFailed));
  const auto rec = store::Store::open(db()).get_study(id);
  EXPECT_NE(rec->error->find("/design"), std::string::npos) << *rec->error;
  EXPECT_TRUE(runner_.started().empty());
}

TEST(WorkerOptions, InvalidOptionsNameTheField) {
  WorkerOptions o;
  o.concurrency = 0;
  std::string why;
  EXPECT_FALSE(stickslip::testing::is_valid(o, why));
  EXPECT_NE(why.find("concurrency"), std::string::npos);
}

}  // namespace
}  // namespace stickslip::server
