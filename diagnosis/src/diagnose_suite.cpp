#include "stickslip/diagnosis/diagnose_suite.h"

#include <boost/random/mersenne_twister.hpp>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <utility>

namespace stickslip::diagnosis {

namespace {

using K = engine::ExtensionKind;

/// Clean AR(1) noise and effects too small to see: long suite only (the cause must be "none" or
/// the right one).
using MakeEffect = std::function<HiddenCase(std::string, K, std::string, double, double)>;

void add_long_only_cases(const HiddenCase& clean, const MakeEffect& effect,
                         std::vector<HiddenCase>* c) {
  HiddenCase ar1 = clean;
  ar1.name = "clean_ar1";
  ar1.noise_rho = 0.8;
  ar1.in_ci = false;
  c->push_back(ar1);
  const auto small = [&](std::string name, K kind, std::string param, double value) {
    HiddenCase s = effect(std::move(name), kind, std::move(param), value, 0.3);
    s.small = true;
    s.in_ci = false;
    c->push_back(s);
  };
  small("small_viscous", K::kViscous, "sigma2", 1.0);
  small("small_drift", K::kDrift, "drift_gamma", 0.2);
  small("small_normal_load", K::kNormalLoadModulation, "load_eta", 0.005);
}

}  // namespace

std::vector<HiddenCase> hidden_effect_cases() {
  // Default CI (in_ci) runs every catalogue effect against its own candidate only, and the white
  // null against the two candidates that most readily fit slip timing and noise (waviness) or
  // slip-velocity structure (viscous); the rivals (bench/diagnose_suite --verbose: waviness
  // against dwell, viscous against drive damping and stribeck_shape, sensor dynamics against
  // drive damping, drift against load modulation) and the whole catalogue run with the long
  // suite, as do clean_ar1 and the small effects (CI budget: docs/diagnose.md "Tests").
  const auto effect = [](std::string name, K kind, std::string param, double value,
                         double rel_tol) {
    HiddenCase c{std::move(name), kind, std::move(param), value, rel_tol};
    c.in_ci = true;
    c.ci_candidates = kind == K::kNone ? std::vector<K>{K::kViscous, K::kWaviness}
                                       : std::vector<K>{kind};
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

  // Velocity weakening: f = 1 - 0.1 ln(1 + |v_r| / 2 mm/s), 0.96 at v_d, 0.88 at 5 mm/s and
  // about 0.76 at the slips' 2 cm/s. Judged on vw_beta (the log slope).
  HiddenCase vw = effect("velocity_weakening", K::kVelocityWeakening, "vw_beta", 0.1, 0.4);
  vw.more = {{"vw_v", 2e-3}};
  c.push_back(vw);

  const HiddenCase clean = effect("clean_white", K::kNone, "", 0.0, 0.3);
  c.push_back(clean);
  add_long_only_cases(clean, effect, &c);
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

// ---- the randomised suite ------------------------------------------------------------------


namespace stickslip::diagnosis {

namespace {

/// Uniform numbers in [lo, hi) from the generator's raw output (boost's mt19937_64 is specified,
/// and this transform is ours, so a seed gives the same suite on every platform).
class Draw {
 public:
  explicit Draw(std::uint64_t seed) : g_(seed) {}
  double operator()(double lo, double hi) {
    const double u = static_cast<double>(g_() >> 11) * (1.0 / 9007199254740992.0);
    return lo + u * (hi - lo);
  }
  bool coin() { return (*this)(0, 1) < 0.5; }

 private:
  boost::random::mt19937_64 g_;
};

struct EffectRange {
  engine::ExtensionKind kind;
  const char* judged;
  double rel_tol;
  /// Draws the effect's parameters into o.model (and records them).
  void (*draw)(Draw&, measured::SynthOptions&, std::vector<std::pair<std::string, double>>&);
};

void put(measured::SynthOptions& o, std::vector<std::pair<std::string, double>>& drawn,
         const char* name, double v) {
  engine::set_parameter(o.model, name, v);
  drawn.emplace_back(name, v);
}

const std::vector<EffectRange>& effect_ranges() {
  using K = engine::ExtensionKind;
  using Dr = std::vector<std::pair<std::string, double>>;
  static const std::vector<EffectRange> r = {
      {K::kViscous, "sigma2", 0.3, [](Draw& d, measured::SynthOptions& o, Dr& x) { put(o, x, "sigma2", d(30, 100)); }},
      {K::kStribeckShape, "stribeck_delta", 0.3,
       [](Draw& d, measured::SynthOptions& o, Dr& x) { put(o, x, "stribeck_delta", d.coin() ? d(0.8, 1.2) : d(3.0, 4.0)); }},
      {K::kDwellTime, "dwell_A", 0.4,
       [](Draw& d, measured::SynthOptions& o, Dr& x) {
         put(o, x, "dwell_A", d(0.4, 1.0));
         put(o, x, "dwell_tau", d(0.05, 0.3));
       }},
      {K::kWaviness, "waviness_eps", 0.3,
       [](Draw& d, measured::SynthOptions& o, Dr& x) {
         put(o, x, "waviness_eps", d(0.04, 0.08));
         put(o, x, "waviness_lambda", d(1.5e-3, 4e-3));
         put(o, x, "waviness_phi", d(0, 2 * M_PI));
       }},
      {K::kDrift, "drift_gamma", 0.3,
       [](Draw& d, measured::SynthOptions& o, Dr& x) { put(o, x, "drift_gamma", (d.coin() ? 1 : -1) * d(8, 20)); }},
      {K::kNormalLoadModulation, "load_eta_v", 0.3,
       [](Draw& d, measured::SynthOptions& o, Dr& x) {
         put(o, x, "load_eta", d(0.2, 0.4));
         put(o, x, "load_phi", d(0.6, 2.5));
       }},
      {K::kSensorDynamics, "sensor_tau", 0.3,
       [](Draw& d, measured::SynthOptions& o, Dr& x) {
         put(o, x, "sensor_tau", d(3e-3, 8e-3));
         put(o, x, "sensor_zeta", d(0.5, 1.0));
       }},
      {K::kDriveDamping, "c_d", 0.3, [](Draw& d, measured::SynthOptions& o, Dr& x) { put(o, x, "c_d", d(15, 40)); }},
      {K::kVelocityWeakening, "vw_beta", 0.4,
       [](Draw& d, measured::SynthOptions& o, Dr& x) {
         put(o, x, "vw_beta", d(0.06, 0.15));
         put(o, x, "vw_v", d(1e-3, 4e-3));
       }},
  };
  return r;
}

/// The base truth, noise and conditions of a case.
measured::SynthOptions draw_dataset(Draw& d, RandomFamily family, std::vector<std::pair<std::string, double>>* drawn) {
  measured::SynthOptions o;
  o.model = engine::SimConfig::seed(engine::model_kind<engine::LuGre>, 0.0);
  // Every LuGre parameter with a positive default, +-12 % (h_v = 0 stays: the viscous effect).
  for (const char* p : {"F_S", "F_C", "v_s", "k_t", "h_t"}) {
    const double v = engine::get_parameter(o.model, p) * d(0.88, 1.12);
    engine::set_parameter(o.model, p, v);
  }
  if (o.model.friction["F_S"] < 1.1 * o.model.friction["F_C"]) o.model.friction["F_S"] = 1.1 * o.model.friction["F_C"];
  for (const char* p : {"F_S", "F_C", "v_s", "k_t", "h_t"}) drawn->emplace_back(p, engine::get_parameter(o.model, p));
  o.noise_sigma = d(0.02, 0.05);
  o.noise_rho = d.coin() ? 0.0 : d(0.5, 0.9);
  o.offset = d(-0.2, 0.2);
  if (family == RandomFamily::kSeed) {
    for (double va : {0.0, 1.1e-3, 4e-3}) {
      measured::MeasuredConditions c;  // t_on = 10 s, 20 s
      c.va = va;
      o.runs.push_back(c);
    }
    o.rate = 2000;
  } else {
    const int n = d.coin() ? 2 : 3;
    const double length = d(6.0, 9.0), t_on = length * d(0.45, 0.6);
    for (int k = 0; k < n; ++k) {
      measured::MeasuredConditions c;
      c.t_on = t_on;
      c.duration = length;
      c.va = k == 0 ? d(1.2e-3, 2e-3) : k == 1 ? d(3e-3, 5e-3) : d(2e-3, 3e-3);
      o.runs.push_back(c);
    }
    o.rate = d.coin() ? 1000 : 2000;
    drawn->emplace_back("length", length);
    drawn->emplace_back("t_on", t_on);
  }
  drawn->emplace_back("noise", o.noise_sigma);
  drawn->emplace_back("rho", o.noise_rho);
  drawn->emplace_back("offset", o.offset);
  o.rtol = 1e-8;
  return o;
}

}  // namespace

std::vector<RandomCase> random_cases(std::uint64_t seed, RandomFamily family) {
  std::vector<RandomCase> out;
  // Each case's draw stream is fixed by its slot k: the first eight effects 1-8, the nulls 9 and
  // 10, later effects (velocity_weakening) 11 on, so that a case keeps its numbers for a seed
  // when the catalogue grows (results measured before stay reproducible).
  const auto make = [&](const EffectRange* e, const char* null_name, bool ar1, std::uint64_t k) {
    RandomCase c;
    c.seed = seed;
    Draw d(seed * 1000003ULL + k * 7919ULL);
    c.data = draw_dataset(d, family, &c.drawn);
    if (e) {
      c.kind = e->kind;
      c.data.model.extension.kind = e->kind;
      e->draw(d, c.data, c.drawn);
      c.judged = e->judged;
      c.rel_tol = e->rel_tol;
      for (const auto& [n, v] : c.drawn)
        if (n == c.judged) c.truth = v;
      if (e->kind == engine::ExtensionKind::kNormalLoadModulation)  // judged on eta sin(phi)
        c.truth = engine::get_parameter(c.data.model, "load_eta") * std::sin(engine::get_parameter(c.data.model, "load_phi"));
      c.name = std::string(to_string(e->kind)) + "#" + std::to_string(seed);
    } else {
      c.data.noise_rho = ar1 ? std::max(c.data.noise_rho, 0.6) : 0.0;
      for (auto& [n, v] : c.drawn)
        if (n == "rho") v = c.data.noise_rho;
      c.name = std::string(null_name) + "#" + std::to_string(seed);
    }
    c.data.name = c.name;
    c.data.seed = seed * 31 + k;
    out.push_back(std::move(c));
  };
  constexpr std::uint64_t kFirstEight = 8;
  std::uint64_t slot = 0;
  for (const EffectRange& e : effect_ranges()) {
    ++slot;
    make(&e, nullptr, false, slot <= kFirstEight ? slot : slot + 2);
  }
  make(nullptr, "null_white", false, kFirstEight + 1);
  make(nullptr, "null_ar1", true, kFirstEight + 2);
  return out;
}

std::string random_suite_ranges() {
  return "LuGre F_S, F_C, v_s, k_t, h_t: Table 1 x U(0.88, 1.12) each (F_S >= 1.1 F_C); h_v = 0\n"
         "noise sigma U(0.02, 0.05) N; AR(1) rho 0 (half the cases) or U(0.5, 0.9) (null_ar1: >= 0.6); "
         "offset U(-0.2, 0.2) N\n"
         "seed family: 3 runs x 20 s, t_on 10 s, v_a 0, 1.1, 4 mm/s, 2 kHz\n"
         "short family: 2 or 3 runs, length U(6, 9) s, t_on U(0.45, 0.6) x length, v_a U(1.2, 2), "
         "U(3, 5), U(2, 3) mm/s, 1 or 2 kHz\n"
         "viscous sigma2 U(30, 100) N s/m; stribeck_shape delta U(0.8, 1.2) or U(3, 4); dwell_time "
         "A U(0.4, 1) N, tau U(0.05, 0.3) s; waviness eps U(0.04, 0.08), lambda U(1.5, 4) mm, phi "
         "U(0, 2 pi); drift gamma +-U(8, 20) /m; normal_load_modulation eta U(0.2, 0.4), phi U(0.6, "
         "2.5) rad; sensor_dynamics tau U(3, 8) ms, zeta U(0.5, 1); drive_damping c_d U(15, 40) N s/m; "
         "velocity_weakening beta U(0.06, 0.15), vw_v U(1, 4) mm/s\n";
}

HiddenVerdict judge(const RandomCase& c, const Diagnosis& d) {
  HiddenVerdict v;
  v.truth = c.truth;
  if (c.kind == engine::ExtensionKind::kNone) {
    v.cause_ok = d.cause == "none";
    v.gain_ok = v.param_ok = true;
    return v;
  }
  for (const auto& cand : d.candidates)
    if (cand.kind == c.kind)
      for (const auto& p : cand.params)
        if (p.name == c.judged) v.recovered = p.value;
  v.cause_ok = d.cause == to_string(c.kind);
  v.gain_ok = d.gain > 0;
  v.param_ok = std::fabs(v.recovered - v.truth) <= c.rel_tol * std::fabs(v.truth);
  return v;
}

}  // namespace stickslip::diagnosis
