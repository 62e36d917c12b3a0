#pragma once
// Internal to the diagnosis: the fitting problem (decimated samples with fit / held-out roles),
// the parameterisation of models and extensions, objective evaluation and the NLopt driver.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <utility>
#include <limits>
#include <string>
#include <vector>

#include "stickslip/diagnosis/detail/diagnose_features.h"
#include "stickslip/diagnosis/detail/diagnose_record.h"
#include "stickslip/engine/params.h"
#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/measured/measured.h"

namespace stickslip::diagnosis::detail {

enum Role : std::uint8_t { kUnused = 0, kFit = 1, kHeld = 2 };

struct RunData {
  std::string name;
  measured::MeasuredConditions cond;
  std::vector<double> t, y;          ///< decimated measured samples [s], [N]
  std::vector<std::uint8_t> role;    ///< Role per sample
  std::vector<int> stage;            ///< stage index per sample
  std::vector<double> stage_start;   ///< [s]
  double fit_end = 0;                ///< last fitted time [s]
  std::vector<WindowSpec> windows;   ///< fitted part of every stage, for the features
  Features features;                 ///< of the measured signal at its full rate
  /// Phase of the still stage's stick-slip cycle at the first switch (still -> next stage), for
  /// the feature objective: the time since the last slip at t_on [s], predicted from the
  /// measured slips of the first feature window (fit data): the last one plus whole mean periods
  /// of its second half (the settled cycle). NaN: no alignment (one stage, or fewer than four
  /// slips). anchor_t = t_on [s].
  double anchor_tau = std::numeric_limits<double>::quiet_NaN();
  double anchor_t = 0;
  /// The model-free reading of the run at its full rate (diagnose_record.h): noise, spikes,
  /// initial state, and the statistics of every stage's fitted and held-out part.
  RecordInfo rec;
  /// Statistics scoring (Span::kStats, diagnose_statfit.h): the simulated burn-in before the
  /// record's t = 0 [s], and per stage the simulated span whose statistics predict the stage's [s].
  double settle = 0;
  std::vector<double> stats_span;
  /// Left out of a whole-run fold (statistics scoring): not simulated while fitting; scored on
  /// every window when Problem::score_left_out.
  bool left_out = false;
};

class ProgressMeter;

struct Problem {
  std::vector<RunData> runs;
  double rtol = 1e-5;
  bool fit_offset = true;
  /// DiagnoseOptions::stop_requested: when it returns true, evaluate fails at once ("cancelled").
  std::function<bool()> stop;
  /// The runs are scored on their statistics (Span::kStats) rather than sample by sample: some
  /// run is not phase-locked (RecordInfo::phase_locked).
  bool stats = false;
  /// Statistics scoring of a whole-run fold: simulate the left-out runs and score all their
  /// windows as held out (the others' windows are then not scored).
  bool score_left_out = false;
  /// Ticked once per evaluation (null: no progress reporting).
  std::shared_ptr<ProgressMeter> meter;
};

/// The numerator and denominator of a ratio fit "a/b" (ParamDef::fit.relative_to); nullopt for a
/// plain parameter name.
std::optional<std::pair<std::string, std::string>> ratio_parts(const std::string& name);

/// The stages cut to [0, t_end] [s].
std::vector<engine::Stage> stages_until(const std::vector<engine::Stage>& stages, double t_end);

/// One scalar parameter in the unit box: u in [0, 1] maps to [lo, hi] linearly or in log.
struct ParamSpec {
  std::string name;  ///< engine parameter name, or a ratio "a/b" (fits a / b; applied after b)
  double lo, hi;
  bool log;
  double init;
  double to_value(double u) const;
  double to_unit(double v) const;
  double dvalue_du(double u) const;
};

/// A model to fit: base model + extension, the fitted parameters and the fixed rest.
struct FitModel {
  engine::SimConfig base;  ///< model kind, friction parameters (fixed ones), extension kind
  std::vector<ParamSpec> specs;
  /// Sets the parameters theta (SI values, one per spec) in c.
  void apply(engine::SimConfig& c, const std::vector<double>& theta) const;
  /// Configuration for a run with parameters theta (SI values, one per spec).
  engine::SimConfig config(const RunData& run, const std::vector<double>& theta, double t_end,
                   double rtol) const;
};

/// Simulated signals at a run's samples.
struct RunSim {
  bool ok = false;
  std::string reason;
  std::vector<double> F, x, v;  ///< at the samples up to t_end (F_d [N], x [m], x' [m/s])
};

/// kShort: fit samples before short_end; kFit: all fit samples; kFull: every sample (held-out
/// scored too); kFeatures: like kFit, but the score is the per-stage cycle features (mean,
/// amplitude, period) of the fit windows, which do not depend on slip timing; kStats: the
/// statistics of the stick-slip of every stage (diagnose_statfit.h), fitted windows in sse_fit and
/// feat, held-out windows in sse_held.
enum class Span { kShort, kFit, kFull, kFeatures, kStats };

struct Evaluation {
  bool ok = false;
  std::string reason;
  double sse_fit = 0, sse_held = 0, offset = 0;
  std::size_t n_fit = 0, n_held = 0;
  std::vector<RunSim> sims;  ///< per run
  std::vector<double> feat;  ///< kFeatures, kStats: the residuals (fixed length per problem)
  /// kStats: the simulated statistics per run and window (aligned with RecordInfo::windows),
  /// and per run and whole stage (simulated_whole).
  std::vector<std::vector<SlipStats>> stats, whole;
};

/// Simulates every run up to the span's end and scores the samples. Short: fit samples with
/// t < short_end only.
Evaluation evaluate(const Problem& p, const FitModel& m, const std::vector<double>& theta,
                    Span span, double short_end);

/// Fit residuals (measured - simulated - offset) in run-major order.
std::vector<double> fit_residuals(const Problem& p, const Evaluation& e, Span span,
                                  double short_end);

struct FitResult {
  std::vector<double> theta;
  double sse = 0;
  int evals = 0;
  bool ok = false;
  std::string reason;
};

/// BOBYQA from the best of the starting points, at most max_evals evaluations in all.
FitResult fit(const Problem& p, const FitModel& m, const std::vector<std::vector<double>>& starts,
              Span span, double short_end, int max_evals);

/// The first forward-difference step in the unit box of the Levenberg-Marquardt fits of a span
/// (time domain 1e-4; cycle features and statistics 2e-3).
double jacobian_step(Span span);

/// sqrt(sse / n) [N]; NaN when n = 0.
double rms(double sse, std::size_t n);

/// The estimates of parameters from .. to-1 of m at theta with standard errors se (empty: NaN),
/// SI; the ratio F_C/F_S is reported as F_C (value and error times F_S = theta[0]).
std::vector<ParamEstimate> estimates(const FitModel& m, const std::vector<double>& theta,
                                     const std::vector<double>& se, std::size_t from,
                                     std::size_t to);

/// Parameter specs of the base models, with data-driven starting values (F_C0: stage-1 mean,
/// F_S0: mean + amplitude / 2).
std::vector<ParamSpec> base_specs(engine::ModelKind m, double F_C0, double F_S0);
/// Parameter specs of an extension.
std::vector<ParamSpec> extension_specs(engine::ExtensionKind k);
/// Extension parameters (in extension_specs order) at which the extension is neutral, i.e. the
/// model is its base (extensions.h). May lie outside the unit box (sensor_tau = 0).
std::vector<double> neutral_extension(engine::ExtensionKind k);

/// Builds the problem from the dataset (decimation and roles).
Problem make_problem(const measured::MeasuredDataset& data, const DiagnoseOptions& o);

/// Data-driven starting levels for base_specs from the measured first stage of every run:
/// F_C0 = mean of the stage means, F_S0 = F_C0 + half the mean peak-to-peak amplitude [N].
struct StartLevels {
  double F_C0 = 0, F_S0 = 0;
};
StartLevels data_driven_start(const Problem& p);

}  // namespace stickslip::diagnosis::detail
