// Scale-free parameter ranges and starts (diagnose_scale.h).
#include "stickslip/diagnosis/detail/diagnose_scale.h"

#include <algorithm>
#include <cmath>

namespace stickslip::diagnosis::detail {

namespace {

/// Table 1's scales: the sliding force, the drive stiffness and velocity.
double ref_force() { return engine::FrictionParams{}["F_C"]; }
double ref_kd() { return engine::Drive{}.k_d; }
double ref_vd() { return engine::Drive{}.v_d; }
double ref_normal_load() { return engine::Drive{}.normal_load(); }

const engine::ParamDef* find_def(engine::ModelKind m, const std::string& name) {
  for (const engine::ParamDef& p : engine::model_traits(m).params)
    if (name == p.name) return &p;
  return nullptr;
}

}  // namespace

double RecordScales::factor(const engine::Dim& d, double k, double v) const {
  const double lF = force;
  const double lL = force * ref_kd() / k;  // (F*/k_d) / (F_ref/k_d,ref)
  const double lT = lL / (v / ref_vd());
  return std::pow(lF, d.force) * std::pow(lL, d.length) * std::pow(lT, d.time);
}

double RecordScales::lo(const engine::Dim& d) const {
  double f = factor(d, kd.front(), vd.front());
  for (std::size_t i = 0; i < kd.size(); ++i) f = std::min(f, factor(d, kd[i], vd[i]));
  return f;
}

double RecordScales::hi(const engine::Dim& d) const {
  double f = factor(d, kd.front(), vd.front());
  for (std::size_t i = 0; i < kd.size(); ++i) f = std::max(f, factor(d, kd[i], vd[i]));
  return f;
}

double RecordScales::mid(const engine::Dim& d) const {
  double lk = 0, lv = 0;
  for (std::size_t i = 0; i < kd.size(); ++i) {
    lk += std::log(kd[i]);
    lv += std::log(vd[i]);
  }
  const double n = static_cast<double>(kd.size());
  return factor(d, std::exp(lk / n), std::exp(lv / n));
}

double RecordScales::coefficient(std::size_t run) const {
  return run < normal_load.size() && normal_load[run] > 0 ? force * ref_normal_load() / normal_load[run]
                                                          : force;
}

double RecordScales::coefficient_lo() const {
  double f = coefficient(0);
  for (std::size_t i = 1; i < normal_load.size(); ++i) f = std::min(f, coefficient(i));
  return f;
}

double RecordScales::coefficient_hi() const {
  double f = coefficient(0);
  for (std::size_t i = 1; i < normal_load.size(); ++i) f = std::max(f, coefficient(i));
  return f;
}

double RecordScales::coefficient_mid() const {
  if (normal_load.empty()) return coefficient(0);
  double l = 0;
  for (std::size_t i = 0; i < normal_load.size(); ++i) l += std::log(coefficient(i));
  return std::exp(l / static_cast<double>(normal_load.size()));
}

RecordScales record_scales(const Problem& p) {
  RecordScales s;
  double lf = 0;
  int n = 0;
  for (const RunData& r : p.runs) {
    s.kd.push_back(r.cond.kd);
    s.vd.push_back(r.cond.vd);
    s.normal_load.push_back(r.cond.Fz + r.cond.m * engine::Drive::kGravity);
    for (const WindowStats& w : r.rec.windows)
      if (w.stage == 0 && !w.held && std::isfinite(w.stats.mean) && std::fabs(w.stats.mean) > 0) {
        lf += std::log(std::fabs(w.stats.mean));
        ++n;
      }
  }
  if (s.kd.empty()) {
    s.kd = {ref_kd()};
    s.vd = {ref_vd()};
  }
  s.force = n > 0 ? std::exp(lf / n) / ref_force() : 1.0;
  return s;
}

engine::Dim spec_dimension(engine::ModelKind m, const std::string& name) {
  if (name.find('/') != std::string::npos) return engine::kDimensionless;
  const engine::ParamDef* d = find_def(m, name);
  return d ? d->dim : engine::kDimensionless;
}

std::vector<ParamSpec> scaled_base_specs(engine::ModelKind m, const RecordScales& s,
                                         const StartLevels& levels) {
  // The levels at Table 1's scale, so that base_specs' clamps act there.
  const double F = s.force;
  std::vector<ParamSpec> specs = base_specs(m, levels.F_C0 / F, levels.F_S0 / F);
  for (ParamSpec& p : specs) {
    const engine::ParamDef* def = find_def(m, p.name);
    if (def != nullptr && def->fit.per_normal_load) {
      p.lo *= s.coefficient_lo();
      p.hi *= s.coefficient_hi();
      p.init = std::clamp(p.init * s.coefficient_mid(), p.lo, p.hi);
      continue;
    }
    const engine::Dim d = spec_dimension(m, p.name);
    if (d == engine::kDimensionless) continue;
    // A start from the levels is already a force; only the range moves for it.
    const double start_factor = d == engine::kForce ? F : s.mid(d);
    p.lo *= s.lo(d);
    p.hi *= s.hi(d);
    p.init = std::clamp(p.init * start_factor, p.lo, p.hi);
  }
  return specs;
}

std::vector<ParamSpec> secondary_specs(engine::ModelKind m, const RecordScales& s) {
  std::vector<ParamSpec> out;
  for (const engine::ParamDef& p : engine::model_traits(m).params) {
    if (p.fit.fitted() || !(p.def > 0) || p.allowed.integer) continue;
    const double v = p.def * s.mid(p.dim);
    out.push_back({p.name, v / 10.0, v * 10.0, true, v});
  }
  return out;
}

engine::Dim extension_dimension(const std::string& name) {
  using engine::Dim;
  if (name == "sigma2" || name == "c_d") return engine::kDamping;
  if (name == "dwell_A") return engine::kForce;
  if (name == "dwell_tau" || name == "sensor_tau" || name == "aging_t0") return engine::kTime;
  if (name == "dwell_v" || name == "vw_v") return engine::kVelocity;
  if (name == "waviness_lambda" || name == "aging_Dc") return engine::kLength;
  if (name == "drift_gamma") return Dim{0, -1, 0};
  return engine::kDimensionless;  // delta, eps, phi, the load's eta and phi and components, zeta
}

std::vector<ParamSpec> scaled_extension_specs(engine::ExtensionKind k, const RecordScales& s) {
  std::vector<ParamSpec> specs = extension_specs(k);
  for (ParamSpec& p : specs) {
    const engine::Dim d = extension_dimension(p.name);
    if (d == engine::kDimensionless) continue;
    // A range through 0 (drift_gamma) keeps its sign: both ends scale alike.
    const bool signed_range = p.lo < 0;
    p.lo *= signed_range ? s.hi(d) : s.lo(d);
    p.hi *= s.hi(d);
    p.init = std::clamp(p.init * s.mid(d), p.lo, p.hi);
  }
  return specs;
}

double scaled_extension_value(const std::string& name, double v, const RecordScales& s) {
  return v * s.mid(extension_dimension(name));
}

void scale_defaults(engine::ModelKind m, const RecordScales& s, engine::SimConfig* cfg) {
  for (const engine::ParamDef& p : engine::model_traits(m).params)
    if (p.def > 0 && !p.allowed.integer) engine::set_parameter(*cfg, p.name, p.def * s.mid(p.dim));
}

}  // namespace stickslip::diagnosis::detail
