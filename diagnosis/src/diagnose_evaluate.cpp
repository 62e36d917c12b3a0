// Simulating every run of a problem at a parameter point and scoring it (evaluate, diagnose_fit.h):
// the time domain, on the samples or their cycle features (diagnose_features.h); the statistics
// are in diagnose_statfit.cpp.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/diagnosis/detail/diagnose_progress.h"
#include "stickslip/diagnosis/detail/diagnose_statfit.h"
#include "stickslip/engine/simulate.h"

namespace stickslip::diagnosis::detail {

namespace {

double span_end(const RunData& r, Span span, double short_end) {
  switch (span) {
    case Span::kShort: return std::min(short_end, r.fit_end) + 1e-3;
    case Span::kFit:
    case Span::kFeatures: return r.fit_end + 1e-3;
    case Span::kStats:
    case Span::kFull: return r.cond.duration;
  }
  return r.cond.duration;
}

bool counts(const RunData& r, std::size_t i, Span span, double short_end) {
  if (r.role[i] != kFit) return false;
  return span != Span::kShort || r.t[i] < short_end;
}

/// The samples of a trace with from <= t < to, as columns on the clock t - shift [s], F_d [N].
void trace_columns(const std::vector<engine::TraceSample>& tr, double from, double to, double shift,
                   std::vector<double>* t, std::vector<double>* F) {
  for (const engine::TraceSample& q : tr)
    if (q.t >= from && q.t < to) {
      t->push_back(q.t - shift);
      F->push_back(q.F_d);
    }
}

/// Length of the phase search around the switch [s]: the measured mean still-stage period
/// (first window's slips), or 1 s when it has fewer than two.
double search_span(const RunData& r) {
  const auto& ts = r.features.t.front();
  return ts.size() >= 2 ? (ts.back() - ts.front()) / static_cast<double>(ts.size() - 1) : 1.0;
}

/// The shift of the switch that puts it at the measured phase of the still stage's stick-slip
/// cycle: t_k + anchor_tau - t_on for the simulated slip t_k (still stage simulated past t_on)
/// that puts it nearest to t_on; 0 when there is none, or when the shifted switch would fall
/// inside the first feature window. The simulated cycle is then as long past its last slip as
/// the measured one, whatever its own period and levels (a force level as the anchor fails
/// where the vibration breaks the stick at once: the measured F_d is already falling just after
/// t_on, and a model whose troughs lie above it never reaches it).
double phase_shift(const RunData& r, const std::vector<engine::TraceSample>& tr) {
  const double T = search_span(r);
  WindowSpec w = r.windows.front();  // the measured level and hysteresis find the slips
  w.t0 = std::max(0.0, r.anchor_t - 2 * T);
  w.t1 = tr.back().t;
  std::vector<double> t, F;
  trace_columns(tr, w.t0, std::numeric_limits<double>::infinity(), 0.0, &t, &F);
  const Features f = extract_features(t, F, {w}, r.cond.kd * r.cond.vd);
  double best = std::numeric_limits<double>::infinity();
  for (double tk : f.t.front()) {
    const double d = tk + r.anchor_tau - r.anchor_t;
    if (std::fabs(d) < std::fabs(best)) best = d;
  }
  if (!std::isfinite(best) || r.anchor_t + best <= r.windows.front().t1) return 0.0;
  return best;
}

/// cfg (all stages) with the first stage ending at t_switch, the later stages unchanged, cut
/// at t_end.
engine::SimConfig switched_at(engine::SimConfig cfg, double t_switch, double t_end) {
  cfg.stages.front().duration = t_switch;
  cfg.stages = stages_until(cfg.stages, t_end);
  return cfg;
}

/// Appends the windows of b to a (the feature vectors are per window).
void append_windows(Features* a, const Features& b) {
  auto cat = [](auto& x, const auto& y) { x.insert(x.end(), y.begin(), y.end()); };
  cat(a->t, b.t);
  cat(a->P, b.P);
  cat(a->Q, b.Q);
  cat(a->blocks, b.blocks);
  cat(a->mean, b.mean);
  cat(a->sd, b.sd);
}

}  // namespace

namespace {

/// What the runs of one evaluation share: the simulated still stages at theta (runs' own traces or
/// phase-only simulations) for the phase of the runs that vibrate after t_on, and, for unaligned
/// spans, the checkpoints of first (still) stages that runs with the same first stage continue
/// from (SimCheckpoint, bitwise the same as from rest). `kept` owns every result pointed to.
struct Shared {
  std::vector<std::pair<const RunData*, const std::vector<engine::TraceSample>*>> still;
  std::vector<std::unique_ptr<engine::SimResult>> kept;
  std::vector<std::pair<engine::SimConfig, engine::SimCheckpoint>> first_stages;
};

/// The trace of a run that vibrates after t_on, aligned on the measured phase of its still stage
/// (features only): the still stage simulated one period and the slip's ramp window past t_on,
/// shared by the runs with the same still stage (the same m, k_d, v_d and t_on), gives the shift
/// of the switch; returns the configuration switched there.
engine::SimConfig aligned_config(const RunData& r, const FitModel& m, const std::vector<double>& theta,
                                 double rtol, double t_end, engine::SimConfig cfg, Shared& sh, double* shift) {
  const double t_a = r.anchor_t + search_span(r) + 0.2;
  const std::vector<engine::TraceSample>* tr = nullptr;
  for (const auto& [q, qt] : sh.still)
    if (q->cond.m == r.cond.m && q->cond.kd == r.cond.kd && q->cond.vd == r.cond.vd &&
        q->anchor_t == r.anchor_t && !qt->empty() && qt->back().t >= t_a)
      tr = qt;
  if (!tr) {
    auto a = std::make_unique<engine::SimResult>(
        engine::simulate(switched_at(m.config(r, theta, r.cond.duration, rtol), t_a, t_a)));
    if (a->status == engine::RunStatus::kOk) {
      tr = &a->trace;
      sh.still.push_back({&r, tr});
      sh.kept.push_back(std::move(a));
    }
  }
  if (tr) *shift = phase_shift(r, *tr);
  if (*shift != 0) cfg = switched_at(m.config(r, theta, r.cond.duration, rtol), r.anchor_t + *shift, t_end + *shift);
  return cfg;
}

/// Simulates run r for the span (aligned for the features when it can be); the result is owned by
/// sh.kept. Throws what the configuration throws.
const engine::SimResult* simulate_run(const Problem& p, const FitModel& m, const std::vector<double>& theta,
                                      const RunData& r, Span span, double t_end, Shared& sh, double* shift) {
  *shift = 0;  // the switch moved by this to the measured phase (features only) [s]
  const bool align = span == Span::kFeatures && std::isfinite(r.anchor_tau) && r.windows.size() > 1;
  engine::SimConfig cfg = m.config(r, theta, t_end, p.rtol);
  bool all_still = true;
  for (const engine::Stage& st : cfg.stages) all_still = all_still && !st.vibrating();
  auto res = std::make_unique<engine::SimResult>();
  if (align && all_still) {
    // Still after t_on too: the switch is nominal, so the run's own trace gives the phase and, on
    // the shifted clock, the later windows; it also serves the vibrating runs.
    *res = engine::simulate(cfg);
    if (res->status == engine::RunStatus::kOk && !res->trace.empty()) {
      *shift = phase_shift(r, res->trace);
      sh.still.push_back({&r, &res->trace});
    }
  } else if (align) {
    *res = engine::simulate(aligned_config(r, m, theta, p.rtol, t_end, cfg, sh, shift));
  } else if (cfg.stages.size() > 1) {
    const engine::SimCheckpoint* from = nullptr;
    for (const auto& [c0, cp] : sh.first_stages)
      if (engine::same_first_stages(cfg, c0, 1)) from = &cp;
    if (from) {
      *res = engine::simulate_from(cfg, *from);
    } else {
      engine::SimCheckpoint cp;
      *res = engine::simulate(cfg, 1, &cp);
      if (!cp.empty()) sh.first_stages.emplace_back(cfg, std::move(cp));
    }
  } else {
    *res = engine::simulate(cfg);
  }
  sh.kept.push_back(std::move(res));
  return sh.kept.back().get();
}

/// The cycle features of a simulated run against the measured ones: the first window (still stage,
/// before the switch) as simulated; the later windows from the switch on, on the measured clock
/// (simulated t - shift; shift = 0 unaligned).
void run_features(const RunData& r, const engine::SimResult& res, double shift, std::vector<double>* level,
                  std::vector<double>* other) {
  const double rise = r.cond.kd * r.cond.vd;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double t_switch = r.windows.size() > 1 ? r.windows[1].t0 + shift : kInf;
  std::vector<double> t0, f0, t1, f1;
  trace_columns(res.trace, -kInf, t_switch, 0.0, &t0, &f0);
  // The later part from 10 ms before the switch, so that the interpolant of the windowed
  // statistics reaches the window's start wherever the trace's grid lies (diagnose_features.cpp).
  trace_columns(res.trace, t_switch - 0.01, kInf, shift, &t1, &f1);
  const std::vector<WindowSpec> first(r.windows.begin(), r.windows.begin() + 1),
      later(r.windows.begin() + 1, r.windows.end());
  Features f = extract_features(t0, f0, first, rise);
  append_windows(&f, extract_features(t1, f1, later, rise));
  feature_residuals(r.features, f, r.windows, rise, level, other);
}

/// The trace linearly interpolated at the run's sample times up to t_end.
void sample_run(const RunData& r, const engine::SimResult& res, double t_end, RunSim* s) {
  std::size_t j = 0;
  for (std::size_t i = 0; i < r.t.size() && r.t[i] <= t_end; ++i) {
    while (j + 2 < res.trace.size() && res.trace[j + 1].t < r.t[i]) ++j;
    const engine::TraceSample &a = res.trace[j], &b = res.trace[j + 1];
    const double w = b.t > a.t ? std::clamp((r.t[i] - a.t) / (b.t - a.t), 0.0, 1.0) : 0.0;
    s->F.push_back(a.F_d + w * (b.F_d - a.F_d));
    s->x.push_back(a.x + w * (b.x - a.x));
    s->v.push_back(a.v + w * (b.v - a.v));
  }
  s->ok = true;
}

/// The offset (the mean residual of the counted samples, when fitted) and the fit and held-out SSE.
void score_samples(const Problem& p, Span span, double short_end, Evaluation& e) {
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < p.runs.size(); ++k)
    for (std::size_t i = 0; i < e.sims[k].F.size(); ++i)
      if (counts(p.runs[k], i, span, short_end)) {
        sum += p.runs[k].y[i] - e.sims[k].F[i];
        ++n;
      }
  e.offset = (p.fit_offset && n > 0) ? sum / static_cast<double>(n) : 0.0;
  for (std::size_t k = 0; k < p.runs.size(); ++k) {
    const RunData& r = p.runs[k];
    for (std::size_t i = 0; i < e.sims[k].F.size(); ++i) {
      const double res = r.y[i] - e.sims[k].F[i] - e.offset;
      if (counts(r, i, span, short_end)) {
        e.sse_fit += res * res;
        ++e.n_fit;
      } else if (span == Span::kFull && r.role[i] == kHeld) {
        e.sse_held += res * res;
        ++e.n_held;
      }
    }
  }
}

/// Per-cycle and per-stage features (diagnose_features.h) as the residuals; the sensor offset
/// shifts every level term alike and is removed in closed form.
void score_features(const Problem& p, const std::vector<double>& level, const std::vector<double>& other,
                    Evaluation& e) {
  double off = 0;
  if (p.fit_offset && !level.empty()) {
    for (double v : level) off += v;
    off /= static_cast<double>(level.size());
  }
  double sse = 0;
  for (double v : level) {
    e.feat.push_back(v - off);
    sse += (v - off) * (v - off);
  }
  for (double v : other) {
    e.feat.push_back(v);
    sse += v * v;
  }
  e.sse_fit = sse;
}

}  // namespace

Evaluation evaluate(const Problem& p, const FitModel& m, const std::vector<double>& theta,
                    Span span, double short_end) {
  if (span == Span::kStats) return evaluate_stats(p, m, theta);
  if (p.meter) p.meter->tick();
  Evaluation e;
  if (p.stop && p.stop()) {
    e.reason = "cancelled";
    return e;
  }
  e.sims.resize(p.runs.size());
  std::vector<double> feat_level, feat_other;
  Shared sh;
  for (std::size_t k = 0; k < p.runs.size(); ++k) {
    const RunData& r = p.runs[k];
    const double t_end = span_end(r, span, short_end);
    double shift = 0;
    const engine::SimResult* res = nullptr;
    try {
      res = simulate_run(p, m, theta, r, span, t_end, sh, &shift);
    } catch (const std::exception& ex) {
      e.reason = ex.what();
      return e;
    }
    if (res->status != engine::RunStatus::kOk || res->trace.size() < 2) {
      e.reason = "run " + r.name + ": " + to_string(res->status) + " " + res->reason;
      return e;
    }
    if (span == Span::kFeatures) run_features(r, *res, shift, &feat_level, &feat_other);
    sample_run(r, *res, t_end, &e.sims[k]);
  }
  score_samples(p, span, short_end, e);
  if (span == Span::kFeatures) score_features(p, feat_level, feat_other, e);
  e.ok = e.n_fit > 0;
  if (!e.ok && e.reason.empty()) e.reason = "no fit samples";
  return e;
}

std::vector<double> fit_residuals(const Problem& p, const Evaluation& e, Span span,
                                  double short_end) {
  std::vector<double> out;
  for (std::size_t k = 0; k < p.runs.size(); ++k)
    for (std::size_t i = 0; i < e.sims[k].F.size(); ++i)
      if (counts(p.runs[k], i, span, short_end))
        out.push_back(p.runs[k].y[i] - e.sims[k].F[i] - e.offset);
  return out;
}


}  // namespace stickslip::diagnosis::detail
