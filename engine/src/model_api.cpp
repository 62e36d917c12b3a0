#include "stickslip/engine/model_api.h"

#include <cstdio>
#include <stdexcept>

namespace stickslip::engine {
namespace {

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// "N", "m^2", "s^-1" style factors of one sign of exponent.
void factors(Dim d, int sign, std::string* out) {
  const std::pair<const char*, int> parts[] = {{"N", d.force}, {"m", d.length}, {"s", d.time}};
  // Conventional order: N before s before m in a numerator ("N s/m"), m before s ("m/s").
  const int order[] = {0, 2, 1};
  for (int k : order) {
    const int e = parts[k].second * sign;
    if (e <= 0) continue;
    if (!out->empty()) *out += ' ';
    *out += parts[k].first;
    if (e > 1) {
      *out += '^';
      *out += std::to_string(e);
    }
  }
}

}  // namespace

std::string unit_of(Dim d) {
  std::string num_part, den_part;
  factors(d, +1, &num_part);
  factors(d, -1, &den_part);
  if (num_part.empty() && den_part.empty()) return "-";
  if (den_part.empty()) return num_part;
  std::string out = num_part.empty() ? std::string(1, '1') : num_part;
  out += '/';
  if (den_part.find(' ') == std::string::npos) {
    out += den_part;
  } else {
    out += '(';
    out += den_part;
    out += ')';
  }
  return out;
}

std::string Interval::why_not(double v) const {
  constexpr double inf = std::numeric_limits<double>::infinity();
  if (contains(v)) return {};
  if (!std::isfinite(v)) return "must be a finite number";
  const bool lo_bad = lo_open ? !(v > lo) : !(v >= lo);
  const bool hi_bad = hi_open ? !(v < hi) : !(v <= hi);
  if (!lo_bad && !hi_bad) return "must be a whole number";
  if (hi == inf) return std::string(lo_open ? "must be > " : "must be >= ") + num(lo);
  if (lo == -inf) return std::string(hi_open ? "must be < " : "must be <= ") + num(hi);
  return "must be in " + std::string(lo_open ? "(" : "[") + num(lo) + ", " + num(hi) +
         (hi_open ? ")" : "]");
}

double ModelInputs::operator[](std::string_view name) const {
  for (std::size_t i = 0; i < defs_.size(); ++i)
    if (name == defs_[i].name) return values_[i];
  throw std::logic_error("model reads parameter '" + std::string(name) +
                         "', which is not in its traits table");
}

int ModelInputs::option(std::string_view name) const {
  for (std::size_t i = 0; i < option_defs_.size(); ++i)
    if (name == option_defs_[i].name) return options_[i];
  throw std::logic_error("model reads option '" + std::string(name) +
                         "', which is not in its traits table");
}

}  // namespace stickslip::engine
