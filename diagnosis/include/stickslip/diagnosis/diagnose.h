#pragma once
// Diagnosis of measured drive-force data (issue 5): calibrate the four base models, pick the
// best on held-out data, fit every catalogue extension with the base parameters refitted, test
// each against the refitted base, and name the cause (or "none").
//
// Method (details in docs/diagnose.md):
//  * Data. Each run's samples are decimated to about fit_rate. In every stage the last
//    holdout_fraction is held out (time blocks within runs); the rest of the first (still)
//    stage and the first later_stage_fit_span seconds of each later stage are fitted.
//  * Objective. Sum of squared time-domain residuals measured - simulated - offset over the fit
//    samples; the offset (one constant per dataset, a sensor bias) is solved in closed form.
//    Parameters are mapped to a unit box (log scale for scale parameters). Every fit starts on
//    per-cycle / per-stage features (slip times, stick ramps, stage-2 block means, window mean
//    and standard deviation; diagnose_features.h), fitted by Levenberg-Marquardt, then refines
//    in the time domain by Levenberg-Marquardt on the sample residuals (its Jacobian's step
//    refined when the steps crawl along the slip-timing valley; NLopt's BOBYQA only when LM
//    makes no step). Extensions start from the base optimum plus
//    starting values of their own (residual spectrum against x for waviness, phase grids), and
//    the slip-acting ones (viscous, drive_damping, stribeck_shape, dwell_time) from profile
//    starts: the base refitted on the features with the extension held at each starting size
//    (viscous and drive_damping also with v_s held at its nominal value, then freed).
//  * Scoring. The base and every candidate's final point are scored by one evaluation over
//    the full span at rtol_score; a candidate whose optimum scores worse on the fit set than
//    the base point is reported at the base point (it nests the base: at_base_point).
//  * Whole runs held out (whole_run_holdout). For every run k: the best base and the named
//    cause's model refitted (time-domain Levenberg-Marquardt, at most max_evals_fold
//    evaluations, started from their all-run optima) on the fit samples of the other runs, then
//    scored on every sample of run k (the seed's Table 2 RMSE of a v_a the fit has not seen).
//    Reported, not used to name the cause.
//  * Uncertainty. Covariance s^2 (J^T J)^-1 from the finite-difference Jacobian of the
//    residuals (Eigen), inflated by n / n_eff for correlated residuals.
//  * Significance. Likelihood ratio n_eff ln(SSE_base / SSE_ext) ~ chi^2(k) with n_eff =
//    n (1 - rho) / (1 + rho) from the AR(1) coefficient rho of the base residuals; Holm's
//    correction over the candidates; and a minimum effect size: the held-out error improves and,
//    in the time domain, the share of the base's held-out error above the record's noise floor
//    that the extension removes (gain_over_noise) is >= min_gain.
//    Every significant candidate also triggers a base-only refit from its base parameters
//    (all in parallel); the best refit, if better, becomes the null and the tests are redone,
//    so an extension never wins only because the base optimisation had stopped early. Among the
//    significant candidates the cause is the one with the lowest n_eff ln(SSE/n) + 2 k on the
//    fit set (base n_eff for all).

#include <filesystem>
#include <functional>
#include <stdexcept>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "stickslip/diagnosis/slip_stats.h"
#include "stickslip/engine/params.h"
#include "stickslip/engine/simulate.h"
#include "stickslip/measured/measured.h"

namespace stickslip::diagnosis {

/// Where a running diagnosis is (DiagnoseOptions::progress).
struct Progress {
  std::string phase;        ///< "reading", "calibration", "candidates", "refits", "whole runs", "done"
  std::string item;         ///< the models or candidates in work, e.g. "lugre, dahl"
  int evaluations = 0;      ///< model evaluations done
  int estimated_total = 0;  ///< the diagnosis' evaluation budget (an upper estimate)
  double seconds = 0;       ///< elapsed [s]
  double seconds_left = 0;  ///< estimate from the rate so far [s]; NaN before there is one
};

/// The default candidates: the engine's catalogue without aging. aging is fitted when asked for
/// (DiagnoseOptions::candidates) but is no default candidate: its fit does not leave the base's
/// basin (the base absorbs regular aging into F_S), so it was never named on a hidden aging case
/// (docs/diagnose.md, "Limits").
const std::vector<engine::ExtensionKind>& default_candidates();

struct DiagnoseOptions {
  std::vector<engine::ModelKind> models = engine::all_models();  ///< every registered model
  std::vector<engine::ExtensionKind> candidates = default_candidates();
  double fit_rate = 250.0;              ///< decimated samples per second [Hz]
  double holdout_fraction = 0.3;        ///< last part of every stage held out [-]
  double later_stage_fit_span = 2.0;    ///< seconds of each later stage fitted [s]
  double short_window = 3.0;            ///< base models' first fit window [s]
  double rtol = 1e-5;                   ///< engine accuracy while fitting (rtol = atol [N])
  /// Engine accuracy of the final scoring (fit-set SSE for the LR test and the information
  /// criterion, held-out RMSE) of the base and of every candidate's fitted point: one span,
  /// one code path, one accuracy for all, so that the comparisons are not decided by
  /// integration error (docs/diagnose.md "Scoring").
  double rtol_score = 1e-7;
  int max_evals_base = 70;              ///< objective evaluations per base model
  int max_evals_candidate = 160;        ///< objective evaluations per extension (phases A + B)
  int max_evals_profile = 12;           ///< per profile start (base refit at a fixed size)
  double alpha = 0.01;                  ///< family-wise significance level [-]
  double min_gain = 0.1;                ///< minimum held-out gain over the noise to name a cause [-]
  bool fit_offset = true;               ///< fit one constant sensor offset [N]
  bool keep_traces = true;              ///< keep measured/base/extended series for plots
  /// Leave each whole run out in turn (needs >= 2 runs): refit on the others, score on it.
  bool whole_run_holdout = true;
  int max_evals_fold = 30;              ///< evaluations per refit of a left-out-run fold
  int threads = 0;                      ///< OpenMP threads (0 = default)
  /// Polled before every model evaluation (from any thread; must be thread-safe). Once it
  /// returns true, the evaluations fail at once and diagnose throws DiagnosisCancelled. Not part
  /// of a request: the server's worker sets it to stop a cancelled or interrupted diagnosis.
  std::function<bool()> stop_requested;
  /// Called with the diagnosis' progress, from any thread, at most every progress_interval
  /// seconds and at each change of phase (must be thread-safe; the calls never overlap). Not part
  /// of a request: the CLI prints it, the server's worker keeps it in the job's state.
  std::function<void(const Progress&)> progress;
  double progress_interval = 0.5;  ///< [s]

  bool IsValid(std::string* why) const;
};

/// Thrown by diagnose when DiagnoseOptions::stop_requested returned true.
struct DiagnosisCancelled : std::runtime_error {
  DiagnosisCancelled() : std::runtime_error("diagnosis cancelled") {}
};

struct ParamEstimate {
  std::string name;
  double value = 0;   ///< SI
  double stderr_ = 0; ///< standard error (SI); NaN when the Jacobian is singular
};

/// Per-stage cycle statistics of a signal (StageAccumulator definitions, simulate.h).
struct StageScore {
  int run = 0, stage = 0;
  double measured_amplitude = 0, model_amplitude = 0;  ///< [N]
  double measured_mean = 0, model_mean = 0;            ///< [N]
  double measured_period = 0, model_period = 0;        ///< [s]
  int measured_slips = 0, model_slips = 0;
};

/// Whether the calibration freed a parameter: "fitted" (in the fit's box), or "held" at a value
/// because the data cannot identify it (why: the test it failed, with the numbers).
struct ParamStatus {
  std::string name;
  std::string status;  ///< "fitted" or "held"
  double value = 0;    ///< SI
  std::string why;
};

struct BaseCalibration {
  engine::ModelKind model = engine::model_kind<engine::LuGre>;
  std::string status = "ok";  ///< "ok" or why the calibration failed
  std::vector<ParamEstimate> params;
  double offset = 0;           ///< fitted sensor offset [N]
  double rmse_fit = 0, rmse_heldout = 0;  ///< [N]
  std::vector<double> rmse_run;  ///< whole-run RMSE per run (seed eq. 23) [N]
  double aic = 0;              ///< n_eff ln(SSE/n) + 2 k on the fit set
  int evals = 0;
  std::vector<StageScore> stages;
  /// Statistics scoring: the RMS of the tolerance-scaled statistics residuals (slip_stats.h) over
  /// the fitted and the held-out windows [-] (1 = off by the tolerance); computed in both
  /// scorings for the adequacy verdict.
  double score_fit = 0, score_heldout = 0;
  /// Every parameter of the model: fitted, or held and why (scale-free starts, diagnose_scale.h).
  std::vector<ParamStatus> identifiability;
  /// Rank of the Jacobian of the fit residuals at the optimum over the fitted parameters, and its
  /// condition number (largest / smallest singular value); rank < fitted: some combination of
  /// them is not identified (see weakest).
  int jacobian_rank = 0;
  double condition = 0;
  std::string weakest;  ///< the parameters of the smallest singular direction, by weight
};

struct CandidateResult {
  engine::ExtensionKind kind = engine::ExtensionKind::kNone;
  std::string status = "ok";
  std::vector<ParamEstimate> params;       ///< extension parameters (SI), size parameter first
  std::vector<ParamEstimate> base_params;  ///< refitted base parameters
  double offset = 0;
  double rmse_fit = 0, rmse_heldout = 0;   ///< [N]
  double gain = 0;         ///< 1 - rmse_heldout / base rmse_heldout
  /// Time domain: the share of the base's held-out error above the noise floor sigma that the
  /// extension removes, 1 - sqrt((rmse_heldout^2 - sigma^2) / (base^2 - sigma^2)), 0 when the
  /// base is within the noise's sampling error of sigma; statistics: = gain.
  double gain_over_noise = 0;
  double aic = 0;          ///< on the same footing as the base's
  double lr = 0;           ///< likelihood-ratio statistic against the refitted base
  int dof = 0;             ///< extra parameters
  double p_value = 1, p_holm = 1;
  /// Time domain: |size - neutral| / its standard error (the first extension parameter; for
  /// normal_load_modulation the larger component); 0 when that error is not finite. NaN in
  /// statistics scoring (no standard errors).
  double size_z = 0;
  bool significant = false;  ///< p_holm < alpha, gain > 0, gain_over_noise >= min_gain, size_z >= 2
  /// The candidate's own optimum scored worse than the base it nests, so it is reported at
  /// the base point (its extension at the neutral size): an extended model is never worse
  /// than its base.
  bool at_base_point = false;
  int evals = 0;
  double score_fit = 0, score_heldout = 0;  ///< statistics scores, as BaseCalibration's [-]
  /// On an inadequate base only: the verdict on the extended model of a candidate that passed
  /// the tests, "adequate" or "inadequate: <what it misses>"; only an adequate one is named.
  /// Empty when not judged.
  std::string adequacy;
};

/// Mean residual in equal-count bins of one variable, for the base model and the extended one
/// (the named cause, else the best candidate; empty when there is none).
struct ResidualProfile {
  std::string variable;  ///< "velocity" [m/s] (sliding samples, |x'| > 1e-4 m/s),
                         ///< "stick_time" [s], "position" [m]
  std::vector<double> center;             ///< mean of the variable in the bin
  std::vector<double> base, extended;     ///< mean residual [N]
  std::vector<int> count;                 ///< samples in the bin
};

/// Least-squares amplitude of a sine in the residuals against one coordinate (position x or
/// time t), on a log grid of periods; base and extended model as in ResidualProfile.
struct ResidualSpectrum {
  std::vector<double> period;             ///< wavelength [m] or period [s]
  std::vector<double> base, extended;     ///< amplitude [N]
};

struct Evidence {
  double residual_rms = 0;        ///< [N]
  double rho = 0;                 ///< lag-1 autocorrelation of fit residuals [-]
  double n = 0, n_eff = 0;        ///< fit samples, effective samples
  double corr_velocity = 0;       ///< corr(residual, simulated x') [-]
  double corr_position = 0;       ///< corr(residual, simulated x) [-]
  double corr_stick_time = 0;     ///< corr(residual, time since the body last slid) [-]
  double trend_per_m = 0;         ///< residual slope against x [N/m]
  double wavelength = 0;          ///< strongest residual period along x [m]
  double wavelength_amplitude = 0;  ///< its amplitude [N]
  double wavelength_ratio = 0;    ///< its power over the median power of the scan [-]
  double wavelength_phase = 0;    ///< phase of the fitted sin(2 pi x / lambda + phase) [rad]
  double frequency = 0;           ///< strongest residual frequency against t [Hz]
  double frequency_amplitude = 0; ///< its amplitude [N]
  double frequency_ratio = 0;     ///< its power over the median power of the scan [-]
  std::vector<ResidualProfile> profiles;  ///< against velocity, stick time, position
  ResidualSpectrum x_spectrum, t_spectrum;
  std::vector<double> stage_mean_residual;  ///< per run and stage, run-major [N]
  std::vector<double> stage_mean_residual_extended;  ///< the same for the extended model [N]
  std::vector<double> stage_va;             ///< the matching v_a [m/s]
  std::vector<StageScore> stages;           ///< base model's per-cycle scores
};

/// How one run was read (diagnose_record.h) and scored.
struct RunReading {
  std::string run;
  std::string scoring;       ///< "time_domain" or "statistics"
  std::string why;           ///< the reason for it
  double noise_sigma = 0;    ///< per-sample noise [N]
  double noise_rho = 0;      ///< its lag-1 autocorrelation [-]
  std::size_t spikes = 0;    ///< impulsive spikes flagged and replaced
  double spike_fraction = 0; ///< of the samples [-]
  double preload = 0;        ///< F_d at the first samples [N]
  bool from_rest = true;     ///< starts with the spring unloaded
  bool stuck_at_start = true;
  double burn_in = 0;        ///< simulated before the record's t = 0 (statistics scoring) [s]
  /// Conditions the manifest left out, the seed's values taken (MeasuredConditions::defaulted),
  /// and the same with values and units ("Fz = 29.4 N, f = 1500 Hz").
  std::vector<std::string> defaulted;
  std::string defaulted_text;
};

/// Measured and predicted statistics of one stage window of one run.
struct StatsComparison {
  std::string run;
  int stage = 0;
  bool held = false;  ///< the stage's held-out part (else its fitted part)
  SlipStats measured, base, extended;  ///< extended: the base's when no cause is named
  double score_base = 0, score_extended = 0;  ///< RMS tolerance-scaled residual [-]
};

/// The verdict on the base models before any cause (issue 21 item 5): the chosen base against
/// trivial predictors, and what it misses.
struct Adequacy {
  std::string verdict = "adequate";  ///< "adequate" or "inadequate"
  std::vector<std::string> missing;  ///< what the base misses, per run, with the numbers
  double noise_floor = 0;            ///< pooled per-sample noise of the records [N]
  double rmse_constant_heldout = 0;  ///< a constant per run (its fitted part's mean) [N]
  double rmse_base_heldout = 0;      ///< the chosen base, the same samples [N]
  double score_constant_heldout = 0; ///< statistics score of no stick-slip (a constant) [-]
  double score_base_heldout = 0;     ///< the chosen base's [-]
  /// When the base is inadequate and candidates were fitted on it: "adequate" when a named
  /// cause's extended model is adequate, "inadequate" when no candidate's is; empty otherwise.
  std::string extended_verdict;
};

/// A calibrated model as `stickslip validate` rebuilds it: every parameter of the base model
/// and, for an extended one, of its effect (SI), and the fitted sensor offset.
struct CalibratedModel {
  engine::ModelKind model = engine::model_kind<engine::LuGre>;
  engine::ExtensionKind effect = engine::ExtensionKind::kNone;
  std::vector<std::pair<std::string, double>> params;
  double offset = 0;  ///< [N]
};

/// Series at the decimated sample times, for plots.
struct RunSeries {
  std::string name;
  std::vector<double> t, measured, base, extended;  ///< extended: empty when cause is none
};

/// One whole run left out (DiagnoseOptions::whole_run_holdout): the base model and the
/// extended one (the named cause; the base itself when the cause is "none") refitted on the
/// other runs' fit samples and scored on every sample of this run.
struct RunHoldout {
  std::string run;
  double va = 0;                                 ///< the run's v_a [m/s]
  std::string status = "ok";                     ///< or why a refit failed
  double rmse_base = 0, rmse_extended = 0;       ///< over the whole run [N] (time domain)
  double score_base = 0, score_extended = 0;     ///< statistics scores of its windows [-]
  double gain = 0;                               ///< 1 - extended / base (RMSE or score) [-]
  std::vector<StageScore> stages_base, stages_extended;  ///< per-stage cycle statistics
  int evals = 0;
  /// The run's measured statistics against those predicted by the refitted models, per window.
  std::vector<StatsComparison> stats;
  /// The predicted (extended) model against the measured record of the run, whole stage 1 (the
  /// issue's "done" criteria): mean force within 10 %, median drop and drop rate within 30 %.
  double mean_error = 0, drop_error = 0, rate_error = 0;  ///< relative [-]; NaN: no drops
  bool reproduced = false;
};

struct Diagnosis {
  std::string dataset;
  std::string scoring = "time_domain";  ///< "time_domain" or "statistics" (see readings)
  std::vector<RunReading> readings;
  Adequacy adequacy;
  /// Measured and predicted statistics of every stage window (chosen base, extended model).
  std::vector<StatsComparison> statistics;
  CalibratedModel base_fit, extended_fit;  ///< extended_fit = base_fit when the cause is none
  engine::ModelKind base_model = engine::model_kind<engine::LuGre>;
  /// Why the base is not the best calibrated model, or why no candidate could be tested on it
  /// (the best takes no catalogue effect); empty otherwise.
  std::string base_note;
  std::vector<ParamEstimate> base_params;
  std::string cause = "none";
  std::string best_candidate;  ///< lowest held-out RMSE, significant or not
  double rmse_base_heldout = 0, rmse_extended_heldout = 0, gain = 0;  ///< [N], [N], [-]
  std::vector<std::string> run_names;
  std::vector<double> run_va;
  std::vector<BaseCalibration> calibrations;
  std::vector<CandidateResult> candidates;
  Evidence evidence;
  std::vector<RunSeries> series;
  /// Whole runs held out, one per run (empty with one run or whole_run_holdout off); pooled
  /// RMSE over every left-out sample and its gain.
  std::vector<RunHoldout> run_holdouts;
  double rmse_base_heldout_runs = 0, rmse_extended_heldout_runs = 0, gain_heldout_runs = 0;
  double score_base_heldout_runs = 0, score_extended_heldout_runs = 0;  ///< statistics [-]
  double seconds = 0;  ///< wall time [s]
  int evaluations = 0;
  DiagnoseOptions options;
};

/// The whole diagnosis as a pure function (no files, no globals). Throws std::invalid_argument
/// for invalid options or a dataset it cannot use (naming the field and value).
Diagnosis diagnose(const measured::MeasuredDataset& data, const DiagnoseOptions& options = {});

/// diagnosis.json content (fields of issue 5; NaN/Inf as null). series are not included.
/// Follows schemas/diagnosis.schema.json.
nlohmann::json to_json(const Diagnosis& d);
/// A window's statistics and a run's reading as JSON (the "slipstats" and "reading" of
/// schemas/diagnosis.schema.json).
nlohmann::json stats_to_json(const SlipStats& s);
nlohmann::json reading_to_json(const RunReading& r);
/// A calibrated model as JSON ({"model", "effect", "params": {name: value}, "offset"}) and back
/// (std::invalid_argument naming a bad field; engine names are checked when the model is built).
nlohmann::json calibrated_json(const CalibratedModel& m);
CalibratedModel calibrated_from_json(const nlohmann::json& j);
/// The evidence view that points at a cause: "velocity", "stick_time", "position" (residual
/// profiles), "x_spectrum", "t_spectrum", "stage_levels"; "" for "none" or an unknown id.
/// write_report marks its panel of evidence.png, and the server's diagnosis resource names it
/// (cause_view), so every reader marks the same panel.
std::string_view evidence_view(std::string_view cause) noexcept;
/// The text of schemas/diagnosis.schema.json (embedded at build time).
std::string_view diagnosis_schema_text() noexcept;
/// A short human-readable summary.
std::string summary_text(const Diagnosis& d);
/// Writes dir/diagnosis.json, the plot data and, when gnuplot is on PATH, PNG plots: per run
/// (runK.png) measured vs base vs extended and the residuals; evidence.png, the base's and the
/// extended model's residuals against velocity, stick time and position, their spectra against
/// x and t, and the stage mean residual against v_a, the panel of the named cause marked.
/// Returns the files written. Plot failures are reported in the returned list, never thrown.
std::vector<std::string> write_report(const Diagnosis& d, const std::filesystem::path& dir);

}  // namespace stickslip::diagnosis
