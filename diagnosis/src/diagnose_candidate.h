#pragma once
// Internal to the diagnosis: the fitted base model and candidates of diagnose(), and its step 3,
// one catalogue extension fitted on the best base with the base parameters refitted (method in
// diagnose.h and docs/diagnose.md "Candidates"):
//  1. starting points: the extension's own starting sizes (extension_starts), and for the
//     extensions that act on the slip itself a profile start per size (the base parameters
//     refitted on the cycle features with the extension held there), refined by bisection;
//  2. phase A: Levenberg-Marquardt on the cycle features from every start;
//  3. phase B: the time-domain fit from the feature optima;
//  4. scoring at rtol_score, nesting in the base (an extension is never reported worse than its
//     base), standard errors.

#include <cstddef>
#include <vector>

#include "stickslip/diagnosis/detail/diagnose_calibrate.h"
#include "stickslip/diagnosis/detail/diagnose_evidence.h"
#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/diagnosis/diagnose.h"

namespace stickslip::diagnosis::detail {

/// A fitted candidate extension (theta: base parameters, then the extension's).
struct CandFit {
  CandidateResult res;
  FitModel model;
  std::vector<double> theta;
  double sse_fit = 0;
  double n_eff = 10;  ///< effective samples from the candidate's own residuals (the noise
                      ///< model under the alternative; under the null both are the noise)
  Evaluation full;
};

/// What every candidate's fit reads. Shared read-only by the threads of diagnose()'s candidate
/// loop; every member outlives it.
struct CandidateInputs {
  const Problem& P;           ///< fitting problem (Problem::rtol = DiagnoseOptions::rtol)
  const Problem& Ps;          ///< scoring problem (rtol_score)
  const BaseFit& base;        ///< the best base model
  const Evidence& ev;         ///< its residual evidence
  const SineScan& scan;       ///< its residual scan against x (waviness starts)
  const DiagnoseOptions& o;
  RecordScales scales;        ///< the record's scales (diagnose_scale.h)
  /// Where the candidates' starts begin (base.model's parameters): the base's first optimum with
  /// its secondary parameters at their held values (BaseFit::origin); empty: base.theta.
  std::vector<double> origin;
  double F_C0 = 0;            ///< data-driven F_C level (data_driven_start) [N]
  double still_period = 0;    ///< mean measured still-stage period [s] (dwell starts)
  double v_slip = 0;          ///< the base's still-stage slip velocity [m/s] (slip_velocity)
  /// Feature SSE of the base point (profile size 0 of the bisecting candidates); +inf when not
  /// computed.
  double base_feature_sse = 0;
};

/// Mean measured stick-slip period of the still stages [s]; 0 when none was measured.
double still_stage_period(const std::vector<StageScore>& stages);

/// sum v^2 / sum |v| [m/s] over the sliding samples (|v| > 1 mm/s) of the still stages of the
/// evaluation e (simulated velocities); 0 when there are none.
double slip_velocity(const Problem& P, const Evaluation& e);

/// True when the candidate of this kind bisects its profile from the base point's feature SSE
/// (CandidateInputs::base_feature_sse is needed).
bool uses_base_feature_sse(engine::ExtensionKind k);

/// Fit RMSE, held-out RMSE, n_eff and AIC of a candidate from its scoring evaluation c.full (in
/// statistics scoring: the statistics scores, n_eff = the residual count).
void score_candidate(const Problem& P, CandFit& c);

/// The candidate `kind` fitted on the statistics (Span::kStats): the extension's starting sizes
/// appended to the base optimum, Levenberg-Marquardt from the best, scored, nested in the base.
/// Never throws.
CandFit fit_candidate_stats(const CandidateInputs& in, engine::ExtensionKind kind);

/// The starting sizes of an extension (extension parameters only), at the record's scales.
std::vector<std::vector<double>> candidate_extension_starts(const CandidateInputs& in,
                                                             engine::ExtensionKind kind,
                                                             const std::vector<ParamSpec>& ext);

/// Fits the candidate `kind` (steps 1-4 above). Never throws: a failure is reported in
/// res.status ("failed: ..."), so the call is safe inside an OpenMP region.
CandFit fit_candidate(const CandidateInputs& in, engine::ExtensionKind kind);

/// A candidate nests its base: at the extension's neutral size it is the base model
/// (tests/engine/test_extensions.cpp, NeutralSizeReproducesBase). When the candidate's own
/// optimum scores worse on the fit set than the base point does, the base point (base
/// parameters, neutral extension) is the better point of the candidate's parameter space
/// known, and the candidate is reported there, with the base's scoring evaluation. Without
/// this, a candidate could end worse than the model it extends (measured on clean data before
/// the common scoring: 0.0356 against 0.0307 N), which makes the LR test and the information
/// criterion meaningless. Returns true when the candidate was moved to the base point.
bool nest_in_base(const Problem& P, CandFit& c, const BaseFit& base, std::size_t nb);

}  // namespace stickslip::diagnosis::detail
