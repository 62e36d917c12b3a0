#include "stickslip/studies/diagnose_suite.h"

#include <cmath>

namespace stickslip::studies {

std::vector<HiddenCase> hidden_effect_cases() {
  using K = ExtensionKind;
  std::vector<HiddenCase> c = {
      {"viscous", K::kViscous, "sigma2", 60.0, 0.3},
      {"stribeck_shape", K::kStribeckShape, "stribeck_delta", 1.0, 0.3},
      {"dwell_time", K::kDwellTime, "dwell_A", 0.5, 0.4},
      {"waviness", K::kWaviness, "waviness_eps", 0.05, 0.3},
      {"drift", K::kDrift, "drift_gamma", 10.0, 0.3},
      {"normal_load_modulation", K::kNormalLoadModulation, "load_eta", 0.3, 0.3},
      {"sensor_dynamics", K::kSensorDynamics, "sensor_tau", 5e-3, 0.3},
      {"drive_damping", K::kDriveDamping, "c_d", 20.0, 0.3},
  };
  HiddenCase clean{"clean_white", K::kNone, "", 0.0};
  c.push_back(clean);
  clean.name = "clean_ar1";
  clean.noise_rho = 0.8;
  c.push_back(clean);
  HiddenCase s;
  s = {"small_viscous", K::kViscous, "sigma2", 1.0, 0.3, true};
  c.push_back(s);
  s = {"small_drift", K::kDrift, "drift_gamma", 0.2, 0.3, true};
  c.push_back(s);
  s = {"small_normal_load", K::kNormalLoadModulation, "load_eta", 0.005, 0.3, true};
  c.push_back(s);
  // Measured with bench/diagnose_suite (docs/diagnose.md): these pass on every seed today.
  // dwell_time, viscous and clean_ar1 pass on seeds 1000 and 1001 since the time-domain
  // Levenberg-Marquardt phase and the nested scoring (branch diag-robust).
  for (auto& k : c)
    k.in_ci = k.name == "drift" || k.name == "clean_white" || k.name == "small_viscous" ||
              k.name == "drive_damping" || k.name == "dwell_time" || k.name == "viscous" ||
              k.name == "clean_ar1";
  return c;
}

SynthOptions hidden_case_dataset(const HiddenCase& c, std::uint64_t seed, bool full) {
  SynthOptions o;
  o.name = c.name;
  o.model = SimConfig::seed(ModelKind::kLuGre, 0.0);
  // Base parameters 5-10 % off Table 1.
  o.model.friction.F_S = 11.1 * 1.06;
  o.model.friction.F_C = 8.3 * 0.95;
  o.model.friction.v_s = 3.5e-4 * 0.92;
  o.model.extension.kind = c.kind;
  if (!c.param.empty()) set_parameter(o.model, c.param, c.value);
  const std::vector<double> vas = full ? std::vector<double>{1.5e-3, 3e-3, 5e-3}
                                       : std::vector<double>{1.5e-3, 5e-3};
  for (double va : vas) {
    MeasuredConditions m;
    m.va = va;
    m.t_on = full ? 4.0 : 3.0;
    m.duration = full ? 7.0 : 4.5;
    o.runs.push_back(m);
  }
  o.rate = full ? 2000.0 : 1000.0;
  o.noise_sigma = c.noise;
  o.noise_rho = c.noise_rho;
  o.offset = 0.1;
  o.seed = seed;
  o.rtol = 1e-8;
  return o;
}

DiagnoseOptions hidden_case_options(bool full) {
  DiagnoseOptions d;
  if (!full) d.models = {ModelKind::kLuGre};
  return d;
}

HiddenVerdict judge(const HiddenCase& c, const Diagnosis& d) {
  HiddenVerdict v;
  const std::string right = to_string(c.kind);
  if (c.kind == ExtensionKind::kNone) {
    v.cause_ok = d.cause == "none";
    v.gain_ok = v.param_ok = true;
    return v;
  }
  for (const auto& cand : d.candidates)
    if (cand.kind == c.kind && !cand.params.empty()) v.recovered = cand.params[0].value;
  if (c.small) {
    v.cause_ok = d.cause == "none" || d.cause == right;
    v.gain_ok = v.param_ok = true;
    return v;
  }
  v.cause_ok = d.cause == right;
  v.gain_ok = d.gain > 0;
  v.param_ok = std::fabs(v.recovered - c.value) <= c.rel_tol * std::fabs(c.value);
  return v;
}

}  // namespace stickslip::studies
