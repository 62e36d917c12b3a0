// Sensitivity analysis: scrambled Sobol points, Saltelli and Morris designs, the Morris estimator
// with bootstrap percentile intervals, and the Ishigami / Sobol G test functions. See
// sensitivity.h for the references (Morris 1991, Campolongo 2007); the Sobol estimators are in
// sa_sobol.cpp. Everything here is dimensionless: designs live on [0,1]^d.
#include "stickslip/studies/sensitivity.h"

#include "sa_bootstrap.h"
#include "stickslip/studies/sa_sobol.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <boost/random/sobol.hpp>

namespace stickslip::studies::sensitivity {
namespace {

using detail::invalid;
using detail::require_finite;
using detail::require_positive;
using detail::Rng;
using detail::uniform_index;

/// Fisher-Yates shuffle of 0..d-1.
std::vector<std::size_t> random_permutation(Rng& rng, std::size_t d) {
  std::vector<std::size_t> perm(d);
  for (std::size_t i = 0; i < d; ++i) perm[i] = i;
  for (std::size_t i = d; i > 1; --i) std::swap(perm[i - 1], perm[uniform_index(rng, 0, i - 1)]);
  return perm;
}

// ---------------------------------------------------------------------------------------------
// Scrambled Sobol points
// ---------------------------------------------------------------------------------------------

// 32-bit Sobol engine: 2^32 - 1 points per dimension are far more than any study evaluates,
// and 32 bits of each coordinate fit exactly in a double.
using Sobol32 = boost::random::sobol_engine<std::uint32_t, 32u,
                                            boost::random::default_sobol_table>;
constexpr std::size_t kSobolMaxDimension = boost::random::default_sobol_table::max_dimension;
constexpr double kTwoPowMinus32 = 1.0 / 4294967296.0;  // 2^-32, grid spacing of the 32-bit words

/// Maps a (shifted) 32-bit Sobol word to the centre of its 2^-32 cell, i.e. strictly inside
/// (0,1): the smallest value is 2^-33 and the largest 1 - 2^-33 (both exact doubles).
double word_to_unit(std::uint32_t word) {
  return (static_cast<double>(word) + 0.5) * kTwoPowMinus32;
}

}  // namespace

// Scrambling is hand-written because Boost.Random (1.74) only provides the plain Sobol sequence:
// no Owen or digital-shift scrambling. We use a random digital shift (XOR of each coordinate's
// 32-bit integer representation with one random 32-bit word per dimension, drawn from
// std::mt19937_64 seeded with `seed`). A digital shift keeps the (t,m,s)-net structure of the
// sequence and makes every point marginally uniform on the 2^-32 grid, so independent seeds give
// independent, unbiased randomised-QMC replicates.
//
// First point: Boost's engine skips the all-zero point of the sequence (its first output is
// point number 1). We put that point back as row 0, because after the shift it is an ordinary
// point (it becomes the shift vector itself) and keeping it makes the first 2^m rows a complete
// (t,m,d)-net: in each coordinate, n = 2^m points hit every interval [k/n, (k+1)/n) exactly once.
Matrix sobol_points(std::size_t n, std::size_t d, std::uint64_t seed) {
  require_positive("n", n, "sobol_points");
  require_positive("d", d, "sobol_points");
  if (d > kSobolMaxDimension)
    invalid("sobol_points: d must be <= " + std::to_string(kSobolMaxDimension) + ", got " +
            std::to_string(d));
  if (n > (std::size_t{1} << 32))
    invalid("sobol_points: n must be <= 2^32, got " + std::to_string(n));

  Rng rng(seed);
  std::vector<std::uint32_t> shift(d);
  for (auto& s : shift) s = static_cast<std::uint32_t>(rng() >> 32);  // high bits of the word

  Matrix points(n, std::vector<double>(d));
  for (std::size_t j = 0; j < d; ++j) points[0][j] = word_to_unit(shift[j]);  // the zero point
  Sobol32 engine(d);
  for (std::size_t k = 1; k < n; ++k)
    for (std::size_t j = 0; j < d; ++j) points[k][j] = word_to_unit(engine() ^ shift[j]);
  return points;
}

Matrix saltelli_design(std::size_t n, std::size_t d, std::uint64_t seed) {
  SaltelliShape shape;
  shape.n = n;
  shape.d = d;
  return saltelli_rows(shape, seed);  // block layout, first order
}

// Morris (1991) trajectories. Each input i gets a base level x*_i from the lower half of the
// p-level grid {0, 1/(p-1), ..., 1} (so that x*_i + delta <= 1) and a random direction; it starts
// at x*_i (direction +) or x*_i + delta (direction -) and moves once, in random order, to the
// other end. Values are formed as level / (p - 1) so they are exact grid points; consecutive rows
// therefore differ by delta up to one rounding of the division.
Matrix morris_design(std::size_t r, std::size_t d, std::size_t levels, std::uint64_t seed) {
  require_positive("r", r, "morris_design");
  require_positive("d", d, "morris_design");
  if (levels < 2 || levels % 2 != 0)
    invalid("morris_design: levels must be even and >= 2, got " + std::to_string(levels));

  const std::size_t half = levels / 2;  // delta expressed in grid steps: delta = half / (p - 1)
  const double step = 1.0 / static_cast<double>(levels - 1);
  Rng rng(seed);
  Matrix design;
  design.reserve(r * (d + 1));
  for (std::size_t t = 0; t < r; ++t) {
    std::vector<std::size_t> start(d), end(d);  // grid levels before / after the move
    for (std::size_t i = 0; i < d; ++i) {
      const std::size_t base = uniform_index(rng, 0, half - 1);
      const bool up = uniform_index(rng, 0, 1) == 1;
      start[i] = up ? base : base + half;
      end[i] = up ? base + half : base;
    }
    const auto order = random_permutation(rng, d);
    std::vector<std::size_t> current = start;
    auto emit = [&] {
      std::vector<double> row(d);
      for (std::size_t i = 0; i < d; ++i) row[i] = static_cast<double>(current[i]) * step;
      design.push_back(std::move(row));
    };
    emit();
    for (const std::size_t i : order) {
      current[i] = end[i];
      emit();
    }
  }
  return design;
}

// ---------------------------------------------------------------------------------------------
// Morris indices
// ---------------------------------------------------------------------------------------------
namespace {

/// Elementary effects ee[i][t] of input i in trajectory t. The moved coordinate and the signed
/// step (+delta or -delta) are read from x itself, so rounding of the grid values cancels.
std::vector<std::vector<double>> elementary_effects(const Matrix& x, const std::vector<double>& y,
                                                    std::size_t r, std::size_t d) {
  std::vector<std::vector<double>> ee(d, std::vector<double>(r));
  for (std::size_t t = 0; t < r; ++t) {
    std::vector<bool> seen(d, false);
    for (std::size_t s = 0; s < d; ++s) {
      const std::size_t before = t * (d + 1) + s, after = before + 1;
      std::size_t moved = d;
      for (std::size_t i = 0; i < d; ++i) {
        if (x[after][i] == x[before][i]) continue;
        if (moved != d)
          invalid("morris_indices: rows " + std::to_string(before) + " and " +
                  std::to_string(after) + " differ in more than one coordinate");
        moved = i;
      }
      if (moved == d || seen[moved])
        invalid("morris_indices: trajectory " + std::to_string(t) + " step " +
                std::to_string(s) + " does not move a new input exactly once");
      seen[moved] = true;
      ee[moved][t] = (y[after] - y[before]) / (x[after][moved] - x[before][moved]);
    }
  }
  return ee;
}

double mean_abs(const std::vector<double>& v, const std::vector<std::size_t>& idx) {
  double s = 0.0;
  for (const std::size_t k : idx) s += std::abs(v[k]);
  return s / static_cast<double>(idx.size());
}

}  // namespace

MorrisIndices morris_indices(const Matrix& x, const std::vector<double>& y, std::size_t r,
                             std::size_t d, double confidence, std::size_t resamples,
                             std::uint64_t seed) {
  require_positive("r", r, "morris_indices");
  require_positive("d", d, "morris_indices");
  detail::require_bootstrap({confidence, resamples, seed, false}, "morris_indices");
  const std::size_t rows = r * (d + 1);
  if (x.size() != rows)
    invalid("morris_indices: x.size() must be r * (d + 1) = " + std::to_string(rows) +
            ", got " + std::to_string(x.size()));
  if (y.size() != rows)
    invalid("morris_indices: y.size() must be r * (d + 1) = " + std::to_string(rows) +
            ", got " + std::to_string(y.size()));
  for (std::size_t k = 0; k < rows; ++k)
    if (x[k].size() != d)
      invalid("morris_indices: x[" + std::to_string(k) + "].size() must be d = " +
              std::to_string(d) + ", got " + std::to_string(x[k].size()));
  require_finite(y, "morris_indices");

  const auto ee = elementary_effects(x, y, r, d);
  std::vector<std::size_t> idx(r);
  for (std::size_t t = 0; t < r; ++t) idx[t] = t;

  MorrisIndices out;
  out.mu.assign(d, 0.0);
  out.mu_star.assign(d, 0.0);
  out.sigma.assign(d, 0.0);
  out.mu_star_ci.assign(d, Interval{});
  const auto rd = static_cast<double>(r);
  for (std::size_t i = 0; i < d; ++i) {
    double s = 0.0;
    for (const double e : ee[i]) s += e;
    out.mu[i] = s / rd;
    out.mu_star[i] = mean_abs(ee[i], idx);
    double ss = 0.0;
    for (const double e : ee[i]) ss += (e - out.mu[i]) * (e - out.mu[i]);
    // Sample standard deviation (n - 1); not estimable from a single trajectory.
    out.sigma[i] = r > 1 ? std::sqrt(ss / (rd - 1.0)) : std::numeric_limits<double>::quiet_NaN();
  }

  // Bootstrap mu* over whole trajectories (the same trajectories for every input).
  Rng rng(seed);
  std::vector<std::vector<double>> rep(d, std::vector<double>(resamples));
  for (std::size_t b = 0; b < resamples; ++b) {
    for (auto& t : idx) t = uniform_index(rng, 0, r - 1);
    for (std::size_t i = 0; i < d; ++i) rep[i][b] = mean_abs(ee[i], idx);
  }
  for (std::size_t i = 0; i < d; ++i)
    out.mu_star_ci[i] = detail::percentile_interval(rep[i], confidence);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Analytic test functions
// ---------------------------------------------------------------------------------------------

double ishigami(const std::vector<double>& x, double a, double b) {
  if (x.size() != 3)
    invalid("ishigami: x.size() must be 3, got " + std::to_string(x.size()));
  const double s2 = std::sin(x[1]);
  const double x3_2 = x[2] * x[2];
  return std::sin(x[0]) * (1.0 + b * x3_2 * x3_2) + a * s2 * s2;
}

// Partial variances of the Ishigami function for x_i ~ U(-pi, pi) (Sobol & Levitan 1999):
//   V1 = (1 + b pi^4 / 5)^2 / 2,  V2 = a^2 / 8,  V3 = 0,  V13 = b^2 pi^8 (1/18 - 1/50),
//   V  = a^2 / 8 + b pi^4 / 5 + b^2 pi^8 / 18 + 1/2.
SobolIndices ishigami_exact(double a, double b) {
  const double pi4 = std::pow(std::numbers::pi, 4);
  const double pi8 = pi4 * pi4;
  const double v = a * a / 8.0 + b * pi4 / 5.0 + b * b * pi8 / 18.0 + 0.5;
  const double v1 = 0.5 * (1.0 + b * pi4 / 5.0) * (1.0 + b * pi4 / 5.0);
  const double v2 = a * a / 8.0;
  const double v13 = b * b * pi8 * (1.0 / 18.0 - 1.0 / 50.0);

  SobolIndices out;
  out.variance = v;
  out.S1 = {v1 / v, v2 / v, 0.0};
  out.ST = {(v1 + v13) / v, v2 / v, v13 / v};
  for (std::size_t i = 0; i < 3; ++i) {
    out.S1_ci.push_back({out.S1[i], out.S1[i]});  // exact: zero-width intervals
    out.ST_ci.push_back({out.ST[i], out.ST[i]});
  }
  return out;
}

double sobol_g(const std::vector<double>& x, const std::vector<double>& a) {
  if (x.size() != a.size())
    invalid("sobol_g: x.size() must equal a.size() = " + std::to_string(a.size()) + ", got " +
            std::to_string(x.size()));
  double g = 1.0;
  for (std::size_t i = 0; i < x.size(); ++i) g *= (std::abs(4.0 * x[i] - 2.0) + a[i]) / (1.0 + a[i]);
  return g;
}

// Sobol G on U(0,1)^d: V_i = 1 / (3 (1 + a_i)^2), V = prod (1 + V_i) - 1,
// S1_i = V_i / V, ST_i = V_i prod_{j != i} (1 + V_j) / V.
SobolIndices sobol_g_exact(const std::vector<double>& a) {
  if (a.empty()) invalid("sobol_g_exact: a.size() must be > 0, got 0");
  for (std::size_t i = 0; i < a.size(); ++i)
    if (!(a[i] >= 0.0))
      invalid("sobol_g_exact: a[" + std::to_string(i) + "] must be >= 0, got " +
              std::to_string(a[i]));
  const std::size_t d = a.size();
  std::vector<double> vi(d);
  double prod = 1.0;
  for (std::size_t i = 0; i < d; ++i) {
    vi[i] = 1.0 / (3.0 * (1.0 + a[i]) * (1.0 + a[i]));
    prod *= 1.0 + vi[i];
  }
  const double v = prod - 1.0;

  SobolIndices out;
  out.variance = v;
  for (std::size_t i = 0; i < d; ++i) {
    double others = 1.0;
    for (std::size_t j = 0; j < d; ++j)
      if (j != i) others *= 1.0 + vi[j];
    out.S1.push_back(vi[i] / v);
    out.ST.push_back(vi[i] * others / v);
    out.S1_ci.push_back({out.S1.back(), out.S1.back()});
    out.ST_ci.push_back({out.ST.back(), out.ST.back()});
  }
  return out;
}

}  // namespace stickslip::studies::sensitivity
