#pragma once
// Internal to the diagnosis: the adequacy verdict on the chosen base before any cause (issue 21
// item 5; docs/diagnose.md "Adequacy"), and the measured-against-predicted statistics of every
// stage window.
//
// The chosen base is scored against two trivial predictors: a constant level per run (its fitted
// part's mean: the held-out RMSE in the time domain) and the statistics of no stick-slip (a
// constant: the statistics score of the held-out windows). It is inadequate, and no cause is
// named, when it predicts worse than either, or when in some stage window with a clear regime
// (clear_regime) it shows another regime, drops off by more than kAdequateFactor, or a mean level
// off by more than kAdequateMean of the larger of the window's mean and the run's level (run_level);
// `missing` says which, with the numbers.

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "stickslip/diagnosis/detail/diagnose_calibrate.h"

namespace stickslip::diagnosis::detail {

inline constexpr double kAdequateFactor = 2.0;
inline constexpr double kAdequateMean = 0.25;
/// A window's regime is clear when it has no drops, or at least 2 kMinDrops whose median is
/// kClearThresholds drop thresholds or more; otherwise a mismatch is not judged.
inline constexpr double kClearThresholds = 3.0;

/// The run's level for the mean-level check [N]: the largest |mean| of its measured stage windows
/// (fitted parts). Not the record's median: when the vibrating stage is most of the record (the
/// seed's 3 x 20 s runs at v_a = 4 mm/s: ~1.2 N against ~7 N still), the median is that stage's
/// low level, and a level error that is small against the run's friction force would read as
/// 30 % "of the level"; that is the very signature of effects that act under vibration
/// (velocity weakening, normal-load modulation), which an inadequate verdict leaves untested.
double run_level(const std::vector<StatsComparison>& cmp, const std::string& run);

/// What the base misses in the stage window c (appended to *missing; see above). spec: the
/// window's statistics spec; run_level [N] as above.
void judge_window(const StatsComparison& c, const StatsSpec& spec, double run_level,
                  std::vector<std::string>* missing);

/// The regime of s when it is clear (see above); false otherwise.
bool clear_regime(const SlipStats& s, const StatsSpec& spec, Regime* regime);

/// Measured against predicted statistics of every stage window: base from the base's statistics
/// evaluation, extended from ext's (the base's when ext is null).
std::vector<StatsComparison> compare_stats(const Problem& P, const Evaluation& base,
                                           const Evaluation* ext);

/// The verdict on the chosen base (see above); cmp from compare_stats.
Adequacy judge_adequacy(const Problem& P, const BaseFit& base, const std::vector<StatsComparison>& cmp);

/// One calibrated base model as the choice of the base sees it.
struct BaseChoice {
  std::string model;         ///< its name
  double heldout = std::numeric_limits<double>::quiet_NaN();  ///< held-out RMSE [N] or score [-]; NaN: not calibrated
  bool adequate = false;     ///< judge_adequacy accepts it
  std::string first_miss;    ///< the first thing it misses (Adequacy::missing), when inadequate
  bool effects = true;       ///< takes catalogue effects (engine::ModelInfo::effects)
  /// Held-out statistics score [-] (every scoring has one); NaN: not calibrated.
  double stats_score = std::numeric_limits<double>::quiet_NaN();
};

/// The base the diagnosis is built on (an index into c; -1 when no base was calibrated).
/// * The lowest held-out score among the adequate bases; the lowest overall when none is adequate
///   (the verdict is then inadequate: "inadequate" means that no base model reproduces the
///   record). The held-out RMSE alone prefers a smooth model when the slip phase drifts: a
///   shifted oscillation is penalised twice, a constant once. On a hidden drift Dahl, with no
///   stick-slip at all, beat every stick-slip model (1.51 N against 2.2-2.4 N) although they
///   reproduce the drops and it does not.
/// * Candidates are catalogue effects, and a model without them (rate_state, gms) cannot carry
///   one. When candidates are asked for and that base is such a model, the base is the best
///   adequate one that takes effects, if there is one.
/// `note` says when and why the base is not the lowest held-out score, with the scores, and why
/// no candidate can be tested; empty otherwise. stats: the scores are statistics scores.
int pick_base(const std::vector<BaseChoice>& c, bool candidates_asked, bool stats, std::string* note);

/// The model that carries the candidates when no adequate model can (the base `base` is
/// inadequate, or it takes no catalogue effect and no adequate model that does exists): the base
/// itself when it takes effects, else the effect-taking model whose held-out statistics are
/// closest to the record's (lowest stats_score: the stick-slip a catalogue effect is to correct,
/// not the held-out RMSE, which prefers a smooth model with no stick-slip when the slip phase
/// drifts). -1: no calibrated model takes effects.
int pick_carrier(const std::vector<BaseChoice>& c, int base);

/// The records' pooled per-sample noise sqrt(mean sigma^2) [N] and n / n_eff = (1 + rho) /
/// (1 - rho) of their mean lag-1 correlation.
double noise_floor(const Problem& P);
double noise_inflation(const Problem& P);

/// The effect size of the time domain (docs/diagnose.md step 5): the share of the base's held-out
/// error above the noise floor that the extension removes, as an RMSE ratio,
/// 1 - sqrt((rmse_ext^2 - sigma^2) / (rmse_base^2 - sigma^2)). A plain RMSE gain is capped by the
/// noise at 1 - sigma / rmse_base, so a base 10 % above the noise could never carry a cause (hidden
/// drive damping c_d = 37 N s/m, noise 0.036 N: base 0.047 N, candidate 0.043 N at p_holm 1e-151,
/// gain 0.09). 0 when the base's excess over the noise is within three standard errors of a noise
/// variance estimated from n_held / inflation independent samples (sd sigma^2 sqrt(2 / n)): there is
/// then nothing above the noise to explain.
/// rmse_base, rmse_ext, sigma [N]; n_held held-out samples; inflation = n / n_eff of the noise.
double gain_over_noise(double rmse_base, double rmse_ext, double sigma, std::size_t n_held, double inflation);

}  // namespace stickslip::diagnosis::detail
