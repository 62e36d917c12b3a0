#pragma once
// Power of a few harmonics of a periodic sample (internal to the FAST estimators; see sa_fast.h
// for why no FFT is used).
#include <cstddef>
#include <vector>

namespace stickslip::studies::sensitivity::detail {

/// cos and sin of 2 pi t / n for t < n.
class Roots {
 public:
  explicit Roots(std::size_t n);
  std::size_t size() const noexcept { return cos_.size(); }
  /// |sum_k z_k exp(-2 pi i f k / n)|^2 / n^2 for a sample z of size n (its mean removed first).
  double power(const std::vector<double>& z, double mean, std::size_t f) const;

 private:
  std::vector<double> cos_, sin_;
};

}  // namespace stickslip::studies::sensitivity::detail
