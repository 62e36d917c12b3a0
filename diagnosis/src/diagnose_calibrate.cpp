// Step 1 of the diagnosis: calibrating one base model (diagnose_calibrate.h).
#include "stickslip/diagnosis/detail/diagnose_calibrate.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "stickslip/diagnosis/detail/diagnose_progress.h"
#include "stickslip/engine/metrics.h"

namespace stickslip::diagnosis::detail {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::vector<double> inits(const FitModel& m) {
  std::vector<double> v;
  for (const ParamSpec& s : m.specs) v.push_back(s.init);
  return v;
}

/// The statistics fit's starts: the start, and each log-scaled parameter moved kStatsStartSpread
/// of its box either way (the velocity and time scales are the least certain from the record).
std::vector<std::vector<double>> stats_starts(const FitModel& m) {
  const std::vector<double> init = inits(m);
  std::vector<std::vector<double>> out = {init};
  for (std::size_t j = 0; j < m.specs.size(); ++j) {
    if (!m.specs[j].log) continue;
    for (const double du : {-kStatsStartSpread, kStatsStartSpread}) {
      const double u = m.specs[j].to_unit(init[j]) + du;
      if (u < 0 || u > 1) continue;
      std::vector<double> th = init;
      th[j] = m.specs[j].to_value(u);
      out.push_back(th);
    }
  }
  return out;
}

/// Step 2: the first fit of the fitted parameters.
FitResult first_fit(const CalibrationInputs& in, const FitModel& m) {
  const Problem& P = in.P;
  const DiagnoseOptions& o = in.o;
  const std::vector<double> init = inits(m);
  if (P.stats) return fit(P, m, stats_starts(m), Span::kStats, 0, o.max_evals_base);
  // Cycle features first (independent of slip timing), then the time-domain fit from there.
  const int n_short = o.max_evals_base * 2 / 5;
  const FitResult a = fit(P, m, {init}, Span::kFeatures, 0, n_short);
  std::vector<std::vector<double>> starts = {init};
  if (a.ok) starts.insert(starts.begin(), a.theta);
  FitResult fr = fit(P, m, starts, Span::kFit, 0, o.max_evals_base - a.evals);
  fr.evals += a.evals;
  return fr;
}

std::string fmt(const char* f, double a, double b) {
  char buf[200];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

/// Step 3: the secondary parameters freed when identifiable, then all refitted.
void free_secondaries(const CalibrationInputs& in, engine::ModelKind kind, BaseFit& b) {
  const Problem& P = in.P;
  const Span span = fit_span(P);
  for (const ParamSpec& s : b.model.specs) b.cal.identifiability.push_back({s.name, "fitted", 0, ""});
  const Evaluation e0 = evaluate(P, b.model, b.theta, span, 0);
  ++b.cal.evals;
  if (!e0.ok) return;
  const double threshold =
      P.stats ? 1.0 : 4.0 * e0.sse_fit / static_cast<double>(std::max<std::size_t>(e0.n_fit, 1)) * in.noise_inflation;
  FitModel freed = b.model;
  std::vector<double> theta = b.theta;
  for (const ParamSpec& s : secondary_specs(kind, in.scales)) {
    const double v = engine::get_parameter(b.model.base, s.name);
    double change = 0;
    for (const double f : {kIdentifyFactor, 1.0 / kIdentifyFactor}) {
      FitModel moved = b.model;
      engine::set_parameter(moved.base, s.name, v * f);
      const Evaluation e = evaluate(P, moved, b.theta, span, 0);
      ++b.cal.evals;
      if (e.ok) change = std::max(change, std::fabs(e.sse_fit - e0.sse_fit));
    }
    if (change > threshold) {
      freed.specs.push_back({s.name, v / 10.0, v * 10.0, true, v});
      theta.push_back(v);
      b.cal.identifiability.push_back({s.name, "fitted", 0, ""});
    } else {
      b.cal.identifiability.push_back(
          {s.name, "held", v,
           fmt("not identifiable: moving it x3 either way changes the fit objective by %.3g "
               "(threshold %.3g)", change, threshold)});
    }
  }
  // Parameters with no fit range and a zero default (LuGre's h_v: the catalogue's viscous term
  // stands for it) stay at their defaults.
  for (const engine::ParamDef& p : engine::model_traits(kind).params) {
    bool listed = false;
    for (const ParamStatus& q : b.cal.identifiability) listed = listed || q.name == p.name;
    for (const ParamSpec& q : b.model.specs) listed = listed || q.name.rfind(p.name, 0) == 0;
    if (!listed)
      b.cal.identifiability.push_back({p.name, "held", engine::get_parameter(b.model.base, p.name),
                                       "not fitted: no fit range (a catalogue effect stands for it)"});
  }
  b.origin = b.theta;
  if (freed.specs.size() == b.model.specs.size()) return;
  const FitResult fr = fit(P, freed, {theta}, span, 0, in.o.max_evals_base / 2);
  b.cal.evals += fr.evals;
  if (!fr.ok) return;
  b.model = freed;
  b.origin = theta;
  b.theta = fr.theta;
}

}  // namespace

Span fit_span(const Problem& P) { return P.stats ? Span::kStats : Span::kFit; }

FitModel base_model(const CalibrationInputs& in, engine::ModelKind kind) {
  FitModel m;
  m.base = engine::SimConfig::seed(kind, 0.0);
  scale_defaults(kind, in.scales, &m.base);
  m.specs = scaled_base_specs(kind, in.scales, in.levels);
  return m;
}

std::vector<StageScore> stage_scores(const Problem& p, const Evaluation& e) {
  std::vector<StageScore> out;
  engine::MetricOptions mo;
  for (std::size_t k = 0; k < p.runs.size() && k < e.sims.size(); ++k) {
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

BaseFit calibrate(const CalibrationInputs& in, engine::ModelKind kind) {
  BaseFit b;
  b.cal.model = kind;
  ProgressItem item(in.P.meter.get(), engine::to_string(kind));
  try {
    b.model = base_model(in, kind);
    const FitResult fr = first_fit(in, b.model);
    b.cal.evals = fr.evals;
    if (!fr.ok) {
      b.cal.status = "failed: " + fr.reason;
      return b;
    }
    b.theta = fr.theta;
    free_secondaries(in, kind, b);
    for (ParamStatus& q : b.cal.identifiability)
      for (std::size_t i = 0; i < b.model.specs.size(); ++i)
        if (q.status == "fitted" && b.model.specs[i].name == q.name) q.value = b.theta[i];
    finish_base(in, b);
  } catch (const std::exception& e) {
    b.cal.status = std::string("failed: ") + e.what();
  }
  return b;
}

BaseFit polish(const CalibrationInputs& in, const BaseFit& b, const std::vector<double>& start) {
  BaseFit p;
  p.cal = b.cal;
  p.model = b.model;
  p.cal.status = "ok";
  try {
    const FitResult fr = fit(in.P, p.model, {start}, fit_span(in.P), 0, in.o.max_evals_base / 2);
    p.cal.evals = fr.evals;
    if (!fr.ok) {
      p.cal.status = "failed: " + fr.reason;
      return p;
    }
    p.theta = fr.theta;
    finish_base(in, p);
  } catch (const std::exception& e) {
    p.cal.status = std::string("failed: ") + e.what();
  }
  return p;
}

void finish_base(const CalibrationInputs& in, BaseFit& b) {
  const Problem& Ps = in.Ps;
  BaseCalibration& c = b.cal;
  b.stats = evaluate(Ps, b.model, b.theta, Span::kStats, 0);
  if (b.stats.ok) {
    c.score_fit = rms(b.stats.sse_fit, b.stats.n_fit);
    c.score_heldout = rms(b.stats.sse_held, b.stats.n_held);
  } else {
    c.score_fit = c.score_heldout = kNaN;
  }
  if (Ps.stats) {
    b.full = b.stats;
    if (!b.full.ok) {
      c.status = "failed: " + b.full.reason;
      return;
    }
    c.offset = 0;
    c.rmse_fit = c.rmse_heldout = kNaN;
    b.sse_fit = b.full.sse_fit;
    b.n_fit = b.full.n_fit;
    return;
  }
  b.full = evaluate(Ps, b.model, b.theta, Span::kFull, 0);
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
  for (std::size_t k = 0; k < Ps.runs.size(); ++k) {
    double s = 0;
    for (std::size_t i = 0; i < b.full.sims[k].F.size(); ++i) {
      const double r = Ps.runs[k].y[i] - b.full.sims[k].F[i] - b.full.offset;
      s += r * r;
    }
    c.rmse_run.push_back(rms(s, b.full.sims[k].F.size()));
  }
  c.stages = stage_scores(Ps, b.full);
}

JacobianInfo jacobian_info(const Problem& p, const FitModel& m, const std::vector<double>& theta,
                           Span span, double n_over_neff, int* evals) {
  const std::size_t k = theta.size();
  JacobianInfo out;
  out.se.assign(k, kNaN);
  const auto residuals = [&](const std::vector<double>& th, std::vector<double>* r) {
    const Evaluation e = evaluate(p, m, th, span, 0);
    ++*evals;
    if (!e.ok) return false;
    *r = span == Span::kStats || span == Span::kFeatures ? e.feat : fit_residuals(p, e, span, 0);
    return true;
  };
  std::vector<double> r0;
  if (!residuals(theta, &r0)) return out;
  const std::size_t n = r0.size();
  if (n <= k + 1) return out;
  const double step = jacobian_step(span);
  Eigen::MatrixXd J(n, k);
  std::vector<double> u(k);
  for (std::size_t j = 0; j < k; ++j) u[j] = m.specs[j].to_unit(theta[j]);
  for (std::size_t j = 0; j < k; ++j) {
    const double h = u[j] > 1.0 - 2 * step ? -step : step;
    std::vector<double> th = theta, r;
    th[j] = m.specs[j].to_value(u[j] + h);
    if (!residuals(th, &r) || r.size() != n) return out;
    for (std::size_t i = 0; i < n; ++i)
      J(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = (r[i] - r0[i]) / h;
  }
  double sse = 0;
  for (double r : r0) sse += r * r;
  const double s2 = sse / static_cast<double>(n - k);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(J, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const auto& sv = svd.singularValues();
  const auto kk = static_cast<Eigen::Index>(k);
  out.condition = sv(kk - 1) > 0 ? sv(0) / sv(kk - 1) : std::numeric_limits<double>::infinity();
  // Rank at a relative tolerance of 1e-6 of the largest singular value (the unit box makes the
  // columns commensurate: a change over the whole range of each parameter).
  for (Eigen::Index i = 0; i < kk; ++i) out.rank += sv(i) > 1e-6 * sv(0) ? 1 : 0;
  for (Eigen::Index i = 0; i < kk; ++i) out.weakest.push_back(std::fabs(svd.matrixV()(i, kk - 1)));
  if (sv(0) <= 0 || out.rank < static_cast<int>(k)) return out;
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(kk, kk);
  for (Eigen::Index i = 0; i < kk; ++i)
    cov += svd.matrixV().col(i) * svd.matrixV().col(i).transpose() / (sv(i) * sv(i));
  cov *= s2 * n_over_neff;
  out.cov.assign(k * k, 0.0);
  for (std::size_t i = 0; i < k; ++i) {
    const double di = m.specs[i].dvalue_du(u[i]);
    out.se[i] = std::sqrt(std::max(0.0, cov(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)))) * std::fabs(di);
    for (std::size_t j = 0; j < k; ++j)
      out.cov[i * k + j] = cov(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) * di *
                           m.specs[j].dvalue_du(u[j]);
  }
  return out;
}

std::vector<double> standard_errors(const Problem& p, const FitModel& m,
                                    const std::vector<double>& theta, double n_over_neff,
                                    int* evals, std::vector<double>* cov_si) {
  JacobianInfo j = jacobian_info(p, m, theta, fit_span(p), n_over_neff, evals);
  if (cov_si) *cov_si = std::move(j.cov);
  return j.se;
}

CalibratedModel calibrated_model(const FitModel& m, const std::vector<double>& theta, double offset) {
  CalibratedModel c;
  engine::SimConfig cfg = m.base;
  m.apply(cfg, theta);
  c.model = cfg.model;
  c.effect = cfg.extension.kind;
  c.offset = offset;
  for (const engine::ParamDef& p : engine::model_traits(cfg.model).params)
    c.params.emplace_back(p.name, cfg.friction[p.name]);
  for (const std::string& name : engine::extension_parameter_names(cfg.extension.kind)) {
    double v = 0;
    if (engine::get_extension_parameter(cfg.extension, name, &v)) c.params.emplace_back(name, v);
  }
  return c;
}

}  // namespace stickslip::diagnosis::detail
