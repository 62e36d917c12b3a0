#pragma once
// Internal to the diagnosis: step 1, calibrating one base model (docs/diagnose.md "Calibration").
//  1. Specs: the registry's fitted parameters moved to the record's own scales, started from the
//     measured levels (diagnose_scale.h); every other parameter held at its scaled default.
//  2. The fit. Phase-locked records (time domain): Levenberg-Marquardt on the cycle features
//     (2/5 of the budget), then on the samples. Statistics scoring: the start and each
//     log-scaled parameter moved kStatsStartSpread of its box either way are screened, and
//     Levenberg-Marquardt runs from the best on the statistics (Span::kStats).
//  3. Secondary parameters (k_t, h_t ...): each moved by kIdentifyFactor either way at the
//     optimum. It is freed when the fit objective moves by more than the identifiability
//     threshold: in the time domain 4 noise variances (times n / n_eff for correlated noise), a
//     2-sigma change of the profile likelihood; in statistics one tolerance unit. Otherwise it is
//     held, and reported as not identifiable with the change measured. The freed ones and the
//     rest are then refitted together.
//  4. Scoring at rtol_score (finish_base), in both scorings' terms.
// Why our own Levenberg-Marquardt and not Ceres Solver's (which has bounds and robust losses):
// every residual is a simulation whose slip timing makes the objective a narrow, curved valley;
// the fit must refine its forward-difference step when its steps crawl or fail (levenberg_
// marquardt in diagnose_fit.cpp, with the measurements there), share one evaluation budget
// across its phases, and poll cancellation per evaluation. Ceres's numeric differentiation has
// a fixed relative step and counts iterations, not evaluations. The robust part Ceres would
// bring is covered before the fit: impulsive spikes are flagged and replaced from the record
// (slip_stats.h, despike) and the statistics are medians and quantiles.

#include <cstddef>
#include <string>
#include <vector>

#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/diagnosis/detail/diagnose_scale.h"
#include "stickslip/diagnosis/diagnose.h"

namespace stickslip::diagnosis::detail {

inline constexpr double kStatsStartSpread = 0.25;  ///< of the unit box
inline constexpr double kIdentifyFactor = 3.0;

/// A calibrated base model: its result, model, fitted point and scoring evaluations.
struct BaseFit {
  BaseCalibration cal;
  FitModel model;
  std::vector<double> theta;
  double sse_fit = 0;
  std::size_t n_fit = 0;
  Evaluation full;   ///< the scoring evaluation of the problem's own scoring
  Evaluation stats;  ///< the statistics scoring evaluation (the same as full in statistics)
  /// The first fit's optimum (step 2) with the freed secondary parameters at their held values:
  /// the point the candidates start from (CandidateInputs::origin). A base that lacks an effect
  /// absorbs it, and with k_t and h_t free it does so in odd corners (a hidden viscous term:
  /// v_s 3.4e-5 m/s, k_t 1.1e8 N/m, fit 0.114 N against 0.030 N of noise), from which the
  /// candidates' profile starts no longer reach the effect (sigma2 16 for 60 N s/m); from the
  /// first optimum they do, and they free the secondaries themselves.
  std::vector<double> origin;
};

/// What every calibration reads (shared read-only by the threads of the calibration loop).
struct CalibrationInputs {
  const Problem& P;    ///< fitting problem (rtol)
  const Problem& Ps;   ///< scoring problem (rtol_score)
  RecordScales scales;
  StartLevels levels;
  const DiagnoseOptions& o;
  /// n / n_eff of the records' noise ((1 + rho) / (1 - rho), pooled rho): inflates the time
  /// domain's identifiability threshold and the standard errors.
  double noise_inflation = 1.0;
};

/// The span the problem is fitted on: Span::kStats or Span::kFit.
Span fit_span(const Problem& P);

/// The model to calibrate: kind with its parameters at the record's scales (steps 1).
FitModel base_model(const CalibrationInputs& in, engine::ModelKind kind);

/// Steps 1-4 for one base model. Never throws: a failure is in cal.status.
BaseFit calibrate(const CalibrationInputs& in, engine::ModelKind kind);

/// b refitted from start (a point of b.model's specs) with half the base budget, scored; the
/// point kept only when better is the caller's choice.
BaseFit polish(const CalibrationInputs& in, const BaseFit& b, const std::vector<double>& start);

/// Per-stage cycle statistics (the engine's StageAccumulator) of measured and simulated F_d at the
/// decimated samples of every run.
std::vector<StageScore> stage_scores(const Problem& p, const Evaluation& e);

/// Scores b at b.theta on the scoring problem (step 4).
void finish_base(const CalibrationInputs& in, BaseFit& b);

/// The Jacobian of a span's residuals at theta (forward differences in the unit box at
/// jacobian_step(span)): standard errors (SI; inflated by n_over_neff), the SI covariance, the
/// rank and condition number, and the weights of the smallest singular direction.
struct JacobianInfo {
  std::vector<double> se;      ///< NaN when singular
  std::vector<double> cov;     ///< row-major k x k, SI; empty when singular
  int rank = 0;
  double condition = 0;
  std::vector<double> weakest;  ///< |component| of the smallest right singular vector
};
JacobianInfo jacobian_info(const Problem& p, const FitModel& m, const std::vector<double>& theta,
                           Span span, double n_over_neff, int* evals);

/// Standard errors (SI) of the problem's fit span (jacobian_info's).
std::vector<double> standard_errors(const Problem& p, const FitModel& m,
                                    const std::vector<double>& theta, double n_over_neff,
                                    int* evals, std::vector<double>* cov_si = nullptr);

/// b's parameters as a CalibratedModel (every parameter of its configuration, the offset).
CalibratedModel calibrated_model(const FitModel& m, const std::vector<double>& theta, double offset);

}  // namespace stickslip::diagnosis::detail
