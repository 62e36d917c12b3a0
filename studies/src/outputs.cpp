// Output names of stored runs and their values (see outputs.h).
#include "stickslip/studies/outputs.h"

#include <cmath>
#include <regex>

namespace stickslip::studies {

std::optional<OutputRef> parse_output(const OutputContext& c, const std::string& name,
                                      std::string* why) {
  static const std::regex re(R"(stage([1-9][0-9]{0,5})\.(amplitude|mean_force|period))");
  std::smatch m;
  if (!c.analytic_model.empty()) {
    if (name == "y") return OutputRef{};
    *why = "unknown output '" + name + "' of an analytic (" + c.analytic_model +
           ") study: the only output is 'y'";
    return std::nullopt;
  }
  if (name == "reduction_ratio") {
    if (c.stages < 2) {
      *why = "output 'reduction_ratio' needs at least 2 stages; the study has " +
             std::to_string(c.stages);
      return std::nullopt;
    }
    return OutputRef{OutputRef::Kind::kRatio, c.stages};
  }
  if (std::regex_match(name, m, re)) {
    const std::size_t k = std::stoul(m[1].str());
    if (k > c.stages) {
      *why = "output '" + name + "': stage " + std::to_string(k) +
             " does not exist (the study has " + std::to_string(c.stages) + " stage(s))";
      return std::nullopt;
    }
    const std::string what = m[2].str();
    return OutputRef{what == "amplitude"    ? OutputRef::Kind::kAmplitude
                     : what == "mean_force" ? OutputRef::Kind::kMeanForce
                                            : OutputRef::Kind::kPeriod,
                     k};
  }
  *why = "unknown output '" + name +
         "' (expected stage<k>.amplitude, stage<k>.mean_force, stage<k>.period, reduction_ratio, "
         "or y for analytic studies)";
  return std::nullopt;
}

std::vector<std::string> default_outputs(const OutputContext& c) {
  if (!c.analytic_model.empty()) return {"y"};
  std::vector<std::string> out;
  for (std::size_t k = 1; k <= c.stages; ++k)
    for (const char* what : {".amplitude", ".mean_force", ".period"})
      out.push_back("stage" + std::to_string(k) + what);
  if (c.stages >= 2) out.push_back("reduction_ratio");
  return out;
}

namespace {

const store::StageMetricsRecord* find_stage(const store::RunRecord& run, std::size_t k) {
  for (const auto& s : run.stages)
    if (s.stage == static_cast<int>(k)) return &s;
  return nullptr;
}

double stage_value(const store::RunRecord& run, std::size_t k, OutputRef::Kind kind,
                   std::string* why) {
  const store::StageMetricsRecord* s = find_stage(run, k);
  const std::string stage = "stage " + std::to_string(k);
  if (s == nullptr) {
    *why = stage + " has no metrics (not reached)";
    return std::nan("");
  }
  if (kind == OutputRef::Kind::kPeriod) {
    if (s->mean_period > 0.0 && std::isfinite(s->mean_period)) return s->mean_period;
    *why = stage + " has fewer than two stick-slip peaks: no period";
    return std::nan("");
  }
  const bool amplitude = kind == OutputRef::Kind::kAmplitude || kind == OutputRef::Kind::kY;
  const double v = amplitude ? s->amplitude : s->mean_force;
  if (!std::isfinite(v)) *why = stage + (amplitude ? " amplitude" : " mean_force") + " is not finite";
  return v;
}

}  // namespace

double output_value(const OutputRef& o, const store::RunRecord& run, std::size_t stages,
                    std::string* why) {
  if (o.kind != OutputRef::Kind::kRatio) return stage_value(run, o.stage, o.kind, why);
  const double first = stage_value(run, 1, OutputRef::Kind::kAmplitude, why);
  if (!std::isfinite(first)) return first;
  const double last = stage_value(run, stages, OutputRef::Kind::kAmplitude, why);
  if (!std::isfinite(last)) return last;
  if (first == 0.0) {
    *why = "reduction_ratio undefined: stage 1 has no stick-slip (amplitude 0)";
    return std::nan("");
  }
  return last / first;
}

}  // namespace stickslip::studies
