#pragma once
// Internal: StageAccumulator (metrics.cpp) in structure-of-arrays form for L lanes that share
// their sample times. The common path (integrals, min/max, running peak/trough) is branch-free
// and vectorises; the rare peak/trough confirmations are done per lane afterwards. It performs
// the same floating-point operations, in the same order, as StageAccumulator::sample/finish, so
// the metrics of a batch lane equal simulate()'s bitwise (Batch.LanesMatchSimulate checks this).
// Keep the two in step when changing either.
#include <array>
#include <vector>

#include "stickslip/engine/metrics.h"
#include "stickslip/engine/simulate.h"

namespace stickslip::engine::detail {

template <int L>
class LaneAccumulators {
 public:
  /// thr: per-lane cycle_threshold [N].
  LaneAccumulators(double t_start, double t_end, double settle_fraction, const double* thr)
      : t_start_(t_start), t_end_(t_end), t_judge_(t_start + settle_fraction * (t_end - t_start)) {
    for (int j = 0; j < L; ++j) {
      thr_[j] = thr[j];
      seek_[j] = 0.0;
    }
  }

  bool in_window(double t) const noexcept { return !(t < t_judge_ || t > t_end_); }

  /// One sample per lane at the shared time t (drive force fd [N], friction ff [N]).
  void sample(double t, const double* __restrict fd, const double* __restrict ff) {
    if (!in_window(t)) return;
    if (!have_prev_) {
      have_prev_ = true;
      t_first_ = t;
      t_prev_ = t;
      for (int j = 0; j < L; ++j) {
        min_[j] = max_[j] = fd[j];
        run_max_[j] = fd[j];
        run_max_t_[j] = t;
        fd_prev_[j] = fd[j];
        ff_prev_[j] = ff[j];
      }
      return;  // a first sample can confirm nothing (F_d == run_max)
    }
    const double dt = t - t_prev_;
    for (int j = 0; j < L; ++j) {
      const double F = fd[j];
      int_fd_[j] += 0.5 * dt * (F + fd_prev_[j]);
      int_ff_[j] += 0.5 * dt * (ff[j] + ff_prev_[j]);
      min_[j] = F < min_[j] ? F : min_[j];  // std::min(min_, F)
      max_[j] = max_[j] < F ? F : max_[j];  // std::max(max_, F)
      fd_prev_[j] = F;
      ff_prev_[j] = ff[j];
      // Running peak (seek 0) or trough (seek 1); the confirmations (ev) are rare and done
      // below. Bitwise & on bools keeps the loop free of branches.
      const bool peak = seek_[j] == 0.0;
      const double rmax = run_max_[j], rmin = run_min_[j];
      const bool up = peak & (F > rmax);
      const bool down = !peak & (F < rmin);
      run_max_[j] = up ? F : rmax;
      run_max_t_[j] = up ? t : run_max_t_[j];
      run_min_[j] = down ? F : rmin;
      const bool ev_peak = peak & !(F > rmax) & (F < rmax - thr_[j]);
      const bool ev_trough = !peak & !(F < rmin) & (F > rmin + thr_[j]);
      event_[j] = (ev_peak | ev_trough) ? 1.0 : 0.0;
    }
    t_prev_ = t;
    bool any = false;  // (a reduction inside the loop above would block vectorising it)
    for (int j = 0; j < L; ++j) any = any || event_[j] != 0.0;
    if (!any) return;
    for (int j = 0; j < L; ++j) {
      if (event_[j] == 0.0) continue;
      Rare& q = rare_[j];
      const double F = fd[j];
      if (seek_[j] == 0.0) {  // peak confirmed
        q.last_peak = run_max_[j];
        q.last_peak_real = run_max_t_[j] > t_first_;
        if (q.last_peak_real) {
          if (q.peaks == 0) q.first_peak_t = run_max_t_[j];
          q.last_peak_t = run_max_t_[j];
          ++q.peaks;
        }
        seek_[j] = 1.0;
        run_min_[j] = F;
      } else {  // trough confirmed
        if (q.last_peak_real) q.amplitudes.push_back(q.last_peak - run_min_[j]);
        seek_[j] = 0.0;
        run_max_[j] = F;
        run_max_t_[j] = t;
      }
    }
  }

  StageMetrics finish(int j) const {
    StageMetrics m;
    m.t_start = t_start_;
    m.t_end = t_end_;
    const double span = t_prev_ - t_first_;
    if (have_prev_ && span > 0) {
      m.mean_force = int_fd_[j] / span;
      m.mean_friction = int_ff_[j] / span;
    } else if (have_prev_) {
      m.mean_force = fd_prev_[j];
      m.mean_friction = ff_prev_[j];
    }
    const Rare& q = rare_[j];
    m.amplitude_raw = have_prev_ ? max_[j] - min_[j] : 0.0;
    m.amplitude = median(q.amplitudes);
    m.slip_events = q.peaks;
    m.mean_period = q.peaks > 1 ? (q.last_peak_t - q.first_peak_t) / (q.peaks - 1) : 0.0;
    return m;
  }

 private:
  struct Rare {
    double last_peak = 0.0;
    bool last_peak_real = false;
    int peaks = 0;
    double first_peak_t = 0.0, last_peak_t = 0.0;
    std::vector<double> amplitudes;
  };
  double t_start_, t_end_, t_judge_;
  bool have_prev_ = false;
  double t_first_ = 0.0, t_prev_ = 0.0;
  alignas(64) double thr_[L];
  alignas(64) double seek_[L];  // 0: seeking a peak, 1: seeking a trough
  alignas(64) double fd_prev_[L] = {}, ff_prev_[L] = {};
  alignas(64) double int_fd_[L] = {}, int_ff_[L] = {};
  alignas(64) double min_[L] = {}, max_[L] = {};
  alignas(64) double run_max_[L] = {}, run_max_t_[L] = {}, run_min_[L] = {};
  alignas(64) double event_[L] = {};
  std::array<Rare, L> rare_;
};

}  // namespace stickslip::engine::detail
