#pragma once
// Streaming per-stage metrics of a drive-force signal (see simulate.h for the definitions).
// Works on any time series: simulation steps or measured samples (uneven sampling is fine).

#include <vector>

#include "stickslip/engine/params.h"
#include "stickslip/engine/simulate.h"

namespace stickslip::engine {

class StageAccumulator {
 public:
  /// Judges samples with t in [t_start + settle_fraction (t_end - t_start), t_end].
  StageAccumulator(double t_start, double t_end, const MetricOptions& opt);
  /// Feed samples in non-decreasing t. Samples outside the judged window are ignored.
  void sample(double t, double F_d, double F_f) noexcept;
  StageMetrics finish() const;
  double window_start() const noexcept { return t_judge_; }

 private:
  enum class Seek { kPeak, kTrough };
  double t_start_, t_end_, t_judge_, threshold_;
  bool have_prev_ = false;
  double t_first_ = 0, t_prev_ = 0, fd_prev_ = 0, ff_prev_ = 0;
  double int_fd_ = 0, int_ff_ = 0;
  double min_ = 0, max_ = 0;
  Seek seek_ = Seek::kPeak;
  double run_max_ = 0, run_max_t_ = 0, run_min_ = 0;
  double last_peak_ = 0;
  bool last_peak_real_ = false;
  int peaks_ = 0;
  double first_peak_t_ = 0, last_peak_t_ = 0;
  std::vector<double> amplitudes_;
};

/// Median of a copy of v (0 for an empty vector).
double median(std::vector<double> v);

}  // namespace stickslip::engine
