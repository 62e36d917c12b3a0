// The catalogue extensions (engine/include/stickslip/engine/extensions.h): neutral sizes give the
// base model; nonzero sizes change the physics in the direction (and, where a closed form
// exists, by the amount) the physics says.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

#include "stickslip/engine/simulate.h"

using namespace stickslip::engine;

namespace {

SimConfig short_run(ModelKind m, double v_a, double t1 = 3.0, double t2 = 3.0) {
  SimConfig c = SimConfig::seed(m, v_a);
  c.stages = {Stage{t1, 0.0, 1500.0}, Stage{t2, v_a, 1500.0}};
  return c;
}

SimResult run_ok(const SimConfig& c) {
  SimResult r = simulate(c);
  EXPECT_EQ(r.status, RunStatus::kOk) << r.reason;
  return r;
}

double mean_between(const std::vector<TraceSample>& tr, double t0, double t1) {
  double s = 0;
  int n = 0;
  for (const auto& p : tr)
    if (p.t >= t0 && p.t < t1) { s += p.F_d; ++n; }
  return n ? s / n : NAN;
}

/// LuGre sliding steadily at drive velocity v [m/s] (h_v [N s/m] large enough to keep the
/// slope positive), 2 s + 2 s still: the second stage's mean F_d [N] without the extension and
/// with the one extend(c.extension) sets; neither run slips in that stage.
template <class Extend>
std::pair<double, double> steady_levels(double v, double h_v, Extend&& extend) {
  SimConfig c = short_run(model_kind<LuGre>, 0.0, 2.0, 2.0);
  c.friction["h_v"] = h_v;
  c.drive.v_d = v;
  const SimResult r0 = run_ok(c);
  extend(c.extension);
  const SimResult r = run_ok(c);
  EXPECT_EQ(r.stages[1].slip_events, 0) << v;
  return {r0.stages[1].mean_force, r.stages[1].mean_force};
}
}  // namespace

TEST(Extensions, CatalogueIdsAndNames) {
  ASSERT_EQ(extension_catalogue().size(), 10u);
  for (ExtensionKind k : extension_catalogue()) {
    EXPECT_EQ(extension_from_string(to_string(k)), k);
    EXPECT_FALSE(extension_parameter_names(k).empty()) << to_string(k);
  }
  EXPECT_EQ(extension_parameter_names(ExtensionKind::kDwellTime)[0], "dwell_A");
  EXPECT_THROW(extension_from_string("viscosity"), InvalidParameter);
}

namespace {
/// set_parameter(c, name, value) throws InvalidParameter for the field `name`, its message
/// holding the value as `text`.
void expect_refused_naming(SimConfig& c, const std::string& name, double value, const std::string& text) {
  try {
    set_parameter(c, name, value);
    FAIL() << name << " = " << value << ": no throw";
  } catch (const InvalidParameter& e) {
    EXPECT_EQ(e.field(), name);
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
  }
}
}  // namespace

TEST(Extensions, BadValuesNameFieldAndValue) {
  SimConfig c;
  expect_refused_naming(c, "waviness_eps", 1.5, "1.5");
  EXPECT_THROW(set_parameter(c, "sigma2", -1.0), InvalidParameter);
  EXPECT_THROW(set_parameter(c, "dwell_tau", 0.0), InvalidParameter);
  EXPECT_THROW(set_parameter(c, "sensor_zeta", NAN), InvalidParameter);
  EXPECT_THROW(set_parameter(c, "c_d", INFINITY), InvalidParameter);
  // A parameter of an effect that is not selected is reported, not silently ignored.
  set_parameter(c, "sigma2", 50.0);
  std::vector<std::string> errors;
  EXPECT_FALSE(c.IsValid(&errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("sigma2 = 50"), std::string::npos) << errors[0];
  set_extension(c, "viscous");
  EXPECT_TRUE(c.IsValid());
  EXPECT_DOUBLE_EQ(get_parameter(c, "sigma2"), 50.0);
  // Drift that would drive the friction level negative within the run.
  SimConfig d;
  set_extension(d, "drift");
  set_parameter(d, "drift_gamma", -100.0);  // 1 - 100 * 0.02 m < 0
  errors.clear();
  EXPECT_FALSE(d.IsValid(&errors));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors[0].find("drift_gamma"), std::string::npos);
  set_parameter(d, "sensor_omega_n", 500.0);  // wrong effect again
  EXPECT_DOUBLE_EQ(d.extension.sensor_tau, 1.0 / 500.0);
  // Velocity weakening: beta outside [0, 0.5), a reference velocity <= 0, and a level that the
  // run's own drive velocity would push below the floor.
  expect_refused_naming(d, "vw_beta", 0.5, "0.5");
  EXPECT_THROW(set_parameter(d, "vw_v", 0.0), InvalidParameter);
  SimConfig w;
  set_extension(w, "velocity_weakening");
  set_parameter(w, "vw_beta", 0.45);
  set_parameter(w, "vw_v", 1e-6);  // f(v_d = 1 mm/s) = 1 - 0.45 ln(1001) < 0
  errors.clear();
  EXPECT_FALSE(w.IsValid(&errors));
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("vw_beta = 0.45"), std::string::npos) << errors[0];
  EXPECT_NE(errors[0].find("vw_v = 9.99"), std::string::npos) << errors[0];
  set_parameter(w, "vw_v", 1e-3);  // f(1 mm/s) = 0.69
  EXPECT_TRUE(w.IsValid());
}

// Every effect at its neutral size reproduces the base model, for every model and integrator.
// "Reproduces" is judged against the run's own sensitivity: some vibrating runs are chaotic
// (LuGre at 0.2 mm/s, Dahl at 1.1 mm/s: a 1e-14 relative change of m moves F_d by up to 2 N),
// and the compiler may contract a*b+c into an FMA differently in the extended code path, so we
// use a still stage plus 4 mm/s, and allow 10x the change a 1e-14 perturbation of m makes.
TEST(Extensions, NeutralSizeReproducesBase) {
  auto worst_trace_diff = [](const SimResult& a, const SimResult& b) {
    double w = 0;
    for (std::size_t i = 0; i < std::min(a.trace.size(), b.trace.size()); ++i)
      w = std::max(w, std::fabs(a.trace[i].F_d - b.trace[i].F_d));
    return w;
  };
  for (ModelKind m : {model_kind<Dahl>, model_kind<Karnopp>, model_kind<ResetIntegrator>,
                      model_kind<LuGre>}) {
    for (IntegratorKind integ : {IntegratorKind::kAdaptive, IntegratorKind::kRk4Event}) {
      SimConfig base = short_run(m, 4e-3, 1.5, 1.0);
      base.integrator.kind = integ;
      base.integrator.dt = 2e-6;
      base.trace.rate = 2000;
      const SimResult r0 = run_ok(base);
      SimConfig pert = base;
      pert.drive.m *= 1 + 1e-14;
      const double tol = 1e-9 + 10 * worst_trace_diff(r0, run_ok(pert));
      EXPECT_LT(tol, 0.1) << to_string(m) << " too sensitive for this check";  // Karnopp: 0.04
      for (ExtensionKind k : extension_catalogue()) {
        SimConfig c = base;
        c.extension.kind = k;
        const SimResult r = run_ok(c);
        const std::string what = std::string(to_string(m)) + "/" + to_string(integ) + "/" +
                                 to_string(k);
        ASSERT_EQ(r.stages.size(), r0.stages.size()) << what;
        for (std::size_t i = 0; i < r.stages.size(); ++i) {
          EXPECT_NEAR(r.stages[i].mean_force, r0.stages[i].mean_force, tol) << what;
          EXPECT_NEAR(r.stages[i].amplitude, r0.stages[i].amplitude, tol) << what;
          EXPECT_EQ(r.stages[i].slip_events, r0.stages[i].slip_events) << what;
        }
        ASSERT_EQ(r.trace.size(), r0.trace.size()) << what;
        EXPECT_LE(worst_trace_diff(r, r0), tol) << what;
      }
    }
  }
}

// Viscous: in steady sliding (Dahl on a still base slides at v_d) the drive force rises by
// sigma2 v_d.
TEST(Extensions, ViscousRaisesSlidingForceBySigma2TimesV) {
  SimConfig c = short_run(model_kind<Dahl>, 0.0);
  const double base = run_ok(c).stages[1].mean_force;
  EXPECT_NEAR(base, 8.3, 0.01);
  c.extension.kind = ExtensionKind::kViscous;
  c.extension.sigma2 = 300.0;  // 0.3 N at 1 mm/s
  const double with = run_ok(c).stages[1].mean_force;
  EXPECT_NEAR(with - base, 300.0 * 1e-3, 0.01 * 0.3);
}

// Stribeck shape: LuGre sliding steadily (a large h_v keeps the slope positive) follows the
// steady-state curve F_C + h_v v + (F_S - F_C) exp(-|v/v_s|^delta).
TEST(Extensions, StribeckExponentFollowsSteadyStateCurve) {
  double prev = 0;
  for (double delta : {2.0, 1.0, 0.7}) {
    SimConfig c = short_run(model_kind<LuGre>, 0.0, 2.0, 2.0);
    c.friction["h_v"] = 2000.0;
    c.extension.kind = ExtensionKind::kStribeckShape;
    c.extension.stribeck_delta = delta;
    const SimResult r = run_ok(c);
    const double v = 1e-3, vs = 3.5e-4;
    EXPECT_GT(r.stages[1].mean_force, prev + 0.1) << delta;  // flatter curve, more friction
    prev = r.stages[1].mean_force;
    const double expect = 8.3 + 2000.0 * v + 2.8 * std::exp(-std::pow(v / vs, delta));
    EXPECT_NEAR(r.stages[1].mean_force, expect, 2e-3 * expect) << delta;
    EXPECT_EQ(r.stages[1].slip_events, 0) << delta;
  }
}

// Dwell time: the Coulomb spring-block breaks away at P = F_S + A ln(1 + t_stick / tau), with
// t_stick = 2 (P - F_slip) / (k_d v_d), so the amplitude 2 (P - F_slip) grows.
TEST(Extensions, DwellTimeRaisesBreakawayByLogOfStickTime) {
  SimConfig c = short_run(model_kind<Karnopp>, 0.0, 4.0, 1.0);
  c.friction["DV"] = 1e-8;
  const double amp0 = run_ok(c).stages[0].amplitude;
  c.extension.kind = ExtensionKind::kDwellTime;
  c.extension.dwell_A = 0.4;
  c.extension.dwell_tau = 0.05;
  const double amp = run_ok(c).stages[0].amplitude;
  double P = 11.1;
  for (int i = 0; i < 100; ++i)
    P = 11.1 + 0.4 * std::log1p(2 * (P - 8.3) / (11700 * 1e-3) / 0.05);
  EXPECT_GT(amp, amp0 + 0.5);
  EXPECT_NEAR(amp, 2 * (P - 8.3), 0.01 * amp);
}

// Waviness: Dahl slides steadily, so F_d follows F_C (1 + eps sin(2 pi x / lambda)): the
// Fourier component of F_d along x at 1/lambda has amplitude eps F_C (the undamped 21 Hz
// ringing left from the start-up averages out of it), and the base has none.
TEST(Extensions, WavinessModulatesForceAlongTrack) {
  auto component = [](const SimResult& r, double lambda) {
    // x(t) is not uniform (the body rings at 21 Hz), so remove the mean before projecting.
    double mean = 0, re = 0, im = 0;
    int n = 0;
    for (const auto& p : r.trace)
      if (p.t >= 4.0) { mean += p.F_d; ++n; }
    mean /= n;
    for (const auto& p : r.trace)
      if (p.t >= 4.0) {
        re += (p.F_d - mean) * std::cos(2 * M_PI * p.x / lambda);
        im += (p.F_d - mean) * std::sin(2 * M_PI * p.x / lambda);
      }
    return 2 * std::hypot(re, im) / n;
  };
  SimConfig c = short_run(model_kind<Dahl>, 0.0, 4.0, 4.0);
  c.trace.rate = 1000;
  const double lambda = 0.5e-3;  // 8 wavelengths over the 4 mm of stage 2
  EXPECT_LT(component(run_ok(c), lambda), 0.01);
  c.extension.kind = ExtensionKind::kWaviness;
  c.extension.waviness_eps = 0.05;
  c.extension.waviness_lambda = lambda;
  const SimResult r = run_ok(c);
  EXPECT_NEAR(component(r, lambda), 0.05 * 8.3, 0.03 * 0.415);
  EXPECT_NEAR(r.stages[1].mean_force, 8.3, 0.05);
}

// Drift: Dahl's sliding force grows as F_C (1 + gamma x), x ~ v_d t.
TEST(Extensions, DriftMakesMeanLevelGrowWithDistance) {
  SimConfig c = short_run(model_kind<Dahl>, 0.0, 4.0, 4.0);
  c.extension.kind = ExtensionKind::kDrift;
  c.extension.drift_gamma = 10.0;  // +10 % per cm
  c.trace.rate = 1000;
  const SimResult r = run_ok(c);
  const double m1 = mean_between(r.trace, 2.0, 3.0), m2 = mean_between(r.trace, 6.0, 7.0);
  // x advances 4 mm between the window centres: F_C gamma dx = 8.3 * 10 * 4e-3 = 0.332 N.
  EXPECT_NEAR(m2 - m1, 8.3 * 10 * 4e-3, 0.02 * 0.332);
  c.extension.drift_gamma = -10.0;
  const SimResult rn = run_ok(c);
  EXPECT_LT(mean_between(rn.trace, 6.0, 7.0), mean_between(rn.trace, 2.0, 3.0) - 0.3);
}

// Normal-load modulation: nothing changes on the still base; at v_a = 4 mm/s Dahl behaves as a
// rigid Coulomb contact, so the mean drive force is the average of
// F_C (1 + eta sin(theta + phi)) sgn(v_d - v_a cos theta) over a period.
TEST(Extensions, NormalLoadModulationShiftsVibratingMeanOnly) {
  SimConfig c = short_run(model_kind<Dahl>, 4e-3, 2.0, 2.0);
  const SimResult r0 = run_ok(c);
  c.extension.kind = ExtensionKind::kNormalLoadModulation;
  c.extension.load_eta = 0.3;
  c.extension.load_phi = M_PI / 2;
  const SimResult r = run_ok(c);
  EXPECT_NEAR(r.stages[0].mean_force, r0.stages[0].mean_force, 1e-9);
  double avg = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double th = 2 * M_PI * (i + 0.5) / n;
    avg += (1 + 0.3 * std::sin(th + M_PI / 2)) * (1e-3 - 4e-3 * std::cos(th) > 0 ? 1 : -1);
  }
  const double expect = 8.3 * avg / n;  // rigid Coulomb with the modulated level
  const double base_expect = 8.3 * (2 / M_PI) * std::asin(0.25);
  EXPECT_LT(expect, base_expect - 0.5);  // the effect is large, and lowers the mean
  EXPECT_NEAR(r.stages[1].mean_force, expect, 0.05 * base_expect);
  EXPECT_NEAR(r0.stages[1].mean_force, base_expect, 0.05 * base_expect);
}

// Sensor dynamics: during stick F_d ramps at k_d v_d, and a second-order sensor follows a ramp
// with the lag 2 zeta / omega_n; the physics (metrics) is unchanged.
TEST(Extensions, SensorDynamicsLagsTheRampAndKeepsPhysics) {
  SimConfig c = short_run(model_kind<Karnopp>, 0.0, 3.0, 1.0);
  c.friction["DV"] = 1e-8;
  c.trace.rate = 2000;
  const SimResult r0 = run_ok(c);
  c.extension.kind = ExtensionKind::kSensorDynamics;
  c.extension.sensor_tau = 1.0 / 200.0;
  c.extension.sensor_zeta = 0.7;
  const SimResult r = run_ok(c);
  EXPECT_NEAR(r.stages[0].amplitude, r0.stages[0].amplitude, 1e-9);
  ASSERT_EQ(r.trace.size(), r0.trace.size());
  const double lag_force = 11700 * 1e-3 * 2 * 0.7 / 200.0;  // 0.0819 N
  // Samples deep inside stick phases: F_d rising steadily for the last 60 ms.
  int used = 0;
  for (std::size_t i = 200; i < r0.trace.size(); ++i) {
    bool ramp = true;
    for (std::size_t j = i - 120; j < i && ramp; ++j)
      ramp = std::fabs(r0.trace[j + 1].F_d - r0.trace[j].F_d - 11.7 / 2000) < 1e-4;
    if (!ramp) continue;
    EXPECT_NEAR(r0.trace[i].F_d - r.trace[i].F_d, lag_force, 0.03 * lag_force) << r.trace[i].t;
    ++used;
  }
  EXPECT_GT(used, 500);
  // A lightly damped sensor rings after the slip's fast drop: it undershoots the true trough.
  c.extension.sensor_zeta = 0.15;
  const SimResult rl = run_ok(c);
  double lo0 = 1e9, lo = 1e9;
  for (std::size_t i = 0; i < rl.trace.size(); ++i)
    if (rl.trace[i].t > 1.0) {
      lo0 = std::min(lo0, r0.trace[i].F_d);
      lo = std::min(lo, rl.trace[i].F_d);
    }
  EXPECT_LT(lo, lo0 - 0.3);
}

// Velocity weakening: LuGre sliding steadily (a large h_v keeps the slope positive) follows
// f(v) (F_C + (F_S - F_C) exp(-(v/v_s)^2)) + h_v v with f = 1 - beta ln(1 + v / vw_v), at two
// drive velocities; the level falls by the log law, not by a constant factor.
TEST(Extensions, VelocityWeakeningLowersSteadyLevelByLogOfVelocity) {
  const double beta = 0.1, vw = 1e-3, h_v = 2000.0, vs = 3.5e-4;
  std::vector<double> drop;
  for (double v : {1e-3, 4e-3}) {
    const auto [plain, weakened] = steady_levels(v, h_v, [&](auto& e) {
      e.kind = ExtensionKind::kVelocityWeakening;
      e.vw_beta = beta;
      e.vw_v = vw;
    });
    const double f = 1.0 - beta * std::log1p(v / vw);
    const double curve = 8.3 + 2.8 * std::exp(-(v / vs) * (v / vs));
    EXPECT_NEAR(plain, curve + h_v * v, 2e-3 * curve) << v;
    EXPECT_NEAR(weakened, f * curve + h_v * v, 2e-3 * curve) << v;
    drop.push_back((plain - weakened) / curve);
  }
  // 1 - f: beta ln 2 = 0.069 at 1 mm/s, beta ln 5 = 0.161 at 4 mm/s.
  EXPECT_NEAR(drop[0], beta * std::log(2.0), 3e-3);
  EXPECT_NEAR(drop[1], beta * std::log(5.0), 3e-3);
}

// Aging: in steady sliding the contact age settles at theta = D_c / v, so LuGre sliding
// steadily (large h_v) follows (1 + beta ln(1 + D_c / (v t0))) (F_C + (F_S - F_C) e^{-(v/v_s)^2})
// + h_v v, at two drive velocities (a stronger level at the slower one).
TEST(Extensions, AgingSettlesAtTheSteadyStateAgeOfEachVelocity) {
  const double beta = 0.05, Dc = 1e-4, t0 = 0.01, h_v = 2000.0, vs = 3.5e-4;
  for (double v : {1e-3, 4e-3}) {
    const auto [plain, aged] = steady_levels(v, h_v, [&](auto& e) {
      e.kind = ExtensionKind::kAging;
      e.aging_beta = beta;
      e.aging_Dc = Dc;
      e.aging_t0 = t0;
    });
    const double level = 1.0 + beta * std::log1p(Dc / (v * t0));  // 1.120, 1.063
    const double curve = 8.3 + 2.8 * std::exp(-(v / vs) * (v / vs));
    EXPECT_NEAR(aged, level * curve + h_v * v, 2e-3 * curve) << v;
    EXPECT_NEAR(aged - plain, (level - 1) * curve, 0.05 * (level - 1) * curve) << v;
  }
}

// Aging heals the contact while it sticks: Karnopp sticks with v_r = 0, so the age grows by the
// stick time T and the breakaway level is F_S (1 + beta ln(1 + T / t0)), as dwell_time's closed
// form with a relative size. Each fast slip (theta ~ D_c / |v| ~ 1 ms) renews the contact, so the
// cycles are regular: the peak P solves P = F_S (1 + beta ln(1 + T / t0)) with T the stick time
// 2 (P - F_C) / (k_d v_d) of the symmetric Coulomb slip about F_C. (Measured 1.2 % below: the
// slip's own level, theta ~ D_c / |v| > 0, is a little above F_C.)
TEST(Extensions, AgingRaisesBreakawayByLogOfStickTime) {
  SimConfig c = short_run(model_kind<Karnopp>, 0.0, 4.0, 1.0);
  c.friction["DV"] = 1e-8;
  const double amp0 = run_ok(c).stages[0].amplitude;
  const double beta = 0.05, t0 = 0.01;
  c.extension.kind = ExtensionKind::kAging;
  c.extension.aging_beta = beta;
  c.extension.aging_Dc = 1e-5;
  c.extension.aging_t0 = t0;
  const SimResult r = run_ok(c);
  double P = 11.1;
  for (int i = 0; i < 100; ++i)
    P = 11.1 * (1.0 + beta * std::log1p(2 * (P - 8.3) / (11700 * 1e-3) / t0));
  EXPECT_GT(r.stages[0].amplitude, amp0 + 1.0);
  EXPECT_NEAR(r.stages[0].amplitude, 2 * (P - 8.3), 0.02 * r.stages[0].amplitude);
  EXPECT_GT(r.stages[0].slip_events, 2);
}

// Drive damping: dissipation in the drive shrinks the stick-slip amplitude monotonically, and
// adds nothing while the body slides at v_d (Dahl, still base).
TEST(Extensions, DriveDampingDampsStickSlip) {
  SimConfig c = short_run(model_kind<Karnopp>, 0.0, 4.0, 1.0);
  c.extension.kind = ExtensionKind::kDriveDamping;
  double prev = 1e9;
  for (double cd : {0.0, 10.0, 30.0, 60.0}) {
    c.extension.c_d = cd;
    const double amp = run_ok(c).stages[0].amplitude;
    EXPECT_LT(amp, prev - (cd > 0 ? 0.1 : 0.0)) << cd;
    prev = amp;
  }
  SimConfig d = short_run(model_kind<Dahl>, 0.0);
  const double base = run_ok(d).stages[1].mean_force;
  d.extension.kind = ExtensionKind::kDriveDamping;
  d.extension.c_d = 50.0;
  EXPECT_NEAR(run_ok(d).stages[1].mean_force, base, 1e-4);
}
