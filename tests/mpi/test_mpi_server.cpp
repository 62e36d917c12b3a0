// stickslipd --launcher: each study is one MPI job (mpirun -np 3 here) whose runs the server
// commits itself. Submit, progress while it runs, the result through the API (bit for bit the
// OpenMP run's), cancel (the job ends, nothing of it is left running), and the automatic retry
// after a lost rank (succeeds with every run once) or its limit (fails naming the rank).
#include <dirent.h>

#include <chrono>
#include <fstream>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "mpi_support.h"
#include "server/daemon.h"

namespace {

using namespace stickslip::mpitest;
using namespace std::chrono_literals;
using nlohmann::json;
using stickslip::server::testing::curl;
using stickslip::server::testing::Daemon;
using stickslip::testing::TempDir;

class MpiServer : public ::testing::Test {
 protected:
  /// A daemon whose studies run through `mpirun -np 3` (with a fault when given).
  std::unique_ptr<Daemon> start(const std::string& fault = "", int retries = 2) {
    return std::make_unique<Daemon>(
        dir_.path(), std::vector<std::string>{"--launcher", launcher(3, fault),
                                              "--launcher-program", kClient,
                                              "--launcher-retries", std::to_string(retries)});
  }
  std::string submit(Daemon& d, const std::string& spec) {
    const fs::path file = write_file(dir_ / "post.json", spec);
    std::string at = file.string();  // not "@" + string: a false -Wrestrict (GCC bug 105329)
    at.insert(at.begin(), '@');
    const auto post = curl(dir_.path(), {"-X", "POST", "-H", "Content-Type: application/json",
                                         "--data-binary", at,
                                         d.url() + "/v1/studies"});
    EXPECT_EQ(post.status, 202) << post.body;
    return json::parse(post.body).value("id", "");
  }
  json get(Daemon& d, const std::string& path) {
    const auto r = curl(dir_.path(), {d.url() + path});
    EXPECT_EQ(r.status, 200) << path << ": " << r.body;
    return json::parse(r.body);
  }
  /// Polls the study until pred; every progress.done seen goes to *seen.
  json poll(Daemon& d, const std::string& id, const std::function<bool(const json&)>& pred,
            std::set<std::int64_t>* seen = nullptr) {
    json s;
    for (const auto end = std::chrono::steady_clock::now() + 90s;
         std::chrono::steady_clock::now() < end; std::this_thread::sleep_for(50ms)) {
      s = get(d, "/v1/studies/" + id);
      if (seen != nullptr) seen->insert(s["progress"]["done"].get<std::int64_t>());
      if (pred(s)) return s;
    }
    ADD_FAILURE() << "timed out; last: " << s.dump();
    return s;
  }
  /// Children of the daemon still alive (the launcher, mpirun and its ranks).
  static int children_of(pid_t parent) {
    int n = 0;
    DIR* proc = ::opendir("/proc");
    while (const dirent* e = ::readdir(proc)) {
      std::ifstream stat(std::string("/proc/") + e->d_name + "/stat");
      std::string pid, comm, state;
      pid_t ppid = 0;
      if (stat >> pid >> comm >> state >> ppid && ppid == parent && state != "Z") ++n;
    }
    ::closedir(proc);
    return n;
  }
  std::string reference(const std::string& name, int n) {
    const std::string db = (dir_ / (name + "-ref.db")).string();
    const fs::path spec = write_file(dir_ / (name + ".json"), grid_spec(name, n));
    const CommandResult r = run_command(
        {kClient, "study", "run", spec.string(), "--db", db, "--quiet"}, dir_.path());
    EXPECT_EQ(r.code, 0) << r.err;
    return db;
  }
  TempDir dir_{"stickslip-mpis"};
};

TEST_F(MpiServer, SubmitProgressResultAndCancelThroughTheApi) {
  const std::string ref = reference("s", 20);
  auto d = start();
  const std::string id = submit(*d, grid_spec("s", 20));
  std::set<std::int64_t> seen;
  const json done = poll(*d, id, [](const json& s) { return s["state"] == "succeeded"; }, &seen);
  EXPECT_EQ(done["progress"], json({{"total", 40}, {"done", 40}, {"ok", 40}, {"failed", 0}}));
  const bool partial = std::any_of(seen.begin(), seen.end(), [](auto v) { return v > 0 && v < 40; });
  EXPECT_TRUE(partial) << "no progress was seen while the MPI job ran";
  // The result through the API equals the OpenMP run's, bit for bit through JSON.
  const json runs = get(*d, "/v1/studies/" + id + "/runs?page_size=100");
  ASSERT_EQ(runs["runs"].size(), 40u) << runs.dump();
  const auto amp = query(ref, "SELECT printf('%!.17g', amplitude) FROM stage_metrics "
                              "WHERE design_index = 7 AND stage = 2");
  for (const json& r : runs["runs"]) {
    if (r["design_index"] == 7) {
      EXPECT_EQ(r["stages"][1]["amplitude"].get<double>(), std::stod(amp.at(0))) << r.dump();
    }
  }
  EXPECT_EQ(rows_missing(ref, dir_ / "e2e.db"), 0) << "a stored run differs from OpenMP's";

  // Cancel a longer study while its job runs: it ends cancelled, with part of its runs, and
  // the job (mpirun and its ranks) is gone.
  const std::string slow = submit(*d, grid_spec("slow", 60));
  poll(*d, slow, [](const json& s) { return s["progress"]["done"].get<int>() > 0; });
  const auto cancel = curl(dir_.path(), {"-X", "POST", d->url() + "/v1/studies/" + slow + ":cancel"});
  EXPECT_EQ(cancel.status, 202) << cancel.body;
  const json cancelled = poll(*d, slow, [](const json& s) { return s["state"] != "running"; });
  EXPECT_EQ(cancelled["state"], "cancelled") << cancelled.dump();
  EXPECT_LT(cancelled["progress"]["done"].get<int>(), 120);
  int left = -1;
  for (int i = 0; i < 100 && (left = children_of(d->process().pid())) > 0; ++i)
    std::this_thread::sleep_for(50ms);
  EXPECT_EQ(left, 0) << "processes of the cancelled job are still running";
  EXPECT_EQ(integrity(dir_ / "e2e.db"), "ok");
  d->process().signal(SIGTERM);
  EXPECT_EQ(d->process().wait(30s), 0);
}

TEST_F(MpiServer, LostRankIsRetriedForTheMissingRunsThenTheLimitFailsTheStudy) {
  const std::string ref = reference("r", 20);
  const std::string once = (dir_ / "fired").string();
  {
    auto d = start("rank=1,chunk=2,action=kill,once=" + once, 2);
    const std::string id = submit(*d, grid_spec("r", 20));
    const json s = poll(*d, id, [](const json& s) { return s["state"] != "running" &&
                                                           s["state"] != "queued"; });
    EXPECT_EQ(s["state"], "succeeded") << s.dump();
    EXPECT_TRUE(fs::exists(once)) << "the fault did not fire: the retry was not tested";
    expect_complete(dir_ / "e2e.db", 40);
    expect_same_results(ref, dir_ / "e2e.db");
    EXPECT_NE(d->process().out().find("attempt 1 lost work"), std::string::npos);
    d->process().signal(SIGTERM);
    EXPECT_EQ(d->process().wait(30s), 0);
  }
  // Every job loses rank 2: after 1 retry the study fails, with the launcher's message.
  auto d = start("rank=2,chunk=2,action=kill", 1);
  const std::string id = submit(*d, grid_spec("f", 20));
  const json s = poll(*d, id, [](const json& s) { return s["state"] == "failed"; });
  const std::string error = s["error"].get<std::string>();
  EXPECT_NE(error.find("process rank 2"), std::string::npos) << error;
  EXPECT_NE(error.find("run the study again"), std::string::npos) << error;
  EXPECT_EQ(integrity(dir_ / "e2e.db"), "ok");
  d->process().signal(SIGTERM);
  EXPECT_EQ(d->process().wait(30s), 0);
}

}  // namespace
