#pragma once
// Internal to the diagnosis: whole runs held out (DiagnoseOptions::whole_run_holdout; docs/
// diagnose.md "Whole runs held out"). For every run k, the chosen base and the extended model
// (the named cause's; the base itself when none is named) are refitted on the other runs, from
// their all-run optima, with at most max_evals_fold evaluations, and predict run k:
//  * time domain: the RMSE over every sample of run k (the seed's Table 2 RMSE of conditions the
//    fit has not seen), and the cycle statistics per stage;
//  * both scorings: the statistics of run k's windows (a statistics score), and the issue's
//    criteria on its whole first stage: the mean force within kMeanTolerance, the median drop and
//    the drop rate within kDropTolerance (RunHoldout::reproduced).
// A parameter that only the left-out run constrains keeps its all-run value there (the fold's
// fit cannot move it), so a fold says how well the model carries over to conditions it was not
// fitted on, not how well the parameter could have been found without them.

#include <cstddef>

#include "stickslip/diagnosis/detail/diagnose_calibrate.h"

namespace stickslip::diagnosis::detail {

inline constexpr double kMeanTolerance = 0.10;
inline constexpr double kDropTolerance = 0.30;

/// The problem for leaving run k out (time domain: run k's samples all held out and simulated
/// only to its fit_end = 0, the others' held-out samples unused; statistics: run k not simulated
/// while fitting, scored alone with score_left_out).
Problem leave_run_out(const Problem& P, std::size_t k, double rtol, bool score);

/// The folds of every run into d->run_holdouts and the pooled scores (see above). ext: the
/// extended model and point (null: the base is the extended model).
void whole_run_holdouts(const CalibrationInputs& in, const FitModel& base, const std::vector<double>& base_theta,
                        const FitModel* ext, const std::vector<double>* ext_theta, int threads,
                        Diagnosis* d);

}  // namespace stickslip::diagnosis::detail
