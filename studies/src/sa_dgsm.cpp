// DGSM design and estimator (see sa_dgsm.h for the formulas and the references).
#include "stickslip/studies/sa_dgsm.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "sa_bootstrap.h"

namespace stickslip::studies::sensitivity {

using detail::invalid;

double unit_uniform_poincare() { return 1.0 / (std::numbers::pi * std::numbers::pi); }

Matrix dgsm_design(std::size_t n, std::size_t d, double step, std::uint64_t seed) {
  detail::require_positive("n", n, "dgsm_design");
  detail::require_positive("d", d, "dgsm_design");
  if (!(step > 0.0 && step <= 0.5))
    invalid("dgsm_design: step must be in (0, 0.5], got " + std::to_string(step));
  const Matrix base = sobol_points(n, d, seed);
  Matrix out;
  out.reserve(n * (d + 1));
  for (const auto& x : base) {
    out.push_back(x);
    for (std::size_t i = 0; i < d; ++i) {
      std::vector<double> moved = x;
      moved[i] = x[i] + step <= 1.0 ? x[i] + step : x[i] - step;
      out.push_back(std::move(moved));
    }
  }
  return out;
}

namespace {

/// Squared difference quotients g[i][j] of base point j along input i, checking the layout.
std::vector<std::vector<double>> squared_slopes(const Matrix& x, const std::vector<double>& y,
                                                std::size_t n, std::size_t d) {
  std::vector<std::vector<double>> g(d, std::vector<double>(n));
  for (std::size_t j = 0; j < n; ++j) {
    const std::size_t base = j * (d + 1);
    for (std::size_t i = 0; i < d; ++i) {
      const std::size_t row = base + 1 + i;
      for (std::size_t k = 0; k < d; ++k) {
        const bool moved = x[row][k] != x[base][k];
        if (moved != (k == i))
          invalid("dgsm_analysis: row " + std::to_string(row) + " must differ from base row " +
                  std::to_string(base) + " in coordinate " + std::to_string(i) + " only (" +
                  (moved ? "coordinate " + std::to_string(k) + " moves too)" : "it does not move)"));
      }
      const double h = x[row][i] - x[base][i];
      const double slope = (y[row] - y[base]) / h;
      g[i][j] = slope * slope;
    }
  }
  return g;
}

}  // namespace

MethodIndices dgsm_analysis(const Matrix& x, const std::vector<double>& y, std::size_t n,
                            std::size_t d, const std::vector<double>& poincare,
                            const BootstrapOptions& opt) {
  detail::require_positive("n", n, "dgsm_analysis");
  detail::require_positive("d", d, "dgsm_analysis");
  detail::require_bootstrap(opt, "dgsm_analysis");
  detail::require_matrix(x, n * (d + 1), d, "dgsm_analysis");
  if (y.size() != x.size())
    invalid("dgsm_analysis: y has " + std::to_string(y.size()) + " values, x has " +
            std::to_string(x.size()) + " rows");
  if (poincare.size() != d)
    invalid("dgsm_analysis: poincare has " + std::to_string(poincare.size()) +
            " constants, expected d = " + std::to_string(d));
  for (std::size_t i = 0; i < d; ++i)
    if (!(poincare[i] > 0.0 && std::isfinite(poincare[i])))
      invalid("dgsm_analysis: poincare[" + std::to_string(i) + "] must be > 0, got " +
              std::to_string(poincare[i]));
  detail::require_finite(y, "dgsm_analysis");

  const auto g = squared_slopes(x, y, n, d);  // checks the layout first
  MethodIndices out;
  if (detail::constant_output(y, "dgsm", n, &out)) return out;
  std::vector<double> base(n);
  for (std::size_t j = 0; j < n; ++j) base[j] = y[j * (d + 1)];

  // out = [nu (d), dgsm (d), V]
  const detail::Statistic stat = [&](const std::vector<std::size_t>& rows, std::vector<double>& o) {
    const auto m = static_cast<double>(rows.size());
    double s = 0.0, s2 = 0.0;
    for (const std::size_t j : rows) s += base[j];
    const double mean = s / m;
    for (const std::size_t j : rows) s2 += (base[j] - mean) * (base[j] - mean);
    const double v = s2 / m;
    o[2 * d] = v;
    for (std::size_t i = 0; i < d; ++i) {
      double nu = 0.0;
      for (const std::size_t j : rows) nu += g[i][j];
      o[i] = nu / m;
      o[d + i] = v > 0.0 ? poincare[i] * o[i] / v : std::numeric_limits<double>::quiet_NaN();
    }
  };
  std::vector<double> point(2 * d + 1);
  stat(detail::identity_rows(n), point);
  auto reps = detail::bootstrap(n, 2 * d + 1, opt, stat);
  out.method = "dgsm";
  out.units = n;
  out.variance = point[2 * d];
  out.per_parameter.push_back(detail::make_index("nu", point, reps, 0, d, opt));
  out.per_parameter.push_back(detail::make_index("dgsm", point, reps, d, d, opt));
  if (!(out.variance > 0.0))
    out.notes.push_back("f takes one value at every base point: dgsm (nu / V) is undefined");
  return out;
}

}  // namespace stickslip::studies::sensitivity
