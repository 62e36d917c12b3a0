// SIGKILL at random moments, in a bounded loop: a real stickslipd running studies and a
// diagnosis, and `stickslip study run`, are killed with kill -9 after a random time, again and
// again; after each kill the file is checked against what the API or the CLI confirmed (every
// confirmed run and job is there, integrity_check ok, no duplicates), and the process is started
// again. At the end the jobs complete, and the study's runs equal those of a run without kills.
//
// Default: 3 kills of each. STICKSLIP_FAULTS_KILLS=N sets the number; STICKSLIP_FAULTS_LONG=1
// makes it 100. The random moments come from STICKSLIP_FAULTS_SEED (default: the time; printed,
// so that a failure can be replayed).
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <random>
#include <regex>
#include <thread>

#include "faults/live.h"
#include "stickslip/studies/runner.h"
#include "stickslip/studies/spec.h"
#include "support/temp_dir.h"

namespace stickslip {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using server::testing::CommandResult;
using server::testing::kClientBin;
using server::testing::Process;
using server::testing::run_command;
using testing::Daemon;
using testing::Job;
using testing::RawDb;

long kills_wanted() {
  return testing::env_long("STICKSLIP_FAULTS_KILLS", testing::long_faults() ? 100 : 3);
}

std::uint64_t seed() {
  const long s = testing::env_long("STICKSLIP_FAULTS_SEED", 0);
  const auto v = s != 0 ? static_cast<std::uint64_t>(s)
                        : static_cast<std::uint64_t>(
                              std::chrono::system_clock::now().time_since_epoch().count() % 1000003);
  std::printf("[faults] STICKSLIP_FAULTS_SEED=%llu\n", static_cast<unsigned long long>(v));
  return v;
}

/// The runs of spec computed in-process without faults: what every killed study must end with.
std::map<std::int64_t, std::string> reference_runs(const fs::path& dir, const std::string& spec_text) {
  const auto parsed = studies::parse_study(spec_text);
  EXPECT_TRUE(parsed.ok()) << common::to_string(parsed.errors);
  const fs::path db = dir / "reference.db";
  std::string id;
  {
    auto s = store::Store::open(db);
    id = studies::create_or_find_study(s, *parsed.spec).id;
  }
  studies::RunnerOptions o;
  o.threads = 1;
  const auto sum = studies::run_study(db, id, *parsed.spec, o);
  EXPECT_EQ(sum.outcome, studies::RunOutcome::kCompleted) << sum.error;
  return testing::run_contents(RawDb(db), id, false);
}

class Kills : public ::testing::Test {
 protected:
  fs::path write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
  stickslip::testing::TempDir dir_{"stickslip-kills"};
};

TEST_F(Kills, ServerKilledAtRandomMomentsKeepsEveryConfirmedRunAndJobAndFinishesThem) {
  const long kills = kills_wanted();
  std::mt19937_64 rng(seed());
  // 80 runs of 2 x 1 s: several seconds of work; when a study is done another is submitted, so
  // any number of kills lands mid-study.
  const std::string spec = testing::study_json("kills", 40, 1.0);
  const fs::path spec_file = write("study.json", spec);
  std::vector<Job> jobs;
  jobs.push_back(testing::make_job("diagnoses", "kills-diagnosis",
                                   write("diagnosis.json", testing::diagnosis_body(dir_.path()))));
  const fs::path db = dir_ / "e2e.db";
  const std::vector<std::string> opts = {"--diagnosis-threads", "1", "--diagnosis-grace", "0"};
  long survived = 0, runs_checked = 0;
  for (long k = 0; k < kills; ++k) {
    SCOPED_TRACE("kill " + std::to_string(k + 1) + " of " + std::to_string(kills));
    Daemon d(dir_.path(), opts);
    // Replays: the same Idempotency-Key gives the same job after any number of kills.
    for (Job& job : jobs) testing::post_job(dir_.path(), d.url(), job);
    if (jobs.size() == 1 || jobs.back().succeeded) {
      jobs.push_back(testing::make_job("studies", "kills-study-" + std::to_string(k), spec_file));
      testing::post_job(dir_.path(), d.url(), jobs.back());
    }
    const auto until = std::chrono::steady_clock::now() +
                       std::chrono::milliseconds(200 + rng() % 1300);
    while (std::chrono::steady_clock::now() < until)
      for (Job& job : jobs) testing::poll_job(dir_.path(), d.url(), job);
    d.process().signal(SIGKILL);
    ASSERT_EQ(d.process().wait(20s), 128 + SIGKILL) << "not killed: " << d.process().err();
    for (const Job& job : jobs) runs_checked += job.done;
    testing::expect_jobs_kept(db, jobs, "after the kill");
    if (HasFailure()) return;
    ++survived;
  }
  // The restart finishes everything.
  Daemon d(dir_.path(), opts);
  ASSERT_TRUE(testing::wait_all_succeeded(dir_.path(), d.url(), jobs, 600s))
      << "not every job finished after the restart";
  d.process().signal(SIGTERM);
  EXPECT_EQ(d.process().wait(60s), 0);
  testing::expect_jobs_kept(db, jobs, "at the end");
  const auto reference = reference_runs(dir_.path(), spec);
  for (const Job& job : jobs) {
    if (job.collection == "studies") {
      EXPECT_EQ(testing::run_contents(RawDb(db), job.id, false), reference) << job.id;
    }
  }
  std::printf("[faults] stickslipd: %ld kills -9 survived, %zu jobs (1 diagnosis), %ld confirmed "
              "runs checked after the kills\n",
              survived, jobs.size(), runs_checked);
  RecordProperty("kills", std::to_string(survived));
}

/// The last "progress: D/T runs done" line of `stickslip study run` (what the CLI confirmed).
std::int64_t last_progress(const std::string& err) {
  static const std::regex re(R"(progress: (\d+)/\d+ runs done)");
  std::int64_t done = 0;
  for (auto it = std::sregex_iterator(err.begin(), err.end(), re); it != std::sregex_iterator();
       ++it)
    done = std::max<std::int64_t>(done, std::stoll((*it)[1]));
  return done;
}

TEST_F(Kills, StudyRunKilledAtRandomMomentsKeepsEveryReportedRunAndResumes) {
  const long kills = kills_wanted();
  std::mt19937_64 rng(seed() + 1);
  // 80 runs for the default 3 kills; more for more kills, so that the study is still running at
  // the last one (each restart resumes it and computes for 0.2 to 1.5 s).
  const int n_va = static_cast<int>(std::max<long>(40, 10 * kills));
  const std::string spec = testing::study_json("cli-kills", n_va, 1.0);
  const fs::path spec_file = write("study.json", spec);
  const fs::path db = dir_ / "cli.db";
  const std::vector<std::string> argv = {kClientBin, "study", "run", spec_file.string(), "--db",
                                         db.string(), "--threads", "2"};
  long survived = 0, k = 0;
  std::string id;
  for (; k < kills; ++k) {
    SCOPED_TRACE("kill " + std::to_string(k + 1));
    Process p(argv, (dir_ / ("run" + std::to_string(k))).string());
    std::this_thread::sleep_for(std::chrono::milliseconds(200 + rng() % 1300));
    p.signal(SIGKILL);
    const auto code = p.wait(20s);
    ASSERT_TRUE(code.has_value());
    if (*code != 128 + SIGKILL) {  // it finished first: nothing more to kill
      ASSERT_EQ(*code, 0) << p.err();
      break;
    }
    ++survived;
    const std::int64_t reported = last_progress(p.err());
    testing::expect_sound_file(db, "after the kill");
    RawDb raw(db);
    if (id.empty() && raw.integer("SELECT count(*) FROM sqlite_master WHERE name = 'studies'") > 0)
      id = raw.text("SELECT id FROM studies");
    EXPECT_LE(raw.integer("SELECT count(*) FROM studies"), 1) << "a second study was created";
    if (!id.empty()) {
      EXPECT_GE(raw.integer("SELECT count(*) FROM runs WHERE study_id = " + testing::quoted(id)),
                reported)
          << "the CLI reported " << reported << " runs done";
    }
    if (HasFailure()) return;
  }
  const CommandResult r = run_command(argv, dir_.path(), {}, 600s);
  ASSERT_EQ(r.code, 0) << r.err;
  RawDb raw(db);
  ASSERT_EQ(raw.integer("SELECT count(*) FROM studies"), 1);
  id = raw.text("SELECT id FROM studies");
  EXPECT_EQ(raw.text("SELECT state FROM studies"), "succeeded");
  testing::expect_sound_file(db, "at the end");
  EXPECT_EQ(testing::run_contents(raw, id, false), reference_runs(dir_.path(), spec));
  std::printf("[faults] stickslip study run: %ld kills -9 survived\n", survived);
  RecordProperty("kills", std::to_string(survived));
}

}  // namespace
}  // namespace stickslip
