// The store under other processes, end to end (issue 18, defect 1 and the single writer): while
// stickslipd runs a study, a `sqlite3` shell reads the store, `stickslip study run` and a second
// stickslipd try to write to it, and `stickslip store check` checks it; then the server is
// killed with SIGKILL. Every run the API confirmed is in the file, the other writers were
// refused with the holder named, and the study completes on the next start.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "daemon.h"
#include "process.h"
#include "test_support.h"

namespace stickslip::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using nlohmann::json;
using testing::CommandResult;
using testing::curl;
using testing::Daemon;
using testing::kClientBin;
using testing::kServerBin;
using testing::run_command;
using testing::TempDir;

std::string sqlite3_count(const fs::path& dir, const fs::path& db, const std::string& sql) {
  const CommandResult r = run_command({"sqlite3", db.string(), sql}, dir);
  EXPECT_EQ(r.code, 0) << r.err;
  std::string out = r.out;
  while (!out.empty() && out.back() == '\n') out.pop_back();
  return out;
}

TEST(StoreEndToEnd, OtherProcessesNeverCostAConfirmedRun) {
  if (run_command({"sh", "-c", "command -v sqlite3"}, fs::temp_directory_path()).code != 0)
    GTEST_SKIP() << "no sqlite3 shell";
  TempDir dir;
  const fs::path db = dir.path() / "e2e.db";
  const json spec = {{"name", "durable"},
                     {"stages", {{{"duration", 1.5}}, {{"duration", 1.5}, {"f", 1500}}}},
                     {"outputs", {{"traces", {{"rate", 100}}}}},
                     {"design", {{"type", "grid"},
                                 {"axes", {{{"name", "model"}, {"values", {"dahl", "lugre"}}},
                                           {{"name", "va_over_vd"}, {"linspace", {0, 4, 40}}}}}}}};
  std::ofstream(dir.path() / "spec.json") << spec.dump();
  std::ofstream(dir.path() / "other.json") << R"({"name": "other", "stages": [{"duration": 0.2}]})";
  std::string id;
  std::int64_t confirmed = 0;
  {
    Daemon d(dir.path());
    std::string data_arg = "@";  // appended: "@" + std::string makes GCC 12 report a false
    data_arg += (dir.path() / "spec.json").string();  // -Wrestrict (GCC bug 105329)
    const auto sub = curl(dir.path(), {"-X", "POST", "-H", "Content-Type: application/json",
                                       "--data-binary", data_arg, d.url() + "/v1/studies"});
    ASSERT_EQ(sub.status, 202) << sub.body;
    id = json::parse(sub.body)["id"];
    const auto progress = [&] {
      return json::parse(curl(dir.path(), {d.url() + "/v1/studies/" + id}).body)["progress"]["done"]
          .get<std::int64_t>();
    };
    for (int i = 0; i < 600 && progress() == 0; ++i) std::this_thread::sleep_for(50ms);
    // A reader with its own connection, then two would-be writers: both refused, naming the server.
    EXPECT_NE(sqlite3_count(dir.path(), db, "SELECT count(*) FROM runs"), "0");
    const std::string pid = "pid " + std::to_string(d.process().pid());
    const CommandResult cli = run_command(
        {kClientBin, "study", "run", (dir.path() / "other.json").string(), "--db", db.string()},
        dir.path());
    EXPECT_EQ(cli.code, 2) << cli.out << cli.err;
    EXPECT_NE(cli.err.find("stickslipd (" + pid), std::string::npos) << cli.err;
    EXPECT_NE(cli.err.find("stickslip submit"), std::string::npos) << cli.err;
    EXPECT_NE(cli.err.find(d.url()), std::string::npos) << cli.err;
    const CommandResult second = run_command(
        {kServerBin, "--db", db.string(), "--port", "0"}, dir.path(), {}, 30s);
    EXPECT_EQ(second.code, 1) << second.out << second.err;
    EXPECT_NE(second.err.find(pid), std::string::npos) << second.err;
    const CommandResult check = run_command({kClientBin, "store", "check", db.string()}, dir.path());
    EXPECT_EQ(check.code, 0) << check.out << check.err;
    EXPECT_NE(check.out.find("writer: stickslipd"), std::string::npos) << check.out;
    std::this_thread::sleep_for(1s);
    confirmed = progress();
    d.process().signal(SIGKILL);
    d.process().wait(10s);
  }
  EXPECT_GT(confirmed, 0);
  EXPECT_GE(std::stoll(sqlite3_count(dir.path(), db,
                                     "SELECT count(*) FROM runs WHERE study_id = '" + id + "'")),
            confirmed)
      << "runs the API confirmed are not in the file";
  EXPECT_EQ(sqlite3_count(dir.path(), db, "PRAGMA integrity_check"), "ok");
  EXPECT_EQ(sqlite3_count(dir.path(), db, "SELECT count(*) FROM studies"), "1")
      << "a refused writer created a study";
  Daemon again(dir.path());
  json s;
  for (int i = 0; i < 1200; ++i) {
    s = json::parse(curl(dir.path(), {again.url() + "/v1/studies/" + id}).body);
    if (s["state"] == "succeeded") break;
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(s["state"], "succeeded") << s.dump();
  EXPECT_EQ(sqlite3_count(dir.path(), db,
                          "SELECT count(DISTINCT design_index) || '/' || count(*) FROM runs"),
            "80/80");
  again.process().signal(SIGTERM);
  EXPECT_EQ(again.process().wait(60s), 0);
}

}  // namespace
}  // namespace stickslip::server
