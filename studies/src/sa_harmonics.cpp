// Harmonic power of a periodic sample (see sa_harmonics.h).
#include "sa_harmonics.h"

#include <cmath>
#include <numbers>

namespace stickslip::studies::sensitivity::detail {

Roots::Roots(std::size_t n) : cos_(n), sin_(n) {
  for (std::size_t t = 0; t < n; ++t) {
    const double a = 2.0 * std::numbers::pi * static_cast<double>(t) / static_cast<double>(n);
    cos_[t] = std::cos(a);
    sin_[t] = std::sin(a);
  }
}

double Roots::power(const std::vector<double>& z, double mean, std::size_t f) const {
  const std::size_t n = cos_.size();
  const std::size_t step = f % n;
  double re = 0.0, im = 0.0;
  std::size_t t = 0;  // f k mod n, advanced without overflow
  for (std::size_t k = 0; k < n; ++k) {
    const double v = z[k] - mean;
    re += v * cos_[t];
    im -= v * sin_[t];
    t += step;
    if (t >= n) t -= n;
  }
  const auto nn = static_cast<double>(n);
  return (re * re + im * im) / (nn * nn);
}

}  // namespace stickslip::studies::sensitivity::detail
