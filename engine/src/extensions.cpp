#include "stickslip/engine/extensions.h"

#include <cmath>
#include <cstdio>

#include "stickslip/engine/params.h"

namespace stickslip::engine {
namespace {

enum class Dom { kNonNegative, kPositive, kFraction, kHalf, kAny };

struct ExtField {
  const char* name;
  ExtensionKind kind;
  Dom dom;
  double Extension::*ptr;
  double neutral;  ///< default value (the neutral value for size parameters)
};

// Size parameter of each effect first.
const ExtField kExtFields[] = {
    {"sigma2", ExtensionKind::kViscous, Dom::kNonNegative, &Extension::sigma2, 0.0},
    {"stribeck_delta", ExtensionKind::kStribeckShape, Dom::kPositive, &Extension::stribeck_delta,
     2.0},
    {"dwell_A", ExtensionKind::kDwellTime, Dom::kNonNegative, &Extension::dwell_A, 0.0},
    {"dwell_tau", ExtensionKind::kDwellTime, Dom::kPositive, &Extension::dwell_tau, 0.1},
    {"dwell_v", ExtensionKind::kDwellTime, Dom::kPositive, &Extension::dwell_v, 1.0e-4},
    {"waviness_eps", ExtensionKind::kWaviness, Dom::kFraction, &Extension::waviness_eps, 0.0},
    {"waviness_lambda", ExtensionKind::kWaviness, Dom::kPositive, &Extension::waviness_lambda,
     1e-3},
    {"waviness_phi", ExtensionKind::kWaviness, Dom::kAny, &Extension::waviness_phi, 0.0},
    {"drift_gamma", ExtensionKind::kDrift, Dom::kAny, &Extension::drift_gamma, 0.0},
    {"load_eta", ExtensionKind::kNormalLoadModulation, Dom::kFraction, &Extension::load_eta, 0.0},
    {"load_phi", ExtensionKind::kNormalLoadModulation, Dom::kAny, &Extension::load_phi, 0.0},
    {"sensor_tau", ExtensionKind::kSensorDynamics, Dom::kNonNegative, &Extension::sensor_tau, 0.0},
    {"sensor_zeta", ExtensionKind::kSensorDynamics, Dom::kPositive, &Extension::sensor_zeta, 0.7},
    {"c_d", ExtensionKind::kDriveDamping, Dom::kNonNegative, &Extension::c_d, 0.0},
    {"vw_beta", ExtensionKind::kVelocityWeakening, Dom::kHalf, &Extension::vw_beta, 0.0},
    {"vw_v", ExtensionKind::kVelocityWeakening, Dom::kPositive, &Extension::vw_v, 1.0e-3},
    {"aging_beta", ExtensionKind::kAging, Dom::kNonNegative, &Extension::aging_beta, 0.0},
    {"aging_Dc", ExtensionKind::kAging, Dom::kPositive, &Extension::aging_Dc, 1.0e-5},
    {"aging_t0", ExtensionKind::kAging, Dom::kPositive, &Extension::aging_t0, 0.01},
};

std::string fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

const char* check(Dom d, double v) {
  if (!std::isfinite(v)) return "must be a finite number";
  switch (d) {
    case Dom::kNonNegative: return v >= 0 ? nullptr : "must be >= 0";
    case Dom::kPositive: return v > 0 ? nullptr : "must be > 0";
    case Dom::kFraction: return (v >= 0 && v < 1) ? nullptr : "must be in [0, 1)";
    case Dom::kHalf: return (v >= 0 && v < 0.5) ? nullptr : "must be in [0, 0.5)";
    case Dom::kAny: return nullptr;
  }
  return nullptr;
}

}  // namespace

const char* to_string(ExtensionKind k) noexcept {
  switch (k) {
    case ExtensionKind::kNone: return "none";
    case ExtensionKind::kViscous: return "viscous";
    case ExtensionKind::kStribeckShape: return "stribeck_shape";
    case ExtensionKind::kDwellTime: return "dwell_time";
    case ExtensionKind::kWaviness: return "waviness";
    case ExtensionKind::kDrift: return "drift";
    case ExtensionKind::kNormalLoadModulation: return "normal_load_modulation";
    case ExtensionKind::kSensorDynamics: return "sensor_dynamics";
    case ExtensionKind::kDriveDamping: return "drive_damping";
    case ExtensionKind::kVelocityWeakening: return "velocity_weakening";
    case ExtensionKind::kAging: return "aging";
  }
  return "?";
}

const std::vector<ExtensionKind>& extension_catalogue() {
  static const std::vector<ExtensionKind> kAll = {
      ExtensionKind::kViscous,  ExtensionKind::kStribeckShape,
      ExtensionKind::kDwellTime, ExtensionKind::kWaviness,
      ExtensionKind::kDrift,    ExtensionKind::kNormalLoadModulation,
      ExtensionKind::kSensorDynamics, ExtensionKind::kDriveDamping,
      ExtensionKind::kVelocityWeakening, ExtensionKind::kAging};
  return kAll;
}

ExtensionKind extension_from_string(std::string_view name) {
  if (name == "none") return ExtensionKind::kNone;
  for (ExtensionKind k : extension_catalogue())
    if (name == to_string(k)) return k;
  throw InvalidParameter("effect", std::string(name),
                         "unknown effect; expected none or one of viscous, stribeck_shape, "
                         "dwell_time, waviness, drift, normal_load_modulation, sensor_dynamics, "
                         "drive_damping, velocity_weakening, aging");
}

bool Extension::IsValid(std::vector<std::string>* errors, double x_max, double v_max) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors) errors->push_back(m);
  };
  for (const ExtField& f : kExtFields) {
    const double v = this->*f.ptr;
    if (const char* why = check(f.dom, v)) {
      fail(std::string(f.name) + " = " + fmt(v) + ": " + why);
    } else if (f.kind != kind && v != f.neutral) {
      fail(std::string(f.name) + " = " + fmt(v) + ": belongs to effect " + to_string(f.kind) +
           " but the effect is " + to_string(kind));
    }
  }
  if (kind == ExtensionKind::kDrift && x_max > 0 && std::isfinite(drift_gamma) &&
      !(1.0 + drift_gamma * x_max > 0.05))
    fail("drift_gamma = " + fmt(drift_gamma) + ": the friction level 1 + gamma x falls to " +
         fmt(1.0 + drift_gamma * x_max) + " at x = " + fmt(x_max) + " m (must stay > 0.05)");
  if (kind == ExtensionKind::kVelocityWeakening && v_max > 0 && std::isfinite(vw_beta) &&
      std::isfinite(vw_v) && vw_v > 0) {
    const double f = 1.0 - vw_beta * std::log1p(v_max / vw_v);
    if (!(f > kVelocityWeakeningFloor))
      fail("vw_beta = " + fmt(vw_beta) + ": the friction level 1 - beta ln(1 + |v_r| / vw_v) "
           "falls to " + fmt(f) + " at the run's drive plus vibration velocity " + fmt(v_max) +
           " m/s with vw_v = " + fmt(vw_v) + " m/s (must stay > " +
           fmt(kVelocityWeakeningFloor) + ")");
  }
  return ok;
}

std::vector<std::string> extension_parameter_names(ExtensionKind k) {
  std::vector<std::string> out;
  for (const ExtField& f : kExtFields)
    if (f.kind == k) out.emplace_back(f.name);
  return out;
}

std::vector<std::string> all_extension_parameter_names() {
  std::vector<std::string> out;
  for (const ExtField& f : kExtFields) out.emplace_back(f.name);
  out.emplace_back("sensor_omega_n");
  return out;
}

ExtensionKind extension_of_parameter(std::string_view name) {
  if (name == "sensor_omega_n") return ExtensionKind::kSensorDynamics;
  for (const ExtField& f : kExtFields)
    if (name == f.name) return f.kind;
  return ExtensionKind::kNone;
}

bool set_extension_parameter(Extension& e, std::string_view name, double value) {
  if (name == "sensor_omega_n") {
    if (!std::isfinite(value) || !(value > 0))
      throw InvalidParameter("sensor_omega_n", value, "must be a finite number > 0");
    e.sensor_tau = 1.0 / value;
    return true;
  }
  for (const ExtField& f : kExtFields) {
    if (name != f.name) continue;
    if (const char* why = check(f.dom, value)) throw InvalidParameter(f.name, value, why);
    e.*f.ptr = value;
    return true;
  }
  return false;
}

bool get_extension_parameter(const Extension& e, std::string_view name, double* value) {
  if (name == "sensor_omega_n") {
    *value = e.sensor_tau > 0 ? 1.0 / e.sensor_tau : HUGE_VAL;
    return true;
  }
  for (const ExtField& f : kExtFields) {
    if (name != f.name) continue;
    *value = e.*f.ptr;
    return true;
  }
  return false;
}

}  // namespace stickslip::engine
