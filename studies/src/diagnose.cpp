// The diagnosis pipeline (see diagnose.h): calibrate, choose, extend, test, name.
#include "stickslip/studies/diagnose.h"

#include <omp.h>

#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "diagnose_evidence.h"
#include "diagnose_fit.h"
#include "diagnose_load.h"
#include "diagnose_sensor.h"
#include "diagnose_starts.h"
#include "stickslip/engine/metrics.h"

namespace stickslip::studies {

using namespace diag;

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
  if (max_evals_base < 10) return fail("max_evals_base = " + std::to_string(max_evals_base) + ": must be >= 10");
  if (max_evals_candidate < 10)
    return fail("max_evals_candidate = " + std::to_string(max_evals_candidate) + ": must be >= 10");
  if (max_evals_profile < 4)
    return fail("max_evals_profile = " + std::to_string(max_evals_profile) + ": must be >= 4");
  if (max_evals_fold < 5)
    return fail("max_evals_fold = " + std::to_string(max_evals_fold) + ": must be >= 5");
  if (!(alpha > 0 && alpha < 1)) return fail("alpha = " + std::to_string(alpha) + ": must be in (0, 1)");
  if (!(min_gain >= 0 && min_gain < 1)) return fail("min_gain = " + std::to_string(min_gain) + ": must be in [0, 1)");
  for (ExtensionKind k : candidates)
    if (k == ExtensionKind::kNone) return fail("candidates: \"none\" is not a candidate");
  return true;
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double rms(double sse, std::size_t n) { return n ? std::sqrt(sse / static_cast<double>(n)) : kNaN; }

std::vector<ParamEstimate> estimates(const FitModel& m, const std::vector<double>& theta,
                                     const std::vector<double>& se, std::size_t from,
                                     std::size_t to) {
  std::vector<ParamEstimate> out;
  for (std::size_t i = from; i < to; ++i) {
    std::string name = m.specs[i].name;
    double v = theta[i], s = se.empty() ? kNaN : se[i];
    if (name == "F_C/F_S") {  // report F_C itself
      const double F_S = theta[0];
      name = "F_C";
      v = theta[i] * F_S;
      s = std::isfinite(s) ? s * F_S : s;
    }
    out.push_back({name, v, s});
  }
  return out;
}

/// Per-stage cycle statistics of measured and simulated F_d at the samples.
std::vector<StageScore> stage_scores(const Problem& p, const Evaluation& e) {
  std::vector<StageScore> out;
  MetricOptions mo;
  for (std::size_t k = 0; k < p.runs.size(); ++k) {
    const RunData& r = p.runs[k];
    for (std::size_t j = 0; j < r.stage_start.size(); ++j) {
      const double t0 = r.stage_start[j];
      const double t1 = j + 1 < r.stage_start.size() ? r.stage_start[j + 1] : r.cond.duration;
      StageAccumulator am(t0, t1, mo), as(t0, t1, mo);
      for (std::size_t i = 0; i < r.t.size() && i < e.sims[k].F.size(); ++i) {
        if (r.t[i] < t0 || r.t[i] > t1) continue;
        am.sample(r.t[i], r.y[i], r.y[i]);
        as.sample(r.t[i], e.sims[k].F[i] + e.offset, e.sims[k].F[i]);
      }
      const StageMetrics a = am.finish(), b = as.finish();
      out.push_back({static_cast<int>(k), static_cast<int>(j), a.amplitude, b.amplitude,
                     a.mean_force, b.mean_force, a.mean_period, b.mean_period, a.slip_events,
                     b.slip_events});
    }
  }
  return out;
}

struct BaseFit {
  BaseCalibration cal;
  FitModel model;
  std::vector<double> theta;
  double sse_fit = 0;
  std::size_t n_fit = 0;
  Evaluation full;
};

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
BaseFit calibrate(const Problem& P, const Problem& Ps, ModelKind kind, double F_C0, double F_S0,
                  const DiagnoseOptions& o, const std::vector<double>* start) {
  BaseFit b;
  b.cal.model = kind;
  b.model.base = SimConfig::seed(kind, 0.0);
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

struct CandFit {
  CandidateResult res;
  FitModel model;
  std::vector<double> theta;
  double sse_fit = 0;
  double n_eff = 10;  ///< effective samples from the candidate's own residuals (the noise
                      ///< model under the alternative; under the null both are the noise)
  Evaluation full;
};

/// Base parameters shifted for a dwell-time start at (A, tau): a base without the effect
/// absorbs the dwell strengthening of the still stage's long sticks into F_S (hidden A = 0.5 N,
/// tau = 0.1 s, seed 1000: base F_S 12.99 for F_S0 = 11.77 N), while the short sticks of a
/// vibrating stage see F_S0. Started from the base optimum with A held, the profile refit
/// stays there and misses slips (feature SSE 5.1 at A = 0.3 N, 30 at 1 N, against 0.066 for
/// the base). Here F_S starts at F_S - A ln(1 + T / tau), T the measured still-stage period
/// (the stick time of a still-base cycle is most of its period), and F_C/F_S is rescaled so
/// that F_C stays; other base models (no F_S parameter) are returned unchanged.
std::vector<double> dwell_origin(const FitModel& base, std::vector<double> theta, double A,
                                 double tau, double period) {
  std::size_t iS = theta.size(), iR = theta.size();
  for (std::size_t j = 0; j < base.specs.size() && j < theta.size(); ++j) {
    if (base.specs[j].name == "F_S") iS = j;
    if (base.specs[j].name == "F_C/F_S") iR = j;
  }
  if (iS >= theta.size() || !(period > 0) || !(tau > 0)) return theta;
  const double F_S = theta[iS];
  const double F_S0 = std::max(F_S - A * std::log1p(period / tau), 0.5 * F_S);
  theta[iS] = F_S0;
  if (iR < theta.size()) theta[iR] = std::min(theta[iR] * F_S / F_S0, 1.0);
  return theta;
}

/// Base parameters shifted for a start of a slip-velocity extension (viscous friction sigma2,
/// drive damping c_d) at size c: a base without the effect has absorbed the force c v_r of the
/// slips into a raised F_C (hidden sigma2 = 30 N s/m on the 3 x 20 s benchmark: base F_C 8.99
/// for 8.3 N), so F_C starts at F_C - c v_slip, v_slip = sum v^2 / sum |v| over the base's
/// simulated still-stage slips (the velocity that weighs the slips' dissipation; 0.020 m/s
/// there against the 0.023 m/s the truth implies). Held at the base's F_C, the profile refit
/// from the base optimum misses slips (feature SSE ~100 at sigma2 = 20-60 against 2 for the
/// base). F_S and v_s stay; base models without an F_C parameter are returned unchanged.
std::vector<double> slip_velocity_origin(const FitModel& base, std::vector<double> theta,
                                         double c, double v_slip) {
  for (std::size_t j = 0; j < base.specs.size() && j < theta.size(); ++j) {
    if (base.specs[j].name == "F_C") theta[j] = std::max(theta[j] - c * v_slip, 0.5 * theta[j]);
    if (base.specs[j].name == "F_C/F_S")
      theta[j] = std::max(theta[j] - c * v_slip / theta[0], base.specs[j].lo);
  }
  return theta;
}

/// sum v^2 / sum |v| [m/s] over the sliding samples (|v| > 1 mm/s) of the still stages of the
/// base's scoring evaluation; 0 when there are none.
double slip_velocity(const Problem& P, const Evaluation& e) {
  double s1 = 0, s2 = 0;
  for (std::size_t k = 0; k < P.runs.size() && k < e.sims.size(); ++k)
    for (std::size_t i = 0; i < e.sims[k].v.size(); ++i) {
      const double v = std::fabs(e.sims[k].v[i]);
      if (P.runs[k].stage[i] == 0 && v > 1e-3) {
        s1 += v;
        s2 += v * v;
      }
    }
  return s1 > 0 ? s2 / s1 : 0.0;
}

/// A profile point of an extension: the base parameters refitted on the cycle features with the
/// extension held at (size, rest).
struct ProfilePoint {
  double size;
  double sse;                 ///< feature SSE of the refit
  std::vector<double> theta;  ///< base parameters
  std::vector<double> rest;   ///< the extension's other parameters (dwell_tau), held too
};

const ProfilePoint& best_profile(const std::vector<ProfilePoint>& p) {
  return *std::min_element(p.begin(), p.end(),
                           [](const ProfilePoint& a, const ProfilePoint& b) { return a.sse < b.sse; });
}

/// The next size to profile: between the best point and its better neighbour (in size, among the
/// points with the best one's other parameters), at the geometric mean (arithmetic next to size
/// 0); 0 when the best is bracketed to 5 % already or has no neighbour.
double next_profile_size(const std::vector<ProfilePoint>& p) {
  const ProfilePoint& best = best_profile(p);
  const double b = best.size;
  const ProfilePoint *lo = nullptr, *hi = nullptr;
  for (const ProfilePoint& q : p) {
    if (q.rest != best.rest) continue;
    if (q.size < b && (!lo || q.size > lo->size)) lo = &q;
    if (q.size > b && (!hi || q.size < hi->size)) hi = &q;
  }
  const ProfilePoint* n = !lo ? hi : !hi ? lo : (lo->sse < hi->sse ? lo : hi);
  if (!n) return 0.0;
  const double s = n->size > 0 && b > 0 ? std::sqrt(n->size * b) : 0.5 * (n->size + b);
  return std::fabs(s - b) > 0.05 * std::max(b, n->size) ? s : 0.0;
}

/// Fit RMSE, held-out RMSE, n_eff and AIC of a candidate from its scoring evaluation c.full.
void score_candidate(const Problem& P, CandFit& c) {
  c.sse_fit = c.full.sse_fit;
  c.res.offset = c.full.offset;
  c.res.rmse_fit = rms(c.full.sse_fit, c.full.n_fit);
  c.res.rmse_heldout = rms(c.full.sse_held, c.full.n_held);
  const double rho = lag1(P, c.full);
  c.n_eff = std::max(static_cast<double>(c.full.n_fit) * (1 - rho) / (1 + rho), 10.0);
  c.res.aic = c.n_eff * std::log(c.full.sse_fit / c.full.n_fit) + 2.0 * c.theta.size();
}

/// A candidate nests its base: at the extension's neutral size it is the base model
/// (tests/engine/test_extensions.cpp, NeutralSizeReproducesBase). When the candidate's own
/// optimum scores worse on the fit set than the base point does, the base point (base
/// parameters, neutral extension) is the better point of the candidate's parameter space
/// known, and the candidate is reported there, with the base's scoring evaluation. Without
/// this, a candidate could end worse than the model it extends (measured on clean data before
/// the common scoring: 0.0356 against 0.0307 N), which makes the LR test and the information
/// criterion meaningless. Returns true when the candidate was moved to the base point.
bool nest_in_base(const Problem& P, CandFit& c, const BaseFit& base, std::size_t nb) {
  if (!base.full.ok || c.full.sse_fit <= base.full.sse_fit) return false;
  c.theta.assign(base.theta.begin(), base.theta.end());
  const auto neutral = neutral_extension(c.res.kind);
  c.theta.insert(c.theta.end(), neutral.begin(), neutral.end());
  c.full = base.full;
  score_candidate(P, c);
  c.res.base_params = base.cal.params;
  c.res.params = estimates(c.model, c.theta, {}, nb, c.theta.size());
  c.res.at_base_point = true;
  return true;
}

std::vector<std::vector<double>> extension_starts(ExtensionKind k, const std::vector<ParamSpec>& specs,
                                                  const Evidence& ev, const SineScan& scan,
                                                  double F_C0) {
  std::vector<std::vector<double>> s;
  switch (k) {
    case ExtensionKind::kViscous: s = {{0.0}, {20.0}, {60.0}, {150.0}}; break;
    case ExtensionKind::kStribeckShape: s = {{2.0}, {1.0}, {4.0}}; break;
    case ExtensionKind::kDwellTime: s = {{0.0, 0.1}, {0.3, 0.1}, {1.0, 0.1}, {0.3, 1.0}}; break;
    case ExtensionKind::kWaviness: {
      // The three strongest local maxima of the residual spectrum against x.
      std::vector<std::size_t> peaks;
      for (std::size_t i = 1; i + 1 < scan.period.size(); ++i)
        if (scan.amplitude[i] >= scan.amplitude[i - 1] && scan.amplitude[i] >= scan.amplitude[i + 1])
          peaks.push_back(i);
      std::sort(peaks.begin(), peaks.end(),
                [&](std::size_t a, std::size_t b) { return scan.amplitude[a] > scan.amplitude[b]; });
      peaks.resize(std::min<std::size_t>(peaks.size(), 3));
      for (std::size_t i : peaks) {
        const double eps = std::clamp(scan.amplitude[i] / F_C0, 0.003, 0.25);
        for (double ph : {0.0, 0.5 * M_PI, M_PI, 1.5 * M_PI})
          s.push_back({eps, scan.period[i], ph - M_PI});
        s.push_back({eps, scan.period[i], scan.phase[i]});
      }
      if (s.empty()) s = {{specs[0].init, specs[1].init, specs[2].init}};
      break;
    }
    case ExtensionKind::kDrift:
      s = {{0.0}, {std::clamp(ev.trend_per_m / F_C0, -39.0, 39.0)}};
      break;
    case ExtensionKind::kNormalLoadModulation:
      // (eta_v, eta_q), diagnose_load.h: the observed levels are linear in them, so the
      // feature LM needs no phase scan; one start per sign of each component.
      s = {{0.0, 0.0}, {0.1, 0.0}, {-0.1, 0.0}, {0.0, 0.1}, {0.0, -0.1}};
      break;
    case ExtensionKind::kSensorDynamics:
      s = {{2e-3, 0.7}, {1e-3, 0.3}, {5e-3, 1.0}, {5e-3, 0.3}};
      break;
    case ExtensionKind::kDriveDamping: s = {{0.0}, {10.0}, {30.0}, {80.0}}; break;
    case ExtensionKind::kNone: break;
  }
  return s;
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
int calibration_rank(ModelKind m) {
  switch (m) {
    case ModelKind::kLuGre: return 3;
    case ModelKind::kDahl: return 2;
    case ModelKind::kKarnopp: return 1;
    case ModelKind::kResetIntegrator: return 1;
  }
  return 0;
}

/// Relative cost rank of a candidate's fit: viscous and drive_damping have profile starts at
/// four sizes with held-v_s refits, a bisection and two feature fits; sensor_dynamics held-v_s
/// starts; dwell_time, stribeck_shape and waviness profile starts; drift and the load
/// modulation neither.
int candidate_rank(ExtensionKind k) {
  switch (k) {
    case ExtensionKind::kViscous:
    case ExtensionKind::kDriveDamping: return 3;
    case ExtensionKind::kSensorDynamics:
    case ExtensionKind::kDwellTime: return 2;
    case ExtensionKind::kStribeckShape:
    case ExtensionKind::kWaviness: return 1;
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

Diagnosis diagnose(const MeasuredDataset& data, const DiagnoseOptions& o) {
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
  for (ModelKind m : o.models) model_rank.push_back(calibration_rank(m));
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

  // 3. Every candidate extension on the best base, base parameters refitted.
  // Mean measured stick-slip period of the still stages [s] (dwell_origin).
  double still_period = 0;
  {
    int n = 0;
    for (const StageScore& st : base.cal.stages)
      if (st.stage == 0 && std::isfinite(st.measured_period) && st.measured_period > 0) {
        still_period += st.measured_period;
        ++n;
      }
    still_period = n ? still_period / n : 0.0;
  }
  const double v_slip = slip_velocity(P, base.full);
  double base_feature_sse = std::numeric_limits<double>::infinity();  // profile size 0
  if (std::any_of(o.candidates.begin(), o.candidates.end(), [](ExtensionKind k) {
        return k == ExtensionKind::kViscous || k == ExtensionKind::kDriveDamping ||
               k == ExtensionKind::kDwellTime;
      })) {  // only the profile bisection (slip-velocity and dwell candidates) uses it
    const Evaluation e = evaluate(P, base.model, base.theta, Span::kFeatures, 0);
    ++d.evaluations;
    if (e.ok) base_feature_sse = e.sse_fit;
  }
  const std::size_t nb = base.theta.size();
  std::vector<CandFit> cands(o.candidates.size());
  std::vector<int> cand_rank;
  for (ExtensionKind k : o.candidates) cand_rank.push_back(candidate_rank(k));
  const auto cand_order = longest_first(cand_rank);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (std::size_t j = 0; j < o.candidates.size(); ++j) {
    const std::size_t i = cand_order[j];
    CandFit& c = cands[i];
    c.res.kind = o.candidates[i];
    try {
      c.model = base.model;
      c.model.base.extension.kind = o.candidates[i];
      const auto ext = extension_specs(o.candidates[i]);
      c.model.specs.insert(c.model.specs.end(), ext.begin(), ext.end());
      c.res.dof = static_cast<int>(ext.size());
      std::vector<std::vector<double>> starts, held_starts;
      // Effects that act on the slip itself (viscous, drive damping, Stribeck shape, dwell
      // time) change the stick-slip cycle so much that the base optimum is no start for a
      // moderate size: their cycle features at (base optimum, size) miss slips. For them every
      // starting size gets its own profile start: the base parameters refitted on the
      // features with the extension held at that size.
      const ExtensionKind kind = o.candidates[i];
      const bool slip_force = kind == ExtensionKind::kViscous || kind == ExtensionKind::kDriveDamping;
      const bool profile = slip_force ||
                           kind == ExtensionKind::kStribeckShape || kind == ExtensionKind::kDwellTime;
      auto ext_starts = extension_starts(kind, ext, ev, scan, F_C0);
      bool wave_profile = false;
      if (kind == ExtensionKind::kWaviness) {
        // The residual spectrum is slip-timing noise when the base misses slips: starts from the
        // measured peaks against the stick position instead (diagnose_starts.h), each with a
        // profile start (the base has absorbed part of the effect), when there are enough peaks.
        auto ws = waviness_peak_starts(P, base.full.offset, ext, 3);
        if (!ws.empty()) {
          ext_starts = std::move(ws);
          wave_profile = true;
        }
      }
      const bool bisect = slip_force || kind == ExtensionKind::kDwellTime;
      // The base model with the extension held at es (a profile), and, for the candidates that
      // bisect their profile, the base optimum shifted for that size (dwell_origin,
      // slip_velocity_origin).
      const auto held_model = [&](const std::vector<double>& es) {
        FitModel pm = base.model;
        pm.base.extension.kind = kind;
        for (std::size_t j = 0; j < es.size(); ++j) set_parameter(pm.base, ext[j].name, es[j]);
        return pm;
      };
      const auto shifted_origin = [&](const std::vector<double>& es) {
        return slip_force ? slip_velocity_origin(base.model, base.theta, es[0], v_slip)
                          : dwell_origin(base.model, base.theta, es[0], es[1], still_period);
      };
      const std::vector<double> neutral_ext = neutral_extension(kind);
      std::vector<ProfilePoint> profiles = {
          {neutral_ext[0], base_feature_sse, base.theta, {neutral_ext.begin() + 1, neutral_ext.end()}}};
      for (const auto& es : ext_starts) {
        std::vector<double> th = base.theta;
        const bool neutral = profile && es[0] == neutral_ext[0];
        if ((profile && !neutral) || wave_profile) {
          FitModel pm = held_model(es);
          std::vector<std::vector<double>> origins = {base.theta};
          if (bisect) origins.push_back(shifted_origin(es));
          const FitResult pr = fit(P, pm, origins, Span::kFeatures, 0, o.max_evals_profile);
          c.res.evals += pr.evals;
          if (pr.ok) {
            th = pr.theta;
            profiles.push_back({es[0], pr.sse, pr.theta, {es.begin() + 1, es.end()}});
          }
          // Viscous friction and drive damping both add force in proportion to the slip
          // velocity. A base without them absorbs that force by a raised F_C and a v_s far
          // below its true value (hidden sigma2 = 60 N s/m: v_s 7.2e-5 for 3.2e-4 m/s), and
          // the feature objective has a false minimum there: refitted from the base optimum
          // with the size held, v_s runs to its lower bound. So these also get a second
          // profile start with v_s held at its nominal value (the spec's start, Table 1) and
          // the other base parameters refitted; phase B then picks the better start by the
          // time-domain objective.
          std::size_t iv = nb;
          for (std::size_t j = 0; j < nb; ++j)
            if (base.model.specs[j].name == "v_s") iv = j;
          if (slip_force && iv < nb) {
            FitModel hm = pm;
            set_parameter(hm.base, "v_s", base.model.specs[iv].init);
            hm.specs.erase(hm.specs.begin() + static_cast<std::ptrdiff_t>(iv));
            std::vector<double> h0 = base.theta;
            h0.erase(h0.begin() + static_cast<std::ptrdiff_t>(iv));
            const FitResult hr = fit(P, hm, {h0}, Span::kFeatures, 0, o.max_evals_profile);
            c.res.evals += hr.evals;
            if (hr.ok) {
              std::vector<double> th2 = hr.theta;
              th2.insert(th2.begin() + static_cast<std::ptrdiff_t>(iv), base.model.specs[iv].init);
              th2.insert(th2.end(), es.begin(), es.end());
              starts.push_back(th2);
              held_starts.push_back(th2);
            }
          }
        }
        th.insert(th.end(), es.begin(), es.end());
        starts.push_back(th);
      }
      if (bisect) {
        // The size grid is coarse (20, 60, 150; dwell A 0.3, 1) and the profile's minimum narrow
        // on long still stages: refine it by bisection between the best size and its better
        // neighbour, the other parameters (dwell_tau) held at the best point's.
        for (int step = 0; step < 3; ++step) {
          const double size = next_profile_size(profiles);
          if (!(size > 0)) break;
          const ProfilePoint best = best_profile(profiles);  // a copy: profiles grows below
          std::vector<double> es = {size};
          es.insert(es.end(), best.rest.begin(), best.rest.end());
          const FitResult pr = fit(P, held_model(es), {best.theta, shifted_origin(es)},
                                   Span::kFeatures, 0, o.max_evals_profile);
          c.res.evals += pr.evals;
          if (!pr.ok) break;
          profiles.push_back({size, pr.sse, pr.theta, best.rest});
          std::vector<double> th = pr.theta;
          th.insert(th.end(), es.begin(), es.end());
          starts.push_back(th);
        }
      }
      if (kind == ExtensionKind::kSensorDynamics)  // held-v_s profile starts (diagnose_sensor.h)
        sensor_profile_starts(P, base.model, base.theta, o, &starts, &held_starts, &c.res.evals);
      // Phase A: cycle features (mean, amplitude, period per stage; smooth in the parameters,
      // unlike the slip timing), so the base parameters can move far from the base optimum
      // together with the extension (a viscous term raises the cycle mean that the base had
      // absorbed in F_C). Phase B: time domain from there (below).
      const int n_feat = o.max_evals_candidate / 2;
      const FitResult fa = fit(P, c.model, starts, Span::kFeatures, 0, n_feat);
      if (fa.ok) starts.insert(starts.begin(), fa.theta);
      if (!held_starts.empty()) {
        // The base optimum usually has the best features of all starts, so phase A stays in
        // the base's basin; a second feature fit from the best held-v_s start, every
        // parameter free, explores the other basin (docs/diagnose.md "Status").
        const FitResult fh = fit(P, c.model, held_starts, Span::kFeatures, 0, n_feat);
        c.res.evals += fh.evals;
        if (fh.ok) starts.insert(starts.begin(), fh.theta);
      }
      // Phase B starts from the feature optima only (phase A's, and the held-v_s one). The
      // base point has the best time-domain SSE of all starts whenever the features have moved
      // the base parameters (slip timing), so picking phase B's start by that SSE kept every
      // slip-acting candidate at the base point (hidden dwell A = 0.5 N, seed 1000: phase A
      // reached A = 0.31 N with feature SSE 0.0046 against the base's 0.066, phase B went back
      // to A = 3e-4 N). The base point stays the candidate's fallback (nest_in_base).
      std::vector<std::vector<double>> b_starts;
      if (fa.ok) b_starts.push_back(fa.theta);
      if (!held_starts.empty() && fa.ok && starts.size() > 1) b_starts.push_back(starts[0]);
      if (b_starts.empty()) b_starts = starts;
      FitResult fr = fit(P, c.model, b_starts, Span::kFit, 0, o.max_evals_candidate - fa.evals);
      fr.evals += fa.evals;
      c.res.evals += fr.evals;
      if (!fr.ok) throw std::runtime_error(fr.reason);
      c.theta = fr.theta;
      c.full = evaluate(Ps, c.model, c.theta, Span::kFull, 0);
      ++c.res.evals;
      if (!c.full.ok) throw std::runtime_error(c.full.reason);
      if (!nest_in_base(P, c, base, nb)) {
        score_candidate(P, c);
        std::vector<double> cov;
        const auto se =
            standard_errors(P, c.model, c.theta, c.full.n_fit / c.n_eff, &c.res.evals, &cov);
        c.res.base_params = estimates(c.model, c.theta, se, 0, nb);
        c.res.params = estimates(c.model, c.theta, se, nb, c.theta.size());
        if (kind == ExtensionKind::kNormalLoadModulation)
          append_load_estimates(c.theta, nb, cov, &c.res.params);
      } else if (kind == ExtensionKind::kNormalLoadModulation) {
        append_load_estimates(c.theta, nb, {}, &c.res.params);
      }
    } catch (const std::exception& e) {
      c.res.status = std::string("failed: ") + e.what();
    }
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

}  // namespace stickslip::studies
