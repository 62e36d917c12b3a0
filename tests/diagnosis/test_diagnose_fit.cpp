// The diagnosis' Levenberg-Marquardt (diagnosis/src/diagnose_fit.cpp) on the seed's long runs.
// Over a 10 s still stage (about 30 slips) the slip timing makes both objectives narrow curved
// valleys: a forward-difference Jacobian over a step wider than the valley is a biased secant,
// every Gauss-Newton step comes out short, and the search crawls along the valley instead of
// failing, so a step refined only on failure was never refined. At the seed's conditions that
// left the base calibration at 0.20 N fit RMS for noise of 0.03 N, and a too-small hidden
// effect (viscous sigma2 = 1 N s/m) was then named stribeck_shape, whose extra evaluations had
// gone further down the same valley (docs/diagnose.md "Status on main (session 8)").
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/diagnosis/diagnose_suite.h"
#include "stickslip/measured/synth.h"

using namespace stickslip;
using namespace stickslip::diagnosis;

namespace {

double fit_rms(const detail::Problem& p, const detail::FitModel& m, const std::vector<double>& th) {
  const detail::Evaluation e = detail::evaluate(p, m, th, detail::Span::kFit, 0);
  EXPECT_TRUE(e.ok) << e.reason;
  return std::sqrt(e.sse_fit / static_cast<double>(e.n_fit));
}

}  // namespace

// The seed's three runs (3 x 20 s, t_on = 10 s, v_a = 0, 1.1 and 4 mm/s), LuGre 5-10 % off
// Table 1 with a viscous term too small to matter (sigma2 = 1 N s/m), white noise 0.03 N. The
// LuGre base is fitted as the diagnosis calibrates it (diagnose.cpp, calibrate): the cycle
// features from the data-driven start, then the time domain from there, with the default
// budget (70 evaluations: 28 on the features, which crawl here and stop at fit RMS 0.34 N, then
// 42 in the time domain). The time domain must reach the valley floor: within 3 % of the true
// model's fit RMS. Before the crawl detection: 0.201 N (truth 0.0300 N); with it 0.0302 N.
TEST(DiagnoseFit, BaseCalibrationReachesTheValleyFloorOnTheSeedsLongRuns) {
  const measured::SynthOptions so = hidden_case_dataset(hidden_case("small_viscous"), 1000, SuiteDatasets::kSeed);
  const detail::Problem p = detail::make_problem(measured::synthesize(so), hidden_case_options(SuiteDatasets::kSeed));
  ASSERT_EQ(p.runs.size(), 3u);

  // The true model: LuGre with the hidden viscous term.
  detail::FitModel truth;
  truth.base = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  truth.base.extension.kind = engine::ExtensionKind::kViscous;
  truth.specs = detail::base_specs(engine::model_kind<engine::LuGre>, 8.3, 11.1);
  const auto ext = detail::extension_specs(engine::ExtensionKind::kViscous);
  truth.specs.insert(truth.specs.end(), ext.begin(), ext.end());
  const engine::FrictionParams& f = so.model.friction;
  const std::vector<double> th_true = {f["F_S"], f["F_C"] / f["F_S"], f["v_s"], 1.0};
  const double rms_true = fit_rms(p, truth, th_true);

  // The data-driven start diagnose() uses: stage-1 mean and amplitude.
  const detail::StartLevels start = detail::data_driven_start(p);
  detail::FitModel base;
  base.base = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  base.specs = detail::base_specs(engine::model_kind<engine::LuGre>, start.F_C0, start.F_S0);
  std::vector<double> init;
  for (const auto& s : base.specs) init.push_back(s.init);
  const double rms_init = fit_rms(p, base, init);

  const DiagnoseOptions o;
  const int n_features = o.max_evals_base * 2 / 5;
  const detail::FitResult a = detail::fit(p, base, {init}, detail::Span::kFeatures, 0, n_features);
  ASSERT_TRUE(a.ok) << a.reason;
  EXPECT_LE(a.evals, n_features);

  const detail::FitResult b = detail::fit(p, base, {a.theta, init}, detail::Span::kFit, 0,
                                      o.max_evals_base - a.evals);
  ASSERT_TRUE(b.ok) << b.reason;
  EXPECT_LE(b.evals, o.max_evals_base - a.evals);
  const double rms_fit = fit_rms(p, base, b.theta);
  EXPECT_LT(rms_fit, 1.03 * rms_true) << "start " << rms_init << " N, truth " << rms_true << " N";
  // And not by an offset alone: F_S within 0.2 % (the viscous term's 1 N s/m x ~0.02 m/s slip
  // velocity is absorbed by F_C, which is therefore not compared).
  EXPECT_NEAR(b.theta[0], f["F_S"], 2e-3 * f["F_S"]);
  RecordProperty("fit_rms_mN", static_cast<int>(std::lround(1e3 * rms_fit)));
}
