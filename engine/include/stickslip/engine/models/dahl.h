#pragma once
// Dahl (the seed's eqs. 7-9; Dahl P.R. (1968) A solid friction model, Aerospace Corp.
// TOR-0158(3107-18)-1). Internal state: the bristle strain s [m].
//
//   F_f = k_t s                                                        [N]
//   s'  = v_r |1 - sigma|^kappa sgn(1 - sigma),  sigma = k_t sgn(v_r) s / F_C     [m/s]
//
// v_r = x' - u' is the velocity relative to the base [m/s]. For kappa = 1 this is the seed's
// [1 - sigma]^kappa; the signed power keeps a non-integer kappa real when sigma > 1. For kappa = 1
// the strain equation is linear in s, s' = v_r - lambda s with lambda = k_t |v_r| / F_C [1/s],
// which the adaptive integrator advances by an integrating factor. No static friction: Dahl
// shows no stick-slip at the seed's conditions.
#include <cmath>

#include "stickslip/engine/model_api.h"
#include "stickslip/engine/models/contact.h"

namespace stickslip::engine {

struct Dahl {
  static constexpr ModelInfo kInfo{"dahl", "Dahl", "Rybkiewicz & Leus eqs. 7-9; Dahl 1968",
                                   ModelClass::kSmooth};
  /// Fitted parameters first, in the diagnosis' order.
  static constexpr ParamDef kParams[] = {
      contact::kFC.with_fit({0.3, 60.0, FitScale::kLog, contact::kStartSlip}),
      contact::kKt.with_fit({1e5, 1e9, FitScale::kLog}),
      // kappa >= 1: below 1 the strain equation is not Lipschitz at saturation and the adaptive
      // steps collapse (2 s still base at rtol 1e-5: 20 k steps at kappa = 1, 3.9 M at 0.3).
      {"kappa", kDimensionless, 1.0, kPositive, "Dahl exponent", {1.0, 5.0, FitScale::kLog}},
  };
  static constexpr int kStates = 1;
  /// One of the seed's four models: every study spec's canonical form carries its parameters
  /// (registry.h, ModelTraits::in_every_canonical_spec).
  static constexpr bool kInEveryCanonicalSpec = true;

  double k_t, kappa, F_C;
  double k_over_FC;  // k_t / F_C [1/m]

  explicit Dahl(const ModelInputs& in)
      : k_t(in["k_t"]), kappa(in["kappa"]), F_C(in["F_C"]), k_over_FC(k_t / F_C) {}

  FrictionEval operator()(double v_r, double s, double /*F_d*/) const noexcept {
    const double one_minus = 1.0 - k_over_FC * sgn(v_r) * s;
    const double shape =
        kappa == 1.0 ? one_minus : std::copysign(std::pow(std::fabs(one_minus), kappa), one_minus);
    return {k_t * s, v_r * shape};
  }
  /// Integrating-factor rate lambda with s' = v_r - lambda s (exact for kappa = 1) [1/s].
  double lambda(double v_r) const noexcept { return k_over_FC * std::fabs(v_r); }
  /// Local-error weights [N per unit]: x' by the contact impedance sqrt(k_t m), s by k_t.
  ErrorWeights<1> error_weights(const Drive& d) const noexcept {
    return {std::sqrt(k_t * d.m), {k_t}};
  }
  /// Scale of s for the divergence guard [m] (f_ref: the run's force scale [N]).
  std::array<double, 1> state_scale(double f_ref) const noexcept { return {f_ref / k_t}; }
  /// The rate that limits explicit RK4 (named in a divergence's reason) [1/s].
  static constexpr const char* kStiffRate = "the bristle rate k_t|v_r|/F_C";
  double stiff_rate(double v_r) const noexcept { return k_t * std::fabs(v_r) / F_C; }

  /// With a catalogue effect: F_C scaled by the friction level, plus sigma2 v_r.
  FrictionEval eval_ext(const EffectTerms& r, const Mod& m, double v_r, double s,
                        double F_d) const noexcept {
    FrictionEval fe;
    if (m.level == 1.0) {
      fe = (*this)(v_r, s, F_d);
    } else {
      Dahl dd = *this;
      dd.F_C = F_C * m.level;
      dd.k_over_FC = dd.k_t / dd.F_C;
      fe = dd(v_r, s, F_d);
    }
    fe.F_f += r.sigma2 * v_r;
    return fe;
  }

  /// Batched kernel: chunks whose lanes all have kappa = 1 run DahlLinear (no std::pow branch,
  /// so the lane loop vectorises); others run Dahl itself (correct, not vectorised).
  struct Linear;
  template <class Kernel>
  static void run_batch(Kernel& k);
};

/// Dahl restricted to kappa = 1: the same arithmetic as Dahl's kappa == 1 branch.
struct Dahl::Linear {
  Dahl d;
  static constexpr int kStates = 1;
  FrictionEval operator()(double v_r, double s, double /*F_d*/) const noexcept {
    const double one_minus = 1.0 - d.k_over_FC * sgn(v_r) * s;
    return {d.k_t * s, v_r * one_minus};
  }
};

template <class Kernel>
void Dahl::run_batch(Kernel& k) {
  if (k.all([](const Dahl& d) { return d.kappa == 1.0; }))
    k.template run<Linear>([](const Dahl& d) { return Linear{d}; });
  else
    k.template run<Dahl>([](const Dahl& d) { return d; });
}

}  // namespace stickslip::engine
