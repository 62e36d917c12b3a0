// Fixed-step classic RK4 (the seed's ode4), plain and with located stick/slip switches.
#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>

#include "integrators.h"
#include "rk4_step.h"
#include "run_stepper.h"
#include "system.h"

namespace stickslip::engine::detail {
namespace {

// ---- plain RK4: the right-hand side is evaluated as it stands, switches are not located -----

template <class Model>
void rk4_plain(RunContext& ctx, const Model& model, StateOf<Model>& y) {
  ctx.guard = make_guard(ctx.cfg, model);
  drive_stages(ctx, y, nullptr, [&](const Plant& p, double t0, double t1, StageAccumulator& acc) {
    const long n = steps_for(t1 - t0, ctx.cfg.integrator.dt);
    const double h = (t1 - t0) / static_cast<double>(n);
    BasePhase ph(p.w, h);
    for (long k = 0; k < n; ++k) {
      const double t = t0 + static_cast<double>(k) * h;
      ph.advance(k, t - t0);
      const StateOf<Model> y0 = y;
      const auto k1 = rk4_plain_step(model, p, t, h, y, p.v_a * ph.c0(), p.v_a * ph.c_half(),
                                     p.v_a * ph.c_full());
      acc.sample(t, k1.F_d, k1.F_f);
      if (ctx.trace.active())
        ctx.trace.add({t, k1.F_d, k1.F_f, y0.x, y0.v, primary_state(model, y0)});
      after_step(p, t + h, y);
      if (!ctx.guard.ok(y)) {
        fail_diverged(ctx, t + h, {y.x, y.v, y.s}, p.v_a * ph.c_full(), h);
        return false;
      }
    }
    ctx.result.steps += static_cast<std::size_t>(n);
    const auto end = rhs(model, p, t1, y, p.base_velocity(t1));
    acc.sample(t1, end.F_d, end.F_f);
    if (ctx.trace.active())
      ctx.trace.add({t1, end.F_d, end.F_f, y.x, y.v, primary_state(model, y)});
    return true;
  });
}

// ---- RK4 with located switches for the hybrid (Karnopp, Reset Integrator) forms -------------

template <class H>
struct Frozen {
  using State = typename H::State;
  static constexpr int Z = H::Model::kStates;
  const H& hyb;
  typename H::Mode mode;
  DerivT<Z> operator()(const Plant& p, double t, const State& y) const noexcept {
    const Point pt = p.point(t, y.x, y.v);
    return frozen_deriv(p, pt, y, hyb.eval(mode, pt, states_of(y)));
  }
  double event(const Plant& p, double t, const State& y, typename H::Mode* next) const noexcept {
    return hyb.event(mode, p.point(t, y.x, y.v), states_of(y), next);
  }
};

template <class F, int Z, bool M>
StateStorage<Z, M> rk4_step(const F& f, const Plant& p, double t, const StateStorage<Z, M>& y,
                            double h) noexcept {
  const auto k1 = f(p, t, y);
  const auto k2 = f(p, t + 0.5 * h, axpy(y, 0.5 * h, k1.d));
  const auto k3 = f(p, t + 0.5 * h, axpy(y, 0.5 * h, k2.d));
  const auto k4 = f(p, t + h, axpy(y, h, k3.d));
  const double h6 = h / 6.0;
  StateStorage<Z, M> out{y.x + h6 * (k1.d.x + 2.0 * (k2.d.x + k3.d.x) + k4.d.x),
                y.v + h6 * (k1.d.v + 2.0 * (k2.d.v + k3.d.v) + k4.d.v),
                y.s + h6 * (k1.d.s + 2.0 * (k2.d.s + k3.d.s) + k4.d.s)};
  if constexpr (Z > 1)
    for (int k = 0; k < Z - 1; ++k)
      out.zs[k] = y.zs[k] + h6 * (k1.d.zs[k] + 2.0 * (k2.d.zs[k] + k3.d.zs[k]) + k4.d.zs[k]);
  return out;
}

template <class H>
void rk4_event(RunContext& ctx, const H& hyb, typename H::State& y) {
  using State = typename H::State;
  ctx.guard = make_guard(ctx.cfg, hyb.m);
  drive_stages(ctx, y, nullptr, [&](const Plant& p, double t0, double t1, StageAccumulator& acc) {
    const long n = steps_for(t1 - t0, ctx.cfg.integrator.dt);
    const double h = (t1 - t0) / static_cast<double>(n);
    auto point = [&](double t, const State& z) { return p.point(t, z.x, z.v); };
    typename H::Mode mode = stage_start_mode(ctx, hyb, point(t0, y), states_of(y));
    hyb.on_enter(mode, point(t0, y), y, mode);
    for (long k = 0; k < n; ++k) {
      double t = t0 + static_cast<double>(k) * h;
      const double t_next = t0 + static_cast<double>(k + 1) * h;
      {
        const auto d0 = Frozen<H>{hyb, mode}(p, t, y);
        acc.sample(t, d0.F_d, d0.F_f);
        if (ctx.trace.active())
          ctx.trace.add({t, d0.F_d, d0.F_f, y.x, y.v, primary_state(hyb.m, y)});
      }
      // Sub-steps end at located switches; at most a few per grid step.
      for (int sub = 0; t < t_next && sub < 16; ++sub) {
        const Frozen<H> f{hyb, mode};
        const double hh = t_next - t;
        const State y1 = rk4_step(f, p, t, y, hh);
        typename H::Mode next{};
        if (f.event(p, t + hh, y1, &next) >= 0.0) {
          y = y1;
          t = t_next;
          break;
        }
        if (sub == 15) {  // safety net: never seen since events fire on < 0 (see locate_switch)
          y = y1;
          t = t_next;
          mode = hyb.classify(point(t, y), states_of(y));
          hyb.on_enter(mode, point(t, y), y, mode);
          ++ctx.result.switches;
          break;
        }
        typename H::Mode dummy{};
        State yb = y1;
        const double b = locate_switch(
            f.event(p, t, y, &dummy), hh, f.event(p, t + hh, y1, &dummy), yb,
            [&](double th, State& out) {
              out = rk4_step(f, p, t, y, th);
              return f.event(p, t + th, out, &dummy);
            });
        f.event(p, t + b, yb, &next);
        y = yb;
        t += b;
        {  // the old mode's forces at the switch, so that averages see the jump in F_f
          const auto d = f(p, t, y);
          acc.sample(t, d.F_d, d.F_f);
        }
        const typename H::Mode from = mode;
        mode = hyb.settle(mode, next, point(t, y));
        hyb.on_enter(mode, point(t, y), y, from);
        {
          const auto d = Frozen<H>{hyb, mode}(p, t, y);
          acc.sample(t, d.F_d, d.F_f);
        }
        ++ctx.result.switches;
      }
      t = t_next;
      after_step(p, t, y);
      if (!ctx.guard.ok(y)) {
        fail_diverged(ctx, t, {y.x, y.v, y.s}, p.base_velocity(t), h);
        return false;
      }
    }
    ctx.result.steps += static_cast<std::size_t>(n);
    ctx.mode.put(mode);
    const auto end = Frozen<H>{hyb, mode}(p, t1, y);
    acc.sample(t1, end.F_d, end.F_f);
    if (ctx.trace.active())
      ctx.trace.add({t1, end.F_d, end.F_f, y.x, y.v, primary_state(hyb.m, y)});
    return true;
  });
}

/// A model that does not accept an integrator (ModelInfo::integrators; e.g. one with its own
/// Stepper, or GMS, which needs located switches) is refused here: SimConfig::IsValid says so
/// before a run starts, and the integrator is not even instantiated for it.
[[noreturn, maybe_unused]] void refuse_fixed_step(const char* model) {
  throw std::logic_error(std::string("fixed-step RK4 asked to run model ") + model +
                         ", which does not accept it");
}
template <class M>
constexpr bool accepts(IntegratorKind k) {
  return (M::kInfo.integrators >> static_cast<int>(k)) & 1u;
}

}  // namespace

void run_rk4(RunContext& ctx) {
  visit_model(ctx.cfg.model, [&]<class M>(std::type_identity<M>) {
    if constexpr (OwnStepper<M> || !accepts<M>(IntegratorKind::kRk4)) {
      refuse_fixed_step(M::kInfo.name);
    } else {
      const M model = make_model<M>(ctx.cfg);
      ctx.primary = primary_state_fn(model);
      StateOf<M> y = initial_state(model, ctx.cfg.drive);
      rk4_plain(ctx, scalar_form(model), y);
    }
  });
}

void run_rk4_event(RunContext& ctx) {
  visit_model(ctx.cfg.model, [&]<class M>(std::type_identity<M>) {
    if constexpr (OwnStepper<M> || !accepts<M>(IntegratorKind::kRk4Event)) {
      refuse_fixed_step(M::kInfo.name);
    } else {
      const M model = make_model<M>(ctx.cfg);
      ctx.primary = primary_state_fn(model);
      StateOf<M> y = initial_state(model, ctx.cfg.drive);
      if constexpr (M::kInfo.model_class == ModelClass::kSwitching)
        rk4_event(ctx, typename M::Hybrid(model, ctx.cfg.drive), y);
      else
        rk4_plain(ctx, scalar_form(model), y);
    }
  });
}

}  // namespace stickslip::engine::detail
