#pragma once
// JSON has no NaN or infinity: every writer of study results maps them to null through these.
#include <cmath>
#include <optional>

#include <nlohmann/json.hpp>

namespace stickslip::common {

/// v as a JSON number, or null when v is NaN or infinite.
inline nlohmann::json json_number(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}
/// As above; null also when v is empty.
inline nlohmann::json json_number(const std::optional<double>& v) {
  return v ? json_number(*v) : nlohmann::json(nullptr);
}

}  // namespace stickslip::common
