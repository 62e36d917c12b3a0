// One measured run read before any model (diagnose_record.h).
#include "stickslip/diagnosis/detail/diagnose_record.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace stickslip::diagnosis::detail {

namespace {

/// y resampled at the median interval by linear interpolation, from t.front() on.
std::vector<double> uniform(const std::vector<double>& t, const std::vector<double>& y, double* dt) {
  std::vector<double> d(t.size() - 1);
  for (std::size_t i = 1; i < t.size(); ++i) d[i - 1] = t[i] - t[i - 1];
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  *dt = d[d.size() / 2];
  const auto n = static_cast<std::size_t>(std::floor((t.back() - t.front()) / *dt + 1e-9)) + 1;
  std::vector<double> out(n);
  std::size_t j = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double ti = t.front() + static_cast<double>(i) * *dt;
    while (j + 2 < t.size() && t[j + 1] <= ti) ++j;
    const double f = std::clamp((ti - t[j]) / (t[j + 1] - t[j]), 0.0, 1.0);
    out[i] = y[j] + f * (y[j + 1] - y[j]);
  }
  return out;
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

std::string fmt(const char* f, double a, double b = 0) {
  char buf[160];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

}  // namespace

double natural_period(const measured::MeasuredConditions& c) {
  return 2 * M_PI * std::sqrt(c.m / c.kd);
}

std::vector<double> window_samples(const std::vector<double>& y, double dt, double t0, double t1) {
  const auto a = static_cast<std::size_t>(std::clamp(std::ceil(t0 / dt - 1e-9), 0.0, static_cast<double>(y.size())));
  const auto b = static_cast<std::size_t>(std::clamp(std::ceil(t1 / dt - 1e-9), 0.0, static_cast<double>(y.size())));
  return {y.begin() + static_cast<std::ptrdiff_t>(a), y.begin() + static_cast<std::ptrdiff_t>(std::max(a, b))};
}

namespace {

/// The preload, whether the record starts at rest, and whether the body is stuck at the start.
void initial_state(const measured::MeasuredConditions& c, RecordInfo& r) {
  const std::size_t n0 = std::clamp<std::size_t>(static_cast<std::size_t>(kPreloadSpan / r.dt), 5, r.y.size());
  r.preload = median_of({r.y.begin(), r.y.begin() + static_cast<std::ptrdiff_t>(n0)});
  r.from_rest = std::fabs(r.preload) < kRestFraction * std::fabs(r.level);
  // The least-squares slope of the first 0.2 s (at least 20 samples).
  const std::size_t n1 = std::clamp<std::size_t>(static_cast<std::size_t>(0.2 / r.dt), 20, r.y.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < n1; ++i) {
    const double x = static_cast<double>(i) * r.dt;
    sx += x, sy += r.y[i], sxx += x * x, sxy += x * r.y[i];
  }
  const double n = static_cast<double>(n1);
  r.start_slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  const double rise = c.kd * c.vd;
  r.stuck_at_start = std::fabs(r.start_slope - rise) < 0.5 * rise;
}

/// Every stage's statistics: the whole stage, its fitted and its held-out part, with one spec.
void stage_statistics(const measured::MeasuredConditions& c, double holdout_fraction, RecordInfo& r) {
  const int smooth = std::max(1, static_cast<int>(std::lround(natural_period(c) / 8 / r.dt)));
  // The smoothed noise: the AR(1) model's, raised by what the smoothed signal shows beyond it
  // (noise at scales above two samples), at most twice (an oscillation near the smoothing scale
  // shows as noise there).
  const double ar1 = averaged_noise(r.noise.sigma, r.noise.rho, smooth);
  const double noise_sd = ar1 > 0 ? ar1 * std::clamp(smoothed_noise(r.y, smooth) / ar1, 1.0, 2.0) : 0.0;
  const int lag = std::max(1, static_cast<int>(std::lround(natural_period(c) / r.dt)));
  std::vector<std::pair<double, double>> stages;
  if (c.t_on > 0) stages.emplace_back(0.0, std::min(c.t_on, c.duration));
  if (c.t_on < c.duration) stages.emplace_back(c.t_on, c.duration);
  const double t_end = std::min(c.duration, static_cast<double>(r.y.size()) * r.dt);
  for (std::size_t j = 0; j < stages.size(); ++j) {
    const double s = stages[j].first, e = std::min(stages[j].second, t_end);
    if (!(e > s)) continue;
    StatsSpec spec;
    spec.dt = r.dt;
    spec.smooth = smooth;
    spec.rise = c.kd * c.vd;
    spec.noise_sd = noise_sd;
    spec.threshold = drop_threshold(noise_sd);
    spec.lag = lag;
    spec.level = r.level;
    // First pass over the whole stage: the band edge and the detrending window from its slips.
    SlipStats whole = slip_stats(window_samples(r.y, r.dt, s, e), spec);
    if (whole.regime != Regime::kCreep && whole.interval_median > 0) {
      spec.f_lo = 0.25 / whole.interval_median;
      spec.detrend_window = 4.0 * whole.interval_median;
      whole = slip_stats(window_samples(r.y, r.dt, s, e), spec);
    }
    r.whole.push_back(whole);
    const double split = s + (1.0 - holdout_fraction) * (e - s);
    for (const bool held : {false, true}) {
      WindowStats w;
      w.stage = static_cast<int>(j);
      w.held = held;
      w.t0 = held ? split : s;
      w.t1 = held ? e : split;
      w.spec = spec;
      w.stats = slip_stats(window_samples(r.y, r.dt, w.t0, w.t1), spec);
      r.windows.push_back(w);
    }
  }
}

/// Phase-locked or not, and why.
void choose_scoring(RecordInfo& r) {
  const SlipStats& first = r.windows.front().stats;
  if (!r.from_rest) {
    r.phase_locked = false;
    r.why = fmt("starts mid-experiment (F_d(0) = %.3g N, %.0f %% of the median level)", r.preload,
                100 * r.preload / r.level);
  } else if (first.regime != Regime::kCreep && first.interval_cv > kRegularCv) {
    r.phase_locked = false;
    r.why = fmt("irregular slips (coefficient of variation of the time between drops %.2f > %.2f)",
                first.interval_cv, kRegularCv);
  } else {
    r.phase_locked = true;
    r.why = first.regime == Regime::kCreep
                ? std::string("starts at rest, no slips in the first stage")
                : fmt("starts at rest, regular slips (coefficient of variation %.2f <= %.2f)",
                      first.interval_cv, kRegularCv);
  }
}

}  // namespace

RecordInfo analyse_record(const measured::MeasuredRun& run, double holdout_fraction) {
  if (run.t.size() < 16) throw std::invalid_argument("run " + run.name + ": too few samples");
  RecordInfo r;
  r.name = run.name;
  const std::vector<double> raw = uniform(run.t, run.Fd, &r.dt);
  r.noise = estimate_noise(raw);
  std::vector<std::size_t> flagged;
  r.y = despike(raw, r.noise.sigma, &flagged);
  r.spikes = flagged.size();
  r.level = median_of(r.y);
  initial_state(run.conditions, r);
  stage_statistics(run.conditions, holdout_fraction, r);
  if (r.windows.empty()) throw std::invalid_argument("run " + run.name + ": no stage with samples");
  choose_scoring(r);
  return r;
}

}  // namespace stickslip::diagnosis::detail
