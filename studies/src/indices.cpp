// Sensitivity indices of stored studies (see indices.h).
#include "stickslip/common/json_number.h"
#include "stickslip/studies/indices.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <regex>
#include <sstream>
#include <stdexcept>

namespace stickslip::studies {
namespace {

using nlohmann::json;

json interval(const sensitivity::Interval& i) { return json::array({common::json_number(i.lo), common::json_number(i.hi)}); }

std::size_t stage_count(const StudySpec& spec) {
  return spec.is_analytic() ? 1 : spec.base_config().stages.size();
}

// A parsed output name.
struct Output {
  enum class Kind { kAmplitude, kMeanForce, kRatio, kY } kind = Kind::kY;
  std::size_t stage = 1;  // 1-based (amplitude, mean_force)
};

std::optional<Output> parse_output(const StudySpec& spec, const std::string& name,
                                   std::string* why) {
  static const std::regex re(R"(stage([1-9][0-9]{0,5})\.(amplitude|mean_force))");
  std::smatch m;
  const std::size_t stages = stage_count(spec);
  if (spec.is_analytic()) {
    if (name == "y") return Output{};
    *why = "unknown output '" + name + "' of an analytic (" + spec.analytic_model() +
           ") study: the only output is 'y'";
    return std::nullopt;
  }
  if (name == "reduction_ratio") {
    if (stages < 2) {
      *why = "output 'reduction_ratio' needs at least 2 stages; the study has " +
             std::to_string(stages);
      return std::nullopt;
    }
    return Output{Output::Kind::kRatio, stages};
  }
  if (std::regex_match(name, m, re)) {
    const std::size_t k = std::stoul(m[1].str());
    if (k > stages) {
      *why = "output '" + name + "': stage " + std::to_string(k) + " does not exist (the study has " +
             std::to_string(stages) + " stage(s))";
      return std::nullopt;
    }
    return Output{m[2].str() == "amplitude" ? Output::Kind::kAmplitude : Output::Kind::kMeanForce,
                  k};
  }
  *why = "unknown output '" + name +
         "' (expected stage<k>.amplitude, stage<k>.mean_force, reduction_ratio, or y for analytic "
         "studies)";
  return std::nullopt;
}

const store::StageMetricsRecord* find_stage(const store::RunRecord& run, std::size_t k) {
  for (const auto& s : run.stages)
    if (s.stage == static_cast<int>(k)) return &s;
  return nullptr;
}

// The value of an output for an ok run; NaN with a reason when it is not finite.
double output_value(const Output& o, const store::RunRecord& run, std::size_t stages, std::string* why) {
  auto stage_value = [&](std::size_t k, bool amplitude) {
    const store::StageMetricsRecord* s = find_stage(run, k);
    if (s == nullptr) {
      *why = "stage " + std::to_string(k) + " has no metrics (not reached)";
      return std::nan("");
    }
    const double v = amplitude ? s->amplitude : s->mean_force;
    if (!std::isfinite(v))
      *why = std::string("stage ") + std::to_string(k) + (amplitude ? " amplitude" : " mean_force") +
             " is not finite";
    return v;
  };
  switch (o.kind) {
    case Output::Kind::kY: return stage_value(1, true);
    case Output::Kind::kAmplitude: return stage_value(o.stage, true);
    case Output::Kind::kMeanForce: return stage_value(o.stage, false);
    case Output::Kind::kRatio: {
      const double first = stage_value(1, true);
      if (!std::isfinite(first)) return first;
      const double last = stage_value(stages, true);
      if (!std::isfinite(last)) return last;
      if (first == 0.0) {
        *why = "reduction_ratio undefined: stage 1 has no stick-slip (amplitude 0)";
        return std::nan("");
      }
      return last / first;
    }
  }
  return std::nan("");
}

StudySpec parse_stored(const store::StudyRecord& study) {
  Limits limits;
  limits.max_runs = static_cast<std::size_t>(std::max<std::int64_t>(study.total_runs, 1));
  ParseResult parsed = parse_study(study.spec_json, limits);
  if (!parsed.ok())
    throw std::invalid_argument("study " + study.id + ": its stored spec does not parse: " +
                                to_string(parsed.errors.front()));
  return std::move(*parsed.spec);
}

std::string fmt(double v, const char* f = "%8.4f") {
  if (!std::isfinite(v)) return "     n/a";
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

}  // namespace

bool IndicesOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(confidence > 0.0 && confidence < 1.0))
    return fail("confidence must be in (0, 1), got " + std::to_string(confidence));
  if (resamples < 10) return fail("resamples must be >= 10, got " + std::to_string(resamples));
  return true;
}

bool StudyIndices::valid() const noexcept {
  return std::all_of(outputs.begin(), outputs.end(), [](const OutputIndices& o) { return o.valid; });
}

std::vector<std::string> default_outputs(const StudySpec& spec) {
  if (spec.is_analytic()) return {"y"};
  std::vector<std::string> out;
  const std::size_t stages = stage_count(spec);
  for (std::size_t k = 1; k <= stages; ++k) {
    out.push_back("stage" + std::to_string(k) + ".amplitude");
    out.push_back("stage" + std::to_string(k) + ".mean_force");
  }
  if (stages >= 2) out.push_back("reduction_ratio");
  return out;
}

std::string check_output(const StudySpec& spec, const std::string& output) {
  std::string why;
  return parse_output(spec, output, &why) ? std::string() : why;
}

StudyIndices compute_indices(store::Store& store, const std::string& study_id,
                             const std::vector<std::string>& outputs,
                             const IndicesOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument("indices options: " + why);
  const auto study = store.get_study(study_id);
  if (!study) throw store::StoreError("unknown study '" + study_id + "' in " + store.path().string());
  const StudySpec spec = parse_stored(*study);
  const Design& design = spec.design();
  if (design.type != DesignType::kSobol && design.type != DesignType::kMorris)
    throw std::invalid_argument("study " + study_id + " (" + study->name + ") has a '" +
                                to_string(design.type) +
                                "' design; sensitivity indices need a 'sobol' or 'morris' design");

  StudyIndices result;
  result.study_id = study->id;
  result.study_name = study->name;
  result.state = to_string(study->state);
  result.method = to_string(design.type);
  result.parameters = spec.variables();
  result.total_runs = static_cast<std::int64_t>(spec.run_count());
  result.options = options;
  const std::size_t d = result.parameters.size();
  if (spec.F_S_below_F_C() == FsBelowFc::kRaiseToFc)
    for (std::size_t i = 0; i < spec.run_count(); ++i) {
      try {
        if (spec.raises_F_S(spec.point(i))) ++result.F_S_raised_runs;
      } catch (const std::exception&) {
        // A point with another problem is an invalid run; it is counted as failed below.
      }
    }
  if (design.type == DesignType::kSobol) {
    result.n = design.n;
  } else {
    result.trajectories = design.trajectories;
    result.levels = design.levels;
  }

  const std::vector<std::string> names = outputs.empty() ? default_outputs(spec) : outputs;
  std::vector<Output> parsed;
  for (const auto& name : names) {
    auto o = parse_output(spec, name, &why);
    if (!o) throw std::invalid_argument("study " + study_id + ": " + why);
    parsed.push_back(*o);
  }

  // Every output's value per design index; NaN marks an offending point.
  const std::size_t runs = spec.run_count();
  const std::size_t stages = stage_count(spec);
  std::vector<std::vector<double>> y(names.size(), std::vector<double>(runs, std::nan("")));
  std::vector<std::vector<InvalidPoint>> bad(names.size());
  std::vector<std::size_t> bad_count(names.size(), 0);
  std::vector<char> stored(runs, 0);
  auto note = [&](std::size_t o, InvalidPoint p) {
    ++bad_count[o];
    if (bad[o].size() < options.max_listed) bad[o].push_back(std::move(p));
  };
  std::int64_t after = -1;
  while (true) {
    const auto page = store.get_runs(study_id, after, 2000);
    if (page.empty()) break;
    for (const store::RunRecord& run : page) {
      after = run.design_index;
      if (run.design_index < 0 || static_cast<std::size_t>(run.design_index) >= runs) continue;
      const auto i = static_cast<std::size_t>(run.design_index);
      stored[i] = 1;
      ++result.stored_runs;
      if (run.status != "ok") ++result.failed_runs;
      for (std::size_t o = 0; o < names.size(); ++o) {
        if (run.status != "ok") {
          note(o, {run.design_index, run.status, run.error});
          continue;
        }
        std::string reason;
        const double v = output_value(parsed[o], run, stages, &reason);
        if (std::isfinite(v)) y[o][i] = v;
        else note(o, {run.design_index, "ok", reason.empty() ? "output is not finite" : reason});
      }
    }
  }
  // Missing runs, in design order after the stored ones (the count is what matters).
  std::size_t missing = 0;
  for (std::size_t i = 0; i < runs; ++i)
    if (!stored[i]) {
      ++missing;
      for (std::size_t o = 0; o < names.size(); ++o)
        note(o, {static_cast<std::int64_t>(i), "missing", "run not stored (study not finished?)"});
    }

  // The unit design (Morris needs the rows; Sobol only their order).
  sensitivity::Matrix x;
  if (design.type == DesignType::kMorris) {
    x.reserve(runs);
    for (std::size_t i = 0; i < runs; ++i) x.push_back(spec.unit_point(i));
  }

  for (std::size_t o = 0; o < names.size(); ++o) {
    OutputIndices out;
    out.output = names[o];
    out.invalid_count = bad_count[o];
    out.invalid_points = std::move(bad[o]);
    if (bad_count[o] > 0) {
      // Counts by kind over ALL offending points (the list may be truncated): every failed and
      // every missing run counts against every output; the rest are non-finite outputs.
      const std::size_t miss = missing;
      const auto failed = static_cast<std::size_t>(result.failed_runs);
      const std::size_t nonfinite = bad_count[o] - miss - failed;
      std::ostringstream r;
      r << "indices invalid: " << bad_count[o] << " of " << runs << " design points unusable (";
      bool first = true;
      auto part = [&](std::size_t c, const char* what) {
        if (c == 0) return;
        r << (first ? "" : ", ") << c << ' ' << what;
        first = false;
      };
      part(failed, "failed runs");
      part(miss, "missing runs");
      part(nonfinite, "non-finite outputs");
      r << "); the estimators need every point of the design";
      out.reason = r.str();
      out.valid = false;
    } else {
      const auto& v = y[o];
      // Shifted by the first value so that a constant output has exactly zero mean deviation.
      double shift = 0.0;
      for (double e : v) shift += e - v.front();
      const double mean = v.front() + shift / static_cast<double>(v.size());
      double var = 0.0;
      for (double e : v) var += (e - mean) * (e - mean);
      out.mean = mean;
      out.variance = v.size() > 1 ? var / static_cast<double>(v.size() - 1) : 0.0;
      try {
        if (design.type == DesignType::kSobol)
          out.sobol = sensitivity::sobol_indices(v, design.n, d, options.confidence,
                                                 options.resamples, options.seed);
        else
          out.morris = sensitivity::morris_indices(x, v, design.trajectories, d,
                                                   options.confidence, options.resamples,
                                                   options.seed);
        out.valid = true;
      } catch (const std::invalid_argument& e) {
        out.valid = false;
        out.reason = std::string("indices invalid: ") + e.what();
      }
    }
    result.outputs.push_back(std::move(out));
  }
  return result;
}

nlohmann::json indices_to_json(const StudyIndices& r) {
  json j{{"study_id", r.study_id},         {"study_name", r.study_name},
         {"state", r.state},               {"method", r.method},
         {"parameters", r.parameters},     {"total_runs", r.total_runs},
         {"stored_runs", r.stored_runs},   {"failed_runs", r.failed_runs},
         {"F_S_raised_runs", r.F_S_raised_runs},
         {"confidence", r.options.confidence}, {"resamples", r.options.resamples},
         {"valid", r.valid()}};
  if (r.method == "sobol") j["n"] = r.n;
  else {
    j["trajectories"] = r.trajectories;
    j["levels"] = r.levels;
  }
  json outs = json::array();
  for (const auto& o : r.outputs) {
    json jo{{"output", o.output}, {"valid", o.valid}, {"reason", o.reason},
            {"invalid_count", o.invalid_count}};
    json pts = json::array();
    for (const auto& p : o.invalid_points)
      pts.push_back({{"design_index", p.design_index}, {"status", p.status}, {"reason", p.reason}});
    jo["invalid_points"] = pts;
    jo["mean"] = o.valid ? common::json_number(o.mean) : json(nullptr);
    jo["variance"] = o.valid ? common::json_number(o.variance) : json(nullptr);
    json idx = json::array();
    for (std::size_t p = 0; p < r.parameters.size(); ++p) {
      if (o.sobol) {
        const auto& s = *o.sobol;
        idx.push_back({{"parameter", r.parameters[p]},
                       {"S1", common::json_number(s.S1[p])},
                       {"S1_ci", interval(s.S1_ci[p])},
                       {"ST", common::json_number(s.ST[p])},
                       {"ST_ci", interval(s.ST_ci[p])}});
      } else if (o.morris) {
        const auto& m = *o.morris;
        idx.push_back({{"parameter", r.parameters[p]},
                       {"mu", common::json_number(m.mu[p])},
                       {"mu_star", common::json_number(m.mu_star[p])},
                       {"mu_star_ci", interval(m.mu_star_ci[p])},
                       {"sigma", common::json_number(m.sigma[p])}});
      }
    }
    jo["indices"] = idx;
    outs.push_back(std::move(jo));
  }
  j["outputs"] = outs;
  return j;
}

std::string indices_to_table(const StudyIndices& r) {
  std::ostringstream s;
  s << "study " << r.study_id << " (" << r.study_name << "), " << r.method << " design: ";
  if (r.method == "sobol") s << "N = " << r.n;
  else s << "r = " << r.trajectories << " trajectories, p = " << r.levels << " levels";
  s << ", " << r.stored_runs << "/" << r.total_runs << " runs stored, " << r.failed_runs
    << " failed; " << static_cast<int>(std::lround(r.options.confidence * 100))
    << "% bootstrap intervals\n";
  if (r.F_S_raised_runs > 0)
    s << r.F_S_raised_runs << " runs had F_S < F_C and were simulated with F_S = F_C\n";
  std::size_t w = 9;
  for (const auto& p : r.parameters) w = std::max(w, p.size());
  for (const auto& o : r.outputs) {
    s << "\n" << o.output << ":";
    if (!o.valid) {
      s << " INVALID\n  " << o.reason << "\n";
      for (const auto& p : o.invalid_points)
        s << "  design index " << p.design_index << ": " << p.status
          << (p.reason.empty() ? "" : " (" + p.reason + ")") << "\n";
      if (o.invalid_count > o.invalid_points.size())
        s << "  ... and " << (o.invalid_count - o.invalid_points.size()) << " more\n";
      continue;
    }
    s << " mean " << fmt(o.mean, "%.6g") << ", variance " << fmt(o.variance, "%.6g") << "\n";
    s << "  " << std::string(w - 9, ' ') << "parameter";
    if (o.sobol) s << "       S1  S1 interval             ST  ST interval\n";
    else s << "       mu      mu*  mu* interval         sigma\n";
    for (std::size_t p = 0; p < r.parameters.size(); ++p) {
      s << "  " << std::string(w - r.parameters[p].size(), ' ') << r.parameters[p] << " ";
      if (o.sobol) {
        const auto& x = *o.sobol;
        s << fmt(x.S1[p]) << "  [" << fmt(x.S1_ci[p].lo) << "," << fmt(x.S1_ci[p].hi) << "] "
          << fmt(x.ST[p]) << "  [" << fmt(x.ST_ci[p].lo) << "," << fmt(x.ST_ci[p].hi) << "]\n";
      } else {
        const auto& x = *o.morris;
        s << fmt(x.mu[p], "%8.4g") << " " << fmt(x.mu_star[p], "%8.4g") << "  ["
          << fmt(x.mu_star_ci[p].lo, "%8.4g") << "," << fmt(x.mu_star_ci[p].hi, "%8.4g") << "] "
          << fmt(x.sigma[p], "%8.4g") << "\n";
      }
    }
  }
  return s.str();
}

nlohmann::json indices_json(store::Store& store, const std::string& study_id,
                            const std::vector<std::string>& outputs,
                            const IndicesOptions& options) {
  return indices_to_json(compute_indices(store, study_id, outputs, options));
}

}  // namespace stickslip::studies
