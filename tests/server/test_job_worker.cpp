// The job worker under store faults (issue 18, defect 2): a persistent I/O error used to make
// the worker claim the same study again at once, fail again and log the error about 3,300 times
// a second while the study stayed running. Now it pauses with backoff, puts the study back to
// queued with the error, marks the server's health degraded, and resumes by itself once the
// store takes writes again. Also: the kinds stay apart, and a new kind needs only a RunJobFn.
#include "stickslip/server/job_worker.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <atomic>
#include <thread>

#include "stickslip/server/worker.h"
#include "support/fault_vfs.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

using namespace std::chrono_literals;
using store::StudyState;
using testing::TempDir;

std::string queue_study(const std::filesystem::path& db) {
  auto store = store::Store::open(db);
  store::NewStudy s;
  s.name = "faulty";
  s.spec_json = R"({"name": "faulty"})";
  s.spec_hash = store::param_hash(s.spec_json);
  s.total_runs = 1;
  return store.create_study(s).study.id;
}

template <class Pred>
bool eventually(Pred pred, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(20ms);
  }
  return pred();
}

TEST(JobWorker, APersistentStoreFaultPausesTheWorkerInsteadOfLoopingAndItRecovers) {
  TempDir dir;
  const auto db = dir.path() / "f.db";
  const std::string id = queue_study(db);
  stickslip::testing::FaultVfs vfs;
  std::atomic<int> calls{0};
  // A runner whose first write meets a disk that fails every write from now on (as after the
  // -wal was deleted under the server, or a full or failing disk).
  RunStudyFn run = [&](const std::filesystem::path& path, const std::string& study,
                       const studies::StudySpec&, const studies::RunnerOptions&) {
    if (++calls == 1) vfs.fail_writes(SQLITE_IOERR_WRITE);
    store::Store::open(path).set_study_state(study, StudyState::kRunning);  // throws while failing
    store::Store::open(path).set_study_state(study, StudyState::kSucceeded);
    studies::RunSummary s;
    s.outcome = studies::RunOutcome::kCompleted;
    return s;
  };
  WorkerOptions o;
  o.poll = 20ms;
  o.limits.max_runs = 10;
  auto health = std::make_shared<Health>();
  Worker worker(db, o, run, health);
  worker.start();
  std::this_thread::sleep_for(2500ms);
  EXPECT_EQ(calls.load(), 1) << "the worker ran the study again while the store failed";
  ASSERT_TRUE(health->problem());
  EXPECT_NE(health->problem()->find("disk I/O error"), std::string::npos) << *health->problem();
  EXPECT_LT(vfs.failures(), 50) << "the worker kept writing to a failing store";
  vfs.fail_writes(0);
  // The pause doubles from 1 s (1 + 2 s so far): the next attempt comes within 4 s.
  EXPECT_TRUE(eventually([&] { return calls.load() >= 2; }, 6s));
  EXPECT_TRUE(eventually(
      [&] { return store::Store::open(db).get_study(id)->state == StudyState::kSucceeded; }, 5s));
  EXPECT_FALSE(health->problem());
  worker.shutdown();
}

TEST(JobWorker, AnyKindOfJobRunsThroughItsRunJobFnAndKindsStayApart) {
  TempDir dir;
  const auto db = dir.path() / "k.db";
  std::string job_id;
  {
    auto store = store::Store::open(db);
    store::NewJob j;
    j.kind = "validation";
    j.name = "v";
    j.request_json = R"({"n": 3})";
    job_id = store.create_job(j).job.id;
  }
  const std::string study_id = queue_study(db);
  std::atomic<int> ran{0};
  JobWorkerOptions o;
  o.kind = "validation";
  o.poll = 20ms;
  JobWorker worker(db, o, [&](JobContext& ctx) {
    ++ran;
    EXPECT_EQ(ctx.job.kind, "validation");
    EXPECT_EQ(*ctx.job.request_json, R"({"n": 3})");
    return JobOutcome{JobOutcome::Kind::kSucceeded, R"({"score": 1})", {}};
  });
  worker.start();
  ASSERT_TRUE(eventually([&] { return worker.finished() == 1; }, 5s));
  std::this_thread::sleep_for(100ms);
  worker.shutdown();
  EXPECT_EQ(ran.load(), 1);
  auto store = store::Store::open(db);
  const auto job = store.get_job(job_id, {.request = false, .result = true});
  EXPECT_EQ(job->state, StudyState::kSucceeded);
  EXPECT_EQ(*job->result_json, R"({"score": 1})");
  EXPECT_EQ(store.get_study(study_id)->state, StudyState::kQueued);  // not this worker's kind
  EXPECT_EQ(cancel_unclaimed(store, "validation", study_id), CancelOutcome::kNotFound);
}

}  // namespace
}  // namespace stickslip::server
