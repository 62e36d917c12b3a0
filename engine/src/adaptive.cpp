// Adaptive-step Dormand-Prince 5(4) with
//  - an integrating factor (Lawson) on the bristle strain of Dahl, LuGre and elasto-plastic: with
//    lambda_n = |v_r|/g(v_r) frozen at the step start, w = exp(lambda_n tau) s turns
//    s' = v_r - lambda(v_r) s into w' = exp(lambda_n tau) (v_r - (lambda - lambda_n) s), which is
//    not stiff, so fast slips (lambda up to ~5e5 1/s) do not limit the step (applied to the
//    deviation of s from its quasi-steady value v_r/lambda, and only where lambda h >= 1);
//  - located stick/slip switches for Karnopp and the Reset Integrator (frozen mode inside a step,
//    switch time found by regula falsi on the step length), which keeps the order of the method;
//  - error control in force units (see IntegratorOptions);
//  - Dahl/LuGre: a step limiter (and an approach step) at the reversals of v_r and the base
//    velocity at the stage times by angle addition (BaseAtStages);
//  - Karnopp/Reset Integrator: switches located on the continuous extension (DenseStep).
// Measurements behind each choice: docs/engine.md, "Work-precision".
// Dormand J.R., Prince P.J. (1980) A family of embedded Runge-Kutta formulae. J. Comp. Appl.
// Math. 6:19-26. Lawson J.D. (1967) Generalized Runge-Kutta processes for stable systems with
// large Lipschitz constants. SIAM J. Numer. Anal. 4:372-380.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <tuple>
#include <type_traits>

#include "integrators.h"
#include "run_stepper.h"
#include "stickslip/engine/exp.h"
#include "system.h"

namespace stickslip::engine::detail {
namespace {

constexpr int kStages = 7;
constexpr std::array<double, kStages> kC = {0.0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1.0, 1.0};
constexpr double kA[kStages][kStages] = {
    {},
    {1.0 / 5},
    {3.0 / 40, 9.0 / 40},
    {44.0 / 45, -56.0 / 15, 32.0 / 9},
    {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
    {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656},
    {35.0 / 384, 0.0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84}};
constexpr std::array<double, kStages> kB = {35.0 / 384,     0.0, 500.0 / 1113, 125.0 / 192,
                                            -2187.0 / 6784, 11.0 / 84, 0.0};
constexpr std::array<double, kStages> kE = {71.0 / 57600,      0.0,        -71.0 / 16695,
                                            71.0 / 1920,       -17253.0 / 339200,
                                            22.0 / 525,        -1.0 / 40};  // b - b_hat

/// A smooth system (Dahl, LuGre) with its integrating-factor rate.
template <class Model>
struct SmoothSys {
  const Model& model;
  using State = StateOf<Model>;
  using Deriv = DerivOf<State>;
  using Mode = int;
  const Model& base_model() const noexcept { return model; }
  Deriv eval(const Plant& p, double t, const State& y, Mode) const noexcept {
    return rhs(model, p, t, y, p.base_velocity(t));
  }
  /// The same with the base velocity ub [m/s] at t given (see BaseAtStages).
  Deriv eval_ub(const Plant& p, double t, const State& y, double ub, double /*ab*/,
                Mode) const noexcept {
    return rhs(model, p, t, y, ub);
  }
  /// The integrating-factor rate of s: lambda(v_r) or lambda(v_r, s); 0 (no factor) when the
  /// model has neither.
  double lambda_ub(const State& y, double ub) const noexcept {
    if constexpr (requires { model.lambda(0.0); }) return model.lambda(y.v - ub);
    else if constexpr (requires { model.lambda(0.0, 0.0); }) return model.lambda(y.v - ub, y.s);
    else return 0.0;
  }
  /// The factor acts about the quasi-steady s = v_r / lambda (where s' = v_r - lambda s
  /// vanishes), or, where lambda is the Jacobian -ds'/ds (Model::kLinearisedFactor), about the
  /// Newton point s + s'/lambda (see lawson_factor).
  static constexpr bool kNewtonCentre = [] {
    if constexpr (requires { Model::kLinearisedFactor; }) return Model::kLinearisedFactor;
    else return false;
  }();
  static constexpr bool kEvents = false;
  /// v_r reverses inside the step: the kink of |v_r| and the Stribeck bump (width ~v_s) sit
  /// there, see reversal_limited_step.
  static constexpr bool kReversals = true;
  double event(const Plant&, double, const State&, Mode, Mode*) const noexcept { return 1.0; }
  Mode start_mode(const Plant&, double, State&, const RunContext* = nullptr) const noexcept {
    return 0;
  }
  Mode enter(Mode, Mode to, const Plant&, double, State&) const noexcept { return to; }
};

/// A switching system (Karnopp, Reset Integrator) in hybrid form.
template <class H>
struct HybridSys {
  const H& hyb;
  using State = typename H::State;
  using Deriv = DerivOf<State>;
  using Mode = typename H::Mode;
  const auto& base_model() const noexcept { return hyb.m; }
  static Point point(const Plant& p, double t, const State& y) noexcept {
    return p.point(t, y.x, y.v);
  }
  static constexpr bool kMore = requires(State s) { s.zs; };  // internal states beyond s
  Deriv eval(const Plant& p, double t, const State& y, Mode mode) const noexcept {
    return eval_at(p, point(p, t, y), y, mode);
  }
  /// The same with the base velocity ub [m/s] and acceleration ab [m/s^2] at t given
  /// (BaseAtStages; a catalogue extension's point is built by the plant).
  Deriv eval_ub(const Plant& p, double t, const State& y, double ub, double ab,
                Mode mode) const noexcept {
    if (p.ext) [[unlikely]]
      return eval(p, t, y, mode);
    return eval_at(p, Point{p.drive_force(t, y.x), y.v - ub, ab}, y, mode);
  }
  Deriv eval_at(const Plant& p, const Point& pt, const State& y, Mode mode) const noexcept {
    if constexpr (kMore) {
      return frozen_deriv(p, pt, y, hyb.eval(mode, pt, internal_states(y)));
    } else {
      const FrictionEval fe = hyb.eval(mode, pt, y.s);
      return {{y.v, (pt.F_d - fe.F_f) * p.m_inv, fe.ds}, pt.F_d, fe.F_f};
    }
  }
  static constexpr bool kEvents = true;
  /// The reversal step limiter and the stage base motion by angle addition of adaptive() where
  /// the hybrid form asks for them (H::kReversals: GMS, whose element damping's Stribeck factor
  /// has a bump ~v_s wide at every reversal of v_r); Karnopp and the Reset Integrator locate
  /// their switches only.
  static constexpr bool kReversals = [] {
    if constexpr (requires { H::kReversals; }) return H::kReversals;
    else return false;
  }();
  static constexpr bool kNewtonCentre = false;
  double lambda_ub(const State&, double) const noexcept { return 0.0; }  // no factor
  double event(const Plant& p, double t, const State& y, Mode mode, Mode* next) const noexcept {
    if constexpr (kMore) return hyb.event(mode, point(p, t, y), internal_states(y), next);
    else return hyb.event(mode, point(p, t, y), y.s, next);
  }
  double event_at(const Point& pt, const State& y, Mode mode, Mode* next) const noexcept {
    if constexpr (kMore) return hyb.event(mode, pt, internal_states(y), next);
    else return hyb.event(mode, pt, y.s, next);
  }
  Mode classify(const Point& pt, const State& y) const noexcept {
    if constexpr (kMore) return hyb.classify(pt, internal_states(y));
    else return hyb.classify(pt, y.s);
  }
  /// The mode at t from the state (ctx: at a stage start, the last stage's mode where it holds).
  Mode start_mode(const Plant& p, double t, State& y,
                  const RunContext* ctx = nullptr) const noexcept {
    const Point pt = point(p, t, y);
    Mode m;
    if (ctx) {
      if constexpr (kMore) m = stage_start_mode(*ctx, hyb, pt, internal_states(y));
      else m = stage_start_mode(*ctx, hyb, pt, y.s);
    } else {
      m = classify(pt, y);
    }
    hyb.on_enter(m, pt, y, m);
    return m;
  }
  Mode enter(Mode from, Mode to, const Plant& p, double t, State& y) const noexcept {
    return enter_at(from, to, point(p, t, y), y);
  }
  /// The same at the point pt of y.
  Mode enter_at(Mode from, Mode to, const Point& pt, State& y) const noexcept {
    const Mode m = hyb.settle(from, to, pt);
    hyb.on_enter(m, pt, y, from);
    return m;
  }
};

template <class State>
struct StepOutT {
  State y;
  DerivOf<State> k_end;  // f(y_new): first stage of the next step (FSAL)
  double err;            // weighted error norm (<= 1 accepted)
};

/// Weights turning local errors into forces [N]: x by k_d, x' by z_v, s by k_t (the model's
/// error_weights) and, in a state with further internal states, those by k_zs.
template <class State>
struct ErrorScaleT {
  double k_d, z_v, k_t, inv_tol;
};
template <int Z>
struct ErrorScaleT<StateStorage<Z, true>> {
  double k_d, z_v, k_t, inv_tol;
  std::array<double, Z - 1> k_zs{};
  /// How many of the further internal states move (the model's active_states() - 1, e.g. GMS
  /// with 4 of its 12 element slots): the others stay 0 and are skipped, exactly.
  std::size_t nzs = Z - 1;
};

#include "adaptive_support.inc"  // (inside this anonymous namespace)

template <class Sys, class State = typename Sys::State, class Deriv = typename Sys::Deriv,
          class StepOut = StepOutT<State>>
StepOut dp5_step(const Sys& sys, const Plant& p, double t, const State& y, const Deriv& k1,
                 double h, typename Sys::Mode mode, double L, const ErrorScaleT<State>& es,
                 const BaseAtStages* base = nullptr,
                 std::array<State, kStages>* k_out = nullptr, double s_eq = 0.0) {
  // Integrating factors e_i = exp(-L c_i h) (L = 0 -> plain Dormand-Prince), applied to the
  // strain's deviation u = s - s_eq from a constant s_eq (exact for any constant: u' = s').
  std::array<double, kStages> ef;
  for (int i = 0; i < kStages; ++i) ef[i] = L == 0.0 ? 1.0 : std::exp(-L * kC[i] * h);
  const double u0 = y.s - s_eq;
  // k[i].s holds N_i = s'_i + L (s_i - s_eq); written into *k_out where given (no copy)
  std::array<State, kStages> k_own;
  std::array<State, kStages>& k = k_out ? *k_out : k_own;
  Deriv kd;  // the last stage's right-hand side (the 7th: f(y_new), FSAL)
  constexpr bool kMore = requires(State s) { s.zs; };  // internal states beyond s (plain DP5)
  // Stage derivatives member by member, of the internal states only those that move (the
  // others are never read): a whole 12-slot State per stage was ~5 % of the GMS run.
  auto set_k = [&](State& ki, const Deriv& d, double u) {
    ki.x = d.d.x;
    ki.v = d.d.v;
    ki.s = d.d.s + L * u;
    if constexpr (kMore)
      for (std::size_t q = 0; q < es.nzs; ++q) ki.zs[q] = d.d.zs[q];
  };
  set_k(k[0], k1, u0);
  for (int i = 1; i < kStages; ++i) {
    State yi = y;
    double ss = 0.0;
    for (int j = 0; j < i; ++j) {
      const double a = kA[i][j];
      if (a == 0.0) continue;
      yi.x += h * a * k[j].x;
      yi.v += h * a * k[j].v;
      ss += a * (ef[i] / ef[j]) * k[j].s;
      if constexpr (kMore)
        for (std::size_t q = 0; q < es.nzs; ++q) yi.zs[q] += h * a * k[j].zs[q];
    }
    const double ui = ef[i] * u0 + h * ss;
    yi.s = s_eq + ui;
    if (Sys::kReversals && base)
      kd = sys.eval_ub(p, t + kC[i] * h, yi, base->ub[i], base->ab[i], mode);
    else
      kd = sys.eval(p, t + kC[i] * h, yi, mode);
    set_k(k[i], kd, ui);
  }
  // Stage 7 is evaluated at the 5th-order solution (FSAL), so y_new is the stage-7 input.
  State y_new = y;
  double ss = 0.0, ex = 0.0, ev = 0.0, esum = 0.0;
  for (int j = 0; j < kStages; ++j) {
    y_new.x += h * kB[j] * k[j].x;
    y_new.v += h * kB[j] * k[j].v;
    ss += kB[j] * (ef[6] / ef[j]) * k[j].s;
    ex += kE[j] * k[j].x;
    ev += kE[j] * k[j].v;
    esum += kE[j] * (ef[6] / ef[j]) * k[j].s;
  }
  y_new.s = s_eq + (ef[6] * u0 + h * ss);
  if constexpr (kMore) {
    double e = std::max({es.k_d * std::fabs(h * ex), es.z_v * std::fabs(h * ev),
                         es.k_t * std::fabs(h * esum)});
    for (std::size_t q = 0; q < es.nzs; ++q) {
      double ez = 0.0;
      for (int j = 0; j < kStages; ++j) {
        y_new.zs[q] += h * kB[j] * k[j].zs[q];
        ez += kE[j] * k[j].zs[q];
      }
      e = std::max(e, es.k_zs[q] * std::fabs(h * ez));
    }
    return {y_new, kd, e * es.inv_tol};
  } else {
    const double err = std::max({es.k_d * std::fabs(h * ex), es.z_v * std::fabs(h * ev),
                                 es.k_t * std::fabs(h * esum)}) *
                       es.inv_tol;
    return {y_new, kd, err};
  }
}

// PI step-size controller exponents for the order-5 error estimate: Hairer's dopri5 values
// (beta = 0.04, alpha = 1/5 - 0.75 beta). Measured on the 20 s LuGre seed runs against plain
// I-control (beta = 0): beta = 0.04 removes ~40 % of the rejected steps and gives 1.4x smaller
// F_d errors for the same work at v_a = 4 mm/s; beta = 0.08 is slightly better still in error per
// step but takes 20 % more steps at a given rtol; beta = 0.13 stalls (tiny steps).
constexpr double kBeta = 0.04;
// lambda h from which the step uses the integrating factor (below: plain Dormand-Prince).
// With the factor applied to the deviation from the quasi-steady strain (see lawson_factor),
// measured on the 20 s LuGre runs at rtol 1e-4 .. 3e-4: 1 takes ~10 % fewer steps at 4 mm/s
// than 3 (the old value, chosen when the factor acted on s itself) at the same errors; 0.5 and
// 0.25 take a few % fewer steps still, with less regular errors.
constexpr double kLawsonMin = 1.0;
constexpr double kAlpha = 0.2 - 0.75 * kBeta;
// Fractional part of the golden ratio: spreads where the reversal falls in the cut step.
constexpr double kGoldenFrac = 0.6180339887498949;
constexpr double kLogErrFloor = -9.210340371976184;  // log(1e-4): floor of the PI memory

/// adaptive()'s state within one stage, carried from step to step (y and the step size h are
/// carried by drive_stages, also between the stages).
template <class Sys>
struct StageLoop {
  double t;                 ///< time reached [s]
  typename Sys::Mode mode;  ///< a switching system's mode (0 for a smooth one)
  typename Sys::Deriv k1;   ///< f(t, y): the first stage of the next step (FSAL)
  int zero_switches = 0;    ///< zero-length switches in a row
  double theta = 0.0;       ///< reversal position in the cut step (low-discrepancy sequence)
  double h_rev = 0.0;       ///< step proposed after the last accepted reversal step (0: none yet)
  BaseAtStages base;        ///< base motion at the stage times (smooth models)
  std::array<typename Sys::State, kStages> kst;  ///< stages of the last step (dense output)
  double log_err_prev = kLogErrFloor;  ///< PI controller memory: log of Hairer's initial 1e-4
  bool no_growth = false;  ///< the next step may not grow: the last attempt was rejected, or
                          ///< (GMS) a switch cut it

  StageLoop(const Sys& sys, const Plant& p, double t0, typename Sys::State& y,
            const RunContext& ctx)
      : t(t0), mode(sys.start_mode(p, t0, y, &ctx)), k1(sys.eval(p, t0, y, mode)) {}
};

#include "adaptive_switch.inc"  // (inside this anonymous namespace): locate_in_step

/// The stage metrics and the trace at an accepted time t [s]: the forces of d, the state y.
template <class Sys>
inline void record_sample(RunContext& ctx, StageAccumulator& acc, const Sys& sys, double t,
                          const typename Sys::Deriv& d, const typename Sys::State& y) {
  acc.sample(t, d.F_d, d.F_f);
  const auto& model = sys.base_model();
  if constexpr (HasPrimaryState<std::remove_cvref_t<decltype(model)>>) {
    if (ctx.trace.active()) ctx.trace.add({t, d.F_d, d.F_f, y.x, y.v, primary_state(model, y)});
  } else {
    if (ctx.trace.active()) ctx.trace.add({t, d.F_d, d.F_f, y.x, y.v, y.s});
  }
}

/// The step to try from s.t [s]: h, or shorter where v_r reverses inside it (Sys::kReversals;
/// starts s.base at s.t and sets vr0, v_r there [m/s]).
template <class Sys>
inline double reversal_limited_step(const Plant& p, const typename Sys::State& y, double h,
                                    StageLoop<Sys>& s, double& vr0) {
  double h_try = h;
  if constexpr (Sys::kReversals) {
    // Reversal step limiter. Where v_r changes sign, |v_r| has a kink and the Stribeck
    // factor exp(-(v_r/v_s)^2) a bump ~v_s / |v_r'| wide (~9 us at 4 mm/s, 1.5 kHz): a step
    // across it needs to be ~5x shorter than the steps just before, where the bristle is
    // saturated and the error estimate is small. The controller learnt that anew at every
    // reversal through 2-4 rejected steps (24 % of all attempts at 4 mm/s, err up to 100).
    // Linear extrapolation of v_r tells whether the next reversal falls inside the step; if
    // so the step is cut to h_rev, the controller's proposal after the previous accepted
    // reversal step (so it follows the tolerance). Measured on the 20 s LuGre run at 4 mm/s
    // (rtol 1e-4 .. 3e-4): rejections 160k -> 60k, and the F_d error 2e-4 N or less at every
    // rtol instead of 3e-4 .. 4e-3 N. The error is a bias of the mean friction from the
    // velocity error of the reversal steps (it appears during the first second of
    // vibration and then stays constant); placing the reversal in the MIDDLE of every cut
    // step made that error systematic (up to 3.9e-3 N at rtol 2.5e-4), ending steps AT the
    // predicted reversal was 5 % cheaper but less regular (7e-5 .. 6e-4 N).
    s.base.start(p, s.t);
    vr0 = y.v - s.base.ub[0];
    const double ar0 = s.k1.d.v - s.base.ab0;
    if (vr0 * ar0 < 0.0) {
      const double t_c = -vr0 / ar0;  // time to the reversal [s]
      if (t_c < h_try && s.h_rev > 0.0) {
        if (t_c > 2.0 * s.h_rev) {
          // Approach step: end the step (0.05 .. 0.95) h_rev before the predicted reversal,
          // the position taken from a golden-ratio sequence so that it is spread evenly
          // over the steps that then contain the reversal. Before, the approach ran in
          // steps of h_rev (4-5 per reversal, err ~1e-6); at 4 mm/s and rtol 3e-4 this
          // cut 430k -> 360k attempts for 2.6e-4 -> 3.7e-4 N. At most 0.6 of the
          // controller's step: the approach runs into the reversal, where the step the
          // controller learnt away from it fails (err ~6, one rejection per reversal);
          // 0.6 gave 385k -> 371k attempts and 3.7e-4 -> 2.8e-4 N (0.5, 0.75: no better).
          s.theta += kGoldenFrac;
          if (s.theta >= 1.0) s.theta -= 1.0;
          h_try = std::min(t_c - (0.05 + 0.9 * s.theta) * s.h_rev, 0.6 * h_try);
        } else {
          h_try = std::min(h_try, s.h_rev);
        }
      }
    }
  }
  return h_try;
}

/// A step's integrating factor: its rate L [1/s] (0: plain Dormand-Prince) and the strain s_eq
/// about which it acts.
struct LawsonFactor {
  double L = 0.0, s_eq = 0.0;
};

/// The integrating factor of the step [s.t, s.t + hh] from y (vr0: v_r at s.t [m/s]); s.base
/// gets the step's stage times (Sys::kReversals; smooth systems have no factor otherwise).
template <class Sys>
inline LawsonFactor lawson_factor(const Sys& sys, const Plant& p, const typename Sys::State& y,
                                  double hh, double vr0, StageLoop<Sys>& s) {
  // Integrating factor only where the bristle equation is stiff for this step. Where
  // lambda h < kLawsonMin plain Dormand-Prince is stable, and far more accurate: the
  // Lawson scheme is exact only for a constant lambda, and lambda ~ |v_r| sweeps from 0 to
  // ~4e4 1/s within a step around every zero of v_r under vibration. Always-on, it left a
  // systematic error per v_r crossing that the error estimate did not see: 7.7e-4 N RMS at
  // rtol 1e-6 on the 20 s LuGre run at v_a = 4 mm/s, 2e-6 N with this rule (same work).
  // Keep exp(-L h) well inside double range; never binding for physical parameters.
  //
  // The factor acts on the deviation of s from s_eq = v_r0 / lambda_0, the strain at which
  // s' = v_r - lambda s vanishes at the step start (sgn(v_r) g(v_r)). On s itself, Lawson's
  // scheme integrates exp(L tau) times the forcing v_r, which polynomials fit badly when
  // L h >> 1: during the still base's slips (s at its steady value, lambda h ~ 5-15) every
  // such step was rejected (err 2-66), 3 rejections for every 2 accepted plain steps at
  // lambda h < 3, 25 % of all attempts. About s_eq the forcing is ~0 and the steps pass:
  // still base, rtol 3e-4: 251k steps + 86k rejections -> 200k + 80 (dt_max-limited).
  LawsonFactor f;
  if constexpr (Sys::kReversals) {
    s.base.stages(p, s.t, hh);
    const double lam = sys.lambda_ub(y, s.base.ub[0]);
    f.L = std::min(lam, 600.0 / hh);
    if (f.L * hh < kLawsonMin) f.L = 0.0;
    if constexpr (Sys::kNewtonCentre) {
      if (f.L > 0.0) f.s_eq = y.s + s.k1.d.s / lam;  // s.k1: s' at (s.t, y)
    } else {
      if (f.L > 0.0) f.s_eq = vr0 / lam;
    }
  }
  return f;
}

/// A rejected step of length hh [s] with the error err: h [s] becomes the shorter step to try.
/// False when that is too short (the run diverged; ctx filled).
template <class Sys>
inline bool reject_step(RunContext& ctx, const Plant& p, StageLoop<Sys>& s,
                        const typename Sys::State& y, double err, double hh, double& h) {
  ++ctx.result.rejected;
  s.no_growth = true;
  const double fac = std::isfinite(err) ? 0.9 * std::pow(err, -kAlpha) : 0.1;
  h = hh * std::clamp(fac, 0.1, 0.9);
  if (h < 1e-14 * std::max(1.0, s.t)) {
    fail_diverged(ctx, s.t, y, p.base_velocity(s.t), h);
    return false;
  }
  return true;
}

/// The step [s] after an accepted step of length hh [s] with the error err, at most dt_max.
/// PI step-size control (Gustafsson 1991; Hairer, Norsett & Wanner, Solving ODEs I,
/// IV.2 / dopri5): h_new = h 0.9 err^-alpha err_prev^beta, no growth right after a rejection.
/// One log and one exp instead of two pow (pow was 8 % of the run time, perf).
template <class Sys>
inline double pi_step(StageLoop<Sys>& s, double err, double hh, double dt_max) {
  const double log_err = std::log(std::max(err, 1e-10));
  double fac = 0.9 * std::exp(kBeta * s.log_err_prev - kAlpha * log_err);
  fac = std::clamp(fac, 0.2, s.no_growth ? 1.0 : 5.0);
  s.log_err_prev = std::max(log_err, kLogErrFloor);
  s.no_growth = false;
  return std::min(hh * fac, dt_max);
}

/// A switching system after the accepted step out of length hh [s] from (s.t, y) with the
/// integrating-factor rate L: where its event fired inside, the step is cut to the switch (out
/// becomes the step to it, y its state, its old mode's forces recorded) and the new mode is
/// entered. Returns the time the step reached [s].
template <class Sys, class StepOut>
inline double take_switch(RunContext& ctx, StageAccumulator& acc, const Sys& sys,
                          const ErrorScaleT<typename Sys::State>& es, const Plant& p,
                          StageLoop<Sys>& s, typename Sys::State& y, StepOut& out, double hh,
                          double L) {
  double t_new = s.t + hh;
  typename Sys::Mode next{};
  // A run of zero-length switches means the modes disagree at a tangency; classify from
  // the state instead and take the step as computed, which always makes progress.
  if (s.zero_switches > 8) {
    s.zero_switches = 0;
    s.mode = sys.start_mode(p, t_new, out.y);
    out.k_end = sys.eval(p, t_new, out.y, s.mode);
  } else if (const double fh = event_at_end(sys, p, s.base, t_new, out.y, s.mode, &next);
             fh < 0.0) {
    const SwitchSearch<Sys> q(sys, p, es, s, y, out, hh, L, fh);
    StepOut ob;
    const double b = locate_in_step(q, ob);
    t_new = (b == hh) ? t_new : s.t + b;
    // GMS (kReversals): one point at the switch (base motion by angle addition; entering a mode
    // changes element forces only) for the event, the old mode's forces there and the new
    // mode's. Karnopp and the Reset Integrator take it from the plant, after on_enter too.
    Point pt{};
    if constexpr (Sys::kReversals) {
      pt = q.point_at(b, ob.y);
      sys.event_at(pt, ob.y, s.mode, &next);
      if (b < hh) ob.k_end = sys.eval_at(p, pt, ob.y, s.mode);
    } else {
      sys.event(p, s.t + b, ob.y, s.mode, &next);
    }
    out = ob;
    y = out.y;
    record_sample(ctx, acc, sys, t_new, out.k_end, y);  // the old mode's forces (F_f jumps)
    if constexpr (Sys::kReversals) {
      s.mode = sys.enter_at(s.mode, next, pt, y);
      out.k_end = sys.eval_at(p, pt, y, s.mode);
    } else {
      s.mode = sys.enter(s.mode, next, p, t_new, y);
      out.k_end = sys.eval(p, t_new, y, s.mode);
    }
    out.y = y;  // keep the projection onto the new mode's set (on_enter)
    ++ctx.result.switches;
    s.zero_switches = b < 1e-9 * hh ? s.zero_switches + 1 : 0;
    // GMS: the cut step's error says nothing of the new mode (an element entering slip relaxes at
    // C_el); letting the next step grow up to 5x made 141k rejections per 149k switches at
    // 4 mm/s, rtol 1e-4, and a 4.5e-4 F_ref trace error at rtol 3e-4 (6.7e-5 without growth).
    if constexpr (Sys::kReversals) s.no_growth = true;
  }
  return t_new;
}

/// One stage [t0, t1] [s] of adaptive(): steps from y with the step size h, both carried on.
/// False when the run diverged (ctx filled).
template <class Sys>
inline bool adaptive_stage(RunContext& ctx, const Sys& sys,
                           const ErrorScaleT<typename Sys::State>& es, const Plant& p, double t0,
                           double t1, StageAccumulator& acc, typename Sys::State& y, double& h) {
  using StepOut = StepOutT<typename Sys::State>;
  const IntegratorOptions& opt = ctx.cfg.integrator;
  const double dt_max = stage_dt_max<Sys>(ctx.cfg, p);
  h = std::min(h, dt_max);  // a still stage's longer step does not carry into a vibrating one
  StageLoop<Sys> s(sys, p, t0, y, ctx);
  record_sample(ctx, acc, sys, s.t, s.k1, y);
  while (s.t < t1) {
    if (static_cast<double>(ctx.result.steps + ctx.result.rejected) > opt.max_steps) {
      ctx.result.status = RunStatus::kDiverged;
      ctx.result.t_end = s.t;
      ctx.result.reason = "step limit reached at t = " + std::to_string(s.t) + " s";
      return false;
    }
    double vr0 = 0.0;  // v_r at the step start [m/s] (Sys::kReversals)
    const double h_try = reversal_limited_step(p, y, h, s, vr0);
    const bool last = s.t + h_try >= t1 * (1.0 - 1e-15) - 1e-15;
    const double hh = last ? t1 - s.t : h_try;
    const LawsonFactor f = lawson_factor(sys, p, y, hh, vr0, s);
    StepOut out = dp5_step(sys, p, s.t, y, s.k1, hh, s.mode, f.L, es, &s.base,
                           Sys::kEvents ? &s.kst : nullptr, f.s_eq);
    if constexpr (Sys::kEvents && Sys::kReversals)  // GMS: see kReversalErrorWeight
      if (vr0 * (out.y.v - s.base.ub[kStages - 1]) <= 0.0) out.err *= kReversalErrorWeight;
    if (!(out.err <= 1.0)) {  // also catches NaN
      if (!reject_step(ctx, p, s, y, out.err, hh, h)) return false;
      continue;
    }
    double t_new = s.t + hh;
    if constexpr (Sys::kEvents) t_new = take_switch(ctx, acc, sys, es, p, s, y, out, hh, f.L);
    y = out.y;
    s.t = t_new;
    s.k1 = out.k_end;
    if (after_step(p, s.t, y)) s.k1 = sys.eval(p, s.t, y, s.mode);  // dwell_time's clock restarted
    ++ctx.result.steps;
    if (!ctx.guard.ok(y)) {
      fail_diverged(ctx, s.t, y, p.base_velocity(s.t), hh);
      return false;
    }
    record_sample(ctx, acc, sys, s.t, s.k1, y);
    h = pi_step(s, out.err, hh, dt_max);
    if constexpr (Sys::kReversals) {
      if (vr0 * (y.v - s.base.ub[kStages - 1]) <= 0.0) s.h_rev = h;  // this step reversed v_r
    }
    if (last) s.t = t1;
  }
  if constexpr (Sys::kEvents) ctx.mode.put(s.mode);
  return true;
}

/// y: the state at t = 0 (the model's initial_state).
template <class Sys>
void adaptive(RunContext& ctx, const Sys& sys, const ErrorScaleT<typename Sys::State>& es,
              typename Sys::State y) {
  const IntegratorOptions& opt = ctx.cfg.integrator;
  double h = std::min(opt.dt, opt.dt_max);
  drive_stages(ctx, y, &h, [&](const Plant& p, double t0, double t1, StageAccumulator& acc) {
    return adaptive_stage(ctx, sys, es, p, t0, t1, acc, y, h);
  });
}

/// A model's weights of the local errors [N per unit] with the tolerance folded in.
template <class M>
ErrorScaleT<StateOf<M>> error_scale(const SimConfig& c, const M& model) {
  const double f_ref = force_scale(c, model);
  const double inv_tol = 1.0 / (c.integrator.atol + c.integrator.rtol * f_ref);
  const auto w = model.error_weights(c.drive);
  ErrorScaleT<StateOf<M>> es{c.drive.k_d, w.v, 0.0, inv_tol};  // no internal state: s stays 0
  if constexpr (M::kStates > 0) es.k_t = w.z[0];
  if constexpr (M::kStates > 1)
    for (int q = 0; q < M::kStates - 1; ++q) es.k_zs[q] = w.z[q + 1];
  if constexpr (M::kStates > 1 && requires { model.active_states(); })
    es.nzs = static_cast<std::size_t>(std::clamp(model.active_states(), 1, M::kStates) - 1);
  return es;
}

}  // namespace

void run_adaptive(RunContext& ctx) {
  const SimConfig& c = ctx.cfg;
  visit_model(c.model, [&]<class M>(std::type_identity<M>) {
    const M model = make_model<M>(c);
    if constexpr (OwnStepper<M>) {  // the model's own integrator (run_stepper.h)
      run_stepper(ctx, model);
    } else {
      ctx.guard = make_guard(c, model);
      ctx.primary = primary_state_fn(model);
      const auto es = error_scale(c, model);
      if constexpr (M::kInfo.model_class == ModelClass::kSwitching) {
        const typename M::Hybrid h(model, c.drive);
        adaptive(ctx, HybridSys<typename M::Hybrid>{h}, es, initial_state(model, c.drive));
      } else {
        const auto scalar = scalar_form(model);
        adaptive(ctx, SmoothSys<decltype(scalar)>{scalar}, es, initial_state(model, c.drive));
      }
    }
  });
}

}  // namespace stickslip::engine::detail
