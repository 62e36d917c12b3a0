#pragma once
// Validation of a diagnosis on new runs (issue 21 item 7; `stickslip validate`, POST
// /v1/validations): the calibrated base and extended models of a diagnosis.json (its "models")
// predict every run of a measured dataset, with no refit. Per run:
//  * the record read as the diagnosis reads it (noise, spikes, initial state; slip_stats.h);
//  * the measured statistics of every whole stage against those the two models predict (a
//    simulation from rest through a burn-in to the record's preload, over a span of some 25
//    drops, as the diagnosis' statistics scoring), the statistics score of each, and the issue's
//    criteria: mean force within 10 %, median drop and drop rate within 30 %;
//  * both models' F_d at every measured sample time, aligned at the record's initial state
//    (aligned_series, diagnose_statfit.h), and their RMSE against the record (a number to read
//    with care past the first slips of an irregular record).
// Output: DIR/validation.json (schemas/validation.schema.json), DIR/<run>.csv with the columns
// t, Fd_measured, Fd_base, Fd_extended (Fd_extended equals Fd_base when the diagnosis named no
// cause), and DIR/<run>.png (gnuplot: the whole record and its first periods).

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/measured/measured.h"

namespace stickslip::diagnosis {

/// One model's prediction of one stage of a run.
struct StagePrediction {
  int stage = 0;
  SlipStats measured, base, extended;
  double score_base = 0, score_extended = 0;  ///< RMS tolerance-scaled residual [-]
  /// Predicted (extended) over measured minus 1 [-]: mean force, median drop, drop rate (NaN
  /// without drops in either); reproduced: within 10 %, 30 %, 30 % (or no drops in either).
  double mean_error = 0, drop_error = 0, rate_error = 0;
  bool reproduced = false;
};

struct RunValidation {
  std::string run;
  measured::MeasuredConditions conditions;
  RunReading reading;
  std::vector<StagePrediction> stages;
  double rmse_base = 0, rmse_extended = 0;  ///< aligned series against the record [N]
  /// At the measured sample times [s], [N].
  std::vector<double> t, measured, base, extended;
  std::string status = "ok";  ///< or why a prediction failed
};

struct Validation {
  std::string diagnosis_dataset;  ///< the dataset the models were calibrated on
  std::string dataset;            ///< the one validated
  CalibratedModel base, extended;
  std::string cause;
  std::string verdict;            ///< the diagnosis' adequacy verdict
  std::vector<RunValidation> runs;
  double seconds = 0;
};

struct ValidateOptions {
  double rtol = 1e-7;           ///< engine accuracy (rtol = atol [N])
  int threads = 0;              ///< OpenMP threads over the runs (0 = default)
  std::function<bool()> stop_requested;             ///< as DiagnoseOptions'
  std::function<void(const Progress&)> progress;    ///< as DiagnoseOptions' (phase "validation")
  bool IsValid(std::string* why) const;
};

/// Predicts every run of data with the models of diagnosis (a diagnosis.json document). Throws
/// std::invalid_argument naming the field for a document without usable models, and
/// DiagnosisCancelled when stop_requested says so.
Validation validate(const nlohmann::json& diagnosis, const measured::MeasuredDataset& data,
                    const ValidateOptions& options = {});

/// validation.json (schemas/validation.schema.json; the series are not in it).
nlohmann::json to_json(const Validation& v);
std::string_view validation_schema_text() noexcept;
/// The CSV of one run: "t,Fd_measured,Fd_base,Fd_extended" and one line per measured sample.
std::string validation_csv(const RunValidation& r);
/// A short human-readable summary.
std::string summary_text(const Validation& v);
/// Writes dir/validation.json, dir/<run>.csv and, when gnuplot is on PATH, dir/<run>.png.
/// Returns the files written; plot failures are listed, never thrown.
std::vector<std::string> write_validation(const Validation& v, const std::filesystem::path& dir);

}  // namespace stickslip::diagnosis
