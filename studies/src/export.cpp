#include "stickslip/common/json_number.h"
#include "stickslip/studies/export.h"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace stickslip::studies {
namespace {

using nlohmann::json;


std::string cell(double v) {
  if (!std::isfinite(v)) return "";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}
std::string cell(const std::optional<double>& v) { return v ? cell(*v) : ""; }

std::string quoted(std::string s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += (c == '\n' || c == '\r') ? ' ' : c;
  }
  return out + "\"";
}

}  // namespace

json run_to_json(const store::RunRecord& r) {
  json stages = json::array();
  for (const auto& s : r.stages)
    stages.push_back({{"stage", s.stage},
                      {"t_start", common::json_number(s.t_start)},
                      {"t_end", common::json_number(s.t_end)},
                      {"amplitude", common::json_number(s.amplitude)},
                      {"amplitude_raw", common::json_number(s.amplitude_raw)},
                      {"mean_force", common::json_number(s.mean_force)},
                      {"mean_friction", common::json_number(s.mean_friction)},
                      {"slip_events", s.slip_events},
                      {"mean_period", common::json_number(s.mean_period)},
                      {"rmse", common::json_number(s.rmse)}});
  json params = json::parse(r.params_json.empty() ? "{}" : r.params_json, nullptr, false);
  if (params.is_discarded()) params = json::object();
  json out = {{"design_index", r.design_index},
              {"model", r.model ? json(*r.model) : json(nullptr)},
              {"va_over_vd", common::json_number(r.va_over_vd)},
              {"status", r.status},
              {"error", r.error.empty() ? json(nullptr) : json(r.error)},
              {"params", params},
              {"param_hash", r.param_hash},
              {"wall_time_s", common::json_number(r.wall_time_s)},
              {"t_end", common::json_number(r.t_end)},
              {"steps", r.steps},
              {"rmse", common::json_number(r.rmse)},
              {"finished_at", r.finished_at},
              {"stages", stages}};
  return out;
}

json study_to_json(const store::StudyRecord& s, const store::RunCounts& c) {
  const auto opt = [](const std::optional<std::string>& v) { return v ? json(*v) : json(nullptr); };
  return {{"id", s.id},
          {"name", s.name},
          {"state", to_string(s.state)},
          {"spec_hash", s.spec_hash},
          {"progress", {{"total", c.total}, {"done", c.done}, {"ok", c.ok}, {"failed", c.failed}}},
          {"created_at", s.created_at},
          {"started_at", opt(s.started_at)},
          {"finished_at", opt(s.finished_at)},
          {"error", opt(s.error)}};
}

std::vector<std::string> param_names_of(const store::RunRecord& run) {
  std::vector<std::string> names;
  const json params = json::parse(run.params_json.empty() ? "{}" : run.params_json, nullptr, false);
  if (!params.is_object()) return names;
  for (const auto& [k, v] : params.items())  // nlohmann::json objects iterate sorted
    if (k != "model" && k != "va_over_vd") names.push_back(k);  // va_over_vd has its own column
  return names;
}

std::string runs_csv_header(const std::vector<std::string>& names, std::size_t stages) {
  std::ostringstream o;
  o << "design_index,model,va_over_vd,status";
  for (const auto& n : names) o << ',' << n;
  for (std::size_t s = 1; s <= stages; ++s)
    o << ",amplitude_" << s << ",amplitude_raw_" << s << ",mean_force_" << s << ",mean_friction_"
      << s << ",slip_events_" << s << ",mean_period_" << s << ",rmse_" << s;
  o << ",rmse,wall_time_s,steps,error\n";
  return o.str();
}

std::string runs_csv_rows(const std::vector<store::RunRecord>& runs, const std::vector<std::string>& names,
                          std::size_t stages) {
  std::ostringstream o;
  for (const store::RunRecord& r : runs) {
    const json params = json::parse(r.params_json.empty() ? "{}" : r.params_json, nullptr, false);
    o << r.design_index << ',' << (r.model ? *r.model : "") << ',' << cell(r.va_over_vd) << ','
      << r.status;
    for (const auto& n : names) {
      o << ',';
      if (params.is_object() && params.contains(n) && params[n].is_number())
        o << cell(params[n].get<double>());
    }
    for (std::size_t s = 1; s <= stages; ++s) {
      const store::StageMetricsRecord* m = nullptr;
      for (const auto& st : r.stages)
        if (st.stage == static_cast<int>(s)) m = &st;
      if (m == nullptr) {
        o << ",,,,,,,";
        continue;
      }
      o << ',' << cell(m->amplitude) << ',' << cell(m->amplitude_raw) << ','
        << cell(m->mean_force) << ',' << cell(m->mean_friction) << ',' << m->slip_events << ','
        << cell(m->mean_period) << ',' << cell(m->rmse);
    }
    o << ',' << cell(r.rmse) << ',' << cell(r.wall_time_s) << ',' << r.steps << ','
      << (r.error.empty() ? "" : quoted(r.error)) << '\n';
  }
  return o.str();
}

}  // namespace stickslip::studies
