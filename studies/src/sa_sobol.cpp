// Sobol indices S1, ST, S2 from Saltelli designs in either layout, and their convergence over
// nested prefixes (see sa_sobol.h for the design, the estimators and the references).
#include "stickslip/studies/sa_sobol.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include <boost/random/sobol.hpp>

#include "sa_bootstrap.h"

namespace stickslip::studies::sensitivity {

using detail::invalid;

std::size_t SaltelliShape::run(std::size_t j, std::size_t b) const noexcept {
  return layout == SaltelliLayout::kBlocks ? b * n + j : j * blocks() + b;
}

Matrix saltelli_rows(const SaltelliShape& s, std::uint64_t seed) {
  detail::require_positive("n", s.n, "saltelli_rows");
  detail::require_positive("d", s.d, "saltelli_rows");
  constexpr std::size_t kMaxDim = boost::random::default_sobol_table::max_dimension;
  if (2 * s.d > kMaxDim)
    invalid("saltelli_rows: d must be <= " + std::to_string(kMaxDim / 2) + ", got " +
            std::to_string(s.d));
  const Matrix base = sobol_points(s.n, 2 * s.d, seed);
  const auto d = static_cast<std::ptrdiff_t>(s.d);
  Matrix out(s.runs());
  for (std::size_t j = 0; j < s.n; ++j) {
    const std::vector<double> a(base[j].begin(), base[j].begin() + d);
    const std::vector<double> b(base[j].begin() + d, base[j].end());
    out[s.run(j, 0)] = a;
    out[s.run(j, 1)] = b;
    for (std::size_t i = 0; i < s.d; ++i) {
      auto& ab = out[s.run(j, 2 + i)];
      ab = a;
      ab[i] = b[i];
      if (!s.second_order) continue;
      auto& ba = out[s.run(j, 2 + s.d + i)];
      ba = b;
      ba[i] = a[i];
    }
  }
  return out;
}

namespace {

/// Per-base-row terms of the estimators, so a bootstrap replicate only sums resampled rows.
struct Terms {
  std::size_t d = 0;
  std::vector<double> za, zb;                      ///< f(A) - c, f(B) - c
  std::vector<std::vector<double>> first, total;   ///< [i][j]
  std::vector<std::array<std::size_t, 2>> pairs;   ///< second order: (i, k), i < k
  std::vector<std::vector<double>> closed;         ///< [p][j] (f(BA_i)-c)(f(AB_k)-c) - za zb
};

Terms make_terms(const std::vector<double>& y, const SaltelliShape& s, std::size_t n) {
  Terms t;
  t.d = s.d;
  // The centre sums f(A) then f(B) in row order, like sobol_indices, so that both give the same
  // numbers bit for bit on a first-order design in the block layout.
  double sum = 0.0;
  for (std::size_t j = 0; j < n; ++j) sum += y[s.run(j, 0)];
  for (std::size_t j = 0; j < n; ++j) sum += y[s.run(j, 1)];
  const double c = sum / static_cast<double>(2 * n);
  t.za.resize(n);
  t.zb.resize(n);
  t.first.assign(s.d, std::vector<double>(n));
  t.total.assign(s.d, std::vector<double>(n));
  if (s.second_order)
    for (std::size_t i = 0; i < s.d; ++i)
      for (std::size_t k = i + 1; k < s.d; ++k) t.pairs.push_back({i, k});
  t.closed.assign(t.pairs.size(), std::vector<double>(n));
  for (std::size_t j = 0; j < n; ++j) {
    const double fa = y[s.run(j, 0)], fb = y[s.run(j, 1)];
    t.za[j] = fa - c;
    t.zb[j] = fb - c;
    for (std::size_t i = 0; i < s.d; ++i) {
      const double fab = y[s.run(j, 2 + i)];
      t.first[i][j] = (fb - c) * (fab - fa);
      t.total[i][j] = (fa - fab) * (fa - fab);
    }
    for (std::size_t p = 0; p < t.pairs.size(); ++p) {
      const auto [i, k] = t.pairs[p];
      t.closed[p][j] = (y[s.run(j, 2 + s.d + i)] - c) * (y[s.run(j, 2 + k)] - c) - t.za[j] * t.zb[j];
    }
  }
  return t;
}

/// out = [S1 (d), ST (d), S2 (pairs), V] over the rows listed.
void estimate(const Terms& t, const std::vector<std::size_t>& rows, std::vector<double>& out) {
  const auto m = static_cast<double>(rows.size());
  double s = 0.0, s2 = 0.0;
  for (const std::size_t j : rows) {
    s += t.za[j] + t.zb[j];
    s2 += t.za[j] * t.za[j] + t.zb[j] * t.zb[j];
  }
  const double mean = s / (2.0 * m);
  const double variance = std::max(0.0, s2 / (2.0 * m) - mean * mean);
  const std::size_t d = t.d, pairs = t.pairs.size();
  out[2 * d + pairs] = variance;
  if (!(variance > 0.0)) {  // a resample without variation: no index (left out of intervals)
    std::fill(out.begin(), out.end() - 1, std::numeric_limits<double>::quiet_NaN());
    return;
  }
  for (std::size_t i = 0; i < d; ++i) {
    double v1 = 0.0, vt = 0.0;
    for (const std::size_t j : rows) {
      v1 += t.first[i][j];
      vt += t.total[i][j];
    }
    out[i] = (v1 / m) / variance;
    out[d + i] = (vt / (2.0 * m)) / variance;
  }
  for (std::size_t p = 0; p < pairs; ++p) {
    double vc = 0.0;
    for (const std::size_t j : rows) vc += t.closed[p][j];
    out[2 * d + p] = (vc / m) / variance - out[t.pairs[p][0]] - out[t.pairs[p][1]];
  }
}

}  // namespace

MethodIndices sobol_analysis(const std::vector<double>& y, const SaltelliShape& shape,
                             const BootstrapOptions& opt, std::size_t n_used) {
  detail::require_positive("n", shape.n, "sobol_analysis");
  detail::require_positive("d", shape.d, "sobol_analysis");
  detail::require_bootstrap(opt, "sobol_analysis");
  if (y.size() != shape.runs())
    invalid("sobol_analysis: y has " + std::to_string(y.size()) + " values, the design has " +
            std::to_string(shape.runs()) + " runs");
  if (n_used > shape.n)
    invalid("sobol_analysis: n_used must be <= n = " + std::to_string(shape.n) + ", got " +
            std::to_string(n_used));
  detail::require_finite(y, "sobol_analysis");
  const std::size_t n = n_used == 0 ? shape.n : n_used;

  MethodIndices out;
  std::vector<double> used;
  used.reserve(n * shape.blocks());
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t b = 0; b < shape.blocks(); ++b) used.push_back(y[shape.run(j, b)]);
  if (detail::constant_output(used, "sobol", n, &out)) return out;
  const Terms t = make_terms(y, shape, n);
  const std::size_t d = shape.d, pairs = t.pairs.size(), values = 2 * d + pairs + 1;
  const detail::Statistic stat = [&t](const std::vector<std::size_t>& rows,
                                      std::vector<double>& o) { estimate(t, rows, o); };
  std::vector<double> point(values);
  stat(detail::identity_rows(n), point);
  out.method = "sobol";
  out.units = n;
  out.variance = point.back();
  if (!(point.back() > 0.0)) {
    out.defined = false;
    out.reason = "f(A) and f(B) take one value at all " + std::to_string(2 * n) +
                 " points (only the mixed AB/BA rows vary): the variance the indices divide by "
                 "is 0, so every index is undefined";
    return out;
  }
  auto reps = detail::bootstrap(n, values, opt, stat);
  out.per_parameter.push_back(detail::make_index("S1", point, reps, 0, d, opt));
  out.per_parameter.push_back(detail::make_index("ST", point, reps, d, d, opt));
  if (shape.second_order) {
    out.pairs = t.pairs;
    out.per_pair.push_back(detail::make_index("S2", point, reps, 2 * d, pairs, opt));
  }
  return out;
}

std::vector<std::size_t> convergence_sizes(std::size_t n, std::size_t n_min) {
  std::vector<std::size_t> sizes;
  std::size_t p = 1;
  while (p < std::max<std::size_t>(n_min, 1)) p *= 2;
  for (; p <= n; p *= 2) sizes.push_back(p);
  if (n >= n_min && (sizes.empty() || sizes.back() != n)) sizes.push_back(n);
  return sizes;
}

std::vector<ConvergenceStep> sobol_convergence(const std::vector<double>& y,
                                               const SaltelliShape& shape,
                                               const BootstrapOptions& opt, std::size_t n_min) {
  std::vector<ConvergenceStep> steps;
  for (const std::size_t n : convergence_sizes(shape.n, n_min))
    steps.push_back({n, sobol_analysis(y, shape, opt, n)});
  return steps;
}

}  // namespace stickslip::studies::sensitivity
