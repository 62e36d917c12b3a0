// `stickslip indices` and `stickslip report` as real processes: exit codes, table and JSON output,
// invalid indices reported with exit 4, a bad report config rejected with exit 2 and nothing
// written, a report written twice with the second night comparing against the first.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <nlohmann/json.hpp>

#include "support/cli_process.h"

namespace {

namespace fs = std::filesystem;

class ReportCli : public ::testing::Test {
 protected:
  using Result = stickslip::testing::CliSandbox::Result;
  fs::path write(const std::string& name, const std::string& text) { return box_.write(name, text); }
  Result run(const std::string& args) { return box_.run(args); }
  static std::string slurp(const fs::path& p) { return stickslip::testing::slurp(p); }
  stickslip::testing::CliSandbox box_{"stickslip-rcli"};
  const fs::path& dir_ = box_.dir();
};

TEST_F(ReportCli, IndicesTableJsonAndExitCodes) {
  write("ish.json", R"({"name": "ish", "base": {"model": "ishigami"},
                        "design": {"type": "sobol", "n": 512}})");
  ASSERT_EQ(run("study run ish.json --db s.db --quiet").code, 0);
  const Result table = run("indices ish --db s.db");
  ASSERT_EQ(table.code, 0) << table.err;
  EXPECT_NE(table.out.find("sobol design, method sobol, N = 512"), std::string::npos) << table.out;
  // S1 of x3 is 0 exactly; its estimate is slightly negative with an interval covering 0.
  const auto x3 = table.out.find("x3");
  ASSERT_NE(x3, std::string::npos);
  EXPECT_NE(table.out.substr(x3, table.out.find('\n', x3) - x3).find("\u2248 0"), std::string::npos)
      << table.out;
  const Result delta = run("indices ish --db s.db --method delta --resamples 50 --json");
  ASSERT_EQ(delta.code, 0) << delta.err;
  EXPECT_EQ(nlohmann::json::parse(delta.out)["method"], "delta");
  const Result conv = run("indices ish --db s.db --convergence --resamples 50 --json");
  ASSERT_EQ(conv.code, 0) << conv.err;
  const auto steps = nlohmann::json::parse(conv.out)["outputs"][0]["convergence"];
  ASSERT_EQ(steps.size(), 6u);  // N = 16, 32, ..., 512
  EXPECT_EQ(steps.back()["n"], 512);
  EXPECT_EQ(run("indices ish --db s.db --method efast").code, 2);
  const Result js = run("indices ish --db s.db --json --output y");
  ASSERT_EQ(js.code, 0) << js.err;
  const auto j = nlohmann::json::parse(js.out);
  EXPECT_EQ(j["method"], "sobol");
  EXPECT_EQ(j["outputs"][0]["indices"].size(), 3u);
  EXPECT_NEAR(j["outputs"][0]["indices"][1]["S1"].get<double>(), 0.4424, 0.1);
  EXPECT_TRUE(j["outputs"][0]["indices"][0]["ST_ci"].is_array());

  const Result bad_output = run("indices ish --db s.db --output stage2.amplitude");
  EXPECT_EQ(bad_output.code, 2);
  EXPECT_NE(bad_output.err.find("only output is 'y'"), std::string::npos) << bad_output.err;
  EXPECT_EQ(run("indices nosuch --db s.db").code, 2);

  // F_S < F_C at some points: printed as invalid with the failed design indices, exit 4.
  write("fail.json", R"({"name": "fail", "base": {"model": "karnopp"}, "stages": [{"duration": 0.2}],
      "design": {"type": "sobol", "n": 4, "ranges": [{"name": "F_S", "min": 6, "max": 12}]}})");
  ASSERT_EQ(run("study run fail.json --db s.db --quiet").code, 0);
  const Result inv = run("indices fail --db s.db");
  EXPECT_EQ(inv.code, 4) << inv.out << inv.err;
  EXPECT_NE(inv.out.find("INVALID"), std::string::npos) << inv.out;
  EXPECT_NE(inv.out.find(": invalid ("), std::string::npos) << inv.out;
}

TEST_F(ReportCli, ReportBadConfigExitsTwoAndTwoNights) {
  write("bad.json", R"({"name": "r", "studies": [{"id": "x", "kind": "indices", "spec": "nope.json"}],
                        "extra": 1})");
  const Result bad = run("report --config bad.json --out out --db r.db");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("/extra"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
  EXPECT_FALSE(fs::exists(dir_ / "r.db"));

  write("sobol.json", R"({"name": "s", "base": {"model": "sobol_g", "a": [0, 1, 9]},
                          "design": {"type": "sobol", "n": 64}})");
  write("ok.json", R"({"name": "r", "studies": [
      {"id": "g", "kind": "indices", "spec": "sobol.json"},
      {"id": "m", "kind": "map", "spec": {"name": "m", "stages": [{"duration": 1.5}, {"duration": 0.5}],
        "design": {"type": "grid", "axes": [{"name": "model", "values": ["karnopp"]},
                                            {"name": "va_over_vd", "values": [0, 2]}]}}}]})");
  EXPECT_EQ(run("report --config ok.json --out out --db r.db --date 2026-02-30").code, 2);
  const Result first = run("report --config ok.json --out out --db r.db --date 2026-04-01 --quiet");
  ASSERT_EQ(first.code, 0) << first.err;
  const Result second = run("report --config ok.json --out out --db r.db --date 2026-04-02 --quiet");
  ASSERT_EQ(second.code, 0) << second.err;
  EXPECT_NE(second.out.find("0 change(s) flagged since 2026-04-01"), std::string::npos)
      << second.out;
  EXPECT_TRUE(fs::exists(dir_ / "out/2026-04-02/index.html"));
  const auto s = nlohmann::json::parse(slurp(dir_ / "out/2026-04-02/summary.json"));
  EXPECT_EQ(s["entries"]["g"]["run"]["computed"], 0);
  EXPECT_EQ(s["entries"]["g"]["indices"]["valid"], true);
}

}  // namespace
