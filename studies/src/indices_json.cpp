// JSON and table forms of a study's indices (see indices.h).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "stickslip/common/json_number.h"
#include "stickslip/studies/indices.h"
#include "stickslip/studies/sa_json.h"

namespace stickslip::studies {
namespace {

using nlohmann::json;
using common::json_number;
namespace sa = sensitivity;

/// The index a heat map shows for a method: the one that ranks parameters.
std::string main_index(const std::string& method) {
  if (method == "sobol" || method == "efast") return "ST";
  if (method == "rbd_fast") return "S1";
  if (method == "morris") return "mu_star";
  return method;  // "delta", "pawn", "dgsm"
}

json heatmap_json(const StudyIndices& r) {
  const std::string index = main_index(r.method);
  json h{{"index", index}, {"parameters", r.parameters}};
  json outputs = json::array(), value = json::array(), ci = json::array(), status = json::array();
  for (const OutputIndices& o : r.outputs) {
    outputs.push_back(o.output);
    status.push_back(o.status);
    json row = json::array(), rci = json::array();
    const sa::IndexValues* v = o.indices ? o.indices->find(index) : nullptr;
    for (std::size_t p = 0; p < r.parameters.size(); ++p) {
      row.push_back(v != nullptr ? json_number(v->value[p]) : json(nullptr));
      rci.push_back(v != nullptr && !v->ci.empty()
                        ? json::array({json_number(v->ci[p].lo), json_number(v->ci[p].hi)})
                        : json(nullptr));
    }
    value.push_back(std::move(row));
    ci.push_back(std::move(rci));
  }
  h["outputs"] = std::move(outputs);
  h["value"] = std::move(value);
  h["ci"] = std::move(ci);
  h["status"] = std::move(status);
  return h;
}

json output_json(const StudyIndices& r, const OutputIndices& o) {
  json jo{{"output", o.output},     {"status", o.status},
          {"valid", o.valid()},     {"reason", o.reason},
          {"warnings", o.warnings}, {"invalid_count", o.invalid_count}};
  json pts = json::array();
  for (const auto& p : o.invalid_points)
    pts.push_back({{"design_index", p.design_index}, {"status", p.status}, {"reason", p.reason}});
  jo["invalid_points"] = pts;
  const bool has_moments = o.status != "invalid";
  jo["mean"] = has_moments ? json_number(o.mean) : json(nullptr);
  jo["variance"] = has_moments ? json_number(o.variance) : json(nullptr);
  jo["notes"] = o.indices ? json(o.indices->notes) : json::array();
  if (o.indices) sa::write_method_json(*o.indices, r.parameters, jo);
  else jo["indices"] = json::array();
  if (!o.convergence.empty()) {
    json steps = json::array();
    for (const auto& step : o.convergence) {
      json s{{"n", step.n}};
      sa::write_method_json(step.indices, r.parameters, s);
      steps.push_back(std::move(s));
    }
    jo["convergence"] = std::move(steps);
  }
  return jo;
}

std::string fmt(double v, const char* f) {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

}  // namespace

nlohmann::json indices_to_json(const StudyIndices& r) {
  json j{{"study_id", r.study_id},         {"study_name", r.study_name},
         {"state", r.state},               {"design", r.design},
         {"method", r.method},             {"parameters", r.parameters},
         {"n", r.n},                       {"total_runs", r.total_runs},
         {"stored_runs", r.stored_runs},   {"failed_runs", r.failed_runs},
         {"F_S_raised_runs", r.F_S_raised_runs},
         {"confidence", r.options.confidence}, {"resamples", r.options.resamples},
         {"seed", r.options.seed},         {"valid", r.valid()}};
  if (r.design == "morris") {
    j["trajectories"] = r.trajectories;
    j["levels"] = r.levels;
  }
  if (r.design == "efast") {
    j["replicates"] = r.replicates;
    j["M"] = r.harmonics;
  }
  if (r.design == "sobol") j["second_order"] = r.second_order;
  if (r.until) {
    const UntilStatus& u = *r.until;
    j["until"] = {{"max_st_width", u.max_st_width}, {"n", u.n}, {"n_max", u.n_max},
                  {"widest", json_number(u.widest)}, {"widest_at", u.widest_at},
                  {"grow", u.grow}, {"next_n", u.next_n}, {"reason", u.reason}};
  }
  json outs = json::array();
  for (const auto& o : r.outputs) outs.push_back(output_json(r, o));
  j["outputs"] = std::move(outs);
  j["heatmap"] = heatmap_json(r);
  return j;
}

std::string indices_to_table(const StudyIndices& r) {
  std::ostringstream s;
  s << "study " << r.study_id << " (" << r.study_name << "), " << r.design << " design, method "
    << r.method << ", N = " << r.n << ", " << r.stored_runs << "/" << r.total_runs
    << " runs stored, " << r.failed_runs << " failed; "
    << static_cast<int>(std::lround(r.options.confidence * 100)) << "% bootstrap intervals\n";
  if (r.F_S_raised_runs > 0)
    s << r.F_S_raised_runs << " runs had F_S < F_C and were simulated with F_S = F_C\n";
  if (r.until) s << "until: " << r.until->reason << "\n";
  std::size_t w = 9;
  for (const auto& p : r.parameters) w = std::max(w, p.size());
  for (const auto& o : r.outputs) {
    s << "\n" << o.output << ":";
    if (o.status != "ok") {
      s << " " << (o.status == "undefined" ? "UNDEFINED" : "INVALID") << "\n  " << o.reason << "\n";
      for (const auto& p : o.invalid_points)
        s << "  design index " << p.design_index << ": " << p.status
          << (p.reason.empty() ? "" : " (" + p.reason + ")") << "\n";
      if (o.invalid_count > o.invalid_points.size())
        s << "  ... and " << (o.invalid_count - o.invalid_points.size()) << " more\n";
      continue;
    }
    s << " mean " << fmt(o.mean, "%.6g") << ", variance " << fmt(o.variance, "%.6g") << "\n";
    for (const auto& warning : o.warnings) s << "  warning: " << warning << "\n";
    for (const auto& note : o.indices->notes) s << "  note: " << note << "\n";
    s << "  " << std::string(w - 9, ' ') << "parameter";
    for (const auto& v : o.indices->per_parameter) s << "  " << v.name << (v.ci.empty() ? "" : " [interval]");
    s << "\n";
    for (std::size_t p = 0; p < r.parameters.size(); ++p) {
      s << "  " << std::string(w - r.parameters[p].size(), ' ') << r.parameters[p];
      for (const auto& v : o.indices->per_parameter) {
        s << "  " << sa::display_index(v.value[p], v.ci.empty() ? nullptr : &v.ci[p], "%.4g");
        if (!v.ci.empty()) s << " " << sa::display_interval(v.ci[p], "%.4g");
      }
      s << "\n";
    }
    for (std::size_t k = 0; k < o.indices->pairs.size(); ++k) {
      const auto& v = o.indices->per_pair.front();
      s << "  S2 " << r.parameters[o.indices->pairs[k][0]] << ", "
        << r.parameters[o.indices->pairs[k][1]] << ": "
        << sa::display_index(v.value[k], &v.ci[k], "%.4g") << " "
        << sa::display_interval(v.ci[k], "%.4g") << "\n";
    }
  }
  return s.str();
}

}  // namespace stickslip::studies
