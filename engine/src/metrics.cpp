#include "stickslip/engine/metrics.h"

#include <algorithm>

namespace stickslip::engine {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  const double hi = *mid;
  const double lo = *std::max_element(v.begin(), mid);
  return 0.5 * (lo + hi);
}

StageAccumulator::StageAccumulator(double t_start, double t_end, const MetricOptions& opt)
    : t_start_(t_start),
      t_end_(t_end),
      t_judge_(t_start + opt.settle_fraction * (t_end - t_start)),
      threshold_(opt.cycle_threshold) {}

void StageAccumulator::sample(double t, double F_d, double F_f) noexcept {
  if (t < t_judge_ || t > t_end_) return;
  if (!have_prev_) {
    have_prev_ = true;
    t_first_ = t;
    min_ = max_ = F_d;
    run_max_ = F_d;
    run_max_t_ = t;
  } else {
    const double dt = t - t_prev_;
    int_fd_ += 0.5 * dt * (F_d + fd_prev_);
    int_ff_ += 0.5 * dt * (F_f + ff_prev_);
    min_ = std::min(min_, F_d);
    max_ = std::max(max_, F_d);
  }
  t_prev_ = t;
  fd_prev_ = F_d;
  ff_prev_ = F_f;

  // Cycle detection with hysteresis. A peak at the very first sample is the window edge cutting
  // a slope, not a slip; it still arms the trough search but is not counted.
  if (seek_ == Seek::kPeak) {
    if (F_d > run_max_) {
      run_max_ = F_d;
      run_max_t_ = t;
    } else if (F_d < run_max_ - threshold_) {
      last_peak_ = run_max_;
      last_peak_real_ = run_max_t_ > t_first_;
      if (last_peak_real_) {
        if (peaks_ == 0) first_peak_t_ = run_max_t_;
        last_peak_t_ = run_max_t_;
        ++peaks_;
      }
      seek_ = Seek::kTrough;
      run_min_ = F_d;
    }
  } else {
    if (F_d < run_min_) {
      run_min_ = F_d;
    } else if (F_d > run_min_ + threshold_) {
      if (last_peak_real_) amplitudes_.push_back(last_peak_ - run_min_);
      seek_ = Seek::kPeak;
      run_max_ = F_d;
      run_max_t_ = t;
    }
  }
}

StageMetrics StageAccumulator::finish() const {
  StageMetrics m;
  m.t_start = t_start_;
  m.t_end = t_end_;
  const double span = t_prev_ - t_first_;
  if (have_prev_ && span > 0) {
    m.mean_force = int_fd_ / span;
    m.mean_friction = int_ff_ / span;
  } else if (have_prev_) {
    m.mean_force = fd_prev_;
    m.mean_friction = ff_prev_;
  }
  m.amplitude_raw = have_prev_ ? max_ - min_ : 0.0;
  m.amplitude = median(amplitudes_);
  m.slip_events = peaks_;
  m.mean_period = peaks_ > 1 ? (last_peak_t_ - first_peak_t_) / (peaks_ - 1) : 0.0;
  return m;
}

}  // namespace stickslip::engine
