// The diagnosis pipeline (see diagnose.h): calibrate, choose, extend, test, name.
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
#include "stickslip/diagnosis/detail/diagnose_evidence.h"
#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/engine/metrics.h"

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
  return true;
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Per-stage cycle statistics of measured and simulated F_d at the samples.
std::vector<StageScore> stage_scores(const Problem& p, const Evaluation& e) {
  std::vector<StageScore> out;
  engine::MetricOptions mo;
  for (std::size_t k = 0; k < p.runs.size(); ++k) {
    const RunData& r = p.runs[k];
    for (std::size_t j = 0; j < r.stage_start.size(); ++j) {
      const double t0 = r.stage_start[j];
      const double t1 = j + 1 < r.stage_start.size() ? r.stage_start[j + 1] : r.cond.duration;
      engine::StageAccumulator am(t0, t1, mo), as(t0, t1, mo);
      for (std::size_t i = 0; i < r.t.size() && i < e.sims[k].F.size(); ++i) {
        if (r.t[i] < t0 || r.t[i] > t1) continue;
        am.sample(r.t[i], r.y[i], r.y[i]);
        as.sample(r.t[i], e.sims[k].F[i] + e.offset, e.sims[k].F[i]);
      }
      const engine::StageMetrics a = am.finish(), b = as.finish();
      out.push_back({static_cast<int>(k), static_cast<int>(j), a.amplitude, b.amplitude,
                     a.mean_force, b.mean_force, a.mean_period, b.mean_period, a.slip_events,
                     b.slip_events});
    }
  }
  return out;
}

/// Scores the base at its fitted point with the scoring problem (Problem::rtol = rtol_score).
void finish_base(const Problem& P, BaseFit& b) {
  b.full = evaluate(P, b.model, b.theta, Span::kFull, 0);
  BaseCalibration& c = b.cal;
  if (!b.full.ok) {
    c.status = "failed: " + b.full.reason;
    return;
  }
  c.offset = b.full.offset;
  c.rmse_fit = rms(b.full.sse_fit, b.full.n_fit);
  c.rmse_heldout = rms(b.full.sse_held, b.full.n_held);
  b.sse_fit = b.full.sse_fit;
  b.n_fit = b.full.n_fit;
  c.rmse_run.clear();
  for (std::size_t k = 0; k < P.runs.size(); ++k) {
    double s = 0;
    for (std::size_t i = 0; i < b.full.sims[k].F.size(); ++i) {
      const double r = P.runs[k].y[i] - b.full.sims[k].F[i] - b.full.offset;
      s += r * r;
    }
    c.rmse_run.push_back(rms(s, b.full.sims[k].F.size()));
  }
  c.stages = stage_scores(P, b.full);
}

/// Fits on P (Problem::rtol = rtol), scores on Ps (rtol_score).
BaseFit calibrate(const Problem& P, const Problem& Ps, engine::ModelKind kind, double F_C0, double F_S0,
                  const DiagnoseOptions& o, const std::vector<double>* start) {
  BaseFit b;
  b.cal.model = kind;
  b.model.base = engine::SimConfig::seed(kind, 0.0);
  b.model.specs = base_specs(kind, F_C0, F_S0);
  std::vector<double> init;
  for (const auto& s : b.model.specs) init.push_back(s.init);
  FitResult fr;
  if (start) {  // polish from a given point
    fr = fit(P, b.model, {*start}, Span::kFit, 0, o.max_evals_base / 2);
  } else {
    // Cycle features first (independent of slip timing), then the time-domain fit from there.
    const int n_short = o.max_evals_base * 2 / 5;
    const FitResult a = fit(P, b.model, {init}, Span::kFeatures, 0, n_short);
    std::vector<std::vector<double>> starts = {init};
    if (a.ok) starts.insert(starts.begin(), a.theta);
    fr = fit(P, b.model, starts, Span::kFit, 0, o.max_evals_base - a.evals);
    fr.evals += a.evals;
  }
  b.cal.evals = fr.evals;
  if (!fr.ok) {
    b.cal.status = "failed: " + fr.reason;
    return b;
  }
  b.theta = fr.theta;
  finish_base(Ps, b);
  return b;
}

/// The problem for leaving run k out: every run, run k's samples all held out, the other runs'
/// held-out samples unused. Span::kFit fits the other runs' fit samples (run k is simulated
/// only to its fit_end, 0 here); Span::kFull scores run k with the offset fitted on the others.
Problem leave_run_out(const Problem& P, std::size_t k, double rtol) {
  Problem q = P;
  q.rtol = rtol;
  for (std::size_t j = 0; j < q.runs.size(); ++j) {
    RunData& r = q.runs[j];
    for (auto& role : r.role)
      role = j == k ? static_cast<std::uint8_t>(kHeld)
                    : role == kHeld ? static_cast<std::uint8_t>(kUnused) : role;
  }
  q.runs[k].fit_end = 0;
  return q;
}

/// One model's refit without run k and its score on run k (into h's base or extended side).
struct FoldFit {
  double sse = 0;
  std::size_t n = 0;
  std::vector<StageScore> stages;
  std::string status = "ok";
  int evals = 0;
};

FoldFit fold_fit(const Problem& P, double rtol_score, std::size_t k, const FitModel& m,
                 const std::vector<double>& theta, int max_evals) {
  FoldFit out;
  const FitResult fr = fit(leave_run_out(P, k, P.rtol), m, {theta}, Span::kFit, 0, max_evals);
  out.evals = fr.evals;
  if (!fr.ok) {
    out.status = "failed: " + fr.reason;
    return out;
  }
  const Problem score = leave_run_out(P, k, rtol_score);
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

/// Leave each run out in turn (DiagnoseOptions::whole_run_holdout): the base and, when a cause
/// is named, its model refitted on the other runs from their all-run optima and scored on the
/// run left out. A parameter that only the left-out run constrains keeps its all-run value
/// there (the fold's fit cannot move it), so a fold says how well the model carries over to a
/// v_a it was not fitted on, not how well the parameter could have been found without it.
void whole_run_holdouts(const Problem& P, double rtol_score, const BaseFit& base,
                        const CandFit* cause, const DiagnoseOptions& o, int threads,
                        Diagnosis* d) {
  const std::size_t n = P.runs.size(), sides = cause ? 2 : 1;
  std::vector<FoldFit> fits(n * sides);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (std::size_t i = 0; i < fits.size(); ++i) {
    const std::size_t k = i / sides;
    const bool ext = i % sides == 1;
    try {
      fits[i] = ext ? fold_fit(P, rtol_score, k, cause->model, cause->theta, o.max_evals_fold)
                    : fold_fit(P, rtol_score, k, base.model, base.theta, o.max_evals_fold);
    } catch (const std::exception& e) {
      fits[i].status = std::string("failed: ") + e.what();
    }
  }
  double sb = 0, se = 0;
  std::size_t nb = 0, ne = 0;
  bool all_ok = true;
  for (std::size_t k = 0; k < n; ++k) {
    const FoldFit& b = fits[k * sides];
    const FoldFit& x = fits[k * sides + sides - 1];  // the base itself without a cause
    RunHoldout h;
    h.run = P.runs[k].name;
    h.va = P.runs[k].cond.va;
    h.evals = b.evals + (cause ? x.evals : 0);
    h.status = b.status != "ok" ? "base " + b.status : x.status != "ok" ? "extended " + x.status : "ok";
    h.rmse_base = rms(b.sse, b.n);
    h.rmse_extended = rms(x.sse, x.n);
    h.gain = 1.0 - h.rmse_extended / h.rmse_base;
    h.stages_base = b.stages;
    h.stages_extended = x.stages;
    if (h.status == "ok") {
      sb += b.sse;
      nb += b.n;
      se += x.sse;
      ne += x.n;
    } else {
      all_ok = false;
    }
    d->evaluations += h.evals;
    d->run_holdouts.push_back(std::move(h));
  }
  d->rmse_base_heldout_runs = all_ok ? rms(sb, nb) : kNaN;
  d->rmse_extended_heldout_runs = all_ok ? rms(se, ne) : kNaN;
  d->gain_heldout_runs = 1.0 - d->rmse_extended_heldout_runs / d->rmse_base_heldout_runs;
}

/// Indices 0 .. rank.size()-1 in the order their work items should start: the highest rank (the
/// most expensive) first, ties in index order, so that the two threads of a dynamic schedule do
/// not end with one long item running alone (measured on the 3 x 20 s benchmark: the candidates
/// with profile starts cost 2-4x the others, docs/diagnose.md). The results are stored by
/// index, so the order changes only the wall time.
std::vector<std::size_t> longest_first(const std::vector<int>& rank) {
  std::vector<std::size_t> order(rank.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return rank[a] > rank[b]; });
  return order;
}

/// Relative cost rank of a base model's calibration (LuGre: three parameters and the stiffest
/// simulation; Dahl three parameters).
int calibration_rank(engine::ModelKind m) {
  switch (m) {
    case engine::model_kind<engine::LuGre>: return 3;
    case engine::model_kind<engine::Dahl>: return 2;
    case engine::model_kind<engine::Karnopp>: return 1;
    case engine::model_kind<engine::ResetIntegrator>: return 1;
  }
  return 0;
}

/// Relative cost rank of a candidate's fit: viscous and drive_damping have profile starts at
/// four sizes with held-v_s refits, a bisection and two feature fits; sensor_dynamics held-v_s
/// starts; dwell_time, stribeck_shape and waviness profile starts; drift and the load
/// modulation neither.
int candidate_rank(engine::ExtensionKind k) {
  switch (k) {
    case engine::ExtensionKind::kViscous:
    case engine::ExtensionKind::kDriveDamping: return 3;
    case engine::ExtensionKind::kSensorDynamics:
    case engine::ExtensionKind::kDwellTime: return 2;
    case engine::ExtensionKind::kStribeckShape:
    case engine::ExtensionKind::kWaviness: return 1;
    default: return 0;
  }
}

void significance(std::vector<CandFit>& cands, double sse0, double rmse0_held,
                  const DiagnoseOptions& o) {
  using boost::math::chi_squared;
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < cands.size(); ++i) {
    CandidateResult& c = cands[i].res;
    c.significant = false;
    c.p_holm = 1;
    if (c.status != "ok") { c.p_value = 1; continue; }
    c.lr = cands[i].sse_fit < sse0 ? cands[i].n_eff * std::log(sse0 / cands[i].sse_fit) : 0.0;
    c.p_value = c.lr > 0 ? boost::math::cdf(boost::math::complement(chi_squared(c.dof), c.lr)) : 1.0;
    c.gain = 1.0 - c.rmse_heldout / rmse0_held;
    order.push_back(i);
  }
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return cands[a].res.p_value < cands[b].res.p_value; });
  const double m = static_cast<double>(cands.size());
  double running = 0;
  for (std::size_t r = 0; r < order.size(); ++r) {
    CandidateResult& c = cands[order[r]].res;
    running = std::max(running, std::min(1.0, (m - static_cast<double>(r)) * c.p_value));
    c.p_holm = running;
    c.significant = c.p_holm < o.alpha && c.gain >= o.min_gain;
  }
}

}  // namespace

Diagnosis diagnose(const measured::MeasuredDataset& data, const DiagnoseOptions& o) {
  const auto t_start = std::chrono::steady_clock::now();
  if (std::string why; !o.IsValid(&why)) throw std::invalid_argument(why);
  if (data.runs.empty()) throw std::invalid_argument("runs: the dataset has no runs");
  const Problem P = make_problem(data, o);
  // The scoring problem: same samples and roles, tighter engine accuracy (rtol_score). Every
  // number the tests and the naming compare (fit SSE, held-out RMSE) comes from it.
  Problem Ps = P;
  Ps.rtol = o.rtol_score;
  Diagnosis d;
  d.dataset = data.name;
  d.options = o;
  d.options.stop_requested = nullptr;  // the result does not keep the caller's callback
  // Cancellation: the evaluations fail at once (Problem::stop); these checks, in serial code
  // only (never inside an OpenMP region), turn that into DiagnosisCancelled.
  auto check_stop = [&o] {
    if (o.stop_requested && o.stop_requested()) throw DiagnosisCancelled();
  };
  check_stop();
  for (const auto& r : P.runs) {
    d.run_names.push_back(r.name);
    d.run_va.push_back(r.cond.va);
  }
  const int threads = o.threads > 0 ? o.threads : omp_get_max_threads();

  // Data-driven starting values from the measured first stage of every run.
  const StartLevels start = data_driven_start(P);
  const double F_C0 = start.F_C0, F_S0 = start.F_S0;

  // 1. Calibrate every base model.
  std::vector<BaseFit> bases(o.models.size());
  std::vector<int> model_rank;
  for (engine::ModelKind m : o.models) model_rank.push_back(calibration_rank(m));
  const auto model_order = longest_first(model_rank);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (std::size_t j = 0; j < o.models.size(); ++j) {
    const std::size_t i = model_order[j];
    try {
      bases[i] = calibrate(P, Ps, o.models[i], F_C0, F_S0, o, nullptr);
    } catch (const std::exception& e) {
      bases[i].cal.model = o.models[i];
      bases[i].cal.status = std::string("failed: ") + e.what();
    }
  }
  check_stop();
  int best = -1;
  for (std::size_t i = 0; i < bases.size(); ++i) {
    d.evaluations += bases[i].cal.evals;
    if (bases[i].cal.status == "ok" && std::isfinite(bases[i].cal.rmse_heldout) &&
        (best < 0 || bases[i].cal.rmse_heldout < bases[best].cal.rmse_heldout))
      best = static_cast<int>(i);
  }
  if (best < 0) throw std::runtime_error("no base model could be calibrated: " + bases[0].cal.status);
  BaseFit base = bases[best];

  // 2. Evidence from the best base model's residuals.
  SineScan scan;
  Evidence ev = base_evidence(P, base.full, base.n_fit, &scan);
  {
    int ev_evals = 0;
    const auto se = standard_errors(P, base.model, base.theta, ev.n / ev.n_eff, &ev_evals);
    d.evaluations += ev_evals;
    base.cal.params = estimates(base.model, base.theta, se, 0, base.theta.size());
  }
  for (std::size_t i = 0; i < bases.size(); ++i) {
    if (static_cast<int>(i) == best) bases[i].cal.params = base.cal.params;
    else if (bases[i].cal.status == "ok")
      bases[i].cal.params = estimates(bases[i].model, bases[i].theta, {}, 0, bases[i].theta.size());
  }

  // 3. Every candidate extension on the best base, base parameters refitted
  //    (diagnose_candidate.h), in parallel, each into its own slot.
  CandidateInputs in{P, Ps, base, ev, scan, o};
  in.F_C0 = F_C0;
  in.still_period = still_stage_period(base.cal.stages);
  in.v_slip = slip_velocity(P, base.full);
  in.base_feature_sse = std::numeric_limits<double>::infinity();
  if (std::any_of(o.candidates.begin(), o.candidates.end(), uses_base_feature_sse)) {
    const Evaluation e = evaluate(P, base.model, base.theta, Span::kFeatures, 0);
    ++d.evaluations;
    if (e.ok) in.base_feature_sse = e.sse_fit;
  }
  const std::size_t nb = base.theta.size();
  std::vector<CandFit> cands(o.candidates.size());
  std::vector<int> cand_rank;
  for (engine::ExtensionKind k : o.candidates) cand_rank.push_back(candidate_rank(k));
  const auto cand_order = longest_first(cand_rank);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (std::size_t j = 0; j < o.candidates.size(); ++j) {
    const std::size_t i = cand_order[j];
    cands[i] = fit_candidate(in, o.candidates[i]);
  }
  check_stop();
  for (const auto& c : cands) d.evaluations += c.res.evals;
  // Information criterion of every calibrated base model, on the best base's n_eff.
  auto set_aic = [&](BaseFit& b) {
    b.cal.aic = ev.n_eff * std::log(b.sse_fit / static_cast<double>(b.n_fit)) +
                2.0 * static_cast<double>(b.theta.size());
  };
  for (auto& b : bases)
    if (b.cal.status == "ok") set_aic(b);
  set_aic(base);
  significance(cands, base.sse_fit, base.cal.rmse_heldout, o);

  // 4. An extension must beat a fully refitted base: refit the base from each significant
  //    candidate's base parameters (in parallel; each refit depends only on its start); the
  //    best refit, if better than the base, replaces the null and the tests are redone.
  {
    std::vector<std::size_t> sig;
    for (std::size_t i = 0; i < cands.size(); ++i)
      if (cands[i].res.significant) sig.push_back(i);
    std::vector<BaseFit> polished(sig.size());
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
    for (std::size_t j = 0; j < sig.size(); ++j) {
      try {
        const std::vector<double> start(cands[sig[j]].theta.begin(),
                                        cands[sig[j]].theta.begin() + nb);
        polished[j] = calibrate(P, Ps, base.cal.model, F_C0, F_S0, o, &start);
      } catch (const std::exception& e) {
        polished[j].cal.status = std::string("failed: ") + e.what();
      }
    }
    check_stop();
    int better = -1;
    for (std::size_t j = 0; j < polished.size(); ++j) {
      d.evaluations += polished[j].cal.evals;
      const double bar = better < 0 ? base.sse_fit : polished[better].sse_fit;
      if (polished[j].cal.status == "ok" && polished[j].sse_fit < bar) better = static_cast<int>(j);
    }
    if (better >= 0) {
      BaseFit& p = polished[better];
      int se_evals = 0;
      const auto se = standard_errors(P, p.model, p.theta, ev.n / ev.n_eff, &se_evals);
      d.evaluations += se_evals;
      p.cal.params = estimates(p.model, p.theta, se, 0, nb);
      p.cal.evals += base.cal.evals;
      set_aic(p);
      base = p;
      bases[best] = base;
      // Every candidate nests the new base too.
      for (auto& c : cands)
        if (c.res.status == "ok") nest_in_base(P, c, base, nb);
      significance(cands, base.sse_fit, base.cal.rmse_heldout, o);
    }
  }

  check_stop();
  // 5. Name the cause.
  d.base_model = base.cal.model;
  d.base_params = base.cal.params;
  d.rmse_base_heldout = base.cal.rmse_heldout;
  // Among the significant candidates (each already beats the refitted base on held-out data
  // by min_gain), the cause is the one with the lowest information criterion on the fit set, on
  // a common footing (the base's n_eff for all). Not the lowest held-out RMSE: held-out blocks
  // are extrapolations in time whose slip phase errors dominate, so two similar candidates
  // rank by chance there (hidden drive damping c_d = 20 N s/m: the drive_damping candidate
  // fitted 0.031 N RMS at c_d = 20.6, viscous 0.041 N, but held-out 0.054 against 0.038 N).
  auto criterion = [&](std::size_t i) {
    return ev.n_eff * std::log(cands[i].sse_fit / static_cast<double>(cands[i].full.n_fit)) +
           2.0 * cands[i].res.dof;
  };
  int cause = -1, best_c = -1;
  for (std::size_t i = 0; i < cands.size(); ++i) {
    const auto& c = cands[i].res;
    if (c.status != "ok") continue;
    if (best_c < 0 || c.rmse_heldout < cands[best_c].res.rmse_heldout) best_c = static_cast<int>(i);
    if (c.significant && (cause < 0 || criterion(i) < criterion(static_cast<std::size_t>(cause))))
      cause = static_cast<int>(i);
  }
  if (best_c >= 0) d.best_candidate = to_string(cands[best_c].res.kind);
  if (cause >= 0) {
    d.cause = to_string(cands[cause].res.kind);
    d.rmse_extended_heldout = cands[cause].res.rmse_heldout;
  } else {
    d.cause = "none";
    d.rmse_extended_heldout = d.rmse_base_heldout;
  }
  d.gain = 1.0 - d.rmse_extended_heldout / d.rmse_base_heldout;
  for (auto& b : bases) d.calibrations.push_back(b.cal);
  for (auto& c : cands) d.candidates.push_back(c.res);
  ev.stages = base.cal.stages;
  // The extended model of the plots and the residual views: the cause, else the best candidate.
  const int shown = cause >= 0 ? cause : best_c;
  add_residual_views(P, base.full, shown >= 0 && cands[shown].full.ok ? &cands[shown].full : nullptr,
                     &ev);
  d.evidence = ev;

  // 6. Whole runs held out.
  if (o.whole_run_holdout && P.runs.size() >= 2)
    whole_run_holdouts(P, o.rtol_score, base, cause >= 0 ? &cands[cause] : nullptr, o, threads, &d);
  check_stop();
  if (o.keep_traces) {
    for (std::size_t k = 0; k < P.runs.size(); ++k) {
      RunSeries s;
      s.name = P.runs[k].name;
      s.t = P.runs[k].t;
      s.measured = P.runs[k].y;
      for (double F : base.full.sims[k].F) s.base.push_back(F + base.full.offset);
      if (shown >= 0 && cands[shown].full.ok)
        for (double F : cands[shown].full.sims[k].F) s.extended.push_back(F + cands[shown].full.offset);
      d.series.push_back(std::move(s));
    }
  }
  d.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return d;
}

}  // namespace stickslip::diagnosis
