#pragma once
// Derivative-based global sensitivity measures (DGSM) from finite differences.
//
//   nu_i   = E[(df/dx_i)^2]            Sobol & Kucherenko (2009); Kucherenko et al. (2009)
//   dgsm_i = C_i nu_i / V              an upper bound of the total index ST_i, C_i the Poincare
//                                      constant of input i: 1/pi^2 for U(0,1) (Sobol & Kucherenko
//                                      2009), sigma^2 for N(mu, sigma^2) (Lamboni et al. 2013)
// estimated over n base points x_j as nu_i = mean_j ((f(x_j + h_ij e_i) - f(x_j)) / h_ij)^2 and V
// the (population) variance of f over the base points. The step h_ij is read from the design rows
// themselves (it is negative where x_j + h e_i would leave the unit cube), so any coordinates can
// be differenced: the unit cube of a study, or physical coordinates in the tests. Intervals:
// percentile bootstrap over base points (nu and V recomputed together).
//
// References: Sobol I.M., Kucherenko S. (2009) Derivative based global sensitivity measures and
// their link with global sensitivity indices. Math. Comput. Simul. 79:3009-3017. Kucherenko S. et
// al. (2009) Monte Carlo evaluation of derivative-based global sensitivity measures. Reliab. Eng.
// Syst. Saf. 94:1135-1148. Lamboni M. et al. (2013) Derivative-based global sensitivity measures:
// general links with Sobol' indices and numerical tests. Math. Comput. Simul. 87:45-54.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "stickslip/studies/sa_indices.h"

namespace stickslip::studies::sensitivity {

/// n base points (a d-dimensional scrambled Sobol sequence), each followed by its d perturbed
/// copies: rows [j (d + 1), (j + 1)(d + 1)) are x_j, x_j + h e_1, ..., x_j + h e_d, with -h
/// instead of h where x_ji + h > 1. Extensible like the Saltelli kRows layout: base point j's rows
/// do not depend on n. step in (0, 0.5].
Matrix dgsm_design(std::size_t n, std::size_t d, double step, std::uint64_t seed);

/// nu and dgsm (see above) from rows x and outputs y in dgsm_design's layout (n (d + 1) rows).
/// poincare[i] > 0 is input i's Poincare constant in the coordinates of x (1/pi^2 for the unit
/// cube). Throws std::invalid_argument on bad sizes, rows that are not base point + one moved
/// coordinate, non-finite y or bad options; a constant output is undefined (sa_indices.h).
MethodIndices dgsm_analysis(const Matrix& x, const std::vector<double>& y, std::size_t n,
                            std::size_t d, const std::vector<double>& poincare,
                            const BootstrapOptions& opt);

/// The Poincare constant of U(0, 1), 1 / pi^2.
double unit_uniform_poincare();

}  // namespace stickslip::studies::sensitivity
