#pragma once
// Internal: RosenbrockStepper<M> (declared in model_api.h), the engine's linearly implicit
// integrator for stiff friction models, run through the own-Stepper hook (run_stepper.h).
//
// Method: RODAS4 (Hairer E., Wanner G. (1996) Solving Ordinary Differential Equations II, 2nd
// ed., Springer, Sec. IV.7; the coefficients of Hairer's rodas.f, METH = 1): six stages, order 4
// with an embedded order-3 solution, L-stable and stiffly accurate, so that the stiff modes
// (the rate-and-state velocity equation's eigenvalue dF_f/dv_r / m reaches 1e15 1/s while the
// body creeps) are damped in one step whatever h lambda is. Each step solves six linear systems
// with the matrix I/(gamma h) - J, J the exact Jacobian of the system (the model's jacobian()
// for the friction law, the drive and the inertia here), and uses the explicit time derivative
// of the right-hand side (drive and base motion). Why not Boost.Odeint's rosenbrock4: it works on
// ublas vectors and matrices of run-time size with a per-component relative/absolute error
// norm; this one is fixed-size (Eigen, N = 2 + internal states, in registers), measures the
// error in force units like the adaptive integrator (IntegratorOptions), steps through the
// engine's stages and base motion, and needs the explicit time derivative of the base motion
// that odeint expects as a user functor anyway.
//
// Error control: the embedded error of each component weighted into force units (the system's
// error_weights() at the step's start: a weight may depend on the state), max-norm, against
// atol + rtol F_ref (F_ref: the model's force_scale()).
// Modes: the system may advance its state in several charts (modes) with events between them
// (rate-and-state: the velocity while sliding, mu/a near stick). After an accepted step whose
// end point leaves the mode (event < 0), the system's enter() maps the state to the next mode,
// possibly stepping over a short time interval itself. Where the step's end lies within the
// system's event_floor (a chart boundary that is only a change of coordinates: the end state is
// as good as any point of the step) it enters from there. Otherwise the event is located on the
// cubic Hermite interpolant of the step (regula falsi) and the step is re-taken to that point.
// Why enter from the end: re-taking cost three RODAS attempts per switch, 15 % of the
// rate-and-state run at 4 mm/s (90k of 617k attempts), for a boundary the physics does not have.
// Trust: a system may refuse a step whose change it knows the linearisation cannot follow
// (optional Sys::trust_ratio > 1); the step is retried at h 0.8 / ratio.
// Projection: a system may project its state onto a slow manifold after each step (optional
// Sys::project; rate-and-state near stick, where the velocity relaxes in ~1e-10 s). The
// projected component's error still counts: the trace interpolates the friction linearly
// between steps, and without it (steps near stick up to dt_max under 0.2 mm/s vibration, where
// mu/a follows the base's inertia through +-3.5 at 1500 Hz) the friction trace at rtol 1e-4
// was 3.5e-3 of F_ref off a tight run's instead of 4.9e-4.
// Step-size control: h_new = h 0.9 err^(-1/4), within [0.2, 6] h (no growth right after a
// rejection), at most dt_max.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "system.h"

namespace stickslip::engine {

template <class M>
class RosenbrockStepper {
 public:
  static constexpr int Z = M::kStates;
  using Sys = typename M::Implicit;
  static constexpr int N = Sys::N;
  using Vec = Eigen::Matrix<double, N, 1>;
  using Mat = Eigen::Matrix<double, N, N>;
  using Arr = std::array<double, N>;
  using State = detail::StateOf<M>;

  RosenbrockStepper(const M& model, const Drive& drive, const IntegratorOptions& o)
      : m_(model), sys_(model, drive), opt_(o) {
    inv_tol_ = 1.0 / (o.atol + o.rtol * model.force_scale());
  }

  void begin_stage(double t0, const State& y, double h, double v_a, double w) {
    t0_ = t0;
    v_a_ = v_a;
    w_ = w;
    set_time(t0);
    set_mode(sys_.mode_of(y.v - b0_.ub));
    y_ = vec(sys_.from_state(mode_, y.x, y.v, internal_states(y), b0_));
    h_ = h > 0 ? h : opt_.dt;
    rejected_last_ = false;
    linearise();
  }
  TraceSample sample() const {
    double x, v;
    std::array<double, Z> z;
    sys_.to_state(mode_, arr(y_), b0_, &x, &v, &z);
    double s = z[0];
    if constexpr (detail::HasPrimaryState<M>) s = m_.primary_state(z);
    return {t_, F_d_, F_f_, x, v, s};
  }
  double t() const { return t_; }
  std::string failure() const { return failure_; }
  void end_stage(State& y, double* h) const {
    std::array<double, Z> z;
    sys_.to_state(mode_, arr(y_), b0_, &y.x, &y.v, &z);
    for (int k = 0; k < Z; ++k) internal(y, k) = z[static_cast<std::size_t>(k)];
    *h = h_;
  }
  std::size_t steps() const { return steps_; }
  std::size_t rejected() const { return rejected_; }
  std::size_t switches() const { return switches_; }

  /// One accepted step, ending at t1 at the latest; false (failure() says why) when the step
  /// size underflows or the step limit is reached.
  bool step(double t1) {
    for (;;) {
      if (static_cast<double>(steps_ + rejected_) > opt_.max_steps) {
        failure_ = "step limit reached at t = " + std::to_string(t_) + " s";
        return false;
      }
      if (stalled_ > 100) {
        failure_ = "mode switches without progress at t = " + std::to_string(t_) + " s";
        return false;
      }
      double h = std::min(h_, opt_.dt_max);
      // End the step just past a predicted event rather than have it rejected across the event
      // (or, near stick, before the change a step can be trusted with).
      const double t_ev = sys_.time_to_event(mode_, arr(y_), arr(f0_), arr(J_ * f0_ + ft_), b0_);
      if (t_ev < h) h = std::max(t_ev, 1e-12);
      const bool last = t_ + h >= t1 * (1.0 - 1e-15) - 1e-15;
      if (last) h = t1 - t_;
      Vec y_new;
      double e = attempt(h, &y_new);
      double fac = std::isfinite(e) ? 0.9 / std::sqrt(std::sqrt(e)) : 0.1;
      if constexpr (requires(Arr a) { sys_.trust_ratio(mode_, a, a); }) {
        const double r = sys_.trust_ratio(mode_, arr(y_), arr(y_new));
        if (e <= 1.0 && r > 1.0) {
          e = HUGE_VAL;  // rejected
          fac = 0.8 / r;
        }
      }
      if (!(e <= 1.0)) {  // also NaN
        ++rejected_;
        rejected_last_ = true;
        h_ = h * std::clamp(fac, 0.1, 0.9);
        if (h_ < 1e-14 * std::max(1.0, std::fabs(t_))) {
          char buf[200];
          std::snprintf(buf, sizeof buf, "step size underflow at t = %.9g s (h = %.3g s)", t_,
                        h_);
          failure_ = buf;
          return false;
        }
        continue;
      }
      fac = 0.9 / std::sqrt(std::sqrt(std::max(e, 1e-10)));  // 0.9 e^(-1/4)
      h_ = std::min(h * std::clamp(fac, 0.2, rejected_last_ ? 1.0 : 6.0), opt_.dt_max);
      rejected_last_ = false;
      ++steps_;
      const double t_new = last ? t1 : t_ + h;
      if (sys_.event(mode_, arr(y_), b0_, t_new, arr(y_new), base_at(t_new - t_)) < 0.0) {
        switch_at_event(h, y_new, t1);
      } else {
        set_time(t_new);
        y_ = y_new;
        project(h);
        linearise();
      }
      return true;
    }
  }

 private:
  static Arr arr(const Vec& v) {
    Arr a;
    for (int i = 0; i < N; ++i) a[static_cast<std::size_t>(i)] = v[i];
    return a;
  }
  static Vec vec(const Arr& a) {
    Vec v;
    for (int i = 0; i < N; ++i) v[i] = a[static_cast<std::size_t>(i)];
    return v;
  }
  void set_mode(int mode) { mode_ = mode; }
  /// u', u'', u''' from the phase's cosine and sine: u' = v_a cos(w (t - t0)).
  BaseMotion motion(double c, double s) const noexcept {
    return {v_a_ * c, -v_a_ * w_ * s, -v_a_ * w_ * w_ * c};
  }
  /// The current time t_, with the base motion there (b0_) and its phase's cosine and sine: the
  /// one glibc sin/cos pair of a step.
  void set_time(double t) {
    t_ = t;
    if (v_a_ == 0.0) return;
    const double ph = w_ * (t - t0_);
    c0_ = std::cos(ph);
    s0_ = std::sin(ph);
    b0_ = motion(c0_, s0_);
  }
  /// The base motion at t_ + dt, 0 <= w dt <= 1, by angle addition from t_ (small_sincos): the
  /// glibc sincos of the large phase at every stage was 14 % of the rate-and-state run at
  /// 1.1 mm/s (perf). Beyond w dt = 1 (never with the default dt_max) from the phase itself.
  BaseMotion base_at(double dt) const noexcept {
    if (v_a_ == 0.0) return {};
    if (!(w_ * dt <= 1.0)) {
      const double ph = w_ * (t_ + dt - t0_);
      return motion(std::cos(ph), std::sin(ph));
    }
    double c, s;
    detail::small_sincos(w_ * dt, &c, &s);
    return motion(c0_ * c - s0_ * s, s0_ * c + c0_ * s);
  }
  Vec rhs(double dt, const Vec& y) const {
    return vec(sys_.eval(mode_, t_ + dt, arr(y), base_at(dt)).f);
  }
  /// The system's projection onto a slow manifold, where it has one (Sys::project): after a
  /// step of length h.
  void project(double h) {
    if constexpr (requires(Arr a) { sys_.project(mode_, t_, a, b0_, h); }) {
      Arr a = arr(y_);
      sys_.project(mode_, t_, a, b0_, h);
      y_ = vec(a);
    }
  }
  /// f, J and f_t at the current (t_, y_), the forces and the error weights there.
  void linearise() {
    const Arr w = sys_.error_weights(mode_, arr(y_), b0_);
    for (int i = 0; i < N; ++i) weight_[i] = w[static_cast<std::size_t>(i)] * inv_tol_;
    const ImplicitLinear<N> l = sys_.linearise(mode_, t_, arr(y_), b0_);
    F_d_ = l.F_d;
    F_f_ = l.F_f;
    for (int i = 0; i < N; ++i) {
      const auto ii = static_cast<std::size_t>(i);
      f0_[i] = l.f[ii];
      ft_[i] = l.f_t[ii];
      for (int j = 0; j < N; ++j) J_(i, j) = l.J[ii][static_cast<std::size_t>(j)];
    }
  }
  /// The accepted step of length h from (t_, y_) to y1 left the mode. Enters the next mode from
  /// y1 where its event value is within the system's floor; otherwise locates the event on the
  /// step's cubic Hermite interpolant, re-takes the step to it (moving on towards the step's
  /// end until the event has fired there), and enters the next mode.
  void switch_at_event(double h, const Vec& y1, double t1) {
    const double floor = sys_.event_floor(mode_);
    const Arr y0 = arr(y_);
    auto ev = [&](double th, const Vec& y) {
      return sys_.event(mode_, y0, b0_, t_ + th * h, arr(y), base_at(th * h));
    };
    double fb = ev(1.0, y1);
    if (fb >= floor) {
      enter_at(h, 1.0, y1, t1);
      return;
    }
    const Vec f1 = rhs(h, y1);
    auto hermite = [&](double th) -> Vec {
      const double t2 = th * th, t3 = t2 * th;
      return (2 * t3 - 3 * t2 + 1) * y_ + (t3 - 2 * t2 + th) * h * f0_ +
             (-2 * t3 + 3 * t2) * y1 + (t3 - t2) * h * f1;
    };
    double a = 0.0, fa = std::max(ev(0.0, y_), 0.0), b = 1.0;
    int side = 0;
    for (int it = 0; it < 60 && b - a > 1e-12; ++it) {  // regula falsi (Illinois)
      double th = fa - fb != 0.0 ? b - fb * (b - a) / (fb - fa) : 0.5 * (a + b);
      if (!(th > a && th < b)) th = 0.5 * (a + b);
      const double ft = ev(th, hermite(th));
      if (ft < 0.0) {
        b = th;
        fb = ft;
        if (side == -1) fa *= 0.5;
        side = -1;
      } else {
        a = th;
        fa = ft;
        if (side == +1) fb *= 0.5;
        side = +1;
      }
    }
    // Real steps from the start: to the interpolant's point b; if that is not yet past the
    // event, a little further; if it is too far past (event below the system's floor, e.g. a
    // sliding step that crossed v_r = 0 itself), regula falsi on real steps between a and it.
    Vec y = y1;
    double th = 1.0;
    auto real = [&](double tt, Vec* yt) {
      attempt(tt * h, yt);
      return ev(tt, *yt);
    };
    Vec yb;
    double eb = real(b, &yb);
    for (double step_on : {1e-6, 1e-3, 0.1}) {
      if (eb < 0.0) break;
      a = b;
      fa = eb;
      b = std::min(1.0, b + step_on * (1.0 - b));
      eb = b < 1.0 ? real(b, &yb) : fb;
      if (b >= 1.0) yb = y1;
    }
    if (eb < 0.0) {
      side = 0;
      for (int it = 0; it < 30 && eb < floor; ++it) {  // too far: back towards a
        double tt = fa - eb != 0.0 ? b - eb * (b - a) / (eb - fa) : 0.5 * (a + b);
        if (!(tt > a && tt < b)) tt = 0.5 * (a + b);
        Vec yt;
        const double et = real(tt, &yt);
        if (et < 0.0) {
          b = tt;
          eb = et;
          yb = yt;
          if (side == -1) fa *= 0.5;
          side = -1;
        } else {
          a = tt;
          fa = et;
          if (side == +1) eb *= 0.5;
          side = +1;
        }
      }
      y = yb;
      th = b;
    }
    enter_at(h, th, y, t1);
  }
  /// The switch point of switch_at_event: y at the fraction th of the step of length h from t_.
  /// Moves there and enters the next mode (a time jump of the model's never goes past t1).
  void enter_at(double h, double th, const Vec& y, double t1) {
    const double t_before = t_;
    set_time(t_ + th * h);
    y_ = y;
    Arr ya = arr(y_);
    const auto jump = sys_.enter(mode_, t_, ya, b0_, std::max(0.0, t1 - t_));
    y_ = vec(ya);
    if (jump.dt != 0.0) set_time(std::min(t1, t_ + jump.dt));
    set_mode(jump.mode);
    ++switches_;
    stalled_ = t_ > t_before ? 0 : stalled_ + 1;
    project(h);
    linearise();
  }
  /// One RODAS4 step of length h from (t_, y_): the new state and its weighted error norm.
  double attempt(double h, Vec* y_out) const {
    // Hairer's rodas.f (METH = 1) in its transformed form: stage i solves
    // (I/(gamma h) - J) k_i = f(t + c_i h, y + sum_j a_ij k_j) + sum_j (c_ij / h) k_j + d_i h f_t
    // and y_new = y + a51 k1 + ... + a54 k4 + k5 + k6; the embedded solution lacks k6, which is
    // the error estimate.
    constexpr double gamma = 0.25;
    constexpr double c2 = 0.386, c3 = 0.21, c4 = 0.63;
    constexpr double d1 = 0.25, d2 = -0.1043, d3 = 0.1035, d4 = -0.3620000000000023e-01;
    constexpr double a21 = 1.544, a31 = 0.9466785280815826, a32 = 0.2557011698983284,
                     a41 = 3.314825187068521, a42 = 2.896124015972201, a43 = 0.9986419139977817,
                     a51 = 1.221224509226641, a52 = 6.019134481288629, a53 = 12.53708332932087,
                     a54 = -0.6878860361058950;
    constexpr double c21 = -5.6688, c31 = -2.430093356833875, c32 = -0.2063599157091915,
                     c41 = -0.1073529058151375, c42 = -9.594562251023355,
                     c43 = -20.47028614809616, c51 = 7.496443313967647,
                     c52 = -10.24680431464352, c53 = -33.99990352819905,
                     c54 = 11.70890893206160, c61 = 8.083246795921522,
                     c62 = -7.981132988064893, c63 = -31.52159432874371,
                     c64 = 16.31930543123136, c65 = -6.058818238834054;
    Mat A = -J_;
    A.diagonal().array() += 1.0 / (gamma * h);
    // The explicit inverse (cofactors for N <= 4) and a product per stage: Eigen's LU's two
    // triangular solves per stage were 16 % of the rate-and-state run at 1.1 mm/s (perf).
    const Mat Ai = A.inverse();
    auto solve = [&Ai](const Vec& r) -> Vec { return Ai * r; };
    const double hi = 1.0 / h;
    const Vec k1 = solve(f0_ + (h * d1) * ft_);
    const Vec k2 = solve(rhs(c2 * h, y_ + a21 * k1) + (h * d2) * ft_ + (c21 * hi) * k1);
    const Vec k3 = solve(rhs(c3 * h, y_ + a31 * k1 + a32 * k2) + (h * d3) * ft_ +
                            hi * (c31 * k1 + c32 * k2));
    const Vec k4 = solve(rhs(c4 * h, y_ + a41 * k1 + a42 * k2 + a43 * k3) +
                            (h * d4) * ft_ + hi * (c41 * k1 + c42 * k2 + c43 * k3));
    const Vec y5 = y_ + a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4;
    const Vec k5 = solve(rhs(h, y5) + hi * (c51 * k1 + c52 * k2 + c53 * k3 + c54 * k4));
    const Vec y6 = y5 + k5;
    const Vec k6 = solve(rhs(h, y6) +
                            hi * (c61 * k1 + c62 * k2 + c63 * k3 + c64 * k4 + c65 * k5));
    *y_out = y6 + k6;
    double e = 0.0;
    for (int i = 0; i < N; ++i) {
      const double ei = weight_[i] * std::fabs(k6[i]);
      if (!(ei <= e)) e = ei;  // (std::max would drop a NaN)
    }
    return std::isfinite((*y_out).sum()) ? e : HUGE_VAL;
  }

  const M& m_;
  Sys sys_;
  IntegratorOptions opt_;
  std::array<double, N> weight_{};  // error weights over the tolerance [1 per unit]
  double inv_tol_ = 0.0;
  int mode_ = 0;
  double t_ = 0.0, t0_ = 0.0, v_a_ = 0.0, w_ = 0.0, h_ = 0.0;
  double c0_ = 1.0, s0_ = 0.0;  // cos and sin of the base's phase at t_
  BaseMotion b0_{};             // the base motion at t_
  Vec y_ = Vec::Zero(), f0_ = Vec::Zero(), ft_ = Vec::Zero();
  Mat J_ = Mat::Zero();
  double F_d_ = 0.0, F_f_ = 0.0;
  bool rejected_last_ = false;
  std::size_t steps_ = 0, rejected_ = 0, switches_ = 0;
  int stalled_ = 0;  // mode switches in a row that did not advance time
  std::string failure_;
};

}  // namespace stickslip::engine
