#pragma once
// Batched mode: many trajectories of the same model advance together in structure-of-arrays
// form, so that g++ vectorises the RK4 step across trajectories ("lanes"). This is the mode
// parameter studies use.
//
// Every lane may have its own drive (m, k_d, v_d), friction parameters and cycle_threshold.
// All lanes must share what fixes the time grid and the base motion: the model, the integrator
// (fixed-step `rk4`, the seed's ode4), dt, the stages (count, durations, v_a, f) and
// settle_fraction. The base vibration's cos is computed once per step for all lanes.
//
// Each lane's SimResult is bitwise the one simulate() gives for that lane's configuration with
// the `rk4` integrator (same steps, same floating-point operations, same per-stage metrics), and
// lanes never influence each other. A lane that diverges ends with status kDiverged, its time and
// reason, and stops contributing; the others run on. Traces are not recorded in batch mode.

#include <string>
#include <vector>

#include "stickslip/engine/params.h"
#include "stickslip/engine/simulate.h"

namespace stickslip::engine {

/// Most lanes advanced together by one SIMD kernel call; a batch is split into chunks of
/// batch_chunk_lanes(model) lanes (tuned per model, see docs/engine.md).
inline constexpr int kBatchMaxLanes = 16;
int batch_chunk_lanes(ModelKind model) noexcept;

/// Checks that cfgs can run as one batch. Returns false and sets *error ("field: lane i has X,
/// lane 0 has Y") on the first field that differs or is unsupported. Lanes whose own
/// configuration is invalid do not make the batch incompatible (they come back kInvalid).
bool batch_compatible(const std::vector<SimConfig>& cfgs, std::string* error = nullptr);

/// Runs every configuration; result i belongs to cfgs[i]. Throws InvalidParameter naming the
/// field and the values when the batch is incompatible (see batch_compatible). A lane whose own
/// configuration is invalid gets status kInvalid with the reason, like simulate().
/// Single-threaded: callers parallelise by splitting the vector.
std::vector<SimResult> simulate_batch(const std::vector<SimConfig>& cfgs);

}  // namespace stickslip::engine
