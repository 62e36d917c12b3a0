// Independent physics checks: closed-form results that do not depend on our code.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "stickslip/engine/metrics.h"
#include "stickslip/engine/simulate.h"

using namespace stickslip::engine;

namespace {

// Durations of complete stick and slip intervals in a trace (v > threshold means slipping).
struct Intervals {
  std::vector<double> stick, slip;
};
Intervals intervals(const std::vector<TraceSample>& tr, double v_threshold, double t_from) {
  Intervals out;
  bool have = false, slipping = false;
  double t_change = 0;
  for (const auto& s : tr) {
    if (s.t < t_from) continue;
    const bool now = s.v > v_threshold;
    if (!have) { have = true; slipping = now; t_change = -1; continue; }
    if (now != slipping) {
      if (t_change >= 0) (slipping ? out.slip : out.stick).push_back(s.t - t_change);
      t_change = s.t;
      slipping = now;
    }
  }
  return out;
}

}  // namespace

// Karnopp with a small band on a still base is the textbook Coulomb spring-block.
TEST(Physics, CoulombSpringBlockKarnopp) {
  SimConfig c = SimConfig::seed(model_kind<Karnopp>, 0.0);
  c.friction["DV"] = 1e-8;  // creep inside the band is then 1e-5 of v_d
  c.stages = {Stage{4.0, 0.0, 1500.0}};
  c.metrics.settle_fraction = 0.3;
  c.trace.rate = 2e5;
  const SimResult r = simulate(c);
  ASSERT_EQ(r.status, RunStatus::kOk) << r.reason;
  const double F_S = 11.1, F_slip = 8.3, k_d = 11700, m = 0.665, v_d = 1e-3;
  const double amp = 2 * (F_S - F_slip);
  EXPECT_NEAR(r.stages[0].amplitude, amp, 0.01 * amp);
  double fmax = -1e9, fmin = 1e9;
  for (const auto& s : r.trace)
    if (s.t > 1.2) { fmax = std::max(fmax, s.F_d); fmin = std::min(fmin, s.F_d); }
  EXPECT_NEAR(fmax, F_S, 0.01 * F_S);
  EXPECT_NEAR(fmin, 2 * F_slip - F_S, 0.01 * (2 * F_slip - F_S));
  const double t_stick = 2 * (F_S - F_slip) / (k_d * v_d);
  const double t_slip =
      (M_PI + 2 * std::atan(v_d * std::sqrt(k_d * m) / (F_S - F_slip))) / std::sqrt(k_d / m);
  const Intervals iv = intervals(r.trace, 1e-6, 1.2);
  ASSERT_GE(iv.stick.size(), 3u);
  ASSERT_GE(iv.slip.size(), 3u);
  for (double d : iv.stick) EXPECT_NEAR(d, t_stick, 0.01 * t_stick);
  for (double d : iv.slip) EXPECT_NEAR(d, t_slip, 0.01 * t_slip);
  EXPECT_NEAR(r.stages[0].mean_period, t_stick + t_slip, 0.01 * (t_stick + t_slip));
}

// Rigid-Coulomb law: with v_a > v_d the base-relative velocity changes sign every cycle and the
// mean friction (= mean drive force) becomes F_C (2/pi) asin(v_d/v_a).
TEST(Physics, RigidCoulombVibrationLawDahl) {
  const double F_C = 8.3, v_d = 1e-3;
  for (double v_a : {2e-3, 4e-3}) {
    const SimResult r = simulate(SimConfig::seed(model_kind<Dahl>, v_a));
    ASSERT_EQ(r.status, RunStatus::kOk) << r.reason;
    const double law = F_C * 2 / M_PI * std::asin(v_d / v_a);
    EXPECT_NEAR(r.stages[1].mean_force, law, 0.05 * law) << "v_a = " << v_a;
  }
  EXPECT_NEAR(8.3 * 2 / M_PI * std::asin(1.0 / 4.0), 1.335, 1e-3);
}

// A step that is far too large for explicit RK4 ends in 'diverged' with a reason, never NaN.
TEST(Physics, TooLargeStepDivergesCleanly) {
  SimConfig c = SimConfig::seed(model_kind<LuGre>, 4e-3);
  c.integrator.kind = IntegratorKind::kRk4;
  c.integrator.dt = 5e-5;
  const SimResult r = simulate(c);
  EXPECT_EQ(r.status, RunStatus::kDiverged);
  EXPECT_GT(r.t_end, 0.0);
  EXPECT_LT(r.t_end, 20.0);
  EXPECT_NE(r.reason.find("unstable"), std::string::npos) << r.reason;
  const std::string json = summary_json(c, r);
  EXPECT_EQ(json.find("nan"), std::string::npos);
  EXPECT_EQ(json.find("NaN"), std::string::npos);
  EXPECT_NE(json.find("\"diverged\""), std::string::npos);
  // The adaptive integrator handles the same run.
  c.integrator.kind = IntegratorKind::kAdaptive;
  EXPECT_EQ(simulate(c).status, RunStatus::kOk);
}

// The amplitude detector on a synthetic saw-tooth with known peak-to-trough.
TEST(Physics, MetricsOnKnownSignal) {
  MetricOptions opt;
  opt.settle_fraction = 0.0;
  StageAccumulator acc(0.0, 10.0, opt);
  // Saw-tooth: rises 5.5 -> 11.1 over 0.45 s, drops over 0.05 s; period 0.5 s.
  for (int i = 0; i <= 100000; ++i) {
    const double t = i * 1e-4, ph = std::fmod(t, 0.5);
    const double f = ph < 0.45 ? 5.5 + 5.6 * ph / 0.45 : 11.1 - 5.6 * (ph - 0.45) / 0.05;
    acc.sample(t, f, f);
  }
  const StageMetrics m = acc.finish();
  EXPECT_NEAR(m.amplitude, 5.6, 1e-3);
  EXPECT_NEAR(m.mean_period, 0.5, 1e-3);
  EXPECT_NEAR(m.mean_force, 8.3, 0.01);
  EXPECT_GE(m.slip_events, 19);
}
