// Statistics scoring (diagnose_statfit.h).
#include "stickslip/diagnosis/detail/diagnose_statfit.h"

#include <algorithm>
#include <cmath>

#include "stickslip/engine/simulate.h"

namespace stickslip::diagnosis::detail {

namespace {

/// The measured fitted and held-out windows of stage j of r (nullptr when absent).
const WindowStats* measured_window(const RunData& r, int stage, bool held) {
  for (const WindowStats& w : r.rec.windows)
    if (w.stage == stage && w.held == held) return &w;
  return nullptr;
}

/// Stage boundaries of the record [s].
std::vector<std::pair<double, double>> record_stages(const measured::MeasuredConditions& c) {
  std::vector<std::pair<double, double>> st;
  if (c.t_on > 0) st.emplace_back(0.0, std::min(c.t_on, c.duration));
  if (c.t_on < c.duration) st.emplace_back(c.t_on, c.duration);
  return st;
}

}  // namespace

void plan_stats(RunData& r) {
  const auto& c = r.cond;
  const double Tn = natural_period(c);
  const WindowStats* first = measured_window(r, 0, false);
  const bool drops = first && first->stats.regime != Regime::kCreep && first->stats.interval_median > 0;
  const double interval = drops ? first->stats.interval_median : 0.0;
  r.settle = 0.0;
  if (!r.rec.from_rest) {
    const double rise = c.kd * c.vd;
    const double load = rise > 0 ? std::max(r.rec.preload, 0.0) / rise : 0.0;
    r.settle = load + (drops ? 3.0 * interval : 10.0 * Tn);
  }
  const auto stages = record_stages(c);
  r.stats_span.clear();
  for (const auto& [s, e] : stages) {
    if (stages.size() > 1) {
      r.stats_span.push_back(e - s);
      continue;
    }
    const double want = std::max({kSpanIntervals * interval, kSpanPeriods * Tn, kSpanMin});
    r.stats_span.push_back(std::min(want, e - s));
  }
}

engine::SimConfig stats_config(const FitModel& m, const RunData& r, const std::vector<double>& theta,
                               double rtol) {
  engine::SimConfig cfg = m.config(r, theta, r.cond.duration, rtol);
  cfg.stages.front().duration += r.settle;
  if (cfg.stages.size() == 1) cfg.stages.front().duration = r.settle + r.stats_span.front();
  bool still = true;
  for (const engine::Stage& s : cfg.stages) still = still && !s.vibrating();
  if (still) cfg.integrator.dt_max = std::min(kStillStepMax, natural_period(r.cond) / 20.0);
  cfg.trace.rate = 1.0 / r.rec.dt;
  double total = 0;
  for (const engine::Stage& s : cfg.stages) total += s.duration;
  cfg.integrator.max_steps = 1e6 * std::max(total, 1.0);
  return cfg;
}

std::vector<SlipStats> simulated_stats(const RunData& r, const std::vector<engine::TraceSample>& trace) {
  std::vector<SlipStats> out;
  const auto stages = record_stages(r.cond);
  for (std::size_t j = 0; j < stages.size() && j < r.stats_span.size(); ++j) {
    const WindowStats* w = measured_window(r, static_cast<int>(j), false);
    if (!w) {
      out.emplace_back();
      continue;
    }
    const double t0 = r.settle + stages[j].first, t1 = t0 + r.stats_span[j];
    std::vector<double> y;
    y.reserve(static_cast<std::size_t>((t1 - t0) / r.rec.dt) + 2);
    for (const engine::TraceSample& q : trace)
      if (q.t >= t0 - 1e-12 && q.t < t1 - 1e-12) y.push_back(q.F_d);
    out.push_back(slip_stats(y, w->spec));
  }
  return out;
}

Evaluation evaluate_stats(const Problem& p, const FitModel& m, const std::vector<double>& theta) {
  Evaluation e;
  if (p.stop && p.stop()) {
    e.reason = "cancelled";
    return e;
  }
  e.sims.resize(p.runs.size());
  std::vector<double> held;
  for (std::size_t k = 0; k < p.runs.size(); ++k) {
    const RunData& r = p.runs[k];
    engine::SimResult res;
    try {
      res = engine::simulate(stats_config(m, r, theta, p.rtol));
    } catch (const std::exception& ex) {
      e.reason = ex.what();
      return e;
    }
    if (res.status != engine::RunStatus::kOk || res.trace.size() < 4) {
      e.reason = "run " + r.name + ": " + to_string(res.status) + " " + res.reason;
      return e;
    }
    e.stats.push_back(simulated_stats(r, res.trace));
    for (std::size_t j = 0; j < e.stats.back().size(); ++j) {
      for (const bool h : {false, true}) {
        const WindowStats* w = measured_window(r, static_cast<int>(j), h);
        if (!w) continue;
        stats_residuals(w->stats, e.stats.back()[j], w->spec, h ? &held : &e.feat);
      }
    }
    e.sims[k].ok = true;
  }
  for (double v : e.feat) e.sse_fit += v * v;
  for (double v : held) e.sse_held += v * v;
  e.n_fit = e.feat.size();
  e.n_held = held.size();
  e.ok = e.n_fit > 0;
  if (!e.ok) e.reason = "no statistics to fit";
  return e;
}

void constant_stats_score(const Problem& p, double* sse_fit, std::size_t* n_fit, double* sse_held,
                          std::size_t* n_held) {
  *sse_fit = *sse_held = 0;
  *n_fit = *n_held = 0;
  for (const RunData& r : p.runs) {
    for (const WindowStats& w : r.rec.windows) {
      // A constant at the fitted part's mean: no drops, no spread beyond the noise.
      const WindowStats* f = measured_window(r, w.stage, false);
      SlipStats c;
      c.mean = f ? f->stats.mean : w.stats.mean;
      c.q05 = c.q95 = c.mean;
      c.ramp_slope = c.creep = c.f_peak = std::numeric_limits<double>::quiet_NaN();
      std::vector<double> res;
      stats_residuals(w.stats, c, w.spec, &res);
      double s = 0;
      for (double v : res) s += v * v;
      (w.held ? *sse_held : *sse_fit) += s;
      (w.held ? *n_held : *n_fit) += res.size();
    }
  }
}

}  // namespace stickslip::diagnosis::detail
