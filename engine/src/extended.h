#pragma once
// Internal: the run-time state of a catalogue extension (stickslip/engine/extensions.h). A Plant
// without an ExtRuntime (the default) never reaches this code.
//
// Each extension reduces, at one instant, to
//   level  multiplier of the friction level (waviness, drift, normal load, velocity
//          weakening, aging) [-]
//   dFS    addition to the static friction force (dwell time) [N]
//   sigma2 viscous coefficient [N s/m], delta the Stribeck exponent, c_d the drive damping
// and each model's eval_ext (models/*.h) applies them with the same operation order as its base
// law, so that neutral sizes reproduce the base model bit for bit.

#include <cmath>

#include "stickslip/engine/extensions.h"
#include "stickslip/engine/model_api.h"

namespace stickslip::engine::detail {

/// Per-run extension state: the parameters, reduced to what the evaluation needs, plus the
/// stick clock for dwell_time (updated after every accepted integrator step). The EffectTerms
/// base holds the effective sigma2 (0 unless kind == viscous) and Stribeck exponent delta (2
/// unless stribeck_shape) that the models' eval_ext read.
struct ExtRuntime : EffectTerms {
  ExtensionKind kind = ExtensionKind::kNone;
  Extension e;
  double c_d = 0.0;     ///< effective drive damping [N s/m]
  double two_pi_over_lambda = 0.0;  ///< waviness wavenumber [1/m]
  double t_slip = 0.0;  ///< last time |v_r| > dwell_v [s]
  double theta = 0.0;   ///< aging: the contact age [s]
  double t_age = 0.0;   ///< aging: the time theta belongs to [s]

  ExtRuntime() = default;
  explicit ExtRuntime(const Extension& ext) : kind(ext.kind), e(ext) {
    if (kind == ExtensionKind::kViscous) sigma2 = e.sigma2;
    if (kind == ExtensionKind::kStribeckShape) delta = e.stribeck_delta;
    if (kind == ExtensionKind::kDriveDamping) c_d = e.c_d;
    two_pi_over_lambda = 2.0 * M_PI / e.waviness_lambda;
  }
  bool tracks_stick() const noexcept { return kind == ExtensionKind::kDwellTime; }
  bool tracks_age() const noexcept { return kind == ExtensionKind::kAging; }

  /// aging: advances theta' = 1 - a theta, a = |v_r| / D_c, from t_age to t with v_r held,
  /// exactly: theta e^{-a h} + h (1 - e^{-a h}) / (a h). Returns true when the level changed.
  bool age(double t, double v_r) noexcept {
    const double h = t - t_age;
    if (!(h > 0.0)) return false;
    const double g = std::fabs(v_r) / e.aging_Dc * h;
    const double phi = g > 1e-8 ? -std::expm1(-g) / g : 1.0 - 0.5 * g;
    theta = theta * std::exp(-g) + h * phi;
    t_age = t;
    return e.aging_beta != 0.0;
  }

  /// v_a, w, t0: the current stage's base vibration (u' = v_a cos(w (t - t0))); v_r the
  /// relative velocity x' - u' [m/s].
  Mod modulation(double t, double x, double v_r, double v_a, double w,
                 double t0) const noexcept {
    Mod m;
    switch (kind) {
      case ExtensionKind::kWaviness:
        m.level = 1.0 + e.waviness_eps * std::sin(two_pi_over_lambda * x + e.waviness_phi);
        break;
      case ExtensionKind::kDrift: m.level = 1.0 + e.drift_gamma * x; break;
      case ExtensionKind::kNormalLoadModulation:
        if (v_a > 0.0) m.level = 1.0 + e.load_eta * std::sin(w * (t - t0) + e.load_phi);
        break;
      case ExtensionKind::kDwellTime:
        m.dFS = e.dwell_A * std::log1p(std::fmax(t - t_slip, 0.0) / e.dwell_tau);
        break;
      case ExtensionKind::kAging:
        m.level = 1.0 + e.aging_beta * std::log1p(theta / e.aging_t0);
        break;
      case ExtensionKind::kVelocityWeakening:
        m.level = std::fmax(1.0 - e.vw_beta * std::log1p(std::fabs(v_r) / e.vw_v),
                            kVelocityWeakeningFloor);
        break;
      default: break;
    }
    return m;
  }
};

/// The force sensor of sensor_dynamics: y'' + 2 zeta wn y' + wn^2 y = wn^2 u, driven by the
/// true F_d u(t), taken as piecewise linear between the integrator's steps. Integrated by
/// classic RK4 with sub-steps of at most 0.1/wn (local error ~1e-7 relative per sub-step),
/// written by hand because it is 10 lines and sits inside the trace recorder. Starts at rest
/// on the first sample (y = u, y' = 0).
class SensorFilter {
 public:
  SensorFilter() = default;
  SensorFilter(double tau, double zeta) : wn_(tau > 0 ? 1.0 / tau : 0.0), zeta_(zeta) {}
  bool active() const noexcept { return wn_ > 0.0; }
  double step(double t, double u) noexcept {
    if (!init_) {
      init_ = true;
      y_ = u;
      t_ = t;
      u_ = u;
      return y_;
    }
    const double span = t - t_;
    if (span > 0) {
      const int n = static_cast<int>(std::ceil(span * wn_ / 0.1));
      const double h = span / n, du = (u - u_) / n;
      const double w2 = wn_ * wn_, c = 2.0 * zeta_ * wn_;
      auto f = [&](double y, double yd, double uu, double* a) { *a = w2 * (uu - y) - c * yd; };
      for (int i = 0; i < n; ++i) {
        const double u0 = u_ + du * i, um = u0 + 0.5 * du, u1 = u0 + du;
        double a1, a2, a3, a4;
        f(y_, yd_, u0, &a1);
        const double y2 = y_ + 0.5 * h * yd_, yd2 = yd_ + 0.5 * h * a1;
        f(y2, yd2, um, &a2);
        const double y3 = y_ + 0.5 * h * yd2, yd3 = yd_ + 0.5 * h * a2;
        f(y3, yd3, um, &a3);
        const double y4 = y_ + h * yd3, yd4 = yd_ + h * a3;
        f(y4, yd4, u1, &a4);
        y_ += h / 6.0 * (yd_ + 2.0 * (yd2 + yd3) + yd4);
        yd_ += h / 6.0 * (a1 + 2.0 * (a2 + a3) + a4);
      }
    }
    t_ = t;
    u_ = u;
    return y_;
  }

 private:
  double wn_ = 0.0, zeta_ = 0.7;
  bool init_ = false;
  double t_ = 0, u_ = 0, y_ = 0, yd_ = 0;
};

}  // namespace stickslip::engine::detail
