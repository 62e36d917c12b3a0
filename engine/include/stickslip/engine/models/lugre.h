#pragma once
// LuGre (the seed's eqs. 18-22; Canudas de Wit C., Olsson H., Astrom K.J., Lischinsky P. (1995)
// A new model for control of systems with friction, IEEE Trans. Autom. Control 40:419-425).
// Internal state: the bristle strain s [m].
//
//   s'  = v_r - |v_r| s / g(v_r)                                                      [m/s]
//   g(v_r) = (F_C + (F_S - F_C) exp(-(v_r/v_s)^2)) / k_t                             [m]
//   F_f = k_t s + h_t(v_r) s' + h_v v_r,   h_t(v_r) = h_t exp(-(v_r/v_s)^2)          [N]
//
// The strain equation is linear in s for a given v_r, s' = v_r - lambda s with
// lambda = |v_r| / g(v_r) [1/s], which the adaptive integrator advances by an integrating factor.
// The Stribeck factor uses exp_vectorizable (exp.h), bitwise the same in single and batched runs,
// and is flushed to 0 beyond (v_r/v_s)^2 = kStribeckFlush.
#include <cmath>

#include "stickslip/engine/model_api.h"
#include "stickslip/engine/models/contact.h"

namespace stickslip::engine {

struct LuGre {
  static constexpr ModelInfo kInfo{"lugre", "LuGre",
                                   "Rybkiewicz & Leus eqs. 18-22; Canudas de Wit et al. 1995",
                                   ModelClass::kSmooth};
  static constexpr ParamDef kParams[] = {
      contact::kFS.with_fit(contact::kFitStaticForce),
      contact::kFC.with_fit(contact::kFitCoulombFraction),
      contact::kVs.with_fit({2e-5, 1e-2, FitScale::kLog}),
      contact::kKt,
      contact::kHt,
      contact::kHv,
  };
  static constexpr Constraint kConstraints[] = {{"F_S", "F_C"}};
  static constexpr int kStates = 1;
  /// One of the seed's four models: every study spec's canonical form carries its parameters
  /// (registry.h, ModelTraits::in_every_canonical_spec).
  static constexpr bool kInEveryCanonicalSpec = true;

  double k_t, h_t, h_v, F_C, F_S, v_s;
  double inv_vs2;  // 1 / v_s^2 [s^2/m^2]

  explicit LuGre(const ModelInputs& in)
      : k_t(in["k_t"]), h_t(in["h_t"]), h_v(in["h_v"]), F_C(in["F_C"]), F_S(in["F_S"]),
        v_s(in["v_s"]), inv_vs2(1.0 / (v_s * v_s)) {}

  /// The select form, which the batched kernels vectorise.
  FrictionEval operator()(double v_r, double s, double /*F_d*/) const noexcept {
    // Ordered (and fused) for a short dependency chain: the terms that do not wait for the exp
    // and the division are summed first.
    const double e = stribeck(v_r);
    const double g_kt = fmadd(F_S - F_C, e, F_C);  // k_t g(v_r) [N]
    const double ds = v_r - std::fabs(v_r) * k_t * s / g_kt;
    return {fmadd(h_t * e, ds, fmadd(k_t, s, h_v * v_r)), ds};
  }
  /// Scalar form of operator() for single trajectories (rk4, adaptive): bitwise the same
  /// results, but beyond the flush point (|v_r| > 7.7 v_s, where e = 0) a branch skips the exp
  /// and its latency: with e = 0, fmadd(F_S - F_C, 0, F_C) is F_C and fmadd(0, ds, X) is X
  /// exactly, which is what this branch computes. The batched kernels keep the select form
  /// (operator()) so that they vectorise.
  FrictionEval eval_scalar(double v_r, double s) const noexcept {
    if (v_r * v_r * inv_vs2 > kStribeckFlush)
      return {fmadd(k_t, s, h_v * v_r), v_r - std::fabs(v_r) * k_t * s / F_C};
    return (*this)(v_r, s, 0.0);
  }
  /// (v_r/v_s)^2 beyond which the Stribeck factor is taken as 0: exp(-60) = 8.8e-27, so the
  /// dropped terms (F_S - F_C) e and h_t e s' are below 1e-22 N for |s'| < 1 m/s, far below the
  /// round-off of g and F_f (~1e-15 N).
  static constexpr double kStribeckFlush = 60.0;
  /// exp(-(v_r/v_s)^2), flushed to 0 beyond kStribeckFlush (exp would give subnormals beyond 708).
  double stribeck(double v_r) const noexcept {
    const double q = v_r * v_r * inv_vs2;
    return q > kStribeckFlush ? 0.0 : exp_vectorizable(-q);
  }
  /// Stribeck factor exp(-|v_r/v_s|^delta) of the stribeck_shape effect; the seed's for delta = 2.
  double stribeck(double delta, double v_r) const noexcept {
    if (delta == 2.0) return stribeck(v_r);
    const double q = std::pow(std::fabs(v_r) / v_s, delta);
    return q > 745.0 ? 0.0 : std::exp(-q);
  }
  double lambda(double v_r) const noexcept {
    return std::fabs(v_r) * k_t / (F_C + (F_S - F_C) * stribeck(v_r));
  }
  ErrorWeights<1> error_weights(const Drive& d) const noexcept {
    return {std::sqrt(k_t * d.m), {k_t}};
  }
  std::array<double, 1> state_scale(double f_ref) const noexcept { return {f_ref / k_t}; }
  static constexpr const char* kStiffRate = "the bristle rate k_t|v_r|/F_C";
  double stiff_rate(double v_r) const noexcept { return k_t * std::fabs(v_r) / F_C; }

  /// With a catalogue effect: F_C and F_S scaled by the level inside g (the bristle relaxes to the
  /// new level), F_S raised by dFS, the Stribeck exponent delta, plus sigma2 v_r.
  FrictionEval eval_ext(const EffectTerms& r, const Mod& m, double v_r, double s,
                        double /*F_d*/) const noexcept {
    const double e = stribeck(r.delta, v_r);
    const double F_c = F_C * m.level, F_s = (F_S + m.dFS) * m.level;
    const double g_kt = F_c + (F_s - F_c) * e;
    const double ds = v_r - std::fabs(v_r) * k_t * s / g_kt;
    return {k_t * s + h_t * e * ds + h_v * v_r + r.sigma2 * v_r, ds};
  }

  /// Single trajectories (rk4, adaptive) evaluate LuGre through Scalar (eval_scalar).
  struct Scalar;
};

struct LuGre::Scalar : LuGre {
  explicit Scalar(const LuGre& l) : LuGre(l) {}
  FrictionEval operator()(double v_r, double s, double /*F_d*/) const noexcept {
    return eval_scalar(v_r, s);
  }
};

}  // namespace stickslip::engine
