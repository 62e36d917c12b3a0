#pragma once
// Internal entry points of the integrators (see docs/integrators.md).
#include "system.h"

namespace stickslip::engine::detail {
void run_rk4(RunContext& ctx);
void run_rk4_event(RunContext& ctx);
void run_adaptive(RunContext& ctx);
/// Marks the run diverged at time t with a reason that names the likely cause.
void fail_diverged(RunContext& ctx, double t, const State& y, double ub, double h);
}  // namespace stickslip::engine::detail
