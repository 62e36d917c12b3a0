#pragma once
// Rate-and-state friction (Dieterich J.H. (1979) Modeling of rock friction 1, J. Geophys. Res.
// 84:2161-2168; Ruina A. (1983) Slip instability and state variable friction laws, J. Geophys.
// Res. 88:10359-10370), in the regularised form of Rice & Ben-Zion (1996) (Rice J.R., Ben-Zion
// Y., Slip complexity in earthquake fault models, PNAS 93:3811-3818; Rice J.R., Lapusta N.,
// Ranjith K. (2001) Rate and state dependent friction and the stability of sliding between
// elastically deformable solids, J. Mech. Phys. Solids 49:1865-1898). Applied to paper on paper
// by Heslot F., Baumberger T., Perrin B., Caroli B., Caroli C. (1994) Creep, stick-slip, and
// dry-friction dynamics: experiments and a heuristic model, Phys. Rev. E 49:4973-4988.
//
//   F_f = F_N mu(v_r, psi),  F_N = F_z + m g  (Drive::normal_load())                     [N]
//   mu  = a asinh(v_r / (2 V0) exp(psi / a))                                              [-]
//   psi = mu0 + b ln(V0 theta / D_c)            (the state, in friction units)           [-]
//   aging law (Dieterich): theta' = 1 - |v_r| theta / D_c
//       psi' = (b V0 / D_c) exp((mu0 - psi) / b) - b |v_r| / D_c                        [1/s]
//   slip law (Ruina):      theta' = -(|v_r| theta / D_c) ln(|v_r| theta / D_c)
//       psi' = -(|v_r| / D_c) (b ln(|v_r| / V0) + psi - mu0)                            [1/s]
//
// v_r = x' - u' [m/s]; theta [s] is the contact's age. The regularised mu is defined through
// v_r = 0 and for negative v_r (a vibrating base reverses v_r), odd in v_r, and for
// |v_r| >> 2 V0 exp(-psi/a) it is the plain law mu0 + a ln(|v_r|/V0) + b ln(V0 theta/D_c)
// (asinh(z) = ln(2z) + O(z^-2); RateStateLaw.PlainLawFarFromZero checks it). Steady sliding at
// V: theta = D_c/V, mu_ss = mu0 + (a - b) ln(V/V0), both laws.
//
// Why psi and not theta as the integrated state: theta spans decades (D_c/V in a slip, ~1e-5 s,
// to the time since the last slip in a stick, ~1 s, or hours after a hold) while the friction
// depends on ln(theta). An absolute error control on theta would be far too loose on a young
// contact and far too tight on an old one; on psi = mu0 + b ln(V0 theta/D_c) an absolute error
// is a relative error of theta and exactly the friction error F_N delta(psi) it causes (mu is
// linear in psi where |v_r| >> V0 exp(-psi/a)). The evolution laws are smooth in psi, and the
// aging law's 1/theta becomes exp((mu0 - psi)/b), which never divides by zero.
//
// Initial state: theta0 = D_c / V_init + t_hold, i.e. steady sliding at V_init and then a hold
// of t_hold at rest (aging law: theta' = 1 at v_r = 0). The body starts at rest with F_d = 0.
//
// Stiffness: dF_f/dv_r = F_N a / sqrt(v_r^2 + (2 V0 exp(-psi/a))^2) is F_N a/|v_r| in sliding
// and up to F_N a exp(psi/a) / (2 V0) ~ 1e15 N s/m at rest: the velocity equation's eigenvalue
// dF_f/dv_r / m reaches 1e15 1/s while the body creeps between slips. No explicit integrator
// can step that, so the model brings the engine's linearly implicit Rosenbrock integrator
// (RosenbrockStepper, RODAS4, L-stable) with this header's exact Jacobian; it accepts the
// adaptive integrator only, and has no batched kernel.
//
// Parameter names: mu0, a_rs, b_rs, D_c, V0 (a and b name the analytic test functions' inputs in
// a study spec's base, so the coefficients carry the suffix).
//
// Defaults (stick-slip at the seed's conditions k_d = 11700 N/m, F_N = 35.92 N, v_d = 1 mm/s):
// a = 0.01, b = 0.02, D_c = 1 um are the orders of magnitude Heslot et al. (1994) and
// Baumberger & Caroli (2006, Adv. Phys. 55:279) report for paper on paper (a ~ 1e-2, b - a ~
// 1e-2, D_c ~ 1 um); they give k_c = F_N (b - a) / D_c = 3.6e5 N/m, 30 times the drive's
// stiffness, so the seed's rig sticks and slips. mu0 = 0.231 at V0 = v_d = 1 mm/s makes the
// steady sliding friction at the drive velocity the seed's F_C = 8.3 N (Table 1). They are not a
// fit to a record.
#include <algorithm>
#include <array>
#include <cmath>

#include "stickslip/engine/model_api.h"

namespace stickslip::engine {

struct RateStateImplicit;

struct RateState {
  static constexpr const char* kLaws[] = {"aging", "slip"};
  static constexpr ModelInfo kInfo{
      "rate_state",
      "Rate-and-state",
      "Dieterich 1979; Ruina 1983; regularised: Rice & Ben-Zion 1996, Rice, Lapusta & Ranjith "
      "2001; paper on paper: Heslot et al. 1994",
      ModelClass::kSmooth,
      {"psi", kDimensionless, "state psi = mu0 + b ln(V0 theta / D_c)"},
      "stiff: runs on its own implicit (Rosenbrock) integrator",
      kAdaptiveOnly,  // its own RosenbrockStepper
      false};
  static constexpr ParamDef kParams[] = {
      {"mu0", kDimensionless, 0.231, kPositive,
       "rate-and-state steady friction coefficient at V0",
       // Written at Table 1's scale (slip level over Table 1's F_N); the diagnosis moves the
       // range and start to the record's level over its F_N (FitRange::per_normal_load).
       {0.01, 3.0, FitScale::kLog,
        [](const FitLevels& l) { return std::clamp(l.slip / Drive{}.normal_load(), 0.011, 2.9); },
        nullptr, true}},
      {"a_rs", kDimensionless, 0.01, kPositive, "rate-and-state direct-effect coefficient a",
       {1e-4, 0.1, FitScale::kLog, nullptr, nullptr, true}},
      {"b_rs", kDimensionless, 0.02, kNonNegative, "rate-and-state evolution-effect coefficient b",
       {1e-4, 0.2, FitScale::kLog, nullptr, nullptr, true}},
      {"D_c", kLength, 1e-6, kPositive, "rate-and-state characteristic slip distance",
       {1e-8, 1e-3, FitScale::kLog}},
      {"V0", kVelocity, 1e-3, kPositive, "rate-and-state reference velocity"},
      {"V_init", kVelocity, 1e-3, kPositive,
       "rate-and-state initial state: steady sliding at this velocity (theta0 = D_c/V_init)"},
      {"t_hold", kTime, 0.0, kNonNegative,
       "rate-and-state initial state: then held at rest this long (theta0 += t_hold)"},
  };
  static constexpr OptionDef kOptions[] = {
      {"law", kLaws, 0, "rate-and-state evolution law: aging (Dieterich) or slip (Ruina)"}};
  static constexpr int kStates = 1;

  double mu0, a, b, D_c, V0, V_init, t_hold;
  double F_N;          // normal load [N]
  double slip_law;     // 1: slip law, 0: aging law (a double: models are structs of doubles)
  double inv_a, inv_b; // 1/a, 1/b (0 when b = 0) [-]
  double half_inv_V0;  // 1 / (2 V0) [s/m]

  explicit RateState(const ModelInputs& in)
      : mu0(in["mu0"]), a(in["a_rs"]), b(in["b_rs"]), D_c(in["D_c"]), V0(in["V0"]),
        V_init(in["V_init"]), t_hold(in["t_hold"]), F_N(in.drive().normal_load()),
        slip_law(in.option("law") == 1 ? 1.0 : 0.0), inv_a(1.0 / a),
        inv_b(b > 0 ? 1.0 / b : 0.0), half_inv_V0(0.5 / V0) {}

  /// psi of the initial state theta0 = D_c/V_init + t_hold [-].
  double psi0() const noexcept {
    return mu0 + b * std::log(V0 / V_init + V0 * t_hold / D_c);
  }
  /// psi of steady sliding at |v| [-].
  double psi_ss(double v) const noexcept { return mu0 - b * std::log(std::fabs(v) / V0); }
  /// The friction coefficient and its derivatives by v_r [s/m] and psi [-].
  struct Mu {
    double mu, d_dv, d_dpsi;
  };
  Mu mu(double v_r, double psi) const noexcept {
    const double q = psi * inv_a;
    if (v_r == 0.0) return {0.0, a * half_inv_V0 * std::exp(std::fmin(q, 700.0)), 0.0};
    const double av = std::fabs(v_r);
    const double L = std::log(av * half_inv_V0) + q;  // ln|z|, z = v_r/(2 V0) exp(psi/a)
    double as, w;  // asinh|z|, |z|/sqrt(1 + z^2)
    if (L > 17.0) {
      // asinh|z| = L + ln 2 + u/4 + O(u^2), u = e^-2L < 1.8e-15: u/4 is below 2.5e-17 of
      // asinh and w = 1/sqrt(1 + u) is 1 to 9e-16, round-off. No exponential then: at the
      // seed's state (psi/a ~ 21.5) that is sliding faster than ~20 um/s, most of a vibrated
      // run's sliding steps (a bound of 20 took it only above ~1 mm/s).
      as = L + M_LN2;
      w = 1.0;
    } else if (L > 9.0) {
      // asinh|z| = L + ln(1 + sqrt(1 + u)) = L + ln 2 + u/4 - 3u^2/32 + O(u^3), u = z^-2 <
      // 2e-8: exact to round-off, without the logarithm glibc's asinh takes (sliding at
      // |v_r| < ~1e-3 m/s, most of a vibrated run's sliding steps).
      const double z = std::exp(L), u = 1.0 / (z * z);
      as = L + M_LN2 + u * (0.25 - 0.09375 * u);
      w = 1.0 / std::sqrt(1.0 + u);
    } else {
      const double z = std::exp(L);
      as = std::asinh(z);
      w = z / std::sqrt(1.0 + z * z);
    }
    return {std::copysign(a * as, v_r), a * w / av, std::copysign(w, v_r)};
  }
  /// The v_r at which the friction coefficient is mu (the inverse of mu(v_r, psi)) [m/s].
  double mu_inverse(double mu_value, double psi) const noexcept {
    return 2.0 * V0 * std::exp(-psi * inv_a) * std::sinh(mu_value * inv_a);
  }
  /// psi' [1/s] and its derivatives by v_r [1/m] and psi [1/s].
  struct Rate {
    double dpsi, d_dv, d_dpsi;
  };
  Rate rate(double v_r, double psi) const noexcept {
    const double av = std::fabs(v_r);
    if (slip_law != 0.0) {
      if (av == 0.0) return {0.0, 0.0, 0.0};  // |v| ln|v| -> 0
      const double lv = std::log(av / V0);
      const double k = av / D_c;
      return {-k * (b * lv + psi - mu0), -sgn(v_r) * (b * lv + b + psi - mu0) / D_c, -k};
    }
    if (b == 0.0) return {0.0, 0.0, 0.0};  // no state dependence: psi stays mu0
    const double heal = b * V0 / D_c * std::exp((mu0 - psi) * inv_b);  // b / theta [1/s]
    return {heal - b * av / D_c, -b * sgn(v_r) / D_c, -heal * inv_b};
  }

  /// The right-hand side in the engine's coordinates (the shared rhs(), tests).
  FrictionEval operator()(double v_r, double psi, double /*F_d*/) const noexcept {
    return {F_N * mu(v_r, psi).mu, rate(v_r, psi).dpsi};
  }
  std::array<double, 1> initial_z(const Drive& /*d*/) const noexcept { return {psi0()}; }
  /// The force scale: steady friction at V0, F_N mu0 [N] (tolerances, divergence guard).
  double force_scale() const noexcept { return F_N * mu0; }
  /// x' by the drive impedance sqrt(k_d m); psi by F_N (delta F_f = F_N delta psi).
  ErrorWeights<1> error_weights(const Drive& d) const noexcept {
    return {std::sqrt(d.k_d * d.m), {F_N}};
  }
  std::array<double, 1> state_scale(double /*f_ref*/) const noexcept { return {1.0}; }

  /// The system the Rosenbrock integrator advances (below).
  using Implicit = RateStateImplicit;
  using Stepper = RosenbrockStepper<RateState>;
};

/// The system the Rosenbrock integrator advances, in two charts (modes) of the same state:
///
///   sliding:     y = (x, x', psi)
///       x'' = (F_d - F_N mu(v_r, psi)) / m,  psi' = G(v_r, psi)
///   near stick:  y = (x, w, psi),  w = mu/a = asinh(v_r / c),  c = 2 V0 exp(-psi/a),
///       v_r = c sinh w,  C = c cosh w = sqrt(v_r^2 + c^2):
///       x' = u' + v_r,  w' = (A + G v_r / a) / C,  psi' = G,  A = (F_d - F_N a w)/m - u''
///       (w' from v_r' = A and c' = -c psi'/a)
///
/// with G the evolution law (psi'). Sliding turns to near stick where |v_r| falls below
/// v_eps = 1e-3 v_d (1e-6 m/s at the seed's drive), near stick back to sliding where |v_r|
/// exceeds 2 v_eps (located events).
///
/// Why two charts. mu = a asinh(v_r/c) with c ~ 1e-16 m/s rises by ~16 N / F_N a within
/// |v_r| < 1e-13 m/s. In x' alone, where a slip ends (v_r -> 0 while F_f > F_d) a linearly
/// implicit step linearises asinh at some v_r and overshoots by orders of magnitude; the
/// integrator chattered about v_r = 0 with ~5e-8 s steps for 0.1-0.2 s after every slip (1-2 M
/// steps per slip on the seed's still base). In w the friction is linear (F_f = F_N a w) and the
/// stiff relaxation to the balance w_eq (below) is damped by the L-stable method in one step. But
/// w(t) is log-singular where v_r falls linearly towards zero under a friction far above the
/// balance (w = ln(2 v_r/c), steps shrinking geometrically), and through zero (a vibrating base
/// drives the body through v_r = 0 3000 times a second) it needed steps down to c/|v_r'| ~ 1e-18
/// s. So x' is the state while sliding, w near the balance, and the deceleration from v_eps to
/// the balance or through zero, ~1e-7 s at the seed, is stepped over.
///
/// Jumps. With F_need = F_d - m u'' (the force friction must balance: the drive's and the base's
/// inertia), the balance w_eq = F_need / (F_N a) and its velocity v_bal = c sinh(w_eq):
///   - entering |v_r| < v_eps from sliding with the balance inside the band, on this side and
///     within 2 of w (friction near the balance): continue in w (chart switch);
///   - otherwise, and near stick when |w - w_eq| > 4 (the body accelerates towards a far
///     balance, through v_r = 0 or not): jump to the target, the balance velocity if it lies
///     inside the band (then near stick at w = w_eq), else the band's edge towards it (then
///     sliding at v_r = +-v_eps).
/// A jump is a linear ramp of v_r to the target, through zero in two pieces, each at the
/// acceleration (F_need - F_mean)/m, F_mean the exact mean of the friction F_N a asinh(v/c) over
/// the piece; x advances by the integral of u' (Taylor to u''') and of the ramp, psi by the
/// evolution law integrated over it. Its error is that of a constant F_need and mean friction
/// over the jump (~1e-7 s at the seed). Jumps are taken only where the law is steep at the band
/// (asinh(v_eps/c) > 5); otherwise w is smooth through v_r = 0 and is integrated.
///
/// Near stick the state is also projected onto the slow manifold after each step (project()),
/// and a step may change w by 3 at most (trust_ratio()). A jump that would end past the stage's end
/// stops on its ramp there.
struct RateStateImplicit {
  static constexpr int N = 3;
  using Y = std::array<double, N>;
  static constexpr int kSliding = 0, kNearStick = 1;
  RateState m;
  Drive d;
  double v_eps;  ///< chart boundary [m/s]
  RateStateImplicit(const RateState& model, const Drive& drive)
      : m(model), d(drive), v_eps(1e-3 * drive.v_d) {}

  /// The chart of an engine state: near stick when |v_r| < v_eps.
  int mode_of(double v_r) const noexcept {
    return std::fabs(v_r) < v_eps ? kNearStick : kSliding;
  }
  Y from_state(int mode, double x, double v, const std::array<double, 1>& z,
               const BaseMotion& b) const noexcept {
    if (mode == kSliding) return {x, v, z[0]};
    return {x, m.mu(v - b.ub, z[0]).mu * m.inv_a, z[0]};
  }
  void to_state(int mode, const Y& y, const BaseMotion& b, double* x, double* v,
                std::array<double, 1>* z) const noexcept {
    *x = y[0];
    *v = mode == kSliding ? y[1] : b.ub + vel(y).v_r;
    (*z)[0] = y[2];
  }
  ImplicitEval<N> eval(int mode, double t, const Y& y, const BaseMotion& b) const noexcept {
    const double F_d = d.k_d * (d.v_d * t - y[0]);
    if (mode == kSliding) {
      const double v_r = y[1] - b.ub;
      const double F_f = m.F_N * m.mu(v_r, y[2]).mu;
      return {{y[1], (F_d - F_f) / d.m, m.rate(v_r, y[2]).dpsi}, F_d, F_f};
    }
    const Vel k = vel(y);
    const double F_f = m.F_N * m.a * y[1];
    const double G = m.rate(k.v_r, y[2]).dpsi;
    const double A = (F_d - F_f) / d.m - b.ab;
    return {{b.ub + k.v_r, (A + G * k.v_r * m.inv_a) / k.C, G}, F_d, F_f};
  }
  ImplicitLinear<N> linearise(int mode, double t, const Y& y,
                              const BaseMotion& b) const noexcept {
    ImplicitLinear<N> l;
    l.F_d = d.k_d * (d.v_d * t - y[0]);
    if (mode == kSliding) {
      const double v_r = y[1] - b.ub;
      const RateState::Mu u = m.mu(v_r, y[2]);
      const RateState::Rate r = m.rate(v_r, y[2]);
      l.F_f = m.F_N * u.mu;
      l.f = {y[1], (l.F_d - l.F_f) / d.m, r.dpsi};
      l.J[0] = {0.0, 1.0, 0.0};
      l.J[1] = {-d.k_d / d.m, -m.F_N * u.d_dv / d.m, -m.F_N * u.d_dpsi / d.m};
      l.J[2] = {0.0, r.d_dv, r.d_dpsi};
      l.f_t = {0.0, (d.k_d * d.v_d + m.F_N * u.d_dv * b.ab) / d.m, -r.d_dv * b.ab};
      return l;
    }
    const Vel k = vel(y);
    l.F_f = m.F_N * m.a * y[1];
    const RateState::Rate r = m.rate(k.v_r, y[2]);
    const double G = r.dpsi, A = (l.F_d - l.F_f) / d.m - b.ab;
    const double P = A + G * k.v_r * m.inv_a, iC = 1.0 / k.C;
    const double G_w = r.d_dv * k.C, G_psi = r.d_dpsi - r.d_dv * k.v_r * m.inv_a;
    const double P_w = -m.F_N * m.a / d.m + (G_w * k.v_r + G * k.C) * m.inv_a;
    const double P_psi = k.v_r * m.inv_a * (G_psi - G * m.inv_a);
    l.f = {b.ub + k.v_r, P * iC, G};
    l.J[0] = {0.0, k.C, -k.v_r * m.inv_a};
    l.J[1] = {-d.k_d / d.m * iC, P_w * iC - P * k.v_r * iC * iC,
              P_psi * iC + P * m.inv_a * iC};
    l.J[2] = {0.0, G_w, G_psi};
    l.f_t = {b.ab, (d.k_d * d.v_d / d.m - b.jb) * iC, 0.0};
    return l;
  }
  /// [N per unit], at the step's start (y, b): x by k_d; psi by F_N (delta F_f = F_N delta
  /// psi); near stick w by F_N a (delta F_f = F_N a delta w); sliding x' by the friction error
  /// it causes, dF_f/dv_r = F_N a / C, C = sqrt(v_r^2 + c^2), and at least the drive impedance
  /// sqrt(k_d m). So both charts measure the same friction error (F_N a delta w = F_N a
  /// delta v_r / C). Why: with sqrt(k_d m) alone, the velocity error of the sliding steps at
  /// small |v_r| (accelerating out of the band and decelerating into it; there F_N a/C is up to
  /// ~5e3 sqrt(k_d m)) went uncontrolled and biased the run: at 1.1 mm/s a steady F_d offset
  /// (2.0e-4 of F_ref at rtol 1e-4), at 0.2 mm/s a stick-slip phase drift growing over the
  /// stage (5.5e-2 of F_ref at rtol 1e-4); with it 1.2e-6 and 3.5e-6.
  Y error_weights(int mode, const Y& y, const BaseMotion& b) const noexcept {
    if (mode != kSliding) return {d.k_d, m.F_N * m.a, m.F_N};
    const double v_r = y[1] - b.ub, c = 2.0 * m.V0 * std::exp(-y[2] * m.inv_a);
    const double C = std::sqrt(v_r * v_r + c * c);
    return {d.k_d, std::max(std::sqrt(d.k_d * d.m), m.F_N * m.a / C), m.F_N};
  }
  /// >= 0 inside the mode; fires when < 0. (y0, b0): the step's start, whose sign of v_r the
  /// sliding event keeps, so that a step across v_r = 0 fires it too. Near stick: leaving
  /// |v_r| < 2 v_eps, or w more than kFar from the balance w_eq (where the law is steep), where
  /// the body would accelerate towards a far balance, through v_r = 0 or not: log-singular in
  /// w, and jumped over.
  double event(int mode, const Y& y0, const BaseMotion& b0, double t, const Y& y,
               const BaseMotion& b) const noexcept {
    if (mode == kSliding) return (y0[1] - b0.ub < 0 ? b.ub - y[1] : y[1] - b.ub) - v_eps;
    const double leave = 2.0 * v_eps - std::fabs(vel(y).v_r);
    if (!steep(y[2])) return leave;
    return std::min(leave, kFar - std::fabs(y[1] - w_balance(t, y, b)));
  }
  static constexpr double kFar = 4.0;
  /// Near stick, where the velocity relaxes to the balance much faster than the step and than
  /// the balance moves, the state is put on the slow manifold (after each step): w = w_eq
  /// - tau_r dw_eq/dt + (m/(F_N a)) v_r psi'/a, tau_r = m C / (F_N a) the relaxation time (from
  /// F_N a w = F_d - m u'' - m v_r', v_r' = C w' - v_r psi'/a, to first order in tau_r). Why:
  /// a linearly implicit step off the manifold, at h/tau_r ~ 100, linearises the exponential
  /// C(w) and overshoots (w -5.94 -> -9.99 at w_eq = -5.57); its error estimate rejected it down
  /// to a step-size underflow (h < 1e-13 s) under 1.1 mm/s vibration. Applied where tau_r <
  /// 0.01 h and tau_r |dw_eq/dt| < 1e-4 (the neglected second order is then < 1e-8 in w), at a
  /// balance inside the band (|v_r| < v_eps there; beyond it the body breaks free).
  void project(int mode, double t, Y& y, const BaseMotion& b, double h) const noexcept {
    if (mode != kNearStick) return;
    const Manifold s = manifold(t, y, b);
    if (on_manifold(s, h)) y[1] = s.w;
  }
  /// The lowest event value accepted at a located event: a sliding step must not end past
  /// v_r = 0 (there the friction has jumped inside the step), one near stick not far past it.
  double event_floor(int mode) const noexcept { return mode == kSliding ? -v_eps : -v_eps; }
  /// Near stick a step may change w by kTrust = 3 at most (v_r by a factor 20): beyond that the
  /// linearisation of the exponential C(w) is not to be trusted, whatever the error estimate
  /// says (at rtol 1e-3 a step from w ~ 20 to 120 passed it). The ratio of the change to that
  /// bound (> 1: refused).
  static constexpr double kTrust = 3.0;
  double trust_ratio(int mode, const Y& y0, const Y& y1) const noexcept {
    return mode == kSliding ? 0.0 : std::fabs(y1[1] - y0[1]) / kTrust;
  }
  /// Time until the sliding event where |v_r| falls, aiming at |v_r| = v_eps/2, so that the
  /// step ends inside the band instead of being rejected across the jump in friction at
  /// v_r = 0 [s]; infinite otherwise. By linear extrapolation of v_r, or quadratic (fd = dy'/dt:
  /// the jerk) where the deceleration grows and that comes sooner: a vibrating base drives v_r
  /// through zero with a growing deceleration, and the linear aim crossed zero (4 mm/s, rtol
  /// 1e-4: 55k rejections, 10k with this). Where the deceleration weakens (v_r settling to a
  /// balance) the quadratic aim, later, ended steps deeper in the steep law: more rejections.
  /// Near stick: the time in which w changes by 2/3 of the trust bound at its present rate, so
  /// that a step is seldom refused (each refusal cut h tenfold and regrew it over three steps;
  /// at 0.2 mm/s w follows the base's inertia through +-3.5 at 1500 Hz).
  double time_to_event(int mode, const Y& y, const Y& f, const Y& fd,
                       const BaseMotion& b) const noexcept {
    if (mode != kSliding) return f[1] != 0.0 ? (2.0 / 3.0) * kTrust / std::fabs(f[1]) : HUGE_VAL;
    const double v_r = y[1] - b.ub, a_r = f[1] - b.ab;
    if (!(v_r * a_r < 0.0)) return HUGE_VAL;
    // In the direction of v_r: |v_r| - aim - |a_r| t + j t^2/2 = 0, j the jerk along v_r.
    const double gap = std::fabs(v_r) - 0.5 * v_eps, acc = std::fabs(a_r);
    const double t_lin = gap / acc, j = std::copysign(1.0, v_r) * (fd[1] - b.jb);
    const double disc = acc * acc - 2.0 * j * gap;
    if (gap <= 0.0 || !(j < 0.0 && disc >= 0.0)) return t_lin;
    return 2.0 * gap / (acc + std::sqrt(disc));  // the smaller positive root, stably
  }
  struct Jump {
    int mode;
    double dt;  ///< time stepped over [s]
  };
  /// At an event of mode `mode` at (t, y): a chart switch, or a jump to the target (see above);
  /// y is transformed in place and advanced by dt <= dt_max (a jump that would end later, past
  /// the stage's end, stops on its ramp at dt_max, near stick).
  Jump enter(int mode, double t, Y& y, const BaseMotion& b, double dt_max) const noexcept {
    const double v_r = mode == kSliding ? y[1] - b.ub : vel(y).v_r;
    if (mode == kNearStick && std::fabs(v_r) >= 1.999 * v_eps) {  // leaving: sliding
      y[1] = b.ub + v_r;
      return {kSliding, 0.0};
    }
    const double w = m.mu(v_r, y[2]).mu * m.inv_a, w_eq = w_balance(t, y, b);
    const double v_bal = m.mu_inverse(w_eq * m.a, y[2]);  // the balance velocity (may be inf)
    const bool inside = std::fabs(v_bal) < v_eps;
    auto chart = [&] {
      if (mode == kNearStick) {  // (nothing to jump: let it slide)
        y[1] = b.ub + v_r;
        return Jump{kSliding, 0.0};
      }
      y[1] = w;
      return Jump{kNearStick, 0.0};
    };
    // (i): from sliding, a balance near on this side, or a law that is not steep
    if (mode == kSliding && (!steep(y[2]) || (inside && v_bal * v_r > 0 && w * w_eq > 0 &&
                                               std::fabs(w) - std::fabs(w_eq) <= 2.0)))
      return chart();
    // The target: the balance inside the band (near stick), else the band's edge towards it
    // (sliding), or sliding at once from beyond that edge.
    if (!inside && v_r * w_eq > 0.0 && std::fabs(v_r) >= v_eps) return chart();
    const double target = inside ? v_bal : std::copysign(v_eps * (1.0 + 1e-9), w_eq);
    Ramp r{v_r, 0.0, 0.0, target, 0.0};  // v_r -> v1 in t1 -> v2 in t2
    const double F_need = m.F_N * m.a * w_eq;
    auto seg_time = [&](double p, double q) {  // a ramp of one sign from p to q; <0: not so
      const double F_mean = std::copysign(mean_friction(std::fabs(p), std::fabs(q), y[2]),
                                          p + q);
      const double accel = (F_need - F_mean) / d.m;
      return (q - p) * accel > 0.0 ? (q - p) / accel : -1.0;
    };
    if (v_r * target < 0.0) {  // through zero
      r.v1 = 0.0;
      r.t1 = seg_time(v_r, 0.0);
      r.t2 = seg_time(0.0, target);
    } else {
      r.v1 = target;
      r.t1 = seg_time(v_r, target);
      r.v2 = target;
    }
    if (!(r.t1 >= 0.0 && r.t2 >= 0.0)) return chart();  // no consistent ramp: integrate
    const double dt = r.t1 + r.t2;
    if (dt > dt_max) {  // stop on the ramp at dt_max, near stick
      const double v_end = dt_max <= r.t1 ? r.v0 + (r.v1 - r.v0) * dt_max / r.t1
                                          : r.v1 + (r.v2 - r.v1) * (dt_max - r.t1) / r.t2;
      if (dt_max <= r.t1) {
        r.v1 = r.v2 = v_end;
        r.t1 = dt_max;
        r.t2 = 0.0;
      } else {
        r.v2 = v_end;
        r.t2 = dt_max - r.t1;
      }
      advance(y, b, r);
      y[1] = m.mu(v_end, y[2]).mu * m.inv_a;
      return {kNearStick, dt_max};
    }
    advance(y, b, r);
    if (inside) {
      // Onto the slow manifold at first order where its correction tau dw_eq/dt is small: at
      // w_eq the state started off it by that much (~2e-3 at 1.1 mm/s, tau ~ 1e-8 s), and the
      // first step's error estimate saw the transient until h ~ tau (ten rejections per entry).
      y[1] = w_eq;
      const double t_end = t + dt;
      const BaseMotion b_end{b.ub + b.ab * dt + 0.5 * b.jb * dt * dt, b.ab + b.jb * dt, b.jb};
      const Manifold s = manifold(t_end, y, b_end);
      if (s.tau * std::fabs(s.dw_eq) < 0.1) y[1] = s.w;
      return {kNearStick, dt};
    }
    y[1] = b.ub + b.ab * dt + 0.5 * b.jb * dt * dt + target;
    return {kSliding, dt};
  }

 private:
  /// The law is steep at the band (asinh(v_eps/c) > 5): jumps apply; otherwise w is smooth
  /// through v_r = 0 and is integrated.
  bool steep(double psi) const noexcept { return m.mu(v_eps, psi).mu * m.inv_a > 5.0; }
  /// The mean of |F_f| over a linear ramp of |v_r| from p to q (exact: the integral of
  /// asinh(v/c) is v asinh(v/c) - sqrt(v^2 + c^2)) [N].
  double mean_friction(double p, double q, double psi) const noexcept {
    const double c = 2.0 * m.V0 * std::exp(-psi * m.inv_a);
    auto I = [&](double v) { return v * m.mu(v, psi).mu * m.inv_a - std::hypot(v, c); };
    const double mean = std::fabs(q - p) > 1e-12 * std::max(p, q)
                            ? (I(q) - I(p)) / (q - p)
                            : m.mu(p, psi).mu * m.inv_a;
    return m.F_N * m.a * mean;
  }
  /// The slow manifold at (t, y) (project()): w there to first order in tau, tau and dw_eq/dt
  /// [-, s, 1/s]; tau infinite where the balance lies outside the band.
  struct Manifold {
    double w, tau, dw_eq;
  };
  /// The projection applies where the relaxation is much faster than the step and the neglected
  /// second order (tau dw_eq/dt)^2 is below 1e-8 (project()).
  static bool on_manifold(const Manifold& s, double h) noexcept {
    return s.tau < 0.01 * h && s.tau * std::fabs(s.dw_eq) < 1e-4;
  }
  Manifold manifold(double t, const Y& y, const BaseMotion& b) const noexcept {
    const double Fa = m.F_N * m.a;
    Y z = y;
    z[1] = w_balance(t, y, b);  // the manifold at zeroth order: its v_r, C and tau there
    const Vel k = vel(z);
    if (!(std::fabs(k.v_r) < v_eps)) return {z[1], HUGE_VAL, 0.0};
    const double tau = d.m * k.C / Fa;
    const double dw_eq = (d.k_d * (d.v_d - b.ub - k.v_r) - d.m * b.jb) / Fa;
    const double G = m.rate(k.v_r, y[2]).dpsi;
    return {z[1] - tau * dw_eq + d.m / Fa * k.v_r * G * m.inv_a, tau, dw_eq};
  }
  /// The w at which friction balances the drive and the base's inertia: F_d - m u'' = F_N a w.
  double w_balance(double t, const Y& y, const BaseMotion& b) const noexcept {
    return (d.k_d * (d.v_d * t - y[0]) - d.m * b.ab) / (m.F_N * m.a);
  }
  struct Vel {
    double v_r, C;
  };
  /// v_r = c sinh w and C = c cosh w as V0 (e^(w-q) -+ e^(-w-q)), q = psi/a: the exponents
  /// stay near ln(|v_r|/V0), no overflow for any a.
  Vel vel(const Y& y) const noexcept {
    const double q = y[2] * m.inv_a;
    const double ep = m.V0 * std::exp(y[1] - q), em = m.V0 * std::exp(-y[1] - q);
    return {ep - em, ep + em};
  }
  /// A jump's v_r: linear from v0 to v1 in t1, then from v1 to v2 in t2 (each segment of one
  /// sign) [m/s, s].
  struct Ramp {
    double v0, v1, t1, v2, t2;
  };
  /// x and psi over a jump.
  void advance(Y& y, const BaseMotion& b, const Ramp& r) const noexcept {
    const double dt = r.t1 + r.t2;
    y[0] += b.ub * dt + 0.5 * b.ab * dt * dt + b.jb * dt * dt * dt / 6.0 +
            0.5 * (r.v0 + r.v1) * r.t1 + 0.5 * (r.v1 + r.v2) * r.t2;
    y[2] += psi_change(std::fabs(r.v0), std::fabs(r.v1), r.t1, y[2]);
    if (r.t2 > 0.0) y[2] += psi_change(std::fabs(r.v1), std::fabs(r.v2), r.t2, y[2]);
  }
  /// The evolution law integrated over a linear ramp of |v_r| from p to q in tau [-].
  double psi_change(double p, double q, double tau, double psi) const noexcept {
    const double mean_v = 0.5 * (p + q);
    if (m.slip_law != 0.0) {
      // integral of |v| (b ln(|v|/V0) + psi - mu0) dt over the ramp
      auto F = [&](double v) {
        return v > 0.0 ? 0.5 * v * v * std::log(v / m.V0) - 0.25 * v * v : 0.0;
      };
      const double vlnv = std::fabs(q - p) > 1e-9 * std::max(p, q)
                              ? (F(q) - F(p)) / (q - p)
                              : (p > 0.0 ? p * std::log(p / m.V0) : 0.0);
      return -tau / m.D_c * (m.b * vlnv + (psi - m.mu0) * mean_v);
    }
    if (m.b == 0.0) return 0.0;
    return (m.b * m.V0 / m.D_c * std::exp((m.mu0 - psi) * m.inv_b) - m.b * mean_v / m.D_c) *
           tau;
  }
};

}  // namespace stickslip::engine
