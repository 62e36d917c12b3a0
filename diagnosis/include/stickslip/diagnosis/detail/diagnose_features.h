#pragma once
// Internal to the diagnosis: per-cycle and per-stage features of a drive-force signal, the
// smooth objective used to start every fit (docs/diagnose.md "Method").
//
// Whole-trace residuals of stick-slip are dominated by slip timing: a 3 % change of one
// parameter moves late slips by more than a slip's width and the time-domain SSE jumps from the
// noise floor to ~1 N RMS, so its basin is narrow. The features below are continuous in the
// parameters (as long as the number of slips in a window does not change), so an optimiser can
// cross large distances with them; the time-domain fit then refines.
//
// Per still-base stage window with stick-slip (measured peak-to-peak >= 1 N), per slip k:
//   t_k  time F_d falls through the mid level L (linear interpolation between samples; slips
//        found with hysteresis +-h, h = a quarter of the measured peak-to-peak);
//   P_k  stick ramp before the slip extrapolated to t_k: mean of F_d - k_d v_d (t - t_k) over
//        [t_k - 0.10 s, t_k - 0.01 s] (the body is stuck, so F_d rises at k_d v_d; the mean
//        averages the noise, unlike a sample maximum);
//   Q_k  the same over [t_k + 0.05 s, t_k + 0.12 s] (stuck again after the slip).
// Per window in every case: the mean and the standard deviation of F_d (continuous in the
// parameters even where slips appear or vanish, so they still point the way when the slip counts
// differ and the cycle terms are flat).
// Per other stage window (vibrating base, or no stick-slip): the mean of F_d over consecutive 0.25 s blocks.
// Residuals: k_d v_d (t_k^meas - t_k^sim) [N], P, Q and block-mean differences [N] (minus
// their mean when a sensor offset is fitted); every slip of one signal without a partner in the
// other costs (peak-to-peak)^2.
//
// Windows after the first switch (still -> vibrating, or a later still window) are scored with
// the simulated switch moved to the measured phase of the still stage's cycle (diagnose_fit.cpp,
// phase_shift; RunData::anchor_tau): the next stage's transient starts from the state the
// cycle is in at the switch, and after a long still stage that phase turns through whole cycles
// as the parameters change (1 % of F_S is about one cycle after 10 s), which made the objective
// ripple and the fits stop in a ripple (tests/diagnosis/test_diagnose_features.cpp).

#include <vector>

namespace stickslip::diagnosis::detail {

/// How the features of one stage window are extracted (from the measured signal).
struct WindowSpec {
  double t0 = 0, t1 = 0;  ///< [s]
  bool cycles = false;    ///< stick-slip window
  double level = 0, hysteresis = 0, peak_to_peak = 0;  ///< [N]
};

struct Features {
  std::vector<std::vector<double>> t, P, Q;  ///< per window, per slip
  std::vector<std::vector<double>> blocks;   ///< per window, block means [N]
  std::vector<double> mean, sd;              ///< per window: mean and standard deviation [N]
};

/// Window spec from measured samples (t, F) in [t0, t1]; still: the base does not vibrate
/// (vibrating windows are scored by block means only: their small oscillations are not the
/// stick ramps the cycle features assume).
WindowSpec make_window(const std::vector<double>& t, const std::vector<double>& F, double t0,
                       double t1, bool still);

/// Features of a signal over the windows; rise = k_d v_d [N/s].
Features extract_features(const std::vector<double>& t, const std::vector<double>& F,
                          const std::vector<WindowSpec>& windows, double rise);

/// Appends the residual terms (measured - simulated) and returns the sum of squares. level_terms
/// (P, Q, block differences) and other terms are returned separately for the offset.
void feature_residuals(const Features& measured, const Features& simulated,
                       const std::vector<WindowSpec>& windows, double rise,
                       std::vector<double>* level_terms, std::vector<double>* other_terms);

}  // namespace stickslip::diagnosis::detail
