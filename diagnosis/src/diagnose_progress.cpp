// The progress meter (diagnose_progress.h).
#include "stickslip/diagnosis/detail/diagnose_progress.h"

#include <cmath>
#include <limits>

namespace stickslip::diagnosis::detail {

ProgressMeter::ProgressMeter(std::function<void(const Progress&)> callback, double interval)
    : callback_(std::move(callback)), interval_(interval),
      start_(std::chrono::steady_clock::now()), last_(start_) {}

void ProgressMeter::phase(const std::string& name, int more_evaluations) {
  std::lock_guard<std::mutex> lock(mu_);
  phase_ = name;
  items_.clear();
  budget_ += more_evaluations;
  report_locked(true);
}

void ProgressMeter::begin(const std::string& item) {
  std::lock_guard<std::mutex> lock(mu_);
  ++items_[item];
}

void ProgressMeter::end(const std::string& item) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = items_.find(item);
  if (it != items_.end() && --it->second <= 0) items_.erase(it);
}

void ProgressMeter::tick() {
  ++evals_;
  if (!callback_) return;
  const auto now = std::chrono::steady_clock::now();
  std::unique_lock<std::mutex> lock(mu_, std::try_to_lock);
  if (!lock.owns_lock()) return;  // another thread is reporting
  if (std::chrono::duration<double>(now - last_).count() < interval_) return;
  report_locked(false);
}

void ProgressMeter::add_budget(int evaluations) { budget_ += evaluations; }

void ProgressMeter::done() {
  std::lock_guard<std::mutex> lock(mu_);
  phase_ = "done";
  items_.clear();
  budget_ = evals_.load();
  report_locked(true);
}

void ProgressMeter::report_locked(bool force) {
  if (!callback_) return;
  const auto now = std::chrono::steady_clock::now();
  if (!force && std::chrono::duration<double>(now - last_).count() < interval_) return;
  last_ = now;
  Progress p;
  p.phase = phase_;
  for (const auto& [item, n] : items_) p.item += (p.item.empty() ? "" : ", ") + item;
  p.evaluations = evals_.load();
  p.estimated_total = std::max(budget_.load(), p.evaluations);
  p.seconds = std::chrono::duration<double>(now - start_).count();
  p.seconds_left = p.evaluations > 0 && p.seconds > 0
                       ? (p.estimated_total - p.evaluations) * p.seconds / p.evaluations
                       : std::numeric_limits<double>::quiet_NaN();
  callback_(p);
}

}  // namespace stickslip::diagnosis::detail
