#pragma once
// Internal to the diagnosis: the progress meter behind DiagnoseOptions::progress. One meter per
// diagnosis, shared by every copy of its Problem (a shared_ptr): evaluate() ticks it once per
// model evaluation from any thread; the orchestration names the phase and the items (models,
// candidates) in work. The callback runs under the meter's mutex, so its calls never overlap,
// at most every `interval` seconds and on every change of phase.

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <mutex>
#include <string>

#include "stickslip/diagnosis/diagnose.h"

namespace stickslip::diagnosis::detail {

class ProgressMeter {
 public:
  ProgressMeter(std::function<void(const Progress&)> callback, double interval);
  /// A new phase (serial code); reports at once.
  void phase(const std::string& name, int more_evaluations);
  /// An item (a model, a candidate, a fold) starts or ends work; thread-safe.
  void begin(const std::string& item);
  void end(const std::string& item);
  /// One model evaluation; thread-safe; may report.
  void tick();
  /// Adds to the budget (an upper estimate of the evaluations still to come).
  void add_budget(int evaluations);
  int evaluations() const noexcept { return evals_.load(); }
  /// The final report ("done").
  void done();

 private:
  void report_locked(bool force);
  std::function<void(const Progress&)> callback_;
  double interval_;
  std::chrono::steady_clock::time_point start_, last_;
  std::atomic<int> evals_{0};
  std::atomic<int> budget_{0};
  std::mutex mu_;
  std::string phase_;
  std::map<std::string, int> items_;
};

/// RAII: begin(item) now, end(item) at scope exit; a null meter does nothing.
class ProgressItem {
 public:
  ProgressItem(ProgressMeter* m, std::string item) : m_(m), item_(std::move(item)) {
    if (m_) m_->begin(item_);
  }
  ~ProgressItem() {
    if (m_) m_->end(item_);
  }
  ProgressItem(const ProgressItem&) = delete;
  ProgressItem& operator=(const ProgressItem&) = delete;

 private:
  ProgressMeter* m_;
  std::string item_;
};

}  // namespace stickslip::diagnosis::detail
