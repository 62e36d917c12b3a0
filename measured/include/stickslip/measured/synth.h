#pragma once
// Synthetic measured data (issue 5): a dataset in the measured-data format (measured.h) made by
// the engine from any model with any catalogue extension, at a converged accuracy, sampled at a
// chosen rate, with a constant sensor offset and white or AR(1) Gaussian noise from a seed.
//
// Noise: e_k = rho e_{k-1} + sqrt(1 - rho^2) sigma w_k, w_k ~ N(0, 1) i.i.d., e_0 = sigma w_0, so
// every sample has standard deviation sigma [N] and lag-1 correlation rho (rho = 0: white).
// Boost.Random's generator and normal distribution are used because, unlike <random>'s
// distributions, their output is specified, so a seed gives the same data on every platform.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "stickslip/engine/params.h"
#include "stickslip/measured/measured.h"

namespace stickslip::measured {

struct SynthOptions {
  std::string name = "synthetic";
  engine::SimConfig model;  ///< model, friction parameters and extension; drive/stages come from runs
  std::vector<MeasuredConditions> runs;  ///< one measured run per entry
  double rate = 2000.0;       ///< sampling rate [Hz]
  double noise_sigma = 0.03;  ///< noise standard deviation [N]
  double noise_rho = 0.0;     ///< AR(1) coefficient [-], in [0, 1)
  double offset = 0.0;        ///< constant sensor offset added to F_d [N]
  std::uint64_t seed = 1;
  double rtol = 1e-9;         ///< engine accuracy (adaptive rtol = atol [N]); converged

  /// True if every field holds. Otherwise appends one message per broken constraint, naming the
  /// field and the value, to *errors when errors is non-null.
  bool IsValid(std::vector<std::string>* errors = nullptr) const;
};

/// Simulates every run and returns the dataset in memory (manifest path empty; each run's file
/// is "<run name>.csv"). Throws std::invalid_argument for bad options (naming the field and the
/// value) and std::runtime_error when a run does not finish.
MeasuredDataset synthesize(const SynthOptions& options);

/// Writes dir/manifest.json and one CSV (t,Fd) per run; creates dir. Returns the manifest path.
std::filesystem::path write_dataset(const MeasuredDataset& data, const std::filesystem::path& dir);

}  // namespace stickslip::measured
