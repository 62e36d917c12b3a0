// The inverse of map_to_json, so that `stickslip map ID --server URL` prints the same table
// (map_to_table) as the local `stickslip map ID --db FILE`.
#include <cmath>
#include <limits>

#include "stickslip/studies/map.h"

namespace stickslip::studies {

using nlohmann::json;

namespace {
double number(const json& v) {
  return v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
}
std::optional<double> optional_number(const json& v) {
  if (!v.is_number()) return std::nullopt;
  return v.get<double>();
}
}  // namespace

StudyMap map_from_json(const json& j) {
  StudyMap m;
  m.study_id = j.value("study_id", "");
  m.study_name = j.value("study_name", "");
  m.state = j.value("state", "");
  m.models = j.value("models", std::vector<std::string>{});
  m.key_names = j.value("key_names", std::vector<std::string>{});
  m.stages = j.value("stages", std::size_t{0});
  m.missing = j.value("missing", std::int64_t{0});
  m.failed = j.value("failed", std::int64_t{0});
  for (const auto& r : j.value("rows", json::array())) {
    MapRow row;
    for (const auto& name : m.key_names)
      row.key.emplace_back(name, number(r["key"].value(name, json(nullptr))));
    for (const auto& model : m.models) {
      MapCell c;
      c.amplitude.assign(m.stages, std::numeric_limits<double>::quiet_NaN());
      c.mean_force = c.amplitude;
      c.stage_rmse.assign(m.stages, std::nullopt);
      if (r["cells"].contains(model)) {
        const json& cj = r["cells"][model];
        const std::string state = cj.value("state", "missing");
        c.state = state == "ok"       ? CellState::kOk
                  : state == "failed" ? CellState::kFailed
                                      : CellState::kMissing;
        c.design_index = cj.value("design_index", std::int64_t{-1});
        c.status = cj.value("status", "");
        c.error = cj.value("error", "");
        for (std::size_t s = 0; s < m.stages; ++s) {
          if (cj.contains("amplitude") && s < cj["amplitude"].size())
            c.amplitude[s] = number(cj["amplitude"][s]);
          if (cj.contains("mean_force") && s < cj["mean_force"].size())
            c.mean_force[s] = number(cj["mean_force"][s]);
          if (cj.contains("stage_rmse") && s < cj["stage_rmse"].size())
            c.stage_rmse[s] = optional_number(cj["stage_rmse"][s]);
        }
        if (cj.contains("ratio")) c.ratio = optional_number(cj["ratio"]);
        if (cj.contains("rmse")) c.rmse = optional_number(cj["rmse"]);
      }
      row.cells.push_back(std::move(c));
    }
    m.rows.push_back(std::move(row));
  }
  return m;
}

}  // namespace stickslip::studies
