// THROWAWAY (issue 19 demonstration, reverted): the tanh Coulomb model's own physics.
#include <gtest/gtest.h>

#include <cmath>

#include "stickslip/engine/simulate.h"

using namespace stickslip::engine;

// Steady sliding (overdamped: no stick-slip): the drive force settles at F_C tanh(v_d / v_e).
TEST(TanhCoulomb, SteadySlidingForceIsTheCoulombLevel) {
  SimConfig c = SimConfig::seed(model_from_string("tanh_coulomb"), 0.0);
  const SimResult r = simulate(c);
  ASSERT_EQ(r.status, RunStatus::kOk) << r.reason;
  EXPECT_NEAR(r.stages[0].mean_force, c.friction["F_C"] * std::tanh(c.drive.v_d / c.friction["v_e"]),
              0.05);
  EXPECT_LT(r.stages[0].amplitude, 0.05);
}
