#pragma once
// Running one simulation: status, per-stage metrics and an optional decimated trace.
//
// Metrics (per stage, judged over the settled part, i.e. the last (1 - settle_fraction) of the
// stage; default the last 60 %):
//   amplitude      [N]  median peak-to-trough F_d drop over detected stick-slip cycles. A cycle is
//                       detected with hysteresis: a peak is confirmed once F_d has fallen
//                       cycle_threshold (default 0.2 N) below it, and the following trough once F_d
//                       has risen cycle_threshold above it. No complete cycle -> 0 (no stick-slip).
//   amplitude_raw  [N]  max F_d - min F_d over the same window (includes transients and ripple).
//   mean_force     [N]  time average of F_d over the window.
//   mean_friction  [N]  time average of F_f over the window (momentum balance: equals mean_force
//                       over a settled periodic window).
//   slip_events    [-]  number of confirmed peaks (slips) in the window.
//   mean_period    [s]  mean time between consecutive confirmed peaks (0 with fewer than two).
// The detector sees every integrator step, so peaks are not aliased by the trace rate.

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "stickslip/engine/params.h"

namespace stickslip::engine {

enum class RunStatus { kOk, kDiverged, kInvalid };
const char* to_string(RunStatus s) noexcept;

struct StageMetrics {
  double t_start = 0.0;        ///< [s]
  double t_end = 0.0;          ///< [s]
  double amplitude = 0.0;      ///< [N]
  double amplitude_raw = 0.0;  ///< [N]
  double mean_force = 0.0;     ///< [N]
  double mean_friction = 0.0;  ///< [N]
  int slip_events = 0;         ///< [-]
  double mean_period = 0.0;    ///< [s]
};

/// One decimated trace sample (SI): t [s], F_d [N], F_f [N], x [m], x' [m/s], s [m].
struct TraceSample {
  double t, F_d, F_f, x, v, s;
};

struct SimResult {
  RunStatus status = RunStatus::kOk;
  std::string reason;           ///< why a run diverged or was invalid; empty when ok
  double t_end = 0.0;           ///< time reached [s] (the failure time when diverged)
  std::vector<StageMetrics> stages;  ///< only completed stages
  std::vector<TraceSample> trace;    ///< empty unless cfg.trace.rate > 0
  double x_end = 0.0, v_end = 0.0, s_end = 0.0;  ///< final state [m, m/s, m]
  std::size_t steps = 0;        ///< accepted integrator steps
  std::size_t rejected = 0;     ///< rejected steps (adaptive only)
  std::size_t switches = 0;     ///< located stick/slip switches (event integrators only)
};

/// Runs cfg. Never throws for a bad configuration: returns status kInvalid with the reason.
/// Never returns NaN: a run that blows up ends with kDiverged, the time and the reason.
SimResult simulate(const SimConfig& cfg);

namespace detail {
struct CheckpointData;
}

/// A run stopped at the end of one of its stages, from which simulate_from() continues any
/// configuration that agrees with that run up to there (same_first_stages): runs that share a
/// still stage integrate it once. Continuing gives bitwise the result of running the other
/// configuration from t = 0: the stage loop carries only the state, the step size, the
/// extension's clock, the trace recorder and the result so far from stage to stage, and the
/// checkpoint holds exactly those (tests/engine/test_checkpoint.cpp). Adaptive integrator only.
/// Cheap to copy (shared, immutable).
class SimCheckpoint {
 public:
  bool empty() const noexcept { return !data_; }
  /// Stages the run had completed [-] (0 when empty).
  std::size_t stages() const noexcept;

 private:
  friend SimResult simulate(const SimConfig&, std::size_t, SimCheckpoint*);
  friend SimResult simulate_from(const SimConfig&, const SimCheckpoint&);
  std::shared_ptr<const detail::CheckpointData> data_;
};

/// Runs cfg like simulate(cfg) and, when the run completes its first `stages` stages (1 <=
/// stages < cfg.stages.size(), adaptive integrator), stores it at that point in *checkpoint;
/// otherwise *checkpoint is left empty.
SimResult simulate(const SimConfig& cfg, std::size_t stages, SimCheckpoint* checkpoint);

/// Runs cfg from the checkpoint on. Status kInvalid, with the reason, when the checkpoint is
/// empty or cfg does not agree with the checkpoint's run in its first checkpoint.stages()
/// stages (same_first_stages), or cfg itself is invalid.
SimResult simulate_from(const SimConfig& cfg, const SimCheckpoint& checkpoint);

/// True when a and b agree in everything that determines their first n stages: model, drive,
/// friction, extension, integrator, metric and trace options, and stages 0 .. n-1 (both have
/// at least n). Later stages play no part in the earlier ones (the stage loop runs forward).
bool same_first_stages(const SimConfig& a, const SimConfig& b, std::size_t n);

/// JSON summary {"model","status","reason","t_end","steps","stages":[{...}]}; no NaN ever.
std::string summary_json(const SimConfig& cfg, const SimResult& r, int indent = 2);
/// CSV trace with header "t,F_d,F_f,x,v,s".
void write_trace_csv(const std::vector<TraceSample>& trace, const std::string& path);

}  // namespace stickslip::engine
