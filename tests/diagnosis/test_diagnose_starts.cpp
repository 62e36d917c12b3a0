// Waviness starting values from the measured stick-slip peaks (diagnosis/include/stickslip/diagnosis/detail/diagnose_starts.h):
// the scan must find a hidden wave's length, size and phase from the data alone, before any
// model is fitted, and must decline when there are too few distinct stick positions.
#include <gtest/gtest.h>

#include <cmath>

#include "stickslip/diagnosis/detail/diagnose_starts.h"
#include "stickslip/diagnosis/diagnose_suite.h"
#include "stickslip/measured/synth.h"

using namespace stickslip;
using namespace stickslip::diagnosis;

namespace {

HiddenCase waviness_case() { return hidden_case("waviness"); }

detail::Problem problem_of(const HiddenCase& c, std::uint64_t seed) {
  return detail::make_problem(measured::synthesize(hidden_case_dataset(c, seed, SuiteDatasets::kCi)),
                            hidden_case_options(SuiteDatasets::kCi));
}

double wrap(double a) { return std::remainder(a, 2 * M_PI); }

}  // namespace

TEST(DiagnoseStarts, WavinessPeakScanFindsTheHiddenWave) {
  const HiddenCase c = waviness_case();  // eps 0.05, lambda 1 mm, phi 0; 6 s still stage
  for (std::uint64_t seed : {1000u, 1001u}) {
    const auto starts = detail::waviness_peak_starts(
        problem_of(c, seed), 0.1, detail::extension_specs(engine::ExtensionKind::kWaviness), 3);
    ASSERT_FALSE(starts.empty()) << "seed " << seed;
    ASSERT_EQ(starts[0].size(), 3u);
    EXPECT_NEAR(starts[0][1], 1e-3, 0.03e-3) << "lambda, seed " << seed;
    // The peaks carry F_S (1 + eps sin) plus a presliding bias of ~1 % of F_S: eps within 10 %.
    EXPECT_NEAR(starts[0][0], 0.05, 0.005) << "eps, seed " << seed;
    EXPECT_NEAR(wrap(starts[0][2]), 0.0, 0.1) << "phi, seed " << seed;
  }
}

TEST(DiagnoseStarts, WavinessPeakScanDeclinesWithTooFewStickPositions) {
  // The shared conditions (3 s still stage): 2 slips per run in the fitted part, at the same
  // positions in both runs; a 3-parameter wave is not identifiable from them.
  HiddenCase c = waviness_case();
  c.own_t_on = 0;
  c.own_duration = 0;
  EXPECT_TRUE(detail::waviness_peak_starts(problem_of(c, 1000), 0.1,
                                         detail::extension_specs(engine::ExtensionKind::kWaviness), 3)
                  .empty());
}

TEST(DiagnoseStarts, WavinessPeakScanOnCleanDataSeesNoWave) {
  // Clean data with the waviness case's conditions: every start's modulation is at the noise
  // level of the peaks (0.03 N noise averaged over the 90 ms stick ramp; measured: eps at the
  // 0.003 floor of the starts), far below the hidden 5 %. Before the collinearity guard a
  // wavelength matching the (nearly regular) slip jump gave eps = 0.25 here.
  HiddenCase c = waviness_case();
  c.kind = engine::ExtensionKind::kNone;
  c.param.clear();
  const auto starts = detail::waviness_peak_starts(
      problem_of(c, 1000), 0.1, detail::extension_specs(engine::ExtensionKind::kWaviness), 3);
  for (const auto& s : starts) {
    EXPECT_LT(s[0], 0.01) << "lambda " << s[1];
  }
}
