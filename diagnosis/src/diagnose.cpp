// The diagnosis pipeline (see diagnose.h): read, calibrate, choose, judge, extend, test, name,
// hold out. The steps are in diagnose_steps.cpp.
#include "stickslip/diagnosis/diagnose.h"
#include "stickslip/diagnosis/diagnosis_request.h"

#include <omp.h>

#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "diagnose_candidate.h"
#include "diagnose_steps.h"
#include "stickslip/diagnosis/detail/diagnose_adequacy.h"
#include "stickslip/diagnosis/detail/diagnose_evidence.h"
#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/diagnosis/detail/diagnose_holdout.h"
#include "stickslip/diagnosis/detail/diagnose_progress.h"
#include "stickslip/diagnosis/detail/diagnose_statfit.h"

namespace stickslip::diagnosis {

using namespace detail;

bool DiagnoseOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  auto pos = [](double v) { return std::isfinite(v) && v > 0; };
  if (models.empty()) return fail("models: at least one base model is needed");
  if (!pos(fit_rate)) return fail("fit_rate = " + std::to_string(fit_rate) + ": must be > 0");
  if (!(holdout_fraction > 0 && holdout_fraction < 0.9))
    return fail("holdout_fraction = " + std::to_string(holdout_fraction) + ": must be in (0, 0.9)");
  if (!pos(later_stage_fit_span))
    return fail("later_stage_fit_span = " + std::to_string(later_stage_fit_span) + ": must be > 0");
  if (!pos(short_window)) return fail("short_window = " + std::to_string(short_window) + ": must be > 0");
  if (!pos(rtol)) return fail("rtol = " + std::to_string(rtol) + ": must be > 0");
  if (!pos(rtol_score)) return fail("rtol_score = " + std::to_string(rtol_score) + ": must be > 0");
  // The bounds of the options a request may set come from the request schema (one source).
  for (const auto& [name, value] : {std::pair<const char*, int>{"max_evals_base", max_evals_base},
                                    {"max_evals_candidate", max_evals_candidate},
                                    {"max_evals_fold", max_evals_fold}}) {
    const int min = option_minimum(name);
    if (value < min)
      return fail(std::string(name) + " = " + std::to_string(value) + ": must be >= " +
                  std::to_string(min));
  }
  if (max_evals_profile < 4)
    return fail("max_evals_profile = " + std::to_string(max_evals_profile) + ": must be >= 4");
  if (!(alpha > 0 && alpha < 1)) return fail("alpha = " + std::to_string(alpha) + ": must be in (0, 1)");
  if (!(min_gain >= 0 && min_gain < 1)) return fail("min_gain = " + std::to_string(min_gain) + ": must be in [0, 1)");
  for (engine::ExtensionKind k : candidates)
    if (k == engine::ExtensionKind::kNone) return fail("candidates: \"none\" is not a candidate");
  if (!pos(progress_interval))
    return fail("progress_interval = " + std::to_string(progress_interval) + ": must be > 0");
  return true;
}

const std::vector<engine::ExtensionKind>& default_candidates() {
  static const std::vector<engine::ExtensionKind> kDefault = [] {
    std::vector<engine::ExtensionKind> v;
    for (const engine::ExtensionKind k : engine::extension_catalogue())
      if (k != engine::ExtensionKind::kAging) v.push_back(k);
    return v;
  }();
  return kDefault;
}

Diagnosis diagnose(const measured::MeasuredDataset& data, const DiagnoseOptions& o) {
  const auto t_start = std::chrono::steady_clock::now();
  if (std::string why; !o.IsValid(&why)) throw std::invalid_argument(why);
  if (data.runs.empty()) throw std::invalid_argument("runs: the dataset has no runs");
  auto meter = std::make_shared<ProgressMeter>(o.progress, o.progress_interval);
  meter->phase("reading", 0);
  Problem P = make_problem(data, o);
  P.meter = meter;
  // The scoring problem: same samples and roles, tighter engine accuracy (rtol_score). Every
  // number the tests and the naming compare (fit SSE, held-out RMSE) comes from it.
  Problem Ps = P;
  Ps.rtol = o.rtol_score;
  Diagnosis d;
  d.dataset = data.name;
  d.options = o;
  d.options.stop_requested = nullptr;  // the result does not keep the caller's callbacks
  d.options.progress = nullptr;
  d.scoring = P.stats ? "statistics" : "time_domain";
  d.readings = run_readings(P);
  for (const auto& r : P.runs) {
    d.run_names.push_back(r.name);
    d.run_va.push_back(r.cond.va);
  }
  Steps st{P, Ps, CalibrationInputs{P, Ps, record_scales(P), data_driven_start(P), o, noise_inflation(P)},
           o, o.threads > 0 ? o.threads : omp_get_max_threads(), meter.get()};
  st.check_stop();

  // 1. Calibrate every base model; the best adequate one on held-out data is the base.
  std::vector<BaseFit> bases = calibrate_all(st, &d);
  const int best = base_for_causes(st, bases, &d.base_note);
  BaseFit base = bases[best];
  // 2. Its evidence and uncertainty; 3. the adequacy verdict against trivial predictors.
  SineScan scan;
  Evidence ev = describe_base(st, &base, &bases, best, &scan, &d);
  d.statistics = compare_stats(Ps, base.stats, nullptr);
  d.adequacy = judge_adequacy(Ps, base, d.statistics);
  // 4. Candidates, tested against the (refitted) base, and the cause. On an inadequate base (the
  // carrier, pick_carrier) a cause is named only when its extended model is adequate (the record
  // is then reproduced by a model: the base with the effect).
  std::vector<CandFit> cands;
  int cause = -1;
  const bool need_adequate = d.adequacy.verdict != "adequate";
  if (engine::model_traits(base.cal.model).info->effects && !o.candidates.empty()) {
    cands = fit_candidates(st, base, ev, scan, &d);
    cause = test_and_name(st, &base, &bases[best], &cands, ev, need_adequate, &d);
    if (need_adequate) {
      // The verdict and what is missing are those of the base reported, which test_and_name may
      // have refitted from a candidate's point (on the Colas records: score 1.62 -> 1.41).
      d.adequacy = judge_adequacy(Ps, base, compare_stats(Ps, base.stats, nullptr));
      d.adequacy.extended_verdict = cause >= 0 ? "adequate" : d.adequacy.verdict == "adequate" ? "" : "inadequate";
    }
  } else {
    for (engine::ExtensionKind k : o.candidates) {
      CandidateResult c;
      c.kind = k;
      c.status = "not tested: the base takes no catalogue effect (base_note)";
      d.candidates.push_back(c);
    }
  }
  d.base_model = base.cal.model;
  d.base_params = base.cal.params;
  for (auto& b : bases) d.calibrations.push_back(b.cal);
  const CandFit* named = cause >= 0 ? &cands[static_cast<std::size_t>(cause)] : nullptr;
  extended_statistics(st, base, named, &d);
  if (!P.stats) {
    ev.stages = base.cal.stages;
    const int shown = cause >= 0 ? cause : best_candidate_index(cands, P.stats);
    add_residual_views(P, base.full,
                       shown >= 0 && cands[static_cast<std::size_t>(shown)].full.ok ? &cands[static_cast<std::size_t>(shown)].full : nullptr,
                       &ev);
  }
  d.evidence = ev;
  // 5. Whole runs held out.
  if (o.whole_run_holdout && P.runs.size() >= 2) {
    meter->phase("whole runs", static_cast<int>(P.runs.size()) * (named ? 2 : 1) * (o.max_evals_fold + 2));
    whole_run_holdouts(st.in, base.model, base.theta, named ? &named->model : nullptr,
                       named ? &named->theta : nullptr, st.threads, &d);
  }
  st.check_stop();
  if (o.keep_traces) keep_series(st, base, cands, cause, &d);
  meter->done();
  d.evaluations = meter->evaluations();
  d.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return d;
}

}  // namespace stickslip::diagnosis
