#pragma once
// Sensitivity indices of a stored study, for any outputs of its runs (outputs.h), with the
// estimators of sa_*.h and sensitivity.h: pure read-only functions of (store, study id, output
// names, options). The CLI (`stickslip indices`), the nightly report and the server's
// GET /v1/studies/{id}/indices all call compute_indices() / indices_json().
//
// Methods (IndicesOptions::method; "" = the design's own):
//   design sobol    : "sobol" (S1, ST, and S2 with second_order) | given data
//   design efast    : "efast"            design morris : "morris"      design dgsm : "dgsm"
//   design rbd_fast : "rbd_fast" | given data
//   design random / lhs : "delta" | given data
// Given data: "rbd_fast", "delta", "pawn" on the design's points (for sobol: its A and B rows).
//
// Each output's status:
//   "ok"        indices computed (possibly with warnings: a near-constant output, or one whose
//               points nearly all share a value);
//   "invalid"   a run is missing or failed, or the output is not defined at some point (e.g.
//               reduction_ratio where stage 1 has no stick-slip): the estimators need every
//               point of the design, so nothing is computed; the offending points are listed;
//   "undefined" the output is constant over the design: variance-based indices are 0/0, so none
//               is reported (never zeros), with the reason. (Morris stays "ok": an elementary
//               effect of 0 is well defined; it carries a warning instead.)
//
// Units. Variance-based indices are fractions of the output variance [-]; delta and PAWN are in
// [0, 1]; Morris' elementary effects and DGSM's nu are per UNIT-CUBE step (output units per full
// parameter range), so different parameters compare directly.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/store/store.h"
#include "stickslip/studies/sa_indices.h"
#include "stickslip/studies/sa_sobol.h"
#include "stickslip/studies/spec.h"

namespace stickslip::studies {

struct IndicesOptions {
  double confidence = 0.95;     ///< level of the bootstrap percentile intervals, in (0, 1)
  std::size_t resamples = 1000; ///< bootstrap resamples, >= 10
  std::uint64_t seed = 1;       ///< bootstrap seed (results are deterministic in it)
  std::size_t max_listed = 100; ///< at most this many offending points are listed per output
  std::string method;           ///< "" = the design's own method (see above)
  bool keep_resamples = false;  ///< keep every bootstrap replicate in the result
  bool convergence = false;     ///< sobol: also the indices on the prefixes N = 16, 32, ...
  /// True if every field holds. Otherwise appends one message per broken constraint, naming the
  /// field and the value, to *errors when errors is non-null.
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// A design point that makes an output's indices invalid.
struct InvalidPoint {
  std::int64_t design_index = 0;
  std::string status;  ///< "missing", "diverged", "invalid", or "ok" (run ok, output not finite)
  std::string reason;  ///< the run's error, or why the output is not finite
};

struct OutputIndices {
  std::string output;
  std::string status = "invalid";           ///< "ok", "invalid" or "undefined" (see above)
  std::string reason;                       ///< why not ok
  std::vector<std::string> warnings;        ///< ok outputs that deserve a second look
  std::size_t invalid_count = 0;            ///< points that make it invalid (all of them)
  std::vector<InvalidPoint> invalid_points; ///< the first IndicesOptions::max_listed of them
  double mean = 0.0, variance = 0.0;        ///< over the points used (ok and undefined)
  std::optional<sensitivity::MethodIndices> indices;  ///< ok only
  std::vector<sensitivity::ConvergenceStep> convergence;  ///< sobol, on request
  /// Indices computed (status ok). An undefined output is not valid but not invalid either.
  bool valid() const noexcept { return status == "ok"; }
};

/// The "until" rule of a Sobol design evaluated on the runs stored so far.
struct UntilStatus {
  double max_st_width = 0.0;
  std::size_t n = 0, n_max = 0;  ///< base sample size now, and its limit
  double widest = 0.0;           ///< widest ST interval over the judged outputs (NaN: none)
  std::string widest_at;         ///< "output/parameter" of the widest interval
  bool grow = false;             ///< the runner doubles n (to next_n)
  std::size_t next_n = 0;
  std::string reason;            ///< why it grows or stops
};

struct StudyIndices {
  std::string study_id, study_name, state;
  std::string design;                   ///< the design type
  std::string method;                   ///< see above
  std::vector<std::string> parameters;  ///< design variables (columns of the unit design)
  std::size_t n = 0;      ///< sobol/dgsm: base rows used; efast: points per curve; given data: points
  std::size_t trajectories = 0, levels = 0;  ///< morris: r and p
  std::size_t replicates = 0, harmonics = 0; ///< efast
  bool second_order = false;                 ///< sobol
  std::int64_t total_runs = 0, stored_runs = 0, failed_runs = 0;
  /// Design points simulated with F_S raised to F_C (spec "F_S_below_F_C": "raise_F_S_to_F_C";
  /// the indices then describe y(x) = f(x with F_S = max(F_S, F_C))).
  std::int64_t F_S_raised_runs = 0;
  IndicesOptions options;
  std::vector<OutputIndices> outputs;
  std::optional<UntilStatus> until;     ///< sobol designs with "until"
  bool valid() const noexcept;          ///< every output ok
  bool complete() const noexcept;       ///< no output invalid (ok or undefined)
};

/// The default outputs of a spec (outputs.h).
std::vector<std::string> default_outputs(const StudySpec& spec);
/// Checks an output name against a spec; returns an error message naming the output, or "".
std::string check_output(const StudySpec& spec, const std::string& output);
/// The spec of a stored study (parsed without the run limit: it was checked when created).
StudySpec stored_spec(const store::StudyRecord& study);

/// Computes the indices of a stored study. outputs empty = default_outputs.
/// Throws StoreError for an unknown study or an unreadable store, and std::invalid_argument for
/// a design without indices (grid, list), a method the design does not support, an unknown
/// output name, or invalid options (the message names the study, the output or the option and
/// its value). Invalid runs do not throw: they make the affected outputs invalid.
StudyIndices compute_indices(store::Store& store, const std::string& study_id,
                             const std::vector<std::string>& outputs = {},
                             const IndicesOptions& options = {});

/// The "until" rule of a stored Sobol study with one: is its widest ST interval over the
/// rule's outputs at most max_st_width with the runs stored now, and if not, to what base size
/// does it grow? nullopt for a study without the rule. Used by the runner after each round.
std::optional<UntilStatus> until_status(store::Store& store, const std::string& study_id);

/// JSON form (docs/report.md; schemas/openapi.json "StudyIndices"):
/// {"study_id", "study_name", "state", "design", "method", "parameters": [...], "n",
///  "trajectories", "levels" (morris), "replicates", "M" (efast), "second_order" (sobol),
///  "total_runs", "stored_runs", "failed_runs", "F_S_raised_runs", "confidence", "resamples",
///  "seed", "valid", "until" (sobol with until: {"max_st_width", "n", "n_max", "widest",
///  "widest_at", "grow", "next_n", "reason"}),
///  "heatmap": {"index", "parameters", "outputs", "value": [[output][parameter]], "ci":
///              [[output][parameter] -> [lo, hi]], "status": [per output]},
///  "outputs": [{"output", "status", "valid" (status ok), "reason", "warnings", "invalid_count",
///   "invalid_points": [{"design_index", "status", "reason"}], "mean", "variance",
///   "indices": [{"parameter", <index>, <index>_ci, <index>_resamples?}], "second_order"?,
///   "notes", "convergence"?: [{"n", "indices": [...]}]}]}
/// Non-finite numbers are written as null; "indices" is [] unless the status is ok.
nlohmann::json indices_to_json(const StudyIndices& indices);
/// A readable table: one block per output, one line per parameter ("≈ 0" rule of sa_json.h).
std::string indices_to_table(const StudyIndices& indices);

/// compute_indices + indices_to_json: the handler body of GET /v1/studies/{id}/indices.
nlohmann::json indices_json(store::Store& store, const std::string& study_id,
                            const std::vector<std::string>& outputs = {},
                            const IndicesOptions& options = {});

}  // namespace stickslip::studies
