#pragma once
// The seed's four friction models as small copyable value types. Each one maps the relative
// velocity v_r = x' - u' [m/s], the bristle (elastic contact) strain s [m] and the applied drive
// force F_d [N] to the friction force F_f [N] and the strain rate s' [m/s]:
//
//   Dahl (eqs. 7-9):      F_f = k_t s,
//                         s'  = v_r |1 - sigma|^kappa sgn(1 - sigma),  sigma = k_t sgn(v_r) s / F_C
//                         (for kappa = 1 this is the seed's [1 - sigma]^kappa; the signed power
//                         keeps non-integer kappa real when sigma > 1).
//   Karnopp (eq. 11):     |v_r| <= DV : F_f = sat(F_d, F_S) = clamp(F_d, -F_S, F_S)   (stick)
//                         |v_r| >  DV : F_f = F_slip sgn(v_r)                          (slip)
//                         The seed prints min(|F_d|, F_S) sgn(v_r) in the stick band. Inside the
//                         band v_r is "zero" and its sign is noise: with sgn(v_r) a body creeping
//                         backwards by 1e-6 m/s would be pushed forward by friction, i.e. friction
//                         would do positive work. Static friction reacts to the applied force, so
//                         the physical sign is that of F_d: then m x'' = F_d - F_f = 0 while
//                         |F_d| <= F_S, which is what "stick" means. No s state.
//   Reset Integrator (eqs. 12-17):
//                         s' = 0 if (v_r < 0 and s <= -s0) or (v_r > 0 and s >= s0), else v_r
//                         F_f = (1 + a(s)) k_t s + beta s',  a(s) = alpha while |s| < s0, else 0
//                         so that sliding friction is k_t s0 (eq. 16) and the breakaway force is
//                         (1 + alpha) k_t s0.
//   LuGre (eqs. 18-22):   s' = v_r - |v_r| s / g(v_r)
//                         g(v_r) = (F_C + (F_S - F_C) exp(-(v_r/v_s)^2)) / k_t
//                         F_f = k_t s + h_t(v_r) s' + h_v v_r,  h_t(v_r) = h_t exp(-(v_r/v_s)^2)
//
// For Dahl and LuGre the strain equation is linear in s for a given v_r:
//   s' = v_r - lambda(v_r) s,  lambda = |v_r| / g(v_r)   (Dahl, kappa = 1: k_t |v_r| / F_C)
// which the adaptive integrator advances exactly with an integrating factor (see integrators.md).
//
// Constructors validate their parameters and throw InvalidParameter naming the field and value.

#include <cmath>

#include "stickslip/engine/exp.h"
#include "stickslip/engine/params.h"

namespace stickslip::engine {

struct FrictionEval {
  double F_f;  ///< friction force on the body [N]
  double ds;   ///< strain rate s' [m/s]
};

inline double sgn(double v) noexcept { return (v > 0.0) - (v < 0.0); }

struct Dahl {
  double k_t, kappa, F_C;
  double k_over_FC;  // k_t / F_C [1/m]
  explicit Dahl(const FrictionParams& p);
  static constexpr bool kHasStrain = true;
  FrictionEval operator()(double v_r, double s, double /*F_d*/) const noexcept {
    const double one_minus = 1.0 - k_over_FC * sgn(v_r) * s;
    const double shape =
        kappa == 1.0 ? one_minus : std::copysign(std::pow(std::fabs(one_minus), kappa), one_minus);
    return {k_t * s, v_r * shape};
  }
  /// Linear-part rate lambda with s' = v_r - lambda s (exact for kappa = 1) [1/s].
  double lambda(double v_r) const noexcept { return k_over_FC * std::fabs(v_r); }
  /// Largest strain magnitude reachable in normal operation [m] (for divergence checks).
  double strain_scale() const noexcept { return F_C / k_t; }
};

struct Karnopp {
  double DV, F_S, F_slip;
  explicit Karnopp(const FrictionParams& p);
  static constexpr bool kHasStrain = false;
  // Written with selects, not branches, so that the batched kernels vectorise it. Equal to
  // sat(F_d, F_S) in the band and F_slip sgn(v_r) outside (v_r != 0 there since DV > 0).
  FrictionEval operator()(double v_r, double /*s*/, double F_d) const noexcept {
    const double stick = F_d > F_S ? F_S : (F_d < -F_S ? -F_S : F_d);
    const double slip = std::copysign(F_slip, v_r);
    return {std::fabs(v_r) <= DV ? stick : slip, 0.0};
  }
  double strain_scale() const noexcept { return 1.0; }
};

struct ResetIntegrator {
  double k_t, beta, s0, alpha;
  explicit ResetIntegrator(const FrictionParams& p);
  static constexpr bool kHasStrain = true;
  FrictionEval operator()(double v_r, double s, double /*F_d*/) const noexcept {
    const bool held = (v_r < 0.0 && s <= -s0) || (v_r > 0.0 && s >= s0);
    const double ds = held ? 0.0 : v_r;
    const double a = std::fabs(s) < s0 ? alpha : 0.0;
    return {(1.0 + a) * k_t * s + beta * ds, ds};
  }
  double strain_scale() const noexcept { return s0; }
};

struct LuGre {
  double k_t, h_t, h_v, F_C, F_S, v_s;
  double inv_vs2;  // 1 / v_s^2 [s^2/m^2]
  explicit LuGre(const FrictionParams& p);
  static constexpr bool kHasStrain = true;
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
  /// exp(-(v_r/v_s)^2), by the vectorisable exp of exp.h (bitwise the same in single and
  /// batched runs). Flushed to 0 beyond (v_r/v_s)^2 = kStribeckFlush (see there; exp would
  /// give subnormals beyond 708).
  double stribeck(double v_r) const noexcept {
    const double q = v_r * v_r * inv_vs2;
    return q > kStribeckFlush ? 0.0 : exp_vectorizable(-q);
  }
  double lambda(double v_r) const noexcept {
    return std::fabs(v_r) * k_t / (F_C + (F_S - F_C) * stribeck(v_r));
  }
  double strain_scale() const noexcept { return F_S / k_t; }
};

}  // namespace stickslip::engine
