// Synthetic measured data and the diagnosis.
//
// Synth: round trip through load_measured and the noise model's statistics.
// Hidden-effect suite (issue 5; cases in diagnosis/src/diagnose_suite.cpp): every catalogue
// effect hidden in LuGre data at a moderate size must be named as the cause, with a positive
// held-out gain and its size parameter recovered within the case's tolerance (30-40 %); clean
// data (white and AR(1) noise, base parameters 5-10 % off Table 1) must give "none" with an
// adequate base; an effect too small to see must not be named as a wrong cause. Default CI: the
// short datasets, one seed, every catalogue effect against its own candidate and the white null
// against viscous and waviness (HiddenCase::ci_candidates). STICKSLIP_DIAG_LONG=1: every case (clean_ar1 and the
// small effects too) against the whole catalogue on 2 seeds; STICKSLIP_DIAGNOSE_SUITE=full: the
// full datasets (3 runs x 7 s at 2 kHz, every base model), 3 seeds per case. The randomised
// suite: test_diagnose_random.cpp; bench/diagnose_suite prints the confusion tables.
#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/diagnosis/diagnose_suite.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <string>

#include "stickslip/measured/measured.h"
#include "stickslip/measured/synth.h"
#include "long_tests.h"
#include "support/temp_dir.h"

using namespace stickslip;
using namespace stickslip::diagnosis;

namespace {

measured::MeasuredConditions short_conditions(double va) {
  measured::MeasuredConditions c;
  c.va = va;
  c.t_on = 4.0;
  c.duration = 6.0;
  return c;
}

measured::SynthOptions short_dataset(std::uint64_t seed) {
  measured::SynthOptions o;
  o.model = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  o.runs = {short_conditions(0.0), short_conditions(4e-3)};
  o.noise_sigma = 0.03;
  o.seed = seed;
  o.rtol = 1e-8;
  return o;
}


}  // namespace

TEST(HiddenCases, LookupByNameFindsTheCaseAndNamesAnUnknownOne) {
  EXPECT_EQ(hidden_case("dwell_time").kind, engine::ExtensionKind::kDwellTime);
  EXPECT_EQ(hidden_case("small_viscous").value, 1.0);
  try {
    hidden_case("dwel_time");
    ADD_FAILURE() << "no error for an unknown case";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("\"dwel_time\""), std::string::npos) << e.what();
  }
}

TEST(Synth, WritesADatasetThatLoadsBack) {
  stickslip::testing::TempDir dir;
  measured::SynthOptions o = short_dataset(3);
  o.offset = 0.25;
  o.model.extension.kind = engine::ExtensionKind::kDrift;
  o.model.extension.drift_gamma = 5.0;
  const measured::MeasuredDataset d = measured::synthesize(o);
  const auto manifest = measured::write_dataset(d, dir.path());
  const measured::MeasuredDataset back = measured::load_measured(manifest);
  ASSERT_EQ(back.runs.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(back.runs[k].t.size(), d.runs[k].t.size());
    EXPECT_NEAR(back.runs[k].t.back(), 6.0, 1e-9);
    EXPECT_DOUBLE_EQ(back.runs[k].conditions.va, o.runs[k].va);
    EXPECT_DOUBLE_EQ(back.runs[k].conditions.t_on, 4.0);
    EXPECT_NEAR(back.runs[k].Fd[100], d.runs[k].Fd[100], 1e-6);
  }
}

// The noise has the requested standard deviation and lag-1 correlation, reproducibly per seed.
TEST(Synth, NoiseIsWhiteOrAr1WithTheRequestedStatistics) {
  measured::SynthOptions o = short_dataset(11);
  o.runs = {short_conditions(0.0)};
  o.noise_sigma = 0.0;
  const measured::MeasuredDataset clean = measured::synthesize(o);
  for (double rho : {0.0, 0.8}) {
    o.noise_sigma = 0.05;
    o.noise_rho = rho;
    const measured::MeasuredDataset noisy = measured::synthesize(o);
    const auto& a = clean.runs[0].Fd;
    const auto& b = noisy.runs[0].Fd;
    double s2 = 0, c1 = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      s2 += (b[i] - a[i]) * (b[i] - a[i]);
      if (i) c1 += (b[i] - a[i]) * (b[i - 1] - a[i - 1]);
    }
    const double sd = std::sqrt(s2 / a.size()), r1 = c1 / s2;
    EXPECT_NEAR(sd, 0.05, 0.05 * 0.08) << rho;  // 12000 samples; 8 % covers AR(1) spread
    EXPECT_NEAR(r1, rho, 0.05) << rho;
    EXPECT_EQ(measured::synthesize(o).runs[0].Fd, b);  // same seed, same data
  }
  o.noise_rho = 1.0;
  EXPECT_THROW(measured::synthesize(o), std::invalid_argument);
}

// ---- hidden-effect suite ----------------------------------------------------------------------

namespace {

bool full_suite() {
  const char* env = std::getenv("STICKSLIP_DIAGNOSE_SUITE");
  return env && std::string(env) == "full";
}

void run_case(const HiddenCase& c) {
  const bool full = full_suite(), long_run = stickslip::testing::long_diagnosis_tests();
  if (!c.in_ci && !long_run)
    GTEST_SKIP() << c.name << " runs with the long suite: set STICKSLIP_DIAG_LONG=1";
  const int seeds = full ? 3 : long_run ? 2 : 1;
  for (int s = 0; s < seeds; ++s) {
    const SuiteDatasets family = full ? SuiteDatasets::kFull : SuiteDatasets::kCi;
    // The whole-run folds are reported, not judged (tested in test_diagnose_report.cpp):
    // left out here for CI time. Default CI: the case against ci_candidates only.
    DiagnoseOptions o = hidden_case_options(family);
    o.whole_run_holdout = false;
    if (!long_run) o.candidates = c.ci_candidates;
    const Diagnosis d = diagnose(measured::synthesize(hidden_case_dataset(c, 1000 + s, family)), o);
    const HiddenVerdict v = judge(c, d);
    EXPECT_TRUE(v.cause_ok) << c.name << " seed " << s << ": named " << d.cause << "\n"
                            << summary_text(d);
    EXPECT_TRUE(v.gain_ok) << c.name << " seed " << s << ": gain " << d.gain;
    EXPECT_TRUE(v.param_ok) << c.name << " seed " << s << ": "
                            << (c.judged.empty() ? c.param : c.judged) << " = " << v.recovered
                            << ", hidden " << v.truth << " (tolerance " << c.rel_tol * 100 << " %)";
    if (c.kind == engine::ExtensionKind::kNone && s == 0) {
      // The base is recovered, every parameter is accounted for, the verdict is adequate and
      // the JSON has every field issues 5 and 21 ask for.
      EXPECT_EQ(d.base_model, engine::model_kind<engine::LuGre>);
      EXPECT_EQ(d.adequacy.verdict, "adequate");
      ASSERT_GE(d.base_params.size(), 2u);
      EXPECT_NEAR(d.base_params[0].value, 11.1 * 1.06, 0.02 * 11.1 * 1.06);
      EXPECT_NEAR(d.base_params[1].value, 8.3 * 0.95, 0.02 * 8.3 * 0.95);
      const auto j = to_json(d);
      for (const char* f : {"base_model", "base_params", "cause", "rmse_base_heldout",
                            "rmse_extended_heldout", "gain", "candidates", "evidence",
                            "calibrations", "verdict", "adequacy", "readings", "statistics", "models"})
        EXPECT_TRUE(j.contains(f)) << f;
      EXPECT_EQ(j["candidates"].size(), o.candidates.size());
    }
  }
}

}  // namespace

// Cancellation (the server's worker sets stop_requested when a running diagnosis is cancelled or
// the server shuts down): once the callback says stop, the evaluations fail at once and the
// diagnosis throws DiagnosisCancelled instead of returning a result.
TEST(Diagnose, StopRequestedEndsTheDiagnosisWithDiagnosisCancelled) {
  const measured::MeasuredDataset data = measured::synthesize(short_dataset(11));
  DiagnoseOptions o;
  o.models = {engine::model_kind<engine::LuGre>};
  o.candidates = {engine::ExtensionKind::kViscous, engine::ExtensionKind::kDrift};
  o.max_evals_base = 20;
  o.max_evals_candidate = 20;
  o.whole_run_holdout = false;
  o.keep_traces = false;

  // Never stopped: it polls before every evaluation and finishes; the result keeps no callback.
  std::atomic<int> polls{0};
  o.stop_requested = [&] {
    ++polls;
    return false;
  };
  const Diagnosis full = diagnose(data, o);
  EXPECT_GE(polls.load(), full.evaluations);
  EXPECT_FALSE(full.options.stop_requested);

  // Stopped during the base calibration, and again during the candidates.
  for (const int stop_after : {5, full.evaluations / 2}) {
    std::atomic<int> n{0};
    o.stop_requested = [&] { return ++n > stop_after; };
    EXPECT_THROW(diagnose(data, o), DiagnosisCancelled) << "stop after " << stop_after;
    EXPECT_GT(n.load(), stop_after);
  }
}

class HiddenEffect : public ::testing::TestWithParam<HiddenCase> {};

TEST_P(HiddenEffect, NamesTheRightCause) { run_case(GetParam()); }

INSTANTIATE_TEST_SUITE_P(
    Suite, HiddenEffect, ::testing::ValuesIn(hidden_effect_cases()),
    [](const ::testing::TestParamInfo<HiddenCase>& i) { return i.param.name; });
