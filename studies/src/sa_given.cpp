// Given-data estimators: RBD-FAST (EASI ordering), Borgonovo's delta and PAWN (see sa_given.h for
// the formulas, the choices and the references).
#include "stickslip/studies/sa_given.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include "sa_bootstrap.h"
#include "sa_harmonics.h"

namespace stickslip::studies::sensitivity {

using detail::invalid;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Ranks of every column of x and of y (ties broken by row index), so that a bootstrap resample
/// is put in the order of any column by a counting sort in O(n).
struct Ranks {
  std::vector<std::vector<std::size_t>> x;  ///< [i][row]
  std::vector<std::size_t> y;               ///< [row]
};

template <class Value>
std::vector<std::size_t> ranks_of(std::size_t n, Value value) {
  std::vector<std::size_t> order(n), rank(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return value(a) < value(b); });
  for (std::size_t r = 0; r < n; ++r) rank[order[r]] = r;
  return rank;
}

Ranks make_ranks(const Matrix& x, const std::vector<double>& y) {
  Ranks r;
  const std::size_t d = x.front().size();
  for (std::size_t i = 0; i < d; ++i)
    r.x.push_back(ranks_of(y.size(), [&](std::size_t k) { return x[k][i]; }));
  r.y = ranks_of(y.size(), [&](std::size_t k) { return y[k]; });
  return r;
}

/// Writes to `out` the elements e of a resample (element e is row rows[e]) in ascending order of
/// key[rows[e]], stable (counting sort; keys are ranks < rows.size()).
void order_elements(const std::vector<std::size_t>& key, const std::vector<std::size_t>& rows,
                    std::vector<std::size_t>& start, std::vector<std::size_t>& out) {
  const std::size_t n = rows.size();
  start.assign(n + 1, 0);
  for (const std::size_t r : rows) ++start[key[r] + 1];
  for (std::size_t k = 0; k < n; ++k) start[k + 1] += start[k];
  out.resize(n);
  for (std::size_t e = 0; e < n; ++e) out[start[key[rows[e]]]++] = e;
}

/// Checks shared by the given-data estimators; returns d.
std::size_t check_given(const Matrix& x, const std::vector<double>& y, std::size_t min_n,
                        const BootstrapOptions& opt, const char* func) {
  detail::require_bootstrap(opt, func);
  if (y.size() < min_n)
    invalid(std::string(func) + ": needs at least " + std::to_string(min_n) + " points, got " +
            std::to_string(y.size()));
  const std::size_t d = x.empty() ? 0 : x.front().size();
  detail::require_positive("d (columns of x)", d, func);
  detail::require_matrix(x, y.size(), d, func);
  detail::require_finite(y, func);
  for (std::size_t k = 0; k < x.size(); ++k)
    for (std::size_t i = 0; i < d; ++i)
      if (!std::isfinite(x[k][i]))
        invalid(std::string(func) + ": x[" + std::to_string(k) + "][" + std::to_string(i) +
                "] is not finite");
  return d;
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 == 1 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

}  // namespace

// --------------------------------------------------------------------------------- RBD-FAST

namespace {

/// S1 of every input for one resample: EASI ordering, M harmonics, Tissot-Prieur correction.
struct RbdFastStatistic {
  const std::vector<double>& y;
  const Ranks& ranks;
  const detail::Roots& roots;
  std::size_t harmonics;
  std::vector<std::size_t> start = {}, ord = {};
  std::vector<double> z = {};

  void operator()(const std::vector<std::size_t>& rows, std::vector<double>& o) {
    const std::size_t n = rows.size(), d = ranks.x.size();
    const double lambda = 2.0 * static_cast<double>(harmonics) / static_cast<double>(n);
    double mean = 0.0, v = 0.0;
    for (const std::size_t r : rows) mean += y[r];
    mean /= static_cast<double>(n);
    for (const std::size_t r : rows) v += (y[r] - mean) * (y[r] - mean);
    v /= static_cast<double>(n);
    z.resize(n);
    for (std::size_t i = 0; i < d; ++i) {
      if (!(v > 0.0)) {
        o[i] = kNaN;
        continue;
      }
      order_elements(ranks.x[i], rows, start, ord);
      // EASI: even positions up, odd positions back down.
      std::size_t k = 0;
      for (std::size_t p = 0; p < n; p += 2) z[k++] = y[rows[ord[p]]];
      for (std::size_t p = (n % 2 == 0 ? n - 1 : n - 2); p < n; p -= 2) z[k++] = y[rows[ord[p]]];
      double d1 = 0.0;
      for (std::size_t f = 1; f <= harmonics; ++f) d1 += 2.0 * roots.power(z, mean, f);
      const double s1 = d1 / v;
      o[i] = s1 - lambda / (1.0 - lambda) * (1.0 - s1);
    }
  }
};

}  // namespace

MethodIndices rbd_fast_analysis(const Matrix& x, const std::vector<double>& y,
                                const BootstrapOptions& opt, std::size_t harmonics) {
  detail::require_positive("harmonics", harmonics, "rbd_fast_analysis");
  const std::size_t d = check_given(x, y, 2 * harmonics + 1, opt, "rbd_fast_analysis");
  MethodIndices out;
  if (detail::constant_output(y, "rbd_fast", y.size(), &out)) return out;
  const std::size_t n = y.size();
  const Ranks ranks = make_ranks(x, y);
  const detail::Roots roots(n);
  const detail::StatisticFactory make = [&] {
    return detail::Statistic(RbdFastStatistic{y, ranks, roots, harmonics});
  };
  std::vector<double> point(d);
  make()(detail::identity_rows(n), point);
  auto reps = detail::bootstrap(n, d, opt, make);
  out.method = "rbd_fast";
  out.units = n;
  out.variance = detail::population_variance(y);
  out.per_parameter.push_back(detail::make_index("S1", point, reps, 0, d, opt));
  return out;
}

// --------------------------------------------------------------------------------- delta

std::size_t delta_classes(std::size_t n) {
  const double nn = static_cast<double>(n);
  const double e = 2.0 / (7.0 + std::tanh((1500.0 - nn) / 500.0));
  return static_cast<std::size_t>(std::min(std::ceil(std::pow(nn, e)), 48.0));
}

namespace {

constexpr std::size_t kGrid = 256;

double silverman(double sd, double m) { return sd * std::pow(0.75 * m, -0.2); }

/// The y grid and each point's linear-binning position on it.
struct DensityGrid {
  double y0 = 0.0, dy = 1.0;
  std::vector<std::size_t> bin;  ///< [row] left grid point
  std::vector<double> frac;      ///< [row] share of the right grid point
};

DensityGrid make_grid(const std::vector<double>& y, std::size_t classes) {
  const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
  const double sd = std::sqrt(detail::population_variance(y));
  const double pad = 4.0 * silverman(sd, std::floor(static_cast<double>(y.size()) / classes));
  DensityGrid g;
  g.y0 = *lo - pad;
  g.dy = (*hi - *lo + 2.0 * pad) / static_cast<double>(kGrid - 1);
  g.bin.resize(y.size());
  g.frac.resize(y.size());
  for (std::size_t k = 0; k < y.size(); ++k) {
    const double t = (y[k] - g.y0) / g.dy;
    const auto b = std::min<std::size_t>(static_cast<std::size_t>(t), kGrid - 2);
    g.bin[k] = b;
    g.frac[k] = t - static_cast<double>(b);
  }
  return g;
}

/// Kernel density on the grid of the points (rows) listed: f[g], g < kGrid.
class BinnedKde {
 public:
  explicit BinnedKde(const DensityGrid& grid) : grid_(grid), mass_(kGrid, 0.0) {}
  template <class Rows>
  void estimate(const std::vector<double>& y, const Rows& rows, std::vector<double>& f) {
    std::size_t lo = kGrid, hi = 0;
    double s = 0.0, s2 = 0.0, m = 0.0;
    for (const std::size_t r : rows) {
      const std::size_t b = grid_.bin[r];
      mass_[b] += 1.0 - grid_.frac[r];
      mass_[b + 1] += grid_.frac[r];
      lo = std::min(lo, b);
      hi = std::max(hi, b + 1);
      s += y[r];
      s2 += y[r] * y[r];
      m += 1.0;
    }
    const double var = m > 1.0 ? std::max(0.0, (s2 - s * s / m) / (m - 1.0)) : 0.0;
    // A class of one repeated value is a point mass: one grid step of width stands in for it.
    const double h = var > 0.0 ? silverman(std::sqrt(var), m) : grid_.dy;
    const double u = grid_.dy / h;
    const auto w = std::min<std::size_t>(kGrid, static_cast<std::size_t>(std::ceil(4.0 / u)));
    // The discrete kernel is normalised to unit mass on the grid, so every point contributes
    // exactly its weight even when h is not much wider than a grid step.
    kernel_.resize(w + 1);
    double total = 0.0;
    for (std::size_t t = 0; t <= w; ++t) {
      const double z = u * static_cast<double>(t);
      kernel_[t] = std::exp(-0.5 * z * z);
      total += (t == 0 ? 1.0 : 2.0) * kernel_[t];
    }
    for (double& k : kernel_) k /= m * grid_.dy * total;
    std::fill(f.begin(), f.end(), 0.0);
    for (std::size_t b = lo; b <= hi; ++b) {
      const double c = mass_[b];
      if (c == 0.0) continue;
      mass_[b] = 0.0;
      const std::size_t g0 = b > w ? b - w : 0, g1 = std::min(kGrid - 1, b + w);
      for (std::size_t g = g0; g <= g1; ++g) f[g] += c * kernel_[g > b ? g - b : b - g];
    }
  }

 private:
  const DensityGrid& grid_;
  std::vector<double> mass_, kernel_;
};

/// Trapezoid integral of |a - b| over the grid.
double l1_distance(const std::vector<double>& a, const std::vector<double>& b, double dy) {
  double s = 0.0;
  for (std::size_t g = 0; g < kGrid; ++g)
    s += (g == 0 || g + 1 == kGrid ? 0.5 : 1.0) * std::abs(a[g] - b[g]);
  return s * dy;
}

}  // namespace

namespace {

/// delta of every input for one resample (before the bias reduction).
struct DeltaStatistic {
  const std::vector<double>& y;
  const Ranks& ranks;
  const DensityGrid& grid;
  std::size_t classes;
  BinnedKde kde;
  std::vector<double> fy = std::vector<double>(kGrid), fc = std::vector<double>(kGrid);
  std::vector<std::size_t> start = {}, ord = {}, members = {};

  void operator()(const std::vector<std::size_t>& rows, std::vector<double>& o) {
    const std::size_t n = rows.size();
    kde.estimate(y, rows, fy);
    for (std::size_t i = 0; i < ranks.x.size(); ++i) {
      order_elements(ranks.x[i], rows, start, ord);
      double delta = 0.0;
      for (std::size_t c = 0; c < classes; ++c) {
        const std::size_t a = c * n / classes, b = (c + 1) * n / classes;
        members.clear();
        for (std::size_t p = a; p < b; ++p) members.push_back(rows[ord[p]]);
        kde.estimate(y, members, fc);
        delta += static_cast<double>(b - a) / (2.0 * static_cast<double>(n)) *
                 l1_distance(fy, fc, grid.dy);
      }
      o[i] = delta;
    }
  }
};

}  // namespace

MethodIndices delta_analysis(const Matrix& x, const std::vector<double>& y,
                             const BootstrapOptions& opt) {
  const std::size_t d = check_given(x, y, 20, opt, "delta_analysis");
  MethodIndices out;
  if (detail::constant_output(y, "delta", y.size(), &out)) return out;
  const std::size_t n = y.size(), classes = delta_classes(n);
  const Ranks ranks = make_ranks(x, y);
  const DensityGrid grid = make_grid(y, classes);
  const detail::StatisticFactory make = [&] {
    return detail::Statistic(DeltaStatistic{y, ranks, grid, classes, BinnedKde(grid)});
  };
  std::vector<double> point(d);
  make()(detail::identity_rows(n), point);
  auto reps = detail::bootstrap(n, d, opt, make);
  // Bias reduction (Plischke et al. 2013): 2 d - mean(d*), and its replicates 2 d - d*.
  for (std::size_t i = 0; i < d; ++i) {
    double mean = 0.0;
    for (double& r : reps[i]) {
      mean += r;
      r = 2.0 * point[i] - r;
    }
    point[i] = 2.0 * point[i] - mean / static_cast<double>(reps[i].size());
  }
  out.method = "delta";
  out.units = n;
  out.variance = detail::population_variance(y);
  out.per_parameter.push_back(detail::make_index("delta", point, reps, 0, d, opt));
  return out;
}

// --------------------------------------------------------------------------------- PAWN

namespace {

/// KS distance between the empirical CDF of a conditioning interval's members (in ascending y,
/// each with the counts of all points below (lower) and up to (upper) its value) and that of all
/// n points.
struct Member {
  double y;
  std::size_t lower, upper;
};

double ks_distance(const std::vector<Member>& m, std::size_t n) {
  const auto nc = static_cast<double>(m.size()), nn = static_cast<double>(n);
  double ks = 0.0;
  for (std::size_t k = 0; k < m.size();) {
    std::size_t end = k + 1;
    while (end < m.size() && m[end].y == m[k].y) ++end;
    // Just below the value: F = lower / n, F_c = k / n_c; at the value: F = upper / n, F_c = end / n_c.
    ks = std::max(ks, static_cast<double>(m[k].lower) / nn - static_cast<double>(k) / nc);
    ks = std::max(ks, static_cast<double>(end) / nc - static_cast<double>(m[k].upper) / nn);
    k = end;
  }
  return ks;
}

/// pawn (median) and pawn_max of every input for one resample.
struct PawnStatistic {
  const std::vector<double>& y;
  const Ranks& ranks;
  std::size_t intervals;
  std::vector<std::size_t> start = {}, by_y = {}, by_x = {}, chunk = {}, lower = {}, upper = {};
  std::vector<std::vector<Member>> lists = {};
  std::vector<double> ks = {};

  void operator()(const std::vector<std::size_t>& rows, std::vector<double>& o) {
    const std::size_t n = rows.size(), d = ranks.x.size();
    chunk.resize(n);
    lower.resize(n);
    upper.resize(n);
    lists.resize(intervals);
    ks.resize(intervals);
    order_elements(ranks.y, rows, start, by_y);
    for (std::size_t k = 0; k < n;) {  // counts below / up to each element's value
      std::size_t end = k + 1;
      while (end < n && y[rows[by_y[end]]] == y[rows[by_y[k]]]) ++end;
      for (std::size_t p = k; p < end; ++p) {
        lower[by_y[p]] = k;
        upper[by_y[p]] = end;
      }
      k = end;
    }
    for (std::size_t i = 0; i < d; ++i) {
      order_elements(ranks.x[i], rows, start, by_x);
      for (std::size_t p = 0; p < n; ++p) chunk[by_x[p]] = p * intervals / n;
      for (auto& l : lists) l.clear();
      for (const std::size_t e : by_y) lists[chunk[e]].push_back({y[rows[e]], lower[e], upper[e]});
      for (std::size_t c = 0; c < intervals; ++c) ks[c] = ks_distance(lists[c], n);
      o[i] = median_of(ks);
      o[d + i] = *std::max_element(ks.begin(), ks.end());
    }
  }
};

}  // namespace

MethodIndices pawn_analysis(const Matrix& x, const std::vector<double>& y,
                            const BootstrapOptions& opt, std::size_t intervals) {
  if (intervals < 2) invalid("pawn_analysis: intervals must be >= 2, got " + std::to_string(intervals));
  const std::size_t d = check_given(x, y, 5 * intervals, opt, "pawn_analysis");
  MethodIndices out;
  if (detail::constant_output(y, "pawn", y.size(), &out)) return out;
  const std::size_t n = y.size();
  const Ranks ranks = make_ranks(x, y);
  const detail::StatisticFactory make = [&] {
    return detail::Statistic(PawnStatistic{y, ranks, intervals});
  };
  std::vector<double> point(2 * d);
  make()(detail::identity_rows(n), point);
  auto reps = detail::bootstrap(n, 2 * d, opt, make);
  out.method = "pawn";
  out.units = n;
  out.variance = detail::population_variance(y);
  out.per_parameter.push_back(detail::make_index("pawn", point, reps, 0, d, opt));
  out.per_parameter.push_back(detail::make_index("pawn_max", point, reps, d, d, opt));
  return out;
}

}  // namespace stickslip::studies::sensitivity
