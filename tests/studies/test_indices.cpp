// Sensitivity indices END TO END: analytic and friction studies are created, run by the study
// runner (OpenMP, batched SQLite writer), read back from the store and fed to the estimators by
// compute_indices(). The estimators themselves are tested directly in test_sensitivity.cpp (with
// larger coverage experiments); here the point is that nothing is lost, reordered or silently
// dropped between the design, the runner, the store and the indices.
#include "stickslip/studies/indices.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "stickslip/studies/runner.h"
#include "stickslip/studies/sensitivity.h"

#include "support/study_run.h"
#include "support/temp_dir.h"

namespace {

namespace fs = std::filesystem;
namespace ss = stickslip::studies::sensitivity;
using namespace stickslip;
using namespace stickslip::studies;

// A fresh temp directory per test, removed at scope exit.
struct TempDir : stickslip::testing::TempDir {
  TempDir() : stickslip::testing::TempDir("stickslip-indices") {}
};

using stickslip::testing::parse_ok;

// Creates the study and runs it to completion with 2 threads; returns its id.
std::string run(const fs::path& db, const StudySpec& spec) {
  return stickslip::testing::run_to_end(db, spec).id;
}

StudyIndices indices(const fs::path& db, const std::string& id,
                     const std::vector<std::string>& outputs = {}, IndicesOptions opt = {}) {
  store::Store store = store::Store::open(db, store::Store::Mode::kReadOnly);
  return compute_indices(store, id, outputs, opt);
}

// The S1 / ST of a Sobol result, under the names of the exact values' struct.
struct SobolView {
  explicit SobolView(const ss::MethodIndices& m)
      : S1(m.find("S1")->value), ST(m.find("ST")->value), S1_ci(m.find("S1")->ci),
        ST_ci(m.find("ST")->ci) {}
  const std::vector<double>& S1;
  const std::vector<double>& ST;
  const std::vector<ss::Interval>& S1_ci;
  const std::vector<ss::Interval>& ST_ci;
};

bool covers(const ss::Interval& i, double v) { return i.lo <= v && v <= i.hi; }

TEST(IndicesEndToEnd, IshigamiN10000) {
  TempDir dir;
  const StudySpec spec = parse_ok(R"({"name": "ishigami", "base": {"model": "ishigami"},
      "design": {"type": "sobol", "n": 10000, "seed": 3}})");
  ASSERT_EQ(spec.run_count(), 50000u);
  const std::string id = run(dir / "s.db", spec);
  const StudyIndices r = indices(dir / "s.db", id);
  ASSERT_EQ(r.outputs.size(), 1u);
  const OutputIndices& y = r.outputs[0];
  ASSERT_TRUE(y.valid()) << y.reason;
  ASSERT_TRUE(y.indices.has_value());
  const SobolView sv(*y.indices);
  EXPECT_EQ(r.parameters, (std::vector<std::string>{"x1", "x2", "x3"}));
  EXPECT_EQ(r.stored_runs, 50000);
  EXPECT_EQ(r.failed_runs, 0);
  const double s1[] = {0.3139, 0.4424, 0.0}, st[] = {0.5576, 0.4424, 0.2437};
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(sv.S1[i], s1[i], 0.03) << "S1 x" << i + 1;
    EXPECT_NEAR(sv.ST[i], st[i], 0.03) << "ST x" << i + 1;
  }
  // The Ishigami variance is a^2/8 + b pi^4/5 + b^2 pi^8/18 + 1/2 = 13.845 for a = 7, b = 0.1.
  EXPECT_NEAR(y.variance, 13.845, 0.5);
}

TEST(IndicesEndToEnd, SobolGN4096) {
  TempDir dir;
  const StudySpec spec = parse_ok(R"({"name": "g6",
      "base": {"model": "sobol_g", "a": [78, 12, 0.5, 2, 97, 33]},
      "design": {"type": "sobol", "n": 4096, "seed": 11}})");
  ASSERT_EQ(spec.run_count(), 4096u * 8u);
  const std::string id = run(dir / "s.db", spec);
  const StudyIndices r = indices(dir / "s.db", id, {"y"});
  ASSERT_TRUE(r.valid());
  const SobolView s(*r.outputs[0].indices);
  const double s1[] = {0.000276, 0.010195, 0.765743, 0.191436, 0.000179, 0.001490};
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(s.S1[i], s1[i], 0.01) << "S1 x" << i + 1;
  const auto exact = ss::sobol_g_exact({78, 12, 0.5, 2, 97, 33});
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(s.ST[i], exact.ST[i], 0.02) << "ST x" << i + 1;
}

// 20 independent design seeds (and bootstrap seeds), each a full study through runner and store,
// at N = 256 to keep the test short (the direct estimator test in test_sensitivity.cpp does the
// same at N = 2000). Per index, the 95% interval must contain the exact value in >= 18 of 20.
TEST(IndicesEndToEnd, IshigamiCoverage20Seeds) {
  TempDir dir;
  const auto exact = ss::ishigami_exact();
  int s1_hits[3] = {0, 0, 0}, st_hits[3] = {0, 0, 0};
  double widest = 0.0;
  for (int seed = 0; seed < 20; ++seed) {
    const StudySpec spec = parse_ok(R"({"name": "ish-cov", "base": {"model": "ishigami"},
        "design": {"type": "sobol", "n": 256, "seed": )" + std::to_string(100 + seed) + "}}");
    const std::string id = run(dir / "cov.db", spec);
    IndicesOptions opt;
    opt.seed = 7000 + static_cast<std::uint64_t>(seed);
    const StudyIndices r = indices(dir / "cov.db", id, {}, opt);
    ASSERT_TRUE(r.valid());
    const SobolView s(*r.outputs[0].indices);
    for (int i = 0; i < 3; ++i) {
      s1_hits[i] += covers(s.S1_ci[i], exact.S1[i]);
      st_hits[i] += covers(s.ST_ci[i], exact.ST[i]);
      widest = std::max({widest, s.S1_ci[i].hi - s.S1_ci[i].lo, s.ST_ci[i].hi - s.ST_ci[i].lo});
    }
  }
  for (int i = 0; i < 3; ++i) {
    std::cout << "[e2e coverage N=256] x" << i + 1 << ": S1 " << s1_hits[i] << "/20, ST "
              << st_hits[i] << "/20\n";
    EXPECT_GE(s1_hits[i], 18) << "S1 x" << i + 1;
    EXPECT_GE(st_hits[i], 18) << "ST x" << i + 1;
  }
  std::cout << "[e2e coverage N=256] widest interval " << widest << "\n";
  EXPECT_LT(widest, 0.8);  // can fail on degenerate, uninformative intervals
}

// Stage 1 (still base) cannot depend on the stage-2 vibration, so over a Sobol design of stage-2
// v_a and f its amplitude and mean force are exactly constant: their indices are undefined (0/0),
// said with the reason and never reported as zeros; the stage-2 outputs have indices (the
// vibration does matter there).
TEST(IndicesEndToEnd, ConstantOutputIsUndefinedNotZero) {
  TempDir dir;
  const StudySpec spec = parse_ok(R"({"name": "const", "base": {"model": "dahl"},
      "stages": [{"duration": 1.2}, {"duration": 0.3}],
      "design": {"type": "sobol", "n": 8, "ranges": [
          {"name": "v_a", "min": 0.0005, "max": 0.004}, {"name": "f", "min": 500, "max": 1500}]}})");
  const std::string id = run(dir / "c.db", spec);
  const StudyIndices r = indices(dir / "c.db", id, {"stage1.amplitude", "stage1.mean_force",
                                                    "stage2.amplitude", "stage2.mean_force"});
  ASSERT_EQ(r.outputs.size(), 4u);
  for (std::size_t k = 0; k < 2; ++k) {
    const OutputIndices& o = r.outputs[k];
    EXPECT_EQ(o.status, "undefined") << o.output;
    EXPECT_FALSE(o.valid()) << o.output;  // no indices ...
    EXPECT_TRUE(r.complete()) << o.output;  // ... but nothing failed
    EXPECT_EQ(o.variance, 0.0) << o.output;
    EXPECT_FALSE(o.indices.has_value());
    EXPECT_NE(o.reason.find("constant"), std::string::npos) << o.reason;
    EXPECT_NE(o.reason.find("0/0"), std::string::npos) << o.reason;
  }
  const OutputIndices& mean2 = r.outputs[3];
  ASSERT_EQ(mean2.status, "ok") << mean2.reason;
  EXPECT_GT(mean2.variance, 0.0);
  const SobolView s(*mean2.indices);
  EXPECT_GT(std::max(s.ST[0], s.ST[1]), 0.1);
  const auto j = indices_to_json(r);
  EXPECT_EQ(j["outputs"][0]["status"], "undefined");
  EXPECT_TRUE(j["outputs"][0]["indices"].empty());
  EXPECT_EQ(j["heatmap"]["status"][0], "undefined");
  EXPECT_TRUE(j["heatmap"]["value"][0][0].is_null());
}

// F_S in [8, 12] and F_C in [7, 10]: the points with F_S < F_C are invalid runs (the engine
// rejects them). Every output must then be invalid, name the count and list those indices.
TEST(IndicesEndToEnd, FailedRunsMakeIndicesInvalid) {
  TempDir dir;
  const StudySpec spec = parse_ok(R"({"name": "fails", "base": {"model": "karnopp"},
      "stages": [{"duration": 0.3}, {"duration": 0.2}],
      "design": {"type": "sobol", "n": 8, "ranges": [
          {"name": "F_S", "min": 8, "max": 12}, {"name": "F_C", "min": 7, "max": 10}]}})");
  const std::string id = run(dir / "f.db", spec);
  std::set<std::int64_t> failed;
  {
    store::Store store = store::Store::open(dir / "f.db", store::Store::Mode::kReadOnly);
    for (const auto& run : store.get_runs(id, -1, 100000))
      if (run.status != "ok") failed.insert(run.design_index);
  }
  ASSERT_FALSE(failed.empty()) << "the design was meant to contain F_S < F_C points";
  const StudyIndices r = indices(dir / "f.db", id, {"stage2.amplitude", "stage1.mean_force"});
  EXPECT_FALSE(r.valid());
  EXPECT_EQ(r.failed_runs, static_cast<std::int64_t>(failed.size()));
  for (const auto& o : r.outputs) {
    EXPECT_FALSE(o.valid());
    EXPECT_FALSE(o.indices.has_value());
    EXPECT_EQ(o.invalid_count, failed.size());
    EXPECT_NE(o.reason.find(std::to_string(failed.size()) + " failed runs"), std::string::npos)
        << o.reason;
    std::set<std::int64_t> listed;
    for (const auto& p : o.invalid_points) {
      listed.insert(p.design_index);
      EXPECT_EQ(p.status, "invalid");
      EXPECT_NE(p.reason.find("F_S"), std::string::npos) << p.reason;
    }
    EXPECT_EQ(listed, failed);
  }
  const auto j = indices_to_json(r);
  EXPECT_FALSE(j["valid"].get<bool>());
  EXPECT_EQ(j["outputs"][0]["indices"].size(), 0u);
  EXPECT_EQ(j["outputs"][0]["invalid_points"].size(), failed.size());
}

// The same overlapping ranges with "F_S_below_F_C": "raise_F_S_to_F_C": every run succeeds, the
// indices are valid, and the count of raised points is reported. Those runs equal runs made with
// F_S = F_C explicitly.
TEST(IndicesEndToEnd, RaisedStaticFrictionKeepsIndicesValidAndIsCounted) {
  TempDir dir;
  const std::string text = R"({"name": "raised", "base": {"model": "karnopp"},
      "F_S_below_F_C": "raise_F_S_to_F_C",
      "stages": [{"duration": 0.3}, {"duration": 0.2}],
      "design": {"type": "sobol", "n": 8, "ranges": [
          {"name": "F_S", "min": 8, "max": 12}, {"name": "F_C", "min": 7, "max": 10}]}})";
  const StudySpec spec = parse_ok(text);
  const std::string id = run(dir / "r.db", spec);
  std::int64_t expected = 0;
  for (std::size_t i = 0; i < spec.run_count(); ++i) {
    const DesignPoint p = spec.point(i);
    if (*p.value("F_S") < *p.value("F_C")) ++expected;
    EXPECT_EQ(spec.raises_F_S(p), *p.value("F_S") < *p.value("F_C")) << i;
  }
  ASSERT_GT(expected, 0) << "the design was meant to contain F_S < F_C points";
  const StudyIndices r = indices(dir / "r.db", id, {"stage1.mean_force"});
  // No raised run is a failed one. (Within 0.3 s the body still sticks at every point, so the
  // stage-1 mean force is the same everywhere: undefined, not invalid.)
  EXPECT_TRUE(r.complete()) << r.outputs.at(0).reason;
  EXPECT_EQ(r.failed_runs, 0);
  EXPECT_EQ(r.F_S_raised_runs, expected);
  EXPECT_EQ(indices_to_json(r)["F_S_raised_runs"], expected);
  EXPECT_NE(indices_to_table(r).find(std::to_string(expected) + " runs had F_S < F_C"),
            std::string::npos);

  // A raised point's stored result is the run with F_S = F_C set explicitly.
  std::size_t raised = 0;
  while (!spec.raises_F_S(spec.point(raised))) ++raised;
  const double fc = *spec.point(raised).value("F_C");
  nlohmann::json doc = {{"name", "explicit"},
                        {"base", {{"model", "karnopp"}}},
                        {"stages", {{{"duration", 0.3}}, {{"duration", 0.2}}}},
                        {"design", {{"type", "list"}, {"points", {{{"F_S", fc}, {"F_C", fc}}}}}}};
  const StudySpec explicit_spec = parse_ok(doc.dump());
  const store::RunRecord want = compute_run(explicit_spec, 0, "x");
  store::Store store = store::Store::open(dir / "r.db", store::Store::Mode::kReadOnly);
  const auto got = store.get_runs(id, static_cast<std::int64_t>(raised) - 1, 1);
  ASSERT_EQ(got.size(), 1u);
  ASSERT_EQ(got[0].status, "ok") << got[0].error;
  ASSERT_EQ(got[0].stages.size(), want.stages.size());
  for (std::size_t k = 0; k < want.stages.size(); ++k) {
    EXPECT_EQ(got[0].stages[k].mean_force, want.stages[k].mean_force) << k;
    EXPECT_EQ(got[0].stages[k].amplitude, want.stages[k].amplitude) << k;
  }
}

TEST(IndicesEndToEnd, MissingRunsMakeIndicesInvalid) {
  TempDir dir;
  const StudySpec spec = parse_ok(R"({"name": "half", "base": {"model": "ishigami"},
      "design": {"type": "sobol", "n": 16}})");
  std::string id;
  {
    store::Store store = store::Store::open(dir / "m.db");
    id = create_or_find_study(store, spec).id;
    store::RunWriter w = store::RunWriter::open(dir / "m.db");
    for (std::size_t i = 0; i < spec.run_count(); i += 2) w.add(compute_run(spec, i, id));
    w.flush();
  }
  IndicesOptions opt;
  opt.max_listed = 5;
  const StudyIndices r = indices(dir / "m.db", id, {}, opt);
  ASSERT_FALSE(r.valid());
  const auto& o = r.outputs[0];
  EXPECT_EQ(o.invalid_count, spec.run_count() / 2);
  ASSERT_EQ(o.invalid_points.size(), 5u);
  EXPECT_EQ(o.invalid_points[0].design_index, 1);
  EXPECT_EQ(o.invalid_points[0].status, "missing");
  EXPECT_NE(o.reason.find("40 missing runs"), std::string::npos) << o.reason;
  EXPECT_NE(indices_to_table(r).find("and 35 more"), std::string::npos);
}

// The reduction ratio is undefined when stage 1 has no stick-slip: those points are listed as
// "ok" runs with a non-finite output, never dropped.
TEST(IndicesEndToEnd, UndefinedRatioIsReportedPerPoint) {
  TempDir dir;
  // Dahl has no static friction peak: no stick-slip in stage 1, amplitude 0 -> ratio undefined.
  const StudySpec spec = parse_ok(R"({"name": "ratio", "base": {"model": "dahl"},
      "stages": [{"duration": 1.0}, {"duration": 0.2}],
      "design": {"type": "sobol", "n": 2, "ranges": [{"name": "v_a", "min": 0.001, "max": 0.002}]}})");
  const std::string id = run(dir / "r.db", spec);
  const StudyIndices r = indices(dir / "r.db", id, {"reduction_ratio", "stage1.amplitude"});
  ASSERT_EQ(r.outputs[1].status, "undefined") << r.outputs[1].reason;  // 0 everywhere
  ASSERT_EQ(r.outputs[1].mean, 0.0) << "premise: Dahl shows no stick-slip in stage 1";
  EXPECT_FALSE(r.outputs[0].valid());
  EXPECT_EQ(r.outputs[0].invalid_count, spec.run_count());
  EXPECT_EQ(r.outputs[0].invalid_points[0].status, "ok");
  EXPECT_NE(r.outputs[0].invalid_points[0].reason.find("stage 1 has no stick-slip"),
            std::string::npos);
}

// A Morris study through the runner gives exactly what the estimator gives on the same design.
TEST(IndicesEndToEnd, MorrisMatchesDirectEstimator) {
  TempDir dir;
  const StudySpec spec = parse_ok(R"({"name": "ish-morris", "base": {"model": "ishigami"},
      "design": {"type": "morris", "trajectories": 40, "levels": 4, "seed": 5}})");
  const std::string id = run(dir / "m.db", spec);
  const StudyIndices r = indices(dir / "m.db", id);
  ASSERT_TRUE(r.valid());
  EXPECT_EQ(r.method, "morris");
  const auto x = ss::morris_design(40, 3, 4, 5);
  std::vector<double> y;
  for (const auto& row : x) {
    std::vector<double> in(3);
    for (int i = 0; i < 3; ++i) in[i] = -M_PI + 2 * M_PI * row[i];
    y.push_back(ss::ishigami(in));
  }
  const auto direct = ss::morris_indices(x, y, 40, 3);
  const auto& mi = *r.outputs[0].indices;
  struct {
    const std::vector<double>& mu_star;
    const std::vector<double>& sigma;
  } m{mi.find("mu_star")->value, mi.find("sigma")->value};
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(m.mu_star[i], direct.mu_star[i], 1e-9 * (1 + direct.mu_star[i]));
    EXPECT_NEAR(m.sigma[i], direct.sigma[i], 1e-9 * (1 + direct.sigma[i]));
  }
  // x2 enters only through a sin^2 term of weight 7: the largest mu* of the three.
  EXPECT_GT(m.mu_star[1], m.mu_star[2]);
  const auto j = indices_to_json(r);
  EXPECT_EQ(j["outputs"][0]["indices"][1]["parameter"], "x2");
  EXPECT_TRUE(j["outputs"][0]["indices"][1].contains("mu_star_ci"));
}

TEST(IndicesEndToEnd, BadRequestsNameTheProblem) {
  TempDir dir;
  const StudySpec grid = parse_ok(R"({"name": "grid", "stages": [{"duration": 0.1}],
      "design": {"type": "grid", "axes": [{"name": "m", "values": [0.5]}]}})");
  const StudySpec ish = parse_ok(R"({"name": "ish", "base": {"model": "ishigami"},
      "design": {"type": "sobol", "n": 4}})");
  store::Store store = store::Store::open(dir / "b.db");
  const std::string gid = create_or_find_study(store, grid).id;
  const std::string iid = create_or_find_study(store, ish).id;
  auto message = [&](const std::string& id, std::vector<std::string> outs) -> std::string {
    try {
      compute_indices(store, id, outs);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message(gid, {}).find("'grid' design"), std::string::npos);
  EXPECT_NE(message(iid, {"stage2.amplitude"}).find("only output is 'y'"), std::string::npos);
  EXPECT_THROW(compute_indices(store, "st-nope"), store::StoreError);
  IndicesOptions bad;
  bad.confidence = 1.5;
  EXPECT_THROW(compute_indices(store, iid, {}, bad), std::invalid_argument);
  IndicesOptions efast;
  efast.method = "efast";
  try {
    compute_indices(store, iid, {}, efast);
    ADD_FAILURE() << "a sobol study accepted method efast";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("does not apply"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'delta'"), std::string::npos) << e.what();
  }
  IndicesOptions unknown;
  unknown.method = "fast99";
  EXPECT_THROW(compute_indices(store, iid, {}, unknown), std::invalid_argument);
}

}  // namespace
