// Statistics scoring (diagnose_statfit.h).
#include "stickslip/diagnosis/detail/diagnose_statfit.h"

#include <algorithm>
#include <cmath>

#include "stickslip/diagnosis/detail/diagnose_progress.h"
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

namespace {

/// The simulated F_d of a trace in [t0, t1) (simulated time) [N].
std::vector<double> trace_window(const std::vector<engine::TraceSample>& trace, double t0, double t1,
                                 double dt) {
  std::vector<double> y;
  y.reserve(static_cast<std::size_t>(std::max(0.0, (t1 - t0) / dt)) + 2);
  for (const engine::TraceSample& q : trace)
    if (q.t >= t0 - 1e-12 && q.t < t1 - 1e-12) y.push_back(q.F_d);
  return y;
}

}  // namespace

std::vector<SlipStats> simulated_stats(const RunData& r, const std::vector<engine::TraceSample>& trace) {
  std::vector<SlipStats> out;
  const auto stages = record_stages(r.cond);
  for (const WindowStats& w : r.rec.windows) {
    const auto j = static_cast<std::size_t>(w.stage);
    if (j >= stages.size() || j >= r.stats_span.size()) {
      out.emplace_back();
      continue;
    }
    // The whole stage simulated: the measured window itself; else the simulated span stands for
    // every window of the stage.
    const bool whole = r.stats_span[j] >= stages[j].second - stages[j].first - 1e-9;
    const double t0 = r.settle + (whole ? w.t0 : stages[j].first);
    const double t1 = whole ? r.settle + w.t1 : t0 + r.stats_span[j];
    out.push_back(slip_stats(trace_window(trace, t0, t1, r.rec.dt), w.spec));
  }
  return out;
}

std::vector<SlipStats> simulated_whole(const RunData& r, const std::vector<engine::TraceSample>& trace) {
  std::vector<SlipStats> out;
  const auto stages = record_stages(r.cond);
  for (std::size_t j = 0; j < stages.size() && j < r.stats_span.size(); ++j) {
    const WindowStats* w = measured_window(r, static_cast<int>(j), false);
    if (!w) {
      out.emplace_back();
      continue;
    }
    const double t0 = r.settle + stages[j].first;
    out.push_back(slip_stats(trace_window(trace, t0, t0 + r.stats_span[j], r.rec.dt), w->spec));
  }
  return out;
}

Evaluation evaluate_stats(const Problem& p, const FitModel& m, const std::vector<double>& theta) {
  if (p.meter) p.meter->tick();
  Evaluation e;
  if (p.stop && p.stop()) {
    e.reason = "cancelled";
    return e;
  }
  e.sims.resize(p.runs.size());
  e.stats.resize(p.runs.size());
  e.whole.resize(p.runs.size());
  std::vector<double> held;
  for (std::size_t k = 0; k < p.runs.size(); ++k) {
    const RunData& r = p.runs[k];
    if (r.left_out != p.score_left_out) continue;  // a fold: fit the others, score the left out
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
    e.stats[k] = simulated_stats(r, res.trace);
    e.whole[k] = simulated_whole(r, res.trace);
    for (std::size_t i = 0; i < e.stats[k].size(); ++i) {
      const WindowStats& w = r.rec.windows[i];
      stats_residuals(w.stats, e.stats[k][i], w.spec, w.held || r.left_out ? &held : &e.feat);
    }
    e.sims[k].ok = true;
  }
  for (double v : e.feat) e.sse_fit += v * v;
  for (double v : held) e.sse_held += v * v;
  e.n_fit = e.feat.size();
  e.n_held = held.size();
  e.ok = e.n_fit > 0 || (p.score_left_out && e.n_held > 0);
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

namespace stickslip::diagnosis::detail {

namespace {

/// The first time in [from, to) where F crosses F0 in the given direction [s]; NaN when none.
double first_crossing(const std::vector<engine::TraceSample>& tr, double from, double to, double F0,
                      bool rising) {
  for (std::size_t i = 1; i < tr.size(); ++i) {
    if (tr[i].t < from) continue;
    if (tr[i].t >= to) break;
    const double a = tr[i - 1].F_d, b = tr[i].F_d;
    if (rising ? (a < F0 && b >= F0) : (a > F0 && b <= F0)) {
      const double w = b != a ? (F0 - a) / (b - a) : 0.0;
      return tr[i - 1].t + w * (tr[i].t - tr[i - 1].t);
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

/// F_d of a trace at the times t + shift (linear interpolation; t increasing).
std::vector<double> sample_trace(const std::vector<engine::TraceSample>& tr, const std::vector<double>& t,
                                 double shift) {
  std::vector<double> out;
  std::size_t j = 0;
  for (double ti : t) {
    const double s = ti + shift;
    while (j + 2 < tr.size() && tr[j + 1].t < s) ++j;
    const engine::TraceSample &a = tr[j], &b = tr[j + 1];
    const double w = b.t > a.t ? std::clamp((s - a.t) / (b.t - a.t), 0.0, 1.0) : 0.0;
    out.push_back(a.F_d + w * (b.F_d - a.F_d));
  }
  return out;
}

}  // namespace

std::vector<double> aligned_series(const RunData& r, const FitModel& m, const std::vector<double>& theta,
                                   double rtol, const std::vector<double>& t, double* shift) {
  *shift = 0;
  if (r.rec.from_rest) {
    engine::SimConfig cfg = m.config(r, theta, r.cond.duration, rtol);
    const engine::SimResult res = engine::simulate(cfg);
    if (res.status != engine::RunStatus::kOk || res.trace.size() < 2) return {};
    return sample_trace(res.trace, t, 0.0);
  }
  // The burn-in plus a search window for the crossing: a measured period, or ten natural ones.
  const WindowStats* w = measured_window(r, 0, false);
  const double period = w && w->stats.interval_median > 0 ? w->stats.interval_median : 10 * natural_period(r.cond);
  engine::SimConfig cfg = m.config(r, theta, r.cond.duration, rtol);
  const double search = r.settle + 1.5 * period;
  bool still = true;
  for (const engine::Stage& s : cfg.stages) still = still && !s.vibrating();
  if (still) cfg.integrator.dt_max = std::min(kStillStepMax, natural_period(r.cond) / 20.0);
  engine::SimConfig probe = cfg;
  probe.stages = {cfg.stages.front()};
  probe.stages.front().duration = search;
  const engine::SimResult pr = engine::simulate(probe);
  if (pr.status != engine::RunStatus::kOk || pr.trace.size() < 2) return {};
  double at = first_crossing(pr.trace, r.settle, search, r.rec.preload, r.rec.stuck_at_start);
  if (!std::isfinite(at)) at = r.settle;
  *shift = at;
  cfg.stages.front().duration += at;
  double total = 0;
  for (const engine::Stage& s : cfg.stages) total += s.duration;
  cfg.integrator.max_steps = 1e6 * std::max(total, 1.0);
  const engine::SimResult res = engine::simulate(cfg);
  if (res.status != engine::RunStatus::kOk || res.trace.size() < 2) return {};
  return sample_trace(res.trace, t, at);
}

}  // namespace stickslip::diagnosis::detail
