#pragma once
// Sensitivity from given data: estimators that need only a sample of (x, y) pairs with independent
// inputs, so they run on any stored study with random, LHS, Sobol (its A and B rows) or RBD points.
// They use the inputs only through their ranks, so any monotone map of a column (unit cube,
// physical units, a log scale) gives the same indices.
//
// RBD-FAST first order (Tarantola et al. 2006) with the EASI reordering of Plischke (2010): sort
// the points by x_i, take the odd-numbered ones up and the even-numbered ones back down, so y
// becomes a periodic signal whose first M harmonics carry x_i's first-order effect:
//   S1_i = 2 sum_{f=1..M} P(f) / V, then S1_i - lambda / (1 - lambda) (1 - S1_i), lambda = 2M/n,
// the bias correction of Tissot & Prieur (2012) for the noise every frequency picks up (as SALib
// does; its default M = 10 is ours too).
//
// delta (Borgonovo 2007) with the given-data estimator of Plischke, Borgonovo & Smith (2013):
//   delta_i = 1/2 E_{X_i}[ integral |f_Y(y) - f_{Y|X_i}(y)| dy ],
// the inputs split into C equal-count classes by the rank of x_i, C = min(ceil(n^(2 / (7 +
// tanh((1500 - n) / 500)))), 48), each density a Gaussian kernel density estimate (bandwidth
// sd (3 m / 4)^(-1/5) for m points, scipy's Silverman rule as in SALib), evaluated by linear binning
// on a grid of 256 points over the range of y padded by 4 bandwidths, the integral by the
// trapezoid rule. Bias reduction as in Plischke et al. (2013) and SALib: delta = 2 d - mean(d*_b)
// over the bootstrap replicates d*_b; interval: percentiles of 2 d - d*_b.
// Boost.Math (1.74) has no kernel density estimator; the binned one here is needed anyway to make
// 1000 bootstrap replicates affordable (O(n + classes x grid x kernel width) each).
//
// PAWN (Pianosi & Wagener 2015; given-data version 2018): split the points into S equal-count
// conditioning intervals by the rank of x_i; in each, the two-sample Kolmogorov-Smirnov statistic
// between the empirical CDF of y on the interval and that of all y; pawn_i = the median over the
// intervals, pawn_max_i = the maximum. Boost.Math (1.74) has no two-sample KS statistic; ours runs
// in O(n) per parameter from precomputed ranks, which the bootstrap needs.
//
// Intervals: percentile bootstrap over the points (with replacement; ranks are reused, so each
// replicate is O(n) per parameter plus the density work of delta).
//
// References: Plischke E. (2010) An effective algorithm for computing global sensitivity indices
// (EASI). Reliab. Eng. Syst. Saf. 95:354-360. Tissot J.-Y., Prieur C. (2012) Bias correction for
// the estimation of sensitivity indices based on random balance designs. Reliab. Eng. Syst. Saf.
// 107:205-213. Borgonovo E. (2007) A new uncertainty importance measure. Reliab. Eng. Syst. Saf.
// 92:771-784. Plischke E., Borgonovo E., Smith C.L. (2013) Global sensitivity measures from given
// data. Eur. J. Oper. Res. 226:536-550. Pianosi F., Wagener T. (2015) A simple and efficient method
// for global sensitivity analysis based on cumulative distribution functions. Environ. Model.
// Softw. 67:1-11. Pianosi F., Wagener T. (2018) Distribution-based sensitivity analysis from a
// generic input-output sample. Environ. Model. Softw. 108:197-207.

#include <cstddef>
#include <vector>

#include "stickslip/studies/sa_indices.h"

namespace stickslip::studies::sensitivity {

/// RBD-FAST first-order indices "S1" of every column of x (n rows of d columns, n > 2 M).
MethodIndices rbd_fast_analysis(const Matrix& x, const std::vector<double>& y,
                                const BootstrapOptions& opt, std::size_t harmonics = 10);

/// Borgonovo's delta ("delta") of every column of x. n >= 20.
MethodIndices delta_analysis(const Matrix& x, const std::vector<double>& y,
                             const BootstrapOptions& opt);

/// PAWN indices "pawn" (median KS) and "pawn_max" (maximum KS) with `intervals` conditioning
/// intervals (n >= 5 intervals).
MethodIndices pawn_analysis(const Matrix& x, const std::vector<double>& y,
                            const BootstrapOptions& opt, std::size_t intervals = 10);

/// The class count of the delta estimator for n points (Plischke et al. 2013, as SALib).
std::size_t delta_classes(std::size_t n);

}  // namespace stickslip::studies::sensitivity
