#pragma once
// Test helpers of the sensitivity estimator tests: evaluating a function on design rows, the
// Ishigami function on the unit cube, Gaussian inputs from unit-cube points, and a printer of an
// estimate against its exact value (the numbers docs/report.md quotes).
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include <boost/math/distributions/normal.hpp>

#include "stickslip/studies/sa_indices.h"
#include "stickslip/studies/sensitivity.h"

namespace stickslip::testing {

inline std::vector<double> evaluate(const studies::sensitivity::Matrix& rows,
                                    const std::function<double(const std::vector<double>&)>& f) {
  std::vector<double> y;
  y.reserve(rows.size());
  for (const auto& row : rows) y.push_back(f(row));
  return y;
}

/// Ishigami (a = 7, b = 0.1) of a unit-cube row mapped onto [-pi, pi]^3.
inline double ishigami_unit(const std::vector<double>& u) {
  std::vector<double> x(u.size());
  for (std::size_t i = 0; i < u.size(); ++i) x[i] = -std::numbers::pi + 2.0 * std::numbers::pi * u[i];
  return studies::sensitivity::ishigami(x);
}

/// Rows of independent N(0, sigma_i^2) inputs from unit-cube rows (inverse CDF).
inline studies::sensitivity::Matrix gaussian_rows(const studies::sensitivity::Matrix& unit,
                                         const std::vector<double>& sigma) {
  const boost::math::normal n01;
  studies::sensitivity::Matrix x = unit;
  for (auto& row : x)
    for (std::size_t i = 0; i < row.size(); ++i) row[i] = sigma[i] * boost::math::quantile(n01, row[i]);
  return x;
}

/// y = sum a_i x_i.
inline double linear(const std::vector<double>& x, const std::vector<double>& a) {
  double y = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) y += a[i] * x[i];
  return y;
}

inline studies::sensitivity::BootstrapOptions bootstrap(std::size_t resamples, std::uint64_t seed = 1) {
  studies::sensitivity::BootstrapOptions o;
  o.resamples = resamples;
  o.seed = seed;
  return o;
}

/// "x1", "x2", ... for input index i (0-based). (Built by insert: GCC 12 warns falsely about
/// -Wrestrict on "x" + std::to_string(...), PR 105329.)
inline std::string input_name(std::size_t i) {
  std::string s = std::to_string(i + 1);
  s.insert(0, 1, 'x');
  return s;
}

/// Prints "[tag] name: estimate (exact e, error err)" and returns |error|.
inline double report(const std::string& tag, const std::string& name, double estimate,
                     double exact) {
  std::printf("[%s] %s: %.5f (exact %.5f, error %+.5f)\n", tag.c_str(), name.c_str(), estimate,
              exact, estimate - exact);
  return std::abs(estimate - exact);
}

}  // namespace stickslip::testing
