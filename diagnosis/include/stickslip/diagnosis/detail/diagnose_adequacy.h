#pragma once
// Internal to the diagnosis: the adequacy verdict on the chosen base before any cause (issue 21
// item 5; docs/diagnose.md "Adequacy"), and the measured-against-predicted statistics of every
// stage window.
//
// The chosen base is scored against two trivial predictors: a constant level per run (its fitted
// part's mean: the held-out RMSE in the time domain) and the statistics of no stick-slip (a
// constant: the statistics score of the held-out windows). It is inadequate, and no cause is
// named, when it predicts worse than either, or when in some stage window with a clear regime
// (clear_regime) it shows another regime, drops off by more than kAdequateFactor, or a mean level
// off by more than kAdequateMean of the larger of the window's mean and the run's level;
// `missing` says which, with the numbers.

#include <string>
#include <vector>

#include "stickslip/diagnosis/detail/diagnose_calibrate.h"

namespace stickslip::diagnosis::detail {

inline constexpr double kAdequateFactor = 2.0;
inline constexpr double kAdequateMean = 0.25;
/// A window's regime is clear when it has no drops, or at least 2 kMinDrops whose median is
/// kClearThresholds drop thresholds or more; otherwise a mismatch is not judged.
inline constexpr double kClearThresholds = 3.0;

/// The regime of s when it is clear (see above); false otherwise.
bool clear_regime(const SlipStats& s, const StatsSpec& spec, Regime* regime);

/// Measured against predicted statistics of every stage window: base from the base's statistics
/// evaluation, extended from ext's (the base's when ext is null).
std::vector<StatsComparison> compare_stats(const Problem& P, const Evaluation& base,
                                           const Evaluation* ext);

/// The verdict on the chosen base (see above); cmp from compare_stats.
Adequacy judge_adequacy(const Problem& P, const BaseFit& base, const std::vector<StatsComparison>& cmp);

/// The records' pooled per-sample noise sqrt(mean sigma^2) [N] and n / n_eff = (1 + rho) /
/// (1 - rho) of their mean lag-1 correlation.
double noise_floor(const Problem& P);
double noise_inflation(const Problem& P);

}  // namespace stickslip::diagnosis::detail
