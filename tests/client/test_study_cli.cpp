// End-to-end tests of `stickslip study run` and friends as real processes: bad input gives exit
// 2 with every error named and the database untouched; a run killed with SIGKILL part-way leaves
// a sound database that keeps every committed run, and running again resumes to exactly one
// result per run; map/export/rmse read the store.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "stickslip/store/store.h"
#include "support/cli_process.h"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using stickslip::store::Store;

const std::string kBinary = std::string(STICKSLIP_BINARY_DIR) + "/client/stickslip";

class StudyCli : public ::testing::Test {
 protected:
  using Result = stickslip::testing::CliSandbox::Result;
  fs::path write(const std::string& name, const std::string& text) { return box_.write(name, text); }
  Result run(const std::string& args) { return box_.run(args); }
  static std::string slurp(const fs::path& p) { return stickslip::testing::slurp(p); }
  stickslip::testing::CliSandbox box_{"stickslip-cli"};
  const fs::path& dir_ = box_.dir();
};

const char* kGood = R"({"name": "g", "stages": [{"duration": 2.5}, {"duration": 1}],
  "design": {"type": "grid", "axes": [{"name": "model", "values": ["karnopp", "lugre"]},
                                      {"name": "va_over_vd", "values": [0, 2]}]}})";

TEST_F(StudyCli, BadSpecsExitTwoNameEveryErrorAndLeaveTheDatabaseUnchanged) {
  ASSERT_EQ(run("study run " + write("good.json", kGood).string() + " --db s.db --quiet").code, 0);
  const std::string before = slurp(dir_ / "s.db");
  ASSERT_FALSE(before.empty());
  struct Case {
    const char* name;
    std::string spec;
    std::vector<std::string> expect;  // substrings of stderr
  };
  const std::vector<Case> cases = {
      {"malformed", R"({"name": "x", )", {"(document)", "line"}},
      {"unknown", R"({"name": "x", "colour": 1, "base": {"mass": 2}})", {"colour", "mass"}},
      {"types", R"({"name": "x", "base": {"m": "heavy"}})", {"/base/m"}},
      {"negative", R"({"name": "x", "base": {"m": -1, "k_d": 0}})", {"/base/m", "/base/k_d"}},
      {"model", R"({"name": "x", "base": {"model": "coulomb"}})", {"/base/model", "coulomb"}},
      {"empty", R"({"name": "x", "design": {"type": "grid", "axes": [{"name": "m", "values": []}]}})",
       {"/design/axes/0/values"}},
      {"limit", R"({"name": "x", "design": {"type": "grid", "axes": [
          {"name": "m", "linspace": [0.5, 1, 400]}, {"name": "k_d", "linspace": [1e4, 2e4, 400]}]}})",
       {"160000", "100000"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Result r = run("study run " + write(std::string(c.name) + ".json", c.spec).string() +
                         " --db s.db");
    EXPECT_EQ(r.code, 2) << r.err;
    for (const auto& s : c.expect) EXPECT_NE(r.err.find(s), std::string::npos) << r.err;
    EXPECT_EQ(slurp(dir_ / "s.db"), before);  // not a byte changed
  }
  // A missing spec file.
  const Result missing = run("study run nothere.json --db s.db");
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.err.find("nothere.json"), std::string::npos) << missing.err;
}

TEST_F(StudyCli, UnwritablePathAndForeignDatabaseAreBadInputAndLeftAlone) {
  const fs::path spec = write("good.json", kGood);
  fs::create_directories(dir_ / "ro");
  fs::permissions(dir_ / "ro", fs::perms::owner_read | fs::perms::owner_exec);
  if (::geteuid() != 0) {  // root can write anywhere
    const Result r = run("study run " + spec.string() + " --db ro/s.db");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("ro/s.db"), std::string::npos) << r.err;
  }
  const Result r2 = run("study run " + spec.string() + " --db nodir/s.db");
  EXPECT_EQ(r2.code, 2) << r2.err;
  EXPECT_FALSE(fs::exists(dir_ / "nodir"));

  write("foreign.db", "name,value\nthis is a csv file, not a database\n");
  const std::string before = slurp(dir_ / "foreign.db");
  const Result r3 = run("study run " + spec.string() + " --db foreign.db");
  EXPECT_EQ(r3.code, 2) << r3.err;
  EXPECT_NE(r3.err.find("foreign.db"), std::string::npos) << r3.err;
  EXPECT_EQ(slurp(dir_ / "foreign.db"), before);
}

TEST_F(StudyCli, MapExportAndShowReadTheStore) {
  ASSERT_EQ(run("study run " + write("good.json", kGood).string() + " --db s.db --quiet").code, 0);
  const Result map = run("map g --db s.db");
  ASSERT_EQ(map.code, 0) << map.err;
  EXPECT_NE(map.out.find("karnopp"), std::string::npos) << map.out;
  EXPECT_NE(map.out.find("missing 0, failed 0"), std::string::npos) << map.out;
  const Result csv = run("map g --db s.db --format csv --out map.csv");
  ASSERT_EQ(csv.code, 0) << csv.err;
  std::istringstream lines(slurp(dir_ / "map.csv"));
  std::string header, line;
  std::getline(lines, header);
  EXPECT_EQ(header.rfind("va_over_vd,model,state,design_index,amplitude_1", 0), 0u) << header;
  int rows = 0;
  while (std::getline(lines, line)) ++rows;
  EXPECT_EQ(rows, 4);
  const Result json = run("map g --db s.db --format json");
  EXPECT_NE(json.out.find("\"rows\""), std::string::npos);
  const Result show = run("study show g --db s.db");
  EXPECT_NE(show.out.find("\"succeeded\""), std::string::npos) << show.out;
  const Result exp = run("study export g --db s.db --format csv");
  EXPECT_EQ(std::count(exp.out.begin(), exp.out.end(), '\n'), 5);
  const Result unknown = run("map nosuch --db s.db");
  EXPECT_EQ(unknown.code, 2);
  EXPECT_NE(unknown.err.find("nosuch"), std::string::npos);
  const Result nodb = run("study list --db absent.db");
  EXPECT_EQ(nodb.code, 2);
  EXPECT_FALSE(fs::exists(dir_ / "absent.db"));
}

// Kill -9 a real `stickslip study run` part-way, check the database, then resume.
TEST_F(StudyCli, SigkillPartWayThenResumeGivesExactlyOneResultPerRun) {
  const fs::path spec = write("kill.json", R"({"name": "kill", "stages": [{"duration": 4}, {"duration": 4}],
    "design": {"type": "grid", "axes": [{"name": "model", "values": ["lugre", "karnopp"]},
                                        {"name": "va_over_vd", "linspace": [0, 3, 20]}]}})");
  const fs::path db = dir_ / "k.db";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    freopen("/dev/null", "w", stderr);
    freopen("/dev/null", "w", stdout);
    execl(kBinary.c_str(), kBinary.c_str(), "study", "run", spec.c_str(), "--db", db.c_str(),
          static_cast<char*>(nullptr));
    _exit(127);
  }
  // Wait until some runs are committed, then kill without warning.
  std::int64_t seen = 0;
  std::string id;
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(20ms);
    if (!fs::exists(db)) continue;
    try {
      Store s = Store::open(db, Store::Mode::kReadOnly);
      const auto studies = s.list_studies(10);
      if (studies.empty()) continue;
      id = studies.front().id;
      seen = s.count_runs(id).done;
      if (seen >= 5) break;
    } catch (const std::exception&) {  // not initialised yet
    }
  }
  ASSERT_GE(seen, 5) << "the study did not commit 5 runs within 60 s";
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  std::int64_t after_kill = 0;
  {
    Store s = Store::open(db, Store::Mode::kReadOnly);
    after_kill = s.count_runs(id).done;
    EXPECT_GE(after_kill, seen);  // every committed run is still there
    EXPECT_LT(after_kill, 40) << "killed too late to test resume";
  }
  const std::string check = "sqlite3 '" + db.string() + "' 'PRAGMA integrity_check;'";
  FILE* p = popen(check.c_str(), "r");
  ASSERT_NE(p, nullptr);
  char buf[64] = {0};
  ASSERT_NE(fgets(buf, sizeof buf, p), nullptr);
  pclose(p);
  EXPECT_EQ(std::string(buf), "ok\n");

  const Result again = run("study run " + spec.string() + " --db k.db --json");
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_NE(again.out.find("\"skipped\": " + std::to_string(after_kill)), std::string::npos)
      << again.out;
  EXPECT_NE(again.out.find("\"computed\": " + std::to_string(40 - after_kill)), std::string::npos)
      << again.out;
  Store s = Store::open(db, Store::Mode::kReadOnly);
  EXPECT_EQ(s.list_studies(10).size(), 1u);  // resumed, not a second study
  const auto runs = s.get_runs(id, -1, 1000);
  ASSERT_EQ(runs.size(), 40u);
  std::set<std::int64_t> idx;
  for (const auto& r : runs) idx.insert(r.design_index);
  EXPECT_EQ(idx.size(), 40u);
  EXPECT_EQ(*idx.begin(), 0);
  EXPECT_EQ(*idx.rbegin(), 39);
}

}  // namespace
