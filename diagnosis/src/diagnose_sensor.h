#pragma once
// Internal to the diagnosis: starting points of the sensor_dynamics candidate.
//
// A second-order force sensor (omega_n = 1 / tau, zeta) acts on stick-slip mostly as a delay
// of 2 zeta tau (7 ms for tau = 5 ms, zeta = 0.7) plus a rounding of each slip over ~20 ms.
// Measured with the engine (LuGre, hidden-effect suite parameters, v_a = 1.5 mm/s, still
// stage at 1 kHz): the filtered F_d differs from the ideal one by 0.40 N RMS, by 0.057 N after
// the best time shift (8 ms). A base model absorbs the delay almost exactly: a slip happens when
// the stick ramp k_d v_d t reaches F_S, so raising F_S (and the trough) by k_d v_d 2 zeta tau
// = 0.08 N delays every slip by 7 ms, and the fitted sensor offset takes the level back. What
// is left, the slip shape, the base absorbs with a far too small Stribeck velocity (hidden
// suite, seed 1000: v_s = 6.1e-5 for 3.2e-4 m/s, fit 0.19 N RMS), and the candidate refitted
// from there stays in that basin (tau 3.2 ms, zeta 1.24: the delay is right, the split of it
// is not; fit 0.081 N, worse than the base on held-out data).
//
// So, like viscous friction and drive damping (docs/diagnose.md "diag2"), the candidate gets
// profile starts with v_s held at its nominal value: for each sensor time constant of a grid
// (zeta = 0.7) the other base parameters are refitted on the cycle features with (v_s, tau,
// zeta) held; a free feature fit and the time-domain fit start from the best of them.

#include <vector>

#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/diagnosis/detail/diagnose_scale.h"
#include "stickslip/diagnosis/diagnose.h"

namespace stickslip::diagnosis::detail {

/// Held-v_s profile starts of the sensor_dynamics candidate (full theta: base parameters then
/// sensor_tau, sensor_zeta), appended to starts and held_starts. base / base_theta: the fitted
/// base model (its specs must contain v_s; otherwise nothing is added). Counts evaluations.
void sensor_profile_starts(const Problem& P, const FitModel& base,
                           const std::vector<double>& base_theta, const DiagnoseOptions& o,
                           const RecordScales& scales, std::vector<std::vector<double>>* starts,
                           std::vector<std::vector<double>>* held_starts, int* evals);

}  // namespace stickslip::diagnosis::detail
