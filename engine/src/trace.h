#pragma once
// Internal: the decimated trace of a run (TraceSample, simulate.h), recorded by linear
// interpolation between integrator steps.
#include <vector>

#include "extended.h"
#include "stickslip/engine/simulate.h"

namespace stickslip::engine::detail {

/// Records decimated trace samples by linear interpolation between integrator steps.
class TraceRecorder {
 public:
  TraceRecorder(double rate, std::vector<TraceSample>* out) : out_(out) {
    if (rate > 0) period_ = 1.0 / rate;
  }
  bool active() const noexcept { return period_ > 0; }
  /// sensor_dynamics: the trace's F_d becomes the sensor's output (see extensions.h).
  void set_sensor(const SensorFilter& f) { sensor_ = f; }
  /// Further samples go to out (a copy of the recorder continues another run's trace).
  void retarget(std::vector<TraceSample>* out) noexcept { out_ = out; }
  /// Called on every integrator step: the common case (no sample due, no sensor) is inline.
  void add(const TraceSample& now) {
    if (period_ <= 0) return;
    if (have_prev_ && now.t < next_t_ && !sensor_.active()) {
      prev_ = now;
      return;
    }
    add_slow(now);
  }

 private:
  void add_slow(TraceSample now) {
    if (sensor_.active()) now.F_d = sensor_.step(now.t, now.F_d);
    if (!have_prev_) {
      prev_ = now;
      have_prev_ = true;
      if (now.t >= next_t_) emit(now);
      return;
    }
    while (next_t_ <= now.t) {
      const double span = now.t - prev_.t;
      const double w = span > 0 ? (next_t_ - prev_.t) / span : 1.0;
      auto lerp = [&](double a, double b) { return a + w * (b - a); };
      emit({next_t_, lerp(prev_.F_d, now.F_d), lerp(prev_.F_f, now.F_f), lerp(prev_.x, now.x),
            lerp(prev_.v, now.v), lerp(prev_.s, now.s)});
    }
    prev_ = now;
  }

  void emit(const TraceSample& s) {
    out_->push_back(s);
    ++count_;
    next_t_ = static_cast<double>(count_) * period_;
  }
  std::vector<TraceSample>* out_;
  double period_ = 0.0;
  double next_t_ = 0.0;
  std::size_t count_ = 0;
  bool have_prev_ = false;
  TraceSample prev_{};
  SensorFilter sensor_;
};

}  // namespace stickslip::engine::detail
