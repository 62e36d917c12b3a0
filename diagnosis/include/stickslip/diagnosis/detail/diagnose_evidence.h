#pragma once
// Internal to the diagnosis: the evidence in a model's residuals (issue 5, "Evidence from the
// residuals"): correlation with the body's velocity, its position and the time since it last
// slid; the residual's trend along x; sine scans against x and t; the stage mean residual
// against v_a; binned residual profiles for the plots.

#include <vector>

#include "stickslip/diagnosis/detail/diagnose_fit.h"

namespace stickslip::diagnosis::detail {

/// The residual measured - simulated - offset of every sample with a simulated value, and the
/// simulated state there: run-major, every role (fit and held-out alike).
struct ResidualColumns {
  std::vector<double> t;      ///< sample time [s]
  std::vector<double> res;    ///< [N]
  std::vector<double> x, v;   ///< simulated position [m], velocity [m/s]
  std::vector<double> stick;  ///< time since |x'| last exceeded 1e-4 m/s in the run [s]
};
ResidualColumns residual_columns(const Problem& p, const Evaluation& e);

/// Least-squares sin/cos fit res ~ a sin(2 pi c / P) + b cos(2 pi c / P) for each period P of
/// the log grid P_i = lo ratio^(i / (n - 1)), i = 0 .. n-1 (by hand: a 2 x 2 solve per period;
/// the data are unevenly spaced along x, which rules out an FFT). amplitude = hypot(a, b),
/// phase = atan2(b, a).
struct SineScan {
  std::vector<double> period, amplitude, phase;
};
SineScan sine_scan(const std::vector<double>& res, const std::vector<double>& coord, double lo,
                   double ratio, int n);

/// Index of the largest amplitude and its power over the median power of the scan.
std::size_t scan_peak(const SineScan& s, double* power_over_median);

/// Lag-1 autocorrelation of the fit residuals, pooled within runs, clamped to [0, 0.99].
double lag1(const Problem& p, const Evaluation& e);

/// The scalar evidence of the base model's scoring evaluation e (n_fit its fit samples), and
/// the x scan the waviness candidate's fallback starts come from (x_scan).
Evidence base_evidence(const Problem& p, const Evaluation& e, std::size_t n_fit, SineScan* x_scan);

/// Adds the binned profiles, both spectra and the stage mean residuals of the extended model
/// (ext may be null: no extended model) to ev.
void add_residual_views(const Problem& p, const Evaluation& base, const Evaluation* ext,
                        Evidence* ev);

}  // namespace stickslip::diagnosis::detail
