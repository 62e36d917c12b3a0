#include "stickslip/server/health.h"

namespace stickslip::server {

void Health::degrade(const std::string& kind, const std::string& error,
                     std::chrono::milliseconds retry_in) {
  std::lock_guard lock(mu_);
  degraded_[kind] = "the " + kind + " worker is paused by a store fault (next attempt in " +
                    std::to_string(retry_in.count() / 1000.0).substr(0, 4) + " s): " + error;
}

void Health::recover(const std::string& kind) {
  std::lock_guard lock(mu_);
  degraded_.erase(kind);
}

std::optional<std::string> Health::problem() const {
  std::lock_guard lock(mu_);
  if (degraded_.empty()) return std::nullopt;
  std::string out;
  for (const auto& [kind, what] : degraded_) out += (out.empty() ? "" : "\n") + what;
  return out;
}

}  // namespace stickslip::server
