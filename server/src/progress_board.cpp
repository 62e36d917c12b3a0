#include "stickslip/server/progress_board.h"

#include <cmath>

namespace stickslip::server {

nlohmann::json progress_json(const diagnosis::Progress& p) {
  const auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"phase", p.phase},
          {"item", p.item},
          {"evaluations", p.evaluations},
          {"estimated_total", p.estimated_total},
          {"seconds", num(p.seconds)},
          {"seconds_left", num(p.seconds_left)}};
}

void ProgressBoard::set(const std::string& id, const diagnosis::Progress& p) {
  nlohmann::json j = progress_json(p);
  std::lock_guard<std::mutex> lock(mu_);
  board_[id] = std::move(j);
}

void ProgressBoard::erase(const std::string& id) {
  std::lock_guard<std::mutex> lock(mu_);
  board_.erase(id);
}

std::optional<nlohmann::json> ProgressBoard::get(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mu_);
  const auto it = board_.find(id);
  if (it == board_.end()) return std::nullopt;
  return it->second;
}

}  // namespace stickslip::server
