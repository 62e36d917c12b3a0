#pragma once
// Internal to the diagnosis: one measured run read before any model (docs/diagnose.md "Records"):
// its noise and spikes, its initial state, the statistics of every stage's fitted and held-out
// part, and whether its samples can be fitted in the time domain.
//
// Initial state. The preload F0 is the median of the first kPreloadSpan seconds of the despiked
// record; the record starts at rest when F0 is below kRestFraction of the median level (the
// seed's rig and our synthetic data: the spring starts unloaded), otherwise mid-experiment. The
// body is stuck at the start when the first samples rise at k_d v_d (slope within 50 %), sliding
// otherwise.
//
// Scoring. A run is phase-locked, and fitted sample by sample in the time domain, when it starts
// at rest and its first stage's slips are regular (coefficient of variation of the time between
// drops below kRegularCv) or absent: then a deterministic model started at rest can follow it
// slip by slip. Any other run (mid-experiment start, irregular slips) is fitted and scored on
// its statistics (diagnose_stats.h): a trace fit is meaningless past the first few random slips.

#include <cstddef>
#include <string>
#include <vector>

#include "stickslip/diagnosis/slip_stats.h"
#include "stickslip/measured/measured.h"

namespace stickslip::diagnosis::detail {

inline constexpr double kPreloadSpan = 0.01;   ///< [s]
inline constexpr double kRestFraction = 0.2;   ///< [-]
inline constexpr double kRegularCv = 0.15;     ///< [-]

/// The statistics of one window of a record: a stage's fitted or held-out part.
struct WindowStats {
  int stage = 0;
  bool held = false;
  double t0 = 0, t1 = 0;  ///< [s]
  StatsSpec spec;         ///< shared by the stage's fitted and held parts and by simulations
  SlipStats stats;        ///< of the measured signal
};

struct RecordInfo {
  std::string name;
  double dt = 0;                      ///< uniform sample interval [s] (the median interval)
  std::vector<double> y;              ///< despiked samples at t = i dt [N]
  NoiseEstimate noise;
  std::size_t spikes = 0;             ///< samples flagged as impulsive spikes
  double preload = 0;                 ///< F0 [N]
  double start_slope = 0;             ///< slope of the first samples [N/s]
  bool from_rest = true;
  bool stuck_at_start = true;
  double level = 0;                   ///< median of the record [N]
  std::vector<WindowStats> windows;   ///< per stage: fitted part, then held part
  std::vector<SlipStats> whole;       ///< per stage: the statistics of the whole stage
  bool phase_locked = false;
  std::string why;                    ///< the reason for the scoring (phase_locked or not)
};

/// Natural period of the body on the drive spring, 2 pi sqrt(m / k_d) [s].
double natural_period(const measured::MeasuredConditions& c);

/// Reads a run (see above). holdout_fraction: the last part of every stage held out.
RecordInfo analyse_record(const measured::MeasuredRun& run, double holdout_fraction);

/// The samples of y (interval dt, from t = 0) in [t0, t1).
std::vector<double> window_samples(const std::vector<double>& y, double dt, double t0, double t1);

}  // namespace stickslip::diagnosis::detail
