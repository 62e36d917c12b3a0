#pragma once
// Internal: the seed's system as a plain right-hand side, plus the "frozen-mode" forms of the
// switching models that the event-locating integrators need. Not part of the public API.

#include <cmath>
#include <string>

#include "stickslip/engine/metrics.h"
#include "stickslip/engine/models.h"
#include "stickslip/engine/simulate.h"
#include "extended.h"

namespace stickslip::engine::detail {

struct State {
  double x = 0.0;  ///< body position [m]
  double v = 0.0;  ///< body velocity [m/s]
  double s = 0.0;  ///< bristle strain [m] (unused by Karnopp)
};

/// Everything the friction model sees at one instant besides the state.
struct Point {
  double F_d;        ///< drive force [N]
  double v_r;        ///< relative velocity [m/s]
  double a_b = 0.0;  ///< base acceleration u'' [m/s^2]
  Mod mod{};          ///< extension: friction level and static-friction increase
  double sigma2 = 0.0;  ///< extension: viscous coefficient [N s/m]
};

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
              modulation(t, x), ext->sigma2};
    return {drive_force(t, x), v - base_velocity(t), base_accel(t)};
  }
  Mod modulation(double t, double x) const noexcept {
    return ext ? ext->modulation(t, x, v_a, w, t0) : Mod{};
  }
  double drive_force(double t, double x) const noexcept { return k_d * fmadd(v_d, t, -x); }
};

/// LuGre for single trajectories (rk4, adaptive): the same results as LuGre, bitwise, through
/// LuGre::eval_scalar (a branch past the Stribeck flush point instead of the batched kernels'
/// select). The batched kernels use LuGre itself.
struct ScalarLuGre : LuGre {
  explicit ScalarLuGre(const FrictionParams& p) : LuGre(p) {}
  FrictionEval operator()(double v_r, double s, double /*F_d*/) const noexcept {
    return eval_scalar(v_r, s);
  }
};

/// Derivative plus the forces it came from.
struct Deriv {
  State d;
  double F_d, F_f;
};

template <class Model>
inline Deriv rhs(const Model& model, const Plant& p, double t, const State& y,
                 double ub) noexcept {
  if (p.ext) [[unlikely]] {
    const double F_d = p.drive_force(t, y.x) + p.ext->c_d * (p.v_d - y.v);
    const FrictionEval fe = eval_ext(model, *p.ext, p.modulation(t, y.x), y.v - ub, y.s, F_d);
    return {{y.v, (F_d - fe.F_f) * p.m_inv, fe.ds}, F_d, fe.F_f};
  }
  const double F_d = p.drive_force(t, y.x);
  const FrictionEval fe = model(y.v - ub, y.s, F_d);
  return {{y.v, (F_d - fe.F_f) * p.m_inv, fe.ds}, F_d, fe.F_f};
}

/// After every accepted step: the dwell_time extension's stick clock restarts while slipping.
/// Returns true when the friction law changed at t (so a cached derivative at t is stale).
inline bool after_step(const Plant& p, double t, const State& y) noexcept {
  if (p.ext && p.ext->tracks_stick() && std::fabs(y.v - p.base_velocity(t)) > p.ext->e.dwell_v) {
    const bool changed = p.ext->e.dwell_A != 0.0 && t > p.ext->t_slip;
    p.ext->t_slip = t;
    return changed;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
// Hybrid forms for event location. A mode freezes the branch of a switching model so that the
// right-hand side is smooth inside a step; event functions are >= 0 while the mode holds.
// ---------------------------------------------------------------------------------------------

enum class KMode { kSlipPos, kSlipNeg, kStick, kSatPos, kSatNeg, kEdgePos, kEdgeNeg };
enum class RMode { kStick, kSlidePos, kSlideNeg };

/// Karnopp in hybrid form. Besides slip (|v_r| > DV) and the band (stick, or saturated stick
/// when |F_d| > F_S), a vibrating base creates sliding motion ON a band edge v_r = +-DV: the
/// slip side pushes v_r back into the band while the band side (where the body does not
/// accelerate but the base does) pushes it out. Filippov's convention then keeps v_r = +-DV,
/// i.e. the body is carried by the base, with F_f = F_d - m u''. A fixed-step integration of
/// eq. (11) approximates the same motion by chattering across the edge every step.
struct KarnoppHybrid {
  Karnopp m;
  double mass;  ///< body mass [kg]
  using Mode = KMode;
  Mode classify(const Point& p, double /*s*/) const noexcept {
    if (p.v_r > m.DV) return Mode::kSlipPos;
    if (p.v_r < -m.DV) return Mode::kSlipNeg;
    return band_mode(p);
  }
  /// Static and slip friction at this point (the Table 1 values unless an extension modulates
  /// them; slip friction includes the viscous extension's sigma2 |v_r|) [N].
  double FS(const Point& p) const noexcept { return p.mod.level * (m.F_S + p.mod.dFS); }
  double Fslip(const Point& p) const noexcept {
    return p.mod.level * m.F_slip + p.sigma2 * std::fabs(p.v_r);
  }
  Mode band_mode(const Point& p) const noexcept {
    const double F_S = FS(p);
    if (p.F_d > F_S) return Mode::kSatPos;
    if (p.F_d < -F_S) return Mode::kSatNeg;
    return Mode::kStick;
  }
  /// Body acceleration inside the band [m/s^2].
  double band_accel(const Point& p) const noexcept {
    const double F_S = FS(p);
    return (p.F_d - std::fmin(std::fmax(p.F_d, -F_S), F_S)) / mass;
  }
  FrictionEval eval(Mode mode, const Point& p, double /*s*/) const noexcept {
    switch (mode) {
      case Mode::kSlipPos: return {Fslip(p), 0.0};
      case Mode::kSlipNeg: return {-Fslip(p), 0.0};
      case Mode::kStick: return {p.F_d, 0.0};
      case Mode::kSatPos: return {FS(p), 0.0};
      case Mode::kSatNeg: return {-FS(p), 0.0};
      case Mode::kEdgePos:
      case Mode::kEdgeNeg: return {p.F_d - mass * p.a_b, 0.0};
    }
    return {0.0, 0.0};
  }
  /// Smallest event function of the mode (>= 0 inside, fires when < 0), and the mode it leads to.
  double event(Mode mode, const Point& p, double /*s*/, Mode* next) const noexcept {
    const double up = m.DV - p.v_r;     // leaves the band upwards when < 0
    const double down = p.v_r + m.DV;  // leaves the band downwards when < 0
    const double F_S = FS(p), F_slip = Fslip(p);
    double e = 1e300;
    auto take = [&](double value, Mode to) {
      if (value < e) { e = value; *next = to; }
    };
    switch (mode) {
      case Mode::kSlipPos: take(-up, Mode::kStick); break;    // v_r falls to DV
      case Mode::kSlipNeg: take(-down, Mode::kStick); break;  // v_r rises to -DV
      case Mode::kStick:
        take(F_S - p.F_d, Mode::kSatPos);
        take(p.F_d + F_S, Mode::kSatNeg);
        take(up, Mode::kSlipPos);
        take(down, Mode::kSlipNeg);
        break;
      case Mode::kSatPos:
        take(p.F_d - F_S, Mode::kStick);
        take(up, Mode::kSlipPos);
        take(down, Mode::kSlipNeg);
        break;
      case Mode::kSatNeg:
        take(-F_S - p.F_d, Mode::kStick);
        take(up, Mode::kSlipPos);
        take(down, Mode::kSlipNeg);
        break;
      case Mode::kEdgePos:  // needs band side pushing up and slip side pushing down
        take(band_accel(p) - p.a_b, Mode::kStick);
        take(p.a_b - (p.F_d - F_slip) / mass, Mode::kSlipPos);
        break;
      case Mode::kEdgeNeg:
        take(p.a_b - band_accel(p), Mode::kStick);
        take((p.F_d + F_slip) / mass - p.a_b, Mode::kSlipNeg);
        break;
    }
    return e;
  }
  /// The mode actually entered when an event of mode 'from' asks for 'to' at point p.
  Mode settle(Mode from, Mode to, const Point& p) const noexcept {
    const double band_flow = band_accel(p) - p.a_b;  // dv_r/dt inside the band
    switch (to) {
      case Mode::kStick:
      case Mode::kSatPos:
      case Mode::kSatNeg:
        if (from == Mode::kSlipPos && band_flow > 0) return Mode::kEdgePos;
        if (from == Mode::kSlipNeg && band_flow < 0) return Mode::kEdgeNeg;
        return band_mode(p);
      case Mode::kSlipPos: {  // at v_r = +DV, leaving the band or an edge upwards
        if ((p.F_d - Fslip(p)) / mass - p.a_b >= 0) return to;  // slip side moves away
        if (from != Mode::kEdgePos && band_flow > 0) return Mode::kEdgePos;
        return band_mode(p);  // both sides flow back into the band
      }
      case Mode::kSlipNeg: {
        if ((p.F_d + Fslip(p)) / mass - p.a_b <= 0) return to;
        if (from != Mode::kEdgeNeg && band_flow < 0) return Mode::kEdgeNeg;
        return band_mode(p);
      }
      default: return to;
    }
  }
  /// Projects the state onto the entered mode's set: on an edge v_r = +-DV exactly, inside the
  /// band |v_r| <= DV. Without this, round-off drift of 1e-11 m/s past an edge makes the band's
  /// exit event fire at once, and the integrator ping-pongs between modes at zero step length.
  ///
  /// A slip that ends in the band (from kSlipPos/kSlipNeg) ends exactly on its edge: the
  /// located point is up to the locator's tolerance past the event v_r = +-DV, and the body
  /// then creeps through the whole stick at that velocity. The creep velocity's shortfall eps
  /// below DV delays the next breakaway by sqrt(2 m eps / (k_d v_d)) (the band must be crossed
  /// by the saturated acceleration first): eps = 4e-14 m/s (a 1e-14 s tolerance at 4 m/s^2)
  /// gave a 7e-8 s late slip and 1.5e-6 N of F_d offset per stick-slip cycle. The edge is
  /// entered 1e-12 DV inside: exactly on it, the round-off of v_r = x' - u' (~1e-21 m/s) made
  /// the band's exit event fire at once under vibration (4757 zero-length switch loops in 6 s
  /// at 4 mm/s, each ending in a step taken without location: 0.03 N momentum imbalance).
  static constexpr double kEdgeInside = 1.0 - 1e-12;
  void on_enter(Mode mode, const Point& p, State& y, Mode from) const noexcept {
    double target = p.v_r;
    if (mode == Mode::kEdgePos) target = m.DV;
    else if (mode == Mode::kEdgeNeg) target = -m.DV;
    else if (mode == Mode::kStick || mode == Mode::kSatPos || mode == Mode::kSatNeg) {
      target = std::fmin(std::fmax(p.v_r, -m.DV), m.DV);
      if (from == Mode::kSlipPos) target = kEdgeInside * m.DV;
      if (from == Mode::kSlipNeg) target = -kEdgeInside * m.DV;
    }
    y.v += target - p.v_r;
  }
};

struct ResetHybrid {
  ResetIntegrator m;
  using Mode = RMode;
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
  /// With an extension: the contact force scaled by the friction level, the stiction gain
  /// raised by dFS / (k_t s0) (breakaway force + dFS), plus sigma2 v_r.
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

/// Limits beyond which a run is declared diverged (never reached by a healthy run).
struct DivergenceGuard {
  double v_limit;  ///< [m/s]
  double s_limit;  ///< [m]
  bool ok(const State& y) const noexcept {
    return std::fabs(y.v) < v_limit && std::fabs(y.s) < s_limit && std::isfinite(y.x);
  }
};

/// Records decimated trace samples by linear interpolation between integrator steps.
class TraceRecorder {
 public:
  TraceRecorder(double rate, std::vector<TraceSample>* out) : out_(out) {
    if (rate > 0) period_ = 1.0 / rate;
  }
  bool active() const noexcept { return period_ > 0; }
  /// sensor_dynamics: the trace's F_d becomes the sensor's output (see extensions.h).
  void set_sensor(const SensorFilter& f) { sensor_ = f; }
  /// Further samples go to out (a copy of the recorder continues another run's trace).
  void retarget(std::vector<TraceSample>* out) noexcept { out_ = out; }
  /// Called on every integrator step: the common case (no sample due, no sensor) is inline.
  void add(const TraceSample& now) {
    if (period_ <= 0) return;
    if (have_prev_ && now.t < next_t_ && !sensor_.active()) {
      prev_ = now;
      return;
    }
    add_slow(now);
  }

 private:
  void add_slow(TraceSample now) {
    if (sensor_.active()) now.F_d = sensor_.step(now.t, now.F_d);
    if (!have_prev_) {
      prev_ = now;
      have_prev_ = true;
      if (now.t >= next_t_) emit(now);
      return;
    }
    while (next_t_ <= now.t) {
      const double span = now.t - prev_.t;
      const double w = span > 0 ? (next_t_ - prev_.t) / span : 1.0;
      auto lerp = [&](double a, double b) { return a + w * (b - a); };
      emit({next_t_, lerp(prev_.F_d, now.F_d), lerp(prev_.F_f, now.F_f), lerp(prev_.x, now.x),
            lerp(prev_.v, now.v), lerp(prev_.s, now.s)});
    }
    prev_ = now;
  }

  void emit(const TraceSample& s) {
    out_->push_back(s);
    ++count_;
    next_t_ = static_cast<double>(count_) * period_;
  }
  std::vector<TraceSample>* out_;
  double period_ = 0.0;
  double next_t_ = 0.0;
  std::size_t count_ = 0;
  bool have_prev_ = false;
  TraceSample prev_{};
  SensorFilter sensor_;
};

struct CheckpointData;

/// What an integrator needs for one run: stage loop bookkeeping is shared by all of them.
struct RunContext {
  const SimConfig& cfg;
  SimResult& result;
  TraceRecorder trace;
  DivergenceGuard guard;
  ExtRuntime ext{};  ///< catalogue extension state (kind none: the base model)
  /// Continue from this run's end of a stage (simulate_from; result, trace and ext are already
  /// restored; drive_stages restores the state and the step size).
  const CheckpointData* resume = nullptr;
  /// Save the run here after its first save_after stages (simulate with a checkpoint).
  CheckpointData* save = nullptr;
  std::size_t save_after = 0;
};

/// A run at the end of one of its stages (simulate.h, SimCheckpoint): everything the stage loop
/// carries from one stage to the next.
struct CheckpointData {
  SimConfig cfg;               ///< the run it came from
  std::size_t stages_done = 0; ///< the next stage's index
  double t0 = 0.0;             ///< the next stage's start [s]
  State y{};
  double h = 0.0;              ///< the adaptive integrator's next step [s]
  ExtRuntime ext{};
  TraceRecorder trace{0.0, nullptr};  ///< its output pointer is stale: retarget before use
  SimResult result;            ///< the run so far
};

/// The divergence limits simulate() uses for cfg.
DivergenceGuard make_guard(const SimConfig& cfg);

std::string divergence_reason(const SimConfig& cfg, double t, const State& y, double ub,
                              double h);

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
double locate_switch(double f0, double h, double f_h, Out& out_h, Eval&& eval) {
  double a = 0.0, fa = std::fmax(f0, 0.0), b = h, fb = f_h;
  int side = 0;
  const double tol = std::fmax(1e-15, 1e-10 * h);
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

inline Plant make_plant(const SimConfig& cfg) {
  return Plant{1.0 / cfg.drive.m, cfg.drive.k_d, cfg.drive.v_d};
}

/// Runs the stage loop shared by every integrator. integrate_stage(plant, t0, t1, acc) advances
/// the state from t0 to t1 under the stage's base motion, feeding the accumulator, and returns
/// false when the run diverged (having filled result.status/reason/t_end). h: the integrator's
/// step size carried between stages (adaptive; nullptr for the fixed-step integrators), saved
/// in and restored from checkpoints with the state y.
template <class IntegrateStage>
void drive_stages(RunContext& ctx, State& y, double* h, IntegrateStage&& integrate_stage) {
  Plant plant = make_plant(ctx.cfg);
  if (ctx.ext.kind != ExtensionKind::kNone) plant.ext = &ctx.ext;
  double t0 = 0.0;
  std::size_t first = 0;
  if (ctx.resume) {
    first = ctx.resume->stages_done;
    t0 = ctx.resume->t0;
    y = ctx.resume->y;
    if (h) *h = ctx.resume->h;
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
    if (!ok) return;
    ctx.result.stages.push_back(acc.finish());
    t0 = t1;
    if (ctx.save && i + 1 == ctx.save_after) {
      CheckpointData& c = *ctx.save;
      c.cfg = ctx.cfg;
      c.stages_done = i + 1;
      c.t0 = t0;
      c.y = y;
      c.h = h ? *h : 0.0;
      c.ext = ctx.ext;
      c.trace = ctx.trace;
      c.result = ctx.result;
      c.result.t_end = t0;
    }
  }
  ctx.result.t_end = t0;
}

}  // namespace stickslip::engine::detail
