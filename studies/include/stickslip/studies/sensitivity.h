#pragma once
// Sensitivity analysis: sample designs (scrambled Sobol points, the Saltelli design, Morris
// trajectories), the Morris estimator (mu, mu*, sigma) with bootstrap intervals, and the analytic
// test functions Ishigami and Sobol G with their exact indices. The other methods (Sobol S1, ST,
// S2; eFAST, RBD-FAST, delta, PAWN, DGSM) are in sa_*.h.
//
// All designs live on the unit hypercube [0,1]^d; studies map them onto parameter ranges.
//
// References:
//  - Saltelli A. et al. (2010) Variance based sensitivity analysis of model output. Design and
//    estimator for the total sensitivity index. Comput. Phys. Commun. 181:259-270 (the design).
//  - Morris M.D. (1991) Factorial sampling plans for preliminary computational experiments.
//    Technometrics 33:161-174; Campolongo F. et al. (2007) for mu*.

#include <cstdint>
#include <string>
#include <vector>

namespace stickslip::studies::sensitivity {

using Matrix = std::vector<std::vector<double>>;  ///< rows = points, columns = dimensions

/// n points of a d-dimensional Sobol sequence (Boost.Random's sobol engine), scrambled with a
/// seed-driven random digital shift so that independent seeds give independent replicates.
/// Points are strictly inside (0,1).
Matrix sobol_points(std::size_t n, std::size_t d, std::uint64_t seed);

/// Saltelli design with base sample size n over d inputs: n * (d + 2) rows, laid out in blocks
///   rows [0, n)                   : A
///   rows [n, 2n)                  : B
///   rows [(2+i) n, (3+i) n), i<d  : AB_i  (A with column i taken from B)
/// A and B are the two halves of a 2d-dimensional scrambled Sobol sequence. (saltelli_rows of
/// sa_sobol.h with the block layout and no second order.)
Matrix saltelli_design(std::size_t n, std::size_t d, std::uint64_t seed);

/// Morris design: r trajectories of (d + 1) points on a p-level grid (p even), step
/// delta = p / (2 (p - 1)). Rows [(d+1) k, (d+1)(k+1)) are trajectory k. Deterministic in seed.
Matrix morris_design(std::size_t r, std::size_t d, std::size_t levels, std::uint64_t seed);

struct Interval {
  double lo = 0.0, hi = 0.0;
};

/// Exact first-order and total indices of the analytic test functions (the estimators are in
/// sa_sobol.h).
struct SobolIndices {
  std::vector<double> S1, ST;          ///< per input
  std::vector<Interval> S1_ci, ST_ci;  ///< zero-width at the exact values
  double variance = 0.0;               ///< output variance
};

struct MorrisIndices {
  std::vector<double> mu, mu_star, sigma;  ///< per input
  std::vector<Interval> mu_star_ci;        ///< bootstrap over trajectories
};

/// x and y are the design rows (unit cube) and outputs of morris_design(r, d, ...).
/// sigma is the sample standard deviation (n - 1), NaN when r == 1 (not estimable).
/// Throws std::invalid_argument on bad sizes/arguments, a non-finite y, or rows that are not
/// Morris trajectories (each step must move exactly one new input).
MorrisIndices morris_indices(const Matrix& x, const std::vector<double>& y, std::size_t r,
                             std::size_t d, double confidence = 0.95,
                             std::size_t resamples = 1000, std::uint64_t seed = 1);

/// Ishigami function on inputs already mapped to [-pi, pi]: sin x1 + a sin^2 x2 + b x3^4 sin x1.
double ishigami(const std::vector<double>& x, double a = 7.0, double b = 0.1);
/// Analytic Ishigami indices (S1, ST) for a, b.
SobolIndices ishigami_exact(double a = 7.0, double b = 0.1);
/// Sobol G function on [0,1]^d: prod (|4 x_i - 2| + a_i) / (1 + a_i).
double sobol_g(const std::vector<double>& x, const std::vector<double>& a);
SobolIndices sobol_g_exact(const std::vector<double>& a);

}  // namespace stickslip::studies::sensitivity
