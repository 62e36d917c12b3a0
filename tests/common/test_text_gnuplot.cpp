// common::join and common::run_gnuplot. run_gnuplot is exercised with /bin/sh standing in for
// gnuplot (it too runs `<executable> <script>`), so that the working directory, the log, the exit
// status and the not-found case are checked without depending on gnuplot's own output.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "stickslip/common/gnuplot.h"
#include "stickslip/common/text.h"
#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using stickslip::common::GnuplotCall;
using stickslip::common::join;
using stickslip::common::kGnuplotNotFound;
using stickslip::common::run_gnuplot;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(Join, PutsTheSeparatorBetweenParts) {
  EXPECT_EQ(join({}, "; "), "");
  EXPECT_EQ(join({"a"}, "; "), "a");
  EXPECT_EQ(join({"a", "b", "c"}, "; "), "a; b; c");
  EXPECT_EQ(join({"x", "y"}, " or "), "x or y");
}

TEST(RunGnuplot, RunsTheScriptInItsDirectoryAndLogsStderr) {
  stickslip::testing::TempDir dir("stickslip-gnuplot");
  fs::create_directories(dir / "work dir");
  // A name a shell would interpret: run_gnuplot passes it as one argument, no shell in between.
  std::ofstream(dir / "work dir" / "plot's $x.gp") << "echo out; echo err >&2; pwd > where; exit 3\n";
  GnuplotCall call;
  call.executable = "sh";
  call.script = "plot's $x.gp";
  call.workdir = dir / "work dir";
  call.log = dir / "log";
  EXPECT_EQ(run_gnuplot(call), 3);
  EXPECT_EQ(slurp(dir / "log"), "err\n");  // stdout is not in the log unless asked for
  std::string where = slurp(dir / "work dir" / "where");
  if (!where.empty() && where.back() == '\n') where.pop_back();
  EXPECT_EQ(fs::path(where), fs::canonical(dir / "work dir"));

  call.log_stdout = true;
  EXPECT_EQ(run_gnuplot(call), 3);
  EXPECT_EQ(slurp(dir / "log"), "out\nerr\n");  // truncated, then both streams
}

TEST(RunGnuplot, ReportsAMissingExecutableAndLeavesNoLog) {
  stickslip::testing::TempDir dir("stickslip-gnuplot");
  GnuplotCall call;
  call.executable = "stickslip-no-such-gnuplot";
  call.script = dir / "plots.gp";
  call.log = dir / "gnuplot.log";
  EXPECT_EQ(run_gnuplot(call), kGnuplotNotFound);
  EXPECT_FALSE(fs::exists(dir / "gnuplot.log"));
}

TEST(RunGnuplot, ReportsAWorkdirThatCannotBeEntered) {
  stickslip::testing::TempDir dir("stickslip-gnuplot");
  GnuplotCall call;
  call.executable = "sh";
  call.script = "plots.gp";
  call.workdir = dir / "missing";
  EXPECT_EQ(run_gnuplot(call), 126);
}

}  // namespace
