#pragma once
// Internal to the diagnosis: scoring a model on the statistics of the stick-slip (Span::kStats;
// docs/diagnose.md "Statistics scoring"), for records that a deterministic model cannot follow
// slip by slip (a mid-experiment start, irregular slips: RecordInfo::phase_locked is false).
//
// A run is simulated from rest with a burn-in `settle` before the record's t = 0: the time the
// stuck body takes to load the spring to the measured preload (F0 / (k_d v_d)) plus three
// measured periods between drops (ten natural periods without drops), so that the record is
// compared with the model's settled motion, whatever state it started in. A one-stage run is
// simulated for stats_span past the burn-in: the measured time between drops times
// kSpanIntervals, at least kSpanPeriods natural periods and kSpanMin, at most the stage (a
// deterministic model's statistics settle in a few dozen cycles; a 375 s record needs no 375 s
// simulation); a run of several stages is simulated whole. The statistics of each simulated
// stage (diagnose_stats.h, with the measured stage's StatsSpec) are compared with those of the
// measured stage's fitted part (the objective, Evaluation::feat and sse_fit) and held-out part
// (sse_held): a model's statistics predict any window of the stage.
//
// Steps: a still run needs no step shorter than the dynamics of the body on its spring, so the
// largest step is min(kStillStepMax, natural period / 20) there (the engine's default 1e-4 s is
// set for a 1500 Hz base); the error control still shortens the steps of a slip.

#include <vector>

#include "stickslip/diagnosis/detail/diagnose_fit.h"

namespace stickslip::diagnosis::detail {

inline constexpr double kSpanIntervals = 25.0;
inline constexpr double kSpanPeriods = 50.0;
inline constexpr double kSpanMin = 2.0;         ///< [s]
inline constexpr double kStillStepMax = 1e-3;   ///< [s]

/// Sets r.settle and r.stats_span from r.rec and r.cond (see above).
void plan_stats(RunData& r);

/// The simulation of run r at theta for its statistics: burn-in, span, steps and a trace at the
/// record's sample interval.
engine::SimConfig stats_config(const FitModel& m, const RunData& r, const std::vector<double>& theta,
                               double rtol);

/// The simulated statistics of every window of r (aligned with r.rec.windows) from a trace of
/// stats_config: over the measured window itself when the whole stage is simulated (a run of
/// several stages, a short record), else over the simulated span of its stage.
std::vector<SlipStats> simulated_stats(const RunData& r, const std::vector<engine::TraceSample>& trace);
/// The simulated statistics of every stage of r over its simulated span (the prediction of the
/// whole stage).
std::vector<SlipStats> simulated_whole(const RunData& r, const std::vector<engine::TraceSample>& trace);

/// evaluate(p, m, theta, Span::kStats).
Evaluation evaluate_stats(const Problem& p, const FitModel& m, const std::vector<double>& theta);

/// The model's F_d at the times t of run r, aligned on the record's initial state (the estimated
/// initial state; docs/diagnose.md "Records that start anywhere"): a record from rest is
/// simulated from rest; any other from rest through the burn-in, and record time 0 is put at the
/// first time after the burn-in (within one and a half measured periods) where the simulated F_d
/// crosses the measured preload in the record's direction (rising when the body starts stuck,
/// falling when sliding), or at the burn-in's end when it never does. *shift: simulated time of
/// the record's t = 0 [s]. Empty when a simulation fails.
std::vector<double> aligned_series(const RunData& r, const FitModel& m, const std::vector<double>& theta,
                                   double rtol, const std::vector<double>& t, double* shift);

/// The statistics score of a constant level per run (no stick-slip): the trivial predictor of the
/// statistics; sse over the fitted (held-out) windows into *fit (*held), with counts.
void constant_stats_score(const Problem& p, double* sse_fit, std::size_t* n_fit, double* sse_held,
                          std::size_t* n_held);

}  // namespace stickslip::diagnosis::detail
