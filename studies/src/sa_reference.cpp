// Exact indices of the analytic test functions (see sa_reference.h for the formulas).
#include "stickslip/studies/sa_reference.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include <boost/math/distributions/normal.hpp>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <boost/math/tools/minima.hpp>

#include "stickslip/studies/sensitivity.h"

namespace stickslip::studies::sensitivity {
namespace {

constexpr double kPi = std::numbers::pi;

double std_normal_cdf(double z) { return 0.5 * std::erfc(-z / std::numbers::sqrt2); }

/// Total-variation distance between N(m1, s1^2) and N(m2, s2^2): the probability difference on the
/// interval between the two points where the densities cross (one point when s1 == s2).
double normal_tv(double m1, double s1, double m2, double s2) {
  if (s1 == s2) return 2.0 * std_normal_cdf(std::abs(m1 - m2) / (2.0 * s1)) - 1.0;
  const double a = 1.0 / (s2 * s2) - 1.0 / (s1 * s1);
  const double b = 2.0 * (m1 / (s1 * s1) - m2 / (s2 * s2));
  const double c = m2 * m2 / (s2 * s2) - m1 * m1 / (s1 * s1) + 2.0 * std::log(s2 / s1);
  const double root = std::sqrt(std::max(0.0, b * b - 4.0 * a * c));
  double y1 = (-b - root) / (2.0 * a), y2 = (-b + root) / (2.0 * a);
  if (y1 > y2) std::swap(y1, y2);
  const double p1 = std_normal_cdf((y2 - m1) / s1) - std_normal_cdf((y1 - m1) / s1);
  const double p2 = std_normal_cdf((y2 - m2) / s2) - std_normal_cdf((y1 - m2) / s2);
  return std::abs(p1 - p2);
}

void check_linear(const std::vector<double>& a, const std::vector<double>& sigma, const char* f) {
  if (a.empty() || a.size() != sigma.size())
    throw std::invalid_argument(std::string(f) + ": a and sigma must have the same size > 0, got " +
                                std::to_string(a.size()) + " and " + std::to_string(sigma.size()));
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!(sigma[i] > 0.0))
      throw std::invalid_argument(std::string(f) + ": sigma[" + std::to_string(i) +
                                  "] must be > 0, got " + std::to_string(sigma[i]));
}

double linear_variance(const std::vector<double>& a, const std::vector<double>& sigma) {
  double v = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) v += a[i] * a[i] * sigma[i] * sigma[i];
  return v;
}

using Quadrature = boost::math::quadrature::gauss_kronrod<double, 61>;

}  // namespace

std::array<double, 3> ishigami_second_order_exact(double a, double b) {
  const double v = ishigami_exact(a, b).variance;
  const double pi8 = std::pow(kPi, 8);
  return {0.0, b * b * pi8 * (1.0 / 18.0 - 1.0 / 50.0) / v, 0.0};
}

std::array<double, 3> ishigami_dgsm_exact(double a, double b) {
  const double pi4 = std::pow(kPi, 4);
  return {0.5 * (1.0 + 2.0 * b * pi4 / 5.0 + b * b * pi4 * pi4 / 9.0), 0.5 * a * a,
          8.0 * b * b * std::pow(kPi, 6) / 7.0};
}

std::vector<double> sobol_g_second_order_exact(const std::vector<double>& a) {
  const SobolIndices first = sobol_g_exact(a);  // validates a
  std::vector<double> s2;
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = i + 1; j < a.size(); ++j)
      s2.push_back(first.S1[i] * first.S1[j] * first.variance);  // V_i V_j / V
  return s2;
}

std::vector<double> linear_gaussian_delta_exact(const std::vector<double>& a,
                                                const std::vector<double>& sigma) {
  check_linear(a, sigma, "linear_gaussian_delta_exact");
  const double v = linear_variance(a, sigma);
  std::vector<double> delta;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double rest = v - a[i] * a[i] * sigma[i] * sigma[i];
    if (a[i] == 0.0) {
      delta.push_back(0.0);
    } else if (!(rest > 0.0)) {
      delta.push_back(1.0);  // y is a function of x_i alone: the conditional is a point mass
    } else {
      const double s = std::sqrt(v), r = std::sqrt(rest), scale = a[i] * sigma[i];
      auto integrand = [&](double z) {
        return normal_tv(0.0, s, scale * z, r) * std::exp(-0.5 * z * z) / std::sqrt(2.0 * kPi);
      };
      const double inf = std::numeric_limits<double>::infinity();
      delta.push_back(Quadrature::integrate(integrand, -inf, inf, 15, 1e-12));
    }
  }
  return delta;
}

PawnExact linear_gaussian_pawn_exact(const std::vector<double>& a, const std::vector<double>& sigma,
                                     std::size_t intervals) {
  check_linear(a, sigma, "linear_gaussian_pawn_exact");
  if (intervals < 2)
    throw std::invalid_argument("linear_gaussian_pawn_exact: intervals must be >= 2, got " +
                                std::to_string(intervals));
  const double v = linear_variance(a, sigma), s = std::sqrt(v);
  const boost::math::normal unit;
  const auto count = static_cast<double>(intervals);
  PawnExact out;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double r = std::sqrt(std::max(0.0, v - a[i] * a[i] * sigma[i] * sigma[i]));
    if (!(r > 0.0))
      throw std::invalid_argument("linear_gaussian_pawn_exact: input " + std::to_string(i) +
                                  " explains all of the variance (the conditional CDF is a step)");
    std::vector<double> ks;
    for (std::size_t c = 0; c < intervals; ++c) {
      // F_c(y) = P(Y <= y | X_i / sigma_i in (q_c, q_c+1)) with q_c the c / S standard normal
      // quantile: integral of Phi((y - a sigma z) / r) phi(z) dz over the interval, times S.
      const double inf = std::numeric_limits<double>::infinity();
      const double z0 = c == 0 ? -inf : boost::math::quantile(unit, static_cast<double>(c) / count);
      const double z1 = c + 1 == intervals
                            ? inf
                            : boost::math::quantile(unit, static_cast<double>(c + 1) / count);
      auto conditional_cdf = [&](double y) {
        auto f = [&](double z) {
          return std_normal_cdf((y - a[i] * sigma[i] * z) / r) * std::exp(-0.5 * z * z) /
                 std::sqrt(2.0 * kPi);
        };
        return count * Quadrature::integrate(f, z0, z1, 15, 1e-11);
      };
      auto gap = [&](double y) { return -std::abs(conditional_cdf(y) - std_normal_cdf(y / s)); };
      constexpr int kScan = 160;
      double best_y = 0.0, best = 0.0;
      for (int k = 0; k <= kScan; ++k) {
        const double y = s * (-6.0 + 12.0 * k / kScan);
        if (const double g = gap(y); g < best) best = g, best_y = y;
      }
      const double step = 12.0 * s / kScan;
      const auto [y_min, g_min] =
          boost::math::tools::brent_find_minima(gap, best_y - step, best_y + step, 40);
      (void)y_min;
      ks.push_back(-std::min(g_min, best));
    }
    std::sort(ks.begin(), ks.end());
    const std::size_t m = ks.size() / 2;
    out.median.push_back(ks.size() % 2 == 1 ? ks[m] : 0.5 * (ks[m - 1] + ks[m]));
    out.max.push_back(ks.back());
  }
  return out;
}

}  // namespace stickslip::studies::sensitivity
