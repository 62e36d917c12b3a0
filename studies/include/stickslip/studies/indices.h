#pragma once
// Sensitivity indices of a stored study: Sobol (S1, ST) for a "sobol" design and Morris (mu, mu*,
// sigma) for a "morris" design, for any output of its runs, computed with the estimators of
// sensitivity.h from the runs in the store. Pure read-only functions of (store, study id, output
// names, options): the CLI (`stickslip indices`), the nightly report and the server's
// GET /v1/studies/{id}/indices all call indices_json() / compute_indices().
//
// Outputs (names):
//   "stage<k>.amplitude"   stick-slip amplitude of stage k [N] (k from 1)
//   "stage<k>.mean_force"  mean drive force of stage k [N]
//   "reduction_ratio"      amplitude of the last stage / amplitude of the first stage [-]
//   "y"                    the analytic model's value (ishigami, sobol_g; stored as stage 1's
//                          amplitude by the runner)
// Default outputs: "y" for analytic studies; otherwise every stage's amplitude and mean_force,
// plus reduction_ratio when there are at least two stages.
//
// Validity. The estimators need every point of the design. If any run is missing (not stored
// yet), failed (status "diverged" / "invalid") or has a non-finite output (e.g. reduction_ratio
// when stage 1 has no stick-slip, or a stage that was never reached), the output's indices are
// NOT computed: the result says valid = false, why, and lists every offending design index with
// its status. Points are never dropped silently (dropping a point of a Saltelli block or a Morris
// trajectory biases every index).
//
// Units. Sobol indices are fractions of the output variance [-]. Morris elementary effects are
// (y(x + delta e_i) - y(x)) / delta with delta measured on the UNIT cube, i.e. in output units per
// full parameter range, so mu* of different parameters are directly comparable.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/studies/sensitivity.h"
#include "stickslip/studies/spec.h"
#include "stickslip/store/store.h"

namespace stickslip::studies {

struct IndicesOptions {
  double confidence = 0.95;     ///< level of the bootstrap percentile intervals, in (0, 1)
  std::size_t resamples = 1000; ///< bootstrap resamples, >= 10
  std::uint64_t seed = 1;       ///< bootstrap seed (results are deterministic in it)
  std::size_t max_listed = 100; ///< at most this many offending points are listed per output
  bool IsValid(std::string* why) const;
};

/// A design point that makes an output's indices invalid.
struct InvalidPoint {
  std::int64_t design_index = 0;
  std::string status;  ///< "missing", "diverged", "invalid", or "ok" (run ok, output not finite)
  std::string reason;  ///< the run's error, or why the output is not finite
};

struct OutputIndices {
  std::string output;
  bool valid = false;
  std::string reason;                       ///< why not valid (empty when valid)
  std::size_t invalid_count = 0;            ///< points that make it invalid (all of them)
  std::vector<InvalidPoint> invalid_points; ///< the first IndicesOptions::max_listed of them
  double mean = 0.0, variance = 0.0;        ///< of the output over the design (valid only)
  std::optional<sensitivity::SobolIndices> sobol;    ///< sobol designs, valid only
  std::optional<sensitivity::MorrisIndices> morris;  ///< morris designs, valid only
};

struct StudyIndices {
  std::string study_id, study_name, state;
  std::string method;                   ///< "sobol" or "morris"
  std::vector<std::string> parameters;  ///< design variables (columns of the unit design)
  std::size_t n = 0;                    ///< sobol: base sample size N
  std::size_t trajectories = 0, levels = 0;  ///< morris: r and p
  std::int64_t total_runs = 0, stored_runs = 0, failed_runs = 0;
  /// Design points simulated with F_S raised to F_C (spec "F_S_below_F_C": "raise_F_S_to_F_C";
  /// the indices then describe y(x) = f(x with F_S = max(F_S, F_C))).
  std::int64_t F_S_raised_runs = 0;
  IndicesOptions options;
  std::vector<OutputIndices> outputs;
  bool valid() const noexcept;  ///< every output valid
};

/// The default outputs of a spec (see above).
std::vector<std::string> default_outputs(const StudySpec& spec);
/// Checks an output name against a spec; returns an error message naming the output, or "".
std::string check_output(const StudySpec& spec, const std::string& output);

/// Computes the indices of a stored study. outputs empty = default_outputs.
/// Throws StoreError for an unknown study or an unreadable store, and std::invalid_argument for
/// a study whose design is not sobol/morris, an unknown output name, or invalid options (the
/// message names the study, the output or the option and its value). Invalid runs do not throw:
/// they make the affected outputs invalid (see above).
StudyIndices compute_indices(store::Store& store, const std::string& study_id,
                             const std::vector<std::string>& outputs = {},
                             const IndicesOptions& options = {});

/// JSON form:
/// {"study_id", "study_name", "state", "method", "parameters": [...], "n" | "trajectories",
///  "levels", "total_runs", "stored_runs", "failed_runs", "confidence", "resamples", "valid",
///  "outputs": [{"output", "valid", "reason", "invalid_count", "invalid_points": [{"design_index",
///  "status", "reason"}], "mean", "variance", "indices": [
///     sobol : {"parameter", "S1", "S1_ci": [lo, hi], "ST", "ST_ci": [lo, hi]}
///     morris: {"parameter", "mu", "mu_star", "mu_star_ci": [lo, hi], "sigma"}]}]}
/// Non-finite numbers (sigma with one trajectory) are written as null. "indices" is [] when the
/// output is invalid.
nlohmann::json indices_to_json(const StudyIndices& indices);
/// A readable table: one block per output, one line per parameter.
std::string indices_to_table(const StudyIndices& indices);

/// compute_indices + indices_to_json: the handler body of GET /v1/studies/{id}/indices.
nlohmann::json indices_json(store::Store& store, const std::string& study_id,
                            const std::vector<std::string>& outputs = {},
                            const IndicesOptions& options = {});

}  // namespace stickslip::studies
