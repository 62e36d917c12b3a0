// Every sensitivity method END TO END (spec -> runner -> store -> compute_indices) on the analytic
// test functions, the Sobol "until" rule growing a study by itself, and the outputs' status
// (undefined constant outputs, warnings). The estimators' accuracy is tested in test_sa_*.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "stickslip/studies/indices.h"
#include "stickslip/studies/runner.h"
#include "support/study_run.h"
#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
namespace ss = stickslip::studies::sensitivity;
using namespace stickslip;
using namespace stickslip::studies;

struct TempDir : stickslip::testing::TempDir {
  TempDir() : stickslip::testing::TempDir("stickslip-methods") {}
};

using stickslip::testing::parse_ok;
using Ran = stickslip::testing::RanStudy;
const auto run = stickslip::testing::run_to_end;

StudyIndices indices(const fs::path& db, const std::string& id, IndicesOptions opt = {}) {
  store::Store store = store::Store::open(db, store::Store::Mode::kReadOnly);
  return compute_indices(store, id, {}, opt);
}

double value(const OutputIndices& o, const char* name, std::size_t p) {
  return o.indices->find(name)->value[p];
}

const double kS1[] = {0.3139, 0.4424, 0.0}, kST[] = {0.5576, 0.4424, 0.2437};

}  // namespace

// Each design type on Ishigami: its own method recovers the ranking and the values roughly
// (small N, loose tolerances: the point is the plumbing, not the estimator).
TEST(MethodsEndToEnd, EveryDesignOnIshigami) {
  TempDir dir;
  struct Case {
    const char* design;
    const char* method;
    const char* index;
    const double* exact;
    double tol;
  };
  const Case cases[] = {
      {R"({"type": "sobol", "n": 1024, "second_order": true})", "sobol", "ST", kST, 0.05},
      {R"({"type": "efast", "n": 1025, "M": 8, "replicates": 4})", "efast", "ST", kST, 0.03},
      {R"({"type": "rbd_fast", "n": 4000})", "rbd_fast", "S1", kS1, 0.04},
      {R"({"type": "lhs", "n": 4000})", "rbd_fast", "S1", kS1, 0.04},
  };
  for (const Case& c : cases) {
    const StudySpec spec = parse_ok(std::string(R"({"name": "m", "base": {"model": "ishigami"},
        "design": )") + c.design + "}");
    const Ran r = run(dir / "m.db", spec);
    IndicesOptions o;
    o.method = c.method;
    o.resamples = 100;
    const StudyIndices ind = indices(dir / "m.db", r.id, o);
    ASSERT_EQ(ind.method, c.method) << c.design;
    ASSERT_TRUE(ind.outputs[0].valid()) << c.design << ": " << ind.outputs[0].reason;
    for (std::size_t i = 0; i < 3; ++i)
      EXPECT_NEAR(value(ind.outputs[0], c.index, i), c.exact[i], c.tol) << c.design << " x" << i + 1;
  }
}

TEST(MethodsEndToEnd, SecondOrderDeltaPawnAndDgsmThroughTheStore) {
  TempDir dir;
  const Ran s = run(dir / "s.db", parse_ok(R"({"name": "s2", "base": {"model": "ishigami"},
      "design": {"type": "sobol", "n": 2048, "second_order": true}})"));
  const StudyIndices ind = indices(dir / "s.db", s.id);
  ASSERT_EQ(ind.outputs[0].indices->pairs.size(), 3u);
  EXPECT_NEAR(ind.outputs[0].indices->per_pair[0].value[1], 0.2437, 0.03);  // S13
  IndicesOptions o;
  o.method = "delta";
  o.resamples = 50;
  const StudyIndices delta = indices(dir / "s.db", s.id, o);  // on the 4096 A and B rows
  EXPECT_GT(value(delta.outputs[0], "delta", 1), value(delta.outputs[0], "delta", 2));
  o.method = "pawn";
  EXPECT_GT(value(indices(dir / "s.db", s.id, o).outputs[0], "pawn", 0), 0.05);
  const Ran g = run(dir / "g.db", parse_ok(R"({"name": "d", "base": {"model": "ishigami"},
      "design": {"type": "dgsm", "n": 512, "step": 0.001}})"));
  const StudyIndices dg = indices(dir / "g.db", g.id);
  EXPECT_EQ(dg.method, "dgsm");
  for (std::size_t i = 0; i < 3; ++i) EXPECT_GE(value(dg.outputs[0], "dgsm", i), kST[i] - 0.02);
  o.method = "efast";
  EXPECT_THROW(indices(dir / "g.db", g.id, o), std::invalid_argument);
}

// "until": N = 64 to begin with; the runner doubles N until every ST interval is at most 0.12
// wide (or N = 2048). The runs of each round keep their design indices; the study ends
// succeeded by itself with a total that is a power-of-two multiple of 64 base rows.
TEST(SobolUntil, GrowsUntilTheIntervalsAreNarrowAndStops) {
  TempDir dir;
  const StudySpec spec = parse_ok(R"({"name": "until", "base": {"model": "ishigami"},
      "design": {"type": "sobol", "n": 64, "until": {"max_st_width": 0.12, "n_max": 2048,
                 "resamples": 200}}})");
  EXPECT_EQ(spec.run_count(), 64u * 5u);
  EXPECT_EQ(spec.max_run_count(), 2048u * 5u);
  const Ran r = run(dir / "u.db", spec);
  ASSERT_GE(r.summary.until.size(), 2u);
  EXPECT_NE(r.summary.until.back().find("reached"), std::string::npos) << r.summary.until.back();
  store::Store store = store::Store::open(dir / "u.db", store::Store::Mode::kReadOnly);
  const auto study = store.get_study(r.id);
  ASSERT_TRUE(study.has_value());
  EXPECT_EQ(study->state, store::StudyState::kSucceeded);
  const std::size_t n = static_cast<std::size_t>(study->total_runs) / 5;
  std::printf("[until] grew to N = %zu: %s\n", n, r.summary.until.back().c_str());
  EXPECT_EQ(n & (n - 1), 0u);  // a power of two
  EXPECT_GT(n, 64u);
  EXPECT_EQ(r.summary.computed, study->total_runs);  // each run computed once
  const auto u = until_status(store, r.id);
  ASSERT_TRUE(u.has_value());
  EXPECT_LE(u->widest, 0.12);
  EXPECT_FALSE(u->grow);
  // A second run_study changes nothing: the rule is met.
  RunnerOptions opt;
  opt.threads = 1;
  const RunSummary again = run_study(dir / "u.db", r.id, spec, opt);
  EXPECT_EQ(again.computed, 0);
}

TEST(SobolUntil, StopsAtNMaxAndSaysSo) {
  TempDir dir;
  const Ran r = run(dir / "m.db", parse_ok(R"({"name": "cap", "base": {"model": "ishigami"},
      "design": {"type": "sobol", "n": 32, "until": {"max_st_width": 0.01, "n_max": 128}}})"));
  ASSERT_EQ(r.summary.until.size(), 3u);  // 32 -> 64 -> 128, stop
  EXPECT_NE(r.summary.until.back().find("n_max = 128"), std::string::npos) << r.summary.until.back();
  const StudyIndices ind = indices(dir / "m.db", r.id);
  EXPECT_EQ(ind.n, 128u);
  ASSERT_TRUE(ind.until.has_value());
  EXPECT_FALSE(ind.until->grow);
}

// A constant output (stage 1 of a study that varies only the stage-2 vibration) is undefined,
// with the reason, for every method; never zeros.
TEST(OutputStatus, ConstantOutputIsUndefinedWithTheReason) {
  TempDir dir;
  const Ran r = run(dir / "c.db", parse_ok(R"({"name": "const", "base": {"model": "dahl"},
      "stages": [{"duration": 1.2}, {"duration": 0.3}],
      "design": {"type": "sobol", "n": 16, "ranges": [
          {"name": "v_a", "min": 0.0005, "max": 0.004}, {"name": "f", "min": 500, "max": 1500}]}})"));
  for (const char* method : {"sobol", "delta"}) {
    IndicesOptions o;
    o.method = method;
    const StudyIndices ind = indices(dir / "c.db", r.id, o);
    for (const auto& out : ind.outputs) {
      if (out.output.rfind("stage1.amplitude", 0) != 0 && out.output.rfind("stage1.mean_force", 0) != 0)
        continue;
      EXPECT_EQ(out.status, "undefined") << method << " " << out.output;
      EXPECT_NE(out.reason.find("constant"), std::string::npos) << out.reason;
      EXPECT_FALSE(out.indices.has_value());
      const auto j = indices_to_json(ind);
      for (const auto& jo : j["outputs"]) {
        if (jo["output"] == out.output) {
          EXPECT_TRUE(jo["indices"].empty());
        }
      }
    }
  }
}
