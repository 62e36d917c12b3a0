#pragma once
// Internal: the seed's system as a plain right-hand side for any registered model, the glue
// between a model's traits and the integrators (its scalar form, hybrid form, internal states,
// error weights, divergence guard), and the stage loop shared by every integrator. Not part of
// the public API.

#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <string>
#include <type_traits>
#include <vector>

#include "extended.h"
#include "stickslip/engine/exp.h"
#include "stickslip/engine/metrics.h"
#include "stickslip/engine/params.h"
#include "stickslip/engine/simulate.h"
#include "trace.h"

namespace stickslip::engine::detail {

/// cos(x) and sin(x) for |x| <= 1 by their Taylor series (Horner in x^2): the small offsets of
/// the base's phase inside a step, added to one glibc sin/cos pair of the large phase (angle
/// addition) by the adaptive and the Rosenbrock integrators.
inline void small_sincos(double x, double* c_out, double* s_out) noexcept {
  // |x| <= 1: the first omitted terms are x^20/20! < 4.2e-19 and x^19/19! < 8.3e-18.
  const double x2 = x * x;
  double c = kInvFactorial[18], sn = kInvFactorial[19];
  for (int k = 16; k >= 0; k -= 2) {  // Horner in x^2, alternating signs
    c = kInvFactorial[k] - x2 * c;
    sn = kInvFactorial[k + 1] - x2 * sn;
  }
  *c_out = c;
  *s_out = sn * x;
}

/// Body, drive and the current stage's base motion. u'(t) = v_a cos(w (t - t0)).
struct Plant {
  double m_inv, k_d, v_d;
  double v_a = 0.0, w = 0.0, t0 = 0.0;
  ExtRuntime* ext = nullptr;  ///< catalogue extension (nullptr: the base model)
  double base_velocity(double t) const noexcept {
    return v_a == 0.0 ? 0.0 : v_a * std::cos(w * (t - t0));
  }
  double base_accel(double t) const noexcept {
    return v_a == 0.0 ? 0.0 : -v_a * w * std::sin(w * (t - t0));
  }
  Point point(double t, double x, double v) const noexcept {
    if (ext) [[unlikely]]
      return {drive_force(t, x) + ext->c_d * (v_d - v), v - base_velocity(t), base_accel(t),
              modulation(t, x, v - base_velocity(t)), ext->sigma2};
    return {drive_force(t, x), v - base_velocity(t), base_accel(t)};
  }
  /// v_r: the relative velocity x' - u' [m/s].
  Mod modulation(double t, double x, double v_r) const noexcept {
    return ext ? ext->modulation(t, x, v_r, v_a, w, t0) : Mod{};
  }
  double drive_force(double t, double x) const noexcept { return k_d * fmadd(v_d, t, -x); }
};

inline Plant make_plant(const SimConfig& cfg) {
  return Plant{1.0 / cfg.drive.m, cfg.drive.k_d, cfg.drive.v_d};
}

/// Derivative plus the forces it came from.
template <class S>
struct DerivOf {
  S d;
  double F_d, F_f;
};
template <int Z>
using DerivT = DerivOf<StateT<Z>>;
/// The state and derivative of the models with at most one internal state (all of the seed's).
using State = StateT<1>;
using Deriv = DerivT<1>;

// ------------------------------------------------------------------ model glue (traits hooks)

template <class M>
using StateOf = StateT<M::kStates>;

/// The internal states of y as a model's right-hand side reads them: the double s (a model with
/// at most one internal state) or an array.
template <int Z, bool B>
auto states_of(const StateStorage<Z, B>& y) noexcept {
  if constexpr (Z <= 1) return y.s;
  else return internal_states(y);
}
template <class M>
concept WithEffects = requires(const M& m, const EffectTerms& r, const Mod& mod,
                               const StateOf<M>& y) { m.eval_ext(r, mod, 0.0, states_of(y), 0.0); };
template <class M>
concept WithLambda = requires(const M& m) { m.lambda(0.0); };

/// A derivative from a hybrid form's friction evaluation (pt: the point it was evaluated at).
template <class S, class Eval>
inline DerivOf<S> frozen_deriv(const Plant& p, const Point& pt, const S& y,
                               const Eval& fe) noexcept {
  if constexpr (std::is_same_v<Eval, FrictionEval>) {
    return {{y.v, (pt.F_d - fe.F_f) * p.m_inv, fe.ds}, pt.F_d, fe.F_f};
  } else {
    DerivOf<S> d{{y.v, (pt.F_d - fe.F_f) * p.m_inv, fe.dz[0]}, pt.F_d, fe.F_f};
    for (std::size_t k = 1; k < fe.dz.size(); ++k) d.d.zs[k - 1] = fe.dz[k];
    return d;
  }
}

/// The form single trajectories evaluate (M::Scalar when the model has one, e.g. LuGre's
/// branch past the Stribeck flush point).
template <class M>
auto scalar_form(const M& m) {
  if constexpr (requires { typename M::Scalar; }) return typename M::Scalar(m);
  else return m;
}

/// The state at t = 0: the body at rest at x = 0 and the model's initial internal states.
template <class M>
StateOf<M> initial_state(const M& m, const Drive& d) {
  StateOf<M> y{};
  if constexpr (requires { m.initial_z(d); }) {
    const auto z = m.initial_z(d);
    for (int k = 0; k < M::kStates; ++k) internal(y, k) = z[static_cast<std::size_t>(k)];
  }
  (void)m;
  (void)d;
  return y;
}

/// A model may name a primary internal state other than s for the trace and the result
/// (primary_state(z), z its internal states), e.g. GMS the summed element force.
template <class M>
concept HasPrimaryState =
    requires(const M& m, const StateOf<M>& y) { m.primary_state(internal_states(y)); };
/// The model's primary internal state: the trace's and the result's "s".
template <class M>
double primary_state(const M& m, const StateOf<M>& y) noexcept {
  if constexpr (HasPrimaryState<M>) return m.primary_state(internal_states(y));
  else return y.s;
}

/// The run's force scale F_ref [N]: the model's force_scale() when it has one, else the
/// contact's friction level max(F_S, F_C) (tolerance and divergence scale).
template <class M>
double force_scale(const SimConfig& cfg, const M& m) {
  if constexpr (requires { m.force_scale(); }) return m.force_scale();
  (void)m;
  return std::max(cfg.friction["F_S"], cfg.friction["F_C"]);
}

/// A model's right-hand side at time t, state y and base velocity ub [m/s]: the derivative and the
/// forces it came from. A model with catalogue effects (ModelInfo::effects) evaluates them with
/// its eval_ext when the plant carries one.
template <class Model>
inline DerivT<Model::kStates> rhs(const Model& model, const Plant& p, double t,
                                 const StateOf<Model>& y, double ub) noexcept {
  if constexpr (requires { Model::kInfo; })  // (not the batched forms, which run without effects)
    static_assert(!Model::kInfo.effects || WithEffects<Model>,
                  "a model with ModelInfo::effects = true needs eval_ext (see models/lugre.h)");
  if constexpr (Model::kStates <= 1) {
    if constexpr (WithEffects<Model>) {
      if (p.ext) [[unlikely]] {
        const double F_d = p.drive_force(t, y.x) + p.ext->c_d * (p.v_d - y.v);
        const FrictionEval fe =
            model.eval_ext(*p.ext, p.modulation(t, y.x, y.v - ub), y.v - ub, y.s, F_d);
        return {{y.v, (F_d - fe.F_f) * p.m_inv, fe.ds}, F_d, fe.F_f};
      }
    }
    const double F_d = p.drive_force(t, y.x);
    const FrictionEval fe = model(y.v - ub, y.s, F_d);
    return {{y.v, (F_d - fe.F_f) * p.m_inv, fe.ds}, F_d, fe.F_f};
  } else {  // several internal states: the model reads and returns them as arrays
    double F_d = p.drive_force(t, y.x);
    FrictionEvalN<Model::kStates> fe;
    if constexpr (WithEffects<Model>) {
      if (p.ext) [[unlikely]] {
        F_d += p.ext->c_d * (p.v_d - y.v);
        fe = model.eval_ext(*p.ext, p.modulation(t, y.x, y.v - ub), y.v - ub,
                            internal_states(y), F_d);
      } else {
        fe = model(y.v - ub, internal_states(y), F_d);
      }
    } else {
      fe = model(y.v - ub, internal_states(y), F_d);
    }
    DerivT<Model::kStates> d{{y.v, (F_d - fe.F_f) * p.m_inv, fe.dz[0]}, F_d, fe.F_f};
    for (int k = 1; k < Model::kStates; ++k) d.d.zs[k - 1] = fe.dz[k];
    return d;
  }
}

/// After every accepted step: the dwell_time extension's stick clock restarts while slipping;
/// the aging extension's contact age advances to t. Returns true when the friction law changed
/// at t (so a cached derivative at t is stale).
template <class S>
inline bool after_step(const Plant& p, double t, const S& y) noexcept {
  if (p.ext && p.ext->tracks_age()) [[unlikely]]
    return p.ext->age(t, y.v - p.base_velocity(t));
  if (p.ext && p.ext->tracks_stick() && std::fabs(y.v - p.base_velocity(t)) > p.ext->e.dwell_v) {
    const bool changed = p.ext->e.dwell_A != 0.0 && t > p.ext->t_slip;
    p.ext->t_slip = t;
    return changed;
  }
  return false;
}

// ------------------------------------------------------------------ divergence

/// Limits beyond which a run is declared diverged (never reached by a healthy run).
struct DivergenceGuard {
  double v_limit;  ///< [m/s]
  double s_limit;  ///< [unit of s]
  std::array<double, kMaxInternalStates - 1> zs_limit{};  ///< further internal states
  template <class S>
  bool ok(const S& y) const noexcept {
    if constexpr (requires { y.zs; }) {
      bool in = std::fabs(y.v) < v_limit && std::fabs(y.s) < s_limit && std::isfinite(y.x);
      for (std::size_t k = 0; k < y.zs.size(); ++k) in = in && std::fabs(y.zs[k]) < zs_limit[k];
      return in;
    } else {
      return std::fabs(y.v) < v_limit && std::fabs(y.s) < s_limit && std::isfinite(y.x);
    }
  }
};

/// Far beyond anything physical: drive, vibration and slip velocities are mm/s to cm/s, and the
/// internal states never exceed a few times the model's state_scale.
template <class M>
DivergenceGuard make_guard(const SimConfig& cfg, const M& m) {
  double v_a_max = 0.0;
  for (const auto& s : cfg.stages) v_a_max = std::max(v_a_max, s.v_a);
  const double f_ref = force_scale(cfg, m);
  const double v_slip = f_ref / std::sqrt(cfg.drive.k_d * cfg.drive.m);
  const auto scale = m.state_scale(f_ref);
  DivergenceGuard g{1e3 * (cfg.drive.v_d + v_a_max + v_slip), HUGE_VAL};  // no state: s stays 0
  if constexpr (std::tuple_size_v<decltype(scale)> > 0) g.s_limit = 1e3 * scale[0];
  for (std::size_t k = 1; k < scale.size(); ++k) g.zs_limit[k - 1] = 1e3 * scale[k];
  return g;
}

/// Why a run left the physical range, naming the likely cause: the model's stiff rate (the
/// bristle rate of Dahl and LuGre) against explicit RK4's stability limit, or the step.
template <class M>
[[gnu::noinline, gnu::cold]] std::string divergence_reason(const M& m, double t, double v,
                                                           double s, double v_r, double h) {
  char buf[512];
  if constexpr (requires { m.stiff_rate(v_r); }) {
    const double lam = m.stiff_rate(v_r);
    std::snprintf(buf, sizeof buf,
                  "state left the physical range at t = %.9g s (x' = %.3g m/s, s = %.3g m); "
                  "step %.3g s times %s = %.3g 1/s is %.3g, and explicit RK4 is unstable above "
                  "about 2.8: reduce dt or use the adaptive integrator",
                  t, v, s, h, M::kStiffRate, lam, h * lam);
  } else {
    std::snprintf(buf, sizeof buf,
                  "state left the physical range at t = %.9g s (x' = %.3g m/s, s = %.3g m) "
                  "with step %.3g s: reduce dt",
                  t, v, s, h);
  }
  return buf;
}

// ------------------------------------------------------------------ the stage loop

struct CheckpointData;

/// A switching model's mode at the end of a stage, carried into the next stage and through
/// checkpoints (a GMS element slipping below its limit under a rising Stribeck curve must go on
/// slipping; the state alone says it sticks). Any hybrid form's Mode (trivially copyable, <= 16
/// bytes) as bytes, so that CheckpointData stays one type for every model.
class CarriedMode {
 public:
  template <class M>
  void put(const M& m) noexcept {
    static_assert(std::is_trivially_copyable_v<M> && sizeof(M) <= kBytes);
    std::memcpy(bytes_.data(), &m, sizeof m);
    valid_ = true;
  }
  /// The mode put last into *m; false (m untouched) when none was put (the run's first stage).
  template <class M>
  bool get(M* m) const noexcept {
    static_assert(std::is_trivially_copyable_v<M> && sizeof(M) <= kBytes);
    if (!valid_) return false;
    std::memcpy(m, bytes_.data(), sizeof *m);
    return true;
  }

 private:
  static constexpr std::size_t kBytes = 16;
  std::array<unsigned char, kBytes> bytes_{};
  bool valid_ = false;
};

/// What an integrator needs for one run: stage loop bookkeeping is shared by all of them.
struct RunContext {
  const SimConfig& cfg;
  SimResult& result;
  TraceRecorder trace;
  DivergenceGuard guard{};  ///< set by the integrator from the model (make_guard)
  /// The result's s_end from the final state, for models with a primary_state (nullptr: y.s);
  /// set by the integrator.
  std::function<double(const double* z)> primary{};
  ExtRuntime ext{};  ///< catalogue extension state (kind none: the base model)
  /// Continue from this run's end of a stage (simulate_from; result, trace and ext are already
  /// restored; drive_stages restores the state and the step size).
  const CheckpointData* resume = nullptr;
  /// Save the run here after its first save_after stages (simulate with a checkpoint).
  CheckpointData* save = nullptr;
  std::size_t save_after = 0;
  /// A switching model's mode at the end of the last stage (set by the integrator; drive_stages
  /// saves and restores it with the state).
  CarriedMode mode{};
};

/// A run at the end of one of its stages (simulate.h, SimCheckpoint): everything the stage loop
/// carries from one stage to the next.
struct CheckpointData {
  SimConfig cfg;               ///< the run it came from
  std::size_t stages_done = 0; ///< the next stage's index
  double t0 = 0.0;             ///< the next stage's start [s]
  State y{};                   ///< x, x', s
  std::array<double, kMaxInternalStates - 1> zs{};  ///< further internal states
  double h = 0.0;              ///< the adaptive integrator's next step [s]
  CarriedMode mode{};          ///< a switching model's mode
  ExtRuntime ext{};
  TraceRecorder trace{0.0, nullptr};  ///< its output pointer is stale: retarget before use
  SimResult result;            ///< the run so far
};

/// For RunContext::primary: M's primary_state over the internal states z[0 .. kStates).
template <class M>
std::function<double(const double*)> primary_state_fn(const M& m) {
  if constexpr (HasPrimaryState<M>) {
    return [m](const double* z) {
      std::array<double, M::kStates> a;
      for (int k = 0; k < M::kStates; ++k) a[static_cast<std::size_t>(k)] = z[k];
      return m.primary_state(a);
    };
  } else {
    return nullptr;
  }
}

/// Marks the run diverged at time t with a reason that names the likely cause (simulate.cpp).
void fail_diverged(RunContext& ctx, double t, const State& y, double ub, double h);
/// The same for a state with further internal states (the reason names x' and s).
template <int Z>
void fail_diverged(RunContext& ctx, double t, const StateStorage<Z, true>& y, double ub, double h) {
  fail_diverged(ctx, t, State{y.x, y.v, y.s}, ub, h);
}

/// Runs the stage loop shared by every integrator. integrate_stage(plant, t0, t1, acc) advances
/// the state from t0 to t1 under the stage's base motion, feeding the accumulator, and returns
/// false when the run diverged (having filled result.status/reason/t_end). h: the integrator's
/// step size carried between stages (adaptive; nullptr for the fixed-step integrators), saved
/// in and restored from checkpoints with the state y.
template <class S, class IntegrateStage>
void drive_stages(RunContext& ctx, S& y, double* h, IntegrateStage&& integrate_stage) {
  Plant plant = make_plant(ctx.cfg);
  if (ctx.ext.kind != ExtensionKind::kNone) plant.ext = &ctx.ext;
  double t0 = 0.0;
  std::size_t first = 0;
  if (ctx.resume) {
    first = ctx.resume->stages_done;
    t0 = ctx.resume->t0;
    y.x = ctx.resume->y.x;
    y.v = ctx.resume->y.v;
    y.s = ctx.resume->y.s;
    if constexpr (requires { y.zs; })
      for (std::size_t k = 0; k < y.zs.size(); ++k) y.zs[k] = ctx.resume->zs[k];
    if (h) *h = ctx.resume->h;
    ctx.mode = ctx.resume->mode;
  }
  for (std::size_t i = first; i < ctx.cfg.stages.size(); ++i) {
    const Stage& st = ctx.cfg.stages[i];
    const double t1 = t0 + st.duration;
    plant.v_a = st.v_a;
    plant.w = 2.0 * M_PI * st.f;
    plant.t0 = t0;
    StageAccumulator acc(t0, t1, ctx.cfg.metrics);
    const bool ok = integrate_stage(plant, t0, t1, acc);
    ctx.result.x_end = y.x;
    ctx.result.v_end = y.v;
    ctx.result.s_end = y.s;
    if constexpr (requires { y.zs; }) {
      if (ctx.primary) {
        std::array<double, kMaxInternalStates> z{y.s};
        for (std::size_t k = 0; k < y.zs.size(); ++k) z[k + 1] = y.zs[k];
        ctx.result.s_end = ctx.primary(z.data());
      }
    }
    if (!ok) return;
    ctx.result.stages.push_back(acc.finish());
    t0 = t1;
    if (ctx.save && i + 1 == ctx.save_after) {
      CheckpointData& c = *ctx.save;
      c.cfg = ctx.cfg;
      c.stages_done = i + 1;
      c.t0 = t0;
      c.y = {y.x, y.v, y.s};
      if constexpr (requires { y.zs; })
        for (std::size_t k = 0; k < y.zs.size(); ++k) c.zs[k] = y.zs[k];
      c.h = h ? *h : 0.0;
      c.mode = ctx.mode;
      c.ext = ctx.ext;
      c.trace = ctx.trace;
      c.result = ctx.result;
      c.result.t_end = t0;
    }
  }
  ctx.result.t_end = t0;
}

/// A hybrid form's mode at the start of a stage at point pt with internal states z: the mode the
/// last stage ended in (ctx.mode) where its event function is >= 0 here (the base velocity may
/// jump at the stage start, e.g. a slip whose v_r reversed), else classified from the state.
template <class H, class Z>
typename H::Mode stage_start_mode(const RunContext& ctx, const H& hyb, const Point& pt,
                                  const Z& z) noexcept {
  typename H::Mode m{}, next{};
  if (ctx.mode.get(&m) && hyb.event(m, pt, z, &next) >= 0.0) return m;
  return hyb.classify(pt, z);
}

/// Locates the first switch in a step of length h whose frozen-mode event function is f0 (>= 0,
/// clamped) at the start and f_h (< 0) at the end, by regula falsi with the Illinois
/// modification. eval(theta, out) integrates the frozen mode from the step start over theta,
/// stores the result in out and returns the event value there. On return out_h holds the result
/// at the returned length, the first point found with the event value < 0.
///
/// Events fire on a STRICTLY negative value: a mode holds while its event function is >= 0. The
/// mode classifications use strict inequalities (F_d > F_S saturates, v_r > DV slips), so the
/// point returned always lies in the next mode's region. With "<= 0" a switch could land exactly
/// on the boundary (event == 0; it does at small steps, where the locator's tolerance reaches
/// 1e-15 s), the next mode's classification sent it back to the old mode, and the old mode's
/// event was 0 again at once: a loop of zero-length switches (the rk4_event dt = 1e-7 Karnopp
/// bug: 3.6e7 switches, a body creeping at v_r = DV for ever).
///
/// Safeguard: every fifth iteration the bracket must have shrunk to half its width five
/// iterations before, otherwise that iteration bisects. Event functions are minima over several
/// conditions (Karnopp's stick mode: min(F_S - F_d, DV - v_r, ...)), and a body creeping at
/// v_r = DV - 1e-19 makes the minimum ~1e-19 and flat until F_d crosses F_S. Regula falsi then
/// creeps from the flat end: Illinois needs ~50 halvings of f(b) before it moves, the 80
/// iterations ran out with the bracket still [~0, h], and the switch was taken at the END of the
/// step. With the adaptive integrator's 1e-4 s stick steps every Karnopp breakaway came up to
/// 1e-4 s late (the ~1e-2 N RMS "adaptive vs rk4_event bias"; test
/// EventLocation.AdaptiveKarnoppBreakawayOnTime).
template <class Out, class Eval>
double locate_switch(double f0, double h, double f_h, Out& out_h, Eval&& eval,
                     double rel_tol = 1e-10) {
  double a = 0.0, fa = std::fmax(f0, 0.0), b = h, fb = f_h;
  int side = 0;
  const double tol = std::fmax(1e-15, rel_tol * h);
  double width_check = b - a;
  for (int it = 0; it < 200 && b - a > tol; ++it) {
    bool bisect = false;
    if (it % 5 == 4) {
      bisect = b - a > 0.5 * width_check;
      width_check = b - a;
    }
    double th = (fa - fb) != 0.0 ? b - fb * (b - a) / (fb - fa) : 0.5 * (a + b);
    if (bisect || !(th > a && th < b)) {
      th = 0.5 * (a + b);
      side = 0;  // no Illinois halving right after a bisection
    }
    Out ot;
    const double ft = eval(th, ot);
    if (ft < 0.0) {
      b = th;
      fb = ft;
      out_h = ot;
      if (side == -1) fa *= 0.5;
      side = -1;
    } else {
      a = th;
      fa = ft;
      if (side == +1) fb *= 0.5;
      side = +1;
    }
  }
  return b;
}

}  // namespace stickslip::engine::detail
