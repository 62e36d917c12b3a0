#pragma once
// Internal to the diagnosis: the steps of diagnose() (diagnose.cpp runs them in order; the
// method is in diagnose.h and docs/diagnose.md).

#include <vector>

#include "diagnose_candidate.h"
#include "stickslip/diagnosis/detail/diagnose_calibrate.h"
#include "stickslip/diagnosis/detail/diagnose_evidence.h"
#include "stickslip/diagnosis/diagnose.h"

namespace stickslip::diagnosis::detail {

class ProgressMeter;

/// What every step reads.
struct Steps {
  const Problem& P;   ///< fitting problem (rtol)
  const Problem& Ps;  ///< scoring problem (rtol_score)
  CalibrationInputs in;
  const DiagnoseOptions& o;
  int threads = 1;
  ProgressMeter* meter = nullptr;
  /// Throws DiagnosisCancelled once DiagnoseOptions::stop_requested says so. Serial code only
  /// (never inside an OpenMP region): the evaluations fail at once meanwhile (Problem::stop).
  void check_stop() const;
};

/// How one run's record was read (noise, spikes, initial state, defaulted conditions); the
/// caller sets the scoring, its reason when it differs, and the burn-in.
RunReading record_reading(const RunData& r);

/// How every run was read and scored.
std::vector<RunReading> run_readings(const Problem& P);

/// Step 1: every base model calibrated (in parallel, the costliest first). Throws
/// std::runtime_error when none could be.
std::vector<BaseFit> calibrate_all(const Steps& st, Diagnosis* d);

/// The base the diagnosis is built on: pick_base (diagnose_adequacy.h) over the calibrated
/// bases, each judged by judge_adequacy; when candidates are asked for and that base cannot carry
/// them on an adequate footing (inadequate, or it takes no effect), pick_carrier's model instead
/// (*note says so).
int base_for_causes(const Steps& st, const std::vector<BaseFit>& bases, std::string* note);

/// Step 2: the base's residual evidence (time domain; empty in statistics) and its parameters
/// with standard errors, Jacobian rank and condition; the other bases' parameters.
Evidence describe_base(const Steps& st, BaseFit* base, std::vector<BaseFit>* bases, int best,
                       SineScan* scan, Diagnosis* d);

/// Step 4a: every catalogue candidate fitted on the base (in parallel).
std::vector<CandFit> fit_candidates(const Steps& st, const BaseFit& base, const Evidence& ev,
                                    const SineScan& scan, Diagnosis* d);

/// Step 4b: significance against the base, the base refitted from every significant candidate
/// (the better refit becomes the null and the tests are redone), and the cause. base and *slot
/// (its entry among the calibrations) are updated. need_adequate (the base is inadequate): a
/// significant candidate is nameable only when its extended model is adequate
/// (CandidateResult::adequacy). Returns the cause's index, or -1.
int test_and_name(const Steps& st, BaseFit* base, BaseFit* slot, std::vector<CandFit>* cands,
                  const Evidence& ev, bool need_adequate, Diagnosis* d);

/// A candidate's extended model judged as a base is (judge_adequacy on its own statistics, its
/// held-out RMSE and score against the trivial predictors).
Adequacy judge_extension(const Steps& st, const BaseFit& base, const CandFit& c);

/// The candidate with the lowest held-out RMSE (statistics: score); -1 when none is ok.
int best_candidate_index(const std::vector<CandFit>& cands, bool stats);

/// The extended model's statistics next to the base's (d->statistics), both calibrated models
/// (d->base_fit, d->extended_fit) and, in statistics scoring, the base's time-domain RMSE on the
/// record aligned at its initial state (d->adequacy).
void extended_statistics(const Steps& st, const BaseFit& base, const CandFit* named, Diagnosis* d);

/// The measured, base and extended series at the decimated sample times (d->series).
void keep_series(const Steps& st, const BaseFit& base, const std::vector<CandFit>& cands, int cause,
                 Diagnosis* d);

}  // namespace stickslip::diagnosis::detail
