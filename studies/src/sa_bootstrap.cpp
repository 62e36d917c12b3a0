// Internal helpers of the sensitivity estimators (see sa_bootstrap.h).
#include "sa_bootstrap.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <stdexcept>

#include "stickslip/common/text.h"

#include <boost/random/uniform_int_distribution.hpp>

namespace stickslip::studies::sensitivity {

bool BootstrapOptions::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors != nullptr) errors->push_back(m);
  };
  if (!(confidence > 0.0 && confidence < 1.0))
    fail("confidence must be in (0, 1), got " + std::to_string(confidence));
  if (resamples == 0) fail("resamples must be > 0, got 0");
  return ok;
}

const IndexValues* MethodIndices::find(const std::string& name) const {
  for (const IndexValues& v : per_parameter)
    if (v.name == name) return &v;
  return nullptr;
}

namespace detail {

std::size_t uniform_index(Rng& rng, std::size_t lo, std::size_t hi) {
  return boost::random::uniform_int_distribution<std::size_t>(lo, hi)(rng);
}

void invalid(const std::string& what) { throw std::invalid_argument(what); }

void require_positive(const char* name, std::size_t value, const char* func) {
  if (value == 0) invalid(std::string(func) + ": " + name + " must be > 0, got 0");
}

void require_finite(const std::vector<double>& y, const char* func) {
  for (std::size_t k = 0; k < y.size(); ++k)
    if (!std::isfinite(y[k]))
      invalid(std::string(func) + ": y[" + std::to_string(k) + "] is not finite (" +
              std::to_string(y[k]) + ")");
}

void require_bootstrap(const BootstrapOptions& opt, const char* func) {
  if (std::vector<std::string> errors; !opt.IsValid(&errors))
    invalid(std::string(func) + ": " + common::join(errors, "; "));
}

void require_matrix(const Matrix& x, std::size_t rows, std::size_t d, const char* func) {
  if (x.size() != rows)
    invalid(std::string(func) + ": x has " + std::to_string(x.size()) + " rows, expected " +
            std::to_string(rows));
  for (std::size_t k = 0; k < rows; ++k)
    if (x[k].size() != d)
      invalid(std::string(func) + ": x[" + std::to_string(k) + "] has " +
              std::to_string(x[k].size()) + " columns, expected d = " + std::to_string(d));
}

bool constant_output(const std::vector<double>& y, const std::string& method, std::size_t units,
                     MethodIndices* out) {
  if (y.empty()) return false;
  const auto [lo, hi] = std::minmax_element(y.begin(), y.end());
  if (*lo != *hi) return false;
  *out = MethodIndices{};
  out->method = method;
  out->defined = false;
  out->units = units;
  out->variance = 0.0;
  char value[32];
  std::snprintf(value, sizeof value, "%.9g", *lo);
  out->reason = "the output is constant (all " + std::to_string(y.size()) +
                " values used are " + value +
                "): there is no variation to attribute to the parameters, so every index is 0/0, "
                "undefined";
  return true;
}

std::vector<std::size_t> identity_rows(std::size_t n) {
  std::vector<std::size_t> rows(n);
  for (std::size_t j = 0; j < n; ++j) rows[j] = j;
  return rows;
}

std::vector<std::vector<double>> bootstrap(std::size_t units, std::size_t values,
                                           const BootstrapOptions& opt,
                                           const StatisticFactory& make) {
  Rng rng(opt.seed);
  std::vector<std::vector<double>> reps(values, std::vector<double>(opt.resamples));
  // Resamples drawn ahead per chunk: at most ~2^20 row indices (8 MB) at a time.
  const std::size_t chunk = std::clamp<std::size_t>((std::size_t{1} << 20) / units, 1, 64);
  std::vector<std::vector<std::size_t>> rows(chunk, std::vector<std::size_t>(units));
  std::exception_ptr failure;
  for (std::size_t b0 = 0; b0 < opt.resamples && !failure; b0 += chunk) {
    const std::size_t m = std::min(chunk, opt.resamples - b0);
    for (std::size_t k = 0; k < m; ++k)
      for (auto& j : rows[k]) j = uniform_index(rng, 0, units - 1);
#pragma omp parallel if (m * units * values >= 200000)
    {
      // No exception may leave the region: the first one is kept and rethrown below.
      // Resamples are dealt out by thread number (no worksharing construct, so a thread that
      // fails cannot leave the others waiting at a barrier).
      try {
        const Statistic stat = make();
        std::vector<double> out(values);
        const auto threads = static_cast<std::size_t>(omp_get_num_threads());
        for (auto k = static_cast<std::size_t>(omp_get_thread_num()); k < m; k += threads) {
          stat(rows[k], out);
          for (std::size_t v = 0; v < values; ++v) reps[v][b0 + k] = out[v];
        }
      } catch (...) {
#pragma omp critical(sa_bootstrap_failure)
        if (!failure) failure = std::current_exception();
      }
    }
  }
  if (failure) std::rethrow_exception(failure);
  return reps;
}

std::vector<std::vector<double>> bootstrap(std::size_t units, std::size_t values,
                                           const BootstrapOptions& opt, const Statistic& stat) {
  return bootstrap(units, values, opt, StatisticFactory([&stat] { return stat; }));
}

namespace {
double sorted_quantile(const std::vector<double>& sorted, double q) {
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  const double frac = pos - static_cast<double>(lo);
  return sorted[lo] + frac * (sorted[hi] - sorted[lo]);
}
}  // namespace

Interval percentile_interval(std::vector<double> replicates, double confidence) {
  const std::size_t all = replicates.size();
  replicates.erase(std::remove_if(replicates.begin(), replicates.end(),
                                  [](double v) { return !std::isfinite(v); }),
                   replicates.end());
  if (replicates.empty() || 2 * replicates.size() < all) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan};
  }
  std::sort(replicates.begin(), replicates.end());
  return {sorted_quantile(replicates, 0.5 * (1.0 - confidence)),
          sorted_quantile(replicates, 0.5 * (1.0 + confidence))};
}

IndexValues make_index(const std::string& name, const std::vector<double>& point,
                       std::vector<std::vector<double>>& reps, std::size_t first,
                       std::size_t count, const BootstrapOptions& opt) {
  IndexValues v;
  v.name = name;
  v.value.assign(point.begin() + static_cast<std::ptrdiff_t>(first),
                 point.begin() + static_cast<std::ptrdiff_t>(first + count));
  v.ci.reserve(count);
  for (std::size_t k = 0; k < count; ++k) {
    v.ci.push_back(percentile_interval(reps[first + k], opt.confidence));
    if (opt.keep_resamples) v.resamples.push_back(std::move(reps[first + k]));
  }
  return v;
}

double population_variance(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  double mean = 0.0;
  for (double e : v) mean += e;
  mean /= static_cast<double>(v.size());
  double ss = 0.0;
  for (double e : v) ss += (e - mean) * (e - mean);
  return ss / static_cast<double>(v.size());
}

}  // namespace detail
}  // namespace stickslip::studies::sensitivity
