#pragma once
// Internal to the diagnosis: data-driven starting values for candidates whose size, shape and
// phase parameters cannot be guessed from a fixed grid (docs/diagnose.md "branch diag-shape").

#include <vector>

#include "stickslip/diagnosis/detail/diagnose_fit.h"

namespace stickslip::diagnosis::detail {

/// Starting points (eps, lambda, phi) for the waviness candidate, best first, from the measured
/// stick-slip peaks against the position where the body was stuck.
///
/// Physics: while the body sticks, x is constant and F_d = k_d (v_d t - x) rises until it reaches
/// the local static level F_S (1 + eps sin(2 pi x / lambda + phi)) (plus a presliding bias common
/// to every slip). So the measured peak P_k (the stick ramp extrapolated to the slip,
/// diagnose_features.h) against x_k = v_d t_k - (P_k - offset) / k_d, known from the data alone,
/// is c0 + a sin(2 pi x / lambda) + b cos(2 pi x / lambda): linear least squares (Eigen) for
/// every wavelength on a grid uniform in 1 / lambda (step 1 / (8 X), X the range of x_k), over
/// the extension's bounds limited to [2 X / n, 2 X] for n peaks (all runs). The local maxima of the drop
/// of the sum of squares are the starts: eps = hypot(a, b) / c0, phi = atan2(b, a).
///
/// Why not the residuals of the base model: with a hidden waviness every slip happens at a
/// different force, the base's slips drift out of phase with the measured ones, and its
/// residuals are slip-timing errors of several N (hidden waviness case, seed 1000: base fit
/// 0.42 N RMS, held-out 2.6 N; the residual spectrum peaked at lambda = 0.24 mm for the true
/// 1 mm). A linear scan of the cycle-feature residuals around the base optimum fails too: the
/// features are far from linear in the modulation (each peak moves the next stick position)
/// and the base parameters have absorbed part of the effect (measured, docs/diagnose.md).
///
/// Needs at least 5 distinct stick positions (2e-5 m apart; returns nothing otherwise, and the
/// caller falls back to the residual-spectrum starts).
std::vector<std::vector<double>> waviness_peak_starts(const Problem& p, double offset,
                                                      const std::vector<ParamSpec>& wave_specs,
                                                      int n_starts);

}  // namespace stickslip::diagnosis::detail
