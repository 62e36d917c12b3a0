#pragma once
// Internal: the stage loop for a model that brings its own integrator (M::Stepper), e.g. a
// stiff model that needs an implicit method with its own stage solver, or a switching model with
// many elements and its own event handling. The model header declares
//
//   struct Stepper {
//     Stepper(const M& model, const Drive& drive, const IntegratorOptions& options);
//     // Start a stage at t0 from the integrator state y (x, x', internal states) with the step
//     // size h carried from the previous stage; base velocity u' = v_a cos(w (t - t0)).
//     void begin_stage(double t0, const StateOf<M>& y, double h, double v_a, double w);
//     TraceSample sample() const;      // {t, F_d, F_f, x, x', primary internal state} now
//     double t() const;                // the time reached [s]
//     bool step(double t1);            // one accepted step, never past t1; false: failed
//     std::string failure() const;     // why step() failed (the run's reason)
//     void end_stage(StateOf<M>& y, double* h) const;  // the state and next step size back
//     std::size_t steps() const, rejected() const, switches() const;  // running counts
//   };
//
// and accepts the adaptive integrator only (ModelInfo::integrators = 1u << kAdaptive): its
// IntegratorOptions (rtol, atol, dt, dt_max) are the stepper's. The stepper's whole state goes
// through y between stages, so checkpoints (simulate_from) work unchanged. Metrics and the
// trace see every accepted step, as with the built-in integrators.
#include <cmath>
#include <cstddef>
#include <string>

#include "rosenbrock.h"
#include "system.h"

namespace stickslip::engine::detail {

/// A model that brings its own integrator (see above).
template <class M>
concept OwnStepper = requires { typename M::Stepper; };

template <class M>
void run_stepper(RunContext& ctx, const M& model) {
  static_assert(M::kInfo.integrators == (1u << static_cast<int>(IntegratorKind::kAdaptive)),
                "a model with its own Stepper accepts the adaptive integrator only");
  static_assert(!M::kInfo.effects, "catalogue effects are not applied by a model's own Stepper");
  const SimConfig& c = ctx.cfg;
  typename M::Stepper S(model, c.drive, c.integrator);
  StateOf<M> y = initial_state(model, c.drive);
  double h = c.integrator.dt;
  ctx.guard = make_guard(c, model);
  ctx.primary = primary_state_fn(model);
  drive_stages(ctx, y, &h, [&](const Plant& p, double t0, double t1, StageAccumulator& acc) {
    S.begin_stage(t0, y, h, p.v_a, p.w);
    const std::size_t steps0 = S.steps(), rejected0 = S.rejected(), switches0 = S.switches();
    auto record = [&](const TraceSample& s) {
      acc.sample(s.t, s.F_d, s.F_f);
      if (ctx.trace.active()) ctx.trace.add(s);
    };
    auto count = [&] {
      ctx.result.steps += S.steps() - steps0;
      ctx.result.rejected += S.rejected() - rejected0;
      ctx.result.switches += S.switches() - switches0;
    };
    auto fail = [&](std::string reason) {
      S.end_stage(y, &h);
      count();
      ctx.result.status = RunStatus::kDiverged;
      ctx.result.t_end = S.t();
      ctx.result.reason = std::move(reason);
      return false;
    };
    record(S.sample());
    while (S.t() < t1) {
      if (!S.step(t1)) return fail(S.failure());
      const TraceSample s = S.sample();
      if (!(std::isfinite(s.x) && std::fabs(s.v) < ctx.guard.v_limit))
        return fail(divergence_reason(model, s.t, s.v, s.s, s.v - p.base_velocity(s.t), 0.0));
      record(s);
    }
    S.end_stage(y, &h);
    count();
    if (!ctx.guard.ok(y)) {
      fail_diverged(ctx, S.t(), y, p.base_velocity(S.t()), h);
      return false;
    }
    return true;
  });
}

}  // namespace stickslip::engine::detail
