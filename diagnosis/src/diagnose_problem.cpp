// The fitting problem of a measured dataset (diagnose_fit.h): decimated samples with their fit and
// held-out roles, the feature windows, the model-free reading of every run and its statistics
// plan; and the measured levels the fits start from.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "stickslip/diagnosis/detail/diagnose_fit.h"
#include "stickslip/diagnosis/detail/diagnose_statfit.h"
#include "stickslip/engine/metrics.h"

namespace stickslip::diagnosis::detail {

Problem make_problem(const measured::MeasuredDataset& data, const DiagnoseOptions& o) {
  Problem p;
  p.rtol = o.rtol;
  p.fit_offset = o.fit_offset;
  p.stop = o.stop_requested;
  for (const measured::MeasuredRun& mr : data.runs) {
    RunData r;
    r.name = mr.name;
    r.cond = mr.conditions;
    if (mr.t.size() < 2) throw std::invalid_argument("run " + mr.name + ": too few samples");
    r.rec = analyse_record(mr, o.holdout_fraction);
    p.stats = p.stats || !r.rec.phase_locked;
    std::vector<double> dt(mr.t.size() - 1);
    for (std::size_t i = 1; i < mr.t.size(); ++i) dt[i - 1] = mr.t[i] - mr.t[i - 1];
    std::nth_element(dt.begin(), dt.begin() + dt.size() / 2, dt.end());
    const double dt_med = dt[dt.size() / 2];
    const std::size_t step =
        std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(1.0 / (o.fit_rate * dt_med))));
    engine::SimConfig c;
    measured::apply_conditions(r.cond, c);
    double t0 = 0;
    std::vector<std::pair<double, double>> stages;
    for (const engine::Stage& s : c.stages) {
      stages.emplace_back(t0, t0 + s.duration);
      r.stage_start.push_back(t0);
      t0 += s.duration;
    }
    {  // Feature windows: the fitted part of every stage, from the full-rate measured signal.
      std::vector<double> ft, fy;
      for (std::size_t i = 0; i < mr.t.size() && mr.t[i] <= r.cond.duration; ++i) {
        ft.push_back(mr.t[i]);
        fy.push_back(mr.Fd[i]);
      }
      for (std::size_t j = 0; j < stages.size(); ++j) {
        const double s = stages[j].first, d = stages[j].second - s;
        double e = s + (1.0 - o.holdout_fraction) * d;
        if (j > 0) e = std::min(e, s + o.later_stage_fit_span);
        r.windows.push_back(make_window(ft, fy, s, e, c.stages[j].v_a <= 0.0));
      }
      r.features = extract_features(ft, fy, r.windows, r.cond.kd * r.cond.vd);
      const auto& ts = r.features.t.front();
      if (stages.size() > 1 && c.stages[0].v_a <= 0.0 && ts.size() >= 4) {
        const std::size_t h = ts.size() / 2;
        const double T = (ts.back() - ts[h]) / static_cast<double>(ts.size() - 1 - h);
        r.anchor_t = stages[1].first;
        r.anchor_tau = std::fmod(r.anchor_t - ts.back(), T);
      }
    }
    for (std::size_t i = 0; i < mr.t.size(); i += step) {
      const double t = mr.t[i];
      if (t > r.cond.duration) break;
      int j = 0;
      while (j + 1 < static_cast<int>(stages.size()) && t >= stages[j + 1].first) ++j;
      const double s = stages[j].first, d = stages[j].second - s;
      const double held_from = s + (1.0 - o.holdout_fraction) * d;
      std::uint8_t role = kUnused;
      if (t >= held_from) role = kHeld;
      else if (j == 0 || t < s + o.later_stage_fit_span) role = kFit;
      r.t.push_back(t);
      r.y.push_back(mr.Fd[i]);
      r.role.push_back(role);
      r.stage.push_back(j);
      if (role == kFit) r.fit_end = std::max(r.fit_end, t);
    }
    plan_stats(r);
    p.runs.push_back(std::move(r));
  }
  return p;
}

StartLevels data_driven_start(const Problem& p) {
  // The engine's stage metrics of the measured first stage of every run (its settled part:
  // MetricOptions::settle_fraction), with the cycle threshold moved from Table 1's scale to the
  // record's (0.2 N at forces of ~10 N) and kept above the record's noise: the mean level, and
  // the median drop.
  const double F_ref = engine::FrictionParams{}["F_C"];
  double mean_sum = 0, amp_sum = 0;
  int n = 0;
  for (const auto& r : p.runs) {
    const double t1 = r.stage_start.size() > 1 ? r.stage_start[1] : r.cond.duration;
    engine::MetricOptions mo;
    mo.cycle_threshold = std::max(mo.cycle_threshold * std::fabs(r.rec.level) / F_ref,
                                  kThresholdSigmas * r.rec.noise.sigma);
    engine::StageAccumulator acc(0.0, t1, mo);
    for (std::size_t i = 0; i < r.t.size() && r.t[i] <= t1; ++i) acc.sample(r.t[i], r.y[i], r.y[i]);
    const engine::StageMetrics m = acc.finish();
    mean_sum += m.mean_force;
    amp_sum += m.amplitude;
    ++n;
  }
  StartLevels s;
  if (n == 0) return s;
  s.F_C0 = mean_sum / n;
  s.F_S0 = s.F_C0 + 0.5 * amp_sum / n;
  return s;
}


}  // namespace stickslip::diagnosis::detail
