#pragma once
// The outputs of a study's runs that sensitivity indices are computed for, by name:
//   "stage<k>.amplitude"   stick-slip amplitude of stage k [N] (k from 1)
//   "stage<k>.mean_force"  mean drive force of stage k [N]
//   "stage<k>.period"      mean stick-slip period of stage k [s]; not defined (NaN) at a run with
//                          fewer than two confirmed peaks in that stage
//   "reduction_ratio"      amplitude of the last stage / amplitude of stage 1 [-]; not defined
//                          where stage 1 has no stick-slip
//   "y"                    the analytic model's value (ishigami, sobol_g)
// Default outputs: "y" for analytic studies; otherwise every stage's amplitude, mean_force and
// period, plus reduction_ratio when there are at least two stages.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "stickslip/store/store.h"

namespace stickslip::studies {

/// What an output name depends on in a study.
struct OutputContext {
  std::string analytic_model;  ///< "" for friction-model studies
  std::size_t stages = 1;
};

/// A parsed output name.
struct OutputRef {
  enum class Kind { kAmplitude, kMeanForce, kPeriod, kRatio, kY } kind = Kind::kY;
  std::size_t stage = 1;  ///< 1-based (amplitude, mean_force, period)
};

/// The output `name`, or nullopt with *why naming the output and what is accepted.
std::optional<OutputRef> parse_output(const OutputContext& context, const std::string& name,
                                      std::string* why);
/// The default outputs (see above).
std::vector<std::string> default_outputs(const OutputContext& context);
/// The output's value at an ok run; NaN with *why when it is not defined or not finite there.
double output_value(const OutputRef& output, const store::RunRecord& run, std::size_t stages,
                    std::string* why);

}  // namespace stickslip::studies
