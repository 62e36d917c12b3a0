#pragma once
// Stored runs as JSON and CSV, for `stickslip study export` and the server's run listings.
#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/store/store.h"

namespace stickslip::studies {

/// {"design_index", "model", "va_over_vd", "status", "error", "params": {...}, "param_hash",
///  "wall_time_s", "t_end", "steps", "rmse", "finished_at", "stages": [{"stage", "t_start", ...}]}
/// with NaN written as null.
nlohmann::json run_to_json(const store::RunRecord& run);
nlohmann::json study_to_json(const store::StudyRecord& study, const store::RunCounts& counts);

/// CSV header for runs with `stages` stages: design_index,model,va_over_vd,status,<params...>,
/// then per stage s: amplitude_s, amplitude_raw_s, mean_force_s, mean_friction_s,
/// slip_events_s, mean_period_s, rmse_s; then rmse, wall_time_s, steps, error.
/// param_names are the parameter columns (e.g. from the first run's params).
std::string runs_csv_header(const std::vector<std::string>& param_names, std::size_t stages);
/// One CSV line (with "\n") per run, in the header's column order.
std::string runs_csv_rows(const std::vector<store::RunRecord>& runs,
                          const std::vector<std::string>& param_names, std::size_t stages);
/// The parameter names of a run's params_json, sorted, "model" excluded.
std::vector<std::string> param_names_of(const store::RunRecord& run);

}  // namespace stickslip::studies
