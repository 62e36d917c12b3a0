// Whole runs held out (diagnose_holdout.h).
#include "stickslip/diagnosis/detail/diagnose_holdout.h"

#include <omp.h>

#include <cmath>
#include <limits>

#include "stickslip/diagnosis/detail/diagnose_adequacy.h"
#include "stickslip/diagnosis/detail/diagnose_progress.h"

namespace stickslip::diagnosis::detail {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// One model's refit without run k and its prediction of run k.
struct FoldFit {
  double sse = 0;          ///< time domain: over run k's samples [N^2]
  std::size_t n = 0;
  double score_sse = 0;    ///< statistics residuals of run k's windows
  std::size_t score_n = 0;
  std::vector<StageScore> stages;
  std::vector<SlipStats> stats;  ///< per window of run k
  std::vector<SlipStats> whole;  ///< per stage of run k
  std::string status = "ok";
  int evals = 0;
};

FoldFit fold_fit(const CalibrationInputs& in, std::size_t k, const FitModel& m,
                 const std::vector<double>& theta) {
  const Problem& P = in.P;
  FoldFit out;
  ProgressItem item(P.meter.get(), "without " + P.runs[k].name);
  const FitResult fr = fit(leave_run_out(P, k, P.rtol, false), m, {theta}, fit_span(P), 0, in.o.max_evals_fold);
  out.evals = fr.evals;
  if (!fr.ok) {
    out.status = "failed: " + fr.reason;
    return out;
  }
  const Problem score = leave_run_out(P, k, in.Ps.rtol, true);
  const Evaluation s = evaluate(score, m, fr.theta, Span::kStats, 0);
  ++out.evals;
  if (!s.ok) {
    out.status = "failed: " + s.reason;
    return out;
  }
  out.score_sse = s.sse_held;
  out.score_n = s.n_held;
  out.stats = s.stats[k];
  out.whole = s.whole[k];
  if (P.stats) return out;
  const Evaluation e = evaluate(score, m, fr.theta, Span::kFull, 0);
  ++out.evals;
  if (!e.ok) {
    out.status = "failed: " + e.reason;
    return out;
  }
  out.sse = e.sse_held;
  out.n = e.n_held;
  for (const StageScore& st : stage_scores(score, e))
    if (st.run == static_cast<int>(k)) out.stages.push_back(st);
  return out;
}

/// The criteria for run k from the extended fold's predicted first stage.
void judge_fold(const RunData& r, const FoldFit& x, RunHoldout* h) {
  h->mean_error = h->drop_error = h->rate_error = kNaN;
  h->reproduced = false;
  if (r.rec.whole.empty() || x.whole.empty()) return;
  const SlipStats &m = r.rec.whole.front(), &s = x.whole.front();
  h->mean_error = (s.mean - m.mean) / std::fabs(m.mean);
  const bool dm = m.regime != Regime::kCreep, ds = s.regime != Regime::kCreep;
  if (dm && ds) {
    h->drop_error = s.drop_median / m.drop_median - 1;
    h->rate_error = s.rate / m.rate - 1;
  }
  const bool level = std::fabs(h->mean_error) <= kMeanTolerance;
  const bool slips = dm == ds && (!dm || (std::fabs(h->drop_error) <= kDropTolerance &&
                                          std::fabs(h->rate_error) <= kDropTolerance));
  h->reproduced = level && slips;
}

}  // namespace

Problem leave_run_out(const Problem& P, std::size_t k, double rtol, bool score) {
  Problem q = P;
  q.rtol = rtol;
  for (std::size_t j = 0; j < q.runs.size(); ++j) {
    RunData& r = q.runs[j];
    for (auto& role : r.role)
      role = j == k ? static_cast<std::uint8_t>(kHeld)
                    : role == kHeld ? static_cast<std::uint8_t>(kUnused) : role;
    r.left_out = j == k;
  }
  q.runs[k].fit_end = 0;
  q.score_left_out = score;
  return q;
}

void whole_run_holdouts(const CalibrationInputs& in, const FitModel& base, const std::vector<double>& base_theta,
                        const FitModel* ext, const std::vector<double>* ext_theta, int threads,
                        Diagnosis* d) {
  const Problem& P = in.P;
  const std::size_t n = P.runs.size(), sides = ext ? 2 : 1;
  std::vector<FoldFit> fits(n * sides);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (std::size_t i = 0; i < fits.size(); ++i) {
    const std::size_t k = i / sides;
    try {
      fits[i] = i % sides == 1 ? fold_fit(in, k, *ext, *ext_theta) : fold_fit(in, k, base, base_theta);
    } catch (const std::exception& e) {
      fits[i].status = std::string("failed: ") + e.what();
    }
  }
  double sb = 0, se = 0, qb = 0, qe = 0;
  std::size_t nb = 0, ne = 0, mb = 0, me = 0;
  bool all_ok = true;
  for (std::size_t k = 0; k < n; ++k) {
    const FoldFit& b = fits[k * sides];
    const FoldFit& x = fits[k * sides + sides - 1];  // the base itself without a cause
    const RunData& r = P.runs[k];
    RunHoldout h;
    h.run = r.name;
    h.va = r.cond.va;
    h.evals = b.evals + (ext ? x.evals : 0);
    h.status = b.status != "ok" ? "base " + b.status : x.status != "ok" ? "extended " + x.status : "ok";
    h.rmse_base = P.stats ? kNaN : rms(b.sse, b.n);
    h.rmse_extended = P.stats ? kNaN : rms(x.sse, x.n);
    h.score_base = rms(b.score_sse, b.score_n);
    h.score_extended = rms(x.score_sse, x.score_n);
    h.gain = P.stats ? 1.0 - h.score_extended / h.score_base : 1.0 - h.rmse_extended / h.rmse_base;
    h.stages_base = b.stages;
    h.stages_extended = x.stages;
    // The left-out run's windows: measured against the folds' predictions.
    Problem only;
    only.runs = {r};
    Evaluation eb, ex;
    eb.stats = {b.stats};
    ex.stats = {x.stats};
    h.stats = compare_stats(only, eb, &ex);
    judge_fold(r, x, &h);
    if (h.status == "ok") {
      sb += b.sse, nb += b.n, se += x.sse, ne += x.n;
      qb += b.score_sse, mb += b.score_n, qe += x.score_sse, me += x.score_n;
    } else {
      all_ok = false;
    }
    d->evaluations += h.evals;
    d->run_holdouts.push_back(std::move(h));
  }
  d->rmse_base_heldout_runs = all_ok && !P.stats ? rms(sb, nb) : kNaN;
  d->rmse_extended_heldout_runs = all_ok && !P.stats ? rms(se, ne) : kNaN;
  d->score_base_heldout_runs = all_ok ? rms(qb, mb) : kNaN;
  d->score_extended_heldout_runs = all_ok ? rms(qe, me) : kNaN;
  d->gain_heldout_runs = P.stats ? 1.0 - d->score_extended_heldout_runs / d->score_base_heldout_runs
                                 : 1.0 - d->rmse_extended_heldout_runs / d->rmse_base_heldout_runs;
}

}  // namespace stickslip::diagnosis::detail
