#pragma once
// Reset Integrator (the seed's eqs. 12-17; Haessig D.A., Friedland B. (1991) On the modeling and
// simulation of friction, J. Dyn. Syst. Meas. Control 113:354-362). Internal state: the elastic
// strain s [m].
//
//   s'  = 0 if (v_r < 0 and s <= -s0) or (v_r > 0 and s >= s0), else v_r              [m/s]
//   F_f = (1 + a(s)) k_t s + beta s',  a(s) = alpha while |s| < s0, else 0            [N]
//
// so that sliding friction is k_t s0 (eq. 16) and the breakaway force (1 + alpha) k_t s0.
// beta defaults to Table 1 (4869 N s/m, which equals eq. 15's 0.707 sqrt(k_t m)).
#include <algorithm>
#include <cmath>

#include "stickslip/engine/model_api.h"
#include "stickslip/engine/models/contact.h"

namespace stickslip::engine {

struct ResetHybrid;

struct ResetIntegrator {
  static constexpr ModelInfo kInfo{"reset_integrator", "Reset Integrator",
                                   "Rybkiewicz & Leus eqs. 12-17; Haessig & Friedland 1991",
                                   ModelClass::kSwitching, {"s", kLength, "elastic strain"}};
  static constexpr ParamDef kParams[] = {
      {"s0", kLength, 1.1e-7, kPositive, "Reset Integrator maximum elastic strain",
       // from the sliding level: k_t s0 = F_C at Table 1's k_t
       {5e-9, 1e-5, FitScale::kLog, [](const FitLevels& l) { return l.slip / contact::kKt.def; }}},
      {"alpha", kDimensionless, 0.34, kNonNegative, "Reset Integrator stiction gain",
       // from the breakaway/sliding ratio: (1 + alpha) k_t s0 = F_S
       {1e-3, 3.0, FitScale::kLog,
        [](const FitLevels& l) { return std::clamp(l.stick / l.slip - 1.0, 2e-3, 2.5); }}},
      contact::kKt,
      {"beta", kDamping, 4.869e3, kNonNegative, "Reset Integrator damping"},
  };
  static constexpr int kStates = 1;
  /// One of the seed's four models: every study spec's canonical form carries its parameters
  /// (registry.h, ModelTraits::in_every_canonical_spec).
  static constexpr bool kInEveryCanonicalSpec = true;

  double k_t, beta, s0, alpha;

  explicit ResetIntegrator(const ModelInputs& in)
      : k_t(in["k_t"]), beta(in["beta"]), s0(in["s0"]), alpha(in["alpha"]) {}

  FrictionEval operator()(double v_r, double s, double /*F_d*/) const noexcept {
    const bool held = (v_r < 0.0 && s <= -s0) || (v_r > 0.0 && s >= s0);
    const double ds = held ? 0.0 : v_r;
    const double a = std::fabs(s) < s0 ? alpha : 0.0;
    return {(1.0 + a) * k_t * s + beta * ds, ds};
  }
  /// x' by the contact impedance sqrt((1 + alpha) k_t m), s by k_t.
  ErrorWeights<1> error_weights(const Drive& d) const noexcept {
    return {std::sqrt((1.0 + alpha) * k_t * d.m), {k_t}};
  }
  std::array<double, 1> state_scale(double /*f_ref*/) const noexcept { return {s0}; }

  /// With a catalogue effect: the contact force scaled by the friction level, the stiction gain
  /// raised by dFS / (k_t s0) (breakaway force + dFS), plus sigma2 v_r.
  FrictionEval eval_ext(const EffectTerms& r, const Mod& m, double v_r, double s,
                        double /*F_d*/) const noexcept {
    const bool held = (v_r < 0.0 && s <= -s0) || (v_r > 0.0 && s >= s0);
    const double ds = held ? 0.0 : v_r;
    const double a = std::fabs(s) < s0 ? alpha + m.dFS / (k_t * s0) : 0.0;
    return {m.level * ((1.0 + a) * k_t * s + beta * ds) + r.sigma2 * v_r, ds};
  }

  using Hybrid = ResetHybrid;
};

/// The Reset Integrator in hybrid form: stick (s' = v_r) or sliding at the strain limit.
struct ResetHybrid {
  enum class Mode { kStick, kSlidePos, kSlideNeg };
  using Model = ResetIntegrator;
  using State = StateT<Model::kStates>;
  ResetIntegrator m;
  ResetHybrid(const ResetIntegrator& r, const Drive& /*d*/) : m(r) {}

  Mode classify(const Point& p, double s) const noexcept {
    if (s >= m.s0 && p.v_r > 0) return Mode::kSlidePos;
    if (s <= -m.s0 && p.v_r < 0) return Mode::kSlideNeg;
    return Mode::kStick;
  }
  FrictionEval eval(Mode mode, const Point& p, double s) const noexcept {
    if (p.mod.level != 1.0 || p.mod.dFS != 0.0 || p.sigma2 != 0.0) [[unlikely]]
      return eval_extended(mode, p, s);
    switch (mode) {
      case Mode::kStick: return {(1.0 + m.alpha) * m.k_t * s + m.beta * p.v_r, p.v_r};
      case Mode::kSlidePos: return {m.k_t * m.s0, 0.0};
      case Mode::kSlideNeg: return {-m.k_t * m.s0, 0.0};
    }
    return {0.0, 0.0};
  }
  /// With an effect: as ResetIntegrator::eval_ext, per mode.
  FrictionEval eval_extended(Mode mode, const Point& p, double s) const noexcept {
    const double visc = p.sigma2 * p.v_r;
    switch (mode) {
      case Mode::kStick: {
        const double a = m.alpha + p.mod.dFS / (m.k_t * m.s0);
        return {p.mod.level * ((1.0 + a) * m.k_t * s + m.beta * p.v_r) + visc, p.v_r};
      }
      case Mode::kSlidePos: return {p.mod.level * m.k_t * m.s0 + visc, 0.0};
      case Mode::kSlideNeg: return {-p.mod.level * m.k_t * m.s0 + visc, 0.0};
    }
    return {0.0, 0.0};
  }
  double event(Mode mode, const Point& p, double s, Mode* next) const noexcept {
    switch (mode) {
      case Mode::kStick: {
        const double hi = m.s0 - s, lo = s + m.s0;
        *next = hi < lo ? Mode::kSlidePos : Mode::kSlideNeg;
        return hi < lo ? hi : lo;
      }
      case Mode::kSlidePos: *next = Mode::kStick; return p.v_r;
      case Mode::kSlideNeg: *next = Mode::kStick; return -p.v_r;
    }
    return 1e300;
  }
  Mode settle(Mode /*from*/, Mode to, const Point&) const noexcept { return to; }
  /// The strain sits exactly at its limit while sliding (eq. 16).
  void on_enter(Mode mode, const Point&, State& y, Mode /*from*/) const noexcept {
    if (mode == Mode::kSlidePos) y.s = m.s0;
    if (mode == Mode::kSlideNeg) y.s = -m.s0;
  }
};

}  // namespace stickslip::engine
