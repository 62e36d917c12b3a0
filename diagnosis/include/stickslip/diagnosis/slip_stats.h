#pragma once
// What a drive-force record says before any model is fitted, and the statistics of its
// stick-slip, computed the same way on a measured and a simulated signal (docs/diagnose.md
// "Statistics"); the diagnosis fits and scores models on them, and `stickslip validate` reports
// them. SI units: t [s], F_d [N].
//
// Noise (estimate_noise). The noise is taken as AR(1): e_k = rho e_{k-1} + ..., sd sigma. Its
// level and correlation come from robust (median absolute deviation) variances of the centred
// second differences d_h(k) = y_k - (y_{k-h} + y_{k+h}) / 2, which remove a ramp:
//   var d_h = sigma^2 (1 - q)(3 - q) / 2,  q = rho^h.
// Two estimates are made and the smaller level is kept (a signal only ever inflates one):
//  - lags 1-3: rho from var d_2 / var d_1 and var d_3 / var d_1. Blind to a smooth signal (its
//    curvature grows as h^4) but, at rho > ~0.85, rho = 0.89 and 0.99 differ by 3 % in
//    var d_3 / var d_1, so any excess sent rho to its clamp and sigma several times high;
//  - lags 1, 2, 3, 4, 6, 8, 12, 16, 24, 32 (those with 8 h <= the sample count): var d_h fitted
//    as sigma^2 (1 - q)(3 - q)/2 + c h^4 (the second term a smooth signal's curvature), sigma^2,
//    c >= 0 by least squares in relative residuals, rho on a grid of 0.001 in [0, 0.99]. The
//    samples near a slip or a spike are left out: centres within H (the longest lag) of one
//    whose |d_H| exceeds 4 robust sd are not used at any lag (twice, the second time with the
//    sd of what the first kept). A steady oscillation of a few tens of samples (the Colas
//    records' 30 Hz at 2 kHz) is curvature the h^4 term follows only at short lags: this
//    estimate reads it as correlated noise, and the lags 1-3 estimate is kept there.
// A fast oscillation of 30x the noise at 40 samples' period reads ~20 % high (the limit).
//
// Spikes (despike). A sample is an impulsive spike when it lies more than kSpikeSigmas sigma
// from the centre c of the medians L, R of the kSpikeHalf samples on either side, and L and R
// agree (|L - R| < |y - c| / 2): a slip's corner has very different levels on its two sides, a
// spike the same level. Flagged samples are replaced by c and counted (reported, never silently).
//
// Statistics (slip_stats), on the despiked signal smoothed by a centred moving average of
// `smooth` samples (the same for measured and simulated signals):
//  * level: mean, 5 % and 95 % quantiles; the local spread: the standard deviation about a moving
//    average over detrend_window (slow wander of the level, which no model here has, left out);
//  * drops: falls by more than `threshold` within `lag` samples (about a natural period of the
//    body on the drive spring: a slip takes about half of one, and so does the falling half of an
//    inertial oscillation, while a noisy stick ramp never falls that fast; a running-maximum
//    hysteresis would count the noise's excursions along a long ramp). The drop size is peak -
//    trough: median and quartiles; the drop rate (drops per second) and the time between drops
//    (median, quartiles, coefficient of variation);
//  * fall fraction: median of (fall time) / (fall + next rise time): a few per cent for
//    stick-slip (the slip is short, the stick long), about one half for an inertial oscillation;
//  * stick-ramp slope: median least-squares slope over the middle of each rise, over k_d v_d
//    (1: the body is stuck while the spring loads);
//  * creep: median ratio of the slope over the last quarter of a rise (before the slip) to the
//    middle slope (1: stuck up to the slip; < 1: the body creeps before it slips);
//  * spectrum: the frequency of the strongest band of the periodogram of the despiked signal
//    (linear trend removed; log-spaced bands, 12 per decade) above f_lo.
//  * regime: "stick_slip" (at least kMinDrops drops, fall fraction < kInertialFall), "inertial"
//    (drops, fall fraction >= kInertialFall: an oscillation about a sliding state), "creep"
//    (fewer drops: steady sliding, nothing above the noise).

#include <cstddef>
#include <string>
#include <vector>

namespace stickslip::diagnosis {

inline constexpr double kSpikeSigmas = 6.0;
inline constexpr int kSpikeHalf = 6;
inline constexpr int kMinDrops = 3;
inline constexpr double kInertialFall = 0.3;

struct NoiseEstimate {
  double sigma = 0;  ///< per-sample noise standard deviation [N]
  double rho = 0;    ///< lag-1 autocorrelation [-], in [0, 0.99]
};

/// AR(1) noise of a uniformly sampled signal (see above). Zero for fewer than 8 samples.
NoiseEstimate estimate_noise(const std::vector<double>& y);

/// y with its impulsive spikes replaced (see above); *flagged receives their indices.
std::vector<double> despike(const std::vector<double>& y, double sigma,
                            std::vector<std::size_t>* flagged);

/// Standard deviation of the mean of m consecutive samples of AR(1) noise (sigma, rho) [N].
double averaged_noise(double sigma, double rho, int m);

/// Standard deviation of the noise of y's moving average over m samples, measured on it: the
/// robust variance of z_k - (z_{k-m} + z_{k+m}) / 2 of the moving average z is 3/2 of it for
/// noise uncorrelated beyond m samples. Unlike averaged_noise it sees noise at every scale above
/// the sample interval (mains hum, vibration of the rig, the quantisation of a slow sensor), which
/// an AR(1) fitted at lags 1 and 2 misses.
double smoothed_noise(const std::vector<double>& y, int m);

/// Centred moving average over m samples (shorter windows at the ends).
std::vector<double> moving_average(const std::vector<double>& y, int m);

enum class Regime { kCreep, kStickSlip, kInertial };
/// "creep", "stick_slip", "inertial".
const char* to_string(Regime r) noexcept;

/// How the statistics of a signal are computed: one spec per record window, shared by the
/// measured signal and every simulation of it.
struct StatsSpec {
  double dt = 5e-4;              ///< sample interval [s]
  int smooth = 1;                ///< moving-average length [samples]
  double threshold = 0;          ///< a drop falls more than this [N] ...
  int lag = 1;                   ///< ... within this many samples (about a natural period)
  double rise = 0;               ///< k_d v_d [N/s]
  double f_lo = 0;               ///< lower edge of the spectral band [Hz]
  double detrend_window = 0;     ///< local spread's moving-average window [s]; 0: whole signal
  double noise_sd = 0;           ///< sd of the smoothed noise [N] (measured; see stats_residuals)
  /// The run's force level [N] (the median of its record): a mean level is judged relative to
  /// the larger of it and the window's own mean, so that a stage whose mean nearly vanishes (a
  /// vibrating base) is not judged in per cent of almost nothing.
  double level = 0;
};

struct SlipStats {
  double duration = 0;  ///< [s]
  double mean = 0, q05 = 0, q95 = 0, spread = 0;  ///< level [N]; spread = local sd [N]
  int drops = 0;
  double drop_median = 0, drop_q25 = 0, drop_q75 = 0;  ///< [N]
  double rate = 0;  ///< drops per second [1/s]
  double interval_median = 0, interval_q25 = 0, interval_q75 = 0, interval_cv = 0;  ///< [s], [-]
  double fall_fraction = 0;  ///< [-]
  double ramp_slope = 0;     ///< stick-ramp slope / (k_d v_d) [-]; NaN without rises
  double creep = 0;          ///< late / middle ramp slope [-]; NaN without rises
  double f_peak = 0;         ///< dominant frequency [Hz]; NaN when the band is empty
  Regime regime = Regime::kCreep;
};

/// Statistics of a uniformly sampled, despiked signal y (interval spec.dt).
SlipStats slip_stats(const std::vector<double>& y, const StatsSpec& spec);

/// Tolerance-scaled residuals simulated - measured, appended to *r (a fixed count per call:
/// kStatsResiduals), so that 1 is a miss at the tolerance: the mean by 10 % of the measured mean
/// (or of spec.level, when larger),
/// the drop size, drop rate, dominant frequency and local spread by a factor 1.3 (log ratio), the
/// ramp slope and fall fraction by 0.1, the creep ratio by 0.2. A statistic that one signal has and
/// the other lacks (no drops in one) costs kMissingStat. The simulated spread has the measured
/// noise (spec.noise_sd) added in quadrature (a simulation is noise-free).
inline constexpr std::size_t kStatsResiduals = 8;
inline constexpr double kMissingStat = 3.0;
void stats_residuals(const SlipStats& measured, const SlipStats& simulated, const StatsSpec& spec,
                     std::vector<double>* r);

/// The drop threshold for a noise level: kThresholdSigmas times the smoothed noise (a fall of 7
/// sigma within a natural period, about 6 independent smoothed values, happens by chance once in
/// ~10^6 of them), and at least 1e-6 N (a noise-free signal still needs a finite threshold).
inline constexpr double kThresholdSigmas = 7.0;
double drop_threshold(double smoothed_noise_sd);

}  // namespace stickslip::diagnosis
