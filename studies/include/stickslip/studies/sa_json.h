#pragma once
// JSON and text forms of a method's indices (sa_indices.h), shared by `stickslip indices`, the
// nightly report and GET /v1/studies/{id}/indices.
//
// JSON of one output's indices (docs/report.md, schemas/openapi.json "OutputIndices"):
//   "indices": [{"parameter": "F_S", "S1": 0.12, "S1_ci": [0.05, 0.19], "ST": ..., "ST_ci": ...}]
//     one object per parameter with every index of the method; "<name>_ci" is present when the
//     index has intervals ([lo, hi], null ends when not estimable), "<name>_resamples" when the
//     bootstrap replicates were kept;
//   "second_order": [{"parameters": ["F_S", "F_C"], "S2": ..., "S2_ci": [...]}]  (Sobol with BA
//     blocks only; otherwise absent).
// Non-finite numbers are written as null.
//
// Display rule ("≈ 0"): an index estimated below 0 whose interval covers 0 is shown as "≈ 0"
// followed by the estimate; below 0 with an interval that excludes 0 it is shown with "(< 0!)",
// which means the estimator's sampling error at this N exceeds its interval (raise N).

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/studies/sa_indices.h"

namespace stickslip::studies::sensitivity {

/// Fills "indices" (and "second_order" when the result has pairs) of `out` from m, the parameter
/// names in design order. An undefined m gives "indices": [].
void write_method_json(const MethodIndices& m, const std::vector<std::string>& parameters,
                       nlohmann::json& out);

/// The text of one index value for tables: printf-formatted with `format`, with the "≈ 0" rule
/// above applied when ci is given.
std::string display_index(double value, const Interval* ci, const char* format = "%.3f");

/// "[lo, hi]" with `format`, "–" for a missing end.
std::string display_interval(const Interval& ci, const char* format = "%.3f");

}  // namespace stickslip::studies::sensitivity
