// Lost and hung ranks (docs/scale.md, "Failures"), injected by the test-only PMPI wrapper
// fault_rank_preload.cpp: the job ends non-zero within a bounded time, the store passes
// PRAGMA integrity_check, every run committed before the fault is unchanged, and running the
// study again (or the automatic retry) ends with exactly the design's runs, each once, equal
// to the OpenMP run bit for bit.
#include <chrono>

#include "mpi_support.h"

namespace {

using namespace stickslip::mpitest;
using stickslip::testing::TempDir;
using Clock = std::chrono::steady_clock;

constexpr int kRuns = 40;  // grid_spec(..., 20): 2 models x 20 values, about 80 ms a run

class MpiFaults : public ::testing::Test {
 protected:
  void SetUp() override {
    spec_ = write_file(dir_ / "k.json", grid_spec("k", kRuns / 2)).string();
    const CommandResult omp = run_command(
        {kClient, "study", "run", spec_, "--db", ref(), "--threads", "2", "--quiet"}, dir_.path());
    ASSERT_EQ(omp.code, 0) << omp.err;
  }
  std::string ref() const { return (dir_ / "ref.db").string(); }
  std::vector<std::string> run_args(const std::string& db) const {
    return {kClient, "study", "run", spec_, "--db", db, "--threads", "1"};
  }
  /// Runs argv, which must end non-zero within limit; returns what it printed.
  CommandResult run_failing(const std::vector<std::string>& argv, std::chrono::seconds limit) {
    const auto t0 = Clock::now();
    const CommandResult r = run_command(argv, dir_.path(), {}, limit + std::chrono::seconds(30));
    const double took = std::chrono::duration<double>(Clock::now() - t0).count();
    EXPECT_NE(r.code, 0) << r.out << r.err;
    EXPECT_NE(r.code, -1) << "still running after " << took << " s";
    EXPECT_LT(took, static_cast<double>(limit.count())) << r.err;
    return r;
  }
  /// After a fault: the file is whole, some runs were committed, and a copy is kept.
  void check_after_fault(const fs::path& db) {
    EXPECT_EQ(integrity(db), "ok");
    const std::int64_t stored = query_int(db, "SELECT count(*) FROM runs");
    EXPECT_GT(stored, 0) << "nothing was committed before the fault: the test proves little";
    EXPECT_LT(stored, kRuns) << "the fault came after the last run";
    snapshot(db, dir_ / "before.db");
  }
  /// After the resume: complete, no duplicates, the committed runs unchanged, = OpenMP.
  void check_resumed(const fs::path& db) {
    EXPECT_EQ(state_of(db), "succeeded");
    expect_complete(db, kRuns);
    EXPECT_EQ(rows_missing(dir_ / "before.db", db), 0) << "a committed run changed";
    expect_same_results(ref(), db);
  }
  TempDir dir_{"stickslip-mpif"};
  std::string spec_;
};

// mpirun stickslip study run: rank 1 is killed as it receives its 3rd chunk. Open MPI then
// ends the whole job (rank 0 too, within about 1 s); rank 0's commits stay.
TEST_F(MpiFaults, KilledRankEndsTheJobAndRunningAgainCompletesIt) {
  const fs::path db = dir_ / "kill.db";
  const CommandResult r = run_failing(
      cat(mpirun(3, "rank=1,chunk=3,action=kill"), run_args(db.string())), std::chrono::seconds(30));
  EXPECT_NE(r.err.find("rank 1"), std::string::npos) << r.err;  // mpirun names the rank
  check_after_fault(db);
  EXPECT_EQ(state_of(db), "running");  // rank 0 was killed too: the state stays resumable
  EXPECT_NE(error_of(db).find("MPI job of 3 ranks"), std::string::npos) << error_of(db);
  const CommandResult again = run_command(cat(mpirun(3), run_args(db.string())), dir_.path());
  ASSERT_EQ(again.code, 0) << again.err;
  check_resumed(db);
}

// A rank that stops answering (its first chunk) is found by the chunk deadline (2 s here):
// rank 0 commits what the other rank returned, marks the study failed naming the rank, and
// ends the job with MPI_Abort.
TEST_F(MpiFaults, HungRankIsFoundByTheChunkDeadlineAndFailsTheStudyNamingIt) {
  const fs::path db = dir_ / "hang.db";
  const CommandResult r =
      run_failing(cat(mpirun(3, "rank=1,chunk=1,action=hang"),
                      cat(run_args(db.string()), {"--chunk-deadline", "2"})),
                  std::chrono::seconds(30));
  check_after_fault(db);
  EXPECT_EQ(state_of(db), "failed");
  EXPECT_NE(error_of(db).find("rank 1 did not return chunk"), std::string::npos) << error_of(db);
  EXPECT_NE(r.err.find("rank 1 did not return chunk"), std::string::npos) << r.err;
  const CommandResult again = run_command(cat(mpirun(3), run_args(db.string())), dir_.path());
  ASSERT_EQ(again.code, 0) << again.err;
  check_resumed(db);
}

// --launcher: this process is the writer and outlives the MPI job, so a killed rank becomes
// the study's error, with the launcher's own words; --retries starts the job again.
TEST_F(MpiFaults, LauncherJobThatLosesARankFailsTheStudyWithTheLaunchersMessage) {
  const fs::path db = dir_ / "launch.db";
  run_failing(cat(run_args(db.string()),
                  {"--launcher", launcher(3, "rank=1,chunk=3,action=kill")}),
              std::chrono::seconds(30));
  check_after_fault(db);
  EXPECT_EQ(state_of(db), "failed");
  const std::string error = error_of(db);
  EXPECT_NE(error.find("exited with status"), std::string::npos) << error;
  EXPECT_NE(error.find("process rank 1"), std::string::npos) << error;
  EXPECT_NE(error.find("signal 9"), std::string::npos) << error;
  // Again, with a retry: the first job loses rank 2, the second one finishes the study.
  const std::string once = (dir_ / "fired").string();
  const CommandResult again = run_command(
      cat(run_args(db.string()),
          {"--retries", "1", "--launcher", launcher(3, "rank=2,chunk=2,action=kill,once=" + once)}),
      dir_.path());
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_TRUE(fs::exists(once)) << "the fault did not fire: the retry was not tested";
  EXPECT_NE(again.err.find("attempt 1 lost work"), std::string::npos) << again.err;
  check_resumed(db);
}

}  // namespace
