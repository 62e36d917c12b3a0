#pragma once
// Sobol indices from Saltelli designs: first order S1, total ST and, with the BA blocks, second
// order S2; on any prefix of the base sample, in either run layout; and their convergence over
// nested prefixes N = 2^k.
//
// Design (Saltelli 2002; Saltelli et al. 2010). Base row j = 0, 1, ... is point j of a
// 2d-dimensional scrambled Sobol sequence (sobol_points): A_j its first d coordinates, B_j its last
// d. Each base row has these blocks (rows of the unit design):
//   block 0: A_j       block 1: B_j       block 2 + i: AB_i (A_j with column i taken from B_j)
//   block 2 + d + i: BA_i (B_j with column i taken from A_j; second order only)
// i.e. N (d + 2) runs, or N (2d + 2) with second order.
//
// Layouts (run index of base row j, block b):
//   kBlocks: b * N + j  (saltelli_design's order; studies stored before second order existed)
//   kRows  : j * blocks + b. A base row's runs are consecutive, so the first N' base rows are the
//            first N' * blocks runs, and extending N to 2N keeps every run at its index: Sobol point
//            j does not depend on N (the scrambling is a digital shift of each coordinate).
//
// Estimators (c: mean of f(A), f(B); V: their variance, population form), per parameter i, j:
//   S1_i  = mean[(f(B) - c)(f(AB_i) - f(A))] / V        Saltelli et al. 2010, Table 2 (b), with
//                                                       f(B) centred as SALib does
//   ST_i  = mean[(f(A) - f(AB_i))^2] / (2 V)            Jansen 1999 (Saltelli 2010, Table 2 (f))
//   S2_ij = mean[(f(BA_i) - c)(f(AB_j) - c) - (f(A) - c)(f(B) - c)] / V - S1_i - S1_j
//           (the closed index V^c_ij of Saltelli 2002, Theorem 1, minus both first orders; the
//           centring changes no expectation and removes the mean's contribution to the variance)
// Intervals: percentile bootstrap over base rows (the same row index selects every block).
//
// References: Saltelli A. (2002) Making best use of model evaluations to compute sensitivity
// indices. Comput. Phys. Commun. 145:280-297. Saltelli A. et al. (2010) Comput. Phys. Commun.
// 181:259-270. Jansen M.J.W. (1999) Comput. Phys. Commun. 117:35-43.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "stickslip/studies/sa_indices.h"

namespace stickslip::studies::sensitivity {

enum class SaltelliLayout { kBlocks, kRows };

struct SaltelliShape {
  std::size_t n = 0;  ///< base rows N
  std::size_t d = 0;  ///< parameters
  bool second_order = false;
  SaltelliLayout layout = SaltelliLayout::kBlocks;
  std::size_t blocks() const noexcept { return second_order ? 2 * d + 2 : d + 2; }
  std::size_t runs() const noexcept { return n * blocks(); }
  /// Run index of base row j, block b.
  std::size_t run(std::size_t j, std::size_t b) const noexcept;
};

/// Every run's unit-cube row in the shape's layout (shape.runs() rows of d columns). With
/// kBlocks and no second order it equals saltelli_design(n, d, seed).
Matrix saltelli_rows(const SaltelliShape& shape, std::uint64_t seed);

/// S1, ST (and S2 with second order) from y in the shape's layout, using the first n_used base
/// rows (0 = all). Undefined for a constant output (sa_indices.h). Throws std::invalid_argument
/// for a wrong size, a non-finite y, n_used > n, or bad options.
MethodIndices sobol_analysis(const std::vector<double>& y, const SaltelliShape& shape,
                             const BootstrapOptions& opt, std::size_t n_used = 0);

/// The prefix sizes of a convergence study: every power of two from n_min to n, and n itself
/// when it is not one (ascending; empty when n < n_min).
std::vector<std::size_t> convergence_sizes(std::size_t n, std::size_t n_min = 16);

struct ConvergenceStep {
  std::size_t n = 0;
  MethodIndices indices;
};

/// sobol_analysis on each prefix of convergence_sizes(shape.n, n_min). The first 2^k scrambled
/// Sobol points form a (t, k, 2d)-net, so every power-of-two prefix is a balanced design.
std::vector<ConvergenceStep> sobol_convergence(const std::vector<double>& y,
                                               const SaltelliShape& shape,
                                               const BootstrapOptions& opt,
                                               std::size_t n_min = 16);

}  // namespace stickslip::studies::sensitivity
