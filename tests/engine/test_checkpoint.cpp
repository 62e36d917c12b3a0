// Checkpoints (simulate.h, SimCheckpoint): a run continued from another run's end of a shared
// stage is bitwise the run simulated from t = 0, for every model the adaptive integrator runs and
// for the extensions that carry state across the stage boundary (dwell_time's stick clock,
// sensor_dynamics' filter in the trace recorder); a configuration that does not share the stage
// is refused with a reason, never continued.
#include <gtest/gtest.h>

#include "stickslip/engine/simulate.h"

using namespace stickslip::engine;

namespace {

SimConfig two_stage(ModelKind m, double v_a) {
  SimConfig c = SimConfig::seed(m, v_a);
  c.stages = {Stage{1.5, 0.0, 1500.0}, Stage{0.6, v_a, 1500.0}};
  c.integrator.rtol = c.integrator.atol = 1e-5;
  c.trace.rate = 4000.0;
  return c;
}

void expect_identical(const SimResult& a, const SimResult& b) {
  ASSERT_EQ(a.status, RunStatus::kOk) << a.reason;
  ASSERT_EQ(b.status, RunStatus::kOk) << b.reason;
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.rejected, b.rejected);
  EXPECT_EQ(a.switches, b.switches);
  EXPECT_EQ(a.t_end, b.t_end);
  EXPECT_EQ(a.x_end, b.x_end);
  EXPECT_EQ(a.v_end, b.v_end);
  EXPECT_EQ(a.s_end, b.s_end);
  ASSERT_EQ(a.stages.size(), b.stages.size());
  for (std::size_t i = 0; i < a.stages.size(); ++i) {
    EXPECT_EQ(a.stages[i].amplitude, b.stages[i].amplitude) << i;
    EXPECT_EQ(a.stages[i].mean_force, b.stages[i].mean_force) << i;
    EXPECT_EQ(a.stages[i].slip_events, b.stages[i].slip_events) << i;
  }
  ASSERT_EQ(a.trace.size(), b.trace.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a.trace.size(); ++i)
    differ += a.trace[i].t != b.trace[i].t || a.trace[i].F_d != b.trace[i].F_d ||
              a.trace[i].x != b.trace[i].x || a.trace[i].v != b.trace[i].v;
  EXPECT_EQ(differ, 0u);
}

}  // namespace

TEST(Checkpoint, ContinuedRunIsBitwiseTheRunFromRest) {
  struct Case {
    ModelKind model;
    ExtensionKind ext;
  };
  for (const Case c : {Case{model_kind<LuGre>, ExtensionKind::kNone},
                       Case{model_kind<Dahl>, ExtensionKind::kNone},
                       Case{model_kind<Karnopp>, ExtensionKind::kNone},
                       Case{model_kind<ResetIntegrator>, ExtensionKind::kNone},
                       Case{model_kind<LuGre>, ExtensionKind::kDwellTime},
                       Case{model_kind<LuGre>, ExtensionKind::kSensorDynamics},
                       Case{model_kind<LuGre>, ExtensionKind::kNormalLoadModulation}}) {
    SCOPED_TRACE(std::string(to_string(c.model)) + " + " + to_string(c.ext));
    // Run a: still after the first stage too; run b: vibrating at 4 mm/s after it.
    SimConfig a = two_stage(c.model, 0.0), b = two_stage(c.model, 4e-3);
    for (SimConfig* s : {&a, &b}) {
      s->extension.kind = c.ext;
      if (c.ext == ExtensionKind::kDwellTime) s->extension.dwell_A = 0.5;
      if (c.ext == ExtensionKind::kSensorDynamics) s->extension.sensor_tau = 5e-3;
      if (c.ext == ExtensionKind::kNormalLoadModulation) s->extension.load_eta = 0.3;
    }
    SimCheckpoint cp;
    const SimResult ra = simulate(a, 1, &cp);
    ASSERT_EQ(ra.status, RunStatus::kOk) << ra.reason;
    ASSERT_FALSE(cp.empty());
    EXPECT_EQ(cp.stages(), 1u);
    expect_identical(ra, simulate(a));  // saving changes nothing
    const SimResult from_rest = simulate(b);
    expect_identical(simulate_from(b, cp), from_rest);
    // The still stage's slips happened in both (Dahl has no static peak: no stick-slip); the
    // vibrating stage differs from a's.
    if (c.model != model_kind<Dahl>) {
      EXPECT_GT(from_rest.stages[0].slip_events, 0);
    }
    EXPECT_NE(from_rest.stages[1].mean_force, ra.stages[1].mean_force);
  }
}

TEST(Checkpoint, RunsThatDoNotShareTheStageAreRefused) {
  SimConfig a = two_stage(model_kind<LuGre>, 0.0);
  SimCheckpoint cp;
  ASSERT_EQ(simulate(a, 1, &cp).status, RunStatus::kOk);
  SimConfig b = two_stage(model_kind<LuGre>, 4e-3);
  b.friction["F_S"] = 11.2;
  SimResult r = simulate_from(b, cp);
  EXPECT_EQ(r.status, RunStatus::kInvalid);
  EXPECT_NE(r.reason.find("differs from the checkpoint's run in its first 1 stage"),
            std::string::npos)
      << r.reason;
  b = two_stage(model_kind<LuGre>, 4e-3);
  b.stages[0].duration = 1.4;
  EXPECT_EQ(simulate_from(b, cp).status, RunStatus::kInvalid);
  b = two_stage(model_kind<LuGre>, 4e-3);
  b.integrator.kind = IntegratorKind::kRk4;
  EXPECT_NE(simulate_from(b, cp).reason.find("adaptive"), std::string::npos);
  EXPECT_NE(simulate_from(two_stage(model_kind<LuGre>, 4e-3), SimCheckpoint{}).reason.find("empty"),
            std::string::npos);
  // No checkpoint where there is no later stage to continue, or with a fixed-step integrator.
  SimConfig one = a;
  one.stages.resize(1);
  simulate(one, 1, &cp);
  EXPECT_TRUE(cp.empty());
  SimConfig rk = a;
  rk.integrator.kind = IntegratorKind::kRk4;
  rk.integrator.dt = 1e-6;
  rk.stages = {Stage{0.05, 0.0, 1500.0}, Stage{0.05, 4e-3, 1500.0}};
  simulate(rk, 1, &cp);
  EXPECT_TRUE(cp.empty());
  // same_first_stages looks at the shared stages only.
  EXPECT_TRUE(same_first_stages(a, two_stage(model_kind<LuGre>, 4e-3), 1));
  EXPECT_FALSE(same_first_stages(a, two_stage(model_kind<LuGre>, 4e-3), 2));
  EXPECT_FALSE(same_first_stages(a, one, 2));
}
