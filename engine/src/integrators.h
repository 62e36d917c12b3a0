#pragma once
// Internal entry points of the integrators (see docs/integrators.md).
#include "system.h"

namespace stickslip::engine::detail {
void run_rk4(RunContext& ctx);
void run_rk4_event(RunContext& ctx);
void run_adaptive(RunContext& ctx);
}  // namespace stickslip::engine::detail
