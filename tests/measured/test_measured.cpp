// Tests of measured-data loading: a good dataset loads with defaults applied; every kind of bad
// file is reported with the file, the line and the problem; manifest schema errors carry JSON
// pointers; condition matching and the RMSE of eq. 23.
#include "stickslip/measured/measured.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>

#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
using namespace stickslip;
using namespace stickslip::measured;

class Measured : public ::testing::Test {
 protected:
  void write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name, std::ios::binary) << text;
  }
  static std::string good_csv(std::size_t n = 50) {
    std::string s = "t,Fd,x\n";
    for (std::size_t i = 0; i < n; ++i)
      s += std::to_string(0.01 * i) + "," + std::to_string(8.0 + 0.1 * i) + ",0\n";
    return s;
  }
  void manifest(const std::string& runs) {
    write("m.json", R"({"name": "stand", "runs": )" + runs + "}");
  }
  // The single error of loading m.json (fails the test if it loads or has several errors).
  std::string only_error() {
    try {
      load_measured(dir_ / "m.json");
    } catch (const MeasuredError& e) {
      EXPECT_EQ(e.errors().size(), 1u) << e.what();
      return e.errors().front().pointer + " | " + e.errors().front().message;
    }
    ADD_FAILURE() << "expected a MeasuredError";
    return "";
  }
  stickslip::testing::TempDir tmp_{"stickslip-measured"};
  const fs::path& dir_ = tmp_.path();
};

TEST_F(Measured, GoodDatasetLoadsWithDefaultsAndUnevenSampling) {
  write("a.csv", "Fd,t\n8.0,0\n8.5,0.001\n" + std::string("9.0,0.0015\n") + [] {
    std::string s;
    for (int i = 0; i < 30; ++i) s += "9.1," + std::to_string(0.01 + 0.01 * i) + "\n";
    return s;
  }());
  manifest(R"([{"name": "va0.2", "file": "a.csv", "conditions": {"va": 0.0002, "t_on": 5}}])");
  const MeasuredDataset ds = load_measured(dir_ / "m.json");
  EXPECT_EQ(ds.name, "stand");
  ASSERT_EQ(ds.runs.size(), 1u);
  const MeasuredRun& r = ds.runs[0];
  EXPECT_EQ(r.t.size(), 33u);
  EXPECT_DOUBLE_EQ(r.t[2], 0.0015);
  EXPECT_DOUBLE_EQ(r.Fd[1], 8.5);  // columns found by name, not position
  EXPECT_DOUBLE_EQ(r.conditions.va, 0.0002);
  EXPECT_DOUBLE_EQ(r.conditions.t_on, 5.0);
  EXPECT_DOUBLE_EQ(r.conditions.m, 0.665);     // seed default
  EXPECT_DOUBLE_EQ(r.conditions.Fz, 29.4);     // seed default
  EXPECT_DOUBLE_EQ(r.conditions.duration, 20.0);
  // The loader says which it took from the seed, with their values and units.
  EXPECT_EQ(r.conditions.defaulted,
            (std::vector<std::string>{"m", "kd", "vd", "Fz", "f", "duration"}));
  EXPECT_EQ(defaulted_text(r.conditions),
            "m = 0.665 kg, kd = 11700 N/m, vd = 0.001 m/s, Fz = 29.4 N, f = 1500 Hz, duration = 20 s");
}

// The external normal load is an optional condition (>= 0; 0 for a slider loaded by its weight
// alone), applied to the drive (F_N = F_z + m g) and part of matching; a negative one is a schema
// error naming it.
TEST_F(Measured, NormalLoadConditionIsOptionalAndApplied) {
  write("a.csv", good_csv());
  manifest(R"([{"name": "r", "file": "a.csv", "conditions": {"Fz": 0, "m": 0.0307}}])");
  const MeasuredDataset ds = load_measured(dir_ / "m.json");
  EXPECT_DOUBLE_EQ(ds.runs[0].conditions.Fz, 0.0);
  EXPECT_EQ(std::count(ds.runs[0].conditions.defaulted.begin(), ds.runs[0].conditions.defaulted.end(), "Fz"), 0);
  engine::SimConfig cfg;
  apply_conditions(ds.runs[0].conditions, cfg);
  EXPECT_DOUBLE_EQ(cfg.drive.F_z, 0.0);
  EXPECT_NEAR(cfg.drive.normal_load(), 0.0307 * 9.81, 1e-15);
  EXPECT_TRUE(matches_conditions(cfg, ds.runs[0].conditions));
  cfg.drive.F_z = 29.4;
  EXPECT_FALSE(matches_conditions(cfg, ds.runs[0].conditions));
  manifest(R"([{"name": "r", "file": "a.csv", "conditions": {"Fz": -1}}])");
  const std::string e = only_error();
  EXPECT_NE(e.find("/runs/0/conditions/Fz"), std::string::npos) << e;
}

TEST_F(Measured, MissingFileNamesIt) {
  manifest(R"([{"name": "r", "file": "nope.csv"}])");
  const std::string e = only_error();
  EXPECT_NE(e.find("/runs/0/file"), std::string::npos) << e;
  EXPECT_NE(e.find("nope.csv"), std::string::npos) << e;
}

TEST_F(Measured, MissingColumnNamesTheColumnAndTheHeader) {
  write("a.csv", "time,Fd\n0,1\n");
  manifest(R"([{"name": "r", "file": "a.csv"}])");
  const std::string e = only_error();
  EXPECT_NE(e.find("a.csv:1: missing column 't'"), std::string::npos) << e;
  EXPECT_NE(e.find("time, Fd"), std::string::npos) << e;
}

TEST_F(Measured, NonNumericCellNamesLineAndColumn) {
  std::string csv = good_csv();
  csv.replace(csv.find("\n0.030000,") + 1, 8, "0.03abc");
  write("a.csv", csv);
  manifest(R"([{"name": "r", "file": "a.csv"}])");
  const std::string e = only_error();
  EXPECT_NE(e.find("a.csv:5: column 't': '0.03abc"), std::string::npos) << e;
  EXPECT_NE(e.find("not a number"), std::string::npos) << e;
}

TEST_F(Measured, NonIncreasingTimeIsReported) {
  std::string csv = good_csv();
  csv += "0.2,8\n";  // goes back in time
  write("a.csv", csv);
  manifest(R"([{"name": "r", "file": "a.csv"}])");
  const std::string e = only_error();
  EXPECT_NE(e.find("a.csv:52: t = 0.2"), std::string::npos) << e;
  EXPECT_NE(e.find("does not increase"), std::string::npos) << e;
}

TEST_F(Measured, NanAndInfAreReported) {
  std::string csv = good_csv();
  csv += "10,nan\n";
  write("a.csv", csv);
  manifest(R"([{"name": "r", "file": "a.csv"}])");
  const std::string e = only_error();
  EXPECT_NE(e.find("a.csv:52: column 'Fd': nan is not finite"), std::string::npos) << e;
}

TEST_F(Measured, TooFewSamplesIsReported) {
  write("a.csv", good_csv(5));
  manifest(R"([{"name": "r", "file": "a.csv"}])");
  const std::string e = only_error();
  EXPECT_NE(e.find("5 samples, need at least 20"), std::string::npos) << e;
}

TEST_F(Measured, ManifestSchemaErrorsCarryPointersAndAllAreReported) {
  write("a.csv", good_csv());
  manifest(R"([{"name": "r", "file": "a.csv", "conditions": {"m": -1, "speed": 3}},
               {"file": "a.csv"}])");
  try {
    load_measured(dir_ / "m.json");
    FAIL() << "expected a MeasuredError";
  } catch (const MeasuredError& e) {
    std::string all;
    for (const auto& err : e.errors()) all += err.pointer + " | " + err.message + "\n";
    EXPECT_NE(all.find("/runs/0/conditions/m"), std::string::npos) << all;
    EXPECT_NE(all.find("speed"), std::string::npos) << all;
    EXPECT_NE(all.find("/runs/1"), std::string::npos) << all;
    EXPECT_GE(e.errors().size(), 3u) << all;
  }
  write("m.json", "{\"name\": ");
  const std::string e = only_error();
  EXPECT_NE(e.find("malformed JSON"), std::string::npos) << e;
  write("m.json", std::string(200000, '['));  // would overflow the parser's recursion
  const std::string deep = only_error();
  EXPECT_NE(deep.find("nested more than 64 levels"), std::string::npos) << deep;
}

TEST(MeasuredConditionsTest, ApplyAndMatchFollowTheBaseMotion) {
  MeasuredConditions c;
  c.va = 0.4e-3;
  c.t_on = 3.0;
  c.duration = 8.0;
  c.kd = 20000;
  engine::SimConfig cfg;
  apply_conditions(c, cfg);
  ASSERT_EQ(cfg.stages.size(), 2u);
  EXPECT_DOUBLE_EQ(cfg.stages[0].duration, 3.0);
  EXPECT_DOUBLE_EQ(cfg.stages[0].v_a, 0.0);
  EXPECT_DOUBLE_EQ(cfg.stages[1].duration, 5.0);
  EXPECT_DOUBLE_EQ(cfg.stages[1].v_a, 0.4e-3);
  EXPECT_DOUBLE_EQ(cfg.drive.k_d, 20000);
  EXPECT_TRUE(matches_conditions(cfg, c));
  // Splitting a stage in two does not change the base motion.
  engine::SimConfig split = cfg;
  split.stages = {engine::Stage{1.0, 0, 1500}, engine::Stage{2.0, 0, 900}, engine::Stage{5.0, 0.4e-3, 1500}};
  EXPECT_TRUE(matches_conditions(split, c));
  engine::SimConfig other = cfg;
  other.stages[1].v_a = 0.5e-3;
  EXPECT_FALSE(matches_conditions(other, c));
  other = cfg;
  other.drive.m = 0.7;
  EXPECT_FALSE(matches_conditions(other, c));
  other = cfg;
  other.stages[0].duration = 4.0;
  EXPECT_FALSE(matches_conditions(other, c));
}

TEST(MeasuredRmse, IsTheRootMeanSquareOverTheWindowWithLinearInterpolation) {
  const std::vector<double> ts = {0, 1, 2, 3}, fs = {0, 10, 20, 30};  // F = 10 t
  const std::vector<double> t = {0.5, 1.5, 2.5, 3.5}, fd = {6, 15, 24, 35};
  // errors: 1, 0, -1, 35 - 30 (held at the last value) = 5
  EXPECT_NEAR(rmse_window(t, fd, ts, fs, 0, 3), std::sqrt(2.0 / 3.0), 1e-12);
  EXPECT_NEAR(rmse_window(t, fd, ts, fs, 1, 2), 0.0, 1e-12);
  EXPECT_NEAR(rmse_window(t, fd, ts, fs, 0, 10), std::sqrt(27.0 / 4.0), 1e-12);
  EXPECT_TRUE(std::isnan(rmse_window(t, fd, ts, fs, 5, 6)));
}

}  // namespace

// --- the same dataset held in memory (the server's POST /v1/diagnoses) ---

namespace {

/// Every error of loading {"manifest": m, "files": files} from memory as "pointer | message".
std::vector<std::string> memory_errors(const std::string& manifest,
                                       const std::map<std::string, std::string>& files) {
  try {
    load_measured(nlohmann::json::parse(manifest), files);
  } catch (const MeasuredError& e) {
    std::vector<std::string> out;
    for (const auto& err : e.errors()) out.push_back(err.pointer + " | " + err.message);
    return out;
  }
  return {};
}

}  // namespace

TEST_F(Measured, InMemoryDatasetLoadsLikeTheSameFiles) {
  const std::string csv = good_csv(40);
  write("a.csv", csv);
  const std::string m =
      R"({"name": "stand", "runs": [{"name": "r", "file": "a.csv", "conditions": {"va": 0.002}}]})";
  write("m.json", m);
  const MeasuredDataset from_file = load_measured(dir_ / "m.json");
  const MeasuredDataset from_memory = load_measured(nlohmann::json::parse(m), {{"a.csv", csv}});
  ASSERT_EQ(from_memory.runs.size(), 1u);
  EXPECT_EQ(from_memory.name, "stand");
  EXPECT_EQ(from_memory.runs[0].t, from_file.runs[0].t);
  EXPECT_EQ(from_memory.runs[0].Fd, from_file.runs[0].Fd);
  EXPECT_DOUBLE_EQ(from_memory.runs[0].conditions.va, 0.002);
  EXPECT_TRUE(from_memory.manifest.empty());
}

TEST_F(Measured, InMemoryCsvProblemsGiveTheFileLoadersMessagesAtTheFilesPointer) {
  std::string bad_cell = good_csv();
  bad_cell.replace(bad_cell.find("\n0.030000,") + 1, 8, "0.03abc");
  const std::vector<std::string> cases = {"time,Fd\n0,1\n", bad_cell, good_csv() + "0.2,8\n",
                                          good_csv() + "10,nan\n", good_csv(5)};
  const std::string m = R"({"name": "stand", "runs": [{"name": "r", "file": "a.csv"}]})";
  for (const auto& csv : cases) {
    write("a.csv", csv);
    manifest(R"([{"name": "r", "file": "a.csv"}])");
    const std::string from_file = only_error();
    const auto errors = memory_errors(m, {{"a.csv", csv}});
    ASSERT_EQ(errors.size(), 1u) << csv.substr(0, 40);
    // File: "/runs/0/file | /tmp/.../a.csv:5: problem"; memory: "/files/a.csv | a.csv:5: problem".
    const std::string problem = from_file.substr(from_file.find("a.csv"));
    EXPECT_EQ(errors[0], "/files/a.csv | " + problem);
  }
}

TEST_F(Measured, InMemoryMissingPathLikeAndUnusedFilesAndSchemaErrorsArePointed) {
  const std::string csv = good_csv();
  // A run's file with no content.
  auto e = memory_errors(R"({"name": "s", "runs": [{"name": "r", "file": "b.csv"}]})",
                         {{"b.csv.txt", csv}});
  ASSERT_EQ(e.size(), 2u);
  EXPECT_NE(e[0].find("/manifest/runs/0/file | no content for file 'b.csv'"), std::string::npos)
      << e[0];
  EXPECT_NE(e[1].find("/files/b.csv.txt | file 'b.csv.txt' is not named by any run"),
            std::string::npos)
      << e[1];
  // Path-like names, in the manifest and in files: nothing is read from disk.
  write("a.csv", csv);
  e = memory_errors(R"({"name": "s", "runs": [{"name": "r", "file": ")" + (dir_ / "a.csv").string() +
                        R"("}]})",
                    {{"../a.csv", csv}});
  ASSERT_EQ(e.size(), 2u);
  EXPECT_NE(e[0].find("/files/..~1a.csv | '../a.csv' is not a plain file name"), std::string::npos)
      << e[0];
  EXPECT_NE(e[1].find("/manifest/runs/0/file | '" + (dir_ / "a.csv").string() +
                      "' is not a plain file name"),
            std::string::npos)
      << e[1];
  // Schema errors point under /manifest.
  e = memory_errors(R"({"name": "s", "runs": [{"name": "r", "file": "a.csv",
                        "conditions": {"m": -1}}]})",
                    {{"a.csv", csv}});
  ASSERT_EQ(e.size(), 1u);
  EXPECT_TRUE(e[0].starts_with("/manifest/runs/0/conditions/m | ")) << e[0];
}
