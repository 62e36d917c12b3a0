#include "stickslip/diagnosis/diagnose_suite.h"

#include <cmath>
#include <stdexcept>
#include <utility>

namespace stickslip::diagnosis {

std::vector<HiddenCase> hidden_effect_cases() {
  using K = engine::ExtensionKind;
  // Default CI (in_ci) runs every catalogue effect, both nulls and small_viscous; all pass on
  // seeds 1000 and 1001 on the merged build (bench/diagnose_suite and fresh-clone CI,
  // docs/diagnose.md "Status on main (session 4)"). small_drift and small_normal_load pass too
  // but are left out for CI time.
  const auto effect = [](std::string name, K kind, std::string param, double value,
                         double rel_tol) {
    HiddenCase c{std::move(name), kind, std::move(param), value, rel_tol};
    c.in_ci = true;
    return c;
  };
  std::vector<HiddenCase> c;
  c.push_back(effect("viscous", K::kViscous, "sigma2", 60.0, 0.3));

  HiddenCase stribeck = effect("stribeck_shape", K::kStribeckShape, "stribeck_delta", 1.0, 0.3);
  // The Stribeck exponent is seen where the vibration makes v_r sweep just through zero,
  // v_a slightly above v_d = 1 mm/s (the stage-2 level and its relaxation); at the shared
  // 1.5 and 5 mm/s a base with v_s free absorbs delta = 1 to 0.004 N (docs/diagnose.md,
  // "branch diag-shape"). 3 s vibrating, so the fitted 2 s reach the settled level.
  // Not chaotic: dm/m = 1e-12 moves F_d by < 7e-5 N.
  stribeck.own_va = {1.2e-3, 1.3e-3};
  stribeck.own_duration = 6.0;
  c.push_back(stribeck);

  c.push_back(effect("dwell_time", K::kDwellTime, "dwell_A", 0.5, 0.4));

  HiddenCase waviness = effect("waviness", K::kWaviness, "waviness_eps", 0.05, 0.3);
  // Enough stick-slip peaks at distinct positions to see a wave along x (the peaks' scan,
  // diagnose_starts.h): 6 s of still base, so the fitted 4.2 s hold 5 slips per run at
  // x = 0 ... 2.7 mm. With the shared 3 s there are 2 (the fitted 2.1 s), the same in both
  // runs: a 3-parameter wave is not identifiable from them (an alias, lambda = 0.40 mm,
  // eps = 0.075, fits 0.044 N RMS against 0.030 N for the truth; docs/diagnose.md).
  waviness.own_t_on = 6.0;
  waviness.own_duration = 7.5;
  c.push_back(waviness);

  c.push_back(effect("drift", K::kDrift, "drift_gamma", 10.0, 0.3));

  // Normal-load modulation is seen only through the change of each vibrating stage's mean
  // level, mostly through its part in phase with the base velocity, eta_v = eta sin(phi)
  // (diagnose_load.h). Hidden at phi = 1 rad, so both components are non-zero; judged on
  // eta_v within 15 % (measured errors 2-3 %, docs/diagnose.md).
  HiddenCase load = effect("normal_load_modulation", K::kNormalLoadModulation, "load_eta", 0.3, 0.15);
  load.more = {{"load_phi", 1.0}};
  load.judged = "load_eta_v";
  load.judged_value = 0.3 * std::sin(1.0);
  c.push_back(load);

  // Sensor tau within 15 % (measured errors 1-3 %).
  c.push_back(effect("sensor_dynamics", K::kSensorDynamics, "sensor_tau", 5e-3, 0.15));
  c.push_back(effect("drive_damping", K::kDriveDamping, "c_d", 20.0, 0.3));

  HiddenCase clean = effect("clean_white", K::kNone, "", 0.0, 0.3);
  c.push_back(clean);
  clean.name = "clean_ar1";
  clean.noise_rho = 0.8;
  c.push_back(clean);

  HiddenCase small = effect("small_viscous", K::kViscous, "sigma2", 1.0, 0.3);
  small.small = true;
  c.push_back(small);
  small = effect("small_drift", K::kDrift, "drift_gamma", 0.2, 0.3);
  small.small = true;
  small.in_ci = false;
  c.push_back(small);
  small = effect("small_normal_load", K::kNormalLoadModulation, "load_eta", 0.005, 0.3);
  small.small = true;
  small.in_ci = false;
  c.push_back(small);
  return c;
}

HiddenCase hidden_case(std::string_view name) {
  for (HiddenCase& c : hidden_effect_cases())
    if (c.name == name) return std::move(c);
  throw std::invalid_argument("hidden case \"" + std::string(name) + "\": no such case");
}

measured::SynthOptions hidden_case_dataset(const HiddenCase& c, std::uint64_t seed, SuiteDatasets family) {
  const bool full = family == SuiteDatasets::kFull, seed_cond = family == SuiteDatasets::kSeed;
  measured::SynthOptions o;
  o.name = c.name;
  o.model = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  // Base parameters 5-10 % off Table 1.
  o.model.friction["F_S"] = 11.1 * 1.06;
  o.model.friction["F_C"] = 8.3 * 0.95;
  o.model.friction["v_s"] = 3.5e-4 * 0.92;
  o.model.extension.kind = c.kind;
  if (!c.param.empty()) engine::set_parameter(o.model, c.param, c.value);
  for (const auto& [name, value] : c.more) engine::set_parameter(o.model, name, value);
  std::vector<double> vas = full ? std::vector<double>{1.5e-3, 3e-3, 5e-3}
                                 : std::vector<double>{1.5e-3, 5e-3};
  if (seed_cond) vas = {0.0, 1.1e-3, 4e-3};
  else if (!c.own_va.empty()) vas = c.own_va;
  for (double va : vas) {
    measured::MeasuredConditions m;  // the seed's t_on = 10 s, duration = 20 s
    m.va = va;
    if (!seed_cond) {
      m.t_on = full ? 4.0 : 3.0;
      m.duration = full ? 7.0 : 4.5;
      if (c.own_t_on > 0) m.t_on = c.own_t_on;
      if (c.own_duration > 0) m.duration = c.own_duration;
    }
    o.runs.push_back(m);
  }
  o.rate = family == SuiteDatasets::kCi ? 1000.0 : 2000.0;
  o.noise_sigma = c.noise;
  o.noise_rho = c.noise_rho;
  o.offset = 0.1;
  o.seed = seed;
  o.rtol = 1e-8;
  return o;
}

DiagnoseOptions hidden_case_options(SuiteDatasets family) {
  DiagnoseOptions d;
  if (family != SuiteDatasets::kFull) d.models = {engine::model_kind<engine::LuGre>};
  return d;
}

HiddenVerdict judge(const HiddenCase& c, const Diagnosis& d) {
  HiddenVerdict v;
  const std::string right = to_string(c.kind);
  if (c.kind == engine::ExtensionKind::kNone) {
    v.cause_ok = d.cause == "none";
    v.gain_ok = v.param_ok = true;
    return v;
  }
  v.truth = c.judged.empty() ? c.value : c.judged_value;
  for (const auto& cand : d.candidates)
    if (cand.kind == c.kind && !cand.params.empty()) {
      v.recovered = cand.params[0].value;
      for (const auto& p : cand.params)
        if (!c.judged.empty() && p.name == c.judged) v.recovered = p.value;
    }
  if (c.small) {
    v.cause_ok = d.cause == "none" || d.cause == right;
    v.gain_ok = v.param_ok = true;
    return v;
  }
  v.cause_ok = d.cause == right;
  v.gain_ok = d.gain > 0;
  v.param_ok = std::fabs(v.recovered - v.truth) <= c.rel_tol * std::fabs(v.truth);
  return v;
}

}  // namespace stickslip::diagnosis
