#pragma once
// Internal helpers of the sensitivity estimators: argument checks, the bootstrap loop, percentile
// intervals and the constant-output rule. Random draws use Boost.Random's distributions (fixed
// algorithms), so a seed gives the same intervals with every standard library.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "stickslip/studies/sa_indices.h"

namespace stickslip::studies::sensitivity::detail {

using Rng = std::mt19937_64;

/// Uniform integer in [lo, hi] (inclusive).
std::size_t uniform_index(Rng& rng, std::size_t lo, std::size_t hi);

[[noreturn]] void invalid(const std::string& what);
void require_positive(const char* name, std::size_t value, const char* func);
void require_finite(const std::vector<double>& y, const char* func);
void require_bootstrap(const BootstrapOptions& opt, const char* func);
/// x must have `rows` rows of `d` columns.
void require_matrix(const Matrix& x, std::size_t rows, std::size_t d, const char* func);

/// True, with *out set to an undefined MethodIndices of `method` over `units` bootstrap units that
/// names the value, when every y is the same value (see sa_indices.h).
bool constant_output(const std::vector<double>& y, const std::string& method, std::size_t units,
                     MethodIndices* out);

/// Writes the statistics of the units listed in `rows` (with repetitions) to `out`.
using Statistic = std::function<void(const std::vector<std::size_t>& rows, std::vector<double>& out)>;
/// Makes a Statistic with its own scratch buffers: one is made per thread.
using StatisticFactory = std::function<Statistic()>;

/// 0, 1, ..., n - 1.
std::vector<std::size_t> identity_rows(std::size_t n);

/// Replicates [value][b] of `values` statistics over opt.resamples resamples of `units` units
/// drawn with replacement, in sequence from Rng(opt.seed): resample b draws its units one after
/// another with uniform_index(rng, 0, units - 1). The draws are sequential and the statistics of
/// a chunk of resamples are computed in parallel (OpenMP, one Statistic per thread), so the
/// replicates do not depend on the thread count.
std::vector<std::vector<double>> bootstrap(std::size_t units, std::size_t values,
                                           const BootstrapOptions& opt,
                                           const StatisticFactory& make);
/// The same for a Statistic without scratch state (safe to call from several threads).
std::vector<std::vector<double>> bootstrap(std::size_t units, std::size_t values,
                                           const BootstrapOptions& opt, const Statistic& stat);

/// The index `name` for items k < count, from point[first + k] and replicates reps[first + k]
/// (percentile intervals; the replicates are moved into the result when opt.keep_resamples).
IndexValues make_index(const std::string& name, const std::vector<double>& point,
                       std::vector<std::vector<double>>& reps, std::size_t first,
                       std::size_t count, const BootstrapOptions& opt);

/// Percentile interval [(1-c)/2, (1+c)/2] (type-7 quantiles) of the finite replicates; NaN ends
/// when fewer than half of them are finite.
Interval percentile_interval(std::vector<double> replicates, double confidence);

/// Population variance of v (0 for fewer than two values).
double population_variance(const std::vector<double>& v);

}  // namespace stickslip::studies::sensitivity::detail
