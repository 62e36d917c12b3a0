#pragma once
// Exact sensitivity indices of the analytic test functions, the references of the estimator tests
// (tests/studies/test_sa_*.cpp) and of the accuracy table in docs/report.md. ishigami_exact and
// sobol_g_exact (first order and total) are in sensitivity.h.
//
//   Ishigami f = sin x1 + a sin^2 x2 + b x3^4 sin x1, x ~ U(-pi, pi)^3:
//     second order: S12 = S23 = 0, S13 = b^2 pi^8 (1/18 - 1/50) / V (Sobol & Levitan 1999);
//     DGSM nu_i = E[(df/dx_i)^2]: nu1 = (1 + 2 b pi^4 / 5 + b^2 pi^8 / 9) / 2, nu2 = a^2 / 2,
//     nu3 = 8 b^2 pi^6 / 7 (from E[x^k] = pi^k / (k + 1) for even k and E[cos^2] = E[sin^2] = 1/2).
//   Sobol G on U(0,1)^d: S_ij = V_i V_j / V with V_i = 1 / (3 (1 + a_i)^2) (Saltelli et al. 2008).
//   Linear model y = sum a_i x_i, x_i ~ N(0, sigma_i^2) independent, V = sum a_i^2 sigma_i^2:
//     S1_i = ST_i = a_i^2 sigma_i^2 / V; DGSM nu_i = a_i^2, dgsm_i = sigma_i^2 nu_i / V = ST_i;
//     Y | X_i = x ~ N(a_i x, V - a_i^2 sigma_i^2), so Borgonovo's delta_i is the mean over
//     x ~ N(0, sigma_i^2) of the total-variation distance between N(0, V) and that normal (closed
//     form through the two crossing points of the densities), integrated by Gauss-Kronrod
//     quadrature (Boost.Math); PAWN's KS distance on an equal-probability interval of x_i is the
//     supremum over y of |F_{Y | X_i in interval}(y) - F_Y(y)|, the conditional CDF integrated the
//     same way and the supremum found on a fine grid refined by Brent's method.

#include <array>
#include <cstddef>
#include <vector>

namespace stickslip::studies::sensitivity {

/// {S12, S13, S23} of the Ishigami function.
std::array<double, 3> ishigami_second_order_exact(double a = 7.0, double b = 0.1);
/// nu_i = E[(df/dx_i)^2] of the Ishigami function in its own coordinates x in (-pi, pi).
std::array<double, 3> ishigami_dgsm_exact(double a = 7.0, double b = 0.1);
/// S_ij of the Sobol G function for i < j, in the order (0,1), (0,2), ..., (1,2), ...
std::vector<double> sobol_g_second_order_exact(const std::vector<double>& a);

/// Borgonovo's delta of each input of the linear Gaussian model (see above).
std::vector<double> linear_gaussian_delta_exact(const std::vector<double>& a,
                                                const std::vector<double>& sigma);

struct PawnExact {
  std::vector<double> median, max;  ///< over the conditioning intervals, per input
};
/// Population PAWN indices of the linear Gaussian model with `intervals` equal-probability
/// conditioning intervals.
PawnExact linear_gaussian_pawn_exact(const std::vector<double>& a,
                                     const std::vector<double>& sigma, std::size_t intervals);

}  // namespace stickslip::studies::sensitivity
