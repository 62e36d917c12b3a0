#pragma once
// Fourier amplitude sensitivity tests: the extended FAST (eFAST) design and estimator of first-order
// and total indices, and the random balance design (RBD) of RBD-FAST. RBD-FAST's estimator works
// on any sample and is in sa_given.h.
//
// eFAST (Saltelli, Tarantola & Chan 1999). For each parameter i a search curve of n points
// s_k = 2 pi k / n drives every input along x_j(s) = 1/2 + arcsin(sin(omega_j s + phi_j)) / pi
// (uniform on [0, 1]), with omega_i = omega_max = floor((n - 1) / (2 M)) for parameter i and low
// complementary frequencies for the others (SALib's fast_sampler assignment), phi_j random phases.
// With the power spectrum P(f) of y along the curve and V its variance:
//   S1_i = 2 sum_{p=1..M} P(p omega_i) / V,   ST_i = 1 - 2 sum_{f=1..omega_i/2} P(f) / V.
// Replicates: the design repeats the d curves `replicates` times with independent random phases
// (the resampling scheme of Saltelli et al. 1999, section 4); indices are the mean over the
// replicates, intervals the percentile bootstrap over replicates (none with one replicate).
// Requires n > 4 M^2 (omega_max >= 2M, so each complementary frequency is >= 1).
//
// RBD (Tarantola, Gatelli & Mara 2006): n points s_k = -pi + 2 pi (k + 1/2) / n; input i takes
// x_i = 1/2 + arcsin(sin(s_{perm_i(k)})) / pi with an independent random permutation perm_i per
// input, so each column is a uniform triangle-wave sample and the columns are independent.
//
// Only a few harmonics are needed per curve (M + omega/2 for eFAST, M for RBD-FAST), so they are
// summed directly (O(n) each, with a table of the n-th roots of unity) instead of a full FFT.
//
// References: Saltelli A., Tarantola S., Chan K.P.-S. (1999) A quantitative model-independent
// method for global sensitivity analysis of model output. Technometrics 41:39-56. Tarantola S.,
// Gatelli D., Mara T.A. (2006) Random balance designs for the estimation of first order global
// sensitivity indices. Reliab. Eng. Syst. Saf. 91:717-727.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "stickslip/studies/sa_indices.h"

namespace stickslip::studies::sensitivity {

struct EfastShape {
  std::size_t n = 0;           ///< points per search curve, > 4 M^2
  std::size_t d = 0;           ///< parameters (one curve each per replicate)
  std::size_t M = 4;           ///< interference factor: harmonics counted in S1
  std::size_t replicates = 1;  ///< independent random-phase repetitions of the d curves
  std::size_t runs() const noexcept { return replicates * d * n; }
  /// Run index of point k of the curve of parameter i in replicate r.
  std::size_t run(std::size_t r, std::size_t i, std::size_t k) const noexcept {
    return (r * d + i) * n + k;
  }
  /// True if every field holds. Otherwise appends one message per broken constraint, naming the
  /// field and the value, to *errors when errors is non-null.
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// [0]: omega_max, the frequency of the curve's own parameter; [1..d-1]: the frequencies of the
/// other parameters, in parameter order skipping the curve's own.
std::vector<std::size_t> efast_frequencies(const EfastShape& shape);

/// Every run's unit-cube row (shape.runs() rows of d columns). Phases are drawn in run order from
/// the seed, so replicate r's rows do not depend on the number of replicates.
Matrix efast_design(const EfastShape& shape, std::uint64_t seed);

/// S1 and ST from y in efast_design's order. Throws std::invalid_argument for a wrong size, a
/// non-finite y or bad options; a constant output is undefined (sa_indices.h).
MethodIndices efast_analysis(const std::vector<double>& y, const EfastShape& shape,
                             const BootstrapOptions& opt);

/// Tarantola et al. (2006) random balance design: n rows of d columns (see above). n >= 2.
Matrix rbd_design(std::size_t n, std::size_t d, std::uint64_t seed);

}  // namespace stickslip::studies::sensitivity
