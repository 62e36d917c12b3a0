// I/O errors inside a real stickslipd: the fault VFS shim is preloaded into the server
// (fault_vfs_preload.cpp) and armed with SIGUSR2 while a study and a diagnosis run.
//  - A disk that fails every write (persistent): the worker pauses instead of looping (little CPU,
//    few log lines), /healthz turns degraded, every confirmed run stays in the file, and when
//    the disk works again (SIGUSR1) the jobs complete without a restart.
//  - One failed write, fsync or lock at a chosen moment (transient): no job fails; all complete.
// After each case the server is killed (-9) and the file checked against what the API
// confirmed; a restart completes every job.
//
// They check the job worker's handling of store faults (issue 18 defects 2 and 3: backoff instead
// of a hot loop, a store fault puts the job back instead of failing it).
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string_view>
#include <thread>
#include <vector>

#include "faults/live.h"
#include "support/temp_dir.h"

namespace stickslip {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using testing::Daemon;
using testing::Job;

/// CPU time (user + system) a process has used so far [s].
double cpu_seconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::istringstream fields(stat.substr(stat.rfind(')') + 2));  // after "pid (comm) "
  std::string f;
  double ticks = 0;
  for (int i = 3; i <= 15 && fields >> f; ++i)
    if (i == 14 || i == 15) ticks += std::stod(f);
  return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
}

std::size_t lines(const std::string& s) {
  return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n'));
}

std::size_t occurrences(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (auto at = s.find(what); at != std::string::npos; at = s.find(what, at + what.size())) ++n;
  return n;
}

class ServerFaults : public ::testing::Test {
 protected:
  fs::path write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p;
  }
  std::vector<std::string> env(const std::string& plan) const {
    return {std::string("LD_PRELOAD=") + STICKSLIP_FAULT_VFS_LIB, "STICKSLIP_FAULT_VFS=" + plan,
            "STICKSLIP_FAULT_VFS_ARM=signal"};
  }
  std::vector<Job> submit(Daemon& d, const std::string& tag, bool with_diagnosis) {
    std::vector<Job> jobs;
    jobs.push_back(testing::make_job("studies", tag + "-study",
                                     write(tag + ".json", testing::study_json(tag, 40, 1.0))));
    if (with_diagnosis)
      jobs.push_back(testing::make_job("diagnoses", tag + "-diagnosis",
                                       write(tag + "-d.json", testing::diagnosis_body(dir_ / tag))));
    for (Job& job : jobs) testing::post_job(dir_.path(), d.url(), job);
    return jobs;
  }
  /// Kills d, checks the file, restarts without faults and finishes every job.
  void kill_check_and_finish(Daemon& d, std::vector<Job>& jobs) {
    for (Job& job : jobs) testing::poll_job(dir_.path(), d.url(), job);
    d.process().signal(SIGKILL);
    ASSERT_EQ(d.process().wait(20s), 128 + SIGKILL);
    testing::expect_jobs_kept(dir_ / "e2e.db", jobs, "after the kill");
    Daemon again(dir_.path(), opts_);
    ASSERT_TRUE(testing::wait_all_succeeded(dir_.path(), again.url(), jobs, 600s));
    again.process().signal(SIGTERM);
    EXPECT_EQ(again.process().wait(60s), 0);
    testing::expect_jobs_kept(dir_ / "e2e.db", jobs, "at the end");
  }

  const std::vector<std::string> opts_ = {"--diagnosis-threads", "1", "--diagnosis-grace", "0"};
  stickslip::testing::TempDir dir_{"stickslip-server-faults"};
};

TEST_F(ServerFaults, DiskFailingEveryWritePausesTheWorkersAndTheJobsCompleteWhenItRecovers) {
  Daemon d(dir_.path(), opts_, env("write:1:persist"));
  std::vector<Job> jobs = submit(d, "persistent", true);
  const auto start = std::chrono::steady_clock::now();
  while (jobs[0].done == 0 && std::chrono::steady_clock::now() - start < 120s)
    testing::poll_job(dir_.path(), d.url(), jobs[0]);
  ASSERT_GT(jobs[0].done, 0) << "the study did not start";
  d.process().signal(SIGUSR2);  // the disk fails from now on
  // The study worker meets the fault at its next commit, the diagnosis worker when it stores
  // the outcome: /healthz names each paused worker and the store's error. (With every write
  // failing, the error cannot be written into the job's record: /healthz is where it shows.)
  testing::Curl health;
  const auto both_paused = [&] {
    health = testing::curl(dir_.path(), {d.url() + "/healthz"});
    return health.status == 503 &&
           health.body.find("the study worker is paused") != std::string::npos &&
           health.body.find("the diagnosis worker is paused") != std::string::npos;
  };
  while (!both_paused() && std::chrono::steady_clock::now() - start < 300s)
    std::this_thread::sleep_for(200ms);
  ASSERT_TRUE(both_paused()) << health.status << " " << health.body;
  EXPECT_NE(health.body.find("degraded"), std::string::npos) << health.body;
  EXPECT_NE(health.body.find("I/O error"), std::string::npos) << health.body;
  // Both workers paused: the process must now be all but idle.
  // stickslipd logs to stdout (spdlog's default logger); stderr has what else it prints.
  const std::size_t out_before = d.process().out().size(), err_before = d.process().err().size();
  const double cpu_before = cpu_seconds(d.process().pid());
  std::this_thread::sleep_for(5s);
  const double cpu = cpu_seconds(d.process().pid()) - cpu_before;
  const std::string log_window =
      d.process().out().substr(out_before) + d.process().err().substr(err_before);
  const std::size_t logged = lines(log_window);
  // Issue 18 defect 2: a hot loop took 0.6 of a core and logged 3,300 lines a second.
  EXPECT_LT(cpu, 0.5) << "CPU seconds in 5 s of a failing disk";
  EXPECT_LT(logged, 20u) << "log lines in 5 s of a failing disk";
  // Each attempt logs one "store fault, pausing" line. A pause of 1 s doubling (1, 2, 4 s)
  // leaves at most 3 attempts per worker in any 5 s (at +0, +1 and +3 s of its first pause); a
  // worker that retried at its 1 s poll instead would make 5 each.
  EXPECT_LE(occurrences(log_window, "store fault, pausing"), 6u) << log_window;
  for (Job& job : jobs) {
    const testing::Curl c =
        testing::curl(dir_.path(), {d.url() + "/v1/" + job.collection + "/" + job.id});
    const auto j = nlohmann::json::parse(c.body);
    EXPECT_NE(j["state"], "failed") << c.body.substr(0, 300);
    EXPECT_NE(j["state"], "succeeded") << "written while every write fails? " << c.body.substr(0, 300);
  }
  testing::expect_jobs_kept(dir_ / "e2e.db", jobs, "while the disk fails");
  d.process().signal(SIGUSR1);  // the disk works again
  const std::size_t injected = occurrences(d.process().err(), "libstickslip_fault_vfs: injected");
  EXPECT_GE(injected, 2u);  // the study's commit and the diagnosis's outcome at least
  EXPECT_TRUE(testing::wait_all_succeeded(dir_.path(), d.url(), jobs, 600s))
      << "the jobs did not complete after the disk recovered";
  EXPECT_EQ(testing::curl(dir_.path(), {d.url() + "/healthz"}).status, 200);
  kill_check_and_finish(d, jobs);
  std::printf("[faults] stickslipd, every write failing: %zu write errors injected, both workers "
              "paused, %.2f CPU s and %zu log lines in 5 s\n",
              injected, cpu, logged);
}

TEST_F(ServerFaults, OneFailedWriteSyncOrLockNeverFailsAJob) {
  struct Plan {
    const char* text;  // STICKSLIP_FAULT_VFS (fault_vfs_preload.cpp)
    bool diagnosis;
  };
  // One of each kind by default (13: SQLITE_FULL, a full disk); more calls with
  // STICKSLIP_FAULTS_LONG=1.
  std::vector<Plan> plans = {
      {"write:3", true}, {"sync:1", false}, {"lock:10", false}, {"write:2:13", false}};
  if (testing::long_faults())
    plans.insert(plans.end(), {{"write:1", true}, {"write:40", false}, {"write:80", false},
                               {"sync:3", true}, {"lock:1", false}, {"lock:30", true},
                               {"write:20:13", false}});
  long injected = 0;
  for (std::size_t k = 0; k < plans.size(); ++k) {
    const Plan& plan = plans[k];
    SCOPED_TRACE(plan.text);
    for (const char* ext : {"", "-wal", "-shm", ".lock"})
      fs::remove(dir_.path() / ("e2e.db" + std::string(ext)));
    Daemon d(dir_.path(), opts_, env(plan.text));
    std::vector<Job> jobs = submit(d, "transient-" + std::to_string(k), plan.diagnosis);
    const auto start = std::chrono::steady_clock::now();
    while (jobs[0].done == 0 && std::chrono::steady_clock::now() - start < 120s)
      testing::poll_job(dir_.path(), d.url(), jobs[0]);
    d.process().signal(SIGUSR2);  // the plan's call from now on fails once
    ASSERT_TRUE(testing::wait_all_succeeded(dir_.path(), d.url(), jobs, 600s))
        << "a job did not complete after one " << plan.text << " error";
    // The shim logs each failure it injected: exactly one. With WAL and synchronous = NORMAL,
    // SQLite syncs only at checkpoints: a study this small reaches none (1000 pages), so a sync
    // plan meets its call at the checkpoint of the last connection's close when the server stops
    // (SIGTERM); that stop must keep every job too.
    std::size_t n = occurrences(d.process().err(), "libstickslip_fault_vfs: injected");
    const bool at_stop = n == 0 && std::string_view(plan.text).substr(0, 5) == "sync:";
    if (at_stop) {
      d.process().signal(SIGTERM);
      EXPECT_EQ(d.process().wait(60s), 0) << d.process().err();
      n = occurrences(d.process().err(), "libstickslip_fault_vfs: injected");
    }
    EXPECT_EQ(n, 1u) << "the fault was not injected: " << d.process().err();
    injected += static_cast<long>(n);
    if (at_stop) {
      testing::expect_jobs_kept(dir_ / "e2e.db", jobs, "after the stop");
      Daemon again(dir_.path(), opts_);
      testing::expect_jobs_kept(dir_ / "e2e.db", jobs, "after the restart");
      again.process().signal(SIGTERM);
      EXPECT_EQ(again.process().wait(60s), 0);
    } else {
      kill_check_and_finish(d, jobs);
    }
    if (HasFailure()) return;
  }
  std::printf("[faults] stickslipd: %ld single write/sync/lock/full-disk errors injected, no job "
              "failed\n",
              injected);
}

}  // namespace
}  // namespace stickslip
