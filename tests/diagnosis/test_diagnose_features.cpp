// The cycle-feature objective (diagnosis/include/stickslip/diagnosis/detail/diagnose_features.h) that starts every fit of the
// diagnosis. After a long still stage the simulated stick-slip cycle reaches the switch at a
// phase that turns through whole cycles as the parameters change (a 1 % change of F_S moves it
// by about one cycle after 10 s), and the transient of the next stage follows that phase. So
// the later stages are scored with the simulated switch moved to the measured phase
// (diagnose_fit.cpp, phase_shift). Without it the objective ripples along F_S and the fits stop
// in a ripple (the 3 x 20 s benchmark named a wrong cause; docs/diagnose.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/measured/synth.h"

using namespace stickslip;
using namespace stickslip::diagnosis;

namespace {

/// Feature SSE of the LuGre base at F_S = scale * F_S0 (F_C and v_s at the truth).
double feature_sse(const detail::Problem& p, double scale) {
  detail::FitModel m;
  m.base = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  m.specs = detail::base_specs(engine::model_kind<engine::LuGre>, 8.3, 11.1);
  const engine::FrictionParams f;
  const double F_S = f["F_S"] * scale;
  const detail::Evaluation e =
      detail::evaluate(p, m, {F_S, f["F_C"] / F_S, f["v_s"]}, detail::Span::kFeatures, 0);
  EXPECT_TRUE(e.ok) << e.reason;
  return e.sse_fit;
}

}  // namespace

// One run as the seed's (10 s still, then v_a = 1.5 mm/s, where the vibration ends the
// stick-slip), clean LuGre data. At F_S 0.3-1.5 % off the truth the still stage's period
// changes by about 1-5 %, so at the switch the simulated cycle is up to half a cycle and more
// away from the measured one. Put at the measured phase, the switch leaves the vibrating
// stage's features with their own smooth dependence on F_S; with the alignment switched off
// (anchor_tau = NaN) they ripple with the phase, which shows that the scenario stresses it.
TEST(DiagnoseFeatures, LaterStagesAreScoredFromTheMeasuredPhaseOfTheStillCycle) {
  measured::SynthOptions s;
  s.model = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  measured::MeasuredConditions c;
  c.va = 1.5e-3;
  c.t_on = 10.0;
  c.duration = 12.5;
  s.runs = {c};
  s.rate = 2000.0;
  s.noise_sigma = 1e-3;
  s.seed = 7;
  s.rtol = 1e-8;
  DiagnoseOptions o;
  o.fit_offset = false;  // the two windows' level terms would share the offset
  const detail::Problem aligned = detail::make_problem(measured::synthesize(s), o);
  ASSERT_EQ(aligned.runs[0].windows.size(), 2u);
  ASSERT_TRUE(std::isfinite(aligned.runs[0].anchor_tau)) << "no phase anchor";
  detail::Problem unaligned = aligned;
  unaligned.runs[0].anchor_tau = std::nan("");
  // The still window alone: the later window's share is the difference.
  detail::Problem still = unaligned;
  still.runs[0].windows.resize(1);
  for (auto* v : {&still.runs[0].features.t, &still.runs[0].features.P, &still.runs[0].features.Q,
                  &still.runs[0].features.blocks})
    v->resize(1);
  still.runs[0].features.mean.resize(1);
  still.runs[0].features.sd.resize(1);

  const std::vector<double> xs = {-0.015, -0.009, -0.003, 0.003, 0.009, 0.015};
  std::vector<double> la, lu;
  std::string scan;
  for (double x : xs) {
    const double s0 = feature_sse(still, 1 + x);
    la.push_back(feature_sse(aligned, 1 + x) - s0);
    lu.push_back(feature_sse(unaligned, 1 + x) - s0);
    scan += std::to_string(x) + ": later window " + std::to_string(la.back()) + " aligned, " +
            std::to_string(lu.back()) + " not [N^2]\n";
  }
  // Aligned: the later window's share is the stage's own, smooth dependence on F_S (the state
  // the cycle reaches a given time after a slip): it grows with the distance from the truth on
  // either side, no ripple. Not aligned: the phase dominates, ten times that somewhere.
  EXPECT_GT(la[0], la[1]) << scan;
  EXPECT_GT(la[1], la[2]) << scan;
  EXPECT_LT(la[3], la[4]) << scan;
  EXPECT_LT(la[4], la[5]) << scan;
  EXPECT_GT(*std::max_element(lu.begin(), lu.end()), 10 * *std::max_element(la.begin(), la.end()))
      << scan;
}

namespace {

/// A stick-slip sawtooth [N] at t [s]: ramps at `rise` from 6.6 N for 0.4 s, then falls back
/// linearly in 2 ms.
double sawtooth(double t, double rise) {
  const double period = 0.402, ramp = 0.4;
  const double s = std::fmod(t, period);
  const double peak = 6.6 + rise * ramp;
  return s < ramp ? 6.6 + rise * s : peak - (peak - 6.6) * (s - ramp) / (period - ramp);
}

/// Every windowed feature of the sawtooth sampled at 4 kHz on a grid offset by `delta` [s].
std::vector<double> sawtooth_features(double delta, const std::vector<detail::WindowSpec>& w,
                                      double rise, std::size_t* slips) {
  std::vector<double> t, F;
  for (double s = delta; s <= 5.0; s += 2.5e-4) {
    t.push_back(s);
    F.push_back(sawtooth(s, rise));
  }
  const detail::Features f = detail::extract_features(t, F, w, rise);
  std::vector<double> out;
  *slips = 0;
  for (std::size_t k = 0; k < w.size(); ++k) {
    out.push_back(f.mean[k]);
    out.push_back(f.sd[k]);
    out.insert(out.end(), f.blocks[k].begin(), f.blocks[k].end());
    out.insert(out.end(), f.P[k].begin(), f.P[k].end());
    out.insert(out.end(), f.Q[k].begin(), f.Q[k].end());
    for (double tk : f.t[k]) out.push_back(rise * tk);  // as the residual weighs it [N]
    *slips += f.t[k].size();
  }
  return out;
}

}  // namespace

// The windowed statistics (window mean and sd, block means, the ramp levels P and Q beside each
// slip) are integrals of the interpolated signal, so they move continuously as the samples slide
// past the windows' edges. Sample means jumped by (F entering - F leaving) / n whenever a sample
// crossed an edge (4.6 N / 1000 samples on a sawtooth block), and such steps, on the simulated
// clock shifted to the measured phase, made the feature objective a staircase on which the fits
// stopped short (3 x 20 s benchmark, docs/diagnose.md session 7).
TEST(DiagnoseFeatures, WindowedStatisticsAreContinuousInTheSamplePositions) {
  const double rise = 11.7;  // k_d v_d of the seed [N/s]
  std::vector<double> t, F;
  for (double s = 0; s <= 5.0; s += 2.5e-4) {
    t.push_back(s);
    F.push_back(sawtooth(s, rise));
  }
  const std::vector<detail::WindowSpec> w = {detail::make_window(t, F, 0.5, 4.5, true),
                                           detail::make_window(t, F, 0.5, 4.5, false)};
  ASSERT_TRUE(w[0].cycles);
  ASSERT_FALSE(w[1].cycles);
  std::size_t slips0 = 0;
  std::vector<double> prev = sawtooth_features(0.0, w, rise, &slips0);
  EXPECT_GE(slips0, 8u);
  double max_step = 0;
  // One sample interval (250 us) in 1 us steps: every sample crosses every window edge once.
  for (int k = 1; k <= 260; ++k) {
    std::size_t slips = 0;
    const std::vector<double> cur = sawtooth_features(k * 1e-6, w, rise, &slips);
    ASSERT_EQ(slips, slips0) << "offset " << k << " us";
    ASSERT_EQ(cur.size(), prev.size());
    for (std::size_t i = 0; i < cur.size(); ++i) max_step = std::max(max_step, std::fabs(cur[i] - prev[i]));
    prev = cur;
  }
  // A 1 us shift moves the interpolant by at most the steepest slope (2.3 kN/s in the fall)
  // times 1 us over a 2 ms stretch of windows 70 ms to 4 s long: well under 0.1 mN. A sample
  // mean steps by up to 4.6 mN.
  EXPECT_LT(max_step, 1e-4) << "largest change of a feature between grid offsets 1 us apart";
  // And the level is right: the sawtooth's mean is 6.6 + rise * 0.2 (ramp and fall alike); the
  // window holds 9.95 periods, which biases its mean by at most 0.05 * 2.3 N / 9.95.
  std::size_t slips = 0;
  const std::vector<double> f = sawtooth_features(1.3e-4, w, rise, &slips);
  EXPECT_NEAR(f[0], 6.6 + rise * 0.2, 0.02);
}
