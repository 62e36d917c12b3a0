#pragma once
// Result types shared by the sensitivity methods (sa_sobol.h, sa_fast.h, sa_given.h, sa_dgsm.h).
//
// Every method returns named indices, one value per parameter (and, for Sobol's second order, per
// pair of parameters), each with a bootstrap percentile interval and, on request, the bootstrap
// replicates themselves. The names are the JSON keys of `stickslip indices --json` and
// GET /v1/studies/{id}/indices: "S1", "ST", "S2" (Sobol, eFAST, RBD-FAST), "delta" (Borgonovo),
// "pawn", "pawn_max" (PAWN), "nu", "dgsm" (DGSM). docs/report.md says what each one means.
//
// Undefined indices. An output that takes one value at every point has no variation to attribute
// to the parameters: every variance-based index is 0/0 and the distribution-based ones compare a
// point mass with itself. Such a result has defined = false and a reason, and no index values:
// it is never reported as zeros.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "stickslip/studies/sensitivity.h"

namespace stickslip::studies::sensitivity {

/// How the intervals are made: percentile bootstrap over the method's resampling units (base
/// rows for Sobol and DGSM, replicates for eFAST, points for the given-data methods).
struct BootstrapOptions {
  double confidence = 0.95;      ///< interval level, in (0, 1)
  std::size_t resamples = 1000;  ///< bootstrap resamples, > 0
  std::uint64_t seed = 1;        ///< the intervals are a deterministic function of it
  bool keep_resamples = false;   ///< keep every replicate in IndexValues::resamples
  /// True if every field holds. Otherwise appends one message per broken constraint, naming the
  /// field and the value, to *errors when errors is non-null.
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// One named index for every parameter (or parameter pair).
struct IndexValues {
  std::string name;
  std::vector<double> value;
  /// Percentile intervals; empty when the index has none (e.g. eFAST with one replicate). An end
  /// is NaN when fewer than half of the replicates were finite (see sa_bootstrap).
  std::vector<Interval> ci;
  std::vector<std::vector<double>> resamples;  ///< [item][b]; empty unless keep_resamples
};

struct MethodIndices {
  std::string method;     ///< "sobol", "efast", "rbd_fast", "delta", "pawn" or "dgsm"
  bool defined = true;    ///< false for a constant output (see above)
  std::string reason;     ///< why not defined
  std::size_t units = 0;  ///< how many units the bootstrap resampled
  double variance = 0.0;  ///< output variance over the points the method used
  std::vector<IndexValues> per_parameter;
  std::vector<std::array<std::size_t, 2>> pairs;  ///< (i, j), i < j: the items of per_pair
  std::vector<IndexValues> per_pair;
  std::vector<std::string> notes;  ///< e.g. why an interval is missing
  /// The per-parameter index of that name, or nullptr.
  const IndexValues* find(const std::string& name) const;
};

}  // namespace stickslip::studies::sensitivity
