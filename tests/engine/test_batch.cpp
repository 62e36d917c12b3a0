// Batched (structure-of-arrays) mode: every lane reproduces simulate() bitwise, lanes are
// independent, a diverging lane is reported alone, and incompatible batches are refused with
// the field named.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "engine/result_compare.h"
#include "stickslip/engine/batch.h"
#include "stickslip/engine/extensions.h"
#include "stickslip/engine/exp.h"
#include "stickslip/engine/simulate.h"

using namespace stickslip::engine;

namespace {

// Short two-stage run: still base, then vibrating; long enough for several stick-slip cycles.
SimConfig short_cfg(ModelKind m, double dt) {
  SimConfig c = SimConfig::seed(m, 2e-4);
  c.stages[0].duration = 1.5;
  c.stages[1].duration = 1.0;
  c.integrator.kind = IntegratorKind::kRk4;
  c.integrator.dt = dt;
  return c;
}

double dt_for(ModelKind m) {
  // LuGre/Dahl need dt well below the bristle stability limit (~5e-6 s); the others do not.
  return (m == model_kind<LuGre> || m == model_kind<Dahl>) ? 2e-6 : 1e-5;
}

// Lanes with different drive and friction parameters (11 lanes: a full chunk plus a partial one).
std::vector<SimConfig> varied_lanes(ModelKind m) {
  std::vector<SimConfig> cfgs;
  for (int i = 0; i < 11; ++i) {
    SimConfig c = short_cfg(m, dt_for(m));
    c.friction["F_S"] = 11.1 - 0.2 * i;
    c.friction["F_C"] = 8.3 - 0.1 * (i % 4);
    c.drive.k_d = 11700.0 * (1.0 + 0.05 * i);
    c.drive.m = 0.665 * (1.0 + 0.03 * (i % 3));
    c.drive.v_d = 1e-3 * (1.0 + 0.1 * (i % 5));
    c.metrics.cycle_threshold = 0.2 + 0.05 * (i % 2);
    if (m == model_kind<ResetIntegrator>) c.friction["alpha"] = 0.34 - 0.02 * i;
    cfgs.push_back(c);
  }
  return cfgs;
}

}  // namespace

// The hand-written exp (exp.h) against std::exp over its whole domain: within ~1 ulp.
TEST(Batch, ExpMatchesStdExp) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> wide(-708.0, 709.0), narrow(-40.0, 1.0);
  double worst = 0.0;
  for (int i = 0; i < 400000; ++i) {
    const double x = (i % 2) ? wide(rng) : narrow(rng);
    const double e = std::exp(x);
    worst = std::max(worst, std::fabs(exp_vectorizable(x) - e) / e);
  }
  EXPECT_LT(worst, 2.5e-16);
  EXPECT_EQ(exp_vectorizable(0.0), 1.0);
}

// Each lane of a batch is bitwise the trajectory and metrics of simulate() with rk4.
TEST(Batch, LanesMatchSimulate) {
  for (ModelKind m : {model_kind<LuGre>, model_kind<Karnopp>, model_kind<ResetIntegrator>,
                      model_kind<Dahl>}) {
    const auto cfgs = varied_lanes(m);
    const auto batch = simulate_batch(cfgs);
    ASSERT_EQ(batch.size(), cfgs.size());
    for (std::size_t i = 0; i < cfgs.size(); ++i) {
      const SimResult single = simulate(cfgs[i]);
      ASSERT_EQ(single.status, RunStatus::kOk) << single.reason;
      expect_same_result(batch[i], single,
                         std::string(to_string(m)) + " lane " + std::to_string(i));
    }
  }
}

// Dahl with kappa != 1 takes the non-vectorised path; still identical to simulate().
TEST(Batch, DahlGeneralKappaMatchesSimulate) {
  auto cfgs = varied_lanes(model_kind<Dahl>);
  cfgs.resize(3);
  cfgs[1].friction["kappa"] = 1.5;
  const auto batch = simulate_batch(cfgs);
  for (std::size_t i = 0; i < cfgs.size(); ++i)
    expect_same_result(batch[i], simulate(cfgs[i]), "dahl lane " + std::to_string(i));
}

// A lane's result does not depend on its neighbours, and the physics follows each lane's own
// parameters: on the still base the Karnopp amplitude is 2 (F_S - F_slip) per lane.
TEST(Batch, LanesDoNotContaminateEachOther) {
  SimConfig probe = short_cfg(model_kind<Karnopp>, 1e-5);
  probe.friction["DV"] = 1e-8;
  const SimResult alone = simulate_batch({probe})[0];
  std::vector<SimConfig> mixed;
  for (int i = 0; i < 8; ++i) {
    SimConfig c = probe;
    c.friction["F_S"] = 9.0 + 0.5 * i;  // amplitudes 1.4 ... 8.4 N
    mixed.push_back(c);
  }
  mixed[5] = probe;
  const auto out = simulate_batch(mixed);
  expect_same_result(out[5], alone, "probe among neighbours");
  for (int i = 0; i < 8; ++i) {
    const double expected = 2.0 * (mixed[i].friction["F_S"] - mixed[i].friction["F_C"]);
    EXPECT_NEAR(out[i].stages[0].amplitude, expected, 0.01 * expected) << "lane " << i;
  }
}

// One lane with a 100x stiffer contact makes RK4 unstable at this dt (dt k_t |v_r| / F_C far
// above 2.8): it alone is reported diverged, exactly as simulate() reports it; the others finish.
TEST(Batch, DivergingLaneIsReportedAlone) {
  auto cfgs = varied_lanes(model_kind<LuGre>);
  cfgs.resize(6);
  cfgs[2].friction["k_t"] *= 100.0;
  cfgs[2].friction["h_t"] *= 10.0;
  const auto out = simulate_batch(cfgs);
  const SimResult single = simulate(cfgs[2]);
  ASSERT_EQ(single.status, RunStatus::kDiverged);
  expect_same_result(out[2], single, "diverging lane");
  EXPECT_LT(out[2].t_end, cfgs[2].total_duration());
  EXPECT_NE(out[2].reason.find("reduce dt"), std::string::npos) << out[2].reason;
  for (const auto& st : out[2].stages) {
    EXPECT_TRUE(std::isfinite(st.mean_force));
    EXPECT_TRUE(std::isfinite(st.amplitude));
  }
  for (int i : {0, 1, 3, 4, 5}) {
    EXPECT_EQ(out[i].status, RunStatus::kOk) << "lane " << i;
    expect_same_result(out[i], simulate(cfgs[i]), "healthy lane " + std::to_string(i));
  }
}

// A lane that is invalid on its own comes back kInvalid naming the field; the rest run.
TEST(Batch, InvalidLaneIsReportedAlone) {
  auto cfgs = varied_lanes(model_kind<Karnopp>);
  cfgs.resize(3);
  cfgs[1].drive.m = -1.0;
  const auto out = simulate_batch(cfgs);
  EXPECT_EQ(out[1].status, RunStatus::kInvalid);
  EXPECT_NE(out[1].reason.find("m"), std::string::npos) << out[1].reason;
  EXPECT_EQ(out[0].status, RunStatus::kOk);
  EXPECT_EQ(out[2].status, RunStatus::kOk);
  EXPECT_TRUE(simulate_batch({}).empty());
}

// Lanes that do not share the model, integrator, time grid or base motion are refused, with an
// error naming the field and both values.
TEST(Batch, IncompatibleBatchNamesTheField) {
  const SimConfig base = short_cfg(model_kind<LuGre>, 2e-6);
  auto expect_field = [&](SimConfig other, const std::string& field, const std::string& value) {
    const std::vector<SimConfig> cfgs = {base, other};
    std::string err;
    EXPECT_FALSE(batch_compatible(cfgs, &err)) << field;
    EXPECT_NE(err.find(field), std::string::npos) << err;
    try {
      simulate_batch(cfgs);
      ADD_FAILURE() << "no error for " << field;
    } catch (const InvalidParameter& e) {
      EXPECT_EQ(e.field(), field);
      EXPECT_NE(std::string(e.what()).find(value), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("lane 1"), std::string::npos) << e.what();
    }
  };
  SimConfig c = base;
  c.model = model_kind<Karnopp>;
  expect_field(c, "model", "karnopp");
  c = base;
  c.integrator.dt = 1e-6;
  expect_field(c, "dt", "2e-06");
  c = base;
  c.integrator.kind = IntegratorKind::kAdaptive;
  expect_field(c, "integrator", "adaptive");
  c = base;
  c.stages[1].v_a = 1.1e-3;
  expect_field(c, "stage2.v_a", "0.0011");
  c = base;
  c.stages[0].duration = 2.0;
  expect_field(c, "stage1.duration", "2");
  c = base;
  c.stages.push_back(Stage{1.0, 0.0, 1500.0});
  expect_field(c, "stages", "3");
  c = base;
  c.trace.rate = 100.0;
  expect_field(c, "trace.rate", "100");
  c = base;  // catalogue extensions run through simulate() only
  c.extension.kind = ExtensionKind::kViscous;
  c.extension.sigma2 = 30.0;
  expect_field(c, "effect", "viscous");
  // Parameters that only change a lane's own dynamics are fine.
  c = base;
  c.friction["F_S"] = 10.0;
  c.drive.k_d = 20000.0;
  c.metrics.cycle_threshold = 0.3;
  EXPECT_TRUE(batch_compatible({base, c}));
}
