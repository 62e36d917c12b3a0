// The hook for a model that brings its own integrator (M::Stepper, engine/src/run_stepper.h):
// the stage loop drives the stepper, feeds every accepted step to the metrics and the trace,
// carries the whole state (any number of internal states) and the step size through stages and
// checkpoints, and turns a failed step into a diverged run with the stepper's reason.
//
// White-box: no registered model has a Stepper yet (rate-and-state and GMS will), so this drives
// run_stepper directly with a test model: LuGre with two extra internal states that do not act
// on the force (the slip distance and the work of friction), stepped by its own fixed-step RK4.
// Its stage metrics must agree with simulate() on LuGre under rk4 at the same step.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

// engine/src is internal; this test reaches into it on purpose (see above).
#include "../../engine/src/run_stepper.h"

using namespace stickslip::engine;
using detail::StateOf;

namespace {

struct SteppedLuGre : LuGre {
  static constexpr ModelInfo kInfo{"stepped_lugre_test", "LuGre, own stepper (test)", "test",
                                   ModelClass::kSmooth,
                                   {"s", kLength, "bristle strain"},
                                   "test model",
                                   1u << static_cast<int>(IntegratorKind::kAdaptive),
                                   false};
  static constexpr int kStates = 3;  // s, slip distance [m], friction work [J]
  explicit SteppedLuGre(const ModelInputs& in) : LuGre(in) {}
  ErrorWeights<3> error_weights(const Drive& d) const noexcept {
    return {std::sqrt(k_t * d.m), {k_t, 1.0, 1.0}};
  }
  std::array<double, 3> state_scale(double f_ref) const noexcept {
    return {f_ref / k_t, 1e3, 1e6};
  }

  struct Stepper {
    const SteppedLuGre& m;
    Drive d;
    double dt, t_ = 0.0, v_a = 0.0, w = 0.0, t0 = 0.0, hh = 0.0;
    long n = 0, k = 0;  // the stage's uniform grid, as rk4's
    StateOf<SteppedLuGre> y{};
    std::size_t n_steps = 0;
    double fail_at = HUGE_VAL;  // a planted failure time [s]

    Stepper(const SteppedLuGre& model, const Drive& drive, const IntegratorOptions& o)
        : m(model), d(drive), dt(o.dt) {}
    double ub(double t) const { return v_a == 0.0 ? 0.0 : v_a * std::cos(w * (t - t0)); }
    StateOf<SteppedLuGre> f(double t, const StateOf<SteppedLuGre>& z, double* F_d = nullptr,
                            double* F_f = nullptr) const {
      const double v_r = z.v - ub(t);
      const double Fd = d.k_d * (d.v_d * t - z.x);
      const FrictionEval fe = m.eval_scalar(v_r, z.s);
      if (F_d) *F_d = Fd;
      if (F_f) *F_f = fe.F_f;
      return {z.v, (Fd - fe.F_f) / d.m, fe.ds, {{std::fabs(v_r), fe.F_f * v_r}}};
    }
    static StateOf<SteppedLuGre> add(const StateOf<SteppedLuGre>& a, double h,
                                     const StateOf<SteppedLuGre>& b) {
      return {a.x + h * b.x, a.v + h * b.v, a.s + h * b.s,
              {{a.zs[0] + h * b.zs[0], a.zs[1] + h * b.zs[1]}}};
    }
    void begin_stage(double t_start, const StateOf<SteppedLuGre>& y0, double h, double va,
                     double omega) {
      t_ = t0 = t_start;
      n = k = 0;
      y = y0;
      dt = h;
      v_a = va;
      w = omega;
    }
    TraceSample sample() const {
      double F_d = 0, F_f = 0;
      f(t_, y, &F_d, &F_f);
      return {t_, F_d, F_f, y.x, y.v, y.s};
    }
    double t() const { return t_; }
    bool step(double t1) {
      if (t_ >= fail_at) return false;
      if (n == 0) {
        n = std::max(1L, static_cast<long>(std::ceil((t1 - t0) / dt * (1.0 - 1e-12))));
        hh = (t1 - t0) / static_cast<double>(n);
      }
      const double h = hh;
      const auto k1 = f(t_, y), k2 = f(t_ + 0.5 * h, add(y, 0.5 * h, k1));
      const auto k3 = f(t_ + 0.5 * h, add(y, 0.5 * h, k2)), k4 = f(t_ + h, add(y, h, k3));
      y = add(add(add(add(y, h / 6, k1), h / 3, k2), h / 3, k3), h / 6, k4);
      ++k;
      t_ = k == n ? t1 : t0 + static_cast<double>(k) * h;
      ++n_steps;
      return true;
    }
    std::string failure() const { return "planted failure at t = " + std::to_string(t_); }
    void end_stage(StateOf<SteppedLuGre>& out, double* h) const {
      out = y;
      *h = dt;
    }
    std::size_t steps() const { return n_steps; }
    std::size_t rejected() const { return 0; }
    std::size_t switches() const { return 0; }
  };
};
static_assert(detail::OwnStepper<SteppedLuGre>);

SimConfig two_stage(double v_a) {
  SimConfig c = SimConfig::seed(model_kind<LuGre>, v_a);
  c.stages = {Stage{1.5, 0.0, 1500.0}, Stage{0.5, v_a, 1500.0}};
  c.integrator.dt = 2e-6;
  return c;
}

struct StepperRun {
  SimResult r;
  detail::CheckpointData saved;
};

// Runs the test model through the stage loop, optionally saving after stage 1 or resuming.
StepperRun run_model(const SimConfig& c, std::size_t save_after = 0,
              const detail::CheckpointData* resume = nullptr) {
  StepperRun out;
  if (resume) out.r = resume->result;
  detail::RunContext ctx{c, out.r, detail::TraceRecorder(c.trace.rate, &out.r.trace)};
  if (resume) {
    ctx.trace = resume->trace;
    ctx.trace.retarget(&out.r.trace);
    ctx.resume = resume;
  }
  if (save_after) {
    ctx.save = &out.saved;
    ctx.save_after = save_after;
  }
  detail::run_stepper(ctx, make_model<SteppedLuGre>(c));
  return out;
}

}  // namespace

// Metrics from the model's own stepper equal those of the built-in rk4 on the same equations
// and step (the stepper's base velocity is the exact cosine, rk4's a recurrence: 1e-9 N).
TEST(OwnStepper, StageLoopDrivesTheStepperLikeTheBuiltInRk4) {
  for (double v_a : {0.0, 4e-3}) {
    SCOPED_TRACE(v_a);
    SimConfig ref = two_stage(v_a);
    ref.integrator.kind = IntegratorKind::kRk4;
    const SimResult a = simulate(ref);
    const SimResult b = run_model(two_stage(v_a)).r;
    ASSERT_EQ(a.status, RunStatus::kOk) << a.reason;
    ASSERT_EQ(b.status, RunStatus::kOk) << b.reason;
    EXPECT_EQ(b.steps, a.steps);
    EXPECT_DOUBLE_EQ(b.t_end, 2.0);
    ASSERT_EQ(b.stages.size(), 2u);
    for (std::size_t k = 0; k < 2; ++k) {
      EXPECT_NEAR(b.stages[k].mean_force, a.stages[k].mean_force, 1e-9);
      EXPECT_NEAR(b.stages[k].amplitude, a.stages[k].amplitude, 1e-9);
      EXPECT_EQ(b.stages[k].slip_events, a.stages[k].slip_events);
    }
    EXPECT_NEAR(b.x_end, a.x_end, 1e-12);
    EXPECT_NEAR(b.s_end, a.s_end, 1e-15);
  }
}

// The state with its extra internal states and the step size go through a checkpoint: the run
// continued after stage 1 is bitwise the run from rest, trace included.
TEST(OwnStepper, CheckpointCarriesEveryInternalState) {
  SimConfig c = two_stage(4e-3);
  c.trace.rate = 2000.0;
  const StepperRun whole = run_model(c, 1);
  ASSERT_EQ(whole.r.status, RunStatus::kOk);
  ASSERT_EQ(whole.saved.stages_done, 1u);
  EXPECT_GT(whole.saved.zs[0], 1e-4) << "slip distance carried in the checkpoint";
  EXPECT_GT(whole.saved.zs[1], 1e-4) << "friction work carried in the checkpoint";
  const StepperRun continued = run_model(c, 0, &whole.saved);
  ASSERT_EQ(continued.r.status, RunStatus::kOk);
  EXPECT_EQ(continued.r.x_end, whole.r.x_end);
  EXPECT_EQ(continued.r.steps, whole.r.steps);
  ASSERT_EQ(continued.r.stages.size(), 2u);
  EXPECT_EQ(continued.r.stages[1].mean_force, whole.r.stages[1].mean_force);
  ASSERT_EQ(continued.r.trace.size(), whole.r.trace.size());
  EXPECT_EQ(continued.r.trace.back().F_d, whole.r.trace.back().F_d);
}

// A failed step ends the run as diverged, at the stepper's time, with the stepper's reason;
// the stage in progress is not reported.
TEST(OwnStepper, FailedStepIsADivergedRunWithTheStepperReason) {
  struct Failing : SteppedLuGre {
    using SteppedLuGre::SteppedLuGre;
    struct Stepper : SteppedLuGre::Stepper {
      Stepper(const Failing& m, const Drive& d, const IntegratorOptions& o)
          : SteppedLuGre::Stepper(m, d, o) {
        fail_at = 1.7;
      }
    };
  };
  const SimConfig c = two_stage(4e-3);
  SimResult r;
  detail::RunContext ctx{c, r, detail::TraceRecorder(0.0, &r.trace)};
  detail::run_stepper(ctx, make_model<Failing>(c));
  EXPECT_EQ(r.status, RunStatus::kDiverged);
  EXPECT_NE(r.reason.find("planted failure"), std::string::npos) << r.reason;
  EXPECT_NEAR(r.t_end, 1.7, 1e-5);
  EXPECT_EQ(r.stages.size(), 1u);
  EXPECT_GT(r.x_end, 0.0);
}
