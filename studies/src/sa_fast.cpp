// eFAST design and estimator, and the RBD design (see sa_fast.h for the formulas and references).
#include "stickslip/studies/sa_fast.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <tuple>
#include <utility>

#include "sa_bootstrap.h"
#include "sa_harmonics.h"
#include "stickslip/common/text.h"

namespace stickslip::studies::sensitivity {

using detail::invalid;

namespace {

constexpr double kPi = std::numbers::pi;

/// The search-curve transform: uniform on [0, 1] when s is uniform.
double curve(double angle) { return 0.5 + std::asin(std::sin(angle)) / kPi; }

/// Uniform double in [0, 1) from the top 53 bits of the generator.
double unit(detail::Rng& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

}  // namespace

bool EfastShape::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors != nullptr) errors->push_back(m);
  };
  if (d == 0) fail("d must be > 0, got 0");
  if (M == 0) fail("M must be > 0, got 0");
  if (replicates == 0) fail("replicates must be > 0, got 0");
  if (n <= 4 * M * M)
    fail("n must be > 4 M^2 = " + std::to_string(4 * M * M) + " (M = " + std::to_string(M) +
         "), got " + std::to_string(n));
  return ok;
}

std::vector<std::size_t> efast_frequencies(const EfastShape& s) {
  if (std::vector<std::string> errors; !s.IsValid(&errors))
    invalid("efast_frequencies: " + common::join(errors, "; "));
  std::vector<std::size_t> omega(s.d);
  omega[0] = (s.n - 1) / (2 * s.M);
  const std::size_t m = omega[0] / (2 * s.M);  // >= 1 since n > 4 M^2
  const std::size_t others = s.d - 1;
  for (std::size_t k = 0; k < others; ++k) {
    if (m >= others) {  // spread over [1, m] as numpy.linspace + floor
      omega[1 + k] = others == 1 ? 1
                                 : static_cast<std::size_t>(std::floor(
                                       1.0 + static_cast<double>(k) * static_cast<double>(m - 1) /
                                                 static_cast<double>(others - 1)));
    } else {
      omega[1 + k] = k % m + 1;
    }
  }
  return omega;
}

Matrix efast_design(const EfastShape& s, std::uint64_t seed) {
  const auto omega = efast_frequencies(s);
  detail::Rng rng(seed);
  Matrix x(s.runs(), std::vector<double>(s.d));
  for (std::size_t r = 0; r < s.replicates; ++r)
    for (std::size_t i = 0; i < s.d; ++i) {
      std::vector<double> w(s.d), phase(s.d);
      for (std::size_t j = 0, other = 1; j < s.d; ++j) {
        w[j] = static_cast<double>(j == i ? omega[0] : omega[other++]);
        phase[j] = 2.0 * kPi * unit(rng);
      }
      for (std::size_t k = 0; k < s.n; ++k) {
        const double sk = 2.0 * kPi * static_cast<double>(k) / static_cast<double>(s.n);
        for (std::size_t j = 0; j < s.d; ++j) x[s.run(r, i, k)][j] = curve(w[j] * sk + phase[j]);
      }
    }
  return x;
}

namespace {

/// S1 and ST of one curve (NaN when y does not vary along it).
std::pair<double, double> curve_indices(const std::vector<double>& z, std::size_t omega,
                                        std::size_t M, const detail::Roots& roots) {
  double mean = 0.0;
  for (double v : z) mean += v;
  mean /= static_cast<double>(z.size());
  double v = 0.0;
  for (double e : z) v += (e - mean) * (e - mean);
  v /= static_cast<double>(z.size());  // = sum of P(f) over f = 1..n-1 (Parseval)
  if (!(v > 0.0)) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan};
  }
  double d1 = 0.0, dt = 0.0;
  for (std::size_t p = 1; p <= M; ++p) d1 += 2.0 * roots.power(z, mean, p * omega);
  for (std::size_t f = 1; f <= omega / 2; ++f) dt += 2.0 * roots.power(z, mean, f);
  return {d1 / v, 1.0 - dt / v};
}

}  // namespace

MethodIndices efast_analysis(const std::vector<double>& y, const EfastShape& s,
                             const BootstrapOptions& opt) {
  if (std::vector<std::string> errors; !s.IsValid(&errors))
    invalid("efast_analysis: " + common::join(errors, "; "));
  detail::require_bootstrap(opt, "efast_analysis");
  if (y.size() != s.runs())
    invalid("efast_analysis: y has " + std::to_string(y.size()) + " values, the design has " +
            std::to_string(s.runs()) + " runs");
  detail::require_finite(y, "efast_analysis");
  MethodIndices out;
  if (detail::constant_output(y, "efast", s.replicates, &out)) return out;
  const std::size_t omega = efast_frequencies(s)[0];
  const detail::Roots roots(s.n);
  // per[r] = [S1 (d), ST (d)] of replicate r
  std::vector<std::vector<double>> per(s.replicates, std::vector<double>(2 * s.d));
  std::vector<double> z(s.n);
  for (std::size_t r = 0; r < s.replicates; ++r)
    for (std::size_t i = 0; i < s.d; ++i) {
      for (std::size_t k = 0; k < s.n; ++k) z[k] = y[s.run(r, i, k)];
      std::tie(per[r][i], per[r][s.d + i]) = curve_indices(z, omega, s.M, roots);
    }
  const detail::Statistic stat = [&](const std::vector<std::size_t>& rows, std::vector<double>& o) {
    std::fill(o.begin(), o.end(), 0.0);
    for (const std::size_t r : rows)
      for (std::size_t v = 0; v < o.size(); ++v) o[v] += per[r][v];
    for (double& v : o) v /= static_cast<double>(rows.size());
  };
  std::vector<double> point(2 * s.d);
  stat(detail::identity_rows(s.replicates), point);
  out.method = "efast";
  out.units = s.replicates;
  out.variance = detail::population_variance(y);
  const bool intervals = s.replicates >= 2;
  auto reps = intervals ? detail::bootstrap(s.replicates, 2 * s.d, opt, stat)
                        : std::vector<std::vector<double>>(2 * s.d);
  out.per_parameter.push_back(detail::make_index("S1", point, reps, 0, s.d, opt));
  out.per_parameter.push_back(detail::make_index("ST", point, reps, s.d, s.d, opt));
  if (!intervals) {
    for (auto& iv : out.per_parameter) {
      iv.ci.clear();
      iv.resamples.clear();
    }
    out.notes.push_back("one replicate: eFAST intervals need replicates >= 2 (they bootstrap "
                        "over independent random-phase replicates)");
  }
  return out;
}

Matrix rbd_design(std::size_t n, std::size_t d, std::uint64_t seed) {
  if (n < 2) invalid("rbd_design: n must be >= 2, got " + std::to_string(n));
  detail::require_positive("d", d, "rbd_design");
  detail::Rng rng(seed);
  Matrix x(n, std::vector<double>(d));
  std::vector<std::size_t> perm(n);
  for (std::size_t j = 0; j < d; ++j) {
    for (std::size_t k = 0; k < n; ++k) perm[k] = k;
    for (std::size_t k = n; k > 1; --k) std::swap(perm[k - 1], perm[detail::uniform_index(rng, 0, k - 1)]);
    for (std::size_t k = 0; k < n; ++k) {
      const double s = -kPi + 2.0 * kPi * (static_cast<double>(perm[k]) + 0.5) / static_cast<double>(n);
      x[k][j] = curve(s);
    }
  }
  return x;
}

}  // namespace stickslip::studies::sensitivity
