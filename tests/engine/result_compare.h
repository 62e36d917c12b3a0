#pragma once
// Test support: two simulation results are the same, bitwise (status, reason, end time and
// state, steps, every stage metric).
#include <gtest/gtest.h>

#include <string>

#include "stickslip/engine/simulate.h"

namespace stickslip::engine {

inline void expect_same_result(const SimResult& a, const SimResult& b, const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(a.status, b.status) << a.reason << " | " << b.reason;
  EXPECT_EQ(a.reason, b.reason);
  EXPECT_EQ(a.t_end, b.t_end);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.x_end, b.x_end);
  EXPECT_EQ(a.v_end, b.v_end);
  EXPECT_EQ(a.s_end, b.s_end);
  ASSERT_EQ(a.stages.size(), b.stages.size());
  for (std::size_t k = 0; k < a.stages.size(); ++k) {
    const StageMetrics &p = a.stages[k], &q = b.stages[k];
    EXPECT_EQ(p.amplitude, q.amplitude) << "stage " << k;
    EXPECT_EQ(p.amplitude_raw, q.amplitude_raw) << "stage " << k;
    EXPECT_EQ(p.mean_force, q.mean_force) << "stage " << k;
    EXPECT_EQ(p.mean_friction, q.mean_friction) << "stage " << k;
    EXPECT_EQ(p.slip_events, q.slip_events) << "stage " << k;
    EXPECT_EQ(p.mean_period, q.mean_period) << "stage " << k;
  }
}

}  // namespace stickslip::engine
